// test_free_camera.cpp: steps 13, 14, 15 and 21 (the orbit camera, the slab method, trilinear
// samples, leaping along a free ray; most cases on step 25, which has them all) run as programs
// (tools/run_step.h): its pictures along the three axes against part 1's (step 10), the slab
// method's stiff cases seen in its traces and float images, trilinear samples on a linear ramp
// against the closed form, and a sphere whose silhouette has the same radius from every
// direction.
#include <doctest/doctest.h>
#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>
#include "tools/compare.h"
#include "harness.h"
#include "image.h"
#include "phantom.h"
#include "tools/run_step.h"
#include "volume.h"

using namespace ctlab;

namespace {

const std::string free_camera = "25_free_leaping";
const std::string part1 = "10_opacity_correction";

// Runs a step with --pfm into `folder` and returns its result; the image is read separately.
RunResult render(const std::string& step, const std::vector<std::string>& volume_flags,
                 std::vector<std::string> flags, const TempFolder& folder) {
    flags.insert(flags.begin(), volume_flags.begin(), volume_flags.end());
    flags.insert(flags.end(), {"--out", folder.path(), "--pfm", "--threads", "2"});
    RunResult run = run_step(step, flags);
    INFO(run.command() << "\n" << run.err);
    REQUIRE(run.status == 0);
    return run;
}

Image pfm_of(const TempFolder& folder, const std::string& step, const std::string& view) {
    return read_pfm(step_output(folder.path(), step, view, "pfm"));
}

// Pixels whose channels differ at all, between a and b (b mirrored left-right if asked).
int differing_pixels(const Image& a, const Image& b, bool mirror_b) {
    REQUIRE(a.width == b.width);
    REQUIRE(a.height == b.height);
    int count = 0;
    for (int y = 0; y < a.height; ++y) {
        for (int x = 0; x < a.width; ++x) {
            const Rgb& p = a.at(x, y);
            const Rgb& q = b.at(mirror_b ? b.width - 1 - x : x, y);
            if (p.r != q.r || p.g != q.g || p.b != q.b) ++count;
        }
    }
    return count;
}

int non_finite_pixels(const Image& image) {
    int count = 0;
    for (const Rgb& p : image.pixels) {
        if (!std::isfinite(p.r) || !std::isfinite(p.g) || !std::isfinite(p.b)) ++count;
    }
    return count;
}

// The phantom with spacing 1,1,1, so a camera's square pixels land on every voxel centre in
// the front and side views too.
std::vector<std::string> isotropic_phantom(const TempFolder& folder) {
    Volume volume = make_phantom();
    volume.sx = volume.sy = volume.sz = 1;
    return write_raw_volume(volume, folder.path("phantom_iso.raw"));
}

// Every "p=(X, Y, Z) value=V" of a trace, as numbers.
struct TracedSample {
    double x, y, z, value;
};
std::vector<TracedSample> traced_samples(const PixelTrace& trace) {
    std::vector<TracedSample> samples;
    for (const std::string& line : trace.lines) {
        const size_t at = line.find("p=(");
        if (at == std::string::npos) continue;
        TracedSample s{};
        if (std::sscanf(line.c_str() + at, "p=(%lf, %lf, %lf) value=%lf", &s.x, &s.y, &s.z,
                        &s.value) == 4) {
            samples.push_back(s);
        }
    }
    return samples;
}

// The line of a trace that starts with `prefix` ("box", "ray"), or "".
std::string trace_line(const PixelTrace& trace, const std::string& prefix) {
    for (const std::string& line : trace.lines) {
        if (line.compare(0, prefix.size(), prefix) == 0) return line;
    }
    return "";
}

}  // namespace

