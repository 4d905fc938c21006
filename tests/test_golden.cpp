// test_golden.cpp: every step and every view, rendered on the phantom as the default run does,
// against data/reference/NN_name_<view>.png; and no NaN or infinity in any pixel before the
// PNG conversion (which would hide it as black).
//
// Tolerance (8-bit units, both pictures quantised as build/grade does): every channel within
// 2, and at most 0.1% of the pixels with a channel more than 1 off. New references after an
// intended change: make reference (tools/make_reference.sh).
#include <doctest/doctest.h>
#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>
#include <string>
#include <vector>
#include "tools/compare.h"
#include "error.h"
#include "harness.h"
#include "image.h"
#include "view.h"

using namespace ctlab;
namespace fs = std::filesystem;

namespace {

constexpr int golden_max_abs = 2;            // 8-bit units: the largest channel error allowed
constexpr double golden_near_tolerance = 1;  // 8-bit units: "off by more than rounding"
constexpr double golden_max_over_pct = 0.1;  // % of pixels allowed more than 1 off
const std::string regenerate_command = "make reference";

// The repository: the current folder when the tests run from it (make test), else the
// folder above the test binary's (build/ctlab_tests).
fs::path repository() {
    if (fs::is_directory("steps") && fs::is_directory("data")) return ".";
    std::error_code error;
    const fs::path binary = fs::read_symlink("/proc/self/exe", error);
    return error ? fs::path(".") : binary.parent_path().parent_path();
}

// "03_depth_shading" for every steps/NN_name.cpp, sorted.
std::vector<std::string> steps_in_folder() {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(repository() / "steps")) {
        const std::string file = entry.path().filename().string();
        const bool numbered = file.size() > 7 &&
                              std::isdigit(static_cast<unsigned char>(file[0])) &&
                              std::isdigit(static_cast<unsigned char>(file[1])) && file[2] == '_';
        if (numbered && entry.path().extension() == ".cpp") names.push_back(entry.path().stem());
    }
    std::sort(names.begin(), names.end());
    return names;
}

int non_finite_pixels(const Image& image) {
    int count = 0;
    for (const Rgb& p : image.pixels) {
        if (!std::isfinite(p.r) || !std::isfinite(p.g) || !std::isfinite(p.b)) ++count;
    }
    return count;
}

}  // namespace

TEST_CASE("golden: every step in steps/ has its binary beside the tests") {
    const std::vector<std::string> in_folder = steps_in_folder();
    // part1_step_names() have three axis views each; part 2's steps (13 on) render one
    // camera picture and have their golden test in tests/test_free_camera.cpp.
    std::vector<std::string> part1;
    for (const std::string& name : in_folder) {
        if (name < "13") part1.push_back(name);
    }
    CHECK(part1 == ctlab_test::part1_step_names());
    CHECK(in_folder == ctlab_test::step_names());
    std::string missing;
    for (const std::string& name : in_folder) {
        if (access(step_binary(name).c_str(), X_OK) != 0) missing += " " + name;
    }
    CHECK_MESSAGE(missing.empty(), "steps not built beside the tests (make all):" << missing);
    CHECK(in_folder.size() >= 6);
}

TEST_CASE("golden: every step and view on the phantom matches its reference, no NaN") {
    const fs::path references = repository() / "data" / "reference";
    int compared = 0;
    for (const std::string& step : ctlab_test::part1_step_names()) {
        CAPTURE(step);
        // The default run, as make reference renders it; the float image read back (--pfm).
        const ctlab_test::StepRender run =
            ctlab_test::render(step, {"--volume", "phantom", "--view", "all"});
        REQUIRE(run.images.size() == 3);
        for (size_t n = 0; n < run.views.size(); ++n) {
            const std::string& view = run.views[n];
            CAPTURE(view);
            const Image& image = run.images[n];
            CHECK(non_finite_pixels(image) == 0);
            CHECK(summary_count(run.summary(view), "samples") > 0);

            const fs::path path = references / (step + "_" + view + ".png");
            if (!fs::exists(path)) {
                FAIL_CHECK("missing reference " << path.string()
                                                << "; generate with: " << regenerate_command);
                continue;
            }
            const Image reference = read_image(path.string());
            REQUIRE(reference.width == image.width);
            REQUIRE(reference.height == image.height);
            const Comparison c = compare_images(image, reference, golden_near_tolerance,
                                                "the float render (--pfm)", path.string());
            INFO(path.string() << ": " << comparison_line(c));
            CHECK(c.max_abs <= golden_max_abs);
            CHECK(c.over_tol_pct <= golden_max_over_pct);
            ++compared;
        }
    }
    CHECK(compared == 3 * int(ctlab_test::part1_step_names().size()));
}

TEST_CASE("golden: every reference image belongs to an existing step and view") {
    const std::vector<std::string> steps = steps_in_folder();
    const std::set<std::string> step_set(steps.begin(), steps.end());
    int checked = 0;
    for (const auto& entry : fs::directory_iterator(repository() / "data" / "reference")) {
        const std::string file = entry.path().filename().string();
        // Only NN_name_<view>.png: variants (..._front_skin030.png) belong to a step's handout.
        std::string step;
        for (const char* view : {"_top.png", "_front.png", "_side.png", "_camera.png"}) {
            const std::string ending = view;
            if (file.size() > ending.size() &&
                file.compare(file.size() - ending.size(), ending.size(), ending) == 0) {
                step = file.substr(0, file.size() - ending.size());
            }
        }
        if (step.empty() || !std::isdigit(static_cast<unsigned char>(file[0]))) continue;
        CHECK_MESSAGE(step_set.count(step) == 1,
                      file << " is a reference for no step in steps/ (renamed or removed?)");
        ++checked;
    }
    int pictures = 0;  // three views per part 1 step, one camera picture per part 2 step
    for (const std::string& step : steps) pictures += step < "13" ? 3 : 1;
    CHECK(checked >= pictures);
}
