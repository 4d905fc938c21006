// test_compositing.cpp: steps 06-09. The transfer function file and its lookup table, both
// compositing orders, early ray termination, opacity correction and lighting work, leaping
// over empty space, and the
// stiff cases of shared/numerics.md. Expected values come from closed forms computed here.
// The steps are included whole, each in a namespace of its own, so their lesson functions
// can be called directly (their main() becomes an ordinary function).
#include <doctest/doctest.h>
#include "common/ctlab.h"
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>
#include "harness.h"

namespace step06 {
#include "../steps/06_transfer_function.cpp"
}
namespace step07 {
#include "../steps/07_compositing_order.cpp"
}
namespace step08 {
#include "../steps/08_lit_compositing.cpp"
}
namespace step09 {
#include "../steps/09_empty_space.cpp"
}

using namespace ctlab;

namespace {

// A column of voxels, 1 x 1 x n: the top view has one pixel whose ray runs over all of them.
Volume column(const std::vector<int16_t>& values, double spacing = 1) {
    Volume volume;
    volume.nx = volume.ny = 1;
    volume.nz = int(values.size());
    volume.sz = spacing;
    volume.data = values;
    volume.name = "column";
    update_range(volume);
    return volume;
}

// A transfer function with one constant range over [from, to): colour (r, g, b), opacity a.
TransferFunction one_range(int from, int to, float r, float g, float b, double a) {
    TransferFunction tf;
    tf.source = "test";
    TfRange range;
    range.from = from;
    range.to = to;
    range.start = range.end = {r, g, b, float(a)};
    tf.ranges.push_back(range);
    return tf;
}

View top(const Volume& volume) { return make_view(volume, ViewAxis::top); }

// The message of the InputError body() throws ("" when it throws none).
template <class Body>
std::string error_of(Body body) {
    try {
        body();
    } catch (const InputError& error) {
        return error.what();
    }
    return "";
}

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

// Front to back (step 07) over the one ray of a column, with threshold `ert`.
step07::Accumulated f2b_column(const Volume& volume, const step07::Lut& lut, double ert,
                               Work& work) {
    step07::Params params;
    params.ert = ert;
    return step07::composite_front_to_back(volume, top(volume), 0, 0, lut, params, work,
                                           nullptr);
}

// Step 08 over the one ray of a column: unlit, samples `step` apart, corrected or not.
step08::Accumulated lit_column(const Volume& volume, const TransferFunction& tf, double step,
                               bool correction, Work& work) {
    step08::Params params;
    params.ert = 0;
    params.step = step;
    params.unlit = true;
    params.no_correction = !correction;
    const step08::Lut lut = step08::build_lut(tf, step08::opacity_ratio(params));
    return step08::composite_front_to_back(volume, top(volume), 0, 0, lut, params, work,
                                           nullptr);
}

// Back to front (step 06) over the one ray of a column.
Rgb b2f_column(const Volume& volume, const TransferFunction& tf, Work& work) {
    const step06::Lut lut = step06::build_lut(tf);
    return step06::composite_back_to_front(volume, top(volume), 0, 0, lut, work, nullptr);
}

// The same ranges, every colour white: then C = the opacity A = 1 - T.
TransferFunction whitened(TransferFunction tf) {
    for (TfRange& range : tf.ranges) {
        range.start.r = range.start.g = range.start.b = 1;
        range.end.r = range.end.g = range.end.b = 1;
    }
    return tf;
}

// Mean channel difference of two pictures of the same size.
double mean_difference(const Image& a, const Image& b) {
    double sum = 0;
    for (size_t n = 0; n < a.pixels.size(); ++n) {
        sum += std::abs(a.pixels[n].r - b.pixels[n].r) + std::abs(a.pixels[n].g - b.pixels[n].g) +
               std::abs(a.pixels[n].b - b.pixels[n].b);
    }
    return sum / (3.0 * a.pixels.size());
}

double max_difference(const Image& a, const Image& b) {
    double largest = 0;
    for (size_t n = 0; n < a.pixels.size(); ++n) {
        largest = std::max({largest, double(std::abs(a.pixels[n].r - b.pixels[n].r)),
                            double(std::abs(a.pixels[n].g - b.pixels[n].g)),
                            double(std::abs(a.pixels[n].b - b.pixels[n].b))});
    }
    return largest;
}

// The phantom once for every test below (it takes a few tens of ms).
const Volume& phantom() {
    static const Volume volume = make_phantom();
    return volume;
}

// The empty space step 09 leaps over, built as its main() builds it.
step09::EmptySpace space09(const Volume& volume, const step09::Lut& lut) {
    step09::EmptySpace space;
    space.bricks = make_bricks(volume);
    space.empty = step09::find_empty_bricks(space.bricks, lut);
    return space;
}

constexpr int skin_value = 0, bone_value = 1000;  // CT values inside the classic ranges

}  // namespace