TEST_CASE("free camera: along the three axes it draws part 1's top and side views and the "
          "mirror of its front view, bit for bit") {
    // Orthographic, zoom 1 (one pixel per voxel), the image the size of part 1's, the step the
    // spacing along the ray: every sample is a voxel centre, where trilinear is the voxel.
    const TempFolder folder("free_camera_axes");
    const std::vector<std::string>& phantom = ctlab_test::phantom_flags();
    for (const std::string lighting : {"unlit", "lit"}) {
        CAPTURE(lighting);
        const bool lit = lighting == "lit";
        std::vector<std::string> light_flags;
        if (!lit) light_flags.push_back("--unlit");

        // Top: the phantom as it is (spacing 1,1,2), the step 2 along k.
        std::vector<std::string> top = {"--azimuth", "180", "--elevation", "90", "--size",
                                        "256x256", "--step", "2"};
        top.insert(top.end(), light_flags.begin(), light_flags.end());
        render(free_camera, phantom, top, folder);
        std::vector<std::string> part1_top = {"--view", "top", "--step", "2"};
        part1_top.insert(part1_top.end(), light_flags.begin(), light_flags.end());
        render(part1, phantom, part1_top, folder);
        const Image camera_top = pfm_of(folder, free_camera, "camera");
        CHECK(differing_pixels(camera_top, pfm_of(folder, part1, "top"), false) == 0);

        // Side and front need square pixels on the voxels: the phantom at spacing 1,1,1.
        const std::vector<std::string> iso = isotropic_phantom(folder);
        std::vector<std::string> side = {"--azimuth", "90", "--elevation", "0", "--size",
                                         "256x113", "--step", "1"};
        side.insert(side.end(), light_flags.begin(), light_flags.end());
        render(free_camera, iso, side, folder);
        std::vector<std::string> part1_side = {"--view", "side", "--step", "1"};
        part1_side.insert(part1_side.end(), light_flags.begin(), light_flags.end());
        render(part1, iso, part1_side, folder);
        CHECK(differing_pixels(pfm_of(folder, free_camera, "camera"), pfm_of(folder, part1, "side"),
                               false) == 0);

        // Front: the camera facing the face sees part 1's front view mirrored. Lit, its light
        // (30 degrees to the camera's right) is part 1's mirrored too: --light-angle -30 there.
        std::vector<std::string> front = {"--azimuth", "0", "--elevation", "0", "--size",
                                          "256x113", "--step", "1"};
        front.insert(front.end(), light_flags.begin(), light_flags.end());
        render(free_camera, iso, front, folder);
        std::vector<std::string> part1_front = {"--view", "front", "--step", "1"};
        if (lit) part1_front.insert(part1_front.end(), {"--light-angle", "-30"});
        part1_front.insert(part1_front.end(), light_flags.begin(), light_flags.end());
        render(part1, iso, part1_front, folder);
        const Image camera_front = pfm_of(folder, free_camera, "camera");
        const Image part1_front_image = pfm_of(folder, part1, "front");
        if (lit) {
            // The mirrored light is the same direction, computed in another order: within
            // 1/255 (the brief's bound where the path differs), most pixels identical.
            int over = 0;
            for (int y = 0; y < camera_front.height; ++y) {
                for (int x = 0; x < camera_front.width; ++x) {
                    const Rgb& p = camera_front.at(x, y);
                    const Rgb& q = part1_front_image.at(camera_front.width - 1 - x, y);
                    if (std::fabs(p.r - q.r) > 1 / 255.0 || std::fabs(p.g - q.g) > 1 / 255.0 ||
                        std::fabs(p.b - q.b) > 1 / 255.0) {
                        ++over;
                    }
                }
            }
            CHECK(over == 0);
        } else {
            CHECK(differing_pixels(camera_front, part1_front_image, true) == 0);
            // ... and it is not the unmirrored picture (the phantom is not symmetric).
            CHECK(differing_pixels(camera_front, part1_front_image, false) > 100);
        }
    }
}

