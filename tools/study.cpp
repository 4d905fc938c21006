// study.cpp: what each method costs and what it buys. Renders a matrix of methods and
// parameters and measures, in the same run, the wall time (median of --runs renders, one
// thread) and the error against a converged reference:
//
//   depth      first hit: nearest sample (step 03), finer ray steps, interpolated (step 05),
//              against an analytic sphere and a tilted ellipsoid; error in voxels (samples)
//   step       step 10's sample step 4 .. 1/8 voxel, with and without opacity correction,
//              against step 10 at step 1/32 (double sums, no early termination); error in
//              8-bit units (RMSE and max over every channel of every pixel)
//   ert        early ray termination thresholds 0 .. 0.1 (steps 08 and 10, top view):
//              time saved against error added
//   jitter     step 17 (the free camera) at step 4 .. 1/2 with jitter none, hash and blue
//              noise, each with trilinear and nearest samples, against step 1/4 without
//              jitter (trilinear): RMSE, and RMSE after a 5x5 blur
//              (the rings and bands that survive it; noise does not)
//   shadows    steps 22-24: shadow rays, the light-transmittance volume and ambient
//              occlusion, each against step 15's light (what it adds) with its time and
//              samples read (step 24, which has them all); rays and volume at step 4 .. 1/2
//              against shadow rays at step 1/4 (step 23)
//   shear-warp step 38 against step 30 (and step 34's time): along an axis and at angles,
//              error in 8-bit units against the ray caster's picture, time per render
//   precision  the cost of subnormal arithmetic on this machine, and of a float ray
//   numerics   the stiff and extreme cases the tests check, with the analytic answer and the
//              error measured here (handouts/numerics.md quotes them)
//
//   build/study [--out DIR] [--runs N] [--quick]      (make study: a few minutes)
//   build/study --only shear-warp [--out DIR]         (that study alone: DIR/shear_warp.md)
//
// --quick (make study QUICK=1, run by CI so the study cannot rot): one render per case, the
// phantom at 64 x 64 x 29 (written to a raw file) and a reference step of 1/16. Its figures
// are not to be quoted, and its tables are not marked as sections for the handouts.
//
// Writes DIR/error_vs_time.csv, DIR/error_vs_time.png (log-log, a panel per study),
// DIR/error_vs_time.md (the tables) and DIR/numerics.md. handouts/error_vs_time.md and
// handouts/numerics.md discuss one run of it.
//
// The methods are the steps themselves: each runs as its own program (tools/run_step.h) on
// volumes written here (analytic shapes as raw files, the phantom), and the study reads what
// it writes: the float picture (--pfm), the summary line (samples, and with --repeat the
// median time of the warm renders) and the --debug-pixel trace (step 05's sub-voxel depth).
// Where the study needs a variant no step has, it changes the input, never the code: thinner
// slices of the same shape for finer first-hit steps (to 1/8 voxel); a stretched phantom with
// a thinned table for compositing steps finer than --step allows (1/8, and the 1/32 reference).
#include "common/ctlab.h"
#include <cfloat>
#include <cstring>
#include <ctime>
#include <fstream>
#include <functional>
#include <sstream>
#if defined(__SSE__)
#include <xmmintrin.h>  // the MXCSR register: flush-to-zero and denormals-are-zero
#endif

#include <thread>
#include "machine_load.h"
#include "plot.h"
#include "run_step.h"
#include "text_format.h"

using namespace ctlab;

namespace {

constexpr const char* tool_name = "study";
constexpr int default_runs = 5;           // timed renders per case (median), after a warm-up
constexpr int surface_threshold = 400;    // CT value of the analytic surfaces (and of bone)
double reference_step = 1.0 / 32;  // voxels: the converged compositing reference
constexpr double quick_reference_step = 1.0 / 16;  // --quick
constexpr int quick_dims[3] = {64, 64, 29};        // --quick: the phantom this size
bool quick = false;
constexpr double byte_units = 255;        // errors in 8-bit units: 0..1 times 255
constexpr double pi = 3.14159265358979323846;
constexpr double not_applicable = -1;     // an error column a case has no figure for

// --- Timing and error -------------------------------------------------------------------

int runs = default_runs;

// Median wall time of `runs` calls after one warm-up call.
double median_ms(const std::function<void()>& body) {
    body();
    std::vector<double> ms;
    for (int n = 0; n < runs; ++n) {
        const Timer timer;
        body();
        ms.push_back(timer.ms());
    }
    std::sort(ms.begin(), ms.end());
    return ms[ms.size() / 2];
}

struct ImageError {
    double rmse = 0, max = 0;  // 8-bit units, over every channel of every pixel
};

ImageError image_error(const Image& image, const Image& reference) {
    double sum = 0, largest = 0;
    for (size_t n = 0; n < image.pixels.size(); ++n) {
        const Rgb& a = image.pixels[n];
        const Rgb& b = reference.pixels[n];
        for (const double d : {double(a.r) - b.r, double(a.g) - b.g, double(a.b) - b.b}) {
            sum += d * d;
            largest = std::max(largest, std::abs(d));
        }
    }
    return {std::sqrt(sum / (3.0 * image.pixels.size())) * byte_units, largest * byte_units};
}

// "1/8" for 0.125, "4" for 4: step sizes as the tables show them.
std::string step_text(double step) {
    if (step >= 1) return text_of("%g", step);
    return text_of("1/%g", 1 / step);
}

// One measured point: a row of the CSV and of a table, and a point of the plot.
struct Point {
    std::string study, method, parameter;
    double ms = 0;
    double error = 0, max_error = 0;
    std::string error_unit;
    uint64_t samples = 0;
};

std::vector<Point> points;

void record(const Point& point) {
    points.push_back(point);
    std::printf("  %-10s %-34s %-7s %9.2f ms  error %-9.4g max %-9.4g %s\n",
                point.study.c_str(), point.method.c_str(), point.parameter.c_str(), point.ms,
                point.error, point.max_error, point.error_unit.c_str());
    std::fflush(stdout);
}

// --- Running the steps --------------------------------------------------------------------

// One folder for the whole run: the volumes, transfer functions and pictures it writes.
const TempFolder& scratch() {
    static const TempFolder folder("study");
    return folder;
}

// One run of a step: what it printed and its float pictures (--pfm), in summary-line order.
struct Run {
    RunResult result;
    std::vector<Image> images;
    const Summary& line(size_t n = 0) const { return result.summaries.at(n); }
    uint64_t count(const char* key, size_t n = 0) const { return summary_count(line(n), key); }
    // Timed runs: the median of the renders after the first (warm_ms=); else time_ms=.
    double ms(size_t n = 0) const {
        return line(n).count("warm_ms") ? summary_number(line(n), "warm_ms")
                                        : summary_number(line(n), "time_ms");
    }
    const Image& image(size_t n = 0) const { return images.at(n); }
};

// Runs `step` with these flags (1 thread unless they say otherwise), --pfm into the scratch
// folder; timed: --repeat runs + 1, the first render the warm-up, the median of the others.
Run run(const std::string& step, std::vector<std::string> flags, bool timed = false) {
    if (std::find(flags.begin(), flags.end(), "--threads") == flags.end()) {
        flags.insert(flags.end(), {"--threads", "1"});
    }
    const std::string out = scratch().path("out");
    flags.insert(flags.end(), {"--pfm", "--out", out});
    if (timed) flags.insert(flags.end(), {"--repeat", std::to_string(runs + 1)});
    Run result;
    result.result = run_step(step, flags, 3600);
    if (result.result.status != 0 || result.result.summaries.empty()) {
        throw std::runtime_error(result.result.command() + " failed (status " +
                                 std::to_string(result.result.status) + "): " +
                                 result.result.err);
    }
    for (const Summary& line : result.result.summaries) {
        result.images.push_back(read_pfm(step_output(out, step, line.at("view"), "pfm")));
    }
    return result;
}

std::vector<std::string> operator+(std::vector<std::string> a, const std::vector<std::string>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
}

// A volume as a raw file in the scratch folder: the flags that load it.
std::vector<std::string> volume_flags(const Volume& volume, const std::string& name) {
    return write_raw_volume(volume, scratch().path(name + ".raw"));
}

// A transfer function file in the scratch folder: the --tf flag naming it.
std::vector<std::string> tf_flags(const std::string& text, const std::string& name) {
    const std::string path = scratch().path(name + ".tf");
    std::ofstream(path) << text;
    return {"--tf", path};
}

// "FROM TO constant R G B A\n": one range of a .tf file.
std::string tf_range(int from, int to, double r, double g, double b, double a) {
    return text_of("%d %d constant %.9g %.9g %.9g %.9g\n", from, to, r, g, b, a);
}

// The traced ray's numbers come from its records (the sidecar beside its ray picture,
// PixelTrace::records), never from the printed lines.

// Step 05's crossing record (kind hit: n and fraction, "hit at A + F") in samples along the
// ray, or a hit at the first sample (n = 0).
bool traced_t_hit(const PixelTrace& trace, double& t_hit) {
    for (const TraceRecord& record : trace.records) {
        if (record.kind == TraceKind::hit && record.has("n") && record.has("fraction")) {
            t_hit = record.number("n", 0) + record.number("fraction", 0);
            return true;
        }
    }
    if (!trace.records.empty()) {
        const TraceRecord& first = trace.records[0];
        if (first.kind == TraceKind::sample && first.hit && first.number("n", -1) == 0) {
            t_hit = 0;
            return true;
        }
    }
    return false;
}

// The lit steps' shade record: the gradient at the hit.
bool traced_gradient(const PixelTrace& trace, double g[3]) {
    for (const TraceRecord& record : trace.records) {
        if (record.kind == TraceKind::shade && record.has("gradient.i") &&
            record.has("gradient.j") && record.has("gradient.k")) {
            g[0] = record.number("gradient.i", 0);
            g[1] = record.number("gradient.j", 0);
            g[2] = record.number("gradient.k", 0);
            return true;
        }
    }
    return false;
}

// The transparency after the traced ray's last record that gives one (T).
double traced_transparency(const Run& run) {
    double t = -1;
    for (const PixelTrace& trace : run.result.traces) {
        for (const TraceRecord& record : trace.records) t = record.number("T", t);
    }
    return t;
}

std::vector<std::string> debug_pixel(int x, int y) {
    return {"--debug-pixel", text_of("%d,%d", x, y)};
}

// --- 1. First-hit depth against analytic surfaces ---------------------------------------

// An ellipsoid turned by `tilt` about the j axis; a sphere when its semi-axes are equal.
// Value f = 400 + 100 * s * (1 - |q|), q = the point in the ellipsoid's frame divided by the
// semi-axes (|q| = 1 on the surface) and s the shortest semi-axis: for a sphere of radius R
// f = 400 + 100 (R - |p - c|), shared/numerics.md's sphere. Positions in physical units.
struct Ellipsoid {
    std::string name;
    double ci, cj, ck;    // centre
    double a, b, c;       // semi-axes along the ellipsoid's own i, j, k
    double tilt;          // radians, about j

