// make_student.cpp: generates the student skeleton (`make student`): a copy of the lab that
// builds with the same Makefile, in which the body of every lesson function is a stub.
//
//   build/make_student [--from DIR] [--to DIR] [--force]     (defaults: . and student)
//
// Copies Makefile, .gitignore, common/, tools/, tests/, data/ (not data/CThead) and handouts/.
// Each steps/NN_name.cpp is copied with the body of every function defined in a lesson region
// (tools/lesson_markers.h) replaced by a stub that compiles and runs:
//     {
//         not_done("NN_name", "first_hit", volume, view, x, y, threshold, work, trace);
//         return {};
//     }
// Comments, signatures, structs and constants stay; nothing outside the regions changes.
// The handouts' listings are refreshed from the stubbed steps, so they quote what the student
// has. Besides, it writes:
//   README.md          the student's "start here" (tools/student_README.md, with a table of
//                      the steps and their functions); the lab's README.md becomes LAB.md;
//   .ctlab/pristine/   the stubbed steps as generated: `make diff` in the kit compares these,
//                      so that it shows what a step teaches, not the student's own code;
//   .ctlab/carry.txt   which lesson functions a step takes unchanged from the step it builds
//                      on, or that step's ancestors (the same code in the solution): `make
//                      carry` (tools/carry.cpp) copies the student's own version forward into
//                      the later step's stub.
// DIR/.ctlab-student lists every generated file with its hash: regenerating refuses to
// overwrite a file changed since (a student's work) unless --force is given.
// The whole tree is made in memory first. When any file of it would hold a lesson body of the
// solution, or one of its distinctive lines (tools/find_answers.cpp's search), make_student
// names where and exits 1, writing nothing (an earlier tree in DIR is left as it was); exit 2
// for bad input.
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>
#include "error.h"
#include "tools/kit_tool.h"
#include "tools/lesson_markers.h"

using ctlab::InputError;
namespace fs = std::filesystem;

