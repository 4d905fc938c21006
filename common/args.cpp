// args.cpp: strict parsing of the shared flags and a step's own.
#include "args.h"
#include <dirent.h>
#include <sys/stat.h>
#include <cctype>
#include <fstream>
#include <sstream>
#include <algorithm>
#include <unistd.h>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include "error.h"
#include "file_input.h"
#include "formats.h"
#include "phantom.h"

namespace ctlab {

static const char* const default_cthead_path = "data/CThead";
static const char* const presets_folder = "data/presets";
static bool is_file_units_flag(const std::string& flag);
static Volume load_volume_anew(const Options& options);
constexpr int max_threads = 256;
constexpr int max_repeat = 1000;  // renders of one view for --repeat: enough for a median

void parse_size(const std::string& text, int max_side, int* width, int* height) {
    const size_t cross = text.find('x');
    if (cross == std::string::npos) {
        throw InputError("--size: expected WIDTHxHEIGHT such as 512x512, got '" + text + "'");
    }
    *width = parse_int("--size", text.substr(0, cross), 1, max_side);
    *height = parse_int("--size", text.substr(cross + 1), 1, max_side);
}

int parse_int(const std::string& flag, const std::string& text, int min, int max) {
    errno = 0;
    char* end = nullptr;
    const long value = std::strtol(text.c_str(), &end, 10);
    if (text.empty() || *end != '\0' || text.find_first_of(" \t") == 0) {
        throw InputError(flag + ": expected a whole number, got '" + text + "'");
    }
    if (errno == ERANGE || value < min || value > max) {  // ERANGE: beyond even a long
        throw InputError(flag + ": expected a whole number from " + std::to_string(min) +
                         " to " + std::to_string(max) + ", got " + text);
    }
    return static_cast<int>(value);
}

static std::string number_text(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", value);
    return text;
}

double parse_double(const std::string& flag, const std::string& text, double min, double max) {
    errno = 0;
    char* end = nullptr;
    const double value = std::strtod(text.c_str(), &end);
    const bool out_of_range = errno == ERANGE;  // 1e999 overflows; 1e-308 underflows
    if (text.empty() || *end != '\0' || (!out_of_range && !std::isfinite(value)) ||
        text.find_first_of(" \t") == 0) {
        throw InputError(flag + ": expected a number, got '" + text + "'");
    }
    if (out_of_range) {
        throw InputError(flag + ": " + text + " is out of range (" +
                         (std::fabs(value) > 1 ? "too large" : "too close to 0") +
                         " for a double); expected a number from " + number_text(min) + " to " +
                         number_text(max));
    }
    if (value < min || value > max) {
        throw InputError(flag + ": expected a number from " + number_text(min) + " to " +
                         number_text(max) + ", got " + text);
    }
    return value;
}

// "a,b,c" -> {"a", "b", "c"}; the count must match.
static std::vector<std::string> split_list(const std::string& flag, const std::string& text,
                                           size_t count, const std::string& form) {
    std::vector<std::string> parts;
    size_t start = 0;
    while (true) {
        const size_t comma = text.find(',', start);
        parts.push_back(text.substr(start, comma - start));
        if (comma == std::string::npos) break;
        start = comma + 1;
    }
    if (parts.size() != count) {
        throw InputError(flag + ": expected " + form + ", got '" + text + "'");
    }
    return parts;
}

Args::Args(std::string step, std::string summary)
    : step_(std::move(step)), summary_(std::move(summary)) {}

void Args::add_int(const std::string& flag, int* target, int min, int max,
                   const std::string& help) {
    flags_.push_back({flag, Kind::integer, target, double(min), double(max), {}, help});
}

void Args::add_double(const std::string& flag, double* target, double min, double max,
                      const std::string& help) {
    flags_.push_back({flag, Kind::real, target, min, max, {}, help});
}

void Args::add_choice(const std::string& flag, std::string* target,
                      const std::vector<std::string>& choices, const std::string& help) {
    flags_.push_back({flag, Kind::choice, target, 0, 0, choices, help});
}

void Args::add_string(const std::string& flag, std::string* target, const std::string& help,
                      const std::string& metavar) {
    flags_.push_back({flag, Kind::text, target, 0, 0, {}, help, metavar});
}

void Args::add_switch(const std::string& flag, bool* target, const std::string& help) {
    flags_.push_back({flag, Kind::on_off, target, 0, 0, {}, help});
}

std::string Args::usage() const {
    std::string text = "usage: build/" + step_ + " [options]\n" + summary_ + "\n\n";
    text +=
        "  --volume PATH|phantom   CT volume (default: data/CThead if present, else the phantom;\n"
        "                          phantom:SEED: a grader's variant, moved, mirrored, resized)\n"
        "  --dims NX,NY,NZ         raw file of NX*NY*NZ values, no header\n"
        "  --type T                raw sample type: uint8, int8, uint16, int16 (default), float32\n"
        "  --endian little|big     byte order of a raw file (default little)\n"
        "  --spacing SX,SY,SZ      voxel spacing (CThead: 1,1,2)\n"
        "  --view top|front|side|all   which views to render (default all)\n"
        "  --out DIR               folder for the PNGs (default out)\n"
        "  --no-window             render, write the PNGs and exit\n"
        "  --debug-pixel X,Y       print what happened along the ray of image column X, row Y\n"
        "                          (given again: one trace and ray picture per pixel)\n"
        "  --no-ray-picture        --debug-pixel prints its traces and writes their records\n"
        "                          (OUT/..._ray_X_Y.txt), but draws no ray picture\n"
        "  --trace-only            --debug-pixel casts only the rays it needs: the traced ones\n"
        "                          and the pixels their ray pictures show; no view PNG, no\n"
        "                          summary line, no window\n"
        "  --threads N             render threads (default: all cores)\n"
        "  --pfm                   also write OUT/STEP_VIEW.pfm: the float RGB image before\n"
        "                          rounding to 8 bits (colour PFM, little-endian)\n"
        "  --work-map              also write OUT/STEP_VIEW_work.txt: each ray's work counters\n"
        "                          (make check finds the first ray whose work differs)\n"
        "  --repeat N              render each view N times [1 .. 1000]: time_ms= is the\n"
        "                          first (cold) render, warm_ms= the median of the others\n"
        "  --help                  this text\n";
    text += "  --preset NAME           a volume's settings from data/presets/NAME.preset (flags\n"
            "                          given on the command line win; key P in the window\n"
            "                          switches to the next preset):";
    const std::vector<std::string> names = preset_names();
    for (const std::string& name : names) text += " " + name;
    text += names.empty() ? " none found\n" : "\n";
    text += std::string("\n") + volume_formats_help();
    if (!flags_.empty()) text += "\nthis step:\n";
    for (const Flag& flag : flags_) {
        std::string line = "  " + flag.name;
        if (flag.kind == Kind::integer || flag.kind == Kind::real) line += " N";
        if (flag.kind == Kind::text) line += " " + flag.metavar;
        if (flag.kind == Kind::choice) {
            line += " ";
            for (size_t n = 0; n < flag.choices.size(); ++n) {
                line += (n ? "|" : "") + flag.choices[n];
            }
        }
        line.resize(std::max<size_t>(line.size() + 1, 26), ' ');
        line += flag.help;
        if (flag.kind == Kind::integer || flag.kind == Kind::real) {
            line += " [" + number_text(flag.min) + " .. " + number_text(flag.max) + "]";
        }
        text += line + "\n";
    }
    return text;
}

std::vector<std::string> preset_names() {
    std::vector<std::string> names;
    if (DIR* folder = opendir(presets_folder)) {
        while (const dirent* entry = readdir(folder)) {
            const std::string name = entry->d_name;
            const size_t dot = name.rfind(".preset");
            if (dot != std::string::npos && dot > 0 && dot + 7 == name.size()) {
                names.push_back(name.substr(0, dot));
            }
        }
        closedir(folder);
    }
    std::sort(names.begin(), names.end());
    return names;
}

std::string next_preset(const std::string& current) {
    const std::vector<std::string> names = preset_names();
    if (names.empty()) return "";
    const auto after = std::upper_bound(names.begin(), names.end(), current);
    return after == names.end() ? names.front() : *after;
}

namespace {
// What the window's P key asked for, and the preset it switched to (see request_preset).
struct PresetSwitch {
    bool requested = false;
    std::string requested_name;
    bool active = false;  // Args::parse uses `name` in place of the command line's --preset
    std::string name;
};
PresetSwitch preset_switch;
}  // namespace

void request_preset(const std::string& name) {
    preset_switch.requested = true;
    preset_switch.requested_name = name;
}

bool take_preset_request(std::string* name) {
    if (!preset_switch.requested) return false;
    preset_switch.requested = false;
    *name = preset_switch.requested_name;
    return true;
}

void switch_preset(const std::string& name) {
    preset_switch.active = !name.empty();
    preset_switch.name = name;
}

const std::string& switched_preset() { return preset_switch.name; }

namespace {
// What the window's control panel asked for (see request_rerun).
struct WordsSwitch {
    bool requested = false;
    std::vector<std::string> requested_words;
    bool active = false;  // Args::parse uses `words` in place of the command line's
    std::vector<std::string> words;
};
WordsSwitch words_switch;
}  // namespace

void request_rerun(const std::vector<std::string>& words) {
    words_switch.requested = true;
    words_switch.requested_words = words;
}

bool take_rerun_request(std::vector<std::string>* words) {
    if (!words_switch.requested) return false;
    words_switch.requested = false;
    *words = words_switch.requested_words;
    return true;
}

void switch_words(const std::vector<std::string>& words) {
    words_switch.active = true;
    words_switch.words = words;
}

void end_rerun() { words_switch.active = false; }

bool rerunning() { return words_switch.active; }

// A flag's value as a command line gives it: "0.12", "400", "nearest".
static std::string flag_value_text(FlagKind kind, const void* target) {
    switch (kind) {
        case FlagKind::integer: return std::to_string(*static_cast<const int*>(target));
        case FlagKind::real: {
            const double value = *static_cast<const double*>(target);
            char text[40];
            // The shortest text that reads back as the same double.
            for (int digits = 6; digits <= 17; ++digits) {
                std::snprintf(text, sizeof text, "%.*g", digits, value);
                if (std::strtod(text, nullptr) == value) break;
            }
            return text;
        }
        case FlagKind::on_off: return *static_cast<const bool*>(target) ? "1" : "";
        default: return *static_cast<const std::string*>(target);
    }
}

// The preset's lines "flag value" (or "flag" alone for a switch) as words, keeping only the
// flags this step has: a preset names settings for every step (the threshold of step 02, the
// transfer function of step 07), and each step takes its own.
std::vector<std::string> Args::preset_words(const std::string& name) const {
    for (char c : name) {
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) {
            throw InputError("--preset: expected a name such as cthead, got '" + name + "'");
        }
    }
    const std::string path = std::string(presets_folder) + "/" + name + ".preset";
    // Opened without blocking, only an ordinary file, at most 64 KiB (common/file_input.h): a
    // preset that is a FIFO, a device or a huge file is refused, never read on and on.
    constexpr uint64_t max_preset_bytes = 64 * 1024;
    struct stat info {};
    std::istringstream in;
    if (lstat(path.c_str(), &info) == 0) {
        try {
            const std::vector<unsigned char> bytes = read_small_file(path, max_preset_bytes);
            in.str(std::string(bytes.begin(), bytes.end()));
        } catch (const InputError& error) {
            throw InputError(std::string("--preset: ") + error.what());
        }
    } else {
        std::string known;
        for (const std::string& each : preset_names()) known += (known.empty() ? "" : ", ") + each;
        throw InputError("--preset: no " + path + " (presets: " +
                         (known.empty() ? "none found; run from the repository folder" : known) +
                         ")");
    }
    static const char* const shared[] = {"--volume", "--dims", "--endian", "--spacing", "--type",
                                         "--view"};
    std::vector<std::string> words;
    std::string line;
    int number = 0;
    while (std::getline(in, line) && number < 1000) {
        ++number;
        const size_t hash = line.find('#');
        if (hash != std::string::npos) line.resize(hash);
        std::istringstream fields(line);
        std::string flag, value, extra;
        if (!(fields >> flag)) continue;
        const bool has_value = bool(fields >> value);
        if (fields >> extra || flag.rfind("--", 0) != 0) {
            throw InputError(path + ":" + std::to_string(number) +
                             ": expected '--flag value' or '--flag', got '" + line + "'");
        }
        bool known = false;
        for (const char* each : shared) known = known || flag == each;
        for (const Flag& own : flags_) known = known || own.name == flag;
        if (!known) continue;
        words.push_back(flag);
        if (has_value) words.push_back(value);
    }
    return words;
}

