// test_steps.cpp: steps 00-05 against closed-form answers (a linear ramp, a sphere, constant,
// one-voxel-thick and int16-extreme volumes); every step, later ones too, for NaN on those
// volumes, and for the debug trace against the image.
//
// The steps run as programs (tools/run_step.h, harness.h): each analytic volume is written to
// a temporary raw file and rendered with --pfm, and the test reads what a student would see:
// the float image, the summary line's counters, and the --debug-pixel trace (the gradient a
// lit step printed, step 05's sub-voxel t_hit). The expected values are closed forms computed
// here; nothing here calls or repeats a lesson function, so a lesson may change its names.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>
#include "args.h"
#include "harness.h"
#include "vec3.h"
#include "view.h"

using namespace ctlab;
using ctlab_test::render;
using ctlab_test::render_step;
using ctlab_test::step_names;
using ctlab_test::default_views;
using ctlab_test::is_camera_step;
using ctlab_test::size_flags;
using ctlab_test::StepRender;

namespace {

constexpr ViewAxis all_axes[] = {ViewAxis::top, ViewAxis::front, ViewAxis::side};
constexpr const char* axis_view[] = {"top", "front", "side"};
constexpr double pi = 3.14159265358979323846;
constexpr double rad = pi / 180;

// The lighting the handouts of steps 04 and 05 specify: ambient 0.1, plus (1 - ambient) N.L
// for the outward normal N; the light at --light-angle degrees to the right of the viewer
// (default 30) and 20 degrees above.
constexpr float ambient = 0.1f;
constexpr double default_light_angle = 30, light_elevation = 20;

Vec3 light_towards(const View& view, double angle) {
    const double a = angle * rad, e = light_elevation * rad;
    return volume_direction(view, float(std::sin(a) * std::cos(e)), float(-std::sin(e)),
                            float(-std::cos(a) * std::cos(e)));
}

double lit_shade(const Vec3& outward_normal, const Vec3& light) {
    return ambient + (1 - ambient) * std::max(0.0, double(dot(outward_normal, light)));
}

// A volume whose value at voxel (i, j, k) is value(i, j, k), rounded and clamped to int16.
Volume make_volume(int nx, int ny, int nz, const std::function<double(int, int, int)>& value,
                   double sx = 1, double sy = 1, double sz = 1) {
    Volume volume;
    volume.nx = nx;
    volume.ny = ny;
    volume.nz = nz;
    volume.sx = sx;
    volume.sy = sy;
    volume.sz = sz;
    volume.name = "test";
    resize_dense(volume);
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                const double v = std::clamp(std::round(value(i, j, k)), -32768.0, 32767.0);
                volume.data[volume.index(i, j, k)] = int16_t(v);
            }
    update_range(volume);
    return volume;
}

// The linear ramp of numerics.md: f = 3i + 5j + 7k (+ offset).
Volume ramp_volume(int nx, int ny, int nz, double sx = 1, double sy = 1, double sz = 1,
                   int offset = 0) {
    return make_volume(
        nx, ny, nz, [&](int i, int j, int k) { return 3 * i + 5 * j + 7 * k + offset; }, sx, sy,
        sz);
}

bool finite(const Rgb& pixel) {
    return std::isfinite(pixel.r) && std::isfinite(pixel.g) && std::isfinite(pixel.b);
}

// Steps 00-05 show a grey in 0..1; later ones may leave values above 1 to the PNG's clamp.
bool shows_unit_grey(const std::string& step) { return step < "06"; }

// Counts pixels that are not finite, or outside 0..1 when must_be_unit.
int bad_pixels(const Image& image, bool must_be_unit) {
    int bad = 0;
    for (const Rgb& p : image.pixels) {
        const bool in_unit = p.r >= 0 && p.r <= 1 && p.g >= 0 && p.g <= 1 && p.b >= 0 && p.b <= 1;
        if (!finite(p) || (must_be_unit && !in_unit)) ++bad;
    }
    return bad;
}

// "--debug-pixel X,Y"
std::vector<std::string> debug_pixel(int x, int y) {
    return {"--debug-pixel", std::to_string(x) + "," + std::to_string(y)};
}

std::vector<std::string> joined(std::vector<std::string> a, const std::vector<std::string>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
}

// The trace of `view` in a run; fails the test when there is none.
const PixelTrace* trace_of(const StepRender& render, const std::string& view) {
    for (const PixelTrace& trace : render.run.traces) {
        if (trace.view == view) return &trace;
    }
    FAIL_CHECK("no trace of the " << view << " view in: " << render.run.out);
    return nullptr;
}

// The lit steps' last trace line "gradient=(GI, GJ, GK) shade=S": the gradient at the hit.
bool traced_gradient(const PixelTrace& trace, Vec3& gradient) {
    for (const std::string& line : trace.lines) {
        float g[3];
        if (std::sscanf(line.c_str(), "gradient=(%f, %f, %f)", &g[0], &g[1], &g[2]) == 3) {
            gradient = {g[0], g[1], g[2]};
            return true;
        }
    }
    return false;
}

// Step 05's "crossing between n=A and n=B: hit at A + F", in samples along the ray (or a
// hit at n = 0 when the first sample is already above); false for a miss.
bool traced_t_hit(const PixelTrace& trace, double& t_hit) {
    for (const std::string& line : trace.lines) {
        const size_t at = line.find("hit at ");
        if (at != std::string::npos) {
            int whole = 0;
            double fraction = 0;
            if (std::sscanf(line.c_str() + at, "hit at %d + %lf", &whole, &fraction) == 2) {
                t_hit = whole + fraction;
                return true;
            }
        }
    }
    if (!trace.lines.empty() && trace.lines[0].rfind("n=  0 ", 0) == 0 &&
        trace.lines[0].find("hit") != std::string::npos) {
        t_hit = 0;
        return true;
    }
    return false;
}