// --- The transfer function file ---------------------------------------------------------

TEST_CASE("compositing: classic.tf and the built-in classic table are the same") {
    const TransferFunction file = load_transfer_function(classic_tf_path);
    const TransferFunction built_in = classic_transfer_function();
    REQUIRE(file.ranges.size() == 2);
    REQUIRE(built_in.ranges.size() == file.ranges.size());
    for (size_t n = 0; n < file.ranges.size(); ++n) {
        const TfRange& a = file.ranges[n];
        const TfRange& b = built_in.ranges[n];
        CHECK(a.from == b.from);
        CHECK(a.to == b.to);
        CHECK(a.ramp == b.ramp);
        CHECK(a.label == b.label);
        CHECK(a.start.r == b.start.r);
        CHECK(a.start.g == b.start.g);
        CHECK(a.start.b == b.start.b);
        CHECK(a.start.a == b.start.a);
    }
    CHECK(load_transfer_function("").ranges.size() == 2);  // the default: one or the other
    CHECK(find_range(file, "skin")->start.a == 0.12f);
}

TEST_CASE("compositing: the classic lookup table maps the interval boundaries exactly") {
    const step06::Lut lut = step06::build_lut(classic_transfer_function());
    REQUIRE(lut.entries.size() == 65536);
    auto entry = [&](int value) { return lut.entries[value - lowest_ct_value]; };
    const Rgba skin = {1.0f, 0.79f, 0.6f, 0.12f}, bone = {1, 1, 1, 0.8f};
    auto is = [](const Rgba& e, const Rgba& want) {
        return e.r == want.r && e.g == want.g && e.b == want.b && e.a == want.a;
    };
    const Rgba clear = {0, 0, 0, 0};
    CHECK(is(entry(-32768), clear));
    CHECK(is(entry(-301), clear));
    CHECK(is(entry(-300), skin));
    CHECK(is(entry(49), skin));
    CHECK(is(entry(50), clear));
    CHECK(is(entry(299), clear));
    CHECK(is(entry(300), bone));
    CHECK(is(entry(2248), bone));
    CHECK(is(entry(32767), bone));
    // Steps 07 and 08 build the same table (08 at step 1 with correction).
    CHECK(is(step07::build_lut(classic_transfer_function()).entries[300 - lowest_ct_value],
             bone));
    CHECK(is(step08::build_lut(classic_transfer_function(), 1.0).entries[49 - lowest_ct_value],
             skin));
    // A table nobody filled is all transparent (what a student's unwritten build_lut gives).
    const step06::Lut unfilled;
    CHECK(std::all_of(unfilled.entries.begin(), unfilled.entries.end(),
                      [&](const Rgba& e) { return is(e, clear); }));
}

TEST_CASE("compositing: a ramp goes linearly from FROM to TO, and ends before TO") {
    const TransferFunction tf = parse_transfer_function(
        "# a ramp\n  0 100 ramp 0 0 0 0  1 0.5 0.25 1  soft  # trailing comment\n", "ramp.tf");
    REQUIRE(tf.ranges.size() == 1);
    CHECK(tf.ranges[0].label == "soft");
    CHECK(tf.ranges[0].line == 2);
    const step06::Lut lut = step06::build_lut(tf);
    auto entry = [&](int value) { return lut.entries[value - lowest_ct_value]; };
    CHECK(entry(0).a == 0.0f);
    CHECK(entry(50).a == doctest::Approx(0.5));
    CHECK(entry(50).g == doctest::Approx(0.25));
    CHECK(entry(99).a == doctest::Approx(0.99));
    CHECK(entry(100).a == 0.0f);  // TO is outside the range
    CHECK(entry(-1).a == 0.0f);
}

