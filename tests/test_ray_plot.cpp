// test_ray_plot.cpp: the ray picture of --debug-pixel (common/ray_plot.h). The trace's records
// are typed events with their numbers by name; the plotted numbers (the .txt sidecar the picture is drawn
// from) equal the numbers of the text trace; the pictures of the probe rays equal the golden
// ones in data/reference/rays/ (make reference writes them, data/reference/probes.txt says
// which); a run that fails writes no ray picture either.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "tools/compare.h"
#include "harness.h"
#include "image.h"
#include "output_files.h"
#include "ray_plot.h"
#include "render.h"

using namespace ctlab;
namespace fs = std::filesystem;

namespace {

std::string read_text(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

std::vector<std::string> lines_starting(const std::string& text, const std::string& start) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
        if (line.rfind(start, 0) == 0) lines.push_back(line);
    }
    return lines;
}

// The number printed after "NAME=" in a trace line ("C=(" : the first of the tuple, etc.).
// Returns false when the line has no such label; *decimals is how many the text shows.
bool printed(const std::string& line, const std::string& label, int component, double* value,
             int* decimals) {
    const std::regex pattern("(^|[ (])" + label + "=\\(?");
    std::smatch match;
    if (!std::regex_search(line, match, pattern)) return false;
    size_t at = match.position(0) + match.length(0);
    for (int c = 0; c < component; ++c) at = line.find(", ", at) + 2;
    while (at < line.size() && line[at] == ' ') ++at;
    size_t end = at;
    while (end < line.size() && std::string("-+.0123456789eE").find(line[end]) != std::string::npos)
        ++end;
    const std::string number = line.substr(at, end - at);
    *value = std::stod(number);
    const size_t dot = number.find('.');
    const size_t exponent = number.find_first_of("eE");
    *decimals = dot == std::string::npos
                    ? 0
                    : int((exponent == std::string::npos ? number.size() : exponent) - dot - 1);
    if (exponent != std::string::npos) *decimals = 300;  // %g with an exponent: relative check
    return true;
}

void check_equal_to_text(double plotted, const std::string& line, const std::string& label,
                         int component) {
    double shown = 0;
    int decimals = 0;
    REQUIRE_MESSAGE(printed(line, label, component, &shown, &decimals), line, " has no ", label);
    const double allowed =
        decimals >= 300 ? std::fabs(shown) * 1e-5 : 0.5 * std::pow(10.0, -decimals) + 1e-12;
    // %g prints 6 significant digits: T=0.7744 or 0.00422185.
    const double significant = std::fabs(shown) * 5e-6;
    CHECK_MESSAGE(std::fabs(plotted - shown) <= std::max(allowed, significant), label, "[",
                  component, "] plotted ", plotted, " but the trace shows ", shown, " in: ", line);
}

}  // namespace