TEST_CASE("free camera: --interpolation nearest at voxel centres is trilinear's picture and "
          "part 1's top view, bit for bit") {
    // The top view's camera, the step the spacing: every sample is a voxel centre, where the
    // nearest voxel and the trilinear value are that voxel, and the nearest voxel's gradient
    // is step 10's.
    const TempFolder folder("free_camera_nearest");
    const std::vector<std::string>& phantom = ctlab_test::phantom_flags();
    for (const std::string lighting : {"unlit", "lit"}) {
        CAPTURE(lighting);
        std::vector<std::string> top = {"--azimuth", "180", "--elevation", "90", "--size",
                                        "256x256", "--step", "2"};
        std::vector<std::string> part1_top = {"--view", "top", "--step", "2"};
        if (lighting == "unlit") {
            top.push_back("--unlit");
            part1_top.push_back("--unlit");
        }
        std::vector<std::string> nearest = top;
        nearest.insert(nearest.end(), {"--interpolation", "nearest"});
        const RunResult run = render(free_camera, phantom, nearest, folder);
        CHECK(run.out.find("interpolation=nearest") != std::string::npos);
        const Image nearest_top = pfm_of(folder, free_camera, "camera");
        render(free_camera, phantom, top, folder);
        CHECK(differing_pixels(nearest_top, pfm_of(folder, free_camera, "camera"), false) == 0);
        render(part1, phantom, part1_top, folder);
        CHECK(differing_pixels(nearest_top, pfm_of(folder, part1, "top"), false) == 0);
    }
    // Off the voxel centres (the default oblique camera) the two differ.
    const TempFolder oblique("free_camera_nearest_oblique");
    render(free_camera, phantom, {"--size", "64x64", "--zoom", "0.25"}, oblique);
    const Image trilinear = pfm_of(oblique, free_camera, "camera");
    render(free_camera, phantom, {"--size", "64x64", "--zoom", "0.25", "--interpolation",
                                  "nearest"}, oblique);
    CHECK(differing_pixels(trilinear, pfm_of(oblique, free_camera, "camera"), false) > 100);
}

TEST_CASE("free camera: the slab method's stiff cases give an entry and exit or a clean "
          "miss, never NaN") {
    const TempFolder folder("free_camera_slab");
    // The phantom painted once (harness.h); the runs whose whole output is searched for
    // "nan" name the built-in one, as their volume line would name a temporary path.
    const std::vector<std::string>& phantom = ctlab_test::phantom_flags();
    const std::vector<std::string> built_in = {"--volume", "phantom"};

    SUBCASE("rays parallel to two faces, their origins on the faces' planes (0 * inf)") {
        // Looking straight down k: direction (0, -0, 1). Pixel (0, 0) starts on the planes
        // i = 0 and j = 0 and runs along the box's edge from corner (0, 0, 0) to (0, 0, 224);
        // pixel (255, 255) along the opposite edge, on the planes i = 255 and j = 255.
        // --no-leaping: the edge is air, and the trace should show every sample read.
        const RunResult run = render(free_camera, built_in,
                                     {"--azimuth", "180", "--elevation", "90", "--size",
                                      "256x256", "--step", "2", "--debug-pixel", "0,0",
                                      "--no-leaping"},
                                     folder);
        CHECK(non_finite_pixels(pfm_of(folder, free_camera, "camera")) == 0);
        REQUIRE(run.traces.size() == 1);
        const PixelTrace& trace = run.traces[0];
        CHECK(trace.complete);
        CHECK(run.out.find("nan") == std::string::npos);
        const std::string ray = trace_line(trace, "ray");
        CHECK(ray.compare(0, 19, "ray origin=(0, 0, -") == 0);  // below the crown, k < 0
        CHECK(ray.find("direction=(0, -0, 1)") != std::string::npos);
        CHECK(trace_line(trace, "box").find("at (0.0000, 0.0000, 0.0000) through the k face")
              != std::string::npos);
        CHECK(trace_line(trace, "box").find("at (0.0000, 0.0000, 224.0000)") !=
              std::string::npos);
        CHECK(trace.samples > 0);

        const RunResult far = render(free_camera, phantom,
                                     {"--azimuth", "180", "--elevation", "90", "--size",
                                      "256x256", "--step", "2", "--debug-pixel", "255,255"},
                                     folder);
        REQUIRE(far.traces.size() == 1);
        CHECK(trace_line(far.traces[0], "box").find("exit t=") != std::string::npos);
        CHECK(trace_line(far.traces[0], "box").find("(255.0000, 255.0000, 224.0000)") !=
              std::string::npos);
    }

    SUBCASE("rays that miss the box") {
        // Zoomed out, the image's corner pixels pass beside the box.
        const RunResult run = render(free_camera, phantom,
                                     {"--size", "128x128", "--zoom", "0.25", "--debug-pixel",
                                      "0,0"},
                                     folder);
        const Image image = pfm_of(folder, free_camera, "camera");
        CHECK(non_finite_pixels(image) == 0);
        REQUIRE(run.traces.size() == 1);
        CHECK(trace_line(run.traces[0], "box").find("missed") != std::string::npos);
        CHECK(run.traces[0].samples == 0);
        CHECK(image.at(0, 0).r == 0.0f);
        CHECK(image.at(64, 64).r > 0.0f);  // the centre pixel meets the head
    }

    SUBCASE("a perspective camera inside the box") {
        const RunResult run = render(free_camera, built_in,
                                     {"--projection", "perspective", "--zoom", "20", "--size",
                                      "96x64", "--fov", "90", "--debug-pixel", "48,32"},
                                     folder);
        CHECK(non_finite_pixels(pfm_of(folder, free_camera, "camera")) == 0);
        REQUIRE(run.traces.size() == 1);
        const std::string box = trace_line(run.traces[0], "box");
        CHECK(box.find("entry t=0.000000") != std::string::npos);
        CHECK(box.find("none (starts inside)") != std::string::npos);
        CHECK(run.out.find("nan") == std::string::npos);
    }

    SUBCASE("every axis-aligned camera, ortho and perspective: no NaN anywhere") {
        for (const char* azimuth : {"-180", "-90", "0", "90", "180", "270"}) {
            for (const char* elevation : {"-90", "0", "90"}) {
                for (const char* projection : {"ortho", "perspective"}) {
                    CAPTURE(azimuth);
                    CAPTURE(elevation);
                    CAPTURE(projection);
                    const RunResult run = render(
                        free_camera, phantom,
                        {"--azimuth", azimuth, "--elevation", elevation, "--projection",
                         projection, "--size", "64x48", "--zoom", "0.25", "--unlit"},
                        folder);
                    const Image image = pfm_of(folder, free_camera, "camera");
                    CHECK(non_finite_pixels(image) == 0);
                    CHECK(summary_count(run.summary("camera"), "samples") > 0);
                }
            }
        }
    }
}

