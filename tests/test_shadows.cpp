// test_shadows.cpp: blocked light, each idea in the step that brings it, run as a program
// (tools/run_step.h) on volumes and transfer functions written here. Step 22, shadow rays: a
// homogeneous slab between the light and a surface (Beer-Lambert), a lone voxel in empty space
// (nothing blocks its light), --shadows none is step 15's picture bit for bit. Step 23, the
// light-transmittance volume: the same slab (Beer-Lambert again, close to the shadow ray), and
// on the phantom close to the shadow rays' picture for far fewer reads. Step 24, ambient
// occlusion: the lone voxel (nothing around it), a uniform block (a known medium). Each later
// step with its new idea off renders the step before's picture, bit for bit.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <string>
#include <vector>
#include "harness.h"
#include "image.h"
#include "tools/run_step.h"
#include "volume.h"

using namespace ctlab;

namespace {

const std::string shadow_rays_step = "22_shadow_rays";
const std::string light_volume_step = "23_light_volume";
const std::string ambient_occlusion_step = "24_ambient_occlusion";

RunResult run_shadows(const std::string& step, const std::vector<std::string>& volume_flags,
                      std::vector<std::string> flags, const TempFolder& folder) {
    flags.insert(flags.begin(), volume_flags.begin(), volume_flags.end());
    flags.insert(flags.end(), {"--out", folder.path(), "--pfm", "--threads", "2"});
    RunResult run = run_step(step, flags);
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

// A composited sample of the trace, from its records (full precision): where it is, its value,
// the light reaching it, its ambient occlusion (-1 before step 24) and how many samples its
// shadow ray (and occlusion probes) read.
struct LitSample {
    double t = 0, i = 0, j = 0, k = 0, value = 0, light_t = -1, occlusion = -1;
    int shadow_samples = -1;
};
std::vector<LitSample> lit_samples(const PixelTrace& trace) {
    std::vector<LitSample> samples;
    for (const TraceRecord& record : trace.records) {
        if (record.kind != TraceKind::sample || !record.has("light_T")) continue;
        LitSample s;
        s.t = record.number("t", 0);
        s.i = record.number("p.i", 0);
        s.j = record.number("p.j", 0);
        s.k = record.number("p.k", 0);
        s.value = record.number("value", 0);
        s.light_t = record.number("light_T", -1);
        s.occlusion = record.number("ao", -1);
        s.shadow_samples = int(record.number("shadow_samples", -1));
        samples.push_back(s);
    }
    return samples;
}

// The largest difference between two pictures of the same size, over every channel of every
// pixel (0: bit for bit).
float largest_difference(const Image& p, const Image& q) {
    REQUIRE(p.pixels.size() == q.pixels.size());
    float largest = 0;
    for (size_t n = 0; n < p.pixels.size(); ++n) {
        largest = std::max({largest, std::fabs(p.pixels[n].r - q.pixels[n].r),
                            std::fabs(p.pixels[n].g - q.pixels[n].g),
                            std::fabs(p.pixels[n].b - q.pixels[n].b)});
    }
    return largest;
}

}  // namespace

namespace {

// 24 x 32 x 40 voxels at spacing 1. Air 2000 (transparent), a slab of 1000 for 10 <= k <= 20
// (the table's boundary 1500 falls half-way between voxels: the slab is 11 units thick, 9.5
// <= k <= 20.5), a surface of 3000 from k = 36 on (seen from k = 35.5, where the value
// reaches 2500). Opacity 0.05 per unit in the slab: sigma = -ln(0.95); the surface's 1e-4
// hardly blocks its own light. The camera looks down +k (azimuth 180, elevation 90; right =
// +i, image y = +j); the light (--light-angle 0) comes from 20 degrees above the viewer:
// L = (0, -sin 20, -cos 20), so the shadow ray crosses the slab over d = 11 / cos 20. The
// surface's values rise into it, so its normal faces the light (up, -k), as does the slab's
// lower face; the slab's upper face and its inside (no gradient) face no light, and march no
// shadow ray.
struct Slab {
    TempFolder folder{"shadows_slab"};
    std::vector<std::string> raw, flags;
    const double sigma = -std::log(0.95);
    const double cos_light = std::cos(20 * 3.14159265358979323846 / 180);
    const double d = 11 / cos_light;
    const double step = 0.25;

