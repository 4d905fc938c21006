// args.cpp: strict parsing of the shared flags and a step's own.
#include "args.h"
#include <sys/stat.h>
#include <unistd.h>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include "error.h"
#include "phantom.h"

namespace ctlab {

static const char* const default_cthead_path = "data/CThead";
constexpr int max_threads = 256;
constexpr int max_repeat = 1000;  // renders of one view for --repeat: enough for a median

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

void Args::add_string(const std::string& flag, std::string* target, const std::string& help) {
    flags_.push_back({flag, Kind::text, target, 0, 0, {}, help});
}

void Args::add_switch(const std::string& flag, bool* target, const std::string& help) {
    flags_.push_back({flag, Kind::on_off, target, 0, 0, {}, help});
}

std::string Args::usage() const {
    std::string text = "usage: build/" + step_ + " [options]\n" + summary_ + "\n\n";
    text +=
        "  --volume PATH|phantom   CT volume (default: data/CThead if present, else the phantom)\n"
        "  --dims NX,NY,NZ         raw file of NX*NY*NZ signed 16-bit values, no header\n"
        "  --endian little|big     byte order of a raw file (default little)\n"
        "  --spacing SX,SY,SZ      voxel spacing (CThead: 1,1,2)\n"
        "  --view top|front|side|all   which views to render (default all)\n"
        "  --out DIR               folder for the PNGs (default out)\n"
        "  --no-window             render, write the PNGs and exit\n"
        "  --debug-pixel X,Y       print what happened along the ray of image column X, row Y\n"
        "  --threads N             render threads (default: all cores)\n"
        "  --pfm                   also write OUT/STEP_VIEW.pfm: the float RGB image before\n"
        "                          rounding to 8 bits (colour PFM, little-endian)\n"
        "  --repeat N              render each view N times [1 .. 1000]: time_ms= is the\n"
        "                          first (cold) render, warm_ms= the median of the others\n"
        "  --help                  this text\n";
    if (!flags_.empty()) text += "\nthis step:\n";
    for (const Flag& flag : flags_) {
        std::string line = "  " + flag.name;
        if (flag.kind == Kind::integer || flag.kind == Kind::real) line += " N";
        if (flag.kind == Kind::text) line += " FILE";
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

Options Args::parse(int argc, char** argv) {
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
            options.debug_x = parse_int(flag, parts[0], 0, INT_MAX);
            options.debug_y = parse_int(flag, parts[1], 0, INT_MAX);
            options.has_debug_pixel = true;
        } else if (flag == "--threads") {
            options.threads = parse_int(flag, take_value(), 1, max_threads);
        } else if (flag == "--pfm") {
            if (has_value) throw InputError(flag + ": takes no value");
            options.pfm = true;
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
    return options;
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

Volume load_volume(const Options& options) {
    std::string path = options.volume;
    if (path.empty()) path = default_volume_path();

    Volume volume;
    if (path == "phantom") {
        if (options.has_dims) {
            volume = make_phantom_sized(options.raw.nx, options.raw.ny, options.raw.nz);
        } else {
            volume = make_phantom();
        }
        if (options.has_spacing) {
            volume.sx = options.raw.sx;
            volume.sy = options.raw.sy;
            volume.sz = options.raw.sz;
        }
    } else if (options.has_dims) {
        RawFormat format = options.raw;
        volume = load_raw(path, format);
    } else if (options.has_endian || options.has_spacing) {
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
    std::printf("volume=%s dims=%dx%dx%d spacing=%g,%g,%g min=%d max=%d\n",
                printable(volume.name).c_str(),
                volume.nx, volume.ny, volume.nz, volume.sx, volume.sy, volume.sz,
                volume.min_value, volume.max_value);
    return volume;
}

}  // namespace ctlab
