// phantom.cpp: the built-in CT head, painted from ellipsoids and elliptic cylinders.
//
// The anatomy lives in a fixed physical box of 256 x 256 x 226 mm (CThead's 256 x 256 x 113
// voxels at 1:1:2): x across the head (i), y from the face backwards (j), z from the crown
// down (k). Every voxel is sampled at its centre. Shapes are painted in order, later over
// earlier, one image row (fixed j, k) at a time: for each shape the row's inside is one
// interval of x, found with one square root, so the whole head takes a few tens of ms.
// Each voxel gets a tissue label; the label's CT value plus a small hash noise is stored.
// Bone voxels on a bone surface are graded by how deep the surface lies (see bone_value),
// so surfaces found at threshold 400 are smooth instead of voxel terraces.
// handouts/phantom.md lists every structure with its value and where it is.
#include "phantom.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>
#include "error.h"

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
    bool graded;   // bone whose surface voxels are graded down towards surface_value
};

// Chosen so that noise never carries a tissue across a transfer-function boundary
// (-300, 50, 300, 400): the occupied bands are listed in handouts/phantom.md.
constexpr TissueValue tissue_values[tissue_count] = {
    {-1000, 20, false}, // air
    {-900, 20, false},  // sinus_air: maxillary and frontal sinuses
    {-950, 20, false},  // airway: nose, nasal cavity, pharynx
    {-90, 10, false},   // fat: behind the eyes
    {25, 10, false},    // soft: skin, muscle, cartilage
    {28, 6, false},     // cord: spinal cord
    {36, 6, false},     // grey_matter: cortex
    {28, 6, false},     // white_matter
    {10, 4, false},     // csf: ventricles, the fluid around the brain
    {15, 4, false},     // eye: vitreous
    {75, 10, false},    // disc: intervertebral discs (transparent in the classic TF)
    {200, 10, false},   // head_rest: plastic (transparent in the classic TF, seen in MIP)
    {1700, 30, true},   // cortical: outer and inner skull tables, mandible
    {900, 30, true},    // diploe: spongy bone between the skull tables
    {1200, 30, true},   // face_bone: maxilla, zygoma, nasal septum, frontal bone
    {700, 30, true},    // vertebra: cervical spine
    {1900, 30, true},   // tooth: enamel
    {2248, 0, false},   // filling: amalgam, the volume maximum (CThead's too)
};

struct Vec3 {
    double x, y, z;
};
Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 cross(Vec3 a, Vec3 b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Vec3 normalized(Vec3 a) { return (1 / std::sqrt(dot(a, a))) * a; }

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
    Plane planes[max_planes] = {};
    int plane_count = 0;
    uint8_t over = any_tissue;
};

