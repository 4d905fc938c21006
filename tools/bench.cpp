// bench.cpp: how fast every step renders, with one thread and with all cores, and how much
// faster the shipped code is than a deliberately naive loop of the same step.
//
//   build/bench [--volume phantom|PATH] [--runs N] [--out FILE] [--steps NN,NN]
//               [--flags "FLAGS"] [--quick]                                    (make bench)
//
// For every step at its default settings and every view: ms per frame (median, and min-max,
// over --runs renders after one warm-up), Msamples/s, the parallel speed-up, and the naive
// loop's ms (fewer runs: it is slow). The naive picture must equal the shipped one, and the
// 1-thread picture the all-cores one: the table says so. Writes FILE (out/bench.md) as
// Markdown, on the phantom and, when present, on data/CThead. The targets of issue 5 are
// checked from the same figures at the end (reported, not enforced: timing is no test).
// --steps 07,08 times only those steps. --flags gives every step extra flags after its own
// defaults (say "--tf data/tf/transparent.tf --steps 07"); the naive loop still runs the
// defaults, so its pictures then differ, and the targets are only met at default settings.
//
// --quick (make bench QUICK=1, run by CI so the benchmark cannot rot): the phantom at
// 64 x 64 x 29, one timed render per case, no CThead; exit status 1 when a picture differs.
// Its figures are not to be quoted.
//
// The steps are compiled in here, each in a namespace of its own (all_steps.h, as in
// tests/test_steps.cpp), and their main() runs in-process: load_volume() hands them the
// benchmark's volume and run_views() hands the benchmark their renderer, as they built it.
#include "common/ctlab.h"
#include <sys/stat.h>
#include <cstdarg>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <thread>
#include "machine_load.h"

namespace {

const ctlab::Volume* bench_volume = nullptr;
std::function<void(const ctlab::Options&, const ctlab::Volume&, const ctlab::Renderer&)>
    bench_use;

ctlab::Volume bench_load_volume(const ctlab::Options&) { return *bench_volume; }

int bench_run_views(const ctlab::Options& options, const ctlab::Volume& volume,
                    const ctlab::Renderer& renderer) {
    bench_use(options, volume, renderer);
    return 0;
}

}  // namespace

#define load_volume bench_load_volume
#define run_views bench_run_views
#include "all_steps.h"
#undef load_volume
#undef run_views

using namespace ctlab;

namespace {

constexpr const char* tool_name = "bench";
constexpr int default_runs = 15;      // timed renders per case, after one warm-up
constexpr int min_runs = 10;          // issue 5: at least 10
int naive_runs = min_runs;  // the naive loop is slow: the minimum, 10 (--quick: 1)
constexpr int quick_dims[3] = {64, 64, 29};  // --quick: the phantom this size
constexpr double frame_budget_ms = 16;     // target: every step 01-08, 256x256, all cores
constexpr double f2b_top_budget_ms = 2;    // target: step 07 front to back, top view
constexpr double parallel_target = 1.7;    // target: speed-up of the parallel loop, 2 cores

using StepMain = int (*)(int, char**);
struct Step {
    std::string name;
    StepMain main;
};

const std::vector<Step> steps = [] {
    std::vector<Step> list;
    for (const IncludedStep& step : all_steps) list.push_back({step.name, step.main});
    return list;
}();

// Runs a step's main() with these flags; use() receives the renderer it built.
void with_renderer(const Step& step, const Volume& volume, std::vector<std::string> flags,
                   const std::function<void(const Options&, const Renderer&)>& use) {
    flags.insert(flags.begin(), step.name);
    std::vector<char*> argv;
    for (std::string& flag : flags) argv.push_back(flag.data());
    argv.push_back(nullptr);
    bench_volume = &volume;
    bool reached = false;
    bench_use = [&](const Options& options, const Volume&, const Renderer& renderer) {
        reached = true;
        use(options, renderer);
    };
    const int status = step.main(int(argv.size()) - 1, argv.data());
    if (status != 0 || !reached) {
        throw std::runtime_error(step.name + " did not reach run_views (status " +
                                 std::to_string(status) + ")");
    }
}

// Median and range of a set of timings.
struct Timing {
    double median = 0, min = 0, max = 0;
};

Timing summarise(std::vector<double> ms) {
    std::sort(ms.begin(), ms.end());
    const size_t n = ms.size();
    const double median = n % 2 ? ms[n / 2] : 0.5 * (ms[n / 2 - 1] + ms[n / 2]);
    return {median, ms.front(), ms.back()};
}

// One warm-up, then `runs` timed calls of render(work) -> Image. Keeps the last image and work.
Timing time_renders(int runs, const std::function<Image(Work&)>& render, Image& image,
                    Work& work) {
    Work warm_up;
    image = render(warm_up);
    std::vector<double> ms;
    for (int n = 0; n < runs; ++n) {
        work = Work();
        const Timer timer;
        image = render(work);
        ms.push_back(timer.ms());
    }
    return summarise(ms);
}

bool same_pixels(const Image& a, const Image& b) {
    return a.width == b.width && a.height == b.height &&
           std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(Rgb)) == 0;
}

