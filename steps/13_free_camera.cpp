// 13_free_camera.cpp: any view, from an orbit camera.
//
// New here:   an orbit camera around the volume's box (azimuth, elevation, ortho or
//             perspective): step 12's rays from any angle; the light turns with it.
// Defaults:   azimuth 30, elevation 20, ortho, 512x512, --fov 30; light 30 right, 20 up.
// Builds on:  12_physical_rays (rays in physical space, tested against the box).
// Handout:    handouts/13_free_camera.md
// Run:        make run STEP=13 ARGS="--azimuth 60 --projection perspective"
// Reference:  data/reference/13_free_camera_camera.png: the default run, on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "13_free_camera";
constexpr const char* skin_label = "skin";  // the range --skin-opacity changes
constexpr Rgb background = {0, 0, 0};       // what a ray sees behind the volume: black
constexpr double default_ert = 0.01;        // stop a ray once T is below this; 0: never
constexpr double min_transparency = 1e-300;  // stop below this T even with --ert 0
constexpr double unit_length = 1;     // physical length the TF opacities hold for: one voxel
                                      // at spacing 1
constexpr double default_step = 1;    // physical units between two samples along a ray
constexpr double min_step = 0.25, max_step = 4;  // --step limits, physical units
constexpr double step_key_factor = 2;            // Up doubles the step, Down halves it
constexpr double default_light_angle = 30;  // degrees to the right of the viewer
constexpr double light_elevation = 20;      // degrees above the viewer, fixed
constexpr float ambient = 0.1f;             // light that reaches every surface, 0..1
constexpr double degrees = 3.14159265358979323846 / 180;

struct Params : CameraFlags {  // --azimuth, --elevation, --zoom, --projection, --fov, --size
    std::string tf_path;       // "": data/tf/classic.tf when present, else the built-in copy
    double skin_opacity = -1;  // 0..1; -1: as the transfer function file says
    double ert = default_ert;  // early ray termination threshold for T
    double step = default_step;  // physical units between samples
    double light_angle = default_light_angle;
    bool unlit = false;          // L = 1 everywhere, no gradients (as step 08)
    bool no_correction = false;  // use the TF opacities as they are, whatever the step
};

// What a ray has gathered so far, front to back (in double, as step 07 explains).
struct Accumulated {
    double r = 0, g = 0, b = 0;  // colour, each sample weighted by its opacity and T
    double transparency = 1;     // T: the share of what lies further back that still shows
};

// The camera, in physical space. forward, right and up are unit vectors at right angles.
struct Camera {
    Vec3d centre;              // the centre of the volume's box: what the camera looks at
    Vec3d forward, right, up;  // the view direction; image x (to the right); image -y (up)
    bool perspective = false;
    Vec3d eye;                 // perspective: where every ray starts
    double distance = 0;       // ortho: how far before the centre the rays start
    double pixel_size = 1;     // ortho: physical units per pixel
    double pixel_angle = 0;    // perspective: tan(fov / 2) / (height / 2), per pixel
    int width = 0, height = 0;
};

// A ray: origin + t * direction, direction of length 1, so t is a physical distance.
struct Ray {
    Vec3d origin, direction;
};

// The box of voxel centres, 0 .. (n - 1) * spacing along each axis: every point in it has
// its eight neighbouring voxels (the last voxel is at (n - 1) * spacing, not n * spacing).
static Vec3d box_high(const Volume& volume) {
    return {(volume.nx - 1) * volume.sx, (volume.ny - 1) * volume.sy, (volume.nz - 1) * volume.sz};
}

// sin and cos of an angle in degrees, exact at multiples of 90: std::sin(180 * pi / 180) is
// 1.2e-16, not 0, and a camera meant to look along an axis would look a hair past it, its
// samples a hair off the voxel centres.
static double sin_degrees(double angle) {
    if (std::fmod(angle, 90) == 0) {
        const int quarter = ((int(angle / 90) % 4) + 4) % 4;  // 0, 90, 180, 270 degrees
        const double exact[] = {0, 1, 0, -1};
        return exact[quarter];
    }
    return std::sin(angle * degrees);
}
static double cos_degrees(double angle) { return sin_degrees(angle + 90); }

