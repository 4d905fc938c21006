// grade.cpp: the instructor's grader. Compares a student's PNGs with the
// reference images (one pair, one student's folder, or a whole class) and says pass or fail
// with the numbers.
//
//   build/grade STUDENT.png REFERENCE.png [--tol N] [--diff OUT.png]
//   build/grade --submission DIR [--reference DIR] [--tol N] [--report OUT_DIR]
//   build/grade --class DIR [--reference DIR] [--tol N] --report OUT_DIR
//
// Errors are in 8-bit units after quantising both pictures; a pixel fails when one of its
// channels differs by more than --tol. Exit status: 0 all pass, 1 something fails, 2 bad
// input (the checker's own arguments, the reference folder, the output folder).
//
// A submission is not trusted: it is read by folder descriptor, never through a symbolic
// link, every file bounded before it is read (image_read.h); nothing is ever written into it
// or into the reference folder. Reports go to --report OUT_DIR only (output_folder.h).
#include <fcntl.h>
#include <dirent.h>
#include <poll.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <cctype>
#include <csignal>
#include <mutex>
#include <thread>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>
#include "args.h"
#include "tools/compare.h"
#include "error.h"
#include "image.h"
#include "tools/image_read.h"
#include "tools/output_folder.h"
#include "tools/process.h"
#include "tools/run_step.h"
#include "tools/sandbox.h"

using namespace ctlab;
namespace fs = std::filesystem;

