// test_check.cpp: the checker's metrics and heat map (compare.h), and read_image on PNG
// and PPM files, good and bad.
#include <doctest/doctest.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <zlib.h>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <unistd.h>
#include "tools/compare.h"
#include "error.h"
#include "image.h"
#include "tools/image_read.h"
#include "tools/output_folder.h"

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

std::vector<unsigned char> bytes_of(const std::string& text) {
    return std::vector<unsigned char>(text.begin(), text.end());
}

// The message of read_image_bytes(bytes), and whether it was a DamagedImage.
std::pair<std::string, bool> bytes_error(const std::string& bytes) {
    try {
        read_image_bytes(bytes_of(bytes), "p");
    } catch (const DamagedImage& error) {
        return {error.what(), true};
    } catch (const InputError& error) {
        return {error.what(), false};
    }
    return {"", false};
}

void put_32(std::string& out, uint32_t value) {
    for (int shift = 24; shift >= 0; shift -= 8) out += static_cast<char>((value >> shift) & 0xff);
}

// A PNG chunk with its length and CRC, written here with zlib's crc32.
std::string png_chunk(const std::string& type, const std::string& data) {
    std::string chunk;
    put_32(chunk, static_cast<uint32_t>(data.size()));
    chunk += type + data;
    const std::string covered = type + data;
    put_32(chunk, static_cast<uint32_t>(
                      crc32(0, reinterpret_cast<const Bytef*>(covered.data()), covered.size())));
    return chunk;
}

