// 14_shadows.cpp: light that is blocked: shadows towards the light, and ambient occlusion.
//
// New here:   for every lit sample of step 10's composite, a shadow ray towards the light
//             (--shadows ray): the transmittance of the volume between the sample and the
//             light, T_light = product of (1 - alpha) of its samples (Beer-Lambert, with the
//             opacity-corrected table), darkens the diffuse light; ambient occlusion (--ao on):
//             the mean transmittance over a short distance in six directions darkens the
//             ambient light. --shadows none --ao off is step 10's picture.
// Builds on:  10_free_camera (the orbit camera, the slab method, trilinear samples, lit front
//             to back).
// Handout:    handouts/14_shadows.md
// Run:        make run STEP=14 ARGS="--light-angle 70 --ao off"
// Reference:  data/reference/14_shadows_camera.png: the default run (shadow rays and ambient
//             occlusion, azimuth 30, elevation 20, orthographic, 512x512), on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "14_shadows";
constexpr const char* skin_label = "skin";  // the range --skin-opacity changes
constexpr Rgb background = {0, 0, 0};       // what a ray sees behind the volume: black
constexpr double default_ert = 0.01;        // stop a ray once T is below this; 0: never
constexpr double min_transparency = 1e-300;  // stop below this T even with --ert 0
constexpr double unit_length = 1;     // physical length the TF opacities hold for: one voxel
                                      // at spacing 1
constexpr double default_step = 1;    // physical units between two samples along a ray
constexpr double min_step = 0.25, max_step = 4;  // --step limits, physical units
constexpr double step_key_factor = 2;            // Up doubles the step, Down halves it
constexpr double max_samples_per_voxel = 64;  // a finer step against the spacing is refused
constexpr double default_light_angle = 30;  // degrees to the right of the viewer
constexpr double light_elevation = 20;      // degrees above the viewer, fixed
constexpr float ambient = 0.1f;             // light that reaches every surface, 0..1
constexpr double degrees = 3.14159265358979323846 / 180;
constexpr double default_azimuth = 30;    // degrees around the vertical, 0: facing the face
constexpr double default_elevation = 20;  // degrees above the i-j plane
constexpr double default_fov = 30;        // degrees, the perspective image's height
constexpr const char* default_size = "512x512";  // pixels, columns x rows
constexpr int max_image_side = 8192;             // pixels, --size limit per side
// Samples at t_entry + n*step up to t_exit; the last may be this many steps past the exit in
// rounding (a ray 224 units long at step 2 gets 113 samples even when t_exit is 223.99999...).
constexpr double sample_count_slack = 1e-9;
constexpr double min_light_transmittance = 1e-4;  // a shadow ray stops below this: dark enough
constexpr double occlusion_radius = 4;  // physical units around a sample ambient occlusion sees
constexpr double occlusion_step = 1;    // physical units between its samples

struct Params {
    std::string tf_path;       // "": data/tf/classic.tf when present, else the built-in copy
    double skin_opacity = -1;  // 0..1; -1: as the transfer function file says
    double ert = default_ert;  // early ray termination threshold for T
    double step = default_step;  // physical units between samples
    double light_angle = default_light_angle;
    bool unlit = false;          // L = 1 everywhere, no gradients (as step 07)
    bool no_correction = false;  // use the TF opacities as they are, whatever the step
    double azimuth = default_azimuth;      // degrees
    double elevation = default_elevation;  // degrees, -90..90
    double zoom = 1;                       // ortho: pixels per voxel; perspective: closer
    std::string projection = "ortho";      // "ortho" or "perspective"
    double fov = default_fov;              // degrees, perspective only
    std::string size = default_size;       // "WxH"
    std::string shadows = "ray";           // "ray": a shadow ray per lit sample; "none"
    std::string ao = "on";                 // "on": ambient occlusion; "off"
};

// What a ray has gathered so far, front to back (in double, as step 06 explains).
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

// Where a ray is inside the box: t_entry <= t <= t_exit; hit false when it misses.
struct Span {
    bool hit = false;
    double t_entry = 0, t_exit = 0;
    int entry_axis = -1;  // the axis whose face the ray enters through; -1: it starts inside
};

