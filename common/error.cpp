// error.cpp: messages that stay one line, whatever a path or value holds.
#include "error.h"
#include <cstdio>

namespace ctlab {

namespace {

// Length of the well-formed UTF-8 sequence starting at text[at], or 0 when it is not one.
size_t utf8_length(const std::string& text, size_t at, unsigned* code) {
    const unsigned char first = static_cast<unsigned char>(text[at]);
    size_t length = 0;
    unsigned value = 0, lowest = 0;
    if (first >= 0xC2 && first <= 0xDF) length = 2, value = first & 0x1F, lowest = 0x80;
    else if (first >= 0xE0 && first <= 0xEF) length = 3, value = first & 0x0F, lowest = 0x800;
    else if (first >= 0xF0 && first <= 0xF4) length = 4, value = first & 0x07, lowest = 0x10000;
    else return 0;
    if (at + length > text.size()) return 0;
    for (size_t n = 1; n < length; ++n) {
        const unsigned char next = static_cast<unsigned char>(text[at + n]);
        if ((next & 0xC0) != 0x80) return 0;
        value = (value << 6) | (next & 0x3F);
    }
    if (value < lowest || value > 0x10FFFF || (value >= 0xD800 && value <= 0xDFFF)) return 0;
    *code = value;
    return length;
}

}  // namespace

std::string printable(const std::string& text) {
    std::string result;
    result.reserve(text.size());
    for (size_t at = 0; at < text.size();) {
        const unsigned char c = static_cast<unsigned char>(text[at]);
        char escape[8];
        if (c >= 0x20 && c < 0x7F) {
            result += char(c);
            ++at;
            continue;
        }
        if (c == '\n' || c == '\t' || c == '\r') {
            result += c == '\n' ? "\\n" : c == '\t' ? "\\t" : "\\r";
            ++at;
            continue;
        }
        unsigned code = 0;
        const size_t length = c >= 0x80 ? utf8_length(text, at, &code) : 0;
        if (length > 0 && !(code >= 0x80 && code <= 0x9F)) {  // C1 controls act like ESC [
            result.append(text, at, length);
            at += length;
            continue;
        }
        // A control character, a C1 control or a byte that is not UTF-8: one byte escaped.
        std::snprintf(escape, sizeof escape, "\\x%02x", c);
        result += escape;
        ++at;
    }
    return result;
}

}  // namespace ctlab
