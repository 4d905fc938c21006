// machine_load.h: how busy the machine was, apart from us, while a tool timed something.
// The lab machine is shared: a timing taken while other programs ran says little, so the
// bench and the study report the share of the cores other processes used during their run
// (0% = the machine was ours alone). Linux only (/proc/stat); elsewhere the share is unknown.
#pragma once
#include <sys/resource.h>
#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

namespace machine {

// CPU seconds every core has spent busy since boot (user, nice, system, irq, softirq, steal).
inline double busy_seconds() {
    std::ifstream in("/proc/stat");
    std::string cpu;
    double user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0,
           steal = 0;
    if (!(in >> cpu >> user >> nice >> system >> idle >> iowait >> irq >> softirq >> steal)) {
        return -1;
    }
    return (user + nice + system + irq + softirq + steal) / double(sysconf(_SC_CLK_TCK));
}

// CPU seconds this process (all its threads) and the children it has waited for (the step
// programs it timed) have used: theirs is our own load, not the others'.
inline double own_seconds() {
    double seconds = 0;
    for (const int who : {RUSAGE_SELF, RUSAGE_CHILDREN}) {
        rusage usage {};
        getrusage(who, &usage);
        seconds += usage.ru_utime.tv_sec + usage.ru_utime.tv_usec * 1e-6 +
                   usage.ru_stime.tv_sec + usage.ru_stime.tv_usec * 1e-6;
    }
    return seconds;
}

class OtherLoad {
public:
    OtherLoad()
        : busy_(busy_seconds()), own_(own_seconds()), start_(std::chrono::steady_clock::now()) {}

    // Share (0..1) of all cores that other processes kept busy since construction; -1 when
    // /proc/stat cannot be read.
    double share() const {
        const double busy = busy_seconds();
        if (busy < 0 || busy_ < 0) return -1;
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
        const double cores = std::max(1u, std::thread::hardware_concurrency());
        const double others = (busy - busy_) - (own_seconds() - own_);
        return std::clamp(others / (wall * cores), 0.0, 1.0);
    }

private:
    double busy_, own_;
    std::chrono::steady_clock::time_point start_;
};

// What /proc/stat cannot show: on a virtual machine the host may run other guests on our
// cores, or beside them on the same shared cache and memory, and every timing then stretches
// while the guest's own counters say "idle". The speed check times two fixed pieces of work
// and keeps the fastest of a few tries of each: a chain of integer multiply-adds (about 45 ms
// on the lab's machines) on one thread, then on every core at once; and a walk of dependent
// reads through 16 MiB, a CThead-sized volume's worth (it stays in the last-level cache
// unless other guests push it out). The same code on the same machine should take the same
// time all day: a check that took longer than the run's fastest one means the machine was
// that much slower then, whatever the load figures say.
struct SpeedCheck {
    double one_thread_ms = 0;  // the arithmetic on one thread
    double all_cores_ms = 0;   // the same on every core at once (the slowest of them)
    double memory_ms = 0;      // the walk through 16 MiB, one thread
};

// Dependent reads through 16 MiB in a fixed random order (each read gives the next place):
// every read waits for the last, so the time is the memory's latency, not its bandwidth.
inline double memory_walk_ms() {
    constexpr uint32_t places = uint32_t(1) << 21;  // 8-byte places: 16 MiB
    constexpr uint32_t reads = uint32_t(1) << 19;
    static const std::vector<uint64_t> next = [] {
        // One cycle through every place (Sattolo's shuffle), from a fixed seed.
        std::vector<uint64_t> order(places);
        for (uint32_t n = 0; n < places; ++n) order[n] = n;
        uint64_t seed = 12345;
        for (uint32_t n = places - 1; n > 0; --n) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            std::swap(order[n], order[(seed >> 33) % n]);
        }
        return order;
    }();
    const auto start = std::chrono::steady_clock::now();
    uint64_t at = 0;
    for (uint32_t n = 0; n < reads; ++n) at = next[at];
    volatile uint64_t sink = at;
    (void)sink;
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
        .count();
}

inline double fixed_loop_ms() {
    constexpr uint64_t steps = uint64_t(1) << 25;  // multiply-adds in the chain
    const auto start = std::chrono::steady_clock::now();
    uint64_t x = 1;
    for (uint64_t n = 0; n < steps; ++n) x = x * 6364136223846793005ull + n;  // serial chain
    volatile uint64_t sink = x;  // the result is used: the loop cannot be dropped
    (void)sink;
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
        .count();
}

inline SpeedCheck speed_check(int tries = 3) {
    SpeedCheck best{1e300, 1e300, 1e300};
    const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
    for (int t = 0; t < tries; ++t) {
        best.one_thread_ms = std::min(best.one_thread_ms, fixed_loop_ms());
        std::vector<double> each(cores);
        std::vector<std::thread> threads;
        for (unsigned c = 0; c < cores; ++c) {
            threads.emplace_back([&each, c] { each[c] = fixed_loop_ms(); });
        }
        for (std::thread& thread : threads) thread.join();
        best.all_cores_ms =
            std::min(best.all_cores_ms, *std::max_element(each.begin(), each.end()));
        best.memory_ms = std::min(best.memory_ms, memory_walk_ms());
    }
    return best;
}

}  // namespace machine