TEST_CASE("free camera: trilinear samples of a linear ramp equal the closed form") {
    // value(i, j, k) = 3i + 5j + 7k on a 9x8x7 grid with spacing 1, 0.5, 2: a linear field in
    // physical space, value(x, y, z) = 3x + 10y + 3.5z, which trilinear reproduces anywhere.
    Volume volume;
    volume.nx = 9;
    volume.ny = 8;
    volume.nz = 7;
    volume.sx = 1;
    volume.sy = 0.5;
    volume.sz = 2;
    resize_dense(volume);
    for (int k = 0; k < volume.nz; ++k)
        for (int j = 0; j < volume.ny; ++j)
            for (int i = 0; i < volume.nx; ++i)
                volume.data[volume.index(i, j, k)] = int16_t(3 * i + 5 * j + 7 * k);
    const TempFolder folder("free_camera_ramp");
    const std::vector<std::string> raw = write_raw_volume(volume, folder.path("ramp.raw"));
    for (const std::string projection : {"ortho", "perspective"}) {
        CAPTURE(projection);
        const RunResult run = render(free_camera, raw,
                                     {"--projection", projection, "--azimuth", "33",
                                      "--elevation", "-21", "--size", "24x24", "--zoom", "2",
                                      "--step", "0.25", "--ert", "0", "--debug-pixel", "12,11"},
                                     folder);
        REQUIRE(run.traces.size() == 1);
        const std::vector<TracedSample> samples = traced_samples(run.traces[0]);
        CHECK(samples.size() >= 15);  // the box is 3.5 units deep along j: a chord of ~4.5
        CHECK(samples.size() == run.traces[0].samples);
        double worst = 0;
        for (const TracedSample& s : samples) {
            worst = std::max(worst, std::fabs(s.value - (3 * s.x + 10 * s.y + 3.5 * s.z)));
        }
        CHECK(worst < 2e-3);  // the trace's 4 decimals and float rounding of values up to 112
    }
}