namespace {

const char* const record_name = ".ctlab-student";  // marks a generated tree, lists its files
// What a student tree holds besides steps/: enough to build, test and read the lab.
const std::vector<std::string> copied = {"Makefile", ".gitignore", "common", "tools",
                                         "tests",    "data",       "handouts"};
const std::vector<std::string> not_copied = {
    "data/CThead",               // not ours to hand out
    "tests/check_mistakes.txt",  // its patches quote solution lines
    "tools/student_README.md"};  // becomes README.md
const char* const readme_template = "tools/student_README.md";
const char* const readme_steps = "{{steps}}";    // where the template wants the table
const char* const pristine_folder = ".ctlab/pristine/";
const char* const carry_record = ".ctlab/carry.txt";
constexpr int shown_answers = 10;  // answers found in the kit, named in the error
constexpr int exit_answers_found = 1;  // the kit would hand out answers: nothing written
constexpr size_t stub_width = 96;  // columns: stub calls wrap before this
const char* const usage_text =
    "usage: make_student [--from DIR] [--to DIR] [--force]\n"
    "Writes a student copy of the lab in DIR (default student) from the lab in --from\n"
    "(default .): lesson functions become stubs that say they are not written yet.\n"
    "--force overwrites files changed since the last generation.\n";

struct Settings {
    std::string from = ".", to = "student";
    bool force = false;
};

Settings parse_arguments(int argc, char** argv) {
    Settings settings;
    kit_tool::parse(argc, argv, "make_student", usage_text,
                    {kit_tool::value_flag("--from", &settings.from),
                     kit_tool::value_flag("--to", &settings.to),
                     kit_tool::switch_flag("--force", &settings.force)});
    return settings;
}

// "    not_done(step_name, "first_hit", volume, view, ...);", wrapped before stub_width. `step`
// is the step's own step_name constant, or its name in quotes when it has none: with the
// constant, a function's stub reads the same in every step, and `make diff` shows no change.
std::string not_done_call(const std::string& step, const lesson::Function& function) {
    std::vector<std::string> arguments = {step, "\"" + function.name + "\""};
    for (const std::string& name : function.parameters) arguments.push_back(name);
    const std::string indent = "    ", open = "not_done(";
    std::string text = indent + open, line = text;
    for (size_t n = 0; n < arguments.size(); ++n) {
        const std::string piece = arguments[n] + (n + 1 < arguments.size() ? ", " : ");");
        if (line.size() + lesson::trim(piece).size() > stub_width && n > 0) {
            while (!text.empty() && text.back() == ' ') text.pop_back();
            line = indent + std::string(open.size(), ' ');
            text += "\n" + line;
        }
        text += piece;
        line += piece;
    }
    return text;
}

std::string stub_body(const std::string& step, const lesson::Function& function,
                      const std::string& where) {
    const std::string& type = function.return_type;
    if (type == "auto" || type == "decltype(auto)") {
        throw InputError(where + function.name + "() returns auto: give it a named return type "
                         "so that its stub can return {}");
    }
    if (!type.empty() && (type.back() == '&')) {
        throw InputError(where + function.name + "() returns a reference: a stub cannot " +
                         "return {} for it");
    }
    std::string body = "{\n" + not_done_call(step, function) + "\n";
    if (!type.empty() && type != "void") body += "    return {};\n";
    return body + "}";
}

// A step with every lesson function stubbed. Static functions that nothing calls any more
// (lesson functions or helpers whose callers are stubs now) get [[maybe_unused]], so that the
// kit's build stays quiet under -Werror.
std::string stub_step(const std::string& source, const std::string& path,
                      const std::string& step, int& stubbed) {
    std::string result = source;
    const std::vector<lesson::Region> regions = lesson::find_regions(source, path);
    const std::string masked = lesson::mask_code(source);
    const std::vector<std::string> words = lesson::tokens(masked);
    bool has_step_name = false;  // `constexpr const char* step_name = "NN_name";`
    for (size_t n = 0; n + 2 < words.size(); ++n) {
        has_step_name = has_step_name ||
                        (words[n] == "*" && words[n + 1] == "step_name" && words[n + 2] == "=");
    }
    const std::string step_argument = has_step_name ? "step_name" : "\"" + step + "\"";
    for (auto region = regions.rbegin(); region != regions.rend(); ++region) {
        const auto functions = lesson::find_functions(source, masked, *region, path);
        if (functions.empty()) {
            std::fprintf(stderr, "make_student: %s: region '%s' defines no function: copied "
                         "unchanged\n", path.c_str(), region->name.c_str());
        }
        for (auto function = functions.rbegin(); function != functions.rend(); ++function) {
            const std::string where =
                path + ":" + std::to_string(lesson::line_of(source, function->header)) + ": ";
            result.replace(function->body_open, function->body_close + 1 - function->body_open,
                           stub_body(step_argument, *function, where));
            ++stubbed;
        }
    }
    // Which static functions (lesson or not) does nothing call any more? A call is the name
    // followed by "(" and not after "." or "->" (a member of that name is another function);
    // a parameter or variable of the same name is no call. Marking a function that is still
    // used through a pointer does no harm; missing one stops the kit's -Werror build.
    const std::string stubbed_masked = lesson::mask_code(result);
    const std::vector<std::string> stubbed_words = lesson::tokens(stubbed_masked);
    lesson::Region whole;
    whole.name = "(the whole file)";
    whole.end = result.size();
    std::vector<size_t> unused_at;
    for (const auto& function : lesson::find_functions(result, stubbed_masked, whole, path)) {
        if (!function.is_static || function.is_template) continue;
        int calls = 0;
        for (size_t n = 0; n + 1 < stubbed_words.size(); ++n) {
            const bool member = n > 0 && (stubbed_words[n - 1] == "." ||
                                          stubbed_words[n - 1] == "->");
            calls += stubbed_words[n] == function.name && stubbed_words[n + 1] == "(" && !member;
        }
        const bool marked = result.compare(function.header, 17, "[[maybe_unused]] ") == 0;
        if (calls <= 1 && !marked) unused_at.push_back(function.header);  // 1: its definition
    }
    std::sort(unused_at.rbegin(), unused_at.rend());
    for (size_t at : unused_at) result.insert(at, "[[maybe_unused]] ");
    return result;
}

// One step's lesson functions: the solution's text of each (comments, signature, body), its
// code alone (lesson::code_only) and the stub's text, by name.
struct StepFunctions {
    std::string step, title;  // "02_threshold", "where does the ray first meet bone?"
    std::vector<size_t> builds_on;  // indices of the steps it builds on (lesson::step_parents)
    std::vector<std::string> names;
    std::map<std::string, std::string> solution, code, stub;
};

std::map<std::string, std::string> function_texts(const std::string& source,
                                                  const std::string& path,
                                                  std::vector<std::string>* names = nullptr) {
    std::map<std::string, std::string> texts;
    const std::string masked = lesson::mask_code(source);
    for (const auto& function : lesson::lesson_functions(source, masked, path)) {
        texts[function.name] = lesson::function_text(source, function);
        if (names) names->push_back(function.name);
    }
    return texts;
}

StepFunctions step_functions(const std::string& step, const std::string& solution,
                             const std::string& stubbed, const std::string& path) {
    StepFunctions functions;
    functions.step = step;
    functions.solution = function_texts(solution, path, &functions.names);
    for (const auto& [name, text] : functions.solution) {
        functions.code[name] = lesson::code_only(text);
    }
    functions.stub = function_texts(stubbed, path);
    // The title: what follows "NN_name.cpp: " on the first line, and the comment lines that
    // continue its sentence up to the header's first empty "//" line (a title of two lines
    // was cut in the middle of a sentence).
    size_t end = solution.find('\n');
    const std::string first_line = solution.substr(0, end);
    const size_t colon = first_line.find(".cpp: ");
    if (colon != std::string::npos) {
        std::string title = lesson::trim(first_line.substr(colon + 6));
        while (end != std::string::npos) {
            const size_t next = solution.find('\n', end + 1);
            const std::string line = solution.substr(end + 1, next - end - 1);
            if (line.compare(0, 3, "// ") != 0 || lesson::trim(line.substr(2)).empty()) break;
            title += " " + lesson::trim(line.substr(2));
            end = next;
        }
        functions.title = title;
    }
    return functions;
}

// The step that step `n`'s function `name` is compared with (tools/lesson_markers.h, "Copies
// across steps": the nearest of its Builds-on ancestors defining it, so step 19 takes step
// 12's composite_front_to_back(), not step 17's jittered one), when its code there is the same
// as in step `n` (comments aside: a later step may say "step 10's, unchanged" instead); else
// -1. Step n takes that function unchanged: `make carry` brings the student's version.
int carried_from(const std::vector<StepFunctions>& steps, size_t n, const std::string& name) {
    std::vector<std::vector<size_t>> parents;
    for (const StepFunctions& step : steps) parents.push_back(step.builds_on);
    const int m = lesson::compared_step(parents, n, [&](size_t m) {
        return steps[m].code.count(name) > 0;
    });
    return m >= 0 && steps[size_t(m)].code.at(name) == steps[n].code.at(name) ? m : -1;
}

// .ctlab/carry.txt: "TO_STEP FUNCTION FROM_STEP STUB_HASH" for every lesson function whose
// code equals that of the step it is compared with (carried_from). STUB_HASH is the hash of
// the function's stub as generated in TO_STEP: `make carry` replaces only a function that is
// still that stub, never one the student wrote.
std::string carry_text(const std::vector<StepFunctions>& steps) {
    std::string text =
        "# Lesson functions a step takes unchanged from an earlier step (make_student wrote\n"
        "# this file). `make carry [STEP=NN]` copies your version from FROM_STEP into TO_STEP\n"
        "# while TO_STEP still has the stub whose hash is STUB_HASH: never over your work.\n"
        "# TO_STEP FUNCTION FROM_STEP STUB_HASH\n";
    for (size_t n = 0; n < steps.size(); ++n) {
        for (const std::string& name : steps[n].names) {
            const int before = carried_from(steps, n, name);
            if (before < 0) continue;
            text += steps[n].step + " " + name + " " + steps[before].step + " " +
                    lesson::content_hash(steps[n].stub.at(name)) + "\n";
        }
    }
    return text;
}

// README.md of the student tree: the template with a table of the steps.
std::string student_readme(const fs::path& from, const std::vector<StepFunctions>& steps) {
    std::string table =
        "| step | handout | what it teaches | you write | `make carry` brings |\n"
        "|---|---|---|---|---|\n";
    for (size_t n = 0; n < steps.size(); ++n) {
        std::string write, carried;
        for (const std::string& name : steps[n].names) {
            const int before = carried_from(steps, n, name);
            const bool same = before >= 0;
            std::string& list = same ? carried : write;
            list += std::string(list.empty() ? "" : ", ") + "`" + name + "`" +
                    (same ? " (" + steps[before].step.substr(0, 2) + ")" : "");
        }
        table += "| " + steps[n].step.substr(0, 2) + " | [" + steps[n].step + "](handouts/" +
                 steps[n].step + ".md) | " + steps[n].title + " | " +
                 (write.empty() ? "-" : write) + " | " + (carried.empty() ? "-" : carried) +
                 " |\n";
    }
    std::string text = lesson::read_text((from / readme_template).string());
    const size_t at = text.find(readme_steps);
    if (at == std::string::npos) {
        throw InputError(std::string(readme_template) + ": no " + readme_steps +
                         " line for the table of steps");
    }
    return text.replace(at, std::string(readme_steps).size(), table);
}

// Relative paths of the files to copy (sorted), "steps/..." excluded.
std::vector<std::string> files_to_copy(const fs::path& from) {
    std::vector<std::string> files;
    for (const std::string& entry : copied) {
        const fs::path path = from / entry;
        if (fs::is_regular_file(path)) files.push_back(entry);
        if (!fs::is_directory(path)) continue;
        for (const auto& item : fs::recursive_directory_iterator(path)) {
            if (!item.is_regular_file()) continue;
            const std::string relative = fs::relative(item.path(), from).generic_string();
            if (std::find(not_copied.begin(), not_copied.end(), relative) == not_copied.end()) {
                files.push_back(relative);
            }
        }
    }
    std::sort(files.begin(), files.end());
    return files;
}

// The kit must hold no lesson body of the solution (tools/find_answers.cpp checks a written
// tree; tests/student_test.sh fails on any). Says on stderr where the generated tree would have
// one, and returns how many pieces it found: make_student then writes nothing.
int report_answers(const fs::path& from, const std::map<std::string, std::string>& tree) {
    const std::vector<lesson::Answer> answers = lesson::solution_answers(from);
    std::string where;
    int found = 0;
    for (const auto& [relative, text] : tree) {
        for (const lesson::Leak& leak : lesson::find_answers(text, answers)) {
            if (++found <= shown_answers) {
                where += "\n  " + relative + ":" + std::to_string(leak.line) + ": " +
                         leak.answer->step + " " + leak.answer->function + "()";
            }
        }
    }
    if (found == 0) return 0;
    std::fprintf(stderr,
                 "make_student: error: the kit would hold %d piece(s) of lesson bodies of the "
                 "solution:%s%s\nmake_student: nothing written. A tool, test or handout that "
                 "calls or quotes a lesson function hands out its answer (all of them: "
                 "build/find_answers --solution %s --in DIR)\n",
                 found, where.c_str(), found > shown_answers ? "\n  ..." : "",
                 from.string().c_str());
    return found;
}

// Refuses to replace a folder that was not generated, or generated files changed since.
void check_destination(const fs::path& to, bool force) {
    if (!fs::exists(to)) return;
    if (!fs::is_directory(to)) throw InputError("--to: '" + to.string() + "' is not a folder");
    const fs::path record = to / record_name;
    if (!fs::exists(record)) {
        if (fs::is_empty(to)) return;
        throw InputError("'" + to.string() + "' exists and was not made by make_student (no " +
                         record_name + "): move it away or choose another --to");
    }
    std::ifstream lines(record);
    std::string line, changed;
    int count = 0;
    while (std::getline(lines, line)) {
        if (line.empty() || line[0] == '#') continue;
        const size_t space = line.find("  ");
        if (space == std::string::npos) continue;
        const std::string relative = line.substr(space + 2);
        const fs::path file = to / relative;
        if (!fs::exists(file) || lesson::content_hash(lesson::read_text(file.string())) !=
                                     line.substr(0, space)) {
            changed += "\n  " + (to / relative).generic_string();
            ++count;
        }
    }
    if (count > 0 && !force) {
        throw InputError(std::to_string(count) + " file(s) changed since '" + to.string() +
                         "' was generated:" + changed +
                         "\nkeep them elsewhere, or regenerate anyway with --force (make student "
                         "FORCE=1)");
    }
}

void write_file(const fs::path& path, const std::string& text) {
    fs::create_directories(path.parent_path());
    std::ofstream file(path, std::ios::binary);
    file << text;
    file.close();
    if (!file) throw InputError("cannot write '" + path.string() + "'");
}

int generate(const Settings& settings) {
    const fs::path from = settings.from, to = settings.to;
    if (!fs::is_regular_file(from / "Makefile") || !fs::is_directory(from / "steps")) {
        throw InputError("--from: '" + settings.from + "' is not the lab (no Makefile, steps/)");
    }
    if (fs::exists(from / record_name)) {
        throw InputError("--from: '" + settings.from + "' is itself a student tree");
    }
    const fs::path from_full = fs::weakly_canonical(from), to_full = fs::weakly_canonical(to);
    if (to_full == from_full || from_full.string().rfind(to_full.string() + "/", 0) == 0) {
        throw InputError("--to: '" + settings.to + "' would contain the lab itself");
    }

    // Everything is generated in memory first: nothing is written if a step cannot be stubbed.
    std::map<std::string, std::string> tree;  // relative path -> content
    std::vector<fs::path> step_paths;
    for (const auto& item : fs::directory_iterator(from / "steps")) {
        if (!item.is_regular_file() || !lesson::is_step(item.path())) {
            continue;  // only steps/NN_name.cpp
        }
        step_paths.push_back(item.path());
    }
    std::sort(step_paths.begin(), step_paths.end());
    int stubbed = 0;
    std::vector<StepFunctions> steps;
    std::vector<std::pair<std::string, std::string>> sources;  // stems and solutions
    for (const fs::path& path : step_paths) {
        const std::string relative = "steps/" + path.filename().string();
        const std::string solution = lesson::read_text(path.string());
        const std::string step = path.stem().string();
        tree[relative] = stub_step(solution, relative, step, stubbed);
        tree[pristine_folder + relative] = tree[relative];
        steps.push_back(step_functions(step, solution, tree[relative], relative));
        sources.push_back({step, solution});
    }
    const std::vector<std::vector<size_t>> parents = lesson::step_parents(sources);
    for (size_t n = 0; n < steps.size(); ++n) steps[n].builds_on = parents[n];
    tree[carry_record] = carry_text(steps);
    tree["README.md"] = student_readme(from, steps);
    if (fs::is_regular_file(from / "README.md")) {
        tree["LAB.md"] = lesson::read_text((from / "README.md").string());
    }
    for (const std::string& relative : files_to_copy(from)) {
        tree[relative] = lesson::read_text((from / relative).string());
    }
    // Handouts quote the stubs, not the solution.
    for (auto& [relative, text] : tree) {
        if (relative.rfind("handouts/", 0) != 0 || fs::path(relative).extension() != ".md") {
            continue;
        }
        const auto listings = lesson::find_listings(text, relative);
        text = lesson::refresh_listings(text, listings, [&](const lesson::Listing& listing) {
            const auto found = tree.find(listing.path);
            const std::string source = found != tree.end()
                ? found->second : lesson::read_listed_file(settings.from, listing, relative);
            return lesson::listing_text(source, listing, relative);
        });
    }

    if (report_answers(from, tree) > 0) return exit_answers_found;  // nothing written
    check_destination(to, settings.force);
    if (fs::exists(to / record_name)) fs::remove_all(to);  // only a tree we generated
    std::string record =
        "# Generated by make student (tools/make_student.cpp): the lesson functions in steps/\n"
        "# are stubs to fill in. Regenerating refuses to overwrite a file listed here whose\n"
        "# content no longer has this hash.\n";
    for (const auto& [relative, text] : tree) {
        write_file(to / relative, text);
        const fs::path original = from / relative;
        if (fs::exists(original) && relative.rfind("steps/", 0) != 0) {
            fs::permissions(to / relative, fs::status(original).permissions());
        }
        record += lesson::content_hash(text) + "  " + relative + "\n";
    }
    write_file(to / record_name, record);
    std::printf("make_student: wrote %s/: %d steps, %d lesson functions stubbed, %zu files. "
                "Start with %s/README.md\n", settings.to.c_str(), int(steps.size()), stubbed,
                tree.size(), settings.to.c_str());
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    return kit_tool::run_main("make_student",
                              [&] { return generate(parse_arguments(argc, argv)); });
}