// Physical position of a voxel centre: index times spacing (voxel centres at whole indices).
struct Point {
    double x, y, z;
};
Point position(const Volume& volume, const Voxel& voxel) {
    return {voxel.i * volume.sx, voxel.j * volume.sy, voxel.k * volume.sz};
}

// The sphere f = 400 + 100 (R - |p - c|), rounded to int16, p in physical units.
struct Sphere {
    Point centre;
    double radius;
    double distance(const Point& p) const {
        return std::sqrt((p.x - centre.x) * (p.x - centre.x) + (p.y - centre.y) * (p.y - centre.y) +
                         (p.z - centre.z) * (p.z - centre.z));
    }
    double value(const Point& p) const { return 400 + 100 * (radius - distance(p)); }
};

// The unit outward normal the surface would have at p, as (p - c)/|p - c|, per volume axis.
Vec3 analytic_normal(const Sphere& sphere, const Point& p) {
    const double d = sphere.distance(p);
    return {float((p.x - sphere.centre.x) / d), float((p.y - sphere.centre.y) / d),
            float((p.z - sphere.centre.z) / d)};
}

Vec3 outward_normal(const Vec3& gradient) { return (-1.0f / length(gradient)) * gradient; }

double angle_degrees(const Vec3& a, const Vec3& b) {
    const double cosine = std::clamp(double(dot(a, b)) / (length(a) * length(b)), -1.0, 1.0);
    return std::acos(cosine) * 180 / pi;
}

// Where the ray through pixel (x, y) meets the sphere, in samples along the ray:
// t* = (along - sqrt(R^2 - rho^2)) / ray_spacing, rho = the ray's distance from the centre.
struct RayMeeting {
    double rho;        // distance between the ray and the centre, physical units
    double t_surface;  // t*, valid when rho <= R
};
RayMeeting meet_sphere(const Volume& volume, const View& view, const Sphere& sphere, int x, int y) {
    const Point p0 = position(volume, view.voxel(x, y, 0));
    const Point p1 = position(volume, view.voxel(x, y, 1 < view.ray_length ? 1 : 0));
    const double step = view.ray_spacing;
    const Point direction = {(p1.x - p0.x) / step, (p1.y - p0.y) / step, (p1.z - p0.z) / step};
    const Point to_centre = {sphere.centre.x - p0.x, sphere.centre.y - p0.y,
                             sphere.centre.z - p0.z};
    const double along =
        to_centre.x * direction.x + to_centre.y * direction.y + to_centre.z * direction.z;
    const double rho2 = to_centre.x * to_centre.x + to_centre.y * to_centre.y +
                        to_centre.z * to_centre.z - along * along;
    const double r2 = sphere.radius * sphere.radius;
    RayMeeting meeting;
    meeting.rho = std::sqrt(std::max(0.0, rho2));
    meeting.t_surface = rho2 <= r2 ? (along - std::sqrt(r2 - rho2)) / step : 0;
    return meeting;
}

}  // namespace

// --- The linear ramp -----------------------------------------------------------------------

TEST_CASE("ramp: steps 04/05 light it with the exact gradient (3, 5, 7)/spacing, borders too") {
    // Along every axis the ramp's differences are exact, one-sided at the border as central
    // inside: the gradient is (3/sx, 5/sy, 7/sz) at every voxel and at every point between
    // two, so every hit pixel shows the same closed-form shade (for any light angle), and the
    // trace prints that gradient: at the volume's first and last pixels and in between.
    struct Spacing {
        double sx, sy, sz;
    };
    for (Spacing s : {Spacing{1, 1, 1}, Spacing{1, 1, 2}, Spacing{0.5, 2, 4}}) {
        CAPTURE(s.sx);
        CAPTURE(s.sy);
        CAPTURE(s.sz);
        const Volume volume = ramp_volume(9, 7, 5, s.sx, s.sy, s.sz, -60);  // -60 .. 22
        const Vec3 gradient = {float(3 / s.sx), float(5 / s.sy), float(7 / s.sz)};
        const Vec3 normal = outward_normal(gradient);
        for (const char* step : {"04_gradient_lighting", "05_interpolated_hits"}) {
            for (const double angle : {-180.0, -45.0, 0.0, 30.0, 90.0}) {
                CAPTURE(step);
                CAPTURE(angle);
                // The trace of pixel 0,0 in every view, or of 6,4 (the last of the side view).
                const bool last = angle == 0.0 || angle == 90.0;
                std::vector<std::string> flags = {"--threshold", "0", "--light-angle",
                                                  std::to_string(angle)};
                flags = joined(flags, last ? debug_pixel(6, 4) : debug_pixel(0, 0));
                const StepRender lit = render(step, flags, volume);
                REQUIRE(lit.images.size() == 3);
                int hits = 0;
                for (ViewAxis axis : all_axes) {
                    const View view = make_view(volume, axis);
                    CAPTURE(view.name);
                    const double expected = lit_shade(normal, light_towards(view, angle));
                    const Image& image = lit.image(view.name);
                    int view_hits = 0;
                    for (const Rgb& pixel : image.pixels) {
                        if (pixel.r == 0.0f) continue;  // a miss (every shade is >= 0.1)
                        CHECK(pixel.r == doctest::Approx(expected).epsilon(1e-5));
                        ++view_hits;
                    }
                    const Summary& summary = lit.summary(view.name);
                    CHECK(summary_count(summary, "hits") == uint64_t(view_hits));
                    CHECK(summary_count(summary, "gradients") >= uint64_t(view_hits));
                    CHECK(view_hits > 0);
                    hits += view_hits;
                }
                for (const PixelTrace& trace : lit.run.traces) {
                    Vec3 traced;
                    if (!traced_gradient(trace, traced)) continue;  // that ray missed
                    CHECK(traced.i == doctest::Approx(gradient.i).epsilon(1e-3));
                    CHECK(traced.j == doctest::Approx(gradient.j).epsilon(1e-3));
                    CHECK(traced.k == doctest::Approx(gradient.k).epsilon(1e-3));
                }
                CHECK(hits > 0);
            }
        }
    }
}

