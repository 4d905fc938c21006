// test_check.cpp: the checker's metrics and heat map (compare.h), and read_image on PNG
// and PPM files, good and bad.
#include <doctest/doctest.h>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <unistd.h>
#include "compare.h"
#include "error.h"
#include "image.h"

using namespace ctlab;
namespace fs = std::filesystem;

namespace {

// A w x h picture with every channel at the 8-bit value `level`.
Image flat(int width, int height, int level) {
    Image image(width, height);
    for (Rgb& pixel : image.pixels) pixel = grey(level / 255.0f);
    return image;
}

// A folder of its own under the system temp folder, removed with everything in it.
struct TempFolder {
    fs::path path;
    TempFolder() {
        path = fs::temp_directory_path() / ("ctlab_test_check_" + std::to_string(getpid()));
        fs::create_directories(path);
    }
    ~TempFolder() {
        std::error_code ignored;
        fs::remove_all(path, ignored);
    }
    std::string file(const std::string& name, const std::string& bytes) const {
        const std::string full = (path / name).string();
        std::ofstream(full, std::ios::binary) << bytes;
        return full;
    }
};

// The InputError message of read_image(path), or "" when it does not throw.
std::string read_error(const std::string& path) {
    try {
        read_image(path);
    } catch (const InputError& error) {
        return error.what();
    }
    return "";
}

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

}  // namespace

TEST_CASE("compare: one channel of one pixel off by 10 in a 2x2 picture") {
    const Image reference = flat(2, 2, 100);
    Image student = reference;
    student.at(1, 0).g = 110 / 255.0f;
    const Comparison c = compare_images(student, reference, 2);
    // 12 channels, one of them 10 off.
    const double rmse = std::sqrt(100.0 / 12);
    CHECK(c.width == 2);
    CHECK(c.height == 2);
    CHECK(c.max_abs == 10);
    CHECK(c.mean_abs == doctest::Approx(10.0 / 12));
    CHECK(c.rmse == doctest::Approx(rmse));
    CHECK(c.psnr_db == doctest::Approx(20 * std::log10(255 / rmse)));  // 38.92 dB
    CHECK(c.over_tol_pct == doctest::Approx(25.0));                     // 1 pixel of 4
    CHECK_FALSE(c.pass);
    CHECK(comparison_line(c) ==
          "max_abs=10 mean_abs=0.8333 rmse=2.8868 psnr_db=38.92 over_tol_pct=25.000 tol=2 "
          "result=fail");
}

TEST_CASE("compare: identical pictures have infinite PSNR and pass at tolerance 0") {
    const Image image = flat(3, 2, 37);
    const Comparison c = compare_images(image, image, 0);
    CHECK(c.max_abs == 0);
    CHECK(c.mean_abs == 0);
    CHECK(c.rmse == 0);
    CHECK(std::isinf(c.psnr_db));
    CHECK(c.over_tol_pct == 0);
    CHECK(c.pass);
    CHECK(format_psnr(c.psnr_db) == "inf");
    CHECK(contains(comparison_line(c), "psnr_db=inf"));
    CHECK(contains(comparison_line(c), "result=pass"));
}

TEST_CASE("compare: an error equal to the tolerance passes, one more fails") {
    const Image reference = flat(4, 1, 200);
    for (int tolerance : {0, 2, 5}) {
        Image at_tolerance = reference, beyond = reference;
        at_tolerance.at(2, 0).b = (200 - tolerance) / 255.0f;
        beyond.at(2, 0).b = (200 - tolerance - 1) / 255.0f;
        CHECK(compare_images(at_tolerance, reference, tolerance).pass);
        const Comparison c = compare_images(beyond, reference, tolerance);
        CHECK_FALSE(c.pass);
        CHECK(c.max_abs == tolerance + 1);
        CHECK(c.over_tol_pct == doctest::Approx(25.0));
    }
    // A fractional tolerance: 2 <= 2.5 passes, 3 > 2.5 fails.
    Image two = reference, three = reference;
    two.at(0, 0).r = 202 / 255.0f;
    three.at(0, 0).r = 203 / 255.0f;
    CHECK(compare_images(two, reference, 2.5).pass);
    CHECK_FALSE(compare_images(three, reference, 2.5).pass);
}