// --- The naive loops --------------------------------------------------------------------
// "Naive" is each step as it might first be written, before any thought about speed: one
// thread; pixel after pixel, each ray walked in full; every voxel read through a
// std::function (an indirect call the compiler cannot inline or hoist) doing a
// bounds-checked vector read of the untouched cthead[k][j][i] layout; the transfer function
// searched range by range for every sample instead of one table read; step 08's opacity
// correction recomputed for every sample. The arithmetic is the step's own, in the same
// order (its pure helpers - shade, light_direction, mix, corrected_opacity - are called
// directly), so the naive picture is bit for bit the shipped one: the table checks it.

using Sampler = std::function<int(int i, int j, int k)>;

Sampler make_sampler(const Volume& volume) {
    return [&volume](int i, int j, int k) {
        return int(volume.data.at((size_t(k) * volume.ny + j) * volume.nx + i));
    };
}

int sample_at(const Sampler& sample, const View& view, int x, int y, int t) {
    const Voxel voxel = view.voxel(x, y, t);
    return sample(voxel.i, voxel.j, voxel.k);
}

float display(const Volume& volume, int value) {
    const int range = volume.max_value - volume.min_value;
    return range > 0 ? float(value - volume.min_value) / float(range) : 0.0f;
}

// The transfer function of one CT value, searched for every sample (no lookup table).
Rgba classify(const TransferFunction& tf, int value) {
    for (const TfRange& range : tf.ranges) {
        if (value < range.from || value >= range.to) continue;
        const float width = float(range.to - range.from);
        const float f = range.ramp ? float(value - range.from) / width : 0.0f;
        return step06::mix(range.start, range.end, f);
    }
    return {};
}

// Central differences, one-sided at the border, through the sampler (steps 04/05/08).
float naive_derivative(const std::function<double(int)>& sample, int n, int count,
                       double spacing) {
    if (count == 1) return 0.0f;
    if (n == 0) return float((sample(1) - sample(0)) / spacing);
    if (n == count - 1) return float((sample(n) - sample(n - 1)) / spacing);
    return float((sample(n + 1) - sample(n - 1)) / (2 * spacing));
}

Vec3 naive_gradient(const Sampler& sample, const Volume& volume, const Voxel& v, Work& work) {
    ++work.gradients;
    return {naive_derivative([&](int m) { return double(sample(m, v.j, v.k)); }, v.i,
                             volume.nx, volume.sx),
            naive_derivative([&](int m) { return double(sample(v.i, m, v.k)); }, v.j,
                             volume.ny, volume.sy),
            naive_derivative([&](int m) { return double(sample(v.i, v.j, m)); }, v.k,
                             volume.nz, volume.sz)};
}

Vec3 naive_gradient_along_ray(const Sampler& sample, const Volume& volume, const View& view,
                              int x, int y, int before, float fraction, Work& work) {
    const int after = std::min(before + 1, view.ray_length - 1);
    const Vec3 g_before = naive_gradient(sample, volume, view.voxel(x, y, before), work);
    if (fraction == 0.0f) return g_before;
    const Vec3 g_after = naive_gradient(sample, volume, view.voxel(x, y, after), work);
    return (1.0f - fraction) * g_before + fraction * g_after;
}

struct Hit {
    bool found = false;
    int t = 0;           // the sample at or before the hit
    float fraction = 0;  // how far past it the hit lies (step 05)
};