Options Args::parse(int argc, char** argv) {
    // --preset NAME: its settings go first, so that the command line's own flags win.
    std::vector<std::string> words;
    std::vector<std::string> given(argv + std::min(argc, 1), argv + argc);
    if (words_switch.active) given = words_switch.words;  // the window's panel
    if (preset_switch.active) words = preset_words(preset_switch.name);  // the window's P
    for (size_t n = 0; n < given.size() && !preset_switch.active; ++n) {
        std::string value;
        if (given[n] == "--preset" && n + 1 < given.size()) {
            value = given[n + 1];
        } else if (given[n].rfind("--preset=", 0) == 0) {
            value = given[n].substr(9);
        } else if (given[n] == "--preset") {
            throw InputError("--preset: missing value");
        } else {
            continue;
        }
        for (const std::string& word : preset_words(value)) words.push_back(word);
    }
    Options options;
    std::vector<std::string> typed = given;  // the words as typed (or as the panel wrote them)
    if (!words.empty() || words_switch.active) {
        std::vector<char*> all;
        all.push_back(argc > 0 ? argv[0] : nullptr);
        for (std::string& word : words) all.push_back(word.data());
        for (std::string& word : given) all.push_back(word.data());
        all.push_back(nullptr);
        options = parse_words(int(all.size()) - 1, all.data());
    } else {
        options = parse_words(argc, argv);
    }
    if (preset_switch.active) {
        // The window's P: the preset in use replaces the command line's --preset.
        options.preset = preset_switch.name;
        std::vector<std::string> kept = {"--preset", preset_switch.name};
        for (size_t n = 0; n < typed.size(); ++n) {
            if (typed[n] == "--preset") ++n;
            else if (typed[n].rfind("--preset=", 0) != 0) kept.push_back(typed[n]);
        }
        typed = kept;
    }
    options.words = typed;
    options.program = argc > 0 && argv[0] ? argv[0] : "";
    options.rerun = words_switch.active;
    for (const Flag& own : flags_) {
        std::string value = flag_value_text(own.kind, own.target);
        for (const Options::FileUnitsFlag& units : options.file_units) {
            if (units.name == own.name) value = units.text;  // in the file's units, as typed
        }
        options.flags.push_back({own.name, own.kind, own.min, own.max, own.choices, own.help,
                                 value, is_file_units_flag(own.name)});
    }
    return options;
}

