// view.cpp: image size and ray axis for each of the three views.
#include "view.h"
#include "error.h"
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace ctlab {

View make_view(const Volume& volume, ViewAxis axis) {
    View view;
    view.axis = axis;
    switch (axis) {
        case ViewAxis::top:  // image (i, j), ray down k
            view.name = "top";
            view.width = volume.nx;
            view.height = volume.ny;
            view.ray_length = volume.nz;
            view.ray_spacing = volume.sz;
            view.pixel_width = volume.sx;
            view.pixel_height = volume.sy;
            break;
        case ViewAxis::front:  // image (i, k), ray along j from the face
            view.name = "front";
            view.width = volume.nx;
            view.height = volume.nz;
            view.ray_length = volume.ny;
            view.ray_spacing = volume.sy;
            view.pixel_width = volume.sx;
            view.pixel_height = volume.sz;
            break;
        case ViewAxis::side:  // image (j, k), ray along i
            view.name = "side";
            view.width = volume.ny;
            view.height = volume.nz;
            view.ray_length = volume.nx;
            view.ray_spacing = volume.sx;
            view.pixel_width = volume.sy;
            view.pixel_height = volume.sz;
            break;
    }
    return view;
}

RayVoxels ray_voxels(const Volume& volume, const View& view, int x, int y) {
    const Voxel start = view.voxel(x, y, 0);
    const Voxel next = view.voxel(x, y, 1);  // index arithmetic only: never read
    const ptrdiff_t stride = ptrdiff_t(volume.index(next.i, next.j, next.k)) -
                             ptrdiff_t(volume.index(start.i, start.j, start.k));
    return {&volume.data[volume.index(start.i, start.j, start.k)], stride};
}

View make_camera_view(int width, int height) {
    View view;
    view.camera = true;
    view.name = "camera";
    view.width = width;
    view.height = height;
    return view;
}

Vec3 volume_direction(const View& view, float along_x, float along_y, float along_ray) {
    switch (view.axis) {
        case ViewAxis::top: return {along_x, along_y, along_ray};    // x = i, y = j, ray = k
        case ViewAxis::front: return {along_x, along_ray, along_y};  // x = i, y = k, ray = j
        default: return {along_ray, along_x, along_y};               // x = j, y = k, ray = i
    }
}

std::vector<View> views_named(const Volume& volume, const std::string& which) {
    if (which == "top") return {make_view(volume, ViewAxis::top)};
    if (which == "front") return {make_view(volume, ViewAxis::front)};
    if (which == "side") return {make_view(volume, ViewAxis::side)};
    if (which == "all") {
        return {make_view(volume, ViewAxis::top), make_view(volume, ViewAxis::front),
                make_view(volume, ViewAxis::side)};
    }
    throw InputError("--view: expected top, front, side or all, got '" + which + "'");
}

std::string too_many_samples(const Volume& volume, double step) {
    for (const View& view : views_named(volume, "all")) {
        const double samples = view.ray_length * view.ray_spacing / step;
        const double limit = std::min(max_samples_per_voxel * view.ray_length,
                                      double(std::numeric_limits<int>::max()));
        if (samples <= limit) continue;
        char text[320];
        std::snprintf(text, sizeof text, "--step %g with --spacing %g,%g,%g asks for %.4g "
                      "samples per ray in the %s view, over the limit of %.0f (%g per voxel): "
                      "raise --step or lower --spacing", step, volume.sx, volume.sy, volume.sz,
                      samples, view.name.c_str(), limit, max_samples_per_voxel);
        return text;
    }
    return "";
}

std::string too_many_samples_along_box(const Volume& volume, double step) {
    const double di = (volume.nx - 1) * volume.sx, dj = (volume.ny - 1) * volume.sy;
    const double dk = (volume.nz - 1) * volume.sz;
    const double samples = std::sqrt(di * di + dj * dj + dk * dk) / step;
    const double limit = max_samples_per_voxel * (volume.nx + volume.ny + volume.nz);
    if (samples <= limit) return "";
    char text[320];
    std::snprintf(text, sizeof text, "--step %g with --spacing %g,%g,%g asks for %.4g samples "
                  "along the box's diagonal, over the limit of %.0f: raise --step or lower "
                  "--spacing", step, volume.sx, volume.sy, volume.sz, samples, limit);
    return text;
}

}  // namespace ctlab
