// carry.cpp: in a student tree, copies the student's own lesson functions forward into the
// later steps that use them unchanged (`make carry [STEP=NN]`), so that each is written once.
//
//   build/carry [--step NN] [--tree DIR]       (default: every step, in the tree .)
//
// make_student writes DIR/.ctlab/carry.txt: one line "TO_STEP FUNCTION FROM_STEP STUB_HASH"
// per lesson function that TO_STEP takes unchanged from FROM_STEP in the solution: the nearest
// step it builds on, by its header's "Builds on:" chain, that has the function (step 19 takes
// step 15's composite_front_to_back(), not the jittered one of step 17, numbered before it).
// For each line (in step order, and FROM_STEP is always an earlier step, so 02 -> 03 -> 04 and
// 12 -> 16 -> 17 carry in one run):
//   - FROM_STEP's function still a stub (it calls not_done): nothing to carry yet;
//   - TO_STEP's function no longer the stub generated there (STUB_HASH): the student wrote or
//     changed it, and it is left alone;
//   - otherwise TO_STEP's function (comment lines, signature and body) is replaced by
//     FROM_STEP's, and the rest of the file is untouched.
// Prints one line per function it looked at. Exit 0, or 2 for bad input (no record, a step
// that does not parse).
//
//   build/carry --lab --function NAME --from NN [--tree DIR]      (make carry-lab)
//
// In the lab (the solution): a fix to step NN's function NAME reaches every later step whose
// "Builds on:" chain takes it from step NN unchanged (tools/lesson_markers.h, "Copies across
// steps": the steps compared with step NN's copy, or with one so carried, whose copy does not
// say "changed in step MM" for their own MM); a step that changes it keeps its version, and so
// do the steps that build on it. tests/test_lesson_markers.cpp fails when such copies differ.
#include <sys/stat.h>
#include <unistd.h>
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include "error.h"
#include "tools/kit_tool.h"
#include "tools/lesson_markers.h"

using ctlab::InputError;
namespace fs = std::filesystem;

namespace {

const char* const record_path = ".ctlab/carry.txt";
const char* const usage_text =
    "usage: carry [--step NN] [--tree DIR]\n"
    "In a student tree (default .), copies your version of each lesson function that a later\n"
    "step uses unchanged into that step, where it is still the generated stub. Never\n"
    "overwrites a function you wrote. --step NN: only into step NN.\n"
    "\n"
    "usage: carry --lab --function NAME --from NN [--tree DIR]\n"
    "In the lab: copies step NN's function NAME (comments, signature, body) into every later\n"
    "step that takes it from step NN unchanged by its \"Builds on:\" chain, up to a step whose\n"
    "copy says \"changed in step MM\" (MM its own number): the steps built on that one keep\n"
    "its version.\n";

struct Settings {
    std::string step;  // "" = every step; else the two digits
    std::string tree = ".";
    bool lab = false;             // --lab: carry a function of the solution forward
    std::string function, from;  // --function NAME --from NN (with --lab)
};

Settings parse_arguments(int argc, char** argv) {
    Settings settings;
    kit_tool::parse(argc, argv, "carry", usage_text,
                    {kit_tool::value_flag("--step", &settings.step),
                     kit_tool::value_flag("--tree", &settings.tree),
                     kit_tool::switch_flag("--lab", &settings.lab),
                     kit_tool::value_flag("--function", &settings.function),
                     kit_tool::value_flag("--from", &settings.from)});
    if (settings.lab != (!settings.function.empty() || !settings.from.empty())) {
        throw InputError("--lab goes with --function NAME and --from NN (see carry --help)");
    }
    if (settings.lab) {
        if (settings.function.empty() || settings.from.empty()) {
            throw InputError("--lab needs --function NAME and --from NN");
        }
        if (!settings.step.empty()) throw InputError("--step is for a student tree, not --lab");
        std::string& from = settings.from;
        const auto digit = [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; };
        if (!std::all_of(from.begin(), from.end(), digit) || from.size() > 2) {
            throw InputError("--from: expected a step number like 10, got '" + from + "'");
        }
        if (from.size() == 1) from = "0" + from;
    }
    std::string& step = settings.step;
    const auto digit = [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; };
    if (!step.empty() && !std::all_of(step.begin(), step.end(), digit)) {
        throw InputError("--step: expected a step number like 03, got '" + step + "'");
    }
    if (step.size() == 1) step = "0" + step;
    if (step.size() > 2) {
        throw InputError("--step: expected a step number like 03, got '" + step + "'");
    }
    return settings;
}

struct Line {
    std::string to, function, from, stub_hash;
};

// "03_depth_shading": two digits, '_', then lower-case letters, digits and '_'.
bool step_name(const std::string& name) {
    if (name.size() < 4 || !std::isdigit(static_cast<unsigned char>(name[0])) ||
        !std::isdigit(static_cast<unsigned char>(name[1])) || name[2] != '_') {
        return false;
    }
    return std::all_of(name.begin() + 3, name.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
    });
}