Options Args::parse_words(int argc, char** argv) {
    Options options;
    options.step = step_;
    const unsigned cores = std::thread::hardware_concurrency();
    options.threads = cores > 0 ? static_cast<int>(std::min<unsigned>(cores, max_threads)) : 1;

    for (int n = 1; n < argc; ++n) {
        std::string flag = argv[n];
        std::string value;
        bool has_value = false;
        const size_t equals = flag.find('=');
        if (flag.rfind("--", 0) == 0 && equals != std::string::npos) {
            value = flag.substr(equals + 1);
            flag = flag.substr(0, equals);
            has_value = true;
        }
        // The value of a flag: "--flag=value" or the next argument.
        auto take_value = [&]() -> std::string {
            if (has_value) return value;
            if (n + 1 >= argc) throw InputError(flag + ": missing value");
            return argv[++n];
        };

        if (flag == "--help" || flag == "-h") {
            std::fputs(usage().c_str(), stdout);
            std::exit(0);
        } else if (flag == "--volume") {
            options.volume = take_value();
            if (options.volume.empty()) throw InputError("--volume: expected a path or 'phantom'");
        } else if (flag == "--dims") {
            const auto parts = split_list(flag, take_value(), 3, "NX,NY,NZ");
            options.raw.nx = parse_int(flag, parts[0], 1, INT_MAX);
            options.raw.ny = parse_int(flag, parts[1], 1, INT_MAX);
            options.raw.nz = parse_int(flag, parts[2], 1, INT_MAX);
            options.has_dims = true;
        } else if (flag == "--endian") {
            const std::string text = take_value();
            if (text != "little" && text != "big") {
                throw InputError("--endian: expected little or big, got '" + text + "'");
            }
            options.raw.endian = text == "little" ? Endian::little : Endian::big;
            options.has_endian = true;
        } else if (flag == "--type") {
            const std::string text = take_value();
            if (!parse_sample_type(text, &options.raw.type)) {
                throw InputError("--type: expected uint8, int8, uint16, int16 or float32, got '" +
                                 text + "'");
            }
            options.has_type = true;
        } else if (flag == "--spacing") {
            const auto parts = split_list(flag, take_value(), 3, "SX,SY,SZ");
            constexpr double max_spacing = 1e6;
            options.raw.sx = parse_double(flag, parts[0], 0, max_spacing);
            options.raw.sy = parse_double(flag, parts[1], 0, max_spacing);
            options.raw.sz = parse_double(flag, parts[2], 0, max_spacing);
            if (!(options.raw.sx > 0 && options.raw.sy > 0 && options.raw.sz > 0)) {
                throw InputError("--spacing: expected three positive numbers SX,SY,SZ");
            }
            options.has_spacing = true;
        } else if (flag == "--view") {
            options.view = take_value();
            if (options.view != "top" && options.view != "front" && options.view != "side" &&
                options.view != "all") {
                throw InputError("--view: expected top, front, side or all, got '" +
                                 options.view + "'");
            }
        } else if (flag == "--out") {
            options.out = take_value();
            if (options.out.empty()) throw InputError("--out: expected a folder");
        } else if (flag == "--no-window") {
            if (has_value) throw InputError(flag + ": takes no value");
            options.no_window = true;
        } else if (flag == "--debug-pixel") {
            const auto parts = split_list(flag, take_value(), 2, "X,Y (image column, row)");
            const int x = parse_int(flag, parts[0], 0, INT_MAX);
            const int y = parse_int(flag, parts[1], 0, INT_MAX);
            if (!options.has_debug_pixel) options.debug_x = x, options.debug_y = y;
            options.has_debug_pixel = true;
            const std::pair<int, int> pixel(x, y);
            const auto& pixels = options.debug_pixels;
            if (std::find(pixels.begin(), pixels.end(), pixel) == pixels.end()) {
                if (pixels.size() >= max_debug_pixels) {
                    throw InputError(flag + ": at most " + std::to_string(max_debug_pixels) +
                                     " pixels in one run");
                }
                options.debug_pixels.push_back(pixel);
            }
        } else if (flag == "--no-ray-picture") {
            if (has_value) throw InputError(flag + ": takes no value");
            options.ray_pictures = false;
        } else if (flag == "--trace-only") {
            if (has_value) throw InputError(flag + ": takes no value");
            options.trace_only = true;
        } else if (flag == "--threads") {
            options.threads = parse_int(flag, take_value(), 1, max_threads);
        } else if (flag == "--preset") {
            options.preset = take_value();  // its settings are already in argv (parse())
        } else if (flag == "--pfm") {
            if (has_value) throw InputError(flag + ": takes no value");
            options.pfm = true;
        } else if (flag == "--work-map") {
            if (has_value) throw InputError(flag + ": takes no value");
            options.work_map = true;
        } else if (flag == "--repeat") {
            options.repeat = parse_int(flag, take_value(), 1, max_repeat);
        } else if (flag == "--window-script") {
            options.window_script = take_value();
        } else {
            bool known = false;
            for (const Flag& own : flags_) {
                if (own.name != flag) continue;
                known = true;
                if (own.kind == Kind::on_off) {
                    if (has_value) throw InputError(flag + ": takes no value");
                    *static_cast<bool*>(own.target) = true;
                    break;
                }
                const std::string text = take_value();
                if (own.kind == Kind::integer && is_file_units_flag(flag)) {
                    // In the volume file's own units: converted by load_volume(). A whole
                    // number in range also sets the target now (for a volume of int16 values).
                    Options::FileUnitsFlag units;
                    units.name = flag;
                    units.value = parse_double(flag, text, -1e30, 1e30);
                    units.text = text;
                    units.target = static_cast<int*>(own.target);
                    units.min = int(own.min);
                    units.max = int(own.max);
                    if (units.value == std::floor(units.value) && units.value >= own.min &&
                        units.value <= own.max) {
                        *units.target = int(units.value);
                    }
                    options.file_units.push_back(units);
                    break;
                }
                switch (own.kind) {
                    case Kind::integer:
                        *static_cast<int*>(own.target) =
                            parse_int(flag, text, int(own.min), int(own.max));
                        break;
                    case Kind::real:
                        *static_cast<double*>(own.target) =
                            parse_double(flag, text, own.min, own.max);
                        break;
                    case Kind::choice: {
                        std::string expected;
                        bool found = false;
                        for (const std::string& choice : own.choices) {
                            expected += (expected.empty() ? "" : ", ") + choice;
                            found = found || choice == text;
                        }
                        if (!found) {
                            throw InputError(flag + ": expected one of " + expected + ", got '" +
                                             text + "'");
                        }
                        *static_cast<std::string*>(own.target) = text;
                        break;
                    }
                    default:
                        if (text.empty()) throw InputError(flag + ": expected a value");
                        *static_cast<std::string*>(own.target) = text;
                }
                break;
            }
            if (!known) {
                throw InputError("unknown option '" + std::string(argv[n]) + "' (see --help)");
            }
        }
    }
    if (options.trace_only && !options.has_debug_pixel) {
        throw InputError("--trace-only: give the rays to trace with --debug-pixel X,Y");
    }
    if (options.trace_only && (options.pfm || options.work_map || options.repeat > 1)) {
        throw InputError("--trace-only renders no whole picture: it takes no --pfm, --work-map "
                         "or --repeat");
    }
    return options;
}

