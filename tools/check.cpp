// check.cpp: checks a tree's PROGRAMS, as `make check` runs it: every step, with every run the
// reference manifest lists (its default run and its variants), on the reference volume, and
// every picture and work counter compared with the reference run's. A student sees the verdict
// the instructor will see.
//
//   build/check [--tree DIR] [--bin DIR] [--reference DIR] [--out DIR] [--step NN]...
//               [--run NAME]... [--view top|front|side] [--args "FLAGS"] [--volume PATH]
//               [--timeout S]
//
// For each run (manifest line `NAME: ARGUMENTS [tol=N] [counters=LIST]`) the step's binary is
// run as a process in the tree:  BIN/NN_name --volume V --no-window --out OUT/NAME ARGS
// (V: the phantom, or the volume REFERENCE/volume.txt names)
// into a folder emptied first (an old picture never passes). Then, for each view:
//   - the picture against REFERENCE/NN_name_<view>[_VARIANT].png, within the run's tolerance
//     (8-bit units, tools/compare.h);
//   - the summary line's work counters against REFERENCE/counters.txt (written by make
//     reference): each must be equal, since the lab prescribes the work as well as the result.
// Per step it prints one row of a progress table (not built, not started, crashed, failing,
// passing) and, for a step that is not passing, the first things to look at: the TODO line of
// a stub, the signal of a crash and how to find its line, the worst pixel ready for
// --debug-pixel, a side-by-side picture (student | reference | heat map), a picture that
// matches another view's reference, the counter that differs; and, for the step's first
// failing run only, its probe rays and the first ray whose work differs, traced (each trace
// renders the picture again, the probes in the same run as the work map when both are
// traced; a later failing run gets its pictures' and counters' verdicts, and a step not
// started, its TODO lines).
//
// Exit status: 0 every graded step passes, 1 some step does not, 2 bad input.
#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include "args.h"
#include "ray_plot.h"
#include "tools/class_cache.h"
#include "tools/compare.h"
#include "error.h"
#include "image.h"
#include "tools/process.h"
#include "tools/sandbox.h"
#include "tools/run_step.h"

using namespace ctlab;
namespace fs = std::filesystem;

namespace {

constexpr double default_tolerance = 2;    // 8-bit units: rounding differences pass
constexpr double max_tolerance = 255;      // 8-bit units
constexpr double default_timeout_s = 120;  // per run: a step on the phantom takes < 2 s
constexpr double default_budget_s = 600;   // per student tree with --build: build and runs
constexpr size_t max_output_bytes = 1 << 20;  // of a run's stdout or stderr that is read
constexpr int max_details = 4;             // lines of "look at" printed per step
constexpr int gap = 4;                     // pixels between the side-by-side panels
constexpr int exit_pass = 0, exit_fail = 1;
const std::vector<std::string> views = {"top", "front", "side"};
// The pictures a run may write: part 1's views, or part 2's one camera picture (steps 13 on).
const std::vector<std::string> pictures = {"top", "front", "side", "camera"};
// The work counters of the summary line that a run must reproduce (common/render.h's Work).
const std::vector<std::string> work_counters = {"samples", "skipped", "leapt",
                                                "gradients", "terminated", "hits"};

const char* const usage_text =
    "usage: check [--tree DIR] [--bin DIR] [--reference DIR] [--out DIR] [--step NN]...\n"
    "             [--run NAME]... [--view top|front|side] [--args \"FLAGS\"] [--volume PATH]\n"
    "             [--timeout S]\n"
    "\n"
    "Runs every step of the tree with every run of REFERENCE/manifest.txt (on the phantom) and\n"
    "compares each picture and the summary lines' work counters with the reference run's.\n"
    "\n"
    "  --tree DIR        the lab or a student tree: its steps/ say which steps exist, and the\n"
    "                    steps run inside it (default .)\n"
    "  --bin DIR         where the step binaries are (default TREE/build)\n"
    "  --reference DIR   pictures, manifest.txt and counters.txt (default TREE/data/reference)\n"
    "  --out DIR         the runs' pictures, side-by-side pictures and report.txt\n"
    "                    (default TREE/out/check; emptied of earlier runs first)\n"
    "  --step NN         grade only step NN (repeatable; default every step)\n"
    "  --view V          render and grade only view V (runs that choose a view are kept)\n"
    "  --run NAME        grade only the manifest run NAME (NN_name or NN_name_VARIANT) of\n"
    "                    the steps graded (repeatable; default every run)\n"
    "  --args \"FLAGS\"    more flags for every run, split at spaces (e.g. \"--threads 1\")\n"
    "  --volume PATH     the volume to render (default: REFERENCE/volume.txt's volume: and\n"
    "                    arguments: lines, as make reference VOLUME=... writes them; else\n"
    "                    the phantom)\n"
    "  --timeout S       seconds a run may take before it is stopped (default 120)\n"
    "\n"
    "Grading a student's tree (the instructor; build/grade --class does this for a class):\n"
    "  --build           build the tree's steps/*.cpp from source (ordinary files only, links\n"
    "                    never followed) against the instructor's lab (--lab: its Makefile,\n"
    "                    common/ and compiled library), never running what TREE/build holds;\n"
    "                    build and runs inside the sandbox (bubblewrap: no network, no home,\n"
    "                    only the sources, the volume and one output folder; limits on CPU,\n"
    "                    memory, file size, files, processes and output)\n"
    "  --lab DIR         the instructor's lab (default: the one this check was built in)\n"
    "  --jobs N          compile N steps at once (default 2)\n"
    "  --budget S        wall-clock seconds for the whole tree, build and runs (default 600):\n"
    "                    runs past it are not started\n"
    "  --no-sandbox      with --build where bubblewrap cannot run: run the programs anyway,\n"
    "                    with limits but unconfined (the instructor's explicit choice)\n"
    "  --cache DIR       with --build: a class run's cache (build/grade --class makes one):\n"
    "                    a step whose source another tree had byte for byte takes its binary,\n"
    "                    and that binary's runs with the same arguments their outcome\n"
    "                    (tools/class_cache.h); not with --no-sandbox\n"
    "  --help            this text\n"
    "\n"
    "Exit status: 0 every graded step passes, 1 some step does not, 2 bad input.\n";

// --- Settings and the manifest ---------------------------------------------------------------

struct Settings {
    fs::path tree = ".", bin, reference, out;
    std::vector<std::string> steps;  // NN or NN_name; empty: all
    std::vector<std::string> runs;   // manifest runs (NN_name[_VARIANT]) to grade; empty: all
    std::string view;                // "" = every view
    std::vector<std::string> extra_args;
    std::string volume;                       // "" = REFERENCE/volume.txt's, else the phantom
    std::vector<std::string> volume_args;     // --dims ... from REFERENCE/volume.txt
    double timeout_s = default_timeout_s;
    bool build = false;          // a stranger's tree: built and run in the sandbox
    bool no_sandbox = false;     // --build without a sandbox, explicitly
    fs::path lab;                // the instructor's lab: Makefile, common/, its library
    fs::path cache;              // --build: the class run's shared builds and runs, or ""
    int jobs = 2;
    double budget_s = default_budget_s;
};

std::vector<std::string> split_words(const std::string& text) {
    std::vector<std::string> words;
    std::istringstream in(text);
    for (std::string word; in >> word;) words.push_back(word);
    return words;
}

Settings parse_arguments(int argc, char** argv) {
    Settings settings;
    bool has_bin = false, has_reference = false, has_out = false;
    for (int a = 1; a < argc; ++a) {
        const std::string arg = argv[a];
        auto value = [&]() -> std::string {
            if (a + 1 >= argc) throw InputError(arg + ": expected a value after it");
            return argv[++a];
        };
        if (arg == "--help" || arg == "-h") {
            std::printf("%s", usage_text);
            std::exit(exit_pass);
        } else if (arg == "--tree") {
            settings.tree = value();
        } else if (arg == "--bin") {
            settings.bin = value();
            has_bin = true;
        } else if (arg == "--reference") {
            settings.reference = value();
            has_reference = true;
        } else if (arg == "--out") {
            settings.out = value();
            has_out = true;
        } else if (arg == "--step") {
            settings.steps.push_back(value());
        } else if (arg == "--run") {
            settings.runs.push_back(value());
        } else if (arg == "--view") {
            settings.view = value();
            if (std::find(views.begin(), views.end(), settings.view) == views.end()) {
                throw InputError("--view: expected top, front or side, got '" + settings.view +
                                 "'");
            }
        } else if (arg == "--args") {
            for (const std::string& word : split_words(value())) {
                settings.extra_args.push_back(word);
            }
        } else if (arg == "--volume") {
            settings.volume = value();
            if (settings.volume.empty()) throw InputError("--volume: expected a file or phantom");
        } else if (arg == "--timeout") {
            settings.timeout_s = parse_double(arg, value(), 0.1, 24 * 3600);
        } else if (arg == "--build") {
            settings.build = true;
        } else if (arg == "--no-sandbox") {
            settings.no_sandbox = true;
        } else if (arg == "--lab") {
            settings.lab = value();
            if (settings.lab.empty()) throw InputError("--lab: expected a folder");
        } else if (arg == "--cache") {
            settings.cache = value();
            if (settings.cache.empty()) throw InputError("--cache: expected a folder");
        } else if (arg == "--jobs") {
            settings.jobs = parse_int(arg, value(), 1, 256);
        } else if (arg == "--budget") {
            settings.budget_s = parse_double(arg, value(), 1, 7 * 24 * 3600);
        } else {
            throw InputError("unknown argument '" + arg + "' (see check --help)");
        }
    }
    for (const fs::path* path : {&settings.tree, &settings.bin, &settings.reference,
                                 &settings.out}) {
        if (path == &settings.tree || (path == &settings.bin && has_bin) ||
            (path == &settings.reference && has_reference) || (path == &settings.out && has_out)) {
            if (path->empty()) throw InputError("expected a folder name, got ''");
        }
    }
    if (settings.build && has_bin) {
        throw InputError("--build builds the tree's steps itself: no --bin");
    }
    if (!settings.cache.empty() && (!settings.build || settings.no_sandbox)) {
        throw InputError("--cache is for --build in the sandbox: an unconfined program could "
                         "write into it");
    }
    if (!has_bin) settings.bin = settings.tree / "build";
    if (!has_reference) settings.reference = settings.tree / "data" / "reference";
    if (!has_out) settings.out = settings.tree / "out" / "check";
    return settings;
}

// One run of a step: its default run (variant "") or a manifest variant.
struct Run {
    std::string name;     // NN_name or NN_name_VARIANT
    std::string variant;  // "" for the default run
    std::vector<std::string> arguments;
    double tolerance = default_tolerance;
    bool has_tolerance = false;     // set on this line (a variant inherits its step's)
    std::vector<std::string> counters = work_counters;  // compared with the reference run's
    bool has_counters = false;
};

struct Step {
    std::string name;  // NN_name
    std::vector<Run> runs;
};

std::string trim(const std::string& text) {
    const size_t first = text.find_first_not_of(" \t\r");
    if (first == std::string::npos) return "";
    return text.substr(first, text.find_last_not_of(" \t\r") + 1 - first);
}

// Reads at most `limit` bytes of a regular file (not through a symlink).
std::string read_bounded(const fs::path& path, size_t limit, bool* truncated = nullptr) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) throw InputError("cannot read '" + path.string() + "': " + std::strerror(errno));
    struct stat info {};
    if (fstat(fd, &info) != 0 || !S_ISREG(info.st_mode)) {
        ::close(fd);
        throw InputError("'" + path.string() + "' is not a regular file");
    }
    std::string text;
    char buffer[65536];
    ssize_t got;
    while (text.size() < limit && (got = ::read(fd, buffer, sizeof buffer)) > 0) {
        text.append(buffer, static_cast<size_t>(got));
    }
    ::close(fd);
    if (truncated) *truncated = text.size() >= limit;
    if (text.size() > limit) text.resize(limit);
    return text;
}

