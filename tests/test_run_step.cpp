// test_run_step.cpp: the seam the tests, bench and study use to drive the steps
// (tools/run_step.h): a step binary run as a process, its summary lines and traces parsed, its
// --pfm float image read back and checked against its PNG, --repeat's cold and warm times,
// and the analytic raw volume written for --volume/--dims.
#include <doctest/doctest.h>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include "error.h"
#include "image.h"
#include "tools/run_step.h"
#include "volume.h"

using namespace ctlab;

TEST_CASE("run_step: summary lines are key=value words") {
    const Summary s = parse_summary("step=03_x view=front size=4x5 time_ms=1.5 odd word= =v");
    CHECK(s.at("step") == "03_x");
    CHECK(s.at("size") == "4x5");
    CHECK(summary_number(s, "time_ms") == 1.5);
    CHECK(s.at("word") == "");
    CHECK(s.count("odd") == 0);
    CHECK(s.count("") == 0);
    CHECK_THROWS(summary_number(s, "samples"));
}

TEST_CASE("run_step: exit status, stderr, timeout and a program that does not exist") {
    const RunResult ok = run_program("/bin/sh", {"-c", "echo out; echo err >&2; exit 3"});
    CHECK(ok.status == 3);
    CHECK(ok.out == "out\n");
    CHECK(ok.err == "err\n");
    CHECK_FALSE(ok.timed_out);
    const RunResult slow = run_program("/bin/sleep", {"5"}, 0.2);
    CHECK(slow.timed_out);
    CHECK(slow.status == 128 + 9);
    const RunResult missing = run_program("/no/such/program", {});
    CHECK(missing.status == 127);
    CHECK(missing.err.find("cannot run /no/such/program") != std::string::npos);
    const RunResult bad = run_step("03_depth_shading", {"--repeat", "0"});
    CHECK(bad.status == 2);
    CHECK(bad.err.find("--repeat: expected a whole number from 1 to 1000") != std::string::npos);
}

TEST_CASE("run_step: --pfm writes the float image, its PNG is the same rounded; traces parse") {
    // A ramp along k, 0..300 in steps of 10, in a 5x4x31 volume: step 01's MIP (the display
    // grey of the maximum, (max - min)/(max - min) in the top view) is 1 at every top pixel;
    // the front view at row k shows (10k + 3i*0)/300.
    Volume volume;
    volume.nx = 5;
    volume.ny = 4;
    volume.nz = 31;
    volume.sz = 2;
    resize_dense(volume);
    for (int k = 0; k < volume.nz; ++k)
        for (int j = 0; j < volume.ny; ++j)
            for (int i = 0; i < volume.nx; ++i) volume.data[volume.index(i, j, k)] = 10 * k;
    const TempFolder folder("run_step");
    std::vector<std::string> flags = write_raw_volume(volume, folder.path("ramp.raw"));
    CHECK(flags[3] == "5,4,31");
    CHECK(flags[5] == "1,1,2");
    flags.insert(flags.end(), {"--out", folder.path(), "--pfm", "--threads", "1", "--repeat",
                               "3", "--debug-pixel", "2,7"});
    const RunResult run = run_step("01_ray_loops", flags);
    INFO(run.command() << "\n" << run.out << run.err);
    REQUIRE(run.status == 0);
    REQUIRE(run.summaries.size() == 3);
    const Summary& front = run.summary("front");
    CHECK(front.at("size") == "5x31");
    CHECK(summary_count(front, "samples") == 5 * 31 * 4);
    CHECK(summary_number(front, "time_ms") >= 0);
    CHECK(summary_number(front, "warm_ms") >= 0);
    CHECK(front.at("repeat") == "3");
    for (const char* view : {"top", "front", "side"}) {
        CAPTURE(view);
        const Image pfm = read_pfm(step_output(folder.path(), "01_ray_loops", view, "pfm"));
        const Image png = read_image(step_output(folder.path(), "01_ray_loops", view, "png"));
        REQUIRE(pfm.width == png.width);
        REQUIRE(pfm.height == png.height);
        int differ = 0;
        for (size_t n = 0; n < pfm.pixels.size(); ++n) {
            differ += to_byte(pfm.pixels[n].r) != to_byte(png.pixels[n].r);
        }
        CHECK(differ == 0);
    }
    const Image front_pfm = read_pfm(step_output(folder.path(), "01_ray_loops", "front", "pfm"));
    for (int y = 0; y < front_pfm.height; ++y) {
        CHECK(front_pfm.at(0, y).r == doctest::Approx(y / 30.0).epsilon(1e-6));  // row y = k
    }
    // The trace of pixel 2,7: only the front and side views are that tall (top is 5x4).
    REQUIRE(run.traces.size() == 2);
    for (const PixelTrace& trace : run.traces) {
        CHECK(trace.complete);
        CHECK(trace.x == 2);
        CHECK(trace.y == 7);
        CHECK(trace.rgb.r == doctest::Approx(70.0 / 300).epsilon(1e-5));
        const Image pfm = read_pfm(step_output(folder.path(), "01_ray_loops", trace.view, "pfm"));
        CHECK(std::abs(trace.rgb.r - pfm.at(2, 7).r) <= 5e-7);
        CHECK(trace.png[0] == to_byte(pfm.at(2, 7).r));
        CHECK(trace.samples == trace.lines.size());  // one line per sample in step 01
    }
    CHECK(run.traces[0].view == "front");
    CHECK(run.traces[0].samples == 4);  // the front ray runs over j
}

