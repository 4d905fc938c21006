// bricks.h: a coarse summary of a volume, for leaping over empty space.
//
// The volume is cut into bricks of size^3 voxels (brick_size unless a step asks for another
// power of two), and each brick keeps the smallest and
// the largest CT value in it. A step that knows which values its transfer function leaves
// transparent can then tell from those two numbers that a whole brick is transparent, and
// leap over it instead of reading its voxels one by one (step 11 does).
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
constexpr int max_brick_size = 1 << 14;  // make_bricks refuses a larger (or non power of 2) size

struct ValueRange {
    int16_t min = 0, max = 0;
};

struct Bricks {
    int size = brick_size;           // voxels along each axis, a power of two
    int shift = 3;                   // log2(size): a voxel index >> shift is its brick's
    int bx = 0, by = 0, bz = 0;      // bricks along i, j, k
    std::vector<ValueRange> ranges;  // brick (a, b, c) at (c*by + b)*bx + a, i fastest as voxels

    // The brick that holds voxel (i, j, k) (indices are never negative). A shift, not a
    // division: the size is only known at run time.
    size_t index(int i, int j, int k) const {
        return (size_t(unsigned(k) >> shift) * by + (unsigned(j) >> shift)) * bx +
               (unsigned(i) >> shift);
    }
    size_t count() const { return ranges.size(); }
};

// One pass over the volume, its layers of bricks along k shared among `threads` threads
// (the render threads: the same bricks on any number); it does not depend on the transfer
// function, so a step makes it once, when the volume is loaded. `size`: a power of two from
// 1 to max_brick_size (else std::invalid_argument: a step's constant, not user input).
Bricks make_bricks(const Volume& volume, int size = brick_size, int threads = 1);

// Empty runs along one axis (0: i, 1: j, 2: k): for each brick, how many bricks in a row from
// it towards larger indices are flagged in `empty` (one flag per brick, 1: empty), itself
// included; 0 for a brick that is not empty. Capped at 255. A ray along that axis in an empty
// brick can then leap over the whole run at once, not one brick at a time.
std::vector<uint8_t> empty_runs(const Bricks& bricks, const std::vector<uint8_t>& empty,
                                int axis);

}  // namespace ctlab