TEST_CASE("trace records: typed events, their numbers at full precision, their lines made") {
    const double third = 1.0 / 3.0;
    Trace trace;
    trace.sample(TraceSample(43, Voxel{128, 43, 30}, 10).threshold_hit(true));
    trace.crossing(42, 0.25);
    trace.sample(TraceSample(44, Voxel{128, 44, 30}, 10)
                     .rgba(Rgba{1.0f, 0.79f, 0.6f, 0.12f})
                     .colour(third, 0.5, 0.25)
                     .transparency(0.7744));
    trace.stop(0.00422, 0.01, 205);
    trace.leap_to_voxel(8.0, 15.0, 8, 15);
    trace.sample(TraceSample(37.25, Vec3d{1, 2, 3}, 400.5).skipped());
    trace.stop(0.004, 0.01, 7);
    const std::vector<TraceRecord> records = trace.records();
    REQUIRE(records.size() == 7);

    CHECK(records[0].kind == TraceKind::sample);
    CHECK(records[0].hit);
    CHECK(records[0].text == "n= 43 voxel (128, 43, 30) value=   10  > threshold: hit");
    std::vector<std::string> names;
    for (const TraceField& f : records[2].fields) names.push_back(f.name);
    CHECK(names == std::vector<std::string>{"n", "voxel.i", "voxel.j", "voxel.k", "value",
                                            "rgba.r", "rgba.g", "rgba.b", "rgba.a", "C.r",
                                            "C.g", "C.b", "T"});
    CHECK(records[2].number("C.r", 0) == third);  // the number, not the 6 decimals printed
    CHECK(records[2].text == "n= 44 voxel (128, 44, 30) value=   10 rgba=(1.000, 0.790, 0.600, "
                             "0.1200) C=(0.333333, 0.500000, 0.250000) T=0.7744");
    CHECK(!records[2].hit);

    CHECK(records[1].kind == TraceKind::hit);
    CHECK(records[1].text == "crossing between n=42 and n=43: hit at 42 + 0.250000");
    CHECK(records[1].number("fraction", 0) == 0.25);

    // A stop is where the last sample was, in the place that sample printed.
    CHECK(records[3].kind == TraceKind::stop);
    CHECK(records[3].text == "T=0.00422 < 0.01: early ray termination at n=44, 205 samples not "
                             "visited");
    CHECK(records[3].number("n", -1) == 44);
    CHECK(records[6].text == "T=0.004 < 0.01: early ray termination at t=37.2500, 7 samples not "
                             "visited");
    CHECK(records[6].number("t", -1) == 37.25);

    CHECK(records[4].kind == TraceKind::leap);
    CHECK(records[4].text == "t=   8.00..15.00 empty bricks up to voxel 15: 8 samples leapt over");
    CHECK(records[4].number("t_end", 0) == 15.0);
    CHECK(records[5].text == "t=  37.2500 p=(1.000000, 2.000000, 3.000000) value= 400.5000 "
                             "transparent: skipped");

    // The plot reads the kinds: the hit moved to the crossing, the stop, the leap.
    View view;
    view.ray_length = 100, view.ray_spacing = 2;
    const RayPlot plot = ray_plot_from_trace(records, view, {}, Rgb{}, "records");
    CHECK(plot.samples.size() == 3);
    std::vector<RayMark::Kind> kinds;
    for (const RayMark& mark : plot.marks) kinds.push_back(mark.kind);
    CHECK(kinds == std::vector<RayMark::Kind>{RayMark::hit, RayMark::terminated, RayMark::leapt,
                                              RayMark::terminated});
    CHECK(plot.marks[0].from == doctest::Approx((42 + 0.25) * 2));
    CHECK(plot.marks[1].from == 44 * 2);
    CHECK(plot.marks[3].from == 37.25);
}

// A ray caster's ray that misses the box leaves the background; in object order the pixel
// is the warp's blend of intermediate pixels (traced after it), whatever its camera ray does.
TEST_CASE("a missed box says the pixel is the background only when the ray makes the pixel") {
    Trace by_ray, by_warp;
    by_warp.pixel_from_warp();
    by_ray.box_missed(Vec3d{255, 255, 224});
    by_warp.box_missed(Vec3d{255, 255, 224});
    for (const Trace* trace : {&by_ray, &by_warp}) {
        REQUIRE(trace->records().size() == 1);
        const TraceRecord box = trace->records()[0];  // records(): a copy
        CHECK(box.kind == TraceKind::box);
        CHECK(box.missed);  // the camera ray misses the box either way
        CHECK(box.number("box.k", 0) == 224);
    }
    CHECK(by_ray.lines()[0] ==
          "box (0, 0, 0)..(255, 255, 224): missed, the pixel shows the background");
    CHECK(by_warp.lines()[0] == "box (0, 0, 0)..(255, 255, 224): missed, but the pixel is the "
                                "warp's blend of the intermediate pixels traced below");
}