namespace {

// "1 student", "0 students", "3 students": a count and its noun, singular for exactly one.
std::string counted(size_t count, const char* one, const char* many) {
    return std::to_string(count) + " " + (count == 1 ? one : many);
}

constexpr double default_tolerance = 2;  // 8-bit units: rounding differences pass
constexpr double max_tolerance = 255;    // 8-bit units: above this every picture passes
constexpr int exit_pass = 0, exit_fail = 1;
const char* const default_reference = "data/reference";
constexpr size_t max_folder_entries = 100000;  // a submission or a class is far smaller
const char* const pictures_folder = "pictures";  // OUT_DIR/pictures/NAME.png, side by side
const char* const tree_checker = "check";          // beside build/grade: grades a student tree
constexpr double default_budget_s = 600;         // wall-clock seconds for one student's tree
constexpr double budget_margin_s = 60;           // build/check's own start and end, past it
const char* const graded_mark = "graded.txt";    // students/NAME/graded.txt: finished

// Only NN_name_top|front|side.png count: variants (..._front_skin030.png), manifests and
// anything else in the reference folder are not expected from the student.
// Part 2's steps (13 on) write one picture, NN_name_camera.png.
const std::regex expected_name("^([0-9]{2}_[a-z0-9_]+)_(top|front|side|camera)\\.png$");
// A variant's picture: a view and a variant's name after it (NN_name_camera_mip.png).
const std::regex variant_name("^[0-9]{2}_[a-z0-9_]+_(top|front|side|camera)_[a-z0-9_]+\\.png$");

const char* const usage_text =
    "usage: grade STUDENT.png REFERENCE.png [--tol N] [--diff OUT.png]\n"
    "       grade --submission DIR [--reference DIR] [--tol N] [--report OUT_DIR]\n"
    "       grade --class DIR [--reference DIR] [--tol N] --report OUT_DIR\n"
    "\n"
    "Compares pictures after rounding both to 8 bits per channel. Errors are in 8-bit\n"
    "units (0..255); a pixel fails when any channel differs by more than the tolerance.\n"
    "\n"
    "  --tol N             tolerance in 8-bit units, a number from 0 to 255 (default: each\n"
    "                      step's tol= in the reference folder's manifest.txt, as make check\n"
    "                      grades it, else 2)\n"
    "  --diff OUT.png      one pair: write a heat map of the differences (black = equal,\n"
    "                      blue = within the tolerance, magenta, yellow, white = largest);\n"
    "                      OUT's folder must exist; an input or a reference is never replaced\n"
    "  --submission DIR    one student's folder: every NN_name_top|front|side|camera.png of\n"
    "                      the reference folder is expected in DIR (names match in any case;\n"
    "                      pictures in one subfolder such as DIR/out/ are found and said so)\n"
    "  --class DIR         a class: one subfolder per student, each a folder of pictures or a\n"
    "                      student tree (has .ctlab-student or steps/). A tree's steps/ are\n"
    "                      built from source and run by build/check --build in a sandbox,\n"
    "                      against this lab's common/ (its own build/ is never used)\n"
    "  --reference DIR     the reference folder (default data/reference)\n"
    "  --report OUT_DIR    where reports go (created if missing; never inside a submission or\n"
    "                      the reference folder): report.md, report.csv and pictures/NAME.png\n"
    "                      (student | reference | heat map) for each picture that fails; for a\n"
    "                      class: class.csv, summary.md and students/NAME/ as above\n"
    "  --jobs N            --class: grade N students at once (default 1)\n"
    "  --budget S          --class: wall-clock seconds for one student tree, its build and\n"
    "                      all its runs (default 600)\n"
    "  --timeout S         --class: seconds one run of a step may take (default 120)\n"
    "  --step NN           --class: build and grade only step NN (again for more steps)\n"
    "  --regrade           --class: grade again the students a stopped run had finished\n"
    "                      (otherwise their reports are kept and they are skipped)\n"
    "  --no-cache          --class: build and run every tree's steps, even a source another\n"
    "                      tree had byte for byte (otherwise its binary is built once per class\n"
    "                      run, in a sandbox that saw only that source, and its runs' outcomes\n"
    "                      kept for the same arguments: tools/class_cache.h)\n"
    "  --no-sandbox        --class: where bubblewrap cannot run, build and run the trees'\n"
    "                      programs anyway, unconfined (otherwise they are not run)\n"
    "  --help              this text\n"
    "\n"
    "Verdicts per picture: pass, fail, damaged (its CRC or checksum is wrong: a changed or\n"
    "cut byte), error (not a readable picture, another size, a symbolic link), missing, extra.\n"
    "A submission is only read: links are never followed, nothing is written into it.\n"
    "\n"
    "One pair prints: max_abs= mean_abs= rmse= psnr_db= over_tol_pct= tol= result=\n"
    "Exit status: 0 all pass, 1 a picture (or a student) fails or is missing, 2 bad input.\n";

struct Settings {
    std::vector<std::string> files;  // STUDENT.png REFERENCE.png
    double tolerance = default_tolerance;
    bool has_tolerance = false;  // --tol given: it holds for every picture
    std::string diff, submission, class_folder, reference = default_reference, report;
    bool has_submission = false, has_class = false, has_reference = false, has_report = false;
    bool help = false;
    int jobs = 1;                           // --class: students graded at once
    double budget_s = default_budget_s;     // --class: wall-clock seconds per student tree
    std::string timeout;                    // --class: build/check's --timeout (per run)
    std::vector<std::string> steps;         // --class: only these steps (--step NN, repeated)
    bool no_sandbox = false, regrade = false, has_class_flag = false;
    bool no_cache = false;                  // --class: no class cache (tools/class_cache.h)
};

Settings parse_arguments(int argc, char** argv) {
    Settings settings;
    for (int a = 1; a < argc; ++a) {
        const std::string arg = argv[a];
        auto take_value = [&]() -> std::string {
            if (a + 1 >= argc) throw InputError(arg + ": expected a value after it");
            return argv[++a];
        };
        if (arg == "--help" || arg == "-h") {
            settings.help = true;
        } else if (arg == "--tol") {
            settings.tolerance = parse_double(arg, take_value(), 0, max_tolerance);
            settings.has_tolerance = true;
        } else if (arg == "--diff") {
            settings.diff = take_value();
            if (settings.diff.empty()) throw InputError("--diff: expected a file name, got ''");
        } else if (arg == "--submission") {
            settings.submission = take_value();
            settings.has_submission = true;
        } else if (arg == "--class") {
            settings.class_folder = take_value();
            settings.has_class = true;
        } else if (arg == "--reference") {
            settings.reference = take_value();
            settings.has_reference = true;
        } else if (arg == "--report") {
            settings.report = take_value();
            settings.has_report = true;
        } else if (arg == "--jobs") {
            settings.jobs = parse_int(arg, take_value(), 1, 256);
            settings.has_class_flag = true;
        } else if (arg == "--budget") {
            settings.budget_s = parse_double(arg, take_value(), 1, 7 * 24 * 3600);
            settings.has_class_flag = true;
        } else if (arg == "--timeout") {
            settings.timeout = std::to_string(parse_double(arg, take_value(), 0.1, 24 * 3600));
            settings.has_class_flag = true;
        } else if (arg == "--step") {
            settings.steps.push_back(take_value());
            settings.has_class_flag = true;
        } else if (arg == "--no-sandbox") {
            settings.no_sandbox = true;
            settings.has_class_flag = true;
        } else if (arg == "--no-cache") {
            settings.no_cache = true;
            settings.has_class_flag = true;
        } else if (arg == "--regrade") {
            settings.regrade = true;
            settings.has_class_flag = true;
        } else if (arg.size() > 1 && arg[0] == '-') {
            throw InputError("unknown flag '" + printable(arg) + "' (see grade --help)");
        } else {
            settings.files.push_back(arg);
        }
    }
    if (settings.help) return settings;
    if (settings.has_class_flag && !settings.has_class) {
        throw InputError("--jobs, --budget, --timeout, --step, --no-sandbox, --no-cache and "
                         "--regrade are for --class DIR");
    }
    if (settings.has_submission && settings.has_class) {
        throw InputError("--submission and --class: one at a time");
    }
    if (settings.has_submission || settings.has_class) {
        const std::string flag = settings.has_class ? "--class" : "--submission";
        const std::string& folder =
            settings.has_class ? settings.class_folder : settings.submission;
        if (folder.empty()) throw InputError(flag + ": expected a folder");
        if (!settings.files.empty()) {
            throw InputError(flag + " compares folders: no picture names expected, got '" +
                             printable(settings.files[0]) + "'");
        }
        if (!settings.diff.empty()) {
            throw InputError("--diff is for one pair; " + flag +
                             " writes its heat maps to --report OUT_DIR");
        }
        if (settings.has_reference && settings.reference.empty()) {
            throw InputError("--reference: expected a folder, got ''");
        }
        if (settings.has_report && settings.report.empty()) {
            throw InputError("--report: expected a folder, got ''");
        }
        if (settings.has_class && !settings.has_report) {
            throw InputError("--class needs --report OUT_DIR: the folder for the class's CSV, "
                             "summary and reports");
        }
        // The same folder (by any name or link) would pass everything against itself.
        struct stat a {}, b {};
        if (stat(folder.c_str(), &a) == 0 && stat(settings.reference.c_str(), &b) == 0 &&
            a.st_dev == b.st_dev && a.st_ino == b.st_ino) {
            throw InputError(flag + " '" + printable(folder) + "' is the reference folder '" +
                             printable(settings.reference) + "': it would pass against itself");
        }
        return settings;
    }
    if (settings.has_reference || settings.has_report) {
        throw InputError("--reference and --report need --submission DIR or --class DIR");
    }
    if (settings.files.size() != 2) {
        throw InputError("expected STUDENT.png REFERENCE.png or --submission DIR, got " +
                         counted(settings.files.size(), "file name", "file names") +
                         " (see --help)");
    }
    return settings;
}

std::string lower(std::string text) {
    std::transform(text.begin(), text.end(), text.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return text;
}

bool has_png_extension(const std::string& name) {
    return name.size() >= 4 && lower(name.substr(name.size() - 4)) == ".png";
}

// --- Where the checker may write ---------------------------------------------------------

fs::path absolute_path(const std::string& path) {
    std::error_code error;
    fs::path result = fs::weakly_canonical(fs::absolute(path), error);
    return error ? fs::absolute(path).lexically_normal() : result;
}

// True when `inner` is `outer` or lies inside it (both absolute and canonical).
bool within(const fs::path& inner, const fs::path& outer) {
    auto i = inner.begin();
    for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
        if (o->empty()) continue;  // a trailing slash
        if (i == inner.end() || *i != *o) return false;
    }
    return true;
}

// The report folder must not be, lie inside or contain a folder the checker reads.
void check_report_place(const std::string& report,
                        const std::vector<std::pair<std::string, std::string>>& read_folders) {
    const fs::path out = absolute_path(report);
    for (const auto& [what, folder] : read_folders) {
        const fs::path in = absolute_path(folder);
        std::string relation;
        if (out == in) {
            relation = "is the " + what;
        } else if (within(out, in)) {
            relation = "is inside the " + what + " '" + printable(folder) + "'";
        } else if (within(in, out)) {
            relation = "holds the " + what + " '" + printable(folder) + "'";
        }
        if (!relation.empty()) {
            throw InputError("--report '" + printable(report) + "' " + relation +
                             ": the checker never writes there; choose a folder of its own, "
                             "e.g. --report reports");
        }
    }
}

// --- Folders read by descriptor, never through a link -------------------------------------

struct Folder {
    std::shared_ptr<int> fd;
    std::string shown;  // for messages
};

Folder open_folder(int parent_fd, const std::string& name, const std::string& shown,
                   bool follow_link) {
    int flags = O_RDONLY | O_DIRECTORY | O_CLOEXEC;
    if (!follow_link) flags |= O_NOFOLLOW;
    const int fd = ::openat(parent_fd, name.c_str(), flags);
    if (fd < 0) {
        const int error = errno;
        struct stat info {};
        const bool exists = ::fstatat(parent_fd, name.c_str(), &info, AT_SYMLINK_NOFOLLOW) == 0;
        if (!exists) throw InputError("'" + printable(shown) + "' does not exist");
        if (S_ISLNK(info.st_mode) && !follow_link) {
            throw InputError("'" + printable(shown) + "' is a symbolic link: not followed");
        }
        if (error == ENOTDIR) throw InputError("'" + printable(shown) + "' is not a folder");
        throw InputError("cannot open '" + printable(shown) + "': " + std::strerror(error));
    }
    return {std::shared_ptr<int>(new int(fd), [](int* p) { ::close(*p); delete p; }), shown};
}

enum class Kind { file, link, folder, other };

struct Entry {
    std::string name;
    Kind kind;
};

std::vector<Entry> list_folder(const Folder& folder) {
    const int fd = ::dup(*folder.fd);
    DIR* listing = fd < 0 ? nullptr : ::fdopendir(fd);
    if (!listing) {
        if (fd >= 0) ::close(fd);
        throw InputError("cannot list '" + printable(folder.shown) + "': " + std::strerror(errno));
    }
    ::rewinddir(listing);
    std::vector<Entry> entries;
    while (const dirent* item = ::readdir(listing)) {
        const std::string name = item->d_name;
        if (name == "." || name == "..") continue;
        if (entries.size() == max_folder_entries) {
            ::closedir(listing);
            throw InputError("'" + printable(folder.shown) + "' holds more than " +
                             std::to_string(max_folder_entries) +
                             " entries: not a folder of pictures");
        }
        struct stat info {};
        Kind kind = Kind::other;
        if (::fstatat(*folder.fd, name.c_str(), &info, AT_SYMLINK_NOFOLLOW) == 0) {
            kind = S_ISREG(info.st_mode) ? Kind::file
                 : S_ISLNK(info.st_mode) ? Kind::link
                 : S_ISDIR(info.st_mode) ? Kind::folder
                                         : Kind::other;
        }
        entries.push_back({name, kind});
    }
    ::closedir(listing);
    std::sort(entries.begin(), entries.end(),
              [](const Entry& a, const Entry& b) { return a.name < b.name; });
    return entries;
}

std::string join(const std::string& folder, const std::string& name) {
    return folder.empty() || folder.back() == '/' ? folder + name : folder + "/" + name;
}

// --- The reference folder -----------------------------------------------------------------

struct References {
    std::string folder;
    std::vector<std::string> names;   // expected pictures, sorted
    std::vector<std::string> steps;   // their steps (NN_name), sorted, each once
    std::map<std::string, Image> images;
    std::map<std::string, double> tolerances;  // picture -> its tolerance (8-bit units)
};

// REFERENCE/manifest.txt's tol=N of each step's default line ("NN_name: ... tol=N"), as
// build/check reads it: step -> tolerance.
std::map<std::string, double> manifest_tolerances(const std::string& folder) {
    std::map<std::string, double> tolerances;
    std::ifstream manifest(join(folder, "manifest.txt"));
    for (std::string line; std::getline(manifest, line);) {
        const size_t colon = line.find(':');
        if (line.empty() || line[0] == '#' || colon == std::string::npos) continue;
        const std::string name = line.substr(0, colon);
        std::istringstream words(line.substr(colon + 1));
        for (std::string word; words >> word;) {
            if (word.rfind("tol=", 0) == 0) {
                tolerances[name] = parse_double("tol", word.substr(4), 0, max_tolerance);
            }
        }
    }
    return tolerances;
}

std::string step_of(const std::string& picture) {
    std::smatch match;
    return std::regex_match(picture, match, expected_name) ? match[1].str() : "";
}

// Reads every expected reference picture once (a class reuses them): an unreadable one is
// bad input.
References load_references(const std::string& folder, const Settings& settings) {
    References references;
    references.folder = folder;
    std::error_code error;
    const fs::file_status status = fs::status(folder, error);
    if (!fs::exists(status)) {
        throw InputError("reference folder '" + printable(folder) + "' does not exist");
    }
    if (!fs::is_directory(status)) {
        throw InputError("reference folder '" + printable(folder) + "' is not a folder");
    }
    for (const fs::directory_entry& entry : fs::directory_iterator(folder, error)) {
        const std::string name = entry.path().filename().string();
        if (std::regex_match(name, expected_name)) references.names.push_back(name);
    }
    if (error) throw InputError("cannot list '" + printable(folder) + "': " + error.message());
    if (references.names.empty()) {
        throw InputError("reference folder '" + printable(folder) +
                         "' has no pictures named NN_name_top|front|side.png");
    }
    std::sort(references.names.begin(), references.names.end());
    std::set<std::string> steps;
    for (const std::string& name : references.names) {
        references.images[name] = read_image(join(folder, name));
        steps.insert(step_of(name));
    }
    references.steps.assign(steps.begin(), steps.end());
    const std::map<std::string, double> manifest = manifest_tolerances(folder);
    for (const std::string& name : references.names) {
        const auto step = manifest.find(step_of(name));
        references.tolerances[name] = settings.has_tolerance || step == manifest.end()
                                          ? settings.tolerance : step->second;
    }
    return references;
}

// --- Grading one folder of pictures --------------------------------------------------------

struct Row {
    std::string file;          // the expected name (or, for an extra, the file's own)
    std::string result;        // pass, fail, damaged, error, missing or extra
    bool has_numbers = false;  // pass and fail rows carry the metrics
    Comparison numbers;
    std::string note;          // why a row is not a pass, or how the file was named
    std::string reason;        // a short class of the note, for the class summary
    std::string found_as;      // the student's file name (may differ in case)
    unsigned long long hash = 0;  // FNV-1a of the student's bytes (pass and fail rows)
    size_t bytes = 0;
};

struct Graded {
    std::vector<Row> rows;
    std::map<std::string, int> counts;  // result -> rows
    std::vector<std::string> notes;     // said once per submission (subfolder, sizes)
    Folder pictures;                    // the folder the pictures were read from
    std::string source = "pictures";
    bool all_pass = false;
    int passed = 0, expected = 0;
};

unsigned long long fnv1a(const std::vector<unsigned char>& bytes) {
    unsigned long long hash = 1469598103934665603ULL;
    for (unsigned char b : bytes) hash = (hash ^ b) * 1099511628211ULL;
    return hash;
}

// Student | reference | heat map, side by side on a dark background.
Image side_by_side(const Image& student, const Image& reference, const Image& heat) {
    constexpr int gap = 4;  // pixels between the pictures
    const int width = student.width + reference.width + heat.width + 2 * gap;
    const int height = std::max({student.height, reference.height, heat.height});
    Image canvas(width, height);
    for (Rgb& pixel : canvas.pixels) pixel = grey(0.15f);
    int left = 0;
    for (const Image* part : {&student, &reference, &heat}) {
        for (int y = 0; y < part->height; ++y) {
            for (int x = 0; x < part->width; ++x) canvas.at(left + x, y) = part->at(x, y);
        }
        left += part->width + gap;
    }
    return canvas;
}

// Which of the expected names the folder holds (matched without regard to case).
std::map<std::string, std::vector<Entry>> match_names(const std::vector<Entry>& entries,
                                                      const References& references) {
    std::map<std::string, std::string> by_lower;
    for (const std::string& name : references.names) by_lower[lower(name)] = name;
    std::map<std::string, std::vector<Entry>> found;
    for (const Entry& entry : entries) {
        const auto it = by_lower.find(lower(entry.name));
        if (it != by_lower.end()) found[it->second].push_back(entry);
    }
    return found;
}

Row grade_picture(const Folder& folder, const Entry& entry, const std::string& name,
                  const References& references, double tolerance,
                  const OutputFolder* pictures) {
    Row row;
    row.file = name;
    row.result = "error";
    row.found_as = entry.name;
    const std::string shown = join(folder.shown, entry.name);
    if (entry.kind == Kind::link) {
        row.note = "'" + printable(shown) + "': is a symbolic link: not followed (a "
                   "submission's pictures must be ordinary files)";
        row.reason = "a symbolic link";
        return row;
    }
    if (entry.kind != Kind::file) {
        row.note = "'" + printable(shown) + "': is " +
                   (entry.kind == Kind::folder ? "a folder" : "not an ordinary file") +
                   ", not a picture";
        row.reason = "not a file";
        return row;
    }
    const Image& reference = references.images.at(name);
    tolerance = references.tolerances.at(name);
    Image student;
    std::vector<unsigned char> bytes;
    try {
        student = read_image_at(*folder.fd, entry.name, shown, &bytes);
        row.numbers = compare_images(student, reference, tolerance, "'" + printable(shown) + "'",
                                     "the reference");
    } catch (const DamagedImage& error) {
        row.result = "damaged";
        row.note = error.what();
        row.reason = "a damaged PNG";
        return row;
    } catch (const InputError& error) {
        row.note = error.what();
        const bool size = student.width > 0 && (student.width != reference.width ||
                                                student.height != reference.height);
        row.reason = size ? "another picture size" : "not a readable picture";
        return row;
    }
    row.hash = fnv1a(bytes);
    row.bytes = bytes.size();
    row.has_numbers = true;
    row.result = row.numbers.pass ? "pass" : "fail";
    row.reason = row.numbers.pass ? "" : "pixels beyond the tolerance";
    if (entry.name != name) row.note = "named " + printable(entry.name);
    if (pictures) {
        if (row.numbers.pass) {
            pictures->remove(name);  // a picture left from an earlier, failing run
        } else {
            pictures->write_png(name, side_by_side(student, reference,
                                                   diff_heat_map(student, reference, tolerance)));
        }
    }
    return row;
}

Graded grade_folder(const Folder& submission, const References& references, double tolerance,
                    const OutputFolder* pictures) {
    Graded graded;
    graded.pictures = submission;
    std::vector<Entry> entries = list_folder(submission);
    std::map<std::string, std::vector<Entry>> found = match_names(entries, references);
    if (found.empty()) {
        // None at the top: the pictures may sit in one subfolder (out/, a zip's own folder).
        size_t best = 0;
        for (const Entry& entry : entries) {
            if (entry.kind != Kind::folder) continue;
            const Folder inner = open_folder(*submission.fd, entry.name,
                                             join(submission.shown, entry.name), false);
            std::vector<Entry> inner_entries = list_folder(inner);
            std::map<std::string, std::vector<Entry>> inner_found =
                match_names(inner_entries, references);
            if (inner_found.size() > best) {
                best = inner_found.size();
                graded.pictures = inner;
                entries = std::move(inner_entries);
                found = std::move(inner_found);
            }
        }
        if (best > 0) {
            graded.notes.push_back("the pictures sit in the subfolder '" +
                                   printable(fs::path(graded.pictures.shown).filename().string()) +
                                   "/' of '" + printable(submission.shown) +
                                   "': graded from there");
            graded.source = "pictures in " +
                            printable(fs::path(graded.pictures.shown).filename().string()) + "/";
        }
    }
    const Folder& folder = graded.pictures;
    std::set<std::string> used;
    for (const std::string& name : references.names) {
        Row row;
        const auto it = found.find(name);
        if (it == found.end()) {
            row = {name, "missing", false, {}, "not in the submission", "missing", "", 0, 0};
        } else if (it->second.size() > 1) {
            std::string names;
            for (const Entry& entry : it->second) {
                names += (names.empty() ? "" : ", ") + printable(entry.name);
                used.insert(entry.name);
            }
            row = {name, "error", false, {}, "several files differ only in case: " + names,
                   "names differing only in case", "", 0, 0};
        } else {
            used.insert(it->second[0].name);
            row = grade_picture(folder, it->second[0], name, references, tolerance, pictures);
        }
        graded.rows.push_back(row);
        ++graded.counts[row.result];
    }
    for (const Entry& entry : entries) {
        if (used.count(entry.name) || !has_png_extension(entry.name)) continue;
        // A variant's picture (NN_name_camera_mip.png) is in the reference folder, but a
        // folder of pictures is graded on each step's default run only: say so, not "not in".
        std::error_code error;
        const bool variant = std::regex_match(lower(entry.name), variant_name) &&
                             fs::is_regular_file(join(references.folder, lower(entry.name)), error);
        graded.rows.push_back({printable(entry.name), "extra", false, {},
                               entry.kind == Kind::link ? "a symbolic link, not in the reference folder"
                               : variant ? "a variant of the reference folder, not graded: a "
                                           "folder of pictures is graded on each step's "
                                           "default run (a student tree on every run)"
                                         : "not in the reference folder",
                               "extra", entry.name, 0, 0});
        ++graded.counts["extra"];
    }
    graded.expected = static_cast<int>(references.names.size());
    graded.passed = graded.counts["pass"];
    graded.all_pass = graded.passed == graded.expected;
    int sized = 0, compared = 0;
    for (const Row& row : graded.rows) {
        if (row.result == "missing" || row.result == "extra") continue;
        ++compared;
        if (row.reason == "another picture size") ++sized;
    }
    if (compared > 1 && sized == compared) {
        graded.notes.push_back("every picture has another size than its reference: rendered "
                               "from another volume or view?");
    }
    return graded;
}

// --- Reports -------------------------------------------------------------------------------

const std::vector<std::string> metrics = {"max_abs", "mean_abs", "rmse", "psnr_db",
                                          "over_tol_pct"};
const std::vector<std::string> columns = {"file",     "result", "max_abs",      "mean_abs",
                                          "rmse",     "psnr_db", "over_tol_pct", "note"};

// A row as the text of its columns (no metrics for missing, extra and error rows).
std::vector<std::string> cells(const Row& row) {
    std::vector<std::string> result = {row.file, row.result};
    std::map<std::string, std::string> values;
    if (row.has_numbers) {
        for (const auto& [name, value] : comparison_fields(row.numbers)) values[name] = value;
    }
    for (const std::string& metric : metrics) result.push_back(values[metric]);
    result.push_back(row.note);
    return result;
}

std::string csv_field(std::string text) {
    // A cell a spreadsheet would run as a formula (a file named "=HYPERLINK(...).png") is
    // quoted as text with a leading apostrophe.
    if (!text.empty() && std::string("=+@\t").find(text[0]) != std::string::npos) {
        text = "'" + text;
    }
    if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
    std::string quoted = "\"";
    for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    return quoted + "\"";
}

std::string csv_line(const std::vector<std::string>& fields) {
    std::string text;
    for (size_t f = 0; f < fields.size(); ++f) text += (f ? "," : "") + csv_field(fields[f]);
    return text + "\n";
}

std::string markdown_field(std::string text) {
    for (size_t at = 0; (at = text.find('|', at)) != std::string::npos; at += 2) {
        text.replace(at, 1, "\\|");
    }
    std::replace(text.begin(), text.end(), '\n', ' ');
    return text;
}

void print_table(const std::vector<Row>& rows) {
    std::vector<size_t> widths(columns.size());
    for (size_t c = 0; c < columns.size(); ++c) widths[c] = columns[c].size();
    for (const Row& row : rows) {
        const std::vector<std::string> text = cells(row);
        for (size_t c = 0; c < text.size(); ++c) widths[c] = std::max(widths[c], text[c].size());
    }
    auto print_line = [&](const std::vector<std::string>& text) {
        std::string line;
        for (size_t c = 0; c < text.size(); ++c) {
            const bool left = c < 2 || c + 1 == text.size();  // names left, numbers right
            const std::string pad(widths[c] - text[c].size(), ' ');
            line += (c ? "  " : "") + (left ? text[c] + pad : pad + text[c]);
        }
        while (!line.empty() && line.back() == ' ') line.pop_back();
        std::printf("%s\n", line.c_str());
    };
    print_line(columns);
    for (const Row& row : rows) print_line(cells(row));
}

std::string tolerance_text(double tolerance) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", tolerance);
    return text;
}

