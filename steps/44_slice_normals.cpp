// 44_slice_normals.cpp: the records' normal indices made a slice at a time: no normal volume.
//
// New here:   step 43 fills a volume of normal indices (2 bytes a voxel) that pack_slice()
//             reads back; here each slice's go into an array of the slice's as it is packed:
//             no normal volume. Step 43's pictures, to the bit. A perspective camera:
//             step 30's rays (--step their spacing). --work-map is refused: the work is
//             counted per row of the intermediate image.
// Builds on:  43_run_records.
// Handout:    handouts/44_slice_normals.md
// Run:        make run STEP=44 ARGS="--azimuth 180 --elevation 90 --size 256x256"
// Reference:  data/reference/44_slice_normals_camera.png: the default run (lit composite,
//             azimuth 30, elevation 20, orthographic, 512x512), on the phantom.
#include "common/ctlab.h"
#include <cstring>  // std::memcpy: a float's bits
#include <memory>  // std::unique_ptr: arrays left unset until written
using namespace ctlab;

constexpr const char* step_name = "44_slice_normals";
constexpr Rgb background = {0, 0, 0};       // what a ray sees behind the volume: black
constexpr double default_ert = 0.01;        // stop a ray once T is below this; 0: never
constexpr double min_transparency = 1e-300;  // stop below this T even with --ert 0
constexpr double unit_length = 1;     // physical length the TF opacities hold for: one voxel
                                      // at spacing 1
constexpr double default_step = 1;    // physical units between two samples along a ray
constexpr double min_step = 0.25, max_step = 4;  // --step limits, physical units
constexpr double step_key_factor = 2;            // Up doubles the step, Down halves it
constexpr const char* skin_label = "skin";  // the range --skin-opacity changes
constexpr double default_light_angle = 30;  // degrees to the right of the viewer
constexpr double light_elevation = 20;      // degrees above the viewer, fixed
constexpr float ambient = 0.1f;             // light that reaches every surface, 0..1
constexpr double degrees = 3.14159265358979323846 / 180;
// Samples at t_entry + n*step up to t_exit; the last may be this many steps past the exit in
// rounding (a ray 224 units long at step 2 gets 113 samples even when t_exit is 223.99999...).
constexpr double sample_count_slack = 1e-9;

struct Params : CameraFlags {  // --azimuth, --elevation, --zoom, --projection, --fov, --size
    std::string mode = "composite";  // "composite" or "mip"
    std::string tf_path;       // "": data/tf/classic.tf when present, else the built-in copy
    double skin_opacity = -1;  // 0..1; -1: as the transfer function file says
    double ert = default_ert;  // early ray termination threshold for T
    double step = default_step;  // physical units between samples
    double light_angle = default_light_angle;
    bool unlit = false;          // L = 1 everywhere, no gradients (as step 08)
    bool no_correction = false;  // use the TF opacities as they are, whatever the step
    std::string interpolation = "trilinear";  // how a sample is read: or "nearest"
    bool nearest = false;                     // interpolation == "nearest"
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

// --- Part 2's renderer: part 2's lessons, unchanged (make carry brings a student's own) ---

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

//> lesson: opacity_correction
// The opacity correction of step 10, unchanged.
static float corrected_opacity(float alpha, double ratio) {
    if (alpha <= 0.0f) return 0.0f;
    if (alpha >= 1.0f) return 1.0f;
    return float(-std::expm1(ratio * std::log1p(-double(alpha))));
}

// Changed in step 36: the samples are one slice apart, `spacing` physical units along a ray
// (it depends on the view), not --step apart.
static double opacity_ratio(const Params& params, double spacing) {
    return params.no_correction ? 1.0 : spacing / unit_length;
}
//< lesson: opacity_correction

// Step 10's lookup table, unchanged: one RGBA per CT value, opacities corrected for the step.
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

// Given: lerp() for gradients.
static Vec3 lerp_vector(Vec3 a, Vec3 b, float f) { return a + f * (b - a); }

//> lesson: gradient
// Step 10's derivative and gradient at a voxel, unchanged.
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

// The gradient at a point: the eight corner voxels' gradients interpolated trilinearly, as the
// values are. At a voxel centre it is that voxel's gradient exactly (step 10's at its samples).
static Vec3 gradient_trilinear(const Volume& volume, const Cell& c, Work& work) {
    auto g = [&](int a, int b, int d) {  // corner a along i, b along j, d along k: 0 or 1
        return gradient_at(volume, Voxel{a ? c.i1 : c.i, b ? c.j1 : c.j, d ? c.k1 : c.k}, work);
    };
    const Vec3 low_low = lerp_vector(g(0, 0, 0), g(1, 0, 0), c.fi);
    const Vec3 high_low = lerp_vector(g(0, 1, 0), g(1, 1, 0), c.fi);
    const Vec3 low_high = lerp_vector(g(0, 0, 1), g(1, 0, 1), c.fi);
    const Vec3 high_high = lerp_vector(g(0, 1, 1), g(1, 1, 1), c.fi);
    return lerp_vector(lerp_vector(low_low, high_low, c.fj), lerp_vector(low_high, high_high, c.fj),
                       c.fk);
}

// A sample's gradient: with nearest samples the nearest voxel's own (step 10's, one voxel's
// differences), else trilinear.
static Vec3 sample_gradient(const Volume& volume, const Cell& c, bool nearest, Work& work) {
    if (!nearest) return gradient_trilinear(volume, c, work);
    return gradient_at(volume, Voxel{c.i, c.j, c.k}, work);
}
//< lesson: gradient

//> lesson: shade
// Step 10's diffuse shading, unchanged.
static float shade(Vec3 gradient, Vec3 to_light) {
    const float size = length(gradient);
    if (size == 0.0f) return ambient;
    const Vec3 normal = (-1.0f / size) * gradient;
    return ambient + (1.0f - ambient) * std::max(0.0f, dot(normal, to_light));
}

// Unit direction towards the light, angle to the right of the camera and elevation above it:
// step 10's light, in the camera's frame (so part 1's top and side views get the same light).
static Vec3 light_direction(const Camera& camera, double angle) {
    const float along_x = float(std::sin(angle * degrees) * std::cos(light_elevation * degrees));
    const float along_y = float(-std::sin(light_elevation * degrees));  // image y points down
    const float along_ray = float(-std::cos(angle * degrees) * std::cos(light_elevation * degrees));
    auto axis = [](const Vec3d& a) { return Vec3{float(a.i), float(a.j), float(a.k)}; };
    return along_x * axis(camera.right) + (-along_y) * axis(camera.up) +
           along_ray * axis(camera.forward);
}
//< lesson: shade

// CT value -> grey 0..1: (value - min) / (max - min) of the whole volume, as in step 18.
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

//> lesson: ray_output
static Rgb over_background(const Accumulated& ray) {
    return {float(ray.r + ray.transparency * background.r),
            float(ray.g + ray.transparency * background.g),
            float(ray.b + ray.transparency * background.b)};
}
//< lesson: ray_output

// --- Object order from any orthographic camera: the shear (step 37) ---

// The slices: the planes of voxels across axis c, the axis the camera looks along; a, b a
// slice's axes (a the lower: a row is contiguous in memory when a is i). Along an axis each
// ray runs down one voxel column: intermediate pixel (u, v) meets slice c at voxel (u, v).
// At an angle c is the principal axis and the slices shift (the shear): the ray of pixel
// (u, v) meets slice m (front to back) at a = u + base_a + m * delta_a, b = v + base_b + ....
struct Shear {
    int a = 0, b = 1, c = 2;     // the axes: 0 i, 1 j, 2 k
    int na = 1, nb = 1, nc = 1;  // voxels along a, b, c
    size_t stride_a = 1, stride_b = 1, stride_c = 1;  // volume.index() steps along a, b, c
    int first_slice = 0, slice_step = 1;  // slice m is c = first_slice + m * slice_step
    double delta_a = 0, delta_b = 0;      // voxels along a and b from one slice to the next
    double base_a = 0, base_b = 0;        // where the ray of pixel (0, 0) meets slice 0
    int width = 1, height = 1;            // the intermediate image, pixels
    double spacing = 1;  // physical length along a ray from one slice to the next
};

// Slice m's shift: pixel (u, v) samples the cell whose low corner is voxel (u + ia, v + ib)
// of the slice, fa and fb of the way past it: the same bilinear weights for every pixel.
struct SliceShift {
    int slice = 0;          // its c
    int ia = 0, ib = 0;     // from pixel to cell, voxels
    float fa = 0, fb = 0;   // the fractions past the low corner, 0..1
    size_t da = 0, db = 0;  // index steps to the cell's high corner (0 when the fraction is 0)
    int last_a = 0, last_b = 0;  // the last cell: n - 1 when the fraction is 0, else n - 2
};

// A run's voxels, packed (pack_slice()). A run of cells [begin, end) along a in slice row b
// keeps one record per voxel column a = begin .. end (one more than its cells: a cell's high
// corner), the runs one after another in slice order: a sample of cell a reads record a and
// the next one, and nothing else (lit or not: record_light(), common/object_order.h).
struct Record {
    int16_t low, high;  // the voxel values at (a, b) and (a, b + 1) of the slice (the last row
                        // and column repeated at the slice's edges)
    uint16_t low_normal, high_normal;  // their normal indices; lit composite only, else 0
};
using Records = std::unique_ptr<Record[]>;  // one slice's, left unset until packed

struct Runs : SliceRuns {  // the runs (common/object_order.h), and their records
    std::vector<Records> records;      // per slice: its runs', in order
    TableVector<const Record*> start;  // per run: its first record; empty: not packed
    size_t record_count = 0;           // records, all slices
    size_t normals = 0;                // normal indices computed while packing (0: unlit)

