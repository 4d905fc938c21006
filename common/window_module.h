// window_module.h: what the window module (build/ctlab_window.so) hands the steps.
#pragma once
#include "window.h"

namespace ctlab {

struct WindowFunctions {
    void (*check_window_script)(const Options& options);
    bool (*show_preview)(const Options& options, Preview& preview);
    bool (*window_open)();
    void (*window_note)(const std::string& note);
};

}  // namespace ctlab