// "2", or "2, and 3 for 08_compositing_order, 10_opacity_correction (manifest.txt's tol=)".
std::string tolerances_text(const References& references, double tolerance) {
    std::map<double, std::set<std::string>> others;
    for (const auto& [name, value] : references.tolerances) {
        if (value != tolerance) others[value].insert(step_of(name));
    }
    std::string text = tolerance_text(tolerance);
    for (const auto& [value, steps] : others) {
        text += ", " + tolerance_text(value) + " for";
        bool first = true;
        for (const std::string& step : steps) {
            text += std::string(first ? " " : ", ") + step;
            first = false;
        }
    }
    return others.empty() ? text : text + " (manifest.txt's tol=)";
}

std::string summary_line(const Graded& graded) {
    std::map<std::string, int> counts = graded.counts;
    return std::to_string(graded.expected) + " expected: " + std::to_string(counts["pass"]) +
           " pass, " + std::to_string(counts["fail"]) + " fail, " +
           std::to_string(counts["damaged"]) + " damaged, " + std::to_string(counts["error"]) +
           " error, " + std::to_string(counts["missing"]) + " missing; " +
           std::to_string(counts["extra"]) + " extra; result=" +
           (graded.all_pass ? "pass" : "fail");
}

std::string markdown_report(const std::string& submission, const References& references,
                            double tolerance, const Graded& graded) {
    std::string text = "# Check report\n\n";
    text += "- submission: `" + printable(submission) + "`\n";
    text += "- reference: `" + printable(references.folder) + "`\n";
    text += "- tolerance: " + tolerances_text(references, tolerance) + " (8-bit units)\n";
    for (const std::string& note : graded.notes) text += "- note: " + note + "\n";
    text += "- " + summary_line(graded) + "\n\n";
    std::string header = "|", rule = "|";
    for (const std::string& column : columns) {
        header += " " + column + " |";
        rule += column == "file" || column == "result" || column == "note" ? "---|" : "--:|";
    }
    text += header + "\n" + rule + "\n";
    for (const Row& row : graded.rows) {
        std::string line = "|";
        for (const std::string& cell : cells(row)) line += " " + markdown_field(cell) + " |";
        text += line + "\n";
    }
    bool any_picture = false;
    for (const Row& row : graded.rows) any_picture |= row.result == "fail";
    if (any_picture) {
        text += "\nEach failing picture is in `" + std::string(pictures_folder) +
                "/` under its own name: the student's, the reference and the heat map of "
                "their differences, side by side.\n";
    }
    return text;
}

