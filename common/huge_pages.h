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
#include <type_traits>

namespace ctlab {

// `bytes` from the calling thread's current block (a new one when it is full: 2 MiB, or the
// request rounded up to whole 2 MiB pages), aligned to 64 bytes (a cache line), left unset.
// *owner keeps the block alive; the thread keeps its current block too (at most one per
// thread), so the next table carries on where this one ended. Each thread fills blocks of
// its own: the pages are first touched by the thread that writes them, no lock is taken.
void* take_huge_pages(size_t bytes, std::shared_ptr<const void>* owner);

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

}  // namespace ctlab
