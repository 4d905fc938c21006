// view.h: the three axis-aligned views and how image pixels map to voxels.
//
//   top   = image (x, y) = (i, j), the ray runs over k (from the crown down)
//   front = image (x, y) = (i, k), the ray runs over j (from the face backwards)
//   side  = image (x, y) = (j, k), the ray runs over i
// Image row y = k in front and side, so the head stands upright. Rays start at index 0.
//   camera = part 2: an image of any size from a camera the step places (steps/10_*); its
//            rays are the step's own, so ray_length, voxel() and volume_direction() do not
//            apply to it.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>
#include "vec3.h"
#include "volume.h"

namespace ctlab {

enum class ViewAxis { top, front, side };

struct Voxel {
    int i, j, k;
};

struct View {
    ViewAxis axis = ViewAxis::top;  // (a camera view keeps the default: it has no axis)
    bool camera = false;     // part 2: a camera's image, made by make_camera_view
    std::string name;        // "top", "front", "side" or "camera"
    int width = 0;           // image columns
    int height = 0;          // image rows
    int ray_length = 0;      // voxels along the ray axis (one sample each, up to step 08)
    double ray_spacing = 1;  // physical distance between two voxels along the ray
    double pixel_width = 1;  // physical size of a pixel across (x) and down (y): for display
    double pixel_height = 1;

    // The voxel seen at sample n along the ray through pixel (x, y) (one sample per voxel).
    Voxel voxel(int x, int y, int n) const {
        switch (axis) {
            case ViewAxis::top: return {x, y, n};
            case ViewAxis::front: return {x, n, y};
            default: return {n, x, y};
        }
    }
};

View make_view(const Volume& volume, ViewAxis axis);

// The voxels along the ray through pixel (x, y) of an axis view, as they lie in memory: the
// ray's voxel n is first[n * stride], the same value as volume.at() of view.voxel(x, y, n).
// Where a ray starts and how far apart its voxels lie are worked out once per ray, not per
// sample. Speed: the top view's voxels lie nx*ny values apart (128 KiB on CThead), the front
// view's nx, the side view's 1.
struct RayVoxels {
    const int16_t* first = nullptr;  // the voxel at n = 0
    ptrdiff_t stride = 0;            // values from one voxel of the ray to the next

    int16_t operator[](int n) const { return first[n * stride]; }
};

RayVoxels ray_voxels(const Volume& volume, const View& view, int x, int y);

// A direction given in the view's frame (along image x to the right, along image y down,
// along the ray away from the viewer) as components along the volume axes i, j, k.
Vec3 volume_direction(const View& view, float along_x, float along_y, float along_ray);

// A camera's image, width x height pixels (part 2): view=camera in the summary line.
View make_camera_view(int width, int height);

// "top", "front", "side" -> views; "all" -> all three. Throws InputError otherwise.
std::vector<View> views_named(const Volume& volume, const std::string& which);

// A sample step finer than this against the voxel spacing is refused (--step): the work of a
// render stays bounded by the volume's size.
constexpr double max_samples_per_voxel = 64;

// Why `step` (physical units, steps 10-11) asks too much of the axis views' rays, or "": more
// than max_samples_per_voxel samples per voxel (--spacing 1e6,1e6,1e6 at --step 1 would take
// a million, hours of work), or more samples per ray than an int counts. Checked before any
// render.
std::string too_many_samples(const Volume& volume, double step);

// The same for a free camera's rays (part 2): a ray crosses at most the box's diagonal, and
// more than max_samples_per_voxel samples per voxel along it is refused.
std::string too_many_samples_along_box(const Volume& volume, double step);

}  // namespace ctlab
