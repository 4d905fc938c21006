// test_isosurface.cpp: steps 19 (the isosurface), 17 (Phong) and 18 (the clipping plane) run
// as programs (tools/run_step.h), against analytic volumes written here as raw int16 files: a
// sphere so large that its surface is nearly flat across the volume (the bisected hit on it), a
// sphere seen from many directions (its silhouette) and grazed, a linear ramp whose diffuse and
// Phong terms are computed by hand below, and a slab cut by the clipping plane. Each feature is
// tested in the step that brings it, and again in the steps after it that keep it.
#include <doctest/doctest.h>
#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>
#include "tools/compare.h"
#include "harness.h"
#include "image.h"
#include "tools/run_step.h"
#include "volume.h"

using namespace ctlab;

namespace {

const std::string iso_step = "19_isosurface";       // the first crossing, bisected
const std::string phong_step = "20_phong";           // Phong's terms
const std::string clip_step = "21_clipping_plane";   // the clipping plane
const std::vector<std::string> surface_steps = {iso_step, phong_step, clip_step};

// Runs `step` on `volume_flags` with `flags`, --pfm into `folder`, two threads.
RunResult run_iso(const std::string& step, const std::vector<std::string>& volume_flags,
                  std::vector<std::string> flags, const TempFolder& folder) {
    flags.insert(flags.begin(), volume_flags.begin(), volume_flags.end());
    flags.insert(flags.end(), {"--out", folder.path(), "--pfm", "--threads", "2"});
    RunResult run = run_step(step, flags);
    INFO(run.command() << "\n" << run.err);
    REQUIRE(run.status == 0);
    return run;
}

Image picture(const std::string& step, const TempFolder& folder) {
    return read_pfm(step_output(folder.path(), step, "camera", "pfm"));
}

// A volume of nx x ny x nz voxels at spacing 1, value(i, j, k) rounded to int16.
Volume analytic_volume(int nx, int ny, int nz, const std::function<double(int, int, int)>& f) {
    Volume volume;
    volume.nx = nx;
    volume.ny = ny;
    volume.nz = nz;
    resize_dense(volume);
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                const double value = std::clamp(f(i, j, k), -32768.0, 32767.0);
                volume.data[volume.index(i, j, k)] = int16_t(std::lround(value));
            }
    return volume;
}

struct Point {
    double i = 0, j = 0, k = 0;
};

double distance(const Point& a, const Point& b) {
    return std::sqrt((a.i - b.i) * (a.i - b.i) + (a.j - b.j) * (a.j - b.j) +
                     (a.k - b.k) * (a.k - b.k));
}

// The first trace line that starts with `prefix`, or "".
std::string line_starting(const PixelTrace& trace, const std::string& prefix) {
    for (const std::string& line : trace.lines) {
        if (line.compare(0, prefix.size(), prefix) == 0) return line;
    }
    return "";
}

// The trace's bisection lines ("  bisection  3: t=... bracket t=...").
int bisection_lines(const PixelTrace& trace) {
    int count = 0;
    for (const std::string& line : trace.lines) {
        count += line.find("bisection") != std::string::npos &&
                 line.find("bracket") != std::string::npos;
    }
    return count;
}

// The traced hit: "hit t=T p=(I, J, K) normal=(NI, NJ, NK) from ..."; false when none.
struct TracedHit {
    double t = 0;
    Point p, normal;
};
bool traced_hit(const PixelTrace& trace, TracedHit* hit) {
    const std::string line = line_starting(trace, "hit t=");
    return !line.empty() &&
           std::sscanf(line.c_str(), "hit t=%lf p=(%lf, %lf, %lf) normal=(%lf, %lf, %lf)",
                       &hit->t, &hit->p.i, &hit->p.j, &hit->p.k, &hit->normal.i,
                       &hit->normal.j, &hit->normal.k) == 7;
}

// The traced ray: "ray origin=(...) direction=(...)".
bool traced_ray(const PixelTrace& trace, Point* origin, Point* direction) {
    const std::string line = line_starting(trace, "ray origin=");
    return std::sscanf(line.c_str(), "ray origin=(%lf, %lf, %lf) direction=(%lf, %lf, %lf)",
                       &origin->i, &origin->j, &origin->k, &direction->i, &direction->j,
                       &direction->k) == 6;
}

