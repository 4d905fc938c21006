// make_student.cpp: generates the student skeleton (`make student`): a copy of the lab that
// builds with the same Makefile, in which the body of every lesson function is a stub.
//
//   build/make_student [--from DIR] [--to DIR] [--force]     (defaults: . and student)
//
// Copies Makefile, README.md, .gitignore, common/, tools/, tests/, data/ (not data/CThead) and
// handouts/. Each steps/NN_name.cpp is copied with the body of every function defined in a
// lesson region (tools/lesson_markers.h) replaced by a stub that compiles and runs:
//     {
//         not_done("NN_name", "first_hit", volume, view, x, y, threshold, work, trace);
//         return {};
//     }
// Comments, signatures, structs and constants stay; nothing outside the regions changes.
// The handouts' listings are refreshed from the stubbed steps, so they quote what the student
// has. DIR/.ctlab-student lists every generated file with its hash: regenerating refuses to
// overwrite a file changed since (a student's work) unless --force is given.
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
#include "tools/lesson_markers.h"

using ctlab::InputError;
namespace fs = std::filesystem;

namespace {

const char* const record_name = ".ctlab-student";  // marks a generated tree, lists its files
// What a student tree holds besides steps/: enough to build, test and read the lab.
const std::vector<std::string> copied = {"Makefile", "README.md", ".gitignore", "common",
                                         "tools",    "tests",     "data",       "handouts"};
// data/CThead is not ours to hand out; tests/grade_mistakes.txt quotes solution lines.
const std::vector<std::string> not_copied = {"data/CThead", "tests/grade_mistakes.txt"};
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
    for (int a = 1; a < argc; ++a) {
        const std::string arg = argv[a];
        auto value = [&]() -> std::string {
            if (a + 1 >= argc || std::string(argv[a + 1]).empty()) {
                throw InputError(arg + ": expected a folder after it");
            }
            return argv[++a];
        };
        if (arg == "--from") {
            settings.from = value();
        } else if (arg == "--to") {
            settings.to = value();
        } else if (arg == "--force") {
            settings.force = true;
        } else if (arg == "--help" || arg == "-h") {
            std::printf("%s", usage_text);
            std::exit(0);
        } else {
            throw InputError("unknown argument '" + arg + "' (see make_student --help)");
        }
    }
    return settings;
}

// 64-bit FNV-1a: enough to notice that a file was edited.
std::string content_hash(const std::string& text) {
    uint64_t hash = 14695981039346656037ull;
    for (unsigned char c : text) hash = (hash ^ c) * 1099511628211ull;
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(hash));
    return hex;
}

// "    not_done("02_threshold", "first_hit", volume, view, ...);", wrapped before stub_width.
std::string not_done_call(const std::string& step, const lesson::Function& function) {
    std::vector<std::string> arguments = {"\"" + step + "\"", "\"" + function.name + "\""};
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
// (their callers are stubs too) get [[maybe_unused]], so that the build stays quiet.
std::string stub_step(const std::string& source, const std::string& path,
                      const std::string& step, int& stubbed) {
    std::string result = source;
    const std::vector<lesson::Region> regions = lesson::find_regions(source, path);
    const std::string masked = lesson::mask_code(source);
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
                           stub_body(step, *function, where));
            ++stubbed;
        }
    }
    // Which stubbed functions are now never named outside their own definition?
    const std::string stubbed_masked = lesson::mask_code(result);
    std::vector<size_t> unused_at;
    for (const lesson::Region& region : lesson::find_regions(result, path)) {
        for (const auto& function : lesson::find_functions(result, stubbed_masked, region, path)) {
            if (!function.is_static || function.is_template) continue;
            int uses = 0;
            for (const std::string& word : lesson::tokens(stubbed_masked)) {
                uses += word == function.name;
            }
            if (uses == 1) unused_at.push_back(function.header);
        }
    }
    std::sort(unused_at.rbegin(), unused_at.rend());
    for (size_t at : unused_at) result.insert(at, "[[maybe_unused]] ");
    return result;
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
        if (!fs::exists(file) || content_hash(lesson::read_text(file.string())) !=
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
    int steps = 0, stubbed = 0;
    for (const auto& item : fs::directory_iterator(from / "steps")) {
        const std::string name = item.path().filename().string();
        const auto digit = [](char c) { return std::isdigit(static_cast<unsigned char>(c)); };
        if (!item.is_regular_file() || name.size() < 7 || !digit(name[0]) || !digit(name[1]) ||
            name[2] != '_' || item.path().extension() != ".cpp") {
            continue;  // only steps/NN_name.cpp
        }
        const std::string relative = "steps/" + name;
        tree[relative] = stub_step(lesson::read_text(item.path().string()), relative,
                                   item.path().stem().string(), stubbed);
        ++steps;
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

    check_destination(to, settings.force);
    if (fs::exists(to / record_name)) fs::remove_all(to);  // only a tree we generated
    std::string record =
        "# Generated by make student (tools/make_student.cpp): the lesson functions in steps/\n"
        "# are stubs to fill in. Regenerating refuses to overwrite a file listed here whose\n"
        "# content no longer has this hash.\n";
    for (const auto& [relative, text] : tree) {
        write_file(to / relative, text);
        const fs::path original = from / relative;
        if (relative.rfind("steps/", 0) != 0) {
            fs::permissions(to / relative, fs::status(original).permissions());
        }
        record += content_hash(text) + "  " + relative + "\n";
    }
    write_file(to / record_name, record);
    std::printf("make_student: wrote %s/: %d steps, %d lesson functions stubbed, %zu files. "
                "Build it with: make -C %s\n", settings.to.c_str(), steps, stubbed, tree.size(),
                settings.to.c_str());
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return generate(parse_arguments(argc, argv));
    } catch (const std::exception& error) {  // InputError, or a filesystem error
        std::fprintf(stderr, "make_student: error: %s\n", error.what());
        return ctlab::exit_bad_input;
    }
}
