// test_part3.cpp: part 3's speed tricks change the time, not the picture. Every part-3 ray
// caster after the first renders the bench's four cases (handouts/30_speed_baseline.md) on
// the phantom at a small size, and each picture is compared with step 30's, pixel by pixel,
// within the tolerance data/reference/manifest.txt states for part 3. Every sample a trick
// does not read it counts as leapt: samples + leapt is step 30's samples. Steps 35 on (object
// order, then shear-warp and its tricks) sample on the slices instead of along the rays: along
// an axis at one pixel per voxel each renders step 30's pictures within the same tolerance
// (lit, from step 41 on, within the quantised normals' own), steps 37 and 38 step 36's bit for
// bit and step 42 on step 41's; at an angle within the mean and RMS error the manifest states
// (steps 35 and 36 hand an angle to step 30's rays: step 30's picture and counters exactly;
// step 37's, nearest samples, is step 38's with --interpolation nearest bit for bit). And each
// trick's handout quotes its measured gain in a block that make gain fills.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <atomic>
#include <chrono>
#include <sstream>
#include <thread>
#include "common/camera_flags.h"
#include "common/object_order.h"  // step 47's given bit helpers
#include "common/phantom.h"       // make_phantom_sized(): rows that are not whole words
#include "harness.h"

using namespace ctlab_test;

