// 05_interpolated_hits.cpp: find the surface between two samples, not at one.
//
// New here:   the crossing between the last sample at or below the threshold and the first
//             above it (linear interpolation); the gradient interpolated there.
// Builds on:  04_gradient_lighting.
// Handout:    handouts/05_interpolated_hits.md
// Run:        make run STEP=05 ARGS="--view front"
// Reference:  data/reference/05_interpolated_hits_<view>.png: the default run, on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "05_interpolated_hits";
constexpr int bone_threshold = 400;  // CT value: bone starts about 300; 400 keeps it clean
constexpr int threshold_key_step = 50;      // CT units per Up/Down key press
constexpr double default_light_angle = 30;  // degrees to the right of the viewer
constexpr double light_elevation = 20;      // degrees above the viewer, fixed
constexpr float ambient = 0.1f;             // light that reaches every surface, 0..1
constexpr double degrees = 3.14159265358979323846 / 180;

struct Params {
    int threshold = bone_threshold;  // a hit is a value strictly above this
    double light_angle = default_light_angle;
};

struct Hit {
    bool found = false;
    int n = 0;           // index of the last sample before the crossing (exact: an index)
    float fraction = 0;  // how far past sample n the crossing lies, 0 <= fraction < 1
};

//> lesson: first_hit
// The first crossing of the threshold: between the last sample at or below it (value v0, at
// n - 1) and the first above it (v1, at n), a fraction (threshold - v0) / (v1 - v0) of the way
// from n - 1 to n. v1 > threshold >= v0, so v1 != v0: no division by zero, and the fraction is
// in [0, 1). The ray stops there.
// Changed in step 05: the hit lies between two samples.
static Hit first_hit(const Volume& volume, const View& view, int x, int y, int threshold,
                     Work& work, Trace* trace) {
    int previous = 0;  // the sample before n (none at n = 0)
    for (int n = 0; n < view.ray_length; ++n) {
        const Voxel voxel = view.voxel(x, y, n);  // step 01's three loops, as one
        const int value = volume.at(voxel.i, voxel.j, voxel.k);
        ++work.samples;
        const bool above = value > threshold;
        if (trace) trace->sample(TraceSample(n, voxel, value).threshold_hit(above));
        if (above) {
            ++work.hits;
            if (n + 1 < view.ray_length) ++work.terminated;
            if (n == 0) return {true, 0, 0.0f};  // already inside at the volume's edge
            const float fraction = float(threshold - previous) / float(value - previous);
            if (trace) trace->crossing(n - 1, fraction);
            return {true, n - 1, fraction};
        }
        previous = value;
    }
    return {};
}
//< lesson: first_hit

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
        Args args(step_name, "The first surface above the threshold, found between samples, lit by its gradient.");
        args.add_int("--threshold", &params.threshold, -32768, 32767,
                     "CT value a hit must exceed");
        args.add_double("--light-angle", &params.light_angle, -180, 180,
                        "light direction, degrees to the right of the viewer");
        const Options options = args.parse(argc, argv);

        // --- Volume ---
        const Volume volume = load_volume(options);

        // --- Render: one ray per pixel ---
        Renderer renderer;
        renderer.ray = [&](const View& view, int x, int y, Work& work, Trace* trace) {
            const Hit hit = first_hit(volume, view, x, y, params.threshold, work, trace);
            if (!hit.found) return grey(0.0f);
            const Vec3 gradient = gradient_along_ray(volume, view, x, y, hit.n, hit.fraction,
                                                     work);
            const float light = shade(gradient, light_direction(view, params.light_angle));
            if (trace) trace->gradient(gradient, light);
            return grey(light);
        };
        renderer.knob = {"threshold",
                         [&](const View&, int steps) {
                             params.threshold = std::clamp(
                                 params.threshold + steps * threshold_key_step, -32768, 32767);
                         },
                         [&] { return std::to_string(params.threshold); }};
        renderer.settings = [&] {
            return "light_angle=" + std::to_string(int(std::lround(params.light_angle)));
        };

        // --- Output: a PNG and a summary line per view, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
