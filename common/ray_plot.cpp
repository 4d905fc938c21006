// ray_plot.cpp: the ray picture of --debug-pixel (see ray_plot.h).
#include "ray_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "plot.h"

namespace ctlab {

namespace {

// Layout, in picture pixels.
constexpr int title_height = 16;
constexpr int plot_left = 76;  // room for the value labels
constexpr int plot_width = 400;
constexpr int panel_gap = 6;
constexpr int value_panel_height = 96;
constexpr int unit_panel_height = 40;  // opacity, light, T: 0..1
constexpr int strip_height = 14;       // the accumulated colour
constexpr int axis_height = 34;        // two rows of tick labels
constexpr int column_gap = 16;
constexpr int image_column = 208;    // the views, right of the plot
constexpr int main_image_box = 200;  // the traced view fits in this square
constexpr int small_image_box = 96;  // each other view
constexpr int margin = 6;
constexpr int dots_up_to = 160;  // samples drawn with a dot each when there are few
constexpr int small_gap = 8;             // between the small views
constexpr int label_height = 12;         // a small view's name under it

const Rgb white = {1, 1, 1}, black = {0, 0, 0}, grid = {0.85f, 0.85f, 0.85f};
const Rgb text_grey = {0.3f, 0.3f, 0.3f}, panel_back = {0.97f, 0.97f, 0.97f};
const Rgb value_colour = {0.1f, 0.1f, 0.1f}, alpha_colour = {0.85f, 0.45f, 0.0f};
const Rgb transparency_colour = {0.1f, 0.3f, 0.85f}, light_colour = {0.1f, 0.6f, 0.2f};
const Rgb hit_colour = {0.9f, 0.0f, 0.0f}, terminated_colour = {0.7f, 0.0f, 0.7f};
const Rgb leapt_colour = {0.82f, 0.9f, 1.0f}, outside_colour = {0.88f, 0.88f, 0.88f};
const Rgb entry_colour = {0.0f, 0.75f, 0.2f}, stop_colour = {1.0f, 0.85f, 0.0f};

Rgb mix(Rgb a, Rgb b, float f) {
    return {a.r + f * (b.r - a.r), a.g + f * (b.g - a.g), a.b + f * (b.b - a.b)};
}

Rgb clamped(Rgb c) {
    auto unit = [](float v) { return std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f; };
    return {unit(c.r), unit(c.g), unit(c.b)};
}

std::string number_text(double value) {
    char text[32];
    if (std::fabs(value) >= 1000 || value == std::floor(value)) {
        std::snprintf(text, sizeof text, "%.0f", value);
    } else {
        std::snprintf(text, sizeof text, "%.3g", value);
    }
    return text;
}

// 1, 2 or 5 times a power of ten, about range / wanted.
double nice_step(double range, int wanted) {
    const double raw = range / std::max(1, wanted);
    const double power = std::pow(10.0, std::floor(std::log10(std::max(raw, 1e-12))));
    for (double m : {1.0, 2.0, 5.0, 10.0}) {
        if (m * power >= raw) return m * power;
    }
    return 10 * power;
}

// A picture shrunk or grown (nearest pixel) to fit a box, rows stretched by their physical size.
struct Placed {
    int left = 0, top = 0, width = 0, height = 0;
    int source_width = 1, source_height = 1;
    double x(double source_x) const { return left + (source_x + 0.5) * width / source_width; }
    double y(double source_y) const { return top + (source_y + 0.5) * height / source_height; }
};

// Where an image of width x height pixels would sit in a box x box square at (left, top),
// without drawing it.
Placed fitted(int width, int height, const View& view, int box, int left = 0, int top = 0) {
    Placed placed;
    placed.left = left, placed.top = top;
    placed.source_width = std::max(1, width), placed.source_height = std::max(1, height);
    const bool sizes = view.pixel_width > 0 && view.pixel_height > 0;
    const double wide = placed.source_width * (sizes ? view.pixel_width : 1.0);
    const double tall = placed.source_height * (sizes ? view.pixel_height : 1.0);
    const double scale = box / std::max(wide, tall);
    placed.width = std::max(1, int(std::lround(wide * scale)));
    placed.height = std::max(1, int(std::lround(tall * scale)));
    return placed;
}

Placed fitted(const Image& image, const View& view, int box, int left = 0, int top = 0) {
    return fitted(image.width, image.height, view, box, left, top);
}

// The source pixel (column or row, of `size`) that pixel n of its placed copy (`placed` wide
// or tall) shows: the nearest one.
int shown_source(int n, int size, int placed) {
    return std::min(size - 1, int(int64_t(n) * size / placed));
}

Placed place_image(Image& picture, const Image& image, const View& view, int left, int top,
                   int box) {
    const Placed placed = fitted(image, view, box, left, top);
    if (image.width <= 0 || image.height <= 0) return placed;
    for (int y = 0; y < placed.height; ++y) {
        const int source_y = shown_source(y, image.height, placed.height);
        for (int x = 0; x < placed.width; ++x) {
            const int source_x = shown_source(x, image.width, placed.width);
            plot::put(picture, left + x, top + y, clamped(image.at(source_x, source_y)));
        }
    }
    plot::draw_line(picture, left - 1, top - 1, left + placed.width, top - 1, grid, 1);
    plot::draw_line(picture, left - 1, top + placed.height, left + placed.width,
                    top + placed.height, grid, 1);
    return placed;
}

// Does the traced ray show in another axis view? Part 1: a ray along another axis; part 2:
// the camera ray, when the trace gave it.
bool crosses(const RayPlot& plot, const View& traced, const View& other) {
    if (other.camera) return false;
    return traced.camera ? plot.has_ray : traced.axis != other.axis;
}

// The point at t along the traced ray (pixel x, y), in the pixel coordinates of another axis
// view (column, row; fractions between pixel centres). Part 1: voxel n = t / spacing along
// the traced view's axis; part 2: p = origin + t * direction, in physical units, over the
// other view's pixel sizes (its voxel spacing across and down).
void project(const RayPlot& plot, const View& traced, int x, int y, const View& other, double t,
             double* ox, double* oy) {
    double i = 0, j = 0, k = 0;  // voxel units
    if (traced.camera) {
        const Vec3d p = plot.origin + t * plot.direction;
        const double across = other.pixel_width > 0 ? other.pixel_width : 1;
        const double down = other.pixel_height > 0 ? other.pixel_height : 1;
        switch (other.axis) {
            case ViewAxis::top: *ox = p.i / across, *oy = p.j / down; return;
            case ViewAxis::front: *ox = p.i / across, *oy = p.k / down; return;
            default: *ox = p.j / across, *oy = p.k / down; return;
        }
    }
    const double n = t / std::max(traced.ray_spacing, 1e-12);
    switch (traced.axis) {
        case ViewAxis::top: i = x, j = y, k = n; break;
        case ViewAxis::front: i = x, j = n, k = y; break;
        default: i = n, j = x, k = y; break;
    }
    switch (other.axis) {
        case ViewAxis::top: *ox = i, *oy = j; return;
        case ViewAxis::front: *ox = i, *oy = k; return;
        default: *ox = j, *oy = k; return;
    }
}

// Clips the segment (x0, y0)-(x1, y1) to the pixels of a width x height view (their edges at
// -0.5 and width - 0.5); false when nothing of it is inside (Liang-Barsky).
bool clip(double* x0, double* y0, double* x1, double* y1, int width, int height) {
    double a = 0, b = 1;
    const double dx = *x1 - *x0, dy = *y1 - *y0;
    const double p[] = {-dx, dx, -dy, dy};
    const double q[] = {*x0 + 0.5, width - 0.5 - *x0, *y0 + 0.5, height - 0.5 - *y0};
    for (int e = 0; e < 4; ++e) {
        if (p[e] == 0) {
            if (q[e] < 0) return false;
            continue;
        }
        const double r = q[e] / p[e];
        if (p[e] < 0) a = std::max(a, r);
        else b = std::min(b, r);
    }
    if (!(a <= b)) return false;  // NaN too
    const double sx = *x0, sy = *y0;
    *x0 = sx + a * dx, *y0 = sy + a * dy;
    *x1 = sx + b * dx, *y1 = sy + b * dy;
    return true;
}

void draw_marker(Image& picture, double cx, double cy) {
    constexpr int arm = 6, gap = 2;
    plot::draw_line(picture, cx - arm, cy, cx - gap, cy, hit_colour, 1);
    plot::draw_line(picture, cx + gap, cy, cx + arm, cy, hit_colour, 1);
    plot::draw_line(picture, cx, cy - arm, cx, cy - gap, hit_colour, 1);
    plot::draw_line(picture, cx, cy + gap, cx, cy + arm, hit_colour, 1);
}

}  // namespace

std::vector<ValueBand> threshold_bands(double threshold) {
    ValueBand above;
    above.from = threshold;
    above.to = std::numeric_limits<double>::infinity();
    above.colour = {1.0f, 0.55f, 0.55f};
    above.opacity = 1;
    above.label = "> " + number_text(threshold);
    return {above};
}

std::vector<ValueBand> transfer_function_bands(const TransferFunction& tf) {
    std::vector<ValueBand> bands;
    for (const TfRange& range : tf.ranges) {
        ValueBand band;
        band.from = range.from, band.to = range.to;
        band.colour = {range.start.r, range.start.g, range.start.b};
        band.opacity = std::max(range.start.a, range.end.a);
        band.label = range.label.empty() ? number_text(range.from) : range.label;
        bands.push_back(band);
    }
    return bands;
}

RayPlot ray_plot_from_trace(const std::vector<TraceRecord>& records, const View& view,
                            std::vector<ValueBand> bands, Rgb pixel, const std::string& title) {
    RayPlot plot;
    plot.records = records;
    plot.title = title;
    plot.bands = std::move(bands);
    plot.pixel = pixel;
    plot.spacing = view.camera ? 0 : view.ray_spacing;
    plot.t_end = view.camera ? 0 : (view.ray_length - 1) * view.ray_spacing;
    // Where a record says it is: "t" in physical units, else "n" in samples (one per voxel).
    auto where = [&](const TraceRecord& record, double* t) {
        if (record.has("t")) return *t = record.number("t", 0), true;
        if (record.has("n") && !view.camera) return *t = record.number("n", 0) * plot.spacing, true;
        return false;
    };
    // Object order: each intermediate pixel the warp blends is traced after a note of its
    // weight; its samples are a line of their own, not joined to the pixel's before.
    bool starts_line = false;
    for (const TraceRecord& record : records) {
        double t = 0;
        if (record.kind == TraceKind::note && record.has("weight")) starts_line = true;
        switch (record.kind) {
            case TraceKind::ray:
                plot.has_ray = true;
                plot.origin = {record.number("origin.i", 0), record.number("origin.j", 0),
                               record.number("origin.k", 0)};
                plot.direction = {record.number("direction.i", 0),
                                  record.number("direction.j", 0),
                                  record.number("direction.k", 0)};
                continue;
            case TraceKind::sample:
            case TraceKind::bisection:  // step 17's halvings are samples of the ray too
                break;
            default:
                break;
        }
        switch (record.kind) {
            case TraceKind::hit:
                if (record.has("t")) {
                    // part 2's surface hit (step 17)
                    t = record.number("t", 0);
                    plot.marks.push_back({RayMark::hit, t, t});
                } else if (!view.camera) {
                    // step 05's crossing: a fraction past sample n
                    const double at =
                        (record.number("n", 0) + record.number("fraction", 0)) * plot.spacing;
                    if (!plot.marks.empty() && plot.marks.back().kind == RayMark::hit) {
                        plot.marks.back().from = plot.marks.back().to = at;  // interpolated
                    } else {
                        plot.marks.push_back({RayMark::hit, at, at});
                    }
                }
                continue;
            case TraceKind::box:
                if (record.missed) {
                    plot.missed = true;
                } else {
                    RayMark box;
                    box.kind = RayMark::box;
                    box.from = record.number("t", 0), box.to = record.number("t_exit", 0);
                    plot.marks.push_back(box);
                    plot.t_end = std::max(plot.t_end, box.to);
                }
                continue;
            case TraceKind::stop:
                if (where(record, &t)) plot.marks.push_back({RayMark::terminated, t, t});
                continue;
            case TraceKind::leap:
                plot.marks.push_back(
                    {RayMark::leapt, record.number("t", 0), record.number("t_end", 0)});
                continue;
            case TraceKind::sample:
            case TraceKind::bisection:
                break;
            default:
                continue;  // notes, shading: no mark
        }
        if (!where(record, &t)) continue;  // step 00's voxel: no place along a ray
        RaySample sample;
        sample.t = t;
        sample.n = view.camera       ? -1
                   : record.has("n") ? record.number("n", 0)
                                     : t / std::max(plot.spacing, 1e-12);
        sample.value = record.number("value", 0);
        if (record.has("rgba.a"))
            sample.has_alpha = true, sample.alpha = record.number("rgba.a", 0);
        if (record.has("T")) {
            sample.has_transparency = true, sample.transparency = record.number("T", 1);
        }
        if (record.has("L")) sample.has_light = true, sample.light = record.number("L", 1);
        if (record.has("C.r")) {
            sample.has_colour = true;
            sample.colour = {float(record.number("C.r", 0)), float(record.number("C.g", 0)),
                             float(record.number("C.b", 0))};
        }
        if (record.has("max")) sample.has_max = true, sample.max = record.number("max", 0);
        sample.hit = record.hit;
        sample.starts_line = starts_line;
        starts_line = false;
        if (sample.hit) plot.marks.push_back({RayMark::hit, t, t});
        plot.samples.push_back(sample);
        plot.t_end = std::max(plot.t_end, t);
    }
    return plot;
}

std::string ray_plot_text(const RayPlot& plot) {
    std::string text = "# " + plot.title + "\n# sample t n value alpha T L C.r C.g C.b max\n";
    char line[256];
    auto optional = [](bool has, double value) {
        if (!has) return std::string("-");
        char number[32];
        std::snprintf(number, sizeof number, "%.9g", value);
        return std::string(number);
    };
    auto sample_line = [&](const char* kind, const RaySample& s) {
        std::snprintf(
            line, sizeof line, "%s %.9g %.9g %.9g %s %s %s %s %s %s %s\n", kind, s.t, s.n, s.value,
            optional(s.has_alpha, s.alpha).c_str(),
            optional(s.has_transparency, s.transparency).c_str(),
            optional(s.has_light, s.light).c_str(), optional(s.has_colour, s.colour.r).c_str(),
            optional(s.has_colour, s.colour.g).c_str(), optional(s.has_colour, s.colour.b).c_str(),
            optional(s.has_max, s.max).c_str());
        text += line;
    };
    for (const RaySample& s : plot.samples) sample_line("sample", s);
    if (plot.has_ray) {
        std::snprintf(line, sizeof line, "ray %.9g %.9g %.9g %.9g %.9g %.9g\n", plot.origin.i,
                      plot.origin.j, plot.origin.k, plot.direction.i, plot.direction.j,
                      plot.direction.k);
        text += line;
    }
    const char* kinds[] = {"hit", "terminated", "leapt", "box"};
    for (const RayMark& m : plot.marks) {
        std::snprintf(line, sizeof line, "mark %s %.9g %.9g\n", kinds[m.kind], m.from, m.to);
        text += line;
    }
    std::snprintf(line, sizeof line, "pixel %.6f %.6f %.6f\n", plot.pixel.r, plot.pixel.g,
                  plot.pixel.b);
    text += line;
    for (const TraceRecord& record : plot.records) {
        text += "record\t" + record.text + "\t";
        for (size_t n = 0; n < record.fields.size(); ++n) {
            const TraceField& field = record.fields[n];
            std::snprintf(line, sizeof line, "%s%s=%.9g", n ? " " : "", field.name.c_str(),
                          field.number);
            text += line;
        }
        // The record's kind and flags last: a reader of the first three columns (older
        // reference traces have only those) sees words without '=' and passes them by.
        text += std::string("\t") + trace_kind_name(record.kind);
        if (record.hit) text += " hit";
        if (record.missed) text += " missed";
        text += "\n";
    }
    return text;
}

const char* trace_kind_name(TraceKind kind) {
    switch (kind) {
        case TraceKind::sample: return "sample";
        case TraceKind::hit: return "hit";
        case TraceKind::leap: return "leap";
        case TraceKind::stop: return "stop";
        case TraceKind::ray: return "ray";
        case TraceKind::box: return "box";
        case TraceKind::bisection: return "bisection";
        case TraceKind::shade: return "shade";
        case TraceKind::note: return "note";
    }
    return "note";
}

std::vector<TraceRecord> trace_records_from_text(const std::string& sidecar) {
    static const TraceKind kinds[] = {TraceKind::sample, TraceKind::hit,   TraceKind::leap,
                                      TraceKind::stop,   TraceKind::ray,   TraceKind::box,
                                      TraceKind::bisection, TraceKind::shade,
                                      TraceKind::note};
    std::vector<TraceRecord> records;
    size_t start = 0;
    while (start < sidecar.size()) {
        size_t end = sidecar.find('\n', start);
        if (end == std::string::npos) end = sidecar.size();
        const std::string line = sidecar.substr(start, end - start);
        start = end + 1;
        if (line.rfind("record\t", 0) != 0) continue;
        // Columns: "record", the text, the fields, the kind and its flags (absent: a note).
        std::vector<std::string> columns;
        for (size_t from = 0;;) {
            const size_t tab = line.find('\t', from);
            columns.push_back(line.substr(from, tab == std::string::npos ? tab : tab - from));
            if (tab == std::string::npos) break;
            from = tab + 1;
        }
        TraceRecord record;
        record.text = columns.size() > 1 ? columns[1] : "";
        std::istringstream fields(columns.size() > 2 ? columns[2] : "");
        for (std::string word; fields >> word;) {
            const size_t equals = word.rfind('=');
            if (equals == std::string::npos || equals == 0) continue;
            char* after = nullptr;
            const double value = std::strtod(word.c_str() + equals + 1, &after);
            if (after == word.c_str() + equals + 1 || *after != '\0') continue;
            record.fields.push_back({word.substr(0, equals), value});
        }
        std::istringstream kind(columns.size() > 3 ? columns[3] : "");
        std::string word;
        if (kind >> word) {
            for (TraceKind k : kinds) {
                if (word == trace_kind_name(k)) record.kind = k;
            }
            while (kind >> word) {
                record.hit = record.hit || word == "hit";
                record.missed = record.missed || word == "missed";
            }
        }
        records.push_back(std::move(record));
    }
    return records;
}

std::string ray_plot_marks(const RayPlot& plot) {
    std::string text;
    char mark[96];
    for (const RayMark& m : plot.marks) {
        switch (m.kind) {
            case RayMark::hit: std::snprintf(mark, sizeof mark, "hit t=%g", m.from); break;
            case RayMark::terminated: std::snprintf(mark, sizeof mark, "stop t=%g", m.from); break;
            case RayMark::leapt:
                std::snprintf(mark, sizeof mark, "leap t=%g..%g", m.from, m.to);
                break;
            case RayMark::box:
                std::snprintf(mark, sizeof mark, "box t=%g..%g", m.from, m.to);
                break;
        }
        text += (text.empty() ? "" : " ") + std::string(mark);
    }
    return text;
}

ShownPixels ray_picture_pixels(const View& view, bool as_traced, bool as_other) {
    ShownPixels shown;
    shown.columns.assign(size_t(std::max(0, view.width)), false);
    shown.rows.assign(size_t(std::max(0, view.height)), false);
    if (view.width <= 0 || view.height <= 0) return shown;
    for (const bool traced : {true, false}) {
        if (!(traced ? as_traced : as_other)) continue;
        const Placed placed = fitted(view.width, view.height, view,
                                     traced ? main_image_box : small_image_box);
        for (int x = 0; x < placed.width; ++x) {
            shown.columns[size_t(shown_source(x, view.width, placed.width))] = true;
        }
        for (int y = 0; y < placed.height; ++y) {
            shown.rows[size_t(shown_source(y, view.height, placed.height))] = true;
        }
    }
    return shown;
}

std::vector<RayPlotView> mip_views(const Volume& volume, bool shown_only) {
    std::vector<RayPlotView> views;
    const double low = volume.min_value;
    const double range = std::max(1.0, double(volume.max_value) - low);
    for (const View& view : views_named(volume, "all")) {
        Image image(view.width, view.height);
        const ShownPixels shown = ray_picture_pixels(view, false, true);
        for (int y = 0; y < view.height; ++y) {
            if (shown_only && !shown.rows[size_t(y)]) continue;
            for (int x = 0; x < view.width; ++x) {
                if (shown_only && !shown.columns[size_t(x)]) continue;
                const RayVoxels ray = ray_voxels(volume, view, x, y);
                int highest = volume.min_value;
                for (int n = 0; n < view.ray_length; ++n) highest = std::max<int>(highest, ray[n]);
                const float grey = float((highest - low) / range);
                image.at(x, y) = {grey, grey, grey};
            }
        }
        views.push_back({view, image});
    }
    return views;
}

std::string ray_plot_path(const std::string& out, const std::string& step, const View& view, int x,
                          int y, const std::string& extension) {
    return out + "/" + step + "_" + view.name + "_ray_" + std::to_string(x) + "_" +
           std::to_string(y) + extension;
}

Image draw_ray_plot(const RayPlot& plot, const std::vector<RayPlotView>& views, int x, int y) {
    bool any_alpha = false, any_transparency = false, any_light = false, any_colour = false;
    for (const RaySample& s : plot.samples) {
        any_alpha = any_alpha || s.has_alpha;
        any_transparency = any_transparency || s.has_transparency;
        any_light = any_light || s.has_light;
        any_colour = any_colour || s.has_colour;
    }
    struct Panel {
        int top, height;
        std::string name;
    };
    std::vector<Panel> panels;
    int next_top = title_height + 8;
    auto add_panel = [&](const std::string& name, int height) {
        panels.push_back({next_top, height, name});
        next_top += height + panel_gap;
    };
    add_panel("value", value_panel_height);
    if (any_alpha) add_panel("opacity", unit_panel_height);
    if (any_light) add_panel("light L", unit_panel_height);
    if (any_transparency) add_panel("T", unit_panel_height);
    if (any_colour) add_panel("C", strip_height);
    const int plot_bottom = next_top - panel_gap;
    const int plot_height = plot_bottom + axis_height + margin;

    // The views beside the plot: the traced one, and below it the others the ray crosses.
    std::vector<const RayPlotView*> others;
    for (size_t n = 1; n < views.size(); ++n) {
        if (crosses(plot, views.front().view, views[n].view)) others.push_back(&views[n]);
    }
    int others_width = 0;
    for (const RayPlotView* other : others) {
        others_width += (others_width ? small_gap : 0) +
                        fitted(other->image, other->view, small_image_box).width;
    }
    const int column = std::max(image_column, others_width);
    const int images_height =
        views.empty() ? 0
                      : title_height + 8 + main_image_box + 8 + small_image_box + label_height +
                            margin;
    const int width = plot_left + plot_width + (views.empty() ? margin : column_gap + column);
    Image picture(width, std::max(plot_height, images_height));
    std::fill(picture.pixels.begin(), picture.pixels.end(), white);

    char heading[256];
    std::snprintf(heading, sizeof heading, "%s  rgb=(%.3f, %.3f, %.3f)", plot.title.c_str(),
                  plot.pixel.r, plot.pixel.g, plot.pixel.b);
    plot::draw_text(picture, margin, 4, heading, black);

    // --- The t axis: from the first voxel (part 2: the box entry) to the ray's end ---
    double t0 = 0, t1 = std::max(plot.t_end, 1e-9);
    if (plot.spacing == 0) {  // a camera ray: from the box entry, or the first sample
        t0 = plot.samples.empty() ? 0 : plot.samples.front().t;
        for (const RayMark& m : plot.marks) {
            if (m.kind == RayMark::box) t0 = m.from, t1 = std::max(t1, m.to);
        }
        if (t1 <= t0) t1 = t0 + 1;
    }
    // Kept within a million pixels of the plot (NaN: at its left edge): a degenerate t range
    // (a 1-voxel volume) or an infinite leap end must not overflow an int further on.
    constexpr double px_limit = 1e6;
    auto px = [&](double t) {
        const double x = plot_left + (t - t0) / (t1 - t0) * (plot_width - 1);
        return std::isnan(x) ? double(plot_left) : std::clamp(x, -px_limit, px_limit);
    };
    const int plot_top = panels.front().top;
    // C as the ray had it at column xx: after the last coloured sample at or before it front
    // to back, at or after it back to front (step 07 walks from the far end); black (C = 0,
    // or the background) before the first.
    auto colour_at = [&](const std::vector<RaySample>& samples, int xx) {
        const bool backwards = samples.size() > 1 && samples.front().t > samples.back().t;
        Rgb colour = black;
        for (const RaySample& sample : samples) {
            if (!sample.has_colour) continue;
            const double at = px(sample.t);
            if (backwards ? at >= xx - 0.5 : at <= xx + 0.5) colour = sample.colour;
        }
        return colour;
    };

    // Behind everything: the leaps (light blue) across all panels.
    for (const RayMark& m : plot.marks) {
        if (m.kind != RayMark::leapt) continue;
        const int a = int(std::floor(px(m.from))), b = int(std::ceil(px(m.to)));
        plot::fill_rect(picture, a, plot_top, std::max(1, b - a + 1), plot_bottom - plot_top,
                        leapt_colour);
    }

    for (const Panel& panel : panels) {
        const int top = panel.top, bottom = panel.top + panel.height - 1;
        const bool is_strip = panel.name == "C";
        if (!is_strip) {
            for (int yy = top; yy <= bottom; ++yy) {
                for (int xx = plot_left; xx < plot_left + plot_width; ++xx) {
                    if (picture.at(xx, yy).r == white.r && picture.at(xx, yy).b == white.b) {
                        picture.at(xx, yy) = panel_back;
                    }
                }
            }
        }
        plot::draw_text(picture, margin, top + 1, panel.name, text_grey);
        if (panel.name == "value") {
            double low = 1e300, high = -1e300;
            for (const RaySample& s : plot.samples) {
                low = std::min(low, s.value), high = std::max(high, s.value);
            }
            if (plot.samples.empty()) low = 0, high = 1;
            for (const ValueBand& band : plot.bands) {  // a threshold just outside still shows
                if (std::isfinite(band.from) && band.from > high)
                    high = std::min(band.from, high + (high - low));
            }
            if (high <= low) high = low + 1;
            const double pad = 0.06 * (high - low);
            low -= pad, high += pad;
            auto py = [&](double v) { return bottom - (v - low) / (high - low) * (bottom - top); };
            for (const ValueBand& band : plot.bands) {
                const double a =
                    std::clamp(py(std::min(band.to, high)), double(top), double(bottom));
                const double b =
                    std::clamp(py(std::max(band.from, low)), double(top), double(bottom));
                if (b - a < 1) continue;
                // White (bone) would vanish on white: every band is darkened a little.
                const Rgb fill = mix(mix(band.colour, {0.55f, 0.55f, 0.55f}, 0.25f), panel_back,
                                     float(0.75 - 0.45 * std::min(1.0, band.opacity * 2)));
                plot::fill_rect(picture, plot_left, int(a), plot_width, int(b - a) + 1, fill);
                const Rgb edge = mix(band.colour, black, 0.45f);
                if (band.from > low)
                    plot::draw_line(picture, plot_left, b, plot_left + plot_width - 1, b, edge, 1);
                plot::draw_text(picture,
                                plot_left + plot_width - 2 - plot::text_width(band.label, 1),
                                int(a) + 2, band.label, edge);
            }
            for (double v : {high - pad, low + pad}) {
                const std::string label = number_text(v);
                plot::draw_text(picture, plot_left - 4 - plot::text_width(label, 1), int(py(v)) - 3,
                                label, text_grey);
            }
            for (size_t n = 0; n < plot.samples.size(); ++n) {
                const RaySample& s = plot.samples[n];
                if (n > 0 && !s.starts_line) {
                    const RaySample& p = plot.samples[n - 1];
                    plot::draw_line(picture, px(p.t), py(p.value), px(s.t), py(s.value),
                                    value_colour, 1);
                }
                if (plot.samples.size() <= size_t(dots_up_to)) {
                    plot::fill_rect(picture, int(px(s.t)) - 1, int(py(s.value)) - 1, 3, 3,
                                    s.hit ? hit_colour : value_colour);
                }
                // Step 01: the MIP
                if (n > 0 && !s.starts_line && s.has_max && plot.samples[n - 1].has_max) {
                    const RaySample& p = plot.samples[n - 1];
                    plot::draw_line(picture, px(p.t), py(p.max), px(s.t), py(s.max),
                                    transparency_colour, 1);
                }
            }
        } else if (is_strip) {
            for (int xx = plot_left; xx < plot_left + plot_width; ++xx) {
                plot::fill_rect(picture, xx, top, 1, panel.height,
                                clamped(colour_at(plot.samples, xx)));
            }
        } else {
            auto py = [&](double v) { return bottom - std::clamp(v, 0.0, 1.0) * (bottom - top); };
            plot::draw_text(picture, plot_left - 10, top, "1", text_grey);
            plot::draw_text(picture, plot_left - 10, bottom - 6, "0", text_grey);
            bool has_previous = false;
            double previous_x = 0, previous_y = 0;
            for (const RaySample& s : plot.samples) {
                if (s.starts_line) has_previous = false;
                if (panel.name == "opacity" && s.has_alpha) {
                    plot::draw_line(picture, px(s.t), py(0), px(s.t), py(s.alpha), alpha_colour, 2);
                }
                const bool has =
                    panel.name == "T" ? s.has_transparency : panel.name == "light L" && s.has_light;
                if (!has) continue;
                const double value = panel.name == "T" ? s.transparency : s.light;
                const Rgb colour = panel.name == "T" ? transparency_colour : light_colour;
                if (has_previous) {
                    plot::draw_line(picture, previous_x, previous_y, px(s.t), py(value), colour, 2);
                }
                plot::fill_rect(picture, int(px(s.t)) - 1, int(py(value)) - 1, 3, 3, colour);
                has_previous = true, previous_x = px(s.t), previous_y = py(value);
            }
        }
    }

    // The marks, across every panel, labelled above the value panel.
    int label_right = 0;
    for (const RayMark& m : plot.marks) {
        if (m.kind == RayMark::box) {
            for (double edge : {m.from, m.to}) {
                plot::draw_line(picture, px(edge), plot_top, px(edge), plot_bottom, text_grey, 1);
            }
            continue;
        }
        if (m.kind == RayMark::leapt) continue;
        const Rgb colour = m.kind == RayMark::hit ? hit_colour : terminated_colour;
        const double mx = px(m.from);
        for (int yy = plot_top; yy < plot_bottom; yy += 4) {  // dashed
            plot::draw_line(picture, mx, yy, mx, std::min(yy + 2, plot_bottom), colour, 1);
        }
        const std::string label = m.kind == RayMark::hit ? "hit" : "stop";
        int lx = int(mx) + 3;
        if (lx < label_right) lx = label_right + 2;
        plot::draw_text(picture, lx, plot_top + 2, label, colour);
        label_right = lx + plot::text_width(label, 1);
    }

    // Tick labels: samples (voxels along the axis) and distance in physical units.
    auto ticks = [&](int row, double scale, const std::string& name) {
        const double low = t0 / scale, high = t1 / scale;
        const double step = nice_step(high - low, 8);
        for (double v = std::ceil(low / step) * step; v <= high + 1e-9; v += step) {
            const double xx = px(v * scale);
            plot::draw_line(picture, xx, plot_bottom, xx, plot_bottom + 3, black, 1);
            const std::string label = number_text(v);
            plot::draw_text(picture, int(xx) - plot::text_width(label, 1) / 2, row, label, black);
        }
        plot::draw_text(picture, margin, row, name, text_grey);
    };
    plot::draw_line(picture, plot_left, plot_bottom, plot_left + plot_width - 1, plot_bottom, black,
                    1);
    if (plot.missed && plot.samples.empty()) {
        plot::draw_text(picture, plot_left + 8, plot_top + 20, "missed the box", hit_colour);
    } else if (plot.spacing > 0) {
        ticks(plot_bottom + 6, plot.spacing, "n");
        ticks(plot_bottom + 18, 1.0, "dist");
    } else {
        ticks(plot_bottom + 6, 1.0, "dist");
    }

    // --- The views: the traced one with the pixel marked, the others with its ray ---
    // Part 1 the ray runs from the first voxel (t = 0) to the last, part 2 from the box entry to
    // its exit (a ray that missed: along its whole length, dotted). Thick from its start to
    // where it was last sampled (the hit or the stop, a yellow square), thin beyond.
    double ray_from = 0, ray_to = plot.t_end, walked_to = plot.t_end;
    bool inside_box = !views.empty() && !views.front().view.camera;
    for (const RayMark& m : plot.marks) {
        if (m.kind == RayMark::box) ray_from = m.from, ray_to = m.to, inside_box = true;
    }
    walked_to = ray_to;
    bool has_stop = false;
    for (const RayMark& m : plot.marks) {
        if ((m.kind == RayMark::hit || m.kind == RayMark::terminated) && !has_stop) {
            walked_to = m.from, has_stop = true;
        }
    }
    const int images_left = plot_left + plot_width + column_gap;
    if (!views.empty()) {
        const RayPlotView& traced = views.front();
        const Placed main = place_image(picture, traced.image, traced.view, images_left,
                                        title_height + 8, main_image_box);
        draw_marker(picture, main.x(x), main.y(y));
        int left = images_left;
        const int small_top = main.top + main.height + 8;
        for (const RayPlotView* other : others) {
            const Placed small = place_image(picture, other->image, other->view, left,
                                             small_top, small_image_box);
            const int w = other->image.width, h = other->image.height;
            // A piece of the ray from t = a to t = b, clipped to the view.
            auto piece = [&](double a, double b, Rgb colour, int thickness, bool dotted) {
                double x0, y0, x1, y1;
                project(plot, traced.view, x, y, other->view, a, &x0, &y0);
                project(plot, traced.view, x, y, other->view, b, &x1, &y1);
                if (!clip(&x0, &y0, &x1, &y1, w, h)) return;
                if (!dotted) {
                    plot::draw_line(picture, small.x(x0), small.y(y0), small.x(x1), small.y(y1),
                                    colour, thickness);
                    return;
                }
                const double length = std::hypot(small.x(x1) - small.x(x0),
                                                 small.y(y1) - small.y(y0));
                for (double d = 0; d < length; d += 4) {
                    const double f = d / std::max(length, 1e-9);
                    plot::put(picture, int(std::lround(small.x(x0) + f * (small.x(x1) - small.x(x0)))),
                              int(std::lround(small.y(y0) + f * (small.y(y1) - small.y(y0)))),
                              colour);
                }
            };
            if (traced.view.camera && !inside_box) {
                constexpr double far = 1e5;  // physical units: beyond any volume
                piece(-far, far, hit_colour, 1, true);
            } else {
                if (traced.view.camera) {  // from the camera to the box, dotted
                    piece(std::min(0.0, ray_from), ray_from, hit_colour, 1, true);
                }
                piece(ray_from, ray_to, hit_colour, 1, false);
                piece(ray_from, walked_to, hit_colour, 2, false);
                double sx, sy;
                if (traced.view.camera) {
                    project(plot, traced.view, x, y, other->view, ray_from, &sx, &sy);
                    if (sx > -0.5 && sy > -0.5 && sx < w - 0.5 && sy < h - 0.5) {
                        plot::fill_rect(picture, int(small.x(sx)) - 1, int(small.y(sy)) - 1, 3,
                                        3, entry_colour);
                    }
                }
                project(plot, traced.view, x, y, other->view, walked_to, &sx, &sy);
                if (has_stop && sx > -0.5 && sy > -0.5 && sx < w - 0.5 && sy < h - 0.5) {
                    const int cx = int(small.x(sx)), cy = int(small.y(sy));
                    plot::draw_line(picture, cx - 2, cy - 2, cx + 2, cy - 2, stop_colour, 1);
                    plot::draw_line(picture, cx - 2, cy + 2, cx + 2, cy + 2, stop_colour, 1);
                    plot::draw_line(picture, cx - 2, cy - 2, cx - 2, cy + 2, stop_colour, 1);
                    plot::draw_line(picture, cx + 2, cy - 2, cx + 2, cy + 2, stop_colour, 1);
                }
            }
            plot::draw_text(picture, left, small.top + small.height + 3, other->view.name,
                            text_grey);
            left += small.width + small_gap;
        }
    }
    return picture;
}

}  // namespace ctlab