bool identifier(const std::string& name) {
    if (name.empty() || std::isdigit(static_cast<unsigned char>(name[0]))) return false;
    return std::all_of(name.begin(), name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
    });
}

std::vector<Line> read_record(const fs::path& tree) {
    const fs::path path = tree / record_path;
    if (!fs::is_regular_file(path)) {
        throw InputError("no " + path.generic_string() + ": make carry works in a student tree "
                         "made by make student");
    }
    std::vector<Line> lines;
    std::istringstream text(lesson::read_text(path.string()));
    std::string line;
    while (std::getline(text, line)) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream words(line);
        Line entry;
        if (!(words >> entry.to >> entry.function >> entry.from >> entry.stub_hash)) {
            throw InputError(path.generic_string() + ": cannot read the line '" +
                             ctlab::printable(line) + "'");
        }
        // The steps are names, never paths: a line "../../victim" must not reach a file
        // outside the tree's steps/ folder.
        if (!step_name(entry.to) || !step_name(entry.from) || !identifier(entry.function)) {
            throw InputError(path.generic_string() + ": '" + ctlab::printable(line) +
                             "' is not 'NN_step FUNCTION NN_step HASH' (step names are two "
                             "digits, '_' and lower-case letters, digits or '_')");
        }
        lines.push_back(entry);
    }
    return lines;
}

// The function `name` of a step source, or false when the step has none.
bool find_function(const std::string& source, const std::string& path, const std::string& name,
                   lesson::Function& found) {
    for (const lesson::Function& function :
         lesson::lesson_functions(source, lesson::mask_code(source), path)) {
        if (function.name == name) {
            found = function;
            return true;
        }
    }
    return false;
}

// A stub calls not_done(...) (common/not_done.h): such a body is still to write.
bool is_stub(const std::string& function_text) {
    for (const std::string& word : lesson::tokens(lesson::mask_code(function_text))) {
        if (word == "not_done") return true;
    }
    return false;
}

// Through a new temporary beside it (O_EXCL: never an existing file or a link), renamed into
// place: never a half-written step, never a write through a link.
void write_text(const fs::path& path, const std::string& text) {
    std::string temporary = path.string() + ".carry-XXXXXX";
    const int fd = mkstemp(temporary.data());
    if (fd < 0) throw InputError("cannot write '" + path.string() + "': " + std::strerror(errno));
    size_t done = 0;
    while (done < text.size()) {
        const ssize_t wrote = write(fd, text.data() + done, text.size() - done);
        if (wrote < 0 && errno == EINTR) continue;
        if (wrote <= 0) break;
        done += size_t(wrote);
    }
    const bool written = done == text.size() && fchmod(fd, 0644) == 0;
    if (close(fd) != 0 || !written || std::rename(temporary.c_str(), path.c_str()) != 0) {
        const int error = errno;
        unlink(temporary.c_str());
        throw InputError("cannot write '" + path.string() + "': " + std::strerror(error));
    }
}

// A step file carry may read or write: an ordinary file, not a link, in the tree's steps/.
bool plain_step_file(const fs::path& path) {
    std::error_code error;
    const fs::file_status status = fs::symlink_status(path, error);
    return !error && fs::is_regular_file(status) &&
           !fs::is_symlink(fs::symlink_status(path.parent_path(), error)) && !error;
}