// An ellipsoid with semi-axes r.x, r.y, r.z along the orthonormal axes u, v, w.
Shape ellipsoid_axes(Tissue tissue, Vec3 centre, Vec3 u, Vec3 v, Vec3 w, Vec3 r) {
    Shape shape{tissue, centre, {}, {}, {}};
    const Vec3 axes[3] = {u, v, w};
    const double radii[3] = {r.x, r.y, r.z};
    double extent[3] = {0, 0, 0};  // squared half-size of the bounding box
    for (int a = 0; a < 3; ++a) {
        const double e[3] = {axes[a].x, axes[a].y, axes[a].z};
        for (int row = 0; row < 3; ++row) {
            for (int col = 0; col < 3; ++col) {
                shape.m[row][col] += e[row] * e[col] / (radii[a] * radii[a]);
            }
            extent[row] += radii[a] * radii[a] * e[row] * e[row];
        }
    }
    const Vec3 half{std::sqrt(extent[0]), std::sqrt(extent[1]), std::sqrt(extent[2])};
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
Shape ellipsoid_between(Tissue tissue, Vec3 end0, Vec3 end1, Vec3 across, double r1,
                        double r2) {
    const Vec3 u = normalized(end1 - end0);
    const Vec3 v = normalized(across - dot(across, u) * u);
    const double half_length = std::sqrt(dot(end1 - end0, end1 - end0)) / 2;
    return ellipsoid_axes(tissue, 0.5 * (end0 + end1), u, v, cross(u, v),
                          {half_length, r1, r2});
}

// An elliptic cylinder along z from z0 to z1.
Shape cylinder_z(Tissue tissue, double cx, double cy, double rx, double ry, double z0,
                 double z1) {
    Shape shape{tissue, {cx, cy, 0}, {}, {cx - rx, cy - ry, z0}, {cx + rx, cy + ry, z1}};
    shape.m[0][0] = 1 / (rx * rx);
    shape.m[1][1] = 1 / (ry * ry);
    return shape;
}

// Cuts the shape to the box [lo, hi] (mm).
Shape clipped(Shape shape, Vec3 lo, Vec3 hi) {
    shape.lo = {std::max(shape.lo.x, lo.x), std::max(shape.lo.y, lo.y),
                std::max(shape.lo.z, lo.z)};
    shape.hi = {std::min(shape.hi.x, hi.x), std::min(shape.hi.y, hi.y),
                std::min(shape.hi.z, hi.z)};
    return shape;
}

// Keeps only the part with normal . p <= offset.
Shape below_plane(Shape shape, Vec3 normal, double offset) {
    shape.planes[shape.plane_count++] = {normal, offset};
    return shape;
}

// Paints only over voxels that are already `tissue`.
Shape only_over(Shape shape, Tissue tissue) {
    shape.over = tissue;
    return shape;
}

constexpr double centre_x = box_x / 2;  // the head is symmetric about x = 128 mm
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
    s.push_back(clipped(cylinder_z(head_rest, centre_x, 169, 300, 60, 0, box_z),
                        {24, 200, -huge}, {232, huge, huge}));
    s.push_back(clipped(cylinder_z(air, centre_x, 169, 297, 57, 0, box_z),
                        {24, 200, -huge}, {232, huge, huge}));

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
            const Vec3 centre{centre_x + arch_rx * std::sin(angle),
                              arch_cy - arch_ry * std::cos(angle), z};
            const Vec3 along{arch_rx * std::cos(angle), arch_ry * std::sin(angle), 0};
            const double back = std::fabs(angle) / arch_angle;  // 0 front, 1 last molar
            s.push_back(ellipsoid_axes(tooth, centre, normalized(along),
                                       normalized(cross({0, 0, 1}, along)), {0, 0, 1},
                                       {3.6 + 0.8 * back, 2.4 + 2.4 * back, 6}));
        }
    }
    // An amalgam filling on the biting surface of an upper molar (the third tooth, x < 128).
    const double filling_angle = arch_angle * (2.0 * 2 / (teeth_per_jaw - 1) - 1);
    s.push_back(ellipsoid(filling, {centre_x + arch_rx * std::sin(filling_angle),
                                    arch_cy - arch_ry * std::cos(filling_angle), 162},
                          {2.5, 2.5, 2.5}));

    // Airway: the pharynx behind the mouth, down the neck.
    s.push_back(cylinder_z(airway, centre_x, 112, 11, 6, 132, box_z));

    // Cervical spine: bodies with discs between, the arches behind with the cord inside.
    constexpr double body_y = 140, arch_y = 160;  // mm
    constexpr double spine_top = 154, body_height = 12, disc_height = 4;  // mm
    s.push_back(cylinder_z(disc, centre_x, body_y, 12, 9, spine_top, box_z));
    for (double top = spine_top; top < box_z; top += body_height + disc_height) {
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

// Graded bone surfaces. A bone voxel whose centre lies `depth` voxels inside the surface gets
// soft + (surface_value - soft) / (1 - depth): interpolating from its soft neighbour then
// crosses 400 almost exactly where the surface is, and every bone voxel stays >= 410.
constexpr int surface_value = 410;  // CT value of a bone voxel the surface grazes
constexpr int outside_value = 25;   // the soft tissue bone surfaces face

// Signed depth of p below the shape's surface (negative outside), in voxels along the axis
// nearest the surface normal. First order for the quadric: (1 - Q) / |grad Q|.
double signed_depth(const Shape& shape, Vec3 p, Vec3 spacing) {
    const Vec3 d = p - shape.centre;
    const Vec3 gradient{2 * (shape.m[0][0] * d.x + shape.m[0][1] * d.y + shape.m[0][2] * d.z),
                        2 * (shape.m[1][0] * d.x + shape.m[1][1] * d.y + shape.m[1][2] * d.z),
                        2 * (shape.m[2][0] * d.x + shape.m[2][1] * d.y + shape.m[2][2] * d.z)};
    const double q = 0.5 * dot(d, gradient);  // (p - c)^T m (p - c)
    const double length = std::sqrt(dot(gradient, gradient));
    double distance = huge;  // mm
    Vec3 normal{0, 0, 1};
    if (length > 0) {
        distance = (1 - q) / length;
        normal = (1 / length) * gradient;
    }
    // The clip box and the planes are surfaces too.
    const double faces[6] = {p.x - shape.lo.x, shape.hi.x - p.x, p.y - shape.lo.y,
                             shape.hi.y - p.y, p.z - shape.lo.z, shape.hi.z - p.z};
    const Vec3 axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int f = 0; f < 6; ++f) {
        if (faces[f] < distance) distance = faces[f], normal = axes[f / 2];
    }
    for (int n = 0; n < shape.plane_count; ++n) {
        const Plane& plane = shape.planes[n];
        const double length_n = std::sqrt(dot(plane.normal, plane.normal));
        const double to_plane = (plane.offset - dot(plane.normal, p)) / length_n;
        if (to_plane < distance) distance = to_plane, normal = (1 / length_n) * plane.normal;
    }
    // mm to voxels along the dominant axis of the normal.
    const double ax = std::fabs(normal.x), ay = std::fabs(normal.y), az = std::fabs(normal.z);
    const double axis_mm = ax >= ay && ax >= az ? ax * spacing.x
                           : ay >= az           ? ay * spacing.y
                                                : az * spacing.z;
    return distance / axis_mm;
}

