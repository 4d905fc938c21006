// 10_opacity_correction.cpp: sample in physical units, and correct the opacity for the step.
//
// New here:   samples --step physical units apart, linear between voxels (as in step 05), with
//             opacity corrected for the step: the picture keeps its opacity at any step.
// Builds on:  09_lit_compositing (lit front to back with early ray termination).
// Handout:    handouts/10_opacity_correction.md
// Run:        make run STEP=10 ARGS="--step 0.5 --view top"
// Reference:  data/reference/10_opacity_correction_<view>.png: the default run, on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "10_opacity_correction";
constexpr const char* skin_label = "skin";  // the range --skin-opacity changes
constexpr Rgb background = {0, 0, 0};       // what a ray sees behind the volume: black
constexpr double default_ert = 0.01;        // stop a ray once T is below this; 0: never
constexpr double min_transparency = 1e-300;  // stop below this T even with --ert 0
constexpr double unit_length = 1;     // physical length the TF opacities hold for: one voxel
                                      // at spacing 1
constexpr double default_step = 1;    // physical units between two samples along a ray
constexpr double min_step = 0.25, max_step = 4;  // --step limits, physical units
constexpr double step_key_factor = 2;            // Up doubles the step, Down halves it
constexpr double default_light_angle = 30;  // degrees to the right of the viewer
constexpr double light_elevation = 20;      // degrees above the viewer, fixed
constexpr float ambient = 0.1f;             // light that reaches every surface, 0..1
constexpr double degrees = 3.14159265358979323846 / 180;

struct Params {
    std::string tf_path;       // "": data/tf/classic.tf when present, else the built-in copy
    double skin_opacity = -1;  // 0..1; -1: as the transfer function file says
    double ert = default_ert;  // early ray termination threshold for T
    double step = default_step;  // physical units between samples
    double light_angle = default_light_angle;
    bool unlit = false;          // L = 1 everywhere, no gradients (as step 08)
    bool no_correction = false;  // use the TF opacities as they are, whatever the step
};

// What a ray has gathered so far, front to back (in double, as step 07 explains).
struct Accumulated {
    double r = 0, g = 0, b = 0;  // colour, each sample weighted by its opacity and T
    double transparency = 1;     // T: the share of what lies further back that still shows
};

//> lesson: opacity_correction
// The TF's opacity alpha holds for one unit of length. A sample that stands for `ratio` units
// lets (1 - alpha)^ratio through, so its opacity is alpha' = 1 - (1 - alpha)^ratio. Computed
// as -expm1(ratio * log1p(-alpha)): the plain form loses its digits when alpha or the result
// is tiny. alpha = 0 stays 0 and alpha = 1 stays 1 (log1p(-1) would be -infinity).
static float corrected_opacity(float alpha, double ratio) {
    if (alpha <= 0.0f) return 0.0f;
    if (alpha >= 1.0f) return 1.0f;
    return float(-std::expm1(ratio * std::log1p(-double(alpha))));
}

// How many units of length one sample stands for (1 with --no-correction: the TF unchanged).
static double opacity_ratio(const Params& params) {
    return params.no_correction ? 1.0 : params.step / unit_length;
}
//< lesson: opacity_correction

// The lookup table: one RGBA entry per CT value, -32768..32767. The entry of `value` is
// entries[value - lowest_ct_value], so any int16 is a valid index. A new table is transparent.
struct Lut {
    std::vector<Rgba> entries = std::vector<Rgba>(ct_value_end - lowest_ct_value);
};

//> lesson: lookup_table
// The colour a fraction f of the way from a to b (f = 0 gives a exactly).
static Rgba mix(const Rgba& a, const Rgba& b, float f) {
    return {a.r + f * (b.r - a.r), a.g + f * (b.g - a.g), a.b + f * (b.b - a.b),
            a.a + f * (b.a - a.a)};
}

// The table of a transfer function: classifying a sample is then a single read. Values no
// range covers stay transparent. A ramp goes linearly from its start at `from` to its end at
// `to`. The opacities are corrected here, once per entry, for samples `ratio` units apart.
// Changed in step 10: each entry's opacity corrected for the spacing.
static Lut build_lut(const TransferFunction& tf, double ratio) {
    Lut lut;  // every entry {0, 0, 0, 0}
    for (const TfRange& range : tf.ranges) {
        const float width = float(range.to - range.from);
        for (int value = range.from; value < range.to; ++value) {
            const float f = range.ramp ? float(value - range.from) / width : 0.0f;
            Rgba& entry = lut.entries[value - lowest_ct_value];
            entry = mix(range.start, range.end, f);
            entry.a = corrected_opacity(entry.a, ratio);
        }
    }
    return lut;
}
//< lesson: lookup_table

//> lesson: sample_along_ray
// The CT value a fraction (0..1) of the way from the ray's voxel `before` to the next one:
// linear between the two; past the last voxel it stays at the last one (nothing outside).
static float value_along_ray(const Volume& volume, const View& view, int x, int y, int before,
                             float fraction) {
    const int after = std::min(before + 1, view.ray_length - 1);
    const Voxel voxel_before = view.voxel(x, y, before), voxel_after = view.voxel(x, y, after);
    const float value_before = volume.at(voxel_before.i, voxel_before.j, voxel_before.k);
    const float value_after = volume.at(voxel_after.i, voxel_after.j, voxel_after.k);
    return value_before + fraction * (value_after - value_before);
}
//< lesson: sample_along_ray