// Steps 02-05: the first sample above the threshold, interpolated (step 05) or not.
Hit naive_first_hit(const Sampler& sample, const View& view, int x, int y, int threshold,
                    bool interpolate, Work& work) {
    int previous = 0;
    for (int t = 0; t < view.ray_length; ++t) {
        const int value = sample_at(sample, view, x, y, t);
        ++work.samples;
        if (value > threshold) {
            ++work.hits;
            if (t + 1 < view.ray_length) ++work.terminated;
            if (!interpolate || t == 0) return {true, t, 0.0f};
            const float fraction = float(threshold - previous) / float(value - previous);
            return {true, t - 1, fraction};
        }
        previous = value;
    }
    return {};
}

Rgb naive_pixel(const std::string& step, const Volume& volume, const Sampler& sample,
                const TransferFunction& tf, const View& view, int x, int y, Work& work) {
    const int threshold = step02::bone_threshold;  // the same 400 in steps 02-05
    if (step == step00::step_name) {
        ++work.samples;
        return grey(display(volume, sample_at(sample, view, x, y, view.ray_length / 2)));
    }
    if (step == step01::step_name) {
        int highest = sample_at(sample, view, x, y, 0);
        for (int t = 0; t < view.ray_length; ++t) {
            highest = std::max(highest, sample_at(sample, view, x, y, t));
            ++work.samples;
        }
        return grey(display(volume, highest));
    }
    if (step == step02::step_name || step == step03::step_name) {
        const Hit hit = naive_first_hit(sample, view, x, y, threshold, false, work);
        if (step == step02::step_name) return grey(hit.found ? 1.0f : 0.0f);
        return grey(hit.found ? 1.0f - hit.t / float(view.ray_length) : 0.0f);
    }
    if (step == step04::step_name || step == step05::step_name) {
        const bool interpolate = step == step05::step_name;
        const Hit hit = naive_first_hit(sample, view, x, y, threshold, interpolate, work);
        if (!hit.found) return grey(0.0f);
        const Vec3 gradient =
            interpolate ? naive_gradient_along_ray(sample, volume, view, x, y, hit.t,
                                                   hit.fraction, work)
                        : naive_gradient(sample, volume, view.voxel(x, y, hit.t), work);
        const double angle = step04::default_light_angle;
        return grey(step04::shade(gradient, step04::light_direction(view, angle)));
    }
    if (step == step06::step_name) {  // back to front, from the far end
        double r = 0, g = 0, b = 0;
        for (int t = view.ray_length - 1; t >= 0; --t) {
            const Rgba s = classify(tf, sample_at(sample, view, x, y, t));
            ++work.samples;
            if (s.a == 0.0f) {
                ++work.skipped;
                continue;
            }
            const double light = 1.0, alpha = s.a;
            r = alpha * light * s.r + (1 - alpha) * r;
            g = alpha * light * s.g + (1 - alpha) * g;
            b = alpha * light * s.b + (1 - alpha) * b;
        }
        return {float(r), float(g), float(b)};
    }
    // Steps 07, 08 and 09: front to back with early ray termination at their default 0.01.
    const bool lit = step == step08::step_name || step == step09::step_name;
    const double stop_below = std::max(step07::default_ert, step07::min_transparency);
    const double step_length = lit ? step08::default_step : view.ray_spacing;
    const double ratio = step08::default_step / step08::unit_length;
    const int count = lit ? std::max(1, int(std::lround(view.ray_length * view.ray_spacing /
                                                         step_length)))
                          : view.ray_length;
    const Vec3 to_light = step08::light_direction(view, step08::default_light_angle);
    double r = 0, g = 0, b = 0, transparency = 1;
    for (int n = 0; n < count; ++n) {
        Rgba s;
        double position = n;
        int before = n;
        float fraction = 0;
        if (lit) {  // step 08: interpolated along the ray, opacity corrected per sample
            position = n * (step_length / view.ray_spacing);  // as the step computes it
            before = std::min(int(position), view.ray_length - 1);
            const int after = std::min(before + 1, view.ray_length - 1);
            fraction = float(position - before);
            const float v0 = float(sample_at(sample, view, x, y, before));
            const float v1 = float(sample_at(sample, view, x, y, after));
            const float value = v0 + fraction * (v1 - v0);
            s = classify(tf, int(double(value) - lowest_ct_value) + lowest_ct_value);
            s.a = step08::corrected_opacity(s.a, ratio);
        } else {
            s = classify(tf, sample_at(sample, view, x, y, n));
        }
        ++work.samples;
        if (s.a == 0.0f) {
            ++work.skipped;
            continue;
        }
        double light = 1.0;
        if (lit) {
            light = step08::shade(naive_gradient_along_ray(sample, volume, view, x, y, before,
                                                           fraction, work),
                                  to_light);
        }
        const double weight = transparency * s.a * light;
        r += weight * s.r;
        g += weight * s.g;
        b += weight * s.b;
        transparency *= 1 - double(s.a);
        if (transparency < stop_below && n + 1 < count) {
            ++work.terminated;
            break;
        }
    }
    return {float(r), float(g), float(b)};  // over a black background
}