TEST_CASE("compositing: transfer function errors name the file and the line") {
    auto parse = [](const std::string& text) {
        return error_of([&] { parse_transfer_function(text, "bad.tf"); });
    };
    const std::string good = "-300 50 constant 1 0.79 0.6 0.12 skin\n";
    // Syntax: too few numbers, an unknown kind, a word for a number.
    std::string message = parse("# comment\n-300 50 constant 1 0.79 0.6\n");
    CHECK(contains(message, "bad.tf:2:"));
    CHECK(contains(message, "4 numbers"));
    CHECK(contains(parse("\n\n-300 50 linear 1 1 1 1\n"), "bad.tf:3: the kind must be"));
    CHECK(contains(parse("-300 fifty constant 1 1 1 1\n"), "bad.tf:1: TO must be"));
    CHECK(contains(parse("-300 50 constant 1 1 x 1\n"), "bad.tf:1: blue"));
    CHECK(contains(parse("-300 50 constant 1 1 1 1 2\n"), "bad.tf:1: the label"));
    CHECK(contains(parse("1.5 50 constant 1 1 1 1\n"), "bad.tf:1: FROM must be a whole"));
    CHECK(contains(parse("-40000 50 constant 1 1 1 1\n"), "bad.tf:1: FROM must be from"));
    CHECK(contains(parse("50 50 constant 1 1 1 1\n"), "bad.tf:1: FROM must be below TO"));
    // Overlapping and unsorted ranges.
    message = parse(good + "40 300 constant 1 1 1 1\n");
    CHECK(contains(message, "bad.tf:2:"));
    CHECK(contains(message, "overlaps [-300, 50) on line 1"));
    message = parse(good + "# bone first?\n-1000 -300 constant 1 1 1 1\n");
    CHECK(contains(message, "bad.tf:3:"));
    CHECK(contains(message, "sorted"));
    // Opacity and colour outside [0, 1], NaN, infinity.
    CHECK(contains(parse("300 400 constant 1 1 1 1.5\n"), "bad.tf:1: opacity must be from 0"));
    CHECK(contains(parse("300 400 constant 1 1 1 -0.1\n"), "bad.tf:1: opacity"));
    CHECK(contains(parse("300 400 constant 1 1 1 nan\n"), "bad.tf:1: opacity is not a number"));
    CHECK(contains(parse("300 400 constant 1 1 1 inf\n"), "bad.tf:1: opacity"));
    CHECK(contains(parse("300 400 ramp 0 0 0 0 1 1 1 NaN\n"), "bad.tf:1: end opacity"));
    CHECK(contains(parse("300 400 constant 2 1 1 1\n"), "bad.tf:1: red"));
    // Labels: once each. A good file parses without complaint.
    CHECK(contains(parse(good + "300 400 constant 1 1 1 1 skin\n"), "bad.tf:2: the label"));
    CHECK(parse(good + "\n   # only a comment\n300 32768 constant 1 1 1 0.8 bone\n") == "");
    CHECK(parse("") == "");  // no ranges: everything transparent
    // Files and flags.
    CHECK(contains(error_of([] { load_transfer_function("no/such/file.tf"); }), "--tf:"));
    TransferFunction bone_only = load_transfer_function("data/tf/bone_only.tf");
    CHECK(contains(error_of([&] { set_opacity(bone_only, "skin", 0.5, "--skin-opacity"); }),
                   "--skin-opacity: data/tf/bone_only.tf has no range labelled 'skin'"));
}

// --- Compositing: the two orders --------------------------------------------------------

TEST_CASE("compositing: skin, skin, bone gives the numerics.md colour in both orders") {
    const double a_skin = 0.12, a_bone = 0.8;
    const double skin[3] = {1.0, 0.79, 0.6};
    // Closed form, front to back: C = a c1 + (1 - a) a c2 + (1 - a)^2 a_bone c_bone.
    double expected[3];
    for (int n = 0; n < 3; ++n) {
        expected[n] = a_skin * skin[n] + (1 - a_skin) * a_skin * skin[n] +
                      (1 - a_skin) * (1 - a_skin) * a_bone * 1.0;
    }
    const double expected_t = (1 - a_skin) * (1 - a_skin) * (1 - a_bone);
    CHECK(expected[0] == doctest::Approx(0.84512));
    CHECK(expected[1] == doctest::Approx(0.797744));
    CHECK(expected[2] == doctest::Approx(0.75488));
    CHECK(expected_t == doctest::Approx(0.15488));

    const Volume volume = column({skin_value, skin_value, bone_value});
    const TransferFunction classic = classic_transfer_function();
    Work work;
    const step07::Accumulated f2b = f2b_column(volume, step07::build_lut(classic), 0, work);
    CHECK(f2b.r == doctest::Approx(expected[0]).epsilon(1e-6));
    CHECK(f2b.g == doctest::Approx(expected[1]).epsilon(1e-6));
    CHECK(f2b.b == doctest::Approx(expected[2]).epsilon(1e-6));
    CHECK(f2b.transparency == doctest::Approx(expected_t).epsilon(1e-6));

    const Rgb b2f_07 = step07::composite_back_to_front(volume, top(volume), 0, 0,
                                                       step07::build_lut(classic), work, nullptr);
    for (const Rgb b2f : {b2f_column(volume, classic, work), b2f_07}) {
        CHECK(b2f.r == doctest::Approx(expected[0]).epsilon(1e-6));
        CHECK(b2f.g == doctest::Approx(expected[1]).epsilon(1e-6));
        CHECK(b2f.b == doctest::Approx(expected[2]).epsilon(1e-6));
    }
    // Back to front keeps no T; with every colour white, C = 1 - T.
    const Rgb opacity = b2f_column(volume, whitened(classic), work);
    CHECK(1.0 - opacity.r == doctest::Approx(expected_t).epsilon(1e-6));
}