namespace {

constexpr const char* first_part3_step = "30_speed_baseline";
// The first step that takes slices (the maximum only; step 36 composites them): it and every
// part-3 step after it are not ray casters (see the top); the steps before the first that
// turns freely hand a view at an angle to step 30's rays. The shear, the first to turn freely
// (nearest samples: each slice shifted by whole voxels); the first shear-warp step (bilinear
// samples); from the quantised normals' step on, a lit picture rounds its normals.
constexpr const char* first_slice_step = "35_object_order_mip";  // the maximum only
constexpr const char* object_order_step = "36_object_order";
constexpr const char* shear_step = "37_shear";
constexpr const char* shear_warp_step = "38_shear_warp";
constexpr const char* first_turning_step = "37";
constexpr const char* quantised_normals_step = "41_quantised_normals";
// After it the normal indices are kept (step 42), then read from packed records instead of
// the volume (43 on): the same normals and samples, step 41's pictures bit for bit.
// The manifest's tol=2 for part 3, in 8-bit units, as a float channel difference.
constexpr double tolerance = 2.0 / 255;
// The manifest's bounds for shear-warp at an angle: the mean and the RMS channel error, 8-bit.
constexpr double shear_warp_mean = 3.0 / 255, shear_warp_rms = 12.0 / 255;
// The manifest's tol=5 for the lit pictures along an axis from step 41 on: its normals are
// rounded to a fixed set of directions (quantised normals, shaded through a table).
constexpr double shear_warp_lit_tolerance = 5.0 / 255;

// The part-3 steps after the first: 31_... on (part 3 is every step from 30 up).
std::vector<std::string> trick_steps() {
    std::vector<std::string> tricks;
    for (const std::string& name : step_names()) {
        if (name > first_part3_step) tricks.push_back(name);
    }
    return tricks;
}

// The ray casters among them: those before object order.
std::vector<std::string> ray_casting_tricks() {
    std::vector<std::string> tricks;
    for (const std::string& name : trick_steps()) {
        if (name < first_slice_step) tricks.push_back(name);
    }
    return tricks;
}

// Object order and the steps after it: the slices composited.
std::vector<std::string> slice_steps() {
    std::vector<std::string> steps;
    for (const std::string& name : trick_steps()) {
        if (name >= first_slice_step) steps.push_back(name);
    }
    return steps;
}

// The phantom at spacing 1,1,1 (as --volume phantom --spacing 1,1,1): its voxels painted once
// in this process and loaded from a raw file (harness.h), not painted by every run.
std::vector<std::string> isotropic_phantom() {
    std::vector<std::string> flags = phantom_flags();  // ... --spacing 1,1,2, the last
    REQUIRE(flags.size() >= 2);
    REQUIRE(flags[flags.size() - 2] == "--spacing");
    flags.back() = "1,1,1";
    return flags;
}

// The bench's cases at test size: the top view at 64x64 (a quarter of 256, so zoom 1/4), the
// oblique view at 96x96 with the sphere filling it (zoom 1.356 at 512 pixels, scaled).
struct Case {
    const char* name;
    std::vector<std::string> flags;
};
const std::vector<Case>& cases() {
    static const std::vector<Case> all = [] {
        const std::vector<std::string> top = {"--azimuth", "180", "--elevation", "90",
                                              "--size",    "64x64", "--zoom", "0.25"};
        auto with = [](std::vector<std::string> flags, std::vector<std::string> more) {
            flags.insert(flags.end(), more.begin(), more.end());
            return flags;
        };
        const std::vector<std::string> phantom = isotropic_phantom();
        return std::vector<Case>{
            {"a composite unlit, top", with(with(phantom, top), {"--unlit"})},
            {"b composite lit, top", with(phantom, top)},
            {"c composite unlit, oblique",
             with(phantom, {"--unlit", "--azimuth", "30", "--elevation", "20", "--size",
                            "96x96", "--zoom", std::to_string(1.356 * 96 / 512)})},
            {"d maximum intensity, top", with(with(phantom, top), {"--mode", "mip"})},
        };
    }();
    return all;
}

double largest_difference(const ctlab::Image& a, const ctlab::Image& b) {
    double largest = 0;
    for (int y = 0; y < a.height; ++y) {
        for (int x = 0; x < a.width; ++x) {
            const ctlab::Rgb p = a.at(x, y), q = b.at(x, y);
            largest = std::max({largest, double(std::fabs(p.r - q.r)),
                                double(std::fabs(p.g - q.g)), double(std::fabs(p.b - q.b))});
        }
    }
    return largest;
}

// The mean and the RMS of the channel differences, over every channel of every pixel.
void mean_and_rms(const ctlab::Image& a, const ctlab::Image& b, double* mean, double* rms) {
    double sum = 0, squares = 0;
    for (size_t n = 0; n < a.pixels.size(); ++n) {
        const ctlab::Rgb p = a.pixels[n], q = b.pixels[n];
        for (const double d : {double(p.r) - q.r, double(p.g) - q.g, double(p.b) - q.b}) {
            sum += std::fabs(d);
            squares += d * d;
        }
    }
    const double count = 3.0 * a.pixels.size();
    *mean = sum / count;
    *rms = std::sqrt(squares / count);
}

std::string read_text(const std::string& path) {
    std::ifstream in(path);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

}  // namespace

TEST_CASE("part 3: every trick renders step 30's pictures of the four bench cases") {
    const std::vector<std::string> tricks = ray_casting_tricks();
    REQUIRE_MESSAGE(!tricks.empty(), "no part-3 step after " << first_part3_step);
    for (const Case& c : cases()) {
        const StepRender plain = render(first_part3_step, c.flags);
        const ctlab::Image& expected = plain.image("camera");
        const unsigned long long plain_samples =
            ctlab::summary_count(plain.summary("camera"), "samples");
        REQUIRE(plain_samples > 0);
        // The picture is not empty: the comparison below would pass on two black images.
        double brightest = 0;
        for (const ctlab::Rgb& p : expected.pixels) brightest = std::max(brightest, double(p.r));
        CHECK_MESSAGE(brightest > 0.2, c.name << ": step 30 rendered a dark picture");
        for (const std::string& step : tricks) {
            INFO(step << ", case " << c.name);
            const StepRender fast = render(step, c.flags);
            const ctlab::Image& image = fast.image("camera");
            REQUIRE(image.width == expected.width);
            REQUIRE(image.height == expected.height);
            CHECK(largest_difference(image, expected) <= tolerance);
            // Work left out is counted: every sample step 30 read is read or leapt here.
            const ctlab::Summary& summary = fast.summary("camera");
            CHECK(ctlab::summary_count(summary, "samples") +
                      ctlab::summary_count(summary, "leapt") ==
                  plain_samples);
        }
    }
}

TEST_CASE("part 3: the slice steps render step 30's pictures within the manifest's bounds") {
    const std::vector<std::string> steps = slice_steps();
    REQUIRE(!steps.empty());
    REQUIRE(steps.front() == first_slice_step);
    const std::vector<std::string> phantom = isotropic_phantom();
    auto with = [](std::vector<std::string> flags, std::vector<std::string> more) {
        flags.insert(flags.end(), more.begin(), more.end());
        return flags;
    };
    // Along an axis at one pixel per voxel every sample and every pixel lies on a voxel
    // column: the bench's cases a, b and d (the middle 96x96 of the top view). Unlit and the
    // maximum are step 30's floats; lit, the normals' rounding is the difference.
    const std::vector<std::string> top = with(phantom, {"--azimuth", "180", "--elevation", "90",
                                                        "--size", "96x96", "--zoom", "1"});
    for (const std::vector<std::string>& flags :
         {with(top, {"--unlit"}), top, with(top, {"--mode", "mip"})}) {
        const StepRender plain = render(first_part3_step, flags);
        ctlab::Image object_order;  // step 36's: shear-warp's along an axis, bit for bit
        ctlab::Image quantised;     // step 41's: the later steps', bit for bit
        for (const std::string& step : steps) {
            const StepRender fast = render(step, flags);
            INFO(step << " " << flags.back());
            if (step == object_order_step) object_order = fast.image("camera");
            if (step == shear_step || step == shear_warp_step) {
                CHECK(largest_difference(fast.image("camera"), object_order) == 0);
            }
            if (step == quantised_normals_step) quantised = fast.image("camera");
            if (step > quantised_normals_step) {
                REQUIRE(!quantised.pixels.empty());
                CHECK(largest_difference(fast.image("camera"), quantised) == 0);
            }
            const bool lit = flags.back() == "1";  // `top` alone ends with --zoom 1
            const bool rounded = lit && step >= quantised_normals_step;
            CHECK(largest_difference(fast.image("camera"), plain.image("camera")) <=
                  (rounded ? shear_warp_lit_tolerance : tolerance));
            // Every cell is read or left out once per slice, whatever the image's size (this
            // crop reads the whole volume's cells: the cost follows the volume).
            const ctlab::Summary& summary = fast.summary("camera");
            CHECK(ctlab::summary_count(summary, "samples") > 0);
            CHECK(ctlab::summary_count(summary, "samples") +
                      ctlab::summary_count(summary, "leapt") <=
                  uint64_t(ctlab::cthead_nx) * ctlab::cthead_ny * ctlab::cthead_nz);
        }
    }
    // At an angle (case c at test size, and 45 degrees along two axes, lit and unlit; and the
    // maximum at case c's angle: make check's maximum is from above only, where every slice's
    // shift is 0, so a mip_row() that forgets the shift passed it): samples on the slices,
    // bilinear in them, and a warp. The mean and the RMS are bounded; the largest error is
    // not (the head rest's thin film, seen between slices by step 30).
    for (const std::vector<std::string>& angle :
         {std::vector<std::string>{"--unlit", "--azimuth", "30", "--elevation", "20"},
          std::vector<std::string>{"--azimuth", "45", "--elevation", "45"},
          std::vector<std::string>{"--mode", "mip", "--azimuth", "30", "--elevation", "20"}}) {
        const std::vector<std::string> flags =
            with(with(phantom, angle), {"--size", "96x96", "--zoom",
                                        std::to_string(1.356 * 96 / 512)});
        const StepRender plain = render(first_part3_step, flags);
        const ctlab::Image& expected = plain.image("camera");
        ctlab::Image first;  // step 38's: the steps before the quantised normals render it
        ctlab::Image quantised;  // step 41's: the later steps render it
        for (const std::string& step : steps) {
            const StepRender turned = render(step, flags);
            const ctlab::Image& image = turned.image("camera");
            if (step < first_turning_step) {
                INFO(step << ": an angle is step 30's rays (by_rays()): its picture and counters");
                CHECK(largest_difference(image, expected) == 0);
                for (const char* counter : {"samples", "skipped", "gradients", "terminated"}) {
                    CHECK(ctlab::summary_count(turned.summary("camera"), counter) ==
                          ctlab::summary_count(plain.summary("camera"), counter));
                }
                continue;
            }
            if (step == shear_step) {
                INFO("step 38 with --interpolation nearest renders step 37's picture bit for bit");
                const ctlab::Image nearest =
                    render(shear_warp_step, with(flags, {"--interpolation", "nearest"}))
                        .image("camera");
                CHECK(largest_difference(image, nearest) == 0);
            }
            if (step == shear_warp_step) first = image;
            if (step == quantised_normals_step) quantised = image;
            if (step > quantised_normals_step) {
                INFO(step << ": step 41's picture, bit for bit (the same normals and samples)");
                REQUIRE(!quantised.pixels.empty());
                CHECK(largest_difference(image, quantised) == 0);
            }
            if (step > shear_warp_step && step < quantised_normals_step) {
                INFO(step << ": step 38's picture, bit for bit (the same samples composited)");
                CHECK(largest_difference(image, first) == 0);
            }
            REQUIRE(image.width == expected.width);
            REQUIRE(image.height == expected.height);
            double mean = 0, rms = 0;
            mean_and_rms(image, expected, &mean, &rms);
            INFO(step << " " << angle[angle.size() - 3] << " " << angle.back() << ": mean "
                      << mean * 255 << ", RMS " << rms * 255 << " (8-bit units)");
            CHECK(mean <= shear_warp_mean);
            CHECK(rms <= shear_warp_rms);
            CHECK(mean > 0);  // not step 30's picture itself: the bounds are what it costs
        }
    }
}

// A shear-warp is orthographic: a perspective camera is handed to step 30's rays, kept
// verbatim. Its picture, counters and trace are step 30's, to the bit (lit composite with a
// traced pixel, and the maximum), at --step 0.75 (the rays' spacing, which the slices ignore).
static void perspective_by_rays(const std::string& last) {
    std::vector<std::string> camera = {"--projection", "perspective", "--azimuth", "200",
                                       "--elevation", "-25", "--fov", "40", "--zoom", "1.3",
                                       "--size", "48x40", "--step", "0.75"};
    const std::vector<std::string> phantom = phantom_flags();
    camera.insert(camera.begin(), phantom.begin(), phantom.end());
    auto with = [&](std::vector<std::string> more) {
        more.insert(more.begin(), camera.begin(), camera.end());
        return more;
    };
    for (const std::vector<std::string>& flags :
         {with({"--debug-pixel", "24,21"}), with({"--mode", "mip"})}) {
        INFO(last << " " << flags.back());
        const StepRender plain = render(first_part3_step, flags);
        const StepRender slices = render(last, flags);
        const ctlab::Image& expected = plain.image("camera");
        double brightest = 0;  // not two empty pictures
        for (const ctlab::Rgb& p : expected.pixels) brightest = std::max(brightest, double(p.g));
        CHECK(brightest > 0.2);
        REQUIRE(slices.image("camera").pixels.size() == expected.pixels.size());
        CHECK(largest_difference(slices.image("camera"), expected) == 0);
        for (const char* counter : {"samples", "skipped", "leapt", "gradients", "terminated"}) {
            INFO(counter);
            CHECK(ctlab::summary_count(slices.summary("camera"), counter) ==
                  ctlab::summary_count(plain.summary("camera"), counter));
        }
        CHECK(ctlab::summary_count(plain.summary("camera"), "samples") > 0);
        REQUIRE(plain.run.traces.size() == slices.run.traces.size());
        for (size_t n = 0; n < plain.run.traces.size(); ++n) {
            const ctlab::PixelTrace &a = plain.run.traces[n], &b = slices.run.traces[n];
            CHECK(a.complete);
            CHECK(a.samples > 0);
            CHECK(b.lines == a.lines);
            CHECK(b.samples == a.samples);
            CHECK(b.png[0] == a.png[0]);
            CHECK(b.png[1] == a.png[1]);
            CHECK(b.png[2] == a.png[2]);
        }
    }
}

TEST_CASE("part 3: the shear and the last slice step render a perspective camera by step 30's "
          "rays") {
    perspective_by_rays(shear_step);  // the first step that turns freely
    perspective_by_rays(slice_steps().back());
}

// A slice step's output pixel is the warp's blend of up to four intermediate pixels, each
// traced: its camera ray missing the box is not the pixel's verdict. Looking along i at
// 256x256, pixel 137,241's ray passes just below the box (its warp point, v = 112.75, lies past
// the last intermediate row's centre), yet the warp blends in intermediate pixel 137,112 at
// weight 0.25: the pixel is not the background, and no line of its trace may say it is.
TEST_CASE("part 3: a slice step's trace never calls a blended pixel the background") {
    std::vector<std::string> flags = phantom_flags();
    for (const char* flag : {"--mode", "mip", "--azimuth", "90", "--elevation", "0", "--size",
                             "256x256", "--debug-pixel", "137,241"}) {
        flags.push_back(flag);
    }
    for (const std::string& step : slice_steps()) {
        INFO(step);
        const StepRender run = render(step, flags);
        REQUIRE(run.run.traces.size() == 1);
        const ctlab::PixelTrace& trace = run.run.traces[0];
        const ctlab::Rgb pixel = run.image("camera").at(137, 241);
        CHECK(pixel.g > 0.1f);  // not the background (black): the blend of its neighbours
        CHECK(trace.png[1] == int(std::lround(pixel.g * 255)));
        bool missed = false;    // the case at hand: the camera ray misses the box
        double weights = 0;     // the intermediate pixels' weights in the warp
        std::string claims;     // every record and printed line that speaks of the background
        for (const ctlab::TraceRecord& record : trace.records) {
            if (record.kind == ctlab::TraceKind::box && record.missed) missed = true;
            if (record.kind == ctlab::TraceKind::note && record.has("weight")) {
                weights += record.number("weight", 0);
            }
            if (record.text.find("background") != std::string::npos) claims += record.text + "\n";
        }
        for (const std::string& line : trace.lines) {
            if (line.find("background") != std::string::npos) claims += line + "\n";
        }
        CHECK(missed);
        CHECK(weights == doctest::Approx(0.25));  // 137,112 and 138,112 (the others lie outside)
        CHECK(!trace.records.empty());
        CHECK(claims == "");
    }
}

// From step 39 on the rows read only the cells in their runs; a traced pixel's cells outside
// them are leaps ("outside the runs: N cells never read"), not samples. The pixel and the
// samples that give it colour are step 38's; each cell step 38 reads is read or leapt here.
// Looking along j at 64x64 (a quarter of the default run), pixel 32,29's four intermediate
// pixels cross the face: air and soft tissue outside the runs, then skin and bone.
TEST_CASE("part 3: from the runs on, a traced pixel's cells outside them are leapt, not read") {
    std::vector<std::string> flags = phantom_flags();
    for (const char* flag : {"--size", "64x64", "--debug-pixel", "32,29", "--trace-only",
                             "--no-ray-picture"}) {
        flags.push_back(flag);
    }
    auto run = [&](const std::string& step) {
        ctlab::TempFolder out("part3_runs_trace");
        std::vector<std::string> with = flags;
        with.insert(with.end(), {"--out", out.path()});
        const ctlab::RunResult result = ctlab::run_step(step, with);
        REQUIRE(result.status == 0);
        REQUIRE(result.traces.size() == 1);
        return result.traces[0];
    };
    // The records that give the pixel its colour (samples with rgba=), in order.
    auto coloured = [](const ctlab::PixelTrace& trace) {
        std::vector<std::string> lines;
        for (const ctlab::TraceRecord& record : trace.records) {
            if (record.kind == ctlab::TraceKind::sample && record.has("rgba.a")) {
                lines.push_back(record.text);
            }
        }
        return lines;
    };
    const ctlab::PixelTrace every_cell = run(shear_warp_step);
    REQUIRE(every_cell.complete);
    REQUIRE(!coloured(every_cell).empty());
    for (const std::string& step : slice_steps()) {
        if (step <= shear_warp_step) continue;
        INFO(step);
        const ctlab::PixelTrace trace = run(step);
        REQUIRE(trace.complete);
        double leapt = 0;
        int leaps = 0;
        for (const ctlab::TraceRecord& record : trace.records) {
            if (record.kind != ctlab::TraceKind::leap) continue;
            ++leaps;
            leapt += record.number("leapt", 0);
            CHECK(record.text.find("outside the runs") != std::string::npos);
            CHECK(record.number("t_end", 0) >= record.number("t", 0));
        }
        CHECK(leaps >= 4);  // each intermediate pixel crosses air before the face
        CHECK(trace.samples + leapt == every_cell.samples);
        CHECK(trace.samples < every_cell.samples / 2);
        if (step < quantised_normals_step) {  // its light is its own from step 41 on
            CHECK(coloured(trace) == coloured(every_cell));
            for (int c = 0; c < 3; ++c) CHECK(trace.png[c] == every_cell.png[c]);
        }
    }
}

// Step 41's lit samples are four table reads: its trace notes each one's corners' normal
// indices and their light in the table just before the sample, and the sample's L is their
// blend (between the lowest and the highest of the four; along an axis the four corners are
// one voxel, and L is its light).
TEST_CASE("part 3: step 41 traces a lit sample's corners' normal indices and their light") {
    for (const char* angle : {"oblique", "along k"}) {
        INFO(angle);
        std::vector<std::string> flags = phantom_flags();
        flags.insert(flags.end(), {"--size", "64x64", "--debug-pixel", "32,29", "--trace-only",
                                   "--no-ray-picture"});
        if (std::string(angle) == "along k") {
            flags.insert(flags.end(), {"--azimuth", "180", "--elevation", "90", "--debug-pixel",
                                       "25,32"});
        }
        ctlab::TempFolder out("part3_normals_trace");
        flags.insert(flags.end(), {"--out", out.path()});
        const ctlab::RunResult result = ctlab::run_step(quantised_normals_step, flags);
        REQUIRE(result.status == 0);
        REQUIRE(!result.traces.empty());
        const std::vector<ctlab::TraceRecord>& records = result.traces.back().records;
        int lit = 0;
        for (size_t n = 1; n < records.size(); ++n) {
            if (records[n].kind != ctlab::TraceKind::sample || !records[n].has("L")) continue;
            ++lit;
            const ctlab::TraceRecord& note = records[n - 1];
            REQUIRE(note.kind == ctlab::TraceKind::note);
            REQUIRE(note.has("index.3"));
            double lowest = 1, highest = 0;
            for (int c = 0; c < 4; ++c) {
                const std::string corner = std::to_string(c);
                const double index = note.number("index." + corner, -1);
                CHECK(index >= 0);
                CHECK(index <= 129 * 129);
                const double light = note.number("light." + corner, -1);
                lowest = std::min(lowest, light);
                highest = std::max(highest, light);
            }
            CHECK(lowest >= 0.1 - 1e-6);  // at least the ambient
            const double blended = records[n].number("L", -1);
            CHECK(blended >= lowest - 1e-6);
            CHECK(blended <= highest + 1e-6);
            if (std::string(angle) == "along k") {
                CHECK(note.number("index.1", -1) == note.number("index.0", -2));
                CHECK(blended == doctest::Approx(note.number("light.0", -1)).epsilon(1e-6));
            }
        }
        CHECK(lit >= 3);
    }
}

// An object-order step's scene_for() remakes what a view's pixels share in the step's own
// variables (the slices' shifts, the table for their spacing, the runs), and its one-pixel
// path reads them: a ray picture casts its pixels on several threads (--trace-only), which
// corrupted the heap now and then (steps 38 and 40: 3 of 40 probe runs aborted). The wiring
// takes one output pixel at a time, from scene_for() to the pixel.
TEST_CASE("part 3: the slices' one-pixel path takes one pixel at a time on any thread") {
    struct Shear {
        int c = 2;
        double spacing = 1;
    };
    std::atomic<int> inside{0}, most{0};
    auto scene_for = [&](int, const Shear&) {
        const int now = ++inside;
        for (int seen = most.load(); now > seen && !most.compare_exchange_weak(seen, now);) {
        }
        return now;
    };
    auto pixel = [&](int, int, int, ctlab::Work&, ctlab::Trace*) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));  // overlap, if allowed
        --inside;
        return ctlab::Rgb{};
    };
    ctlab::Renderer rays, renderer;
    ctlab::slices_or_rays(
        renderer, rays, [](const ctlab::View&) { return 0; }, [](int) { return false; },
        [](int) { return Shear{}; }, scene_for,
        [](const ctlab::View&, int, ctlab::Work&) { return ctlab::Image(1, 1); }, pixel);
    std::vector<std::thread> threads;
    for (int n = 0; n < 4; ++n) {
        threads.emplace_back([&renderer, n] {
            ctlab::Work work;
            for (int y = 0; y < 5; ++y) renderer.ray(ctlab::View{}, n, y, work, nullptr);
        });
    }
    for (std::thread& thread : threads) thread.join();
    CHECK(inside == 0);
    CHECK(most == 1);
}

