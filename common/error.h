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

}  // namespace ctlab
