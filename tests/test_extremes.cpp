// test_extremes.cpp: every step (part 2's at a small camera picture), every view and every
// path a flag takes it down, on volumes at
// the edges of what a step can be given: one voxel, one voxel thick (1x256x113, 256x1x1), all
// air, all bone, all 32767, all -32768, noise over the whole int16 range, and min = max. Each
// program (run as a process on the volume written to a raw file; the flag variants on the
// int16 extremes and on noise) must exit 0, and its float
// pictures (--pfm) have the view's size and no NaN or infinity; the --debug-pixel trace of
// the first pixel (and of the last, in the default run on noise) must give the picture's value
// (the default runs draw its ray pictures too, each checked written; the flag variants trace
// without them). Under
// `make test SAN=1` the steps are sanitizer builds: this is also the out-of-bounds check of
// every ray loop.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>
#include "harness.h"
#include "view.h"
#include "volume.h"

using namespace ctlab;

namespace {

struct Shape {
    int nx, ny, nz;
};

// The fills; each shape gets each of them.
struct Fill {
    const char* name;
    std::function<int16_t(std::mt19937&)> value;  // the next voxel's value
};

constexpr int16_t air = -1000, bone = 1000;  // CT values of the two materials
constexpr int16_t at_threshold = 400;        // min = max exactly at the surface steps' threshold
constexpr uint32_t noise_seed = 20240611;    // fixed: the same noise on every run

const std::vector<Fill>& fills() {
    static const std::vector<Fill> all = {
        {"air", [](std::mt19937&) { return air; }},
        {"bone", [](std::mt19937&) { return bone; }},
        {"all 32767", [](std::mt19937&) { return int16_t(32767); }},
        {"all -32768", [](std::mt19937&) { return int16_t(-32768); }},
        {"min = max = 400", [](std::mt19937&) { return at_threshold; }},
        {"noise", [](std::mt19937& random) {
             return int16_t(std::uniform_int_distribution<int>(-32768, 32767)(random));
         }},
    };
    return all;
}

Volume make_volume(const Shape& shape, const Fill& fill, double sz) {
    Volume volume;
    volume.nx = shape.nx;
    volume.ny = shape.ny;
    volume.nz = shape.nz;
    volume.sz = sz;
    volume.name = fill.name;
    volume.data.resize(volume.voxel_count());
    std::mt19937 random(noise_seed);
    for (int16_t& value : volume.data) value = fill.value(random);
    update_range(volume);
    return volume;
}

// Flags that take each step down its other paths (and to the ends of its ranges).
std::vector<std::vector<std::string>> variants(const std::string& step) {
    std::vector<std::vector<std::string>> all = {{}};
    if (step.rfind("00", 0) == 0) {
        all.push_back({"--equalise"});
        all.push_back({"--slice", "0"});
    }
    if (step >= "02" && step < "06") {
        all.push_back({"--threshold", "-32768"});
        all.push_back({"--threshold", "32767"});
    }
    if (step >= "04" && step < "06") all.push_back({"--light-angle", "180"});
    const bool projection_modes = step.rfind("18", 0) == 0;  // grey: no transfer function
    if (step >= "06" && !projection_modes) {
        all.push_back({"--skin-opacity", "1"});
        all.push_back({"--tf", "data/tf/transparent.tf"});
    }
    if (step.rfind("08", 0) == 0) {
        all.push_back({"--order", "b2f"});
        all.push_back({"--order", "b2f", "--ert", "0"});
    }
    if (step.rfind("09", 0) == 0) all.push_back({"--unlit", "--light-angle", "-180"});
    if (step.rfind("10", 0) == 0) {
        all.push_back({"--step", "0.25"});
        all.push_back({"--step", "4", "--ert", "0"});
        all.push_back({"--unlit", "--no-correction", "--light-angle", "-180"});
    }
    if (step.rfind("11", 0) == 0) {  // 10 plus leaping: a step that does not divide a brick
        all.push_back({"--step", "0.3"});
        all.push_back({"--no-leaping"});
    }
    // Part 2: the camera from straight above in perspective (rays along k), nearest samples
    // without leaping, the longest step unlit, and each step's own paths.
    // Steps 35 on (object order, shear-warp and its tricks) take one sample per slice (a
    // perspective camera goes to step 30's rays, test_part3); their MIP from below and nearest
    // samples below take their paths. Steps 35 and 36 take slices along an axis only and hand
    // any other view to step 30's rays: one run along an axis, one at an angle.
    const bool shear_warp = step >= "35";
    const bool axes_and_rays = shear_warp && step < "37";
    if (ctlab_test::is_camera_step(step) && !shear_warp) {
        all.push_back({"--projection", "perspective", "--elevation", "90", "--fov", "170"});
        // Steps 13 and 14 read the nearest voxel only (15 on: --interpolation); step 25 leaps (part 3
        // has no --no-leaping).
        std::vector<std::string> nearest = {"--azimuth", "-360"};
        if (step >= "15") nearest.insert(nearest.begin(), {"--interpolation", "nearest"});
        if (step.rfind("25", 0) == 0) nearest.push_back("--no-leaping");
        all.push_back(nearest);
        if (!projection_modes) all.push_back({"--step", "4", "--ert", "0", "--unlit"});
    }
    if (axes_and_rays) {
        all.push_back({"--interpolation", "nearest", "--azimuth", "-360", "--elevation", "-90"});
        all.push_back({"--ert", "0", "--unlit", "--azimuth", "100", "--elevation", "-30"});
    } else if (shear_warp) {
        all.push_back({"--interpolation", "nearest", "--azimuth", "-360", "--elevation", "45"});
        all.push_back({"--ert", "0", "--unlit", "--azimuth", "100", "--elevation", "-30"});
    }
    if (step >= "30") all.push_back({"--mode", "mip", "--elevation", "-90"});  // part 3's MIP
    if (step.rfind("16", 0) == 0) {
        all.push_back({"--jitter", "hash", "--zoom", "0.01"});
        all.push_back({"--jitter", "hash", "--show-jitter"});  // a trace with no ray
    }
    if (step.rfind("17", 0) == 0) {
        // The paths above with the hash's offsets: the default, blue noise, makes its 64x64
        // tile at start-up (0.11 s of CPU a run, measured: more than all the other steps' runs
        // of this test together). The default run on every fill and --jitter blue keep it.
        for (size_t v = 1; v < all.size(); ++v) all[v].insert(all[v].begin(), {"--jitter", "hash"});
        // The hash's own --zoom and --show-jitter runs are step 16's (its --jitter hash is step
        // 13 bit for bit, test_jitter); the tile's --show-jitter is this step's.
        all.push_back({"--jitter", "blue"});
        all.push_back({"--jitter", "blue", "--show-jitter"});  // a trace with no ray
    }
    if (projection_modes) {
        all.push_back({"--mode", "minip", "--slab", "2"});
        all.push_back({"--mode", "average", "--zoom", "100"});
    }
    // Steps 19-21: the iso value at both ends of int16 (no crossing; every ray starts inside);
    // 20 on with the largest --shininess, 21 with clipping planes in both modes.
    if (step >= "19" && step < "22") {
        std::vector<std::string> highest = {"--iso", "32767"}, lowest = {"--iso", "-32768"};
        if (step >= "20") highest.insert(highest.end(), {"--shininess", "1000"});
        if (step >= "21") lowest.insert(lowest.end(), {"--clip", "0,0,1,0"});
        all.push_back(highest);
        all.push_back(lowest);
        if (step >= "21") all.push_back({"--mode", "composite", "--clip", "1,1,1,-1"});
    }
    // Blocked light: each step's own way (the light behind the head), and in step 24, which
    // has them all, occlusion alone and with the light volume.
    if (step >= "22" && step < "24") all.push_back({"--light-angle", "180"});
    if (step.rfind("24", 0) == 0) {
        all.push_back({"--shadows", "none", "--ao", "on"});
        all.push_back({"--shadows", "volume", "--ao", "on", "--light-angle", "180"});
    }
    return all;
}

// Pixels that are NaN, infinite or negative; or above 1 in steps 00-05 (greys in 0..1).
int bad_pixels(const Image& image, bool grey) {
    int bad = 0;
    for (const Rgb& p : image.pixels) {
        for (float channel : {p.r, p.g, p.b}) {
            if (!std::isfinite(channel) || channel < 0 || (grey && channel > 1)) {
                ++bad;
                break;
            }
        }
    }
    return bad;
}

}  // namespace