    void q_of(double pi_, double pj, double pk, double q[3]) const {
        const double di = pi_ - ci, dj = pj - cj, dk = pk - ck;
        q[0] = (std::cos(tilt) * di + std::sin(tilt) * dk) / a;
        q[1] = dj / b;
        q[2] = (-std::sin(tilt) * di + std::cos(tilt) * dk) / c;
    }
    double value(double pi_, double pj, double pk) const {
        double q[3];
        q_of(pi_, pj, pk, q);
        const double size = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        return 400 + 100 * std::min({a, b, c}) * (1 - size);
    }
};

// CThead's grid and spacing, the shape sampled at voxel centres (index times spacing) and
// rounded to int16.
Volume shape_volume(const Ellipsoid& shape) {
    Volume volume;
    volume.nx = cthead_nx, volume.ny = cthead_ny, volume.nz = cthead_nz;
    volume.sx = cthead_sx, volume.sy = cthead_sy, volume.sz = cthead_sz;
    volume.name = shape.name;
    resize_dense(volume);
    for (int k = 0; k < volume.nz; ++k)
        for (int j = 0; j < volume.ny; ++j)
            for (int i = 0; i < volume.nx; ++i) {
                const double v = shape.value(i * volume.sx, j * volume.sy, k * volume.sz);
                volume.data[volume.index(i, j, k)] =
                    int16_t(std::clamp(std::round(v), -32768.0, 32767.0));
            }
    update_range(volume);
    return volume;
}

// Where the top-view ray through pixel (x, y) enters the shape, in samples along the ray
// (k, fractional); `inside` = how deep the ray passes: min |q| along it (0 = through the
// centre, 1 = grazing).
struct Analytic {
    bool hit = false;
    double t = 0;
    double closest = 0;
};

Analytic analytic_top(const Volume& volume, const Ellipsoid& shape, int x, int y) {
    // q(z) = A + B z along the ray (x sx, y sy, z): solve |q|^2 = 1 for the first z.
    double A[3], Q1[3], B[3];
    shape.q_of(x * volume.sx, y * volume.sy, 0, A);
    shape.q_of(x * volume.sx, y * volume.sy, 1, Q1);
    for (int n = 0; n < 3; ++n) B[n] = Q1[n] - A[n];
    const double bb = B[0] * B[0] + B[1] * B[1] + B[2] * B[2];
    const double ab = A[0] * B[0] + A[1] * B[1] + A[2] * B[2];
    const double aa = A[0] * A[0] + A[1] * A[1] + A[2] * A[2];
    Analytic result;
    result.closest = std::sqrt(std::max(0.0, aa - ab * ab / bb));
    const double disc = ab * ab - bb * (aa - 1);
    if (disc < 0) return result;  // never tested with a negative root: grazing rays miss
    result.hit = true;
    result.t = (-ab - std::sqrt(disc)) / bb / volume.sz;
    return result;
}

struct DepthHit {
    bool found = false;
    double t = 0;  // samples (voxels) along the ray
};

// The shape sampled at voxel centres as shape_volume does, but with slices h voxels apart
// along k: what a scanner with thinner slices would give (h = 1: shape_volume itself).
Volume finer_shape_volume(const Ellipsoid& shape, double h) {
    Volume volume;
    volume.nx = cthead_nx, volume.ny = cthead_ny;
    volume.nz = int(std::lround((cthead_nz - 1) / h)) + 1;
    volume.sx = cthead_sx, volume.sy = cthead_sy, volume.sz = cthead_sz * h;
    volume.name = shape.name;
    resize_dense(volume);
    for (int k = 0; k < volume.nz; ++k)
        for (int j = 0; j < volume.ny; ++j)
            for (int i = 0; i < volume.nx; ++i) {
                const double v = shape.value(i * volume.sx, j * volume.sy, k * volume.sz);
                volume.data[volume.index(i, j, k)] =
                    int16_t(std::clamp(std::round(v), -32768.0, 32767.0));
            }
    update_range(volume);
    return volume;
}

// Step 03's picture is 1 - t/N for a hit at sample t of N, 0 for a miss: its depth map.
std::vector<DepthHit> depth_from_picture(const Image& image, int ray_length, double h) {
    std::vector<DepthHit> hits;
    for (const Rgb& p : image.pixels) {
        hits.push_back({p.r > 0, std::round((1.0 - p.r) * ray_length) * h});
    }
    return hits;
}

void depth_study() {
    std::printf("depth: first hit against an analytic sphere and ellipsoid (top view, "
                "256x256x113, spacing 1:1:2)\n");
    const Ellipsoid shapes[] = {
        {"sphere", 127.6, 128.3, 112.7, 80, 80, 80, 0},
        {"ellipsoid", 128.4, 127.3, 113.3, 100, 70, 45, 30 * pi / 180},
    };
    constexpr int traced_every = 16;  // step 05's depth: traced rays, every 16th pixel
    const std::vector<std::string> top = {"--view", "top", "--threshold",
                                          std::to_string(surface_threshold)};
    for (const Ellipsoid& shape : shapes) {
        const Volume volume = shape_volume(shape);
        const View view = make_view(volume, ViewAxis::top);
        std::vector<Analytic> truth;
        for (int y = 0; y < view.height; ++y)
            for (int x = 0; x < view.width; ++x) {
                truth.push_back(analytic_top(volume, shape, x, y));
            }
        // Error over the rays that pass well inside (min |q| <= 0.9): near grazing the depth
        // error of any sampling grows without bound and says little. `only`: the rays with
        // a figure (empty: all).
        auto record_depth = [&](const std::string& method, const std::string& parameter,
                                const std::vector<DepthHit>& hits, const std::vector<bool>& only,
                                double ms, uint64_t samples, const std::string& unit) {
            double sum = 0, largest = 0;
            int measured = 0, disagree = 0;
            for (size_t n = 0; n < truth.size(); ++n) {
                if (!only.empty() && !only[n]) continue;
                if (truth[n].hit && truth[n].closest < 0.98 && !hits[n].found) ++disagree;
                if (!truth[n].hit && hits[n].found) ++disagree;
                if (!truth[n].hit || !hits[n].found || truth[n].closest > 0.9) continue;
                const double error = std::abs(hits[n].t - truth[n].t);
                sum += error;
                largest = std::max(largest, error);
                ++measured;
            }
            record({"depth", shape.name + ": " + method, parameter, ms, sum / measured, largest,
                    unit, samples});
            if (disagree > 0) std::printf("    (%d rays hit or miss unlike the surface)\n",
                                          disagree);
        };
        const std::string unit = "voxels (mean |t - t*|, max)";
        const std::vector<std::string> flags = volume_flags(volume, shape.name);
        const Run nearest = run("03_depth_shading", flags + top, true);
        record_depth("nearest sample (step 03)", "1",
                     depth_from_picture(nearest.image(), view.ray_length, 1), {}, nearest.ms(),
                     nearest.count("samples"), unit);
        // Thinner slices: the same shape sampled every h voxels along the ray, rendered by
        // step 03 (its depth t counts the thin slices: t * h voxels).
        for (const double h : {0.5, 0.25, 0.125}) {
            const Volume finer = finer_shape_volume(shape, h);
            const Run thin = run("03_depth_shading",
                                 volume_flags(finer, shape.name + "_finer") + top, true);
            record_depth("nearest, finer steps", step_text(h),
                         depth_from_picture(thin.image(), finer.nz, h), {}, thin.ms(),
                         thin.count("samples"), unit);
        }
        std::remove(scratch().path(shape.name + "_finer.raw").c_str());
        // Step 05: its time from a whole render; its depth from the traces of the rays on a
        // grid of every 16th pixel that pass well inside.
        const Run interpolated = run("05_interpolated_hits", flags + top, true);
        std::vector<DepthHit> hits(truth.size());
        std::vector<bool> traced(truth.size(), false);
        for (int y = traced_every / 2; y < view.height; y += traced_every)
            for (int x = traced_every / 2; x < view.width; x += traced_every) {
                const size_t n = size_t(y) * view.width + x;
                if (!truth[n].hit || truth[n].closest > 0.9) continue;
                const Run ray = run("05_interpolated_hits", flags + top + debug_pixel(x, y));
                if (ray.result.traces.size() != 1) continue;
                double t = 0;
                hits[n] = {traced_t_hit(ray.result.traces[0], t), t};
                traced[n] = true;
            }
        record_depth("interpolated (step 05)", "1", hits, traced, interpolated.ms(),
                     interpolated.count("samples"),
                     text_of("voxels (mean |t - t*|, max), traced rays every %d pixels",
                            traced_every));
    }
}

// --- 2. Compositing: step size and opacity correction -----------------------------------

// The flags that load the phantom: the built-in one, or with --quick a small one as a raw
// file. Its spacing, for the stretched copies of the step study.
struct Phantom {
    std::vector<std::string> flags;
    double sx = cthead_sx, sy = cthead_sy, sz = cthead_sz;
};

const Phantom& phantom_volume() {
    static const Phantom phantom = [] {
        Phantom p;
        if (!quick) {
            p.flags = {"--volume", "phantom"};
            return p;
        }
        Volume small = make_phantom_sized(quick_dims[0], quick_dims[1], quick_dims[2]);
        // CThead's spacing, so that a step in physical units is the same fraction of a voxel
        // as on the full phantom (and the stretched copies stay within the steps' limit of
        // samples per ray).
        small.sx = cthead_sx, small.sy = cthead_sy, small.sz = cthead_sz;
        p.flags = volume_flags(small, "phantom_quick");
        p.sx = small.sx, p.sy = small.sy, p.sz = small.sz;
        return p;
    }();
    return phantom;
}

// The rows called "step 10" are timed on step 10 itself: step 11 gives the same pixels with
// less work (it leaps over empty bricks), so its times would not be step 10's.
constexpr const char* lit_step = "10_opacity_correction";

void step_study() {
    std::printf("step: step 10 (lit) on the phantom, front view, step 4 .. 1/8 voxel, no early "
                "termination, against step %s\n", step_text(reference_step).c_str());
    const int cores = int(std::max(1u, std::thread::hardware_concurrency()));
    const std::vector<std::string> front = {"--view", "front", "--ert", "0"};
    // Steps finer than --step allows (1/4 voxel): the same phantom with every spacing
    // `scale` times larger, rendered at step 1/4 (1/(4 scale) of its voxel), and, with
    // correction, a table whose opacities hold for 1/scale of the thickness,
    // a' = 1 - (1 - a)^(1/scale): a sample 1/(4 scale) voxel long is then corrected to
    // 1 - (1 - a)^(1/(4 scale)), as in the phantom itself at that step. Without correction
    // each sample takes the table's a as it is, as in the phantom. The gradients are `scale`
    // times smaller and point the same way: the light is the same.
    constexpr double min_step = 0.25;  // step 10's --step limit, physical units
    auto render_at = [&](double step, bool correction, int threads, bool timed) {
        const Phantom& phantom = phantom_volume();
        std::vector<std::string> flags = phantom.flags + front;
        double scale = 1;
        if (step < min_step) {
            scale = min_step / step;
            std::string thinned;
            for (const TfRange& range : classic_transfer_function().ranges) {
                const double a = range.start.a;
                thinned += tf_range(range.from, range.to, range.start.r, range.start.g,
                                    range.start.b,
                                    correction ? -std::expm1(std::log1p(-a) / scale) : a);
            }
            flags = flags + tf_flags(thinned, "thinned") +
                    std::vector<std::string>{"--spacing",
                                             text_of("%g,%g,%g", scale * phantom.sx,
                                                    scale * phantom.sy, scale * phantom.sz)};
        }
        flags = flags + std::vector<std::string>{"--step", text_of("%g", step * scale),
                                                 "--threads", std::to_string(threads)};
        if (!correction) flags.push_back("--no-correction");
        return run(lit_step, flags, timed);
    };
    const Timer timer;
    const Run reference = render_at(reference_step, true, cores, false);
    std::printf("  reference: step %s, %.1f Msamples, %.1f s on %d threads\n",
                step_text(reference_step).c_str(), reference.count("samples") / 1e6,
                timer.ms() / 1000, cores);
    const Run half = render_at(2 * reference_step, true, cores, false);
    const ImageError half_error = image_error(half.image(), reference.image());
    std::printf("  the reference against step %s: RMSE %.3f, max %.3f (8-bit units)\n",
                step_text(2 * reference_step).c_str(), half_error.rmse, half_error.max);
    Point convergence;
    convergence.study = "step-reference";
    convergence.method = "step " + step_text(2 * reference_step) + " against step " +
                         step_text(reference_step);
    convergence.parameter = step_text(2 * reference_step);
    convergence.error = half_error.rmse;
    convergence.max_error = half_error.max;
    convergence.error_unit = "8-bit (RMSE, max)";
    record(convergence);

    for (const double step : {4.0, 2.0, 1.0, 0.5, 0.25, 0.125}) {
        for (const bool correction : {true, false}) {
            const Run image = render_at(step, correction, 1, true);
            const ImageError error = image_error(image.image(), reference.image());
            record({"step", correction ? "opacity corrected" : "not corrected", step_text(step),
                    image.ms(), error.rmse, error.max, "8-bit (RMSE, max)",
                    image.count("samples")});
        }
    }
}

// --- 3. Early ray termination ------------------------------------------------------------

void ert_study() {
    std::printf("ert: early ray termination thresholds, top view of the phantom, 1 thread\n");
    const std::vector<std::string> top =
        phantom_volume().flags + std::vector<std::string>{"--view", "top"};
    Image full07, full08;
    for (const double ert : {0.0, 0.001, 0.01, 0.05, 0.1}) {
        const std::vector<std::string> flags =
            top + std::vector<std::string>{"--ert", text_of("%g", ert)};
        const Run f2b = run("08_compositing_order", flags, true);
        if (ert == 0) full07 = f2b.image();
        const ImageError error = image_error(f2b.image(), full07);
        record({"ert", "step 08 front to back", text_of("%g", ert), f2b.ms(), error.rmse,
                error.max, "8-bit, added (against T* = 0)", f2b.count("samples")});
        const Run lit = run(lit_step, flags, true);
        if (ert == 0) full08 = lit.image();
        const ImageError error08 = image_error(lit.image(), full08);
        record({"ert", "step 10 lit, step 1", text_of("%g", ert), lit.ms(), error08.rmse,
                error08.max, "8-bit, added (against T* = 0)", lit.count("samples")});
    }
    // Back to front cannot stop early: every sample, every time.
    const Run b2f = run("08_compositing_order",
                        top + std::vector<std::string>{"--order", "b2f"}, true);
    const ImageError error = image_error(b2f.image(), full07);
    record({"ert", "step 08 back to front", "-", b2f.ms(), error.rmse, error.max,
            "8-bit (against front to back, T* = 0)", b2f.count("samples")});
}

// --- Jitter: step size x jitter x interpolation on the free camera (step 17) -------------

// The difference image - reference (every channel), blurred by a box of (2 * radius + 1)^2
// pixels: what is left is the low-frequency error the eye sees as bands and rings; fine noise
// averages away.
ImageError low_pass_error(const Image& image, const Image& reference, int radius) {
    double sum = 0, largest = 0;
    long long count = 0;
    for (int y = radius; y + radius < image.height; ++y) {
        for (int x = radius; x + radius < image.width; ++x) {
            double d[3] = {0, 0, 0};
            for (int dy = -radius; dy <= radius; ++dy) {
                for (int dx = -radius; dx <= radius; ++dx) {
                    const Rgb& a = image.at(x + dx, y + dy);
                    const Rgb& b = reference.at(x + dx, y + dy);
                    d[0] += double(a.r) - b.r;
                    d[1] += double(a.g) - b.g;
                    d[2] += double(a.b) - b.b;
                }
            }
            const double box = (2 * radius + 1) * (2 * radius + 1);
            for (const double channel : d) {
                sum += (channel / box) * (channel / box);
                largest = std::max(largest, std::abs(channel / box));
            }
            count += 3;
        }
    }
    if (count == 0) return {};
    return {std::sqrt(sum / count) * byte_units, largest * byte_units};
}

constexpr const char* jitter_step = "17_blue_noise";
constexpr int jitter_blur_radius = 2;  // pixels: the low-pass box is 5 x 5

void jitter_study() {
    std::printf("jitter: step 17 on the phantom, the default camera at 256x256, no early "
                "termination, steps 4 .. 1/2 x jitter none/hash/blue x interpolation "
                "trilinear/nearest, against step 1/4 without jitter, trilinear\n");
    const int cores = int(std::max(1u, std::thread::hardware_concurrency()));
    const std::vector<std::string> camera =
        phantom_volume().flags +
        std::vector<std::string>{"--size", quick ? "64x64" : "256x256", "--zoom",
                                 quick ? "1" : "0.5", "--ert", "0"};
    const Run reference = run(jitter_step, camera + std::vector<std::string>{
                                  "--step", "0.25", "--jitter", "none", "--interpolation",
                                  "trilinear", "--threads", std::to_string(cores)});
    for (const double step : {4.0, 2.0, 1.0, 0.5}) {
        for (const char* interpolation : {"trilinear", "nearest"}) {
            for (const char* jitter : {"none", "hash", "blue"}) {
                const Run image = run(jitter_step, camera + std::vector<std::string>{
                                          "--step", text_of("%g", step), "--jitter", jitter,
                                          "--interpolation", interpolation}, true);
                const std::string method = text_of("%s, %s", jitter, interpolation);
                const ImageError error = image_error(image.image(), reference.image());
                record({"jitter", method, step_text(step), image.ms(), error.rmse, error.max,
                        "8-bit (RMSE, max) vs step 1/4", image.count("samples")});
                const ImageError low = low_pass_error(image.image(), reference.image(),
                                                      jitter_blur_radius);
                record({"jitter-lowpass", method, step_text(step), image.ms(), low.rmse,
                        low.max, "8-bit, 5x5 box-blurred difference", image.count("samples")});
            }
        }
    }
}

// --- Shadows: what blocked light costs and what it adds (steps 22-24) ----------------------

// Step 24 has every kind of blocked light (--shadows ray|volume|none, --ao on|off); step 23
// has shadow rays and the light volume, without ambient occlusion.
constexpr const char* shadows_step = "24_ambient_occlusion";
constexpr const char* light_volume_step = "23_light_volume";

void shadows_study() {
    std::printf("shadows: steps 23 and 24 on the phantom, the default camera at 256x256: "
                "each kind of blocked light against step 15's light; T_light by shadow rays "
                "and by the light-transmittance volume at steps 4 .. 1/2 (step 23) against "
                "shadow rays at step 1/4\n");
    const int cores = int(std::max(1u, std::thread::hardware_concurrency()));
    const std::vector<std::string> camera =
        phantom_volume().flags +
        std::vector<std::string>{"--size", quick ? "64x64" : "256x256", "--zoom",
                                 quick ? "1" : "0.5"};
    // What each adds: the difference from --shadows none --ao off (step 15's light, the same
    // picture as step 15's), at the default step; the cost in time and samples read (the
    // shadow rays', the occlusion probes' and the sweep's reads count as samples).
    const std::string added = "8-bit (RMSE, max) vs step 15's light";
    const Run open = run(shadows_step, camera + std::vector<std::string>{
                             "--shadows", "none", "--ao", "off"}, true);
    record({"shadows", "none, ao off (step 15's light)", "1", open.ms(), 0, 0, added,
            open.count("samples")});
    for (const char* ao : {"off", "on"}) {
        for (const char* shadows : {"ray", "volume", "none"}) {
            if (std::string(shadows) == "none" && std::string(ao) == "off") continue;
            const Run image = run(shadows_step, camera + std::vector<std::string>{
                                      "--shadows", shadows, "--ao", ao}, true);
            const ImageError error = image_error(image.image(), open.image());
            record({"shadows", text_of("%s, ao %s", shadows, ao), "1", image.ms(), error.rmse,
                    error.max, added, image.count("samples")});
        }
    }
    // Error at equal time: T_light by shadow rays and by the light volume (ambient occlusion
    // off), the camera's step and the shadow rays' the same, against shadow rays at step 1/4.
    // Both carry the camera's step error; "shadows-volume" is the light volume's own error,
    // against the shadow rays at the same step.
    const std::vector<std::string>& no_ao = camera;  // step 23 has no ambient occlusion
    const Run reference = run(light_volume_step, no_ao + std::vector<std::string>{
                                  "--step", "0.25", "--shadows", "ray", "--threads",
                                  std::to_string(cores)});
    for (const double step : {4.0, 2.0, 1.0, 0.5}) {
        const std::vector<std::string> at_step = no_ao + std::vector<std::string>{
                                                     "--step", text_of("%g", step)};
        const Run rays = run(light_volume_step, at_step + std::vector<std::string>{
                                 "--shadows", "ray"}, true);
        const Run swept = run(light_volume_step, at_step + std::vector<std::string>{
                                  "--shadows", "volume"}, true);
        for (const Run* image : {&rays, &swept}) {
            const ImageError error = image_error(image->image(), reference.image());
            record({"shadows-error", image == &rays ? "shadow rays" : "light volume",
                    step_text(step), image->ms(), error.rmse, error.max,
                    "8-bit (RMSE, max) vs shadow rays at step 1/4", image->count("samples")});
        }
        const ImageError own = image_error(swept.image(), rays.image());
        record({"shadows-volume", "light volume vs shadow rays", step_text(step), swept.ms(),
                own.rmse, own.max, "8-bit (RMSE, max) vs shadow rays, same step",
                swept.count("samples")});
    }
}

// --- Shear-warp: what step 38's factorisation costs in quality, and what it saves; and step
// 41's quantised normals, the one later shear-warp trick that changes the picture (timed as
// step 42 renders them, each voxel's index kept: step 41's pictures bit for bit) -----------

constexpr const char* ray_caster_step = "30_speed_baseline";  // the reference: rays, step 1
constexpr const char* fastest_ray_caster = "34_fine_bricks";  // the same pictures, faster
constexpr const char* shear_warp_step = "38_shear_warp";
constexpr const char* quantised_normals_step = "42_normal_volume";  // lit: rounded normals

void shear_warp_study() {
    std::printf("shear-warp: step 38 against step 30 (and step 34's time) on the phantom at "
                "spacing 1,1,1, unlit composite: along k at one pixel per voxel, and at "
                "angles (case c's view at 512x512, 45 degrees along two axes); then lit, "
                "along k and at case c's angle (and step 42's quantised normals)\n");
    const std::vector<std::string> lit_phantom =
        phantom_volume().flags + std::vector<std::string>{"--spacing", "1,1,1"};
    const std::vector<std::string> phantom = lit_phantom + std::vector<std::string>{"--unlit"};
    const int side = quick ? 64 : 256, oblique = quick ? 128 : 512;
    const double zoom = 1.356 * oblique / 512;  // case c: the bounding sphere fills the image
    struct View {
        const char* name;
        std::vector<std::string> flags;
    };
    const std::vector<View> views = {
        {"top", {"--azimuth", "180", "--elevation", "90", "--zoom", "1", "--size",
                 text_of("%dx%d", side, side)}},
        {"az30 el20", {"--azimuth", "30", "--elevation", "20", "--zoom", text_of("%.4f", zoom),
                       "--size", text_of("%dx%d", oblique, oblique)}},
        {"az45 el45", {"--azimuth", "45", "--elevation", "45", "--zoom", text_of("%.4f", zoom),
                       "--size", text_of("%dx%d", oblique, oblique)}},
    };
    const std::string unit = "8-bit (RMSE, max) vs step 30";
    struct Lit {  // the views again, lit: step 42's light comes from its quantised normals
        const View& view;
        bool lit;
    };
    const std::vector<Lit> runs = {{views[0], false}, {views[1], false}, {views[2], false},
                                   {views[0], true},  {views[1], true}};
    for (const Lit& lit : runs) {
        const std::string name = std::string(lit.view.name) + (lit.lit ? " lit" : "");
        const std::vector<std::string> flags = (lit.lit ? lit_phantom : phantom) + lit.view.flags;
        const View view = {name.c_str(), lit.view.flags};
        const Run rays = run(ray_caster_step, flags, true);
        const Run fine = run(fastest_ray_caster, flags, true);
        const Run sheared = run(shear_warp_step, flags, true);
        record({"shear-warp", "step 30 (ray casting)", view.name, rays.ms(), 0, 0, unit,
                rays.count("samples")});
        const ImageError same = image_error(fine.image(), rays.image());
        record({"shear-warp", "step 34 (ray casting, fastest)", view.name, fine.ms(), same.rmse,
                same.max, unit, fine.count("samples")});
        const ImageError error = image_error(sheared.image(), rays.image());
        record({"shear-warp", "step 38 (shear-warp)", view.name, sheared.ms(), error.rmse,
                error.max, unit, sheared.count("samples")});
        if (!lit.lit) continue;  // unlit, step 42 renders step 38's picture
        const Run rounded = run(quantised_normals_step, flags, true);
        const ImageError rounding = image_error(rounded.image(), rays.image());
        record({"shear-warp", "step 42 (quantised normals)", view.name, rounded.ms(),
                rounding.rmse, rounding.max, unit, rounded.count("samples")});
    }
}

// --- 4. Subnormal arithmetic --------------------------------------------------------------

// ns per multiply over an array of `start` values times 0.9, repeated: with a subnormal
// start the products stay subnormal (slow path); with `flush` set, flush-to-zero and
// denormals-are-zero make them 0.
template <class Real>
double ns_per_multiply(Real start, bool flush) {
#if defined(__SSE__)
    const unsigned saved = _mm_getcsr();
    if (flush) _mm_setcsr(saved | 0x8040);  // FTZ (bit 15) and DAZ (bit 6)
#else
    if (flush) return 0;
#endif
    constexpr int length = 4096, passes = 400;
    std::vector<Real> in(length, start), out(length);
    const Real factor = Real(0.9);
    const double ms = median_ms([&] {
        for (int pass = 0; pass < passes; ++pass) {
            for (int n = 0; n < length; ++n) out[n] = in[n] * factor;
            asm volatile("" : : "r"(out.data()) : "memory");  // keep every pass
        }
    });
#if defined(__SSE__)
    _mm_setcsr(saved);
#endif
    return ms * 1e6 / (double(length) * passes);
}

struct SubnormalCost {
    double float_normal, float_subnormal, float_flushed;
    double double_normal, double_subnormal, double_flushed;
};

SubnormalCost subnormal_cost() {
    SubnormalCost cost;
    cost.float_normal = ns_per_multiply<float>(1e-3f, false);
    cost.float_subnormal = ns_per_multiply<float>(1e-40f, false);
    cost.float_flushed = ns_per_multiply<float>(1e-40f, true);
    cost.double_normal = ns_per_multiply<double>(1e-3, false);
    cost.double_subnormal = ns_per_multiply<double>(1e-310, false);
    cost.double_flushed = ns_per_multiply<double>(1e-310, true);
    return cost;
}

// A float front-to-back ray through `count` samples of opacity `alpha`, white: ns per
// sample, and how many samples of it had a subnormal T.
struct FloatRay {
    double ns_per_sample = 0;
    int subnormal_samples = 0;
    float transparency = 0;
};

FloatRay float_ray(float alpha, int count, double stop_below, bool flush) {
#if defined(__SSE__)
    const unsigned saved = _mm_getcsr();
    if (flush) _mm_setcsr(saved | 0x8040);
#endif
    constexpr int rays = 2000;
    FloatRay result;
    volatile float sink = 0;
    int visited = 0;
    const double ms = median_ms([&] {
        visited = 0;
        result.subnormal_samples = 0;
        for (int ray = 0; ray < rays; ++ray) {
            float colour = 0, transparency = 1;
            for (int n = 0; n < count; ++n) {
                colour += transparency * alpha;
                transparency *= 1.0f - alpha;
                ++visited;
                if (ray == 0 && std::fpclassify(transparency) == FP_SUBNORMAL) {
                    ++result.subnormal_samples;
                }
                if (transparency < stop_below) break;
            }
            sink = colour;
            result.transparency = transparency;
        }
    });
    (void)sink;
#if defined(__SSE__)
    _mm_setcsr(saved);
#endif
    result.ns_per_sample = ms * 1e6 / visited;
    return result;
}

// --- 5. The stiff cases of the tests ------------------------------------------------------

struct Case {
    std::string name, test, analytic, measured;
    double abs_error = not_applicable, rel_error = not_applicable;
};
std::vector<Case> cases;

void add_case(const std::string& name, const std::string& test, double analytic,
              double measured, const char* number = "%.9g") {
    Case c;
    c.name = name;
    c.test = test;
    c.analytic = text_of(number, analytic);
    c.measured = text_of(number, measured);
    c.abs_error = std::abs(measured - analytic);
    c.rel_error = analytic != 0 ? c.abs_error / std::abs(analytic) : not_applicable;
    cases.push_back(c);
}

// A column of voxels, 1 x 1 x n: the top view's one pixel is one ray.
Volume column(const std::vector<int16_t>& values, double spacing = 1) {
    Volume volume;
    volume.nx = volume.ny = 1;
    volume.nz = int(values.size());
    volume.sz = spacing;
    volume.data = values;
    volume.name = "column";
    update_range(volume);
    return volume;
}

// The top view of a column rendered by `step` with the transfer function `tf` ("" = the
// default), these flags and, with trace, the trace of its ray.
Run column_run(const std::string& step, const Volume& volume, const std::string& tf,
               const std::vector<std::string>& flags, bool trace = false) {
    std::vector<std::string> all = volume_flags(volume, "column") +
                                   std::vector<std::string>{"--view", "top"} + flags;
    if (!tf.empty()) all = all + tf_flags(tf, "column");
    if (trace) all = all + debug_pixel(0, 0);
    return run(step, all);
}

void compositing_cases() {
    const char* test_c = "test_compositing.cpp";
    const std::string f2b = "08_compositing_order", b2f = "07_back_to_front";
    const std::string lit = "10_opacity_correction";
    const std::vector<std::string> no_ert = {"--ert", "0"};
    // Skin, skin, bone: the closed form of numerics.md.
    {
        const Volume volume = column({0, 0, 1000});
        const double a = 0.12, bone = 0.8, skin[3] = {1.0, 0.79, 0.6};
        const Run front = column_run(f2b, volume, "", no_ert, true);
        const Run back = column_run(b2f, volume, "", {});
        const Rgb f = front.image().at(0, 0), b = back.image().at(0, 0);
        const double f2b_rgb[3] = {f.r, f.g, f.b}, b2f_rgb[3] = {b.r, b.g, b.b};
        const char* channel[3] = {"red", "green", "blue"};
        for (int n = 0; n < 3; ++n) {
            const double exact = a * skin[n] + (1 - a) * a * skin[n] + (1 - a) * (1 - a) * bone;
            add_case(std::string("skin, skin, bone: C ") + channel[n] + ", front to back",
                     test_c, exact, f2b_rgb[n]);
            add_case(std::string("skin, skin, bone: C ") + channel[n] + ", back to front",
                     test_c, exact, b2f_rgb[n]);
        }
        add_case("skin, skin, bone: T (trace, 6 digits)", test_c, (1 - a) * (1 - a) * (1 - bone),
                 traced_transparency(front));
    }
    // Homogeneous slabs: T = (1 - a)^n with a as stored (a float).
    struct Slab {
        double a;
        int n;
    };
    for (const Slab slab : {Slab{0.12, 10}, Slab{0.12, 113}, Slab{1e-7, 1000000}}) {
        const std::string tf = tf_range(100, 101, 1, 1, 1, slab.a);
        const double a = double(float(slab.a));
        const double exact_t = std::exp(slab.n * std::log1p(-a));
        const Volume volume = column(std::vector<int16_t>(slab.n, 100));
        const bool trace = slab.n < 1000;  // a trace line per sample
        const Run front = column_run(f2b, volume, tf, no_ert, trace);
        const std::string name = text_of("slab a = %g, n = %d: ", slab.a, slab.n);
        if (trace) {
            add_case(name + "T, front to back (trace, 6 digits)", test_c, exact_t,
                     traced_transparency(front));
        }
        add_case(name + "A = 1 - T, front to back (float out)", test_c,
                 -std::expm1(slab.n * std::log1p(-a)), front.image().at(0, 0).r);
        add_case(name + "A, back to front (float out)", test_c, 1 - exact_t,
                 column_run(b2f, volume, tf, {}).image().at(0, 0).r);
        float t_float = 1;  // the same product kept in float
        for (int n = 0; n < slab.n; ++n) t_float *= 1.0f - float(slab.a);
        add_case(name + "T kept in float", "study variant", exact_t, t_float);
    }
    // Bone, a = 0.8, 1000 samples: where float T turns subnormal, then 0; where double stops.
    {
        float t_float = 1;
        int first_subnormal = 0, first_zero = 0;
        for (int n = 1; n <= 200 && first_zero == 0; ++n) {
            t_float *= 0.2f;
            if (first_subnormal == 0 && std::fpclassify(t_float) == FP_SUBNORMAL) {
                first_subnormal = n;
            }
            if (t_float == 0) first_zero = n;
        }
        const double a = double(0.8f);
        add_case("a = 0.8: first n with float T = 0.2^n subnormal", test_c,
                 std::ceil(std::log(double(FLT_MIN)) / std::log1p(-a)), first_subnormal, "%.0f");
        add_case("a = 0.8: first n with float T = 0", "study variant",
                 std::ceil(std::log(std::ldexp(1.0, -150)) / std::log1p(-a)), first_zero,
                 "%.0f");
        const std::string tf = tf_range(100, 101, 1, 1, 1, 0.8);
        const Volume volume = column(std::vector<int16_t>(1000, 100));
        const Run ray = column_run(f2b, volume, tf, no_ert);
        add_case("a = 0.8, n = 1000, T* = 0: samples until T < 1e-300", test_c,
                 std::ceil(std::log(1e-300) / std::log1p(-a)), double(ray.count("samples")),
                 "%.0f");
        add_case("a = 0.8, n = 1000, T* = 0: C", test_c, 1.0, ray.image().at(0, 0).r);
        const Run stopped = column_run(f2b, volume, tf, {"--ert", "0.01"});
        add_case("a = 0.8, T* = 0.01: samples visited", test_c, 3,
                 double(stopped.count("samples")), "%.0f");
        add_case("a = 0.8, T* = 0.01: C (error <= T* max c = 0.01)", test_c, 1.0,
                 stopped.image().at(0, 0).r);
        add_case("a = 0.8, n = 1000: C back to front", test_c, 1.0,
                 column_run(b2f, volume, tf, {}).image().at(0, 0).r);
    }
    // Opacity 1 hides everything behind; opacity 0 adds nothing.
    {
        const std::string tf = tf_range(100, 101, 1, 0, 0, 1.0) + tf_range(200, 201, 0, 1, 0, 0.5);
        const Volume volume = column({100, 200, 200, 100});
        const Run ray = column_run(f2b, volume, tf, no_ert);
        add_case("opacity 1 in front: C red", test_c, 1.0, ray.image().at(0, 0).r);
        add_case("opacity 1 in front: C green (hidden)", test_c, 0.0, ray.image().at(0, 0).g);
        add_case("opacity 1 in front: samples visited", test_c, 1, double(ray.count("samples")),
                 "%.0f");
        const std::string clear = tf_range(1000, 1001, 1, 1, 1, 0.5);  // 100, 200: none
        const Run empty = column_run(f2b, volume, clear, no_ert);
        add_case("everything transparent: C (T = 1, black behind)", test_c, 0.0,
                 empty.image().at(0, 0).r);
    }
    // Extinction: alpha = 1 - exp(-kappa h), best -expm1(-kappa h).
    {
        const double kh = 1e-8;
        const long double exact = -std::expm1l(-(long double)kh);
        add_case("alpha at kappa h = 1e-8: -expm1 (double)", test_c, double(exact),
                 -std::expm1(-kh), "%.12g");
        add_case("alpha at kappa h = 1e-8: 1 - exp (double)", "study variant", double(exact),
                 1 - std::exp(-kh), "%.12g");
        add_case("alpha at kappa h = 1e-8: 1 - exp (float)", test_c, double(exact),
                 1.0f - std::exp(-float(kh)), "%.12g");
        add_case("T at kappa h = 3: first order 1 - kappa h", test_c, std::exp(-3.0), 1 - 3.0);
    }
    // Opacity correction over --step's range: step 10's stable form (one sample of depth
    // `ratio`, white, unlit: the picture is the corrected opacity) against the plain one.
    {
        const std::vector<float> alphas = {1e-7f, 0.12f, 0.5f, 0.8f, 0.999f};
        std::string tf;
        std::vector<int16_t> values;
        for (size_t n = 0; n < alphas.size(); ++n) {
            tf += tf_range(100 + int(n), 101 + int(n), 1, 1, 1, alphas[n]);
            values.push_back(int16_t(100 + n));
        }
        double stable = 0, plain_float = 0, plain_double = 0;
        std::string worst_float, worst_double;
        for (const double ratio : {0.25, 0.5, 1.0, 2.0, 4.0}) {
            Volume row;  // n x 1 x 1, depth `ratio`: one sample per ray at --step ratio
            row.nx = int(values.size());
            row.ny = row.nz = 1;
            row.sz = ratio;
            row.data = values;
            update_range(row);
            const Run corrected = run(
                lit, volume_flags(row, "row") + tf_flags(tf, "row") +
                         std::vector<std::string>{"--view", "top", "--unlit", "--ert", "0",
                                                  "--step", text_of("%g", ratio)});
            for (size_t n = 0; n < alphas.size(); ++n) {
                const float alpha = alphas[n];
                const long double exact = 1.0L - std::pow(1.0L - alpha, (long double)ratio);
                auto relative = [&](double value) {
                    return double(std::abs(value - exact) / exact);
                };
                stable = std::max(stable, relative(corrected.image().at(int(n), 0).r));
                const double f = relative(1.0f - std::pow(1.0f - alpha, float(ratio)));
                const double d = relative(1.0 - std::pow(1.0 - double(alpha), ratio));
                const std::string where = text_of("%g, %g", alpha, ratio);
                if (f > plain_float) plain_float = f, worst_float = where;
                if (d > plain_double) plain_double = d, worst_double = where;
            }
        }
        Case c;
        c.test = test_c;
        c.analytic = "1 - (1 - alpha)^ratio, long double";
        c.name = "opacity correction, step 10's picture of one corrected sample (float)";
        c.measured = "alpha 1e-7..0.999, ratio 0.25..4";
        c.rel_error = stable;
        cases.push_back(c);
        c.name = "opacity correction, 1 - pow(1 - alpha, ratio) in float";
        c.measured = "worst at alpha, ratio = " + worst_float;
        c.test = "study variant";
        c.rel_error = plain_float;
        cases.push_back(c);
        c.name = "opacity correction, 1 - pow(1 - alpha, ratio) in double";
        c.measured = "worst at alpha, ratio = " + worst_double;
        c.rel_error = plain_double;
        cases.push_back(c);
    }
    // A slab keeps its opacity at any step with correction, in 1- and 2-unit spacing.
    {
        const std::string tf = tf_range(100, 101, 1, 1, 1, 0.12);
        const double a = double(0.12f);
        double worst = 0;
        for (const double spacing : {1.0, 2.0}) {
            const Volume volume = column(std::vector<int16_t>(20, 100), spacing);
            const double exact = std::pow(1 - a, 20 * spacing);
            for (const double step : {0.25, 0.5, 1.0, 2.0, 4.0}) {
                const Run ray = column_run(lit, volume, tf,
                                           {"--ert", "0", "--unlit", "--step", text_of("%g", step)});
                const double t = 1.0 - ray.image().at(0, 0).r;  // white: C = 1 - T
                worst = std::max(worst, std::abs(t - exact) / exact);
            }
            if (spacing == 1) {
                const Run ray = column_run(lit, volume, tf,
                                           {"--ert", "0", "--unlit", "--step", "0.5",
                                            "--no-correction"});
                add_case("slab a = 0.12, 20 units, step 0.5 NOT corrected: T", test_c, exact,
                         1.0 - ray.image().at(0, 0).r);
            }
        }
        Case c;
        c.name = "slab a = 0.12, 20 units, steps 0.25..4, spacing 1 and 2: T, corrected";
        c.test = test_c;
        c.analytic = "(1 - a)^depth";
        c.measured = "worst of 10 (T = 1 - C, float picture)";
        c.rel_error = worst;
        cases.push_back(c);
    }
}

// The surface cases of test_steps.cpp: the ramp, the int16 extremes, a constant volume.
Volume make_volume(int nx, int ny, int nz, const std::function<double(int, int, int)>& value,
                   double sx = 1, double sy = 1, double sz = 1) {
    Volume volume;
    volume.nx = nx, volume.ny = ny, volume.nz = nz;
    volume.sx = sx, volume.sy = sy, volume.sz = sz;
    resize_dense(volume);
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                const double v = std::clamp(std::round(value(i, j, k)), -32768.0, 32767.0);
                volume.data[volume.index(i, j, k)] = int16_t(v);
            }
    update_range(volume);
    return volume;
}