//> lesson: camera
// The orbit camera looks at the centre of the box from `azimuth` degrees around the vertical
// and `elevation` degrees above the i-j plane. Up is -k (k runs from the crown down). Azimuth
// 0, elevation 0 stands in front of the face (small j) looking along +j; azimuth 90 looks along
// +i. right = forward x up makes it a proper camera (part 1's front view is its mirror).
static Camera make_camera(const Volume& volume, const Params& params, const View& view) {
    const double sin_a = sin_degrees(params.azimuth), cos_a = cos_degrees(params.azimuth);
    const double sin_e = sin_degrees(params.elevation), cos_e = cos_degrees(params.elevation);
    const Vec3d high = box_high(volume);
    const double radius = length(high) / 2;  // of the sphere around the box
    Camera camera;
    camera.centre = 0.5 * high;
    camera.forward = {sin_a * cos_e, cos_a * cos_e, sin_e};
    camera.up = {sin_a * sin_e, cos_a * sin_e, -cos_e};  // at right angles to forward
    camera.right = cross(camera.forward, camera.up);
    camera.perspective = params.projection == "perspective";
    camera.width = view.width;
    camera.height = view.height;
    // Ortho: zoom 1 is one pixel per voxel (the smallest spacing), as in part 1's views; the
    // rays start on a plane outside the box's sphere. Perspective: at zoom 1 the eye is just
    // far enough for the fov to hold the whole sphere; zoom > 1 walks it in, into the box.
    // A view of coarser pixels (the window's preview while it turns: view.pixel_width 2 or 4)
    // covers the same field with fewer rays.
    const double smallest_spacing = std::min({volume.sx, volume.sy, volume.sz});
    camera.pixel_size = smallest_spacing / params.zoom * view.pixel_width;
    camera.distance = radius;
    const double half_fov = params.fov / 2;
    camera.pixel_angle = std::tan(half_fov * degrees) / (view.height / 2.0);
    const double eye_distance = radius / std::sin(half_fov * degrees) / params.zoom;
    camera.eye = camera.centre - eye_distance * camera.forward;
    return camera;
}

// The ray through the centre of pixel (x, y). x grows along right, y along -up (rows down).
static Ray camera_ray(const Camera& camera, int x, int y) {
    const double across = x + 0.5 - camera.width / 2.0;  // pixels right of the image centre
    const double above = camera.height / 2.0 - (y + 0.5);  // pixels above it
    if (camera.perspective) {
        const Vec3d direction = camera.forward + (across * camera.pixel_angle) * camera.right +
                                (above * camera.pixel_angle) * camera.up;
        return {camera.eye, (1 / length(direction)) * direction};
    }
    // The sum in this order keeps an axis-aligned camera exact: the zero terms add nothing.
    const Vec3d origin = camera.centre + (across * camera.pixel_size) * camera.right +
                         (above * camera.pixel_size) * camera.up -
                         camera.distance * camera.forward;
    return {origin, camera.forward};
}
//< lesson: camera

//> lesson: opacity_correction
// The TF's opacity alpha holds for one unit of length. A sample that stands for `ratio` units
// lets (1 - alpha)^ratio through, so its opacity is alpha' = 1 - (1 - alpha)^ratio. Computed
// as -expm1(ratio * log1p(-alpha)): the plain form loses its digits when alpha or the result
// is tiny. alpha = 0 stays 0 and alpha = 1 stays 1 (log1p(-1) would be -infinity).
static float corrected_opacity(float alpha, double ratio) {
    if (alpha <= 0.0f) return 0.0f;
    if (alpha >= 1.0f) return 1.0f;
    return float(-std::expm1(ratio * std::log1p(-double(alpha))));
}

// How many units of length one sample stands for (1 with --no-correction: the TF unchanged).
static double opacity_ratio(const Params& params) {
    return params.no_correction ? 1.0 : params.step / unit_length;
}
//< lesson: opacity_correction

// The lookup table: one RGBA entry per CT value, -32768..32767. The entry of `value` is
// entries[value - lowest_ct_value], so any int16 is a valid index. A new table is transparent.
struct Lut {
    std::vector<Rgba> entries = std::vector<Rgba>(ct_value_end - lowest_ct_value);
};

//> lesson: lookup_table
// The colour a fraction f of the way from a to b (f = 0 gives a exactly).
static Rgba mix(const Rgba& a, const Rgba& b, float f) {
    return {a.r + f * (b.r - a.r), a.g + f * (b.g - a.g), a.b + f * (b.b - a.b),
            a.a + f * (b.a - a.a)};
}

