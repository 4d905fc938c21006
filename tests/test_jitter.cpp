// test_jitter.cpp: steps 16 (jitter by a hash) and 14 (blue noise) run as programs
// (tools/run_step.h). Without jitter each is step 15 bit for bit; the hash's offsets are
// uniform on [0, 1) and the same in every run; the blue-noise tile holds every rank once and
// has far less low-frequency power than white noise (the analytic flat spectrum); the trace
// shows the offset; and on a ball, jitter removes the rings a fixed sample grid draws
// (measured as the error that survives averaging along rings).
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>
#include "harness.h"
#include "image.h"
#include "tools/run_step.h"
#include "volume.h"

using namespace ctlab;

namespace {

const std::string jitter_step = "17_blue_noise";  // every mode: none, hash, blue
const std::string hash_step = "16_jitter";        // none and hash
const std::string free_camera = "15_trilinear";
constexpr int tile = 64;  // the blue-noise tile's side, as handouts/17_blue_noise.md says
constexpr double pi = 3.14159265358979323846;

// Runs a step with --pfm into `folder`; --volume phantom loads the phantom painted once in
// this process (harness.h), not painted by every run.
RunResult render(const std::string& step, std::vector<std::string> flags,
                 const TempFolder& folder) {
    flags = ctlab_test::phantom_from_file(flags);
    flags.insert(flags.end(), {"--out", folder.path(), "--pfm", "--threads", "2"});
    RunResult run = run_step(step, flags);
    INFO(run.command() << "\n" << run.err);
    REQUIRE(run.status == 0);
    return run;
}

Image camera_pfm(const TempFolder& folder, const std::string& step) {
    return read_pfm(step_output(folder.path(), step, "camera", "pfm"));
}

// The offsets u a run with --show-jitter drew, row by row (grey: the red channel).
std::vector<double> offsets(const std::string& jitter, int width, int height,
                            const TempFolder& folder) {
    render(jitter_step,
           {"--volume", "phantom", "--jitter", jitter, "--show-jitter", "--size",
            std::to_string(width) + "x" + std::to_string(height)},
           folder);
    const Image image = camera_pfm(folder, jitter_step);
    std::vector<double> u;
    for (const Rgb& p : image.pixels) u.push_back(p.r);
    return u;
}

// Mean power |F(k)|^2 / n^2 of a tile-sized pattern (its mean taken away) over the
// frequencies k = (kx, ky), |k| in (low, high] cycles per tile, by a plain 2-D DFT.
// For white noise of variance s^2 every frequency's expected power is s^2.
double band_power(const std::vector<double>& values, double low, double high) {
    const int n = tile;
    double mean = 0;
    for (double v : values) mean += v;
    mean /= values.size();
    // Rows first: row[y][kx], then columns.
    std::vector<double> re(n * n), im(n * n);
    for (int y = 0; y < n; ++y)
        for (int kx = 0; kx < n; ++kx) {
            double a = 0, b = 0;
            for (int x = 0; x < n; ++x) {
                const double angle = -2 * pi * kx * x / n;
                a += (values[y * n + x] - mean) * std::cos(angle);
                b += (values[y * n + x] - mean) * std::sin(angle);
            }
            re[y * n + kx] = a;
            im[y * n + kx] = b;
        }
    double sum = 0;
    int count = 0;
    for (int ky = 0; ky < n; ++ky)
        for (int kx = 0; kx < n; ++kx) {
            const int fx = kx <= n / 2 ? kx : kx - n, fy = ky <= n / 2 ? ky : ky - n;
            const double radius = std::sqrt(double(fx * fx + fy * fy));
            if (radius <= low || radius > high) continue;
            double a = 0, b = 0;
            for (int y = 0; y < n; ++y) {
                const double angle = -2 * pi * ky * y / n, c = std::cos(angle),
                             s = std::sin(angle);
                a += re[y * n + kx] * c - im[y * n + kx] * s;
                b += re[y * n + kx] * s + im[y * n + kx] * c;
            }
            sum += (a * a + b * b) / (n * n);
            ++count;
        }
    return sum / count;
}

double variance(const std::vector<double>& values) {
    double mean = 0, square = 0;
    for (double v : values) mean += v;
    mean /= values.size();
    for (double v : values) square += (v - mean) * (v - mean);
    return square / values.size();
}

// A ball of soft tissue (value 0, the classic table's skin) of radius 24 in a 64^3 grid of
// air (-1000), as a raw file.
std::vector<std::string> ball(const TempFolder& folder) {
    constexpr int n = 64;
    constexpr double radius = 24;
    Volume volume;
    volume.nx = volume.ny = volume.nz = n;
    resize_dense(volume);
    const double centre = (n - 1) / 2.0;
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const double r = std::sqrt((i - centre) * (i - centre) +
                                           (j - centre) * (j - centre) +
                                           (k - centre) * (k - centre));
                volume.data[volume.index(i, j, k)] = int16_t(r <= radius ? 0 : -1000);
            }
    return write_raw_volume(volume, folder.path("ball.raw"));
}