// The traces of one run: each is complete, of one of the pixels asked for, and agrees with the
// float picture (printed %.6f); every pixel asked for is traced in each view it lies in.
int traces_checked(const ctlab_test::StepRender& run, const std::vector<View>& views,
                   const std::vector<std::pair<int, int>>& pixels) {
    int checked = 0;
    for (const PixelTrace& trace : run.run.traces) {
        CAPTURE(trace.view);
        CAPTURE(trace.x);
        CAPTURE(trace.y);
        CHECK(trace.complete);
        CHECK(std::find(pixels.begin(), pixels.end(), std::make_pair(trace.x, trace.y)) !=
              pixels.end());
        const Rgb& drawn = run.image(trace.view).at(trace.x, trace.y);
        CHECK(std::abs(trace.rgb.r - drawn.r) <= 5e-7f * std::max(1.0f, std::abs(drawn.r)));
        CHECK(std::abs(trace.rgb.g - drawn.g) <= 5e-7f * std::max(1.0f, std::abs(drawn.g)));
        CHECK(std::abs(trace.rgb.b - drawn.b) <= 5e-7f * std::max(1.0f, std::abs(drawn.b)));
        CHECK(trace.lines.size() >= 1);
        ++checked;
    }
    // As many traces as (view, pixel) pairs with the pixel inside the view: none missing.
    int expected = 0;
    for (const View& view : views) {
        for (const auto& [x, y] : pixels) expected += x < view.width && y < view.height;
    }
    CHECK(checked == expected);
    return checked;
}

