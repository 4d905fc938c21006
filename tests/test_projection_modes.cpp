// test_projection_modes.cpp: step 18 (MIP, MinIP, average along the free ray) run as a
// program (tools/run_step.h), against known answers: a linear ramp seen along each axis (the
// largest, smallest and mean value of a column are closed forms), an oblique ray through it
// (linear along the ray: the extremes are its end samples, the mean their midpoint), a slab of
// it, and rays that miss the box or meet only part of it (only samples inside the box count);
// --mode composite is step 15 pixel for pixel.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>
#include "image.h"
#include "tools/run_step.h"
#include "volume.h"

using namespace ctlab;

namespace {

const std::string projection_step = "18_projection_modes";

RunResult render(std::vector<std::string> flags, const TempFolder& folder) {
    flags.insert(flags.end(), {"--out", folder.path(), "--pfm", "--threads", "2"});
    RunResult run = run_step(projection_step, flags);
    INFO(run.command() << "\n" << run.err);
    REQUIRE(run.status == 0);
    return run;
}

Image picture(const TempFolder& folder) {
    return read_pfm(step_output(folder.path(), projection_step, "camera", "pfm"));
}

Volume make_volume(int nx, int ny, int nz, const std::function<int(int, int, int)>& value) {
    Volume volume;
    volume.nx = nx;
    volume.ny = ny;
    volume.nz = nz;
    resize_dense(volume);
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i)
                volume.data[volume.index(i, j, k)] = int16_t(value(i, j, k));
    return volume;
}

// The ramp f = 3i + 5j + 7k on 9 x 8 x 7 voxels, spacing 1: min 0, max 24 + 35 + 42 = 101.
constexpr int nx = 9, ny = 8, nz = 7;
constexpr double ramp_max = 3 * (nx - 1) + 5 * (ny - 1) + 7 * (nz - 1);
double ramp(double i, double j, double k) { return 3 * i + 5 * j + 7 * k; }

// Part 1's grey: (value - min) / (max - min).
double ramp_grey(double value) { return value / ramp_max; }

}  // namespace

TEST_CASE("projection modes: a ramp seen along each axis gives the column's max, min and "
          "mean") {
    const TempFolder folder("projection_axes");
    const std::vector<std::string> volume = write_raw_volume(
        make_volume(nx, ny, nz, [](int i, int j, int k) { return int(ramp(i, j, k)); }),
        folder.path("ramp.raw"));
    // Orthographic, zoom 1, step 1 = the spacing: every sample is a voxel centre. For each
    // camera: the image size, and the column's first voxel and its direction for pixel (x, y).
    struct Axis {
        const char* name;
        std::vector<std::string> flags;
        int width, height, length;  // image size; voxels along the ray
        std::function<double(int, int)> base;  // f of the column's first voxel
        double slope;                           // f's change per voxel along the ray
    };
    const std::vector<Axis> axes = {
        // Down k from the crown: image x = i, y = j (part 1's top view).
        {"k", {"--azimuth", "180", "--elevation", "90"}, nx, ny, nz,
         [](int x, int y) { return ramp(x, y, 0); }, 7},
        // Along +i: image x = j, y = k (part 1's side view).
        {"i", {"--azimuth", "90", "--elevation", "0"}, ny, nz, nx,
         [](int x, int y) { return ramp(0, x, y); }, 3},
        // Along +j, facing the face: image x = -i (part 1's front view, mirrored), y = k.
        {"j", {"--azimuth", "0", "--elevation", "0"}, nx, nz, ny,
         [](int x, int y) { return ramp(nx - 1 - x, 0, y); }, 5},
    };
    for (const Axis& axis : axes) {
        for (const char* mode : {"mip", "minip", "average"}) {
            CAPTURE(axis.name);
            CAPTURE(mode);
            std::vector<std::string> flags = volume;
            flags.insert(flags.end(), axis.flags.begin(), axis.flags.end());
            flags.insert(flags.end(), {"--mode", mode, "--step", "1", "--size",
                                       std::to_string(axis.width) + "x" +
                                           std::to_string(axis.height)});
            const RunResult run = render(flags, folder);
            CHECK(summary_count(run.summary("camera"), "samples") ==
                  (unsigned long long)(axis.width * axis.height * axis.length));
            const Image image = picture(folder);
            double worst = 0;
            for (int y = 0; y < axis.height; ++y)
                for (int x = 0; x < axis.width; ++x) {
                    const double first = axis.base(x, y);
                    const double last = first + axis.slope * (axis.length - 1);
                    double expected = (first + last) / 2;  // the mean of equally spaced samples
                    if (std::string(mode) == "mip") expected = last;
                    if (std::string(mode) == "minip") expected = first;
                    worst = std::max(worst, std::fabs(image.at(x, y).r - ramp_grey(expected)));
                }
            CHECK(worst < 1e-6);
        }
    }
}