std::string csv_report(const std::vector<Row>& rows) {
    std::string text = csv_line(columns);
    for (const Row& row : rows) text += csv_line(cells(row));
    return text;
}

void write_reports(const OutputFolder& out, const std::string& submission,
                   const References& references, double tolerance, const Graded& graded) {
    out.write("report.md", markdown_report(submission, references, tolerance, graded));
    out.write("report.csv", csv_report(graded.rows));
}

// --- One pair ------------------------------------------------------------------------------

// The heat map's target may be new or an ordinary file, never a picture being compared, a
// link, a device or a file in a reference folder; its folder must exist.
void check_diff_target(const std::string& diff, const std::vector<std::string>& inputs) {
    const std::string shown = "--diff '" + printable(diff) + "'";
    struct stat target {};
    if (::lstat(diff.c_str(), &target) == 0) {
        if (S_ISLNK(target.st_mode)) throw InputError(shown + " is a symbolic link: not replaced");
        if (!S_ISREG(target.st_mode)) {
            throw InputError(shown + " is not an ordinary file: not replaced");
        }
        for (const std::string& input : inputs) {
            struct stat info {};
            if (::stat(input.c_str(), &info) == 0 && info.st_dev == target.st_dev &&
                info.st_ino == target.st_ino) {
                throw InputError(shown + " is one of the pictures being compared: not replaced");
            }
        }
    }
    const fs::path folder = absolute_path(diff).parent_path();
    std::error_code error;
    if (!fs::is_directory(folder, error)) {
        throw InputError(shown + ": the folder '" + printable(folder.string()) +
                         "' does not exist (create it first)");
    }
    const bool reference_folder =
        fs::exists(folder / "manifest.txt", error) || fs::exists(folder / "volume.txt", error) ||
        folder == absolute_path(inputs[1]).parent_path() ||
        folder == absolute_path(default_reference);
    if (reference_folder) {
        throw InputError(shown + " is in a reference folder ('" + printable(folder.string()) +
                         "'): write the heat map elsewhere");
    }
}

