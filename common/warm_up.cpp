// warm_up.cpp: the image memory and the render threads, ready before the first render.
#include "warm_up.h"
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <sys/mman.h>
#include <system_error>
#include <thread>
#include "render.h"

namespace ctlab {

namespace {

constexpr size_t page_bytes = 4096;
// glibc refuses an mmap threshold above 32 MiB (on 64-bit): larger images are still mapped
// and unmapped per render, and fault in as before.
constexpr size_t max_kept_bytes = size_t(32) << 20;

// Asks the kernel to map all whole pages of a block in one call (Linux 5.14+): on the lab's
// VM 0.1 ms for 786 KB, against ~2 ms for the same pages faulted in one by one.
void populate(char* block, size_t bytes) {
#ifdef MADV_POPULATE_WRITE
    const uintptr_t first = (reinterpret_cast<uintptr_t>(block) + page_bytes - 1) / page_bytes;
    const uintptr_t end = (reinterpret_cast<uintptr_t>(block) + bytes) / page_bytes;
    if (end <= first) return;  // no whole page: touching it is cheap
    madvise(reinterpret_cast<void*>(first * page_bytes), (end - first) * page_bytes,
            MADV_POPULATE_WRITE);  // best effort: on failure the caller touches each page
#else
    (void)block, (void)bytes;
#endif
}

// Maps every page of `bytes` fresh bytes and frees them: the heap keeps them, faulted in.
void touch_heap(size_t bytes) {
    char* block = static_cast<char*>(std::malloc(bytes));
    if (!block) return;  // nothing lost: the render will fault its pages in itself
    populate(block, bytes);  // when it cannot (older kernels), the writes fault page by page
    for (size_t n = 0; n < bytes; n += page_bytes) block[n] = 1;
    // Read them back through a volatile so the compiler cannot drop the block as unused.
    volatile char sink = 0;
    for (size_t n = 0; n < bytes; n += page_bytes) sink = sink + block[n];
    std::free(block);
}

// Every thread reads one value per cache line of the volume, so each core holds the lines
// it will read as shared copies, not as lines another core wrote (the loader's core).
void read_everywhere(const Volume& volume, int threads) {
    constexpr size_t values_per_line = 64 / sizeof(int16_t);
    auto read_all = [&volume] {
        int64_t sum = 0;  // at most 2^26 lines of 32767: no overflow
        for (size_t n = 0; n < volume.data.size(); n += values_per_line) sum += volume.data[n];
        volatile int64_t sink = sum;
        (void)sink;
    };
    // On the render threads themselves (the pool's workers), so that their cores, caches and
    // address translations are the render's.
    const RowCallback read_once = [](void* context, int, Work&) {
        (*static_cast<decltype(read_all)*>(context))();
    };
    pool_each(threads, read_once, &read_all);
}

}  // namespace

double warm_up(const std::vector<View>& views, int threads, const Volume* volume) {
    const Timer timer;
    size_t image_bytes = 0;
    for (const View& view : views) {
        image_bytes = std::max(image_bytes, size_t(view.width) * view.height * sizeof(Rgb));
    }
    // A render keeps its image while the next is made (--repeat, step 08's two orders), and
    // an object-order render makes an intermediate image beside its own (as large, for a
    // view along an axis): room for three images, rounded up to whole pages.
    const size_t kept = std::min(3 * image_bytes + page_bytes, max_kept_bytes / 2);
#ifdef __GLIBC__
    // Blocks below 2 * kept come from the heap (the threshold must exceed the block touched
    // below, or glibc maps that block apart and unmaps it on free), and a free hands memory
    // back to the system only when more than 4 * kept lies spare.
    mallopt(M_MMAP_THRESHOLD, int(2 * kept));
    mallopt(M_TRIM_THRESHOLD, int(4 * kept));
#endif
    touch_heap(kept);
    start_render_threads(threads);  // the pool, made once (common/render.h)
    // Last: a worker stays awake a moment after its work, for the first render.
    if (volume) read_everywhere(*volume, threads);
    return timer.ms();
}

}  // namespace ctlab
