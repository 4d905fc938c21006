// 08_compositing_order.cpp: the same picture front to back, and stopping when it is opaque.
//
// New here:   front-to-back compositing with the accumulated transparency T; early ray
//             termination once T is below a threshold; the background blended in at the end;
//             --order b2f keeps step 07's back to front (tests compare the two orders).
// Builds on:  07_back_to_front.
// Handout:    handouts/08_compositing_order.md
// Run:        make run STEP=08 ARGS="--ert 0.1 --view top"
// Reference:  data/reference/08_compositing_order_<view>.png: the default run, on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "08_compositing_order";
constexpr const char* skin_label = "skin";  // the range --skin-opacity and the knob change
constexpr double skin_key_step = 0.02;      // opacity per Up/Down key press
constexpr Rgb background = {0, 0, 0};       // what a ray sees behind the volume: black
constexpr double default_ert = 0.01;        // stop a ray once T is below this; 0: never
constexpr double min_transparency = 1e-300;  // stop below this T even with --ert 0

struct Params {
    std::string tf_path;       // "": data/tf/classic.tf when present, else the built-in copy
    double skin_opacity = -1;  // 0..1; -1: as the transfer function file says
    double ert = default_ert;  // early ray termination threshold for T
    std::string order = "f2b";  // f2b or b2f
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

//> lesson: back_to_front
// Back to front, as the lecture first draws it: start with the background at the far end of
// the ray and walk towards the viewer. Each sample covers what lies behind it and lets
// 1 - alpha of it through: C = alpha*L*c + (1 - alpha)*C, with L = 1 (unlit) for now.
// A transparent sample (alpha = 0) changes nothing: skip it. The sums run in double: near 1
// a float only resolves 6e-8, so 1 - alpha for a tiny alpha would be far off.
static Rgb composite_back_to_front(const Volume& volume, const View& view, int x, int y,
                                   const Lut& lut, Work& work, Trace* trace) {
    double r = background.r, g = background.g, b = background.b;  // C
    for (int n = view.ray_length - 1; n >= 0; --n) {
        const Voxel voxel = view.voxel(x, y, n);
        const int value = volume.at(voxel.i, voxel.j, voxel.k);
        const Rgba& sample = lut.entries[value - lowest_ct_value];  // the TF
        ++work.samples;
        if (sample.a == 0.0f) {
            ++work.skipped;
            if (trace) trace->sample(TraceSample(n, voxel, value).skipped());
            continue;
        }
        const double light = 1.0;  // unlit: step 10 lights the samples
        const double alpha = sample.a;  // the opacity, after the TF
        r = alpha * light * sample.r + (1 - alpha) * r;
        g = alpha * light * sample.g + (1 - alpha) * g;
        b = alpha * light * sample.b + (1 - alpha) * b;
        if (trace) trace->sample(TraceSample(n, voxel, value).rgba(sample).colour(r, g, b));
    }
    return {float(r), float(g), float(b)};
}
//< lesson: back_to_front

//> lesson: front_to_back
// Front to back: from the viewer into the volume, keeping T, the share of what lies further
// back that still shows: C += T*alpha*L*c, then T *= 1 - alpha, from C = 0 and T = 1.
// T only shrinks, so once it is below the threshold the rest of the ray can change C by less
// than T*max(c): stop there (early ray termination). Even with --ert 0, stop once T is below
// 1e-300: nothing behind can show, and one more sample (T times 1 - alpha, at least 6e-8 for
// a float alpha < 1) could make T subnormal (below 2.2e-308), where arithmetic is slow.
static Accumulated composite_front_to_back(const Volume& volume, const View& view, int x, int y,
                                           const Lut& lut, const Params& params, Work& work,
                                           Trace* trace) {
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
        const double light = 1.0;  // unlit: step 10 lights the samples
        const double alpha = sample.a;  // the opacity, after the TF
        const double weight = ray.transparency * alpha * light;
        ray.r += weight * sample.r;
        ray.g += weight * sample.g;
        ray.b += weight * sample.b;
        ray.transparency *= 1 - alpha;
        if (trace) {
            trace->sample(TraceSample(n, voxel, value).rgba(sample).colour(ray.r, ray.g, ray.b)
                              .transparency(ray.transparency));
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
        Args args(step_name, "Translucent skin over bone, composited front to back with early "
                             "ray termination (or back to front).");
        args.add_string("--tf", &params.tf_path,
                        "transfer function file (default data/tf/classic.tf)");
        args.add_double("--skin-opacity", &params.skin_opacity, 0, 1,
                        "opacity of the range labelled skin (default: as the file says)");
        args.add_double("--ert", &params.ert, 0, 1,
                        "stop a ray once its transparency T is below this (0: never)");
        args.add_choice("--order", &params.order, {"f2b", "b2f"},
                        "compositing order: front to back or back to front");
        const Options options = args.parse(argc, argv);

        // --- Volume ---
        const Volume volume = load_volume(options);

        // --- Transfer function: the file (in the volume file's units), its lookup table ---
        TransferFunction tf = load_transfer_function(params.tf_path, volume.map);
        if (params.skin_opacity >= 0) {
            set_opacity(tf, skin_label, params.skin_opacity, "--skin-opacity");
        }
        Lut lut = build_lut(tf);

        // --- Render: one ray per pixel ---
        Renderer renderer;
        renderer.transfer_function = &tf;  // the ray picture draws its ranges
        renderer.ray = [&](const View& view, int x, int y, Work& work, Trace* trace) {
            if (params.order == "b2f") {
                return composite_back_to_front(volume, view, x, y, lut, work, trace);
            }
            return over_background(composite_front_to_back(volume, view, x, y, lut, params,
                                                           work, trace));
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
            return "tf=" + tf.source + " order=" + params.order +
                   " ert=" + summary_number(params.ert);
        };

        // --- Output: a PNG and a summary line per view, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