int check_pair(const Settings& settings) {
    const std::string& student_path = settings.files[0];
    const std::string& reference_path = settings.files[1];
    if (!settings.diff.empty()) check_diff_target(settings.diff, settings.files);
    const Image student = read_image_file(student_path, false);
    const Image reference = read_image(reference_path);
    const Comparison result =
        compare_images(student, reference, settings.tolerance, student_path, reference_path);
    if (!settings.diff.empty()) {
        write_file_replacing(settings.diff,
                             png_bytes(diff_heat_map(student, reference, settings.tolerance)));
    }
    std::printf("%s\n", comparison_line(result).c_str());
    return result.pass ? exit_pass : exit_fail;
}

// --- One student's folder --------------------------------------------------------------------

int check_submission(const Settings& settings) {
    {
        // The folder named on the command line may be a link (the instructor's choice);
        // nothing inside it is followed.
        std::error_code error;
        const fs::file_status status = fs::status(settings.submission, error);
        if (!fs::exists(status)) {
            throw InputError("submission folder '" + printable(settings.submission) +
                             "' does not exist");
        }
        if (!fs::is_directory(status)) {
            throw InputError("submission folder '" + printable(settings.submission) +
                             "' is not a folder");
        }
    }
    if (settings.has_report) {
        check_report_place(settings.report, {{"submission folder", settings.submission},
                                             {"reference folder", settings.reference}});
    }
    const References references = load_references(settings.reference, settings);
    const Folder submission = open_folder(AT_FDCWD, settings.submission, settings.submission, true);
    std::unique_ptr<OutputFolder> out, pictures;
    if (settings.has_report) {
        out = std::make_unique<OutputFolder>(OutputFolder::open(settings.report));
        pictures = std::make_unique<OutputFolder>(out->subfolder(pictures_folder));
    }
    const Graded graded = grade_folder(submission, references, settings.tolerance, pictures.get());
    for (const std::string& note : graded.notes) std::printf("note: %s\n", note.c_str());
    print_table(graded.rows);
    std::printf("%s\n", summary_line(graded).c_str());
    if (out) {
        write_reports(*out, settings.submission, references, settings.tolerance, graded);
        std::printf("report: %s %s\n", out->path("report.md").c_str(),
                    out->path("report.csv").c_str());
        if (graded.counts.count("fail")) {
            std::printf("failing pictures (student | reference | heat map): %s/\n",
                        pictures->path().c_str());
        }
    }
    return graded.all_pass ? exit_pass : exit_fail;
}

// --- A class ---------------------------------------------------------------------------------

struct Student {
    std::string name;        // the subfolder's name (printable)
    std::string result;      // pass, fail or error
    std::string source;      // pictures, pictures in out/, program (build/check), ...
    std::string note;
    std::map<std::string, std::pair<int, int>> steps;  // step -> (passed, total)
    std::vector<Row> rows;   // picture rows (not for a program graded by build/check)
    Folder pictures;
    std::map<std::string, std::string> statuses;  // a tree's step -> build/check's status
    int builds = 0, builds_reused = 0, runs = 0, runs_reused = 0;  // the class cache's share
};

// A file or folder name safe as one path component of the report folder.
std::string safe_component(const std::string& name, std::set<std::string>& taken) {
    std::string safe;
    for (unsigned char c : name) {
        safe += std::isalnum(c) || c == '-' || c == '_' || c == '.' ? static_cast<char>(c) : '_';
    }
    if (safe.empty() || safe[0] == '.') safe = "_" + safe;
    std::string unique = safe;
    for (int n = 2; taken.count(lower(unique)); ++n) unique = safe + "-" + std::to_string(n);
    taken.insert(lower(unique));
    return unique;
}

bool is_student_tree(const std::vector<Entry>& entries) {
    for (const Entry& entry : entries) {
        if (entry.name == ".ctlab-student" && entry.kind == Kind::file) return true;
        if (entry.name == "steps" && entry.kind == Kind::folder) return true;
    }
    return false;
}

// build/check beside this program, when it is built.
std::string grade_program() {
    std::error_code error;
    const fs::path self = fs::read_symlink("/proc/self/exe", error);
    if (error) return "";
    const fs::path grade = self.parent_path() / tree_checker;
    return ::access(grade.c_str(), X_OK) == 0 ? grade.string() : "";
}

// Set by SIGINT, SIGTERM or SIGHUP: no student is started, the running ones are stopped.
volatile std::sig_atomic_t stop_requested = 0;

// Compilers each student's build runs at once: the cores left to each of --jobs students.
int grade_jobs(const Settings& settings) {
    const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
    return std::max(1, static_cast<int>(cores) / settings.jobs);
}