TEST_CASE("compositing: homogeneous slabs match A = 1 - (1 - a)^n and T = (1 - a)^n") {
    struct Slab {
        double a;
        int n;
    };
    for (const Slab slab : {Slab{0.12, 10}, Slab{0.12, 113}, Slab{1e-7, 1000000}}) {
        CAPTURE(slab.a);
        CAPTURE(slab.n);
        const TransferFunction tf = one_range(100, 101, 1, 1, 1, slab.a);
        const step07::Lut lut = step07::build_lut(tf);
        const double a = lut.entries[100 - lowest_ct_value].a;  // the opacity as stored (float)
        const double expected_t = std::exp(slab.n * std::log1p(-a));
        const Volume volume = column(std::vector<int16_t>(slab.n, 100));
        Work work;
        const step07::Accumulated f2b = f2b_column(volume, lut, 0, work);
        CHECK(f2b.transparency == doctest::Approx(expected_t).epsilon(1e-9));
        CHECK(f2b.r == doctest::Approx(-std::expm1(slab.n * std::log1p(-a))).epsilon(1e-9));
        CHECK(work.samples == uint64_t(slab.n));
        const Rgb b2f = b2f_column(volume, tf, work);
        CHECK(b2f.r == doctest::Approx(1 - expected_t).epsilon(1e-6));
    }
    // numerics.md's numbers: a = 0.12, n = 10 gives A = 0.72150; n = 113 gives T = 5.33e-7.
    CHECK(1 - std::pow(0.88, 10) == doctest::Approx(0.72150).epsilon(1e-5));
    CHECK(std::pow(0.88, 113) == doctest::Approx(5.33e-7).epsilon(1e-3));

    // Why the sums run in double: near 1 a float resolves only 6e-8, so 1 - 1e-7 in float is
    // 1 - 1.19e-7, and a million samples compound it to T = 0.888 instead of 0.905.
    float t_float = 1;
    for (int n = 0; n < 1000000; ++n) t_float *= 1.0f - 1e-7f;
    CHECK(std::abs(t_float - std::exp(-0.1)) > 0.01);
}

TEST_CASE("compositing: a = 0.8, n = 1000 stays finite and never subnormal") {
    // In float, T = 0.2^n turns subnormal near n = 55 and reaches 0 near n = 64.
    float t_float = 1;
    int first_subnormal = 0;
    for (int n = 1; n <= 100 && first_subnormal == 0; ++n) {
        t_float *= 0.2f;
        if (std::fpclassify(t_float) == FP_SUBNORMAL) first_subnormal = n;
    }
    CHECK(first_subnormal >= 50);
    CHECK(first_subnormal <= 60);

    const TransferFunction tf = one_range(100, 101, 1, 1, 1, 0.8);
    const Volume volume = column(std::vector<int16_t>(1000, 100));
    const step07::Lut lut = step07::build_lut(tf);
    // --ert 0: the ray still stops once T < 1e-300, before any subnormal.
    Work work;
    const step07::Accumulated ray = f2b_column(volume, lut, 0, work);
    const double a = lut.entries[100 - lowest_ct_value].a;
    const int stop_after = int(std::ceil(std::log(1e-300) / std::log1p(-a)));  // about 430
    CHECK(std::fpclassify(ray.transparency) == FP_NORMAL);
    CHECK(ray.transparency < 1e-300);
    CHECK(ray.transparency == doctest::Approx(std::pow(1 - a, stop_after)).epsilon(1e-9));
    CHECK(work.samples == uint64_t(stop_after));
    CHECK(work.terminated == 1);
    CHECK(std::isfinite(ray.r));
    CHECK(ray.r == doctest::Approx(1.0));
    // With the default threshold 0.01 the ray stops after 3 samples (0.2^3 = 0.008).
    Work early;
    const step07::Accumulated stopped = f2b_column(volume, lut, step07::default_ert, early);
    CHECK(early.samples == 3);
    CHECK(stopped.transparency == doctest::Approx(0.008).epsilon(1e-6));
    CHECK(1.0 - stopped.r <= step07::default_ert);  // the error bound T* * max(c)
    // Back to front goes through all 1000 samples and still gives a clean 1.
    const Rgb b2f = b2f_column(volume, tf, early);
    CHECK(b2f.r == 1.0f);
}