// Ring banding: the error (image - reference, red channel) averaged over each ring one pixel
// wide around the image's centre, then the RMS of those ring means, each weighted by its
// pixels, from `from` to `out_to` pixels (the innermost rings hold too few pixels to average).
// Noise averages away along a ring; rings of error (wood grain) do not.
double ring_banding(const Image& image, const Image& reference, double out_to) {
    constexpr int from = 4;
    const int rings = int(out_to);
    std::vector<double> sum(rings, 0.0);
    std::vector<int> count(rings, 0);
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const double r = std::hypot(x + 0.5 - image.width / 2.0, y + 0.5 - image.height / 2.0);
            if (r >= out_to) continue;
            sum[int(r)] += double(image.at(x, y).r) - reference.at(x, y).r;
            ++count[int(r)];
        }
    double square = 0;
    int used = 0;
    for (int n = from; n < rings; ++n) {
        if (count[n] == 0) continue;
        square += count[n] * (sum[n] / count[n]) * (sum[n] / count[n]);
        used += count[n];
    }
    return std::sqrt(square / used);
}

// How many pixels of two pictures of one size differ in any channel (bit for bit).
int differing_pixels(const Image& a, const Image& b) {
    int differing = 0;
    for (size_t n = 0; n < a.pixels.size(); ++n) {
        const Rgb &p = a.pixels[n], &q = b.pixels[n];
        if (p.r != q.r || p.g != q.g || p.b != q.b) ++differing;
    }
    return differing;
}

}  // namespace

TEST_CASE("jitter: --jitter none draws step 15's picture bit for bit, with the same work") {
    const TempFolder folder("jitter_none");
    for (const std::vector<std::string>& camera :
         std::vector<std::vector<std::string>>{{"--size", "96x80", "--zoom", "0.35"},
                                               {"--size", "64x64", "--zoom", "1.5",
                                                "--projection", "perspective", "--step", "2"}}) {
        std::vector<std::string> flags = {"--volume", "phantom"};
        flags.insert(flags.end(), camera.begin(), camera.end());
        const RunResult ten = render(free_camera, flags, folder);
        flags.insert(flags.end(), {"--jitter", "none"});
        for (const std::string& step : {hash_step, jitter_step}) {
            CAPTURE(step);
            const RunResult eleven = render(step, flags, folder);
            const Image a = camera_pfm(folder, free_camera), b = camera_pfm(folder, step);
            REQUIRE(a.pixels.size() == b.pixels.size());
            CHECK(differing_pixels(a, b) == 0);
            for (const char* counter :
                 {"samples", "skipped", "leapt", "gradients", "terminated"}) {
                CAPTURE(counter);
                CHECK(ten.summary("camera").at(counter) == eleven.summary("camera").at(counter));
            }
        }
    }
}

// Step 17 adds the blue-noise tile only: its --jitter hash is step 16's default, bit for bit.
TEST_CASE("jitter: step 17's --jitter hash is step 16's picture, bit for bit, with the same work") {
    const TempFolder folder("jitter_hash_steps");
    const std::vector<std::string> flags = {"--volume", "phantom", "--size", "96x80", "--zoom",
                                            "0.35", "--step", "4"};
    const RunResult twelve = render(hash_step, flags, folder);
    std::vector<std::string> hash = flags;
    hash.insert(hash.end(), {"--jitter", "hash"});
    const RunResult thirteen = render(jitter_step, hash, folder);
    const Image a = camera_pfm(folder, hash_step), b = camera_pfm(folder, jitter_step);
    REQUIRE(a.pixels.size() == b.pixels.size());
    CHECK(differing_pixels(a, b) == 0);
    for (const char* counter : {"samples", "skipped", "gradients", "terminated"}) {
        CAPTURE(counter);
        CHECK(twelve.summary("camera").at(counter) == thirteen.summary("camera").at(counter));
    }
    CHECK(summary_count(twelve.summary("camera"), "samples") > 0);
}