// The interface with build/check (tools/check.cpp), for a student tree:
//   check --build --tree TREE --reference REF --out OUT_DIR --budget S --jobs N
// renders into OUT_DIR (the student's folder in the report, never the tree), writes
// OUT_DIR/report.txt with one line per step, "NN_name: STATUS, pictures P/T, counters C/T"
// ("-" where nothing ran), and exits 0 (all pass), 1 (some fail) or 2 (bad input, its first
// stderr line the reason). Its tolerances are the manifest's per run, not --tol.
void grade_program_tree(const std::string& grade, const std::string& tree,
                        const Settings& settings, const std::string& cache,
                        const OutputFolder& out, Student& student) {
    std::vector<std::string> arguments = {"--build", "--tree", tree, "--reference",
                                          settings.reference, "--out", out.path(),
                                          "--budget", std::to_string(settings.budget_s),
                                          "--jobs", std::to_string(grade_jobs(settings))};
    if (settings.no_sandbox) arguments.push_back("--no-sandbox");
    if (!cache.empty()) arguments.insert(arguments.end(), {"--cache", cache});
    if (!settings.timeout.empty()) arguments.insert(arguments.end(), {"--timeout",
                                                                      settings.timeout});
    for (const std::string& step : settings.steps) arguments.insert(arguments.end(),
                                                                    {"--step", step});
    ProcessOptions options;
    options.limits.wall_s = settings.budget_s + budget_margin_s;
    options.stop = &stop_requested;
    options.limits.output_bytes = 1 << 20;  // bytes of grade's stdout kept
    const ProcessResult result = run_process(grade, arguments, options);
    constexpr size_t max_output = 1 << 20;  // bytes of grade's report read
    const int code = result.exit_status;
    if (result.timed_out || result.interrupted) {
        student.source = "program (build/check)";
        student.result = "error";
        student.note = result.timed_out
            ? "build/check went past the student's budget of " + std::to_string(
                  static_cast<int>(settings.budget_s)) + " s and was stopped"
            : "not finished: the check was interrupted";
        return;
    }
    // grade's report.txt: "NN_name: STATUS, pictures P/T, counters C/T", "-" for none.
    std::string report;
    {
        std::ifstream in(out.path() + "/report.txt", std::ios::binary);
        char chunk[4096];
        while (in && report.size() < max_output) {
            in.read(chunk, sizeof chunk);
            report.append(chunk, static_cast<size_t>(in.gcount()));
        }
    }
    const std::regex line("^([0-9]{2}_[a-z0-9_]+): ([a-z ]+), pictures (-|([0-9]+)/([0-9]+)), "
                          "counters (-|([0-9]+)/([0-9]+))$");
    // "cache: builds reused A/B, runs reused C/D": what the class cache saved this tree.
    const std::regex cache_line("^cache: builds reused ([0-9]+)/([0-9]+), runs reused "
                                "([0-9]+)/([0-9]+)$");
    size_t start = 0;
    std::string step, reason;
    while (start < report.size()) {
        size_t end = report.find('\n', start);
        if (end == std::string::npos) end = report.size();
        const std::string one = report.substr(start, end - start);
        std::smatch match;
        if (std::regex_match(one, match, line)) {
            auto number = [&](int group) {
                return match[group].matched ? std::stoi(match[group]) : 0;
            };
            // Its pictures, its counters and its verdict: a step whose pictures all pass but
            // that still calls a stub (not started) does not pass, nor one where nothing ran.
            const bool passing = match[2] == "passing";
            const int passed = number(4) + number(7) + passing;
            const int total = number(5) + number(8) + 1;
            student.steps[match[1]] = {passed, total};
            student.statuses[match[1]] = match[2];
            step = match[1];
        } else if (std::regex_match(one, match, cache_line)) {
            student.builds_reused = std::stoi(match[1]);
            student.builds = std::stoi(match[2]);
            student.runs_reused = std::stoi(match[3]);
            student.runs = std::stoi(match[4]);
        } else if (reason.empty() && one.rfind("  ", 0) == 0 && one.rfind("    ", 0) != 0) {
            reason = step + ": " + one.substr(2);  // the first problem: one line of reason
        }
        start = end + 1;
    }
    student.source = "program (build/check)";
    if (code == 0 || code == 1) {
        student.result = code == 0 ? "pass" : "fail";
        student.note = reason;
    } else {
        student.result = "error";
        student.note = "build/check stopped with status " + std::to_string(code) +
                       " (its report: " + out.path() + ")";
    }
}

// students/NAME/graded.txt: a student tree whose programs were graded, written last, so a
// stopped class run keeps it (what a rerun reads back instead of grading the tree again).
void write_graded(const OutputFolder& out, const Student& student) {
    if (student.source.rfind("program", 0) != 0) return;  // pictures: quick to grade again
    std::string text = "result: " + student.result + "\nsource: " + student.source +
                       "\nnote: " + student.note + "\n";
    for (const auto& [step, score] : student.steps) {
        const auto status = student.statuses.find(step);
        text += "step: " + step + " " + std::to_string(score.first) + " " +
                std::to_string(score.second) +
                (status == student.statuses.end() ? "" : " " + status->second) + "\n";
    }
    out.write(graded_mark, text);
}

bool read_graded(const OutputFolder& out, Student& student) {
    std::string text;
    try {
        const std::vector<unsigned char> bytes =
            read_file_at(out.fd(), graded_mark, out.path(graded_mark), 1 << 20);
        text.assign(bytes.begin(), bytes.end());
    } catch (const InputError&) {
        return false;
    }
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
        const size_t colon = line.find(": ");
        if (colon == std::string::npos) continue;
        const std::string key = line.substr(0, colon), value = line.substr(colon + 2);
        if (key == "result") student.result = value;
        if (key == "source") student.source = value;
        if (key == "note") student.note = value;
        if (key == "step") {
            std::istringstream words(value);
            std::string step;
            int passed = 0, total = 0;
            if (words >> step >> passed >> total) student.steps[step] = {passed, total};
            std::string status;
            if (std::getline(words >> std::ws, status) && !status.empty()) {
                student.statuses[step] = status;
            }
        }
    }
    return student.result == "pass" || student.result == "fail";
}

std::string score_text(int passed, int total) {
    char text[32];
    std::snprintf(text, sizeof text, "%.2f", total > 0 ? static_cast<double>(passed) / total : 0.0);
    return text;
}

void grade_student(const Folder& class_folder, const Entry& entry, const References& references,
                   const Settings& settings, const OutputFolder& out, const std::string& grade,
                   const std::string& cache, Student& student) {
    const std::string shown = join(class_folder.shown, entry.name);
    if (entry.kind != Kind::folder) {
        student.result = "error";
        student.note = entry.kind == Kind::link
            ? "'" + printable(shown) + "' is a symbolic link: not followed"
            : "'" + printable(shown) + "' is not a folder";
        return;
    }
    const Folder folder = open_folder(*class_folder.fd, entry.name, shown, false);
    Folder pictures = folder;
    if (is_student_tree(list_folder(folder))) {
        if (!grade.empty()) {
            grade_program_tree(grade, shown, settings, cache, out, student);
            return;
        }
        try {
            pictures = open_folder(*folder.fd, "out", join(shown, "out"), false);
        } catch (const InputError& error) {
            student.result = "error";
            student.source = "student tree";
            student.note = std::string(error.what()) + " (build/check is not built, so the "
                           "tree's out/ pictures are graded)";
            return;
        }
        student.source = "tree's out/ pictures (build/check not built: programs not run)";
    }
    const OutputFolder pictures_out = out.subfolder(pictures_folder);
    const Graded graded = grade_folder(pictures, references, settings.tolerance, &pictures_out);
    write_reports(out, shown, references, settings.tolerance, graded);
    if (student.source.empty()) student.source = graded.source;
    student.result = graded.all_pass ? "pass" : "fail";
    student.rows = graded.rows;
    student.pictures = graded.pictures;
    for (const std::string& note : graded.notes) {
        student.note += (student.note.empty() ? "" : "; ") + note;
    }
    for (const Row& row : graded.rows) {
        const std::string step = step_of(row.file);
        if (step.empty() || row.result == "extra") continue;
        auto& [passed, total] = student.steps[step];
        passed += row.result == "pass";
        ++total;
    }
}

