// camera_flags.h: the orbit camera's flags and window controls, the same in every part-2 step:
// --azimuth, --elevation, --zoom, --projection, --fov and --size, the window's drag and wheel,
// their part of the summary line, and the renderer's wiring of a camera made for each render.
// Wiring only: the camera itself (make_camera() and camera_ray(), from these values) is step
// 13's lesson, in the steps.
#pragma once
#include <string>
#include <type_traits>
#include "args.h"
#include "render.h"
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
    double turn_step = 0;  // degrees; > 0: the camera takes multiples of it only (a step that
                           // looks along an axis: 90), its --help, drag and refusal say so
};

// Adds the six flags, with their limits and --help lines (the defaults as `camera` holds them).
void add_camera_flags(Args& args, CameraFlags* camera);

// The camera's image after Args::parse: --size parsed; --view refused (a part-2 step renders
// the camera's view: the axis views are camera angles, --azimuth and --elevation).
View camera_view(const Options& options, const CameraFlags& camera);

// The window's mouse: a drag turns the camera (azimuth kept in -180..180, elevation clamped
// to -90..90), the wheel zooms within min_zoom..max_zoom. With a turn_step the drag adds up
// freely and the camera takes the nearest multiple of it (a quarter turn at a time).
Orbit camera_orbit(CameraFlags* camera);

// The flags an object-order step (one that composites slices into an intermediate image and
// warps it) cannot honour, each refused with a one-line error: --work-map (its work is
// counted per row of the intermediate image, not per ray of the output image, so no
// per-pixel map would sum to the summary line's counters), and with a turn_step (a step that
// looks along an axis only, with no rays of its own) --projection perspective and an angle
// not a multiple of it. A step with step 30's rays renders a perspective camera by them.
void refuse_object_order_flags(const Options& options, const CameraFlags& camera);

// " projection=ortho azimuth=30 elevation=20 zoom=1 fov=30": the summary line's camera part.
std::string camera_settings(const CameraFlags& camera);

// The renderer's image and ray functions for a camera made anew for each render (the window
// turns it, and previews at coarser pixels while it does), and its trace header:
//   make_camera(view)                     the camera of this render's view;
//   light(camera)                         what every ray of the render shares besides the
//                                         camera (the direction towards the light, which
//                                         turns with it), worked out once per render;
//   pixel(camera, to_light, x, y, work, trace)   one ray's colour.
// A light that does work of its own (step 23 sweeps a light volume) takes a second argument,
// light(camera, Work* render_work): the render's work for an image, nullptr for one traced
// ray (whose trace counts that ray's work only). The trace header reads "samples `step`
// physical units apart" (step is read at each trace: the window's knob changes it).
template <class MakeCamera, class Light, class Pixel>
void cast_camera_rays(Renderer& renderer, int threads, const double& step,
                      MakeCamera make_camera, Light light, Pixel pixel) {
    auto light_for = [light](const auto& camera, Work* render_work) {
        if constexpr (std::is_invocable_v<Light, decltype(camera), Work*>) {
            return light(camera, render_work);
        } else {
            return light(camera);
        }
    };
    renderer.image = [=](const View& view, Work& work) {
        const auto camera = make_camera(view);
        const auto to_light = light_for(camera, &work);
        return render_image(view, threads, work, [&](int x, int y, Work& ray_work) {
            return pixel(camera, to_light, x, y, ray_work, nullptr);
        });
    };
    renderer.ray = [=](const View& view, int x, int y, Work& work, Trace* trace) {
        const auto camera = make_camera(view);
        return pixel(camera, light_for(camera, nullptr), x, y, work, trace);
    };
    renderer.ray_samples = [&step](const View&) {
        return "samples " + summary_number(step) + " physical units apart";
    };
}

}  // namespace ctlab