// The traced Phong terms: "phong L=(...) V=(...) ambient=A diffuse=D specular=S ...".
struct TracedPhong {
    Point to_light, to_viewer;
    double ambient = -1, diffuse = -1, specular = -1;
};
bool traced_phong(const PixelTrace& trace, TracedPhong* phong) {
    const std::string line = line_starting(trace, "phong ");
    return std::sscanf(line.c_str(),
                       "phong L=(%lf, %lf, %lf) V=(%lf, %lf, %lf) ambient=%lf diffuse=%lf "
                       "specular=%lf",
                       &phong->to_light.i, &phong->to_light.j, &phong->to_light.k,
                       &phong->to_viewer.i, &phong->to_viewer.j, &phong->to_viewer.k,
                       &phong->ambient, &phong->diffuse, &phong->specular) == 9;
}

// Step 19's traced light at the hit, step 15's shade(): "gradient=(GI, GJ, GK) shade=S".
bool traced_shade(const PixelTrace& trace, double* shade) {
    const std::string line = line_starting(trace, "gradient=(");
    double gi = 0, gj = 0, gk = 0;
    return std::sscanf(line.c_str(), "gradient=(%lf, %lf, %lf) shade=%lf", &gi, &gj, &gk,
                       shade) == 4;
}

int non_finite_pixels(const Image& image) {
    int count = 0;
    for (const Rgb& p : image.pixels) {
        count += !std::isfinite(p.r) || !std::isfinite(p.g) || !std::isfinite(p.b);
    }
    return count;
}

bool is_background(const Rgb& p) { return p.r == 0.0f && p.g == 0.0f && p.b == 0.0f; }

}  // namespace

TEST_CASE("isosurface: the bisected hit lies on a large analytic sphere within 1e-3 voxel") {
    // f = 400 + 1000 * (R - |p - c|), R = 1000 voxels, centre below the volume: its surface
    // crosses the 40^3 volume near k = 16, bulging by at most 0.4 voxel. Error budget for the
    // hit's distance from c: rounding to int16 at most 0.5 / 1000 = 5e-4; trilinear
    // interpolation of |p - c| at most 1/4 * (1/R) = 2.5e-4 (its curvature 1/R across the cell);
    // bisection to a bracket of 1e-4, at most 5e-5 from its midpoint. No voxel is clamped:
    // the surface is at most 25 voxels away, 25000 from 400.
    constexpr double radius = 1000, slope = 1000;
    const Point centre = {19.5, 19.5, 16 + radius};
    const Volume volume = analytic_volume(40, 40, 40, [&](int i, int j, int k) {
        return 400 + slope * (radius - distance({double(i), double(j), double(k)}, centre));
    });
    const TempFolder folder("isosurface_sphere");
    const std::vector<std::string> raw = write_raw_volume(volume, folder.path("sphere.raw"));
    struct Case {
        const char *azimuth, *elevation, *projection, *step, *pixel;
    };
    const Case cases[] = {{"180", "90", "ortho", "1", "20,20"},
                          {"180", "90", "ortho", "1", "3,35"},
                          {"30", "60", "ortho", "1", "24,20"},
                          {"-70", "45", "ortho", "0.7", "20,10"},
                          {"123", "75", "perspective", "1", "20,17"},
                          {"10", "35", "perspective", "2.5", "20,14"}};
    for (const std::string& step : surface_steps) {
        for (const Case& c : cases) {
            CAPTURE(step);
            CAPTURE(std::string(c.azimuth));
            CAPTURE(std::string(c.elevation));
            CAPTURE(std::string(c.projection));
            const RunResult run = run_iso(
                step, raw,
                {"--azimuth", c.azimuth, "--elevation", c.elevation, "--projection",
                 c.projection, "--step", c.step, "--size", "40x40", "--debug-pixel", c.pixel},
                folder);
            REQUIRE(run.traces.size() == 1);
            const PixelTrace& trace = run.traces[0];
            TracedHit hit;
            REQUIRE(traced_hit(trace, &hit));
            CHECK(std::fabs(distance(hit.p, centre) - radius) < 1e-3);
            // Bisection from a bracket of one step to 1e-4 voxel: ceil(log2(step / 1e-4))
            // halvings, each traced.
            const int halvings = int(std::ceil(std::log2(std::stod(c.step) / 1e-4)));
            CHECK(bisection_lines(trace) == halvings);
            CHECK(line_starting(trace, "crossing between").size() > 0);
            // The normal is the sphere's outward one, (p - c) / R, from the gradient.
            const Point outward = {(hit.p.i - centre.i) / radius, (hit.p.j - centre.j) / radius,
                                   (hit.p.k - centre.k) / radius};
            CHECK(distance(hit.normal, outward) < 2e-3);
            CHECK(non_finite_pixels(picture(step, folder)) == 0);
        }
    }
}