// The box of voxel centres, 0 .. (n - 1) * spacing along each axis: every point in it has
// its eight neighbouring voxels (the last voxel is at (n - 1) * spacing, not n * spacing).
static Vec3d box_high(const Volume& volume) {
    return {(volume.nx - 1) * volume.sx, (volume.ny - 1) * volume.sy, (volume.nz - 1) * volume.sz};
}

//> lesson: camera
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

// The orbit camera looks at the centre of the box from `azimuth` degrees around the vertical
// and `elevation` degrees above the i-j plane. Up is -k (k runs from the crown down). Azimuth
// 0, elevation 0 stands in front of the face (small j) looking along +j; azimuth 90 looks along
// +i. right = forward x up makes it a proper camera (part 1's front view is its mirror).
static Camera make_camera(const Volume& volume, const Params& params, int width, int height) {
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
    camera.width = width;
    camera.height = height;
    // Ortho: zoom 1 is one pixel per voxel (the smallest spacing), as in part 1's views; the
    // rays start on a plane outside the box's sphere. Perspective: at zoom 1 the eye is just
    // far enough for the fov to hold the whole sphere; zoom > 1 walks it in, into the box.
    const double smallest_spacing = std::min({volume.sx, volume.sy, volume.sz});
    camera.pixel_size = smallest_spacing / params.zoom;
    camera.distance = radius;
    const double half_fov = params.fov / 2;
    camera.pixel_angle = std::tan(half_fov * degrees) / (height / 2.0);
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

//> lesson: slab
// The slab method: along each axis the ray is between the two planes lo and hi for t from
// (lo - o) / d to (hi - o) / d (swapped when d < 0). It is inside the box where it is inside
// all three slabs: from the largest entry to the smallest exit. It misses when that interval
// is empty or lies behind the origin; a camera inside the box starts at t = 0.
// The stiff case: d = 0 or -0 (parallel to the planes). Then 1/d is +-infinity, and an origin
// exactly on a plane gives 0 * infinity = NaN. So handle it first: the ray is inside that slab
// for every t (on a plane counts as inside) or for none.
static Span intersect_box(const Ray& ray, const Vec3d& low, const Vec3d& high) {
    Span span;
    double t_entry = -std::numeric_limits<double>::infinity();
    double t_exit = std::numeric_limits<double>::infinity();
    for (int axis = 0; axis < 3; ++axis) {
        const double o = ray.origin[axis], d = ray.direction[axis];
        if (d == 0) {  // true for -0 too
            if (o < low[axis] || o > high[axis]) return span;  // beside the slab: a miss
            continue;                                          // within it: no limit
        }
        double t_near = (low[axis] - o) / d, t_far = (high[axis] - o) / d;
        if (t_near > t_far) std::swap(t_near, t_far);
        if (t_near > t_entry) {
            t_entry = t_near;
            span.entry_axis = axis;
        }
        t_exit = std::min(t_exit, t_far);
    }
    if (t_entry > t_exit || t_exit < 0) return span;  // missed, or the box is behind
    if (t_entry < 0) {                                // the origin is inside the box
        t_entry = 0;
        span.entry_axis = -1;
    }
    span.hit = true;
    span.t_entry = t_entry;
    span.t_exit = t_exit;
    return span;
}

// The point where the ray enters, exactly on the face it crosses: o + t*d rounds, and a
// sample a hair outside the face would read past the last voxel's centre.
static Vec3d entry_point(const Ray& ray, const Span& span, const Vec3d& high) {
    const Vec3d point = ray.origin + span.t_entry * ray.direction;
    double on_face[3] = {point.i, point.j, point.k};
    if (span.entry_axis >= 0) {
        const int axis = span.entry_axis;
        on_face[axis] = ray.direction[axis] > 0 ? 0.0 : high[axis];
    }
    return {on_face[0], on_face[1], on_face[2]};
}
//< lesson: slab

//> lesson: opacity_correction
// The opacity correction of step 08, unchanged.
static float corrected_opacity(float alpha, double ratio) {
    if (alpha <= 0.0f) return 0.0f;
    if (alpha >= 1.0f) return 1.0f;
    return float(-std::expm1(ratio * std::log1p(-double(alpha))));
}

static double opacity_ratio(const Params& params) {
    return params.no_correction ? 1.0 : params.step / unit_length;
}
//< lesson: opacity_correction

// Step 08's lookup table, unchanged: one RGBA per CT value, opacities corrected for the step.
struct Lut {
    std::vector<Rgba> entries = std::vector<Rgba>(ct_value_end - lowest_ct_value);
};

//> lesson: lookup_table
static Rgba mix(const Rgba& a, const Rgba& b, float f) {
    return {a.r + f * (b.r - a.r), a.g + f * (b.g - a.g), a.b + f * (b.b - a.b),
            a.a + f * (b.a - a.a)};
}

static Lut build_lut(const TransferFunction& tf, double ratio) {
    Lut lut;
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

// The eight voxels around a point: along one axis, the voxel at or below it, the next one
// (the same one at the last voxel) and how far the point is between them, 0..1.
struct Cell {
    int low, high;
    float fraction;
};

//> lesson: trilinear
// Along one axis: u is the point's coordinate in voxels (physical / spacing), kept within
// 0 .. count - 1. At a voxel centre the fraction is exactly 0, so that voxel comes back as it is.
static Cell cell_along(double u, int count) {
    u = std::clamp(u, 0.0, double(count - 1));
    const int low = std::min(int(u), count - 1);  // u >= 0: int() rounds down
    return {low, std::min(low + 1, count - 1), float(u - low)};
}

// A value fraction f of the way from a to b: a itself when f = 0.
static float lerp(float a, float b, float f) { return a + f * (b - a); }

// Trilinear interpolation: linear along i on the cell's four edges, then along j, then k.
// Exact for any field linear in i, j and k (and so in physical space).
static float trilinear(const Volume& volume, const Vec3d& point) {
    const Cell ci = cell_along(point.i / volume.sx, volume.nx);
    const Cell cj = cell_along(point.j / volume.sy, volume.ny);
    const Cell ck = cell_along(point.k / volume.sz, volume.nz);
    auto v = [&](int i, int j, int k) { return float(volume.at(i, j, k)); };
    const float low_low = lerp(v(ci.low, cj.low, ck.low), v(ci.high, cj.low, ck.low), ci.fraction);
    const float high_low = lerp(v(ci.low, cj.high, ck.low), v(ci.high, cj.high, ck.low),
                                ci.fraction);
    const float low_high = lerp(v(ci.low, cj.low, ck.high), v(ci.high, cj.low, ck.high),
                                ci.fraction);
    const float high_high = lerp(v(ci.low, cj.high, ck.high), v(ci.high, cj.high, ck.high),
                                 ci.fraction);
    return lerp(lerp(low_low, high_low, cj.fraction), lerp(low_high, high_high, cj.fraction),
                ck.fraction);
}
//< lesson: trilinear

//> lesson: gradient
// Step 08's derivative and gradient at a voxel, unchanged.
template <class Sample>
static float derivative(Sample sample, int n, int count, double spacing) {
    if (count == 1) return 0.0f;
    if (n == 0) return float((sample(1) - sample(0)) / spacing);
    if (n == count - 1) return float((sample(n) - sample(n - 1)) / spacing);
    return float((sample(n + 1) - sample(n - 1)) / (2 * spacing));
}

static Vec3 gradient_at(const Volume& volume, int i, int j, int k, Work& work) {
    ++work.gradients;
    auto along_i = [&](int m) { return double(volume.at(m, j, k)); };
    auto along_j = [&](int m) { return double(volume.at(i, m, k)); };
    auto along_k = [&](int m) { return double(volume.at(i, j, m)); };
    return {derivative(along_i, i, volume.nx, volume.sx),
            derivative(along_j, j, volume.ny, volume.sy),
            derivative(along_k, k, volume.nz, volume.sz)};
}

static Vec3 lerp_vector(Vec3 a, Vec3 b, float f) { return a + f * (b - a); }

// The gradient at a point: the voxels' gradients interpolated trilinearly, as the values are.
// At a voxel centre it is that voxel's gradient exactly (step 08's at its samples).
static Vec3 gradient_trilinear(const Volume& volume, const Vec3d& point, Work& work) {
    const Cell ci = cell_along(point.i / volume.sx, volume.nx);
    const Cell cj = cell_along(point.j / volume.sy, volume.ny);
    const Cell ck = cell_along(point.k / volume.sz, volume.nz);
    auto g = [&](int i, int j, int k) { return gradient_at(volume, i, j, k, work); };
    auto along_i = [&](int j, int k) {
        return ci.fraction == 0.0f ? g(ci.low, j, k)
                                   : lerp_vector(g(ci.low, j, k), g(ci.high, j, k), ci.fraction);
    };
    auto along_ij = [&](int k) {
        return cj.fraction == 0.0f ? along_i(cj.low, k)
                                   : lerp_vector(along_i(cj.low, k), along_i(cj.high, k), cj.fraction);
    };
    return ck.fraction == 0.0f ? along_ij(ck.low)
                               : lerp_vector(along_ij(ck.low), along_ij(ck.high), ck.fraction);
}
//< lesson: gradient

//> lesson: shade
// Unit direction towards the light, angle to the right of the camera and elevation above it:
// step 08's light, in the camera's frame (so part 1's top and side views get the same light).
static Vec3 light_direction(const Camera& camera, double angle) {
    const float along_x = float(std::sin(angle * degrees) * std::cos(light_elevation * degrees));
    const float along_y = float(-std::sin(light_elevation * degrees));  // image y points down
    const float along_ray = float(-std::cos(angle * degrees) * std::cos(light_elevation * degrees));
    auto axis = [](const Vec3d& a) { return Vec3{float(a.i), float(a.j), float(a.k)}; };
    return along_x * axis(camera.right) + (-along_y) * axis(camera.up) +
           along_ray * axis(camera.forward);
}
//< lesson: shade

//> lesson: shadow
// How much of the light reaches `point`: march from it towards the light, `step` physical
// units at a time, to where that ray leaves the box, multiplying the transparencies of the
// samples met, T_light = product of (1 - alpha). The table's alphas are corrected for the step,
// so through a homogeneous medium T_light = (1 - alpha)^(distance / unit) = exp(-sigma d),
// Beer-Lambert with sigma = -ln(1 - alpha) per unit. The sample itself is left out (it would
// shadow itself); the march stops once T_light is below min_light_transmittance.
static double light_transmittance(const Volume& volume, const Lut& lut, const Vec3d& point,
                                  const Vec3d& to_light, double step, int* shadow_samples) {
    const Span span = intersect_box({point, to_light}, Vec3d{}, box_high(volume));
    double transmittance = 1;
    for (double t = step; span.hit && t <= span.t_exit; t += step) {
        const float value = trilinear(volume, point + t * to_light);
        ++*shadow_samples;
        transmittance *= 1 - lut.entries[int(double(value) - lowest_ct_value)].a;
        if (transmittance < min_light_transmittance) break;
    }
    return transmittance;
}

// Ambient occlusion: how open the space around `point` is. Along each of the six axis
// directions, the transmittance over occlusion_radius (samples occlusion_step apart, the table's
// alphas corrected for that step); their mean, 1 in empty surroundings, less where material
// around the sample would block light coming from all sides.
static double ambient_occlusion(const Volume& volume, const Lut& occlusion_lut,
                                const Vec3d& point, int* shadow_samples) {
    const Vec3d high = box_high(volume);
    const Vec3d directions[] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1},
                                {0, 0, -1}};
    double sum = 0;
    for (const Vec3d& direction : directions) {
        double transmittance = 1;
        for (double t = occlusion_step; t <= occlusion_radius; t += occlusion_step) {
            const Vec3d p = point + t * direction;
            if (p.i < 0 || p.j < 0 || p.k < 0 || p.i > high.i || p.j > high.j || p.k > high.k) {
                break;  // outside the box: nothing there to block
            }
            const float value = trilinear(volume, p);
            ++*shadow_samples;
            transmittance *= 1 - occlusion_lut.entries[int(double(value) - lowest_ct_value)].a;
        }
        sum += transmittance;
    }
    return sum / 6;
}

