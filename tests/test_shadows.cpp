// test_shadows.cpp: step 19 (shadow rays or a light-transmittance volume towards the light,
// ambient occlusion) run as a program (tools/run_step.h) on volumes and transfer functions
// written here: a homogeneous slab between the light and a surface (Beer-Lambert, by shadow
// ray and by the light volume), a lone voxel in empty space (nothing blocks its light,
// nothing is around it), a uniform block (ambient occlusion of a known medium), and the
// phantom: shadows and occlusion off (step 12's picture, bit for bit), the light volume against
// the shadow rays (close, and far fewer reads).
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <string>
#include <vector>
#include "image.h"
#include "tools/run_step.h"
#include "volume.h"

using namespace ctlab;

namespace {

const std::string shadows_step = "19_shadows";

RunResult run_shadows(const std::vector<std::string>& volume_flags,
                      std::vector<std::string> flags, const TempFolder& folder) {
    flags.insert(flags.begin(), volume_flags.begin(), volume_flags.end());
    flags.insert(flags.end(), {"--out", folder.path(), "--pfm", "--threads", "2"});
    RunResult run = run_step(shadows_step, flags);
    INFO(run.command() << "\n" << run.err);
    REQUIRE(run.status == 0);
    return run;
}

Volume filled_volume(int nx, int ny, int nz, const std::function<int(int, int, int)>& value) {
    Volume volume;
    volume.nx = nx;
    volume.ny = ny;
    volume.nz = nz;
    resize_dense(volume);
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) volume.data[volume.index(i, j, k)] = int16_t(value(i, j, k));
    return volume;
}

// A transfer function file in `folder`: the --tf flag naming it.
std::vector<std::string> tf_flags(const TempFolder& folder, const std::string& ranges) {
    const std::string path = folder.path("shadows.tf");
    std::ofstream(path) << ranges;
    return {"--tf", path};
}

// A composited sample of the trace: "t=T p=(I, J, K) value=V rgba=(...) light_T=X ao=Y (N shadow
// samples, M leapt) ...".
struct LitSample {
    double t = 0, i = 0, j = 0, k = 0, value = 0, light_t = -1, occlusion = -1;
    int shadow_samples = -1;
};
std::vector<LitSample> lit_samples(const PixelTrace& trace) {
    std::vector<LitSample> samples;
    for (const std::string& line : trace.lines) {
        const size_t light = line.find("light_T=");
        if (light == std::string::npos) continue;
        LitSample s;
        if (std::sscanf(line.c_str(), "t=%lf p=(%lf, %lf, %lf) value=%lf", &s.t, &s.i, &s.j, &s.k,
                        &s.value) == 5 &&
            std::sscanf(line.c_str() + light, "light_T=%lf ao=%lf (%d shadow samples)",
                        &s.light_t, &s.occlusion, &s.shadow_samples) == 3) {
            samples.push_back(s);
        }
    }
    return samples;
}

}  // namespace

