// test_threads.cpp: the parallel pixel loop changes how fast a picture comes, never what it
// is. Every step, every view, a few non-default settings: 1, 2, 3 and 7 threads give the same
// pixels bit for bit (the --pfm float images) and the same summary lines but for time and
// thread count (make bench times the same renders). The steps run as programs (harness.h).
#include <doctest/doctest.h>
#include <atomic>
#include <cstring>
#include <string>
#include <thread>
#include <vector>
#include "harness.h"
#include "render.h"

using namespace ctlab;

namespace {

constexpr int thread_counts[] = {1, 2, 3, 7};  // 7: more threads than this machine has cores

// The phantom, small: 64 x 64 x 29 keeps every step's rays short.
const std::vector<std::string> small_phantom = {"--volume", "phantom", "--dims", "64,64,29"};

ctlab_test::StepRender render_with_threads(const std::string& step,
                                           std::vector<std::string> flags, int threads) {
    flags.insert(flags.end(), small_phantom.begin(), small_phantom.end());
    // Part 2: a camera picture of 64 x 48 pixels (rows enough to share among 7 threads).
    if (ctlab_test::is_camera_step(step)) flags.insert(flags.end(), {"--size", "64x48"});
    flags.push_back("--threads");
    flags.push_back(std::to_string(threads));
    return ctlab_test::render(step, flags);
}

bool identical(const Image& a, const Image& b) {
    return a.width == b.width && a.height == b.height &&
           std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(Rgb)) == 0;
}

// The summary line's counters: every key but the timing and the thread count.
Summary counters(Summary summary) {
    for (const char* key : {"time_ms", "warm_ms", "warmup_ms", "precompute_ms", "threads"}) {
        summary.erase(key);  // precompute_ms: step 38's one-off tables, a time too
    }
    return summary;
}

void check_same_for_every_thread_count(const std::string& step,
                                       const std::vector<std::string>& flags) {
    const ctlab_test::StepRender one = render_with_threads(step, flags, 1);
    const size_t pictures = ctlab_test::is_camera_step(step) ? 1 : 3;
    REQUIRE(one.images.size() == pictures);
    for (const int threads : thread_counts) {
        if (threads == 1) continue;
        CAPTURE(threads);
        const ctlab_test::StepRender many = render_with_threads(step, flags, threads);
        REQUIRE(many.images.size() == pictures);
        for (size_t v = 0; v < pictures; ++v) {
            CAPTURE(one.views[v]);
            REQUIRE(one.views[v] == many.views[v]);
            CHECK(identical(one.images[v], many.images[v]));  // the float images, bit for bit
            const Summary& a = one.run.summaries[v];
            const Summary& b = many.run.summaries[v];
            CHECK(summary_count(b, "threads") == uint64_t(threads));
            // samples, skipped, leapt, gradients, terminated, hits and the step's own
            for (const char* key : {"samples", "skipped", "leapt", "gradients", "terminated",
                                    "hits"}) {
                CAPTURE(key);
                CHECK(summary_count(a, key) == summary_count(b, key));
            }
            CHECK(counters(a) == counters(b));
            CHECK(summary_count(a, "samples") > 0);
        }
    }
}

}  // namespace

TEST_CASE("threads: every step and view gives the same pixels with 1, 2, 3 and 7 threads") {
    for (const std::string& step : ctlab_test::step_names()) {
        CAPTURE(step);
        check_same_for_every_thread_count(step, {});
    }
}

TEST_CASE("threads: non-default settings are thread-independent too") {
    struct Variant {
        const char* step;
        std::vector<std::string> flags;
    };
    const Variant variants[] = {
        {"00_slices", {"--equalise"}},
        {"03_depth_shading", {"--threshold", "-500"}},
        {"05_interpolated_hits", {"--threshold", "1000", "--light-angle", "-60"}},
        {"07_back_to_front", {"--skin-opacity", "0.5"}},
        {"08_compositing_order", {"--order", "b2f"}},
        {"08_compositing_order", {"--ert", "0"}},
        {"10_opacity_correction", {"--step", "0.5"}},
        {"10_opacity_correction", {"--step", "4", "--no-correction", "--ert", "0.1"}},
        {"10_opacity_correction", {"--unlit"}},
        {"11_empty_space", {"--no-leaping"}},
        {"11_empty_space", {"--step", "0.3"}},
    };
    for (const Variant& variant : variants) {
        CAPTURE(variant.step);
        CAPTURE(variant.flags.front());
        check_same_for_every_thread_count(variant.step, variant.flags);
    }
}

TEST_CASE("threads: parallel_rows visits every row once and sums every thread's work") {
    for (const int height : {1, 2, 5, 64}) {
        for (const int threads : {1, 2, 3, 7, 100}) {
            CAPTURE(height);
            CAPTURE(threads);
            std::vector<std::atomic<int>> visits(height);
            for (auto& count : visits) count = 0;
            Work total;
            total.hits = 1000;  // counts already there are kept, not overwritten
            parallel_rows(height, threads, total, [&](int y, Work& work) {
                ++visits[y];
                work.samples += uint64_t(y) + 1;
                ++work.terminated;
            });
            int wrong = 0;
            for (const auto& count : visits) wrong += count != 1;
            CHECK(wrong == 0);
            CHECK(total.samples == uint64_t(height) * (height + 1) / 2);
            CHECK(total.terminated == uint64_t(height));
            CHECK(total.hits == 1000);
        }
    }
}

TEST_CASE("threads: the pool serves many renders, nested and concurrent ones, each in full") {
    // Renders back to back (workers awake or asleep), a render started from inside a row (it
    // runs on that thread), and two threads rendering at once (one of them alone): every row
    // once, every count summed.
    auto check_render = [](int height, int threads) {
        std::vector<std::atomic<int>> visits(height);
        for (auto& count : visits) count = 0;
        Work total;
        parallel_rows(height, threads, total, [&](int y, Work& work) {
            ++visits[y];
            work.samples += uint64_t(y) + 1;
            if (y % 7 == 0) {  // a nested render: 3 rows, 2 threads
                Work inner;
                parallel_rows(3, 2, inner, [](int, Work& w) { ++w.hits; });
                work.hits += inner.hits;
            }
        });
        int wrong = 0;
        for (const auto& count : visits) wrong += count != 1;
        uint64_t nested = 0;
        for (int y = 0; y < height; y += 7) nested += 3;
        return wrong == 0 && total.samples == uint64_t(height) * (height + 1) / 2 &&
               total.hits == nested;
    };
    int failed = 0;
    for (int n = 0; n < 300; ++n) failed += !check_render(1 + n % 40, 2 + n % 3);
    CHECK(failed == 0);
    std::atomic<int> failed_elsewhere{0};
    std::thread other([&] {
        for (int n = 0; n < 100; ++n) failed_elsewhere += !check_render(50, 2);
    });
    for (int n = 0; n < 100; ++n) failed += !check_render(50, 2);
    other.join();
    CHECK(failed == 0);
    CHECK(failed_elsewhere == 0);
    CHECK(start_render_threads(2) == 2);
}
