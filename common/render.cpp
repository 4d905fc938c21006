// render.cpp: the per-pixel trace, and the note when render threads are short.
#include "render.h"
#include <cstdarg>
#include <cstdio>
#include <utility>

namespace ctlab {

void Trace::add(const char* format, ...) {
    char line[512];
    va_list arguments;
    va_start(arguments, format);
    std::vsnprintf(line, sizeof line, format, arguments);
    va_end(arguments);
    ++added_;
    if (first_.size() < max_first_lines) {
        first_.emplace_back(line);
    } else if (last_.size() < max_last_lines) {
        last_.emplace_back(line);
    } else {
        last_[last_next_] = line;
        last_next_ = (last_next_ + 1) % max_last_lines;
    }
}

std::vector<std::string> Trace::last_lines() const {
    std::vector<std::string> lines;
    for (size_t n = 0; n < last_.size(); ++n) {
        lines.push_back(last_[(last_next_ + n) % last_.size()]);
    }
    return lines;
}

std::vector<std::string> Trace::lines() const {
    std::vector<std::string> lines = first_;
    for (std::string& line : last_lines()) lines.push_back(std::move(line));
    return lines;
}

void note_fewer_threads(int started, int wanted) {
    static std::atomic<bool> said{false};
    if (said.exchange(true)) return;
    std::fprintf(stderr,
                 "note: only %d of %d render threads could be started (ulimit -u?); rendering "
                 "with %d\n",
                 started, wanted, started);
}

}  // namespace ctlab
