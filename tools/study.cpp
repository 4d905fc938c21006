// study.cpp: what each method costs and what it buys. Renders a matrix of methods and
// parameters and measures, in the same run, the wall time (median of --runs renders, one
// thread) and the error against a converged reference:
//
//   depth      first hit: nearest sample (step 03), finer ray steps, interpolated (step 05),
//              against an analytic sphere and a tilted ellipsoid; error in voxels (samples)
//   step       step 08's sample step 4 .. 1/8 voxel, with and without opacity correction,
//              against step 08 at step 1/32 (double sums, no early termination); error in
//              8-bit units (RMSE and max over every channel of every pixel)
//   ert        early ray termination thresholds 0 .. 0.1 (steps 07 and 08, top view):
//              time saved against error added
//   precision  float against double sums; the cost of subnormal arithmetic on this machine
//   numerics   the stiff and extreme cases the tests check, with the analytic answer and the
//              error measured here (handouts/numerics.md quotes them)
//
//   build/study [--out DIR] [--runs N] [--quick]           (make study: about a minute)
//
// --quick (make study QUICK=1, run by CI so the study cannot rot): one render per case, the
// phantom at 64 x 64 x 29 and a reference step of 1/16. Its figures are not to be quoted.
//
// Writes DIR/error_vs_time.csv, DIR/error_vs_time.png (log-log, a panel per study),
// DIR/error_vs_time.md (the tables) and DIR/numerics.md. handouts/error_vs_time.md and
// handouts/numerics.md discuss one run of it.
//
// The methods are the steps' own code: each step is compiled in here in a namespace of its
// own (as the tests do) and its lesson functions are called directly. Where the study needs
// a variant no step has (finer ray steps for the first hit, float sums), it is written
// below, marked "study variant", built from the same lesson functions.
#include "common/ctlab.h"
#include <cfloat>
#include <cstdarg>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#if defined(__SSE__)
#include <xmmintrin.h>  // the MXCSR register: flush-to-zero and denormals-are-zero
#endif

// The steps, each in a namespace of its own (step03::first_hit, ...); their main() is not
// run here, so load_volume and run_views keep their own meaning.
#include "all_steps.h"
#include "machine_load.h"
#include "plot.h"

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

bool identical(const Image& a, const Image& b) {
    return a.pixels.size() == b.pixels.size() &&
           std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(Rgb)) == 0;
}

std::string format(const char* pattern, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char* pattern, ...) {
    char text[1024];
    va_list arguments;
    va_start(arguments, pattern);
    std::vsnprintf(text, sizeof text, pattern, arguments);
    va_end(arguments);
    return text;
}