TEST_CASE("ramp: step 05's crossing is the analytic one; steps 02/03 stop at the next sample") {
    // Along any ray the ramp is f0 + slope * t, so the surface f = tau is at
    // t* = (tau - f0) / slope; steps 02/03 hit the first whole t above it. Step 03's picture
    // is 1 - t/N (so every pixel gives its t); the counters of all three are sums of closed
    // forms over the rays; step 05's t_hit is read from the trace of a few pixels.
    const Volume volume = ramp_volume(10, 12, 14);
    const int coefficient[3] = {7, 5, 3};  // the slope along the ray: top k, front j, side i
    for (int threshold : {100, 101, 97, 0, -5, 172, 173}) {
        CAPTURE(threshold);
        const std::vector<std::string> flags = {"--threshold", std::to_string(threshold)};
        const StepRender r2 = render("02_threshold", flags, volume);
        const StepRender r3 = render("03_depth_shading", flags, volume);
        const StepRender r5 = render(
            "05_interpolated_hits", joined(joined(flags, debug_pixel(1, 2)), debug_pixel(9, 0)),
            volume);
        int crossings = 0, misses = 0, at_edge = 0, traced = 0;
        for (ViewAxis axis : all_axes) {
            const View view = make_view(volume, axis);
            CAPTURE(view.name);
            const int slope = coefficient[int(axis)];
            const Image& image2 = r2.image(view.name);
            const Image& image3 = r3.image(view.name);
            uint64_t samples = 0, hits = 0, terminated = 0;
            for (int y = 0; y < view.height; ++y) {
                for (int x = 0; x < view.width; ++x) {
                    const Voxel first = view.voxel(x, y, 0);
                    const int f0 = 3 * first.i + 5 * first.j + 7 * first.k;
                    const int f_last = f0 + slope * (view.ray_length - 1);
                    const float shade3 = image3.at(x, y).r;
                    const float shade2 = image2.at(x, y).r;
                    if (f_last <= threshold) {  // never above: no hit, every sample read
                        CHECK(shade2 == 0.0f);
                        CHECK(shade3 == 0.0f);
                        samples += view.ray_length;
                        ++misses;
                        continue;
                    }
                    CHECK(shade2 == 1.0f);
                    const int t_first_above =
                        f0 > threshold ? 0 : (threshold - f0) / slope + 1;  // whole division
                    CHECK(shade3 == doctest::Approx(1.0 - double(t_first_above) /
                                                              view.ray_length));
                    // t + 1 samples read, one hit, stopped early unless at the last sample.
                    samples += t_first_above + 1;
                    ++hits;
                    terminated += t_first_above + 1 < view.ray_length;
                    if (f0 > threshold) {
                        CHECK(shade3 == 1.0f);
                        ++at_edge;
                    } else {
                        ++crossings;
                    }
                }
            }
            for (const StepRender* run : {&r2, &r3, &r5}) {
                const Summary& summary = run->summary(view.name);
                CHECK(summary_count(summary, "samples") == samples);
                CHECK(summary_count(summary, "hits") == hits);
                CHECK(summary_count(summary, "terminated") == terminated);
            }
            // Step 05's sub-voxel t of the traced rays.
            for (const StepRender* run : {&r5}) {  // both traced pixels, in one run
                for (const PixelTrace& trace : run->run.traces) {
                    if (trace.view != view.name) continue;
                    const Voxel first = view.voxel(trace.x, trace.y, 0);
                    const int f0 = 3 * first.i + 5 * first.j + 7 * first.k;
                    const int f_last = f0 + slope * (view.ray_length - 1);
                    double t_hit = -1;
                    const bool found = traced_t_hit(trace, t_hit);
                    CHECK(found == (f_last > threshold));
                    if (!found) {
                        CHECK(trace.samples == uint64_t(view.ray_length));
                        continue;
                    }
                    const double t_surface = f0 > threshold ? 0 : double(threshold - f0) / slope;
                    CHECK(std::abs(t_hit - t_surface) < 1.5e-6);  // printed with 6 decimals
                    ++traced;
                }
            }
        }
        // Every threshold above crosses some rays, except the ones past the ramp's range.
        CHECK(crossings + misses + at_edge == 10 * 12 + 10 * 14 + 12 * 14);
        if (threshold >= 0 && threshold < 170) CHECK(crossings > 0);
        if (threshold >= 0 && threshold < 170) CHECK(traced > 0);
    }
}

// --- The sphere ----------------------------------------------------------------------------