TEST_CASE("jitter: the hash's offsets are uniform on [0, 1), uncorrelated and deterministic") {
    const TempFolder folder("jitter_hash");
    constexpr int width = 512, height = 512;
    const std::vector<double> u = offsets("hash", width, height, folder);
    REQUIRE(u.size() == size_t(width) * height);
    const double count = double(u.size());
    double mean = 0;
    for (double v : u) {
        REQUIRE(v >= 0.0);
        REQUIRE(v < 1.0);
        mean += v;
    }
    mean /= count;
    // Uniform on [0, 1): mean 1/2, variance 1/12. The standard error of the mean is
    // sqrt(1/12 / 262144) = 5.6e-4, of the variance sqrt(1/180 / 262144) = 1.5e-4:
    // the bounds are over 5 standard errors.
    CHECK(std::fabs(mean - 0.5) < 0.003);
    CHECK(std::fabs(variance(u) - 1.0 / 12) < 0.001);
    // 16 equal bins: chi-square with 15 degrees of freedom, 50 is beyond its 0.9999 quantile.
    std::vector<double> bins(16, 0.0);
    for (double v : u) bins[std::min(15, int(v * 16))] += 1;
    double chi_square = 0;
    for (double b : bins) chi_square += (b - count / 16) * (b - count / 16) / (count / 16);
    CHECK(chi_square < 50);
    // Neighbours along a row and down a column: correlation about 0 (standard error 0.002).
    double along_x = 0, along_y = 0;
    for (int y = 0; y + 1 < height; ++y)
        for (int x = 0; x + 1 < width; ++x) {
            along_x += (u[y * width + x] - mean) * (u[y * width + x + 1] - mean);
            along_y += (u[y * width + x] - mean) * (u[(y + 1) * width + x] - mean);
        }
    const double cells = double(width - 1) * (height - 1);
    CHECK(std::fabs(along_x / cells / variance(u)) < 0.012);
    CHECK(std::fabs(along_y / cells / variance(u)) < 0.012);
    // The same offsets in every run; (x, y) and (y, x) differ.
    CHECK(offsets("hash", width, height, folder) == u);
    CHECK(u[3 * width + 7] != u[7 * width + 3]);
}

TEST_CASE("jitter: the blue-noise tile holds every rank once, repeats, and is blue") {
    const TempFolder folder("jitter_blue");
    // Twice the tile across: the second half must repeat the first.
    const std::vector<double> wide = offsets("blue", 2 * tile, tile, folder);
    std::vector<double> u(tile * tile);
    for (int y = 0; y < tile; ++y)
        for (int x = 0; x < tile; ++x) {
            u[y * tile + x] = wide[y * 2 * tile + x];
            CHECK(wide[y * 2 * tile + x + tile] == u[y * tile + x]);
        }
    // Offsets (r + 1/2) / 4096: every rank 0..4095 exactly once.
    std::vector<int> seen(tile * tile, 0);
    for (double v : u) {
        const double rank = v * tile * tile - 0.5;
        REQUIRE(rank == std::round(rank));
        REQUIRE(rank >= 0);
        REQUIRE(rank < tile * tile);
        ++seen[int(rank)];
    }
    CHECK(std::count(seen.begin(), seen.end(), 1) == tile * tile);
    // Deterministic: a second run makes the same tile.
    CHECK(offsets("blue", tile, tile, folder) == u);

    // The spectrum. White noise of variance s^2 has expected power s^2 at every frequency,
    // and by Parseval the mean power over all of them is the variance for any pattern. The
    // same offsets arranged as blue noise move that power out of the low frequencies.
    const double s2 = variance(u);
    CHECK(s2 == doctest::Approx(1.0 / 12).epsilon(0.001));
    const double blue_low = band_power(u, 0, tile / 8.0);
    const double blue_high = band_power(u, tile / 4.0, tile);
    const std::vector<double> white = offsets("hash", tile, tile, folder);
    const double white_low = band_power(white, 0, tile / 8.0);
    const double white_all = band_power(white, 0, tile);
    MESSAGE("power / variance, |k| <= 8 cycles per tile: blue " << blue_low / s2 << ", hash "
            << white_low / variance(white) << "; blue above 16: " << blue_high / s2);
    CHECK(blue_low < 0.1 * s2);
    CHECK(blue_high > s2);
    // The hash is white: its low band is near its variance (about 200 frequencies: within
    // a factor of 1.5), and its mean power over all of them is the variance (Parseval).
    CHECK(white_low > variance(white) / 1.5);
    CHECK(white_low < variance(white) * 1.5);
    CHECK(white_all == doctest::Approx(variance(white) * tile * tile / (tile * tile - 1))
                           .epsilon(1e-6));
}