TEST_CASE("part 3: the slice steps refuse --work-map, whose per-ray counts they do not keep") {
    // Their counters are per slice row of the intermediate image; an output pixel blends four
    // intermediate pixels, so a map of per-pixel counts would not sum to the summary line's.
    for (const std::string& step : slice_steps()) {
        INFO(step);
        TempFolder folder("shear_warp_work_map");
        const ctlab::RunResult run =
            ctlab::run_step(step, {"--volume", "phantom", "--out", folder.path(), "--no-window",
                                   "--size", "32x32", "--work-map"});
        CHECK(run.status == 2);
        CHECK(run.summaries.empty());
        CHECK(run.err.find("--work-map") != std::string::npos);
        CHECK(run.err.find("intermediate image") != std::string::npos);
        CHECK(std::count(run.err.begin(), run.err.end(), '\n') == 1);  // one line
        CHECK(std::filesystem::is_empty(folder.path()));  // nothing written
    }
}

// The value of `key` in the "precompute ..." line a slice step prints; "" when it has none.
static std::string precompute_value(const std::string& out, const std::string& key) {
    std::istringstream lines(out);
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("precompute ", 0) != 0) continue;
        const ctlab::Summary values = ctlab::parse_summary(line);
        const auto found = values.find(key);
        return found == values.end() ? "" : found->second;
    }
    return "";
}