// "1/8" for 0.125, "4" for 4: step sizes as the tables show them.
std::string step_text(double step) {
    if (step >= 1) return format("%g", step);
    return format("1/%g", 1 / step);
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
    volume.data.resize(volume.voxel_count());
    for (int k = 0; k < volume.nz; ++k)
        for (int j = 0; j < volume.ny; ++j)
            for (int i = 0; i < volume.nx; ++i) {
                const double v = shape.value(i * volume.sx, j * volume.sy, k * volume.sz);
                volume.data[(size_t(k) * volume.ny + j) * volume.nx + i] =
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

// Where step 05's hit lies along the ray, in samples: its sample index plus the fraction.
double crossing_of(const step05::Hit& hit) { return hit.n + double(hit.fraction); }

// Study variant (no step has it): step 03's rule - the first sample above the threshold -
// with samples `h` voxels apart, each read as step 08 reads it (linear along the ray).
DepthHit first_hit_finer(const Volume& volume, const View& view, int x, int y, double h,
                         Work& work) {
    const int count = int(std::floor((view.ray_length - 1) / h + 1e-9)) + 1;
    for (int n = 0; n < count; ++n) {
        const double position = n * h;
        ++work.samples;
        if (step08::value_along_ray(volume, view, x, y, position) > surface_threshold) {
            return {true, position};
        }
    }
    return {};
}

void depth_study() {
    std::printf("depth: first hit against an analytic sphere and ellipsoid (top view, "
                "256x256x113, spacing 1:1:2)\n");
    const Ellipsoid shapes[] = {
        {"sphere", 127.6, 128.3, 112.7, 80, 80, 80, 0},
        {"ellipsoid", 128.4, 127.3, 113.3, 100, 70, 45, 30 * pi / 180},
    };
    for (const Ellipsoid& shape : shapes) {
        const Volume volume = shape_volume(shape);
        const View view = make_view(volume, ViewAxis::top);
        std::vector<Analytic> truth;
        for (int y = 0; y < view.height; ++y)
            for (int x = 0; x < view.width; ++x) {
                truth.push_back(analytic_top(volume, shape, x, y));
            }

        struct Method {
            std::string name, parameter;
            std::function<DepthHit(int x, int y, Work&)> hit;
        };
        std::vector<Method> methods;
        methods.push_back({"nearest sample (step 03)", "1", [&](int x, int y, Work& work) {
            const step03::Hit hit = step03::first_hit(volume, view, x, y, surface_threshold,
                                                      work, nullptr);
            return DepthHit{hit.found, double(hit.n)};
        }});
        for (const double h : {0.5, 0.25, 0.125, 0.0625}) {
            methods.push_back({"nearest, finer steps", step_text(h),
                               [&, h](int x, int y, Work& work) {
                                   return first_hit_finer(volume, view, x, y, h, work);
                               }});
        }
        methods.push_back({"interpolated (step 05)", "1", [&](int x, int y, Work& work) {
            const step05::Hit hit = step05::first_hit(volume, view, x, y, surface_threshold,
                                                      work, nullptr);
            return DepthHit{hit.found, crossing_of(hit)};
        }});

        for (const Method& method : methods) {
            std::vector<DepthHit> hits(truth.size());
            Work work;
            const double ms = median_ms([&] {
                work = Work();
                for (int y = 0; y < view.height; ++y)
                    for (int x = 0; x < view.width; ++x) {
                        hits[size_t(y) * view.width + x] = method.hit(x, y, work);
                    }
            });
            // Error over the rays that pass well inside (min |q| <= 0.9): near grazing the
            // depth error of any sampling grows without bound and says little.
            double sum = 0, largest = 0;
            int measured = 0, disagree = 0;
            for (size_t n = 0; n < truth.size(); ++n) {
                if (truth[n].hit && truth[n].closest < 0.98 && !hits[n].found) ++disagree;
                if (!truth[n].hit && hits[n].found) ++disagree;
                if (!truth[n].hit || !hits[n].found || truth[n].closest > 0.9) continue;
                const double error = std::abs(hits[n].t - truth[n].t);
                sum += error;
                largest = std::max(largest, error);
                ++measured;
            }
            Point point;
            point.study = "depth";
            point.method = shape.name + ": " + method.name;
            point.parameter = method.parameter;
            point.ms = ms;
            point.error = sum / measured;
            point.max_error = largest;
            point.error_unit = "voxels (mean |t - t*|, max)";
            point.samples = work.samples;
            record(point);
            if (disagree > 0) std::printf("    (%d rays hit or miss unlike the surface)\n",
                                          disagree);
        }
    }
}

// --- 2. Compositing: step size and opacity correction -----------------------------------

const Volume& phantom() {
    static const Volume volume = quick ? make_phantom_sized(quick_dims[0], quick_dims[1],
                                                            quick_dims[2])
                                       : make_phantom();
    return volume;
}

// Step 08's picture, rendered by step 09 (step 08 plus leaping over empty bricks: the same
// pixels, less work): its table for this step, then its front-to-back ray for every pixel.
Image render_08(const View& view, const step09::Params& params, int threads, Work& work,
                double* ms = nullptr) {
    const step09::Lut lut = step09::build_lut(classic_transfer_function(),
                                              step09::opacity_ratio(params));
    step09::EmptySpace space;  // leaping over empty bricks, as the step does by default
    space.bricks = make_bricks(phantom());
    space.empty = step09::find_empty_bricks(space.bricks, lut);
    auto render = [&] {
        work = Work();
        return render_image(view, threads, work, [&](int x, int y, Work& w) {
            return step09::over_background(step09::composite_front_to_back(
                phantom(), view, x, y, lut, space, params, w, nullptr));
        });
    };
    Image image;
    if (ms) *ms = median_ms([&] { image = render(); });
    else image = render();
    return image;
}

// Study variant (no step has it): step 08's front-to-back loop, line for line, with the sums
// C and T held in Real. Real = double is step 08 itself (the study checks the pictures are
// identical); Real = float is what a renderer that keeps everything in float would get.
// In float, T cannot fall below 1e-300 without reaching 0, so with --ert 0 the ray runs
// until T is exactly 0 (after passing through subnormal values).
template <class Real>
Rgb composite_front_to_back_in(const View& view, int x, int y, const step09::Lut& lut,
                               const step09::EmptySpace& space, const step09::Params& params,
                               Work& work) {
    const Volume& volume = phantom();
    const double stop_below = std::max(params.ert, step09::min_transparency);
    const double depth = view.ray_length * view.ray_spacing;
    const int sample_count = std::max(1, int(std::lround(depth / params.step)));
    const double voxels_per_sample = params.step / view.ray_spacing;
    const Vec3 to_light = params.unlit ? Vec3{}
                                       : step09::light_direction(view, params.light_angle);
    Real r = 0, g = 0, b = 0, transparency = 1;
    for (int n = 0; n < sample_count; ++n) {
        const double position = n * voxels_per_sample;
        const int before = std::min(int(position), view.ray_length - 1);
        const float fraction = float(position - before);
        if (space.is_empty(view.voxel(x, y, before))) {
            const int brick_end = (before / brick_size + 1) * brick_size;
            const int next = std::min(sample_count,
                                      std::max(n + 1, int(brick_end / voxels_per_sample)));
            work.leapt += next - n;
            n = next - 1;
            continue;
        }
        const float value = step09::value_along_ray(volume, view, x, y, position);
        const Rgba& sample = lut.entries[int(double(value) - lowest_ct_value)];
        ++work.samples;
        if (sample.a == 0.0f) {
            ++work.skipped;
            continue;
        }
        double light = 1.0;
        if (!params.unlit) {
            light = step09::shade(step09::gradient_along_ray(volume, view, x, y, before,
                                                             fraction, work),
                                  to_light);
        }
        const Real weight = Real(transparency * Real(sample.a) * Real(light));
        r += weight * Real(sample.r);
        g += weight * Real(sample.g);
        b += weight * Real(sample.b);
        transparency *= Real(1) - Real(sample.a);
        if (transparency < stop_below && n + 1 < sample_count) {
            ++work.terminated;
            break;
        }
    }
    return {float(r), float(g), float(b)};  // over the black background
}

template <class Real>
Image render_08_in(const View& view, const step09::Params& params, Work& work, double* ms) {
    const step09::Lut lut = step09::build_lut(classic_transfer_function(),
                                              step09::opacity_ratio(params));
    step09::EmptySpace space;  // leaping over empty bricks, as step 09 does
    space.bricks = make_bricks(phantom());
    space.empty = step09::find_empty_bricks(space.bricks, lut);
    Image image;
    *ms = median_ms([&] {
        work = Work();
        image = render_image(view, 1, work, [&](int x, int y, Work& w) {
            return composite_front_to_back_in<Real>(view, x, y, lut, space, params, w);
        });
    });
    return image;
}

void step_study() {
    std::printf("step: step 08 (lit) on the phantom, front view, step 4 .. 1/8 voxel, no early "
                "termination, against step %s\n", step_text(reference_step).c_str());
    const View view = make_view(phantom(), ViewAxis::front);
    const int cores = int(std::max(1u, std::thread::hardware_concurrency()));
    step09::Params params;  // step 08 plus leaping: the same pictures
    params.ert = 0;
    params.step = reference_step;
    Work work;
    const Timer timer;
    const Image reference = render_08(view, params, cores, work);
    std::printf("  reference: step %s, %.1f Msamples, %.1f s on %d threads\n",
                step_text(reference_step).c_str(), work.samples / 1e6, timer.ms() / 1000, cores);
    params.step = 2 * reference_step;  // how converged is the reference itself?
    const ImageError half = image_error(render_08(view, params, cores, work), reference);
    std::printf("  the reference against step %s: RMSE %.3f, max %.3f (8-bit units)\n",
                step_text(params.step).c_str(), half.rmse, half.max);
    Point convergence;
    convergence.study = "step-reference";
    convergence.method = "step 1/16 against step 1/32";
    convergence.parameter = step_text(2 * reference_step);
    convergence.error = half.rmse;
    convergence.max_error = half.max;
    convergence.error_unit = "8-bit (RMSE, max)";
    record(convergence);

    for (const double step : {4.0, 2.0, 1.0, 0.5, 0.25, 0.125}) {
        for (const bool correction : {true, false}) {
            params.step = step;
            params.no_correction = !correction;
            double ms = 0;
            const Image image = render_08(view, params, 1, work, &ms);
            const ImageError error = image_error(image, reference);
            record({"step", correction ? "opacity corrected" : "not corrected", step_text(step),
                    ms, error.rmse, error.max, "8-bit (RMSE, max)", work.samples});
            if (!correction) continue;
            // The same in float sums (study variant), and its check that double is step 08.
            Work float_work, double_work;
            double float_ms = 0, double_ms = 0;
            const Image in_float = render_08_in<float>(view, params, float_work, &float_ms);
            const Image in_double = render_08_in<double>(view, params, double_work, &double_ms);
            if (!identical(in_double, image)) {
                throw std::runtime_error("study: the double variant differs from step 08");
            }
            const ImageError float_error = image_error(in_float, reference);
            record({"step", "opacity corrected, float sums", step_text(step), float_ms,
                    float_error.rmse, float_error.max, "8-bit (RMSE, max)", float_work.samples});
            const ImageError float_vs_double = image_error(in_float, image);
            record({"precision", "float sums against double (step 08)", step_text(step),
                    float_ms / double_ms, float_vs_double.rmse, float_vs_double.max,
                    "8-bit (RMSE, max); ms column = float time / double time",
                    float_work.samples});
        }
    }
}

// --- 3. Early ray termination ------------------------------------------------------------

void ert_study() {
    std::printf("ert: early ray termination thresholds, top view of the phantom, 1 thread\n");
    const View view = make_view(phantom(), ViewAxis::top);
    const step07::Lut lut07 = step07::build_lut(classic_transfer_function());
    Image full07, full08;
    for (const double ert : {0.0, 0.001, 0.01, 0.05, 0.1}) {
        step07::Params params07;
        params07.ert = ert;
        Work work;
        Image image;
        const double ms = median_ms([&] {
            work = Work();
            image = render_image(view, 1, work, [&](int x, int y, Work& w) {
                return step07::over_background(step07::composite_front_to_back(
                    phantom(), view, x, y, lut07, params07, w, nullptr));
            });
        });
        if (ert == 0) full07 = image;
        const ImageError error = image_error(image, full07);
        record({"ert", "step 07 front to back", format("%g", ert), ms, error.rmse, error.max,
                "8-bit, added (against T* = 0)", work.samples});

        step09::Params params08;  // step 08 plus leaping: the same pictures
        params08.ert = ert;
        double ms08 = 0;
        const Image image08 = render_08(view, params08, 1, work, &ms08);
        if (ert == 0) full08 = image08;
        const ImageError error08 = image_error(image08, full08);
        record({"ert", "step 08 lit, step 1", format("%g", ert), ms08, error08.rmse,
                error08.max, "8-bit, added (against T* = 0)", work.samples});
    }
    // Back to front cannot stop early: every sample, every time.
    Work work;
    Image image;
    const double ms = median_ms([&] {
        work = Work();
        image = render_image(view, 1, work, [&](int x, int y, Work& w) {
            return step07::composite_back_to_front(phantom(), view, x, y, lut07, w, nullptr);
        });
    });
    const ImageError error = image_error(image, full07);
    record({"ert", "step 07 back to front", "-", ms, error.rmse, error.max,
            "8-bit (against front to back, T* = 0)", work.samples});
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
    c.analytic = format(number, analytic);
    c.measured = format(number, measured);
    c.abs_error = std::abs(measured - analytic);
    c.rel_error = analytic != 0 ? c.abs_error / std::abs(analytic) : not_applicable;
    cases.push_back(c);
}

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

TransferFunction one_range(int from, int to, float r, float g, float b, double a) {
    TransferFunction tf;
    tf.source = "study";
    TfRange range;
    range.from = from;
    range.to = to;
    range.start = range.end = {r, g, b, float(a)};
    tf.ranges.push_back(range);
    return tf;
}

step07::Accumulated f2b_column(const Volume& volume, const TransferFunction& tf, double ert,
                               Work& work) {
    step07::Params params;
    params.ert = ert;
    return step07::composite_front_to_back(volume, make_view(volume, ViewAxis::top), 0, 0,
                                           step07::build_lut(tf), params, work, nullptr);
}

Rgb b2f_column(const Volume& volume, const TransferFunction& tf, Work& work) {
    return step06::composite_back_to_front(volume, make_view(volume, ViewAxis::top), 0, 0,
                                           step06::build_lut(tf), work, nullptr);
}

void compositing_cases() {
    const char* test_c = "test_compositing.cpp";
    // Skin, skin, bone: the closed form of numerics.md.
    {
        const Volume volume = column({0, 0, 1000});
        const TransferFunction classic = classic_transfer_function();
        const double a = 0.12, bone = 0.8, skin[3] = {1.0, 0.79, 0.6};
        Work work;
        const step07::Accumulated f2b = f2b_column(volume, classic, 0, work);
        const Rgb b2f = b2f_column(volume, classic, work);
        const double f2b_rgb[3] = {f2b.r, f2b.g, f2b.b}, b2f_rgb[3] = {b2f.r, b2f.g, b2f.b};
        const char* channel[3] = {"red", "green", "blue"};
        for (int n = 0; n < 3; ++n) {
            const double exact = a * skin[n] + (1 - a) * a * skin[n] + (1 - a) * (1 - a) * bone;
            add_case(std::string("skin, skin, bone: C ") + channel[n] + ", front to back",
                     test_c, exact, f2b_rgb[n]);
            add_case(std::string("skin, skin, bone: C ") + channel[n] + ", back to front",
                     test_c, exact, b2f_rgb[n]);
        }
        add_case("skin, skin, bone: T", test_c, (1 - a) * (1 - a) * (1 - bone),
                 f2b.transparency);
    }
    // Homogeneous slabs: T = (1 - a)^n with a as stored (a float).
    struct Slab {
        double a;
        int n;
    };
    for (const Slab slab : {Slab{0.12, 10}, Slab{0.12, 113}, Slab{1e-7, 1000000}}) {
        const TransferFunction tf = one_range(100, 101, 1, 1, 1, slab.a);
        const double a = double(float(slab.a));
        const double exact_t = std::exp(slab.n * std::log1p(-a));
        const Volume volume = column(std::vector<int16_t>(slab.n, 100));
        Work work;
        const step07::Accumulated f2b = f2b_column(volume, tf, 0, work);
        const std::string name = format("slab a = %g, n = %d: ", slab.a, slab.n);
        add_case(name + "T, front to back (double)", test_c, exact_t, f2b.transparency);
        add_case(name + "A = 1 - T, front to back", test_c, -std::expm1(slab.n * std::log1p(-a)),
                 f2b.r);
        add_case(name + "A, back to front (float out)", test_c, 1 - exact_t,
                 b2f_column(volume, tf, work).r);
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
        const TransferFunction tf = one_range(100, 101, 1, 1, 1, 0.8);
        const Volume volume = column(std::vector<int16_t>(1000, 100));
        Work work;
        const step07::Accumulated ray = f2b_column(volume, tf, 0, work);
        add_case("a = 0.8, n = 1000, T* = 0: samples until T < 1e-300", test_c,
                 std::ceil(std::log(1e-300) / std::log1p(-a)), double(work.samples), "%.0f");
        add_case("a = 0.8, n = 1000, T* = 0: C", test_c, 1.0, ray.r);
        Work early;
        const step07::Accumulated stopped = f2b_column(volume, tf, step07::default_ert, early);
        add_case("a = 0.8, T* = 0.01: samples visited", test_c, 3, double(early.samples),
                 "%.0f");
        add_case("a = 0.8, T* = 0.01: C (error <= T* max c = 0.01)", test_c, 1.0, stopped.r);
        Work all;
        add_case("a = 0.8, n = 1000: C back to front", test_c, 1.0,
                 b2f_column(volume, tf, all).r);
    }
    // Opacity 1 hides everything behind; opacity 0 adds nothing.
    {
        TransferFunction tf = one_range(100, 101, 1, 0, 0, 1.0);
        TfRange green;
        green.from = 200, green.to = 201, green.start = green.end = {0, 1, 0, 0.5f};
        tf.ranges.push_back(green);
        const Volume volume = column({100, 200, 200, 100});
        Work work;
        const step07::Accumulated ray = f2b_column(volume, tf, 0, work);
        add_case("opacity 1 in front: C red", test_c, 1.0, ray.r);
        add_case("opacity 1 in front: C green (hidden)", test_c, 0.0, ray.g);
        add_case("opacity 1 in front: samples visited", test_c, 1, double(work.samples), "%.0f");
        const TransferFunction clear = one_range(1000, 1001, 1, 1, 1, 0.5);  // 100, 200: none
        Work none;
        const step07::Accumulated empty = f2b_column(volume, clear, 0, none);
        add_case("everything transparent: T", test_c, 1.0, empty.transparency);
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
    // Opacity correction, over the test's grid: the stable form against the plain one.
    {
        double stable = 0, plain_float = 0, plain_double = 0;
        std::string worst_float, worst_double;
        for (const float alpha : {1e-7f, 0.12f, 0.5f, 0.8f, 0.999f}) {
            for (const double ratio : {1e-3, 0.25, 0.5, 1.0, 2.0, 4.0, 1e3}) {
                const long double exact = 1.0L - std::pow(1.0L - alpha, (long double)ratio);
                auto relative = [&](double value) {
                    return double(std::abs(value - exact) / exact);
                };
                stable = std::max(stable, relative(step08::corrected_opacity(alpha, ratio)));
                const double f = relative(1.0f - std::pow(1.0f - alpha, float(ratio)));
                const double d = relative(1.0 - std::pow(1.0 - double(alpha), ratio));
                const std::string where = format("%g, %g", alpha, ratio);
                if (f > plain_float) plain_float = f, worst_float = where;
                if (d > plain_double) plain_double = d, worst_double = where;
            }
        }
        Case c;
        c.test = test_c;
        c.analytic = "1 - (1 - alpha)^ratio, long double";
        c.name = "opacity correction, -expm1(ratio log1p(-alpha)) -> float (step 08)";
        c.measured = "alpha 1e-7..0.999, ratio 1e-3..1e3";
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
        const TransferFunction tf = one_range(100, 101, 1, 1, 1, 0.12);
        const double a = double(0.12f);
        double worst = 0;
        for (const double spacing : {1.0, 2.0}) {
            const Volume volume = column(std::vector<int16_t>(20, 100), spacing);
            const double exact = std::pow(1 - a, 20 * spacing);
            for (const double step : {0.25, 0.5, 1.0, 2.0, 4.0}) {
                step08::Params params;
                params.ert = 0, params.step = step, params.unlit = true;
                Work work;
                const step08::Accumulated ray = step08::composite_front_to_back(
                    volume, make_view(volume, ViewAxis::top), 0, 0,
                    step08::build_lut(tf, step08::opacity_ratio(params)), params, work,
                    nullptr);
                worst = std::max(worst, std::abs(ray.transparency - exact) / exact);
            }
            if (spacing == 1) {
                step08::Params params;
                params.ert = 0, params.step = 0.5, params.unlit = true;
                params.no_correction = true;
                Work work;
                const step08::Accumulated ray = step08::composite_front_to_back(
                    volume, make_view(volume, ViewAxis::top), 0, 0,
                    step08::build_lut(tf, step08::opacity_ratio(params)), params, work,
                    nullptr);
                add_case("slab a = 0.12, 20 units, step 0.5 NOT corrected: T", test_c, exact,
                         ray.transparency);
            }
        }
        Case c;
        c.name = "slab a = 0.12, 20 units, steps 0.25..4, spacing 1 and 2: T, corrected";
        c.test = test_c;
        c.analytic = "(1 - a)^depth";
        c.measured = "worst of 10";
        c.rel_error = worst;
        cases.push_back(c);
    }
}

// The surface cases of test_steps.cpp: the ramp, the sphere, the int16 extremes.
Volume make_volume(int nx, int ny, int nz, const std::function<double(int, int, int)>& value,
                   double sx = 1, double sy = 1, double sz = 1) {
    Volume volume;
    volume.nx = nx, volume.ny = ny, volume.nz = nz;
    volume.sx = sx, volume.sy = sy, volume.sz = sz;
    volume.data.resize(volume.voxel_count());
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                const double v = std::clamp(std::round(value(i, j, k)), -32768.0, 32767.0);
                volume.data[(size_t(k) * ny + j) * nx + i] = int16_t(v);
            }
    update_range(volume);
    return volume;
}

void surface_cases() {
    const char* test_s = "test_steps.cpp";
    // Ramp f = 3i + 5j + 7k: gradients and crossings are exact.
    {
        double worst_gradient = 0;
        for (const double s : {1.0, 2.0, 0.5}) {
            const Volume ramp = make_volume(9, 7, 5, [](int i, int j, int k) {
                return 3 * i + 5 * j + 7 * k - 60; }, 1, 1, s);
            Work work;
            for (int k = 0; k < ramp.nz; ++k)
                for (int j = 0; j < ramp.ny; ++j)
                    for (int i = 0; i < ramp.nx; ++i) {
                        const Vec3 g = step04::gradient_at(ramp, {i, j, k}, work);
                        worst_gradient = std::max({worst_gradient, std::abs(g.i - 3.0),
                                                   std::abs(g.j - 5.0), std::abs(g.k - 7 / s)});
                    }
        }
        Case c;
        c.name = "ramp 3i + 5j + 7k: gradient, borders included (spacing 1, 2, 0.5 along k)";
        c.test = test_s;
        c.analytic = "(3, 5, 7 / s_k)";
        c.measured = "every voxel";
        c.abs_error = worst_gradient;
        cases.push_back(c);

        const Volume ramp = make_volume(10, 12, 14, [](int i, int j, int k) {
            return 3 * i + 5 * j + 7 * k; });
        double worst_crossing = 0;
        for (const int threshold : {100, 101, 97, 0, -5, 172, 173}) {
            for (const ViewAxis axis : {ViewAxis::top, ViewAxis::front, ViewAxis::side}) {
                const View view = make_view(ramp, axis);
                const int slope = axis == ViewAxis::top ? 7 : axis == ViewAxis::front ? 5 : 3;
                for (int y = 0; y < view.height; ++y)
                    for (int x = 0; x < view.width; ++x) {
                        const Voxel first = view.voxel(x, y, 0);
                        const int f0 = 3 * first.i + 5 * first.j + 7 * first.k;
                        Work work;
                        const step05::Hit hit =
                            step05::first_hit(ramp, view, x, y, threshold, work, nullptr);
                        if (!hit.found || f0 > threshold) continue;
                        const double exact = double(threshold - f0) / slope;
                        worst_crossing =
                            std::max(worst_crossing, std::abs(crossing_of(hit) - exact));
                    }
            }
        }
        c.name = "ramp: step 05's crossing, every ray, 7 thresholds";
        c.analytic = "(tau - f0) / slope";
        c.measured = "in samples";
        c.abs_error = worst_crossing;
        cases.push_back(c);
    }
    // The sphere of the test: 64 x 64 x 32, spacing 1:1:2, R = 20, centre off the grid.
    {
        const Ellipsoid sphere = {"sphere", 31.3, 29.6, 31.7, 20, 20, 20, 0};
        const Volume volume = make_volume(64, 64, 32, [&](int i, int j, int k) {
            return sphere.value(i * 1.0, j * 1.0, k * 2.0); }, 1, 1, 2);
        for (const ViewAxis axis : {ViewAxis::top, ViewAxis::front, ViewAxis::side}) {
            const View view = make_view(volume, axis);
            double sum3 = 0, sum5 = 0, max5 = 0, normal4 = 0, normal5 = 0, max_normal5 = 0;
            int measured = 0;
            for (int y = 0; y < view.height; ++y)
                for (int x = 0; x < view.width; ++x) {
                    // The ray: from the voxel at t = 0 along the view axis, physical units.
                    const Voxel v0 = view.voxel(x, y, 0);
                    const double p0[3] = {v0.i * volume.sx, v0.j * volume.sy, v0.k * volume.sz};
                    const Vec3 unit = volume_direction(view, 0, 0, 1);
                    const double d[3] = {unit.i, unit.j, unit.k};
                    const double c[3] = {sphere.ci, sphere.cj, sphere.ck};
                    double along = 0, to_c2 = 0;
                    for (int n = 0; n < 3; ++n) {
                        along += (c[n] - p0[n]) * d[n];
                        to_c2 += (c[n] - p0[n]) * (c[n] - p0[n]);
                    }
                    const double rho2 = to_c2 - along * along, r2 = sphere.a * sphere.a;
                    if (rho2 > 0.64 * r2) continue;  // as the test: rho <= 0.8 R
                    const double exact = (along - std::sqrt(r2 - rho2)) / view.ray_spacing;
                    Work work;
                    const step03::Hit hit3 =
                        step03::first_hit(volume, view, x, y, surface_threshold, work, nullptr);
                    const step05::Hit hit5 =
                        step05::first_hit(volume, view, x, y, surface_threshold, work, nullptr);
                    if (!hit3.found || !hit5.found) continue;
                    ++measured;
                    sum3 += std::abs(hit3.n - exact);
                    sum5 += std::abs(crossing_of(hit5) - exact);
                    max5 = std::max(max5, std::abs(crossing_of(hit5) - exact));
                    // Normals: step 04 at the hit voxel, step 05 at the sub-voxel point.
                    auto angle = [&](Vec3 gradient, const double p[3]) {
                        const double size = length(gradient);
                        double dot = 0, dist = 0;
                        for (int n = 0; n < 3; ++n) dist += (p[n] - c[n]) * (p[n] - c[n]);
                        dist = std::sqrt(dist);
                        const double g[3] = {gradient.i, gradient.j, gradient.k};
                        for (int n = 0; n < 3; ++n) dot += -g[n] / size * (p[n] - c[n]) / dist;
                        return std::acos(std::clamp(dot, -1.0, 1.0)) * 180 / pi;
                    };
                    const Voxel v4 = view.voxel(x, y, hit3.n);
                    const double p4[3] = {v4.i * volume.sx, v4.j * volume.sy, v4.k * volume.sz};
                    const double a4 = angle(step04::gradient_at(volume, v4, work), p4);
                    const double s5 = crossing_of(hit5) * view.ray_spacing;
                    const double p5[3] = {p0[0] + s5 * d[0], p0[1] + s5 * d[1],
                                          p0[2] + s5 * d[2]};
                    const double a5 = angle(
                        step05::gradient_along_ray(volume, view, x, y, hit5.n, hit5.fraction, work),
                        p5);
                    normal4 += a4;
                    normal5 += a5;
                    max_normal5 = std::max(max_normal5, a5);
                }
            const std::string name = "sphere R = 20, " + view.name + " view (" +
                                     std::to_string(measured) + " rays, rho <= 0.8 R): ";
            Case c;
            c.test = test_s;
            c.analytic = "c - sqrt(R^2 - rho^2)";
            c.name = name + "depth, step 03 (mean)";
            c.measured = "samples";
            c.abs_error = sum3 / measured;
            cases.push_back(c);
            c.name = name + "depth, step 05 (mean; max)";
            c.measured = format("max %.4f samples", max5);
            c.abs_error = sum5 / measured;
            cases.push_back(c);
            c.analytic = "(p - c) / R";
            c.name = name + "normal, step 04 at the hit voxel (mean)";
            c.measured = "degrees";
            c.abs_error = normal4 / measured;
            cases.push_back(c);
            c.name = name + "normal, step 05 at the sub-voxel hit (mean; max)";
            c.measured = format("max %.3f degrees", max_normal5);
            c.abs_error = normal5 / measured;
            cases.push_back(c);
        }
    }
    // int16 extremes: a crossing between -32768 and 32767.
    {
        const Volume volume = make_volume(4, 4, 4, [](int i, int j, int k) {
            return (k >= 2 || (i == 3 && j == 3 && k == 0)) ? 32767 : -32768; });
        const View top = make_view(volume, ViewAxis::top);
        Work work;
        add_case("int16 extremes: step 05 crossing at threshold 32766", test_s,
                 1.0 + 65534.0 / 65535.0,
                 crossing_of(step05::first_hit(volume, top, 0, 0, 32766, work, nullptr)));
        add_case("int16 extremes: step 05 crossing at threshold 0", test_s,
                 1.0 + 32768.0 / 65535.0,
                 crossing_of(step05::first_hit(volume, top, 0, 0, 0, work, nullptr)));
        const Vec3 gradient = step04::gradient_at(volume, {1, 1, 2}, work);
        add_case("int16 extremes: gradient (32767 + 32768) / 2 along k", test_s, 65535.0 / 2,
                 gradient.k);
    }
    // A constant volume: zero gradient, no normal: ambient, never NaN.
    {
        const Volume volume = make_volume(8, 6, 4, [](int, int, int) { return 500; });
        Work work;
        const Vec3 gradient = step05::gradient_at(volume, {3, 2, 1}, work);
        add_case("constant volume: shade of a zero gradient = ambient", test_s,
                 step05::ambient, step05::shade(gradient, {0, 0, -1}));
    }
}

// --- Output -------------------------------------------------------------------------------

std::string markdown_table(const std::string& study, const char* parameter_name) {
    std::ostringstream out;
    out << "| method | " << parameter_name << " | ms | error | max error | Msamples |\n";
    out << "|---|---:|---:|---:|---:|---:|\n";
    for (const Point& p : points) {
        if (p.study != study) continue;
        out << format("| %s | %s | %.2f | %.4g | %.4g | %.2f |\n", p.method.c_str(),
                      p.parameter.c_str(), p.ms, p.error, p.max_error, p.samples / 1e6);
    }
    return out.str();
}

void write_csv(const std::string& path) {
    std::ofstream out(path);
    out << "study,method,parameter,ms,error,max_error,error_unit,samples\n";
    for (const Point& p : points) {
        out << p.study << ",\"" << p.method << "\"," << p.parameter << ","
            << format("%.4f", p.ms)
            << "," << format("%.6g", p.error) << "," << format("%.6g", p.max_error) << ",\""
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
        nearest.label = (n == 0 ? "SPHERE" : "ELLIPSOID") + std::string(": NEAREST, H = 1..1/16");
    }
    depth.series.erase(depth.series.begin() + 4);
    depth.series.erase(depth.series.begin() + 1);

    plot::Panel step;
    step.title = "COMPOSITING STEP (STEP 08, FRONT)";
    step.x_label = "MS PER FRAME, 1 THREAD";
    step.y_label = "RMSE (8-BIT) VS STEP 1/32";
    step.series = {
        series_of("step", "opacity corrected", "CORRECTED, STEP 4..1/8", blue),
        series_of("step", "not corrected", "NOT CORRECTED", red),
        series_of("step", "opacity corrected, float sums", "CORRECTED, FLOAT SUMS", orange,
                  false),
    };

    plot::Panel ert;
    ert.title = "EARLY RAY TERMINATION (TOP)";
    ert.x_label = "MS PER FRAME, 1 THREAD";
    ert.y_label = "RMSE ADDED (8-BIT)";
    ert.series = {
        series_of("ert", "step 07 front to back", "STEP 07, T* = 0.001..0.1", purple),
        series_of("ert", "step 08 lit, step 1", "STEP 08, T* = 0.001..0.1", green),
    };
    // T* = 0 adds no error, so it cannot sit on a log axis: its time goes into the legend.
    for (plot::Series& s : ert.series) {
        for (size_t n = 0; n < s.notes.size(); ++n) {
            if (s.y[n] == 0) s.label += format(" (T*=0: %.0f MS)", s.x[n]);
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
            return error == not_applicable ? std::string("-") : format("%.3g", error);
        };
        out << format("| %s | %s | %s | %s | %s | %s |\n", c.name.c_str(), c.analytic.c_str(),
                      c.measured.c_str(), figure(c.abs_error).c_str(),
                      figure(c.rel_error).c_str(), c.test.c_str());
    }
    out << "\n### Subnormal arithmetic on this machine\n\n";
    out << "ns per multiply, 4096 values times 0.9, 400 passes (median of " << runs
        << " runs):\n\n";
    out << "| type | normal operands | subnormal operands | subnormal, FTZ+DAZ | slowdown |\n";
    out << "|---|---:|---:|---:|---:|\n";
    out << format("| float | %.3f | %.3f | %.3f | %.0fx |\n", cost.float_normal,
                  cost.float_subnormal, cost.float_flushed,
                  cost.float_subnormal / cost.float_normal);
    out << format("| double | %.3f | %.3f | %.3f | %.0fx |\n", cost.double_normal,
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
        out << format("| %s | %.2f | %d | %.3g |\n", labels[n], rays[n].ns_per_sample,
                      rays[n].subnormal_samples, rays[n].transparency);
    }
    return out.str();
}

std::string load_average() {
    std::ifstream in("/proc/loadavg");
    std::string one, five, fifteen;
    in >> one >> five >> fifteen;
    return one + " " + five + " " + fifteen;
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

int run(int argc, char** argv) {
    std::string out = "out/study";
    for (int n = 1; n < argc; ++n) {
        const std::string flag = argv[n];
        if (flag == "--out" && n + 1 < argc) {
            out = argv[++n];
        } else if (flag == "--runs" && n + 1 < argc) {
            runs = parse_int("--runs", argv[++n], 1, 1000);
        } else if (flag == "--quick") {
            quick = true;
        } else {
            throw InputError("usage: study [--out DIR] [--runs N] [--quick], got '" + flag +
                             "'");
        }
    }
    if (quick) {
        runs = 1;
        reference_step = quick_reference_step;
    }
    make_folder(out);
    const std::string load_before = load_average();
    const machine::OtherLoad others;
    const Timer total;
    depth_study();
    step_study();
    ert_study();
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
    const std::string written_by = format(
        "Written by `make study` (tools/study.cpp) in %.0f s on %d cores (%s); load average "
        "%s before, %s after; other processes used %.0f%% of the cores meanwhile. "
        "Times: median of %d renders, 1 thread.\n",
        total.ms() / 1000, cores, cpu_model().c_str(), load_before.c_str(),
        load_average().c_str(), 100 * others.share(), runs);
    md << written_by << "\n";
    // Each table marked as a section that tools/measured.cpp copies into the handouts' blocks
    // of the same name (make study does), with the line saying where and how it was measured.
    md << "## First-hit depth (top view, 256x256x113, spacing 1:1:2; error in voxels)\n\n"
       << section("study:depth", written_by + "\n" + markdown_table("depth", "step h (voxels)"))
       << "\n";
    md << "## Compositing step (step 08 lit, front view, T* = 0; error in 8-bit units against "
          "step 1/32)\n\n"
       << section("study:step", written_by + "\n" + markdown_table("step-reference", "step") +
                                    "\n" + markdown_table("step", "step (voxels)"))
       << "\n";
    md << "## Early ray termination (top view; error added against T* = 0, 8-bit units)\n\n"
       << section("study:ert", written_by + "\n" + markdown_table("ert", "T*")) << "\n";
    md << "## Float against double sums (step 08, front view; ms column: float time / double "
          "time)\n\n"
       << section("study:precision", written_by + "\n" + markdown_table("precision", "step"))
       << "\n";
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
