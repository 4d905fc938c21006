// test_golden.cpp: every step and every view, rendered on the phantom as the default run does,
// against data/reference/NN_name_<view>.png; and no NaN or infinity in any pixel before the
// PNG conversion (which would hide it as black).
//
// Tolerance (8-bit units, both pictures quantised as build/check does): every channel within
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
#include "compare.h"
#include "error.h"
#include "harness.h"
#include "image.h"
#include "phantom.h"
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

TEST_CASE("golden: the tests include every step in steps/") {
    // Part 1's steps (00..09) run in-process here; part 2's (10 on) render a camera's image
    // and are driven as programs (tests/test_free_camera.cpp, its golden case included).
    std::vector<std::string> in_folder;
    for (const std::string& name : steps_in_folder()) {
        if (name < "10") in_folder.push_back(name);
    }
    std::vector<std::string> in_tests;
    for (const auto& step : ctlab_test::included_steps()) in_tests.push_back(step.name);
    std::string missing;
    for (const std::string& name : in_folder) {
        if (std::find(in_tests.begin(), in_tests.end(), name) == in_tests.end()) {
            missing += " " + name;
        }
    }
    CHECK_MESSAGE(missing.empty(),
                  "steps not compiled into the tests (add them to "
                  "tools/all_steps.h):"
                      << missing);
    CHECK(in_tests == in_folder);
    CHECK(in_folder.size() >= 6);
}

TEST_CASE("golden: every step and view on the phantom matches its reference, no NaN") {
    const Volume phantom = make_phantom();
    const fs::path references = repository() / "data" / "reference";
    int compared = 0;
    for (const auto& step : ctlab_test::included_steps()) {
        CAPTURE(step.name);
        const int status = ctlab_test::run_step(
            step.name, {"--volume", "phantom", "--no-window"}, phantom,
            [&](const Options& options, const Volume& volume, const Renderer& renderer) {
                for (const View& view : views_named(volume, options.view)) {
                    CAPTURE(view.name);
                    Work work;
                    const Image image = render_view(options, view, renderer, work);
                    CHECK(non_finite_pixels(image) == 0);
                    CHECK(work.samples > 0);

                    const fs::path path = references / (step.name + "_" + view.name + ".png");
                    if (!fs::exists(path)) {
                        FAIL_CHECK("missing reference "
                                   << path.string() << "; generate with: " << regenerate_command);
                        continue;
                    }
                    const Image reference = read_image(path.string());
                    REQUIRE(reference.width == image.width);
                    REQUIRE(reference.height == image.height);
                    const Comparison c = compare_images(image, reference, golden_near_tolerance,
                                                        "the in-process render", path.string());
                    INFO(path.string() << ": " << comparison_line(c));
                    CHECK(c.max_abs <= golden_max_abs);
                    CHECK(c.over_tol_pct <= golden_max_over_pct);
                    ++compared;
                }
            });
        CHECK(status == 0);
    }
    CHECK(compared == 3 * int(ctlab_test::included_steps().size()));
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
    for (const std::string& step : steps) pictures += step < "10" ? 3 : 1;
    CHECK(checked >= pictures);
}