// The step flags whose numbers are values of the volume (in the file's own units).
static bool is_file_units_flag(const std::string& flag) {
    return flag == "--threshold" || flag == "--iso";
}

// Without --volume: data/CThead when there is one, else the phantom. Something else of that
// name (a folder, a FIFO, a link to nothing) is a mistake to report, not a reason to fall back.
static std::string default_volume_path() {
    const std::string path = default_cthead_path;
    const std::string advice = " (move it away, or choose --volume PATH or --volume phantom)";
    struct stat link_info {}, info {};
    if (lstat(default_cthead_path, &link_info) != 0) return "phantom";  // nothing there
    if (stat(default_cthead_path, &info) != 0) {
        char target[1024] = "";
        const ssize_t size = readlink(default_cthead_path, target, sizeof target - 1);
        if (size >= 0) target[size] = '\0';
        throw InputError("'" + path + "' is a link to '" + target + "', which does not exist" +
                         advice);
    }
    if (S_ISDIR(info.st_mode)) {
        throw InputError("'" + path + "' is a folder, not the CThead file" + advice);
    }
    if (!S_ISREG(info.st_mode)) {
        throw InputError("'" + path + "' is a FIFO or a device, not the CThead file" + advice);
    }
    return path;
}

// --threshold in file units -> the volume's int16 values. A hit is "value > threshold". A
// shift map loses nothing: the largest int16 t with file(t) <= T keeps exactly the same
// voxels, t = floor(T'). A scale map rounded every sample to the nearest int16 when loading:
// T' is rounded the same way, so a sample equal to T in the file stays not above it (as in
// int16), and the voxels above T are kept to within half a volume step.
static void convert_file_units(const Options& options, const Volume& volume) {
    for (const Options::FileUnitsFlag& flag : options.file_units) {
        const double volume_value = volume.map.to_volume(flag.value);
        const double converted = volume.map.scale == 1.0 ? std::floor(volume_value + 1e-9)
                                                         : std::round(volume_value);
        if (volume.map.identity() && (converted < flag.min || converted > flag.max)) {
            throw InputError(flag.name + ": expected a number from " + std::to_string(flag.min) +
                              " to " + std::to_string(flag.max) + ", got " + printable(flag.text));
        }
        *flag.target = int(std::clamp(converted, double(flag.min), double(flag.max)));
        if (!volume.map.identity()) {
            std::printf("units: %s %s (file units) = %d in the volume's values\n",
                        flag.name.c_str(), number_text(flag.value).c_str(), *flag.target);
        }
    }
}

