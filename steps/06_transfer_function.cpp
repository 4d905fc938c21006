// 06_transfer_function.cpp: a colour and an opacity per CT value: the transfer function.
//
// New here:   a transfer function file (data/tf/classic.tf) turned into a lookup table with
//             one RGBA entry per CT value; each ray shows the table's colour at its first
//             sample the table does not leave transparent (steps 02-05's first-hit search,
//             the table in place of the threshold), lit by its gradient as in step 05.
// Builds on:  05_interpolated_hits (one ray per pixel along the view axis).
// Handout:    handouts/06_transfer_function.md
// Run:        make run STEP=06 ARGS="--skin-opacity 0 --view side"
// Reference:  data/reference/06_transfer_function_<view>.png: the default run, on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "06_transfer_function";
constexpr const char* skin_label = "skin";  // the range --skin-opacity and the knob change
constexpr double skin_key_step = 0.02;      // opacity per Up/Down key press
constexpr Rgb background = {0, 0, 0};       // what a ray sees behind the volume: black
constexpr double default_light_angle = 30;  // degrees to the right of the viewer
constexpr double light_elevation = 20;      // degrees above the viewer, fixed
constexpr float ambient = 0.1f;             // light that reaches every surface, 0..1
constexpr double degrees = 3.14159265358979323846 / 180;

struct Params {
    std::string tf_path;       // "": data/tf/classic.tf when present, else the built-in copy
    double skin_opacity = -1;  // 0..1; -1: as the transfer function file says
    double light_angle = default_light_angle;
};

// The lookup table: one RGBA entry per CT value, -32768..32767. The entry of `value` is
// entries[value - lowest_ct_value], so any int16 is a valid index. A new table is transparent.
struct Lut {
    std::vector<Rgba> entries = std::vector<Rgba>(ct_value_end - lowest_ct_value);
};

struct Visible {
    bool found = false;
    int n = 0;     // index of the sample where it was found
    Rgba colour;   // its entry in the table
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

//> lesson: first_visible
// The first sample along the ray that the table does not leave transparent (alpha > 0): the
// pixel shows its colour, lit as step 05 lit the surface. The ray stops there, as steps 02-05
// stopped at the threshold; a ray that meets nothing shows the background.
static Visible first_visible(const Volume& volume, const View& view, int x, int y,
                             const Lut& lut, Work& work, Trace* trace) {
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
        ++work.hits;
        if (n + 1 < view.ray_length) ++work.terminated;
        if (trace) trace->sample(TraceSample(n, voxel, value).rgba(sample));
        return {true, n, sample};
    }
    return {};
}
//< lesson: first_visible

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

int main(int argc, char** argv) {
    return guarded_main(step_name, [&] {
        // --- Options: the shared flags plus this step's own ---
        Params params;
        Args args(step_name, "The transfer function's colour at the first sample it does "
                             "not leave transparent, lit by its gradient.");
        args.add_string("--tf", &params.tf_path,
                        "transfer function file (default data/tf/classic.tf)");
        args.add_double("--skin-opacity", &params.skin_opacity, 0, 1,
                        "opacity of the range labelled skin (default: as the file says)");
        args.add_double("--light-angle", &params.light_angle, -180, 180,
                        "light direction, degrees to the right of the viewer");
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
            const Visible visible = first_visible(volume, view, x, y, lut, work, trace);
            if (!visible.found) return background;
            const Vec3 gradient = gradient_along_ray(volume, view, x, y, visible.n, 0.0f, work);
            const float light = shade(gradient, light_direction(view, params.light_angle));
            if (trace) trace->gradient(gradient, light);
            return Rgb{light * visible.colour.r, light * visible.colour.g,
                       light * visible.colour.b};
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
            return "tf=" + tf.source +
                   " light_angle=" + std::to_string(int(std::lround(params.light_angle)));
        };

        // --- Output: a PNG and a summary line per view, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