// Step 10's light, blocked: the diffuse part only as far as T_light lets it through, the
// ambient part as far as the surroundings are open.
static float shade_blocked(Vec3 gradient, Vec3 to_light, double light_reaching,
                           double occlusion) {
    const float size = length(gradient);
    const float open = float(occlusion) * ambient;
    if (size == 0.0f) return open;
    const Vec3 normal = (-1.0f / size) * gradient;
    return open + (1.0f - ambient) * float(light_reaching) *
                      std::max(0.0f, dot(normal, to_light));
}
//< lesson: shadow

//> lesson: front_to_back
static void trace_ray(Trace* trace, const Ray& ray, const Span& span, const Vec3d& high,
                      double step) {
    if (!trace) return;
    trace->add("ray origin=(%.6g, %.6g, %.6g) direction=(%.6g, %.6g, %.6g)", ray.origin.i,
               ray.origin.j, ray.origin.k, ray.direction.i, ray.direction.j, ray.direction.k);
    if (!span.hit) {
        trace->add("box (0, 0, 0)..(%g, %g, %g): missed, the pixel shows the background",
                   high.i, high.j, high.k);
        return;
    }
    const Vec3d in = ray.origin + span.t_entry * ray.direction;
    const Vec3d out = ray.origin + span.t_exit * ray.direction;
    const char* through[] = {"the i face", "the j face", "the k face"};
    trace->add("box (0, 0, 0)..(%g, %g, %g): entry t=%.6f at (%.4f, %.4f, %.4f) through %s, "
               "exit t=%.6f at (%.4f, %.4f, %.4f), step %g", high.i, high.j, high.k,
               span.t_entry, in.i, in.j, in.k,
               span.entry_axis >= 0 ? through[span.entry_axis] : "none (starts inside)",
               span.t_exit, out.i, out.j, out.k, step);
}