TEST_CASE("projection modes: an oblique ray through a ramp has its extremes at its end "
          "samples and its mean at their midpoint") {
    const TempFolder folder("projection_oblique");
    const std::vector<std::string> volume = write_raw_volume(
        make_volume(nx, ny, nz, [](int i, int j, int k) { return int(ramp(i, j, k)); }),
        folder.path("ramp.raw"));
    for (const char* projection : {"ortho", "perspective"}) {
        for (const char* mode : {"mip", "minip", "average"}) {
            CAPTURE(projection);
            CAPTURE(mode);
            std::vector<std::string> flags = volume;
            flags.insert(flags.end(), {"--azimuth", "33", "--elevation", "-21", "--projection",
                                       projection, "--size", "24x24", "--zoom", "2", "--step",
                                       "0.25", "--mode", mode, "--debug-pixel", "12,11"});
            const RunResult run = render(flags, folder);
            REQUIRE(run.traces.size() == 1);
            // The sample points the trace prints; f there by the closed form.
            std::vector<double> values;
            for (const std::string& line : run.traces[0].lines) {
                const size_t at = line.find("p=(");
                double i = 0, j = 0, k = 0;
                if (at != std::string::npos &&
                    std::sscanf(line.c_str() + at, "p=(%lf, %lf, %lf)", &i, &j, &k) == 3) {
                    values.push_back(ramp(i, j, k));
                }
            }
            REQUIRE(values.size() >= 10);
            CHECK(values.size() == run.traces[0].samples);
            const double first = values.front(), last = values.back();
            double expected = (first + last) / 2;
            if (std::string(mode) == "mip") expected = std::max(first, last);
            if (std::string(mode) == "minip") expected = std::min(first, last);
            // The trace's 6 decimals and float trilinear values: 1e-4 of the range.
            CHECK(std::fabs(run.traces[0].rgb.r - ramp_grey(expected)) < 1e-4);
            CHECK(std::fabs(picture(folder).at(12, 11).r - ramp_grey(expected)) < 1e-4);
        }
    }
}