void surface_cases() {
    const char* test_s = "test_steps.cpp";
    const std::string lit04 = "04_gradient_lighting", hit05 = "05_interpolated_hits";
    // Ramp f = 3i + 5j + 7k: gradients and crossings are exact.
    {
        double worst_gradient = 0;
        int traced = 0;
        for (const double s : {1.0, 2.0, 0.5}) {
            const Volume ramp = make_volume(9, 7, 5, [](int i, int j, int k) {
                return 3 * i + 5 * j + 7 * k - 60; }, 1, 1, s);
            for (const auto& pixel : {std::pair<int, int>{0, 0}, {4, 3}, {6, 4}}) {
                const Run lit = run(lit04, volume_flags(ramp, "ramp") +
                                               std::vector<std::string>{"--threshold", "0"} +
                                               debug_pixel(pixel.first, pixel.second));
                for (const PixelTrace& trace : lit.result.traces) {
                    double g[3];
                    if (!traced_gradient(trace, g)) continue;
                    worst_gradient = std::max({worst_gradient, std::abs(g[0] - 3.0),
                                               std::abs(g[1] - 5.0), std::abs(g[2] - 7 / s)});
                    ++traced;
                }
            }
        }
        Case c;
        c.name = "ramp 3i + 5j + 7k: gradient at the hit, borders included (spacing 1, 2, 0.5 "
                 "along k)";
        c.test = test_s;
        c.analytic = "(3, 5, 7 / s_k)";
        c.measured = text_of("%d traced rays (printed to 0.01)", traced);
        c.abs_error = worst_gradient;
        cases.push_back(c);

        const Volume ramp = make_volume(10, 12, 14, [](int i, int j, int k) {
            return 3 * i + 5 * j + 7 * k; });
        const std::vector<std::string> flags = volume_flags(ramp, "ramp");
        double worst_crossing = 0;
        int crossings = 0;
        for (const int threshold : {100, 101, 97, 0, -5, 172, 173}) {
            for (const auto& pixel : {std::pair<int, int>{0, 0}, {1, 2}, {5, 7}, {9, 11}}) {
                const Run ray = run(hit05, flags + std::vector<std::string>{
                                                       "--threshold", std::to_string(threshold)} +
                                               debug_pixel(pixel.first, pixel.second));
                for (const PixelTrace& trace : ray.result.traces) {
                    const ViewAxis axis = trace.view == "top"     ? ViewAxis::top
                                          : trace.view == "front" ? ViewAxis::front
                                                                  : ViewAxis::side;
                    const View view = make_view(ramp, axis);
                    const int slope = axis == ViewAxis::top ? 7 : axis == ViewAxis::front ? 5 : 3;
                    const Voxel first = view.voxel(trace.x, trace.y, 0);
                    const int f0 = 3 * first.i + 5 * first.j + 7 * first.k;
                    double t = 0;
                    if (!traced_t_hit(trace, t) || f0 > threshold) continue;
                    worst_crossing = std::max(worst_crossing,
                                              std::abs(t - double(threshold - f0) / slope));
                    ++crossings;
                }
            }
        }
        c.name = "ramp: step 05's crossing, 7 thresholds";
        c.analytic = "(tau - f0) / slope";
        c.measured = text_of("in samples, %d traced rays (printed to 1e-6)", crossings);
        c.abs_error = worst_crossing;
        cases.push_back(c);
    }
    // int16 extremes: a crossing between -32768 and 32767.
    {
        const Volume volume = make_volume(4, 4, 4, [](int i, int j, int k) {
            return (k >= 2 || (i == 3 && j == 3 && k == 0)) ? 32767 : -32768; });
        const std::vector<std::string> flags =
            volume_flags(volume, "extremes") + std::vector<std::string>{"--view", "top"};
        auto crossing = [&](int threshold) {
            const Run ray = run(hit05, flags + std::vector<std::string>{
                                                   "--threshold", std::to_string(threshold)} +
                                           debug_pixel(0, 0));
            double t = -1;
            if (ray.result.traces.size() == 1) traced_t_hit(ray.result.traces[0], t);
            return t;
        };
        add_case("int16 extremes: step 05 crossing at threshold 32766 (trace)", test_s,
                 1.0 + 65534.0 / 65535.0, crossing(32766));
        add_case("int16 extremes: step 05 crossing at threshold 0 (trace)", test_s,
                 1.0 + 32768.0 / 65535.0, crossing(0));
        const Run lit = run(lit04, flags + debug_pixel(1, 1));
        double g[3] = {0, 0, 0};
        if (lit.result.traces.size() == 1) traced_gradient(lit.result.traces[0], g);
        add_case("int16 extremes: gradient (32767 + 32768) / 2 along k (trace)", test_s,
                 65535.0 / 2, g[2]);
    }
    // A constant volume: zero gradient, no normal: ambient (0.1, handout 05), never NaN.
    {
        const Volume volume = make_volume(8, 6, 4, [](int, int, int) { return 500; });
        const Run lit = run(hit05, volume_flags(volume, "constant"));
        add_case("constant volume: shade of a zero gradient = ambient", test_s, 0.1,
                 lit.image().at(3, 2).r);
    }
}