TEST_CASE("isosurface: a sphere's silhouette has the same radius from every direction") {
    // f = 300 + 100 * (20 - r) about the centre of a 64^3 grid: the surface at iso 300 is the
    // sphere of radius 20; an orthographic camera at zoom 1 shows a disc of radius 20 pixels.
    constexpr int n = 64;
    constexpr double radius = 20;
    const double middle = (n - 1) / 2.0;
    const Volume volume = analytic_volume(n, n, n, [&](int i, int j, int k) {
        return 300 + 100 * (radius - distance({double(i), double(j), double(k)},
                                              {middle, middle, middle}));
    });
    const TempFolder folder("isosurface_silhouette");
    const std::vector<std::string> raw = write_raw_volume(volume, folder.path("sphere.raw"));
    const char* directions[][2] = {{"0", "0"},     {"30", "20"},  {"90", "0"},   {"180", "90"},
                                   {"-45", "-60"}, {"123", "37"}, {"200", "-5"}, {"17", "89"}};
    // Step 19 finds the surface; step 21, with all of it, still does (17 lights it only).
    for (const std::string& step : {iso_step, clip_step}) {
        CAPTURE(step);
        double smallest = 1e9, largest = 0;
        for (const auto& direction : directions) {
            CAPTURE(std::string(direction[0]));
            CAPTURE(std::string(direction[1]));
            const RunResult run = run_iso(
                step, raw,
                {"--azimuth", direction[0], "--elevation", direction[1], "--size", "64x64",
                 "--step", "0.5", "--iso", "300"},
                folder);
            const Image image = picture(step, folder);
            CHECK(non_finite_pixels(image) == 0);
            int inside = 0;
            for (const Rgb& p : image.pixels) inside += !is_background(p);
            CHECK(summary_count(run.summary("camera"), "hits") == unsigned(inside));
            const double seen = std::sqrt(inside / 3.14159265358979323846);  // pixels
            CHECK(std::fabs(seen - radius) < 0.5);
            smallest = std::min(smallest, seen);
            largest = std::max(largest, seen);
        }
        CHECK(largest - smallest < 0.5);
    }
}

