// test_compositing.cpp: steps 07-11. The transfer function file (common code, called here),
// and through the programs: the lookup table's boundaries and ramps, both compositing orders,
// early ray termination, opacity correction, lighting work, leaping over empty space, and the
// stiff cases of shared/numerics.md. Expected values come from closed forms computed here.
//
// The steps run as processes (harness.h, tools/run_step.h). Most cases render a column of
// voxels, 1 x 1 x n (or a row of n columns, n x 1 x 1): the top view's pixel then is one ray,
// its --pfm value C (over a black background), its summary line that ray's work, and its
// --debug-pixel trace the ray sample by sample (T to 6 digits). With every colour white,
// C = 1 - T, the ray's opacity. Transfer functions are written to temporary .tf files.
#include <doctest/doctest.h>
#include "common/ctlab.h"
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>
#include "harness.h"

using namespace ctlab;
using ctlab_test::StepRender;

namespace {

constexpr const char* step07 = "07_back_to_front";  // back to front
constexpr const char* step08 = "08_compositing_order";  // front to back, both orders
constexpr const char* step09 = "09_lit_compositing";    // 08 with every sample lit
constexpr const char* step10 = "10_opacity_correction";    // lit, physical step, correction
constexpr const char* step11 = "11_empty_space";        // 10 plus leaping over empty bricks
constexpr double default_ert = 0.01;                    // steps 08-11's --ert default
constexpr int step11_brick_size = 4;  // steps/11_empty_space.cpp's leap_brick_size (voxels)
// Step 11's flag that turns leaping over empty bricks off.
const std::vector<std::string> no_leaping = {"--no-leaping"};

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

// A row of one-voxel rays, n x 1 x 1: top pixel x shows value x alone.
Volume row(const std::vector<int16_t>& values, double spacing = 1) {
    Volume volume;
    volume.nx = int(values.size());
    volume.ny = volume.nz = 1;
    volume.sz = spacing;
    volume.data = values;
    volume.name = "row";
    update_range(volume);
    return volume;
}

// "FROM TO constant R G B A\n": one range of a .tf file.
std::string tf_range(int from, int to, double r, double g, double b, double a) {
    char line[200];
    std::snprintf(line, sizeof line, "%d %d constant %.9g %.9g %.9g %.9g\n", from, to, r, g, b, a);
    return line;
}

// The classic table with every colour white: then C = the opacity 1 - T.
const std::string white_classic =
    tf_range(-300, 50, 1, 1, 1, 0.12) + tf_range(300, 32768, 1, 1, 1, 0.8);

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

std::vector<std::string> joined(std::vector<std::string> a, const std::vector<std::string>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
}

// Renders the top view of `volume` with the transfer function `tf_text` ("" = the default
// classic.tf) and these flags; with trace, --debug-pixel 0,0 too.
StepRender top_view(const char* step, const Volume& volume, const std::string& tf_text,
                    std::vector<std::string> flags, bool trace = false) {
    const ctlab_test::TempFolder folder("tf");
    if (!tf_text.empty()) {
        const std::vector<unsigned char> bytes(tf_text.begin(), tf_text.end());
        flags = joined(flags, {"--tf", folder.file("test.tf", bytes)});
    }
    flags = joined(flags, {"--view", "top", "--threads", "1"});
    if (trace) flags = joined(flags, {"--debug-pixel", "0,0"});
    StepRender run = ctlab_test::render(step, flags, volume);
    REQUIRE(run.images.size() == 1);
    return run;
}

const Rgb& pixel(const StepRender& run, int x = 0) { return run.images[0].at(x, 0); }
uint64_t count(const StepRender& run, const char* key) {
    return summary_count(run.summary(run.views[0]), key);
}

// The transparency T after the last composited sample of the traced ray ("... T=0.00704").
double traced_transparency(const StepRender& run) {
    REQUIRE(run.run.traces.size() == 1);
    double t = -1;
    for (const std::string& line : run.run.traces[0].lines) {
        const size_t at = line.find(" T=");
        if (at != std::string::npos) t = std::strtod(line.c_str() + at + 3, nullptr);
    }
    return t;
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

bool identical(const Image& a, const Image& b) {
    return a.width == b.width && a.height == b.height &&
           std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(Rgb)) == 0;
}

// The phantom as the steps render it by default (full size, 2 threads): painted once in this
// process and loaded from its raw file (harness.h), not painted by every run.
std::vector<std::string> phantom() {
    std::vector<std::string> flags = ctlab_test::phantom_flags();
    flags.insert(flags.end(), {"--threads", "2"});
    return flags;
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

TEST_CASE("compositing: the classic table maps the interval boundaries exactly, in 06-08") {
    // One-voxel rays of the boundary values: each pixel is opacity * colour (T = 1 before
    // it, a black background behind it), so exactly the table entry's a*c, or black.
    const std::vector<int16_t> values = {-32768, -301, -300, 49, 50, 299, 300, 2248, 32767};
    const Volume volume = row(values);
    struct Entry {
        double r, g, b, a;
    };
    const Entry skin = {1.0, 0.79, 0.6, 0.12}, bone = {1, 1, 1, 0.8}, clear = {0, 0, 0, 0};
    const Entry expected[] = {clear, clear, skin, skin, clear, clear, bone, bone, bone};
    for (const auto& flags : {std::pair<const char*, std::vector<std::string>>{step07, {}},
                              {step08, {}},
                              {step08, {"--order", "b2f"}},
                              {step10, {"--unlit"}}}) {
        CAPTURE(flags.first);
        const StepRender run = top_view(flags.first, volume, "", flags.second);
        for (size_t x = 0; x < values.size(); ++x) {
            CAPTURE(values[x]);
            const Entry& e = expected[x];
            // The table holds floats; the products are taken in double, as numerics.md says.
            const double a = float(e.a);
            CHECK(pixel(run, int(x)).r == doctest::Approx(a * float(e.r)).epsilon(1e-6));
            CHECK(pixel(run, int(x)).g == doctest::Approx(a * float(e.g)).epsilon(1e-6));
            CHECK(pixel(run, int(x)).b == doctest::Approx(a * float(e.b)).epsilon(1e-6));
        }
        // Each ray reads its one voxel; the 4 transparent ones are skipped, never shaded.
        CHECK(count(run, "samples") == values.size());
        CHECK(count(run, "skipped") == 4);
    }
}

TEST_CASE("compositing: a ramp goes linearly from FROM to TO, and ends before TO") {
    const std::string text =
        "# a ramp\n  0 100 ramp 0 0 0 0  1 0.5 0.25 1  soft  # trailing comment\n";
    const TransferFunction tf = parse_transfer_function(text, "ramp.tf");
    REQUIRE(tf.ranges.size() == 1);
    CHECK(tf.ranges[0].label == "soft");
    CHECK(tf.ranges[0].line == 2);
    // Through step 07, one-voxel rays: value v in [0, 100) has f = v/100 of the way, rgba =
    // (f, f/2, f/4, f), shown as a * c = (f^2, f^2/2, f^2/4); 100 (TO) and -1 are outside.
    const std::vector<int16_t> values = {0, 50, 99, 100, -1};
    const StepRender run = top_view(step07, row(values), text, {});
    for (size_t x = 0; x < values.size(); ++x) {
        CAPTURE(values[x]);
        const double f = values[x] >= 0 && values[x] < 100 ? values[x] / 100.0 : 0.0;
        CHECK(pixel(run, int(x)).r == doctest::Approx(f * f).epsilon(1e-6));
        CHECK(pixel(run, int(x)).g == doctest::Approx(f * f / 2).epsilon(1e-6));
        CHECK(pixel(run, int(x)).b == doctest::Approx(f * f / 4).epsilon(1e-6));
    }
    CHECK(pixel(run, 1).g == doctest::Approx(0.125));  // a = 0.5, g = 0.25
    CHECK(pixel(run, 2).r == doctest::Approx(0.99 * 0.99));
    CHECK(pixel(run, 3).r == 0.0f);  // TO is outside the range
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
    const StepRender f2b = top_view(step08, volume, "", {"--ert", "0"}, true);
    const StepRender b2f07 = top_view(step08, volume, "", {"--order", "b2f"});
    const StepRender b2f06 = top_view(step07, volume, "", {});
    for (const StepRender* run : {&f2b, &b2f07, &b2f06}) {
        CAPTURE(run->run.command());
        CHECK(pixel(*run).r == doctest::Approx(expected[0]).epsilon(1e-6));
        CHECK(pixel(*run).g == doctest::Approx(expected[1]).epsilon(1e-6));
        CHECK(pixel(*run).b == doctest::Approx(expected[2]).epsilon(1e-6));
    }
    CHECK(traced_transparency(f2b) == doctest::Approx(expected_t).epsilon(1e-5));
    // Back to front keeps no T; with every colour white, C = 1 - T.
    const StepRender opacity = top_view(step07, volume, white_classic, {});
    CHECK(1.0 - pixel(opacity).r == doctest::Approx(expected_t).epsilon(1e-6));
}

TEST_CASE("compositing: homogeneous slabs match A = 1 - (1 - a)^n and T = (1 - a)^n") {
    struct Slab {
        double a;
        int n;
    };
    for (const Slab slab : {Slab{0.12, 10}, Slab{0.12, 113}, Slab{1e-7, 1000000}}) {
        CAPTURE(slab.a);
        CAPTURE(slab.n);
        const std::string tf = tf_range(100, 101, 1, 1, 1, slab.a);
        const double a = float(slab.a);  // the opacity as the table stores it (float)
        const double expected_t = std::exp(slab.n * std::log1p(-a));
        const Volume volume = column(std::vector<int16_t>(slab.n, 100));
        const bool trace = slab.n < 1000;  // a trace line per sample
        const StepRender f2b = top_view(step08, volume, tf, {"--ert", "0"}, trace);
        CHECK(pixel(f2b).r == doctest::Approx(-std::expm1(slab.n * std::log1p(-a))).epsilon(1e-6));
        if (trace) CHECK(traced_transparency(f2b) == doctest::Approx(expected_t).epsilon(1e-5));
        CHECK(count(f2b, "samples") == uint64_t(slab.n));
        const StepRender b2f = top_view(step07, volume, tf, {});
        CHECK(pixel(b2f).r == doctest::Approx(1 - expected_t).epsilon(1e-6));
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

    const std::string tf = tf_range(100, 101, 1, 1, 1, 0.8);
    const Volume volume = column(std::vector<int16_t>(1000, 100));
    // --ert 0: the ray still stops once T < 1e-300, before any subnormal.
    const StepRender ray = top_view(step08, volume, tf, {"--ert", "0"}, true);
    const double a = 0.8f;
    const int stop_after = int(std::ceil(std::log(1e-300) / std::log1p(-a)));  // about 430
    const double t = traced_transparency(ray);
    CHECK(std::fpclassify(t) == FP_NORMAL);
    CHECK(t < 1e-300);
    CHECK(t == doctest::Approx(std::pow(1 - a, stop_after)).epsilon(1e-5));
    CHECK(count(ray, "samples") == uint64_t(stop_after));
    CHECK(count(ray, "terminated") == 1);
    CHECK(std::isfinite(pixel(ray).r));
    CHECK(pixel(ray).r == doctest::Approx(1.0));
    // With the default threshold 0.01 the ray stops after 3 samples (0.2^3 = 0.008).
    const StepRender stopped = top_view(step08, volume, tf, {}, true);
    CHECK(count(stopped, "samples") == 3);
    CHECK(traced_transparency(stopped) == doctest::Approx(0.008).epsilon(1e-5));
    CHECK(1.0 - pixel(stopped).r <= default_ert + 1e-7);  // the error bound T* * max(c)
    // Back to front goes through all 1000 samples and still gives a clean 1.
    const StepRender b2f = top_view(step07, volume, tf, {});
    CHECK(pixel(b2f).r == 1.0f);
    CHECK(count(b2f, "samples") == 1000);
}

TEST_CASE("compositing: opacity exactly 1 hides what is behind; opacity 0 adds nothing") {
    // Value 100: red and opaque; value 200: green, half transparent.
    const std::string tf = tf_range(100, 101, 1, 0, 0, 1.0) + tf_range(200, 201, 0, 1, 0, 0.5);
    const Volume volume = column({100, 200, 200, 100});
    const StepRender f2b = top_view(step08, volume, tf, {"--ert", "0"}, true);
    CHECK(pixel(f2b).r == 1.0f);
    CHECK(pixel(f2b).g == 0.0f);
    CHECK(traced_transparency(f2b) == 0.0);
    CHECK(count(f2b, "samples") == 1);  // T = 0 after one sample: nothing more to see
    for (const StepRender& b2f : {top_view(step07, volume, tf, {}),
                                  top_view(step08, volume, tf, {"--order", "b2f"})}) {
        CHECK(pixel(b2f).r == 1.0f);
        CHECK(pixel(b2f).g == 0.0f);
    }

    // Everything transparent: nothing is shaded, the background (black) shows.
    const StepRender none = top_view(
        step08, volume, "", {"--tf", "data/tf/transparent.tf", "--ert", "0"});
    CHECK(pixel(none).r == 0.0f);
    CHECK(count(none, "skipped") == count(none, "samples"));
    CHECK(count(none, "samples") == 4);
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
    const StepRender b2f = ctlab_test::render(step08, joined(phantom(), {"--order", "b2f"}));
    REQUIRE(b2f.images.size() == 3);
    for (const double ert : {0.0, 0.01, 0.1}) {
        CAPTURE(ert);
        const StepRender f2b =
            ctlab_test::render(step08, joined(phantom(), {"--ert", std::to_string(ert)}));
        REQUIRE(f2b.images.size() == 3);
        for (size_t v = 0; v < 3; ++v) {
            const std::string& view = f2b.views[v];
            CAPTURE(view);
            const Summary& f = f2b.summary(view);
            const Summary& b = b2f.summary(view);
            const double max_colour = 1.0;  // the largest colour channel in the classic table
            const double allowed = ert == 0 ? 1e-5 : ert * max_colour + 1e-6;
            CHECK(max_difference(f2b.image(view), b2f.image(view)) <= allowed);
            CHECK(summary_count(b, "terminated") == 0);
            // Neither order leaps (step 11 does): every sample reached is read.
            CHECK(summary_count(b, "leapt") == 0);
            CHECK(summary_count(f, "leapt") == 0);
            const uint64_t reached = summary_count(f, "samples");
            if (ert > 0) {
                // Early termination reaches fewer samples than going all the way.
                CHECK(reached < summary_count(b, "samples"));
                CHECK(summary_count(f, "terminated") > 0);
            } else {
                CHECK(reached == summary_count(b, "samples"));
            }
            CHECK(summary_count(f, "gradients") == 0);
        }
    }
}

TEST_CASE("compositing: step 09 --unlit is step 08's picture; lit, only the colour changes") {
    const StepRender unlit = ctlab_test::render(step09, joined(phantom(), {"--unlit"}));
    const StepRender lit = ctlab_test::render(step09, phantom());
    const StepRender plain = ctlab_test::render(step08, phantom());
    REQUIRE(unlit.images.size() == 3);
    for (const std::string view : {"top", "front", "side"}) {
        CAPTURE(view);
        CHECK(max_difference(unlit.image(view), plain.image(view)) == 0);
        CHECK(max_difference(lit.image(view), plain.image(view)) > 0.1);
        // The light darkens the colour, never the opacity: the same samples, the same stops.
        for (const char* counter : {"samples", "skipped", "terminated"}) {
            CHECK(summary_count(lit.summary(view), counter) ==
                  summary_count(plain.summary(view), counter));
        }
        // One gradient per lit sample (a sample on a voxel), none unlit.
        CHECK(summary_count(lit.summary(view), "gradients") ==
              summary_count(lit.summary(view), "samples") -
                  summary_count(lit.summary(view), "skipped"));
        CHECK(summary_count(unlit.summary(view), "gradients") == 0);
    }
}

TEST_CASE("compositing: the two orders compared, as a student would (front view, default ert)") {
    // What step 08 itself once reported with --order both: the two pictures' largest channel
    // difference and the share of back to front's samples that front to back never reached.
    const ctlab_test::TempFolder out("compositing");
    const std::vector<std::string> front = joined(phantom(), {"--view", "front"});
    const StepRender f2b = ctlab_test::render(step08, front);
    const StepRender b2f = ctlab_test::render(step08, joined(front, {"--order", "b2f"}));
    REQUIRE(f2b.images.size() == 1);
    REQUIRE(b2f.images.size() == 1);
    const double max_order_diff = max_difference(f2b.image("front"), b2f.image("front"));
    CHECK(max_order_diff > 0);  // early termination leaves something out...
    CHECK(max_order_diff <= default_ert + 1e-6);  // ...at most T * max(c) < 0.01
    const double reached = double(summary_count(f2b.summary("front"), "samples"));
    const double all = double(summary_count(b2f.summary("front"), "samples"));
    CHECK(all == 256.0 * 256 * 113);  // back to front reads every voxel once
    // 5058485 of 7405568 samples reached (data/reference/counters.txt): 0.3169 left out.
    CHECK(1 - reached / all == doctest::Approx(0.316935).epsilon(1e-5));

    // Bad input: exit status 2 and one line on stderr.
    const RunResult bad = run_step(step08, {"--tf", "no/such.tf", "--out", out.path()});
    CHECK(bad.status == exit_bad_input);
    CHECK(std::count(bad.err.begin(), bad.err.end(), '\n') == 1);
}

TEST_CASE("compositing: the trace shows RGBA, C and T per sample and where the ray stopped") {
    const Volume volume = column({-1000, skin_value, bone_value, bone_value, bone_value,
                                  bone_value});
    const StepRender run = top_view(step08, volume, "", {}, true);  // default ert 0.01
    REQUIRE(run.run.traces.size() == 1);
    const std::vector<std::string>& lines = run.run.traces[0].lines;
    // T: 0.88 (skin), 0.176, 0.0352, 0.00704 (bone) < 0.01: stop before the last sample.
    REQUIRE(lines.size() == 6);  // 5 samples, then the termination note
    CHECK(contains(lines[0], "transparent: skipped"));
    CHECK(contains(lines[1], "rgba=(1.000, 0.790, 0.600, 0.1200)"));
    CHECK(contains(lines[1], "T=0.88"));
    CHECK(contains(lines[4], "T=0.00704"));
    CHECK(contains(lines[5], "early ray termination at n=4, 1 samples not visited"));
}

// --- Step 10: lighting work, step size and opacity correction ---------------------------

TEST_CASE("compositing: opacity correction at every step size matches the closed form") {
    // One sample per ray: a one-voxel column of depth `spacing` sampled at --step = spacing.
    // That sample stands for `step` units of depth, so its opacity is corrected to
    // 1 - (1 - a)^(step / unit length), the unit length being one: white, unlit, shown as
    // the corrected opacity itself. A row of rays holds the opacities 1e-7 to 1 side by side.
    const std::vector<double> alphas = {0, 1e-7, 0.12, 0.5, 0.8, 0.999, 1};
    std::string tf;
    std::vector<int16_t> values;
    for (size_t n = 0; n < alphas.size(); ++n) {
        tf += tf_range(100 + int(n), 101 + int(n), 1, 1, 1, alphas[n]);
        values.push_back(int16_t(100 + n));
    }
    for (const double ratio : {0.25, 0.5, 1.0, 2.0, 4.0}) {  // --step's whole range
        CAPTURE(ratio);
        const StepRender run = top_view(step10, row(values, ratio), tf,
                                        {"--step", std::to_string(ratio), "--unlit", "--ert", "0"});
        CHECK(count(run, "samples") == values.size());  // one per ray
        for (size_t n = 0; n < alphas.size(); ++n) {
            CAPTURE(alphas[n]);
            const double alpha = float(alphas[n]);
            const long double exact = 1.0L - std::pow(1.0L - alpha, (long double)ratio);
            const float corrected = pixel(run, int(n)).r;
            CHECK(corrected >= 0.0f);
            CHECK(corrected <= 1.0f);
            CHECK(corrected == doctest::Approx(double(exact)).epsilon(1e-6));
            if (alphas[n] == 0 || alphas[n] == 1) CHECK(corrected == float(alphas[n]));
        }
    }
}

TEST_CASE("compositing: a slab keeps its opacity at any step, in 1- and 2-unit spacing") {
    const std::string tf = tf_range(100, 101, 1, 1, 1, 0.12);
    const double a = 0.12f;
    const int n = 20;
    for (const double spacing : {1.0, 2.0}) {
        const Volume volume = column(std::vector<int16_t>(n, 100), spacing);
        const double depth = n * spacing;  // physical units
        const double expected_t = std::pow(1 - a, depth);
        for (const double step : {0.25, 0.5, 1.0, 2.0, 4.0}) {
            CAPTURE(spacing);
            CAPTURE(step);
            const StepRender ray = top_view(
                step10, volume, tf, {"--step", std::to_string(step), "--unlit", "--ert", "0"});
            CHECK(1.0 - pixel(ray).r == doctest::Approx(expected_t).epsilon(1e-5));
            CHECK(count(ray, "samples") == uint64_t(std::lround(depth / step)));
            CHECK(count(ray, "gradients") == 0);
        }
        // Without correction, half the step makes the slab twice as thick, optically.
        const StepRender uncorrected = top_view(
            step10, volume, tf, {"--step", "0.5", "--unlit", "--ert", "0", "--no-correction"});
        CHECK(1.0 - pixel(uncorrected).r ==
              doctest::Approx(std::pow(1 - a, 2 * depth)).epsilon(1e-5));
    }
}

TEST_CASE("compositing: step 10 interpolates along the ray and never reads outside") {
    // Values from -32768 to 32767 and back: every fractional position maps into the table.
    const Volume volume = column({-32768, 32767, -32768, 32767});
    const std::string tf = tf_range(lowest_ct_value, ct_value_end, 1, 1, 1, 0.01);
    // The values the trace prints at t = 0, 0.5, ..., 3.5 (--step 0.5): the voxels at whole
    // t, halfway between them (-0.5), and past the last voxel its value (clamped at the end).
    const StepRender traced = top_view(step10, volume, tf,
                                       {"--step", "0.5", "--unlit", "--ert", "0"}, true);
    REQUIRE(traced.run.traces.size() == 1);
    const std::vector<std::string>& lines = traced.run.traces[0].lines;
    REQUIRE(lines.size() == 8);
    const double expected[8] = {-32768, -0.5, 32767, -0.5, -32768, -0.5, 32767, 32767};
    for (int n = 0; n < 8; ++n) {
        CAPTURE(lines[n]);
        double t = -1, value = 0;
        REQUIRE(std::sscanf(lines[n].c_str(), "t=%lf value=%lf", &t, &value) == 2);
        CHECK(t == doctest::Approx(0.5 * n));
        CHECK(value == doctest::Approx(expected[n]));
    }
    const double a = 0.01f;
    for (const double step : {0.25, 0.3, 1.0, 4.0}) {
        CAPTURE(step);
        const StepRender ray = top_view(step10, volume, tf,
                                        {"--step", std::to_string(step), "--unlit", "--ert", "0"});
        const double covered = double(count(ray, "samples")) * step;  // each stands for `step`
        CHECK(covered == doctest::Approx(4.0).epsilon(0.1));
        CHECK(1.0 - pixel(ray).r == doctest::Approx(std::pow(1 - a, covered)).epsilon(1e-5));
    }
}

TEST_CASE("compositing: gradients only where alpha > 0; none unlit or fully transparent") {
    auto front = [](const std::vector<std::string>& flags) {
        const StepRender run = ctlab_test::render(step11, joined(joined(phantom(), {"--view",
                                                                                  "front"}),
                                                                 flags));
        REQUIRE(run.images.size() == 1);
        return run;
    };
    const StepRender lit = front({}), unlit = front({"--unlit"}),
                     clear = front({"--tf", "data/tf/transparent.tf"});
    const View view = make_view(make_phantom_sized(4, 4, 4), ViewAxis::front);  // for names only
    const Summary &l = lit.summary("front"), &u = unlit.summary("front"),
                  &c = clear.summary("front");
    CHECK(summary_count(l, "gradients") > 0);
    // At most two per shaded sample.
    CHECK(summary_count(l, "gradients") <=
          2 * (summary_count(l, "samples") - summary_count(l, "skipped")));
    CHECK(summary_count(u, "gradients") == 0);
    CHECK(summary_count(u, "samples") == summary_count(l, "samples"));
    CHECK(summary_count(c, "gradients") == 0);
    CHECK(summary_count(c, "samples") == 0);  // every brick is empty: not one voxel read
    // All leapt over: every sample of every ray of the 256x113 front view (256 deep, step 1).
    CHECK(summary_count(c, "leapt") == uint64_t(256) * 113 * 256);
    CHECK(summary_count(c, "terminated") == 0);
    CHECK(max_difference(clear.images[0], Image(256, 113)) == 0);
    CHECK(view.name == "front");
}

TEST_CASE("compositing: leaping over empty bricks changes no pixel, only the work") {
    // Step 11 with and without leaping, every view of the phantom: the same pictures bit for
    // bit; every sample is either visited or leapt over; the lighting and termination work is
    // the same. Also at steps that do not divide a brick (0.3, 2.5).
    for (const char* step : {"0.3", "1", "2.5"}) {
        CAPTURE(step);
        const std::vector<std::string> flags = joined(phantom(), {"--step", step});
        const StepRender leaping = ctlab_test::render(step11, flags);
        const StepRender reading = ctlab_test::render(step11, joined(flags, no_leaping));
        REQUIRE(leaping.images.size() == 3);
        REQUIRE(reading.images.size() == 3);
        for (size_t v = 0; v < 3; ++v) {
            const std::string& view = leaping.views[v];
            CAPTURE(view);
            CHECK(identical(leaping.image(view), reading.image(view)));
            const Summary& l = leaping.summary(view);
            const Summary& r = reading.summary(view);
            CHECK(summary_count(r, "leapt") == 0);
            // The phantom is mostly air.
            CHECK(summary_count(l, "leapt") > 2 * summary_count(l, "samples"));
            CHECK(summary_count(l, "samples") + summary_count(l, "leapt") ==
                  summary_count(r, "samples"));
            CHECK(summary_count(l, "gradients") == summary_count(r, "gradients"));
            CHECK(summary_count(l, "terminated") == summary_count(r, "terminated"));
        }
    }
}

TEST_CASE("compositing: a sample between an empty brick and bone is not leapt over") {
    // A column of air with bone starting exactly at the first voxel of the second brick.
    // Step 11 at step 0.25 puts samples at 3.25, 3.5, 3.75: between air (-1000) and bone
    // (1000), where they interpolate through the skin range [-300, 50) (3.5 gives 0 exactly).
    // The first brick's range covers voxel brick (the overlap), so it is not empty.
    const int brick = step11_brick_size;
    std::vector<int16_t> values(3 * brick, -1000);
    for (int k = brick; k < 3 * brick; ++k) values[k] = 1000;
    const Volume volume = column(values);
    const std::vector<std::string> flags = {"--step", "0.25", "--ert", "0", "--unlit"};
    const StepRender leaping = top_view(step11, volume, "", flags, true);
    const StepRender reading = top_view(step11, volume, "", joined(flags, no_leaping));
    CHECK(pixel(leaping).r == pixel(reading).r);
    CHECK(pixel(leaping).r > 0);  // T < 1: the bone shows
    CHECK(count(leaping, "leapt") == 0);  // no brick is empty: each holds bone or touches it
    bool zero_at_3_5 = false;
    for (const std::string& line : leaping.run.traces[0].lines) {
        zero_at_3_5 = zero_at_3_5 || line.rfind("t=   3.50 value=    0.00", 0) == 0;
    }
    CHECK(zero_at_3_5);

    // Air all along, but for bone in the last brick: the first two bricks are leapt over, in
    // one leap (they are a run of two empty bricks).
    std::vector<int16_t> far(3 * brick, -1000);
    far.back() = 1000;
    const StepRender far_run = top_view(step11, column(far), "", flags, true);
    const uint64_t samples = 3 * brick * 4;  // step 0.25
    CHECK(count(far_run, "samples") + count(far_run, "leapt") == samples);
    CHECK(count(far_run, "leapt") == 2 * brick * 4);  // bricks 0 and 1, 4 samples a voxel
    REQUIRE(far_run.run.traces.size() == 1);
    CHECK(contains(far_run.run.traces[0].lines[0], "empty bricks up to voxel " +
                                                       std::to_string(2 * brick - 1) + ": " +
                                                       std::to_string(2 * brick * 4) +
                                                       " samples leapt"));
}

TEST_CASE("compositing: the empty bricks follow the table's skin opacity") {
    // Step 11 at skin opacity 0 and at the default 0.12: without skin, the skin's bricks
    // become empty and are leapt over, and the skin is gone from the picture.
    const std::vector<std::string> front = joined(phantom(), {"--view", "front"});
    const StepRender no_skin = ctlab_test::render(step11, joined(front, {"--skin-opacity", "0"}));
    const StepRender skin = ctlab_test::render(step11, front);
    CHECK(summary_count(no_skin.summary("front"), "leapt") >
          summary_count(skin.summary("front"), "leapt"));
    CHECK(max_difference(no_skin.images[0], skin.images[0]) > 0.1);
    CHECK(no_skin.summary("front").at("skin_opacity") == "0");
    CHECK(skin.summary("front").at("skin_opacity") == "0.12");
}

TEST_CASE("compositing: step 10 at step 1 and 0.5 looks the same with correction") {
    // What remains with correction: unlit, thin false skin where samples between two voxels
    // interpolate through [-300, 50) (air next to the head rest, say); lit, also the grain
    // of gradients taken from the phantom's noise, interpolated differently at half steps.
    for (const bool unlit : {false, true}) {
        auto render = [&](const char* step, bool correction) {
            std::vector<std::string> flags = joined(phantom(), {"--step", step});
            if (unlit) flags.push_back("--unlit");
            if (!correction) flags.push_back("--no-correction");
            return ctlab_test::render(step10, flags);
        };
        const StepRender whole = render("1", true), half = render("0.5", true);
        const StepRender whole_raw = render("1", false), half_raw = render("0.5", false);
        for (const std::string& view : whole.views) {
            const double corrected = mean_difference(whole.image(view), half.image(view));
            const double uncorrected =
                mean_difference(whole_raw.image(view), half_raw.image(view));
            MESSAGE("step 10 " << std::string(unlit ? "unlit " : "lit ") << view
                               << ": mean |step 1 - step 0.5| = " << corrected
                               << " with correction, " << uncorrected << " without");
            CAPTURE(unlit);
            CAPTURE(view);
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