// An 8-bit RGB PNG of width x height whose image data is `raw` compressed by zlib.
std::string png_with_raw(int width, int height, const std::string& raw) {
    std::string header;
    put_32(header, static_cast<uint32_t>(width));
    put_32(header, static_cast<uint32_t>(height));
    header += std::string("\x08\x02\x00\x00\x00", 5);
    uLongf size = compressBound(raw.size());
    std::string compressed(size, '\0');
    compress2(reinterpret_cast<Bytef*>(&compressed[0]), &size,
              reinterpret_cast<const Bytef*>(raw.data()), raw.size(), 9);
    compressed.resize(size);
    return std::string("\x89PNG\r\n\x1a\n", 8) + png_chunk("IHDR", header) +
           png_chunk("IDAT", compressed) + png_chunk("IEND", "");
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

TEST_CASE("read_image: a PNG's data must inflate to exactly its declared size") {
    // 2x2 RGB: each row a filter byte (0, none) and 6 samples: 14 bytes in all.
    const std::string row = std::string(1, '\0') + "\x10\x20\x30\x40\x50\x60";
    const Image image = read_image_bytes(bytes_of(png_with_raw(2, 2, row + row)), "p");
    REQUIRE(image.width == 2);
    REQUIRE(image.height == 2);
    CHECK(to_byte(image.at(1, 1).r) == 0x40);
    CHECK(to_byte(image.at(0, 1).b) == 0x30);

    // One byte more than the picture holds: refused as a bomb, not decoded.
    const auto [more, more_damaged] = bytes_error(png_with_raw(2, 2, row + row + "x"));
    CHECK(contains(more, "inflates to more than the 14 bytes its 2x2 picture holds"));
    CHECK_FALSE(more_damaged);
    // A megabyte of zeros behind a 2x2 header: stopped after the first 64 KiB inflated.
    const auto [bomb, bomb_damaged] = bytes_error(png_with_raw(2, 2, std::string(1 << 20, '\0')));
    CHECK(contains(bomb, "(a decompression bomb?)"));
    CHECK_FALSE(bomb_damaged);
    // One row short: damaged (the data stops early).
    const auto [fewer, fewer_damaged] = bytes_error(png_with_raw(2, 2, row));
    CHECK(contains(fewer, "holds 7 bytes, a 2x2 picture 14"));
    CHECK(fewer_damaged);
}

TEST_CASE("read_image: a flipped byte is damaged (CRC), a bad checksum too (Adler-32)") {
    const std::string row = std::string(1, '\0') + "\x10\x20\x30\x40\x50\x60";
    const std::string good = png_with_raw(2, 2, row + row);
    REQUIRE(bytes_error(good).first.empty());
    // Every byte from the IHDR chunk's length to the end, flipped in turn: never a picture.
    int damaged = 0, refused = 0;
    for (size_t at = 8; at < good.size(); ++at) {
        std::string bad = good;
        bad[at] = static_cast<char>(bad[at] ^ 0x04);
        const auto [message, is_damaged] = bytes_error(bad);
        CHECK_MESSAGE(!message.empty(), "flipped byte " << at << " read as a picture");
        (is_damaged ? damaged : refused)++;
    }
    CHECK(damaged > refused);  // most flips land where only the CRC can tell
    // Inside IDAT's data: the CRC says so.
    std::string flipped = good;
    const size_t idat = flipped.find("IDAT");
    flipped[idat + 6] = static_cast<char>(flipped[idat + 6] ^ 0x01);
    const auto [message, is_damaged] = bytes_error(flipped);
    CHECK(is_damaged);
    CHECK(contains(message, "the CRC of its IDAT chunk"));
    // The same flip with the CRC recomputed: zlib's Adler-32 (or the inflated size) says so.
    const std::string data = flipped.substr(idat + 4, flipped.find("IEND") - 8 - idat - 4);
    const std::string recomputed = flipped.substr(0, idat - 4) + png_chunk("IDAT", data) +
                                   png_chunk("IEND", "");
    const auto [adler, adler_damaged] = bytes_error(recomputed);
    CHECK(!adler.empty());
    CHECK(contains(adler, "PNG"));
    // Bytes after IEND are not ignored.
    CHECK(contains(bytes_error(good + "junk").first, "4 bytes after its end (IEND)"));
}

TEST_CASE("read_image: a PPM holds one picture: trailing bytes are refused") {
    CHECK(contains(bytes_error(std::string("P6 1 1 255\n") + "abcdef").first,
                   "3 bytes after its pixel data"));
    CHECK(contains(bytes_error("P3 1 1 255 1 2 3 4").first, "more after its last sample"));
    CHECK(bytes_error("P3 1 1 255 1 2 3\n# a comment at the end\n").first.empty());
}

TEST_CASE("read_image_at: never through a link, never a FIFO; the file's size bounded first") {
    TempFolder folder;
    write_png(flat(4, 3, 90), (folder.path / "real.png").string());
    fs::create_symlink(folder.path / "real.png", folder.path / "link.png");
    ::mkfifo((folder.path / "fifo.png").c_str(), 0600);
    const int fd = ::open(folder.path.c_str(), O_RDONLY | O_DIRECTORY);
    REQUIRE(fd >= 0);
    CHECK(read_image_at(fd, "real.png", "real.png").width == 4);
    auto error_at = [&](const std::string& name) {
        try {
            read_image_at(fd, name, name);
        } catch (const InputError& error) {
            return std::string(error.what());
        }
        return std::string();
    };
    CHECK(error_at("link.png") == "'link.png': is a symbolic link: not followed (a submission's "
                                  "pictures must be ordinary files)");
    CHECK(error_at("fifo.png") == "'fifo.png': is not an ordinary file");
    CHECK(error_at("none.png") == "'none.png': no such file");
    // A 1x1 PPM followed by a sparse megabyte: refused from its first bytes.
    const std::string junk = folder.file("junk.ppm", std::string("P6 1 1 255\n") + "abc");
    REQUIRE(::truncate(junk.c_str(), 1 << 20) == 0);
    CHECK(contains(error_at("junk.ppm"), "more than its declared picture can need (14)"));
    ::close(fd);
    // The path reader follows links only when asked to.
    const std::string link = (folder.path / "link.png").string();
    CHECK(read_image_file(link, true).width == 4);
    CHECK_THROWS_AS(read_image_file(link, false), InputError);
}

TEST_CASE("OutputFolder: replaces a planted link instead of writing through it") {
    TempFolder folder;
    const std::string victim = folder.file("victim.txt", "keep me");
    fs::create_directory(folder.path / "out");
    fs::create_symlink(victim, folder.path / "out" / "report.md");
    const OutputFolder out = OutputFolder::open((folder.path / "out").string());
    out.write("report.md", "the report");
    std::ifstream victim_file(victim);
    std::string kept((std::istreambuf_iterator<char>(victim_file)), std::istreambuf_iterator<char>());
    CHECK(kept == "keep me");
    CHECK(fs::is_regular_file(fs::symlink_status(folder.path / "out" / "report.md")));
    // A subfolder that is a link is refused, not entered.
    fs::create_directory_symlink(folder.path, folder.path / "out" / "pictures");
    CHECK_THROWS_WITH_AS(out.subfolder("pictures"),
                         doctest::Contains("a link or a file of that name is in the way"),
                         InputError);
    // No temporary is left behind.
    int files = 0;
    for (const auto& entry : fs::directory_iterator(folder.path / "out")) {
        (void)entry;
        ++files;
    }
    CHECK(files == 2);  // report.md and the pictures link
    // png_bytes is the PNG write_png writes: it reads back exactly.
    const Image picture = flat(5, 2, 77);
    out.write("flat.png", png_bytes(picture));
    CHECK(compare_images(read_image(out.path("flat.png")), picture, 0).max_abs == 0);
    CHECK(printable("a\nb\x1b[31m") == "a\\nb\\x1b[31m");
}
