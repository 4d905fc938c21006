// camera_flags.cpp: the orbit camera's flags and window controls (camera_flags.h).
#include "camera_flags.h"
#include <algorithm>
#include <cmath>
#include "error.h"

namespace ctlab {

constexpr double min_zoom = CameraFlags::min_zoom, max_zoom = CameraFlags::max_zoom;

void add_camera_flags(Args& args, CameraFlags* camera) {
    args.add_double("--azimuth", &camera->azimuth, -360, 360,
                    "degrees around the vertical; 0 faces the face, 90 looks along +i");
    args.add_double("--elevation", &camera->elevation, -90, 90,
                    "degrees above the i-j plane; 90 looks down from the crown");
    args.add_double("--zoom", &camera->zoom, min_zoom, max_zoom,
                    "ortho: pixels per voxel; perspective: walks the eye in (>1)");
    args.add_choice("--projection", &camera->projection, {"ortho", "perspective"},
                    "parallel rays (ortho) or rays from an eye (perspective)");
    args.add_double("--fov", &camera->fov, 1, 170,
                    "perspective: the image's height as an angle, degrees (default 30)");
    args.add_string("--size", &camera->size, "image size WIDTHxHEIGHT (default 512x512)", "WxH");
}

View camera_view(const Options& options, const CameraFlags& camera) {
    if (options.view != "all") {
        throw InputError("--view: step " + options.step.substr(0, 2) + " renders the camera's "
                         "view; turn it with --azimuth and --elevation instead");
    }
    int width = 0, height = 0;
    parse_size(camera.size, CameraFlags::max_image_side, &width, &height);
    return make_camera_view(width, height);
}

Orbit camera_orbit(CameraFlags* camera) {
    Orbit orbit;
    orbit.turn = [camera](double azimuth, double elevation) {
        camera->azimuth = std::remainder(camera->azimuth + azimuth, 360.0);  // -180..180
        camera->elevation = std::clamp(camera->elevation + elevation, -90.0, 90.0);
    };
    orbit.zoom = [camera](double factor) {
        camera->zoom = std::clamp(camera->zoom * factor, min_zoom, max_zoom);
    };
    orbit.value = [camera] {
        return "azimuth=" + summary_number(camera->azimuth) + " elevation=" +
               summary_number(camera->elevation) + " zoom=" + summary_number(camera->zoom);
    };
    return orbit;
}

std::string camera_settings(const CameraFlags& camera) {
    return " projection=" + camera.projection + " azimuth=" + summary_number(camera.azimuth) +
           " elevation=" + summary_number(camera.elevation) + " zoom=" +
           summary_number(camera.zoom) + " fov=" + summary_number(camera.fov);
}

}  // namespace ctlab