TEST_CASE("sphere: hits, depth and normals of steps 03/04/05 against the closed form") {
    // Spacing 1:1:2 like CThead, a centre off the voxel grid. Positions are index * spacing.
    // Step 03's depth is read from its picture (1 - t/N) at every pixel; step 05's sub-voxel
    // t_hit and the normals of steps 04/05 from the --debug-pixel traces of a grid of pixels
    // (every fourth column and row near the sphere's middle: one run traces the same pixel in
    // all three views).
    const Sphere sphere{{31.3, 29.6, 31.7}, 20.0};
    const Volume volume = make_volume(
        64, 64, 32,
        [&](int i, int j, int k) {
            return sphere.value({i * 1.0, j * 1.0, k * 2.0});
        },
        1, 1, 2);
    const std::vector<Image> depth3 = render_step("03_depth_shading", {}, volume);
    const std::vector<Image> lit4 = render_step("04_gradient_lighting", {}, volume);
    const std::vector<Image> lit5 = render_step("05_interpolated_hits", {}, volume);
    REQUIRE(depth3.size() == 3);
    REQUIRE(lit4.size() == 3);
    REQUIRE(lit5.size() == 3);
    // The traced grid: pixel (x, y) -> its traces in steps 04 and 05, per view.
    constexpr int grid = 4;
    struct Traced {
        PixelTrace step4, step5;
        bool has4 = false, has5 = false;
    };
    std::vector<std::vector<Traced>> traced(3);  // [view][y * 64 + x]
    for (auto& view : traced) view.resize(64 * 64);
    const ctlab_test::TempFolder folder("sphere");
    const std::vector<std::string> volume_flags =
        write_raw_volume(volume, folder.path("sphere.raw"));
    // The wanted pixels traced a few dozen to a run (--debug-pixel given once per pixel).
    std::vector<std::vector<std::string>> runs(1);  // each run's --debug-pixel flags
    for (int y = 1; y < 64; y += grid) {
        for (int x = 1; x < 64; x += grid) {
            bool wanted = false;  // a measured ray (rho <= 0.8 R) in some view
            for (ViewAxis axis : all_axes) {
                const View view = make_view(volume, axis);
                wanted = wanted || (x < view.width && y < view.height &&
                                    meet_sphere(volume, view, sphere, x, y).rho <=
                                        0.8 * sphere.radius);
            }
            if (!wanted) continue;
            if (runs.back().size() == 2 * max_debug_pixels) runs.emplace_back();
            runs.back() = joined(runs.back(), debug_pixel(x, y));
        }
    }
    REQUIRE(!runs[0].empty());
    for (const std::vector<std::string>& pixel_flags : runs) {
        for (const char* step : {"04_gradient_lighting", "05_interpolated_hits"}) {
            const RunResult run = run_step(
                step, joined(joined(volume_flags, {"--out", folder.path()}), pixel_flags));
            REQUIRE_MESSAGE(run.status == 0, run.err);
            for (const PixelTrace& trace : run.traces) {
                for (int v = 0; v < 3; ++v) {
                    if (trace.view != axis_view[v]) continue;
                    Traced& entry = traced[v][trace.y * 64 + trace.x];
                    if (step[1] == '4') {
                        entry.step4 = trace;
                        entry.has4 = true;
                    } else {
                        entry.step5 = trace;
                        entry.has5 = true;
                    }
                }
            }
        }
    }
    for (ViewAxis axis : all_axes) {
        const View view = make_view(volume, axis);
        CAPTURE(view.name);
        const Vec3 light = light_towards(view, default_light_angle);
        double error3_sum = 0, error5_sum = 0, normal4_sum = 0, normal5_sum = 0;
        double error5_max = 0, normal5_max = 0;
        int measured = 0, hits = 0, misses = 0, unsure = 0, traced_hits = 0;
        for (int y = 0; y < view.height; ++y) {
            for (int x = 0; x < view.width; ++x) {
                const RayMeeting meeting = meet_sphere(volume, view, sphere, x, y);
                // Expected: a hit iff some sample lies inside the sphere. A sample within
                // 0.01 of the surface may round either way (int16 values): not counted.
                bool inside = false, near_surface = false;
                for (int t = 0; t < view.ray_length; ++t) {
                    const double d = sphere.distance(position(volume, view.voxel(x, y, t)));
                    inside = inside || d < sphere.radius - 0.01;
                    near_surface = near_surface || std::abs(d - sphere.radius) <= 0.01;
                }
                const float shade3 = depth3[int(axis)].at(x, y).r;
                const bool hit3 = shade3 > 0, hit4 = lit4[int(axis)].at(x, y).r > 0,
                           hit5 = lit5[int(axis)].at(x, y).r > 0;  // shades are >= ambient
                if (meeting.rho > sphere.radius) {  // rays that pass the sphere never hit
                    CHECK_FALSE(hit3);
                    CHECK_FALSE(hit5);
                }
                if (near_surface && !inside) {
                    ++unsure;
                    continue;
                }
                CHECK(hit3 == inside);
                CHECK(hit4 == inside);
                CHECK(hit5 == inside);
                if (!inside) {
                    ++misses;
                    continue;
                }
                ++hits;
                CHECK(meeting.rho <= sphere.radius);
                // Depth: step 03 is up to one sample late, plus what rounding to int16 moves
                // the surface (0.005 in distance, about 0.005 R / h along a ray of half-chord h).
                const double t3 = std::round((1.0 - shade3) * view.ray_length);
                const double error3 = t3 - meeting.t_surface;
                const double half_chord = std::sqrt(std::max(0.0, sphere.radius * sphere.radius -
                                                                      meeting.rho * meeting.rho)) /
                                          view.ray_spacing;
                CHECK(error3 > -0.01);
                CHECK(error3 < 1 + 0.01 * sphere.radius / std::max(half_chord, 0.01));
                // The first sample inside: the voxel step 04 takes its normal at.
                const Voxel voxel4 = view.voxel(x, y, int(t3));
                const Vec3 true_normal4 = analytic_normal(sphere, position(volume, voxel4));
                // The rendered pixels: within what a 1 degree normal error changes (0.016).
                CHECK(std::abs(lit4[int(axis)].at(x, y).r - lit_shade(true_normal4, light)) <
                      0.02);
                const Traced& entry = traced[int(axis)][y * 64 + x];
                if (meeting.rho > 0.8 * sphere.radius) continue;  // near grazing: depth only
                ++measured;
                error3_sum += std::abs(error3);
                if (!entry.has4 || !entry.has5) continue;  // not on the traced grid
                // Step 05's sub-voxel hit and the normals of both steps, from their traces.
                double t5 = -1;
                REQUIRE(traced_t_hit(entry.step5, t5));
                const double error5 = t5 - meeting.t_surface;
                error5_sum += std::abs(error5);
                error5_max = std::max(error5_max, std::abs(error5));
                Vec3 gradient4, gradient5;
                REQUIRE(traced_gradient(entry.step4, gradient4));
                REQUIRE(traced_gradient(entry.step5, gradient5));
                const double angle4 = angle_degrees(outward_normal(gradient4), true_normal4);
                const Point p0 = position(volume, view.voxel(x, y, 0));
                const Vec3 unit_ray = volume_direction(view, 0, 0, 1);
                const double along = t5 * view.ray_spacing;
                const Point p5 = {p0.x + along * unit_ray.i, p0.y + along * unit_ray.j,
                                  p0.z + along * unit_ray.k};
                const Vec3 true_normal5 = analytic_normal(sphere, p5);
                const double angle5 = angle_degrees(outward_normal(gradient5), true_normal5);
                normal4_sum += angle4;
                normal5_sum += angle5;
                normal5_max = std::max(normal5_max, angle5);
                CHECK(angle4 < 1.0);
                CHECK(angle5 < 1.0);
                CHECK(std::abs(lit5[int(axis)].at(x, y).r - lit_shade(true_normal5, light)) <
                      0.02);
                // The traced ray is the picture's.
                CHECK(std::abs(entry.step5.rgb.r - lit5[int(axis)].at(x, y).r) <= 5e-7);
                ++traced_hits;
            }
        }
        CHECK(hits > 500);
        CHECK(misses > 500);
        CHECK(unsure < hits / 100);
        REQUIRE(measured > 300);
        REQUIRE(traced_hits > 20);
        const double mean3 = error3_sum / measured, mean5 = error5_sum / traced_hits;
        MESSAGE("sphere " << view.name << ": mean |depth error| step 03 = " << mean3
                          << ", step 05 = " << mean5 << " (max " << error5_max
                          << ") samples; mean normal error step 04 = "
                          << normal4_sum / traced_hits << " deg, step 05 = "
                          << normal5_sum / traced_hits << " deg (max " << normal5_max
                          << "); step 05 over " << traced_hits << " traced rays");
        CHECK(mean5 * 5 <= mean3);
        CHECK(error5_max < 0.05);
        CHECK(normal5_sum / traced_hits < 0.5);
    }
}