// Step 08's compositing along the camera's ray: samples at t_entry + n * step until t_exit,
// each read by trilinear interpolation, classified by the table, lit where it is not
// transparent, composited front to back; early ray termination as in step 07.
static Accumulated composite_front_to_back(const Volume& volume, const Camera& camera, int x,
                                           int y, const Lut& lut, const Lut& occlusion_lut,
                                           const Params& params, Work& work, Trace* trace) {
    const double stop_below = std::max(params.ert, min_transparency);
    const Vec3d high = box_high(volume);
    const Ray ray = camera_ray(camera, x, y);
    const Span span = intersect_box(ray, Vec3d{}, high);
    trace_ray(trace, ray, span, high, params.step);
    Accumulated pixel;
    if (!span.hit) return pixel;
    const Vec3d entry = entry_point(ray, span, high);
    const double length_inside = span.t_exit - span.t_entry;
    const long long sample_count =
        (long long)(std::floor(length_inside / params.step + sample_count_slack)) + 1;
    const Vec3 to_light = params.unlit ? Vec3{} : light_direction(camera, params.light_angle);
    for (long long n = 0; n < sample_count; ++n) {
        const double along = n * params.step;  // physical units past the entry
        const Vec3d point = entry + along * ray.direction;
        const float value = trilinear(volume, point);
        const Rgba& sample = lut.entries[int(double(value) - lowest_ct_value)];
        ++work.samples;
        const double t = span.t_entry + along;
        if (sample.a == 0.0f) {
            ++work.skipped;
            if (trace) trace->add("t=%9.4f p=(%.6f, %.6f, %.6f) value=%9.4f transparent: "
                                  "skipped", t, point.i, point.j, point.k, value);
            continue;
        }
        double light = 1.0;  // unlit
        double light_t = 1, occlusion = 1;  // nothing blocks the light, nothing around
        int shadow_samples = 0;
        if (!params.unlit) {
            const Vec3d towards = {to_light.i, to_light.j, to_light.k};
            if (params.shadows == "ray") {
                light_t = light_transmittance(volume, lut, point, (1 / length(towards)) *
                                              towards, params.step, &shadow_samples);
            }
            if (params.ao == "on") {
                occlusion = ambient_occlusion(volume, occlusion_lut, point, &shadow_samples);
            }
            light = shade_blocked(gradient_trilinear(volume, point, work), to_light, light_t,
                                  occlusion);
        }
        const double alpha = sample.a;
        const double weight = pixel.transparency * alpha * light;
        pixel.r += weight * sample.r;
        pixel.g += weight * sample.g;
        pixel.b += weight * sample.b;
        pixel.transparency *= 1 - alpha;
        if (trace) trace->add("t=%9.4f p=(%.6f, %.6f, %.6f) value=%9.4f rgba=(%.3f, %.3f, "
                              "%.3f, %.4f) light_T=%.6f ao=%.6f (%d shadow samples) L=%.4f "
                              "C=(%.6f, %.6f, %.6f) T=%.6g", t, point.i, point.j, point.k,
                              value, sample.r, sample.g, sample.b, sample.a, light_t, occlusion,
                              shadow_samples, light, pixel.r, pixel.g, pixel.b,
                              pixel.transparency);
        if (pixel.transparency < stop_below && n + 1 < sample_count) {
            ++work.terminated;
            if (trace) trace->add("T=%.3g < %.3g: early ray termination at t=%.4f, %lld samples "
                                  "not visited", pixel.transparency, stop_below, t,
                                  sample_count - 1 - n);
            break;
        }
    }
    return pixel;
}