TEST_CASE("isosurface: rays grazing a sphere hit it on its surface or miss it, never NaN") {
    // f = 300 + 100 * (R - r), R = 19.53, about the centre of a 64^3 grid, seen along +j at
    // zoom 1. Pixel (51, 31)'s ray passes 19.5064 from the centre: 0.024 inside the sphere, a
    // chord of 1.9 voxels; pixel (51, 30)'s passes 19.5576 from it: 0.028 outside. The trilinear
    // field's surface lies up to 0.013 inside the sphere (|p - c| interpolated is never below
    // the true one) and rounding moves it 0.005: one ray must hit, the other must miss.
    constexpr int n = 64;
    constexpr double radius = 19.53;
    const double middle = (n - 1) / 2.0;
    const Point centre = {middle, middle, middle};
    const Volume volume = analytic_volume(n, n, n, [&](int i, int j, int k) {
        return 300 + 100 * (radius - distance({double(i), double(j), double(k)}, centre));
    });
    const TempFolder folder("isosurface_grazing");
    const std::vector<std::string> raw = write_raw_volume(volume, folder.path("sphere.raw"));
    for (const std::string& iso_program : {iso_step, clip_step}) {
        for (const char* step : {"0.25", "1"}) {
            CAPTURE(iso_program);
            // The four grazing pixels traced in one run.
            const char* pixels[] = {"51,31", "51,30", "12,31", "31,12"};
            std::vector<std::string> flags = {"--azimuth", "0",  "--elevation", "0",  "--size",
                                              "64x64",     "--step", step,     "--iso", "300"};
            for (const char* pixel : pixels) {
                flags.insert(flags.end(), {"--debug-pixel", pixel});
            }
            const RunResult run = run_iso(iso_program, raw, flags, folder);
            REQUIRE(run.traces.size() == 4);
            CHECK(run.out.find("nan") == std::string::npos);
            CHECK(non_finite_pixels(picture(iso_program, folder)) == 0);
            for (int p = 0; p < 4; ++p) {
                const char* pixel = pixels[p];
                CAPTURE(std::string(step));
                CAPTURE(std::string(pixel));
                const PixelTrace& trace = run.traces[p];
                CHECK(std::to_string(trace.x) + "," + std::to_string(trace.y) == pixel);
                Point origin, direction;
                REQUIRE(traced_ray(trace, &origin, &direction));
                // The ray's closest distance to the centre, from its origin and unit direction.
                const Point to_centre = {centre.i - origin.i, centre.j - origin.j,
                                         centre.k - origin.k};
                const double along = to_centre.i * direction.i + to_centre.j * direction.j +
                                     to_centre.k * direction.k;
                const Point closest = {origin.i + along * direction.i,
                                       origin.j + along * direction.j,
                                       origin.k + along * direction.k};
                const double passes = distance(closest, centre);
                CAPTURE(passes);
                REQUIRE(std::fabs(passes - radius) < 0.03);  // these pixels graze
                TracedHit hit;
                const bool hit_found = traced_hit(trace, &hit);
                if (passes > radius) {
                    CHECK_FALSE(hit_found);
                    CHECK(is_background(trace.rgb));
                } else if (std::string(step) == "0.25") {
                    // Samples 0.25 apart land inside a chord of 1.9: it must be found.
                    REQUIRE(hit_found);
                }
                if (hit_found) {
                    // Near grazing the crossing slides along the ray, but stays on the sphere.
                    CHECK(std::fabs(distance(hit.p, centre) - radius) < 0.02);
                    CHECK(std::isfinite(hit.normal.i + hit.normal.j + hit.normal.k));
                    CHECK(!is_background(trace.rgb));
                }
            }
        }
    }
}