    // The records of the run that `run` (a pointer row() gave) starts, from its first column.
    const Record* records_of(const int32_t* run) const {
        return start[size_t(run - bounds.data()) / 2];
    }
};

// Quantised normals (VolPack's way): a voxel's gradient is rounded to the index of the
// nearest direction in a fixed set, two bytes; a table made per render holds the light of
// every direction. A lit sample is then four indices and four table reads, blended as the
// values are: no shade per sample. The set is the octahedral one: a direction d is put on
// the octahedron |x| + |y| + |z| = 1 (d over its length in that sum, no square root), its
// lower half folded over the upper, and its (x, y) rounded to a grid of normal_grid x
// normal_grid points on [-1, 1]^2. Index 0 is "no direction" (a gradient of 0: ambient light
// only, as shade() gives).
constexpr int normal_grid = 129;  // points per side, odd so that the axes are points: 16,641
                                  // directions, one within 1.9 degrees of any direction (0.67
                                  // on average; handout 42, Quality)
constexpr int normal_count = normal_grid * normal_grid + 1;  // with index 0

//> lesson: normals
// The index of the direction nearest g's (0 when g is 0), without a branch (step 46 calls it
// sixteen voxels at a time): the fold's test is k's sign bit, its signs std::copysign.
static inline uint16_t normal_index(Vec3 g) {
    const float sum = std::fabs(g.i) + std::fabs(g.j) + std::fabs(g.k);
    const float inverse = 1.0f / (sum + std::numeric_limits<float>::min());  // finite at 0
    const float x = g.i * inverse, y = g.j * inverse;
    // The lower half (k < 0), folded over the upper one: lower is 1 there, else 0.
    int32_t k_bits;
    std::memcpy(&k_bits, &g.k, sizeof k_bits);
    const float lower = float((k_bits >> 31) & 1);
    const float folded_x = std::copysign(1.0f - std::fabs(y), x);
    const float folded_y = std::copysign(1.0f - std::fabs(x), y);
    const float on_x = x + lower * (folded_x - x), on_y = y + lower * (folded_y - y);
    constexpr float half_grid = 0.5f * (normal_grid - 1);
    const int u = std::min(normal_grid - 1, std::max(0, int((on_x + 1.0f) * half_grid + 0.5f)));
    const int v = std::min(normal_grid - 1, std::max(0, int((on_y + 1.0f) * half_grid + 0.5f)));
    return uint16_t(sum != 0.0f ? 1 + v * normal_grid + u : 0);
}

// Every index's direction, a unit vector (index 0: the zero vector).
static std::vector<Vec3> normal_directions() {
    std::vector<Vec3> directions(normal_count, Vec3{0, 0, 0});
    for (int v = 0; v < normal_grid; ++v) {
        for (int u = 0; u < normal_grid; ++u) {
            float x = 2.0f * u / (normal_grid - 1) - 1.0f, y = 2.0f * v / (normal_grid - 1) - 1.0f;
            const float z = 1.0f - std::fabs(x) - std::fabs(y);
            if (z < 0.0f) {  // unfolded
                const float unfolded_x = (1.0f - std::fabs(y)) * (x >= 0.0f ? 1.0f : -1.0f);
                const float unfolded_y = (1.0f - std::fabs(x)) * (y >= 0.0f ? 1.0f : -1.0f);
                x = unfolded_x;
                y = unfolded_y;
            }
            const Vec3 d = {x, y, z};
            directions[1 + v * normal_grid + u] = (1.0f / length(d)) * d;
        }
    }
    return directions;
}

// The shading table for one render: step 10's shade() of every direction, towards this
// render's light. The rows of directions are shared among the threads.
static void make_shading_table(const std::vector<Vec3>& directions, Vec3 to_light, int threads,
                               std::vector<float>& light) {
    light.resize(directions.size());
    light[0] = shade(directions[0], to_light);  // no direction: ambient
    Work unused;
    parallel_rows(normal_grid, threads, unused, [&](int v, Work&) {
        for (int n = 1 + v * normal_grid; n < 1 + (v + 1) * normal_grid; ++n) {
            light[n] = shade(directions[n], to_light);
        }
    });
}
//< lesson: normals

// Everything a ray needs that is the same for every ray of a render.
struct Scene {
    const Volume& volume;
    const Camera& camera;
    const Shear& shear;  // the slices (object order); empty for step 30's rays
    const std::vector<SliceShift>& shifts;  // slice m's, front to back
    const Runs& runs;
    const Lut& lut;
    const float* shading;            // lit with normals: the light of every normal index
    Vec3 to_light;  // unit vector towards the light; unused when unlit
    const Params& params;
};

// Given: the views the slices do not take (changed in step 37: perspective) are step 30's rays.
static bool by_rays(const Camera& camera) {
    return camera.perspective;
}

//> lesson: slices
// The slices for any orthographic camera: c is the principal axis (along it the view crosses
// most voxels per unit length: a slice shifts by at most a voxel); front to back is the
// sign of the view direction along it. The intermediate image is one pixel per voxel column.
// Changed in step 37: any direction; the shift per slice, the image wide enough for each.
static Shear make_shear(const Volume& volume, const Camera& camera) {
    const double spacing[3] = {volume.sx, volume.sy, volume.sz};
    const int counts[3] = {volume.nx, volume.ny, volume.nz};
    const size_t strides[3] = {1, size_t(volume.nx), size_t(volume.nx) * size_t(volume.ny)};
    double per_unit[3];  // voxels crossed along each axis per physical unit along the view
    for (int axis = 0; axis < 3; ++axis) per_unit[axis] = camera.forward[axis] / spacing[axis];
    Shear shear;
    shear.c = 2;  // k first: on a tie, the slices are contiguous in memory
    for (int axis = 1; axis >= 0; --axis) {
        if (std::fabs(per_unit[axis]) > std::fabs(per_unit[shear.c])) shear.c = axis;
    }
    shear.a = shear.c == 0 ? 1 : 0;
    shear.b = shear.c == 2 ? 1 : 2;
    shear.na = counts[shear.a], shear.nb = counts[shear.b], shear.nc = counts[shear.c];
    shear.stride_a = strides[shear.a], shear.stride_b = strides[shear.b];
    shear.stride_c = strides[shear.c];
    const double along_c = per_unit[shear.c];
    shear.first_slice = along_c > 0 ? 0 : shear.nc - 1;
    shear.slice_step = along_c > 0 ? 1 : -1;
    shear.delta_a = per_unit[shear.a] / std::fabs(along_c);
    shear.delta_b = per_unit[shear.b] / std::fabs(along_c);
    const double last = shear.nc - 1;  // slices after the first
    shear.base_a = -std::max(0.0, last * shear.delta_a);  // pixel 0 meets some slice at a = 0
    shear.base_b = -std::max(0.0, last * shear.delta_b);
    shear.width = int(std::floor(shear.na - 1 + last * std::fabs(shear.delta_a))) + 1;
    shear.height = int(std::floor(shear.nb - 1 + last * std::fabs(shear.delta_b))) + 1;
    shear.spacing = spacing[shear.c] / std::fabs(camera.forward[shear.c]);
    return shear;
}

// Slice m's shift. Nearest samples (--interpolation nearest) round the position to the
// nearest voxel of the slice (a half rounds up), so both fractions are 0.
// Changed in step 38: the fractions kept, for bilinear samples; rounded only when nearest.
static SliceShift slice_shift(const Shear& shear, int m, bool nearest) {
    SliceShift s;
    s.slice = shear.first_slice + m * shear.slice_step;
    auto split = [&](double position, int count, int* low, float* fraction, int* last) {
        *low = int(std::floor(position));
        double past = position - *low;
        if (nearest) {
            if (past >= 0.5) ++*low;
            past = 0;
        }
        *fraction = float(past);
        *last = *fraction == 0.0f ? count - 1 : count - 2;
    };
    split(shear.base_a + m * shear.delta_a, shear.na, &s.ia, &s.fa, &s.last_a);
    split(shear.base_b + m * shear.delta_b, shear.nb, &s.ib, &s.fb, &s.last_b);
    s.da = s.fa == 0.0f ? 0 : shear.stride_a;
    s.db = s.fb == 0.0f ? 0 : shear.stride_b;
    return s;
}

// A sample in a slice: bilinear in its cell (p: the low corner's value), step 30's trilinear
// with the fraction along c at 0, in the same order: the same float.
static inline float slice_value(const int16_t* p, const SliceShift& s) {
    return lerp(lerp(p[0], p[s.da], s.fa), lerp(p[s.db], p[s.da + s.db], s.fa), s.fb);
}
//< lesson: slices

// Given: voxel (i, j, k)'s normal index. A voxel with all six neighbours takes its central
// differences straight from the voxels (step 10's gradient_at() without its edge cases; the
// direction is all that is kept); one on the volume's faces calls gradient_at().
static uint16_t voxel_normal(const Volume& volume, const Voxel& voxel) {
    const int i = voxel.i, j = voxel.j, k = voxel.k;
    if (i > 0 && j > 0 && k > 0 && i < volume.nx - 1 && j < volume.ny - 1 &&
        k < volume.nz - 1) {
        const ptrdiff_t step_j = volume.nx, step_k = ptrdiff_t(volume.nx) * volume.ny;
        const int16_t* p = &volume.data[volume.index(i, j, k)];
        return normal_index({float(p[1] - p[-1]) * float(0.5 / volume.sx),
                             float(p[step_j] - p[-step_j]) * float(0.5 / volume.sy),
                             float(p[step_k] - p[-step_k]) * float(0.5 / volume.sz)});
    }
    Work uncounted;
    return normal_index(gradient_at(volume, voxel, uncounted));
}

//> lesson: records
// VolPack's run-length-encoded volume, one slice at a time: the records of slice c's runs
// (counts: its rows' numbers of runs, bounds: their begin and end), run after run. Column a's
// record holds the values at (a, b) and (a, b + 1) and, for a lit composite, their normal
// indices (changed in step 44: from the slice's normals[b * na + a]). The last column and row
// count again at the slice's edges.
static void pack_slice(const Volume& volume, const Shear& shear, int c, const uint32_t* counts,
                       const int32_t* bounds, const uint16_t* normals, bool lit,
                       Records& records) {
    const int na = shear.na, nb = shear.nb;
    size_t columns = 0;  // the records it writes
    const int32_t* run = bounds;
    for (int b = 0; b < nb; ++b) {
        for (uint32_t r = 0; r < counts[b]; ++r, run += 2) {
            columns += size_t(run[1] - run[0]) + 1;
        }
    }
    const std::vector<uint16_t> none(lit ? 0 : na, 0);  // unlit: every normal index 0
    const size_t sa = shear.stride_a;
    records.reset(new Record[columns]);  // left unset: every record is written below
    Record* out = records.get();
    run = bounds;
    for (int b = 0; b < nb; ++b) {
        const int below = std::min(b + 1, nb - 1);  // the next row, or the last again
        const int16_t* low = &volume.data[c * shear.stride_c + b * shear.stride_b];
        const int16_t* high = &volume.data[c * shear.stride_c + below * shear.stride_b];
        const uint16_t* low_normals = lit ? &normals[size_t(b) * na] : none.data();
        const uint16_t* high_normals = lit ? &normals[size_t(below) * na] : none.data();
        for (uint32_t r = 0; r < counts[b]; ++r, run += 2) {
            for (int a = run[0]; a <= run[1]; ++a, ++out) {
                const int column = std::min(a, na - 1);  // past the end: the last
                *out = {low[column * sa], high[column * sa], low_normals[column],
                        high_normals[column]};
            }
        }
    }
}
//< lesson: records

//> lesson: runs
// Classification, once per transfer function and principal axis: the cells of every slice row
// that the table may see. A bilinear value lies between its cell's lowest and highest corner
// (the last voxel counts again at an edge), so a cell whose four corners all lie in one
// stretch of transparent table entries is transparent wherever a sample falls in it: it is
// left out. Slices are shared among the threads.
static Runs find_runs(const Volume& volume, const Shear& shear, const Lut& lut, int threads) {
    std::vector<int32_t> stretch(lut.entries.size());  // per table entry
    int32_t seen = 0;                                    // entries seen so far
    for (size_t n = 0; n < stretch.size(); ++n) {
        if (lut.entries[n].a > 0.0f) {
            stretch[n] = -1;
            ++seen;
        } else {
            stretch[n] = seen;  // the same for every entry up to the next one seen
        }
    }
    // A range of values [low, high] is transparent when the table sees none of its entries.
    auto clear = [&](int low, int high) {
        const int32_t first = stretch[low - lowest_ct_value];
        return first >= 0 && first == stretch[high - lowest_ct_value];
    };
    const int na = shear.na, nb = shear.nb;
    const size_t sa = shear.stride_a;
    std::vector<std::vector<int32_t>> bounds(shear.nc);  // per slice, its runs
    std::vector<std::vector<uint32_t>> counts(shear.nc);  // per slice, runs per row
    Work unused;
    parallel_rows(shear.nc, threads, unused, [&](int c, Work&) {
        counts[c].assign(nb, 0);
        for (int b = 0; b < nb; ++b) {
            const int16_t* low = &volume.data[c * shear.stride_c + b * shear.stride_b];
            const int16_t* high = &volume.data[c * shear.stride_c +
                                               std::min(b + 1, nb - 1) * shear.stride_b];
            int begin = -1;  // the run being read; -1: none
            auto run_ends = [&](int a) {
                if (begin < 0) return;
                bounds[c].insert(bounds[c].end(), {begin, a});
                ++counts[c][b];
                begin = -1;
            };
            // Given: cell_stretch cells at a time, each cell's lowest and highest corner and
            // the stretch's (common/object_order.h): a stretch of air is clear as a whole.
            CellStretch cells;
            for (int from = 0; from < na; from += cell_stretch) {
                cells.read(low, high, sa, na, from);
                if (clear(cells.lowest, cells.highest)) {
                    run_ends(from);
                    continue;
                }
                for (int n = 0; n < cells.count; ++n) {  // cell by cell
                    if (clear(cells.low[n], cells.high[n])) {
                        run_ends(from + n);
                    } else if (begin < 0) {
                        begin = from + n;
                    }
                }
            }
            run_ends(na);
        }
    });
    Runs runs = join_runs<Runs>(shear.c, nb, counts, bounds);  // given: common/object_order.h
    return runs;
}
//< lesson: runs

// Given: the normal index of every voxel a lit sample can read (each run's voxels and one
// more, on its row and the next), marked first so each is computed once; a slice per thread.
// Changed in step 44: into an array of the slice's, then the slice's records (pack_slice());
// at the end each run's first record (find_starts(), common/object_order.h).
static void pack_records(const Volume& volume, const Shear& shear, bool lit, int threads,
                         Runs& runs) {
    runs.records.resize(shear.nc);
    const int na = shear.na, nb = shear.nb;
    std::vector<size_t> filled(shear.nc, 0);  // per slice: no two threads count in one
    Work unused;
    parallel_rows(shear.nc, threads, unused, [&](int c, Work&) {
        std::vector<uint8_t> needed(lit ? size_t(na) * nb : 0, 0);
        std::unique_ptr<uint16_t[]> normals(new uint16_t[needed.size()]);  // only needed read
        for (int b = 0; lit && b < nb; ++b) {
            int count = 0;
            const int32_t* run = runs.row(c, b, &count);
            for (int r = 0; r < count; ++r) {  // the run's voxels and one more, on both rows
                const int end = std::min(run[2 * r + 1] + 1, na);
                for (const int row : {b, std::min(b + 1, nb - 1)}) {
                    uint8_t* needed_row = &needed[size_t(row) * na];
                    std::fill(needed_row + run[2 * r], needed_row + end, uint8_t(1));
                }
            }
        }
        for (int b = 0; lit && b < nb; ++b) {
            for (int a = 0; a < na; ++a) {
                if (!needed[size_t(b) * na + a]) continue;
                const Voxel voxel = voxel_of(shear, a, b, c);
                normals[size_t(b) * na + a] = voxel_normal(volume, voxel);
                ++filled[c];
            }
        }
        const uint32_t* first = &runs.first[size_t(c) * shear.nb];  // its rows' first runs
        std::vector<uint32_t> counts(shear.nb);
        for (int b = 0; b < shear.nb; ++b) counts[b] = first[b + 1] - first[b];
        pack_slice(volume, shear, c, counts.data(), runs.bounds.data() + 2 * size_t(first[0]),
                   normals.get(), lit, runs.records[c]);
    });
    for (size_t slice : filled) runs.normals += slice;
    find_starts(shear, runs);
}

// Given: a sample's light: its cell's four corners' light from the shading table, blended as
// the values are (VolPack's way: the light is shaded at the voxels, then interpolated; step
// 30 interpolates the gradients, then shades: the same along an axis, where the fractions are
// 0, but for the directions' rounding).
// Changed in step 44: each corner's normal index computed from the voxels (voxel_normal():
// there is no normal volume), record_light()'s float.
static inline float slice_light(const Scene& scene, const SliceShift& s, int a, int b,
                                Work& work) {
    work.gradients += 4;
    const Shear& shear = scene.shear;
    const int step_a = s.da ? 1 : 0, step_b = s.db ? 1 : 0;  // the high corner's offset
    float corner[4];  // corner a + 2b: a, b = 0 or 1 along the slice's axes
    for (int n = 0; n < 4; ++n) {
        const Voxel voxel =
            voxel_of(shear, a + (n & 1) * step_a, b + (n >> 1) * step_b, s.slice);
        corner[n] = scene.shading[voxel_normal(scene.volume, voxel)];
    }
    const float low = lerp(corner[0], corner[1], s.fa), high = lerp(corner[2], corner[3], s.fa);
    return lerp(low, high, s.fb);
}

//> lesson: composite
// Step 10's compositing along the camera's ray: samples at t_entry + n * step until t_exit,
// each read by trilinear interpolation, classified by the table, lit where it is not
// transparent, composited front to back; early ray termination as in step 08.
// The bench's cases a, b and c (part 2's leaping comes back as step 31's trick).
static Accumulated composite_ray(const Scene& scene, int x, int y, Work& work, Trace* trace) {
    const Volume& volume = scene.volume;
    const Params& params = scene.params;
    const double stop_below = std::max(params.ert, min_transparency);
    const Vec3d high = box_high(volume);
    const Ray ray = camera_ray(scene.camera, x, y);
    const Span span = intersect_box(ray, Vec3d{}, high);
    trace_ray(trace, ray, span, high, params.step);
    Accumulated pixel;
    if (!span.hit) return pixel;
    const Walk walk = walk_through(volume, ray, span, params.step);
    for (long long n = 0; n < walk.count; ++n) {
        const Vec3d q = walk.at(n);  // voxel units
        const Cell cell = cell_at(volume, q, params.nearest);
        const double t = span.t_entry + n * params.step;  // physical units along the ray
        const float value = sample_value(volume, cell, params.nearest);
        // The entry of the whole value at or below it (the range [from, to) it falls into):
        // value - lowest_ct_value >= 0, so int() rounds down.
        const Rgba& sample = scene.lut.entries[int(double(value) - lowest_ct_value)];
        ++work.samples;
        const Vec3d point = Vec3d{q.i * volume.sx, q.j * volume.sy, q.k * volume.sz};
        if (sample.a == 0.0f) {
            ++work.skipped;
            if (trace) trace->sample(TraceSample(t, point, value).skipped());
            continue;
        }
        double light = 1.0;  // unlit
        if (!params.unlit) {
            light = shade(sample_gradient(volume, cell, params.nearest, work), scene.to_light);
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
        if (pixel.transparency < stop_below && n + 1 < walk.count) {
            ++work.terminated;
            if (trace) trace->stop(pixel.transparency, stop_below, walk.count - 1 - n);
            break;
        }
    }
    return pixel;
}

// Step 30's compositing of one sample, in double (step 07): colour weighted by opacity, light
// and T; T multiplied by what the sample lets through.
static inline void add_sample(Accumulated& pixel, const Rgba& sample, double light) {
    const double alpha = sample.a;
    const double weight = pixel.transparency * alpha * light;
    pixel.r += weight * sample.r;
    pixel.g += weight * sample.g;
    pixel.b += weight * sample.b;
    pixel.transparency *= 1 - alpha;
}

// Row v of the intermediate image, slice by slice front to back. In each slice the row meets
// one row of cells, and only the cells in its runs are read; the pixels they fall on are
// composited unless already opaque. An opaque pixel is jumped over: next[u] leads to a pixel
// at or after u that is not opaque (each lookup shortens the path it followed), so the opaque
// stretch of a row costs a jump or two per run however wide it is.
// Changed in step 43: a sample reads its cell's record and the next one's, not the volume.
static void composite_row(const Scene& scene, int v, Accumulated* row, Work& work) {
    const Shear& shear = scene.shear;
    const bool unlit = scene.params.unlit;
    const double stop_below = std::max(scene.params.ert, min_transparency);
    const Rgba* lut = scene.lut.entries.data();
    std::vector<int> next(size_t(shear.width) + 1);
    for (int u = 0; u <= shear.width; ++u) next[u] = u;  // next[width]: the end
    auto open_from = [&](int u) {  // the first pixel at or after u that is not opaque
        while (next[u] != u) {
            next[u] = next[next[u]];
            u = next[u];
        }
        return u;
    };
    int open = shear.width;  // pixels not yet opaque
    // Speed: the counters and the slice's shift are local copies. The loop stores to the row
    // and to next[]; through a reference the compiler would read them again after each store.
    Work counted;
    for (const SliceShift& shift : scene.shifts) {
        const SliceShift s = shift;
        const int b = v + s.ib;  // the row of cells this image row meets
        if (b < 0 || b > s.last_b) continue;
        const bool on_voxels = s.fa == 0.0f && s.fb == 0.0f;  // every sample one voxel's value
        // The pixels whose cell lies in the slice.
        const int u_low = std::max(0, -s.ia), u_high = std::min(shear.width, s.last_a + 1 - s.ia);
        if (u_low >= u_high) continue;
        int count = 0;  // the row's runs of cells the table may see, and how many
        const int32_t* run = scene.runs.row(s.slice, b, &count);
        if (scene.runs.start.empty()) count = 0;  // no records (a kit before pack_slice())
        long long in_runs = 0;
        for (int r = 0; r < count && open > 0; ++r) {
            const int from = std::max(u_low, run[2 * r] - s.ia);
            const int to = std::min(u_high, run[2 * r + 1] - s.ia);
            if (from >= to) continue;
            in_runs += to - from;
            const Record* records = scene.runs.records_of(run + 2 * r);  // column run[2r]'s
            for (int u = open_from(from); u < to; u = open_from(u + 1)) {
                const Record* p = records + (u + s.ia - run[2 * r]);  // the cell's low corner
                // On the voxels (along an axis) the value is the record's, a whole number: its
                // table entry without the blend and the conversions (the same entry).
                const int entry =
                    on_voxels ? p->low - lowest_ct_value
                              : int(double(lerp(lerp(p[0].low, p[1].low, s.fa),
                                                lerp(p[0].high, p[1].high, s.fa), s.fb)) -
                                    lowest_ct_value);
                const Rgba& sample = lut[entry];
                ++counted.samples;
                if (sample.a == 0.0f) {
                    ++counted.skipped;
                    continue;
                }
                double light = 1.0;  // unlit
                if (!unlit) {
                    counted.gradients += 4;
                    light = on_voxels ? scene.shading[p->low_normal]
                                      : record_light(scene.shading, p, s);
                }
                add_sample(row[u], sample, light);
                if (row[u].transparency < stop_below) {
                    ++counted.terminated;
                    next[u] = u + 1;
                    --open;
                }
            }
        }
        counted.leapt += (u_high - u_low) - in_runs;  // transparent cells: never read
        if (open == 0) break;  // the whole row is opaque
    }
    work.add(counted);
}
//< lesson: composite

//> lesson: mip
// Case d: step 18's maximum intensity along the same samples, from the first sample (CT
// values go below 0), shown as grey; a ray that misses the box shows the background.
// Changed in step 30: a free ray from the orbit camera, not step 01's ray along an axis.
static Rgb mip_ray(const Scene& scene, int x, int y, Work& work, Trace* trace) {
    const Volume& volume = scene.volume;
    const Params& params = scene.params;
    const Vec3d high = box_high(volume);
    const Ray ray = camera_ray(scene.camera, x, y);
    const Span span = intersect_box(ray, Vec3d{}, high);
    trace_ray(trace, ray, span, high, params.step);
    if (!span.hit) return background;
    const Walk walk = walk_through(volume, ray, span, params.step);
    float highest = 0;
    for (long long n = 0; n < walk.count; ++n) {
        const Vec3d q = walk.at(n);  // voxel units
        const float value = sample_value(volume, cell_at(volume, q, params.nearest),
                                         params.nearest);
        ++work.samples;
        highest = n == 0 ? value : std::max(highest, value);
        if (trace) {
            const Vec3d p = {q.i * volume.sx, q.j * volume.sy, q.k * volume.sz};
            trace->sample(TraceSample(span.t_entry + n * params.step, p, value).max(highest));
        }
    }
    return grey(display_grey(volume, highest));
}

// Row v of the maximum intensity: every cell the row meets in every slice, each pixel keeping
// its highest sample. -infinity: none yet.
// A row of cells contiguous in memory goes first through max_in_stretches() (given: vector
// instructions, the same floats as slice_value()).
// Changed in step 38: each slice shifted, a sample bilinear in its cell.
static void mip_row(const Scene& scene, int v, float* highest, Work& work) {
    const Shear& shear = scene.shear;
    for (const SliceShift& s : scene.shifts) {
        const int b = v + s.ib;
        if (b < 0 || b > s.last_b) continue;
        const size_t row_index = s.slice * shear.stride_c + b * shear.stride_b;
        const int16_t* slice_row = &scene.volume.data[row_index];
        const int u_low = std::max(0, -s.ia);
        const int u_high = std::min(shear.width, s.last_a + 1 - s.ia);
        int u = u_low;
        if (shear.stride_a == 1) {  // a row of cells contiguous in memory: stretches at a time
            u = max_in_stretches(highest, u, u_high, slice_row + s.ia, s.da, s.db, s.fa, s.fb);
        }
        for (; u < u_high; ++u) {
            const float value = slice_value(slice_row + size_t(u + s.ia) * shear.stride_a, s);
            highest[u] = std::max(highest[u], value);
        }
        if (u_high > u_low) work.samples += u_high - u_low;
    }
}
//< lesson: mip

static Rgb mix_rgb(const Rgb& p, const Rgb& q, float f) {
    return {lerp(p.r, q.r, f), lerp(p.g, q.g, f), lerp(p.b, q.b, f)};
}

// Given: the warp's affine map (common/object_order.h), from the camera's rays.
// Changed in step 37: the shear's base offsets (0 along an axis).
static WarpMap make_warp(const Volume& volume, const Shear& shear, const Camera& camera) {
    auto ray = [&](int x, int y) { return camera_ray(camera, x, y); };
    return slice_warp(volume, shear, shear.base_a, shear.base_b, ray);
}

//> lesson: warp
// The output pixel: the intermediate image read bilinearly at the warp's point; past its edge
// it is the background (no ray there meets the volume). pixel(u, v) gives a pixel inside.
template <class Pixel>
static Rgb warp_pixel(const WarpPoint& p, int width, int height, Pixel pixel) {
    const double low_u = std::floor(p.u), low_v = std::floor(p.v);
    if (!(low_u >= -1 && low_u < width && low_v >= -1 && low_v < height)) return background;
    const int u = int(low_u), v = int(low_v);
    const float fu = float(p.u - low_u), fv = float(p.v - low_v);
    auto at = [&](int pu, int pv) {
        return pu >= 0 && pu < width && pv >= 0 && pv < height ? pixel(pu, pv) : background;
    };
    return mix_rgb(mix_rgb(at(u, v), at(u + 1, v), fu), mix_rgb(at(u, v + 1), at(u + 1, v + 1), fu),
                   fv);
}
//< lesson: warp

// Given: warp_pixel() as a value, for the loops of common/object_order.h.
constexpr auto blend = [](const WarpPoint& p, int width, int height, auto pixel) {
    return warp_pixel(p, width, height, pixel);
};

// An intermediate pixel's colour: its composite over the background, or its maximum's grey
// (no sample: the background).
static Rgb composite_colour(const Accumulated& pixel) { return over_background(pixel); }
static Rgb mip_colour(const Volume& volume, float highest) {
    if (highest == -std::numeric_limits<float>::infinity()) return background;
    return grey(display_grey(volume, highest));
}

// Output pixel (x, y) alone (the trace, the ray panel): the four intermediate pixels around its
// warp point, each alone as the rows take it, blended by the warp: the image's pixel exactly.
// Changed in step 44: slice_light() computes the corners' normal indices (no normal volume).
static Rgb shear_warp_pixel(const Scene& scene, int x, int y, Work& work, Trace* trace) {
    const Volume& volume = scene.volume;
    const Shear& shear = scene.shear;
    const Ray ray = camera_ray(scene.camera, x, y);
    const Vec3d high = box_high(volume);
    trace_ray(trace, ray, intersect_box(ray, Vec3d{}, high), high, shear.spacing);
    const double stop_below = std::max(scene.params.ert, min_transparency);
    auto column = [&](int u, int v, auto at) {  // intermediate pixel (u, v) alone, traced
        if (scene.params.mode == "mip") {
            return mip_colour(volume, maximum_column(shear.nc, ray, work, trace, at));
        }
        auto light = [&](int m) {
            const SliceShift& s = scene.shifts[m];
            return scene.params.unlit ? 1.0 : slice_light(scene, s, u + s.ia, v + s.ib, work);
        };
        auto add = [](Accumulated& pixel, const Rgba& sample, double light_of_sample) {
            add_sample(pixel, sample, light_of_sample);
        };
        return composite_colour(composite_column<Accumulated>(
            shear.nc, scene.lut.entries.data(), stop_below, ray, work, trace, at, light, add));
    };
    const WarpMap warp = make_warp(volume, shear, scene.camera);
    return shifted_pixel_traced(volume, shear, scene.shifts, warp, x, y, trace, column, blend,
                                slice_value, &scene.runs);  // common/object_order.h
}

int main(int argc, char** argv) {
    return guarded_main(step_name, [&] {
        // --- Options: the shared flags plus this step's own ---
        Params params;
        Args args(step_name, "The shear: the slices, shifted, composited into the image.");
        args.add_choice("--mode", &params.mode, {"composite", "mip"},
                        "composite through the transfer function, or the maximum intensity");
        args.add_string("--tf", &params.tf_path,
                        "transfer function file (default data/tf/classic.tf)");
        args.add_double("--skin-opacity", &params.skin_opacity, 0, 1,
                        "opacity of the range labelled skin (default: as the file says)");
        args.add_double("--ert", &params.ert, 0, 1,
                        "stop a ray once its transparency T is below this (0: never)");
        args.add_double("--step", &params.step, min_step, max_step,
                        "physical units between two samples along a ray (slices: one each)");
        args.add_double("--light-angle", &params.light_angle, -180, 180,
                        "light direction, degrees to the right of the camera");
        args.add_switch("--unlit", &params.unlit, "no lighting: L = 1, as in step 08");
        args.add_switch("--no-correction", &params.no_correction,
                        "use the TF opacities unchanged, whatever the step");
        args.add_choice("--interpolation", &params.interpolation, {"trilinear", "nearest"},
                        "a sample in its slice: the four voxels around it, or the nearest one");
        add_camera_flags(args, &params);  // common/camera_flags.h
        const Options options = args.parse(argc, argv);
        params.nearest = params.interpolation == "nearest";
        const View camera_image = camera_view(options, params);  // --size; no --view
        refuse_object_order_flags(options, params);  // --work-map

        // --- Volume ---
        const Volume volume = load_volume(options);
        const std::string refused = too_many_samples_along_box(volume, params.step);
        if (!refused.empty()) throw InputError(refused);

        // --- Transfer function: the file (in the file's units), its table for this step size ---
        TransferFunction tf = load_transfer_function(params.tf_path, volume.map);
        if (params.skin_opacity >= 0) {
            set_opacity(tf, skin_label, params.skin_opacity, "--skin-opacity");
        }
        const Lut seen = build_lut(tf, 1.0);  // the runs need only which opacities are not 0
        Lut lut = build_lut(tf, opacity_ratio(params, params.step));
        Lut slice_lut = seen;   // the slices': opacities for their spacing, made once per view
        std::vector<SliceShift> shifts;  // the slices' shifts, made for each render
        std::vector<float> shading;  // lit with normals: the light per normal index
        double lut_ratio = 1;   // the ratio slice_lut was made for: seen's to begin with

        // --- Once per transfer function and principal axis, made by the first render that
        // needs it (so the first render's time_ms= includes it, and precompute_ms= says how
        // much): the runs of cells the table may see, and for a lit composite the normal
        // indices of their corners (the directions' set once per process). Per view, in
        // scene_for() below: the table's opacities for the slices' spacing; for a lit
        // composite, the shading table ---
        Runs runs[3];  // per principal axis
        std::vector<Vec3> directions;  // per normal index, made with the first table
        const bool lit = params.mode == "composite" && !params.unlit;
        double precompute_ms = 0;  // wall clock, this process
        auto prepare = [&](const Shear& shear) {
            if (params.mode == "mip") return;  // no runs: a maximum has no transparent values
            if (runs[shear.c].axis >= 0) return;
            Runs& made = runs[shear.c];  // and its "precompute" line (common/object_order.h)
            auto make = [&] {
                runs[shear.c] = find_runs(volume, shear, seen, options.threads);
                if (lit && directions.empty()) directions = normal_directions();
                pack_records(volume, shear, lit, options.threads, runs[shear.c]);
            };
            precompute_ms += timed_precompute(shear.c, make, [&] {
                char normals_held[80];
                std::snprintf(normals_held, sizeof normals_held,
                              " normal_voxels=%zu", made.normals);
                char records_held[80];
                std::snprintf(records_held, sizeof records_held, " records=%zu records_mb=%.2f",
                              made.record_count, made.record_count * sizeof(Record) / 1048576.0);
                return runs_held(made, volume.voxel_count()) + normals_held + records_held;
            });
        };

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
            const Scene scene{volume, camera, {}, {}, {}, lut, {}, to_light, params};  // no slices
            if (params.mode == "mip") return mip_ray(scene, x, y, work, trace);
            return over_background(composite_ray(scene, x, y, work, trace));
        };
        auto camera_for = [&](const View& view) { return make_camera(volume, params, view); };
        cast_camera_rays(renderer, options.threads, params.step, camera_for, light_towards,
                         pixel);  // common/camera_flags.h: renderer.image, .ray, .ray_samples
        renderer.knob = {"step",
                         [&](const View&, int steps) {
                             const double step = std::clamp(
                                 params.step * std::pow(step_key_factor, steps), min_step,
                                 max_step);
                             if (!too_many_samples_along_box(volume, step).empty()) return;
                             params.step = step;
                             lut = build_lut(tf, opacity_ratio(params, params.step));
                         },
                         [&] { return summary_number(params.step); }};
        renderer.orbit = camera_orbit(&params);  // the window's drag and wheel

        renderer.settings = [&] {
            const TfRange* skin = find_range(tf, skin_label);
            return "mode=" + params.mode + " tf=" + tf.source +
                   " skin_opacity=" + (skin ? summary_number(skin->start.a) : std::string("none")) +
                   " ert=" + summary_number(params.ert) +
                   " light_angle=" + std::to_string(int(std::lround(params.light_angle))) +
                   " lighting=" + (params.unlit ? "off" : "on") +
                   " correction=" + (params.no_correction ? "off" : "on") +
                   camera_settings(params) + " interpolation=" + params.interpolation +
                   " opacity_ratio=" + summary_number(by_rays(camera_for(camera_image))
                                                          ? opacity_ratio(params, params.step)
                                                          : lut_ratio) +
                   " precompute_ms=" + summary_number(precompute_ms);
        };

        // --- Object order, any angle: the slices into the intermediate image, rows shared
        // by the threads, then the warp; every other view is step 30's rays ---
        Renderer rays = renderer;  // step 30's, for the views by_rays() gives it
        auto rays_take = [&](const Camera& c) { return by_rays(c); };
        auto shear_for = [&](const Camera& camera) { return make_shear(volume, camera); };
        auto scene_for = [&](const Camera& camera, const Shear& shear) {
            const double ratio = opacity_ratio(params, shear.spacing);
            if (ratio != lut_ratio) {
                slice_lut = build_lut(tf, ratio);
                lut_ratio = ratio;
            }
            shifts.clear();  // the view's slices' shifts, made with its scene
            for (int m = 0; m < shear.nc; ++m) {
                shifts.push_back(slice_shift(shear, m, params.nearest));
            }
            prepare(shear);
            if (lit) {
                make_shading_table(directions, light_towards(camera), options.threads, shading);
            }
            return Scene{volume, camera, shear, shifts, runs[shear.c], slice_lut,
                         shading.data(), light_towards(camera), params};
        };
        auto slices = [&](const View& view, const Scene& scene, Work& work) {
            const Shear& shear = scene.shear;
            const Image intermediate =  // rows to the threads
                params.mode == "mip"
                    ? intermediate_image(scene, shear.width, shear.height, options.threads, work,
                                         -std::numeric_limits<float>::infinity(), mip_row,
                                         [&](float h) { return mip_colour(volume, h); })
                    : intermediate_image(scene, shear.width, shear.height, options.threads, work,
                                         Accumulated{}, composite_row, composite_colour);
            auto mix = [](const Rgb& p, const Rgb& q, float f) { return mix_rgb(p, q, f); };
            return warp_intermediate(view, options.threads, work,
                                     make_warp(volume, shear, scene.camera), intermediate, blend,
                                     mix);
        };
        slices_or_rays(renderer, rays, camera_for, rays_take, shear_for, scene_for, slices,
                       shear_warp_pixel);  // common/object_order.h: .image, .ray, .ray_samples

        // --- Output: a PNG and a summary line, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