TEST_CASE("run_step: read_pfm reads both byte orders and rows bottom to top") {
    const TempFolder folder("pfm");
    auto bytes_of = [](const std::string& header, const std::vector<float>& values, bool big) {
        std::vector<unsigned char> bytes(header.begin(), header.end());
        for (float value : values) {
            unsigned char b[4];
            std::memcpy(b, &value, 4);  // this machine: little-endian (x86, arm64 Linux)
            for (int n = 0; n < 4; ++n) bytes.push_back(big ? b[3 - n] : b[n]);
        }
        return bytes;
    };
    // 1 wide, 2 high: the bottom row first in the file.
    const std::vector<float> values = {0.25f, 0.5f, 0.75f, 1.5f, -2.0f, 3.0f};
    const Image little = read_pfm(folder.file("l.pfm", bytes_of("PF\n1 2\n-1.0\n", values, false)));
    const Image big = read_pfm(folder.file("b.pfm", bytes_of("PF\n1 2\n1.0\n", values, true)));
    for (const Image& image : {little, big}) {
        REQUIRE(image.width == 1);
        REQUIRE(image.height == 2);
        CHECK(image.at(0, 1).r == 0.25f);  // bottom row
        CHECK(image.at(0, 0).g == -2.0f);  // top row
        CHECK(image.at(0, 0).b == 3.0f);
    }
    CHECK_THROWS_AS(read_pfm(folder.file("short.pfm", bytes_of("PF\n1 2\n-1.0\n", {1}, false))),
                    InputError);
    CHECK_THROWS_AS(read_pfm(folder.text_file("p6.pfm", std::string("P6\n1 1\n255\nabc"))),
                    InputError);
    CHECK_THROWS_AS(read_pfm(folder.text_file("huge.pfm", std::string("PF\n99999999 1\n-1\n"))),
                    InputError);
}

TEST_CASE("run_step: no program outside steps/ compiles a step's source") {
    // The seam: tests, tools and common/ run the step binaries, never #include a .cpp, so
    // a lesson function's name and signature are the step's own business.
    int files = 0;
    std::string offenders;
    for (const char* folder : {"common", "tests", "tools"}) {
        for (const auto& entry : std::filesystem::recursive_directory_iterator(folder)) {
            const std::string ext = entry.path().extension().string();
            if (ext != ".cpp" && ext != ".h") continue;
            ++files;
            std::ifstream in(entry.path());
            for (std::string line; std::getline(in, line);) {
                const size_t start = line.find_first_not_of(" \t");
                if (start == std::string::npos || line.compare(start, 8, "#include") != 0) {
                    continue;
                }
                if (line.find(".cpp") != std::string::npos ||
                    line.find("steps/") != std::string::npos) {
                    offenders += "\n  " + entry.path().string() + ": " + line;
                }
            }
        }
    }
    CHECK_MESSAGE(offenders.empty(), "a step's source included outside steps/:" << offenders);
    CHECK(files > 20);
    CHECK_FALSE(std::filesystem::exists("tools/all_steps.h"));
}
