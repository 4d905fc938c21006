// 00_slices.cpp: look inside the volume one slice at a time.
//
// New here:   reading cthead[k][j][i]; CT values as grey, min..max or --equalise (over 3D).
// Builds on:  nothing: this is the first step.
// Handout:    handouts/00_slices.md
// Run:        make run STEP=00 ARGS="--view front --slice 128"
// Reference:  data/reference/00_slices_<view>.png: the default run, on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "00_slices";
constexpr int middle_slice = -1;  // --slice default: the middle of the view's axis

struct Params {
    int slice = middle_slice;  // index along the view axis: k (top), j (front) or i (side)
    bool equalise = false;     // histogram equalisation instead of the linear min..max map
};

//> lesson: display_mapping
// CT value -> grey 0..1, for every value the volume holds: a table indexed by value - min.
struct Display {
    int min_value = 0;
    std::vector<float> grey_of;  // grey_of[value - min_value]
};

// Linear: (value - min) / (max - min), in floating point (integer division would give 0).
static float display_grey(const Volume& volume, int value) {
    const int range = volume.max_value - volume.min_value;  // 0 for a constant volume
    return range > 0 ? float(value - volume.min_value) / float(range) : 0.0f;
}

// The linear map's table: display_grey() of every value the volume holds.
static Display linear_display(const Volume& volume) {
    Display display{volume.min_value, {}};
    for (int value = volume.min_value; value <= volume.max_value; ++value) {
        display.grey_of.push_back(display_grey(volume, value));
    }
    return display;
}

// Equalised: grey = the fraction of all voxels (in 3D, not one slice) at or below the value.
static Display equalised_display(const Volume& volume) {
    Display display{volume.min_value, {}};
    std::vector<uint64_t> histogram(volume.max_value - volume.min_value + 1, 0);
    for (int k = 0; k < volume.nz; ++k) {
        for (int j = 0; j < volume.ny; ++j) {
            for (int i = 0; i < volume.nx; ++i) ++histogram[volume.at(i, j, k) - volume.min_value];
        }
    }
    uint64_t at_or_below = 0;
    for (uint64_t count : histogram) {
        at_or_below += count;
        display.grey_of.push_back(float(double(at_or_below) / double(volume.voxel_count())));
    }
    return display;
}
//< lesson: display_mapping

//> lesson: slice_pixel
// Pixel (x, y) of a slice. Each view reads the volume along different axes; row y is k in
// the front and side views, so the head stands upright.
static float slice_pixel(const Volume& volume, const View& view, int x, int y, int slice,
                         const Display& display, Work& work, Trace* trace) {
    int i = 0, j = 0, k = 0;
    switch (view.axis) {
        case ViewAxis::top: i = x, j = y, k = slice; break;    // slice k: the head from above
        case ViewAxis::front: i = x, j = slice, k = y; break;  // slice j: from the face
        case ViewAxis::side: i = slice, j = x, k = y; break;   // slice i: from the side
    }
    const int16_t value = volume.at(i, j, k);
    const float grey = display.grey_of[value - display.min_value];
    ++work.samples;
    if (trace) trace->sample(TraceSample(Voxel{i, j, k}, value).grey(grey));
    return grey;
}
//< lesson: slice_pixel

// The slice a view shows: --slice, or the middle of the view's axis.
static int slice_for(const View& view, int slice) {
    return slice == middle_slice ? view.ray_length / 2 : std::min(slice, view.ray_length - 1);
}

int main(int argc, char** argv) {
    return guarded_main(step_name, [&] {
        // --- Options: the shared flags plus this step's own ---
        Params params;
        Args args(step_name, "One slice of the volume in each view, CT values shown as grey.");
        args.add_int("--slice", &params.slice, middle_slice, 32767,
                     "slice along the view axis (-1: the middle)");
        args.add_switch("--equalise", &params.equalise,
                        "histogram equalisation over the whole volume");
        const Options options = args.parse(argc, argv);

        // --- Volume ---
        const Volume volume = load_volume(options);
        const Display display = params.equalise ? equalised_display(volume)
                                                : linear_display(volume);

        // --- View: check the slice exists in every view asked for ---
        for (const View& view : views_named(volume, options.view)) {
            if (params.slice >= view.ray_length) {
                throw InputError("--slice: the " + view.name + " view has slices 0 to " +
                                 std::to_string(view.ray_length - 1) + ", got " +
                                 std::to_string(params.slice));
            }
        }

        // --- Render: one pixel at a time ---
        Renderer renderer;
        renderer.ray = [&](const View& view, int x, int y, Work& work, Trace* trace) {
            const int slice = slice_for(view, params.slice);
            return grey(slice_pixel(volume, view, x, y, slice, display, work, trace));
        };
        renderer.knob = {"slice",
                         [&](const View& view, int steps) {
                             params.slice = std::clamp(slice_for(view, params.slice) + steps, 0,
                                                       view.ray_length - 1);
                         },
                         [&] {
                             return params.slice == middle_slice ? std::string("middle")
                                                                 : std::to_string(params.slice);
                         }};
        renderer.settings = [&] {
            return std::string("equalise=") + (params.equalise ? "yes" : "no");
        };

        // --- Output: a PNG and a summary line per view, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
