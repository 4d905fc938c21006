// phantom.cpp: the built-in CT head, painted from ellipsoids and elliptic cylinders.
//
// The anatomy lives in a fixed physical box of 256 x 256 x 226 mm (CThead's 256 x 256 x 113
// voxels at 1:1:2): x across the head (i), y from the face backwards (j), z from the crown
// down (k). Every voxel is sampled at its centre. Shapes are painted in order, later over
// earlier, one image row (fixed j, k) at a time: for each shape the row's inside is one
// interval of x, found with one square root. Edges are blurred like a scanner's partial
// volume: near a shape's surface it covers a voxel only partly, and the voxel's value is
// blended accordingly (see edge_half_width). Then a small hash noise is added. The whole
// head takes about 0.23 s on one core of the lab's VM, 0.12 s on two (make_phantom(threads)).
// handouts/phantom.md lists every structure with its value and where it is.
#include "phantom.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>
#include "error.h"
#include "render.h"
#include "vec3.h"

namespace ctlab {
namespace {

// The physical box the head is drawn in, in mm.
constexpr double box_x = 256, box_y = 256, box_z = 226;

enum Tissue : uint8_t {
    air, sinus_air, airway, fat, soft, cord, grey_matter, white_matter, csf, eye,
    disc, head_rest, cortical, diploe, face_bone, vertebra, tooth, filling, tissue_count
};

struct TissueValue {
    int value;     // CT value (HU-like)
    int noise;     // the hash noise adds a whole number in [-noise, +noise]
};

// Chosen so that noise never carries the inside of a tissue across a transfer-function
// boundary (-300, 50, 300, 400); edges blend between neighbours (handouts/phantom.md).
constexpr TissueValue tissue_values[tissue_count] = {
    {-1000, 20}, // air
    {-900, 20},  // sinus_air: maxillary and frontal sinuses
    {-950, 20},  // airway: nose, nasal cavity, pharynx
    {-90, 10},   // fat: behind the eyes
    {25, 10},    // soft: skin, muscle, cartilage
    {28, 6},     // cord: spinal cord
    {36, 6},     // grey_matter: cortex
    {28, 6},     // white_matter
    {10, 4},     // csf: ventricles, the fluid around the brain
    {15, 4},     // eye: vitreous
    {75, 10},    // disc: intervertebral discs (transparent in the classic TF)
    {200, 10},   // head_rest: plastic (transparent in the classic TF, seen in MIP)
    {1700, 30},   // cortical: outer and inner skull tables, mandible
    {900, 30},    // diploe: spongy bone between the skull tables
    {1200, 30},   // face_bone: maxilla, zygoma, nasal septum, frontal bone
    {700, 30},    // vertebra: cervical spine
    {1900, 30},   // tooth: enamel
    {2248, 0},   // filling: amalgam, the volume maximum (CThead's too)
};

Vec3 normalized(Vec3 a) { return (1 / length(a)) * a; }

// The inside of a quadric, (p - c)^T m (p - c) <= 1, cut to a box and to at most two
// half-spaces (normal . p <= offset), painted only over `over` unless that is any_tissue.
constexpr int max_planes = 2;
constexpr uint8_t any_tissue = 255;

struct Plane {
    Vec3 normal;
    double offset;
};

struct Shape {
    Tissue tissue;
    Vec3 centre;
    double m[3][3];
    Vec3 lo, hi;  // clip box, mm
    float r_min = 0;  // mm: the smallest semi-axis (across, for a cylinder)
    bool sharp = false;  // painted without a blurred edge (see sharp_edged)
    Plane planes[max_planes] = {};
    int plane_count = 0;
    uint8_t over = any_tissue;
};

// An ellipsoid with semi-axes r.i, r.j, r.k along the orthonormal axes u, v, w.
Shape ellipsoid_axes(Tissue tissue, Vec3 centre, Vec3 u, Vec3 v, Vec3 w, Vec3 r) {
    Shape shape{tissue, centre, {}, {}, {}};
    const Vec3 axes[3] = {u, v, w};
    const double radii[3] = {r.i, r.j, r.k};
    double extent[3] = {0, 0, 0};  // squared half-size of the bounding box
    for (int a = 0; a < 3; ++a) {
        const double e[3] = {axes[a].i, axes[a].j, axes[a].k};
        for (int row = 0; row < 3; ++row) {
            for (int col = 0; col < 3; ++col) {
                shape.m[row][col] += e[row] * e[col] / (radii[a] * radii[a]);
            }
            extent[row] += radii[a] * radii[a] * e[row] * e[row];
        }
    }
    const Vec3 half{float(std::sqrt(extent[0])), float(std::sqrt(extent[1])),
                    float(std::sqrt(extent[2]))};
    shape.r_min = std::min({r.i, r.j, r.k});
    shape.lo = centre - half;
    shape.hi = centre + half;
    return shape;
}

// An axis-aligned ellipsoid.
Shape ellipsoid(Tissue tissue, Vec3 centre, Vec3 r) {
    return ellipsoid_axes(tissue, centre, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, r);
}

// An ellipsoid whose long axis runs from end0 to end1; radius r1 along `across` (made
// perpendicular to the long axis), r2 along the third axis.
Shape ellipsoid_between(Tissue tissue, Vec3 end0, Vec3 end1, Vec3 across, float r1,
                        float r2) {
    const Vec3 u = normalized(end1 - end0);
    const Vec3 v = normalized(across - dot(across, u) * u);
    const float half_length = length(end1 - end0) / 2;
    return ellipsoid_axes(tissue, 0.5 * (end0 + end1), u, v, cross(u, v),
                          {half_length, r1, r2});
}

// An elliptic cylinder along z from z0 to z1.
Shape cylinder_z(Tissue tissue, float cx, float cy, float rx, float ry, float z0, float z1) {
    Shape shape{tissue, {cx, cy, 0}, {}, {cx - rx, cy - ry, z0}, {cx + rx, cy + ry, z1}};
    shape.m[0][0] = 1 / (rx * rx);
    shape.m[1][1] = 1 / (ry * ry);
    shape.r_min = std::min(rx, ry);
    return shape;
}

// Cuts the shape to the box [lo, hi] (mm).
Shape clipped(Shape shape, Vec3 lo, Vec3 hi) {
    shape.lo = {std::max(shape.lo.i, lo.i), std::max(shape.lo.j, lo.j),
                std::max(shape.lo.k, lo.k)};
    shape.hi = {std::min(shape.hi.i, hi.i), std::min(shape.hi.j, hi.j),
                std::min(shape.hi.k, hi.k)};
    return shape;
}

// Keeps only the part with normal . p <= offset.
Shape below_plane(Shape shape, Vec3 normal, double offset) {
    shape.planes[shape.plane_count++] = {normal, offset};
    return shape;
}

// Painted with a sharp edge: a voxel is in or out by its centre. Only for the plastic head
// rest: a blurred thin sheet from -1000 to 200 would cross the skin band of the classic
// transfer function and show as a striped skin-coloured film, which the handout promises
// it is not (it is transparent in the classic TF).
Shape sharp_edged(Shape shape) {
    shape.sharp = true;
    return shape;
}

// Paints only over voxels that are already `tissue`.
Shape only_over(Shape shape, Tissue tissue) {
    shape.over = tissue;
    return shape;
}

constexpr float centre_x = box_x / 2;  // the head is symmetric about x = 128 mm
constexpr double huge = 1e9;            // "no limit" for a clip box, mm
constexpr Vec3 no_lo{-huge, -huge, -huge}, no_hi{huge, huge, huge};

// Skull base: the vault keeps z - y/2 <= 64, a plane rising from z = 84 mm at the forehead
// (y = 40) to z = 164 mm at the back (y = 200); the brain stays a floor's thickness above it.
constexpr Vec3 base_normal{0, -0.5, 1};
constexpr double base_offset = 64;  // mm
constexpr double base_floor = 4;    // mm: the bony floor under the brain

// The whole head, in painting order. Mirrored structures come in pairs (side = -1, +1).
std::vector<Shape> head_shapes() {
    std::vector<Shape> s;
    const int sides[2] = {-1, 1};

    // Head rest: a shallow plastic cradle behind the head (the patient lies on the back).
    s.push_back(sharp_edged(clipped(cylinder_z(head_rest, centre_x, 169, 300, 60, 0, box_z),
                                    {24, 200, -huge}, {232, huge, huge})));
    s.push_back(sharp_edged(clipped(cylinder_z(air, centre_x, 169, 297, 57, 0, box_z),
                                    {24, 200, -huge}, {232, huge, huge})));

    // Soft tissue: cranium, neck, lower face, mid face, chin, nose, ears.
    s.push_back(ellipsoid(soft, {centre_x, 128, 100}, {78, 95, 92}));
    s.push_back(cylinder_z(soft, centre_x, 142, 54, 58, 140, box_z));
    s.push_back(ellipsoid(soft, {centre_x, 84, 172}, {60, 54, 52}));
    s.push_back(ellipsoid(soft, {centre_x, 70, 125}, {64, 42, 52}));
    s.push_back(ellipsoid(soft, {centre_x, 48, 196}, {28, 20, 20}));
    s.push_back(ellipsoid_between(soft, {centre_x, 38, 90}, {centre_x, 18, 140}, {1, 0, 0},
                                  10, 10));  // nose: the bridge
    s.push_back(ellipsoid(soft, {centre_x, 24, 138}, {15, 11, 9}));  // nose: the tip
    for (int side : sides) {
        s.push_back(ellipsoid_between(soft, {centre_x + side * 80, 138, 88},
                                      {centre_x + side * 80, 130, 136}, {1, 0, 0}, 5, 15));
        s.push_back(ellipsoid(airway, {centre_x + side * 5, 22, 142}, {3, 7, 3}));  // nostril
    }

    // Skull vault: outer table, diploe, inner table, then the fluid and the brain inside.
    const Vec3 head_centre{centre_x, 128, 100};
    s.push_back(below_plane(ellipsoid(cortical, head_centre, {72, 89, 86}), base_normal,
                            base_offset));
    s.push_back(below_plane(ellipsoid(diploe, head_centre, {68, 85, 82}), base_normal,
                            base_offset));
    s.push_back(below_plane(ellipsoid(cortical, head_centre, {65, 82, 79}), base_normal,
                            base_offset));
    s.push_back(below_plane(ellipsoid(csf, head_centre, {62.5, 79.5, 76.5}), base_normal,
                            base_offset - base_floor));
    s.push_back(below_plane(ellipsoid(grey_matter, head_centre, {60.5, 77.5, 74.5}),
                            base_normal, base_offset - base_floor - 2));
    s.push_back(below_plane(ellipsoid(white_matter, {centre_x, 128, 96}, {50, 66, 58}),
                            base_normal, base_offset - base_floor - 10));
    // The fissure between the hemispheres, cut into the cortex only.
    s.push_back(only_over(ellipsoid(csf, {centre_x, 128, 60}, {1, 90, 60}), grey_matter));
    for (int side : sides) {  // lateral ventricles
        s.push_back(ellipsoid_between(csf, {centre_x + side * 6, 96, 78},
                                      {centre_x + side * 12, 150, 86}, {1, 0, 0}, 5, 9));
    }
    // Frontal bone thickening over the nose, with the frontal sinus inside it.
    s.push_back(ellipsoid(face_bone, {centre_x, 46, 80}, {22, 6, 12}));
    s.push_back(ellipsoid(sinus_air, {centre_x, 46, 80}, {13, 3, 7}));

    // Mid-face: a shell of bone around the maxillary sinuses and the nasal cavity, the hard
    // palate under them, the nasal bones on top.
    s.push_back(ellipsoid(face_bone, {centre_x, 68, 128}, {46, 28, 32}));
    s.push_back(ellipsoid(soft, {centre_x, 70, 130}, {43, 25, 28}));
    s.push_back(clipped(cylinder_z(face_bone, centre_x, 88, 28, 46, 144, 153), no_lo,
                        {huge, 100, huge}));
    for (int side : sides) {
        s.push_back(ellipsoid(sinus_air, {centre_x + side * 20, 68, 134}, {14, 17, 16}));
    }
    s.push_back(ellipsoid(airway, {centre_x, 72, 126}, {7, 33, 22}));  // nasal cavity
    s.push_back(ellipsoid(airway, {centre_x, 41, 130}, {9, 5, 15}));   // its front opening
    s.push_back(ellipsoid(face_bone, {centre_x, 76, 128}, {1.2, 28, 18}));  // septum
    s.push_back(ellipsoid_between(face_bone, {centre_x, 46, 86}, {centre_x, 33, 112},
                                  {1, 0, 0}, 6, 2.5));

    // Orbits (fat) with the eye balls in front, cut out of the bone; the rims around them.
    for (int side : sides) {
        s.push_back(clipped(ellipsoid(fat, {centre_x + side * 32, 64, 104}, {16, 28, 14}),
                            {-huge, 40, -huge}, no_hi));
        s.push_back(ellipsoid(eye, {centre_x + side * 32, 52, 104}, {11, 11, 11}));
        s.push_back(ellipsoid_between(face_bone, {centre_x + side * 49, 66, 86},
                                      {centre_x + side * 46, 64, 118}, {1, 0, 0}, 3, 4));
    }
    // Cheek bones and the zygomatic arches running back to the ears.
    for (int side : sides) {
        s.push_back(ellipsoid(face_bone, {centre_x + side * 42, 62, 120}, {9, 9, 12}));
        s.push_back(ellipsoid_between(face_bone, {centre_x + side * 46, 62, 122},
                                      {centre_x + side * 58, 124, 118}, {1, 0, 0}, 3, 5));
    }

    // Mandible: a U of bone under the lower teeth, its lower border rising from the chin
    // (z = 210 mm) to the angles, and the two rami up to the ears.
    constexpr double chin_z = 210, border_slope = 0.35;  // mm, mm per mm across
    Shape mandible = clipped(cylinder_z(cortical, centre_x, 88, 34, 50, 174, box_z), no_lo,
                             {huge, 96, huge});
    mandible = below_plane(mandible, {border_slope, 0, 1}, chin_z + border_slope * centre_x);
    mandible = below_plane(mandible, {-border_slope, 0, 1}, chin_z - border_slope * centre_x);
    s.push_back(mandible);
    s.push_back(clipped(cylinder_z(soft, centre_x, 90, 26, 41, 160, box_z), no_lo,
                        {huge, 96, huge}));
    for (int side : sides) {
        s.push_back(ellipsoid_between(cortical, {centre_x + side * 33, 98, 200},
                                      {centre_x + side * 46, 124, 124}, {1, 0, 0}, 3, 9));
    }

    // Teeth: fourteen per jaw on an elliptic arch, front teeth at y = 42 mm.
    constexpr int teeth_per_jaw = 14;
    constexpr double arch_rx = 26, arch_ry = 46, arch_cy = 88;  // mm
    constexpr double arch_angle = 1.36;  // rad: last molar, measured from the front
    const double jaw_z[2] = {158, 172};  // mm: upper and lower crowns meet at z = 165
    for (double z : jaw_z) {
        for (int n = 0; n < teeth_per_jaw; ++n) {
            const double angle = arch_angle * (2.0 * n / (teeth_per_jaw - 1) - 1);
            const Vec3 centre{float(centre_x + arch_rx * std::sin(angle)),
                              float(arch_cy - arch_ry * std::cos(angle)), float(z)};
            const Vec3 along{float(arch_rx * std::cos(angle)), float(arch_ry * std::sin(angle)),
                             0};
            const float back = float(std::fabs(angle) / arch_angle);  // 0 front, 1 last molar
            s.push_back(ellipsoid_axes(tooth, centre, normalized(along),
                                       normalized(cross({0, 0, 1}, along)), {0, 0, 1},
                                       {3.6f + 0.8f * back, 2.4f + 2.4f * back, 6}));
        }
    }
    // An amalgam filling on the biting surface of an upper molar (the third tooth, x < 128).
    const double filling_angle = arch_angle * (2.0 * 2 / (teeth_per_jaw - 1) - 1);
    s.push_back(ellipsoid(filling, {float(centre_x + arch_rx * std::sin(filling_angle)),
                                    float(arch_cy - arch_ry * std::cos(filling_angle)), 162},
                          {2.5, 2.5, 4}));

    // Airway: the pharynx behind the mouth, down the neck.
    s.push_back(cylinder_z(airway, centre_x, 112, 11, 6, 132, box_z));

    // Cervical spine: bodies with discs between, the arches behind with the cord inside.
    constexpr double body_y = 140, arch_y = 160;  // mm
    constexpr double spine_top = 154, body_height = 12, disc_height = 4;  // mm
    s.push_back(cylinder_z(disc, centre_x, body_y, 12, 9, spine_top, box_z));
    for (float top = spine_top; top < box_z; top += body_height + disc_height) {
        s.push_back(cylinder_z(vertebra, centre_x, body_y, 13, 10, top, top + body_height));
        s.push_back(cylinder_z(vertebra, centre_x, arch_y, 17, 13, top + 1,
                               top + body_height - 1));
        s.push_back(ellipsoid_between(vertebra, {centre_x, 170, top + 5},
                                      {centre_x, 190, top + 10}, {1, 0, 0}, 4, 3.5));
    }
    s.push_back(cylinder_z(cord, centre_x, arch_y, 9, 7, 120, box_z));
    return s;
}

// A deterministic integer hash of the voxel index: the same noise on every run and machine.
uint32_t hash3(uint32_t i, uint32_t j, uint32_t k) {
    uint32_t h = i * 0x8da6b343u ^ j * 0xd8163841u ^ k * 0xcb1ab31fu;
    h ^= h >> 16;
    h *= 0x7feb352du;
    h ^= h >> 15;
    h *= 0x846ca68bu;
    h ^= h >> 16;
    return h;
}

// Band-limited edges, like a scanner's partial-volume effect: a shape covers a voxel by a
// fraction that rises smoothly (smoothstep) from 0 to 1 across its surface, over
// 2 * edge_half_width voxels along the surface normal (10% to 90% within 1.5 voxels), and
// the voxel's value moves that fraction of the way from what was painted before to the
// shape's tissue. Every value between two tissues then
// occurs at their boundary, and a threshold crosses it within a voxel of where the surface
// is, so interpolated hits (step 05) are smooth instead of voxel terraces.
constexpr double edge_half_width = 1.25;  // voxels, along the surface normal
// On coarse grids the edge stays this sharp: a voxel counts as at most this many mm when
// measuring edges, so a 1 x 1 x 1 phantom is still the brain, not the head's average.
constexpr double edge_max_voxel = 2;  // mm: CThead's coarsest spacing

// What a row painter needs about one shape, for one grid spacing (mm).
struct Painter {
    const Shape* shape;
    double grow;   // mm: the edge's half width at the coarsest spacing, edge_half_width voxels
    double plane_scale[max_planes];  // |spacing * normal| of each plane: mm per voxel
};

// The x interval of the row (y, z) where the shape, grown by `grow` mm (shrunk when negative),
// may lie: its quadric scaled by 1 + grow / r_min about the centre, its clip box and planes
// moved by `grow`. Scaling by that factor moves every surface point at least |grow| mm (the
// smallest semi-axis is the ellipsoid's nearest approach to its centre). False when empty.
bool row_interval(const Painter& painter, double y, double z, double grow, double& x0,
                  double& x1) {
    const Shape& shape = *painter.shape;
    if (y < shape.lo.j - grow || y > shape.hi.j + grow || z < shape.lo.k - grow ||
        z > shape.hi.k + grow) {
        return false;
    }
    const double scale = 1 + grow / shape.r_min;
    if (scale <= 0) return false;
    // Inside along the row: a dx^2 + b dx + c <= 0 with dx = x - centre.x (a > 0 always).
    const double dy = y - shape.centre.j, dz = z - shape.centre.k;
    const double a = shape.m[0][0];
    const double b = 2 * (shape.m[0][1] * dy + shape.m[0][2] * dz);
    const double c = shape.m[1][1] * dy * dy + 2 * shape.m[1][2] * dy * dz +
                     shape.m[2][2] * dz * dz - scale * scale;
    const double discriminant = b * b - 4 * a * c;
    if (discriminant < 0) return false;
    const double root = std::sqrt(discriminant);
    x0 = std::max(shape.centre.i + (-b - root) / (2 * a), shape.lo.i - grow);
    x1 = std::min(shape.centre.i + (-b + root) / (2 * a), shape.hi.i + grow);
    // A half-space along the row: normal.x * x <= rest.
    for (int n = 0; n < shape.plane_count; ++n) {
        const Plane& plane = shape.planes[n];
        const double rest = plane.offset + grow * length(plane.normal) -
                            plane.normal.j * y - plane.normal.k * z;
        if (plane.normal.i > 0) x1 = std::min(x1, rest / plane.normal.i);
        else if (plane.normal.i < 0) x0 = std::max(x0, rest / plane.normal.i);
        else if (rest < 0) return false;
    }
    return x0 <= x1;
}

// Signed distance of (x, y, z) mm to the shape's surface, in voxels along the surface normal
// (positive inside), first order: for the quadric sqrt(q) = 1 at the surface, a norm, so
// (1 - sqrt q) / |grad sqrt q| is exact for spheres and close near any ellipsoid's surface.
// In voxels (edge_spacing mm each): the gradient is taken per voxel index on every axis.
double edge_distance(const Painter& painter, double x, double y, double z,
                     const double spacing[3]) {
    const Shape& shape = *painter.shape;
    const double d[3] = {x - shape.centre.i, y - shape.centre.j, z - shape.centre.k};
    double g[3];  // m d = grad q / 2
    for (int row = 0; row < 3; ++row) {
        g[row] = shape.m[row][0] * d[0] + shape.m[row][1] * d[1] + shape.m[row][2] * d[2];
    }
    const double q = d[0] * g[0] + d[1] * g[1] + d[2] * g[2];
    const double gx = g[0] * spacing[0], gy = g[1] * spacing[1], gz = g[2] * spacing[2];
    const double g_voxels = std::sqrt(gx * gx + gy * gy + gz * gz);  // |grad sqrt q| sqrt q
    const double root_q = std::sqrt(q);
    double distance = g_voxels > 0 ? (1 - root_q) * root_q / g_voxels : huge;
    // The clip box and the planes are surfaces too.
    const double faces[6] = {(x - shape.lo.i) / spacing[0], (shape.hi.i - x) / spacing[0],
                             (y - shape.lo.j) / spacing[1], (shape.hi.j - y) / spacing[1],
                             (z - shape.lo.k) / spacing[2], (shape.hi.k - z) / spacing[2]};
    for (double face : faces) distance = std::min(distance, face);
    for (int n = 0; n < shape.plane_count; ++n) {
        const Plane& plane = shape.planes[n];
        const double to_plane = plane.offset - (plane.normal.i * x + plane.normal.j * y +
                                                plane.normal.k * z);
        distance = std::min(distance, to_plane / painter.plane_scale[n]);
    }
    return distance;
}

// How much of a voxel at this signed distance (voxels) the shape covers: smoothstep, so
// that the gradients lit surfaces take from these values have no kinks.
double coverage(double distance) {
    const double x = std::clamp(0.5 + distance / (2 * edge_half_width), 0.0, 1.0);
    return x * x * (3 - 2 * x);
}

// One row of voxels (fixed y, z, in mm) being painted: each voxel's value and noise
// amplitude so far, and the tissue that covers at least half of it (for only_over).
struct Row {
    double y, z;
    const double* spacing;  // mm: x, y, z; voxel i sits at x = (i + 0.5) * spacing[0]
    const double* edge_spacing;  // mm: the voxel size edges are measured in (x, y, z)
    double* values;
    double* noise;
    uint8_t* labels;
    int count;
};

// Paints one shape into the row: full coverage inside its shrunk interval, the ramp near
// its surface, nothing outside its grown interval.
void paint_row(const Painter& painter, const Row& row) {
    double x0, x1;
    if (!row_interval(painter, row.y, row.z, painter.grow, x0, x1)) return;
    double inner0 = 1, inner1 = 0;  // empty unless the shrunk interval exists
    if (!row_interval(painter, row.y, row.z, -painter.grow, inner0, inner1)) {
        inner0 = 1, inner1 = 0;
    }
    const Shape& shape = *painter.shape;
    const TissueValue& tissue = tissue_values[shape.tissue];
    // Voxel centres in [x0, x1]: i from ceil(x0/step - 0.5) to floor(x1/step - 0.5).
    const double step = row.spacing[0];
    const int i0 = static_cast<int>(std::max(0.0, std::ceil(x0 / step - 0.5)));
    const int i1 = static_cast<int>(std::min(row.count - 1.0, std::floor(x1 / step - 0.5)));
    for (int i = i0; i <= i1; ++i) {
        if (shape.over != any_tissue && row.labels[i] != shape.over) continue;
        const double x = (i + 0.5) * step;
        const double cover =
            shape.sharp || (x >= inner0 && x <= inner1)
                ? 1.0
                : coverage(edge_distance(painter, x, row.y, row.z, row.edge_spacing));
        if (cover <= 0) continue;
        row.values[i] += cover * (tissue.value - row.values[i]);
        row.noise[i] += cover * (tissue.noise - row.noise[i]);
        if (cover >= 0.5) row.labels[i] = shape.tissue;
    }
}

// --- Variants: the head moved, mirrored, resized, with other noise (phantom:SEED) ---------

// p' = c + D (p - c) + t, D = diag(mirror * scale, scale, scale), c the box's centre: an
// affine map that keeps image rows along x (painting finds each row's inside as one interval).
struct Variant {
    double d[3] = {1, 1, 1};    // D's diagonal
    Vec3 shift{0, 0, 0};        // t, mm
    uint32_t noise_key[3] = {0, 0, 0};  // added to (i, j, k) before hashing the noise
};

constexpr double min_scale = 0.88, max_scale = 1.04;  // the head's size against the kit's
constexpr double max_shift = 12;                      // mm along each axis

// SplitMix64: a well-mixed stream of 64-bit numbers from the seed.
uint64_t split_mix(uint64_t& state) {
    uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

Variant variant_of(uint64_t seed) {
    uint64_t state = seed;
    auto unit = [&] { return (split_mix(state) >> 11) * (1.0 / 9007199254740992.0); };  // [0,1)
    Variant variant;
    const bool mirror = split_mix(state) & 1;
    const double scale = min_scale + (max_scale - min_scale) * unit();
    variant.d[0] = mirror ? -scale : scale;
    variant.d[1] = variant.d[2] = scale;
    variant.shift = {float((2 * unit() - 1) * max_shift), float((2 * unit() - 1) * max_shift),
                     float((2 * unit() - 1) * max_shift)};
    for (uint32_t& key : variant.noise_key) key = uint32_t(split_mix(state));
    return variant;
}

// The shape carried by the variant's map: centre and box mapped, m' = D^-1 m D^-1, planes
// n' = D^-1 n with their offsets moved along.
Shape transformed(Shape shape, const Variant& variant) {
    const double c[3] = {box_x / 2, box_y / 2, box_z / 2};
    const double t[3] = {variant.shift.i, variant.shift.j, variant.shift.k};
    auto map = [&](double p, int axis) { return c[axis] + variant.d[axis] * (p - c[axis]) + t[axis]; };
    shape.centre = {float(map(shape.centre.i, 0)), float(map(shape.centre.j, 1)),
                    float(map(shape.centre.k, 2))};
    for (int row = 0; row < 3; ++row) {
        for (int col = 0; col < 3; ++col) shape.m[row][col] /= variant.d[row] * variant.d[col];
    }
    const double lo[3] = {map(shape.lo.i, 0), map(shape.lo.j, 1), map(shape.lo.k, 2)};
    const double hi[3] = {map(shape.hi.i, 0), map(shape.hi.j, 1), map(shape.hi.k, 2)};
    shape.lo = {float(std::min(lo[0], hi[0])), float(std::min(lo[1], hi[1])),
                float(std::min(lo[2], hi[2]))};
    shape.hi = {float(std::max(lo[0], hi[0])), float(std::max(lo[1], hi[1])),
                float(std::max(lo[2], hi[2]))};
    shape.r_min = float(shape.r_min * std::fabs(variant.d[1]));
    for (int n = 0; n < shape.plane_count; ++n) {
        Plane& plane = shape.planes[n];
        // n . p <= o with p = c + D^-1 (p' - c - t):  (D^-1 n) . p' <= o - n.c + (D^-1 n).(c + t)
        const double normal[3] = {plane.normal.i / variant.d[0], plane.normal.j / variant.d[1],
                                  plane.normal.k / variant.d[2]};
        double offset = plane.offset;
        const double old_normal[3] = {plane.normal.i, plane.normal.j, plane.normal.k};
        for (int a = 0; a < 3; ++a) offset += normal[a] * (c[a] + t[a]) - old_normal[a] * c[a];
        plane.normal = {float(normal[0]), float(normal[1]), float(normal[2])};
        plane.offset = offset;
    }
    return shape;
}

Volume paint_phantom(int nx, int ny, int nz, int threads, const Variant* variant);

}  // namespace

Volume make_phantom_sized(int nx, int ny, int nz, int threads) {
    return paint_phantom(nx, ny, nz, threads, nullptr);
}

Volume make_phantom_variant(uint64_t seed, int threads) {
    return make_phantom_variant_sized(seed, cthead_nx, cthead_ny, cthead_nz, threads);
}

Volume make_phantom_variant_sized(uint64_t seed, int nx, int ny, int nz, int threads) {
    const Variant variant = variant_of(seed);
    Volume volume = paint_phantom(nx, ny, nz, threads, &variant);
    volume.name = "phantom:" + std::to_string(seed);
    return volume;
}

namespace {

Volume paint_phantom(int nx, int ny, int nz, int threads, const Variant* variant) {
    if (nx < 1 || ny < 1 || nz < 1) {
        throw InputError("phantom: dims must be at least 1 voxel each, got " +
                         std::to_string(nx) + "x" + std::to_string(ny) + "x" +
                         std::to_string(nz));
    }
    // The voxel limit and the free memory, before anything is allocated (volume.h).
    check_volume_size("phantom:", uint64_t(nx), uint64_t(ny), uint64_t(nz));
    Volume volume;
    volume.nx = nx;
    volume.ny = ny;
    volume.nz = nz;
    // The head keeps its physical size: spacing = box / voxels (256/113 grid: 1, 1, 2).
    volume.sx = box_x / nx;
    volume.sy = box_y / ny;
    volume.sz = box_z / nz;
    volume.name = "phantom";

    // Voxel sizes as edges see them (mm), and voxel centres' spacing (mm).
    const double edge_spacing[3] = {std::min(volume.sx, edge_max_voxel),
                                    std::min(volume.sy, edge_max_voxel),
                                    std::min(volume.sz, edge_max_voxel)};
    const double spacing[3] = {volume.sx, volume.sy, volume.sz};
    const double coarsest = std::max({edge_spacing[0], edge_spacing[1], edge_spacing[2]});
    std::vector<Shape> shapes = head_shapes();
    if (variant) {
        for (Shape& shape : shapes) shape = transformed(shape, *variant);
    }
    const uint32_t no_key[3] = {0, 0, 0};
    const uint32_t* key = variant ? variant->noise_key : no_key;
    std::vector<Painter> painters;
    for (const Shape& shape : shapes) {
        Painter painter{&shape, shape.sharp ? 0 : edge_half_width * coarsest, {}};
        for (int n = 0; n < shape.plane_count; ++n) {
            const Vec3 normal = shape.planes[n].normal;
            painter.plane_scale[n] = std::sqrt(std::pow(normal.i * edge_spacing[0], 2) +
                                               std::pow(normal.j * edge_spacing[1], 2) +
                                               std::pow(normal.k * edge_spacing[2], 2));
        }
        painters.push_back(painter);
    }

    // Row by row: air, every shape painted in order, then the noise on top. The noise adds
    // (2u - 1) times the voxel's noise amplitude, u in [0, 1) a hash of (i, j, k); rounded.
    // Every row depends on its own (j, k) only, so slices are painted on `threads` threads,
    // each slice with rows of its own: the same voxels however many there are.
    resize_dense(volume);
    constexpr double hash_scale = 1.0 / 16777216;  // 2^-24: the hash's top 24 bits to [0, 1)
    Work unused;  // parallel_rows counts work; painting counts none
    parallel_rows(nz, threads, unused, [&](int k, Work&) {
        std::vector<double> values(nx), noise(nx);
        std::vector<uint8_t> labels(nx);
        for (int j = 0; j < ny; ++j) {
            std::fill(values.begin(), values.end(), tissue_values[air].value);
            std::fill(noise.begin(), noise.end(), tissue_values[air].noise);
            std::fill(labels.begin(), labels.end(), air);
            const Row row{(j + 0.5) * volume.sy, (k + 0.5) * volume.sz, spacing, edge_spacing,
                          values.data(), noise.data(), labels.data(), nx};
            for (const Painter& painter : painters) paint_row(painter, row);
            int16_t* out = &volume.data[volume.index(0, j, k)];
            for (int i = 0; i < nx; ++i) {
                const double u = (hash3(i + key[0], j + key[1], k + key[2]) >> 8) * hash_scale;
                const double value = std::round(values[i] + (2 * u - 1) * noise[i]);
                out[i] = static_cast<int16_t>(std::clamp(value, -32768.0, 32767.0));
            }
        }
    });
    update_range(volume);
    return volume;
}

}  // namespace

Volume make_phantom(int threads) {
    return make_phantom_sized(cthead_nx, cthead_ny, cthead_nz, threads);
}

}  // namespace ctlab
