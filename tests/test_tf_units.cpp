// test_tf_units.cpp: transfer-function files and --threshold are in the volume file's own units.
//
// The same head twice: the phantom as int16 CT values, and as float32 values v / 1000 (a
// scale map, map=file=A*v+B with A far from 1). A threshold and a transfer function whose
// numbers are the CT ones divided by 1000 must give the float file the int16 file's picture:
// exactly where the picture depends on the classification only, and to within rounding where
// a lit step's normals come from the (differently quantised) values.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>
#include "common/error.h"
#include "common/phantom.h"
#include "common/transfer_function.h"
#include "common/volume.h"
#include "tools/run_step.h"

using namespace ctlab;

namespace {

constexpr double per_hu = 0.001;  // file units of the float volume per Hounsfield unit

// The classic table (data/tf/classic.tf) with its values divided by 1000.
const char* const classic_in_thousandths =
    "# classic.tf in thousands of Hounsfield units\n"
    "-0.3    0.05   constant  1.0  0.79  0.6  0.12  skin\n"
    " 0.3   32.768  constant  1.0  1.0   1.0  0.8   bone\n";

struct Pair {
    std::vector<std::string> int16_flags, float_flags;
};

// The phantom at a small size as an int16 file and as a float32 file of v / 1000.
Pair write_pair(const TempFolder& folder) {
    const Volume head = make_phantom_sized(48, 48, 24);
    Pair pair;
    pair.int16_flags = write_raw_volume(head, folder.path("head_int16.raw"));
    std::vector<unsigned char> bytes(head.voxel_count() * 4);
    const std::vector<int16_t> values = dense_values(head);  // the file's order, no padding
    for (size_t n = 0; n < values.size(); ++n) {
        const float value = float(values[n] * per_hu);
        std::memcpy(&bytes[4 * n], &value, 4);  // little-endian machines only (as CI's)
    }
    const std::string dims = std::to_string(head.nx) + "," + std::to_string(head.ny) + "," +
                             std::to_string(head.nz);
    char spacing[64];
    std::snprintf(spacing, sizeof spacing, "%g,%g,%g", head.sx, head.sy, head.sz);
    pair.float_flags = {"--volume", folder.file("head_float32.raw", bytes), "--dims", dims,
                        "--type", "float32", "--spacing", spacing};
    return pair;
}

std::vector<std::string> joined(std::vector<std::string> a, const std::vector<std::string>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
}

// The largest difference of any channel of any pixel (images of one size).
double largest_difference(const Image& a, const Image& b) {
    REQUIRE(a.width == b.width);
    REQUIRE(a.height == b.height);
    double largest = 0;
    for (size_t n = 0; n < a.pixels.size(); ++n) {
        largest = std::max({largest, double(std::fabs(a.pixels[n].r - b.pixels[n].r)),
                            double(std::fabs(a.pixels[n].g - b.pixels[n].g)),
                            double(std::fabs(a.pixels[n].b - b.pixels[n].b))});
    }
    return largest;
}

// Runs `step` on both files (the float one with `float_extra`) and compares the views.
void check_same_picture(const std::string& step, const Pair& pair, const TempFolder& folder,
                        const std::vector<std::string>& int16_extra,
                        const std::vector<std::string>& float_extra, double tolerance) {
    CAPTURE(step);
    const std::string out_int = folder.path(step + "_int16");
    const std::string out_float = folder.path(step + "_float");
    const RunResult a = run_step(step, joined(joined(pair.int16_flags, int16_extra),
                                              {"--out", out_int, "--pfm", "--threads", "1"}));
    const RunResult b = run_step(step, joined(joined(pair.float_flags, float_extra),
                                              {"--out", out_float, "--pfm", "--threads", "1"}));
    REQUIRE_MESSAGE(a.status == 0, a.command() << "\n" << a.err);
    REQUIRE_MESSAGE(b.status == 0, b.command() << "\n" << b.err);
    CHECK(b.out.find("map=file=") != std::string::npos);  // a scale map, not the identity
    CHECK(b.out.find("map=file=1*v") == std::string::npos);
    // The conversion is said in one line (the float run's TF; CT runs print none).
    const auto tf_flag = std::find(float_extra.begin(), float_extra.end(), "--tf");
    if (tf_flag != float_extra.end()) CHECK(b.out.find("units: --tf ") != std::string::npos);
    CHECK(a.out.find("units: ") == std::string::npos);
    REQUIRE(!a.summaries.empty());
    REQUIRE(a.summaries.size() == b.summaries.size());
    for (const Summary& summary : a.summaries) {
        const std::string view = summary.at("view");
        CAPTURE(view);
        const Image int_image = read_pfm(step_output(out_int, step, view, "pfm"));
        const Image float_image = read_pfm(step_output(out_float, step, view, "pfm"));
        const double difference = largest_difference(int_image, float_image);
        CHECK(difference <= tolerance);
        // Not two black pictures: the head is there.
        double brightest = 0;
        for (const Rgb& pixel : int_image.pixels) brightest = std::max(brightest, double(pixel.r));
        CHECK(brightest > 0.2);
    }
}

}  // namespace

