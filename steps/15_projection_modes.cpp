// 15_projection_modes.cpp: maximum, minimum and average intensity along the free camera's ray.
//
// New here:   no transfer function, no compositing: each ray reduces the values it samples
//             inside the box to one number, the largest (MIP), the smallest (MinIP) or their
//             mean (average, a simulated X-ray), shown as grey with part 1's mapping (the
//             volume's min..max to black..white). --slab W keeps only the samples within W/2
//             of the plane through the box's centre, facing the camera (a thin-slab projection).
//             Step 12's table, light and compositing go.
// Builds on:  12_trilinear (the orbit camera, the slab method, trilinear samples).
// Handout:    handouts/15_projection_modes.md
// Run:        make run STEP=15 ARGS="--mode minip --slab 20"
// Reference:  data/reference/15_projection_modes_camera.png: the default run (MIP, azimuth 30,
//             elevation 20, orthographic, 512x512), on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "15_projection_modes";
constexpr Rgb background = {0, 0, 0};  // a ray that meets no sample: black
constexpr double default_step = 1;    // physical units between two samples along a ray
constexpr double min_step = 0.25, max_step = 4;  // --step limits, physical units
constexpr double step_key_factor = 2;            // Up doubles the step, Down halves it
constexpr double degrees = 3.14159265358979323846 / 180;
constexpr double default_azimuth = 30;    // degrees around the vertical, 0: facing the face
constexpr double default_elevation = 20;  // degrees above the i-j plane
constexpr double default_fov = 30;        // degrees, the perspective image's height
constexpr double min_zoom = 0.01, max_zoom = 100;  // --zoom limits (and the window's wheel)
constexpr const char* default_size = "512x512";  // pixels, columns x rows
constexpr int max_image_side = 8192;             // pixels, --size limit per side
constexpr double max_slab = 1e5;                 // physical units, --slab limit
// Samples at t_entry + n*step up to t_exit; the last may be this many steps past the exit in
// rounding (a ray 224 units long at step 2 gets 113 samples even when t_exit is 223.99999...).
constexpr double sample_count_slack = 1e-9;

struct Params {
    std::string mode = "mip";    // "mip", "minip" or "average"
    double slab = 0;             // physical units: only samples this thick a slab; 0: all
    double step = default_step;  // physical units between samples
    double azimuth = default_azimuth;      // degrees
    double elevation = default_elevation;  // degrees, -90..90
    double zoom = 1;                       // ortho: pixels per voxel; perspective: closer
    std::string projection = "ortho";      // "ortho" or "perspective"
    std::string interpolation = "trilinear";  // how a sample is read: or "nearest"
    bool nearest = false;                     // interpolation == "nearest"
    double fov = default_fov;              // degrees, perspective only
    std::string size = default_size;       // "WxH"
};

// What a ray has gathered: the largest and smallest value, and the sum (in double: a long
// ray adds thousands of values) and count of its samples for the mean.
struct Projection {
    float highest = 0, lowest = 0;
    double sum = 0;
    long long count = 0;  // samples inside the box (and the slab): 0 when the ray misses
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


// A ray's samples in voxel units, worked out once per ray: sample n is at first + n * per_step
// (voxel coordinates: physical / spacing), for n = 0 .. count - 1.
struct Walk {
    Vec3d first, per_step;
    long long count = 0;

