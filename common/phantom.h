// phantom.h: a built-in, deterministic CT head with CThead's size, spacing and value style.
// Lets every step run without the real data set. What is in it: handouts/phantom.md.
#pragma once
#include "volume.h"

namespace ctlab {

// 256 x 256 x 113, spacing 1:1:2, crown at k = 0, face at small j. Same result on every call,
// on any number of threads (slices are painted in parallel on the render threads' pool:
// about 0.23 s on one core of the lab's VM, 0.12 s on two).
Volume make_phantom(int threads = 1);

// Same anatomy sampled on another grid (for small test volumes): dims nx, ny, nz,
// the head scaled to fill the grid. make_phantom() == make_phantom_sized(256, 256, 113).
Volume make_phantom_sized(int nx, int ny, int nz, int threads = 1);

}  // namespace ctlab
