// camera_flags.h: the orbit camera's flags and window controls, the same in every part-2 step:
// --azimuth, --elevation, --zoom, --projection, --fov and --size, the window's drag and wheel,
// and their part of the summary line. Wiring only: the camera itself (make_camera() and
// camera_ray(), from these values) is step 12's lesson, in the steps.
#pragma once
#include <string>
#include "args.h"
#include "step.h"
#include "view.h"

namespace ctlab {

// A step's Params derives from this: make_camera() reads params.azimuth and the others.
struct CameraFlags {
    static constexpr double min_zoom = 0.01, max_zoom = 100;  // --zoom and the wheel's limits
    static constexpr int max_image_side = 8192;               // pixels, --size limit per side

    double azimuth = 30;               // degrees around the vertical, 0: facing the face
    double elevation = 20;             // degrees above the i-j plane, -90..90
    double zoom = 1;                   // ortho: pixels per voxel; perspective: closer
    std::string projection = "ortho";  // "ortho" or "perspective"
    double fov = 30;                   // degrees, the perspective image's height
    std::string size = "512x512";      // pixels, "WIDTHxHEIGHT"
};

// Adds the six flags, with their limits and --help lines.
void add_camera_flags(Args& args, CameraFlags* camera);

// The camera's image after Args::parse: --size parsed; --view refused (a part-2 step renders
// the camera's view: the axis views are camera angles, --azimuth and --elevation).
View camera_view(const Options& options, const CameraFlags& camera);

// The window's mouse: a drag turns the camera (azimuth kept in -180..180, elevation clamped
// to -90..90), the wheel zooms within min_zoom..max_zoom.
Orbit camera_orbit(CameraFlags* camera);

// " projection=ortho azimuth=30 elevation=20 zoom=1 fov=30": the summary line's camera part.
std::string camera_settings(const CameraFlags& camera);

}  // namespace ctlab