TEST_CASE("projection modes: --interpolation nearest reads the voxel nearest each sample "
          "point, trilinear the ramp's closed form") {
    const TempFolder folder("projection_nearest");
    const std::vector<std::string> volume = write_raw_volume(
        make_volume(nx, ny, nz, [](int i, int j, int k) { return int(ramp(i, j, k)); }),
        folder.path("ramp.raw"));
    // The sample points and values a trace prints (spacing 1: physical = voxel units).
    struct Sample {
        double i, j, k, value;
    };
    auto traced = [&](const char* interpolation) {
        std::vector<std::string> flags = volume;
        flags.insert(flags.end(), {"--azimuth", "33", "--elevation", "-21", "--size", "24x24",
                                   "--zoom", "2", "--step", "0.25", "--mode", "mip",
                                   "--interpolation", interpolation, "--debug-pixel", "12,11"});
        const RunResult run = render(flags, folder);
        REQUIRE(run.traces.size() == 1);
        CHECK(run.out.find(std::string("interpolation=") + interpolation) != std::string::npos);
        std::vector<Sample> samples;
        for (const std::string& line : run.traces[0].lines) {
            const size_t at = line.find("p=(");
            Sample s{};
            if (at != std::string::npos &&
                std::sscanf(line.c_str() + at, "p=(%lf, %lf, %lf) value=%lf", &s.i, &s.j, &s.k,
                            &s.value) == 4) {
                samples.push_back(s);
            }
        }
        CHECK(samples.size() == run.traces[0].samples);
        return samples;
    };
    const std::vector<Sample> nearest = traced("nearest");
    const std::vector<Sample> trilinear = traced("trilinear");
    REQUIRE(nearest.size() >= 10);
    REQUIRE(nearest.size() == trilinear.size());
    double worst_nearest = 0, worst_trilinear = 0, largest_move = 0;
    int checked = 0;
    for (size_t n = 0; n < nearest.size(); ++n) {
        const Sample& s = nearest[n];
        // A point within the trace's rounding of a half-way plane could go either way: skip it.
        auto near_half = [](double u) { return std::fabs(u - std::floor(u) - 0.5) < 1e-5; };
        if (near_half(s.i) || near_half(s.j) || near_half(s.k)) continue;
        ++checked;
        const double voxel = ramp(std::floor(s.i + 0.5), std::floor(s.j + 0.5),
                                  std::floor(s.k + 0.5));
        worst_nearest = std::max(worst_nearest, std::fabs(s.value - voxel));
        largest_move = std::max(largest_move, std::fabs(s.value - ramp(s.i, s.j, s.k)));
        const Sample& t = trilinear[n];
        worst_trilinear = std::max(worst_trilinear, std::fabs(t.value - ramp(t.i, t.j, t.k)));
    }
    CHECK(checked >= 10);
    CHECK(worst_nearest == 0);     // a voxel's value, exactly (integers print exactly)
    CHECK(largest_move > 1);       // ... and not the interpolated value
    CHECK(worst_trilinear < 2e-3);  // the trace's 4 decimals, float values up to 101
}

TEST_CASE("projection modes: --slab keeps the samples within half its thickness of the "
          "centre") {
    // Down k through the ramp (k = 0..6, centre 3) with a slab 2 thick: k = 2, 3, 4.
    const TempFolder folder("projection_slab");
    const std::vector<std::string> volume = write_raw_volume(
        make_volume(nx, ny, nz, [](int i, int j, int k) { return int(ramp(i, j, k)); }),
        folder.path("ramp.raw"));
    for (const char* mode : {"mip", "minip", "average"}) {
        CAPTURE(mode);
        std::vector<std::string> flags = volume;
        flags.insert(flags.end(), {"--azimuth", "180", "--elevation", "90", "--size", "9x8",
                                   "--step", "1", "--slab", "2", "--mode", mode});
        const RunResult run = render(flags, folder);
        CHECK(summary_count(run.summary("camera"), "samples") == 9ull * 8 * 3);
        const Image image = picture(folder);
        double worst = 0;
        for (int y = 0; y < 8; ++y)
            for (int x = 0; x < 9; ++x) {
                double expected = ramp(x, y, 3);
                if (std::string(mode) == "mip") expected = ramp(x, y, 4);
                if (std::string(mode) == "minip") expected = ramp(x, y, 2);
                worst = std::max(worst, std::fabs(image.at(x, y).r - ramp_grey(expected)));
            }
        CHECK(worst < 1e-5);
    }
}