// Object order: the pixel is the warp's blend of up to four intermediate pixels, each traced
// after a note of its weight. Each one's samples are a line of their own: the value line does
// not run back from one pixel's last sample to the next one's first.
TEST_CASE("the intermediate pixels of a warp are drawn as lines of their own") {
    Trace trace;
    trace.pixel_from_warp();
    // Pixel A rises from -1000 to 1000 over t = 10..30, pixel B falls: joined, the line would
    // run back from (30, 1000) to (10, 1000), level along the top of the value panel.
    const double values[2][3] = {{-1000, 0, 1000}, {1000, 0, -1000}};
    for (int pixel = 0; pixel < 2; ++pixel) {
        trace.note({{"u", double(pixel)}, {"v", 0}, {"weight", 0.5}},
                   "intermediate pixel %d,0, weight 0.5000 in the warp: its ray", pixel);
        for (int n = 0; n < 3; ++n) {
            trace.sample(TraceSample(10.0 + 10 * n, Vec3d{0, 0, 2.0 * n}, values[pixel][n]));
        }
    }
    const RayPlot plot =
        ray_plot_from_trace(trace.records(), make_camera_view(64, 64), {}, Rgb{}, "warp");
    REQUIRE(plot.samples.size() == 6);
    for (size_t n = 0; n < plot.samples.size(); ++n) {
        CHECK(plot.samples[n].starts_line == (n % 3 == 0));
    }
    // Rows of the picture holding a level run of at least 60 pixels of the value line's colour
    // (ray_plot.cpp's value_colour): the line joined, not otherwise.
    auto level_runs = [](const Image& picture) {
        const Rgb line = {0.1f, 0.1f, 0.1f};
        int rows = 0;
        for (int y = 0; y < picture.height; ++y) {
            int run = 0, longest = 0;
            for (int x = 0; x < picture.width; ++x) {
                const Rgb c = picture.at(x, y);
                run = c.r == line.r && c.g == line.g && c.b == line.b ? run + 1 : 0;
                longest = std::max(longest, run);
            }
            rows += longest >= 60;
        }
        return rows;
    };
    RayPlot joined = plot;
    for (RaySample& sample : joined.samples) sample.starts_line = false;
    CHECK(level_runs(draw_ray_plot(joined, {}, 0, 0)) > 0);
    CHECK(level_runs(draw_ray_plot(plot, {}, 0, 0)) == 0);
}

TEST_CASE("the sidecar's records read back: kinds, flags, numbers; the text never parsed") {
    Trace trace;
    trace.sample(TraceSample(0, Voxel{3, 4, 0}, 500).threshold_hit(true));
    trace.crossing(7, 0.125);
    trace.gradient(Vec3{0.5f, -0.25f, 2.0f}, 0.75);
    trace.sample(TraceSample(9, Voxel{3, 4, 9}, 10).transparency(1.0 / 3.0));
    trace.box_missed(Vec3d{255, 255, 224});
    const std::vector<TraceRecord> records = trace.records();
    View view;
    view.ray_length = 100, view.ray_spacing = 1;
    const RayPlot plot = ray_plot_from_trace(records, view, {}, Rgb{}, "sidecar");
    const std::vector<TraceRecord> read = trace_records_from_text(ray_plot_text(plot));
    REQUIRE(read.size() == records.size());
    for (size_t n = 0; n < records.size(); ++n) {
        CAPTURE(n);
        CHECK(read[n].kind == records[n].kind);
        CHECK(read[n].text == records[n].text);
        CHECK(read[n].hit == records[n].hit);
        CHECK(read[n].missed == records[n].missed);
        REQUIRE(read[n].fields.size() == records[n].fields.size());
        for (size_t f = 0; f < records[n].fields.size(); ++f) {
            CHECK(read[n].fields[f].name == records[n].fields[f].name);
            // %.9g: nine significant digits survive
            CHECK(read[n].fields[f].number ==
                  doctest::Approx(records[n].fields[f].number).epsilon(1e-8));
        }
    }
    CHECK(read[0].hit);
    CHECK(read[1].kind == TraceKind::hit);
    CHECK(read[1].number("fraction", 0) == 0.125);
    CHECK(read[2].kind == TraceKind::shade);
    CHECK(read[2].number("gradient.k", 0) == 2.0);
    CHECK(read[4].missed);
    // A record line of an older sidecar, without the kind column, reads as a note.
    const std::vector<TraceRecord> old =
        trace_records_from_text("pixel 0 0 0\nrecord\tn=  1 value=5\tn=1 value=5\n");
    REQUIRE(old.size() == 1);
    CHECK(old[0].kind == TraceKind::note);
    CHECK(old[0].number("value", 0) == 5);
}