TEST_CASE("part 3: steps 46 to 48's cell test, records and normals are their SSE2 copy's") {
    // common/dispatch.h compiles find_runs()'s slice loop (the cell test, pack_slice()'s
    // records) and slice_normals() twice, for SSE2 and AVX2, and the processor picks;
    // CTLAB_VECTORS=sse2 forces the SSE2 copy, the one a processor without AVX2 runs.
    // Neither uses FMA, so the pictures, counters and precomputation must be the same, to the
    // bit: lit and unlit (the runs and records without normals), along an axis (contiguous
    // rows) and at an angle. (On a processor without AVX2 both runs take the SSE2 copy, and
    // this compares it with itself.) Step 47 reads its runs off bits (mask_bits()); step 48
    // writes a lit composite's normal indices beside the records, sixteen at a time.
    const std::vector<std::string> oblique = {"--azimuth", "30", "--elevation", "20",
                                              "--size",    "96x96"};
    std::vector<std::vector<std::string>> runs = {cases()[1].flags, phantom_flags(),
                                                  cases()[0].flags, cases()[2].flags};
    runs[1].insert(runs[1].end(), oblique.begin(), oblique.end());  // spacing 1,1,2
    for (const char* step : {"46_vector_normals", "47_bit_runs", "48_split_records"})
    for (const std::vector<std::string>& flags : runs) {
        INFO(step);
        const bool lit = std::find(flags.begin(), flags.end(), "--unlit") == flags.end();
        INFO((lit ? "lit" : "unlit"));
        const StepRender chosen = render(step, flags);
        REQUIRE(setenv("CTLAB_VECTORS", "sse2", 1) == 0);
        const StepRender forced = render(step, flags);
        REQUIRE(unsetenv("CTLAB_VECTORS") == 0);
        const ctlab::Image &a = chosen.image("camera"), &b = forced.image("camera");
        REQUIRE(a.pixels.size() == b.pixels.size());
        size_t different = 0;
        for (size_t n = 0; n < a.pixels.size(); ++n) {
            const ctlab::Rgb p = a.pixels[n], q = b.pixels[n];
            different += p.r != q.r || p.g != q.g || p.b != q.b;
        }
        CHECK(different == 0);
        for (const char* key : {"samples", "skipped", "leapt", "gradients", "terminated"}) {
            INFO(key);
            CHECK(ctlab::summary_count(chosen.summary("camera"), key) ==
                  ctlab::summary_count(forced.summary("camera"), key));
        }
        const std::string normals = precompute_value(chosen.run.out, "normal_voxels");
        CHECK((std::stoull(normals) > 0) == lit);  // lit: the indices were computed
        CHECK(normals == precompute_value(forced.run.out, "normal_voxels"));
        CHECK(precompute_value(chosen.run.out, "records") ==
              precompute_value(forced.run.out, "records"));
    }
}

