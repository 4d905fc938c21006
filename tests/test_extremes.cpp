// test_extremes.cpp: every step, every view, on the extreme volumes of issue 6: one voxel,
// one voxel thick (1x256x113, 256x1x1), all air, all bone, all 32767, all -32768, noise over
// the whole int16 range, and min = max. The pictures must have the view's size and no NaN or
// infinity; the debug trace of the corner pixels must agree with the picture. Under
// `make test SAN=1` this is also the out-of-bounds check of every ray loop.
#include <doctest/doctest.h>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>
#include "harness.h"
#include "render.h"
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
    if (step >= "06") {
        all.push_back({"--skin-opacity", "1"});
        all.push_back({"--tf", "data/tf/transparent.tf"});
    }
    if (step.rfind("07", 0) == 0) {
        all.push_back({"--order", "b2f"});
        all.push_back({"--order", "both", "--ert", "0"});
    }
    if (step.rfind("08", 0) == 0) {
        all.push_back({"--step", "0.25"});
        all.push_back({"--step", "4", "--ert", "0"});
        all.push_back({"--unlit", "--no-correction", "--light-angle", "-180"});
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

TEST_CASE("extreme volumes: every step, view and variant: right size, finite, traced") {
    const Shape shapes[] = {{1, 1, 1}, {1, 256, 113}, {256, 1, 1}, {7, 5, 3}};
    const ctlab_test::TempFolder out("extremes");  // step 07 --order both writes its diffs
    int images = 0;
    for (const Shape& shape : shapes) {
        for (const Fill& fill : fills()) {
            // Spacing 1:1:2 as CThead, so step 08 samples between slices along k.
            const Volume volume = make_volume(shape, fill, 2.0);
            CAPTURE(shape.nx);
            CAPTURE(shape.ny);
            CAPTURE(shape.nz);
            CAPTURE(fill.name);
            for (const ctlab_test::StepEntry& step : ctlab_test::included_steps()) {
                for (std::vector<std::string> flags : variants(step.name)) {
                    std::string text;
                    for (const std::string& flag : flags) text += flag + " ";
                    CAPTURE(step.name);
                    CAPTURE(text);
                    flags.insert(flags.end(), {"--out", out.path(), "--threads", "2"});
                    const bool grey = step.name < "06";
                    const int status = ctlab_test::run_step(
                        step.name, flags, volume,
                        [&](const Options& options, const Volume& loaded,
                            const Renderer& renderer) {
                            for (const View& view : views_named(loaded, "all")) {
                                CAPTURE(view.name);
                                Work work;
                                const Image image = render_view(options, view, renderer, work);
                                ++images;
                                REQUIRE(image.width == view.width);
                                REQUIRE(image.height == view.height);
                                CHECK(bad_pixels(image, grey) == 0);
                                // The first and last pixel again, with their trace.
                                for (int corner = 0; corner < 2; ++corner) {
                                    const int x = corner ? view.width - 1 : 0;
                                    const int y = corner ? view.height - 1 : 0;
                                    Work ray_work;
                                    Trace trace;
                                    const Rgb pixel = renderer.ray(view, x, y, ray_work, &trace);
                                    if (renderer.image) continue;  // --order both: its own
                                    CHECK(pixel.r == image.at(x, y).r);
                                    CHECK(pixel.g == image.at(x, y).g);
                                    CHECK(pixel.b == image.at(x, y).b);
                                    CHECK(trace.lines().size() >= 1);
                                }
                            }
                        });
                    CHECK(status == 0);
                }
            }
        }
    }
    MESSAGE("extreme volumes: " << images << " pictures checked");
    CHECK(images > 1000);
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