TEST_CASE("free camera: a sphere has the same silhouette radius from every direction") {
    // A radial ramp: value 300 + 100 * (20 - r), r the distance from the centre of a 64^3
    // grid, clamped to int16 range: bone (>= 300) exactly inside r = 20. Skin is switched off.
    constexpr int n = 64;
    constexpr double radius = 20;
    Volume volume;
    volume.nx = volume.ny = volume.nz = n;
    resize_dense(volume);
    const double centre = (n - 1) / 2.0;
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const double r = std::sqrt((i - centre) * (i - centre) +
                                           (j - centre) * (j - centre) +
                                           (k - centre) * (k - centre));
                const double value = std::clamp(300 + 100 * (radius - r), -1000.0, 2000.0);
                volume.data[volume.index(i, j, k)] = int16_t(std::lround(value));
            }
    const TempFolder folder("free_camera_sphere");
    const std::vector<std::string> raw = write_raw_volume(volume, folder.path("sphere.raw"));
    const char* directions[][2] = {{"0", "0"},   {"30", "20"},   {"90", "0"},  {"180", "90"},
                                   {"-45", "-60"}, {"123", "37"}, {"200", "-5"}};
    double smallest = 1e9, largest = 0;
    for (const auto& direction : directions) {
        CAPTURE(direction[0]);
        CAPTURE(direction[1]);
        render(free_camera, raw,
               {"--azimuth", direction[0], "--elevation", direction[1], "--size", "64x64",
                "--step", "0.25", "--skin-opacity", "0", "--unlit"},
               folder);
        const Image image = pfm_of(folder, free_camera, "camera");
        int inside = 0;
        for (const Rgb& p : image.pixels) inside += p.r > 0.5f ? 1 : 0;
        const double seen = std::sqrt(inside / 3.14159265358979323846);  // pixels
        CHECK(std::fabs(seen - radius) < 0.5);
        smallest = std::min(smallest, seen);
        largest = std::max(largest, seen);
    }
    CHECK(largest - smallest < 0.5);
}

TEST_CASE("free camera: bad camera flags are refused with status 2") {
    for (const std::vector<std::string>& flags :
         std::vector<std::vector<std::string>>{{"--view", "top"},
                                               {"--size", "512"},
                                               {"--size", "0x10"},
                                               {"--size", "10x9999"},
                                               {"--elevation", "91"},
                                               {"--projection", "fisheye"},
                                               {"--zoom", "0"},
                                               {"--fov", "180"}}) {
        std::vector<std::string> args = {"--volume", "phantom"};
        args.insert(args.end(), flags.begin(), flags.end());
        const RunResult run = run_step(free_camera, args);
        CAPTURE(run.command());
        CHECK(run.status == 2);
        CHECK(run.err.find("error: " + flags[0]) != std::string::npos);
    }
}

TEST_CASE("free camera: the default run matches its reference image, no NaN") {
    // As test_golden.cpp does for part 1 (same tolerance): make reference renders it.
    const TempFolder folder("free_camera_golden");
    const RunResult run = render(free_camera, ctlab_test::phantom_flags(), {}, folder);
    const Image image = pfm_of(folder, free_camera, "camera");
    CHECK(non_finite_pixels(image) == 0);
    CHECK(summary_count(run.summary("camera"), "samples") > 0);
    CHECK(run.summary("camera").at("size") == "512x512");
    const std::string path = "data/reference/25_free_leaping_camera.png";
    REQUIRE_MESSAGE(access(path.c_str(), R_OK) == 0, "missing " << path << ": make reference");
    const Image reference = read_image(path);
    const Comparison c = compare_images(image, reference, 1, "the float render", path);
    INFO(comparison_line(c));
    CHECK(c.max_abs <= 2);
    CHECK(c.over_tol_pct <= 0.1);
}