TEST_CASE("compositing: opacity exactly 1 hides what is behind; opacity 0 adds nothing") {
    // Value 100: red and opaque; value 200: green, half transparent.
    TransferFunction tf = one_range(100, 101, 1, 0, 0, 1.0);
    TfRange green;
    green.from = 200;
    green.to = 201;
    green.start = green.end = {0, 1, 0, 0.5f};
    tf.ranges.push_back(green);
    const Volume volume = column({100, 200, 200, 100});
    Work work;
    const step07::Accumulated f2b = f2b_column(volume, step07::build_lut(tf), 0, work);
    CHECK(f2b.r == 1.0);
    CHECK(f2b.g == 0.0);
    CHECK(f2b.transparency == 0.0);
    CHECK(work.samples == 1);  // T = 0 after one sample: nothing more to see
    const Rgb b2f = b2f_column(volume, tf, work);
    CHECK(b2f.r == 1.0f);
    CHECK(b2f.g == 0.0f);

    // Everything transparent: nothing is shaded, the background (black) shows.
    const step07::Lut clear = step07::build_lut(load_transfer_function(
        "data/tf/transparent.tf"));
    Work none;
    const step07::Accumulated empty = f2b_column(volume, clear, 0, none);
    CHECK(empty.transparency == 1.0);
    CHECK(empty.r == 0.0);
    CHECK(none.skipped == none.samples);
    CHECK(none.samples == 4);
}

TEST_CASE("compositing: extinction alpha = -expm1(-kappa h) stays in [0, 1]; kappa h does not") {
    for (const double kappa_h : {1e-8, 1.0, 3.0, 50.0}) {
        CAPTURE(kappa_h);
        const double alpha = -std::expm1(-kappa_h);
        CHECK(alpha >= 0);
        CHECK(alpha <= 1);
        CHECK(1 - alpha == doctest::Approx(std::exp(-kappa_h)).epsilon(1e-12));
    }
    CHECK(-std::expm1(-1e-8) == doctest::Approx(1e-8).epsilon(1e-7));  // full precision
    CHECK(1.0f - std::exp(-1e-8f) == 0.0f);  // the plain form loses it all in float
    // The first-order alpha = kappa h exceeds 1: at kappa h = 3, T = 1 - 3 = -2, not 0.0498.
    const double first_order_t = 1 - 3.0;
    CHECK(first_order_t == -2.0);
    CHECK(std::exp(-3.0) == doctest::Approx(0.0498).epsilon(1e-3));
}

TEST_CASE("compositing: front to back and back to front agree on the phantom") {
    const step07::Lut lut = step07::build_lut(classic_transfer_function());
    for (const View& view : views_named(phantom(), "all")) {
        CAPTURE(view.name);
        for (const double ert : {0.0, 0.01, 0.1}) {
            CAPTURE(ert);
            step07::Params params;
            params.ert = ert;
            Work f2b_work, b2f_work;
            const Image f2b = render_image(view, 2, f2b_work, [&](int x, int y, Work& w) {
                return step07::over_background(step07::composite_front_to_back(
                    phantom(), view, x, y, lut, params, w, nullptr));
            });
            const Image b2f = render_image(view, 2, b2f_work, [&](int x, int y, Work& w) {
                return step07::composite_back_to_front(phantom(), view, x, y, lut, w, nullptr);
            });
            const double max_colour = 1.0;  // the largest colour channel in the classic table
            const double allowed = ert == 0 ? 1e-5 : ert * max_colour + 1e-6;
            CHECK(max_difference(f2b, b2f) <= allowed);
            CHECK(b2f_work.terminated == 0);
            // Neither order leaps (step 09 does): every sample reached is read.
            CHECK(b2f_work.leapt == 0);
            CHECK(f2b_work.leapt == 0);
            if (ert > 0) {
                // Early termination reaches fewer samples than going all the way.
                CHECK(f2b_work.samples < b2f_work.samples);
                CHECK(f2b_work.terminated > 0);
            } else {
                CHECK(f2b_work.samples == b2f_work.samples);
            }
            CHECK(f2b_work.gradients == 0);
        }
    }
}

TEST_CASE("compositing: step 07 --order both writes the difference picture") {
    const ctlab_test::TempFolder out("compositing");
    ctlab_test::FakeArgv argv({"--volume", "phantom", "--view", "front", "--no-window",
                               "--threads", "2", "--order", "both", "--out", out.path()});
    int status = -1;
    const std::string printed = ctlab_test::capture_stdout(
        [&] { status = step07::main(argv.argc(), argv.argv()); });
    CHECK(status == 0);
    CHECK(contains(printed, "order=both ert=0.01 max_order_diff="));
    CHECK(contains(printed, "ert_skipped_fraction="));
    CHECK(contains(printed, "diff_scale=100"));
    const Image diff = read_image(out.path("07_compositing_order_front_diff.png"));
    CHECK(diff.width == 256);
    CHECK(diff.height == 113);

    // Bad input: exit status 2 (and one line on stderr).
    ctlab_test::FakeArgv bad({"--tf", "no/such.tf", "--out", out.path()});
    CHECK(step07::main(bad.argc(), bad.argv()) == exit_bad_input);
}

