// vec3.h: a direction or gradient in volume space, one component per volume axis.
// Components are in physical units (voxel index times spacing), so angles are true angles.
#pragma once
#include <cmath>

namespace ctlab {

struct Vec3 {
    float i = 0, j = 0, k = 0;  // components along the i, j and k axes
};

inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.i + b.i, a.j + b.j, a.k + b.k}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.i - b.i, a.j - b.j, a.k - b.k}; }
inline Vec3 operator*(float s, Vec3 a) { return {s * a.i, s * a.j, s * a.k}; }
inline float dot(Vec3 a, Vec3 b) { return a.i * b.i + a.j * b.j + a.k * b.k; }
inline float length(Vec3 a) { return std::sqrt(dot(a, a)); }
inline Vec3 cross(Vec3 a, Vec3 b) {
    return {a.j * b.k - a.k * b.j, a.k * b.i - a.i * b.k, a.i * b.j - a.j * b.i};
}

// A point or direction in physical space, in double (part 2's camera rays): components along
// the i, j and k axes, in the volume's units (voxel index times spacing).
struct Vec3d {
    double i = 0, j = 0, k = 0;
    double operator[](int axis) const { return axis == 0 ? i : axis == 1 ? j : k; }
};

inline Vec3d operator+(Vec3d a, Vec3d b) { return {a.i + b.i, a.j + b.j, a.k + b.k}; }
inline Vec3d operator-(Vec3d a, Vec3d b) { return {a.i - b.i, a.j - b.j, a.k - b.k}; }
inline Vec3d operator*(double s, Vec3d a) { return {s * a.i, s * a.j, s * a.k}; }
inline double dot(Vec3d a, Vec3d b) { return a.i * b.i + a.j * b.j + a.k * b.k; }
inline double length(Vec3d a) { return std::sqrt(dot(a, a)); }
inline Vec3d cross(Vec3d a, Vec3d b) {
    return {a.j * b.k - a.k * b.j, a.k * b.i - a.i * b.k, a.i * b.j - a.j * b.i};
}

}  // namespace ctlab