// --- Lighting ------------------------------------------------------------------------------

TEST_CASE("lighting: a slab's face lit at known angles; no normal inside gives ambient") {
    // A slab: air (-1000) for k < 3, bone (1000) from k = 3, 8x8x8. Its face has the outward
    // normal -k. From the top, every ray meets the face (at k = 3): N.L = cos(angle) cos(20),
    // negative (facing away from the light) for |angle| > 90, where only the ambient remains.
    // From the front and side, the rays of rows k >= 3 start in bone: on row 3 the gradient
    // (1000 - (-1000)) / 2 along k gives the face's normal and N.L = sin(20), the light's
    // elevation, for any angle; on the rows below the gradient is zero: no normal, ambient.
    const Volume slab = make_volume(8, 8, 8, [](int, int, int k) { return k >= 3 ? 1000 : -1000; });
    const Vec3 normal = {0, 0, -1};
    for (const char* step : {"04_gradient_lighting", "05_interpolated_hits"}) {
        for (const double angle : {-180.0, -90.0, -45.0, 0.0, 30.0, 60.0, 90.0, 180.0}) {
            CAPTURE(step);
            CAPTURE(angle);
            const StepRender lit =
                render(step, {"--light-angle", std::to_string(angle), "--threads", "1"}, slab);
            for (ViewAxis axis : all_axes) {
                const View view = make_view(slab, axis);
                CAPTURE(view.name);
                const Vec3 light = light_towards(view, angle);
                CHECK(length(light) == doctest::Approx(1.0));
                const double face = lit_shade(normal, light);
                if (axis == ViewAxis::top) {
                    const double n_dot_l = std::cos(angle * rad) * std::cos(light_elevation * rad);
                    CHECK(face == doctest::Approx(ambient + (1 - ambient) * std::max(0.0, n_dot_l)));
                } else {
                    CHECK(face == doctest::Approx(ambient + (1 - ambient) *
                                                                std::sin(light_elevation * rad)));
                }
                const Image& image = lit.image(view.name);
                int wrong = 0;
                for (int y = 0; y < image.height; ++y)
                    for (int x = 0; x < image.width; ++x) {
                        double expected = face;
                        if (axis != ViewAxis::top) expected = y < 3 ? 0.0 : y == 3 ? face : ambient;
                        wrong += std::abs(image.at(x, y).r - expected) > 1e-5;
                    }
                CHECK(wrong == 0);
            }
        }
    }
}

// --- Constant, thin and extreme volumes ----------------------------------------------------