// The volume a windowed run loaded, kept for the panel's reruns (which change no volume flag:
// the panel shows none), so that moving a widget does not read the file again.
namespace {
struct KeptVolume {
    bool kept = false;
    std::vector<std::string> key;  // the volume's flags as loaded
    Volume volume;
};
KeptVolume kept_volume;
constexpr size_t max_kept_bytes = size_t(128) << 20;  // bytes of voxels a windowed run keeps

std::vector<std::string> volume_key(const Options& options) {
    char raw[200];
    std::snprintf(raw, sizeof raw, "%d %d %d %d %d %.17g %.17g %.17g %d %d %d %d",
                  options.raw.nx, options.raw.ny, options.raw.nz, int(options.raw.type),
                  int(options.raw.endian), options.raw.sx, options.raw.sy, options.raw.sz,
                  options.has_dims, options.has_endian, options.has_spacing, options.has_type);
    return {options.volume, raw, std::to_string(options.threads)};
}

bool display_named() {
    const char* x11 = std::getenv("DISPLAY");
    const char* wayland = std::getenv("WAYLAND_DISPLAY");
    return (x11 && *x11) || (wayland && *wayland);
}
}  // namespace

Volume load_volume(const Options& options) {
    if (options.rerun && kept_volume.kept && kept_volume.key == volume_key(options)) {
        Volume volume = kept_volume.volume;
        convert_file_units(options, volume);
        return volume;
    }
    Volume volume = load_volume_anew(options);
    // A second copy costs memory: kept for volumes up to max_kept_bytes (CThead: 14 MiB);
    // a larger one is read again for each of the panel's reruns.
    const size_t bytes = volume.data.size() * sizeof(volume.data[0]);
    kept_volume = KeptVolume{};
    if (!options.no_window && display_named() && bytes <= max_kept_bytes) {
        kept_volume.kept = true;
        kept_volume.key = volume_key(options);
        kept_volume.volume = volume;
    }
    return volume;
}

