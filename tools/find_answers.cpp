// find_answers.cpp: looks for the solution's lesson bodies in a folder, e.g. a generated
// student tree, which must hold none (tests/student_test.sh runs it).
//
//   build/find_answers --solution DIR --in DIR [--list]
//
// The answers are the bodies of the lesson functions of DIR/steps/NN_*.cpp (the functions in
// the `//> lesson:` regions, tools/lesson_markers.h): each whole body, whitespace-normalised,
// and each of its distinctive code lines (24 characters or more, comment left out, and found
// nowhere in the solution outside the lesson bodies: not in a main(), a stub or common/).
// Every file under --in is searched, whatever its kind (code, handouts, data, build scripts),
// with whitespace normalised, so a re-indented copy or a handout listing is found as well.
// Prints one line per find, "FILE:LINE: STEP FUNCTION(): LINE-OR-BODY", and exits 1 when
// there is any, 0 when there is none, 2 for bad arguments. --list prints the answers searched.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>
#include "error.h"
#include "tools/kit_tool.h"
#include "tools/lesson_markers.h"

using ctlab::InputError;
namespace fs = std::filesystem;

namespace {

constexpr int exit_found = 1;
constexpr size_t shown_characters = 70;  // of an answer, in a report line
const char* const usage_text =
    "usage: find_answers --solution DIR --in DIR [--list]\n"
    "Searches every file under --in for the bodies of the lesson functions of\n"
    "--solution's steps (whole, or one distinctive line); exit 1 when one is found.\n";

struct Settings {
    std::string solution, in;
    bool list = false;
};

Settings parse_arguments(int argc, char** argv) {
    Settings settings;
    kit_tool::parse(argc, argv, "find_answers", usage_text,
                    {kit_tool::value_flag("--solution", &settings.solution),
                     kit_tool::value_flag("--in", &settings.in),
                     kit_tool::switch_flag("--list", &settings.list)});
    if (settings.solution.empty() || settings.in.empty()) {
        throw InputError("expected --solution DIR and --in DIR (see find_answers --help)");
    }
    if (!fs::is_directory(fs::path(settings.solution) / "steps")) {
        throw InputError("--solution: '" + settings.solution + "' has no steps/ folder");
    }
    if (!fs::is_directory(settings.in)) {
        throw InputError("--in: '" + settings.in + "' is not a folder");
    }
    return settings;
}

std::string shown(const std::string& text) {
    return text.size() <= shown_characters ? text : text.substr(0, shown_characters - 3) + "...";
}

int run(const Settings& settings) {
    const std::vector<lesson::Answer> answers = lesson::solution_answers(settings.solution);
    if (settings.list) {
        for (const lesson::Answer& answer : answers) {
            std::printf("%s %s(): %s%s\n", answer.step.c_str(), answer.function.c_str(),
                        answer.whole_body ? "body: " : "", shown(answer.text).c_str());
        }
    }
    int found = 0;
    size_t files = 0;
    for (const fs::path& path : lesson::files_under(settings.in)) {
        ++files;
        const std::string text = lesson::read_text(path.string());
        for (const lesson::Leak& leak : lesson::find_answers(text, answers)) {
            std::printf("%s:%d: %s %s(): %s%s\n", path.generic_string().c_str(), leak.line,
                        leak.answer->step.c_str(), leak.answer->function.c_str(),
                        leak.answer->whole_body ? "the whole body" : "",
                        leak.answer->whole_body ? "" : shown(leak.answer->text).c_str());
            ++found;
        }
    }
    std::fprintf(stderr, "find_answers: %zu answers (bodies and lines) searched in %zu files "
                 "under %s: %d found\n", answers.size(), files, settings.in.c_str(), found);
    return found > 0 ? exit_found : 0;
}

}  // namespace

int main(int argc, char** argv) {
    return kit_tool::run_main("find_answers", [&] { return run(parse_arguments(argc, argv)); });
}
