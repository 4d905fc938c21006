// machine_load.h: how busy the machine was, apart from us, while a tool timed something.
// The lab machine is shared: a timing taken while other programs ran says little, so the
// bench and the study report the share of the cores other processes used during their run
// (0% = the machine was ours alone). Linux only (/proc/stat); elsewhere the share is unknown.
#pragma once
#include <sys/resource.h>
#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <fstream>
#include <string>
#include <thread>

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

}  // namespace machine
