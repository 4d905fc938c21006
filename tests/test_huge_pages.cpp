// test_huge_pages.cpp: HugeArray (common/huge_pages.h), the memory of step 46's records: each
// array its own bytes, aligned, kept while it lives (also after the thread that made it ends),
// and on a kernel that offers transparent huge pages, far fewer page faults than 4 KiB pages;
// and TableVector, the precomputation's other tables: a std::vector off the heap.
#include <doctest/doctest.h>
#include <sys/resource.h>
#include <cstdint>
#include <fstream>
#include <string>
#include <thread>
#include <vector>
#include "huge_pages.h"

using namespace ctlab;

namespace {

constexpr size_t huge_page_bytes = size_t(2) << 20;

// Fills `array` with a pattern of its own (`seed`), or checks that it still holds it.
void fill(const HugeArray<uint32_t>& array, size_t count, uint32_t seed) {
    for (size_t n = 0; n < count; ++n) array.get()[n] = seed * 2654435761u + uint32_t(n);
}
bool holds(const HugeArray<uint32_t>& array, size_t count, uint32_t seed) {
    for (size_t n = 0; n < count; ++n) {
        if (array.get()[n] != seed * 2654435761u + uint32_t(n)) return false;
    }
    return true;
}

// "always" or "madvise": this kernel gives huge pages to memory marked for them.
bool huge_pages_offered() {
    std::ifstream file("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string line;
    std::getline(file, line);
    return line.find("[always]") != std::string::npos ||
           line.find("[madvise]") != std::string::npos;
}

long thread_minor_faults() {
#ifdef RUSAGE_THREAD
    rusage usage{};
    getrusage(RUSAGE_THREAD, &usage);
    return usage.ru_minflt;
#else
    return -1;
#endif
}

}  // namespace

TEST_CASE("HugeArray: arrays of one thread, of many threads and larger than a block") {
    // Sizes around a block's 2 MiB: small ones share a block, 3 MiB takes one of its own.
    const std::vector<size_t> counts = {1, 100, 33000, 200000, 786432, 17, 600000};
    std::vector<HugeArray<uint32_t>> arrays;
    for (size_t n = 0; n < counts.size(); ++n) {
        arrays.emplace_back(counts[n]);
        REQUIRE(arrays.back().get() != nullptr);
        CHECK(reinterpret_cast<uintptr_t>(arrays.back().get()) % 64 == 0);  // a cache line
        fill(arrays.back(), counts[n], uint32_t(n));
    }
    // Made on other threads, which end before the arrays are read: each keeps its block.
    constexpr int threads = 4, per_thread = 20;
    std::vector<HugeArray<uint32_t>> made(threads * per_thread);
    std::vector<std::thread> workers;
    for (int t = 0; t < threads; ++t) {
        workers.emplace_back([&made, t] {
            for (int n = 0; n < per_thread; ++n) {
                const size_t index = size_t(t) * per_thread + n;
                made[index] = HugeArray<uint32_t>(5000 + 3001 * index);
                fill(made[index], 5000 + 3001 * index, uint32_t(1000 + index));
            }
        });
    }
    for (std::thread& worker : workers) worker.join();
    // No array overwrote another: every pattern is intact.
    for (size_t n = 0; n < counts.size(); ++n) CHECK(holds(arrays[n], counts[n], uint32_t(n)));
    for (size_t index = 0; index < made.size(); ++index) {
        CHECK(holds(made[index], 5000 + 3001 * index, uint32_t(1000 + index)));
    }
    CHECK(HugeArray<uint32_t>().get() == nullptr);  // made empty, as a unique_ptr is
}

TEST_CASE("HugeArray: 8 MiB written in a few page faults where huge pages are offered") {
    if (!huge_pages_offered() || thread_minor_faults() < 0) {
        MESSAGE("transparent huge pages not offered here (or no per-thread fault count): skipped");
        return;
    }
    constexpr size_t count = (size_t(8) << 20) / sizeof(uint32_t);
    long faults = -1;
    uintptr_t address = 0;
    std::thread writer([&] {  // a fresh thread: its first array starts a block of its own
        const long before = thread_minor_faults();
        HugeArray<uint32_t> array(count);
        fill(array, count, 7);
        faults = thread_minor_faults() - before;
        address = reinterpret_cast<uintptr_t>(array.get());
        CHECK(holds(array, count, 7));
    });
    writer.join();
    CHECK(address % huge_page_bytes == 0);  // on a 2 MiB boundary
    // 4 KiB pages: 2,048 faults. 2 MiB pages: 4 (and a few for the thread's own start); a
    // kernel short of free 2 MiB pages may hand out some 4 KiB ones, hence the margin.
    MESSAGE("8 MiB in HugeArray: " << faults << " page faults (4 KiB pages: 2048)");
    CHECK(faults < 2048 / 4);
}

TEST_CASE("TableVector: a std::vector off the heap, aligned, kept while it lives, grown and freed") {
    TableVector<int32_t> bounds;
    bounds.reserve(1000);
    for (int n = 0; n < 1000; ++n) bounds.push_back(7 * n - 3);
    TableVector<uint64_t> starts(5000, 3);
    CHECK(reinterpret_cast<uintptr_t>(bounds.data()) % 64 == 0);
    CHECK(reinterpret_cast<uintptr_t>(starts.data()) % 64 == 0);
    // Two tables of one thread: their elements must not overlap.
    const char* b0 = reinterpret_cast<const char*>(bounds.data());
    const char* s0 = reinterpret_cast<const char*>(starts.data());
    CHECK((b0 + 1000 * sizeof(int32_t) <= s0 || s0 + 5000 * sizeof(uint64_t) <= b0));
    // Grown past its reservation (copied into a new allocation: larger than any block's rest,
    // so on plain pages of its own, the old one freed), copied, moved, and freed on another
    // thread: the values stay.
    for (int n = 1000; n < 300000; ++n) bounds.push_back(7 * n - 3);
    TableVector<int32_t> copy = bounds;
    std::thread other([moved = std::move(copy)]() mutable {
        TableVector<int32_t> mine = std::move(moved);
        bool same = mine.size() == 300000;
        for (size_t n = 0; n < mine.size(); n += 997) same = same && mine[n] == 7 * int(n) - 3;
        CHECK(same);
    });
    other.join();
    bool kept = bounds.size() == 300000;
    for (int n = 0; n < 300000; ++n) kept = kept && bounds[size_t(n)] == 7 * n - 3;
    CHECK(kept);
    for (uint64_t value : starts) kept = kept && value == 3;
    CHECK(kept);
}