// The table of a transfer function: classifying a sample is then a single read. Values no
// range covers stay transparent. A ramp goes linearly from its start at `from` to its end at
// `to`. The opacities are corrected here, once per entry, for samples `ratio` units apart.
// Changed in step 10: each entry's opacity corrected for the spacing.
static Lut build_lut(const TransferFunction& tf, double ratio) {
    Lut lut;  // every entry {0, 0, 0, 0}
    for (const TfRange& range : tf.ranges) {
        const float width = float(range.to - range.from);
        for (int value = range.from; value < range.to; ++value) {
            const float f = range.ramp ? float(value - range.from) / width : 0.0f;
            Rgba& entry = lut.entries[value - lowest_ct_value];
            entry = mix(range.start, range.end, f);
            entry.a = corrected_opacity(entry.a, ratio);
        }
    }
    return lut;
}
//< lesson: lookup_table

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
static float shade(Vec3 gradient, Vec3 to_light) {
    const float size = length(gradient);
    if (size == 0.0f) return ambient;
    const Vec3 normal = (-1.0f / size) * gradient;
    return ambient + (1.0f - ambient) * std::max(0.0f, dot(normal, to_light));
}

// Unit direction towards the light, angle to the right of the camera and elevation above it:
// step 10's light, in the camera's frame (so part 1's top and side views get the same light).
// Changed in step 13: in the camera's frame.
static Vec3 light_direction(const Camera& camera, double angle) {
    const float along_x = float(std::sin(angle * degrees) * std::cos(light_elevation * degrees));
    const float along_y = float(-std::sin(light_elevation * degrees));  // image y points down
    const float along_ray = float(-std::cos(angle * degrees) * std::cos(light_elevation * degrees));
    auto axis = [](const Vec3d& a) { return Vec3{float(a.i), float(a.j), float(a.k)}; };
    return along_x * axis(camera.right) + (-along_y) * axis(camera.up) +
           along_ray * axis(camera.forward);
}
//< lesson: shade

//> lesson: front_to_back
// Step 10's compositing along a ray in physical space, at t_mid + m * step (t_mid: the point
// of the ray nearest the box's centre) for |m * step| <= half the box's diagonal. Only samples
// inside the box of voxel centres count, each read from its nearest voxel.
// Changed in step 13: along the camera's ray; t >= 0 only (an eye inside the box).
static Accumulated composite_front_to_back(const Volume& volume,
                                           const Camera& camera, int x, int y,
                                           const Lut& lut, Vec3 to_light, const Params& params,
                                           Work& work, Trace* trace) {
    const double stop_below = std::max(params.ert, min_transparency);
    const Vec3d high = box_high(volume);
    const Ray ray = camera_ray(camera, x, y);
    if (trace) trace->ray(ray.origin, ray.direction);
    const double t_mid = dot(0.5 * high - ray.origin, ray.direction);
    const long long half_count = (long long)(std::floor(length(high) / 2 / params.step));
    Accumulated pixel;
    for (long long m = -half_count; m <= half_count; ++m) {
        const double t = t_mid + m * params.step;  // physical units along the ray
        if (t < 0) continue;                        // behind the eye
        const Vec3d point = ray.origin + t * ray.direction;
        const bool inside = point.i >= 0 && point.i <= high.i && point.j >= 0 &&
                            point.j <= high.j && point.k >= 0 && point.k <= high.k;
        if (!inside) continue;  // outside the box of voxel centres: nothing to read
        // The sample reads its nearest voxel (a half rounds up).
        const Voxel voxel = {int(std::floor(point.i / volume.sx + 0.5)),
                             int(std::floor(point.j / volume.sy + 0.5)),
                             int(std::floor(point.k / volume.sz + 0.5))};
        const float value = volume.at(voxel.i, voxel.j, voxel.k);
        // The entry of the whole value at or below it (the range [from, to) it falls into):
        // value - lowest_ct_value >= 0, so int() rounds down.
        const Rgba& sample = lut.entries[int(double(value) - lowest_ct_value)];
        ++work.samples;
        if (sample.a == 0.0f) {
            ++work.skipped;
            if (trace) trace->sample(TraceSample(t, point, value).skipped());
            continue;
        }
        double light = 1.0;  // unlit
        if (!params.unlit) {
            light = shade(gradient_at(volume, voxel, work), to_light);
        }
        const double alpha = sample.a;  // the opacity, after the TF
        const double weight = pixel.transparency * alpha * light;
        pixel.r += weight * sample.r;
        pixel.g += weight * sample.g;
        pixel.b += weight * sample.b;
        pixel.transparency *= 1 - alpha;
        if (trace) {
            trace->sample(TraceSample(t, point, value).rgba(sample).light(light)
                              .colour(pixel.r, pixel.g, pixel.b)
                              .transparency(pixel.transparency));
        }
        if (pixel.transparency < stop_below && m < half_count) {
            ++work.terminated;
            if (trace) trace->stop(pixel.transparency, stop_below, half_count - m);
            break;
        }
    }
    return pixel;
}