constexpr size_t max_manifest_bytes = 1 << 20;

// The manifest's runs, grouped by step, for the steps in `step_names` (every step gets its
// default run even when the manifest does not list it).
std::vector<Step> read_manifest(const fs::path& path, const std::vector<std::string>& step_names) {
    std::vector<Step> steps;
    for (const std::string& name : step_names) steps.push_back({name, {}});
    auto find_step = [&](const std::string& name) -> Step* {
        for (Step& step : steps) {
            if (name == step.name || name.rfind(step.name + "_", 0) == 0) return &step;
        }
        return nullptr;
    };
    std::istringstream lines(read_bounded(path, max_manifest_bytes));
    std::string line;
    int number = 0;
    while (std::getline(lines, line)) {
        ++number;
        line = trim(line);
        if (line.empty() || line[0] == '#') continue;
        const std::string where = path.string() + ":" + std::to_string(number) + ": ";
        const size_t colon = line.find(':');
        if (colon == std::string::npos) throw InputError(where + "expected 'NAME: ARGUMENTS'");
        Run run;
        run.name = trim(line.substr(0, colon));
        Step* step = find_step(run.name);
        if (!step) continue;  // a step this tree does not have (or not graded now)
        if (run.name != step->name) run.variant = run.name.substr(step->name.size() + 1);
        for (const std::string& word : split_words(line.substr(colon + 1))) {
            if (word.rfind("tol=", 0) == 0) {
                run.tolerance = parse_double("tol", word.substr(4), 0, max_tolerance);
                run.has_tolerance = true;
            } else if (word.rfind("counters=", 0) == 0) {
                run.counters.clear();
                std::string list = word.substr(9);
                if (list != "none") {
                    std::replace(list.begin(), list.end(), ',', ' ');
                    for (const std::string& counter : split_words(list)) {
                        if (std::find(work_counters.begin(), work_counters.end(), counter) ==
                            work_counters.end()) {
                            throw InputError(where + "counters=: unknown counter '" + counter +
                                             "'");
                        }
                        run.counters.push_back(counter);
                    }
                }
                run.has_counters = true;
            } else {
                run.arguments.push_back(word);
            }
        }
        step->runs.push_back(run);
    }
    for (Step& step : steps) {
        auto default_run = std::find_if(step.runs.begin(), step.runs.end(),
                                        [](const Run& run) { return run.variant.empty(); });
        if (default_run == step.runs.end()) {
            step.runs.insert(step.runs.begin(), Run{step.name, "", {}});
            default_run = step.runs.begin();
        }
        for (Run& run : step.runs) {  // a variant inherits what its default line sets
            if (!run.has_tolerance) run.tolerance = default_run->tolerance;
            if (!run.has_counters) run.counters = default_run->counters;
        }
    }
    return steps;
}

// REFERENCE/counters.txt: "NAME: step=.. view=V key=value ..." -> (NAME, V) -> key -> value
// (Summary and parse_summary: tools/run_step.h).
using CounterTable = std::map<std::pair<std::string, std::string>, Summary>;

std::optional<CounterTable> read_counters(const fs::path& path) {
    std::error_code error;
    if (!fs::is_regular_file(fs::symlink_status(path, error))) return std::nullopt;
    CounterTable table;
    std::istringstream lines(read_bounded(path, max_manifest_bytes * 4));
    std::string line;
    while (std::getline(lines, line)) {
        line = trim(line);
        if (line.empty() || line[0] == '#') continue;
        const size_t colon = line.find(':');
        if (colon == std::string::npos) continue;
        Summary fields = parse_summary(line.substr(colon + 1));
        if (!fields.count("view")) continue;
        table[{trim(line.substr(0, colon)), fields["view"]}] = fields;
    }
    return table;
}

// --- Running a step as a process -----------------------------------------------------------
// tools/process.h's run_process: a step runs inside the tree (its relative paths, e.g. data/tf/,
// are the tree's), in a process group of its own, its output read within a bound, and a
// signal kept apart from an exit status. Its stdout and stderr are kept beside its pictures.

using Outcome = ProcessResult;

// Set by SIGINT, SIGTERM or SIGHUP: the running step is stopped and grade ends (its stage
// removed) with status 130.
volatile std::sig_atomic_t interrupted = 0;
struct Interrupted {};

Outcome checked(Outcome outcome) {
    if (outcome.interrupted) throw Interrupted{};
    return outcome;
}

Outcome run_step_process(const fs::path& program, const std::vector<std::string>& arguments,
                         const fs::path& folder, const fs::path& log_folder, double timeout_s) {
    ProcessOptions options;
    options.folder = folder.string();
    options.limits.wall_s = timeout_s;
    options.limits.output_bytes = max_output_bytes;
    options.stop = &interrupted;
    Outcome outcome = checked(run_process(program.string(), arguments, options));
    for (const auto& [name, text] : {std::pair<const char*, const std::string*>{"stdout.txt",
                                                                                &outcome.out},
                                     {"stderr.txt", &outcome.err}}) {
        const fs::path path = log_folder / name;
        const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW, 0644);
        if (fd < 0) continue;
        const ssize_t written = ::write(fd, text->data(), text->size());
        (void)written;
        ::close(fd);
    }
    return outcome;
}

// --- A stranger's tree: staged, then built and run in the sandbox ----------------------------
// The sandbox's user (as root, a uid of its own) must reach every folder it is given, and a
// student's files are read only as ordinary files (never through a link). So a stage under
// the system temp folder (mode 0711) holds copies of just what the build and runs need:
//   STAGE/lab/Makefile, common/, data/tf/, data/presets/   the instructor's
//   STAGE/lab/build/libctlab.a                              the instructor's compiled library
//   STAGE/lab/build/ctlab_*.so                              its modules (formats, window)
//   STAGE/lab/steps/NN_name.cpp                             the student's, ordinary files only
//   STAGE/lab/build/NN_name                                 compiled in the sandbox
//   STAGE/volume/NAME                                       the volume, when it is a file
//   STAGE/run/                                              one run's output folder
// No reference folder, no other student, no home: the sandbox sees /usr and these.

#ifdef __SANITIZE_ADDRESS__
constexpr bool lab_has_sanitizers = true;  // this grader, and so the lab's library, is SAN=1
#else
constexpr bool lab_has_sanitizers = false;
#endif
// The lab's modules beside its library (common/module.h): staged with it, never rebuilt.
constexpr const char* lab_modules[] = {"ctlab_formats.so", "ctlab_dicom.so", "ctlab_window.so"};
constexpr size_t max_source_bytes = 4 << 20;        // one step's .cpp
constexpr size_t max_run_folder_bytes = 64 << 20;   // what a run may leave in its folder
constexpr size_t max_run_folder_files = 256;
constexpr double build_cpu_s = 300;                  // CPU seconds of one compiler process
constexpr size_t build_memory = size_t(4) << 30;     // address space of one compiler process
constexpr size_t run_memory = size_t(4) << 30;       // address space of a step
constexpr size_t build_file_bytes = 512u << 20;      // the largest file a build writes
constexpr size_t run_file_bytes = 64u << 20;         // the largest file a step writes
constexpr size_t sandbox_open_files = 256;
constexpr size_t sandbox_processes = 64;             // processes and threads
constexpr size_t build_tmp_bytes = 512u << 20;       // the compiler's /tmp
constexpr size_t run_tmp_bytes = 16u << 20;

// Copies an ordinary file of at most `limit` bytes, never through a link; "" or the reason.
std::string copy_untrusted(const fs::path& from, const fs::path& to, size_t limit) {
    const int in = ::open(from.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
    if (in < 0) {
        return errno == ELOOP ? "is a symbolic link: not followed"
                              : std::string("cannot be read: ") + std::strerror(errno);
    }
    struct stat info {};
    if (fstat(in, &info) != 0 || !S_ISREG(info.st_mode)) {
        ::close(in);
        return "is not an ordinary file";
    }
    if (static_cast<size_t>(info.st_size) > limit) {
        ::close(in);
        return "is larger than " + readable_size(limit);
    }
    const int out = ::open(to.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC,
                           0644);
    if (out < 0) {
        ::close(in);
        return "cannot be copied to " + to.string() + ": " + std::strerror(errno);
    }
    char buffer[65536];
    size_t total = 0;
    std::string problem;
    for (ssize_t got; (got = ::read(in, buffer, sizeof buffer)) > 0;) {
        total += static_cast<size_t>(got);
        if (total > limit) {
            problem = "is larger than " + readable_size(limit);
            break;
        }
        if (::write(out, buffer, static_cast<size_t>(got)) != got) {
            problem = std::string("cannot be copied: ") + std::strerror(errno);
            break;
        }
    }
    ::close(in);
    ::close(out);
    return problem;
}

// The stage: made once per grade, removed at the end.
class Stage {
public:
    Stage() : folder_("check") {
        fs::permissions(folder_.path(), fs::perms::owner_all | fs::perms::others_exec);
    }
    fs::path root() const { return folder_.path(); }
    fs::path lab() const { return root() / "lab"; }

private:
    TempFolder folder_;
};

std::string signal_name(int signal) {
    switch (signal) {
        case SIGXCPU: return "SIGXCPU (it used up its CPU seconds: a loop that never ends?)";
        case SIGXFSZ: return "SIGXFSZ (it wrote a file larger than the grader allows)";
        default: break;
    }
    switch (signal) {
        case SIGSEGV: return "SIGSEGV (segmentation fault: a read or write outside memory)";
        case SIGABRT: return "SIGABRT (aborted: an assert, or the sanitizers, or a throw "
                             "nobody caught)";
        case SIGFPE: return "SIGFPE (arithmetic: an integer division by zero?)";
        case SIGBUS: return "SIGBUS (bus error)";
        case SIGILL: return "SIGILL (illegal instruction)";
        case SIGKILL: return "SIGKILL (killed: out of memory?)";
        default: {
            const char* text = strsignal(signal);
            return "signal " + std::to_string(signal) + (text ? std::string(" (") + text + ")"
                                                              : std::string());
        }
    }
}

std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
        if (!trim(line).empty()) lines.push_back(line);
    }
    return lines;
}

// --- Pictures --------------------------------------------------------------------------------

// The first pixel with the largest channel error.
struct Worst {
    int x = 0, y = 0, error = 0;
};

Worst worst_pixel(const Image& student, const Image& reference) {
    Worst worst;
    for (int y = 0; y < student.height; ++y) {
        for (int x = 0; x < student.width; ++x) {
            const Rgb& a = student.at(x, y);
            const Rgb& b = reference.at(x, y);
            const int error = std::max({std::abs(to_byte(a.r) - to_byte(b.r)),
                                        std::abs(to_byte(a.g) - to_byte(b.g)),
                                        std::abs(to_byte(a.b) - to_byte(b.b))});
            if (error > worst.error) worst = {x, y, error};
        }
    }
    return worst;
}

