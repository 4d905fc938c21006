// warm_up.h: what a process does once, before its first timed render, so that render costs
// what every later one costs (issue #13).
//
// Why the first render in a fresh process was slow (measured on the lab's 2-core VM, step 07
// top view, with per-render fault counts and times from --repeat):
//  - its image (256x256 RGB floats, 786 KB) lands in memory the process has never touched:
//    192 page faults, about 10 us each on this VM, ~2 ms. glibc hands such a large block
//    back to the system when it is freed, so the next render's image faulted again;
//  - its threads are new: their stacks fault in, and the second core, idle until then, has
//    to be woken (a worker started up to 4 ms late), so two threads were no faster than one.
// warm_up() does that work once, before the timer, and says how long it took: the summary
// line reports it as warmup_ms=, a figure of its own, never hidden in time_ms=.
#pragma once
#include <vector>
#include "view.h"

namespace ctlab {

// Keeps freed image memory in the process (glibc) and touches enough of it for the largest
// of `views`' images twice over; starts and joins `threads` render threads once (glibc keeps
// their stacks for the next ones). Returns the milliseconds it took.
double warm_up(const std::vector<View>& views, int threads);

}  // namespace ctlab