TEST_CASE("jitter: the trace shows the offset, and the first sample lies u * step past the "
          "entry") {
    const TempFolder folder("jitter_trace");
    for (const char* mode : {"hash", "blue"}) {
        CAPTURE(mode);
        const RunResult run = render(jitter_step,
                                     {"--volume", "phantom", "--jitter", mode, "--step", "2",
                                      "--size", "128x128", "--zoom", "0.5", "--debug-pixel",
                                      "64,60"},
                                     folder);
        REQUIRE(run.traces.size() == 1);
        double u = -1, offset = -1, t_entry = -1, t_first = -1;
        for (const std::string& line : run.traces[0].lines) {
            std::sscanf(line.c_str(), "jitter %*s u=%lf, the first sample %lf", &u, &offset);
            const size_t entry = line.find("entry t=");
            if (entry != std::string::npos) std::sscanf(line.c_str() + entry, "entry t=%lf",
                                                        &t_entry);
            if (t_first < 0 && line.rfind("t=", 0) == 0) std::sscanf(line.c_str(), "t=%lf",
                                                                     &t_first);
        }
        REQUIRE(u >= 0);
        CHECK(u < 1);
        CHECK(offset == doctest::Approx(2 * u).epsilon(1e-5));
        REQUIRE(t_entry > 0);
        CHECK(std::fabs(t_first - t_entry - offset) < 2e-4);  // the trace's t has 4 decimals
        // The traced pixel's offset is the one --show-jitter draws.
        render(jitter_step, {"--volume", "phantom", "--jitter", mode, "--show-jitter", "--size",
                             "128x128"},
               folder);
        CHECK(camera_pfm(folder, jitter_step).at(64, 60).r == doctest::Approx(u).epsilon(1e-5));
    }
}

TEST_CASE("jitter: on a ball, jitter turns the sample grid's rings into noise") {
    // A fixed grid samples the ball a whole number of times along each ray: the number jumps
    // by one from ring to ring and T by a factor 0.99^4 at step 4, drawing rings. Jitter makes
    // the expected number of samples the chord / step exactly, so the error averages away
    // along each ring. The reference: step 1/4, no jitter (its rings are 16 times finer).
    const TempFolder folder("jitter_rings");
    const std::vector<std::string> volume = ball(folder);
    std::vector<std::string> common = volume;
    // Thin skin (opacity 0.01 per unit): T = 0.99^48 = 0.62 through the middle, so the
    // picture is not saturated and each ring's extra sample (a factor 0.99^4) shows.
    // Facing the face (along +j) every ray enters the box on the plane j = 0: one sample grid
    // for all, so the count depends on the chord alone and the rings are round.
    common.insert(common.end(), {"--azimuth", "0", "--elevation", "0", "--size", "64x64",
                                 "--unlit", "--ert", "0", "--skin-opacity", "0.01"});
    auto picture = [&](const char* step, const char* jitter) {
        std::vector<std::string> flags = common;
        flags.insert(flags.end(), {"--step", step, "--jitter", jitter});
        render(jitter_step, flags, folder);
        return camera_pfm(folder, jitter_step);
    };
    const Image reference = picture("0.25", "none");
    const double out_to = 22;  // pixels: inside the ball's silhouette (radius 24)
    const double none = ring_banding(picture("4", "none"), reference, out_to);
    const double hash = ring_banding(picture("4", "hash"), reference, out_to);
    const double blue = ring_banding(picture("4", "blue"), reference, out_to);
    MESSAGE("ring banding (RMS of ring means, 0..1): none " << none << ", hash " << hash
            << ", blue " << blue);
    CHECK(none > 0.005);  // rings: over 1 of 255 levels on average along a ring
    CHECK(hash < 0.35 * none);
    CHECK(blue < 0.35 * none);
}

TEST_CASE("jitter: a bad --jitter is refused with status 2") {
    const RunResult run = run_step(jitter_step, {"--volume", "phantom", "--jitter", "white"});
    CHECK(run.status == 2);
    CHECK(run.err.find("error: --jitter") != std::string::npos);
}