// Byte-identical step sources in several student trees, a plagiarism hint: one line per
// group, "- NN_name: A, B, C hand in byte-identical steps/NN_name.cpp (...)". The lab's own
// source (the solution, which no student has) and steps not started (the kit's stubs, alike in
// every tree) are left out. Read as the trees' pictures are: by descriptor, no link followed.
std::string identical_programs(const Folder& class_folder, const std::vector<const Entry*>& entries,
                               const std::vector<Student>& students, const fs::path& lab_build) {
    constexpr long long max_source_bytes = 4 << 20;  // build/check builds no larger source
    // (step, size, hash) -> students; then each group split by its exact bytes.
    std::map<std::tuple<std::string, size_t, unsigned long long>, std::vector<size_t>> same;
    auto source_of = [&](size_t n, const std::string& step) {
        const Folder tree = open_folder(*class_folder.fd, entries[n]->name,
                                        join(class_folder.shown, entries[n]->name), false);
        const Folder steps = open_folder(*tree.fd, "steps", join(tree.shown, "steps"), false);
        return read_file_at(*steps.fd, step + ".cpp", join(steps.shown, step + ".cpp"),
                            max_source_bytes);
    };
    std::map<std::string, std::vector<unsigned char>> lab_sources;
    for (size_t n = 0; n < students.size(); ++n) {
        if (students[n].source.rfind("program", 0) != 0) continue;  // a folder of pictures
        for (const auto& [step, status] : students[n].statuses) {
            if (status == "not started") continue;
            if (!lab_sources.count(step)) {
                std::ifstream in(lab_build.parent_path() / "steps" / (step + ".cpp"),
                                 std::ios::binary);
                lab_sources[step].assign(std::istreambuf_iterator<char>(in),
                                         std::istreambuf_iterator<char>());
            }
            try {
                const std::vector<unsigned char> bytes = source_of(n, step);
                if (bytes == lab_sources[step]) continue;
                same[{step, bytes.size(), fnv1a(bytes)}].push_back(n);
            } catch (const InputError&) {
                // gone or changed since it was graded: no claim
            }
        }
    }
    std::string lines;
    for (const auto& [key, group] : same) {
        if (group.size() < 2) continue;
        const std::string& step = std::get<0>(key);
        std::map<std::vector<unsigned char>, std::vector<size_t>> exact;
        for (size_t n : group) {
            try {
                exact[source_of(n, step)].push_back(n);
            } catch (const InputError&) {
            }
        }
        for (const auto& [bytes, members] : exact) {
            if (members.size() < 2) continue;
            std::string names;
            for (size_t n : members) names += (names.empty() ? "" : ", ") + students[n].name;
            lines += "- " + step + ": " + names + " hand in byte-identical steps/" + step +
                     ".cpp (" + students[members[0]].statuses.at(step) + ")\n";
        }
    }
    return lines;
}

