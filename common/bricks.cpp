// bricks.cpp: the smallest and largest value of each brick, its far faces included.
#include "bricks.h"
#include <algorithm>
#include <limits>
#include <stdexcept>
#include "render.h"

namespace ctlab {

namespace {

// The bricks along one axis that a voxel at index n belongs to: its own, and the one before
// when n is that brick's first voxel past its end (the one-voxel overlap).
struct BrickSpan {
    int first, last;
};

BrickSpan bricks_of(int n, int size) {
    const int own = n / size;
    return {n % size == 0 && own > 0 ? own - 1 : own, own};
}

void widen(ValueRange& range, ValueRange by) {
    range.min = std::min(range.min, by.min);
    range.max = std::max(range.max, by.max);
}

}  // namespace

Bricks make_bricks(const Volume& volume, int size, int threads) {
    if (size < 1 || size > max_brick_size || (size & (size - 1)) != 0) {
        throw std::invalid_argument("make_bricks: the brick size must be a power of two");
    }
    Bricks bricks;
    bricks.size = size;
    bricks.shift = 0;
    while ((1 << bricks.shift) < size) ++bricks.shift;
    bricks.bx = (volume.nx + size - 1) / size;
    bricks.by = (volume.ny + size - 1) / size;
    bricks.bz = (volume.nz + size - 1) / size;
    const ValueRange nothing_yet = {std::numeric_limits<int16_t>::max(),
                                    std::numeric_limits<int16_t>::min()};
    bricks.ranges.assign(size_t(bricks.bx) * bricks.by * bricks.bz, nothing_yet);
    // Each layer of bricks along k on its own (layers in parallel): the rows of voxels that
    // layer covers, overlap included, in memory order. Each row, cut into the pieces that
    // fall in each brick along i (overlap included), widens the layer's bricks that row
    // belongs to along j. A layer writes only its own bricks, and min and max do not depend
    // on the order, so the bricks are the same on any number of threads; the overlap rows
    // between two layers are read by both.
    Work unused;  // parallel_rows counts work; this counts none
    parallel_rows(bricks.bz, threads, unused, [&](int c, Work&) {
        std::vector<ValueRange> pieces(bricks.bx);
        const int k_end = std::min((c + 1) * size, volume.nz - 1);  // included
        for (int k = c * size; k <= k_end; ++k) {
            for (int j = 0; j < volume.ny; ++j) {
                const int16_t* row = &volume.data[volume.index(0, j, k)];
                for (int a = 0; a < bricks.bx; ++a) {
                    const int from = a * size;
                    const int to = std::min(from + size, volume.nx - 1);  // included
                    ValueRange piece = {row[from], row[from]};
                    for (int i = from + 1; i <= to; ++i) widen(piece, {row[i], row[i]});
                    pieces[a] = piece;
                }
                const BrickSpan along_j = bricks_of(j, size);
                for (int b = along_j.first; b <= along_j.last; ++b) {
                    ValueRange* brick_row = &bricks.ranges[(size_t(c) * bricks.by + b) * bricks.bx];
                    for (int a = 0; a < bricks.bx; ++a) widen(brick_row[a], pieces[a]);
                }
            }
        }
    });
    return bricks;
}

std::vector<uint8_t> empty_runs(const Bricks& bricks, const std::vector<uint8_t>& empty,
                                int axis) {
    const size_t strides[3] = {1, size_t(bricks.bx), size_t(bricks.bx) * size_t(bricks.by)};
    const int counts[3] = {bricks.bx, bricks.by, bricks.bz};
    const size_t stride = strides[axis];
    std::vector<uint8_t> runs(empty.size(), 0);
    // From the far end back: a brick's run is one more than the next brick's.
    for (size_t b = empty.size(); b-- > 0;) {
        if (!empty[b]) continue;
        const bool last = int(b / stride % size_t(counts[axis])) + 1 == counts[axis];
        const int after = last ? 0 : runs[b + stride];
        runs[b] = uint8_t(std::min(255, after + 1));
    }
    return runs;
}

}  // namespace ctlab
