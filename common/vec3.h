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

}  // namespace ctlab
