// window_module.cpp: window.h's functions for the steps, without SDL: whether a window is
// wanted is decided here, and the window itself is shown by the window module
// (build/ctlab_window.so, common/window.cpp), opened only then (module.h).
#include <cstdio>
#include <cstdlib>
#include "error.h"
#include "module.h"
#include "window.h"
#include "window_module.h"

namespace ctlab {

namespace {

const WindowFunctions* opened = nullptr;  // the module's functions, once it is open

const WindowFunctions& window_module() {
    using Entry = const WindowFunctions* (*)();
    static const WindowFunctions* functions = reinterpret_cast<Entry>(
        module_entry("ctlab_window.so", "ctlab_window_functions", "to show a window"))();
    opened = functions;
    return *functions;
}

}  // namespace

bool window_wanted(const Options& options) {
    if (options.no_window) return false;
    const char* x11 = std::getenv("DISPLAY");
    const char* wayland = std::getenv("WAYLAND_DISPLAY");
    return (x11 && *x11) || (wayland && *wayland);
}

void check_window_script(const Options& options) {
    // --window-script is for tests; a run without one need not open the module.
    if (options.window_script.empty()) return;
    window_module().check_window_script(options);
}

bool show_preview(const Options& options, Preview& preview) {
    const WindowFunctions* functions = nullptr;
    try {
        functions = &window_module();
    } catch (const InputError& error) {
        // The PNGs are written already: a missing SDL costs the window, not the run.
        std::fprintf(stderr, "note: no window (%s); the PNGs are written\n", error.what());
        return false;
    }
    return functions->show_preview(options, preview);
}

// No window was ever opened while the module is not: nothing to ask it then.
bool window_open() { return opened && opened->window_open(); }

void window_note(const std::string& note) {
    if (opened) opened->window_note(note);
}

}  // namespace ctlab
