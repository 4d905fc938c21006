// kit_tool.h: what the student-kit tools (make_student, find_answers, carry) share around
// their work: their command line (flags with a value, switches, --help, one error line for
// anything else) and their main() (an error is one line "TOOL: error: ..." and exit status 2).
// Header-only, as tools/lesson_markers.h: each tool is a single .cpp file.
#pragma once
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>
#include "error.h"

namespace kit_tool {

// One flag: `--name VALUE` into *value, or, with value null, the switch `--name` setting *on.
struct Flag {
    std::string name;
    std::string* value = nullptr;
    bool* on = nullptr;
};

inline Flag value_flag(const std::string& name, std::string* value) {
    return {name, value, nullptr};
}
inline Flag switch_flag(const std::string& name, bool* on) { return {name, nullptr, on}; }

// Reads argv into the flags. --help (or -h) prints `usage` and exits 0. A value flag needs a
// non-empty value after it; an unknown argument is an InputError naming `tool --help`.
inline void parse(int argc, char** argv, const std::string& tool, const char* usage,
                  const std::vector<Flag>& flags) {
    for (int a = 1; a < argc; ++a) {
        const std::string arg = argv[a];
        if (arg == "--help" || arg == "-h") {
            std::printf("%s", usage);
            std::exit(0);
        }
        const Flag* flag = nullptr;
        for (const Flag& candidate : flags) {
            if (candidate.name == arg) flag = &candidate;
        }
        if (!flag) {
            throw ctlab::InputError("unknown argument '" + arg + "' (see " + tool + " --help)");
        }
        if (flag->on) {
            *flag->on = true;
            continue;
        }
        if (a + 1 >= argc || std::string(argv[a + 1]).empty()) {
            throw ctlab::InputError(arg + ": expected a value after it");
        }
        *flag->value = argv[++a];
    }
}

// A tool's main(): its exit status, or for an InputError (or a filesystem error) one line on
// stderr and exit status 2.
template <class Body>
int run_main(const char* tool, Body body) {
    try {
        return body();
    } catch (const std::exception& error) {
        std::fprintf(stderr, "%s: error: %s\n", tool, error.what());
        return ctlab::exit_bad_input;
    }
}

}  // namespace kit_tool