//> lesson: gradient
// The derivative along one axis at index n (of count samples, spacing apart); sample(m) reads
// the volume at index m on that axis. Central inside, one-sided at the border: never outside.
template <class Sample>
static float derivative(Sample sample, int n, int count, double spacing) {
    if (count == 1) return 0.0f;  // a volume one voxel thick has no slope along this axis
    if (n == 0) return float((sample(1) - sample(0)) / spacing);
    if (n == count - 1) return float((sample(n) - sample(n - 1)) / spacing);
    return float((sample(n + 1) - sample(n - 1)) / (2 * spacing));
}

// The gradient of the CT values at voxel (i, j, k): it points into denser material.
static Vec3 gradient_at(const Volume& volume, const Voxel& voxel, Work& work) {
    const int i = voxel.i, j = voxel.j, k = voxel.k;
    ++work.gradients;
    auto along_i = [&](int m) { return double(volume.at(m, j, k)); };
    auto along_j = [&](int m) { return double(volume.at(i, m, k)); };
    auto along_k = [&](int m) { return double(volume.at(i, j, m)); };
    return {derivative(along_i, i, volume.nx, volume.sx),
            derivative(along_j, j, volume.ny, volume.sy),
            derivative(along_k, k, volume.nz, volume.sz)};
}

// The gradient a fraction (0..1) of the way from the ray's voxel `before` to the next one:
// interpolated between the two, as the CT values were. The index stays an int: a float holds
// every integer only up to 2^24, and int(float(16777219)) would be one past the last voxel.
static Vec3 gradient_along_ray(const Volume& volume, const View& view, int x, int y, int before,
                               float fraction, Work& work) {
    const int after = std::min(before + 1, view.ray_length - 1);
    const Vec3 gradient_before = gradient_at(volume, view.voxel(x, y, before), work);
    if (fraction == 0.0f) return gradient_before;
    const Vec3 gradient_after = gradient_at(volume, view.voxel(x, y, after), work);
    return (1.0f - fraction) * gradient_before + fraction * gradient_after;
}
//< lesson: gradient

//> lesson: shade
// Diffuse lighting: ambient + (1 - ambient) * max(0, N.L), N the outward normal -grad/|grad|.
// A zero gradient (inside a uniform region) has no normal: such a point gets ambient only.
static float shade(Vec3 gradient, Vec3 to_light) {
    const float size = length(gradient);
    if (size == 0.0f) return ambient;
    const Vec3 normal = (-1.0f / size) * gradient;
    return ambient + (1.0f - ambient) * std::max(0.0f, dot(normal, to_light));
}

// Unit direction towards the light, in volume space: angle to the right, elevation upwards.
static Vec3 light_direction(const View& view, double angle) {
    const float along_x = float(std::sin(angle * degrees) * std::cos(light_elevation * degrees));
    const float along_y = float(-std::sin(light_elevation * degrees));  // image y points down
    const float along_ray = float(-std::cos(angle * degrees) * std::cos(light_elevation * degrees));
    return volume_direction(view, along_x, along_y, along_ray);
}
//< lesson: shade

// Samples along a ray: its depth over `step`, at least one (an int: too_many_samples()).
static int samples_along_ray(const View& view, double step) {
    return std::max(1, int(std::lround(view.ray_length * view.ray_spacing / step)));
}

//> lesson: front_to_back
// Front to back: from the viewer into the volume, keeping T, the share of what lies further
// back that still shows: C += T*alpha*L*c, then T *= 1 - alpha, from C = 0 and T = 1.
// T only shrinks, so once it is below the threshold the rest of the ray can change C by less
// than T*max(c): stop there (early ray termination). Even with --ert 0, stop once T is below
// 1e-300: nothing behind can show, and one more sample (T times 1 - alpha, at least 6e-8 for
// a float alpha < 1) could make T subnormal (below 2.2e-308), where arithmetic is slow.
// The light L (0..1) darkens the colour only, never the opacity.
// Changed in step 10: samples `step` physical units apart, between the voxels.
static Accumulated composite_front_to_back(const Volume& volume, const View& view, int x, int y,
                                           const Lut& lut, Vec3 to_light, const Params& params,
                                           Work& work, Trace* trace) {
    const double stop_below = std::max(params.ert, min_transparency);
    const int sample_count = samples_along_ray(view, params.step);
    const double voxels_per_sample = params.step / view.ray_spacing;
    Accumulated ray;
    for (int n = 0; n < sample_count; ++n) {
        const double t = n * params.step;  // physical units from the first voxel
        const double position = n * voxels_per_sample;  // the same in voxels, fractional
        const int before = std::min(int(position), view.ray_length - 1);  // voxel at or before
        const float fraction = float(position - before);  // of the way to the next voxel, 0..1
        const float value = value_along_ray(volume, view, x, y, before, fraction);
        // The entry of the whole value at or below it (the range [from, to) it falls into):
        // value - lowest_ct_value >= 0, so int() rounds down.
        const Rgba& sample = lut.entries[int(double(value) - lowest_ct_value)];
        ++work.samples;
        if (sample.a == 0.0f) {
            ++work.skipped;
            if (trace) trace->sample(TraceSample(t, value).skipped());
            continue;
        }
        double light = 1.0;  // unlit
        if (!params.unlit) {
            light = shade(gradient_along_ray(volume, view, x, y, before, fraction, work),
                          to_light);
        }
        const double alpha = sample.a;  // the opacity, after the TF
        const double weight = ray.transparency * alpha * light;
        ray.r += weight * sample.r;
        ray.g += weight * sample.g;
        ray.b += weight * sample.b;
        ray.transparency *= 1 - alpha;
        if (trace) {
            trace->sample(TraceSample(t, value).rgba(sample).light(light)
                              .colour(ray.r, ray.g, ray.b).transparency(ray.transparency));
        }
        if (ray.transparency < stop_below && n + 1 < sample_count) {
            ++work.terminated;
            if (trace) trace->stop(ray.transparency, stop_below, sample_count - 1 - n);
            break;
        }
    }
    return ray;
}