TEST_CASE("tf units: a transfer function in the file's units converts through a scale map") {
    // File values v / 1000 on the scale map of a float volume spanning -1.117 .. 2.248.
    ValueMap map;
    map.scale = (2.248 - -1.117) / 65535;
    map.offset = -1.117 + 32768 * map.scale;
    const TransferFunction tf = parse_transfer_function(classic_in_thousandths, "t.tf", map);
    REQUIRE(tf.ranges.size() == 2);
    // FROM -0.3: the volume value a sample of exactly -0.3 was stored as.
    CHECK(tf.ranges[0].from == int(std::round(map.to_volume(-0.3))));
    CHECK(tf.ranges[0].to == int(std::round(map.to_volume(0.05))));
    CHECK(tf.ranges[1].from == int(std::round(map.to_volume(0.3))));
    CHECK(tf.ranges[1].to == ct_value_end);  // 32.768 is far above the top: clamped
    CHECK(tf.ranges[0].file_from == -0.3);
    // The identity keeps CT values and their checks (a decimal is a mistake there).
    CHECK(parse_transfer_function("-300 50 constant 1 1 1 1\n", "t.tf").ranges[0].from == -300);
    CHECK_THROWS_AS(parse_transfer_function(classic_in_thousandths, "t.tf"), InputError);
    // A shift map (uint16 whole numbers, offset 40000): exact, FROM is the first value at or
    // above it.
    ValueMap shift;
    shift.offset = 40000;
    const TransferFunction shifted =
        parse_transfer_function("40300.5 40350 constant 1 1 1 1\n", "t.tf", shift);
    CHECK(shifted.ranges[0].from == 301);
    CHECK(shifted.ranges[0].to == 350);
    // Numbers beyond the volume clamp; a non-number is still refused with its line.
    CHECK(parse_transfer_function("-1e300 1e300 constant 1 1 1 1\n", "t.tf", map).ranges[0].from ==
          lowest_ct_value);
    CHECK_THROWS_WITH_AS(parse_transfer_function("x 1 constant 1 1 1 1\n", "t.tf", map),
                         doctest::Contains("t.tf:1: FROM must be a number"), InputError);
    CHECK_THROWS_WITH_AS(parse_transfer_function("nan 1 constant 1 1 1 1\n", "t.tf", map),
                         doctest::Contains("t.tf:1: FROM must be a finite number"), InputError);
}

TEST_CASE("tf units: a float volume with its threshold and TF in file units looks like int16") {
    const TempFolder folder("tf_units");
    const Pair pair = write_pair(folder);
    const std::string tf = folder.text_file("thousandths.tf", classic_in_thousandths);
    // 02: the threshold only (400 HU = 0.4); the picture depends on the hits alone.
    check_same_picture("02_threshold", pair, folder, {"--threshold", "400"},
                       {"--threshold", "0.4"}, 0.0);
    // 06, 07: classification only (a sample's colour and opacity come from the table).
    check_same_picture("07_back_to_front", pair, folder, {}, {"--tf", tf}, 0.0);
    check_same_picture("08_compositing_order", pair, folder, {}, {"--tf", tf}, 0.0);
    // 08 .. 10: lit, with normals from the gradient of the values, which the float file holds
    // on a finer grid (about 20 volume steps per HU): the same picture to within rounding
    // (measured: at most 0.016 of full scale, on a few edge pixels).
    const double lit_tolerance = 0.03;
    check_same_picture("10_opacity_correction", pair, folder, {}, {"--tf", tf}, lit_tolerance);
    check_same_picture("11_empty_space", pair, folder, {}, {"--tf", tf}, lit_tolerance);
    check_same_picture("25_free_leaping", pair, folder, {}, {"--tf", tf}, lit_tolerance);
}