TEST_CASE("shadows: a homogeneous slab between the light and a surface lets exp(-sigma d) "
          "through (Beer-Lambert)") {
    // 24 x 32 x 40 voxels at spacing 1. Air 2000 (transparent), a slab of 3000 for
    // 10 <= k <= 20 (the table's boundary 2500 falls half-way between voxels: the slab is
    // 11 units thick, 9.5 <= k <= 20.5), a surface of 1000 from k = 36 on (seen from
    // k = 35.5, where the value falls below 1500). Opacity 0.05 per unit in the slab:
    // sigma = -ln(0.95); the surface's 1e-4 hardly blocks its own light.
    // The camera looks down +k (azimuth 180, elevation 90; right = +i, image y = +j); the
    // light (--light-angle 0) comes from 20 degrees above the viewer:
    // L = (0, -sin 20, -cos 20), so the shadow ray crosses the slab over d = 11 / cos 20.
    const Volume volume = filled_volume(24, 32, 40, [](int, int, int k) {
        return k >= 10 && k <= 20 ? 3000 : k >= 36 ? 1000 : 2000;
    });
    const TempFolder folder("shadows_slab");
    const std::vector<std::string> raw = write_raw_volume(volume, folder.path("slab.raw"));
    const std::vector<std::string> tf = tf_flags(folder,
                                                 "0 1500 constant 1 1 1 0.0001\n"
                                                 "2500 3500 constant 1 1 1 0.05\n");
    const double sigma = -std::log(0.95);
    const double d = 11 / std::cos(20 * 3.14159265358979323846 / 180);
    const double step = 0.25;
    std::vector<std::string> flags = tf;
    flags.insert(flags.end(), {"--azimuth", "180", "--elevation", "90", "--size", "24x32",
                               "--light-angle", "0", "--step", "0.25", "--ert", "0", "--ao",
                               "off", "--debug-pixel", "12,24"});
    const RunResult run = run_shadows(raw, flags, folder);
    REQUIRE(run.traces.size() == 1);
    const std::vector<LitSample> samples = lit_samples(run.traces[0]);
    // The first surface sample, k = 35.75: its shadow ray goes up through the slab.
    const auto surface = std::find_if(samples.begin(), samples.end(),
                                      [](const LitSample& s) { return s.value < 1500; });
    REQUIRE(surface != samples.end());
    CHECK(surface->k == doctest::Approx(35.75));
    CAPTURE(surface->light_t);
    // Samples 0.25 apart count the slab to within one sample: |ln T + sigma d| <= sigma h.
    // The surface's own 1e-4 adds at most 1e-4 * 0.5 / cos 20 to -ln T.
    CHECK(std::fabs(std::log(surface->light_t) + sigma * d) <= sigma * step + 1e-4);
    CHECK(surface->light_t == doctest::Approx(std::exp(-sigma * d)).epsilon(0.01));
    // The slab's own samples: the light has crossed part of the slab only; the first one, at
    // its top (k = 9.5), nothing but air.
    const auto top = std::find_if(samples.begin(), samples.end(),
                                  [](const LitSample& s) { return s.value >= 2500; });
    REQUIRE(top != samples.end());
    CHECK(top->k == doctest::Approx(9.5));
    CHECK(top->light_t == 1.0);
    // The light-transmittance volume, swept slice by slice along k (the axis the light
    // crosses fastest) in segments d = 1 / cos 20 long: the slab's 11 slices of 3000 each
    // take (0.95)^d, so below the slab T_light = 0.95^(11 d) = exp(-sigma d) to float
    // rounding; it agrees with the shadow ray's answer to within one of its samples' optical
    // depth, sigma * step.
    std::vector<std::string> volume_flags = flags;
    volume_flags.insert(volume_flags.end(), {"--shadows", "volume"});
    const RunResult swept = run_shadows(raw, volume_flags, folder);
    REQUIRE(swept.traces.size() == 1);
    const std::vector<LitSample> from_volume = lit_samples(swept.traces[0]);
    REQUIRE(from_volume.size() == samples.size());
    const LitSample& below = from_volume[size_t(surface - samples.begin())];
    CHECK(below.k == doctest::Approx(35.75));
    CAPTURE(below.light_t);
    CHECK(below.light_t == doctest::Approx(std::exp(-sigma * d)).epsilon(1e-5));
    CHECK(std::fabs(std::log(below.light_t) - std::log(surface->light_t)) <= sigma * step + 1e-4);
    CHECK(below.shadow_samples == 0);  // one trilinear read, no march
    // Inside the slab T_light falls along the ray: the volume, sampled every d along k and
    // read trilinearly, is within one segment's optical depth (sigma d) of the shadow ray.
    for (size_t n = 0; n < samples.size(); ++n) {
        CAPTURE(samples[n].k);
        CHECK(std::fabs(std::log(from_volume[n].light_t) - std::log(samples[n].light_t)) <=
              sigma * (step + 1 / std::cos(20 * 3.14159265358979323846 / 180)) + 1e-4);
    }
    // Without shadow rays nothing blocks it: T_light = 1 everywhere.
    flags.insert(flags.end(), {"--shadows", "none"});
    const RunResult open = run_shadows(raw, flags, folder);
    REQUIRE(open.traces.size() == 1);
    for (const LitSample& s : lit_samples(open.traces[0])) CHECK(s.light_t == 1.0);
}

