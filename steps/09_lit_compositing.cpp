// 09_lit_compositing.cpp: light every sample.
//
// New here:   L from gradient lighting (steps 04-05) for every sample composited front to
//             back, evaluated only where alpha > 0; the light darkens a sample's colour, never
//             its opacity. --unlit gives step 08's picture.
// Builds on:  08_compositing_order (front to back with early ray termination).
// Handout:    handouts/09_lit_compositing.md
// Run:        make run STEP=09 ARGS="--light-angle -60 --view top"
// Reference:  data/reference/09_lit_compositing_<view>.png: the default run, on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "09_lit_compositing";
constexpr const char* skin_label = "skin";  // the range --skin-opacity and the knob change
constexpr double skin_key_step = 0.02;      // opacity per Up/Down key press
constexpr Rgb background = {0, 0, 0};       // what a ray sees behind the volume: black
constexpr double default_ert = 0.01;        // stop a ray once T is below this; 0: never
constexpr double min_transparency = 1e-300;  // stop below this T even with --ert 0
constexpr double default_light_angle = 30;  // degrees to the right of the viewer
constexpr double light_elevation = 20;      // degrees above the viewer, fixed
constexpr float ambient = 0.1f;             // light that reaches every surface, 0..1
constexpr double degrees = 3.14159265358979323846 / 180;

struct Params {
    std::string tf_path;       // "": data/tf/classic.tf when present, else the built-in copy
    double skin_opacity = -1;  // 0..1; -1: as the transfer function file says
    double ert = default_ert;  // early ray termination threshold for T
    double light_angle = default_light_angle;
    bool unlit = false;          // L = 1 everywhere, no gradients (as step 08)
};

// What a ray has gathered so far, front to back (in double, as step 07 explains).
struct Accumulated {
    double r = 0, g = 0, b = 0;  // colour, each sample weighted by its opacity and T
    double transparency = 1;     // T: the share of what lies further back that still shows
};

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
// `to`.
static Lut build_lut(const TransferFunction& tf) {
    Lut lut;  // every entry {0, 0, 0, 0}
    for (const TfRange& range : tf.ranges) {
        const float width = float(range.to - range.from);
        for (int value = range.from; value < range.to; ++value) {
            const float f = range.ramp ? float(value - range.from) / width : 0.0f;
            lut.entries[value - lowest_ct_value] = mix(range.start, range.end, f);
        }
    }
    return lut;
}
//< lesson: lookup_table

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

//> lesson: front_to_back
// Front to back: from the viewer into the volume, keeping T, the share of what lies further
// back that still shows: C += T*alpha*L*c, then T *= 1 - alpha, from C = 0 and T = 1.
// T only shrinks, so once it is below the threshold the rest of the ray can change C by less
// than T*max(c): stop there (early ray termination). Even with --ert 0, stop once T is below
// 1e-300: nothing behind can show, and one more sample (T times 1 - alpha, at least 6e-8 for
// a float alpha < 1) could make T subnormal (below 2.2e-308), where arithmetic is slow.
// The light L (0..1) darkens the colour only, never the opacity.
// Changed in step 09: lit samples.
static Accumulated composite_front_to_back(const Volume& volume, const View& view, int x, int y,
                                           const Lut& lut, Vec3 to_light, const Params& params,
                                           Work& work, Trace* trace) {
    const double stop_below = std::max(params.ert, min_transparency);
    Accumulated ray;
    for (int n = 0; n < view.ray_length; ++n) {
        const Voxel voxel = view.voxel(x, y, n);
        const int value = volume.at(voxel.i, voxel.j, voxel.k);
        const Rgba& sample = lut.entries[value - lowest_ct_value];  // the TF
        ++work.samples;
        if (sample.a == 0.0f) {
            ++work.skipped;
            if (trace) trace->sample(TraceSample(n, voxel, value).skipped());
            continue;
        }
        double light = 1.0;  // unlit
        if (!params.unlit) light = shade(gradient_at(volume, voxel, work), to_light);
        const double alpha = sample.a;  // the opacity, after the TF
        const double weight = ray.transparency * alpha * light;
        ray.r += weight * sample.r;
        ray.g += weight * sample.g;
        ray.b += weight * sample.b;
        ray.transparency *= 1 - alpha;
        if (trace) {
            trace->sample(TraceSample(n, voxel, value).rgba(sample).light(light)
                              .colour(ray.r, ray.g, ray.b).transparency(ray.transparency));
        }
        if (ray.transparency < stop_below && n + 1 < view.ray_length) {
            ++work.terminated;
            if (trace) trace->stop(ray.transparency, stop_below, view.ray_length - 1 - n);
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
                             "sample lit by the gradient.");
        args.add_string("--tf", &params.tf_path,
                        "transfer function file (default data/tf/classic.tf)");
        args.add_double("--skin-opacity", &params.skin_opacity, 0, 1,
                        "opacity of the range labelled skin (default: as the file says)");
        args.add_double("--ert", &params.ert, 0, 1,
                        "stop a ray once its transparency T is below this (0: never)");
        args.add_double("--light-angle", &params.light_angle, -180, 180,
                        "light direction, degrees to the right of the viewer");
        args.add_switch("--unlit", &params.unlit, "no lighting: L = 1, as in step 08");
        const Options options = args.parse(argc, argv);

        // --- Volume ---
        const Volume volume = load_volume(options);

        // --- Transfer function: the file (in the volume file's units), its lookup table ---
        TransferFunction tf = load_transfer_function(params.tf_path, volume.map);
        if (params.skin_opacity >= 0) {
            set_opacity(tf, skin_label, params.skin_opacity, "--skin-opacity");
        }
        Lut lut = build_lut(tf);

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
        renderer.knob = {"skin_opacity",
                         [&](const View&, int steps) {
                             const TfRange* skin = find_range(tf, skin_label);
                             if (!skin) return;  // this file has no skin range to change
                             const double opacity = skin->start.a + steps * skin_key_step;
                             set_opacity(tf, skin_label, std::clamp(opacity, 0.0, 1.0), "key");
                             lut = build_lut(tf);
                         },
                         [&] {
                             const TfRange* skin = find_range(tf, skin_label);
                             return skin ? summary_number(skin->start.a) : std::string("none");
                         }};
        renderer.settings = [&] {
            return "tf=" + tf.source + " ert=" + summary_number(params.ert) +
                   " light_angle=" + std::to_string(int(std::lround(params.light_angle))) +
                   " lighting=" + (params.unlit ? "off" : "on");
        };

        // --- Output: a PNG and a summary line per view, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