// Step `step` renders step `base`'s pictures and counters, to the bit, from the same runs and
// records (the precomputation's counts), on each view: the phantom's, then the same views of
// `resized`. `check` looks further at the two runs' output.
template <class Check>
static void same_as_base(const char* base, const char* step,
                         const std::vector<std::vector<std::string>>& views,
                         const ctlab::Volume& resized, Check check) {
    for (size_t v = 0; v < 2 * views.size(); ++v) {
        const bool is_resized = v >= views.size();
        const std::vector<std::string>& view = views[v % views.size()];
        std::vector<std::string> flags =
            is_resized ? std::vector<std::string>{} : phantom_flags();
        flags.insert(flags.end(), view.begin(), view.end());
        std::string named = is_resized ? "resized: " : "";  // for a failure's message
        for (const std::string& flag : flags) named += flag + " ";
        INFO(base << " against " << step << ", " << named);
        const StepRender before = is_resized ? render(base, flags, resized) : render(base, flags);
        const StepRender after = is_resized ? render(step, flags, resized) : render(step, flags);
        const ctlab::Image &a = before.image("camera"), &b = after.image("camera");
        REQUIRE(a.pixels.size() == b.pixels.size());
        size_t different = 0;
        for (size_t n = 0; n < a.pixels.size(); ++n) {
            const ctlab::Rgb p = a.pixels[n], q = b.pixels[n];
            different += p.r != q.r || p.g != q.g || p.b != q.b;
        }
        CHECK(different == 0);
        for (const char* key : {"samples", "skipped", "leapt", "gradients", "terminated"}) {
            INFO(key);
            CHECK(ctlab::summary_count(before.summary("camera"), key) ==
                  ctlab::summary_count(after.summary("camera"), key));
        }
        for (const char* key : {"run_cells", "runs", "normal_voxels", "records"}) {
            INFO(key);
            CHECK(!precompute_value(after.run.out, key).empty());
            CHECK(precompute_value(before.run.out, key) == precompute_value(after.run.out, key));
        }
        check(flags, before, after);
    }
}