TEST_CASE("constant volume: every step, every view, the known value and never NaN") {
    // min = max: step 00/01's display has no range; every gradient is zero.
    struct Expected {
        const char* step;
        float above;  // volume 500: above the threshold 400 everywhere
        float below;  // volume -1000: nothing above
    };
    const Expected expected[] = {
        {"00_slices", 0.0f, 0.0f},             // min..max display of a zero range: 0
        {"01_ray_loops", 0.0f, 0.0f},          // same mapping
        {"02_threshold", 1.0f, 0.0f},          // hit / miss
        {"03_depth_shading", 1.0f, 0.0f},      // hit at n = 0: 1 - 0/N
        {"04_gradient_lighting", ambient, 0.0f},  // zero gradient: no normal, ambient only
        {"05_interpolated_hits", ambient, 0.0f},
    };
    for (int value : {500, -1000}) {
        const Volume volume = make_volume(8, 6, 4, [&](int, int, int) { return value; });
        CHECK(volume.min_value == volume.max_value);
        for (const std::string& step : step_names()) {
            CAPTURE(step);
            CAPTURE(value);
            const StepRender rendered =
                render(step, joined(size_flags(step), {"--threads", "1"}), volume);
            REQUIRE(rendered.images.size() == default_views(step, volume).size());
            for (const Image& image : rendered.images) {
                CHECK(bad_pixels(image, shows_unit_grey(step)) == 0);
                for (const Expected& known : expected) {
                    if (step != known.step) continue;
                    const float want = value > 400 ? known.above : known.below;
                    for (const Rgb& pixel : image.pixels) {
                        CHECK(pixel.r == want);
                        CHECK(pixel.g == want);
                        CHECK(pixel.b == want);
                    }
                }
            }
        }
        // Equalised, every voxel is at or below the one value: white.
        const std::vector<Image> equalised = render_step("00_slices", {"--equalise"}, volume);
        for (const Image& image : equalised) CHECK(image.at(0, 0).r == 1.0f);
    }
}

TEST_CASE("1x1x1 and one-voxel-thick volumes: every step and view, finite, right size") {
    struct Dims {
        int nx, ny, nz;
    };
    for (Dims dims : {Dims{1, 1, 1}, Dims{1, 16, 16}, Dims{16, 1, 16}, Dims{16, 16, 1}}) {
        CAPTURE(dims.nx);
        CAPTURE(dims.ny);
        CAPTURE(dims.nz);
        // A ramp that crosses the threshold 400 inside the volume (500 for 1x1x1).
        const Volume volume = make_volume(
            dims.nx, dims.ny, dims.nz,
            [](int i, int j, int k) {
                return 300 + 20 * i + 10 * j + 15 * k + 200 * (i + j + k == 0);
            },
            1, 1, 2);
        for (const std::string& step : step_names()) {
            CAPTURE(step);
            const std::vector<Image> images = render_step(step, size_flags(step), volume);
            const std::vector<View> views = default_views(step, volume);
            REQUIRE(images.size() == views.size());
            for (size_t n = 0; n < views.size(); ++n) {
                CAPTURE(views[n].name);
                CHECK(images[n].width == views[n].width);
                CHECK(images[n].height == views[n].height);
                CHECK(bad_pixels(images[n], shows_unit_grey(step)) == 0);
            }
        }
        // Gradients at the hits: finite; zero along a one-voxel axis, exact elsewhere
        // (20, 10, 15/2 per unit) away from the corner voxel that breaks the ramp. Traced at
        // a pixel away from the corner (clamped into each view) in steps 04 and 05.
        const int x = std::min(6, std::max(dims.nx, dims.ny) - 1);
        const int y = std::min(4, std::max(dims.ny, dims.nz) - 1);
        for (const char* step : {"04_gradient_lighting", "05_interpolated_hits"}) {
            const StepRender lit = render(step, debug_pixel(x, y), volume);
            int checked = 0;
            for (const PixelTrace& trace : lit.run.traces) {
                CAPTURE(trace.view);
                Vec3 g;
                if (!traced_gradient(trace, g)) continue;
                CHECK(finite(Rgb{g.i, g.j, g.k}));
                double t_hit = 0;
                if (step[1] == '5' && traced_t_hit(trace, t_hit)) {
                    const View view = make_view(volume, trace.view == "top"     ? ViewAxis::top
                                                        : trace.view == "front" ? ViewAxis::front
                                                                                : ViewAxis::side);
                    CHECK(t_hit >= 0.0);
                    CHECK(t_hit <= double(view.ray_length - 1));
                }
                if (dims.nx * dims.ny * dims.nz == 1) continue;
                if (step[1] == '4') {
                    CHECK(g.i == (dims.nx > 1 ? 20.0f : 0.0f));
                    CHECK(g.j == (dims.ny > 1 ? 10.0f : 0.0f));
                    CHECK(g.k == (dims.nz > 1 ? 7.5f : 0.0f));
                }
                ++checked;
            }
            if (dims.nx * dims.ny * dims.nz > 1) CHECK(checked > 0);
        }
    }
    // 1x1x1 with 500 > 400: a hit at n = 0 in every view: white in step 02, 1 - 0/1 in 03.
    const Volume single = make_volume(1, 1, 1, [](int, int, int) { return 500; });
    for (const char* name : {"02_threshold", "03_depth_shading"}) {
        for (const Image& image : render_step(name, {}, single)) CHECK(image.at(0, 0).r == 1.0f);
    }
}