Image transposed(const Image& image) {
    Image result(image.height, image.width);
    for (int y = 0; y < image.height; ++y) {
        for (int x = 0; x < image.width; ++x) result.at(y, x) = image.at(x, y);
    }
    return result;
}

Image mirrored(const Image& image, bool left_right) {
    Image result(image.width, image.height);
    for (int y = 0; y < image.height; ++y) {
        for (int x = 0; x < image.width; ++x) {
            result.at(x, y) = left_right ? image.at(image.width - 1 - x, y)
                                         : image.at(x, image.height - 1 - y);
        }
    }
    return result;
}

bool same_size(const Image& a, const Image& b) {
    return a.width == b.width && a.height == b.height;
}

bool passes(const Image& student, const Image& reference, double tolerance) {
    return same_size(student, reference) && !student.pixels.empty() &&
           compare_images(student, reference, tolerance).pass;
}

// student | reference | heat map, side by side on dark grey.
Image side_by_side(const Image& student, const Image& reference, double tolerance) {
    const Image heat = diff_heat_map(student, reference, tolerance);
    const int width = student.width + reference.width + heat.width + 2 * gap;
    const int height = std::max({student.height, reference.height, heat.height});
    Image result(width, height);
    std::fill(result.pixels.begin(), result.pixels.end(), grey(0.15f));
    int left = 0;
    for (const Image* panel : {&student, &reference, &heat}) {
        for (int y = 0; y < panel->height; ++y) {
            for (int x = 0; x < panel->width; ++x) result.at(left + x, y) = panel->at(x, y);
        }
        left += panel->width + gap;
    }
    return result;
}

// --- Grading ---------------------------------------------------------------------------------

enum class Status { passing, failing, not_started, crashed, not_built };

const char* status_text(Status status) {
    switch (status) {
        case Status::passing: return "passing";
        case Status::failing: return "failing";
        case Status::not_started: return "not started";
        case Status::crashed: return "crashed";
        case Status::not_built: return "not built";
    }
    return "?";
}

struct StepResult {
    Status status = Status::passing;
    int pictures = 0, pictures_passed = 0;
    int counters = 0, counters_passed = 0;  // summary lines, and those whose counters match
    int runs = 0;
    // The step's first failing run: its rays are traced (the probes, the first ray whose work
    // differs). A later run that fails is graded by its pictures and counters alone: one
    // mistake mostly fails every run, and each trace costs renders of the whole picture.
    std::string traced_run;
    std::vector<std::string> look_at;  // the first things to look at, most useful first
    std::vector<std::string> problems;  // everything, for report.txt
};

// In a student kit: the functions of `step` that it takes unchanged from an earlier step,
// which `make carry` copies in while they are stubs (.ctlab/carry.txt, written by make_student:
// "TO_STEP FUNCTION FROM_STEP HASH"). Empty in the lab, and for a stranger's tree (--build).
std::set<std::string> carried_functions(const fs::path& tree, const std::string& step) {
    std::set<std::string> names;
    std::ifstream carry(tree / ".ctlab" / "carry.txt");
    for (std::string line; std::getline(carry, line);) {
        std::istringstream fields(line);
        std::string to, function;
        if (line.empty() || line[0] == '#' || !(fields >> to >> function)) continue;
        if (to == step) names.insert(function);
    }
    return names;
}

std::string relative_to(const fs::path& path, const fs::path& base) {
    std::error_code error;
    const fs::path relative = fs::relative(path, base, error);
    if (error || relative.empty() || relative.string().rfind("..", 0) == 0) return path.string();
    return relative.string();
}

std::string join(const std::vector<std::string>& words) {
    std::string text;
    for (const std::string& word : words) text += (text.empty() ? "" : " ") + word;
    return text;
}


// --- Probe rays: where a student's ray leaves the reference's ---------------------------------
// REFERENCE/probes.txt names probe pixels per run and view; REFERENCE/traces/ holds their
// reference traces, the sidecars --debug-pixel writes (common/ray_plot.h): each trace line as
// "record<TAB>text<TAB>name=value ...". A failing run's probes are run again with
// --debug-pixel and compared line by line, field by field.

constexpr size_t max_trace_bytes = 8 << 20;
constexpr double trace_absolute_tolerance = 1e-6;  // printed values are rounded to 6 decimals
constexpr double trace_relative_tolerance = 1e-5;  // float against double sums: 1e-7

struct Probe {
    std::string view;
    int x = 0, y = 0;
};

struct TraceLine {
    std::string text;
    std::vector<std::pair<std::string, double>> fields;
    const double* field(const std::string& name) const {
        for (const auto& f : fields) {
            if (f.first == name) return &f.second;
        }
        return nullptr;
    }
};

std::vector<TraceLine> read_trace(const fs::path& path) {
    std::vector<TraceLine> lines;
    for (const TraceRecord& record :
         trace_records_from_text(read_bounded(path, max_trace_bytes))) {
        TraceLine line;
        line.text = record.text;
        for (const TraceField& field : record.fields) {
            line.fields.emplace_back(field.name, field.number);
        }
        lines.push_back(std::move(line));
    }
    return lines;
}

std::string field_value(double value) {
    char text[64];
    if (value == std::floor(value) && std::fabs(value) < 1e15) {
        std::snprintf(text, sizeof text, "%.0f", value);
    } else if (std::fabs(value) < 1e6) {
        std::snprintf(text, sizeof text, "%.6f", value);
    } else {
        std::snprintf(text, sizeof text, "%.6g", value);
    }
    return text;
}

// "n=43" or "t=14.00": where along the ray a line is (else the last such place before it).
std::string place_of(const std::vector<TraceLine>& lines, size_t index) {
    for (size_t n = index + 1; n-- > 0;) {
        if (n >= lines.size()) continue;
        for (const char* name : {"n", "t"}) {
            if (const double* value = lines[n].field(name)) {
                const std::string place = std::string(name) + "=" +
                    (std::string(name) == "t" ? field_value(std::round(*value * 1e4) / 1e4)
                                              : field_value(*value));
                return n == index ? place : "the line after " + place;
            }
        }
    }
    return "line " + std::to_string(index + 1);
}

// The first difference of two traces, or "" when they agree.
std::string first_difference(const std::vector<TraceLine>& yours,
                             const std::vector<TraceLine>& reference) {
    const size_t count = std::max(yours.size(), reference.size());
    for (size_t n = 0; n < count; ++n) {
        if (n >= yours.size()) {
            return place_of(reference, n) + ": your trace ends there (" +
                   std::to_string(yours.size()) + " lines), the reference's goes on (" +
                   std::to_string(reference.size()) + " lines)" +
                   "\n        reference: " + reference[n].text;
        }
        if (n >= reference.size()) {
            return place_of(yours, n) + ": your trace goes on (" + std::to_string(yours.size()) +
                   " lines), the reference's ended (" + std::to_string(reference.size()) +
                   " lines)" + "\n        yours:     " + yours[n].text;
        }
        for (const auto& [name, expected] : reference[n].fields) {
            const double* got = yours[n].field(name);
            const bool same = got && (std::fabs(*got - expected) <=
                                      trace_absolute_tolerance +
                                          trace_relative_tolerance *
                                              std::max(std::fabs(*got), std::fabs(expected)));
            if (same) continue;
            const std::string what =
                got ? "your " + name + " is " + field_value(*got) + ", the reference's " +
                          field_value(expected)
                    : "your line has no " + name + "=, the reference's " + name + " is " +
                          field_value(expected);
            std::string text = place_of(reference, n) + ": " + what;
            if (n > 0) text += "\n        both:      " + reference[n - 1].text;
            text += "\n        yours:     " + yours[n].text +
                    "\n        reference: " + reference[n].text;
            return text;
        }
    }
    return "";
}

// --- Per-ray work: the first ray whose counters differ -------------------------------------
// A step run with --work-map writes each ray's counters (common/step.h, work_map_text):
//   work W H samples,skipped,leapt,gradients,terminated,hits / total ... / "Y: [N*]a,b,c,d,e,f ..."

constexpr size_t max_work_map_bytes = 64 << 20;
constexpr int work_counter_count = 6;
const char* const work_counter_names[work_counter_count] = {"samples",    "skipped",
                                                            "leapt",      "gradients",
                                                            "terminated", "hits"};
using RayWork = std::array<unsigned long long, work_counter_count>;

struct WorkMap {
    int width = 0, height = 0;
    std::vector<RayWork> rays;  // row by row
};

// False when the file is missing or not a whole work map.
bool read_work_map(const fs::path& path, WorkMap& map) {
    std::error_code error;
    if (!fs::is_regular_file(fs::symlink_status(path, error))) return false;
    std::istringstream in(read_bounded(path, max_work_map_bytes));
    std::string line;
    if (!std::getline(in, line)) return false;
    const std::vector<std::string> head = split_words(line);
    if (head.size() < 3 || head[0] != "work") return false;
    map.width = std::atoi(head[1].c_str());
    map.height = std::atoi(head[2].c_str());
    constexpr int max_side = 1 << 14;
    if (map.width <= 0 || map.height <= 0 || map.width > max_side || map.height > max_side) {
        return false;
    }
    map.rays.clear();
    map.rays.reserve(size_t(map.width) * map.height);
    for (int y = 0; y < map.height;) {
        if (!std::getline(in, line)) return false;
        if (line.rfind("total ", 0) == 0) continue;
        const std::vector<std::string> words = split_words(line);
        if (words.empty() || words[0] != std::to_string(y) + ":") return false;
        size_t row = 0;
        for (size_t w = 1; w < words.size(); ++w) {
            const std::string& word = words[w];
            const size_t star = word.find('*');
            const long long count = star == std::string::npos ? 1 : std::atoll(word.c_str());
            RayWork ray{};
            const char* text = word.c_str() + (star == std::string::npos ? 0 : star + 1);
            for (int c = 0; c < work_counter_count; ++c) {
                char* end = nullptr;
                ray[c] = std::strtoull(text, &end, 10);
                if (end == text || (c + 1 < work_counter_count && *end != ',')) return false;
                text = end + 1;
            }
            if (count < 1 || row + size_t(count) > size_t(map.width)) return false;
            for (long long n = 0; n < count; ++n) map.rays.push_back(ray);
            row += size_t(count);
        }
        if (row != size_t(map.width)) return false;
        ++y;
    }
    return true;
}

std::string ray_work_text(const RayWork& ray) {
    std::string text;
    for (int c = 0; c < work_counter_count; ++c) {
        text += (c ? " " : "") + std::string(work_counter_names[c]) + "=" +
                std::to_string(ray[c]);
    }
    return text;
}

class Grader {
public:
    explicit Grader(Settings settings) : settings_(std::move(settings)) {}

