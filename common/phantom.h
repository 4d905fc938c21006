// phantom.h: a built-in, deterministic CT head with CThead's size, spacing and value style.
// Lets every step run without the real data set. What is in it: handouts/phantom.md.
#pragma once
#include <cstdint>
#include "volume.h"

namespace ctlab {

// 256 x 256 x 113, spacing 1:1:2, crown at k = 0, face at small j. Same result on every call,
// on any number of threads (slices are painted in parallel on the render threads' pool:
// about 0.23 s on one core of the lab's VM, 0.12 s on two).
Volume make_phantom(int threads = 1);

// Same anatomy sampled on another grid (for small test volumes): dims nx, ny, nz,
// the head scaled to fill the grid. make_phantom() == make_phantom_sized(256, 256, 113).
Volume make_phantom_sized(int nx, int ny, int nz, int threads = 1);

// A phantom the students never saw, for grading (--volume phantom:SEED): the same anatomy
// mirrored left to right or not, resized by 88% to 104%, moved up to 12 mm along each axis,
// with other noise, all chosen by the seed alone (the same volume on every machine). Same
// grid and spacing as make_phantom(), or nx, ny, nz when given.
Volume make_phantom_variant(uint64_t seed, int threads = 1);
Volume make_phantom_variant_sized(uint64_t seed, int nx, int ny, int nz, int threads = 1);

}  // namespace ctlab