// What the ray left transparent shows the background: C + T*background.
static Rgb over_background(const Accumulated& ray) {
    return {float(ray.r + ray.transparency * background.r),
            float(ray.g + ray.transparency * background.g),
            float(ray.b + ray.transparency * background.b)};
}
//< lesson: front_to_back

int main(int argc, char** argv) {
    return guarded_main(step_name, [&] {
        // --- Options: the shared flags plus this step's own ---
        Params params;
        Args args(step_name, "The volume from an orbit camera: rays through the box in physical "
                             "space, nearest samples, lit front to back.");
        args.add_string("--tf", &params.tf_path,
                        "transfer function file (default data/tf/classic.tf)");
        args.add_double("--skin-opacity", &params.skin_opacity, 0, 1,
                        "opacity of the range labelled skin (default: as the file says)");
        args.add_double("--ert", &params.ert, 0, 1,
                        "stop a ray once its transparency T is below this (0: never)");
        args.add_double("--step", &params.step, min_step, max_step,
                        "physical units between two samples along a ray");
        args.add_double("--light-angle", &params.light_angle, -180, 180,
                        "light direction, degrees to the right of the camera (default 30; "
                        "always 20 degrees above it)");
        args.add_switch("--unlit", &params.unlit, "no lighting: L = 1, as in step 08");
        args.add_switch("--no-correction", &params.no_correction,
                        "use the TF opacities unchanged, whatever the step");
        add_camera_flags(args, &params);  // common/camera_flags.h
        const Options options = args.parse(argc, argv);
        const View camera_image = camera_view(options, params);  // --size; no --view

        // --- Volume ---
        const Volume volume = load_volume(options);
        const std::string refused = too_many_samples_along_box(volume, params.step);
        if (!refused.empty()) throw InputError(refused);

        // --- Transfer function: the file (in the file's units), its table for this step size ---
        TransferFunction tf = load_transfer_function(params.tf_path, volume.map);
        if (params.skin_opacity >= 0) {
            set_opacity(tf, skin_label, params.skin_opacity, "--skin-opacity");
        }
        Lut lut = build_lut(tf, opacity_ratio(params));

        // --- View: the camera's image (its camera is made for each render: the window turns
        // it, and previews at coarser pixels while it does) ---
        Renderer renderer;
        renderer.transfer_function = &tf;  // the ray picture draws its ranges
        renderer.views = {camera_image};

        // --- Light: towards it from every ray of a render (it turns with the camera), so
        // worked out once per render, as step 10 does once per view; none with --unlit ---
        auto light_towards = [&](const Camera& camera) {
            return params.unlit ? Vec3{} : light_direction(camera, params.light_angle);
        };

        // --- Render: one ray per pixel ---
        auto pixel = [&](const Camera& camera, Vec3 to_light, int x, int y, Work& work,
                         Trace* trace) {
            return over_background(composite_front_to_back(volume, camera, x, y, lut, to_light,
                                                           params, work, trace));
        };
        auto camera_for = [&](const View& view) { return make_camera(volume, params, view); };
        cast_camera_rays(renderer, options.threads, params.step, camera_for, light_towards,
                         pixel);  // common/camera_flags.h: renderer.image, .ray, .ray_samples
        renderer.knob = {"step",
                         [&](const View&, int steps) {
                             const double step = std::clamp(
                                 params.step * std::pow(step_key_factor, steps), min_step,
                                 max_step);
                             if (!too_many_samples_along_box(volume, step).empty()) return;  // keep it
                             params.step = step;
                             lut = build_lut(tf, opacity_ratio(params));
                         },
                         [&] { return summary_number(params.step); }};
        renderer.orbit = camera_orbit(&params);  // the window's drag and wheel
        renderer.settings = [&] {
            const TfRange* skin = find_range(tf, skin_label);
            return "tf=" + tf.source +
                   " skin_opacity=" + (skin ? summary_number(skin->start.a) : std::string("none")) +
                   " ert=" + summary_number(params.ert) +
                   " light_angle=" + std::to_string(int(std::lround(params.light_angle))) +
                   " lighting=" + (params.unlit ? "off" : "on") +
                   " correction=" + (params.no_correction ? "off" : "on") +
                   camera_settings(params);
        };

        // --- Output: a PNG and a summary line, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
