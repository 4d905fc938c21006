// compare.cpp: error metrics between two pictures, and a heat map of where they differ.
#include "tools/compare.h"
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <vector>
#include "error.h"

namespace ctlab {

namespace {

constexpr double full_scale = 255.0;  // largest 8-bit channel value, for the PSNR

std::string size_text(const Image& image) {
    return std::to_string(image.width) + "x" + std::to_string(image.height);
}

void check_same_size(const Image& student, const Image& reference,
                     const std::string& student_name, const std::string& reference_name) {
    if (student.width != reference.width || student.height != reference.height) {
        throw InputError(student_name + " is " + size_text(student) + " but " +
                         reference_name + " is " + size_text(reference));
    }
    if (student.pixels.empty()) throw InputError(student_name + " has no pixels");
}

// The three channel errors of pixel n, in 8-bit units.
std::array<int, 3> channel_errors(const Image& student, const Image& reference, size_t n) {
    const Rgb& a = student.pixels[n];
    const Rgb& b = reference.pixels[n];
    return {std::abs(to_byte(a.r) - to_byte(b.r)), std::abs(to_byte(a.g) - to_byte(b.g)),
            std::abs(to_byte(a.b) - to_byte(b.b))};
}

int largest(const std::array<int, 3>& errors) {
    return std::max({errors[0], errors[1], errors[2]});
}

// "2", "2.5", "0.25": at most two decimals, no trailing zeros.
std::string short_number(double value) {
    char text[64];
    std::snprintf(text, sizeof text, "%.2f", value);
    std::string result = text;
    while (result.back() == '0') result.pop_back();
    if (result.back() == '.') result.pop_back();
    return result;
}

std::string fixed(double value, int decimals) {
    char text[64];
    std::snprintf(text, sizeof text, "%.*f", decimals, value);
    return text;
}

// --- Legend: a colour bar with ticks, labelled in a 3x5 pixel font -----------------------

constexpr int glyph_width = 3, glyph_height = 5;  // pixels, before scaling
// Rows top to bottom, 3 bits each (4 = left column): digits 0..9, then '.'.
constexpr std::array<std::array<int, glyph_height>, 11> glyphs = {{
    {7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7}, {5, 5, 7, 1, 1},
    {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 1, 1, 1}, {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7},
    {0, 0, 0, 0, 2},
}};

int text_width(const std::string& text, int scale) {
    return (static_cast<int>(text.size()) * (glyph_width + 1) - 1) * scale;
}

void draw_text(Image& image, const std::string& text, int left, int top, int scale) {
    const Rgb ink = grey(1.0f);
    for (size_t c = 0; c < text.size(); ++c) {
        const int glyph = text[c] == '.' ? 10 : text[c] - '0';
        if (glyph < 0 || glyph > 10) continue;  // only digits and '.' are drawn
        for (int row = 0; row < glyph_height * scale; ++row) {
            for (int column = 0; column < glyph_width * scale; ++column) {
                const int bit = glyph_width - 1 - column / scale;
                if (!((glyphs[glyph][row / scale] >> bit) & 1)) continue;
                const int x = left + static_cast<int>(c) * (glyph_width + 1) * scale + column;
                const int y = top + row;
                if (x >= 0 && x < image.width && y >= 0 && y < image.height) image.at(x, y) = ink;
            }
        }
    }
}

// Appends the legend below `map` (rows from `top` on are legend space).
void draw_legend(Image& map, int top, int scale, double tolerance, int max_error) {
    const int separator = scale, bar = 6 * scale, tick = 2 * scale;
    for (int x = 0; x < map.width; ++x) {
        for (int y = top; y < top + separator; ++y) map.at(x, y) = grey(0.3f);
        const Rgb colour = heat_colour(static_cast<double>(x) / (map.width - 1));
        for (int y = top + separator; y < top + separator + bar; ++y) map.at(x, y) = colour;
    }
    // Ticks and labels at 0, the tolerance and the largest error (when beyond it).
    std::vector<std::pair<double, std::string>> marks = {{0.0, "0"}};
    if (max_error > 0) {
        marks.push_back({tolerance, short_number(tolerance)});
        if (max_error > tolerance) marks.push_back({max_error, std::to_string(max_error)});
    }
    const int tick_top = top + separator + bar;
    const int label_top = tick_top + tick + scale;
    int free_from = 0;  // first column a label may use without overlapping the previous one
    for (const auto& [error, label] : marks) {
        const double position = heat_position(error, tolerance, max_error);
        const int x = static_cast<int>(std::lround(position * (map.width - 1)));
        for (int y = tick_top; y < tick_top + tick; ++y) {
            for (int dx = 0; dx < scale && x + dx < map.width; ++dx) map.at(x + dx, y) = grey(1);
        }
        const int width = text_width(label, scale);
        const int left = std::clamp(x - width / 2, 0, std::max(0, map.width - width));
        if (left < free_from || left + width > map.width) continue;  // no room: tick only
        draw_text(map, label, left, label_top, scale);
        free_from = left + width + 2 * scale;
    }
}

}  // namespace

Comparison compare_images(const Image& student, const Image& reference, double tolerance,
                          const std::string& student_name, const std::string& reference_name) {
    check_same_size(student, reference, student_name, reference_name);
    Comparison result;
    result.width = student.width;
    result.height = student.height;
    result.tolerance = tolerance;
    double sum_abs = 0, sum_squares = 0;  // exact: integers far below 2^53
    size_t over_tolerance = 0;            // pixels
    for (size_t n = 0; n < student.pixels.size(); ++n) {
        const std::array<int, 3> errors = channel_errors(student, reference, n);
        for (int error : errors) {
            sum_abs += error;
            sum_squares += static_cast<double>(error) * error;
        }
        const int worst = largest(errors);
        result.max_abs = std::max(result.max_abs, worst);
        if (worst > tolerance) ++over_tolerance;
    }
    const double pixels = static_cast<double>(student.pixels.size());
    result.mean_abs = sum_abs / (3 * pixels);
    result.rmse = std::sqrt(sum_squares / (3 * pixels));
    result.psnr_db = result.rmse > 0 ? 20 * std::log10(full_scale / result.rmse)
                                     : std::numeric_limits<double>::infinity();
    result.over_tol_pct = 100.0 * over_tolerance / pixels;
    result.pass = over_tolerance == 0;
    return result;
}

std::string format_psnr(double psnr_db) {
    return std::isinf(psnr_db) ? "inf" : fixed(psnr_db, 2);
}

std::vector<std::pair<std::string, std::string>> comparison_fields(const Comparison& c) {
    return {{"max_abs", std::to_string(c.max_abs)},     {"mean_abs", fixed(c.mean_abs, 4)},
            {"rmse", fixed(c.rmse, 4)},                 {"psnr_db", format_psnr(c.psnr_db)},
            {"over_tol_pct", fixed(c.over_tol_pct, 3)}, {"tol", short_number(c.tolerance)},
            {"result", c.pass ? "pass" : "fail"}};
}

std::string comparison_line(const Comparison& comparison) {
    std::string line;
    for (const auto& [name, value] : comparison_fields(comparison)) {
        line += (line.empty() ? "" : " ") + name + "=" + value;
    }
    return line;
}

double heat_position(double error, double tolerance, double max_error) {
    constexpr double smallest = 0.1;   // ramp position of the smallest visible error
    constexpr double at_tolerance = 0.3;  // ramp position of an error equal to the tolerance
    if (error <= 0) return 0;
    if (error <= tolerance) return smallest + (at_tolerance - smallest) * error / tolerance;
    if (max_error <= tolerance) return 1;  // not reached when max_error is the true maximum
    return std::min(1.0, at_tolerance + (1 - at_tolerance) * (error - tolerance) /
                                            (max_error - tolerance));
}

Rgb heat_colour(double position) {
    // Brightness rises along the ramp, so the map also reads in grey.
    struct Stop { double position; Rgb colour; };
    static const std::array<Stop, 5> stops = {{
        {0.0, {0.0f, 0.0f, 0.0f}},      // black: equal
        {0.3, {0.1f, 0.15f, 0.75f}},    // blue: at the tolerance
        {0.55, {0.85f, 0.15f, 0.75f}},  // magenta
        {0.8, {1.0f, 0.9f, 0.15f}},     // yellow
        {1.0, {1.0f, 1.0f, 1.0f}},      // white: the largest error
    }};
    position = std::clamp(position, 0.0, 1.0);
    for (size_t s = 1; s < stops.size(); ++s) {
        if (position > stops[s].position) continue;
        const Stop& a = stops[s - 1];
        const Stop& b = stops[s];
        const float f = static_cast<float>((position - a.position) / (b.position - a.position));
        return {a.colour.r + f * (b.colour.r - a.colour.r),
                a.colour.g + f * (b.colour.g - a.colour.g),
                a.colour.b + f * (b.colour.b - a.colour.b)};
    }
    return stops.back().colour;
}

Image diff_heat_map(const Image& student, const Image& reference, double tolerance,
                    bool legend) {
    check_same_size(student, reference, "the student image", "the reference image");
    std::vector<int> worst(student.pixels.size());
    int max_error = 0;
    for (size_t n = 0; n < worst.size(); ++n) {
        worst[n] = largest(channel_errors(student, reference, n));
        max_error = std::max(max_error, worst[n]);
    }
    const bool with_legend = legend && student.width >= legend_min_width;
    const int scale = student.width >= 200 ? 2 : 1;  // legend pixel size
    const int legend_height = with_legend ? 17 * scale : 0;
    Image map(student.width, student.height + legend_height);
    for (size_t n = 0; n < worst.size(); ++n) {
        map.pixels[n] = heat_colour(heat_position(worst[n], tolerance, max_error));
    }
    if (with_legend) draw_legend(map, student.height, scale, tolerance, max_error);
    return map;
}

}  // namespace ctlab
