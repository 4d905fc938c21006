// error.h: the one error type every bad input turns into.
// A step catches it in guarded_main() and prints one line, exit status 2.
#pragma once
#include <stdexcept>
#include <string>

namespace ctlab {

constexpr int exit_bad_input = 2;  // documented exit status for any bad input

struct InputError : std::runtime_error {
    explicit InputError(const std::string& message) : std::runtime_error(message) {}
};

// `text` made safe to echo on one terminal line: newlines, tabs, ESC and the other control
// characters (C0, DEL and the C1 range U+0080..U+009F), and bytes that are not UTF-8, become
// escapes such as \n, \t and \x1b. Printable text, UTF-8 included, is unchanged.
std::string printable(const std::string& text);

}  // namespace ctlab