Image naive_render(const std::string& step, const Volume& volume, const View& view,
                   Work& work) {
    const Sampler sample = make_sampler(volume);
    const TransferFunction tf = load_transfer_function("");
    Image image(view.width, view.height);
    for (int y = 0; y < view.height; ++y) {
        for (int x = 0; x < view.width; ++x) {
            image.at(x, y) = naive_pixel(step, volume, sample, tf, view, x, y, work);
        }
    }
    return image;
}

// --- Measuring and reporting ------------------------------------------------------------

struct Row {
    std::string step, view;
    int width = 0, height = 0;
    uint64_t samples = 0;  // visited along the rays
    uint64_t leapt = 0;    // passed over unread, in bricks the table leaves empty (09)
    Timing one, all, naive;
    bool threads_identical = false, naive_identical = false;
    double others = 0;  // share of the cores other processes used while this step was timed
};

std::string text_of(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string text_of(const char* format, ...) {
    char buffer[512];
    va_list arguments;
    va_start(arguments, format);
    std::vsnprintf(buffer, sizeof buffer, format, arguments);
    va_end(arguments);
    return buffer;
}

std::string first_line_of(const std::string& path, const std::string& key) {
    std::ifstream in(path);
    for (std::string line; std::getline(in, line);) {
        if (line.rfind(key, 0) != 0) continue;
        const size_t colon = line.find(':');
        return colon == std::string::npos ? line : line.substr(colon + 2);
    }
    return "unknown";
}

std::string load_average() {
    std::ifstream in("/proc/loadavg");
    std::string one, five, fifteen;
    in >> one >> five >> fifteen;
    return one + " " + five + " " + fifteen;
}

// Whether `name` ("07_compositing_order") is among `only` ("07,08"; "" for every step).
bool selected(const std::string& name, const std::string& only) {
    if (only.empty()) return true;
    std::stringstream list(only);
    std::string number;
    while (std::getline(list, number, ',')) {
        if (!number.empty() && name.compare(0, number.size(), number) == 0) return true;
    }
    return false;
}

std::vector<Row> bench_volume_rows(const Volume& volume, int runs, int cores,
                                   const std::string& only,
                                   const std::vector<std::string>& extra_flags) {
    std::vector<Row> rows;
    for (const Step& step : steps) {
        if (!selected(step.name, only)) continue;
        std::vector<Row> step_rows;
        for (const View& view : views_named(volume, "all")) {
            Row row;
            row.step = step.name;
            row.view = view.name;
            row.width = view.width;
            row.height = view.height;
            step_rows.push_back(row);
        }
        std::vector<Image> pictures[2];
        const machine::OtherLoad others;
        for (int pass = 0; pass < 2; ++pass) {
            const int threads = pass == 0 ? 1 : cores;
            std::vector<std::string> flags = {"--threads", std::to_string(threads), "--no-window"};
            flags.insert(flags.end(), extra_flags.begin(), extra_flags.end());
            with_renderer(step, volume, flags,
                          [&](const Options& options, const Renderer& renderer) {
                const std::vector<View> views = views_named(volume, "all");
                for (size_t v = 0; v < views.size(); ++v) {
                    Image image;
                    Work work;
                    const Timing timing = time_renders(runs, [&](Work& w) {
                        return render_view(options, views[v], renderer, w);
                    }, image, work);
                    (pass == 0 ? step_rows[v].one : step_rows[v].all) = timing;
                    step_rows[v].samples = work.samples;
                    step_rows[v].leapt = work.leapt;
                    pictures[pass].push_back(image);
                }
            });
        }
        const std::vector<View> views = views_named(volume, "all");
        for (size_t v = 0; v < views.size(); ++v) {
            Image naive;
            Work work;
            step_rows[v].naive = time_renders(naive_runs, [&](Work& w) {
                return naive_render(step.name, volume, views[v], w);
            }, naive, work);
            step_rows[v].threads_identical = same_pixels(pictures[0][v], pictures[1][v]);
            // The naive loop visits every sample the shipped one visits or leaps over.
            step_rows[v].naive_identical =
                same_pixels(naive, pictures[0][v]) &&
                work.samples == step_rows[v].samples + step_rows[v].leapt;
        }
        const double others_share = others.share();
        for (size_t v = 0; v < views.size(); ++v) {
            step_rows[v].others = others_share;
            const Row& r = step_rows[v];
            std::printf("%-22s %-5s %2d threads %8.2f ms  1 thread %8.2f ms  naive %8.2f ms"
                        "  identical %s/%s  others %.0f%%\n", r.step.c_str(), r.view.c_str(),
                        cores, r.all.median, r.one.median, r.naive.median,
                        r.threads_identical ? "yes" : "NO", r.naive_identical ? "yes" : "NO",
                        100 * r.others);
            std::fflush(stdout);
            rows.push_back(r);
        }
    }
    return rows;
}

std::string table(const std::vector<Row>& rows, int cores) {
    std::ostringstream out;
    out << "| step | view | pixels | Msamples visited | Msamples leapt | 1 thread ms: median "
        << "(min-max) | " << cores << " threads ms: median (min-max) | Msamples/s (visited + "
        << "leapt, " << cores << " thr) | parallel "
        << "speed-up | naive ms | speed-up over naive | same picture: 1 vs " << cores
        << " thr, naive | others' CPU |\n";
    out << "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|\n";
    for (const Row& r : rows) {
        out << text_of("| %s | %s | %dx%d | %.2f | %.2f | %.2f (%.2f-%.2f) | %.2f (%.2f-%.2f) | "
                       "%.0f | %.2fx | %.1f | %.1fx | %s, %s | %.0f%% |\n",
                       r.step.c_str(), r.view.c_str(), r.width, r.height, r.samples / 1e6,
                       r.leapt / 1e6, r.one.median, r.one.min, r.one.max, r.all.median,
                       r.all.min, r.all.max, (r.samples + r.leapt) / 1e3 / r.all.median,
                       r.one.median / r.all.median,
                       r.naive.median, r.naive.median / r.all.median,
                       r.threads_identical ? "yes" : "**no**",
                       r.naive_identical ? "yes" : "**no**", 100 * r.others);
    }
    return out.str();
}

// One step's figures on the phantom as the handouts quote them, marked as section
// "bench:NN_name" for tools/measured.cpp (make bench copies it into the handout's block).
std::string step_section(const std::vector<Row>& rows, const std::string& step, int cores,
                         int runs, double others_share) {
    std::ostringstream out;
    out << "<!-- section: bench:" << step << " -->\n";
    out << text_of("Measured by `make bench` on %d cores (%s), median of %d renders; other "
                   "processes used %.0f%% of the cores during the run.\n\n",
                   cores, first_line_of("/proc/cpuinfo", "model name").c_str(), runs,
                   100 * others_share);
    out << "| view | 1 thread | " << cores << " threads | parallel speed-up | ns per sample, "
        << "1 thread | naive loop |\n";
    out << "|---|---:|---:|---:|---:|---:|\n";
    for (const Row& r : rows) {
        if (r.step != step) continue;
        out << text_of("| %s | %.2f ms | %.2f ms | %.2fx | %.2f | %.1f ms |\n", r.view.c_str(),
                       r.one.median, r.all.median, r.one.median / r.all.median,
                       r.samples > 0 ? r.one.median * 1e6 / double(r.samples) : 0.0,
                       r.naive.median);
    }
    out << "<!-- end section -->\n";
    return out.str();
}

// The targets of issue 5, checked on the phantom's figures.
std::string targets(const std::vector<Row>& rows, int cores) {
    std::ostringstream out;
    double one_sum = 0, all_sum = 0;
    int over_budget = 0, budget_views = 0, not_identical = 0;
    std::string slow;
    double f2b_top = 0;
    for (const Row& r : rows) {
        one_sum += r.one.median;
        all_sum += r.all.median;
        if (!r.threads_identical) ++not_identical;
        if (r.step == step07::step_name && r.view == "top") f2b_top = r.all.median;
        const bool counted = r.step >= "01" && r.width == 256 && r.height == 256;
        if (!counted) continue;
        ++budget_views;
        if (r.all.median >= frame_budget_ms) {
            ++over_budget;
            slow += text_of(" %s %.1f ms;", r.step.c_str(), r.all.median);
        }
    }
    const double parallel = one_sum / all_sum;
    out << "| target | measured | met |\n|---|---|---|\n";
    out << text_of("| every step 01-09, default settings, 256x256 view (top), %d threads: "
                   "under %.0f ms | %d of %d under%s | %s |\n",
                   cores, frame_budget_ms, budget_views - over_budget, budget_views,
                   slow.empty() ? "" : (" (over:" + slow + ")").c_str(),
                   over_budget == 0 ? "yes" : "no");
    out << text_of("| step 07 front to back, top view: under %.0f ms | %.2f ms | %s |\n",
                   f2b_top_budget_ms, f2b_top, f2b_top < f2b_top_budget_ms ? "yes" : "no");
    out << text_of("| parallel loop on %d cores: at least %.1fx | %.2fx (sum of 1-thread "
                   "medians / sum of %d-thread medians, every step and view) | %s |\n",
                   cores, parallel_target, parallel, cores,
                   parallel >= parallel_target ? "yes" : "no");
    out << text_of("| 1 and %d threads give identical pictures | %s | %s |\n", cores,
                   not_identical == 0 ? "identical, every step and view"
                                      : (std::to_string(not_identical) + " differ").c_str(),
                   not_identical == 0 ? "yes" : "no");
    return out.str();
}

bool file_exists(const std::string& path) {
    struct stat info {};
    return stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode);
}