TEST_CASE("free camera: the picture and the work counts do not depend on the thread count") {
    const TempFolder one("free_camera_threads1"), three("free_camera_threads3");
    std::vector<Summary> summaries;
    for (const TempFolder* folder : {&one, &three}) {
        const std::string threads = folder == &one ? "1" : "3";
        std::vector<std::string> args = ctlab_test::phantom_flags();
        args.insert(args.end(), {"--size", "96x80", "--zoom", "0.3", "--projection",
                                 "perspective", "--out", folder->path(), "--pfm", "--threads",
                                 threads});
        const RunResult run = run_step(free_camera, args);
        REQUIRE(run.status == 0);
        summaries.push_back(run.summary("camera"));
    }
    CHECK(differing_pixels(pfm_of(one, free_camera, "camera"), pfm_of(three, free_camera, "camera"),
                           false) == 0);
    for (const char* counter : {"samples", "skipped", "gradients", "terminated"}) {
        CAPTURE(counter);
        CHECK(summaries[0].at(counter) == summaries[1].at(counter));
    }
}

TEST_CASE("free camera: leaping over empty bricks never changes the picture") {
    // Leaping leaves out only samples that would have been transparent: the picture is the
    // same bit for bit, and every sample leapt is one --no-leaping visits and skips.
    const TempFolder folder("free_camera_leaping");
    const std::vector<std::vector<std::string>> cameras = {
        {"--size", "128x128", "--zoom", "0.25"},                        // the default oblique
        {"--azimuth", "-47", "--elevation", "63", "--size", "96x80", "--zoom", "0.4",
         "--step", "0.7"},                                              // oblique, odd step
        {"--azimuth", "200", "--elevation", "-35", "--projection", "perspective", "--size",
         "96x96", "--zoom", "1.5", "--fov", "50"},                      // perspective
        {"--azimuth", "75", "--elevation", "10", "--projection", "perspective", "--size",
         "64x64", "--zoom", "6", "--fov", "90", "--unlit", "--ert", "0"},  // eye inside
        {"--azimuth", "180", "--elevation", "90", "--size", "128x128", "--zoom", "0.5",
         "--skin-opacity", "0"},                                        // along k, bone only
    };
    const std::vector<std::string>& phantom = ctlab_test::phantom_flags();
    for (const std::vector<std::string>& camera : cameras) {
        CAPTURE(camera.size());
        CAPTURE(camera[1]);
        std::vector<std::string> no_leaping = camera;
        no_leaping.push_back("--no-leaping");
        const RunResult plain = render(free_camera, phantom, no_leaping, folder);
        const Image every_sample = pfm_of(folder, free_camera, "camera");
        const RunResult leaping = render(free_camera, phantom, camera, folder);
        const Image leapt = pfm_of(folder, free_camera, "camera");
        CHECK(differing_pixels(leapt, every_sample, false) == 0);
        const Summary with = leaping.summary("camera"), without = plain.summary("camera");
        CHECK(summary_count(without, "leapt") == 0);
        CHECK(summary_count(with, "leapt") > 0);
        CHECK(summary_count(with, "samples") + summary_count(with, "leapt") ==
              summary_count(without, "samples"));
        CHECK(summary_count(with, "skipped") + summary_count(with, "leapt") ==
              summary_count(without, "skipped"));
        for (const char* counter : {"gradients", "terminated"}) {
            CAPTURE(counter);
            CHECK(with.at(counter) == without.at(counter));
        }
    }
}

