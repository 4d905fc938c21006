// huge_pages.h: memory for the large tables a part-3 step precomputes in its first render
// and every later render reads (step 46's records), in 2 MiB pages where the kernel gives
// them.
//
// Why: memory a process has never touched costs a page fault at its first write, one per
// 4 KiB page: about 3,700 for step 46's 14.5 MiB of records on the phantom, a few
// microseconds each on the lab's VM (more on a busy one), most of the first render's
// precomputation. Linux's transparent huge pages (madvise(MADV_HUGEPAGE), for the mode
// "madvise" most distributions set) map 2 MiB per fault: 8 faults. The kernel still clears
// every page before it hands it over; that part of a first write stays.
// Where huge pages are not offered (another system, THP "never") the blocks are plain pages.
#pragma once
#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>
#include <vector>

namespace ctlab {

// `bytes` from the calling thread's current block (a new one when it is full: 2 MiB, or the
// request rounded up to whole 2 MiB pages), aligned to 64 bytes (a cache line), left unset.
// *owner keeps the block alive; the thread keeps its current block too (at most one per
// thread), so the next table carries on where this one ended. Each thread fills blocks of
// its own: the pages are first touched by the thread that writes them, no lock is taken.
void* take_huge_pages(size_t bytes, std::shared_ptr<const void>* owner);

// `bytes` for a table the precomputation keeps beside its records (the runs' bounds, each
// run's start: TableVector), aligned to 64 bytes, left unset: from the rest of the calling
// thread's current block when they fit there (most often memory the kernel cleared when the
// records before them were written), else from a mapping of their own on plain 4 KiB pages
// (a fresh 2 MiB page would be cleared whole for a fraction of it). Not from the heap: there
// these tables took the memory warm_up() had readied for the images, and the first render's
// images faulted theirs in page by page, a cost of the precomputation counted in the render.
void* take_table_pages(size_t bytes, std::shared_ptr<const void>* owner);

// An array of `count` T left unset, as std::unique_ptr<T[]>(new T[count]) is for a T without
// a constructor, in huge pages (take_huge_pages()).
template <class T>
class HugeArray {
    static_assert(std::is_trivially_default_constructible<T>::value &&
                      std::is_trivially_destructible<T>::value,
                  "HugeArray holds plain records: no constructor, no destructor");

public:
    HugeArray() = default;
    explicit HugeArray(size_t count)
        : data_(static_cast<T*>(take_huge_pages(count * sizeof(T), &owner_))) {}
    T* get() const { return data_; }

private:
    std::shared_ptr<const void> owner_;  // the block the array lies in
    T* data_ = nullptr;
};

// A std::vector in take_table_pages()'s memory. Each allocation keeps its block alive through
// the owner in a header line before the elements. A freed allocation's bytes are not reused
// until its block is freed: size such a vector once (reserve()).
template <class T>
struct TableAllocator {
    using value_type = T;
    using Owner = std::shared_ptr<const void>;
    static constexpr size_t header = 64;  // a cache line: the elements stay 64-byte aligned
    static_assert(sizeof(Owner) <= header, "the owner fits in the header");

    TableAllocator() = default;
    template <class U>
    TableAllocator(const TableAllocator<U>&) {}

    T* allocate(size_t count) {
        Owner owner;
        char* base = static_cast<char*>(take_table_pages(header + count * sizeof(T), &owner));
        new (base) Owner(std::move(owner));
        return reinterpret_cast<T*>(base + header);
    }
    void deallocate(T* data, size_t) {
        char* base = reinterpret_cast<char*>(data) - header;
        std::launder(reinterpret_cast<Owner*>(base))->~Owner();
    }
    template <class U>
    bool operator==(const TableAllocator<U>&) const { return true; }
    template <class U>
    bool operator!=(const TableAllocator<U>&) const { return false; }
};

template <class T>
using TableVector = std::vector<T, TableAllocator<T>>;

}  // namespace ctlab