// --- Output -------------------------------------------------------------------------------

std::string markdown_table(const std::string& study, const char* parameter_name) {
    std::ostringstream out;
    out << "| method | " << parameter_name << " | ms | error | max error | Msamples |\n";
    out << "|---|---:|---:|---:|---:|---:|\n";
    for (const Point& p : points) {
        if (p.study != study) continue;
        out << text_of("| %s | %s | %.2f | %.4g | %.4g | %.2f |\n", p.method.c_str(),
                      p.parameter.c_str(), p.ms, p.error, p.max_error, p.samples / 1e6);
    }
    return out.str();
}

void write_csv(const std::string& path) {
    std::ofstream out(path);
    out << "study,method,parameter,ms,error,max_error,error_unit,samples\n";
    for (const Point& p : points) {
        out << p.study << ",\"" << p.method << "\"," << p.parameter << ","
            << text_of("%.4f", p.ms)
            << "," << text_of("%.6g", p.error) << "," << text_of("%.6g", p.max_error) << ",\""
            << p.error_unit << "\"," << p.samples << "\n";
    }
}

plot::Series series_of(const std::string& study, const std::string& method,
                       const std::string& label, Rgb colour, bool notes = true) {
    plot::Series s;
    s.label = label;
    s.colour = colour;
    for (const Point& p : points) {
        if (p.study != study || p.method != method) continue;
        s.x.push_back(p.ms);
        s.y.push_back(p.error);
        s.notes.push_back(notes ? p.parameter : "");
    }
    return s;
}