TEST_CASE("part 3: step 47's runs read off bits are step 46's runs, records and normals") {
    // Step 47 changes how the runs are found (bits, and where they change) and how the voxels
    // a record holds are marked (bits again), not what is found: the same runs, records and
    // normal indices as step 46, so the same pictures and counters, to the bit. Lit and
    // unlit, along k (contiguous rows), along i and j (strided rows, copied), at an angle,
    // a table with three transparent stretches (more than the cell test's two ranges), and
    // the phantom resized.
    const TempFolder folder("bit_runs_tf");
    const std::string three = folder.text_file("three.tf",
                                               "-300 50 constant 1.0 0.79 0.6 0.12 skin\n"
                                               "120 130 constant 0.5 1.0 0.5 0.3\n"
                                               "300 900 constant 1.0 1.0 1.0 0.8 bone\n");
    const std::vector<std::vector<std::string>> views = {
        {"--azimuth", "0", "--elevation", "90", "--size", "96x96"},
        {"--azimuth", "90", "--elevation", "0", "--size", "96x64"},
        {"--azimuth", "0", "--elevation", "0", "--size", "96x64", "--unlit"},
        {"--azimuth", "30", "--elevation", "20", "--size", "96x96", "--unlit"},
        {"--azimuth", "200", "--elevation", "-60", "--size", "80x80", "--tf", three},
        {"--azimuth", "90", "--elevation", "0", "--size", "64x64", "--tf", three}};
    // The phantom resized so that no row is a whole number of words (or of sixteens): 200,
    // 77 and 45 cells, the last word of a row partly past its end.
    const ctlab::Volume odd = ctlab::make_phantom_sized(200, 77, 45);
    same_as_base("46_vector_normals", "47_bit_runs", views, odd,
                 [](const std::vector<std::string>&, const StepRender&, const StepRender&) {});
}

