// 01_ray_loops.cpp: a ray through every pixel; maximum intensity projection (MIP).
//
// New here:   the ray loops written out (for y, for x, along the ray); MIP: the largest value.
// Builds on:  00_slices (the same min..max grey mapping).
// Handout:    handouts/01_ray_loops.md
// Run:        make run STEP=01 ARGS="--view side"
// Reference:  data/reference/01_ray_loops_<view>.png: the default run, on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "01_ray_loops";

//> lesson: display_mapping
// Linear: (value - min) / (max - min), in floating point (integer division would give 0).
static float display_grey(const Volume& volume, int value) {
    const int range = volume.max_value - volume.min_value;  // 0 for a constant volume
    return range > 0 ? float(value - volume.min_value) / float(range) : 0.0f;
}
//< lesson: display_mapping

//> lesson: mip_rays
// Top view: pixel (x, y) is the column (i, j); the ray runs down k, from the crown.
static int mip_top(const Volume& volume, int x, int y, Work& work, Trace* trace) {
    const int i = x, j = y;
    int highest = volume.at(i, j, 0);  // start from the first sample: CT values go below 0
    for (int k = 0; k < volume.nz; ++k) {
        const int value = volume.at(i, j, k);
        highest = std::max(highest, value);
        ++work.samples;
        if (trace) trace->sample(TraceSample(k, Voxel{i, j, k}, value).max(highest));
    }
    return highest;
}

// Front view: pixel (x, y) is (i, k); the ray runs along j, from the face backwards.
static int mip_front(const Volume& volume, int x, int y, Work& work, Trace* trace) {
    const int i = x, k = y;
    int highest = volume.at(i, 0, k);
    for (int j = 0; j < volume.ny; ++j) {
        const int value = volume.at(i, j, k);
        highest = std::max(highest, value);
        ++work.samples;
        if (trace) trace->sample(TraceSample(j, Voxel{i, j, k}, value).max(highest));
    }
    return highest;
}

// Side view: pixel (x, y) is (j, k); the ray runs along i.
static int mip_side(const Volume& volume, int x, int y, Work& work, Trace* trace) {
    const int j = x, k = y;
    int highest = volume.at(0, j, k);
    for (int i = 0; i < volume.nx; ++i) {
        const int value = volume.at(i, j, k);
        highest = std::max(highest, value);
        ++work.samples;
        if (trace) trace->sample(TraceSample(i, Voxel{i, j, k}, value).max(highest));
    }
    return highest;
}
//< lesson: mip_rays

static int mip_ray(const Volume& volume, const View& view, int x, int y, Work& work,
                   Trace* trace) {
    switch (view.axis) {
        case ViewAxis::top: return mip_top(volume, x, y, work, trace);
        case ViewAxis::front: return mip_front(volume, x, y, work, trace);
        default: return mip_side(volume, x, y, work, trace);
    }
}

//> lesson: pixel_loops
// Every pixel: for y, for x, one ray each. Rows are shared among threads (parallel_rows).
static Image render_mip(const Volume& volume, const View& view, int threads, Work& work) {
    Image image(view.width, view.height);
    parallel_rows(view.height, threads, work, [&](int y, Work& row_work) {
        for (int x = 0; x < view.width; ++x) {
            const int highest = mip_ray(volume, view, x, y, row_work, nullptr);
            image.at(x, y) = grey(display_grey(volume, highest));
        }
    });
    return image;
}
//< lesson: pixel_loops

int main(int argc, char** argv) {
    return guarded_main(step_name, [&] {
        // --- Options: the shared flags plus this step's own ---
        Args args(step_name, "Maximum intensity projection along each view's ray axis.");
        const Options options = args.parse(argc, argv);

        // --- Volume ---
        const Volume volume = load_volume(options);

        // --- Render: the pixel loops, and one ray for --debug-pixel ---
        Renderer renderer;
        renderer.ray = [&](const View& view, int x, int y, Work& work, Trace* trace) {
            return grey(display_grey(volume, mip_ray(volume, view, x, y, work, trace)));
        };
        renderer.image = [&](const View& view, Work& work) {
            return render_mip(volume, view, options.threads, work);
        };

        // --- Output: a PNG and a summary line per view, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