void write_plot(const std::string& path) {
    const Rgb blue = {0.12f, 0.35f, 0.75f}, orange = {0.9f, 0.45f, 0.05f};
    const Rgb green = {0.1f, 0.6f, 0.25f}, red = {0.8f, 0.1f, 0.15f};
    const Rgb purple = {0.5f, 0.25f, 0.7f}, grey = {0.45f, 0.45f, 0.45f};
    plot::Panel depth;
    depth.title = "FIRST-HIT DEPTH (TOP VIEW)";
    depth.x_label = "MS PER FRAME, 1 THREAD";
    depth.y_label = "MEAN DEPTH ERROR (VOXELS)";
    depth.series = {
        series_of("depth", "sphere: nearest sample (step 03)", "SPHERE: NEAREST, H=1", blue),
        series_of("depth", "sphere: nearest, finer steps", "SPHERE: NEAREST, FINER H", blue),
        series_of("depth", "sphere: interpolated (step 05)", "SPHERE: INTERPOLATED (05)", orange,
                  false),
        series_of("depth", "ellipsoid: nearest sample (step 03)", "ELLIPSOID: NEAREST, H=1",
                  green, false),
        series_of("depth", "ellipsoid: nearest, finer steps", "ELLIPSOID: NEAREST, FINER H",
                  green, false),
        series_of("depth", "ellipsoid: interpolated (step 05)", "ELLIPSOID: INTERPOLATED", red,
                  false),
    };
    // Join the h = 1 point to its finer steps: one curve per shape.
    for (int n : {0, 3}) {
        plot::Series& nearest = depth.series[n];
        const plot::Series& finer = depth.series[n + 1];
        nearest.x.insert(nearest.x.end(), finer.x.begin(), finer.x.end());
        nearest.y.insert(nearest.y.end(), finer.y.begin(), finer.y.end());
        nearest.notes.insert(nearest.notes.end(), finer.notes.begin(), finer.notes.end());
        nearest.label = (n == 0 ? "SPHERE" : "ELLIPSOID") + std::string(": NEAREST, H = 1..1/8");
    }
    depth.series.erase(depth.series.begin() + 4);
    depth.series.erase(depth.series.begin() + 1);

    plot::Panel step;
    step.title = "COMPOSITING STEP (STEP 10, FRONT)";
    step.x_label = "MS PER FRAME, 1 THREAD";
    step.y_label = "RMSE (8-BIT) VS STEP 1/32";
    step.series = {
        series_of("step", "opacity corrected", "CORRECTED, STEP 4..1/8", blue),
        series_of("step", "not corrected", "NOT CORRECTED", red),
    };

    plot::Panel ert;
    ert.title = "EARLY RAY TERMINATION (TOP)";
    ert.x_label = "MS PER FRAME, 1 THREAD";
    ert.y_label = "RMSE ADDED (8-BIT)";
    ert.series = {
        series_of("ert", "step 08 front to back", "STEP 08, T* = 0.001..0.1", purple),
        series_of("ert", "step 10 lit, step 1", "STEP 10, T* = 0.001..0.1", green),
    };
    // T* = 0 adds no error, so it cannot sit on a log axis: its time goes into the legend.
    for (plot::Series& s : ert.series) {
        for (size_t n = 0; n < s.notes.size(); ++n) {
            if (s.y[n] == 0) s.label += text_of(" (T*=0: %.0f MS)", s.x[n]);
            s.notes[n] = "T*=" + s.notes[n];
        }
    }
    (void)grey;
    write_png(plot::draw_panels({depth, step, ert}, 620, 620), path);
}

