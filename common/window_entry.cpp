// window_entry.cpp: the window module's one entry point (module.h, window.h). Built with
// common/window.cpp and the panel into build/ctlab_window.so, which alone links SDL2 and Dear
// ImGui; a step opens it only
// when it is about to show a window (or check a test's --window-script).
#include "window.h"
#include "window_module.h"

extern "C" __attribute__((visibility("default")))
const ctlab::WindowFunctions* ctlab_window_functions() {
    static const ctlab::WindowFunctions functions = {
        ctlab::check_window_script, ctlab::show_preview, ctlab::window_open, ctlab::window_note};
    return &functions;
}