TEST_CASE("int16 extremes: MIP and display reach exactly 1, thresholds at the extremes") {
    // 4x4x4: -32768 for k < 2, 32767 for k >= 2; and one 32767 voxel at k = 0.
    const Volume volume = make_volume(4, 4, 4, [](int i, int j, int k) {
        return (k >= 2 || (i == 3 && j == 3 && k == 0)) ? 32767 : -32768;
    });
    REQUIRE(volume.min_value == -32768);
    REQUIRE(volume.max_value == 32767);

    // MIP: every top ray meets 32767. Front (x = i) and side (x = j) rows y = k >= 2 are
    // 32767; of the rows k < 2 only the ray through the bright voxel (3, 3, 0) is: x 3, y 0.
    const std::vector<Image> mip = render_step("01_ray_loops", {}, volume);
    REQUIRE(mip.size() == 3);
    for (const Rgb& pixel : mip[0].pixels) CHECK(pixel.r == 1.0f);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) {
            const float expected = (y >= 2 || (y == 0 && x == 3)) ? 1.0f : 0.0f;
            CHECK(mip[1].at(x, y).r == expected);
            CHECK(mip[2].at(x, y).r == expected);
        }
    // Step 00's display of the two extremes, linear and equalised (slice k = 0 of the top
    // view: -32768 but for the bright voxel at 3, 3). Equalised, -32768 is the lowest value
    // of 31 of the 64 voxels: 31/64.
    const std::vector<Image> linear = render_step("00_slices", {"--view", "top", "--slice", "0"},
                                                  volume);
    CHECK(linear[0].at(0, 0).r == 0.0f);
    CHECK(linear[0].at(3, 3).r == 1.0f);
    const std::vector<Image> equalised =
        render_step("00_slices", {"--view", "top", "--slice", "0", "--equalise"}, volume);
    CHECK(equalised[0].at(0, 0).r == doctest::Approx(31.0 / 64));
    CHECK(equalised[0].at(3, 3).r == 1.0f);

    // Threshold 32767: nothing is above it; -32768: everything but the lowest value is.
    for (const Image& image : render_step("02_threshold", {"--threshold", "32767"}, volume)) {
        for (const Rgb& pixel : image.pixels) CHECK(pixel.r == 0.0f);
    }
    const std::vector<Image> lowest =
        render_step("03_depth_shading", {"--threshold=-32768"}, volume);
    CHECK(lowest[0].at(0, 0).r == 0.5f);  // top ray: first above at k = 2 of 4
    CHECK(lowest[0].at(3, 3).r == 1.0f);  // the bright voxel at k = 0
    // Step 05 between -32768 and 32767: the fraction (tau - v0)/(v1 - v0) over 65535.
    auto t_hit_at = [&](int threshold, double& t_hit) {
        const StepRender run =
            render("05_interpolated_hits",
                   joined({"--view", "top", "--threshold", std::to_string(threshold)},
                          debug_pixel(0, 0)),
                   volume);
        REQUIRE(run.run.traces.size() == 1);
        return traced_t_hit(run.run.traces[0], t_hit);
    };
    double t_hit = 0;
    CHECK(t_hit_at(-32768, t_hit));
    CHECK(t_hit == 1.0);
    CHECK(t_hit_at(32766, t_hit));
    CHECK(std::abs(t_hit - (1.0 + 65534.0 / 65535.0)) < 1e-6);
    CHECK(t_hit_at(0, t_hit));
    CHECK(std::abs(t_hit - (1.0 + 32768.0 / 65535.0)) < 1e-6);
    CHECK_FALSE(t_hit_at(32767, t_hit));
    // Step 04 at that hit: gradient (f(k=3) - f(k=1)) / 2 along +k, normal -k, towards the
    // viewer; the light at angle 30, elevation 20 gives N.L = cos 30 cos 20.
    const StepRender lit = render("04_gradient_lighting",
                                  joined({"--view", "top"}, debug_pixel(1, 1)), volume);
    REQUIRE(lit.run.traces.size() == 1);
    Vec3 gradient;
    REQUIRE(traced_gradient(lit.run.traces[0], gradient));
    CHECK(gradient.k == 65535.0f / 2);
    CHECK(lit.images[0].at(1, 1).r ==
          doctest::Approx(ambient + (1 - ambient) * std::cos(30 * rad) * std::cos(20 * rad))
              .epsilon(1e-5));
    for (const std::string& step : step_names()) {
        for (const char* threshold : {"-32768", "32767"}) {
            std::vector<std::string> flags = size_flags(step);
            const bool has_threshold = step >= "02" && step < "06";
            if (has_threshold) flags = joined(flags, {"--threshold", threshold});
            for (const Image& image : render_step(step, flags, volume)) {
                CHECK(bad_pixels(image, shows_unit_grey(step)) == 0);
            }
            if (!has_threshold) break;  // one run is enough without a threshold
        }
    }
}

// --- Step 00 and 01 ------------------------------------------------------------------------

TEST_CASE("step 00: slices read the documented voxels; equalisation uses the whole volume") {
    // Value = unique per voxel, so each pixel tells which voxel it showed.
    const Volume volume =
        make_volume(7, 5, 3, [](int i, int j, int k) { return 100 * k + 10 * j + i; });
    const float range = float(volume.max_value - volume.min_value);
    const std::vector<Image> images = render_step("00_slices", {"--slice", "1"}, volume);
    REQUIRE(images.size() == 3);
    const View views[3] = {make_view(volume, ViewAxis::top), make_view(volume, ViewAxis::front),
                           make_view(volume, ViewAxis::side)};
    for (int n = 0; n < 3; ++n) {
        for (int y = 0; y < views[n].height; ++y)
            for (int x = 0; x < views[n].width; ++x) {
                const Voxel voxel = views[n].voxel(x, y, 1);
                // Float division (integer division would give 0 everywhere but the maximum).
                const float want =
                    float(volume.at(voxel.i, voxel.j, voxel.k) - volume.min_value) / range;
                CHECK(images[n].at(x, y).r == want);
            }
    }

    // 2x2x2: slice k = 0 holds 0, 0, 1, 3; slice k = 1 is all 3. Cumulative fractions over
    // all 8 voxels: value 0 -> 2/8, 1 -> 3/8, 3 -> 8/8.
    const int values[8] = {0, 0, 1, 3, 3, 3, 3, 3};
    const Volume small =
        make_volume(2, 2, 2, [&](int i, int j, int k) { return values[(k * 2 + j) * 2 + i]; });
    const std::vector<Image> top =
        render_step("00_slices", {"--equalise", "--view", "top", "--slice", "0"}, small);
    REQUIRE(top.size() == 1);
    // One slice's own histogram would give 0.5, 0.5, 0.75, 1.
    CHECK(top[0].at(0, 0).r == 0.25f);
    CHECK(top[0].at(1, 0).r == 0.25f);
    CHECK(top[0].at(0, 1).r == 0.375f);
    CHECK(top[0].at(1, 1).r == 1.0f);
    const std::vector<Image> linear = render_step("00_slices", {"--view=top", "--slice=0"}, small);
    CHECK(linear[0].at(0, 1).r == 1.0f / 3);
}