    int run();

private:
    StepResult grade_step(const Step& step);
    void grade_run(const Step& step, const Run& run, StepResult& result);
    void grade_picture(const Step& step, const Run& run, const std::string& view,
                       const fs::path& folder, StepResult& result);
    bool grade_counters(const Run& run, const std::string& view, const Summary& student,
                        StepResult& result);
    void first_ray_apart(const Step& step, const Run& run, const std::string& view,
                         const fs::path& folder, StepResult& result);
    void probe_rays(const Step& step, const Run& run, const std::string& view,
                    const fs::path& folder, StepResult& result);
    // REFERENCE/probes.txt's probe pixels of this run and view that have a reference trace.
    std::vector<Probe> probes_of(const Run& run, const std::string& view) const;
    std::string command_for(const Step& step, const Run& run, const std::string& view,
                            const std::string& more = "") const;
    fs::path reference_picture(const Step& step, const Run& run, const std::string& view) const {
        return settings_.reference /
               (step.name + "_" + view + (run.variant.empty() ? "" : "_" + run.variant) + ".png");
    }
    // The first flags of every run: the volume, no window, the output folder.
    std::vector<std::string> first_arguments(const fs::path& folder) const;
    // Runs the step with these flags, its pictures ending in `folder`.
    Outcome execute(const Step& step, const std::vector<std::string>& arguments,
                    const fs::path& folder);
    // --build: the stage, and the student's steps compiled in the sandbox.
    void stage_and_build(const std::vector<std::string>& names);
    double seconds_left() const;