TEST_CASE("compare: differences below half an 8-bit step vanish; out-of-range clamps") {
    const Image reference = flat(2, 1, 128);
    Image student = reference;
    student.at(0, 0).r += 0.4f / 255;  // still rounds to 128
    student.at(1, 0).g = std::numeric_limits<float>::quiet_NaN();  // NaN counts as 0
    Image bright = flat(2, 1, 255);
    bright.at(0, 0) = grey(7.5f);  // clamps to 255
    CHECK(compare_images(bright, flat(2, 1, 255), 0).max_abs == 0);
    const Comparison c = compare_images(student, reference, 0);
    CHECK(c.max_abs == 128);
    CHECK(c.mean_abs == doctest::Approx(128.0 / 6));
}

TEST_CASE("compare: pictures of different sizes are an InputError naming both") {
    const Image a = flat(2, 2, 0), b = flat(3, 2, 0);
    CHECK_THROWS_WITH_AS(compare_images(a, b, 2, "mine.png", "ref.png"),
                         "mine.png is 2x2 but ref.png is 3x2", InputError);
    CHECK_THROWS_AS(diff_heat_map(a, b, 2), InputError);
}

TEST_CASE("heat map: black where equal, blue within the tolerance, white at the largest") {
    const Image reference = flat(3, 1, 50);
    Image student = reference;
    student.at(1, 0).r = 52 / 255.0f;  // 2: at the tolerance
    student.at(2, 0).r = 90 / 255.0f;  // 40: the largest error
    const Image map = diff_heat_map(student, reference, 2, false);
    REQUIRE(map.width == 3);
    REQUIRE(map.height == 1);
    const Rgb equal = map.at(0, 0), within = map.at(1, 0), largest = map.at(2, 0);
    CHECK(equal.r == 0);
    CHECK(equal.g == 0);
    CHECK(equal.b == 0);
    CHECK(within.b > within.r);  // blue
    CHECK(within.b > 0.5f);      // visible
    CHECK(largest.r == doctest::Approx(1));
    CHECK(largest.g == doctest::Approx(1));
    CHECK(largest.b == doctest::Approx(1));
    // The ramp brightens monotonically with the error.
    double previous = -1;
    for (int error = 0; error <= 40; ++error) {
        const Rgb colour = heat_colour(heat_position(error, 2, 40));
        const double luminance = 0.2126 * colour.r + 0.7152 * colour.g + 0.0722 * colour.b;
        CHECK(luminance > previous);
        previous = luminance;
    }
    // With a legend (wide enough pictures) the map grows below and keeps its top rows.
    const Image wide_reference = flat(64, 8, 50);
    Image wide_student = wide_reference;
    wide_student.at(5, 5).g = 0;
    const Image with_legend = diff_heat_map(wide_student, wide_reference, 2);
    CHECK(with_legend.width == 64);
    CHECK(with_legend.height > 8);
    CHECK(with_legend.at(5, 5).r == doctest::Approx(1));
    CHECK(with_legend.at(4, 5).r == 0);
}

TEST_CASE("read_image: a PNG written by write_png reads back exactly at 8 bits") {
    TempFolder folder;
    Image image(5, 3);
    for (int y = 0; y < image.height; ++y) {
        for (int x = 0; x < image.width; ++x) {
            image.at(x, y) = {x / 4.0f, y * 0.37f, (x * 7 + y * 11) % 13 / 12.0f};
        }
    }
    const std::string path = (folder.path / "round_trip.png").string();
    write_png(image, path);
    const Image back = read_image(path);
    REQUIRE(back.width == 5);
    REQUIRE(back.height == 3);
    for (size_t n = 0; n < image.pixels.size(); ++n) {
        CHECK(to_byte(back.pixels[n].r) == to_byte(image.pixels[n].r));
        CHECK(to_byte(back.pixels[n].g) == to_byte(image.pixels[n].g));
        CHECK(to_byte(back.pixels[n].b) == to_byte(image.pixels[n].b));
    }
    CHECK(compare_images(back, image, 0).max_abs == 0);
}