TEST_CASE("projection modes: only samples inside the box count; a ray that misses it shows "
          "the background") {
    // 500 everywhere but one voxel of -1000 in a corner (min -1000, max 500: grey 1 is 500).
    // Zoomed out, the image's corners pass beside the box. MinIP and average of a ray through
    // the box are 500 (white), not pulled down by "samples" outside it; a miss is black.
    const TempFolder folder("projection_background");
    const std::vector<std::string> volume = write_raw_volume(
        make_volume(16, 16, 16,
                    [](int i, int j, int k) { return i + j + k == 0 ? -1000 : 500; }),
        folder.path("block.raw"));
    for (const char* mode : {"mip", "minip", "average"}) {
        CAPTURE(mode);
        std::vector<std::string> flags = volume;
        flags.insert(flags.end(), {"--size", "40x40", "--zoom", "1", "--mode", mode,
                                   "--debug-pixel", "0,0"});
        const RunResult run = render(flags, folder);
        REQUIRE(run.traces.size() == 1);
        CHECK(run.traces[0].samples == 0);
        const Image image = picture(folder);
        CHECK(image.at(0, 0).r == 0.0f);   // missed: the background
        CHECK(image.at(20, 20).r == 1.0f);  // through the middle: 500 only
        int hit = 0, white = 0;
        for (const Rgb& p : image.pixels) {
            CHECK(std::isfinite(p.r));
            hit += p.r > 0 ? 1 : 0;
            white += p.r == 1.0f ? 1 : 0;
        }
        CHECK(hit > 100);
        CHECK(white >= hit - 10);  // only rays near the -1000 corner differ
    }
}

TEST_CASE("projection modes: a constant volume is black (min = max, no division by zero)") {
    const TempFolder folder("projection_constant");
    std::vector<std::string> flags = write_raw_volume(
        make_volume(5, 4, 3, [](int, int, int) { return 77; }), folder.path("constant.raw"));
    flags.insert(flags.end(), {"--size", "16x16", "--mode", "average"});
    render(flags, folder);
    for (const Rgb& p : picture(folder).pixels) CHECK(p.r == 0.0f);
}

TEST_CASE("projection modes: bad --mode and --slab are refused with status 2") {
    for (const std::vector<std::string>& flags :
         std::vector<std::vector<std::string>>{{"--mode", "max"},
                                               {"--slab", "-1"},
                                               {"--slab", "nan"},
                                               {"--slab", "5", "--mode", "composite"},
                                               {"--view", "front"}}) {
        std::vector<std::string> args = {"--volume", "phantom"};
        args.insert(args.end(), flags.begin(), flags.end());
        const RunResult run = run_step(projection_step, args);
        CAPTURE(run.command());
        CHECK(run.status == 2);
        CHECK(run.err.find("error: " + flags[0]) != std::string::npos);
    }
}

TEST_CASE("projection modes: --mode composite is step 15's compositing, pixel for pixel") {
    const TempFolder folder("projection_composite");
    const std::vector<std::string> scene = {"--volume", "phantom", "--size", "48x40",
                                            "--azimuth", "33", "--elevation", "-21"};
    std::vector<std::string> flags = scene;
    flags.insert(flags.end(), {"--mode", "composite"});
    render(flags, folder);
    const Image composite = picture(folder);
    flags = scene;
    flags.insert(flags.end(), {"--out", folder.path(), "--pfm", "--threads", "2"});
    const RunResult run = run_step("15_trilinear", flags);
    REQUIRE(run.status == 0);
    const Image trilinear = read_pfm(step_output(folder.path(), "15_trilinear", "camera", "pfm"));
    REQUIRE(composite.pixels.size() == trilinear.pixels.size());
    int differing = 0;
    for (size_t n = 0; n < composite.pixels.size(); ++n) {
        const Rgb& a = composite.pixels[n];
        const Rgb& b = trilinear.pixels[n];
        differing += a.r != b.r || a.g != b.g || a.b != b.b;
    }
    CHECK(differing == 0);
    int lit = 0;  // not a black picture on both sides
    for (const Rgb& p : trilinear.pixels) lit += p.r > 0.05f;
    CHECK(lit > 100);
}