TEST_CASE("part 3: step 48's records and the normal indices beside them are step 47's") {
    // Step 48 moves a lit composite's normal indices out of the records into an array beside
    // them (record n's at n): the same values and indices, read from two places. A lit sample
    // blends its cell's four corners' light (one voxel's along an axis), so a value or an index
    // written or read at the wrong place changes the picture; with --ert 0 and the skin's
    // opacity lowered the rays go on through every run, and the pictures hold every record
    // the table sees. Lit and unlit, along k, i and j, at an angle, on the phantom and on it
    // resized so that no row is a whole number of words or of the pack's sixteens (step 47's
    // views and these). And the records' memory: 4 bytes a record unlit (step 47's 8), the
    // same 8 lit (the values, and the indices beside them).
    const std::vector<std::vector<std::string>> views = {
        {"--azimuth", "180", "--elevation", "90", "--size", "96x96"},
        {"--azimuth", "180", "--elevation", "90", "--size", "96x96", "--unlit"},
        {"--azimuth", "90", "--elevation", "0", "--size", "96x64", "--ert", "0",
         "--skin-opacity", "0.02"},
        {"--azimuth", "0", "--elevation", "0", "--size", "96x64", "--unlit", "--ert", "0"},
        {"--azimuth", "30", "--elevation", "20", "--size", "96x96", "--ert", "0",
         "--skin-opacity", "0.02"},
        {"--azimuth", "200", "--elevation", "-60", "--size", "80x80", "--unlit"}};
    const ctlab::Volume odd = ctlab::make_phantom_sized(200, 77, 45);
    same_as_base(
        "47_bit_runs", "48_split_records", views, odd,
        [](const std::vector<std::string>& flags, const StepRender& before,
           const StepRender& after) {
            const bool lit = std::find(flags.begin(), flags.end(), "--unlit") == flags.end();
            INFO((lit ? "lit" : "unlit"));
            const unsigned long long records =
                std::stoull(precompute_value(after.run.out, "records"));
            CHECK(records > 0);
            CHECK((std::stoull(precompute_value(after.run.out, "normal_voxels")) > 0) == lit);
            auto megabytes = [records](int bytes) {  // as the precompute line prints them
                char text[32];
                std::snprintf(text, sizeof text, "%.2f", double(records) * bytes / 1048576.0);
                return std::string(text);
            };
            CHECK(precompute_value(before.run.out, "records_mb") == megabytes(8));
            CHECK(precompute_value(after.run.out, "records_mb") == megabytes(lit ? 8 : 4));
        });
}