    Settings settings_;
    std::optional<CounterTable> counters_;
    fs::path cwd_;
    std::unique_ptr<Stage> stage_;
    fs::path kit_reference_;  // the kit's phantom references, when grading on another volume
    fs::path reference_bin_;  // the solution's own step binaries, when this lab holds them
    std::map<std::string, std::string> not_built_;  // --build: step -> why it was not built
    double build_s_ = 0;  // --build: wall-clock seconds of the sandboxed build
    std::unique_ptr<ClassCache> cache_;             // --cache: the class run's
    std::map<std::string, std::string> build_keys_;  // step -> its cache entry, when it has one
    int builds_ = 0, builds_reused_ = 0, runs_ = 0, runs_reused_ = 0;  // cache: report.txt
    // "RUN VIEW" -> the folder where first_ray_apart's --work-map run also traced the probe
    // pixels (one render for both): probe_rays reads their traces there.
    std::map<std::string, fs::path> probes_traced_;
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

double Grader::seconds_left() const {
    return settings_.budget_s -
           std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

// Sandbox settings shared by the build and the runs: the stage's lab read-only at /lab.
Limits sandbox_limits(double wall_s, bool build) {
    Limits limits;
    limits.wall_s = wall_s;
    limits.cpu_s = build ? build_cpu_s : wall_s;
    // ASan reserves terabytes of address space for its shadow: a sanitizer build's programs
    // cannot start under any limit of it (their memory is still bounded by the build's own
    // checks); the other limits hold.
    limits.address_space = lab_has_sanitizers ? 0 : build ? build_memory : run_memory;
    limits.file_size = build ? build_file_bytes : run_file_bytes;
    limits.open_files = sandbox_open_files;
    limits.processes = sandbox_processes;
    limits.output_bytes = max_output_bytes;
    return limits;
}

std::vector<std::string> Grader::first_arguments(const fs::path& folder) const {
    std::string volume = settings_.volume;
    const fs::path name = fs::path(volume).lexically_normal().filename();
    std::error_code error;
    if (stage_ && !name.empty() && fs::exists(stage_->root() / "volume" / name, error)) {
        volume = "/volume/" + name.string();
    }
    std::vector<std::string> arguments = {"--volume", volume, "--no-window", "--out",
                                          stage_ ? "/out" : fs::absolute(folder).string()};
    arguments.insert(arguments.end(), settings_.volume_args.begin(),
                     settings_.volume_args.end());
    return arguments;
}

Outcome Grader::execute(const Step& step, const std::vector<std::string>& arguments,
                        const fs::path& folder) {
    if (!stage_) {
        return run_step_process(fs::absolute(settings_.bin / step.name), arguments,
                                settings_.tree, folder, settings_.timeout_s);
    }
    Outcome outcome;
    const double left = seconds_left();
    if (left <= 0) {  // the student's budget is spent: reported as a timeout
        outcome.timed_out = true;
        outcome.err = "not run: this tree's budget of " +
                      std::to_string(static_cast<int>(settings_.budget_s)) + " s is used up\n";
        return outcome;
    }
    // The same program with the same arguments ended so before (class_cache.h).
    ++runs_;
    const auto key = build_keys_.find(step.name);
    if (cache_ && key != build_keys_.end() &&
        cache_->take_run(key->second, arguments, folder.string(), outcome)) {
        ++runs_reused_;
        outcome.program = "/lab/build/" + step.name;
        outcome.args = arguments;
        for (const auto& [name, text] : {std::pair<const char*, const std::string*>{
                                             "stdout.txt", &outcome.out},
                                         {"stderr.txt", &outcome.err}}) {
            std::ofstream log(folder / name, std::ios::binary | std::ios::trunc);
            log << *text;
        }
        return outcome;
    }
    const fs::path run_folder = stage_->root() / "run";
    std::error_code error;
    fs::remove_all(run_folder, error);
    fs::create_directory(run_folder);
    give_to_sandbox(run_folder.string());
    // A run sees its own binary, the instructor's modules and data/, the volume and an empty
    // /out: nothing of the tree's other steps, so that what it does depends on it alone.
    Sandbox sandbox;
    const fs::path lab = stage_->lab();
    sandbox.mounts = {{(lab / "data").string(), "/lab/data", false},
                      {(lab / "build" / step.name).string(), "/lab/build/" + step.name, false}};
    for (const char* module : lab_modules) {
        if (fs::is_regular_file(lab / "build" / module, error)) {
            sandbox.mounts.push_back({(lab / "build" / module).string(),
                                      std::string("/lab/build/") + module, false});
        }
    }
    sandbox.mounts.insert(sandbox.mounts.end(),
                          {{(stage_->root() / "volume").string(), "/volume", false},
                           {run_folder.string(), "/out", true}});
    sandbox.folder = "/lab";
    sandbox.tmp_bytes = run_tmp_bytes;
    ProcessOptions options;
    options.limits = sandbox_limits(std::min(settings_.timeout_s, left), false);
    options.prefix = settings_.no_sandbox ? std::vector<std::string>{} : sandbox_command(sandbox);
    options.uid = settings_.no_sandbox ? 0 : sandbox_uid();
    std::vector<std::string> words = arguments;
    if (settings_.no_sandbox) {  // the same flags, the stage's own paths
        for (std::string& word : words) {
            if (word == "/out") word = run_folder.string();
            if (word.rfind("/volume/", 0) == 0) word = (stage_->root() / word.substr(1)).string();
        }
        options.folder = stage_->lab().string();
    }
    const std::string program = settings_.no_sandbox
        ? (stage_->lab() / "build" / step.name).string() : "/lab/build/" + step.name;
    options.stop = &interrupted;
    outcome = checked(run_process(program, words, options));
    // bwrap exits with 128 + N when a signal N ended the program inside it.
    constexpr int signal_status = 128, last_signal = 64;
    if (!settings_.no_sandbox && outcome.signal == 0 && outcome.exit_status > signal_status &&
        outcome.exit_status <= signal_status + last_signal) {
        outcome.signal = outcome.exit_status - signal_status;
        outcome.exit_status = -1;
    }
    // What it left in its folder, ordinary files only and within bounds, goes to `folder`.
    size_t files = 0, bytes = 0;
    std::string problem;
    std::vector<std::string> copied;  // the names of the files copied out
    for (const fs::directory_entry& entry : fs::directory_iterator(run_folder, error)) {
        const fs::path name = entry.path().filename();
        if (++files > max_run_folder_files) {
            problem = "it left more than " + std::to_string(max_run_folder_files) +
                      " files in its output folder";
            break;
        }
        struct stat info {};
        if (::lstat(entry.path().c_str(), &info) != 0 || !S_ISREG(info.st_mode)) continue;
        bytes += static_cast<size_t>(info.st_size);
        if (bytes > max_run_folder_bytes) {
            problem = "it left more than " + readable_size(max_run_folder_bytes) +
                      " in its output folder";
            break;
        }
        if (copy_untrusted(entry.path(), folder / name, max_run_folder_bytes).empty()) {
            copied.push_back(name.string());
        }
    }
    fs::remove_all(run_folder, error);
    if (!problem.empty()) {  // graded as a program that printed too much
        outcome.output_exceeded = true;
        outcome.err = "check: " + problem + "\n" + outcome.err;
    }
    for (const auto& [name, text] : {std::pair<const char*, const std::string*>{"stdout.txt",
                                                                                &outcome.out},
                                     {"stderr.txt", &outcome.err}}) {
        std::ofstream log(folder / name, std::ios::binary | std::ios::trunc);
        log << *text;
    }
    if (cache_ && key != build_keys_.end() && !settings_.no_sandbox) {
        cache_->store_run(key->second, arguments, outcome, folder.string(), copied);
    }
    return outcome;
}

// The instructor's inputs as text for the cache (class_cache.h): their bytes, the flags the
// build adds, the volume and the run limits. Another lab, volume or timeout: another cache.
std::string lab_fingerprint(const fs::path& lab, const Settings& settings) {
    std::string text = std::string("san=") + (lab_has_sanitizers ? "1" : "0") +
                       " timeout=" + std::to_string(settings.timeout_s) + " volume=" +
                       settings.volume + " " + join(settings.volume_args) + "\n";
    std::vector<fs::path> files;
    std::error_code error;
    for (const char* folder : {"common", "data/tf", "data/presets"}) {
        for (const fs::directory_entry& entry :
             fs::recursive_directory_iterator(lab / folder, error)) {
            if (entry.is_regular_file(error)) files.push_back(entry.path());
        }
    }
    std::sort(files.begin(), files.end());
    files.insert(files.begin(), {lab / "Makefile", lab / "build" / "libctlab.a"});
    for (const char* module : lab_modules) files.push_back(lab / "build" / module);
    for (const fs::path& file : files) {
        std::ifstream in(file, std::ios::binary);
        std::ostringstream bytes;
        bytes << in.rdbuf();
        char hash[17];
        std::snprintf(hash, sizeof hash, "%016llx", fnv1a_64(bytes.str()));
        text += relative_to(file, lab) + " " + hash + "\n";
    }
    // A volume file: its size and time (an instructor's volume is not changed mid-class).
    if (fs::is_regular_file(settings.volume, error)) {
        text += "volume " + std::to_string(fs::file_size(settings.volume, error)) + " " +
                std::to_string(fs::last_write_time(settings.volume, error)
                                   .time_since_epoch().count()) + "\n";
    }
    return text;
}

void Grader::stage_and_build(const std::vector<std::string>& names) {
    const fs::path library = fs::path(build_folder()).parent_path() == settings_.lab
        ? fs::path(build_folder()) / "libctlab.a" : settings_.lab / "build" / "libctlab.a";
    std::error_code error;
    if (!fs::is_regular_file(settings_.lab / "Makefile", error) ||
        !fs::is_directory(settings_.lab / "common", error)) {
        throw InputError("--lab: '" + settings_.lab.string() + "' holds no Makefile and common/");
    }
    if (!fs::is_regular_file(library, error)) {
        throw InputError("the lab's library " + library.string() + " is not built: make");
    }
    for (const fs::directory_entry& entry : fs::directory_iterator(settings_.lab / "common")) {
        if (fs::last_write_time(entry.path(), error) > fs::last_write_time(library, error)) {
            throw InputError(entry.path().string() + " is newer than " + library.string() +
                             ": make, so students are built against the library as it is");
        }
    }
    const auto build_start = std::chrono::steady_clock::now();
    stage_ = std::make_unique<Stage>();
    const fs::path lab = stage_->lab();
    fs::create_directories(lab / "steps");
    fs::create_directories(lab / "build");
    fs::create_directories(lab / "data");
    fs::create_directories(stage_->root() / "volume");
    fs::copy_file(settings_.lab / "Makefile", lab / "Makefile");
    fs::copy(settings_.lab / "common", lab / "common", fs::copy_options::recursive);
    for (const char* data : {"tf", "presets"}) {
        if (fs::is_directory(settings_.lab / "data" / data, error)) {
            fs::copy(settings_.lab / "data" / data, lab / "data" / data,
                     fs::copy_options::recursive);
        }
    }
    fs::copy_file(library, lab / "build" / "libctlab.a");
    // The modules the steps open (common/module.h): the instructor's, as the library is.
    for (const char* module : lab_modules) {
        const fs::path built = library.parent_path() / module;
        if (fs::is_regular_file(built, error)) fs::copy_file(built, lab / "build" / module);
    }
    if (settings_.volume != "phantom" && settings_.volume.rfind("phantom:", 0) != 0) {
        // A file, or a folder (a DICOM series): the instructor's, copied as it is.
        const fs::path volume = fs::path(settings_.volume).lexically_normal();
        fs::copy(volume, stage_->root() / "volume" / volume.filename(),
                 fs::copy_options::recursive);
    }
    if (!settings_.cache.empty()) {
        cache_ = std::make_unique<ClassCache>(settings_.cache.string(),
                                              lab_fingerprint(lab, settings_));
    }
    // The student's sources: ordinary files only, never through a link.
    std::vector<std::string> targets;
    std::map<std::string, std::string> sources;  // with the cache: each source's bytes
    for (const std::string& name : names) {
        const fs::path source = lab / "steps" / (name + ".cpp");
        const std::string problem = copy_untrusted(settings_.tree / "steps" / (name + ".cpp"),
                                                   source, max_source_bytes);
        if (!problem.empty()) {
            not_built_[name] = "steps/" + name + ".cpp " + problem;
            continue;
        }
        ++builds_;
        if (cache_) sources[name] = read_bounded(source, max_source_bytes);
        targets.push_back(name);
    }

    // Each step is built by itself, in a sandbox that sees its one source, the instructor's
    // Makefile, common/, library and modules, and a writable build folder of its own: its
    // binary is made from that source alone (no #include of another step's file), as the
    // cache's key says. `jobs` steps at once. With the class cache, a source another tree
    // built takes its binary; one another tree is building now is waited for (its lock).
    const fs::path builds = stage_->root() / "builds";
    // -o: the instructor's library is never remade (nor its objects looked for). STEP_PCH=:
    // no precompiled header. Each build folder compiles one step, and making the header
    // costs more than it saves that one step: measured on step 02 at the lab's flags (three
    // runs, load ~10), 2.7 s of compiler CPU for the header and 0.8 s for the step with it,
    // against 1.4 s for the step without.
    std::vector<std::string> make_flags = {"--no-print-directory", "BUILD=build", "WERROR=0",
                                           "STEP_PCH=", "-o", "build/libctlab.a"};
    for (const char* module : lab_modules) {
        make_flags.insert(make_flags.end(), {"-o", std::string("build/") + module});
    }
    // A sanitizer build of the lab (make SAN=1) has an instrumented library: the students'
    // steps are built the same way, or they would not link against it.
    if (lab_has_sanitizers) make_flags.push_back("SAN=1");
    std::vector<Outcome> outcomes(targets.size());
    std::vector<std::string> keys(targets.size());  // the cache entry each binary came from
    std::vector<char> reused(targets.size(), 0), made(targets.size(), 0);
    std::atomic<size_t> next{0};
    std::mutex failing;
    std::exception_ptr failure;  // a builder's error, thrown again once all have ended
    auto build = [&](size_t n) {
        const std::string& name = targets[n];
        const fs::path binary = lab / "build" / name;
        std::unique_ptr<CacheLock> lock;
        if (cache_) {
            lock = cache_->lock_build(name, sources.at(name), &interrupted);
            keys[n] = cache_->take_build(name, sources.at(name), binary.string());
            if (!keys[n].empty()) {
                reused[n] = made[n] = 1;
                return;
            }
        }
        std::error_code error;
        const fs::path own = builds / name;
        fs::create_directories(own / "steps");
        fs::create_directories(own / "build");
        fs::copy_file(lab / "steps" / (name + ".cpp"), own / "steps" / (name + ".cpp"));
        fs::copy_file(lab / "build" / "libctlab.a", own / "build" / "libctlab.a");
        for (const char* module : lab_modules) {
            if (fs::is_regular_file(lab / "build" / module, error)) {
                fs::copy_file(lab / "build" / module, own / "build" / module);
            }
        }
        if (settings_.no_sandbox) {  // unconfined: the stage's own Makefile and common/
            fs::create_symlink(lab / "Makefile", own / "Makefile");
            fs::create_directory_symlink(lab / "common", own / "common");
        }
        give_to_sandbox((own / "build").string());
        Sandbox sandbox;
        sandbox.mounts = {{(lab / "Makefile").string(), "/lab/Makefile", false},
                          {(lab / "common").string(), "/lab/common", false},
                          {(own / "steps").string(), "/lab/steps", false},
                          {(own / "build").string(), "/lab/build", true}};
        sandbox.folder = "/lab";
        sandbox.tmp_bytes = build_tmp_bytes;
        ProcessOptions options;
        options.limits = sandbox_limits(std::max(1.0, seconds_left()), true);
        options.prefix = settings_.no_sandbox ? std::vector<std::string>{}
                                              : sandbox_command(sandbox);
        options.uid = settings_.no_sandbox ? 0 : sandbox_uid();
        if (settings_.no_sandbox) options.folder = own.string();
        options.stop = &interrupted;
        std::vector<std::string> arguments = make_flags;
        arguments.push_back("build/" + name);
        outcomes[n] = run_process("/usr/bin/make", arguments, options);
        // The binary, made by the sandbox: an ordinary file within bounds, or not built.
        const fs::path built = own / "build" / name;
        if (!fs::is_regular_file(fs::symlink_status(built, error)) ||
            !copy_untrusted(built, binary, build_file_bytes).empty()) {
            return;
        }
        fs::permissions(binary, fs::perms::owner_all | fs::perms::group_read |
                        fs::perms::group_exec | fs::perms::others_read |
                        fs::perms::others_exec, error);
        made[n] = 1;
        if (cache_ && outcomes[n].exit_status == 0) {
            cache_->store_build(name, sources.at(name), binary.string());
            keys[n] = cache_->take_build(name, sources.at(name), binary.string());
        }
    };
    auto builder = [&] {
        for (size_t n; (n = next++) < targets.size() && !interrupted;) {
            try {
                build(n);
            } catch (...) {
                const std::lock_guard<std::mutex> lock(failing);
                if (!failure) failure = std::current_exception();
            }
        }
    };
    std::vector<std::thread> threads;
    const int jobs = std::min(settings_.jobs, static_cast<int>(targets.size()));
    for (int j = 0; j < jobs; ++j) threads.emplace_back(builder);
    for (std::thread& thread : threads) thread.join();
    if (interrupted) throw Interrupted{};
    if (failure) std::rethrow_exception(failure);
    build_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                             build_start).count();
    std::ofstream log(settings_.out / "build.txt", std::ios::binary | std::ios::trunc);
    for (size_t n = 0; n < targets.size(); ++n) {
        const std::string& name = targets[n];
        if (!keys[n].empty()) build_keys_[name] = keys[n];
        builds_reused_ += reused[n];
        if (reused[n]) {
            log << name << ": the class cache's binary of this source, byte for byte\n";
            continue;
        }
        const Outcome& outcome = outcomes[n];
        log << outcome.out << outcome.err;
        if (made[n]) continue;
        // The compiler's first error in this step's file.
        std::string first;
        for (const std::string& line : lines_of(outcome.err + outcome.out)) {
            if (line.rfind("steps/" + name + ".cpp:", 0) == 0 &&
                line.find("error") != std::string::npos) {
                first = line;
                break;
            }
        }
        if (first.empty()) {
            first = !outcome.stop_reason().empty() ? "the build " + outcome.stop_reason()
                        : "no error in steps/" + name + ".cpp (see build.txt)";
        }
        not_built_[name] = "does not compile: " + first;
    }
}

// "build/02_threshold --volume phantom --view top --threshold 500 --debug-pixel 12,40".
std::string Grader::command_for(const Step& step, const Run& run, const std::string& view,
                                const std::string& more) const {
    // --build: the command as the student runs it in their own tree.
    std::string text = (stage_ ? "build/" + step.name : relative_to(settings_.bin / step.name,
                                                                      cwd_)) +
                       " --volume " + settings_.volume;
    if (!settings_.volume_args.empty()) text += " " + join(settings_.volume_args);
    const bool chooses_view = std::find(run.arguments.begin(), run.arguments.end(),
                                        "--view") != run.arguments.end();
    // Only the axis views are chosen with --view; the free camera's picture is the one a
    // part-2 step renders without it (it has no --view camera).
    const bool axis_view = std::find(views.begin(), views.end(), view) != views.end();
    if (!chooses_view && axis_view) text += " --view " + view;
    if (!run.arguments.empty()) text += " " + join(run.arguments);
    if (!settings_.extra_args.empty()) text += " " + join(settings_.extra_args);
    return text + more;
}

bool Grader::grade_counters(const Run& run, const std::string& view, const Summary& student,
                            StepResult& result) {
    if (!counters_ || run.counters.empty()) return false;
    const auto found = counters_->find({run.name, view});
    if (found == counters_->end()) return false;  // the reference run has no line for this view
    const Summary& reference = found->second;
    std::vector<std::string> differ;
    ++result.counters;
    for (const std::string& counter : run.counters) {
        const auto expected = reference.find(counter);
        if (expected == reference.end()) continue;
        const auto got = student.find(counter);
        if (got != student.end() && got->second == expected->second) continue;
        differ.push_back(counter + "=" + (got == student.end() ? "(none)" : got->second) +
                         " where the reference run has " + counter + "=" + expected->second);
    }
    if (differ.empty()) {
        ++result.counters_passed;
        return false;
    }
    std::string text = "counter " + differ[0] + " (" + run.name + ", " + view + ")";
    if (differ.size() > 1) {
        text += "; also ";
        for (size_t d = 1; d < differ.size(); ++d) {
            text += (d > 1 ? ", " : "") + differ[d].substr(0, differ[d].find(' '));
        }
    }
    // Samples and leapt trade one for one: their sum is the samples without leaping.
    auto number = [](const Summary& fields, const std::string& key) -> long long {
        const auto it = fields.find(key);
        return it == fields.end() ? -1 : std::atoll(it->second.c_str());
    };
    if (number(student, "samples") != number(reference, "samples") &&
        number(reference, "leapt") >= 0 &&
        number(student, "samples") + number(student, "leapt") ==
            number(reference, "samples") + number(reference, "leapt")) {
        text += ": samples+leapt is right, so every sample is read or leapt over, but the "
                "leaps are too short or too long";
    } else {
        // What the first counter that differs usually points at.
        static const std::map<std::string, std::string> hints = {
            {"samples", "a loop's range, or where a ray stops (object order, steps 35 on: "
                        "which slices, rows and voxels a row of the intermediate image reads)"},
            {"skipped", "which samples count as transparent (opacity 0) and are skipped"},
            {"leapt", "the samples leapt over: where the ray's samples begin and end, the "
                      "bricks, how far each leap goes"},
            {"gradients", "where a gradient is computed: only where the picture needs one"},
            {"terminated", "where a ray (object order: an intermediate pixel) stops early: "
                           "the test against --ert (default 0.01)"},
            {"hits", "the hit test: the threshold, > or >=, the loop's range"}};
        const std::string first = differ[0].substr(0, differ[0].find('='));
        const auto hint = hints.find(first);
        if (hint != hints.end()) text += ": look at " + hint->second;
    }
    result.problems.push_back(text);
    result.look_at.push_back(text);
    return true;
}

// The run again with --work-map, each ray's counters against the reference's (REFERENCE/work/
// RUN_VIEW_work.txt, or the solution's binary run the same way when this lab has it): the first
// ray, row by row, whose counts differ; with the solution's binary, both rays traced there and
// the first record where they part.
void Grader::first_ray_apart(const Step& step, const Run& run, const std::string& view,
                             const fs::path& folder, StepResult& result) {
    const bool axis_view = std::find(views.begin(), views.end(), view) != views.end();
    auto arguments_for = [&](const fs::path& out, const std::vector<std::string>& more) {
        std::vector<std::string> arguments = first_arguments(out);
        arguments.insert(arguments.end(), run.arguments.begin(), run.arguments.end());
        arguments.insert(arguments.end(), settings_.extra_args.begin(),
                         settings_.extra_args.end());
        if (axis_view) arguments.insert(arguments.end(), {"--view", view});
        arguments.insert(arguments.end(), more.begin(), more.end());
        return arguments;
    };
    auto fresh = [](const fs::path& path) {
        std::error_code error;
        fs::remove_all(path, error);
        make_folder(path.string());
        return path;
    };
    std::error_code error;
    const fs::path reference_program = reference_bin_ / step.name;
    const bool has_reference_program =
        !reference_bin_.empty() && fs::is_regular_file(reference_program, error);
    const std::string map_name = step.name + "_" + view + "_work.txt";

    WorkMap reference;
    bool have_reference =
        read_work_map(settings_.reference / "work" / (run.name + "_" + view + "_work.txt"),
                      reference);
    if (!have_reference && has_reference_program) {
        const fs::path out = fresh(folder / ("work_reference_" + view));
        const Outcome outcome = run_step_process(reference_program,
                                                 arguments_for(out, {"--work-map"}),
                                                 settings_.tree, out, settings_.timeout_s);
        have_reference = outcome.exit_status == 0 && read_work_map(out / map_name, reference);
    }
    if (!have_reference) return;  // nothing to compare the rays with
    // The probe rays that probe_rays traces next, traced in this run too: --debug-pixel
    // leaves the work map and the summary line as they are, and the picture is rendered once
    // instead of twice. When that run fails, the work map alone, as before.
    const fs::path yours_out = fresh(folder / ("work_" + view));
    std::vector<std::string> more = {"--work-map"};
    for (const Probe& probe : probes_of(run, view)) {
        more.insert(more.end(), {"--debug-pixel",
                                 std::to_string(probe.x) + "," + std::to_string(probe.y)});
    }
    Outcome outcome = execute(step, arguments_for(yours_out, more), yours_out);
    auto ran = [](const Outcome& ended) {
        return !ended.timed_out && ended.signal == 0 && ended.exit_status == 0;
    };
    if (more.size() > 1) {
        if (ran(outcome)) {
            probes_traced_[run.name + " " + view] = yours_out;
        } else {
            fresh(yours_out);
            outcome = execute(step, arguments_for(yours_out, {"--work-map"}), yours_out);
        }
    }
    WorkMap yours;
    if (!ran(outcome) || !read_work_map(yours_out / map_name, yours) ||
        yours.width != reference.width || yours.height != reference.height) {
        return;
    }
    size_t first = yours.rays.size();
    size_t apart = 0;
    for (size_t n = 0; n < yours.rays.size(); ++n) {
        if (yours.rays[n] == reference.rays[n]) continue;
        if (first == yours.rays.size()) first = n;
        ++apart;
    }
    if (first == yours.rays.size()) return;  // each ray alone agrees: the sum differs elsewhere
    const int x = static_cast<int>(first % size_t(yours.width));
    const int y = static_cast<int>(first / size_t(yours.width));
    const std::string pixel = std::to_string(x) + "," + std::to_string(y);
    std::string text = run.name + " " + view + ": the first ray whose work differs is pixel " +
        pixel + " (" + std::to_string(apart) + " of " + std::to_string(yours.rays.size()) +
        " rays differ)\n        yours:     " + ray_work_text(yours.rays[first]) +
        "\n        reference: " + ray_work_text(reference.rays[first]) +
        "\n      trace it:     " + command_for(step, run, view, " --debug-pixel " + pixel);
    if (has_reference_program) {  // where along the ray the two part
        const std::string xy = std::to_string(x) + "_" + std::to_string(y);
        const std::string sidecar = step.name + "_" + view + "_ray_" + xy + ".txt";
        const fs::path traced_yours = fresh(folder / ("work_ray_" + view));
        const fs::path traced_reference = fresh(folder / ("work_ray_reference_" + view));
        // Only the one ray is cast, and no ray picture drawn: the sidecars are all that is read.
        const std::vector<std::string> trace_one = {"--debug-pixel", pixel, "--trace-only",
                                                    "--no-ray-picture"};
        const Outcome mine = execute(step, arguments_for(traced_yours, trace_one), traced_yours);
        const Outcome theirs =
            run_step_process(reference_program, arguments_for(traced_reference, trace_one),
                             settings_.tree, traced_reference, settings_.timeout_s);
        if (mine.exit_status == 0 && theirs.exit_status == 0 &&
            fs::is_regular_file(traced_yours / sidecar, error) &&
            fs::is_regular_file(traced_reference / sidecar, error)) {
            const std::string difference = first_difference(
                read_trace(traced_yours / sidecar), read_trace(traced_reference / sidecar));
            if (!difference.empty()) text += "\n      its trace leaves the reference's at " +
                                             difference;
        }
    }
    result.problems.push_back(text);
    result.look_at.push_back(text);
}

void Grader::grade_picture(const Step& step, const Run& run, const std::string& view,
                           const fs::path& folder, StepResult& result) {
    const fs::path reference_path = reference_picture(step, run, view);
    const std::string reference_name = reference_path.filename().string();
    const fs::path student_path = folder / (step.name + "_" + view + ".png");
    auto problem = [&](const std::string& text, bool first = true) {
        result.problems.push_back(reference_name + ": " + text);
        if (first) result.look_at.push_back(reference_name + ": " + text);
    };
    std::error_code error;
    if (!fs::is_regular_file(fs::symlink_status(student_path, error))) {
        problem("the run wrote no " + student_path.filename().string());
        return;
    }
    const Image reference = read_image(reference_path.string());  // bad input: stops the grade
    Image student;
    try {
        student = read_image(student_path.string());
    } catch (const InputError& failure) {
        problem(std::string("cannot be read: ") + failure.what());
        return;
    }
    if (!same_size(student, reference)) {
        problem("is " + std::to_string(student.width) + "x" + std::to_string(student.height) +
                ", the reference is " + std::to_string(reference.width) + "x" +
                std::to_string(reference.height) + ": rendered another view, or a loop over "
                "the wrong axis?");
        return;
    }
    const Comparison comparison = compare_images(student, reference, run.tolerance,
                                                 student_path.string(), reference_name);
    if (comparison.pass) {
        ++result.pictures_passed;
        return;
    }
    // Graded on another volume than the kit's phantom: a picture that is the kit's own
    // reference was not rendered from the volume this run was given.
    const fs::path kit_path = kit_reference_ / reference_name;
    if (!kit_reference_.empty() &&
        fs::is_regular_file(fs::symlink_status(kit_path, error)) &&
        passes(student, read_image(kit_path.string()), run.tolerance)) {
        problem("matches the kit's phantom reference, not the volume it was given (" +
                settings_.volume + "): pictures copied or rendered from another volume");
        return;
    }
    const Worst worst = worst_pixel(student, reference);
    const std::string xy = std::to_string(worst.x) + "," + std::to_string(worst.y);
    char numbers[160];
    std::snprintf(numbers, sizeof numbers,
                  "fails: %.2f%% of the pixels differ by more than %g; the worst, %d levels, "
                  "at pixel %s", comparison.over_tol_pct, run.tolerance, worst.error,
                  xy.c_str());
    // A stub's picture: its TODO lines say what to write, and the table shows those alone.
    // The figures go to report.txt; the side-by-side picture and the turned, mirrored and
    // other views' comparisons (most of a stub run's grading cost) are left out, as a step
    // not started is not traced.
    if (result.status == Status::not_started) {
        problem(numbers);
        return;
    }
    const fs::path pair_path = settings_.out / "side_by_side" / reference_name;
    make_folder(pair_path.parent_path().string());
    write_png(side_by_side(student, reference, run.tolerance), pair_path.string());
    std::string text = std::string(numbers) + "\n      trace it:     " +
                       command_for(step, run, view, " --debug-pixel " + xy) +
                       "\n      side by side: " + relative_to(pair_path, cwd_) +
                       " (yours | reference | differences)";
    // A picture that is right for another view, or right but turned: the axes are swapped.
    for (const std::string& other : views) {
        if (other == view) continue;
        const fs::path other_path = reference_picture(step, run, other);
        if (!fs::is_regular_file(fs::symlink_status(other_path, error))) continue;
        if (passes(student, read_image(other_path.string()), run.tolerance)) {
            text += "\n      it matches the " + other + " view's reference: swapped axes?";
        }
    }
    if (passes(transposed(student), reference, run.tolerance)) {
        text += "\n      it matches the reference turned about its diagonal: x and y (or the "
                "two image axes' voxel indices) swapped?";
    }
    if (passes(mirrored(student, true), reference, run.tolerance)) {
        text += "\n      it matches the reference mirrored left to right: an axis reversed?";
    }
    if (passes(mirrored(student, false), reference, run.tolerance)) {
        text += "\n      it matches the reference upside down: image row = k, k = 0 at the top";
    }
    problem(text);
}

std::vector<Probe> Grader::probes_of(const Run& run, const std::string& view) const {
    const fs::path probes_path = settings_.reference / "probes.txt";
    std::error_code error;
    std::vector<Probe> probes;
    if (!fs::is_regular_file(fs::symlink_status(probes_path, error))) return probes;
    std::istringstream lines(read_bounded(probes_path, max_manifest_bytes));
    for (std::string line; std::getline(lines, line);) {
        const std::vector<std::string> words = split_words(line.substr(0, line.find('#')));
        if (words.size() < 3 || words[0] != run.name || words[1] != view) continue;
        // X,Y as --debug-pixel takes it: a bad one is the instructor's file at fault.
        const size_t comma = words[2].find(',');
        if (comma == std::string::npos) {
            throw InputError(probes_path.string() + ": expected X,Y after '" + run.name + " " +
                             view + "', got '" + words[2] + "'");
        }
        Probe probe;
        probe.view = view;
        probe.x = parse_int(probes_path.string() + ": x", words[2].substr(0, comma), 0, INT_MAX);
        probe.y = parse_int(probes_path.string() + ": y", words[2].substr(comma + 1), 0, INT_MAX);
        const std::string xy = std::to_string(probe.x) + "_" + std::to_string(probe.y);
        const fs::path reference_trace =
            settings_.reference / "traces" / (run.name + "_" + view + "_ray_" + xy + ".txt");
        if (fs::is_regular_file(fs::symlink_status(reference_trace, error))) {
            probes.push_back(probe);
        }
    }
    return probes;
}

void Grader::probe_rays(const Step& step, const Run& run, const std::string& view,
                        const fs::path& folder, StepResult& result) {
    std::error_code error;
    const auto traced = probes_traced_.find(run.name + " " + view);
    std::vector<std::string> agreed;
    for (const Probe& probe : probes_of(run, view)) {
        const std::string xy = std::to_string(probe.x) + "_" + std::to_string(probe.y);
        const fs::path reference_trace =
            settings_.reference / "traces" / (run.name + "_" + view + "_ray_" + xy + ".txt");
        const std::string pixel = std::to_string(probe.x) + "," + std::to_string(probe.y);
        // Traced already by first_ray_apart's run, or here in a run of its own.
        bool ended = true;
        fs::path probe_folder;
        if (traced != probes_traced_.end()) {
            probe_folder = traced->second;
        } else {
            probe_folder = folder / ("probe_" + view + "_" + xy);
            fs::remove_all(probe_folder, error);
            make_folder(probe_folder.string());
            std::vector<std::string> arguments = first_arguments(probe_folder);
            arguments.insert(arguments.end(), run.arguments.begin(), run.arguments.end());
            arguments.insert(arguments.end(), settings_.extra_args.begin(),
                             settings_.extra_args.end());
            if (std::find(views.begin(), views.end(), view) != views.end()) {
                arguments.insert(arguments.end(), {"--view", view});
            }
            // The probe's ray and the pixels its ray picture shows, not the whole picture
            // again (a run of its own: a crash while tracing is "could not be traced").
            arguments.insert(arguments.end(), {"--debug-pixel", pixel, "--trace-only"});
            const Outcome outcome = execute(step, arguments, probe_folder);
            ended = !outcome.timed_out && outcome.signal == 0 && outcome.exit_status == 0;
        }
        const fs::path yours_path =
            probe_folder / (step.name + "_" + view + "_ray_" + xy + ".txt");
        const std::string command = command_for(step, run, view, " --debug-pixel " + pixel);
        std::string text = run.name + " " + view + ": the probe ray " + pixel + " ";
        if (!ended || !fs::is_regular_file(fs::symlink_status(yours_path, error))) {
            text += "could not be traced: " + command;
        } else {
            const std::string difference =
                first_difference(read_trace(yours_path), read_trace(reference_trace));
            if (difference.empty()) {
                agreed.push_back(pixel);
                continue;
            }
            text += "leaves the reference's at " + difference +
                    "\n        both traces: " + relative_to(yours_path, cwd_) + " | " +
                    relative_to(reference_trace, cwd_) + "; the ray drawn: " +
                    relative_to(probe_folder / (step.name + "_" + view + "_ray_" + xy + ".png"),
                                cwd_);
        }
        result.problems.push_back(text);
        result.look_at.push_back(text);
        return;  // the first probe that differs is enough to look at
    }
    if (!agreed.empty()) {
        result.problems.push_back(run.name + " " + view + ": the probe rays " + join(agreed) +
                                  " agree with the reference's traces");
    }
}

void Grader::grade_run(const Step& step, const Run& run, StepResult& result) {
    const fs::path folder = settings_.out / run.name;
    std::error_code error;
    fs::remove_all(folder, error);  // pictures of an earlier run never pass (not followed)
    if (error) throw InputError("cannot empty '" + folder.string() + "': " + error.message());
    make_folder(folder.string());

    std::vector<std::string> arguments = first_arguments(folder);
    const bool chooses_view =
        std::find(run.arguments.begin(), run.arguments.end(), "--view") != run.arguments.end();
    if (!settings_.view.empty() && !chooses_view) {
        arguments.push_back("--view");
        arguments.push_back(settings_.view);
    }
    arguments.insert(arguments.end(), run.arguments.begin(), run.arguments.end());
    arguments.insert(arguments.end(), settings_.extra_args.begin(), settings_.extra_args.end());
    ++result.runs;
    std::vector<std::string> graded_views;  // those the reference run rendered
    for (const std::string& view : pictures) {
        if (!settings_.view.empty() && view != settings_.view) continue;
        if (fs::is_regular_file(fs::symlink_status(reference_picture(step, run, view), error))) {
            graded_views.push_back(view);
        }
    }
    result.pictures += static_cast<int>(graded_views.size());
    const Outcome outcome = execute(step, arguments, folder);
    const std::string command = command_for(step, run, settings_.view);

    // Stubs still in the code: their TODO lines (common/not_done.cpp) say what to write.
    for (const std::string& line : lines_of(outcome.err)) {
        if (line.rfind("TODO: ", 0) != 0) continue;
        result.status = Status::not_started;
        if (std::find(result.look_at.begin(), result.look_at.end(), line) == result.look_at.end()) {
            result.look_at.push_back(line);
            result.problems.push_back(line);
        }
    }
    if (outcome.timed_out) {
        result.status = std::max(result.status, Status::failing);
        const std::string text = run.name + ": " +
            (outcome.err.rfind("not run: ", 0) == 0
                 ? outcome.err.substr(0, outcome.err.find('\n'))
                 : "stopped after " + std::to_string(static_cast<int>(outcome.seconds + 0.5)) +
                       " s: a loop that never ends? run it yourself: " + command);
        result.problems.push_back(text);
        result.look_at.push_back(text);
        return;
    }
    if (outcome.output_exceeded) {
        result.status = std::max(result.status, Status::failing);
        const std::string text = run.name + ": stopped: " +
            (outcome.err.rfind("check: ", 0) == 0
                 ? outcome.err.substr(7, outcome.err.find('\n') - 7)
                 : "it printed more than " + readable_size(max_output_bytes)) +
            " (a print inside a loop?)";
        result.problems.push_back(text);
        result.look_at.push_back(text);
        return;
    }
    if (outcome.signal != 0) {
        if (result.status != Status::not_started) result.status = Status::crashed;
        const std::string text = run.name + ": crashed with " + signal_name(outcome.signal) +
            "\n      to see the line (this step with AddressSanitizer and UBSan): make san STEP=" +
            step.name.substr(0, 2) +
            (run.arguments.empty() && settings_.extra_args.empty() ? std::string()
                 : " ARGS='" + join(run.arguments) +
                       (settings_.extra_args.empty() ? "" : " " + join(settings_.extra_args)) +
                       "'");
        result.problems.push_back(text);
        result.look_at.insert(result.look_at.begin(), text);
        return;
    }
    // A step built with the sanitizers (make san, SAN=1) exits with their report instead.
    std::string sanitizer;
    for (const std::string& line : lines_of(outcome.err)) {
        if (line.find("ERROR: AddressSanitizer") != std::string::npos ||
            line.find("runtime error:") != std::string::npos) {
            if (sanitizer.empty()) sanitizer = line;
        }
        if (line.rfind("SUMMARY: ", 0) == 0) sanitizer = line;  // names the file and line
    }
    if (outcome.exit_status != 0 && !sanitizer.empty()) {
        if (result.status != Status::not_started) result.status = Status::crashed;
        const std::string text = run.name + ": the sanitizers stopped it: " + sanitizer +
                                 "\n      the whole report: " + command;
        result.problems.push_back(text);
        result.look_at.insert(result.look_at.begin(), text);
        return;
    }
    if (outcome.exit_status != 0) {
        if (result.status == Status::passing) result.status = Status::failing;
        std::string first_error;
        for (const std::string& line : lines_of(outcome.err)) {
            if (line.rfind("TODO: ", 0) != 0) {
                first_error = line;
                break;
            }
        }
        const std::string text = run.name + ": exited with status " +
            std::to_string(outcome.exit_status) + (first_error.empty() ? "" : ": " + first_error) +
            "\n      run it yourself: " + command;
        result.problems.push_back(text);
        result.look_at.push_back(text);
        return;
    }

    std::map<std::string, Summary> summaries;  // view -> its summary line
    for (const std::string& line : lines_of(outcome.out)) {
        if (line.rfind("step=", 0) != 0) continue;
        Summary fields = parse_summary(line);
        summaries[fields["view"]] = fields;
    }
    const size_t problems_before = result.problems.size();
    // A stub's ray says nothing the TODO line does not: a step not started is not traced.
    const bool trace = result.status != Status::not_started &&
                       (result.traced_run.empty() || result.traced_run == run.name);
    for (const std::string& view : graded_views) {
        const size_t problems_of_view = result.problems.size();
        grade_picture(step, run, view, folder, result);
        const auto summary = summaries.find(view);
        if (summary == summaries.end()) {
            const std::string text = run.name + ": printed no summary line for the " + view +
                                     " view (step=... view=" + view + " ...)";
            result.problems.push_back(text);
            result.look_at.push_back(text);
        } else {
            // Pictures right, work not: name the ray whose work differs.
            const bool pictures_fine = result.problems.size() == problems_of_view;
            if (grade_counters(run, view, summary->second, result) && pictures_fine && trace) {
                first_ray_apart(step, run, view, folder, result);
            }
        }
        if (result.problems.size() > problems_of_view && trace) {
            probe_rays(step, run, view, folder, result);
        }
    }
    if (result.problems.size() > problems_before) {
        if (result.status == Status::passing) result.status = Status::failing;
        if (trace) {
            result.traced_run = run.name;
        } else if (result.status != Status::not_started) {
            result.problems.push_back(run.name + ": its rays not traced (" + result.traced_run +
                                      "'s are: mend that run first)");
        }
    }
}

StepResult Grader::grade_step(const Step& step) {
    StepResult result;
    const fs::path binary = settings_.bin / step.name;
    const fs::path source = settings_.tree / "steps" / (step.name + ".cpp");
    std::error_code error;
    if (stage_) {
        const auto why = not_built_.find(step.name);
        if (why != not_built_.end()) {
            result.status = Status::not_built;
            result.look_at.push_back(why->second);
            result.problems.push_back(why->second);
            return result;
        }
    }
    const bool built = fs::is_regular_file(binary, error) && access(binary.c_str(), X_OK) == 0;
    if (stage_) {
        // Built from the tree's sources in the sandbox: what TREE/build holds plays no part.
    } else if (!built || (fs::exists(source, error) &&
                   fs::last_write_time(source, error) > fs::last_write_time(binary, error))) {
        result.status = Status::not_built;
        const std::string text = std::string(built ? "steps/" + step.name + ".cpp is newer "
                                                     "than " + relative_to(binary, cwd_)
                                                   : relative_to(binary, cwd_) + " is not built") +
            ": make " + step.name + " shows why (the compiler's first error)";
        result.look_at.push_back(text);
        result.problems.push_back(text);
        return result;
    }
    for (const Run& run : step.runs) grade_run(step, run, result);
    if (result.status == Status::passing && result.pictures == 0) {
        result.status = Status::failing;
        const std::string text = "no reference picture for this step in " +
                                 settings_.reference.string() + ": make reference";
        result.problems.push_back(text);
        result.look_at.push_back(text);
    }
    return result;
}

int Grader::run() {
    cwd_ = fs::current_path();
    std::error_code error;
    if (!fs::is_directory(settings_.tree / "steps", error)) {
        throw InputError("--tree: '" + settings_.tree.string() + "' has no steps/ folder");
    }
    if (!fs::is_directory(settings_.reference, error)) {
        throw InputError("reference folder '" + settings_.reference.string() +
                         "' does not exist");
    }
    if (fs::is_symlink(settings_.out, error)) {
        throw InputError("--out: '" + settings_.out.string() + "' is a symbolic link");
    }

    // A stranger's tree is graded on the lab's steps: a step it lacks is not built, not absent.
    if (settings_.build && settings_.lab.empty()) {
        settings_.lab = fs::path(build_folder()).parent_path();
    }
    if (settings_.build && fs::is_symlink(settings_.tree / "steps", error)) {
        throw InputError("--tree: '" + (settings_.tree / "steps").string() +
                         "' is a symbolic link: not followed");
    }
    const fs::path steps_folder = settings_.build ? settings_.lab / "steps"
                                                  : settings_.tree / "steps";
    std::vector<std::string> names;
    for (const fs::directory_entry& entry : fs::directory_iterator(steps_folder)) {
        const std::string name = entry.path().filename().string();
        if (name.size() > 7 && std::isdigit(static_cast<unsigned char>(name[0])) &&
            std::isdigit(static_cast<unsigned char>(name[1])) && name[2] == '_' &&
            entry.path().extension() == ".cpp") {
            names.push_back(entry.path().stem().string());
        }
    }
    std::sort(names.begin(), names.end());
    if (settings_.build) {  // the reference folder's pictures say which steps are assigned
        std::set<std::string> assigned;
        for (const fs::directory_entry& entry : fs::directory_iterator(settings_.reference)) {
            const std::string file = entry.path().filename().string();
            if (entry.path().extension() != ".png") continue;
            for (const std::string& name : names) {
                if (file.rfind(name + "_", 0) == 0) assigned.insert(name);
            }
        }
        names.assign(assigned.begin(), assigned.end());
    }
    if (!settings_.steps.empty()) {
        std::vector<std::string> chosen;
        for (const std::string& wanted : settings_.steps) {
            bool found = false;
            for (const std::string& name : names) {
                if (name == wanted || name.substr(0, 2) == wanted) {
                    if (std::find(chosen.begin(), chosen.end(), name) == chosen.end()) {
                        chosen.push_back(name);
                    }
                    found = true;
                }
            }
            if (!found) {
                throw InputError("--step " + wanted + ": no such step in " +
                                 steps_folder.string());
            }
        }
        std::sort(chosen.begin(), chosen.end());
        names = chosen;
    }
    const fs::path manifest_path = settings_.reference / "manifest.txt";
    if (!fs::is_regular_file(manifest_path, error)) {
        throw InputError("no " + manifest_path.string() + ": the runs to grade are listed there");
    }
    std::vector<Step> steps = read_manifest(manifest_path, names);
    if (!settings_.runs.empty()) {  // the steps that have one of the runs, with those alone
        for (const std::string& wanted : settings_.runs) {
            bool found = false;
            for (const Step& step : steps) {
                for (const Run& run : step.runs) found = found || run.name == wanted;
            }
            if (!found) {
                throw InputError("--run " + wanted + ": no such run of the steps graded in " +
                                 manifest_path.string());
            }
        }
        auto chosen = [&](const Run& run) {
            return std::find(settings_.runs.begin(), settings_.runs.end(), run.name) !=
                   settings_.runs.end();
        };
        for (Step& step : steps) {
            step.runs.erase(std::remove_if(step.runs.begin(), step.runs.end(),
                                           [&](const Run& run) { return !chosen(run); }),
                            step.runs.end());
        }
        steps.erase(std::remove_if(steps.begin(), steps.end(),
                                   [](const Step& step) { return step.runs.empty(); }),
                    steps.end());
    }
    counters_ = read_counters(settings_.reference / "counters.txt");
    // A reference folder made from another volume says which (make reference VOLUME=...).
    const fs::path volume_record = settings_.reference / "volume.txt";
    if (fs::is_regular_file(fs::symlink_status(volume_record, error))) {
        std::istringstream lines(read_bounded(volume_record, max_manifest_bytes));
        for (std::string line; std::getline(lines, line);) {
            if (line.rfind("volume:", 0) == 0 && settings_.volume.empty()) {
                settings_.volume = trim(line.substr(7));
            } else if (line.rfind("arguments:", 0) == 0) {
                settings_.volume_args = split_words(line.substr(10));
            }
        }
    }
    if (settings_.volume.empty()) settings_.volume = "phantom";
    if (settings_.volume != "phantom") {
        const fs::path kit = (settings_.build ? settings_.lab : settings_.tree) / "data" /
                             "reference";
        if (fs::is_directory(kit, error) && !fs::equivalent(kit, settings_.reference, error)) {
            kit_reference_ = kit;
        }
    }
    // The solution's own steps, beside this program in a lab (not a student kit): the rays of
    // a run whose work differs are compared with theirs. Not when they are the steps graded.
    {
        const fs::path own = fs::path(build_folder());
        const fs::path graded = settings_.build ? fs::path() : settings_.bin;
        if (!fs::exists(own.parent_path() / ".ctlab-student", error) &&
            fs::is_directory(own.parent_path() / "steps", error) &&
            (graded.empty() || !fs::equivalent(own, graded, error))) {
            reference_bin_ = own;
        }
    }
    make_folder(settings_.out.string());
    fs::remove_all(settings_.out / "side_by_side", error);
    if (settings_.build) {
        // A stranger's programs run only in the sandbox, unless the instructor says otherwise.
        if (!sandbox_problem().empty() && !settings_.no_sandbox) {
            throw InputError("no sandbox: " + sandbox_problem() + "; the tree's programs are "
                             "not built or run (--no-sandbox runs them unconfined)");
        }
        std::vector<std::string> step_names;
        for (const Step& step : steps) step_names.push_back(step.name);
        stage_and_build(step_names);
    }

    std::printf("grading %zu step%s of %s against %s on %s%s\n", steps.size(),
                steps.size() == 1 ? "" : "s", relative_to(settings_.tree, cwd_).c_str(),
                relative_to(settings_.reference, cwd_).c_str(), settings_.volume.c_str(),
                counters_ ? "" : " (no counters.txt there: counters not checked)");
    std::fflush(stdout);

    std::string report = "# check report\n\n";
    int passing = 0;
    std::map<Status, int> counts;
    std::vector<std::pair<std::string, StepResult>> results;
    const int name_width = 24, status_width = 12;
    std::printf("%-*s %-*s %9s %9s\n", name_width, "step", status_width, "status", "pictures",
                "counters");
    for (const Step& step : steps) {
        const StepResult result = grade_step(step);
        ++counts[result.status];
        passing += result.status == Status::passing;
        const std::string pictures =
            result.runs ? std::to_string(result.pictures_passed) + "/" +
                              std::to_string(result.pictures) : "-";
        const std::string counters =
            result.counters ? std::to_string(result.counters_passed) + "/" +
                                  std::to_string(result.counters) : "-";
        std::printf("%-*s %-*s %9s %9s\n", name_width, step.name.c_str(), status_width,
                    status_text(result.status), pictures.c_str(), counters.c_str());
        // A step still holding stubs: what to write is all there is to look at. In a kit, the
        // step's own functions first, then those `make carry` brings (a part-3 step takes 20
        // or more from an earlier step: its own were left out of the lines shown).
        std::vector<std::string> look_at, to_carry;
        const std::set<std::string> carried =
            result.status == Status::not_started && !settings_.build
                ? carried_functions(settings_.tree, step.name) : std::set<std::string>{};
        const std::string todo = "TODO: " + step.name + ": ";
        for (const std::string& line : result.look_at) {
            if (result.status != Status::not_started || line.rfind("TODO: ", 0) == 0) {
                const size_t end = line.find("()", todo.size());
                const bool brought = line.rfind(todo, 0) == 0 && end != std::string::npos &&
                                     carried.count(line.substr(todo.size(), end - todo.size()));
                (brought ? to_carry : look_at).push_back(line);
            }
        }
        if (!to_carry.empty()) {
            look_at.push_back("the " + std::to_string(to_carry.size()) + " below are your " +
                              "earlier steps' functions: `make carry STEP=" +
                              step.name.substr(0, 2) + "` copies them in");
            look_at.insert(look_at.end(), to_carry.begin(), to_carry.end());
        }
        int shown = 0;
        for (const std::string& line : look_at) {
            if (shown++ == max_details) {
                std::printf("    ... %zu more in %s\n", look_at.size() - max_details,
                            relative_to(settings_.out / "report.txt", cwd_).c_str());
                break;
            }
            std::printf("    %s\n", line.c_str());
        }
        std::fflush(stdout);
        report += step.name + ": " + status_text(result.status) + ", pictures " + pictures +
                  ", counters " + counters + "\n";
        for (const std::string& problem : result.problems) report += "  " + problem + "\n";
    }
    std::string summary = std::to_string(steps.size()) + " step" +
                          (steps.size() == 1 ? "" : "s") + ": ";
    bool first = true;
    for (Status status : {Status::passing, Status::failing, Status::crashed,
                          Status::not_started, Status::not_built}) {
        if (!counts[status] && status != Status::passing) continue;
        summary += std::string(first ? "" : ", ") + std::to_string(counts[status]) + " " +
                   status_text(status);
        first = false;
    }
    const bool all_pass = passing == static_cast<int>(steps.size());
    summary += std::string("; result=") + (all_pass ? "pass" : "fail");
    report += "\n" + summary + "\n";
    if (stage_) {  // what a class's timing table is made of
        char times[96];
        std::snprintf(times, sizeof times, "time: build %.1f s, runs %.1f s\n", build_s_,
                      settings_.budget_s - seconds_left() - build_s_);
        report += times;
        if (cache_) {  // what the class cache saved this tree (build/grade sums them)
            report += "cache: builds reused " + std::to_string(builds_reused_) + "/" +
                      std::to_string(builds_) + ", runs reused " +
                      std::to_string(runs_reused_) + "/" + std::to_string(runs_) + "\n";
        }
    }
    {
        const fs::path path = settings_.out / "report.txt";
        fs::remove(path, error);
        const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW, 0644);
        if (fd >= 0) {
            const ssize_t written = ::write(fd, report.data(), report.size());
            (void)written;
            ::close(fd);
        }
    }
    std::printf("%s\n", summary.c_str());
    return all_pass ? exit_pass : exit_fail;
}

}  // namespace

int main(int argc, char** argv) {
    for (int signal : {SIGINT, SIGTERM, SIGHUP}) {
        std::signal(signal, [](int) { interrupted = 1; });
    }
    try {
        return Grader(parse_arguments(argc, argv)).run();
    } catch (const Interrupted&) {
        std::fprintf(stderr, "check: interrupted\n");
        return 128 + SIGINT;
    } catch (const InputError& error) {
        std::fprintf(stderr, "check: error: %s\n", error.what());
        return exit_bad_input;
    } catch (const std::exception& error) {
        std::fprintf(stderr, "check: internal error: %s\n", error.what());
        return exit_fail;
    }
}
