// ray_plot.h: one ray, drawn. --debug-pixel X,Y writes OUT/NN_name_<view>_ray_X_Y.png beside
// the text trace: along the ray (t across, in samples and physical units) the sample value over
// the threshold or the transfer function's ranges as coloured bands, the opacity, the
// transparency T, the light L, the accumulated colour C as a strip, and marks where the ray
// hit, was terminated early or leapt; beside it the rendered image with the pixel marked and
// its ray drawn in the other views. OUT/NN_name_<view>_ray_X_Y.txt holds the numbers it was
// drawn from.
//
// Nothing here knows a step: the picture is made from the trace's typed records (render.h),
// by their kind and their fields' names, so a step gets the panels for what it records:
//   a sample   a sample record (or a bisection's) at "t" (physical units) or "n" (sample
//              index, one per voxel), with "value" and what it has of "rgba.a", "L", "C.r..b",
//              "T", "max"; a sample that hit the threshold is marked as a hit
//   hit        a hit record: step 05's crossing at n + fraction, step 17's hit point at "t"
//   terminated a stop record, at the last sample's "t" or "n"
//   leapt      a leap record: from "t" to "t_end"
//   the box    part 2: a box record, entry "t" to "t_exit" (or that the ray missed the box)
//   the ray    part 2: a ray record, "origin" and "direction" (physical units): the camera
//              ray, drawn through the box in the axis views beside the plot (mip_views)
#pragma once
#include <string>
#include <vector>
#include "image.h"
#include "render.h"
#include "transfer_function.h"
#include "vec3.h"
#include "view.h"

namespace ctlab {

// A range of sample values drawn as a coloured band behind the value curve.
struct ValueBand {
    double from = 0, to = 0;  // value range [from, to)
    Rgb colour;
    double opacity = 0;       // how strongly it is shaded (the range's alpha, or 1)
    std::string label;
};

std::vector<ValueBand> threshold_bands(double threshold);  // "> threshold", to +infinity
std::vector<ValueBand> transfer_function_bands(const TransferFunction& tf);

struct RaySample {
    double t = 0;         // physical units along the ray (from its first voxel; part 2: from
                          // the camera)
    double n = -1;        // sample position in voxels along the ray axis (-1: camera ray)
    double value = 0;
    bool has_alpha = false, has_transparency = false, has_light = false, has_colour = false;
    double alpha = 0, transparency = 1, light = 1;
    Rgb colour;           // C accumulated so far
    bool has_max = false;  // step 01's maximum intensity so far
    double max = 0;
    bool hit = false;
    bool starts_line = false;  // object order: the first sample of the next intermediate
                               // pixel's samples (no line from the one before)
};

struct RayMark {
    enum Kind { hit, terminated, leapt, box } kind = hit;
    double from = 0, to = 0;  // t; from == to for a point
};

struct RayPlot {
    std::string title;              // "08_compositing_order front ray x=128 y=30"
    std::vector<RaySample> samples;
    std::vector<RayMark> marks;
    std::vector<ValueBand> bands;
    double t_end = 0;               // where the ray ends (physical units)
    double spacing = 0;             // physical units per voxel along the ray (0: camera)
    Rgb pixel;                      // the pixel's value
    bool missed = false;            // part 2: the ray missed the box
    bool has_ray = false;           // part 2: the trace gave the camera ray
    Vec3d origin, direction;        // ... p = origin + t * direction, physical units
    std::vector<TraceRecord> records;  // the whole trace, every line with its fields
};

// The plot of a traced ray: its samples and marks from the records' fields.
RayPlot ray_plot_from_trace(const std::vector<TraceRecord>& records, const View& view,
                            std::vector<ValueBand> bands, Rgb pixel, const std::string& title);

// The rendered views for the picture's right-hand side: the traced one first.
struct RayPlotView {
    View view;
    Image image;
};

// The picture: the plot, and beside it the traced view with the pixel marked and the other
// axis views with the ray drawn across them: thin where it runs, thick where it was sampled
// (up to the hit or the stop, marked with a cross); part 2: the camera ray from where it
// enters the box to where it leaves it, in each axis view (no views: the plot alone, as the
// window's panel).
Image draw_ray_plot(const RayPlot& plot, const std::vector<RayPlotView>& views, int x, int y);

// The pixels of a view's image that a ray picture shows (each view shrunk to its box, nearest
// pixel): as the traced view, as one of the others, or both. Pixel (x, y) is shown when
// columns[x] && rows[y]; a picture made without the whole render (--trace-only) casts those
// rays alone, the others are never drawn.
struct ShownPixels {
    std::vector<bool> columns, rows;
};
ShownPixels ray_picture_pixels(const View& view, bool as_traced, bool as_other);

// The axis views of the volume itself, for a camera ray's picture (part 2 renders no axis
// views): each the maximum value along its rays, grey from the volume's minimum to maximum.
// shown_only: only the pixels a picture shows of them (ray_picture_pixels), the rest black.
std::vector<RayPlotView> mip_views(const Volume& volume, bool shown_only = false);

// The numbers the picture was drawn from, one line per sample (the ray picture's sidecar):
//   # sample t n value alpha T L C.r C.g C.b max     ("-" where the trace has none)
//   sample 43 43 10 0.12 0.7744 - 0.2256 0.178224 0.13536 -
//   mark hit 48 48
//   pixel 0.995778 0.896602 0.806871
// (part 2's ray as "ray origin.i origin.j origin.k direction.i direction.j direction.k")
// then every trace line, its text and its fields (make check compares these with the
// reference's, data/reference/traces/):
//   record<TAB>n= 43 voxel (128, 43, 30) value=   10 ...<TAB>n=43 voxel.i=128 ... value=10 ...
// Each record line ends with a fourth column, its kind and flags: "<TAB>sample hit".
std::string ray_plot_text(const RayPlot& plot);

// The records of a sidecar, read back from its record lines (the machine form: the text column
// is kept as it is, never parsed; a line without the kind column reads as a note).
std::vector<TraceRecord> trace_records_from_text(const std::string& sidecar);

// "sample", "hit", "leap", ...: the kind's name in the sidecar.
const char* trace_kind_name(TraceKind kind);

// Where the marks are, in one line: "hit t=47.2857 stop t=50" ("" when none).
std::string ray_plot_marks(const RayPlot& plot);

// "out/08_compositing_order_front_ray_128_30.png" (.txt for the sidecar).
std::string ray_plot_path(const std::string& out, const std::string& step, const View& view,
                          int x, int y, const std::string& extension);

}  // namespace ctlab
