// plot.h: just enough drawing for plots (the study's log-log plots, the ray pictures of
// --debug-pixel): a 5x7 bitmap font (our own
// glyphs: A-Z, 0-9 and a few symbols; lower case is drawn as upper case), thick lines,
// square markers, decade ticks and a legend, into a ctlab::Image (write it with write_png).
#pragma once
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>
#include "image.h"

namespace plot {

using ctlab::Image;
using ctlab::Rgb;

constexpr int glyph_width = 5, glyph_height = 7;  // font pixels; a character cell is 6 x 8

struct Glyph {
    char c;
    const char* rows[glyph_height];  // '#' = ink, left to right, top row first
};

// clang-format off
inline const std::vector<Glyph>& glyphs() {
    static const std::vector<Glyph> table = {
        {'A', {".###.", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"}},
        {'B', {"####.", "#...#", "#...#", "####.", "#...#", "#...#", "####."}},
        {'C', {".###.", "#...#", "#....", "#....", "#....", "#...#", ".###."}},
        {'D', {"####.", "#...#", "#...#", "#...#", "#...#", "#...#", "####."}},
        {'E', {"#####", "#....", "#....", "####.", "#....", "#....", "#####"}},
        {'F', {"#####", "#....", "#....", "####.", "#....", "#....", "#...."}},
        {'G', {".###.", "#...#", "#....", "#.###", "#...#", "#...#", ".####"}},
        {'H', {"#...#", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"}},
        {'I', {".###.", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."}},
        {'J', {"..###", "...#.", "...#.", "...#.", "...#.", "#..#.", ".##.."}},
        {'K', {"#...#", "#..#.", "#.#..", "##...", "#.#..", "#..#.", "#...#"}},
        {'L', {"#....", "#....", "#....", "#....", "#....", "#....", "#####"}},
        {'M', {"#...#", "##.##", "#.#.#", "#.#.#", "#...#", "#...#", "#...#"}},
        {'N', {"#...#", "#...#", "##..#", "#.#.#", "#..##", "#...#", "#...#"}},
        {'O', {".###.", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."}},
        {'P', {"####.", "#...#", "#...#", "####.", "#....", "#....", "#...."}},
        {'Q', {".###.", "#...#", "#...#", "#...#", "#.#.#", "#..#.", ".##.#"}},
        {'R', {"####.", "#...#", "#...#", "####.", "#.#..", "#..#.", "#...#"}},
        {'S', {".####", "#....", "#....", ".###.", "....#", "....#", "####."}},
        {'T', {"#####", "..#..", "..#..", "..#..", "..#..", "..#..", "..#.."}},
        {'U', {"#...#", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."}},
        {'V', {"#...#", "#...#", "#...#", "#...#", "#...#", ".#.#.", "..#.."}},
        {'W', {"#...#", "#...#", "#...#", "#.#.#", "#.#.#", "#.#.#", ".#.#."}},
        {'X', {"#...#", "#...#", ".#.#.", "..#..", ".#.#.", "#...#", "#...#"}},
        {'Y', {"#...#", "#...#", ".#.#.", "..#..", "..#..", "..#..", "..#.."}},
        {'Z', {"#####", "....#", "...#.", "..#..", ".#...", "#....", "#####"}},
        {'0', {".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###."}},
        {'1', {"..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###."}},
        {'2', {".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####"}},
        {'3', {"####.", "....#", "....#", ".###.", "....#", "....#", "####."}},
        {'4', {"...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#."}},
        {'5', {"#####", "#....", "####.", "....#", "....#", "#...#", ".###."}},
        {'6', {"..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###."}},
        {'7', {"#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#..."}},
        {'8', {".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###."}},
        {'9', {".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##.."}},
        {'.', {".....", ".....", ".....", ".....", ".....", ".##..", ".##.."}},
        {',', {".....", ".....", ".....", ".....", ".##..", "..#..", ".#..."}},
        {':', {".....", ".##..", ".##..", ".....", ".##..", ".##..", "....."}},
        {'-', {".....", ".....", ".....", "#####", ".....", ".....", "....."}},
        {'+', {".....", "..#..", "..#..", "#####", "..#..", "..#..", "....."}},
        {'=', {".....", ".....", "#####", ".....", "#####", ".....", "....."}},
        {'/', {"....#", "....#", "...#.", "..#..", ".#...", "#....", "#...."}},
        {'(', {"...#.", "..#..", ".#...", ".#...", ".#...", "..#..", "...#."}},
        {')', {".#...", "..#..", "...#.", "...#.", "...#.", "..#..", ".#..."}},
        {'%', {"##..#", "##..#", "...#.", "..#..", ".#...", "#..##", "#..##"}},
        {'^', {"..#..", ".#.#.", "#...#", ".....", ".....", ".....", "....."}},
        {'*', {".....", "#.#.#", ".###.", "#####", ".###.", "#.#.#", "....."}},
        {'<', {"...#.", "..#..", ".#...", "#....", ".#...", "..#..", "...#."}},
        {'>', {".#...", "..#..", "...#.", "....#", "...#.", "..#..", ".#..."}},
        {'_', {".....", ".....", ".....", ".....", ".....", ".....", "#####"}},
        {'\'', {"..#..", "..#..", ".....", ".....", ".....", ".....", "....."}},
        {'|', {"..#..", "..#..", "..#..", "..#..", "..#..", "..#..", "..#.."}},
    };
    return table;
}
// clang-format on

inline const Glyph* find_glyph(char c) {
    const char upper = char(std::toupper(static_cast<unsigned char>(c)));
    for (const Glyph& glyph : glyphs()) {
        if (glyph.c == upper) return &glyph;
    }
    return nullptr;  // a space, or a character the font lacks: left blank
}

inline void put(Image& image, int x, int y, Rgb colour) {
    if (x >= 0 && y >= 0 && x < image.width && y < image.height) image.at(x, y) = colour;
}

inline void fill_rect(Image& image, int x0, int y0, int w, int h, Rgb colour) {
    for (int y = y0; y < y0 + h; ++y)
        for (int x = x0; x < x0 + w; ++x) put(image, x, y, colour);
}

// Pixels a string takes across at this scale (each character cell is 6 font pixels wide).
inline int text_width(const std::string& text, int scale) {
    return text.empty() ? 0 : (int(text.size()) * (glyph_width + 1) - 1) * scale;
}

// Text with its top-left corner at (x, y); every font pixel a scale x scale square.
inline void draw_text(Image& image, int x, int y, const std::string& text, Rgb colour,
                      int scale = 1) {
    for (size_t n = 0; n < text.size(); ++n) {
        const Glyph* glyph = find_glyph(text[n]);
        if (!glyph) continue;
        const int left = x + int(n) * (glyph_width + 1) * scale;
        for (int row = 0; row < glyph_height; ++row)
            for (int column = 0; column < glyph_width; ++column) {
                if (glyph->rows[row][column] != '#') continue;
                fill_rect(image, left + column * scale, y + row * scale, scale, scale, colour);
            }
    }
}

// Text turned a quarter to the left (reading upwards), its bottom-left corner at (x, y):
// for a y axis label.
inline void draw_text_upwards(Image& image, int x, int y, const std::string& text,
                              Rgb colour, int scale = 1) {
    for (size_t n = 0; n < text.size(); ++n) {
        const Glyph* glyph = find_glyph(text[n]);
        if (!glyph) continue;
        const int bottom = y - int(n) * (glyph_width + 1) * scale;
        for (int row = 0; row < glyph_height; ++row)
            for (int column = 0; column < glyph_width; ++column) {
                if (glyph->rows[row][column] != '#') continue;
                fill_rect(image, x + row * scale, bottom - (column + 1) * scale, scale, scale,
                          colour);
            }
    }
}

// A line `thickness` pixels wide: a square pen stepped along it, one pixel at a time.
inline void draw_line(Image& image, double x0, double y0, double x1, double y1, Rgb colour,
                      int thickness = 2) {
    const int steps = int(std::ceil(std::max(std::abs(x1 - x0), std::abs(y1 - y0)))) + 1;
    for (int n = 0; n <= steps; ++n) {
        const double f = double(n) / steps;
        const int x = int(std::lround(x0 + f * (x1 - x0))) - thickness / 2;
        const int y = int(std::lround(y0 + f * (y1 - y0))) - thickness / 2;
        fill_rect(image, x, y, thickness, thickness, colour);
    }
}

struct Series {
    std::string label;                  // legend text
    Rgb colour;
    std::vector<double> x, y;           // data; points with x or y <= 0 are left out (log axes)
    std::vector<std::string> notes;     // optional, one per point: printed next to it
};

struct Panel {
    std::string title, x_label, y_label;
    std::vector<Series> series;
};

// "0.01", "0.1", "1", "10", "1000", "1E-5" for the decade 10^exponent.
inline std::string decade_label(int exponent) {
    if (exponent >= -3 && exponent <= 4) {
        char text[16];
        const int decimals = std::max(0, -exponent);
        std::snprintf(text, sizeof text, "%.*f", decimals, std::pow(10.0, exponent));
        return text;
    }
    return "1E" + std::to_string(exponent);
}

// One log-log panel drawn into image at (left, top), size width x height.
inline void draw_panel(Image& image, const Panel& panel, int left, int top, int width,
                       int height) {
    const Rgb black = {0, 0, 0}, grid = {0.88f, 0.88f, 0.88f}, note = {0.35f, 0.35f, 0.35f};
    constexpr int scale = 2;                       // titles, labels and legend
    constexpr int margin_left = 86, margin_right = 64, margin_top = 34;
    const int legend_rows = int(panel.series.size());
    const int margin_bottom = 64 + legend_rows * 20;
    const int x0 = left + margin_left, x1 = left + width - margin_right;
    const int y0 = top + margin_top, y1 = top + height - margin_bottom;

    // Axis ranges: whole decades around every positive point.
    double x_min = 1e300, x_max = 0, y_min = 1e300, y_max = 0;
    for (const Series& s : panel.series)
        for (size_t n = 0; n < s.x.size(); ++n) {
            if (s.x[n] <= 0 || s.y[n] <= 0) continue;
            x_min = std::min(x_min, s.x[n]), x_max = std::max(x_max, s.x[n]);
            y_min = std::min(y_min, s.y[n]), y_max = std::max(y_max, s.y[n]);
        }
    if (x_max <= 0) x_min = y_min = 1, x_max = y_max = 10;  // nothing to plot
    // A point closer than 0.05 decade to an edge gets the next decade, so none sits on an axis.
    constexpr double pad = 0.05;
    const int dx0 = int(std::floor(std::log10(x_min) - pad));
    const int dx1 = int(std::ceil(std::log10(x_max) + pad));
    const int dy0 = int(std::floor(std::log10(y_min) - pad));
    const int dy1 = int(std::ceil(std::log10(y_max) + pad));
    const int x_decades = std::max(1, dx1 - dx0), y_decades = std::max(1, dy1 - dy0);
    auto px = [&](double v) { return x0 + (std::log10(v) - dx0) / x_decades * (x1 - x0); };
    auto py = [&](double v) { return y1 - (std::log10(v) - dy0) / y_decades * (y1 - y0); };

    draw_text(image, left + (width - text_width(panel.title, scale)) / 2, top + 8, panel.title,
              black, scale);
    // Grid and ticks: a line per decade, short ticks at 2..9 times it.
    for (int d = dx0; d <= dx0 + x_decades; ++d) {
        const double x = px(std::pow(10.0, d));
        draw_line(image, x, y0, x, y1, grid, 1);
        const std::string label = decade_label(d);
        draw_text(image, int(x) - text_width(label, scale) / 2, y1 + 8, label, black, scale);
        for (int m = 2; m <= 9 && d < dx0 + x_decades; ++m) {
            const double xm = px(m * std::pow(10.0, d));
            draw_line(image, xm, y1 - 5, xm, y1, black, 1);
        }
    }
    for (int d = dy0; d <= dy0 + y_decades; ++d) {
        const double y = py(std::pow(10.0, d));
        draw_line(image, x0, y, x1, y, grid, 1);
        const std::string label = decade_label(d);
        draw_text(image, x0 - 8 - text_width(label, scale), int(y) - glyph_height, label, black,
                  scale);
        for (int m = 2; m <= 9 && d < dy0 + y_decades; ++m) {
            const double ym = py(m * std::pow(10.0, d));
            draw_line(image, x0, ym, x0 + 5, ym, black, 1);
        }
    }
    draw_line(image, x0, y1, x1, y1, black, 2);  // the axes
    draw_line(image, x0, y0, x0, y1, black, 2);
    draw_text(image, (x0 + x1 - text_width(panel.x_label, scale)) / 2, y1 + 30, panel.x_label,
              black, scale);
    draw_text_upwards(image, left + 6, (y0 + y1 + text_width(panel.y_label, scale)) / 2,
                      panel.y_label, black, scale);

    // Curves: lines between consecutive points, a square at each, its note beside it.
    for (const Series& s : panel.series) {
        bool has_previous = false;
        double previous_x = 0, previous_y = 0;
        for (size_t n = 0; n < s.x.size(); ++n) {
            if (s.x[n] <= 0 || s.y[n] <= 0) continue;
            const double x = px(s.x[n]), y = py(s.y[n]);
            if (has_previous) draw_line(image, previous_x, previous_y, x, y, s.colour, 2);
            fill_rect(image, int(x) - 3, int(y) - 3, 7, 7, s.colour);
            if (n < s.notes.size()) draw_text(image, int(x) + 6, int(y) + 4, s.notes[n], note);
            has_previous = true, previous_x = x, previous_y = y;
        }
    }
    // Legend, below the x label: a sample of each line and its label.
    for (int n = 0; n < legend_rows; ++n) {
        const Series& s = panel.series[n];
        const int y = y1 + 56 + n * 20;
        draw_line(image, x0, y + 6, x0 + 30, y + 6, s.colour, 2);
        fill_rect(image, x0 + 12, y + 3, 7, 7, s.colour);
        draw_text(image, x0 + 40, y, s.label, black, scale);
    }
}

// Panels side by side on a white picture.
inline Image draw_panels(const std::vector<Panel>& panels, int panel_width, int panel_height) {
    Image image(panel_width * int(panels.size()), panel_height);
    std::fill(image.pixels.begin(), image.pixels.end(), Rgb{1, 1, 1});
    for (size_t n = 0; n < panels.size(); ++n) {
        draw_panel(image, panels[n], int(n) * panel_width, 0, panel_width, panel_height);
    }
    return image;
}

}  // namespace plot