std::string numerics_table(const SubnormalCost& cost, const std::vector<FloatRay>& rays) {
    std::ostringstream out;
    out << "| case | analytic | measured | abs error | rel error | test |\n";
    out << "|---|---|---|---:|---:|---|\n";
    for (const Case& c : cases) {
        auto figure = [](double error) {
            return error == not_applicable ? std::string("-") : text_of("%.3g", error);
        };
        out << text_of("| %s | %s | %s | %s | %s | %s |\n", c.name.c_str(), c.analytic.c_str(),
                      c.measured.c_str(), figure(c.abs_error).c_str(),
                      figure(c.rel_error).c_str(), c.test.c_str());
    }
    out << "\n### Subnormal arithmetic on this machine\n\n";
    out << "ns per multiply, 4096 values times 0.9, 400 passes (median of " << runs
        << " runs):\n\n";
    out << "| type | normal operands | subnormal operands | subnormal, FTZ+DAZ | slowdown |\n";
    out << "|---|---:|---:|---:|---:|\n";
    out << text_of("| float | %.3f | %.3f | %.3f | %.0fx |\n", cost.float_normal,
                  cost.float_subnormal, cost.float_flushed,
                  cost.float_subnormal / cost.float_normal);
    out << text_of("| double | %.3f | %.3f | %.3f | %.0fx |\n", cost.double_normal,
                  cost.double_subnormal, cost.double_flushed,
                  cost.double_subnormal / cost.double_normal);
    out << "\nA float front-to-back ray (2000 rays, white, median of " << runs << " runs):\n\n";
    out << "| opacity a, samples n, how the ray stops | ns per sample | samples with T "
           "subnormal | final T |\n";
    out << "|---|---:|---:|---:|\n";
    const char* labels[] = {"a = 0.01, n = 12000, never (T* = 0)",
                            "a = 0.01, n = 12000, never, FTZ+DAZ on",
                            "a = 0.01, n = 12000, T* = 0.01",
                            "a = 0.8, n = 100, never (T* = 0)",
                            "a = 0.8, n = 100, never, FTZ+DAZ on"};
    for (size_t n = 0; n < rays.size(); ++n) {
        out << text_of("| %s | %.2f | %d | %.3g |\n", labels[n], rays[n].ns_per_sample,
                      rays[n].subnormal_samples, rays[n].transparency);
    }
    return out.str();
}

