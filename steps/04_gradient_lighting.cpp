// 04_gradient_lighting.cpp: light the surface the ray hits.
//
// New here:   the gradient by central differences (one-sided at the border), divided by the
//             voxel spacing; the outward normal -gradient/|gradient|; diffuse + ambient light.
// Builds on:  03_depth_shading.
// Handout:    handouts/04_gradient_lighting.md
// Run:        make run STEP=04 ARGS="--light-angle 60 --view front"
// Reference:  data/reference/04_gradient_lighting_<view>.png: the default run, on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "04_gradient_lighting";
constexpr int bone_threshold = 400;  // CT value: bone starts about 300; 400 keeps it clean
constexpr double default_light_angle = 30;  // degrees to the right of the viewer
constexpr double light_elevation = 20;      // degrees above the viewer, fixed
constexpr double light_key_step = 15;       // degrees per Up/Down key press
constexpr float ambient = 0.1f;             // light that reaches every surface, 0..1
constexpr double degrees = 3.14159265358979323846 / 180;

struct Params {
    int threshold = bone_threshold;  // a hit is a value strictly above this
    double light_angle = default_light_angle;
};

struct Hit {
    bool found = false;
    int n = 0;  // index of the sample where it was found
};

//> lesson: first_hit
// The first sample along the ray whose value is above the threshold. The ray stops there.
static Hit first_hit(const Volume& volume, const View& view, int x, int y, int threshold,
                     Work& work, Trace* trace) {
    for (int n = 0; n < view.ray_length; ++n) {
        const Voxel voxel = view.voxel(x, y, n);  // step 01's three loops, as one
        const int value = volume.at(voxel.i, voxel.j, voxel.k);
        ++work.samples;
        const bool above = value > threshold;
        if (trace) trace->sample(TraceSample(n, voxel, value).threshold_hit(above));
        if (above) {
            ++work.hits;
            if (n + 1 < view.ray_length) ++work.terminated;
            return {true, n};
        }
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
//< lesson: gradient

//> lesson: shade
// Diffuse lighting: ambient + (1 - ambient) * max(0, N.L), N the outward normal -grad/|grad|.
// A zero gradient (inside a uniform region) has no normal: such a point gets ambient only.
// Changed in step 04: lit by the gradient instead of shaded by depth.
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
        Args args(step_name, "The first surface above the threshold, lit by its gradient.");
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
            const Vec3 gradient = gradient_at(volume, view.voxel(x, y, hit.n), work);
            const float light = shade(gradient, light_direction(view, params.light_angle));
            if (trace) trace->gradient(gradient, light);
            return grey(light);
        };
        renderer.knob = {"light_angle",
                         [&](const View&, int steps) {
                             params.light_angle = std::remainder(
                                 params.light_angle + steps * light_key_step, 360.0);
                         },
                         [&] { return std::to_string(int(std::lround(params.light_angle))); }};
        renderer.settings = [&] { return "threshold=" + std::to_string(params.threshold); };

        // --- Output: a PNG and a summary line per view, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
