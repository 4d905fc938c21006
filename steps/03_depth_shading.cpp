// 03_depth_shading.cpp: near things bright, far things dark.
//
// New here:   grey = 1 - d/N at the first hit (d = hit sample, N = samples along the ray).
// Builds on:  02_threshold.
// Handout:    handouts/03_depth_shading.md
// Run:        make run STEP=03 ARGS="--view side"
// Reference:  data/reference/03_depth_shading_<view>.png: the default run, on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "03_depth_shading";
constexpr int bone_threshold = 400;  // CT value: bone starts about 300; 400 keeps it clean
constexpr int threshold_key_step = 50;  // CT units per Up/Down key press

struct Params {
    int threshold = bone_threshold;  // a hit is a value strictly above this
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

//> lesson: shade
// Depth shading: 1 at the front of the volume, falling to 0 at its back; black for a miss.
// Changed in step 03: shaded by depth instead of step 02's white.
static float shade(const Hit& hit, int ray_length) {
    return hit.found ? 1.0f - hit.n / float(ray_length) : 0.0f;
}
//< lesson: shade

int main(int argc, char** argv) {
    return guarded_main(step_name, [&] {
        // --- Options: the shared flags plus this step's own ---
        Params params;
        Args args(step_name, "Grey = 1 - depth/length at the first sample above the threshold.");
        args.add_int("--threshold", &params.threshold, -32768, 32767,
                     "CT value a hit must exceed");
        const Options options = args.parse(argc, argv);

        // --- Volume ---
        const Volume volume = load_volume(options);

        // --- Render: one ray per pixel ---
        Renderer renderer;
        renderer.ray = [&](const View& view, int x, int y, Work& work, Trace* trace) {
            const Hit hit = first_hit(volume, view, x, y, params.threshold, work, trace);
            return grey(shade(hit, view.ray_length));
        };
        renderer.knob = {"threshold",
                         [&](const View&, int steps) {
                             params.threshold = std::clamp(
                                 params.threshold + steps * threshold_key_step, -32768, 32767);
                         },
                         [&] { return std::to_string(params.threshold); }};

        // --- Output: a PNG and a summary line per view, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
