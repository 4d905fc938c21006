// huge_pages.cpp: blocks on 2 MiB pages (transparent huge pages), one being filled per thread.
#include "huge_pages.h"
#include <cstdint>
#include <cstdlib>
#include <new>
#ifdef __linux__
#include <sys/mman.h>
#endif

namespace ctlab {

namespace {

constexpr size_t huge_page_bytes = size_t(2) << 20;  // x86-64's and arm64's (4 KiB base pages)
constexpr size_t line_bytes = 64;                      // a cache line: each array starts on one
constexpr size_t page_bytes = size_t(4) << 10;         // a plain page

size_t round_up(size_t n, size_t unit) { return (n + unit - 1) / unit * unit; }

// A block of whole huge pages: mapped on a 2 MiB boundary and advised, so that the kernel can
// back it with huge pages; else (no mmap, or it failed) from the heap, plain pages. huge
// false: a mapping of plain 4 KiB pages (a table's: take_table_pages()), each page faulted
// in only where it is written.
struct Block {
    char* base = nullptr;
    size_t bytes = 0;
    bool mapped = false;

    explicit Block(size_t size, bool huge = true) : bytes(size) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
        if (!huge) {
            void* start = mmap(nullptr, size, PROT_READ | PROT_WRITE,
                               MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
            if (start != MAP_FAILED) {
                base = static_cast<char*>(start);
                madvise(base, size, MADV_NOHUGEPAGE);  // THP "always": still plain pages
                mapped = true;
                return;
            }
        }
        const size_t span = size + huge_page_bytes;  // room to move the start to a boundary
        void* start = mmap(nullptr, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS,
                           -1, 0);
        if (start != MAP_FAILED) {
            char* const low = static_cast<char*>(start);
            base = reinterpret_cast<char*>(
                round_up(reinterpret_cast<uintptr_t>(low), huge_page_bytes));
            if (base > low) munmap(low, size_t(base - low));  // the unaligned head and tail
            if (low + span > base + size) munmap(base + size, size_t(low + span - base - size));
            madvise(base, size, MADV_HUGEPAGE);  // best effort: plain pages if refused
            mapped = true;
            return;
        }
#endif
        base = static_cast<char*>(std::malloc(size));
        if (!base) throw std::bad_alloc();
    }
    ~Block() {
#ifdef __linux__
        if (mapped) {
            munmap(base, bytes);
            return;
        }
#endif
        std::free(base);
    }
    Block(const Block&) = delete;
    Block& operator=(const Block&) = delete;
};

thread_local std::shared_ptr<Block> current;  // this thread's block being filled
thread_local size_t used = 0;                 // its bytes handed out

}  // namespace

void* take_huge_pages(size_t bytes, std::shared_ptr<const void>* owner) {
    bytes = round_up(bytes == 0 ? 1 : bytes, line_bytes);
    if (!current || used + bytes > current->bytes) {
        current = std::make_shared<Block>(round_up(bytes, huge_page_bytes));
        used = 0;
    }
    void* data = current->base + used;
    used += bytes;
    *owner = current;
    return data;
}

void* take_table_pages(size_t bytes, std::shared_ptr<const void>* owner) {
    bytes = round_up(bytes == 0 ? 1 : bytes, line_bytes);
    if (current && used + bytes <= current->bytes) return take_huge_pages(bytes, owner);
    auto block = std::make_shared<Block>(round_up(bytes, page_bytes), false);
    *owner = block;
    return block->base;
}

}  // namespace ctlab
