// test_work_map.cpp: --work-map (common/step.h) writes every ray's work counters, the ones
// make check compares ray by ray to name the first ray whose work differs. Each ray's counts,
// traced alone, add up to the summary line's of the picture's own render, for a part-1 step
// with a whole-image renderer, one with leaping and the first part-2 step (the free camera,
// found by its --azimuth flag, not by its name).
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "harness.h"
#include "tools/run_step.h"

using namespace ctlab;
namespace fs = std::filesystem;

namespace {

const char* const counter_names[6] = {"samples", "skipped", "leapt", "gradients", "terminated",
                                      "hits"};

// The sums of a work map's rays, read independently of the grader's reader: every "N*a,b,..."
// word of every row, N rays with those counts.
std::vector<unsigned long long> map_sums(const std::string& path, int& width, int& height,
                                         long long& rays) {
    std::ifstream in(path);
    std::string line, word;
    std::getline(in, line);
    std::istringstream head(line);
    head >> word >> width >> height;
    std::getline(in, line);  // total
    std::vector<unsigned long long> sums(6, 0);
    rays = 0;
    while (std::getline(in, line)) {
        std::istringstream words(line);
        words >> word;  // "Y:"
        while (words >> word) {
            long long count = 1;
            const size_t star = word.find('*');
            if (star != std::string::npos) {
                count = std::atoll(word.c_str());
                word = word.substr(star + 1);
            }
            std::istringstream numbers(word);
            for (int c = 0; c < 6; ++c) {
                unsigned long long value = 0;
                char comma = 0;
                numbers >> value;
                if (c < 5) numbers >> comma;
                sums[c] += value * count;
            }
            rays += count;
        }
    }
    return sums;
}

std::string first_step_with(const std::string& flag) {
    std::vector<fs::path> sources;
    for (const auto& entry : fs::directory_iterator("steps")) sources.push_back(entry.path());
    std::sort(sources.begin(), sources.end());
    for (const fs::path& source : sources) {
        std::ifstream in(source);
        std::stringstream text;
        text << in.rdbuf();
        if (text.str().find(flag) != std::string::npos) {
            return source.stem().string();
        }
    }
    return "";
}

}  // namespace

TEST_CASE("--work-map: each ray's counts add up to the summary line's") {
    // The first part-2 step: its camera flags come from common/camera_flags.h.
    const std::string camera_step = first_step_with("add_camera_flags(args");
    std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
        {"01_ray_loops", {"--view", "front"}},
        {"11_empty_space", {"--view", "side"}},
    };
    if (!camera_step.empty()) cases.push_back({camera_step, {"--size", "96x80"}});
    for (const auto& [step, flags] : cases) {
        CAPTURE(step);
        if (!fs::exists(step_binary(step))) continue;  // a tree without that step
        TempFolder folder("work_map");
        std::vector<std::string> arguments = {"--volume", "phantom", "--out", folder.path(),
                                              "--work-map", "--threads", "2"};
        arguments.insert(arguments.end(), flags.begin(), flags.end());
        const RunResult run = run_step(step, arguments);
        REQUIRE(run.status == 0);
        REQUIRE(run.summaries.size() == 1);
        const Summary& summary = run.summaries[0];
        const std::string path =
            folder.path() + "/" + step + "_" + summary.at("view") + "_work.txt";
        REQUIRE(fs::exists(path));
        int width = 0, height = 0;
        long long rays = 0;
        const std::vector<unsigned long long> sums = map_sums(path, width, height, rays);
        CHECK(summary.at("size") == std::to_string(width) + "x" + std::to_string(height));
        CHECK(rays == static_cast<long long>(width) * height);
        for (int c = 0; c < 6; ++c) {
            CAPTURE(counter_names[c]);
            CHECK(sums[c] == summary_count(summary, counter_names[c]));
        }
    }
}