// A surface bone voxel's value from its depth in voxels: the tissue's own value from a
// depth of 1 - (410 - 25) / (value - 25) on (0.77 voxel for cortical bone).
double bone_value(const TissueValue& tissue, double depth) {
    if (depth >= 1) return tissue.value;
    const double graded = outside_value + (surface_value - outside_value) / (1 - depth);
    return std::min<double>(graded, tissue.value);
}

constexpr uint8_t no_painter = 255;  // a voxel no shape painted (air around the head)

// One row of voxels (fixed y, z, in mm) being painted: each voxel's tissue and the index
// of the shape that painted it last.
struct Row {
    double y, z;
    double step_x;  // mm; voxel i sits at x = (i + 0.5) * step_x
    uint8_t* labels;
    uint8_t* painters;
    int count;
};

// Paints shape number `index` into the row.
void paint_row(const Shape& shape, uint8_t index, const Row& row) {
    const double y = row.y, z = row.z;
    if (y < shape.lo.y || y > shape.hi.y || z < shape.lo.z || z > shape.hi.z) return;
    // Inside along the row: a dx^2 + b dx + c <= 0 with dx = x - centre.x (a > 0 always).
    const double dy = y - shape.centre.y, dz = z - shape.centre.z;
    const double a = shape.m[0][0];
    const double b = 2 * (shape.m[0][1] * dy + shape.m[0][2] * dz);
    const double c = shape.m[1][1] * dy * dy + 2 * shape.m[1][2] * dy * dz +
                     shape.m[2][2] * dz * dz - 1;
    const double discriminant = b * b - 4 * a * c;
    if (discriminant < 0) return;
    const double root = std::sqrt(discriminant);
    double x0 = std::max(shape.centre.x + (-b - root) / (2 * a), shape.lo.x);
    double x1 = std::min(shape.centre.x + (-b + root) / (2 * a), shape.hi.x);
    // A half-space along the row: normal.x * x <= rest.
    for (int n = 0; n < shape.plane_count; ++n) {
        const Plane& plane = shape.planes[n];
        const double rest = plane.offset - plane.normal.y * y - plane.normal.z * z;
        if (plane.normal.x > 0) x1 = std::min(x1, rest / plane.normal.x);
        else if (plane.normal.x < 0) x0 = std::max(x0, rest / plane.normal.x);
        else if (rest < 0) return;
    }
    // Voxel centres in [x0, x1]: i from ceil(x0/step - 0.5) to floor(x1/step - 0.5).
    const double step = row.step_x;
    const int i0 = static_cast<int>(std::max(0.0, std::ceil(x0 / step - 0.5)));
    const int i1 = static_cast<int>(std::min(row.count - 1.0, std::floor(x1 / step - 0.5)));
    for (int i = i0; i <= i1; ++i) {
        if (shape.over != any_tissue && row.labels[i] != shape.over) continue;
        row.labels[i] = shape.tissue;
        row.painters[i] = index;
    }
}

