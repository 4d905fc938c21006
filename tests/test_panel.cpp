// test_panel.cpp: the control panel's edits without a window (common/panel.h): the editor
// keeps ranges half open, sorted and apart; a saved table reads back the same; a widget's
// value rewrites the command line as the parser would read it.
#include <doctest/doctest.h>
#include "common/error.h"
#include "common/panel.h"
#include "common/transfer_function.h"
#include "common/window.h"

using namespace ctlab;

namespace {

TransferFunction table(const std::string& text) { return parse_transfer_function(text, "test"); }

// "from to|from to|..." of the table's ranges.
std::string ends(const TransferFunction& tf) {
    std::string text;
    for (const TfRange& range : tf.ranges) {
        text += std::to_string(range.from) + " " + std::to_string(range.to) + "|";
    }
    return text;
}

}  // namespace

TEST_CASE("panel: a range's end stays between its neighbours, a shared end moves for both") {
    TransferFunction tf = table("-300 50 constant 1 0.79 0.6 0.12 skin\n"
                                "50 300 constant 1 0 0 0.5\n"
                                "400 32768 constant 1 1 1 0.8 bone\n");
    tf_set_to(tf, 0, 100);  // shared with range 1: both move
    CHECK(ends(tf) == "-300 100|100 300|400 32768|");
    tf_set_to(tf, 0, 5000);  // not past range 1's own end, which keeps one value
    CHECK(ends(tf) == "-300 299|299 300|400 32768|");
    tf_set_to(tf, 1, 10000);  // a gap before bone: up to bone's start, no overlap
    CHECK(ends(tf) == "-300 299|299 400|400 32768|");
    tf_set_from(tf, 0, -40000);  // clamped to the lowest CT value
    CHECK(ends(tf) == "-32768 299|299 400|400 32768|");
    tf_set_from(tf, 2, 399);  // shared with range 1
    CHECK(ends(tf) == "-32768 299|299 399|399 32768|");
    tf_set_from(tf, 1, 500);  // never empty: from < to
    CHECK(ends(tf) == "-32768 398|398 399|399 32768|");
    CHECK_THROWS_AS(tf_set_to(tf, 3, 0), InputError);
    // A drag that grabbed a free end: it stops at its neighbour, and pushes nothing.
    TransferFunction apart = table("-300 50 constant 1 0.79 0.6 0.12 skin\n"
                                   "300 32768 constant 1 1 1 0.8 bone\n");
    for (int value : {200, 300, 600, 900}) tf_set_to(apart, 0, value, false);
    CHECK(ends(apart) == "-300 300|300 32768|");
}

TEST_CASE("panel: add goes into the widest gap, or splits the selected range") {
    TransferFunction tf = table("-300 50 constant 1 0.79 0.6 0.12 skin\n"
                                "1500 32768 constant 1 1 1 0.8 bone\n");
    // Gaps within the volume's values -1020..2248: [-1020, -300) 720 wide, [50, 1500) 1450.
    CHECK(tf_add_range(tf, -1020, 2249, 0) == 1);
    CHECK(ends(tf) == "-300 50|412 1138|1500 32768|");
    TransferFunction full = table("0 100 constant 1 1 1 1 all\n");
    CHECK(tf_add_range(full, 0, 100, 0) == 1);  // no room: split in two, label kept once
    CHECK(ends(full) == "0 50|50 100|");
    CHECK(full.ranges[0].label == "all");
    CHECK(full.ranges[1].label.empty());
    tf_remove_range(full, 0);
    CHECK(ends(full) == "50 100|");
}

TEST_CASE("panel: a table the editor saves reads back to the same ranges") {
    TransferFunction tf = table("-300 50 constant 1 0.79 0.6 0.12 skin\n"
                                "60 300 ramp 0 0 0 0 0.188235 0.5 1 0.05\n"
                                "300 32768 constant 1 1 1 0.8 bone\n");
    tf_set_colour(tf, 0, 0.1234567f, 0.2f, 1.0f / 3.0f);
    tf_set_opacity(tf, 2, 0.0123456789);
    const TransferFunction again =
        parse_transfer_function(transfer_function_text(tf, ValueMap{}, "saved"), "again");
    REQUIRE(again.ranges.size() == tf.ranges.size());
    for (size_t n = 0; n < tf.ranges.size(); ++n) {
        const TfRange& a = tf.ranges[n];
        const TfRange& b = again.ranges[n];
        CHECK(a.from == b.from);
        CHECK(a.to == b.to);
        CHECK(a.ramp == b.ramp);
        CHECK(a.label == b.label);
        for (const auto& [x, y] : {std::pair(a.start, b.start), std::pair(a.end, b.end)}) {
            CHECK(x.r == y.r);  // bit for bit: the text has the digits to read back
            CHECK(x.g == y.g);
            CHECK(x.b == y.b);
            CHECK(x.a == y.a);
        }
    }
    // A scaled volume (float file values): FROM and TO go back to the file's units.
    ValueMap map;
    map.scale = 0.001;
    TransferFunction small = table("100 200 constant 1 1 1 0.5\n");
    const std::string text = transfer_function_text(small, map, "scaled");
    CHECK(text.find("\n0.1 0.2 constant") != std::string::npos);
}

TEST_CASE("panel: a widget's value rewrites the command line as the parser reads it") {
    Preview preview;
    preview.step = "07_back_to_front";
    preview.program = "build/07_back_to_front";
    preview.words = {"--volume", "phantom", "--skin-opacity=0.3", "--unlit", "--window-script",
                     "set:x=1"};
    preview.flags = {{"--skin-opacity", FlagKind::real, 0, 1, {}, "", "0.3", false},
                     {"--unlit", FlagKind::on_off, 0, 0, {}, "", "1", false},
                     {"--order", FlagKind::choice, 0, 0, {"front", "back"}, "", "front", false},
                     {"--threshold", FlagKind::integer, -32768, 32767, {}, "", "400", true}};
    preview.words = panel_set_flag(preview, "skin-opacity", "0.5");
    CHECK(preview.words == std::vector<std::string>{"--volume", "phantom", "--unlit",
                                                    "--window-script", "set:x=1",
                                                    "--skin-opacity", "0.5"});
    preview.words = panel_set_flag(preview, "--unlit", "0");  // a switch off: gone
    preview.words = panel_set_flag(preview, "order", "back");
    preview.words = panel_set_flag(preview, "threshold", "0.25");  // file units: any number
    CHECK(panel_command(preview) == "build/07_back_to_front --volume phantom "
                                    "--skin-opacity 0.5 --order back --threshold 0.25");
    CHECK_THROWS_AS(panel_set_flag(preview, "skin-opacity", "2"), InputError);
    CHECK_THROWS_AS(panel_set_flag(preview, "order", "sideways"), InputError);
    CHECK_THROWS_AS(panel_set_flag(preview, "no-such-flag", "1"), InputError);
    preview.words = {"--out", "my pictures", "--tf", "it's.tf"};
    CHECK(panel_command(preview) ==
          "build/07_back_to_front --out 'my pictures' --tf 'it'\\''s.tf'");
}
