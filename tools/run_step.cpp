// run_step.cpp: running step binaries as processes and reading what they write.
#include "run_step.h"
#include <sys/stat.h>
#include <unistd.h>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include "error.h"
#include "ray_plot.h"

namespace ctlab {

Summary parse_summary(const std::string& line) {
    Summary summary;
    std::istringstream words(line);
    std::string word;
    while (words >> word) {
        const size_t equals = word.find('=');
        if (equals == std::string::npos || equals == 0) continue;
        summary[word.substr(0, equals)] = word.substr(equals + 1);
    }
    return summary;
}

// "rgb=(0.1, 0.2, 0.3)" -> the three numbers after `key`=( in `line`.
static bool parse_triple(const std::string& line, const std::string& key, double out[3]) {
    const size_t start = line.find(key + "=(");
    if (start == std::string::npos) return false;
    const char* text = line.c_str() + start + key.size() + 2;
    for (int n = 0; n < 3; ++n) {
        char* end = nullptr;
        out[n] = std::strtod(text, &end);
        if (end == text) return false;
        text = end;
        while (*text == ',' || *text == ' ') ++text;
    }
    return true;
}

// The summary lines and the traces in a step's stdout.
static void parse_output(RunResult& result) {
    std::istringstream lines(result.out);
    std::string line;
    PixelTrace* open = nullptr;
    while (std::getline(lines, line)) {
        if (line.rfind("step=", 0) == 0) {
            result.summaries.push_back(parse_summary(line));
            open = nullptr;
        } else if (line.rfind("debug pixel ", 0) == 0) {
            result.traces.emplace_back();
            open = &result.traces.back();
            open->header = line;
            const Summary words = parse_summary(line);
            open->view = words.count("view") ? words.at("view") : "";
            open->x = words.count("x") ? std::atoi(words.at("x").c_str()) : -1;
            open->y = words.count("y") ? std::atoi(words.at("y").c_str()) : -1;
        } else if (open && line.rfind("pixel x=", 0) == 0) {
            double rgb[3] = {0, 0, 0}, png[3] = {0, 0, 0};
            open->complete = parse_triple(line, "rgb", rgb) && parse_triple(line, "png", png);
            open->rgb = {float(rgb[0]), float(rgb[1]), float(rgb[2])};
            for (int n = 0; n < 3; ++n) open->png[n] = int(png[n]);
            const Summary words = parse_summary(line);
            if (words.count("samples")) open->samples = std::strtoull(words.at("samples").c_str(),
                                                                      nullptr, 10);
            open = nullptr;
        } else if (open) {
            open->lines.push_back(line.rfind("  ", 0) == 0 ? line.substr(2) : line);
        }
    }
}

const Summary& RunResult::summary(const std::string& view) const {
    for (const Summary& line : summaries) {
        const auto found = line.find("view");
        if (found != line.end() && found->second == view) return line;
    }
    throw std::runtime_error(command() + ": no summary line for view " + view + "\n" + out +
                             err);
}

RunResult run_program(const std::string& program, const std::vector<std::string>& args,
                      double timeout_s) {
    ProcessOptions options;
    options.limits.wall_s = timeout_s;
    options.limits.output_bytes = size_t(1) << 30;  // long traces: the caller's own programs
    RunResult result;
    static_cast<ProcessResult&>(result) = run_process(program, args, options);
    parse_output(result);
    return result;
}

std::string build_folder() {
    std::error_code error;
    const std::filesystem::path binary = std::filesystem::read_symlink("/proc/self/exe", error);
    if (error) return "build";
    return binary.parent_path().string();
}

std::string step_binary(const std::string& step) { return build_folder() + "/" + step; }

RunResult run_step(const std::string& step, const std::vector<std::string>& flags,
                   double timeout_s) {
    std::vector<std::string> args = {"--no-window"};
    args.insert(args.end(), flags.begin(), flags.end());
    RunResult result = run_program(step_binary(step), args, timeout_s);
    // Each traced ray's records, from the sidecar beside its ray picture.
    std::string out;
    for (size_t n = 0; n + 1 < flags.size(); ++n) {
        if (flags[n] == "--out") out = flags[n + 1];
    }
    if (out.empty() || result.status != 0) return result;
    for (PixelTrace& trace : result.traces) {
        const std::string path = out + "/" + step + "_" + trace.view + "_ray_" +
                                 std::to_string(trace.x) + "_" + std::to_string(trace.y) + ".txt";
        std::ifstream file(path, std::ios::binary);
        if (!file) continue;
        std::ostringstream text;
        text << file.rdbuf();
        trace.records = trace_records_from_text(text.str());
    }
    return result;
}

bool looks_along_axes_only(const std::string& step) {
    const RunResult help = run_program(step_binary(step), {"--help"});
    std::istringstream lines(help.out);
    for (std::string line; std::getline(lines, line);) {
        if (line.find("--azimuth") != std::string::npos) {
            return line.find("a multiple of 90") != std::string::npos;
        }
    }
    return false;
}

double summary_number(const Summary& summary, const std::string& key) {
    const auto found = summary.find(key);
    if (found == summary.end()) throw std::runtime_error("summary line without " + key + "=");
    char* end = nullptr;
    const double value = std::strtod(found->second.c_str(), &end);
    if (end == found->second.c_str() || *end != '\0') {
        throw std::runtime_error("summary " + key + "=" + found->second + " is not a number");
    }
    return value;
}

unsigned long long summary_count(const Summary& summary, const std::string& key) {
    const auto found = summary.find(key);
    if (found == summary.end()) throw std::runtime_error("summary line without " + key + "=");
    char* end = nullptr;
    const unsigned long long value = std::strtoull(found->second.c_str(), &end, 10);
    if (end == found->second.c_str() || *end != '\0') {
        throw std::runtime_error("summary " + key + "=" + found->second + " is not a count");
    }
    return value;
}

// --- PFM -----------------------------------------------------------------------------------

Image read_pfm(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw InputError("cannot read '" + path + "'");
    std::string magic;
    long width = 0, height = 0;
    double scale = 0;
    file >> magic >> width >> height >> scale;
    if (!file || (magic != "PF" && magic != "Pf")) {
        throw InputError(path + ": not a PFM (expected 'PF' or 'Pf', sizes and scale)");
    }
    constexpr long max_side = 1 << 16;  // bounds the allocation below
    if (width < 1 || height < 1 || width > max_side || height > max_side || scale == 0 ||
        !std::isfinite(scale)) {
        throw InputError(path + ": bad PFM size " + std::to_string(width) + "x" +
                         std::to_string(height) + " or scale");
    }
    file.get();  // the single whitespace character after the scale
    const int channels = magic == "PF" ? 3 : 1;
    const size_t count = size_t(width) * size_t(height) * size_t(channels);
    std::vector<unsigned char> bytes(count * 4);
    file.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
    if (size_t(file.gcount()) != bytes.size()) {
        throw InputError(path + ": PFM data ends early (" + std::to_string(file.gcount()) +
                         " of " + std::to_string(bytes.size()) + " bytes)");
    }
    const bool little = scale < 0;
    auto value_at = [&](size_t index) {
        const unsigned char* b = &bytes[4 * index];
        const uint32_t bits = little ? uint32_t(b[0]) | uint32_t(b[1]) << 8 |
                                           uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24
                                     : uint32_t(b[3]) | uint32_t(b[2]) << 8 |
                                           uint32_t(b[1]) << 16 | uint32_t(b[0]) << 24;
        float value;
        std::memcpy(&value, &bits, sizeof value);
        return value;
    };
    Image image{int(width), int(height)};
    for (int y = 0; y < image.height; ++y) {
        const size_t row = size_t(image.height - 1 - y);  // stored bottom row first
        for (int x = 0; x < image.width; ++x) {
            const size_t index = (row * size_t(width) + size_t(x)) * size_t(channels);
            Rgb& p = image.at(x, y);
            p.r = value_at(index);
            p.g = channels == 3 ? value_at(index + 1) : p.r;
            p.b = channels == 3 ? value_at(index + 2) : p.r;
        }
    }
    return image;
}

std::string step_output(const std::string& out, const std::string& step, const std::string& view,
                        const std::string& extension) {
    return out + "/" + step + "_" + view + "." + extension;
}

// --- Volumes and temporary files -----------------------------------------------------------

static std::string number_text(double value) {
    char text[40];
    std::snprintf(text, sizeof text, "%.17g", value);
    return text;
}

std::vector<std::string> write_raw_volume(const Volume& volume, const std::string& path) {
    const std::vector<int16_t> values = dense_values(volume);  // no padding in files
    std::vector<unsigned char> bytes(values.size() * 2);
    for (size_t n = 0; n < values.size(); ++n) {
        const uint16_t bits = uint16_t(values[n]);
        bytes[2 * n] = uint8_t(bits & 0xff);
        bytes[2 * n + 1] = uint8_t(bits >> 8);
    }
    std::ofstream file(path, std::ios::binary | std::ios::trunc);
    file.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    file.close();
    if (!file) throw InputError("cannot write '" + path + "'");
    return {"--volume", path,
            "--dims", std::to_string(volume.nx) + "," + std::to_string(volume.ny) + "," +
                          std::to_string(volume.nz),
            "--spacing", number_text(volume.sx) + "," + number_text(volume.sy) + "," +
                             number_text(volume.sz)};
}

TempFolder::TempFolder(const std::string& tag) : TempFolder(tag, "") {}

TempFolder::TempFolder(const std::string& tag, const std::string& parent) {
    const std::filesystem::path folder =
        parent.empty() ? std::filesystem::temp_directory_path() : std::filesystem::path(parent);
    std::string pattern = (folder / ("ctlab_" + tag + "_XXXXXX")).string();
    if (!mkdtemp(pattern.data())) {
        throw std::runtime_error("cannot create a temporary folder: " +
                                 std::string(strerror(errno)));
    }
    path_ = pattern;
}

TempFolder::~TempFolder() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
}

std::string TempFolder::file(const std::string& name,
                             const std::vector<unsigned char>& bytes) const {
    std::ofstream out(path(name), std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    return path(name);
}

std::string TempFolder::text_file(const std::string& name, const std::string& text) const {
    return file(name, std::vector<unsigned char>(text.begin(), text.end()));
}

}  // namespace ctlab