TEST_CASE("clipping plane (step 21): it removes exactly its half-space, iso and composite") {
    // A slab of bone (1000) for 8 <= k < 24 in air (-1000), 32^3 voxels at spacing 1. Seen
    // along +i (azimuth 90, elevation 0) at zoom 1, pixel (x, y) is the ray along the row of
    // voxels j = x, k = y.
    const Volume volume = analytic_volume(32, 32, 32, [](int, int, int k) {
        return k >= 8 && k < 24 ? 1000.0 : -1000.0;
    });
    const TempFolder folder("isosurface_clip");
    const std::vector<std::string> raw = write_raw_volume(volume, folder.path("slab.raw"));
    const std::vector<std::string> side = {"--azimuth", "90", "--elevation", "0", "--size",
                                           "32x32"};
    auto in_slab = [](int y) { return y >= 8 && y < 24; };
    for (const std::string mode : {"iso", "composite"}) {
        CAPTURE(mode);
        // Unclipped: the slab's rows, every column.
        std::vector<std::string> flags = side;
        flags.insert(flags.end(), {"--mode", mode});
        run_iso(clip_step, raw, flags, folder);
        Image image = picture(clip_step, folder);
        for (int y = 0; y < 32; ++y)
            for (int x = 0; x < 32; ++x) {
                CAPTURE(x);
                CAPTURE(y);
                CHECK(is_background(image.at(x, y)) == !in_slab(y));
            }
        // A plane along the rays: j <= 12.5 kept. Every ray is parallel to it: kept whole or
        // cut away whole.
        std::vector<std::string> clipped = flags;
        clipped.insert(clipped.end(), {"--clip", "0,1,0,12.5"});
        run_iso(clip_step, raw, clipped, folder);
        image = picture(clip_step, folder);
        for (int y = 0; y < 32; ++y)
            for (int x = 0; x < 32; ++x) {
                CAPTURE(x);
                CAPTURE(y);
                CHECK(is_background(image.at(x, y)) == !(in_slab(y) && x <= 12));
            }
        // An oblique one, not normalised: (j + k) / sqrt(2) <= 30.5 / sqrt(2), i.e. j + k <= 30.5.
        clipped = flags;
        clipped.insert(clipped.end(), {"--clip", "0,3,3,91.5"});
        run_iso(clip_step, raw, clipped, folder);
        image = picture(clip_step, folder);
        for (int y = 0; y < 32; ++y)
            for (int x = 0; x < 32; ++x) {
                CAPTURE(x);
                CAPTURE(y);
                CHECK(is_background(image.at(x, y)) == !(in_slab(y) && x + y <= 30));
            }
        // A plane across the rays: i >= 10.25 kept (-i <= -10.25). The rays start on it.
        clipped = flags;
        clipped.insert(clipped.end(), {"--clip", "-1,0,0,-10.25", "--debug-pixel", "5,12"});
        const RunResult run = run_iso(clip_step, raw, clipped, folder);
        REQUIRE(run.traces.size() == 1);
        CHECK(line_starting(run.traces[0], "clip ").find("t=") != std::string::npos);
        CHECK(line_starting(run.traces[0], "clip ").find("entering through the plane") !=
              std::string::npos);
        image = picture(clip_step, folder);
        for (int y = 0; y < 32; ++y)
            for (int x = 0; x < 32; ++x) CHECK(is_background(image.at(x, y)) == !in_slab(y));
        if (mode == "iso") {
            // Inside the slab from the start: the hit is on the plane, the cut face, lit with
            // the plane's outward normal (-1, 0, 0), facing the camera.
            TracedHit hit;
            REQUIRE(traced_hit(run.traces[0], &hit));
            CHECK(hit.p.i == doctest::Approx(10.25).epsilon(1e-9));
            CHECK(hit.normal.i == -1);
            CHECK(hit.normal.j == 0);
            CHECK(hit.normal.k == 0);
            CHECK(line_starting(run.traces[0], "hit t=").find("from the clip plane") !=
                  std::string::npos);
        }
    }
    // A plane that leaves nothing of the volume: the background everywhere, every trace says so.
    std::vector<std::string> nothing = side;
    nothing.insert(nothing.end(), {"--clip", "1,0,0,-1", "--debug-pixel", "16,16"});
    const RunResult run = run_iso(clip_step, raw, nothing, folder);
    for (const Rgb& p : picture(clip_step, folder).pixels) CHECK(is_background(p));
    REQUIRE(run.traces.size() == 1);
    CHECK(line_starting(run.traces[0], "clip ").find("cut away") != std::string::npos);
    CHECK(summary_count(run.summary("camera"), "samples") == 0);
}

namespace {

// f = 400 + 50 (i - 10) + 100 (k - 10) on 21^3 voxels at spacing 1: gradient (50, 0, 100)
// everywhere (central and one-sided differences are exact on a ramp), so the outward normal is
// N = -(1, 0, 2) / sqrt(5) = (-0.447214, 0, -0.894427). The camera looks down +k (azimuth 180,
// elevation 90): V = (0, 0, -1), right = +i, up = -j. --light-angle 0 puts the light 20
// degrees above the viewer: L = (0, -sin 20, -cos 20) = (0, -0.342020, -0.939693), and
//   N.L = 0.894427 * 0.939693 = 0.840487.
// At --light-angle 180 the light comes from behind the volume: L = (0, -0.342020, 0.939693),
// N.L = -0.840487 < 0.
Volume ramp_volume() {
    return analytic_volume(21, 21, 21, [](int i, int, int k) {
        return 400 + 50.0 * (i - 10) + 100.0 * (k - 10);
    });
}
const std::vector<std::string> ramp_view = {"--azimuth", "180", "--elevation", "90", "--size",
                                            "21x21", "--debug-pixel", "7,9"};

// The hit of the ramp's pixel (7, 9): on the plane f = 400, with the normal N above.
void check_ramp_hit(const PixelTrace& trace) {
    TracedHit hit;
    REQUIRE(traced_hit(trace, &hit));
    // On the plane f = 400: 50 (i - 10) + 100 (k - 10) = 0, found to 1e-4 voxel.
    CHECK(std::fabs(50 * (hit.p.i - 10) + 100 * (hit.p.k - 10)) < 100 * 1e-4);
    CHECK(hit.normal.i == doctest::Approx(-0.447214).epsilon(1e-5));
    CHECK(hit.normal.j == 0);
    CHECK(hit.normal.k == doctest::Approx(-0.894427).epsilon(1e-5));
}

}  // namespace