// The re-cut of part 2: step 14 (the slab method, nearest samples) is step 15 with
// --interpolation nearest, and
// step 15 is step 25 with --no-leaping, bit for bit, with the same work where they read the
// same samples: each step adds its one idea without touching the picture of the one before.
TEST_CASE("free camera: step 14 is step 15's nearest picture, step 15 is step 25's unleapt") {
    const std::vector<std::string>& phantom = ctlab_test::phantom_flags();
    const std::vector<std::string> small = {"--size", "160x128", "--azimuth", "40"};
    auto with = [&](std::vector<std::string> flags) {
        flags.insert(flags.begin(), small.begin(), small.end());
        return flags;
    };
    TempFolder ten("recut10"), eleven_nearest("recut11n"), eleven("recut11"), twelve("recut12");
    const RunResult a = render("14_slab_method", phantom, with({}), ten);
    const RunResult b = render("15_trilinear", phantom, with({"--interpolation", "nearest"}),
                               eleven_nearest);
    const RunResult c = render("15_trilinear", phantom, with({}), eleven);
    const RunResult d = render(free_camera, phantom, with({"--no-leaping"}), twelve);
    CHECK(differing_pixels(pfm_of(ten, "14_slab_method", "camera"),
                           pfm_of(eleven_nearest, "15_trilinear", "camera"), false) == 0);
    CHECK(differing_pixels(pfm_of(eleven, "15_trilinear", "camera"),
                           pfm_of(twelve, free_camera, "camera"), false) == 0);
    for (const char* counter : {"samples", "skipped", "gradients", "terminated"}) {
        CAPTURE(counter);
        const auto count = [&](const RunResult& run) {
            return summary_count(run.summary("camera"), counter);
        };
        CHECK(count(a) == count(b));
        CHECK(count(c) == count(d));
    }
    CHECK(summary_count(a.summary("camera"), "samples") > 0);
}

// Step 13 tests every sample for being in the box, at whole steps from the box's centre; step
// 14 walks from the box's entry to its exit. Looking straight down with part 1's top-view
// settings both sample the voxel centres, so the pictures and the work are the same, bit for
// bit; from the default camera the samples lie elsewhere along the rays, and the pictures
// differ by a few nearest-voxel staircases only.
TEST_CASE("free camera: step 13's test per sample is step 14's slab method along an axis") {
    const std::vector<std::string>& phantom = ctlab_test::phantom_flags();
    const std::vector<std::string> above = {"--azimuth", "180", "--elevation", "90", "--size",
                                            "128x128", "--step", "2", "--zoom", "0.5"};
    TempFolder ten("camera10"), eleven("camera11");
    const RunResult a = render("13_free_camera", phantom, above, ten);
    const RunResult b = render("14_slab_method", phantom, above, eleven);
    CHECK(differing_pixels(pfm_of(ten, "13_free_camera", "camera"),
                           pfm_of(eleven, "14_slab_method", "camera"), false) == 0);
    for (const char* counter : {"samples", "skipped", "gradients", "terminated"}) {
        CAPTURE(counter);
        CHECK(summary_count(a.summary("camera"), counter) ==
              summary_count(b.summary("camera"), counter));
    }
    CHECK(summary_count(a.summary("camera"), "samples") > 0);
}

// Step 12 samples part 1's rays at whole steps from the box's centre. Along k on the phantom
// (spacing 2, 113 slices: the centre is slice 56), --step 2 puts every sample on a slice, where
// step 10's linear samples read that slice too: the same picture and the same work, bit for
// bit. At --step 1 every other sample lies between two slices: step 12 reads the nearer one (a
// half rounds up), step 10 interpolates, and the pictures differ.
TEST_CASE("physical rays: step 12's top view at step 2 is step 10's, bit for bit") {
    const std::string step12 = "12_physical_rays";
    const std::vector<std::string>& phantom = ctlab_test::phantom_flags();
    for (const char* step : {"2", "1"}) {
        CAPTURE(step);
        TempFolder ten("rays10"), twelve("rays12");
        const RunResult a = render(part1, phantom, {"--view", "top", "--step", step}, ten);
        const RunResult b = render(step12, phantom, {"--view", "top", "--step", step}, twelve);
        const int differing = differing_pixels(pfm_of(ten, part1, "top"),
                                               pfm_of(twelve, step12, "top"), false);
        if (std::string(step) == "2") {
            CHECK(differing == 0);
            for (const char* counter : {"samples", "skipped", "gradients", "terminated"}) {
                CAPTURE(counter);
                CHECK(summary_count(a.summary("top"), counter) ==
                      summary_count(b.summary("top"), counter));
            }
        } else {
            CHECK(differing > 0);
        }
    }
}
