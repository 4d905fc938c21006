// warm_up.h: what a process does once, before its first timed render, so that render costs
// what every later one costs.
//
// Why the first render in a fresh process was slow (measured on the lab's 2-core VM, step 08
// top view, with per-render fault counts and times from --repeat):
//  - its image (256x256 RGB floats, 786 KB) lands in memory the process has never touched:
//    192 page faults, about 10 us each on this VM, ~2 ms. glibc hands such a large block
//    back to the system when it is freed, so the next render's image faulted again;
//  - its threads were new (made per render then; a pool made here now), and they read a
//    volume whose every line the loader's core has just written: another core's first read
//    of such a line fetches it from that core's cache. With both, two threads were hardly faster than one on the first render
//    (07 top, 2 threads, loaded machine, 8 fresh processes each: cold/warm median 1.4 without
//    the read below, 0.8 with it).
// warm_up() does that work once, before the timer, and says how long it took: the summary
// line reports it as warmup_ms=, a figure of its own, never hidden in time_ms=.
#pragma once
#include <vector>
#include "view.h"
#include "volume.h"

namespace ctlab {

// Keeps freed image memory in the process (glibc) and maps enough of it for the largest of
// `views`' images three times over (a render's intermediate image and picture, while the
// picture before it is kept); starts the pool of render threads (`threads` in all, this one
// included: common/render.h); and, given a volume, has each of `threads` threads read one
// value per cache line of it (a pass over the volume per thread). Returns the milliseconds it
// took: warmup_ms= 2.1-2.8 on the phantom at 1 thread, 3-12 at 2 threads (07-09 top, machine
// load ~4.5 on 2 cores).
double warm_up(const std::vector<View>& views, int threads, const Volume* volume = nullptr);

}  // namespace ctlab
