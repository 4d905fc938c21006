// bricks.h: a coarse summary of a volume, for leaping over empty space.
//
// The volume is cut into bricks of brick_size^3 voxels, and each brick keeps the smallest and
// the largest CT value in it. A step that knows which values its transfer function leaves
// transparent can then tell from those two numbers that a whole brick is transparent, and
// leap over it instead of reading its voxels one by one (step 09 does).
//
// Gotcha: a brick's range also covers the first voxel past it along each axis (neighbouring
// bricks overlap by one voxel). A sample interpolated between a brick's last voxel and the
// next brick's first lies between those two values, so it is inside the brick's range too.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>
#include "volume.h"

namespace ctlab {

constexpr int brick_size = 8;  // voxels along each axis: make bench measured 4, 8 and 16

struct ValueRange {
    int16_t min = 0, max = 0;
};

struct Bricks {
    int bx = 0, by = 0, bz = 0;      // bricks along i, j, k
    std::vector<ValueRange> ranges;  // brick (a, b, c) at (c*by + b)*bx + a, i fastest as voxels

    // The brick that holds voxel (i, j, k) (indices are never negative).
    size_t index(int i, int j, int k) const {
        return (size_t(unsigned(k) / brick_size) * by + unsigned(j) / brick_size) * bx +
               unsigned(i) / brick_size;
    }
    size_t count() const { return ranges.size(); }
};

// One pass over the volume; it does not depend on the transfer function, so a step makes it
// once, when the volume is loaded.
Bricks make_bricks(const Volume& volume);

}  // namespace ctlab