TEST_CASE("the ray picture's numbers are the text trace's, for every kind of step") {
    struct Case {
        std::string step;
        std::vector<std::string> flags;
        std::string file;  // the picture's stem
    };
    const std::vector<Case> cases = {
        {"02_threshold",
         {"--view", "front", "--debug-pixel", "128,30"},
         "02_threshold_front_ray_128_30"},
        {"05_interpolated_hits",
         {"--view", "front", "--debug-pixel", "128,30"},
         "05_interpolated_hits_front_ray_128_30"},
        {"08_compositing_order",
         {"--view", "top", "--debug-pixel", "100,128"},
         "08_compositing_order_top_ray_100_128"},
        {"10_opacity_correction",
         {"--view", "side", "--debug-pixel", "128,60", "--step", "0.5"},
         "10_opacity_correction_side_ray_128_60"},
        {"11_empty_space",
         {"--view", "front", "--debug-pixel", "128,30"},
         "11_empty_space_front_ray_128_30"},
        {"25_free_leaping", {"--debug-pixel", "280,300"}, "25_free_leaping_camera_ray_280_300"},
    };
    for (const Case& c : cases) {
        CAPTURE(c.step);
        ctlab::TempFolder out("ray_plot");
        // The phantom painted once (harness.h), not by each run.
        std::vector<std::string> flags = ctlab_test::phantom_flags();
        // --trace-only: the rays of the trace and its picture, not the whole render.
        flags.insert(flags.end(), {"--out", out.path(), "--trace-only"});
        flags.insert(flags.end(), c.flags.begin(), c.flags.end());
        const RunResult run = run_step(c.step, flags);
        REQUIRE(run.status == 0);
        REQUIRE(run.traces.size() == 1);
        const PixelTrace& trace = run.traces[0];
        REQUIRE(fs::is_regular_file(out.path(c.file + ".png")));
        const std::string sidecar = read_text(out.path(c.file + ".txt"));

        // Every trace line, in order, with the fields the plot is made of.
        std::vector<std::string> record_texts;
        for (const std::string& line : lines_starting(sidecar, "record\t")) {
            record_texts.push_back(line.substr(7, line.find('\t', 7) - 7));
        }
        CHECK(record_texts == trace.lines);

        // Each plotted sample is a sample line of the text, with the same numbers.
        std::vector<std::string> sample_lines;
        for (const std::string& line : trace.lines) {
            if (line.find("value=") != std::string::npos) sample_lines.push_back(line);
        }
        const std::vector<std::string> samples = lines_starting(sidecar, "sample ");
        REQUIRE(samples.size() == sample_lines.size());
        REQUIRE(samples.size() > 10);
        int with_colour = 0;
        for (size_t n = 0; n < samples.size(); ++n) {
            std::istringstream row(samples[n].substr(7));
            std::string t, index, value, alpha, transparency, light, r, g, b;
            row >> t >> index >> value >> alpha >> transparency >> light >> r >> g >> b;
            const std::string& line = sample_lines[n];
            check_equal_to_text(std::stod(value), line, "value", 0);
            if (line.find(" t=") != std::string::npos || line.rfind("t=", 0) == 0) {
                check_equal_to_text(std::stod(t), line, "t", 0);
            } else {
                check_equal_to_text(std::stod(index), line, "n", 0);
            }
            if (alpha != "-") check_equal_to_text(std::stod(alpha), line, "rgba", 3);
            if (transparency != "-") check_equal_to_text(std::stod(transparency), line, "T", 0);
            if (light != "-") check_equal_to_text(std::stod(light), line, "L", 0);
            if (r != "-") {
                ++with_colour;
                check_equal_to_text(std::stod(r), line, "C", 0);
                check_equal_to_text(std::stod(g), line, "C", 1);
                check_equal_to_text(std::stod(b), line, "C", 2);
            }
            CHECK((alpha == "-") == (line.find("rgba=") == std::string::npos));
        }
        if (c.step >= "06") CHECK(with_colour > 0);
        // The marks: a hit in the threshold steps, early termination where the text says so.
        const bool says_hit = std::any_of(trace.lines.begin(), trace.lines.end(), [](auto& l) {
            return l.find("hit") != std::string::npos;
        });
        const bool says_stop = std::any_of(trace.lines.begin(), trace.lines.end(), [](auto& l) {
            return l.find("termination") != std::string::npos;
        });
        CHECK(says_hit == !lines_starting(sidecar, "mark hit ").empty());
        CHECK(says_stop == !lines_starting(sidecar, "mark terminated ").empty());
    }
}