TEST_CASE("isosurface (step 19): the surface is lit as step 15 lights a sample, by hand") {
    // Step 15's shade(): ambient 0.1 + (1 - 0.1) max(0, N.L) on a white surface:
    //   light angle 0: 0.1 + 0.9 * 0.840487 = 0.856438; light angle 180: ambient only, 0.1.
    const TempFolder folder("isosurface_diffuse");
    const std::vector<std::string> raw =
        write_raw_volume(ramp_volume(), folder.path("ramp.raw"));
    for (const auto& [light_angle, lit] : {std::pair<const char*, double>{"0", 0.856438},
                                           std::pair<const char*, double>{"180", 0.1}}) {
        CAPTURE(std::string(light_angle));
        std::vector<std::string> flags = ramp_view;
        flags.insert(flags.end(), {"--light-angle", light_angle});
        const RunResult run = run_iso(iso_step, raw, flags, folder);
        REQUIRE(run.traces.size() == 1);
        const PixelTrace& trace = run.traces[0];
        check_ramp_hit(trace);
        double shade = -1;
        REQUIRE(traced_shade(trace, &shade));
        CHECK(shade == doctest::Approx(lit).epsilon(1e-5));
        CHECK(trace.rgb.r == doctest::Approx(lit).epsilon(1e-5));
        CHECK(trace.rgb.g == doctest::Approx(lit).epsilon(1e-5));
        CHECK(picture(iso_step, folder).at(7, 9).b == doctest::Approx(lit).epsilon(1e-5));
    }
}

TEST_CASE("Phong (steps 20, 21): the terms equal the hand-computed ones for a known normal, "
          "light and view") {
    // With L and N as above (light angle 0):
    //   R = 2 (N.L) N - L = (-0.751755, 0.342020, -0.563817), R.V = 0.563817
    //   ambient 0.1; diffuse 0.6 * 0.840487 = 0.504292;
    //   specular 0.3 * 0.563817^4 = 0.3 * 0.101054 = 0.030316 (shininess 4)
    //   pixel: white surface, 0.1 + 0.504292 + 0.030316 = 0.634608 in every channel.
    // Light angle 180: N.L < 0, ambient only, 0.1.
    const TempFolder folder("isosurface_phong");
    const std::vector<std::string> raw =
        write_raw_volume(ramp_volume(), folder.path("ramp.raw"));
    struct Case {
        const char* light_angle;
        double ambient, diffuse, specular;
    };
    for (const std::string& step : {phong_step, clip_step}) {
        for (const Case& c : {Case{"0", 0.1, 0.504292, 0.030316}, Case{"180", 0.1, 0, 0}}) {
            CAPTURE(step);
            CAPTURE(std::string(c.light_angle));
            std::vector<std::string> flags = ramp_view;
            flags.insert(flags.end(), {"--shininess", "4", "--light-angle", c.light_angle});
            const RunResult run = run_iso(step, raw, flags, folder);
            REQUIRE(run.traces.size() == 1);
            const PixelTrace& trace = run.traces[0];
            check_ramp_hit(trace);
            TracedPhong phong;
            REQUIRE(traced_phong(trace, &phong));
            CHECK(phong.to_viewer.i == 0);
            CHECK(phong.to_viewer.k == doctest::Approx(-1).epsilon(1e-6));
            CHECK(phong.to_light.j == doctest::Approx(-0.342020).epsilon(1e-5));
            CHECK(phong.ambient == doctest::Approx(c.ambient).epsilon(1e-5));
            CHECK(phong.diffuse == doctest::Approx(c.diffuse).epsilon(1e-5));
            CHECK(phong.specular == doctest::Approx(c.specular).epsilon(1e-4));
            const double lit = c.ambient + c.diffuse + c.specular;
            CHECK(trace.rgb.r == doctest::Approx(lit).epsilon(1e-5));
            CHECK(trace.rgb.g == doctest::Approx(lit).epsilon(1e-5));
            CHECK(picture(step, folder).at(7, 9).b == doctest::Approx(lit).epsilon(1e-5));
        }
    }
}

