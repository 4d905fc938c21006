// window.h: the SDL2 preview window. It is a layer on top: every step works without it.
//
// Left: the control panel (common/panel.h), the step's flags as widgets. Centre: the image.
// Right: the ray panel a click opens. The window fits the display it opens on.
// Keys: 1/2/3 top/front/side; Up/Down or +/- change the step's knob and re-render (render
// time in the title); left click prints that pixel's trace and opens (or updates) its ray
// picture in a panel right of the image, redrawn when the knob turns; S saves a PNG; P runs
// the step again with the next preset (data/presets, in name order); Esc/Q quits.
// Part 2 (Preview::orbit set): drag with the left button to turn the camera, the wheel to
// zoom; while it moves the window shows coarse previews (1 in 2x2 pixels or fewer, to stay
// near 25 frames a second) and renders at full size when the mouse stops or is released.
#pragma once
#include <functional>
#include <string>
#include <vector>
#include "args.h"
#include "step.h"
#include "transfer_function.h"
#include "view.h"
#include "volume.h"

namespace ctlab {

struct Preview {
    std::string step;                                   // "05_interpolated_hits"
    std::vector<View> views;                            // the views the user can switch among
    int current = 0;                                    // index into views
    std::function<Image(const View&, Work&)> render;    // re-render the view
    std::function<void(const View&, int x, int y)> trace;  // print one pixel's trace
    Knob knob;                                          // Up/Down; name empty: none
    std::function<std::string(const View&)> save_path;  // where S writes
    // The ray picture of pixel (x, y) (common/ray_plot.h) for the panel beside the image a
    // click opens; *marks says where the ray hit, stopped or leapt ("hit t=47.29"). It is
    // drawn again when the knob turns. Empty: no panel.
    std::function<Image(const View&, int x, int y, std::string* marks)> ray_panel;
    Orbit orbit;                                        // drag and wheel; empty: none
    // The orbit's coarse previews: a render without the summary line (empty: render).
    std::function<Image(const View&, Work&)> render_preview;
    // The summary line's text of a render ("step=... samples=..."), shown live by the panel.
    std::function<std::string(const View&, const Work&, double ms)> summary;

    // The control panel (common/panel.h): the step's own flags as widgets; moving one runs
    // the step again with the command line rewritten (request_rerun).
    std::string program;                       // argv[0], for the command line shown
    std::vector<FlagSpec> flags;               // the step's flag table with its values
    std::vector<std::string> words;            // the command line after the program's name
    const Volume* volume = nullptr;            // for the editor's histogram
    const TransferFunction* transfer_function = nullptr;  // the editor's table; none: no editor
    std::string out;                           // --out: where the editor saves its .tf
};

// Checks --window-script (throws InputError on a bad event), so that run_views can refuse it
// before rendering anything.
void check_window_script(const Options& options);

// True when a window can be tried: not --no-window, and DISPLAY or WAYLAND_DISPLAY is set.
bool window_wanted(const Options& options);

// Opens the window and runs until the user quits. Returns false (having printed one note)
// when no window could be opened (also when the X display accepts a connection and does not
// answer within 2 s); the caller has already written its PNGs. Ctrl-C and SIGTERM end the
// program at once; an X server that goes away ends it with one line and exit status 1. A view
// larger than the window (or the GPU's texture limit) is shown shrunk by whole factors.
// options.window_script (tests): comma-separated events injected after the first frame,
// e.g. "key:2,key:Up,click:40:30,save,quit"; the orbit's mouse: "press:X:Y", "move:X:Y",
// "release:X:Y" (image pixels), "wheel:N" (notches, up: closer) and "wait:MS"; "shot" writes
// the window's pixels to OUT/STEP_VIEW_window_N.png (and the image as shown, one window pixel
// per image pixel, to ..._window_N_image.png) and prints where the ray panel is in it; the
// panel's "set:NAME=VALUE" and "tf:..." (common/panel.h) and "widgets" (where they are).
// The control panel's widgets (and --window-script's set:NAME=VALUE, tf:...) ask for the step
// to run again (request_rerun) and return true with the window still open: the rerun's
// show_preview() goes on in it. "widgets" prints each widget's rectangle (tests aim at them).
bool show_preview(const Options& options, Preview& preview);

// True while the window stays open between the panel's reruns.
bool window_open();

// A message for the panel (a rerun's error), shown under its title.
void window_note(const std::string& note);

}  // namespace ctlab
