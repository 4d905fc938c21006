// 16_jitter.cpp: the wood-grain rings of a fixed sample grid, turned into noise by jitter.
//
// New here:   every ray of step 15 samples at the same distances from where it enters the box,
//             so a surface at a slowly changing depth shows rings. Here each pixel moves its
//             first sample by u * step, u in [0, 1) its own, from a hash of the pixel (white
//             noise: --jitter hash, a PCG hash); --jitter none is step 15. --show-jitter draws
//             the offsets u themselves as grey. Step 17 spreads the offsets more evenly.
// Builds on:  15_trilinear (the orbit camera, the slab method, trilinear samples, lit front to
//             back).
// Handout:    handouts/16_jitter.md
// Run:        make run STEP=16 ARGS="--step 4 --jitter none"
// Reference:  data/reference/16_jitter_camera.png: the default run (hash jitter, azimuth 30,
//             elevation 20, orthographic, 512x512), on the phantom.
#include "common/ctlab.h"
using namespace ctlab;

constexpr const char* step_name = "16_jitter";
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
// Samples at t_entry + n*step up to t_exit; the last may be this many steps past the exit in
// rounding (a ray 224 units long at step 2 gets 113 samples even when t_exit is 223.99999...).
constexpr double sample_count_slack = 1e-9;

struct Params : CameraFlags {  // --azimuth, --elevation, --zoom, --projection, --fov, --size
    std::string tf_path;       // "": data/tf/classic.tf when present, else the built-in copy
    double skin_opacity = -1;  // 0..1; -1: as the transfer function file says
    double ert = default_ert;  // early ray termination threshold for T
    double step = default_step;  // physical units between samples
    double light_angle = default_light_angle;
    bool unlit = false;          // L = 1 everywhere, no gradients (as step 08)
    bool no_correction = false;  // use the TF opacities as they are, whatever the step
    std::string interpolation = "trilinear";  // how a sample is read: or "nearest"
    bool nearest = false;                     // interpolation == "nearest"
    std::string jitter = "hash";           // "none" or "hash"
    bool show_jitter = false;              // draw the offsets u as grey instead of the volume
};

