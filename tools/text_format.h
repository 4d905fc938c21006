// text_format.h: printf-style formatting into a std::string of any length, for the texts
// make bench and make study write (tables, sentences, file names). Header-only: each tool
// that uses it is one file.
#pragma once
#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <string>

namespace ctlab {

// What printf would print: its length measured first, then written, so no text is ever cut
// (a fixed buffer of 512 characters once cut make bench's handout sentence short).
inline std::string text_of(const char* format, ...) __attribute__((format(printf, 1, 2)));
inline std::string text_of(const char* format, ...) {
    va_list arguments, again;
    va_start(arguments, format);
    va_copy(again, arguments);
    const int length = std::vsnprintf(nullptr, 0, format, arguments);  // without the '\0'
    va_end(arguments);
    std::string text(size_t(std::max(length, 0)) + 1, '\0');
    std::vsnprintf(text.data(), text.size(), format, again);
    va_end(again);
    text.pop_back();  // the '\0'
    return text;
}

}  // namespace ctlab
