// camera_flags.cpp: the orbit camera's flags and window controls (camera_flags.h).
#include "camera_flags.h"
#include <algorithm>
#include <cmath>
#include <memory>
#include "error.h"

namespace ctlab {

constexpr double min_zoom = CameraFlags::min_zoom, max_zoom = CameraFlags::max_zoom;

void add_camera_flags(Args& args, CameraFlags* camera) {
    const std::string multiple =  // a step that turns by turn_step only says so
        camera->turn_step > 0 ? ", a multiple of " + summary_number(camera->turn_step) : "";
    args.add_double("--azimuth", &camera->azimuth, -360, 360,
                    "degrees around the vertical" + multiple + "; 0 faces the face, 90 looks "
                    "along +i (default " + summary_number(camera->azimuth) + ")");
    args.add_double("--elevation", &camera->elevation, -90, 90,
                    "degrees above the i-j plane" + multiple + "; 90 looks down from the crown "
                    "(default " + summary_number(camera->elevation) + ")");
    args.add_double("--zoom", &camera->zoom, min_zoom, max_zoom,
                    "ortho: pixels per voxel; perspective: walks the eye in (>1)");
    args.add_choice("--projection", &camera->projection, {"ortho", "perspective"},
                    "parallel rays (ortho) or rays from an eye (perspective)");
    args.add_double("--fov", &camera->fov, 1, 170,
                    "perspective: the image's height as an angle, degrees (default " +
                        summary_number(camera->fov) + ")");
    args.add_string("--size", &camera->size,
                    "image size WIDTHxHEIGHT (default " + camera->size + ")", "WxH");
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
    if (const double snap = camera->turn_step; snap > 0) {
        struct Turned {  // the drag's angles before the snap, degrees
            double azimuth, elevation;
        };
        auto turned = std::make_shared<Turned>(Turned{camera->azimuth, camera->elevation});
        orbit.turn = [camera, snap, turned](double azimuth, double elevation) {
            turned->azimuth = std::remainder(turned->azimuth + azimuth, 360.0);  // -180..180
            turned->elevation = std::clamp(turned->elevation + elevation, -90.0, 90.0);
            camera->azimuth = snap * std::round(turned->azimuth / snap);
            camera->elevation = snap * std::round(turned->elevation / snap);
        };
    }
    orbit.zoom = [camera](double factor) {
        camera->zoom = std::clamp(camera->zoom * factor, min_zoom, max_zoom);
    };
    orbit.value = [camera] {
        return "azimuth=" + summary_number(camera->azimuth) + " elevation=" +
               summary_number(camera->elevation) + " zoom=" + summary_number(camera->zoom);
    };
    return orbit;
}

void refuse_object_order_flags(const Options& options, const CameraFlags& camera) {
    const std::string step = "step " + options.step.substr(0, 2);
    if (options.work_map) {
        throw InputError("--work-map: " + step + " counts its work per row of the intermediate "
                         "image, not per ray of the output image (a pixel blends four "
                         "intermediate pixels), so no per-pixel map would sum to the summary "
                         "line's counters");
    }
    const double turn = camera.turn_step;
    if (turn > 0 && camera.projection != "ortho") {
        throw InputError("--projection " + camera.projection + ": " + step + " looks along an "
                         "axis only, orthographic; the ray casters of part 3 render perspective");
    }
    if (turn > 0 && (std::fmod(camera.azimuth, turn) != 0 ||
                     std::fmod(camera.elevation, turn) != 0)) {
        throw InputError("--azimuth " + summary_number(camera.azimuth) + " --elevation " +
                         summary_number(camera.elevation) + ": " + step + " looks along an "
                         "axis only (multiples of " + summary_number(turn) + " degrees)");
    }
}

std::string camera_settings(const CameraFlags& camera) {
    return " projection=" + camera.projection + " azimuth=" + summary_number(camera.azimuth) +
           " elevation=" + summary_number(camera.elevation) + " zoom=" +
           summary_number(camera.zoom) + " fov=" + summary_number(camera.fov);
}

}  // namespace ctlab
