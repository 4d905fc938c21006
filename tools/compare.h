// compare.h: how close a student's picture is to the reference, as build/grade measures it.
// Both pictures are first quantised to 8 bits per channel (to_byte), so a PNG read back
// compares exactly with the image that was written; every error is in 8-bit units (0..255).
#pragma once
#include <string>
#include <utility>
#include <vector>
#include "image.h"

namespace ctlab {

struct Comparison {
    int width = 0, height = 0;
    double tolerance = 0;      // 8-bit units: a channel error above this fails the pixel
    int max_abs = 0;           // largest channel error
    double mean_abs = 0;       // mean channel error over every channel of every pixel
    double rmse = 0;           // root mean square channel error
    double psnr_db = 0;        // 20 log10(255 / rmse); +infinity when the pictures are equal
    double over_tol_pct = 0;   // percentage of pixels whose largest channel error > tolerance
    bool pass = false;         // no pixel beyond the tolerance
};

// Compares two pictures of the same size. The names are for the size-mismatch InputError
// "STUDENT is WxH but REFERENCE is WxH".
Comparison compare_images(const Image& student, const Image& reference, double tolerance,
                          const std::string& student_name = "the student image",
                          const std::string& reference_name = "the reference image");

// The comparison as text, (name, value) in this order: max_abs, mean_abs, rmse, psnr_db
// ("inf" for equal pictures), over_tol_pct, tol, result ("pass" or "fail").
std::vector<std::pair<std::string, std::string>> comparison_fields(const Comparison& c);
// The same as one line: "max_abs=.. mean_abs=.. ... tol=.. result=pass|fail".
std::string comparison_line(const Comparison& comparison);
std::string format_psnr(double psnr_db);  // "48.13" or "inf"

// A heat map of the channel error per pixel: black where equal, then dark blue (within the
// tolerance), magenta, yellow and white at the largest error. With `legend`, a colour bar is
// added below the picture (when it is at least legend_min_width wide), its ticks labelled
// 0, the tolerance and the largest error.
constexpr int legend_min_width = 32;  // pixels: narrower heat maps get no legend
Image diff_heat_map(const Image& student, const Image& reference, double tolerance,
                    bool legend = true);

// Where an error sits on the heat-map ramp, 0..1 (0 = equal, 1 = the largest error).
double heat_position(double error, double tolerance, double max_error);
Rgb heat_colour(double position);

}  // namespace ctlab