static Rgb over_background(const Accumulated& ray) {
    return {float(ray.r + ray.transparency * background.r),
            float(ray.g + ray.transparency * background.g),
            float(ray.b + ray.transparency * background.b)};
}
//< lesson: front_to_back

// Why `step` asks too much, or "": a ray crosses at most the box's diagonal, and more than
// max_samples_per_voxel samples per voxel along it (e.g. --spacing 1e6,1e6,1e6) is refused.
static std::string too_many_samples(const Volume& volume, double step) {
    const double samples = length(box_high(volume)) / step;
    const double limit = max_samples_per_voxel * (volume.nx + volume.ny + volume.nz);
    if (samples <= limit) return "";
    char text[320];
    std::snprintf(text, sizeof text, "--step %g with --spacing %g,%g,%g asks for %.4g samples "
                  "along the box's diagonal, over the limit of %.0f: raise --step or lower "
                  "--spacing", step, volume.sx, volume.sy, volume.sz, samples, limit);
    return text;
}

// "512x384" -> 512, 384; anything else is refused naming --size.
static void parse_size(const std::string& text, int* width, int* height) {
    const size_t cross = text.find('x');
    if (cross == std::string::npos) {
        throw InputError("--size: expected WIDTHxHEIGHT such as 512x512, got '" + text + "'");
    }
    *width = parse_int("--size", text.substr(0, cross), 1, max_image_side);
    *height = parse_int("--size", text.substr(cross + 1), 1, max_image_side);
}

