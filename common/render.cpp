// render.cpp: the per-pixel trace.
#include "render.h"
#include <cstdarg>
#include <cstdio>

namespace ctlab {

void Trace::add(const char* format, ...) {
    char line[512];
    va_list arguments;
    va_start(arguments, format);
    std::vsnprintf(line, sizeof line, format, arguments);
    va_end(arguments);
    lines_.emplace_back(line);
}

}  // namespace ctlab