// --lab: carry step settings.from's function forward through the solution's steps.
int run_lab(const Settings& settings) {
    const fs::path tree = settings.tree;
    bool identifier_name = !settings.function.empty();
    for (char c : settings.function) identifier_name = identifier_name && lesson::is_identifier_char(c);
    if (!identifier_name) {
        throw InputError("--function: expected a function name, got '" +
                         ctlab::printable(settings.function) + "'");
    }
    std::vector<std::pair<std::string, std::string>> steps = lesson::read_steps(tree);
    const std::vector<std::pair<std::string, std::string>> before = steps;
    const std::vector<lesson::Carried> carried =
        lesson::carry_forward(steps, settings.function, settings.from);
    int written = 0;
    for (const lesson::Carried& step : carried) {
        const std::string what = step.step + ": " + settings.function + "()";
        if (step.outcome == "changes it") {
            std::printf("%s: kept, this step changes it (\"changed in step %s\"): the later "
                        "steps follow this version\n", what.c_str(), step.step.substr(0, 2).c_str());
        } else if (step.outcome == "same") {
            std::printf("%s: already the same\n", what.c_str());
        } else {
            std::printf("%s: carried%s\n", what.c_str(),
                        step.drifted ? (" (its code had drifted from " + step.earlier + "'s)").c_str()
                                     : "");
        }
    }
    for (size_t n = 0; n < steps.size(); ++n) {
        if (steps[n].second == before[n].second) continue;
        const fs::path path = tree / "steps" / (steps[n].first + ".cpp");
        if (!plain_step_file(path)) {
            throw InputError(path.generic_string() + " is not a plain file: nothing written");
        }
    }
    for (size_t n = 0; n < steps.size(); ++n) {
        if (steps[n].second == before[n].second) continue;
        write_text(tree / "steps" / (steps[n].first + ".cpp"), steps[n].second);
        ++written;
    }
    std::printf("carry --lab: %s() from step %s into %d later step(s)\n",
                settings.function.c_str(), settings.from.c_str(), written);
    return 0;
}

int run(const Settings& settings) {
    if (settings.lab) return run_lab(settings);
    const fs::path tree = settings.tree;
    int carried = 0, kept = 0, waiting = 0;
    for (const Line& line : read_record(tree)) {
        if (!settings.step.empty() && line.to.compare(0, 2, settings.step) != 0) continue;
        const std::string to_path = "steps/" + line.to + ".cpp";
        const std::string from_path = "steps/" + line.from + ".cpp";
        const std::string what = line.to + ": " + line.function + "()";
        if (!plain_step_file(tree / to_path) || !plain_step_file(tree / from_path)) {
            std::printf("%s: skipped, %s or %s is missing (or is a link)\n", what.c_str(),
                        to_path.c_str(), from_path.c_str());
            continue;
        }
        const std::string from_source = lesson::read_text((tree / from_path).string());
        std::string to_source = lesson::read_text((tree / to_path).string());
        lesson::Function from_function, to_function;
        if (!find_function(from_source, from_path, line.function, from_function)) {
            std::printf("%s: skipped, %s has no %s() in a lesson region any more\n",
                        what.c_str(), from_path.c_str(), line.function.c_str());
            continue;
        }
        if (!find_function(to_source, to_path, line.function, to_function)) {
            std::printf("%s: skipped, %s has no %s() in a lesson region any more\n",
                        what.c_str(), to_path.c_str(), line.function.c_str());
            continue;
        }
        const std::string from_text = lesson::function_text(from_source, from_function);
        const std::string to_text = lesson::function_text(to_source, to_function);
        if (is_stub(from_text)) {
            std::printf("%s: not yet, write it in %s first\n", what.c_str(), line.from.c_str());
            ++waiting;
        } else if (to_text == from_text) {
            std::printf("%s: already the same as in %s\n", what.c_str(), line.from.c_str());
        } else if (lesson::content_hash(to_text) != line.stub_hash) {
            std::printf("%s: kept, you have changed it there (it differs from %s's)\n",
                        what.c_str(), line.from.c_str());
            ++kept;
        } else {
            size_t end = to_source.find('\n', to_function.body_close);
            end = end == std::string::npos ? to_source.size() : end + 1;
            to_source.replace(to_function.start, end - to_function.start, from_text);
            write_text(tree / to_path, to_source);
            std::printf("%s: carried from %s\n", what.c_str(), line.from.c_str());
            ++carried;
        }
    }
    std::printf("carry: %d function(s) carried, %d kept as you wrote them, %d still to write "
                "in an earlier step\n", carried, kept, waiting);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    return kit_tool::run_main("carry", [&] { return run(parse_arguments(argc, argv)); });
}