TEST_CASE("step 05 marks the interpolated crossing, step 11 its leaps, step 25 the box") {
    ctlab::TempFolder out("ray_plot_marks");
    const auto flags = [&](std::vector<std::string> more) {
        std::vector<std::string> all = ctlab_test::phantom_flags();
        // The sidecars are all that is read: the traced rays alone, no picture.
        all.insert(all.end(), {"--out", out.path(), "--trace-only", "--no-ray-picture"});
        all.insert(all.end(), more.begin(), more.end());
        return all;
    };
    REQUIRE(run_step("05_interpolated_hits", flags({"--view", "front", "--debug-pixel", "128,30"}))
                .status == 0);
    const std::string crossing = read_text(out.path("05_interpolated_hits_front_ray_128_30.txt"));
    const auto hits = lines_starting(crossing, "mark hit ");
    REQUIRE(hits.size() == 1);
    const double at = std::stod(hits[0].substr(9));
    CHECK(at != std::floor(at));  // between two samples, not on one

    REQUIRE(
        run_step("11_empty_space", flags({"--view", "front", "--debug-pixel", "128,30"})).status ==
        0);
    CHECK(!lines_starting(read_text(out.path("11_empty_space_front_ray_128_30.txt")), "mark leapt ")
               .empty());
    REQUIRE(run_step("25_free_leaping", flags({"--debug-pixel", "280,300"})).status == 0);
    CHECK(lines_starting(read_text(out.path("25_free_leaping_camera_ray_280_300.txt")), "mark box ")
              .size() == 1);
}

TEST_CASE("--trace-only: a whole run's traces, records and ray pictures, without its render") {
    // Part 1 (the other axis views beside the plot) and part 2 (the camera's image and the
    // volume's axis views): every file but the views' PNGs, byte for byte.
    const std::vector<std::vector<std::string>> cases = {
        {"11_empty_space", "--view", "front", "--debug-pixel", "128,30", "--debug-pixel", "40,20"},
        {"25_free_leaping", "--debug-pixel", "280,300"},
    };
    for (const std::vector<std::string>& c : cases) {
        CAPTURE(c[0]);
        ctlab::TempFolder whole("trace_whole"), traced("trace_only");
        std::vector<std::string> flags = ctlab_test::phantom_flags();
        flags.insert(flags.end(), c.begin() + 1, c.end());
        std::vector<std::string> whole_flags = flags, traced_flags = flags;
        whole_flags.insert(whole_flags.end(), {"--out", whole.path()});
        traced_flags.insert(traced_flags.end(), {"--out", traced.path(), "--trace-only"});
        const RunResult a = run_step(c[0], whole_flags);
        const RunResult b = run_step(c[0], traced_flags);
        REQUIRE(a.status == 0);
        REQUIRE(b.status == 0);
        CHECK(!a.summaries.empty());
        CHECK(b.summaries.empty());  // nothing rendered, nothing to sum up
        REQUIRE(b.traces.size() == a.traces.size());
        for (size_t n = 0; n < a.traces.size(); ++n) {
            CHECK(b.traces[n].header == a.traces[n].header);
            CHECK(b.traces[n].lines == a.traces[n].lines);
        }
        int ray_files = 0, view_pictures = 0;
        for (const auto& entry : fs::directory_iterator(whole.path())) {
            const std::string name = entry.path().filename().string();
            const fs::path same = fs::path(traced.path()) / name;
            if (name.find("_ray_", c[0].size()) == std::string::npos) {
                ++view_pictures;
                CHECK_MESSAGE(!fs::exists(same), name, " was written by --trace-only");
                continue;
            }
            ++ray_files;
            REQUIRE_MESSAGE(fs::is_regular_file(same), name, " is missing");
            CHECK_MESSAGE(read_text(same.string()) == read_text(entry.path().string()), name,
                          " differs from the whole run's");
        }
        CHECK(ray_files == 2 * int(a.traces.size()));  // a picture and its numbers each
        CHECK(view_pictures > 0);
        CHECK(std::distance(fs::directory_iterator(traced.path()), fs::directory_iterator()) ==
              ray_files);
    }
    // Nothing to trace, or a file of the whole picture asked for: one line, exit status 2.
    ctlab::TempFolder out("trace_refused");
    for (const std::vector<std::string>& extra :
         std::vector<std::vector<std::string>>{{}, {"--debug-pixel", "1,1", "--work-map"},
                                               {"--debug-pixel", "1,1", "--repeat", "3"}}) {
        std::vector<std::string> flags = ctlab_test::phantom_flags();
        flags.insert(flags.end(), {"--out", out.path(), "--trace-only"});
        flags.insert(flags.end(), extra.begin(), extra.end());
        const RunResult refused = run_step("02_threshold", flags);
        CHECK(refused.status == 2);
        CHECK(refused.err.find("--trace-only") != std::string::npos);
    }
}

