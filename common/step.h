// step.h: what every step's main() does after its lesson: render each view, write the PNG,
// print the summary line, trace a debug pixel, then open the preview window.
#pragma once
#include <functional>
#include <string>
#include <vector>
#include "args.h"
#include "image.h"
#include "ray_plot.h"
#include "render.h"
#include "transfer_function.h"
#include "view.h"
#include "volume.h"

namespace ctlab {

// One ray, with its trace when trace != nullptr. The same function renders the image.
using RayFunction = std::function<Rgb(const View&, int x, int y, Work&, Trace*)>;
// A whole picture (optional: the default runs the ray function over every pixel in parallel).
using ImageFunction = std::function<Image(const View&, Work&)>;

// The step's main parameter, on the preview window's Up/Down (+/-) keys.
struct Knob {
    std::string name;                         // "threshold", "slice", ...
    std::function<void(const View&, int steps)> adjust;  // +1 per Up, -1 per Down
    std::function<std::string()> value;       // current value, for the title and summary
};

// Part 2: what the preview window's mouse does to a camera: a drag turns it, the wheel zooms.
// Empty functions (part 1): the mouse only clicks.
struct Orbit {
    std::function<void(double azimuth, double elevation)> turn;  // degrees to add to each
    std::function<void(double factor)> zoom;                     // multiplies the zoom
    std::function<std::string()> value;  // "azimuth=30 elevation=20 zoom=1", for the log
};

struct Renderer {
    RayFunction ray;
    ImageFunction image;                      // empty: render_image() over `ray`
    Knob knob;                                // name empty: no knob
    std::function<std::string()> settings;    // extra "key=value ..." for the summary line
    // The trace header's samples along a ray of a view, "226 samples at step 1 over 113
    // voxels spaced 2" (empty: "113 samples", one per voxel).
    std::function<std::string(const View&)> ray_samples;
    // Part 2: the views to render instead of --view's axis views (a camera's image); empty:
    // the axis views, as part 1.
    std::vector<View> views;
    // The ray picture's value bands (common/ray_plot.h): this transfer function's ranges when
    // set (it may change with the knob), else the threshold when the knob is "threshold".
    const TransferFunction* transfer_function = nullptr;
    Orbit orbit;                              // part 2: the window turns the camera
};

// Renders every selected view: PNG to OUT/STEP_VIEW.png (--pfm: the float image to
// OUT/STEP_VIEW.pfm too; --repeat N: N renders, warm_ms= their median after the first), one
// summary line each, the --debug-pixel trace, then the window unless --no-window or no
// display. Returns 0.
int run_views(const Options& options, const Volume& volume, const Renderer& renderer);

// A number as a summary line shows it (%g): "0.12", "1e-05", "30".
std::string summary_number(double value);

// A trace header's samples along a ray of an axis view sampled `step` physical units apart:
// "226 samples at step 1 over 113 voxels spaced 2".
std::string samples_at_step(int count, double step, const View& view);

// The image of one view, as run_views renders it (used by tests, the window and tools).
Image render_view(const Options& options, const View& view, const Renderer& renderer,
                  Work& work);

// Prints the trace of pixel (x, y): a header, one line per sample, the final pixel value.
// Returns the same ray as a plot (common/ray_plot.h), drawn from the trace's fields.
RayPlot print_trace(const Options& options, const View& view, const Renderer& renderer, int x,
                 int y);

// The ray of pixel (x, y) as a plot, traced without printing (the window's ray panel).
RayPlot traced_plot(const Options& options, const View& view, const Renderer& renderer, int x,
                    int y);

// The value bands of the ray picture: the renderer's transfer function, or its threshold knob.
std::vector<ValueBand> value_bands(const Renderer& renderer);

// Draws the ray picture of pixel (x, y) of `view`: its plot beside the rendered views
// (`images`: the view's own first, then the other axis views; missing ones are rendered).
Image ray_picture(const Options& options, const Renderer& renderer, const RayPlot& plot,
                  const View& view, const std::vector<RayPlotView>& images, int x, int y);

// "out/03_depth_shading_front.png"
std::string output_path(const Options& options, const View& view);

// --work-map: every ray's work, one line per image row (OUT/STEP_VIEW_work.txt), each ray
// traced again alone through the renderer's ray function (the same counts as the picture's
// render: the totals line says so, and make check compares them with the summary line's):
//   work WIDTH HEIGHT samples,skipped,leapt,gradients,terminated,hits
//   total 4123,0,0,0,0,0
//   0: 200*0,0,0,0,0,0 113,0,0,0,1,1 ...     (N*COUNTS: N rays in a row with these counts)
std::string work_map_path(const Options& options, const View& view);
std::string work_map_text(const Options& options, const View& view, const Renderer& renderer);

// "out/03_depth_shading_front.pfm": the float image --pfm writes beside the PNG.
std::string pfm_path(const Options& options, const View& view);

// Runs body(); any InputError (or other exception) becomes one line on stderr
// "STEP: error: ..." and exit status 2 (1 for an unexpected internal error).
int guarded_main(const char* step, const std::function<int()>& body);

}  // namespace ctlab