// The per-pixel offsets of the first sample: none, or by hash.
struct Jitter {
    std::string mode = "none";  // "none" or "hash"
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
static Vec3 light_direction(const Camera& camera, double angle) {
    const float along_x = float(std::sin(angle * degrees) * std::cos(light_elevation * degrees));
    const float along_y = float(-std::sin(light_elevation * degrees));  // image y points down
    const float along_ray = float(-std::cos(angle * degrees) * std::cos(light_elevation * degrees));
    auto axis = [](const Vec3d& a) { return Vec3{float(a.i), float(a.j), float(a.k)}; };
    return along_x * axis(camera.right) + (-along_y) * axis(camera.up) +
           along_ray * axis(camera.forward);
}
//< lesson: shade

//> lesson: hash
// The PCG hash (Jarzynski and Olano, "Hash functions for GPU rendering", 2020): a multiply and
// add as in a PCG random number generator, then a data-dependent shift and a multiply that mix
// every input bit into every output bit. 32 bits in, 32 bits out.
static uint32_t pcg_hash(uint32_t input) {
    const uint32_t state = input * 747796405u + 2891336453u;
    const uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// White noise: pixel (x, y)'s own offset in [0, 1), the same in every run. The row is hashed
// first, so that (x, y) and (y, x) differ. The top 24 bits fill a float's mantissa exactly:
// 0 .. (2^24 - 1) / 2^24, never 1.
static float hash_offset(int x, int y) {
    const uint32_t bits = pcg_hash(uint32_t(x) + pcg_hash(uint32_t(y)));
    return float(bits >> 8) * (1.0f / 16777216.0f);
}
//< lesson: hash

// Pixel (x, y)'s offset u in [0, 1): 0 without jitter.
static float jitter_offset(const Jitter& jitter, int x, int y) {
    if (jitter.mode == "hash") return hash_offset(x, y);
    return 0.0f;
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

//> lesson: front_to_back
// The walk moved by the pixel's offset: sample n at t_entry + (u + n) * step until t_exit.
// A ray shorter than its offset gets no sample: it only grazes the box. With u = 0 this is
// the walk unchanged, bit for bit (step 15's samples).
static Walk jittered(Walk walk, const Span& span, double step, float u) {
    const double offset = u * step;  // physical units from the entry to the first sample
    const double length_inside = span.t_exit - span.t_entry;
    walk.first = walk.first + double(u) * walk.per_step;
    walk.count = length_inside < offset
                     ? 0
                     : (long long)(std::floor((length_inside - offset) / step +
                                              sample_count_slack)) + 1;
    return walk;
}

// Step 15's compositing, its samples moved by the pixel's offset u in [0, 1) from the jitter
// (0: step 15's samples exactly): read by trilinear interpolation, classified by the table,
// lit where it is not transparent, composited front to back; early ray termination as in
// step 08.
// Changed in step 16: the samples move by the pixel's jitter.
static Accumulated composite_front_to_back(const Volume& volume,
                                           const Camera& camera, int x, int y,
                                           const Lut& lut, Vec3 to_light, const Params& params,
                                           const Jitter& jitter, Work& work, Trace* trace) {
    const double stop_below = std::max(params.ert, min_transparency);
    const Vec3d high = box_high(volume);
    const Ray ray = camera_ray(camera, x, y);
    const Span span = intersect_box(ray, Vec3d{}, high);
    trace_ray(trace, ray, span, high, params.step);
    Accumulated pixel;
    if (!span.hit) return pixel;
    const float u = jitter_offset(jitter, x, y);
    const double t_first = span.t_entry + u * params.step;  // the first sample's t
    if (trace) trace->jitter(jitter.mode, u, t_first - span.t_entry);
    const Walk walk = jittered(walk_through(volume, ray, span, params.step), span, params.step,
                               u);
    for (long long n = 0; n < walk.count; ++n) {
        const Vec3d q = walk.at(n);  // voxel units
        const Cell cell = cell_at(volume, q, params.nearest);
        const double t = t_first + n * params.step;  // physical units along the ray
        const float value = sample_value(volume, cell, params.nearest);
        // The entry of the whole value at or below it (the range [from, to) it falls into):
        // value - lowest_ct_value >= 0, so int() rounds down.
        const Rgba& sample = lut.entries[int(double(value) - lowest_ct_value)];
        ++work.samples;
        const Vec3d point = Vec3d{q.i * volume.sx, q.j * volume.sy, q.k * volume.sz};
        if (sample.a == 0.0f) {
            ++work.skipped;
            if (trace) trace->sample(TraceSample(t, point, value).skipped());
            continue;
        }
        double light = 1.0;  // unlit
        if (!params.unlit) {
            light = shade(sample_gradient(volume, cell, params.nearest, work), to_light);
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
        Args args(step_name, "Step 15's orbit camera with each pixel's first sample moved by a "
                             "random fraction of the step: rings become noise.");
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
        args.add_choice("--interpolation", &params.interpolation, {"trilinear", "nearest"},
                        "a sample's value: the eight voxels around it, or the nearest one");
        args.add_choice("--jitter", &params.jitter, {"none", "hash"},
                        "the first sample's offset per pixel: none, or a hash of the pixel");
        args.add_switch("--show-jitter", &params.show_jitter,
                        "draw each pixel's offset u (0..1) as grey instead of the volume");
        add_camera_flags(args, &params);  // common/camera_flags.h
        const Options options = args.parse(argc, argv);
        params.nearest = params.interpolation == "nearest";
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
        // it, and previews at coarser pixels while it does), and each pixel's jitter ---
        Renderer renderer;
        renderer.transfer_function = &tf;  // the ray picture draws its ranges
        renderer.views = {camera_image};
        Jitter jitter;
        jitter.mode = params.jitter;

        // --- Light: towards it from every ray of a render (it turns with the camera), so
        // worked out once per render, as step 10 does once per view; none with --unlit ---
        auto light_towards = [&](const Camera& camera) {
            return params.unlit ? Vec3{} : light_direction(camera, params.light_angle);
        };

        // --- Render: one ray per pixel ---
        auto pixel = [&](const Camera& camera, Vec3 to_light, int x, int y, Work& work,
                         Trace* trace) {
            if (params.show_jitter) {  // the offset itself, no ray: the trace says so
                const double u = jitter_offset(jitter, x, y);
                if (trace) {
                    trace->note({{"u", u}}, "shows the jitter offset u=%.6f (--show-jitter): "
                                "no ray is cast", u);
                }
                return grey(u);
            }
            return over_background(composite_front_to_back(volume, camera, x, y, lut, to_light,
                                                           params, jitter, work, trace));
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
                   camera_settings(params) + " interpolation=" + params.interpolation +
                   " jitter=" + params.jitter +
                   (params.show_jitter ? " show_jitter=on" : "");
        };

        // --- Output: a PNG and a summary line, then the preview window ---
        return run_views(options, volume, renderer);
    });
}