    Vec3d at(long long n) const {
        const double s = double(n);
        return {first.i + s * per_step.i, first.j + s * per_step.j, first.k + s * per_step.k};
    }
};

// The eight voxels around a point: the voxel at or below it (the low corner), how far the
// point is past it along each axis (0..1), and the high corner, the next voxel along each
// axis (at the last voxel of an axis: that voxel again).
struct Cell {
    int i = 0, j = 0, k = 0;           // the low corner
    float fi = 0, fj = 0, fk = 0;      // the point's fractions past it
    int i1 = 0, j1 = 0, k1 = 0;        // the high corner
};

// Given: a value fraction f of the way from a to b: a itself when f = 0.
static float lerp(float a, float b, float f) { return a + f * (b - a); }

//> lesson: trilinear
// The ray's samples from its entry to its exit, `step` physical units apart, in voxel units:
// the divisions by the spacing are done here, once per ray, not at every sample.
static Walk walk_through(const Volume& volume, const Ray& ray, const Span& span, double step) {
    const Vec3d entry = entry_point(ray, span, box_high(volume));
    Walk walk;
    walk.first = {entry.i / volume.sx, entry.j / volume.sy, entry.k / volume.sz};
    walk.per_step = {step * ray.direction.i / volume.sx, step * ray.direction.j / volume.sy,
                     step * ray.direction.k / volume.sz};
    walk.count = (long long)(std::floor((span.t_exit - span.t_entry) / step +
                                        sample_count_slack)) + 1;
    return walk;
}

// Along one axis: u is the point's coordinate in voxels, kept within 0 .. count - 1. At a
// voxel centre the fraction is exactly 0, so that voxel comes back as it is.
static void low_corner(double u, int count, int* low, float* fraction) {
    u = std::clamp(u, 0.0, double(count - 1));
    *low = std::min(int(u), count - 1);  // u >= 0: int() rounds down
    *fraction = float(u - *low);
}

static Cell cell_at(const Volume& volume, const Vec3d& point, bool nearest) {
    Cell cell;
    // nearest: the point first moves to the nearest voxel centre (a half rounds up), so
    // every fraction is 0 and the low corner is that voxel.
    const Vec3d p = nearest ? Vec3d{std::floor(point.i + 0.5), std::floor(point.j + 0.5),
                                    std::floor(point.k + 0.5)}
                            : point;
    low_corner(p.i, volume.nx, &cell.i, &cell.fi);
    low_corner(p.j, volume.ny, &cell.j, &cell.fj);
    low_corner(p.k, volume.nz, &cell.k, &cell.fk);
    cell.i1 = std::min(cell.i + 1, volume.nx - 1);
    cell.j1 = std::min(cell.j + 1, volume.ny - 1);
    cell.k1 = std::min(cell.k + 1, volume.nz - 1);
    return cell;
}

// Trilinear interpolation: linear along i on the cell's four edges, then along j, then k.
// Exact for any field linear in i, j and k (and so in physical space).
static float trilinear(const Volume& volume, const Cell& c) {
    const float low_low = lerp(volume.at(c.i, c.j, c.k), volume.at(c.i1, c.j, c.k), c.fi);
    const float high_low = lerp(volume.at(c.i, c.j1, c.k), volume.at(c.i1, c.j1, c.k), c.fi);
    const float low_high = lerp(volume.at(c.i, c.j, c.k1), volume.at(c.i1, c.j, c.k1), c.fi);
    const float high_high = lerp(volume.at(c.i, c.j1, c.k1), volume.at(c.i1, c.j1, c.k1), c.fi);
    return lerp(lerp(low_low, high_low, c.fj), lerp(low_high, high_high, c.fj), c.fk);
}

// A sample's value (--interpolation): the nearest voxel's, one read (cell_at put the cell's
// low corner on it), or trilinear, eight.
static float sample_value(const Volume& volume, const Cell& c, bool nearest) {
    return nearest ? float(volume.at(c.i, c.j, c.k)) : trilinear(volume, c);
}
//< lesson: trilinear



// CT value -> grey 0..1: (value - min) / (max - min) of the whole volume, as in part 1 (step
// 00); trilinear values lie between voxel values, so within 0..1 too.
// Changed in step 15: takes a trilinear (fractional) value.
static float display_grey(const Volume& volume, double value) {
    const int range = volume.max_value - volume.min_value;  // 0 for a constant volume
    return range > 0 ? float((value - volume.min_value) / range) : 0.0f;
}

// The ray's two trace records (given): where it starts, and where it meets the box. The entry
// is entry_point()'s, on the face (the first sample's point): 0, never a rounded -0.0000.
static void trace_ray(Trace* trace, const Ray& ray, const Span& span, const Vec3d& high,
                      double step) {
    if (!trace) return;
    trace->ray(ray.origin, ray.direction);
    if (!span.hit) {
        trace->box_missed(high);
        return;
    }
    const Vec3d in = entry_point(ray, span, high);
    const Vec3d out = ray.origin + span.t_exit * ray.direction;
    trace->box(high, span.t_entry, in, span.entry_axis, span.t_exit, out, step);
}

//> lesson: projection
// --slab: the part of the span within slab / 2 of the plane through the box's centre at right
// angles to the view. Along the ray that distance grows by dot(direction, forward) per unit
// of t: 1 for an orthographic ray, cos(angle to forward) > 0 for a perspective one.
static Span within_slab(const Ray& ray, Span span, const Camera& camera, double slab,
                        Trace* trace) {
    const double rate = dot(ray.direction, camera.forward);
    const double depth = dot(ray.origin - camera.centre, camera.forward);  // at t = 0
    const double t_near = (-slab / 2 - depth) / rate, t_far = (slab / 2 - depth) / rate;
    if (span.hit && t_near > span.t_entry) {
        span.t_entry = t_near;
        span.entry_axis = -1;  // inside the box: no face to put the entry on
    }
    span.t_exit = std::min(span.t_exit, t_far);
    if (span.hit && span.t_entry > span.t_exit) span.hit = false;
    if (trace) {
        trace->note({{"slab", slab}, {"t", t_near}, {"t_end", t_far}}, "slab %g: t=%.6f..%.6f, %s",
                    slab, t_near, t_far,
                    span.hit ? "samples from the later entry to the earlier exit"
                             : "no part of the box within it");
    }
    return span;
}

// One ray's projection: samples at t_entry + n * step until t_exit (step 12's), read by
// trilinear interpolation; the largest, the smallest and the sum, all starting from the
// first sample (not from 0: CT values go below 0). Only samples inside the box count: a ray
// that misses it has none.
static Projection project_ray(const Volume& volume, const Camera& camera, int x, int y,
                              const Params& params, Work& work, Trace* trace) {
    const Vec3d high = box_high(volume);
    const Ray ray = camera_ray(camera, x, y);
    Span span = intersect_box(ray, Vec3d{}, high);
    trace_ray(trace, ray, span, high, params.step);
    if (params.slab > 0 && span.hit) span = within_slab(ray, span, camera, params.slab, trace);
    Projection projection;
    if (!span.hit) return projection;
    const Walk walk = walk_through(volume, ray, span, params.step);
    for (long long n = 0; n < walk.count; ++n) {
        const Vec3d q = walk.at(n);  // voxel units
        const float value =
            sample_value(volume, cell_at(volume, q, params.nearest), params.nearest);
        ++work.samples;
        if (projection.count == 0) projection.highest = projection.lowest = value;
        projection.highest = std::max(projection.highest, value);
        projection.lowest = std::min(projection.lowest, value);
        projection.sum += value;
        ++projection.count;
        if (trace) {
            const Vec3d p = {q.i * volume.sx, q.j * volume.sy, q.k * volume.sz};
            trace->sample(TraceSample(span.t_entry + n * params.step, p, value)
                              .projection(projection.highest, projection.lowest,
                                          projection.sum / projection.count));
        }
    }
    return projection;
}

// The value the mode shows, as grey; a ray with no sample shows the background.
static Rgb projection_grey(const Volume& volume, const Projection& projection,
                           const std::string& mode) {
    if (projection.count == 0) return background;
    double value = projection.sum / projection.count;  // average
    if (mode == "mip") value = projection.highest;
    if (mode == "minip") value = projection.lowest;
    return grey(display_grey(volume, value));
}
//< lesson: projection

int main(int argc, char** argv) {
    return guarded_main(step_name, [&] {
        // --- Options: the shared flags plus this step's own ---
        Params params;
        Args args(step_name, "Maximum, minimum or average intensity along the rays of an orbit "
                             "camera, as grey.");
        args.add_choice("--mode", &params.mode, {"mip", "minip", "average"},
                        "the largest value along the ray, the smallest, or their mean");
        args.add_double("--slab", &params.slab, 0, max_slab,
                        "only samples within a slab this thick (physical units) through the "
                        "centre, facing the camera; 0: the whole box");
        args.add_double("--step", &params.step, min_step, max_step,
                        "physical units between two samples along a ray");
        args.add_double("--azimuth", &params.azimuth, -360, 360,
                        "degrees around the vertical; 0 faces the face, 90 looks along +i");
        args.add_double("--elevation", &params.elevation, -90, 90,
                        "degrees above the i-j plane; 90 looks down from the crown");
        args.add_double("--zoom", &params.zoom, min_zoom, max_zoom,
                        "ortho: pixels per voxel; perspective: walks the eye in (>1)");
        args.add_choice("--interpolation", &params.interpolation, {"trilinear", "nearest"},
                        "a sample's value: the eight voxels around it, or the nearest one");
        args.add_choice("--projection", &params.projection, {"ortho", "perspective"},
                        "parallel rays (ortho) or rays from an eye (perspective)");
        args.add_double("--fov", &params.fov, 1, 170,
                        "perspective: the image's height as an angle, degrees (default 30)");
        args.add_string("--size", &params.size, "image size WIDTHxHEIGHT (default 512x512)",
                        "WxH");
        const Options options = args.parse(argc, argv);
        params.nearest = params.interpolation == "nearest";
        if (options.view != "all") {
            throw InputError("--view: step 15 renders the camera's view; turn it with "
                             "--azimuth and --elevation instead");
        }
        int width = 0, height = 0;
        parse_size(params.size, max_image_side, &width, &height);

        // --- Volume ---
        const Volume volume = load_volume(options);
        const std::string refused = too_many_samples_along_box(volume, params.step);
        if (!refused.empty()) throw InputError(refused);

        // --- View: the camera's image (its camera is made for each render: the window turns
        // it, and previews at coarser pixels while it does) ---
        Renderer renderer;
        renderer.views = {make_camera_view(width, height)};

        // --- Render: one ray per pixel ---
        auto pixel = [&](const Camera& camera, int x, int y, Work& work, Trace* trace) {
            return projection_grey(volume, project_ray(volume, camera, x, y, params, work, trace),
                                   params.mode);
        };
        renderer.image = [&](const View& view, Work& work) {
            const Camera camera = make_camera(volume, params, view);
            return render_image(view, options.threads, work, [&](int x, int y, Work& ray_work) {
                return pixel(camera, x, y, ray_work, nullptr);
            });
        };
        renderer.ray = [&](const View& view, int x, int y, Work& work, Trace* trace) {
            return pixel(make_camera(volume, params, view), x, y, work, trace);
        };
        renderer.ray_samples = [&](const View&) {
            return "samples " + summary_number(params.step) + " physical units apart";
        };
        renderer.knob = {"step",
                         [&](const View&, int steps) {
                             const double step = std::clamp(
                                 params.step * std::pow(step_key_factor, steps), min_step,
                                 max_step);
                             if (!too_many_samples_along_box(volume, step).empty()) return;  // keep it
                             params.step = step;
                         },
                         [&] { return summary_number(params.step); }};
        renderer.orbit.turn = [&](double azimuth, double elevation) {
            params.azimuth = std::remainder(params.azimuth + azimuth, 360.0);  // -180..180
            params.elevation = std::clamp(params.elevation + elevation, -90.0, 90.0);
        };
        renderer.orbit.zoom = [&](double factor) {
            params.zoom = std::clamp(params.zoom * factor, min_zoom, max_zoom);
        };
        renderer.orbit.value = [&] {
            return "azimuth=" + summary_number(params.azimuth) + " elevation=" +
                   summary_number(params.elevation) + " zoom=" + summary_number(params.zoom);
        };
        renderer.settings = [&] {
            return "mode=" + params.mode + " slab=" + summary_number(params.slab) +
                   " projection=" + params.projection + " azimuth=" + summary_number(params.azimuth) +
                   " elevation=" + summary_number(params.elevation) + " zoom=" + summary_number(params.zoom) +
                   " fov=" + summary_number(params.fov) + " interpolation=" + params.interpolation;
        };

        // --- Output: a PNG and a summary line, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
