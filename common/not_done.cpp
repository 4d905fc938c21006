// not_done.cpp: the stubs' once-per-function TODO line.
#include "not_done.h"
#include <cstdio>
#include <mutex>
#include <set>
#include <string>

namespace ctlab {

void not_done(const char* step, const char* function) {
    static std::mutex mutex;              // stubs run on every render thread
    static std::set<std::string> told;    // "step function" pairs already reported
    const std::lock_guard<std::mutex> lock(mutex);
    if (!told.insert(std::string(step) + " " + function).second) return;
    std::fprintf(stderr, "TODO: %s: %s() is not written yet — see handouts/%s.md\n",
                 step, function, step);
    std::fflush(stderr);
}

}  // namespace ctlab