TEST_CASE("compositing: the trace shows RGBA, C and T per sample and where the ray stopped") {
    const Volume volume = column({-1000, skin_value, bone_value, bone_value, bone_value,
                                  bone_value});
    const step07::Lut lut = step07::build_lut(classic_transfer_function());
    step07::Params params;  // default ert 0.01
    Work work;
    Trace trace;
    step07::composite_front_to_back(volume, top(volume), 0, 0, lut, params, work, &trace);
    // T: 0.88 (skin), 0.176, 0.0352, 0.00704 (bone) < 0.01: stop before the last sample.
    REQUIRE(trace.lines().size() == 6);  // 5 samples, then the termination note
    CHECK(contains(trace.lines()[0], "transparent: skipped"));
    CHECK(contains(trace.lines()[1], "rgba=(1.000, 0.790, 0.600, 0.1200)"));
    CHECK(contains(trace.lines()[1], "T=0.88"));
    CHECK(contains(trace.lines()[4], "T=0.00704"));
    CHECK(contains(trace.lines()[5], "early ray termination at n=4, 1 samples not visited"));
}

// --- Step 08: lighting work, step size and opacity correction ---------------------------

TEST_CASE("compositing: opacity correction at extreme ratios matches the closed form") {
    for (const float alpha : {1e-7f, 0.12f, 0.5f, 0.8f, 0.999f}) {
        for (const double ratio : {1e-3, 0.25, 0.5, 1.0, 2.0, 4.0, 1e3}) {
            CAPTURE(alpha);
            CAPTURE(ratio);
            const float corrected = step08::corrected_opacity(alpha, ratio);
            CHECK(corrected >= 0.0f);
            CHECK(corrected <= 1.0f);
            const long double exact = 1.0L - std::pow(1.0L - alpha, (long double)ratio);
            CHECK(corrected == doctest::Approx(double(exact)).epsilon(1e-6));
        }
        CHECK(step08::corrected_opacity(alpha, 1.0) == doctest::Approx(alpha).epsilon(1e-6));
    }
    for (const double ratio : {1e-3, 1.0, 1e3}) {
        CHECK(step08::corrected_opacity(0.0f, ratio) == 0.0f);
        CHECK(step08::corrected_opacity(1.0f, ratio) == 1.0f);
    }
    // Two half steps let through what one whole step does.
    const float half = step08::corrected_opacity(0.12f, 0.5);
    CHECK((1 - half) * (1 - half) == doctest::Approx(0.88).epsilon(1e-6));
}

TEST_CASE("compositing: a slab keeps its opacity at any step, in 1- and 2-unit spacing") {
    const TransferFunction tf = one_range(100, 101, 1, 1, 1, 0.12);
    const double a = 0.12f;
    const int n = 20;
    for (const double spacing : {1.0, 2.0}) {
        const Volume volume = column(std::vector<int16_t>(n, 100), spacing);
        const double depth = n * spacing;  // physical units
        const double expected_t = std::pow(1 - a, depth);
        for (const double step : {0.25, 0.5, 1.0, 2.0, 4.0}) {
            CAPTURE(spacing);
            CAPTURE(step);
            Work work;
            const step08::Accumulated ray = lit_column(volume, tf, step, true, work);
            CHECK(ray.transparency == doctest::Approx(expected_t).epsilon(1e-5));
            CHECK(work.samples == uint64_t(std::lround(depth / step)));
            CHECK(work.gradients == 0);
        }
        // Without correction, half the step makes the slab twice as thick, optically.
        Work work;
        const step08::Accumulated uncorrected = lit_column(volume, tf, 0.5, false, work);
        CHECK(uncorrected.transparency == doctest::Approx(std::pow(1 - a, 2 * depth))
                                              .epsilon(1e-5));
    }
}

TEST_CASE("compositing: step 08 interpolates along the ray and never reads outside") {
    // Values from -32768 to 32767 and back: every fractional position maps into the table.
    const Volume volume = column({-32768, 32767, -32768, 32767});
    const View view = top(volume);
    CHECK(step08::value_along_ray(volume, view, 0, 0, 0.0) == -32768.0f);
    CHECK(step08::value_along_ray(volume, view, 0, 0, 0.5) == doctest::Approx(-0.5));
    CHECK(step08::value_along_ray(volume, view, 0, 0, 3.0) == 32767.0f);
    CHECK(step08::value_along_ray(volume, view, 0, 0, 3.75) == 32767.0f);  // clamped at the end
    const TransferFunction tf = one_range(lowest_ct_value, ct_value_end, 1, 1, 1, 0.01);
    const double a = 0.01f;
    for (const double step : {0.25, 0.3, 1.0, 4.0}) {
        CAPTURE(step);
        Work work;
        const step08::Accumulated ray = lit_column(volume, tf, step, true, work);
        const double covered = double(work.samples) * step;  // each sample stands for `step`
        CHECK(covered == doctest::Approx(4.0).epsilon(0.1));
        CHECK(ray.transparency == doctest::Approx(std::pow(1 - a, covered)).epsilon(1e-5));
    }
}