int run(int argc, char** argv) {
    std::string volume_name = "phantom", out_path = "out/bench.md", only;
    std::vector<std::string> extra_flags;  // --flags: given to every step, after its defaults
    int runs = default_runs;
    bool quick = false;
    for (int n = 1; n < argc; ++n) {
        const std::string flag = argv[n];
        const bool has_value = n + 1 < argc;
        if (flag == "--quick") {
            quick = true;
        } else if (flag == "--volume" && has_value) {
            volume_name = argv[++n];
        } else if (flag == "--runs" && has_value) {
            runs = parse_int("--runs", argv[++n], min_runs, 1000);
        } else if (flag == "--out" && has_value) {
            out_path = argv[++n];
        } else if (flag == "--steps" && has_value) {
            only = argv[++n];
        } else if (flag == "--flags" && has_value) {
            std::istringstream words(argv[++n]);
            for (std::string word; words >> word;) extra_flags.push_back(word);
        } else {
            throw InputError("usage: bench [--volume phantom|PATH] [--runs N>=10] [--out FILE]"
                             " [--steps NN,NN] [--flags \"FLAGS\"] [--quick], got '" + flag +
                             "'");
        }
    }
    if (quick) runs = naive_runs = 1;
    const unsigned hardware = std::thread::hardware_concurrency();
    const int cores = hardware > 0 ? int(hardware) : 1;
    std::vector<std::pair<std::string, Volume>> volumes;
    if (quick && volume_name == "phantom") {
        volumes.emplace_back("phantom", make_phantom_sized(quick_dims[0], quick_dims[1],
                                                           quick_dims[2]));
    } else {
        volumes.emplace_back(volume_name, volume_name == "phantom" ? make_phantom()
                                                                   : load_cthead(volume_name));
    }
    if (!quick && volume_name == "phantom" && file_exists("data/CThead")) {
        volumes.emplace_back("data/CThead", load_cthead("data/CThead"));
    }

    const std::string load_before = load_average();
    const machine::OtherLoad others;
    std::ostringstream report;
    report << "# ctlab benchmark\n\n";
    if (quick) {
        report << "**Quick mode** (--quick): a small volume and one render per case, to check "
               << "that the benchmark runs and its pictures agree. Do not quote these figures.\n\n";
    }
    if (!extra_flags.empty()) {
        std::string joined;
        for (const std::string& word : extra_flags) joined += " " + word;
        report << "**Not the default settings:** every step ran with" << joined << ". The naive "
               << "loop runs the defaults, so its pictures differ; the targets are for the "
               << "defaults.\n\n";
    }
    report << "Written by `make bench` (tools/bench.cpp). Machine: " << cores << " cores, "
           << first_line_of("/proc/cpuinfo", "model name") << "; compiler " << __VERSION__
           << ", the Makefile's flags (-O2 unless OPT says otherwise). Each figure is the "
           << "median "
           << "of " << runs << " renders after one warm-up (naive loop: " << naive_runs
           << "), min-max in brackets. Load average before the run: " << load_before
           << " (the machine is shared: a load above 0.5 inflates the figures).\n\n";
    report << "*Naive* is each step as first written, one thread: pixel after pixel, every "
           << "voxel read through a `std::function` doing a bounds-checked read of the "
           << "untouched layout, the transfer function searched range by range per sample (no "
           << "table), step 08's opacity correction recomputed per sample, no brick leapt "
           << "over. Its arithmetic is the step's, so its picture must equal the shipped one "
           << "(last column).\n\n";
    std::vector<Row> phantom_rows;
    int differing = 0;  // rows whose pictures differ between threads or from the naive loop
    for (const auto& [name, volume] : volumes) {
        std::printf("bench: %s (%dx%dx%d), %d runs, 1 and %d threads\n", name.c_str(),
                    volume.nx, volume.ny, volume.nz, runs, cores);
        const std::vector<Row> rows = bench_volume_rows(volume, runs, cores, only, extra_flags);
        if (phantom_rows.empty()) phantom_rows = rows;
        for (const Row& row : rows) {
            differing += !row.threads_identical || (extra_flags.empty() && !row.naive_identical);
        }
        report << "## " << name << " (" << volume.nx << "x" << volume.ny << "x" << volume.nz
               << ")\n\n" << table(rows, cores) << "\n";
    }
    // The targets are about every step at its default settings: checked only for such a run.
    const std::string target_table =
        only.empty() && extra_flags.empty()
            ? targets(phantom_rows, cores)
            : "Not checked: the targets need every step at its default settings (no --steps, "
              "no --flags).\n";
    report << "## Targets (issue 5), on " << volumes[0].first << "\n\n" << target_table << "\n";
    report << text_of("Load average after the run: %s. Other processes used %.0f%% of the %d "
                      "cores during the whole run (last column: during each step's timing); "
                      "figures taken above a few percent are not to be trusted.\n",
                      load_average().c_str(), 100 * others.share(), cores);
    // The handouts quote these (make bench runs build/measured): only full runs of the
    // phantom at default settings, so that a quick or a tuned run never reaches a handout.
    if (!quick && extra_flags.empty() && volume_name == "phantom") {
        report << "\n## Per step, as the handouts quote it\n\n";
        std::vector<std::string> names;
        for (const Row& row : phantom_rows) {
            if (names.empty() || names.back() != row.step) names.push_back(row.step);
        }
        for (const std::string& name : names) {
            report << step_section(phantom_rows, name, cores, runs, others.share()) << "\n";
        }
    }

    const size_t slash = out_path.rfind('/');
    if (slash != std::string::npos) make_folder(out_path.substr(0, slash));
    std::ofstream file(out_path);
    if (!file) throw InputError("--out: cannot write '" + out_path + "'");
    file << report.str();
    std::printf("\n%s", target_table.c_str());
    std::printf("bench: other processes used %.0f%% of the cores during the run\n",
                100 * others.share());
    std::printf("bench: wrote %s\n", out_path.c_str());
    if (quick && differing > 0) {
        std::printf("bench: %d step views give different pictures (see the table)\n", differing);
        return 1;
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    return guarded_main(tool_name, [&] { return run(argc, argv); });
}