TEST_CASE("read_image: PPM P6 with comments, P3 text and 16-bit samples") {
    TempFolder folder;
    // 2x1: red (255, 0, 0) and (0, 51, 102); comments between the header fields.
    const std::string p6 = folder.file(
        "comments.ppm", std::string("P6\n# made by hand\n2 # width\n1\n#maxval next\n255\n") +
                            std::string("\xff\x00\x00\x00\x33\x66", 6));
    Image image = read_image(p6);
    REQUIRE(image.width == 2);
    REQUIRE(image.height == 1);
    CHECK(image.at(0, 0).r == doctest::Approx(1));
    CHECK(image.at(0, 0).g == 0);
    CHECK(to_byte(image.at(1, 0).g) == 51);
    CHECK(to_byte(image.at(1, 0).b) == 102);

    // The byte after maxval is the single separator: a raster starting with '\n' (10) or
    // '#' (35) is pixel data, not whitespace or a comment.
    const std::string tricky =
        folder.file("tricky.ppm", std::string("P6 1 1 255\n") + "\n#\x01");
    image = read_image(tricky);
    CHECK(to_byte(image.at(0, 0).r) == 10);
    CHECK(to_byte(image.at(0, 0).g) == 35);
    CHECK(to_byte(image.at(0, 0).b) == 1);

    const std::string p3 =
        folder.file("text.ppm", "P3\n# ascii\n1 2\n15\n15 0 5\n# second row\n3 6 9\n");
    image = read_image(p3);
    REQUIRE(image.width == 1);
    REQUIRE(image.height == 2);
    CHECK(image.at(0, 0).r == doctest::Approx(1));
    CHECK(image.at(0, 0).b == doctest::Approx(5 / 15.0));
    CHECK(image.at(0, 1).g == doctest::Approx(6 / 15.0));

    // maxval 65535: two bytes per sample, most significant first.
    const std::string wide = folder.file(
        "sixteen.ppm", std::string("P6 1 1 65535\n") + std::string("\xff\xff\x80\x00\x00\x01", 6));
    image = read_image(wide);
    CHECK(image.at(0, 0).r == doctest::Approx(1));
    CHECK(image.at(0, 0).g == doctest::Approx(32768 / 65535.0));
    CHECK(image.at(0, 0).b == doctest::Approx(1 / 65535.0));
}

TEST_CASE("read_image: bad files are InputErrors naming the file and the problem") {
    TempFolder folder;
    const std::string missing = (folder.path / "no_such.png").string();
    CHECK(contains(read_error(missing), missing));
    CHECK(contains(read_error(missing), "no such file"));

    CHECK(contains(read_error(folder.path.string()), "folder"));

    const std::string empty = folder.file("empty.png", "");
    CHECK(contains(read_error(empty), empty));
    CHECK(contains(read_error(empty), "empty"));

    const std::string text = folder.file("notes.png", "these are my notes, not a picture\n");
    CHECK(contains(read_error(text), text));
    CHECK(contains(read_error(text), "not a PNG or PPM"));

    const std::string short_raster = folder.file("short.ppm", "P6 2 2 255\nabcdef");
    CHECK(contains(read_error(short_raster), short_raster));
    CHECK(contains(read_error(short_raster), "truncated"));

    const std::string short_header = folder.file("header.ppm", "P6 2 ");
    CHECK(contains(read_error(short_header), "truncated"));

    const std::string short_text = folder.file("short_text.ppm", "P3 2 1 255 1 2 3 4 5");
    CHECK(contains(read_error(short_text), "truncated"));

    const std::string huge = folder.file("huge.ppm", "P6 20000 1 255\n");
    CHECK(contains(read_error(huge), huge));
    CHECK(contains(read_error(huge), "16384"));

    const std::string zero = folder.file("zero.ppm", "P6 0 4 255\n");
    CHECK(contains(read_error(zero), "empty picture"));

    const std::string above = folder.file("above.ppm", "P3 1 1 100 50 101 0\n");
    CHECK(contains(read_error(above), "above its maxval"));

    const std::string bad_number = folder.file("word.ppm", "P6 two 1 255\n");
    CHECK(contains(read_error(bad_number), "width"));

    // A PNG signature followed by garbage.
    const std::string broken =
        folder.file("broken.png", std::string("\x89PNG\r\n\x1a\n", 8) + "garbage garbage");
    CHECK(contains(read_error(broken), broken));
    CHECK(contains(read_error(broken), "PNG"));
}