TEST_CASE("compositing: gradients only where alpha > 0; none unlit or fully transparent") {
    const View view = make_view(phantom(), ViewAxis::front);
    auto render = [&](const TransferFunction& tf, bool unlit, Work& work) {
        step09::Params params;
        params.unlit = unlit;
        const step09::Lut lut = step09::build_lut(tf, step09::opacity_ratio(params));
        const step09::EmptySpace space = space09(phantom(), lut);
        return render_image(view, 2, work, [&](int x, int y, Work& w) {
            return step09::over_background(step09::composite_front_to_back(
                phantom(), view, x, y, lut, space, params, w, nullptr));
        });
    };
    Work lit, unlit, clear;
    render(classic_transfer_function(), false, lit);
    render(classic_transfer_function(), true, unlit);
    const Image black = render(load_transfer_function("data/tf/transparent.tf"), false, clear);
    CHECK(lit.gradients > 0);
    CHECK(lit.gradients <= 2 * (lit.samples - lit.skipped));  // at most two per shaded sample
    CHECK(unlit.gradients == 0);
    CHECK(unlit.samples == lit.samples);
    CHECK(clear.gradients == 0);
    CHECK(clear.samples == 0);  // every brick is empty: not one voxel read, all leapt over
    CHECK(clear.leapt == uint64_t(view.width) * view.height * view.ray_length);  // step 1
    CHECK(clear.terminated == 0);
    CHECK(max_difference(black, Image(view.width, view.height)) == 0);
}

TEST_CASE("compositing: leaping over empty bricks changes no pixel, only the work") {
    // Step 09 with and without leaping, every view of the phantom: the same pictures bit for
    // bit; every sample is either visited or leapt over; the lighting and termination work is
    // the same. Also at steps that do not divide a brick (0.3, 2.5).
    const TransferFunction classic = classic_transfer_function();
    for (const View& view : views_named(phantom(), "all")) {
        CAPTURE(view.name);
        for (const double step : {0.3, 1.0, 2.5}) {
            CAPTURE(step);
            step09::Params params08;
            params08.step = step;
            const step09::Lut lut08 = step09::build_lut(classic, step09::opacity_ratio(params08));
            const step09::EmptySpace leap08 = space09(phantom(), lut08);
            auto render08 = [&](const step09::EmptySpace& space, Work& work) {
                return render_image(view, 2, work, [&](int x, int y, Work& w) {
                    return step09::over_background(step09::composite_front_to_back(
                        phantom(), view, x, y, lut08, space, params08, w, nullptr));
                });
            };
            Work leaping08, reading08;
            const Image leapt08 = render08(leap08, leaping08);
            const Image read08 = render08({}, reading08);
            CHECK(std::memcmp(leapt08.pixels.data(), read08.pixels.data(),
                              read08.pixels.size() * sizeof(Rgb)) == 0);
            CHECK(leaping08.leapt > 2 * leaping08.samples);
            CHECK(leaping08.samples + leaping08.leapt == reading08.samples);
            CHECK(leaping08.gradients == reading08.gradients);
            CHECK(leaping08.terminated == reading08.terminated);
        }
    }
}