TEST_CASE("a camera ray is drawn through the box in the volume's axis views") {
    // A 64 x 48 x 32 volume, spacing 1, 1, 2 (physical box 63 x 47 x 62). Rays parallel to an
    // axis, from outside the box: along i at j = 20, k = 30 (voxel 15); along k at i = 10,
    // j = 40. Each is a straight line across two of the three views and a point in the third:
    // the line is found as a run of the ray's red pixels in one row or one column.
    Volume volume;
    volume.nx = 64, volume.ny = 48, volume.nz = 32;
    volume.sx = 1, volume.sy = 1, volume.sz = 2;
    std::vector<RayPlotView> views = {{make_camera_view(64, 64), Image(64, 64)}};
    for (const View& view : views_named(volume, "all")) {
        views.push_back({view, Image(view.width, view.height)});
    }
    const Rgb red = {0.9f, 0.0f, 0.0f};  // the ray's colour (ray_plot.cpp's hit_colour)
    // How many rows, and how many columns, right of the plot hold a run of at least 60 red
    // pixels (a line across a 96-pixel view: two each, the sampled part is 2 pixels thick).
    auto long_runs = [&](const Image& picture, int* rows, int* columns) {
        constexpr int right_of_plot = 76 + 400, long_run = 60;
        *rows = *columns = 0;
        auto is_red = [&](int x, int y) {
            const Rgb c = picture.at(x, y);
            return c.r == red.r && c.g == red.g && c.b == red.b;
        };
        for (int y = 0; y < picture.height; ++y) {
            int run = 0, longest = 0;
            for (int x = right_of_plot; x < picture.width; ++x) {
                run = is_red(x, y) ? run + 1 : 0;
                longest = std::max(longest, run);
            }
            *rows += longest >= long_run;
        }
        for (int x = right_of_plot; x < picture.width; ++x) {
            int run = 0, longest = 0;
            for (int y = 0; y < picture.height; ++y) {
                run = is_red(x, y) ? run + 1 : 0;
                longest = std::max(longest, run);
            }
            *columns += longest >= long_run;
        }
    };
    auto field = [](const char* name, double number) {
        TraceField f;
        f.name = name, f.number = number;
        return f;
    };
    auto picture_of = [&](Vec3d origin, Vec3d direction, double entry, double exit) {
        TraceRecord ray, box;
        ray.kind = TraceKind::ray;
        box.kind = TraceKind::box;
        ray.text = "ray origin=(...) direction=(...)";
        ray.fields = {field("origin.i", origin.i),       field("origin.j", origin.j),
                      field("origin.k", origin.k),       field("direction.i", direction.i),
                      field("direction.j", direction.j), field("direction.k", direction.k)};
        box.text = "box (0, 0, 0)..(63, 47, 62): entry t=... exit t=...";
        box.fields = {field("t", entry), field("t_exit", exit)};
        const RayPlot plot =
            ray_plot_from_trace({ray, box}, views[0].view, {}, Rgb{}, "camera ray");
        REQUIRE(plot.has_ray);
        CHECK(plot.origin.i == origin.i);
        CHECK(plot.direction.k == direction.k);
        return draw_ray_plot(plot, views, 32, 32);
    };
    int rows = 0, columns = 0;
    // Along i: a row across top (i, j) and one across front (i, k); a point in side.
    long_runs(picture_of({-10, 20, 30}, {1, 0, 0}, 10, 73), &rows, &columns);
    CHECK(rows >= 3);
    CHECK(columns == 0);
    // Along k: a column down front (i, k) and one down side (j, k); a point in top.
    long_runs(picture_of({10, 40, -5}, {0, 0, 1}, 5, 67), &rows, &columns);
    CHECK(columns >= 3);
    CHECK(rows == 0);
}