// Every step, view and variant on the fills of one shape (one test case per shape, so that
// `make test` can run them side by side, tests/run_suite.sh's shards).
void check_extreme_shape(const Shape& shape) {
    int images = 0, traces = 0;
    for (const Fill& fill : fills()) {
        // Spacing 1:1:2 as CThead, so step 10 samples between slices along k.
        const Volume volume = make_volume(shape, fill, 2.0);
        CAPTURE(shape.nx);
        CAPTURE(shape.ny);
        CAPTURE(shape.nz);
        CAPTURE(fill.name);
        // Written once, read by every run on this fill. This folder and each run's (--out)
        // on a memory file system where there is one (harness.h: scratch_parent()).
        const ctlab::TempFolder folder("extremes", ctlab_test::scratch_parent());
        const std::vector<std::string> volume_flags =
            ctlab::write_raw_volume(volume, folder.path("volume.raw"));
        for (const std::string& step : ctlab_test::step_names()) {
            const std::vector<View> views = ctlab_test::default_views(step, volume);
            const std::vector<std::vector<std::string>> all = variants(step);
            for (size_t v = 0; v < all.size(); ++v) {
                // Every fill in the default run; the other paths at the int16 extremes
                // and in noise over the whole range (each run is a process: the count
                // of runs is the time this test takes).
                const std::string name = fill.name;
                if (v > 0 && name != "noise" && name != "all 32767" && name != "all -32768") {
                    continue;
                }
                std::vector<std::string> flags = ctlab_test::size_flags(step);
                flags.insert(flags.end(), all[v].begin(), all[v].end());
                std::string text;
                for (const std::string& flag : flags) text += flag + " ";
                CAPTURE(step);
                CAPTURE(text);
                // The default run on noise traces the last pixel of each view too (each view
                // the pixels that lie inside it): part 2's in that run (one view: its one more
                // ray picture costs about what a process does, and step 17 makes its
                // blue-noise tile, 0.2 s of CPU, once, not twice), part 1's in a run of its
                // own without ray pictures (three views: more pictures than a process costs).
                std::vector<std::pair<int, int>> last_pixels;
                if (v == 0 && std::string(fill.name) == "noise") {
                    for (const View& view : views) {
                        const std::pair<int, int> last = {view.width - 1, view.height - 1};
                        if (last == std::make_pair(0, 0)) continue;  // that is 0,0
                        if (std::find(last_pixels.begin(), last_pixels.end(), last) !=
                            last_pixels.end()) {
                            continue;  // two views of the same size
                        }
                        last_pixels.push_back(last);
                    }
                }
                std::vector<std::string> last_flags;
                for (const auto& [x, y] : last_pixels) {
                    const std::string pixel = std::to_string(x) + "," + std::to_string(y);
                    last_flags.insert(last_flags.end(), {"--debug-pixel", pixel});
                }
                const bool last_here = ctlab_test::is_camera_step(step) && !last_pixels.empty();
                std::vector<std::pair<int, int>> traced = {{0, 0}};
                flags.insert(flags.end(), {"--threads", "2", "--debug-pixel", "0,0"});
                if (last_here) {
                    flags.insert(flags.end(), last_flags.begin(), last_flags.end());
                    traced.insert(traced.end(), last_pixels.begin(), last_pixels.end());
                }
                // The ray pictures are drawn in the default runs (every shape and fill);
                // the variants trace without them (most of a small run's time).
                if (v > 0) flags.push_back("--no-ray-picture");
                flags.insert(flags.begin(), volume_flags.begin(), volume_flags.end());
                const bool grey = step < "06";
                const ctlab::TempFolder out("render", ctlab_test::scratch_parent());
                const ctlab_test::StepRender run = ctlab_test::render_in(out, step, flags);
                REQUIRE(run.images.size() == views.size());
                for (size_t n = 0; n < views.size(); ++n) {
                    CAPTURE(views[n].name);
                    REQUIRE(run.views[n] == views[n].name);
                    const Image& image = run.images[n];
                    ++images;
                    REQUIRE(image.width == views[n].width);
                    REQUIRE(image.height == views[n].height);
                    CHECK(bad_pixels(image, grey) == 0);
                }
                traces += traces_checked(run, views, traced);
                if (v == 0) {  // each trace drew its ray picture (OUT/STEP_VIEW_ray_X_Y.png)
                    for (const PixelTrace& trace : run.run.traces) {
                        const std::string picture = ctlab::step_output(
                            out.path(), step,
                            trace.view + "_ray_" + std::to_string(trace.x) + "_" +
                                std::to_string(trace.y),
                            "png");
                        std::error_code error;  // none: the file is there
                        const auto bytes = std::filesystem::file_size(picture, error);
                        CHECK_MESSAGE((!error && bytes > 0), picture);
                    }
                }
                if (last_pixels.empty() || last_here) continue;
                std::vector<std::string> last_run = ctlab_test::size_flags(step);
                last_run.insert(last_run.end(), volume_flags.begin(), volume_flags.end());
                last_run.push_back("--no-ray-picture");
                last_run.insert(last_run.end(), last_flags.begin(), last_flags.end());
                const ctlab::TempFolder last_out("render", ctlab_test::scratch_parent());
                const ctlab_test::StepRender last =
                    ctlab_test::render_in(last_out, step, last_run);
                traces += traces_checked(last, views, last_pixels);
            }
        }
    }
    MESSAGE("extreme volumes " << shape.nx << "x" << shape.ny << "x" << shape.nz << ": "
                               << images << " pictures and " << traces << " traces checked");
    // Every step's views on every fill at least (the default runs).
    CHECK(images >= int(fills().size() * ctlab_test::step_names().size()));
    CHECK(traces >= images);
}