TEST_CASE("shadows: a lone voxel in empty space gets all the light, T_light = 1 and AO = 1") {
    // One voxel of 1000 (opacity 0.5) at (12, 16, 20) in air (2000, transparent). The ray of
    // pixel (12, 16) from above reads it at its centre: every occlusion probe (1 to 4 units
    // along each axis) lands on a voxel centre of air, every shadow-ray sample within 1 unit
    // of it reads at most 1960 (the voxel's trilinear weight there is under 0.04): nothing is
    // in the way, exactly.
    const Volume volume = filled_volume(24, 32, 40, [](int i, int j, int k) {
        return i == 12 && j == 16 && k == 20 ? 1000 : 2000;
    });
    const TempFolder folder("shadows_lone");
    const std::vector<std::string> raw = write_raw_volume(volume, folder.path("lone.raw"));
    std::vector<std::string> flags = tf_flags(folder, "500 1500 constant 1 1 1 0.5\n");
    flags.insert(flags.end(), {"--azimuth", "180", "--elevation", "90", "--size", "24x32",
                               "--light-angle", "0", "--debug-pixel", "12,16"});
    const RunResult run = run_shadows(raw, flags, folder);
    REQUIRE(run.traces.size() == 1);
    const std::vector<LitSample> samples = lit_samples(run.traces[0]);
    REQUIRE(samples.size() == 1);
    CHECK(samples[0].k == 20);
    CHECK(samples[0].light_t == 1.0);
    CHECK(samples[0].occlusion == 1.0);
    CHECK(samples[0].shadow_samples > 20);  // the probes and the shadow ray did read
}

TEST_CASE("shadows: ambient occlusion inside a uniform medium is (1 - alpha)^(radius / unit) "
          "in every direction") {
    // A uniform block of 1000 (opacity 0.1 per unit), 24 x 32 x 40: a sample at least 4 units
    // from every face sees the medium over the whole occlusion radius (4 units, samples 1
    // apart) in all six directions: AO = 0.9^4 = 0.6561.
    const Volume volume = filled_volume(24, 32, 40, [](int, int, int) { return 1000; });
    const TempFolder folder("shadows_uniform");
    const std::vector<std::string> raw = write_raw_volume(volume, folder.path("block.raw"));
    std::vector<std::string> flags = tf_flags(folder, "500 1500 constant 1 1 1 0.1\n");
    flags.insert(flags.end(), {"--azimuth", "180", "--elevation", "90", "--size", "24x32",
                               "--light-angle", "0", "--ert", "0", "--debug-pixel", "12,16"});
    const RunResult run = run_shadows(raw, flags, folder);
    REQUIRE(run.traces.size() == 1);
    int inside = 0;
    for (const LitSample& s : lit_samples(run.traces[0])) {
        if (s.k < 4 || s.k > 35) continue;
        ++inside;
        CHECK(s.occlusion == doctest::Approx(0.6561).epsilon(1e-6));
        // The shadow ray crosses the medium to the top face: (0.9)^(distance), distance = k
        // / cos 20 (light 20 degrees above the viewer) to within one step.
        const double distance = s.k / std::cos(20 * 3.14159265358979323846 / 180);
        CHECK(std::fabs(std::log(s.light_t) - distance * std::log(0.9)) <=
              -std::log(0.9) * 1.0 + 1e-9);
    }
    CHECK(inside >= 30);
}

TEST_CASE("shadows: with shadows and occlusion off it is step 12's picture, bit for bit") {
    const TempFolder ten("shadows_step10"), fourteen("shadows_off");
    const std::vector<std::string> flags = {"--volume", "phantom", "--size", "128x96", "--zoom",
                                            "0.4", "--azimuth", "-50", "--threads", "2", "--pfm"};
    std::vector<std::string> a = flags, b = flags;
    a.insert(a.end(), {"--out", ten.path()});
    b.insert(b.end(), {"--out", fourteen.path(), "--shadows", "none", "--ao", "off"});
    REQUIRE(run_step("12_trilinear", a).status == 0);
    REQUIRE(run_step(shadows_step, b).status == 0);
    const Image p = read_pfm(step_output(ten.path(), "12_trilinear", "camera", "pfm"));
    const Image q = read_pfm(step_output(fourteen.path(), shadows_step, "camera", "pfm"));
    REQUIRE(p.pixels.size() == q.pixels.size());
    int differing = 0;
    for (size_t n = 0; n < p.pixels.size(); ++n) {
        differing += p.pixels[n].r != q.pixels[n].r || p.pixels[n].g != q.pixels[n].g ||
                     p.pixels[n].b != q.pixels[n].b;
    }
    CHECK(differing == 0);
    // With them on the picture only darkens: blocked light is never more light.
    REQUIRE(run_step(shadows_step, {"--volume", "phantom", "--size", "128x96", "--zoom", "0.4",
                                    "--azimuth", "-50", "--threads", "2", "--pfm", "--out",
                                    fourteen.path()})
                .status == 0);
    const Image r = read_pfm(step_output(fourteen.path(), shadows_step, "camera", "pfm"));
    int darker = 0, lighter = 0;
    for (size_t n = 0; n < p.pixels.size(); ++n) {
        darker += r.pixels[n].r < p.pixels[n].r;
        lighter += r.pixels[n].r > p.pixels[n].r + 1e-6f;
    }
    CHECK(lighter == 0);
    CHECK(darker > 500);
}