static std::string number(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", value);
    return text;
}

int main(int argc, char** argv) {
    return guarded_main(step_name, [&] {
        // --- Options: the shared flags plus this step's own ---
        Params params;
        Args args(step_name, "Step 10's lit compositing with light that is blocked: shadow rays "
                             "towards the light and ambient occlusion.");
        args.add_string("--tf", &params.tf_path,
                        "transfer function file (default data/tf/classic.tf)");
        args.add_double("--skin-opacity", &params.skin_opacity, 0, 1,
                        "opacity of the range labelled skin (default: as the file says)");
        args.add_double("--ert", &params.ert, 0, 1,
                        "stop a ray once its transparency T is below this (0: never)");
        args.add_double("--step", &params.step, min_step, max_step,
                        "physical units between two samples along a ray");
        args.add_double("--light-angle", &params.light_angle, -180, 180,
                        "light direction, degrees to the right of the camera");
        args.add_switch("--unlit", &params.unlit, "no lighting: L = 1, as in step 07");
        args.add_switch("--no-correction", &params.no_correction,
                        "use the TF opacities unchanged, whatever the step");
        args.add_double("--azimuth", &params.azimuth, -360, 360,
                        "degrees around the vertical; 0 faces the face, 90 looks along +i");
        args.add_double("--elevation", &params.elevation, -90, 90,
                        "degrees above the i-j plane; 90 looks down from the crown");
        args.add_double("--zoom", &params.zoom, 0.01, 100,
                        "ortho: pixels per voxel; perspective: walks the eye in (>1)");
        args.add_choice("--projection", &params.projection, {"ortho", "perspective"},
                        "parallel rays (ortho) or rays from an eye (perspective)");
        args.add_double("--fov", &params.fov, 1, 170,
                        "perspective: the image's height as an angle, degrees");
        args.add_string("--size", &params.size, "image size WIDTHxHEIGHT (default 512x512)");
        args.add_choice("--shadows", &params.shadows, {"ray", "none"},
                        "a shadow ray towards the light from every lit sample, or none");
        args.add_choice("--ao", &params.ao, {"on", "off"},
                        "ambient occlusion from the opacity around every lit sample");
        const Options options = args.parse(argc, argv);
        if (options.view != "all") {
            throw InputError("--view: step 14 renders the camera's view; turn it with "
                             "--azimuth and --elevation instead");
        }
        int width = 0, height = 0;
        parse_size(params.size, &width, &height);

        // --- Volume ---
        const Volume volume = load_volume(options);
        const std::string refused = too_many_samples(volume, params.step);
        if (!refused.empty()) throw InputError(refused);

        // --- Transfer function: the file (in the file's units), its table for this step size ---
        TransferFunction tf = load_transfer_function(params.tf_path, volume.map);
        if (params.skin_opacity >= 0) {
            set_opacity(tf, skin_label, params.skin_opacity, "--skin-opacity");
        }
        Lut lut = build_lut(tf, opacity_ratio(params));
        const Lut occlusion_lut = build_lut(tf, occlusion_step / unit_length);

        // --- View: the camera ---
        const Camera camera = make_camera(volume, params, width, height);

        // --- Render: one ray per pixel ---
        Renderer renderer;
        renderer.transfer_function = &tf;  // the ray picture draws its ranges
        renderer.views = {make_camera_view(width, height)};
        renderer.ray = [&](const View&, int x, int y, Work& work, Trace* trace) {
            return over_background(composite_front_to_back(volume, camera, x, y, lut,
                                                           occlusion_lut, params, work, trace));
        };
        renderer.ray_samples = [&](const View&) {
            return "samples " + number(params.step) + " physical units apart";
        };
        renderer.knob = {"step",
                         [&](const View&, int steps) {
                             const double step = std::clamp(
                                 params.step * std::pow(step_key_factor, steps), min_step,
                                 max_step);
                             if (!too_many_samples(volume, step).empty()) return;  // keep it
                             params.step = step;
                             lut = build_lut(tf, opacity_ratio(params));
                         },
                         [&] { return number(params.step); }};
        renderer.settings = [&] {
            const TfRange* skin = find_range(tf, skin_label);
            return "tf=" + tf.source +
                   " skin_opacity=" + (skin ? number(skin->start.a) : std::string("none")) +
                   " ert=" + number(params.ert) +
                   " light_angle=" + std::to_string(int(std::lround(params.light_angle))) +
                   " lighting=" + (params.unlit ? "off" : "on") +
                   " correction=" + (params.no_correction ? "off" : "on") +
                   " projection=" + params.projection + " azimuth=" + number(params.azimuth) +
                   " elevation=" + number(params.elevation) + " zoom=" + number(params.zoom) +
                   " fov=" + number(params.fov) + " shadows=" + params.shadows +
                   " ao=" + params.ao;
        };

        // --- Output: a PNG and a summary line, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