TEST_CASE("step 01: MIP starts from the first sample (an all-negative volume keeps its max)") {
    // f = -1000 + i + 2j + 3k: the largest value of each ray is at its far end.
    const Volume volume =
        make_volume(5, 4, 3, [](int i, int j, int k) { return -1000 + i + 2 * j + 3 * k; });
    const float range = float(volume.max_value - volume.min_value);
    const StepRender mip = render("01_ray_loops", debug_pixel(1, 1), volume);
    for (ViewAxis axis : all_axes) {
        const View view = make_view(volume, axis);
        CAPTURE(view.name);
        const Image& image = mip.image(view.name);
        for (int y = 0; y < view.height; ++y)
            for (int x = 0; x < view.width; ++x) {
                const Voxel far = view.voxel(x, y, view.ray_length - 1);
                const int highest = -1000 + far.i + 2 * far.j + 3 * far.k;
                CHECK(image.at(x, y).r == float(highest - volume.min_value) / range);
            }
        // Every sample of every ray read; the trace prints one line per sample.
        CHECK(summary_count(mip.summary(view.name), "samples") ==
              uint64_t(view.width) * view.height * view.ray_length);
        const PixelTrace* trace = trace_of(mip, view.name);
        REQUIRE(trace);
        CHECK(trace->lines.size() == size_t(view.ray_length));
        CHECK(trace->samples == uint64_t(view.ray_length));
    }
    // A ray of -5 everywhere except one -3 in the middle: max -3, shown as (-3 + 5)/2 = 1;
    // a maximum started from 0 would show (0 + 5)/2 = 2.5 (the float image keeps it).
    const Volume dip = make_volume(1, 1, 3, [](int, int, int k) { return k == 1 ? -3 : -5; });
    const std::vector<Image> images = render_step("01_ray_loops", {"--view", "top"}, dip);
    CHECK(images[0].at(0, 0).r == 1.0f);
}

// --- The debug trace -----------------------------------------------------------------------

TEST_CASE("debug trace: the traced ray gives the image's pixel, and prints it") {
    // Every step on a small phantom, three pixels of every view: the trace's last line gives
    // the very value of the float image (%.6f) and its PNG bytes, after a header and at least
    // one line per sample read.
    const std::vector<std::string> phantom = {"--volume", "phantom", "--dims", "48,48,22"};
    for (const std::string& step : step_names()) {
        CAPTURE(step);
        // The three pixels in one run: one trace per pixel and view, in the order given.
        const std::vector<std::pair<int, int>> pixels = {{24, 11}, {0, 0}, {47, 21}};
        // Part 2's camera picture at the size of the phantom's top view, 48x48.
        std::vector<std::string> flags = joined(phantom, {"--threads", "2"});
        if (is_camera_step(step)) flags = joined(flags, {"--size", "48x48"});
        for (const auto& pixel : pixels) {
            flags = joined(flags, debug_pixel(pixel.first, pixel.second));
        }
        const StepRender run = render(step, flags);
        for (const PixelTrace& trace : run.run.traces) {  // every trace is of a pixel asked for
            const std::pair<int, int> pixel(trace.x, trace.y);
            CHECK(std::find(pixels.begin(), pixels.end(), pixel) != pixels.end());
        }
        for (const auto& pixel : pixels) {
            int traced = 0;
            for (const PixelTrace& trace : run.run.traces) {
                if (trace.x != pixel.first || trace.y != pixel.second) continue;
                CAPTURE(trace.view);
                CHECK(trace.complete);
                CHECK(trace.header.rfind("debug pixel x=" + std::to_string(pixel.first) +
                                             " y=" + std::to_string(pixel.second) +
                                             " view=" + trace.view,
                                         0) == 0);
                const Rgb& drawn = run.image(trace.view).at(trace.x, trace.y);
                char printed[100], expected[100];
                std::snprintf(printed, sizeof printed, "%.6f %.6f %.6f", trace.rgb.r,
                              trace.rgb.g, trace.rgb.b);
                std::snprintf(expected, sizeof expected, "%.6f %.6f %.6f", drawn.r, drawn.g,
                              drawn.b);
                CHECK(std::string(printed) == expected);
                CHECK(trace.png[0] == to_byte(drawn.r));
                CHECK(trace.png[1] == to_byte(drawn.g));
                CHECK(trace.png[2] == to_byte(drawn.b));
                // A line per sample read; a ray that only leapt over empty bricks still says so.
                // (Steps 22-24's samples= count their shadow rays', sweep's and occlusion
                // probes' samples too, and a trace gives a lit sample one line: there the
                // count bounds nothing.)
                const bool blocked_light = step >= "22" && step < "25";
                if (!blocked_light) CHECK(trace.lines.size() >= trace.samples);
                CHECK_FALSE(trace.lines.empty());
                ++traced;
            }
            // 48x48 top; 48x22 front and side: 47,21 is inside all; one 48x48 camera picture.
            CHECK(traced == (is_camera_step(step) ? 1 : 3));
        }
    }
}
