// not_done.h: what the stubs in a student skeleton call (make student, tools/make_student.cpp).
// A stub compiles and runs; this says, loudly and once, that its function is still to write.
#pragma once

namespace ctlab {

// Prints "TODO: STEP: FUNCTION() is not written yet — see handouts/STEP.md" to stderr the
// first time each function calls it. Safe to call from the render threads.
void not_done(const char* step, const char* function);

// The same. A stub also passes its function's parameters, so that the compiler does not warn
// that they are unused before the student writes the body.
template <class... Unused>
void not_done(const char* step, const char* function, const Unused&...) {
    not_done(step, function);
}

}  // namespace ctlab