TEST_CASE("shadows: bad flags are refused with status 2, naming the flag") {
    for (const std::vector<std::string>& flags :
         std::vector<std::vector<std::string>>{{"--shadows", "map"}, {"--ao", "yes"}}) {
        std::vector<std::string> args = {"--volume", "phantom", "--no-window"};
        args.insert(args.end(), flags.begin(), flags.end());
        const RunResult run = run_step(shadows_step, args);
        CAPTURE(run.command());
        CHECK(run.status == 2);
        CHECK(run.err.find("error: " + flags[0]) != std::string::npos);
    }
}

// The phantom's picture of step 19 with these flags, at `size` pixels covering the default
// picture's field (and the run, for its counters).
struct Picture {
    RunResult run;
    Image image;
    unsigned long long count(const char* key) const {
        return summary_count(run.summary("camera"), key);
    }
};
Picture phantom_picture(const std::vector<std::string>& extra, const TempFolder& folder,
                        int size = 256) {
    std::vector<std::string> flags = {"--volume", "phantom", "--size",
                                      std::to_string(size) + "x" + std::to_string(size),
                                      "--zoom", size == 512 ? "1" : "0.5", "--threads", "2",
                                      "--pfm", "--out", folder.path()};
    flags.insert(flags.end(), extra.begin(), extra.end());
    Picture picture;
    picture.run = run_step(shadows_step, flags);
    INFO(picture.run.command() << "\n" << picture.run.err);
    REQUIRE(picture.run.status == 0);
    picture.image = read_pfm(step_output(folder.path(), shadows_step, "camera", "pfm"));
    return picture;
}

TEST_CASE("shadows: the light-transmittance volume gives the shadow rays' picture for one read "
          "per voxel, where the shadow rays read per lit sample") {
    const TempFolder folder("shadows_volume");
    const Picture rays = phantom_picture({"--ao", "off"}, folder);
    const Picture swept = phantom_picture({"--ao", "off", "--shadows", "volume"}, folder);
    const Picture open = phantom_picture({"--ao", "off", "--shadows", "none"}, folder);
    // What the shadows add (the picture without them against with them) and how far the
    // volume is from the rays, both as the mean difference over every channel of every pixel.
    auto mean_difference = [](const Image& p, const Image& q) {
        double sum = 0;
        for (size_t n = 0; n < p.pixels.size(); ++n) {
            sum += std::fabs(p.pixels[n].r - q.pixels[n].r) +
                   std::fabs(p.pixels[n].g - q.pixels[n].g) +
                   std::fabs(p.pixels[n].b - q.pixels[n].b);
        }
        return sum / (3.0 * p.pixels.size());
    };
    const double added = mean_difference(open.image, rays.image);
    const double error = mean_difference(swept.image, rays.image);
    CAPTURE(added);
    CAPTURE(error);
    CHECK(added > 0.01);
    CHECK(error < 0.15 * added);
    // The cost: the sweep reads every voxel once (the phantom's 256 x 256 x 113; the slice
    // nearest the light and voxels lit through a side face read nothing), whatever the
    // picture; the shadow rays read along a march from every lit sample, so four times the
    // pixels (512 x 512, the default and the bench's picture, the same field) cost them
    // about four times the reads, and there the volume reads fewer.
    const unsigned long long voxels = 256ull * 256 * 113;
    const unsigned long long sweep = swept.count("samples") - open.count("samples");
    CHECK(sweep <= voxels);
    CHECK(sweep > voxels / 2);
    const unsigned long long marched = rays.count("samples") - open.count("samples");
    const Picture rays_512 = phantom_picture({"--ao", "off"}, folder, 512);
    const Picture swept_512 = phantom_picture({"--ao", "off", "--shadows", "volume"}, folder, 512);
    const Picture open_512 = phantom_picture({"--ao", "off", "--shadows", "none"}, folder, 512);
    const unsigned long long marched_512 = rays_512.count("samples") - open_512.count("samples");
    CHECK(swept_512.count("samples") - open_512.count("samples") == sweep);
    CAPTURE(marched);
    CAPTURE(marched_512);
    CHECK(marched_512 > 3 * marched);
    CHECK(swept_512.count("samples") < rays_512.count("samples"));
    // and its steps along the shadow rays several times the sweep's reads
    CHECK(marched_512 > 4 * sweep);
}