TEST_CASE("isosurface: the picture and the work do not depend on the thread count") {
    // Step 19's surface, and step 21's with a clipping plane.
    for (const std::string& step : {iso_step, clip_step}) {
        CAPTURE(step);
        const TempFolder one("isosurface_threads1"), three("isosurface_threads3");
        std::vector<Summary> summaries;
        for (const TempFolder* folder : {&one, &three}) {
            // The phantom painted once in this process (harness.h), not by every run.
            std::vector<std::string> flags = ctlab_test::phantom_flags();
            flags.insert(flags.end(), {"--size", "96x80", "--zoom", "0.3", "--projection",
                                       "perspective", "--out", folder->path(), "--pfm",
                                       "--threads", folder == &one ? "1" : "3"});
            if (step == clip_step) flags.insert(flags.end(), {"--clip", "0,-1,0,-110"});
            const RunResult run = run_step(step, flags);
            REQUIRE(run.status == 0);
            summaries.push_back(run.summary("camera"));
        }
        const Image a = picture(step, one), b = picture(step, three);
        CHECK(std::equal(a.pixels.begin(), a.pixels.end(), b.pixels.begin(),
                         [](const Rgb& p, const Rgb& q) {
                             return p.r == q.r && p.g == q.g && p.b == q.b;
                         }));
        for (const char* counter : {"samples", "leapt", "gradients", "terminated", "hits"}) {
            CAPTURE(counter);
            CHECK(summaries[0].at(counter) == summaries[1].at(counter));
        }
    }
}

TEST_CASE("isosurface: bad flags are refused with status 2, naming the flag") {
    using Flags = std::vector<std::string>;
    // Each step refuses bad values of its own flags and of the earlier steps' it keeps.
    const std::vector<std::pair<std::string, std::vector<Flags>>> cases = {
        {iso_step, {{"--mode", "mip"}, {"--iso", "40000"}, {"--view", "top"}}},
        {phong_step, {{"--shininess", "0"}, {"--iso", "40000"}}},
        {clip_step,
         {{"--clip", "1,0,0"}, {"--clip", "0,0,0,5"}, {"--clip", "1,0,0,x"},
          {"--clip", "1,0,0,1e9"}, {"--clip", "1,,0,3"}, {"--mode", "mip"},
          {"--shininess", "0"}, {"--iso", "40000"}, {"--view", "top"}}}};
    for (const auto& [step, all] : cases) {
        for (const Flags& flags : all) {
            Flags args = {"--volume", "phantom", "--no-window"};
            args.insert(args.end(), flags.begin(), flags.end());
            const RunResult run = run_step(step, args);
            CAPTURE(run.command());
            CAPTURE(run.err);
            CHECK(run.status == 2);
            CHECK(run.err.find("error: " + flags[0]) != std::string::npos);
        }
    }
    // A flag of a later step is not one of an earlier step's.
    const std::vector<std::pair<std::string, Flags>> later = {
        {iso_step, {"--shininess", "40"}}, {phong_step, {"--clip", "1,0,0,5"}}};
    for (const auto& [step, flag] : later) {
        Flags args = {"--volume", "phantom", "--no-window"};
        args.insert(args.end(), flag.begin(), flag.end());
        const RunResult run = run_step(step, args);
        CAPTURE(run.command());
        CAPTURE(run.err);
        CHECK(run.status == 2);
    }
}

TEST_CASE("isosurface: each step's default run matches its reference image, no NaN") {
    for (const std::string& step : surface_steps) {
        CAPTURE(step);
        const TempFolder folder("isosurface_golden");
        const RunResult run = run_iso(step, ctlab_test::phantom_flags(), {}, folder);
        const Image image = picture(step, folder);
        CHECK(non_finite_pixels(image) == 0);
        CHECK(summary_count(run.summary("camera"), "hits") > 0);
        CHECK(run.summary("camera").at("size") == "512x512");
        const std::string path = "data/reference/" + step + "_camera.png";
        REQUIRE_MESSAGE(access(path.c_str(), R_OK) == 0,
                        "missing " << path << ": make reference");
        const Comparison c =
            compare_images(image, read_image(path), 1, "the float render", path);
        INFO(comparison_line(c));
        CHECK(c.max_abs <= 2);
        CHECK(c.over_tol_pct <= 0.1);
    }
}
