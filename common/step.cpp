// step.cpp: the part of every main() that is not the lesson.
#include "step.h"
#include <unistd.h>
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include "error.h"
#include "output_files.h"
#include "ray_plot.h"
#include "warm_up.h"
#include "window.h"

namespace ctlab {

// The summary lines must reach their reader: stdout to a full disk (>/dev/full) is an error,
// found before any PNG is renamed into place. The first failed flush keeps its reason.
static int stdout_error = 0;

static void flush_stdout() {
    errno = 0;
    if (std::fflush(stdout) != 0 && stdout_error == 0) stdout_error = errno;
}

static void check_stdout() {
    flush_stdout();
    if (stdout_error != 0 || std::ferror(stdout)) {
        throw InputError(std::string("cannot write the summary to standard output: ") +
                         (stdout_error ? std::strerror(stdout_error) : "write error"));
    }
}

std::string output_path(const Options& options, const View& view) {
    return options.out + "/" + options.step + "_" + view.name + ".png";
}

std::string pfm_path(const Options& options, const View& view) {
    return options.out + "/" + options.step + "_" + view.name + ".pfm";
}

std::string work_map_path(const Options& options, const View& view) {
    return options.out + "/" + options.step + "_" + view.name + "_work.txt";
}

std::string work_map_text(const Options& options, const View& view, const Renderer& renderer) {
    std::vector<Work> rays(size_t(view.width) * view.height);
    Work total;
    render_image(view, options.threads, total, [&](int x, int y, Work& row_work) {
        Work& one = rays[size_t(y) * view.width + x];
        const Rgb colour = renderer.ray(view, x, y, one, nullptr);
        row_work.add(one);
        return colour;
    });
    auto counts = [](const Work& w) {
        char text[160];
        std::snprintf(text, sizeof text, "%llu,%llu,%llu,%llu,%llu,%llu",
                      static_cast<unsigned long long>(w.samples),
                      static_cast<unsigned long long>(w.skipped),
                      static_cast<unsigned long long>(w.leapt),
                      static_cast<unsigned long long>(w.gradients),
                      static_cast<unsigned long long>(w.terminated),
                      static_cast<unsigned long long>(w.hits));
        return std::string(text);
    };
    std::string text = "work " + std::to_string(view.width) + " " +
                       std::to_string(view.height) +
                       " samples,skipped,leapt,gradients,terminated,hits\ntotal " +
                       counts(total) + "\n";
    for (int y = 0; y < view.height; ++y) {
        text += std::to_string(y) + ":";
        for (int x = 0; x < view.width;) {
            const Work& here = rays[size_t(y) * view.width + x];
            auto same = [&](const Work& w) {
                return w.samples == here.samples && w.skipped == here.skipped &&
                       w.leapt == here.leapt && w.gradients == here.gradients &&
                       w.terminated == here.terminated && w.hits == here.hits;
            };
            int run = 1;
            while (x + run < view.width && same(rays[size_t(y) * view.width + x + run])) ++run;
            text += " " + (run > 1 ? std::to_string(run) + "*" : std::string()) + counts(here);
            x += run;
        }
        text += "\n";
    }
    return text;
}

Image render_view(const Options& options, const View& view, const Renderer& renderer,
                  Work& work) {
    if (renderer.image) return renderer.image(view, work);
    return render_image(view, options.threads, work, [&](int x, int y, Work& pixel_work) {
        return renderer.ray(view, x, y, pixel_work, nullptr);
    });
}

// warm_up()'s time in this process (common/warm_up.h), on every summary line; < 0: none yet.
static double warmup_ms = -1;

// The summary line without its newline. warm_ms < 0: no repeated renders (--repeat 1), no
// warm_ms= on the line.
static std::string summary_line(const Options& options, const View& view,
                                const Renderer& renderer, const Work& work, double ms,
                                double warm_ms = -1) {
    char text[512];
    std::snprintf(text, sizeof text,
                  "step=%s view=%s size=%dx%d time_ms=%.2f threads=%d samples=%llu "
                  "skipped=%llu leapt=%llu gradients=%llu terminated=%llu hits=%llu",
                  options.step.c_str(), view.name.c_str(), view.width, view.height, ms,
                  options.threads, static_cast<unsigned long long>(work.samples),
                  static_cast<unsigned long long>(work.skipped),
                  static_cast<unsigned long long>(work.leapt),
                  static_cast<unsigned long long>(work.gradients),
                  static_cast<unsigned long long>(work.terminated),
                  static_cast<unsigned long long>(work.hits));
    std::string line = text;
    if (!renderer.knob.name.empty()) line += " " + renderer.knob.name + "=" + renderer.knob.value();
    if (renderer.settings) line += " " + printable(renderer.settings());
    if (warm_ms >= 0) {
        std::snprintf(text, sizeof text, " warm_ms=%.2f repeat=%d", warm_ms, options.repeat);
        line += text;
    }
    if (warmup_ms >= 0) {
        std::snprintf(text, sizeof text, " warmup_ms=%.2f", warmup_ms);
        line += text;
    }
    return line;
}

static void print_summary(const Options& options, const View& view, const Renderer& renderer,
                          const Work& work, double ms, double warm_ms = -1) {
    std::printf("%s\n", summary_line(options, view, renderer, work, ms, warm_ms).c_str());
    flush_stdout();
}

// The command line of the last run that reached the window: a rerun the panel asked for that
// fails (a value the step refuses) goes back to it.
static std::vector<std::string> good_words;
static bool have_good_words = false;

std::vector<ValueBand> value_bands(const Renderer& renderer) {
    if (renderer.transfer_function) return transfer_function_bands(*renderer.transfer_function);
    if (renderer.knob.name == "threshold" && renderer.knob.value) {
        char* end = nullptr;
        const std::string text = renderer.knob.value();
        const double threshold = std::strtod(text.c_str(), &end);
        if (end != text.c_str()) return threshold_bands(threshold);
    }
    return {};
}

Image ray_picture(const Options&, const Renderer&, const RayPlot& plot, const View& view,
                  const std::vector<RayPlotView>& images, int x, int y) {
    std::vector<RayPlotView> shown;
    for (const RayPlotView& image : images) {
        if (image.view.name == view.name) shown.insert(shown.begin(), image);
        else if (!image.view.camera) shown.push_back(image);  // part 2: the volume's views
    }
    return draw_ray_plot(plot, shown, x, y);
}

RayPlot traced_plot(const Options& options, const View& view, const Renderer& renderer, int x,
                    int y) {
    Work work;
    Trace trace;
    const Rgb pixel = renderer.ray(view, x, y, work, &trace);
    char title[160];
    std::snprintf(title, sizeof title, "%s %s ray x=%d y=%d", options.step.c_str(),
                  view.name.c_str(), x, y);
    return ray_plot_from_trace(trace.records(), view, value_bands(renderer), pixel, title);
}

RayPlot print_trace(const Options& options, const View& view, const Renderer& renderer, int x,
                    int y) {
    const char* axis_names[] = {"k", "j", "i"};  // the ray axis of top, front, side
    const std::string samples = renderer.ray_samples
                                    ? renderer.ray_samples(view)
                                    : std::to_string(view.ray_length) + " samples";
    if (view.camera) {
        std::printf("debug pixel x=%d y=%d view=%s step=%s (ray from the camera, %s)\n", x, y,
                    view.name.c_str(), options.step.c_str(), samples.c_str());
    } else {
        std::printf("debug pixel x=%d y=%d view=%s step=%s (ray over %s, %s)\n", x, y,
                    view.name.c_str(), options.step.c_str(), axis_names[int(view.axis)],
                    samples.c_str());
    }
    Work work;
    Trace trace;
    const Rgb pixel = renderer.ray(view, x, y, work, &trace);
    for (const std::string& line : trace.first_lines()) std::printf("  %s\n", line.c_str());
    if (trace.not_shown() > 0) {
        std::printf("  ... %llu more lines not shown (a trace keeps its first %zu and last %zu)\n",
                    static_cast<unsigned long long>(trace.not_shown()), Trace::max_first_lines,
                    Trace::max_last_lines);
    }
    for (const std::string& line : trace.last_lines()) std::printf("  %s\n", line.c_str());
    std::printf("pixel x=%d y=%d rgb=(%.6f, %.6f, %.6f) png=(%d, %d, %d) samples=%llu\n", x, y,
                pixel.r, pixel.g, pixel.b, to_byte(pixel.r), to_byte(pixel.g), to_byte(pixel.b),
                static_cast<unsigned long long>(work.samples));
    flush_stdout();
    char title[160];
    std::snprintf(title, sizeof title, "%s %s ray x=%d y=%d", options.step.c_str(),
                  view.name.c_str(), x, y);
    return ray_plot_from_trace(trace.records(), view, value_bands(renderer), pixel, title);
}

// --repeat N: the median time of renders 2..N of a view (the first, cold one is time_ms=).
// Their pictures and work counts are the first render's again, so they are dropped.
static double warm_median_ms(const Options& options, const View& view,
                             const Renderer& renderer) {
    std::vector<double> times;
    for (int n = 1; n < options.repeat; ++n) {
        Work work;
        const Timer timer;
        render_view(options, view, renderer, work);
        times.push_back(timer.ms());
    }
    std::sort(times.begin(), times.end());
    const size_t middle = times.size() / 2;
    return times.size() % 2 ? times[middle] : (times[middle - 1] + times[middle]) / 2;
}

static bool inside(const View& view, int x, int y) {
    return x >= 0 && y >= 0 && x < view.width && y < view.height;
}

// --trace-only: the pixels of a view that a ray picture shows (as the traced view, as one of
// the others), each ray cast alone through the ray function; the rest stay black, never drawn.
static Image shown_image(const Options& options, const View& view, const Renderer& renderer,
                         bool as_traced, bool as_other) {
    const ShownPixels shown = ray_picture_pixels(view, as_traced, as_other);
    Work work;  // the rays of a picture, not a render: counted nowhere
    return render_image(view, options.threads, work, [&](int x, int y, Work& ray_work) {
        const bool cast = shown.columns[size_t(x)] && shown.rows[size_t(y)];
        return cast ? renderer.ray(view, x, y, ray_work, nullptr) : Rgb{};
    });
}

static int show_window(const Options& options, const Volume& volume, const Renderer& renderer,
                       const std::vector<View>& views);

int run_views(const Options& options, const Volume& volume, const Renderer& renderer) {
    const std::vector<View> views =
        renderer.views.empty() ? views_named(volume, options.view) : renderer.views;

    // The window's panel ran the step again: straight back to the open window (the PNGs and
    // the summary lines were written by the run as typed).
    if (options.rerun && window_open()) return show_window(options, volume, renderer, views);

    // Refuse bad requests before any work, so nothing is half done.
    for (const auto& [x, y] : options.debug_pixels) {
        bool anywhere = false;
        for (const View& view : views) anywhere = anywhere || inside(view, x, y);
        if (!anywhere) {
            throw InputError("--debug-pixel " + std::to_string(x) + "," + std::to_string(y) +
                             " is outside the " + views[0].name + " image (" +
                             std::to_string(views[0].width) + "x" +
                             std::to_string(views[0].height) + "); X is the column, Y the row");
        }
    }
    try {
        make_folder(options.out);
    } catch (const InputError& error) {
        throw InputError(std::string("--out: ") + error.what());  // name the flag to change
    }
    if (access(options.out.c_str(), W_OK) != 0) {
        throw InputError("--out: cannot write to folder '" + options.out + "'");
    }

    check_window_script(options);  // a typo in it is reported now, not after the PNGs

    // All pictures or none: every file goes to a temporary, renamed when all are written.
    auto outputs = std::make_unique<OutputFiles>();
    // Image memory and threads made ready once, timed on their own (warmup_ms=), so that
    // time_ms= of the first render is the render alone (--trace-only: no render).
    if (!options.trace_only) warmup_ms = warm_up(views, options.threads, &volume);
    std::vector<RayPlotView> rendered;  // for the ray pictures of --debug-pixel
    struct TracedRay {
        View view;
        int x, y;
        RayPlot plot;
    };
    std::vector<TracedRay> plots;
    // A view's picture: rendered (timed), written, its summary line printed.
    auto render_and_write = [&](const View& view) {
        Work work;
        const Timer timer;
        const Image image = render_view(options, view, renderer, work);
        const double ms = timer.ms();
        const double warm_ms =
            options.repeat > 1 ? warm_median_ms(options, view, renderer) : -1;
        if (image.width != view.width || image.height != view.height) {
            throw InputError("the " + view.name + " render is " + std::to_string(image.width) +
                             "x" + std::to_string(image.height) + " but the view is " +
                             std::to_string(view.width) + "x" + std::to_string(view.height) +
                             " (is a lesson function still a TODO stub?)");
        }
        write_png(image, output_path(options, view));
        if (options.pfm) write_pfm(image, pfm_path(options, view));
        if (options.work_map) {
            const std::string text = work_map_text(options, view, renderer);
            write_output_file(work_map_path(options, view), [&](std::FILE* file) {
                return std::fwrite(text.data(), 1, text.size(), file) == text.size();
            });
        }
        print_summary(options, view, renderer, work, ms, warm_ms);
        if (options.has_debug_pixel) rendered.push_back({view, image});
    };
    for (const View& view : views) {
        if (!options.trace_only) render_and_write(view);  // --trace-only: the traced rays alone
        for (const auto& [x, y] : options.debug_pixels) {
            if (inside(view, x, y)) {
                plots.push_back({view, x, y, print_trace(options, view, renderer, x, y)});
            } else {
                std::printf("note: debug pixel %d,%d is outside the %s image (%dx%d)\n", x, y,
                            view.name.c_str(), view.width, view.height);
            }
        }
    }
    // The ray pictures, with the other axis views rendered when --view left them out; a
    // camera ray (part 2) is drawn through the volume's own axis views (mip_views).
    // --no-ray-picture: none of that, the records alone (a ray picture is most of the time of
    // a small run: ~0.7 MB drawn and written per traced ray, whatever the volume's size).
    // --trace-only: of each view only the pixels its pictures show, cast ray by ray.
    const bool pictures = options.ray_pictures;
    if (pictures && !plots.empty() && options.trace_only) {
        const std::vector<View> axis_views = views_named(volume, "all");
        for (const View& view : renderer.views.empty() ? axis_views : views) {
            bool as_traced = false, as_other = false;
            for (const TracedRay& traced : plots) {
                as_traced = as_traced || traced.view.name == view.name;
                as_other = as_other || (!view.camera && traced.view.name != view.name);
            }
            if (as_traced || as_other) {
                rendered.push_back({view, shown_image(options, view, renderer, as_traced,
                                                      as_other)});
            }
        }
    }
    if (pictures && !plots.empty() && !renderer.views.empty()) {
        for (RayPlotView& axis_view : mip_views(volume, options.trace_only)) {
            rendered.push_back(std::move(axis_view));
        }
    }
    if (pictures && !plots.empty() && renderer.views.empty() && !options.trace_only) {
        for (const View& other : views_named(volume, "all")) {
            bool have = false;
            for (const RayPlotView& r : rendered) have = have || r.view.name == other.name;
            if (have) continue;
            Work work;
            rendered.push_back({other, render_view(options, other, renderer, work)});
        }
    }
    for (const TracedRay& traced : plots) {
        const View& view = traced.view;
        if (pictures) {
            write_png(ray_picture(options, renderer, traced.plot, view, rendered, traced.x,
                                  traced.y),
                      ray_plot_path(options.out, options.step, view, traced.x, traced.y, ".png"),
                      fast_png_compression);
        }
        const std::string text = ray_plot_text(traced.plot);
        write_output_file(ray_plot_path(options.out, options.step, view, traced.x, traced.y,
                                        ".txt"),
                          [&](std::FILE* file) {
                              return std::fwrite(text.data(), 1, text.size(), file) ==
                                     text.size();
                          });
    }
    check_stdout();
    outputs->commit();
    outputs.reset();  // the signals' own handlers again, for the window

    if (options.trace_only || !window_wanted(options)) return 0;
    return show_window(options, volume, renderer, views);
}

// The preview window with its control panel (common/window.h), after the PNGs.
static int show_window(const Options& options, const Volume& volume, const Renderer& renderer,
                       const std::vector<View>& views) {
    Preview preview;
    preview.step = options.step;
    preview.views = renderer.views.empty() ? views_named(volume, "all") : renderer.views;
    preview.current = renderer.views.empty() ? int(views[0].axis) : 0;
    preview.render = [&](const View& view, Work& work) {
        const Timer timer;
        Image image = render_view(options, view, renderer, work);
        print_summary(options, view, renderer, work, timer.ms());
        return image;
    };
    preview.trace = [&](const View& view, int x, int y) {
        print_trace(options, view, renderer, x, y);
    };
    preview.ray_panel = [&](const View& view, int x, int y, std::string* marks) {
        const RayPlot plot = traced_plot(options, view, renderer, x, y);
        if (marks) *marks = ray_plot_marks(plot);
        return draw_ray_plot(plot, {}, x, y);
    };
    preview.knob = renderer.knob;
    preview.orbit = renderer.orbit;
    preview.render_preview = [&](const View& view, Work& work) {
        return render_view(options, view, renderer, work);
    };
    preview.save_path = [&](const View& view) { return output_path(options, view); };
    preview.summary = [&](const View& view, const Work& work, double ms) {
        return summary_line(options, view, renderer, work, ms);
    };
    preview.program = options.program;
    preview.flags = options.flags;
    preview.words = options.words;
    preview.volume = &volume;
    preview.transfer_function = renderer.transfer_function;
    preview.out = options.out;
    good_words = options.words;
    have_good_words = true;
    show_preview(options, preview);
    return 0;
}

int guarded_main(const char* step, const std::function<int()>& body) {
    size_t presets_failed = 0;  // in a row, since the window's P key
    for (;;) {
        std::string kind = "error", message;
        int status = 0;
        try {
            status = body();
            std::vector<std::string> words;
            if (take_rerun_request(&words)) {
                // The window's panel: the step again with one flag changed, the window open.
                switch_words(words);
                continue;
            }
            std::string next;
            if (!take_preset_request(&next)) return status;
            // The window's P key: the whole step again (volume, transfer function, views).
            presets_failed = 0;
            end_rerun();
            switch_preset(next);
            std::printf("window: preset=%s\n", next.c_str());
            std::fflush(stdout);
            continue;
        } catch (const InputError& error) {
            message = error.what();
            status = exit_bad_input;
        } catch (const std::bad_alloc&) {
            message = "out of memory (is the volume too large?)";
            status = exit_bad_input;
        } catch (const std::exception& error) {
            kind = "internal error";
            message = error.what();
            status = 1;
        }
        // A value the panel set that the step refuses (a size of 0, a clip plane it cannot
        // read): said in one line and on the panel, then the command line that worked.
        if (status == exit_bad_input && rerunning() && window_open() && have_good_words) {
            std::printf("window: not applied: %s\n", printable(message).c_str());
            std::fflush(stdout);
            window_note("not applied: " + message);
            switch_words(good_words);
            continue;
        }
        // A preset the window switched to that does not fit this volume or step (a threshold
        // beyond its values, a missing data/CThead): said in one line, then the next preset;
        // after every preset failed, the command line as typed (which ran before).
        if (status == exit_bad_input && !switched_preset().empty()) {
            const std::string failed = switched_preset();
            std::printf("window: preset %s does not fit: %s\n", failed.c_str(),
                        printable(message).c_str());
            const bool more = ++presets_failed < preset_names().size();
            switch_preset(more ? next_preset(failed) : "");
            std::printf("window: preset=%s\n", more ? switched_preset().c_str() : "(as typed)");
            std::fflush(stdout);
            continue;
        }
        std::fprintf(stderr, "%s: %s: %s\n", step, kind.c_str(), printable(message).c_str());
        return status;
    }
}

std::string summary_number(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", value);
    return text;
}

std::string samples_at_step(int count, double step, const View& view) {
    char text[128];
    std::snprintf(text, sizeof text, "%d samples at step %g over %d voxels spaced %g", count,
                  step, view.ray_length, view.ray_spacing);
    return text;
}

}  // namespace ctlab
