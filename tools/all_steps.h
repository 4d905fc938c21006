// all_steps.h: every step compiled into one program, each inside a namespace of its own
// (step00 ... step09), for the programs that run the steps in-process: the tests
// (tests/test_steps.cpp), the benchmark (tools/bench.cpp) and the study (tools/study.cpp). A step's lesson functions are
// then step04::gradient_at and the like, and its main() an ordinary function.
//
// Include it once per program, after common/ctlab.h (a step includes only that, and it is
// guarded, so nothing else lands in the namespaces). To run a step's main() in-process, first
// #define load_volume and run_views as the includer's own stand-ins (#undef them after): the
// step then takes its volume from the includer and hands it its renderer instead of writing
// PNGs. tools/study.cpp calls only lesson functions and needs neither.
//
// A new step adds its namespace here and a line to all_steps; nothing else changes.
// No #pragma once: including it twice in one program is a mistake the compiler should report.

namespace step00 {
#include "../steps/00_slices.cpp"
}
namespace step01 {
#include "../steps/01_ray_loops.cpp"
}
namespace step02 {
#include "../steps/02_threshold.cpp"
}
namespace step03 {
#include "../steps/03_depth_shading.cpp"
}
namespace step04 {
#include "../steps/04_gradient_lighting.cpp"
}
namespace step05 {
#include "../steps/05_interpolated_hits.cpp"
}
namespace step06 {
#include "../steps/06_transfer_function.cpp"
}
namespace step07 {
#include "../steps/07_compositing_order.cpp"
}
namespace step08 {
#include "../steps/08_lit_compositing.cpp"
}
namespace step09 {
#include "../steps/09_empty_space.cpp"
}

// Every step above, in order: its name ("03_depth_shading") and its main().
struct IncludedStep {
    const char* name;
    int (*main)(int argc, char** argv);
};

const IncludedStep all_steps[] = {
    {step00::step_name, &step00::main}, {step01::step_name, &step01::main},
    {step02::step_name, &step02::main}, {step03::step_name, &step03::main},
    {step04::step_name, &step04::main}, {step05::step_name, &step05::main},
    {step06::step_name, &step06::main}, {step07::step_name, &step07::main},
    {step08::step_name, &step08::main}, {step09::step_name, &step09::main},
};