bool is_bone(uint8_t label) { return tissue_values[label].value >= surface_value; }

// Tissues and painters of the whole volume, and the shapes that painted them.
struct Labels {
    int nx, ny, nz;
    Vec3 spacing;
    std::vector<uint8_t> tissues, painters;
    std::vector<Shape> shapes;
};

// How deep bone voxel (i, j, k) lies below the nearest bone surface, in voxels; 1 (full
// value) when all its 6-neighbours are bone. The surface facing a non-bone neighbour is
// the voxel's own shape when that neighbour was painted earlier, or the shape that carved
// the neighbour out of it (painted later: the voxel lies outside that shape).
double bone_depth(const Labels& labels, int i, int j, int k) {
    const size_t at = (size_t(k) * labels.ny + j) * labels.nx + i;
    const Vec3 centre{(i + 0.5) * labels.spacing.x, (j + 0.5) * labels.spacing.y,
                      (k + 0.5) * labels.spacing.z};
    const int own = labels.painters[at];
    const long row = labels.nx, slice = long(labels.nx) * labels.ny;
    const bool inside[6] = {i > 0, i + 1 < labels.nx, j > 0, j + 1 < labels.ny, k > 0,
                            k + 1 < labels.nz};
    const long offsets[6] = {-1, 1, -row, row, -slice, slice};
    double depth = 1;
    for (int n = 0; n < 6; ++n) {
        if (!inside[n]) continue;
        const size_t neighbour = at + offsets[n];
        if (is_bone(labels.tissues[neighbour])) continue;
        const int painter = labels.painters[neighbour];
        const bool carved = painter != no_painter && painter > own;
        const double candidate =
            carved ? -signed_depth(labels.shapes[painter], centre, labels.spacing)
                   : signed_depth(labels.shapes[own], centre, labels.spacing);
        depth = std::min(depth, std::max(0.0, candidate));
    }
    return depth;
}

}  // namespace

Volume make_phantom_sized(int nx, int ny, int nz) {
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

    // Tissues and painters, row by row.
    Labels labels{nx, ny, nz, {volume.sx, volume.sy, volume.sz}, {}, {}, head_shapes()};
    if (labels.shapes.size() >= no_painter) throw std::logic_error("phantom: too many shapes");
    const size_t count = volume.voxel_count();
    labels.tissues.assign(count, air);
    labels.painters.assign(count, no_painter);
    for (int k = 0; k < nz; ++k) {
        for (int j = 0; j < ny; ++j) {
            const size_t start = (size_t(k) * ny + j) * nx;
            const Row row{(j + 0.5) * volume.sy, (k + 0.5) * volume.sz, volume.sx,
                          &labels.tissues[start], &labels.painters[start], nx};
            for (size_t n = 0; n < labels.shapes.size(); ++n) {
                paint_row(labels.shapes[n], uint8_t(n), row);
            }
        }
    }

    // Values: the tissue's value plus noise; bone on a bone surface graded by its depth,
    // the noise shrunk alike so that it stays >= surface_value.
    volume.data.resize(count);
    for (int k = 0; k < nz; ++k) {
        for (int j = 0; j < ny; ++j) {
            for (int i = 0; i < nx; ++i) {
                const size_t at = (size_t(k) * ny + j) * nx + i;
                const TissueValue& tissue = tissue_values[labels.tissues[at]];
                // Noise in [-noise, noise]: the hash's top 16 bits scaled, no division.
                const uint32_t span = 2 * tissue.noise + 1;
                const int noise = int(((hash3(i, j, k) >> 16) * span) >> 16) - tissue.noise;
                int value = tissue.value + noise;
                if (tissue.graded) {
                    const double depth = bone_depth(labels, i, j, k);
                    if (depth < 1) {
                        const double graded = bone_value(tissue, depth);
                        value = int(std::lround(graded + noise * (graded - surface_value) /
                                                             (tissue.value - surface_value)));
                    }
                }
                volume.data[at] = static_cast<int16_t>(value);
            }
        }
    }
    update_range(volume);
    return volume;
}

Volume make_phantom() {
    return make_phantom_sized(cthead_nx, cthead_ny, cthead_nz);
}

}  // namespace ctlab
