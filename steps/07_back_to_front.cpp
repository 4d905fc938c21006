// 07_back_to_front.cpp: every sample counts: the table's colours blended back to front.
//
// New here:   compositing back to front, from the background at the far end of the ray to
//             the viewer; the first-visible search of step 06 is gone: every sample counts.
// Builds on:  06_transfer_function (the lookup table).
// Handout:    handouts/07_back_to_front.md
// Run:        make run STEP=07 ARGS="--skin-opacity 0.3 --view side"
// Reference:  data/reference/07_back_to_front_<view>.png: the default run, on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "07_back_to_front";
constexpr const char* skin_label = "skin";  // the range --skin-opacity and the knob change
constexpr double skin_key_step = 0.02;      // opacity per Up/Down key press
constexpr Rgb background = {0, 0, 0};       // what a ray sees behind the volume: black

struct Params {
    std::string tf_path;       // "": data/tf/classic.tf when present, else the built-in copy
    double skin_opacity = -1;  // 0..1; -1: as the transfer function file says
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

int main(int argc, char** argv) {
    return guarded_main(step_name, [&] {
        // --- Options: the shared flags plus this step's own ---
        Params params;
        Args args(step_name, "Translucent skin over bone: a transfer function, composited "
                             "back to front.");
        args.add_string("--tf", &params.tf_path,
                        "transfer function file (default data/tf/classic.tf)");
        args.add_double("--skin-opacity", &params.skin_opacity, 0, 1,
                        "opacity of the range labelled skin (default: as the file says)");
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
            return composite_back_to_front(volume, view, x, y, lut, work, trace);
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
        renderer.settings = [&] { return "tf=" + tf.source; };

        // --- Output: a PNG and a summary line per view, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