TEST_CASE("compositing: a sample between an empty brick and bone is not leapt over") {
    // A column of air with bone starting exactly at the first voxel of the second brick.
    // Step 09 at step 0.25 puts samples at 7.25, 7.5, 7.75: between air (-1000) and bone
    // (1000), where they interpolate through the skin range [-300, 50) (7.5 gives 0 exactly).
    // The first brick's range covers voxel brick_size (the overlap), so it is not empty.
    std::vector<int16_t> values(3 * brick_size, -1000);
    for (int k = brick_size; k < 3 * brick_size; ++k) values[k] = 1000;
    const Volume volume = column(values);
    const Bricks bricks = make_bricks(volume);
    REQUIRE(bricks.count() == 3);
    CHECK(bricks.ranges[0].min == -1000);
    CHECK(bricks.ranges[0].max == 1000);  // voxel brick_size, past the brick, is included
    step09::Params params;
    params.step = 0.25;
    params.ert = 0;
    params.unlit = true;
    const step09::Lut lut = step09::build_lut(classic_transfer_function(),
                                              step09::opacity_ratio(params));
    CHECK(step09::value_along_ray(volume, top(volume), 0, 0, brick_size - 0.5) == 0.0f);
    Work leaping, reading;
    Trace trace;
    const step09::Accumulated leapt = step09::composite_front_to_back(
        volume, top(volume), 0, 0, lut, space09(volume, lut), params, leaping, &trace);
    const step09::Accumulated read = step09::composite_front_to_back(
        volume, top(volume), 0, 0, lut, {}, params, reading, nullptr);
    CHECK(leapt.r == read.r);
    CHECK(leapt.transparency == read.transparency);
    CHECK(leapt.transparency < 1);
    CHECK(leaping.leapt == 0);  // no brick is empty: each holds bone or touches it

    // Air all along, but for bone in the last brick: the first two bricks are leapt over.
    std::vector<int16_t> far(3 * brick_size, -1000);
    far.back() = 1000;
    const Volume far_column = column(far);
    Work far_work;
    Trace far_trace;
    step09::composite_front_to_back(far_column, top(far_column), 0, 0, lut,
                                    space09(far_column, lut), params, far_work, &far_trace);
    const uint64_t samples = 3 * brick_size * 4;  // step 0.25
    CHECK(far_work.samples + far_work.leapt == samples);
    CHECK(far_work.leapt == 2 * brick_size * 4);  // bricks 0 and 1, four samples a voxel
    CHECK(contains(far_trace.lines()[0], "empty brick"));
}

TEST_CASE("compositing: the empty bricks follow the table, also when it changes") {
    // Step 09 in-process: the knob takes the step to 2 and back to 1 (the table is corrected
    // again each time, and its empty bricks found again); each picture equals a fresh render
    // at that step. Without skin the table leaves more bricks empty.
    auto render = [](const std::vector<std::string>& flags, const std::vector<int>& presses,
                     std::vector<Image>& images, std::vector<Work>& works) {
        ctlab_test::run_step("09_empty_space", flags, phantom(),
                             [&](const Options& options, const Volume&, const Renderer& r) {
            const View view = make_view(phantom(), ViewAxis::front);
            for (const int steps : presses) {
                if (steps != 0) r.knob.adjust(view, steps);
                works.emplace_back();
                images.push_back(render_view(options, view, r, works.back()));
            }
        });
    };
    std::vector<Image> fresh, knob;
    std::vector<Work> fresh_work, knob_work;
    render({"--no-window", "--step", "2"}, {0}, fresh, fresh_work);
    render({"--no-window"}, {0}, fresh, fresh_work);
    render({"--no-window", "--skin-opacity", "0"}, {0}, fresh, fresh_work);
    render({"--no-window"}, {+1, -1}, knob, knob_work);  // step 2, and back to 1
    REQUIRE(fresh.size() == 3);
    REQUIRE(knob.size() == 2);
    CHECK(max_difference(fresh[0], knob[0]) == 0);
    CHECK(max_difference(fresh[1], knob[1]) == 0);
    CHECK(knob_work[0].leapt == fresh_work[0].leapt);
    CHECK(knob_work[1].leapt == fresh_work[1].leapt);
    CHECK(fresh_work[2].leapt > fresh_work[1].leapt);  // no skin: more empty bricks
    CHECK(max_difference(fresh[2], fresh[1]) > 0.1);   // and the skin is gone
}

TEST_CASE("compositing: step 08 at step 1 and 0.5 looks the same with correction") {
    // What remains with correction: unlit, thin false skin where samples between two voxels
    // interpolate through [-300, 50) (air next to the head rest, say); lit, also the grain
    // of gradients taken from the phantom's noise, interpolated differently at half steps.
    for (const bool unlit : {false, true}) {
        for (const View& view : views_named(phantom(), "all")) {
            auto render = [&](double step, bool correction) {
                step08::Params params;
                params.step = step;
                params.unlit = unlit;
                params.no_correction = !correction;
                const step08::Lut lut = step08::build_lut(classic_transfer_function(),
                                                          step08::opacity_ratio(params));
                Work work;
                return render_image(view, 2, work, [&](int x, int y, Work& w) {
                    return step08::over_background(step08::composite_front_to_back(
                        phantom(), view, x, y, lut, params, w, nullptr));
                });
            };
            const double corrected = mean_difference(render(1, true), render(0.5, true));
            const double uncorrected = mean_difference(render(1, false), render(0.5, false));
            MESSAGE("step 08 " << std::string(unlit ? "unlit " : "lit ") << view.name
                               << ": mean |step 1 - step 0.5| = " << corrected
                               << " with correction, " << uncorrected << " without");
            CAPTURE(unlit);
            CAPTURE(view.name);
            if (unlit) {
                CHECK(corrected < 0.005);
                CHECK(corrected * 5 < uncorrected);
            } else {
                CHECK(corrected < 0.02);
                CHECK(corrected * 2 < uncorrected);
            }
        }
    }
}