// What the ray left transparent shows the background: C + T*background.
static Rgb over_background(const Accumulated& ray) {
    return {float(ray.r + ray.transparency * background.r),
            float(ray.g + ray.transparency * background.g),
            float(ray.b + ray.transparency * background.b)};
}
//< lesson: front_to_back

int main(int argc, char** argv) {
    return guarded_main(step_name, [&] {
        // --- Options: the shared flags plus this step's own ---
        Params params;
        Args args(step_name, "Translucent skin over bone, composited front to back, each "
                             "sample lit, --step units apart, with opacity correction.");
        args.add_string("--tf", &params.tf_path,
                        "transfer function file (default data/tf/classic.tf)");
        args.add_double("--skin-opacity", &params.skin_opacity, 0, 1,
                        "opacity of the range labelled skin (default: as the file says)");
        args.add_double("--ert", &params.ert, 0, 1,
                        "stop a ray once its transparency T is below this (0: never)");
        args.add_double("--step", &params.step, min_step, max_step,
                        "physical units between two samples along a ray");
        args.add_double("--light-angle", &params.light_angle, -180, 180,
                        "light direction, degrees to the right of the viewer");
        args.add_switch("--unlit", &params.unlit, "no lighting: L = 1, as in step 08");
        args.add_switch("--no-correction", &params.no_correction,
                        "use the TF opacities unchanged, whatever the step");
        const Options options = args.parse(argc, argv);

        // --- Volume ---
        const Volume volume = load_volume(options);
        const std::string refused = too_many_samples(volume, params.step);
        if (!refused.empty()) throw InputError(refused);

        // --- Transfer function: the file (in the file's units), its table for this step size ---
        TransferFunction tf = load_transfer_function(params.tf_path, volume.map);
        if (params.skin_opacity >= 0) {
            set_opacity(tf, skin_label, params.skin_opacity, "--skin-opacity");
        }
        Lut lut = build_lut(tf, opacity_ratio(params));

        // --- Light: towards it from every ray of a view, so worked out once per view (its sin
        // and cos would cost a ray more than its samples); none with --unlit ---
        Vec3 to_light[3] = {};  // by ViewAxis: top, front, side
        for (const View& view : views_named(volume, "all")) {
            if (!params.unlit) to_light[int(view.axis)] = light_direction(view, params.light_angle);
        }

        // --- Render: one ray per pixel ---
        Renderer renderer;
        renderer.transfer_function = &tf;  // the ray picture draws its ranges
        renderer.ray = [&](const View& view, int x, int y, Work& work, Trace* trace) {
            return over_background(composite_front_to_back(
                volume, view, x, y, lut, to_light[int(view.axis)], params, work, trace));
        };
        renderer.ray_samples = [&](const View& view) {
            return samples_at_step(samples_along_ray(view, params.step), params.step, view);
        };
        renderer.knob = {"step",
                         [&](const View&, int steps) {
                             const double step = std::clamp(
                                 params.step * std::pow(step_key_factor, steps), min_step,
                                 max_step);
                             if (!too_many_samples(volume, step).empty()) return;  // keep it
                             params.step = step;
                             lut = build_lut(tf, opacity_ratio(params));
                         },
                         [&] { return summary_number(params.step); }};
        renderer.settings = [&] {
            const TfRange* skin = find_range(tf, skin_label);
            return "tf=" + tf.source +
                   " skin_opacity=" + (skin ? summary_number(skin->start.a) : std::string("none")) +
                   " ert=" + summary_number(params.ert) +
                   " light_angle=" + std::to_string(int(std::lround(params.light_angle))) +
                   " lighting=" + (params.unlit ? "off" : "on") +
                   " correction=" + (params.no_correction ? "off" : "on");
        };

        // --- Output: a PNG and a summary line per view, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