    Slab() {
        const Volume volume = filled_volume(24, 32, 40, [](int, int, int k) {
            return k >= 10 && k <= 20 ? 1000 : k >= 36 ? 3000 : 2000;
        });
        raw = write_raw_volume(volume, folder.path("slab.raw"));
        flags = tf_flags(folder, "500 1500 constant 1 1 1 0.05\n"
                                 "2500 3500 constant 1 1 1 0.0001\n");
        flags.insert(flags.end(), {"--azimuth", "180", "--elevation", "90", "--size", "24x32",
                                   "--light-angle", "0", "--step", "0.25", "--ert", "0",
                                   "--debug-pixel", "12,24"});
    }
    // The traced ray's lit samples, `step` run with `extra` flags.
    std::vector<LitSample> samples(const std::string& step,
                                   const std::vector<std::string>& extra) const {
        std::vector<std::string> all = flags;
        all.insert(all.end(), extra.begin(), extra.end());
        const RunResult run = run_shadows(step, raw, all, folder);
        REQUIRE(run.traces.size() == 1);
        return lit_samples(run.traces[0]);
    }
};

// The first sample on the surface (value 2500 or more), where the shadow ray crosses the slab.
size_t first_surface_sample(const std::vector<LitSample>& samples) {
    const auto surface = std::find_if(samples.begin(), samples.end(),
                                      [](const LitSample& s) { return s.value >= 2500; });
    REQUIRE(surface != samples.end());
    return size_t(surface - samples.begin());
}

}  // namespace

TEST_CASE("shadow rays (step 22): a homogeneous slab between the light and a surface lets "
          "exp(-sigma d) through (Beer-Lambert)") {
    const Slab slab;
    const std::vector<LitSample> samples = slab.samples(shadow_rays_step, {});
    // The first surface sample, k = 35.5: its shadow ray goes up through the slab.
    const LitSample& surface = samples[first_surface_sample(samples)];
    CHECK(surface.k == doctest::Approx(35.5));
    CHECK(surface.occlusion == -1);  // no ambient occlusion before step 24
    CAPTURE(surface.light_t);
    // Samples 0.25 apart count the slab to within one sample: |ln T + sigma d| <= sigma h.
    // The surface's own 1e-4 adds at most 1e-4 * 0.5 / cos 20 to -ln T.
    CHECK(std::fabs(std::log(surface.light_t) + slab.sigma * slab.d) <=
          slab.sigma * slab.step + 1e-4);
    CHECK(surface.light_t == doctest::Approx(std::exp(-slab.sigma * slab.d)).epsilon(0.01));
    // The slab's own samples (9.5 < k < 20.5): down to k = 19 the values fall into the slab or
    // stay flat (no gradient), so no normal faces the light: no shadow ray, T_light stays 1.
    // Below k = 19 they rise back to the air's: the normal faces up, the shadow ray crosses
    // the slab from the sample up to its top, (k - 9.5) / cos 20, to within one sample.
    int facing_away = 0, facing_light = 0;
    for (const LitSample& s : samples) {
        if (s.value >= 1500) continue;  // the surface
        CAPTURE(s.k);
        if (s.k <= 19) {
            ++facing_away;
            CHECK(s.shadow_samples == 0);
            CHECK(s.light_t == 1.0);
        } else {
            ++facing_light;
            CHECK(s.shadow_samples > 0);
            CHECK(std::fabs(std::log(s.light_t) + slab.sigma * (s.k - 9.5) / slab.cos_light) <=
                  slab.sigma * slab.step + 1e-6);
        }
    }
    CHECK(facing_away == 38);  // k = 9.75 .. 19 in steps of 0.25
    CHECK(facing_light == 5);  // k = 19.25 .. 20.25
    // Without shadow rays nothing blocks it: T_light = 1 everywhere, and no sample is read.
    for (const LitSample& s : slab.samples(shadow_rays_step, {"--shadows", "none"})) {
        CHECK(s.light_t == 1.0);
        CHECK(s.shadow_samples == 0);
    }
}

TEST_CASE("light volume (step 23): on the slab it gives Beer-Lambert too, within one segment "
          "of the shadow ray, for one read per voxel") {
    // The light-transmittance volume, swept slice by slice along k (the axis the light
    // crosses fastest) in segments d = 1 / cos 20 long: the slab's 11 slices of 3000 each
    // take (0.95)^d, so below the slab T_light = 0.95^(11 d) = exp(-sigma d) to float
    // rounding; it agrees with the shadow ray's answer to within one of its samples' optical
    // depth, sigma * step.
    const Slab slab;
    const std::vector<LitSample> samples = slab.samples(light_volume_step, {"--shadows", "ray"});
    const std::vector<LitSample> from_volume = slab.samples(light_volume_step, {});
    REQUIRE(from_volume.size() == samples.size());
    const size_t surface = first_surface_sample(samples);
    const LitSample& below = from_volume[surface];
    CHECK(below.k == doctest::Approx(35.5));
    CAPTURE(below.light_t);
    CHECK(below.light_t == doctest::Approx(std::exp(-slab.sigma * slab.d)).epsilon(1e-5));
    CHECK(std::fabs(std::log(below.light_t) - std::log(samples[surface].light_t)) <=
          slab.sigma * slab.step + 1e-4);
    CHECK(below.shadow_samples == 0);  // one trilinear read, no march
    // Inside the slab T_light falls along the ray: the volume, sampled every d along k and
    // read trilinearly, is within one segment's optical depth (sigma d) of the shadow ray.
    for (size_t n = 0; n < samples.size(); ++n) {
        CAPTURE(samples[n].k);
        CHECK(std::fabs(std::log(from_volume[n].light_t) - std::log(samples[n].light_t)) <=
              slab.sigma * (slab.step + 1 / slab.cos_light) + 1e-4);
    }
}

TEST_CASE("shadow rays and ambient occlusion (steps 22, 24): a lone voxel in empty space gets "
          "all the light, T_light = 1 and AO = 1") {
    // One voxel of 1000 (opacity 0.5) at (12, 16, 20) in air (2000, transparent), and under
    // it one of 3000 (transparent too), so that the values rise downwards through the voxel
    // and its normal faces up, to the light (a lone voxel alone has no gradient at its centre,
    // and needs no shadow ray). The ray of pixel (12, 16) from above reads it at its centre:
    // every occlusion probe (1 to 4 units along each axis) lands on a voxel centre of air or
    // of the 3000, every shadow-ray sample within 1 unit of it reads at most 1960 (the
    // voxel's trilinear weight there is under 0.04): nothing is in the way, exactly.
    const Volume volume = filled_volume(24, 32, 40, [](int i, int j, int k) {
        if (i != 12 || j != 16) return 2000;
        return k == 20 ? 1000 : k == 21 ? 3000 : 2000;
    });
    const TempFolder folder("shadows_lone");
    const std::vector<std::string> raw = write_raw_volume(volume, folder.path("lone.raw"));
    std::vector<std::string> flags = tf_flags(folder, "500 1500 constant 1 1 1 0.5\n");
    flags.insert(flags.end(), {"--azimuth", "180", "--elevation", "90", "--size", "24x32",
                               "--light-angle", "0", "--debug-pixel", "12,16"});
    int marched = 0;
    for (const std::string& step : {shadow_rays_step, ambient_occlusion_step}) {
        CAPTURE(step);
        const RunResult run = run_shadows(step, raw, flags, folder);
        REQUIRE(run.traces.size() == 1);
        const std::vector<LitSample> samples = lit_samples(run.traces[0]);
        REQUIRE(samples.size() == 1);
        CHECK(samples[0].k == doctest::Approx(20));
        CHECK(samples[0].light_t == 1.0);
        if (step == shadow_rays_step) {
            CHECK(samples[0].occlusion == -1);
            CHECK(samples[0].shadow_samples > 0);  // the shadow ray did read
            marched = samples[0].shadow_samples;
        } else {
            CHECK(samples[0].occlusion == 1.0);
            // The shadow ray's reads and the 24 occlusion probes (4 in each of 6 directions,
            // all inside the box here).
            CHECK(samples[0].shadow_samples == marched + 24);
        }
    }
}

TEST_CASE("ambient occlusion (step 24): inside a uniform medium it is (1 - alpha)^(radius / "
          "unit) in every direction") {
    // A uniform block, 24 x 32 x 40, of opacity 0.1 per unit (one range of the table covers
    // all its values, 1000 + 10 k: rising downwards, so every normal faces up, to the light,
    // and every sample marches its shadow ray): a sample at least 4 units from every face
    // sees the medium over the whole occlusion radius (4 units, samples 1 apart) in all six
    // directions: AO = 0.9^4 = 0.6561.
    const Volume volume =
        filled_volume(24, 32, 40, [](int, int, int k) { return 1000 + 10 * k; });
    const TempFolder folder("shadows_uniform");
    const std::vector<std::string> raw = write_raw_volume(volume, folder.path("block.raw"));
    std::vector<std::string> flags = tf_flags(folder, "500 1500 constant 1 1 1 0.1\n");
    flags.insert(flags.end(), {"--azimuth", "180", "--elevation", "90", "--size", "24x32",
                               "--light-angle", "0", "--ert", "0", "--debug-pixel", "12,16"});
    const RunResult run = run_shadows(ambient_occlusion_step, raw, flags, folder);
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

namespace {

// A small phantom picture (128x96, turned to azimuth -50) of `step` with `extra` flags.
Image small_picture(const std::string& step, const std::vector<std::string>& extra,
                    const TempFolder& folder) {
    // The phantom painted once in this process (harness.h), not by every run.
    std::vector<std::string> flags = ctlab_test::phantom_flags();
    flags.insert(flags.end(), {"--size", "128x96", "--zoom", "0.4", "--azimuth", "-50",
                               "--threads", "2", "--pfm", "--out", folder.path()});
    flags.insert(flags.end(), extra.begin(), extra.end());
    const RunResult run = run_step(step, flags);
    INFO(run.command() << "\n" << run.err);
    REQUIRE(run.status == 0);
    return read_pfm(step_output(folder.path(), step, "camera", "pfm"));
}

}  // namespace

TEST_CASE("shadows: each step with its new idea off is the step it builds on, bit for bit; "
          "with it on the picture only darkens") {
    const TempFolder folder("shadows_off");
    const Image step_12 = small_picture("15_trilinear", {}, folder);
    const Image rays = small_picture(shadow_rays_step, {}, folder);
    const Image swept = small_picture(light_volume_step, {}, folder);
    // Step 22 without shadow rays is step 15; step 23 with them is step 22; step 24 without
    // ambient occlusion is step 23, either way of finding T_light; all three with no shadows
    // at all are step 15.
    CHECK(largest_difference(small_picture(shadow_rays_step, {"--shadows", "none"}, folder),
                             step_12) == 0);
    CHECK(largest_difference(small_picture(light_volume_step, {"--shadows", "ray"}, folder),
                             rays) == 0);
    CHECK(largest_difference(small_picture(light_volume_step, {"--shadows", "none"}, folder),
                             step_12) == 0);
    CHECK(largest_difference(small_picture(ambient_occlusion_step, {"--ao", "off"}, folder), rays) == 0);
    CHECK(largest_difference(small_picture(ambient_occlusion_step, {"--ao", "off", "--shadows",
                                                            "volume"}, folder),
                             swept) == 0);
    CHECK(largest_difference(small_picture(ambient_occlusion_step, {"--ao", "off", "--shadows",
                                                            "none"}, folder),
                             step_12) == 0);
    // With each on, the picture only darkens: blocked light is never more light.
    const Image occluded = small_picture(ambient_occlusion_step, {}, folder);
    for (const auto& [darker_image, lighter_image] :
         std::vector<std::pair<const Image*, const Image*>>{
             {&rays, &step_12}, {&swept, &step_12}, {&occluded, &rays}}) {
        int darker = 0, lighter = 0;
        for (size_t n = 0; n < step_12.pixels.size(); ++n) {
            darker += darker_image->pixels[n].r < lighter_image->pixels[n].r;
            lighter += darker_image->pixels[n].r > lighter_image->pixels[n].r + 1e-6f;
        }
        CHECK(lighter == 0);
        CHECK(darker > 500);
    }
}

TEST_CASE("shadows: bad flags are refused with status 2, naming the flag") {
    const std::vector<std::pair<std::string, std::vector<std::string>>> refused = {
        {shadow_rays_step, {"--shadows", "map"}},
        {shadow_rays_step, {"--shadows", "volume"}},  // step 23's
        {shadow_rays_step, {"--ao", "on"}},           // step 24's
        {light_volume_step, {"--shadows", "map"}},
        {light_volume_step, {"--ao", "on"}},
        {ambient_occlusion_step, {"--ao", "yes"}}};
    for (const auto& [step, flags] : refused) {
        std::vector<std::string> args = {"--volume", "phantom", "--no-window"};
        args.insert(args.end(), flags.begin(), flags.end());
        const RunResult run = run_step(step, args);
        CAPTURE(run.command());
        CHECK(run.status == 2);
        // "error: --shadows: ..." for a bad value, "error: unknown option '--ao'" for a flag
        // of a later step: either way the flag is named.
        CHECK(run.err.find("error: ") != std::string::npos);
        CHECK(run.err.find(flags[0]) != std::string::npos);
    }
}

// The phantom's picture of step 23 with these flags, at `size` pixels covering the default
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
    std::vector<std::string> flags = ctlab_test::phantom_flags();  // painted once (harness.h)
    flags.insert(flags.end(), {"--size", std::to_string(size) + "x" + std::to_string(size),
                               "--zoom", size == 512 ? "1" : "0.5", "--threads", "2", "--pfm",
                               "--out", folder.path()});
    flags.insert(flags.end(), extra.begin(), extra.end());
    Picture picture;
    picture.run = run_step(light_volume_step, flags);
    INFO(picture.run.command() << "\n" << picture.run.err);
    REQUIRE(picture.run.status == 0);
    picture.image = read_pfm(step_output(folder.path(), light_volume_step, "camera", "pfm"));
    return picture;
}

TEST_CASE("light volume (step 23): it gives the shadow rays' picture for one read per voxel, "
          "where the shadow rays read per lit sample") {
    const TempFolder folder("shadows_volume");
    const Picture rays = phantom_picture({"--shadows", "ray"}, folder);
    const Picture swept = phantom_picture({}, folder);
    const Picture open = phantom_picture({"--shadows", "none"}, folder);
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
    const Picture rays_512 = phantom_picture({"--shadows", "ray"}, folder, 512);
    const Picture swept_512 = phantom_picture({}, folder, 512);
    const Picture open_512 = phantom_picture({"--shadows", "none"}, folder, 512);
    const unsigned long long marched_512 = rays_512.count("samples") - open_512.count("samples");
    CHECK(swept_512.count("samples") - open_512.count("samples") == sweep);
    CAPTURE(marched);
    CAPTURE(marched_512);
    CHECK(marched_512 > 3 * marched);
    CHECK(swept_512.count("samples") < rays_512.count("samples"));
    // and its steps along the shadow rays several times the sweep's reads
    CHECK(marched_512 > 4 * sweep);
}