TEST_CASE("golden ray pictures: the probe rays of data/reference/rays/ drawn again") {
    const std::string probes = read_text("data/reference/probes.txt");
    REQUIRE(!probes.empty());
    int compared = 0;
    bool whole_part1 = false, whole_part2 = false;  // a whole run drawn yet, in each part
    std::istringstream lines(probes);
    for (std::string line; std::getline(lines, line);) {
        std::istringstream words(line);
        std::string name, view, pixel, keep;
        words >> name >> view >> pixel >> keep;
        if (name.empty() || name[0] == '#' || keep != "picture") continue;
        CAPTURE(line);
        const std::string stem = name + "_" + view + "_ray_" + pixel.substr(0, pixel.find(',')) +
                                 "_" + pixel.substr(pixel.find(',') + 1);
        const std::string golden = "data/reference/rays/" + stem + ".png";
        REQUIRE(fs::is_regular_file(golden));
        ctlab::TempFolder out("ray_golden");
        // The phantom painted once (harness.h): the pictures are the built-in phantom's.
        std::vector<std::string> flags = ctlab_test::phantom_flags();
        flags.insert(flags.end(), {"--out", out.path(), "--debug-pixel", pixel});
        // A default run's step is the run's name; a variant's (NN_name_VARIANT) is the step
        // whose name starts it, with the manifest line's arguments.
        std::string step = name, drawn_stem = stem;
        if (!fs::exists("steps/" + name + ".cpp")) {
            for (const auto& entry : fs::directory_iterator("steps")) {
                const std::string file = entry.path().stem().string();
                if (name.rfind(file + "_", 0) == 0) step = file;
            }
            REQUIRE(step != name);
            drawn_stem = step + stem.substr(name.size());
            std::istringstream manifest(read_text("data/reference/manifest.txt"));
            bool listed = false;
            for (std::string entry; std::getline(manifest, entry);) {
                if (entry.rfind(name + ":", 0) != 0) continue;
                listed = true;
                std::istringstream words_of(entry.substr(name.size() + 1));
                for (std::string word; words_of >> word;) {
                    if (word.rfind("tol=", 0) == 0 || word.rfind("counters=", 0) == 0) continue;
                    flags.push_back(word);
                }
            }
            REQUIRE_MESSAGE(listed, name, " is not a run of data/reference/manifest.txt");
        }
        if (view != "camera") flags.insert(flags.end(), {"--view", view});
        // The first probe of each part from a whole run (its rendered views in the picture),
        // the others with --trace-only (only the pixels the picture shows, cast alone): both
        // must draw the golden picture.
        bool& whole = view == "camera" ? whole_part2 : whole_part1;
        if (whole) flags.push_back("--trace-only");
        whole = true;
        REQUIRE(run_step(step, flags).status == 0);
        const Image drawn = read_image(out.path(drawn_stem + ".png"));
        const Image reference = read_image(golden);
        REQUIRE(drawn.width == reference.width);
        REQUIRE(drawn.height == reference.height);
        const Comparison comparison = compare_images(drawn, reference, 2);
        CHECK_MESSAGE(comparison.over_tol_pct < 0.5, stem, ": ", comparison.over_tol_pct,
                      "% of the pixels differ (new golden pictures: make reference)");
        ++compared;
    }
    CHECK(compared >= 8);
}

TEST_CASE("a failed run writes no ray picture (all pictures or none)") {
    // The phantom painted once (harness.h), not by each run.
    const std::vector<std::string> flags = ctlab_test::phantom_flags();
    auto with = [&](std::vector<std::string> more) {
        more.insert(more.begin(), flags.begin(), flags.end());
        return more;
    };
    ctlab::TempFolder out("ray_none");
    const RunResult run = run_step(
        "08_compositing_order",
        with({"--out", out.path(), "--view", "top", "--debug-pixel", "100,128"}), 120);
    REQUIRE(run.status == 0);
    // The same run with the third file written failing as if the disk were full: nothing.
    ctlab::TempFolder out2("ray_none2");
    setenv(fail_write_variable, "2", 1);
    const RunResult failed = run_step(
        "08_compositing_order",
        with({"--out", out2.path(), "--view", "top", "--debug-pixel", "100,128"}));
    unsetenv(fail_write_variable);
    CHECK(failed.status == 2);
    CHECK(fs::is_empty(out2.path()));
}
