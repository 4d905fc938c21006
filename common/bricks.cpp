// bricks.cpp: the smallest and largest value of each brick, its far faces included.
#include "bricks.h"
#include <algorithm>
#include <limits>

namespace ctlab {

namespace {

// The bricks along one axis that a voxel at index n belongs to: its own, and the one before
// when n is that brick's first voxel past its end (the one-voxel overlap).
struct BrickSpan {
    int first, last;
};

BrickSpan bricks_of(int n) {
    const int own = n / brick_size;
    return {n % brick_size == 0 && own > 0 ? own - 1 : own, own};
}

void widen(ValueRange& range, ValueRange by) {
    range.min = std::min(range.min, by.min);
    range.max = std::max(range.max, by.max);
}

}  // namespace

Bricks make_bricks(const Volume& volume) {
    Bricks bricks;
    bricks.bx = (volume.nx + brick_size - 1) / brick_size;
    bricks.by = (volume.ny + brick_size - 1) / brick_size;
    bricks.bz = (volume.nz + brick_size - 1) / brick_size;
    const ValueRange nothing_yet = {std::numeric_limits<int16_t>::max(),
                                    std::numeric_limits<int16_t>::min()};
    bricks.ranges.assign(size_t(bricks.bx) * bricks.by * bricks.bz, nothing_yet);
    // One pass in memory order: each row of voxels, cut into the pieces that fall in each
    // brick along i (overlap included), widens the bricks that row belongs to along j and k.
    std::vector<ValueRange> pieces(bricks.bx);
    for (int k = 0; k < volume.nz; ++k) {
        for (int j = 0; j < volume.ny; ++j) {
            const int16_t* row = &volume.data[(size_t(k) * volume.ny + j) * volume.nx];
            for (int a = 0; a < bricks.bx; ++a) {
                const int from = a * brick_size;
                const int to = std::min(from + brick_size, volume.nx - 1);  // included
                ValueRange piece = {row[from], row[from]};
                for (int i = from + 1; i <= to; ++i) widen(piece, {row[i], row[i]});
                pieces[a] = piece;
            }
            const BrickSpan along_j = bricks_of(j), along_k = bricks_of(k);
            for (int c = along_k.first; c <= along_k.last; ++c) {
                for (int b = along_j.first; b <= along_j.last; ++b) {
                    ValueRange* brick_row = &bricks.ranges[(size_t(c) * bricks.by + b) * bricks.bx];
                    for (int a = 0; a < bricks.bx; ++a) widen(brick_row[a], pieces[a]);
                }
            }
        }
    }
    return bricks;
}

}  // namespace ctlab