int check_class(const Settings& settings) {
    {
        std::error_code error;
        const fs::file_status status = fs::status(settings.class_folder, error);
        if (!fs::exists(status)) {
            throw InputError("class folder '" + printable(settings.class_folder) +
                             "' does not exist");
        }
        if (!fs::is_directory(status)) {
            throw InputError("class folder '" + printable(settings.class_folder) +
                             "' is not a folder");
        }
    }
    check_report_place(settings.report, {{"class folder", settings.class_folder},
                                         {"reference folder", settings.reference}});
    const References references = load_references(settings.reference, settings);
    const Folder class_folder =
        open_folder(AT_FDCWD, settings.class_folder, settings.class_folder, true);
    const OutputFolder out = OutputFolder::open(settings.report);
    const OutputFolder students_out = out.subfolder("students");

    // Student trees' programs are built and run only in the sandbox (build/check --build),
    // unless the instructor says otherwise.
    std::string grade = grade_program();
    if (!grade.empty() && !sandbox_problem().empty() && !settings.no_sandbox) {
        std::printf("grade: no sandbox (%s): student trees' programs are not built or run, "
                    "their out/ pictures are graded (--no-sandbox runs them unconfined)\n",
                    sandbox_problem().c_str());
        grade.clear();
    }
    // The class cache: a step source two trees share byte for byte is built once, and its
    // runs run once (tools/class_cache.h); only with the sandbox. Removed at the end.
    std::unique_ptr<TempFolder> cache;
    if (!grade.empty() && !settings.no_cache && !settings.no_sandbox) {
        cache = std::make_unique<TempFolder>("class_cache");
    }
    // One slot per student, in the class folder's order; a stopped run's finished students
    // (students/NAME/graded.txt) are kept unless --regrade.
    struct Slot {
        Entry entry;
        std::unique_ptr<OutputFolder> out;
        bool kept = false;
    };
    std::vector<Slot> slots;
    std::vector<Student> students;
    std::set<std::string> taken;
    for (const Entry& entry : list_folder(class_folder)) {
        // A class list or a zip is no student, nor is a hidden folder (.git).
        if (entry.kind == Kind::file || entry.name[0] == '.') continue;
        Student student;
        student.name = printable(entry.name);
        Slot slot{entry, std::make_unique<OutputFolder>(
                             students_out.subfolder(safe_component(entry.name, taken)))};
        if (!settings.regrade) slot.kept = read_graded(*slot.out, student);
        students.push_back(std::move(student));
        slots.push_back(std::move(slot));
    }
    for (int signal : {SIGINT, SIGTERM, SIGHUP}) {
        std::signal(signal, [](int) { stop_requested = 1; });
    }
    std::mutex printing;
    std::atomic<size_t> next{0};
    int kept = 0;
    for (const Slot& slot : slots) kept += slot.kept;
    auto worker = [&] {
        for (size_t n; (n = next++) < slots.size() && !stop_requested;) {
            Slot& slot = slots[n];
            Student& student = students[n];
            if (!slot.kept) {
                try {
                    grade_student(class_folder, slot.entry, references, settings, *slot.out,
                                  grade, cache ? cache->path() : "", student);
                } catch (const InputError& error) {
                    student.result = "error";
                    student.note = error.what();
                }
                if (stop_requested) {
                    student.result = "error";
                    student.note = "not finished: the check was interrupted";
                    continue;
                }
                if (student.result == "error") {
                    slot.out->write("report.md", "# Check report\n\n- student: `" +
                                                     student.name + "`\n- result: error\n- " +
                                                     student.note + "\n");
                }
                write_graded(*slot.out, student);
            }
            const std::lock_guard<std::mutex> lock(printing);
            std::printf("%-24s %-5s %s%s%s%s\n", student.name.c_str(), student.result.c_str(),
                        student.source.c_str(), student.note.empty() ? "" : ": ",
                        student.note.c_str(), slot.kept ? " (graded before: kept)" : "");
            std::fflush(stdout);
        }
    };
    std::vector<std::thread> workers;
    for (int w = 0; w < settings.jobs; ++w) workers.emplace_back(worker);
    for (std::thread& thread : workers) thread.join();
    if (stop_requested) {
        size_t finished = 0;
        for (const Student& student : students) {
            finished += student.note != "not finished: the check was interrupted" &&
                        !student.result.empty();
        }
        std::printf("grade: interrupted; %zu of %s graded, their reports kept: run the same "
                    "command again to grade the rest\n", finished,
                    counted(students.size(), "student", "students").c_str());
        return exit_fail;
    }
    if (kept > 0) {
        std::printf("grade: %s graded by an earlier run %s kept (--regrade grades %s "
                    "again)\n", counted(size_t(kept), "student", "students").c_str(),
                    kept == 1 ? "was" : "were", kept == 1 ? "it" : "them");
    }
    if (students.empty()) {
        throw InputError("class folder '" + printable(settings.class_folder) +
                         "' has no student folders (one subfolder per student)");
    }

    // Steps: the reference's, and any build/check reported.
    std::set<std::string> step_set(references.steps.begin(), references.steps.end());
    for (const Student& student : students) {
        for (const auto& [step, score] : student.steps) step_set.insert(step);
    }
    const std::vector<std::string> steps(step_set.begin(), step_set.end());

    // class.csv: one row per student.
    std::vector<std::string> header = {"student", "result", "score_pct", "source"};
    header.insert(header.end(), steps.begin(), steps.end());
    header.push_back("note");
    std::string csv = csv_line(header);
    int passing = 0;
    for (const Student& student : students) {
        int passed = 0, total = 0;
        for (const auto& [step, score] : student.steps) {
            passed += score.first;
            total += score.second;
        }
        char pct[32];
        std::snprintf(pct, sizeof pct, "%.1f", total > 0 ? 100.0 * passed / total : 0.0);
        std::vector<std::string> fields = {student.name, student.result, pct, student.source};
        for (const std::string& step : steps) {
            const auto it = student.steps.find(step);
            fields.push_back(it == student.steps.end()
                                 ? ""
                                 : score_text(it->second.first, it->second.second));
        }
        fields.push_back(student.note);
        csv += csv_line(fields);
        passing += student.result == "pass";
    }
    out.write("class.csv", csv);

    // summary.md: the class at a glance, the commonest failures, identical wrong pictures.
    std::string md = "# Class summary\n\n";
    md += "- class: `" + printable(settings.class_folder) + "`\n";
    md += "- reference: `" + printable(settings.reference) + "`\n";
    md += "- tolerance: " + tolerances_text(references, settings.tolerance) + " (8-bit units)\n";
    md += "- students: " + std::to_string(students.size()) + ", all steps pass: " +
          std::to_string(passing) + "\n";
    int builds = 0, builds_reused = 0, runs = 0, runs_reused = 0;
    for (const Student& student : students) {
        builds += student.builds, builds_reused += student.builds_reused;
        runs += student.runs, runs_reused += student.runs_reused;
    }
    const std::string cache_text = std::to_string(builds_reused) + " of " +
        counted(size_t(builds), "step build", "step builds") + " and " +
        std::to_string(runs_reused) + " of " + counted(size_t(runs), "run", "runs") +
        " taken from another tree's byte-identical source";
    if (cache) md += "- class cache: " + cache_text + " (tools/class_cache.h)\n";
    md += "- per student: `students/NAME/report.md`, failing pictures side by side (student | "
          "reference | heat map) in `students/NAME/pictures/`; for a student tree whose "
          "programs were run (build/check), `students/NAME/report.txt` and "
          "`students/NAME/side_by_side/`; one row each in `class.csv`\n\n";
    md += "## Steps\n\n| step | students passing it | students graded |\n|---|--:|--:|\n";
    for (const std::string& step : steps) {
        int pass = 0, graded = 0;
        for (const Student& student : students) {
            const auto it = student.steps.find(step);
            if (it == student.steps.end()) continue;
            ++graded;
            pass += it->second.first == it->second.second;
        }
        md += "| " + step + " | " + std::to_string(pass) + " | " + std::to_string(graded) + " |\n";
    }
    std::map<std::pair<std::string, std::string>, std::vector<std::string>> failures;
    for (const Student& student : students) {
        for (const Row& row : student.rows) {
            if (row.result == "pass" || row.result == "extra") continue;
            const std::string verdict =
                row.reason.empty() || row.reason == row.result ? row.result
                                                               : row.result + ": " + row.reason;
            failures[{row.file, verdict}].push_back(student.name);
        }
        if (student.rows.empty() && student.result == "error") {
            failures[{"(whole submission)", "error"}].push_back(student.name);
        }
        if (student.rows.empty() && student.result == "fail") {  // a tree graded by build/check
            for (const auto& [step, counts] : student.steps) {
                if (counts.first == counts.second) continue;
                failures[{step + " (the program)", "fail: see the student's report.txt"}]
                    .push_back(student.name);
            }
        }
    }
    std::vector<std::pair<std::pair<std::string, std::string>, std::vector<std::string>>> sorted(
        failures.begin(), failures.end());
    std::stable_sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) {
        return a.second.size() > b.second.size();
    });
    md += "\n## Commonest failures\n\n";
    if (sorted.empty()) md += "None: every graded picture and program passes.\n";
    constexpr size_t shown_failures = 15;
    if (!sorted.empty()) md += "| picture | verdict | students | who |\n|---|---|--:|---|\n";
    for (size_t n = 0; n < sorted.size() && n < shown_failures; ++n) {
        std::string who;
        for (const std::string& name : sorted[n].second) who += (who.empty() ? "" : ", ") + name;
        md += "| " + sorted[n].first.first + " | " + markdown_field(sorted[n].first.second) +
              " | " + std::to_string(sorted[n].second.size()) + " | " + markdown_field(who) +
              " |\n";
    }
    if (sorted.size() > shown_failures) {
        md += "\n(" + counted(sorted.size() - shown_failures, "rarer failure", "rarer failures") +
              ": see each student's report.)\n";
    }
    // Byte-identical failing pictures from different students: grouped by size and hash,
    // then compared byte for byte.
    std::map<std::tuple<std::string, size_t, unsigned long long>,
             std::vector<std::pair<const Student*, const Row*>>> same;
    for (const Student& student : students) {
        for (const Row& row : student.rows) {
            if (row.result == "fail") same[{row.file, row.bytes, row.hash}].push_back({&student, &row});
        }
    }
    std::string hints;
    for (const auto& [key, group] : same) {
        if (group.size() < 2) continue;
        std::vector<unsigned char> first;
        std::string names;
        bool identical = true;
        try {
            for (const auto& [student, row] : group) {
                const std::vector<unsigned char> bytes = read_file_at(
                    *student->pictures.fd, row->found_as,
                    join(student->pictures.shown, row->found_as), max_picture_file_bytes);
                if (first.empty()) {
                    first = bytes;
                } else if (bytes != first) {
                    identical = false;
                }
                names += (names.empty() ? "" : ", ") + student->name;
            }
        } catch (const InputError&) {
            identical = false;  // changed since it was graded: no claim
        }
        if (identical) {
            hints += "- " + std::get<0>(key) + ": " + names +
                     " handed in byte-identical failing pictures\n";
        }
    }
    md += "\n## Identical wrong pictures\n\n";
    md += hints.empty() ? "None: no two students handed in the same failing picture.\n"
                        : "Two renders of the same mistake rarely match to the byte: worth a "
                          "look.\n\n" + hints;
    std::vector<const Entry*> entries;
    for (const Slot& slot : slots) entries.push_back(&slot.entry);
    const std::string same_programs =
        identical_programs(class_folder, entries, students, fs::path(grade).parent_path());
    md += "\n## Identical programs\n\n";
    md += same_programs.empty()
              ? "None: no two student trees hold the same step source.\n"
              : "Two students rarely write a step byte for byte alike: worth a look (the lab's "
                "own source and steps not started, the kit's stubs, are left out).\n\n" +
                    same_programs;
    out.write("summary.md", md);

    const int not_passing = static_cast<int>(students.size()) - passing;
    std::printf("%s: %d %s, %d %s not\n",
                counted(students.size(), "student", "students").c_str(), passing,
                passing == 1 ? "passes" : "pass", not_passing, not_passing == 1 ? "does" : "do");
    if (!hints.empty()) std::printf("hint: byte-identical failing pictures, see summary.md\n");
    if (!same_programs.empty()) {
        std::printf("hint: byte-identical step sources in several trees, see summary.md\n");
    }
    if (cache) std::printf("class cache: %s\n", cache_text.c_str());
    std::printf("report: %s %s %s/\n", out.path("class.csv").c_str(),
                out.path("summary.md").c_str(), students_out.path().c_str());
    return passing == static_cast<int>(students.size()) ? exit_pass : exit_fail;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        const Settings settings = parse_arguments(argc, argv);
        if (settings.help) {
            std::printf("%s", usage_text);
            return exit_pass;
        }
        if (settings.has_class) return check_class(settings);
        return settings.has_submission ? check_submission(settings) : check_pair(settings);
    } catch (const std::exception& error) {
        // InputError, or a picture too large for memory: either way the input is at fault.
        std::fprintf(stderr, "grade: error: %s\n", printable(error.what()).c_str());
        return exit_bad_input;
    }
}
