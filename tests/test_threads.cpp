// test_threads.cpp: the parallel pixel loop changes how fast a picture comes, never what it
// is. Every step, every view, a few non-default settings: 1, 2, 3 and 7 threads give the same
// pixels bit for bit and the same work counts (make bench times the same renders).
#include <doctest/doctest.h>
#include <atomic>
#include <cstring>
#include <string>
#include <vector>
#include "harness.h"
#include "phantom.h"
#include "render.h"

using namespace ctlab;

namespace {

constexpr int thread_counts[] = {1, 2, 3, 7};  // 7: more threads than this machine has cores

// The phantom, small: 64 x 64 x 29 keeps every step's rays short.
const Volume& small_phantom() {
    static const Volume volume = make_phantom_sized(64, 64, 29);
    return volume;
}

struct Render {
    std::vector<Image> images;  // top, front, side
    std::vector<Work> works;
};

Render render_with_threads(const std::string& step, std::vector<std::string> flags,
                           int threads) {
    flags.push_back("--threads");
    flags.push_back(std::to_string(threads));
    Render render;
    const int status = ctlab_test::run_step(step, flags, small_phantom(),
        [&](const Options& options, const Volume& volume, const Renderer& renderer) {
            for (const View& view : views_named(volume, "all")) {
                Work work;
                render.images.push_back(render_view(options, view, renderer, work));
                render.works.push_back(work);
            }
        });
    CHECK(status == 0);
    return render;
}

bool identical(const Image& a, const Image& b) {
    return a.width == b.width && a.height == b.height &&
           std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(Rgb)) == 0;
}

void check_same_for_every_thread_count(const std::string& step,
                                       const std::vector<std::string>& flags) {
    const Render one = render_with_threads(step, flags, 1);
    REQUIRE(one.images.size() == 3);
    for (const int threads : thread_counts) {
        if (threads == 1) continue;
        CAPTURE(threads);
        const Render many = render_with_threads(step, flags, threads);
        REQUIRE(many.images.size() == 3);
        for (size_t v = 0; v < 3; ++v) {
            CAPTURE(v);
            CHECK(identical(one.images[v], many.images[v]));
            CHECK(one.works[v].samples == many.works[v].samples);
            CHECK(one.works[v].skipped == many.works[v].skipped);
            CHECK(one.works[v].leapt == many.works[v].leapt);
            CHECK(one.works[v].gradients == many.works[v].gradients);
            CHECK(one.works[v].terminated == many.works[v].terminated);
            CHECK(one.works[v].hits == many.works[v].hits);
        }
    }
}

}  // namespace

TEST_CASE("threads: every step and view gives the same pixels with 1, 2, 3 and 7 threads") {
    for (const auto& step : ctlab_test::included_steps()) {
        CAPTURE(step.name);
        check_same_for_every_thread_count(step.name, {});
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
        {"06_transfer_function", {"--skin-opacity", "0.5"}},
        {"07_compositing_order", {"--order", "b2f"}},
        {"07_compositing_order", {"--ert", "0"}},
        {"08_lit_compositing", {"--step", "0.5"}},
        {"08_lit_compositing", {"--step", "4", "--no-correction", "--ert", "0.1"}},
        {"08_lit_compositing", {"--unlit"}},
        {"09_empty_space", {"--no-leaping"}},
        {"09_empty_space", {"--step", "0.3"}},
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