TEST_CASE("part 3: step 47's given bit helpers: mask_bits() is its plain loop's, the scans") {
    // mask_bits() packs and gathers with SSE2 instructions where there are some; its plain loop
    // (mask_bits_portable()) is what other processors run: the same bits for any masks.
    uint32_t state = 12345;  // a small generator: any masks, including all 0 and all -1
    for (int trial = 0; trial < 2000; ++trial) {
        int16_t sixteen[16], word[64];  // step 46's stretch, step 47's word
        uint64_t expected = 0;
        for (int n = 0; n < 64; ++n) {
            state = state * 1664525u + 1013904223u;
            const bool set = trial == 0 ? false : trial == 1 ? true : (state >> 28) & 1;
            word[n] = set ? int16_t(-1) : int16_t(0);
            if (n < 16) sixteen[n] = word[n];
            expected |= uint64_t(set) << n;
        }
        CHECK(ctlab::mask_bits_portable(sixteen) == (expected & 0xffff));
        CHECK(ctlab::mask_bits(sixteen) == (expected & 0xffff));
        CHECK(ctlab::mask_bits_portable(word) == expected);
        CHECK(ctlab::mask_bits(word) == expected);
    }
    // The scans on known words: bit 0, 63, and a word of alternating bits.
    CHECK(ctlab::first_bit(1) == 0);
    CHECK(ctlab::first_bit(uint64_t(1) << 63) == 63);
    CHECK(ctlab::first_bit(0xa0) == 5);
    CHECK(ctlab::bit_count(0) == 0);
    CHECK(ctlab::bit_count(~uint64_t(0)) == 64);
    CHECK(ctlab::bit_count(0xaaaaaaaaaaaaaaaa) == 32);
    const uint64_t words[2] = {0xf000000000000001, 0x5};  // items 0, 60..63, 64 and 66
    CHECK(ctlab::bit_at(words, 0));
    CHECK(!ctlab::bit_at(words, 1));
    CHECK(ctlab::bit_at(words, 63));
    CHECK(ctlab::bit_at(words, 66));
    CHECK(!ctlab::bit_at(words, 65));
    CHECK(ctlab::sixteen_bits_at(words, 0) == 0x1);
    CHECK(ctlab::sixteen_bits_at(words, 56) == 0x5f0);  // 60..63 then 64, 66: crossing words
    CHECK(ctlab::sixteen_bits_at(words, 64) == 0x5);
}

TEST_CASE("part 3: a camera with a turn_step takes the nearest multiple as the drag adds up") {
    // The window of a step with a turn_step (common/camera_flags.h; no step sets one since
    // steps 35 and 36 hand other angles to step 30's rays): the drag's angles add up freely;
    // the camera takes the nearest multiple of 90 degrees, so it always looks along an axis.
    ctlab::CameraFlags camera;
    camera.azimuth = 180;
    camera.elevation = 90;
    camera.turn_step = 90;
    const ctlab::Orbit orbit = ctlab::camera_orbit(&camera);
    orbit.turn(30, -30);  // 210 (-150 in -180..180): nearest -180; elevation 60: nearest 90
    CHECK(camera.azimuth == -180);
    CHECK(camera.elevation == 90);
    orbit.turn(30, -20);  // -120: nearest -90; elevation 40: nearest 0
    CHECK(camera.azimuth == -90);
    CHECK(camera.elevation == 0);
    orbit.turn(-40, 0);  // -160: nearest -180 again
    CHECK(camera.azimuth == -180);
    // Without a turn_step the drag turns the camera itself, as in part 2.
    ctlab::CameraFlags free_camera;
    free_camera.azimuth = 30;
    ctlab::camera_orbit(&free_camera).turn(15, 0);
    CHECK(free_camera.azimuth == 45);
}

TEST_CASE("part 3: the manifest states the tolerance the comparison uses") {
    const std::string manifest = read_text("data/reference/manifest.txt");
    CHECK(manifest.find("Every later part-3 step renders step 30's pictures within tol=2") !=
          std::string::npos);
    CHECK(manifest.find("at an angle within a mean channel error of 3 and an RMS of 12") !=
          std::string::npos);
    CHECK(manifest.find("lit, within tol=5") != std::string::npos);
}

TEST_CASE("part 3: each trick's handout has its generated gain block") {
    for (const std::string& step : trick_steps()) {
        INFO(step);
        const std::string handout = read_text("handouts/" + step + ".md");
        REQUIRE(!handout.empty());
        const std::string open = "<!-- measured: gain:" + step + " -->";
        const size_t at = handout.find(open);
        REQUIRE_MESSAGE(at != std::string::npos, "no " << open << " block (make gain fills it)");
        const size_t end = handout.find("<!-- end measured -->", at);
        REQUIRE(end != std::string::npos);
        // Filled, not empty: a table with a row per case, and the gain over the step before.
        const std::string block = handout.substr(at, end - at);
        for (const char* row : {"| a ", "| b ", "| c ", "| d "}) {
            CHECK_MESSAGE(block.find(row) != std::string::npos, "the block has no row " << row);
        }
        CHECK(block.find("gain over step") != std::string::npos);
    }
}