TEST_CASE("extreme volumes 1x1x1: every step, view and variant: right size, finite, traced") {
    check_extreme_shape({1, 1, 1});
}

TEST_CASE("extreme volumes 1x256x113: every step, view and variant: right size, finite, "
          "traced") {
    check_extreme_shape({1, 256, 113});
}

TEST_CASE("extreme volumes 256x1x1: every step, view and variant: right size, finite, traced") {
    check_extreme_shape({256, 1, 1});
}

TEST_CASE("extreme volumes 7x5x3: every step, view and variant: right size, finite, traced") {
    check_extreme_shape({7, 5, 3});
}

TEST_CASE("extreme volumes: the loaders accept the listed shapes from bytes") {
    // 1x256x113 and 256x1x1 through volume_from_bytes, as --dims would read them.
    for (const Shape& shape : {Shape{1, 256, 113}, Shape{256, 1, 1}, Shape{1, 1, 1}}) {
        RawFormat format;
        format.nx = shape.nx;
        format.ny = shape.ny;
        format.nz = shape.nz;
        format.endian = Endian::big;
        const size_t voxels = size_t(shape.nx) * shape.ny * shape.nz;
        std::vector<unsigned char> bytes(2 * voxels);
        for (size_t n = 0; n < voxels; ++n) {  // value n - 32768 (wrapping), big-endian
            const uint16_t value = uint16_t(n * 257);
            bytes[2 * n] = uint8_t(value >> 8);
            bytes[2 * n + 1] = uint8_t(value & 255);
        }
        const Volume volume = volume_from_bytes(bytes, format, "shape");
        CHECK(volume.voxel_count() == voxels);
        CHECK(volume.at(shape.nx - 1, shape.ny - 1, shape.nz - 1) ==
              int16_t(uint16_t((voxels - 1) * 257)));
        for (const View& view : views_named(volume, "all")) {
            CHECK(view.width * view.height * view.ray_length == int(voxels));
        }
    }
}