// The CPU's name, from /proc/cpuinfo ("unknown" elsewhere).
std::string cpu_model() {
    std::ifstream in("/proc/cpuinfo");
    for (std::string line; std::getline(in, line);) {
        if (line.compare(0, 10, "model name") != 0) continue;
        const size_t colon = line.find(':');
        if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
    return "unknown";
}

// BODY marked as section NAME for tools/measured.cpp; a quick run's figures are not marked,
// so they can never reach a handout.
std::string section(const std::string& name, const std::string& body) {
    if (quick) return body;
    return "<!-- section: " + name + " -->\n" + body + "<!-- end section -->\n";
}

// The date and time now, "2026-11-23 13:10 UTC".
std::string utc_now() {
    const std::time_t now = std::time(nullptr);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
    return text;
}

std::string load_average() {
    std::ifstream in("/proc/loadavg");
    std::string one, five, fifteen;
    in >> one >> five >> fifteen;
    return one + " " + five + " " + fifteen;
}

// The shear-warp study's table: each view's steps 30, 34, 38 (lit, 39), error against 30.
std::string shear_warp_table() {
    return "Error against step 30's picture, RMSE and max over every channel of every pixel; "
           "Msamples: samples read (steps 38 and 42: cells read in the slices):\n\n" +
           markdown_table("shear-warp", "view");
}

// --only shear-warp: that study alone, its table in DIR/shear_warp.md (a section for the
// handout's block, as make study writes it into error_vs_time.md).
int shear_warp_only(const std::string& out, const std::string& started,
                    const std::string& load_before, const machine::OtherLoad& others,
                    const Timer& total) {
    shear_warp_study();
    const int cores = int(std::max(1u, std::thread::hardware_concurrency()));
    const std::string written_by = text_of(
        "Figures of `build/study --only shear-warp` (tools/study.cpp), not typed by hand: "
        "started %s, %.0f s on %d cores (%s); load average %s before, %s after; other "
        "processes used %.0f%% of the cores meanwhile (a shared machine inflates the times; "
        "the errors do not depend on it). Times: each step run as a program with --repeat, the "
        "median of the %d renders after the first, 1 thread.\n",
        started.c_str(), total.ms() / 1000, cores, cpu_model().c_str(), load_before.c_str(),
        load_average().c_str(), 100 * others.share(), runs);
    std::ofstream(out + "/shear_warp.md")
        << "# Shear-warp against ray casting\n\n"
        << section("study:shear_warp", written_by + "\n" + shear_warp_table());
    std::printf("study: wrote %s/shear_warp.md\n", out.c_str());
    return 0;
}

constexpr const char* study_usage =
    "usage: study [--out DIR] [--runs N] [--quick] [--only shear-warp]\n"
    "What each method costs and what it buys (make study): time against error for depth,\n"
    "step, ert, jitter, shadows, shear-warp, precision, numerics; writes DIR/*.md (default\n"
    "out/study). --only shear-warp: that study alone.\n";

int run(int argc, char** argv) {
    std::string out = "out/study";
    std::string only;  // --only shear-warp: that study alone, into its own table
    for (int n = 1; n < argc; ++n) {
        const std::string flag = argv[n];
        if (flag == "--help" || flag == "-h") {
            std::printf("%s", study_usage);
            return 0;
        } else if (flag == "--out" && n + 1 < argc) {
            out = argv[++n];
        } else if (flag == "--runs" && n + 1 < argc) {
            runs = parse_int("--runs", argv[++n], 1, 1000);
        } else if (flag == "--quick") {
            quick = true;
        } else if (flag == "--only" && n + 1 < argc) {
            only = argv[++n];
            if (only != "shear-warp") throw InputError("--only: the one study is shear-warp");
        } else {
            throw InputError("unknown flag '" + flag + "' (see study --help)");
        }
    }
    if (quick) {
        runs = 1;
        reference_step = quick_reference_step;
    }
    make_folder(out);
    const std::string load_before = load_average();
    const std::string started = utc_now();
    const machine::OtherLoad others;
    const Timer total;
    if (only == "shear-warp") return shear_warp_only(out, started, load_before, others, total);
    depth_study();
    step_study();
    ert_study();
    jitter_study();
    shadows_study();
    shear_warp_study();
    std::printf("precision: subnormal arithmetic\n");
    const SubnormalCost cost = subnormal_cost();
    std::vector<FloatRay> rays = {
        float_ray(0.01f, 12000, 0, false), float_ray(0.01f, 12000, 0, true),
        float_ray(0.01f, 12000, 0.01, false), float_ray(0.8f, 100, 0, false),
        float_ray(0.8f, 100, 0, true)};
    std::printf("  float multiply: %.3f ns normal, %.3f ns subnormal, %.3f ns with FTZ+DAZ\n",
                cost.float_normal, cost.float_subnormal, cost.float_flushed);
    std::printf("  double multiply: %.3f ns normal, %.3f ns subnormal, %.3f ns with FTZ+DAZ\n",
                cost.double_normal, cost.double_subnormal, cost.double_flushed);
    std::printf("numerics: the stiff cases of the tests\n");
    compositing_cases();
    surface_cases();

    write_csv(out + "/error_vs_time.csv");
    write_plot(out + "/error_vs_time.png");
    const int cores = int(std::max(1u, std::thread::hardware_concurrency()));
    std::ostringstream md;
    md << "# Error against run time: measured tables\n\n";
    if (quick) {
        md << "**Quick mode** (--quick): one render per case, a 64x64x29 phantom, reference step "
              "1/16. Do not quote these figures.\n\n";
    }
    const std::string written_by = text_of(
        "Figures of the last `make study` (tools/study.cpp), not typed by hand: started %s, %.0f s on "
        "%d cores (%s); load average %s before, %s after; other processes used %.0f%% of the "
        "cores meanwhile (a shared machine inflates the times; the errors do not depend on "
        "it). Times: each step run as a program with --repeat, the median of the %d renders "
        "after the first, 1 thread.\n",
        started.c_str(), total.ms() / 1000, cores, cpu_model().c_str(), load_before.c_str(),
        load_average().c_str(), 100 * others.share(), runs);
    md << written_by << "\n";
    // Each table marked as a section that tools/measured.cpp copies into the handouts' blocks
    // of the same name (make study does), with the line saying where and how it was measured.
    md << "## First-hit depth (top view, 256x256x113, spacing 1:1:2; error in voxels)\n\n"
       << section("study:depth", written_by + "\n" + markdown_table("depth", "step h (voxels)"))
       << "\n";
    md << "## Compositing step (step 10 lit, front view, T* = 0; error in 8-bit units against "
       << "step " << step_text(reference_step) << ")\n\n"
       << section("study:step", written_by + "\n" + markdown_table("step-reference", "step") +
                                    "\n" + markdown_table("step", "step (voxels)"))
       << "\n";
    md << "## Early ray termination (top view; error added against T* = 0, 8-bit units)\n\n"
       << section("study:ert", written_by + "\n" + markdown_table("ert", "T*")) << "\n";
    md << "## Jitter (step 17, the default camera at 256x256, T* = 0; error in 8-bit units "
       << "against step 1/4 without jitter, trilinear; method: jitter, interpolation)\n\n"
       << section("study:jitter",
                  written_by + "\nRMSE and max of the difference:\n\n" +
                      markdown_table("jitter", "step") +
                      "\nThe same after a 5x5 box blur of the difference (the bands and rings "
                      "the eye sees; fine noise averages away):\n\n" +
                      markdown_table("jitter-lowpass", "step"))
       << "\n";
    md << "## Shadows (steps 22-24, the default camera at 256x256; error in 8-bit units)\n\n"
       << section("study:shadows",
                  written_by + "\nWhat each adds: step 24 with each kind of blocked light "
                               "(`ray, ao off` is step 22's default picture, `volume, ao off` "
                               "step 23's, `ray, ao on` step 24's), against step 15's light "
                               "(`--shadows none --ao off`), at step 1; samples count every "
                               "read (the camera's rays, the shadow rays, the occlusion probes, "
                               "the light volume's sweep):\n\n" +
                      markdown_table("shadows", "step") +
                      "\nT_light by shadow rays and by the light-transmittance volume (step "
                      "20), against shadow rays at step 1/4 (error at equal "
                      "time: compare the ms column):\n\n" +
                      markdown_table("shadows-error", "step") +
                      "\nThe light volume's own error: against the shadow rays at the same "
                      "step:\n\n" + markdown_table("shadows-volume", "step"))
       << "\n";
    md << "## Shear-warp (step 38 against step 30, unlit composite, spacing 1,1,1; error in "
       << "8-bit units)\n\n"
       << section("study:shear_warp", written_by + "\n" + shear_warp_table()) << "\n";
    std::ofstream(out + "/error_vs_time.md") << md.str();
    std::ofstream(out + "/numerics.md")
        << "# The stiff cases, measured\n\n"
        << section("study:numerics", written_by + "\n" + numerics_table(cost, rays));
    std::printf("%s", numerics_table(cost, rays).c_str());
    std::printf("study: wrote %s/error_vs_time.{csv,png,md} and %s/numerics.md in %.0f s; "
                "other processes used %.0f%% of the cores meanwhile\n",
                out.c_str(), out.c_str(), total.ms() / 1000, 100 * others.share());
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    return guarded_main(tool_name, [&] { return run(argc, argv); });
}