static Volume load_volume_anew(const Options& options) {
    std::string path = options.volume;
    if (path.empty()) path = default_volume_path();

    Volume volume;
    // "phantom:SEED": the variant a grader renders on (phantom.h), SEED a whole number.
    const bool variant = path.rfind("phantom:", 0) == 0;
    if (path == "phantom" || variant) {
        uint64_t seed = 0;
        if (variant) {
            const std::string digits = path.substr(8);
            char* end = nullptr;
            errno = 0;
            seed = std::strtoull(digits.c_str(), &end, 10);
            if (digits.empty() || digits.size() > 19 || *end != '\0' || errno != 0 ||
                !std::isdigit(static_cast<unsigned char>(digits[0]))) {
                throw InputError("--volume " + path + ": expected phantom:SEED, SEED a whole "
                                 "number of up to 19 digits");
            }
        }
        if (variant && options.has_dims) {
            volume = make_phantom_variant_sized(seed, options.raw.nx, options.raw.ny,
                                                options.raw.nz, options.threads);
        } else if (variant) {
            volume = make_phantom_variant(seed, options.threads);
        } else if (options.has_dims) {
            volume = make_phantom_sized(options.raw.nx, options.raw.ny, options.raw.nz,
                                        options.threads);
        } else {
            volume = make_phantom(options.threads);
        }
        volume.format = "phantom";
        if (options.has_spacing) {
            volume.sx = options.raw.sx;
            volume.sy = options.raw.sy;
            volume.sz = options.raw.sz;
        }
    } else if (const std::string format = volume_format_of(path); format != "raw") {
        volume = load_volume_file(format, path);  // NIfTI, NRRD, MetaImage, DICOM
    } else if (options.has_dims) {
        RawFormat format = options.raw;
        volume = load_raw(path, format);
    } else if (RawFormat named = options.raw; raw_format_from_name(path, &named)) {
        // foot_256x256x256_uint8.raw: dims and type from the name (--type still wins).
        if (options.has_type) named.type = options.raw.type;
        volume = load_raw(path, named);
    } else if (options.has_endian || options.has_spacing || options.has_type) {
        // A CThead-sized file with another byte order or spacing.
        RawFormat format = options.raw;
        format.nx = cthead_nx;
        format.ny = cthead_ny;
        format.nz = cthead_nz;
        if (!options.has_spacing) {
            format.sx = cthead_sx;
            format.sy = cthead_sy;
            format.sz = cthead_sz;
        }
        volume = load_raw(path, format);
    } else {
        volume = load_cthead(path);
    }
    if (volume.format != "raw" && volume.format != "phantom" && options.has_spacing) {
        volume.sx = options.raw.sx;  // --spacing overrides what the file says
        volume.sy = options.raw.sy;
        volume.sz = options.raw.sz;
    }
    std::printf("%s\n", volume_line(volume).c_str());
    convert_file_units(options, volume);
    return volume;
}

}  // namespace ctlab
