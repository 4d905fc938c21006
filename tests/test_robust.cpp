// test_robust.cpp: the pieces behind the error messages and the no-crash guarantees, one by
// one: escaped echoes, numbers out of a double's range, transfer-function files an editor
// spoils, the bounded trace, and the all-or-none output set. (tests/bad_input_test.sh runs the
// same cases through the step binaries.)
#include <doctest/doctest.h>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include "error.h"
#include "harness.h"
#include "image.h"
#include "output_files.h"
#include "render.h"
#include "tools/image_read.h"
#include "transfer_function.h"

using namespace ctlab;

namespace {

std::string message_of(const std::function<void()>& action) {
    try {
        action();
    } catch (const InputError& error) {
        return error.what();
    }
    return "(no error)";
}

std::vector<std::string> names_in(const std::filesystem::path& folder) {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(folder)) {
        names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

}  // namespace

TEST_CASE("printable: control characters and stray bytes escaped, UTF-8 kept") {
    CHECK(printable("plain path/CThead") == "plain path/CThead");
    CHECK(printable("a\nb\tc\rd") == "a\\nb\\tc\\rd");
    CHECK(printable("\x1b[31mred") == "\\x1b[31mred");
    CHECK(printable(std::string("nul\0byte", 8)) == "nul\\x00byte");
    CHECK(printable("\x7f") == "\\x7f");
    CHECK(printable("caf\xc3\xa9 \xe2\x82\xac") == "caf\xc3\xa9 \xe2\x82\xac");  // é €: as is
    CHECK(printable("\xc2\x9b" "2J") == "\\xc2\\x9b2J");  // U+009B, the one-byte CSI
    CHECK(printable("\x9b" "2J") == "\\x9b2J");            // the raw byte, not UTF-8
    CHECK(printable("\xe2\x82") == "\\xe2\\x82");          // cut short
    CHECK(printable("\xc0\xaf") == "\\xc0\\xaf");          // overlong '/'
}

TEST_CASE("parse_double and parse_int: beyond a double or a long is out of range") {
    CHECK(message_of([] { parse_double("--ert", "1e-308", 0, 1); }) ==
          "--ert: 1e-308 is out of range (too close to 0 for a double); expected a number "
          "from 0 to 1");
    CHECK(message_of([] { parse_double("--ert", "-1e999", 0, 1); }) ==
          "--ert: -1e999 is out of range (too large for a double); expected a number from 0 "
          "to 1");
    CHECK(message_of([] { parse_double("--ert", "inf", 0, 1); }) ==
          "--ert: expected a number, got 'inf'");
    CHECK(parse_double("--ert", "2.5e-308", 0, 1) == doctest::Approx(2.5e-308));  // normal
    CHECK(message_of([] { parse_int("--threshold", "99999999999999999999", -5, 5); }) ==
          "--threshold: expected a whole number from -5 to 5, got 99999999999999999999");
}

TEST_CASE("transfer-function text: a BOM, a non-breaking space and CR-only lines are named") {
    const std::string range = "-300 50 constant 1 0.79 0.6 0.12 skin";
    CHECK(message_of([&] { parse_transfer_function("\xef\xbb\xbf" + range + "\n", "t.tf"); }) ==
          "t.tf:1: the file starts with a UTF-8 byte order mark (bytes EF BB BF): save it as "
          "UTF-8 without BOM");
    CHECK(message_of([&] {
              parse_transfer_function("# one\n-300\xc2\xa0" "50 constant 1 1 1 0.1\n", "t.tf");
          }) == "t.tf:2: a non-breaking space (bytes C2 A0) at byte 5: separate the fields with "
                "ordinary spaces");
    CHECK(message_of([&] { parse_transfer_function("# a\n# b\r" + range + "\r", "t.tf"); }) ==
          "t.tf:2: a line ends with CR alone (old Mac line endings): save the file with LF (or "
          "CRLF) line endings");
    // What is fine stays fine: CRLF lines, and a non-breaking space inside a comment.
    const TransferFunction crlf = parse_transfer_function(range + "\r\n# x\xc2\xa0y\r\n", "t.tf");
    REQUIRE(crlf.ranges.size() == 1);
    CHECK(crlf.ranges[0].label == "skin");
    CHECK(crlf.ranges[0].to == 50);
}

TEST_CASE("Trace: the first 1000 and the last 20 lines, the rest counted") {
    Trace trace;
    for (int n = 0; n < 5000; ++n) trace.note({{"n", double(n)}}, "sample %d", n);
    REQUIRE(trace.first_lines().size() == Trace::max_first_lines);
    CHECK(trace.first_lines().front() == "sample 0");
    CHECK(trace.first_lines().back() == "sample 999");
    const std::vector<std::string> last = trace.last_lines();
    REQUIRE(last.size() == Trace::max_last_lines);
    CHECK(last.front() == "sample 4980");
    CHECK(last.back() == "sample 4999");
    CHECK(trace.not_shown() == 5000 - 1000 - 20);
    CHECK(trace.lines().size() == 1020);
    const std::vector<TraceRecord> records = trace.records();  // the same, as records
    REQUIRE(records.size() == 1020);
    CHECK(records[999].number("n", -1) == 999);
    CHECK(records[1000].number("n", -1) == 4980);
    CHECK(records.back().text == "sample 4999");

    Trace short_trace;  // below the cap: every line, nothing counted as dropped
    for (int n = 0; n < 7; ++n) short_trace.note({}, "s%d", n);
    CHECK(short_trace.lines().size() == 7);
    CHECK(short_trace.last_lines().empty());
    CHECK(short_trace.not_shown() == 0);
}

TEST_CASE("OutputFiles: renamed together at commit, removed when not committed") {
    ctlab_test::TempFolder folder("outputs");
    const std::string a = folder.path() + "/a.png";
    const std::string b = folder.path() + "/b.png";
    { std::ofstream(a) << "older a"; }
    Image image(3, 2);
    image.at(1, 1) = {1, 0.5f, 0};

    {   // an error before commit (the set destroyed): the folder is as it was
        OutputFiles outputs;
        write_png(image, a);
        write_png(image, b);
        CHECK(names_in(folder.path()).size() == 3);  // a.png and two temporaries
    }
    CHECK(names_in(folder.path()) == std::vector<std::string>{"a.png"});
    std::ifstream older(a);
    std::string text;
    std::getline(older, text);
    CHECK(text == "older a");

    {   // committed: both in place, no temporary left
        OutputFiles outputs;
        write_png(image, a);
        write_png(image, b);
        outputs.commit();
    }
    CHECK(names_in(folder.path()) == std::vector<std::string>{"a.png", "b.png"});
    const Image back = read_image(b);
    REQUIRE(back.width == 3);
    CHECK(back.at(1, 1).g == doctest::Approx(128 / 255.0));

    // Without a set, write_png renames at once (the window's S key, the tools).
    CHECK(OutputFiles::active() == nullptr);
    write_png(image, folder.path() + "/c.png");
    CHECK(names_in(folder.path()).size() == 3);
}

TEST_CASE("write_png: a stored PNG (the ray pictures' level) reads back as the same pixels") {
    // 300 x 250 RGB: more than one stored block of 65535 bytes, an odd row length.
    Image image(300, 250);
    for (int y = 0; y < image.height; ++y) {
        for (int x = 0; x < image.width; ++x) {
            image.at(x, y) = {float((x * 7 + y) % 256) / 255, float((x ^ y) % 256) / 255,
                              float((3 * x + 5 * y) % 256) / 255};
        }
    }
    const ctlab_test::TempFolder folder("stored_png");
    write_png(image, folder.path("stored.png"), stored_png_compression);
    write_png(image, folder.path("compressed.png"));
    // Read by tools/image_read (stb_image, after checking every CRC and the Adler-32).
    const Image stored = read_image(folder.path("stored.png"));
    const Image compressed = read_image(folder.path("compressed.png"));
    REQUIRE(stored.width == image.width);
    REQUIRE(stored.height == image.height);
    int differing = 0;
    for (size_t n = 0; n < image.pixels.size(); ++n) {
        const Rgb& a = stored.pixels[n];
        const Rgb& b = compressed.pixels[n];
        differing += a.r != b.r || a.g != b.g || a.b != b.b ||
                     to_byte(a.r) != to_byte(image.pixels[n].r);
    }
    CHECK(differing == 0);
    CHECK(std::filesystem::file_size(folder.path("stored.png")) > 300 * 250 * 3);
}
