// bench.cpp: how fast every step renders, with one thread and with two.
//
//   build/bench [--volume phantom|PATH] [--runs N] [--out FILE] [--steps NN,NN]
//               [--flags "FLAGS"] [--quick] [--peers] [--gain]         (make bench, make gain)
//
// Each step runs as its own program (tools/run_step.h), as a student runs it, at its default
// settings, with --repeat N: every view is rendered N times, and its summary line gives the
// first render's time (time_ms=, cold: caches and pages not yet warm) and the median of the
// other N - 1 (warm_ms=). On the 256x256 views the cold figure is the median of the first
// renders of five such processes (four more, each rendering once). For every step and view the table gives both, with 1 and with 2
// threads, Msamples/s and the parallel speed-up; and whether the two pictures are identical
// (the float images, --pfm). Writes FILE (out/bench.md) as Markdown, on the phantom and,
// when present, on data/CThead. The speed targets are checked from the same figures at the
// end: reported, never enforced (timing is no test).
// --steps 08,10 times only those steps. --flags gives every step extra flags after its own
// defaults (say "--tf data/tf/transparent.tf --steps 08"); the targets are only checked for
// a run of every step at its default settings.
//
// Two more sets of rows, for the targets: step 11 with --unlit (the empty-space step without
// lighting), and every step's top view on a large volume (the phantom made at 512 x 512 x 512
// and written to a raw file) with the peak memory of each run (the child's ru_maxrss), to
// check that the time per visited sample and the memory grow with the work, not faster.
//
// --quick (make bench QUICK=1, run by CI so the benchmark cannot rot): the phantom at
// 64 x 64 x 29 (written to a raw file), one render per view, no CThead, the large volume
// 128 x 128 x 128; exit status 1 when the 1- and 2-thread pictures differ. Its figures are
// not to be quoted.
//
// The machine is shared: a burst of other work, or a stretch where the host gives this
// machine less than its cores, slows every render of the process it falls on (one idle run
// timed step 04's top view at 7.4 ms on 2 threads, the next at 17.1). So a full run makes
// `passes` passes over every step, one after the other, and each figure is the median of the
// passes' figures: a burst spoils one pass of one step, not the figure.
//
// The peers (a run at the defaults, and --quick): VolPack and VTK, when installed, time the
// four cases of ../shared/performance.md on the phantom at spacing 1,1,1 (--quick: the small
// phantom) interleaved with ctlab's candidate steps for each case; a table of ratios peer ms /
// ctlab ms, first renders, and issue #30's targets met or missed (see peers_section).
// --peers makes that table alone (with --steps, for those ctlab steps alone). --gain (make gain) times the part-3 steps alone, in CPU
// time per render on the same cases (see gain_report; with --steps, those steps alone).
//
// A full run on the phantom at default settings also writes each step's figures as a section
// "bench:NN_name" for tools/measured.cpp (make bench copies them into the handouts' blocks).
#include "common/ctlab.h"
#include <sys/stat.h>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <thread>
#include "machine_load.h"
#include "run_step.h"
#include "text_format.h"

using namespace ctlab;

namespace {

constexpr const char* tool_name = "bench";
constexpr int default_runs = 15;         // renders per view: the first (cold) + 14 for the median
constexpr int min_runs = 10;             // fewer makes the median a poor figure
// Fresh processes per view and thread count whose first render gives the cold figure (their
// median): one first render of 0.2 ms is a coin flip against another, a median of five is not.
// The 256^2 rows only; a 512^3 run loads 256 MiB each time and takes one.
constexpr int cold_processes = 5;
constexpr int passes = 3;  // passes over every step (full runs); each figure their median
// Speed checks that differ by more than this factor: the machine did not keep its speed.
constexpr double speed_spread_limit = 1.1;
constexpr double run_timeout_s = 600;    // one step, every view, every render
constexpr double frame_budget_ms = 16;   // target: every step 01 on, 256x256 view, 2 threads
constexpr double leap_top_budget_ms = 8;  // target: step 11 (empty-space leaping, lit), top view
constexpr double cold_ratio_target = 1.5;  // target: first render / warm median, every view
// The first-render target again, on the renders of at least this warm median only: below it
// (00_slices, 0.1-0.6 ms), a page fault or a timer tick more in the first render is a large
// share of it, and the ratio measures that rather than what a student waits for.
constexpr double cold_ratio_min_warm_ms = 1;
constexpr double unlit_top_budget_ms = 2;  // target: step 11 with --unlit, top view
constexpr int quick_dims[3] = {64, 64, 29};  // --quick: the phantom this size
constexpr int large_dims = 512;              // the large volume: the phantom at 512^3
constexpr int quick_large_dims = 128;        // --quick: at 128^3
constexpr int large_runs = 5;                // renders per run on it: the first + 4 warm
constexpr double per_sample_growth_target = 1.5;  // large / 256^2: time per visited sample
constexpr double memory_target = 1.2;             // peak memory / the volume's int16 bytes
constexpr double parallel_target = 1.7;  // target: speed-up of the parallel loop, 2 threads
constexpr int thread_counts[2] = {1, 2};
// Part 2: each camera step's default run is the oblique view (azimuth 30, elevation 20,
// orthographic, 512x512, the classic table); VTK's CPU ray caster needs about 30 ms for it.
constexpr double camera_budget_ms = 10;     // target: step 25 (composite, leaping), 2 threads
constexpr double isosurface_budget_ms = 15;  // target: step 19 (the isosurface), 2 threads
const char* const first_camera_step = "13_";  // camera views only from here (12: axis views)
const char* const camera_step = "25_";       // the composite camera step's number (leaping)
const char* const isosurface_step = "19_";   // checked once a step 19_* exists
// Blocked light: a default picture usable in the window (shadow rays are allowed longer).
constexpr double shadow_rays_budget_ms = 1000;  // target: steps 22 and 24, 2 threads
constexpr double light_volume_budget_ms = 200;  // target: step 23 (the light volume), 2 threads
// Issue #27: every lesson step (parts 1 and 2) renders its default picture, each view, fast
// enough to use in the window; the shadow-ray steps (shadow_rays_step, occlusion_step) get
// shadow_rays_budget_ms.
constexpr double lesson_window_budget_ms = 200;  // target: warm, 2 threads
constexpr int first_part3_step = 30;  // steps numbered from here on are part 3's
const char* const shadow_rays_step = "22_";
const char* const light_volume_step = "23_";
const char* const occlusion_step = "24_";  // shadow rays and ambient occlusion

// The steps: every steps/NN_name.cpp (make bench runs from the repository). Part 2's steps
// take --view all too and render one view, "camera": their default run (see camera_budget_ms)
// is one row.
std::vector<std::string> step_names() {
    std::vector<std::string> names;
    std::error_code error;
    for (const auto& entry : std::filesystem::directory_iterator("steps", error)) {
        const std::string stem = entry.path().stem().string();
        if (entry.path().extension() == ".cpp" && stem.size() > 3 && std::isdigit(stem[0]) &&
            std::isdigit(stem[1]) && stem[2] == '_') {
            names.push_back(stem);
        }
    }
    if (error) throw InputError("bench: run it from the repository (no folder 'steps')");
    std::sort(names.begin(), names.end());
    return names;
}

bool same_pixels(const Image& a, const Image& b) {
    return a.width == b.width && a.height == b.height &&
           std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(Rgb)) == 0;
}

struct Times {
    double cold = 0, warm = 0;  // ms: the first render (median over fresh processes), the
                                // median of the others
};

double median_of(std::vector<double> values) {
    std::sort(values.begin(), values.end());
    const size_t n = values.size();
    return n == 0 ? 0 : n % 2 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2;
}

struct Row {
    std::string step, view, size;
    std::string flags;     // extra flags of this row ("--unlit"), "" at the defaults
    uint64_t samples = 0;  // visited along the rays
    uint64_t leapt = 0;    // passed over unread, in bricks the table leaves empty
    Times one, two;        // 1 and 2 threads
    long rss_one_kib = 0, rss_two_kib = 0;  // the run's peak memory, 1 and 2 threads
    bool threads_identical = false;
    double others = 0;  // share of the cores other processes used while this step was timed

    std::string label() const { return flags.empty() ? step : step + " " + flags; }
    // Nanoseconds per visited sample, warm median.
    double ns_per_sample(const Times& times) const {
        return samples > 0 ? times.warm * 1e6 / double(samples) : 0.0;
    }
    // Nanoseconds per sample along the rays, visited or leapt over (what the step would visit
    // without leaping), warm median; the same as ns_per_sample for a step that does not leap.
    double ns_per_position(const Times& times) const {
        return samples + leapt > 0 ? times.warm * 1e6 / double(samples + leapt) : 0.0;
    }
};

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

// Whether `name` ("08_compositing_order") is among `only` ("07,08"; "" for every step).
bool selected(const std::string& name, const std::string& only) {
    if (only.empty()) return true;
    std::stringstream list(only);
    std::string number;
    while (std::getline(list, number, ',')) {
        if (!number.empty() && name.compare(0, number.size(), number) == 0) return true;
    }
    return false;
}

// `volume`: the flags that load the volume ("--volume phantom", or a raw file's flags);
// `view`: "all", or one view.
std::vector<Row> bench_volume_rows(const std::vector<std::string>& volume, int runs,
                                   const std::string& only,
                                   const std::vector<std::string>& extra_flags,
                                   const std::string& view = "all", int processes = 1) {
    std::string joined;  // extra_flags as one string, for the rows' labels
    for (const std::string& word : extra_flags) joined += (joined.empty() ? "" : " ") + word;
    std::vector<Row> rows;
    const TempFolder folder("bench");
    for (const std::string& step : step_names()) {
        if (!selected(step, only)) continue;
        // One axis view (the large volume's rows) exists in part 1 only: from step 13 on a
        // step renders its camera view and refuses --view top.
        if (view != "all" && step.compare(0, 2, first_camera_step, 2) >= 0) continue;
        std::vector<Row> step_rows;
        std::vector<Image> pictures[2];
        const machine::OtherLoad others;
        for (int pass = 0; pass < 2; ++pass) {
            const int threads = thread_counts[pass];
            const std::string out = folder.path(std::to_string(threads));
            std::vector<std::string> flags = volume;
            flags.insert(flags.end(), {"--view", view, "--threads", std::to_string(threads),
                                       "--repeat", std::to_string(runs), "--pfm", "--out", out});
            flags.insert(flags.end(), extra_flags.begin(), extra_flags.end());
            const RunResult run = run_step(step, flags, run_timeout_s);
            if (run.status != 0 || run.summaries.empty()) {
                throw std::runtime_error(run.command() + " failed (status " +
                                         std::to_string(run.status) + "): " + run.err);
            }
            for (size_t v = 0; v < run.summaries.size(); ++v) {
                const Summary& line = run.summaries[v];
                if (pass == 0) {
                    Row row;
                    row.step = step;
                    row.view = line.at("view");
                    row.size = line.at("size");
                    row.samples = summary_count(line, "samples");
                    row.leapt = summary_count(line, "leapt");
                    row.flags = joined;
                    step_rows.push_back(row);
                }
                Row& row = step_rows.at(v);
                Times& times = pass == 0 ? row.one : row.two;
                (pass == 0 ? row.rss_one_kib : row.rss_two_kib) = run.max_rss_kib;
                times.cold = summary_number(line, "time_ms");
                times.warm = runs > 1 ? summary_number(line, "warm_ms") : times.cold;
                pictures[pass].push_back(read_pfm(step_output(out, step, row.view, "pfm")));
            }
            // More fresh processes, one render each: the cold figure is their median.
            std::vector<std::vector<double>> colds(step_rows.size());
            for (size_t v = 0; v < step_rows.size(); ++v) {
                colds[v].push_back((pass == 0 ? step_rows[v].one : step_rows[v].two).cold);
            }
            for (int process = 1; process < processes; ++process) {
                std::vector<std::string> once = volume;
                once.insert(once.end(), {"--view", view, "--threads", std::to_string(threads),
                                         "--out", out});
                once.insert(once.end(), extra_flags.begin(), extra_flags.end());
                const RunResult again = run_step(step, once, run_timeout_s);
                if (again.status != 0 || again.summaries.size() != step_rows.size()) {
                    throw std::runtime_error(again.command() + " failed (status " +
                                             std::to_string(again.status) + "): " + again.err);
                }
                for (size_t v = 0; v < step_rows.size(); ++v) {
                    colds[v].push_back(summary_number(again.summaries[v], "time_ms"));
                }
            }
            for (size_t v = 0; v < step_rows.size(); ++v) {
                (pass == 0 ? step_rows[v].one : step_rows[v].two).cold = median_of(colds[v]);
            }
        }
        const double others_share = others.share();
        for (size_t v = 0; v < step_rows.size(); ++v) {
            Row& r = step_rows[v];
            r.others = others_share;
            r.threads_identical = v < pictures[1].size() && same_pixels(pictures[0][v],
                                                                        pictures[1][v]);
            std::printf("%-22s %-5s 1 thread %8.2f ms (cold %8.2f)  2 threads %8.2f ms "
                        "(cold %8.2f)  identical %s  others %.0f%%\n",
                        r.label().c_str(), r.view.c_str(), r.one.warm, r.one.cold, r.two.warm,
                        r.two.cold, r.threads_identical ? "yes" : "NO", 100 * r.others);
            std::fflush(stdout);
            rows.push_back(r);
        }
    }
    return rows;
}

// A speed check (tools/machine_load.h) and when in the run it was made.
struct Check {
    std::string when;
    machine::SpeedCheck speed;
};

Check check_speed(const std::string& when) {
    const Check check{when, machine::speed_check()};
    std::printf("bench: speed check %s: %.1f ms on 1 thread, %.1f ms on every core, "
                "memory %.1f ms\n", when.c_str(), check.speed.one_thread_ms,
                check.speed.all_cores_ms, check.speed.memory_ms);
    std::fflush(stdout);
    return check;
}

// `count` passes of `pass` (bench_volume_rows), one after the other, each after a speed check
// (added to `checks`, named after `what`): each time in the rows is the median over the
// passes (memory and others' load: the largest); the pictures must agree in every pass.
std::vector<Row> median_of_passes(int count, const std::string& what, std::vector<Check>& checks,
                                  const std::function<std::vector<Row>()>& pass) {
    std::vector<std::vector<Row>> runs;
    for (int n = 0; n < count; ++n) {
        if (count > 1) std::printf("bench: %s, pass %d of %d\n", what.c_str(), n + 1, count);
        checks.push_back(check_speed(text_of("before %s, pass %d", what.c_str(), n + 1)));
        runs.push_back(pass());
        if (runs.back().size() != runs.front().size()) {
            throw std::runtime_error("bench: the passes timed different steps and views");
        }
    }
    std::vector<Row> rows = runs.front();
    for (size_t r = 0; r < rows.size(); ++r) {
        auto median = [&](double Times::*field, Times Row::*threads) {
            std::vector<double> values;
            for (const std::vector<Row>& run : runs) values.push_back(run[r].*threads.*field);
            return median_of(values);
        };
        for (Times Row::*threads : {&Row::one, &Row::two}) {
            (rows[r].*threads).cold = median(&Times::cold, threads);
            (rows[r].*threads).warm = median(&Times::warm, threads);
        }
        for (const std::vector<Row>& run : runs) {
            rows[r].rss_one_kib = std::max(rows[r].rss_one_kib, run[r].rss_one_kib);
            rows[r].rss_two_kib = std::max(rows[r].rss_two_kib, run[r].rss_two_kib);
            rows[r].threads_identical = rows[r].threads_identical && run[r].threads_identical;
            rows[r].others = std::max(rows[r].others, run[r].others);
        }
    }
    return rows;
}

// The speed checks of a run, as a paragraph: the spread of each, and whether the machine
// kept its speed. `spread` gets the slowest check over the fastest (one thread or every
// core, whichever is more).
std::string speed_report(const std::vector<Check>& checks, int cores, double* spread) {
    double fastest[3] = {1e300, 1e300, 1e300}, slowest[3] = {0, 0, 0};
    std::string each;
    for (const Check& check : checks) {
        const double ms[3] = {check.speed.one_thread_ms, check.speed.all_cores_ms,
                              check.speed.memory_ms};
        for (int t = 0; t < 3; ++t) {
            fastest[t] = std::min(fastest[t], ms[t]);
            slowest[t] = std::max(slowest[t], ms[t]);
        }
        each += text_of("%s%s %.1f / %.1f / %.1f ms", each.empty() ? "" : "; ",
                        check.when.c_str(), ms[0], ms[1], ms[2]);
    }
    *spread = 1;
    for (int t = 0; t < 3 && !checks.empty(); ++t) {
        *spread = std::max(*spread, slowest[t] / fastest[t]);
    }
    return text_of(
        "Speed check (tools/machine_load.h), best of 3 tries each, %zu times in the run: a "
        "fixed loop of integer arithmetic on 1 thread / the same on all %d cores at once / a "
        "walk of dependent reads through 16 MiB: %s. Slowest against fastest, the worst of "
        "the three: %.2fx; every core against one thread, at best: %.2fx (1.00: each core "
        "its own). %s\n",
        checks.size(), cores, each.c_str(), *spread, fastest[1] / fastest[0],
        *spread > speed_spread_limit
            ? "**The host slowed this machine during the run** (its load figures cannot show "
              "it): the times below carry that, and a target missed by less than the spread "
              "says little."
            : "The machine kept its speed through the run.");
}

// A parallel speed-up as the tables print it. Sharing the rows cannot give much more than
// the thread ratio (2x for 1 against 2 threads; a little more can come from a second core's
// caches, or from the few percent two medians of a shared machine differ by). Well above it,
// most likely the host was slower during the 1-thread runs (its speed varies, see the speed
// check): such a figure is flagged, not printed as if it were real.
constexpr const char* speed_up_flag = " (noise)";
constexpr double speed_up_slack = 1.1;  // flagged above the thread ratio times this
std::string speed_up_text(const Row& r) {
    const double speed_up = r.one.warm / r.two.warm;
    const bool flagged =
        speed_up > speed_up_slack * double(thread_counts[1]) / thread_counts[0];
    return text_of("%.2fx%s", speed_up, flagged ? speed_up_flag : "");
}

// What a table's flagged speed-ups mean, or "" when it has none.
std::string speed_up_note(const std::vector<Row>& rows, const std::string& step = "") {
    for (const Row& r : rows) {
        if (!step.empty() && r.step != step) continue;
        if (speed_up_text(r).find(speed_up_flag) == std::string::npos) continue;
        return text_of("A speed-up marked%s is well above the %dx that %d threads can give "
                       "by sharing the rows against %d: most likely the host was slower during "
                       "its 1-thread runs.\n",
                       speed_up_flag, thread_counts[1] / thread_counts[0], thread_counts[1],
                       thread_counts[0]);
    }
    return "";
}

std::string table(const std::vector<Row>& rows) {
    std::ostringstream out;
    out << "| step | view | pixels | Msamples visited | Msamples leapt | 1 thread ms: warm "
        << "(cold) | 2 threads ms: warm (cold) | Msamples/s (visited + leapt, 2 thr, warm) | "
        << "parallel speed-up (warm) | same picture, 1 vs 2 thr | others' CPU |\n";
    out << "|---|---|---|---:|---:|---:|---:|---:|---:|---|---:|\n";
    for (const Row& r : rows) {
        out << text_of("| %s | %s | %s | %.2f | %.2f | %.2f (%.2f) | %.2f (%.2f) | %.0f | "
                       "%s | %s | %.0f%% |\n",
                       r.label().c_str(), r.view.c_str(), r.size.c_str(), r.samples / 1e6,
                       r.leapt / 1e6, r.one.warm, r.one.cold, r.two.warm, r.two.cold,
                       (r.samples + r.leapt) / 1e3 / r.two.warm, speed_up_text(r).c_str(),
                       r.threads_identical ? "yes" : "**no**", 100 * r.others);
    }
    const std::string note = speed_up_note(rows);
    if (!note.empty()) out << "\n" << note;
    return out.str();
}

// The large volume's rows against the 256^2 ones: time per visited sample and peak memory.
// `base`: the phantom's rows (the same step's top view is the reference); `volume_bytes`:
// the large volume's int16 voxels.
struct Growth {
    const Row* row = nullptr;
    double per_sample_one = 0, per_sample_two = 0;  // large / 256^2, warm ns per sample
    double per_position_one = 0, per_position_two = 0;  // the same per visited + leapt sample
    double memory = 0;                              // peak memory / volume bytes, worst pass
};

std::vector<Growth> growth_of(const std::vector<Row>& large, const std::vector<Row>& base,
                              double volume_bytes) {
    std::vector<Growth> growth;
    for (const Row& r : large) {
        Growth g;
        g.row = &r;
        for (const Row& b : base) {
            if (b.step != r.step || b.view != r.view || !b.flags.empty()) continue;
            if (b.ns_per_sample(b.one) > 0) {
                g.per_sample_one = r.ns_per_sample(r.one) / b.ns_per_sample(b.one);
            }
            if (b.ns_per_sample(b.two) > 0) {
                g.per_sample_two = r.ns_per_sample(r.two) / b.ns_per_sample(b.two);
            }
            if (b.ns_per_position(b.one) > 0) {
                g.per_position_one = r.ns_per_position(r.one) / b.ns_per_position(b.one);
            }
            if (b.ns_per_position(b.two) > 0) {
                g.per_position_two = r.ns_per_position(r.two) / b.ns_per_position(b.two);
            }
        }
        g.memory = std::max(r.rss_one_kib, r.rss_two_kib) * 1024.0 / volume_bytes;
        growth.push_back(g);
    }
    return growth;
}

std::string growth_table(const std::vector<Growth>& growth, double volume_bytes,
                         const std::string& base_name) {
    std::ostringstream out;
    out << text_of("The volume's voxels take %.0f MiB. *ns/sample*: warm median over the samples "
                   "visited; *vs base*: that figure over the same step's on the top view of %s "
                   "in this run. *ns/sample along the rays*: the same over the samples visited "
                   "or leapt over (for a step that leaps, most of its work is the leaping and "
                   "the rays, not the samples it visits; for the others both figures are "
                   "equal). *peak memory*: the step program's largest resident size "
                   "(ru_maxrss), 1 and 2 threads.\n\n",
                   volume_bytes / (1 << 20), base_name.c_str());
    out << "| step | pixels | Msamples visited | Msamples leapt | 1 thread ms: warm (cold) | "
        << "2 threads ms: warm (cold) | ns/sample, 1 thr (vs base) | ns/sample, 2 thr (vs base) "
        << "| ns/sample along the rays, 1 thr (vs base) | ns/sample along the rays, 2 thr (vs "
        << "base) | peak memory MiB (1, 2 thr) | peak / volume |\n";
    out << "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const Growth& g : growth) {
        const Row& r = *g.row;
        out << text_of("| %s | %s | %.1f | %.1f | %.1f (%.1f) | %.1f (%.1f) | %.2f (%.2fx) | "
                       "%.2f (%.2fx) | %.2f (%.2fx) | %.2f (%.2fx) | %.0f, %.0f | %.2fx |\n",
                       r.label().c_str(), r.size.c_str(), r.samples / 1e6, r.leapt / 1e6,
                       r.one.warm, r.one.cold, r.two.warm, r.two.cold, r.ns_per_sample(r.one),
                       g.per_sample_one, r.ns_per_sample(r.two), g.per_sample_two,
                       r.ns_per_position(r.one), g.per_position_one, r.ns_per_position(r.two),
                       g.per_position_two, r.rss_one_kib / 1024.0, r.rss_two_kib / 1024.0,
                       g.memory);
    }
    return out.str();
}

// When and under what load the figures were taken, for the handouts' blocks: "2026-11-23
// 13:10 UTC, load average 1.20 1.05 0.98 before the run".
std::string utc_now() {
    const std::time_t now = std::time(nullptr);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
    return text;
}

// One step's figures on the phantom as the handouts quote them, marked as section
// "bench:NN_name" for tools/measured.cpp (make bench copies it into the handout's block).
// `when`: the run's date and the load before it.
std::string step_section(const std::vector<Row>& rows, const std::string& step, int cores,
                         int runs, double others_share, const std::string& when) {
    std::ostringstream out;
    out << "<!-- section: bench:" << step << " -->\n";
    out << text_of("Figures of the last `make bench` (%s), not typed by hand: %d cores (%s), "
                   "each step its own program with `--repeat %d`; *warm* is the median of the "
                   "%d renders after the first, *cold* the first (the `time_ms=` a run prints); "
                   "each figure the median of %d passes over every step. "
                   "Other processes used %.0f%% of the cores during the run: on a shared "
                   "machine the times are high and only their ratios mean much.\n\n",
                   when.c_str(), cores, first_line_of("/proc/cpuinfo", "model name").c_str(),
                   runs, runs - 1, passes, 100 * others_share);
    out << "| view | 1 thread: warm (cold) | 2 threads: warm (cold) | parallel speed-up | "
        << "ns per sample, 1 thread |\n";
    out << "|---|---:|---:|---:|---:|\n";
    for (const Row& r : rows) {
        if (r.step != step) continue;
        const std::string view = r.flags.empty() ? r.view : r.view + ", " + r.flags;
        out << text_of("| %s | %.2f (%.2f) ms | %.2f (%.2f) ms | %s | %.2f |\n", view.c_str(),
                       r.one.warm, r.one.cold, r.two.warm, r.two.cold, speed_up_text(r).c_str(),
                       r.ns_per_sample(r.one));
    }
    const std::string note = speed_up_note(rows, step);
    if (!note.empty()) out << "\n" << note;
    out << "<!-- end section -->\n";
    return out.str();
}

// Part 2's targets: a camera step's default (oblique, 512x512) run on 2 threads, warm and
// cold. The isosurface row waits, "no step yet", until a step 19_* is benched.
std::string camera_targets(const std::vector<Row>& rows) {
    std::ostringstream out;
    auto row = [&](const char* number, const char* what, double budget) {
        const Row* found = nullptr;
        for (const Row& r : rows) {
            if (r.step.rfind(number, 0) == 0 && r.view == "camera") found = &r;
        }
        if (!found) {
            out << text_of("| %s: oblique %s, 2 threads: at most %.0f ms | no step %s* "
                           "benched | | - |\n", what, "512x512", budget, number);
            return;
        }
        out << text_of("| %s (%s), oblique %s, 2 threads: at most %.0f ms | %.2f (%.2f) ms | "
                       "%.2f (%.2f) ms | %s |\n", what, found->step.c_str(),
                       found->size.c_str(), budget, found->one.warm, found->one.cold,
                       found->two.warm, found->two.cold,
                       found->two.warm <= budget ? "met" : "**missed**");
    };
    row(camera_step, "free camera, composite", camera_budget_ms);
    row(isosurface_step, "isosurface", isosurface_budget_ms);
    row(shadow_rays_step, "shadow rays", shadow_rays_budget_ms);
    row(light_volume_step, "light volume", light_volume_budget_ms);
    row(occlusion_step, "shadow rays and ambient occlusion", shadow_rays_budget_ms);
    return out.str();
}

// The speed targets, each with its figures (warm medians and cold first renders, 1 and 2
// threads): `rows` the first volume's (the phantom's), `unlit` step 11 --unlit's on it,
// `growth` the large volume's against them.
std::string targets(const std::vector<Row>& rows, const std::vector<Row>& unlit,
                    const std::vector<Growth>& growth, const std::string& large_name,
                    const std::string& base_name) {
    std::ostringstream out;
    auto met = [](bool yes) { return yes ? "met" : "**missed**"; };
    auto figures = [](const Row& r) {
        return text_of("%.2f (%.2f) ms | %.2f (%.2f) ms", r.one.warm, r.one.cold, r.two.warm,
                       r.two.cold);
    };
    out << "Each target is on the 2-thread warm median unless it says otherwise; the figures "
        << "give warm (cold) for 1 and 2 threads.\n\n";
    out << "| target | 1 thread: warm (cold) | 2 threads: warm (cold) | result |\n";
    out << "|---|---:|---:|---|\n";
    double one_sum = 0, two_sum = 0;
    int not_identical = 0;
    double worst_cold[2] = {0, 0};  // first render / warm median, 1 and 2 threads
    std::string worst_cold_view[2];
    double worst_cold_long[2] = {0, 0};  // the same, renders of cold_ratio_min_warm_ms or more
    std::string worst_cold_long_view[2];
    int cold_slower_with_two = 0;  // views whose first render is slower on 2 threads than on 1
    std::string slower_views;
    std::vector<const Row*> all;
    for (const Row& r : rows) all.push_back(&r);
    for (const Row& r : unlit) all.push_back(&r);
    for (const Row* r : all) {
        const Times* times[2] = {&r->one, &r->two};
        for (int t = 0; t < 2; ++t) {
            const double ratio = times[t]->warm > 0 ? times[t]->cold / times[t]->warm : 0;
            if (ratio > worst_cold[t]) {
                worst_cold[t] = ratio;
                worst_cold_view[t] = r->label() + " " + r->view;
            }
            if (times[t]->warm >= cold_ratio_min_warm_ms && ratio > worst_cold_long[t]) {
                worst_cold_long[t] = ratio;
                worst_cold_long_view[t] = r->label() + " " + r->view;
            }
        }
        if (r->two.cold > r->one.cold) {
            ++cold_slower_with_two;
            if (cold_slower_with_two <= 4) slower_views += " " + r->label() + " " + r->view + ";";
        }
        one_sum += r->one.warm;
        two_sum += r->two.warm;
        if (!r->threads_identical) ++not_identical;
    }
    // The frame budget: every step from 01 at its defaults, its 256x256 view.
    for (const Row& r : rows) {
        if (r.step < "01" || r.size != "256x256" || !r.flags.empty()) continue;
        out << text_of("| %s %s (%s) under %.0f ms | %s | %s |\n", r.step.c_str(),
                       r.view.c_str(), r.size.c_str(), frame_budget_ms, figures(r).c_str(),
                       met(r.two.warm < frame_budget_ms));
    }
    // The window budget: every lesson step's views at their defaults, the worst against its
    // budget named.
    const Row* worst_window = nullptr;
    double worst_window_share = 0, worst_window_budget = 0;
    int lesson_rows = 0;
    for (const Row& r : rows) {
        if (r.step < "01" || std::stoi(r.step.substr(0, 2)) >= first_part3_step ||
            !r.flags.empty()) {
            continue;
        }
        ++lesson_rows;
        const bool shadow_rays = r.step.rfind(shadow_rays_step, 0) == 0 ||
                                 r.step.rfind(occlusion_step, 0) == 0;
        const double budget = shadow_rays ? shadow_rays_budget_ms : lesson_window_budget_ms;
        if (r.two.warm / budget > worst_window_share) {
            worst_window_share = r.two.warm / budget;
            worst_window = &r;
            worst_window_budget = budget;
        }
    }
    if (worst_window) {
        out << text_of("| every lesson step (%d views at their defaults) usable in the window: "
                       "at most %.0f ms warm, shadow rays (%s*, %s*) %.0f ms, 2 threads | | "
                       "worst %s %s (%s): %.2f ms of %.0f | %s |\n",
                       lesson_rows, lesson_window_budget_ms, shadow_rays_step, occlusion_step,
                       shadow_rays_budget_ms, worst_window->step.c_str(),
                       worst_window->view.c_str(), worst_window->size.c_str(),
                       worst_window->two.warm, worst_window_budget,
                       met(worst_window_share <= 1));
    }
    for (const Row& r : rows) {
        if (r.step.rfind("11_", 0) != 0 || r.view != "top") continue;
        out << text_of("| step 11 (empty space, lit) top under %.0f ms | %s | %s |\n",
                       leap_top_budget_ms, figures(r).c_str(),
                       met(r.two.warm < leap_top_budget_ms));
    }
    for (const Row& r : unlit) {
        if (r.view != "top") continue;
        out << text_of("| step 11 %s top under %.0f ms | %s | %s |\n", r.flags.c_str(),
                       unlit_top_budget_ms, figures(r).c_str(),
                       met(r.two.warm < unlit_top_budget_ms));
    }
    for (int t = 0; t < 2; ++t) {
        const std::string worst = text_of("worst %.2fx (%s)", worst_cold[t],
                                          worst_cold_view[t].c_str());
        out << text_of("| first render at most %.1fx the warm median, every view, %d thread%s | "
                       "%s | %s | %s |\n",
                       cold_ratio_target, t + 1, t == 0 ? "" : "s",
                       t == 0 ? worst.c_str() : "", t == 1 ? worst.c_str() : "",
                       met(worst_cold[t] <= cold_ratio_target));
    }
    for (int t = 0; t < 2; ++t) {
        const std::string worst = text_of("worst %.2fx (%s)", worst_cold_long[t],
                                          worst_cold_long_view[t].c_str());
        out << text_of("| the same, views whose warm median is %.0f ms or more (below it a page "
                       "fault or a timer tick is a large share of the render), %d thread%s | "
                       "%s | %s | %s |\n",
                       cold_ratio_min_warm_ms, t + 1, t == 0 ? "" : "s",
                       t == 0 ? worst.c_str() : "", t == 1 ? worst.c_str() : "",
                       met(worst_cold_long[t] <= cold_ratio_target));
    }
    out << text_of("| first render never slower on 2 threads than on 1 | %d of %zu views "
                   "slower%s | | %s |\n",
                   cold_slower_with_two, all.size(),
                   slower_views.empty() ? "" : (" (" + slower_views + " ...)").c_str(),
                   met(cold_slower_with_two == 0));
    double worst_growth[2] = {0, 0}, worst_memory = 0;
    std::string worst_growth_step[2], worst_memory_step;
    double worst_position[2] = {0, 0};  // per sample along the rays (visited + leapt)
    std::string worst_position_step[2];
    for (const Growth& g : growth) {
        const double per_sample[2] = {g.per_sample_one, g.per_sample_two};
        const double per_position[2] = {g.per_position_one, g.per_position_two};
        for (int t = 0; t < 2; ++t) {
            if (per_sample[t] > worst_growth[t]) {
                worst_growth[t] = per_sample[t];
                worst_growth_step[t] = g.row->label();
            }
            if (per_position[t] > worst_position[t]) {
                worst_position[t] = per_position[t];
                worst_position_step[t] = g.row->label();
            }
        }
        if (g.memory > worst_memory) {
            worst_memory = g.memory;
            worst_memory_step = g.row->label();
        }
    }
    if (!growth.empty()) {
        out << text_of("| %s, top view: time per visited sample (warm) within %.1fx of %s's, "
                       "every step | worst %.2fx (%s) | worst %.2fx (%s) | %s |\n",
                       large_name.c_str(), per_sample_growth_target, base_name.c_str(),
                       worst_growth[0], worst_growth_step[0].c_str(), worst_growth[1],
                       worst_growth_step[1].c_str(),
                       met(std::max(worst_growth[0], worst_growth[1]) <=
                           per_sample_growth_target));
        out << text_of("| the same per sample along the rays, visited or leapt over (step 11's "
                       "work is mostly leaping and rays: its visited samples are a small share) "
                       "| worst %.2fx (%s) | worst %.2fx (%s) | %s |\n",
                       worst_position[0], worst_position_step[0].c_str(), worst_position[1],
                       worst_position_step[1].c_str(),
                       met(std::max(worst_position[0], worst_position[1]) <=
                           per_sample_growth_target));
        out << text_of("| %s: peak memory within %.1fx of the volume's size, every step | "
                       "worst %.2fx (%s), 1 or 2 threads | | %s |\n",
                       large_name.c_str(), memory_target, worst_memory,
                       worst_memory_step.c_str(), met(worst_memory <= memory_target));
    }
    const double parallel = two_sum > 0 ? one_sum / two_sum : 0;
    out << text_of("| parallel loop on 2 threads: at least %.1fx (sum of 1-thread warm medians "
                   "/ sum of 2-thread ones, every step and view) | %.1f ms | %.1f ms: %.2fx | "
                   "%s |\n",
                   parallel_target, one_sum, two_sum, parallel, met(parallel >= parallel_target));
    out << camera_targets(rows);
    out << text_of("| 1 and 2 threads give identical pictures | %s | | %s |\n",
                   not_identical == 0 ? "identical, every step and view"
                                      : (std::to_string(not_identical) + " differ").c_str(),
                   met(not_identical == 0));
    return out.str();
}

// --- Start-up: what a step costs before it renders (common/module.h) ----------------------
constexpr int startup_runs = 51;                 // processes per figure; the median is quoted
constexpr double startup_budget_ms = 3;          // target: `02_threshold --help`, median wall
constexpr const char* startup_step = "02_threshold";

// The median wall time of `program args` run `count` times, each a fresh process (with the
// tools' one way to start a child process, run_program).
double median_start_ms(const std::string& program, const std::vector<std::string>& args,
                       int count) {
    std::vector<double> times;
    for (int n = 0; n < count; ++n) {
        const Timer timer;
        const RunResult run = run_program(program, args, run_timeout_s);
        times.push_back(timer.ms());
        if (run.status != 0) {
            throw InputError(program + " exited with status " + std::to_string(run.status) +
                             " while timing its start");
        }
    }
    return median_of(times);
}

// The start-up table: a step's --help, a phantom run of a tiny volume, and /bin/true (what
// starting any process costs here), each the median of startup_runs fresh processes.
std::string startup_section(int count, bool* met) {
    const std::string step = step_binary(startup_step);
    const TempFolder out("bench_startup");
    const double bare = median_start_ms("/bin/true", {}, count);
    const double help = median_start_ms(step, {"--help"}, count);
    const double tiny = median_start_ms(
        step, {"--volume", "phantom", "--dims", "8,8,4", "--view", "top", "--no-window",
               "--threads", "1", "--out", out.path()},
        count);
    *met = help <= startup_budget_ms;
    return text_of("| program | median wall (ms) |\n|---|---:|\n"
                   "| `/bin/true` (starting any process) | %.2f |\n"
                   "| `%s --help` | %.2f |\n"
                   "| `%s` on an 8x8x4 phantom, top view, 1 thread | %.2f |\n\n"
                   "Each the median of %d fresh processes. Target: `--help` within %.0f ms: "
                   "**%s**. A step maps no format or window library until a file or a "
                   "window needs one (common/module.h).\n",
                   bare, startup_step, help, startup_step, tiny, count, startup_budget_ms,
                   *met ? "met" : "missed");
}

bool file_exists(const std::string& path) {
    struct stat info {};
    return stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode);
}

// --- The peers: VolPack and VTK against ctlab, case by case (../shared/performance.md) ---
// Four cases on the phantom at spacing 1,1,1 with the classic table: a composite unlit top
// view, b composite lit top view, c composite unlit oblique (azimuth 30, elevation 20, the
// bounding sphere filling 512x512), d maximum intensity top view. Each pass runs, case by
// case, every ctlab candidate (1 thread, then every core) and each installed peer (VolPack:
// build/peer_volpack, 1 thread; VTK: tools/peer_vtk.py under xvfb-run, every core), each a
// fresh process rendering `runs` times: its first render is the cold figure, the median of
// the others the warm one. Odd passes run the case's programs in the other order, so that
// a drift of the machine's speed hits ctlab and the peers alike; every figure is the median
// over the passes. Ratios are peer ms / ctlab ms (above 1: ctlab is faster). The targets'
// step renders once in cold_processes - 1 more fresh processes per case, thread count and
// pass: its first render is the median of them all (why: at peer_cold_ratio_target).
struct PeerCase {
    char id;           // 'a'..'d'
    const char* what;  // for the tables
    bool oblique;      // 512x512 (quick: 128x128), else one pixel per voxel, top view
};
const PeerCase peer_cases[] = {{'a', "composite unlit, top", false},
                               {'b', "composite lit, top", false},
                               {'c', "composite unlit, oblique", true},
                               {'d', "maximum intensity, top", false}};
constexpr int peer_case_count = 4;
constexpr int oblique_side = 512, quick_oblique_side = 128;  // pixels, case c

// Issue #30's targets for the last part-3 step, all cores: peer ms / ctlab ms at least this
// (0: none; VolPack has no maximum intensity).
constexpr double volpack_target[peer_case_count] = {2, 1.5, 1, 0};
constexpr double vtk_target[peer_case_count] = {8, 6, 6, 5};
constexpr double volpack_one_thread_goal = 1;   // cases a and b, ctlab on 1 thread
constexpr double peer_cold_ratio_target = 3;    // first render (fresh process) / warm
// A first render writes memory its process has never touched (step 46: 15 MiB of records),
// and the kernel clears each new page as it hands it over. On the lab's VM (its balloon
// reports free memory to the host) that clearing took about 0.1 ms per MiB of 2 MiB pages in
// most processes and 0.7-2.6 ms per MiB in others, with nothing in the process to tell them
// apart: step 46's case b on one thread, the same command alone at load 0.1, precomputed its
// tables in 11-18 ms in 8 runs of 10 and 31-47 ms in 2; its user-space instructions do not
// vary (callgrind: 294,006,199 and 294,006,195), nor its minor faults (5,567-5,570), and every
// huge page was granted; perf: the slow runs' extra time is the kernel's clear_page. Which
// runs are slow followed no rest (5 s before a run or none) and no order that we tried. So
// one first render per pass, three in all, let a median fall in the slow mode (one idle run:
// 45.6 ms for case b on one thread, 8.9 on two); the targets' step's first render is the
// median of cold_processes fresh processes per pass, and the table gives every first
// render's lowest and highest.

// ctlab's candidates for each case, by step name (the number may change): the flags that
// make it render the case ("" when it cannot). Part-3 steps (number >= first_part3_step)
// are candidates for every case with the camera flags of part 2's steps. ctlab's figure for
// a case is its fastest candidate's (every core); the targets are about the last part-3 step.
struct CandidateRule {
    const char* name;  // the step's name after "NN_"
    const char* flags[peer_case_count];
};
// "{top}" is the top camera (elevation 90, one pixel per voxel), "{oblique}" the oblique one.
const CandidateRule candidate_rules[] = {
    {"ray_loops", {"", "", "", "--view top"}},
    {"empty_space", {"--view top --unlit", "--view top", "", ""}},
    {"free_camera", {"{top} --unlit", "{top}", "{oblique} --unlit", ""}},
    {"projection_modes", {"", "", "", "{top} --mode mip"}},
};
const CandidateRule part3_rule = {
    "", {"{top} --unlit", "{top}", "{oblique} --unlit", "{top} --mode mip"}};

struct PeerFigure {
    std::vector<double> cold, warm, precompute;  // ms, one per pass
    std::vector<double> precompute_mib;  // the tables it made (shear-warp's "precompute" lines)
    long rss_kib = 0;                            // the largest over the passes
    std::string error;                           // why a run failed ("" when none did)
    bool ran() const { return error.empty() && !warm.empty(); }
    double cold_ms() const { return median_of(cold); }
    double warm_ms() const { return median_of(warm); }
};

struct Candidate {
    std::string step;
    std::vector<std::string> flags[peer_case_count];  // empty: not a candidate for the case
    PeerFigure one[peer_case_count], all[peer_case_count];  // 1 thread, every core
};

std::vector<std::string> words_of(const std::string& text) {
    std::istringstream in(text);
    std::vector<std::string> words;
    for (std::string word; in >> word;) words.push_back(word);
    return words;
}

// The flags of a rule for a case, the cameras filled in for an image of `side` (top) and
// `oblique` pixels on a volume of `dims` voxels (spacing 1: the box spans dims - 1).
std::vector<std::string> case_flags(const char* rule, int side, int oblique, const int dims[3]) {
    std::vector<std::string> flags;
    const double diagonal = std::sqrt(double(dims[0] - 1) * (dims[0] - 1) +
                                      double(dims[1] - 1) * (dims[1] - 1) +
                                      double(dims[2] - 1) * (dims[2] - 1));
    for (const std::string& word : words_of(rule)) {
        if (word == "{top}") {
            for (const std::string& w : {std::string("--azimuth"), std::string("0"),
                                         std::string("--elevation"), std::string("90"),
                                         std::string("--zoom"), std::string("1"),
                                         std::string("--size"), text_of("%dx%d", side, side)}) {
                flags.push_back(w);
            }
        } else if (word == "{oblique}") {
            for (const std::string& w :
                 {std::string("--azimuth"), std::string("30"), std::string("--elevation"),
                  std::string("20"), std::string("--zoom"), text_of("%.4f", oblique / diagonal),
                  std::string("--size"), text_of("%dx%d", oblique, oblique)}) {
                flags.push_back(w);
            }
        } else {
            flags.push_back(word);
        }
    }
    return flags;
}

// `only` ("39"; "" for every step): --steps, for a peer table of those steps alone.
std::vector<Candidate> ctlab_candidates(int side, int oblique, const int dims[3],
                                        const std::string& only) {
    std::vector<Candidate> candidates;
    for (const std::string& step : step_names()) {
        if (!selected(step, only)) continue;
        const CandidateRule* rule = nullptr;
        if (std::stoi(step.substr(0, 2)) >= first_part3_step) rule = &part3_rule;
        for (const CandidateRule& r : candidate_rules) {
            if (step.substr(3) == r.name) rule = &r;
        }
        if (!rule || !file_exists(step_binary(step))) continue;
        Candidate candidate;
        candidate.step = step;
        const bool axes_only = looks_along_axes_only(step);
        for (int c = 0; c < peer_case_count; ++c) {
            if (!*rule->flags[c]) continue;
            if (axes_only && std::string(rule->flags[c]).find("{oblique}") != std::string::npos) {
                std::printf("bench: %s looks along an axis only: not a candidate for case %c\n",
                            step.c_str(), peer_cases[c].id);
                continue;
            }
            candidate.flags[c] = case_flags(rule->flags[c], side, oblique, dims);
        }
        candidates.push_back(candidate);
    }
    return candidates;
}

// Adds one run's figures (or its failure) to `figure`.
// One fresh process of `step`; false (and figure.error: its status and first error line)
// when it failed or printed no summary line.
bool step_ran(PeerFigure& figure, const std::string& step,
              const std::vector<std::string>& flags, RunResult& run) {
    run = run_step(step, flags, run_timeout_s);
    if (run.status == 0 && !run.summaries.empty()) return true;
    const std::string why = run.err.substr(0, run.err.find('\n'));
    figure.error = text_of("status %d: %s", run.status, why.c_str());
    return false;
}

void add_ctlab_run(PeerFigure& figure, const std::string& step,
                   const std::vector<std::string>& flags) {
    RunResult run;
    if (!step_ran(figure, step, flags, run)) return;
    const Summary& line = run.summaries.front();
    figure.cold.push_back(summary_number(line, "time_ms"));
    figure.warm.push_back(line.count("warm_ms") ? summary_number(line, "warm_ms")
                                                : figure.cold.back());
    if (line.count("precompute_ms")) {
        figure.precompute.push_back(summary_number(line, "precompute_ms"));
    }
    // The tables' memory: a step that makes tables once per process prints a line
    // "precompute ... runs_mb=R normals_mb=N ..." as it makes them (MiB; runs per principal
    // axis, normals so far; records_mb=, the runs' packed voxels, per axis like the runs).
    std::istringstream out(run.out);
    double runs_mib = 0, normals_mib = 0;
    bool tables = false;
    for (std::string text; std::getline(out, text);) {
        if (text.rfind("precompute ", 0) != 0) continue;
        const Summary made = parse_summary(text);
        if (made.count("runs_mb")) runs_mib += summary_number(made, "runs_mb");
        if (made.count("records_mb")) runs_mib += summary_number(made, "records_mb");
        if (made.count("normals_mb")) normals_mib = summary_number(made, "normals_mb");
        tables = true;
    }
    if (tables) figure.precompute_mib.push_back(runs_mib + normals_mib);
    figure.rss_kib = std::max(figure.rss_kib, run.max_rss_kib);
}

// More fresh processes of `step`, one render each: their first renders join figure.cold.
void add_first_renders(PeerFigure& figure, const std::string& step,
                       const std::vector<std::string>& flags, int processes) {
    RunResult run;
    for (int process = 0; process < processes && figure.error.empty(); ++process) {
        if (!step_ran(figure, step, flags, run)) return;
        figure.cold.push_back(summary_number(run.summaries.front(), "time_ms"));
    }
}

void add_peer_run(PeerFigure& figure, const std::string& program,
                  const std::vector<std::string>& args) {
    const RunResult run = run_program(program, args, run_timeout_s);
    std::istringstream lines(run.out);
    Summary line;
    for (std::string text; std::getline(lines, text);) {
        if (text.rfind("peer=", 0) == 0) line = parse_summary(text);
    }
    if (run.status != 0 || !line.count("warm_ms")) {
        const std::string why = run.err.substr(0, run.err.find('\n'));
        figure.error = text_of("status %d: %s", run.status, why.c_str());
        return;
    }
    figure.cold.push_back(summary_number(line, "cold_ms"));
    figure.warm.push_back(summary_number(line, "warm_ms"));
    if (line.count("precompute_ms")) {
        figure.precompute.push_back(summary_number(line, "precompute_ms"));
    }
    figure.rss_kib = std::max(figure.rss_kib, run.max_rss_kib);
}

bool vtk_installed() {
    try {
        return run_program("/usr/bin/python3", {"-c", "import vtk"}, 60).status == 0 &&
               run_program("/bin/sh", {"-c", "command -v xvfb-run"}, 10).status == 0;
    } catch (const std::exception&) {
        return false;
    }
}

std::string ms_text(const PeerFigure& figure) {
    if (!figure.error.empty()) return "failed";
    return figure.warm.empty() ? "-" : text_of("%.2f", figure.warm_ms());
}

std::string ratio_text(const PeerFigure& peer, const PeerFigure& ours) {
    if (!peer.ran() || !ours.ran() || ours.warm_ms() <= 0) return "-";
    return text_of("%.2fx", peer.warm_ms() / ours.warm_ms());
}

// The fastest candidate for case c on every core (nullptr: none ran).
const Candidate* fastest_for(const std::vector<Candidate>& candidates, int c) {
    const Candidate* best = nullptr;
    for (const Candidate& candidate : candidates) {
        if (!candidate.all[c].ran()) continue;
        if (!best || candidate.all[c].warm_ms() < best->all[c].warm_ms()) best = &candidate;
    }
    return best;
}

// The peer section of the report: `raw` is the volume written as a raw file (spacing 1),
// `dims` its size. `failed`: an installed peer or a candidate failed (the quick run's exit
// status).
std::string peers_section(const std::string& raw, const int dims[3], int runs, int pass_count,
                          const std::string& only, int cores, bool quick, bool* failed) {
    const int side = dims[0];
    const int oblique = quick ? quick_oblique_side : oblique_side;
    const std::string volpack = build_folder() + "/peer_volpack";
    const bool have_volpack = file_exists(volpack);
    const bool have_vtk = vtk_installed();
    std::vector<Candidate> candidates = ctlab_candidates(side, oblique, dims, only);
    PeerFigure volpack_figures[peer_case_count], vtk_figures[peer_case_count];
    const TempFolder folder("bench_peers");
    const std::vector<std::string> volume_flags = {
        "--volume", raw, "--dims", text_of("%d,%d,%d", dims[0], dims[1], dims[2]),
        "--spacing", "1,1,1", "--no-window", "--out", folder.path("ctlab")};
    const std::string peer_runs = std::to_string(std::max(runs, 2));
    for (int pass = 0; pass < pass_count; ++pass) {
        for (int c = 0; c < peer_case_count; ++c) {
            const PeerCase& pc = peer_cases[c];
            const int size = pc.oblique ? oblique : side;
            const std::string picture = folder.path(text_of("%c.ppm", pc.id));
            const std::vector<std::string> peer_args = {
                raw, std::to_string(dims[0]), std::to_string(dims[1]), std::to_string(dims[2]),
                std::string(1, pc.id), std::to_string(size), std::to_string(size), peer_runs,
                picture};
            // The case's programs, in this pass's order.
            std::vector<std::function<void()>> programs;
            for (Candidate& candidate : candidates) {
                if (candidate.flags[c].empty()) continue;
                for (int threads : {1, cores}) {
                    programs.push_back([&, threads, c] {
                        std::vector<std::string> flags = volume_flags;
                        flags.insert(flags.end(), candidate.flags[c].begin(),
                                     candidate.flags[c].end());
                        flags.insert(flags.end(), {"--threads", std::to_string(threads),
                                                   "--repeat", std::to_string(runs)});
                        PeerFigure& figure = threads == 1 ? candidate.one[c] : candidate.all[c];
                        if (figure.error.empty()) add_ctlab_run(figure, candidate.step, flags);
                    });
                    if (cores == 1) break;
                }
            }
            if (have_volpack && pc.id != 'd') {
                programs.push_back([&, c] {
                    if (volpack_figures[c].error.empty()) {
                        add_peer_run(volpack_figures[c], volpack, peer_args);
                    }
                });
            }
            if (have_vtk) {
                programs.push_back([&, c] {
                    std::vector<std::string> args = {"-a", "/usr/bin/python3",
                                                     "tools/peer_vtk.py"};
                    args.insert(args.end(), peer_args.begin(), peer_args.end());
                    args.push_back(std::to_string(cores));
                    if (vtk_figures[c].error.empty()) {
                        add_peer_run(vtk_figures[c], "xvfb-run", args);
                    }
                });
            }
            if (pass % 2) std::reverse(programs.begin(), programs.end());
            for (auto& program : programs) program();
        }
        std::printf("bench: peers, pass %d of %d done\n", pass + 1, pass_count);
        std::fflush(stdout);
    }

    std::ostringstream out;
    out << text_of("VolPack (build/peer_volpack, 1 thread): %s. VTK (tools/peer_vtk.py, "
                   "vtkFixedPointVolumeRayCastMapper, %d threads): %s. Each program ran "
                   "afresh per case and pass, rendering %s times: *warm* is the median of all "
                   "but the first render, *first* the first (VolPack's includes its "
                   "classification, VTK's its normals, ctlab's its precomputation and the "
                   "fresh memory it writes, which the kernel clears, on this kind of machine "
                   "some runs several times slower than others). Medians over %d pass%s "
                   "(first renders: with their lowest and highest%s), the programs "
                   "of a case interleaved (reversed every other pass). Ratios: peer ms / "
                   "ctlab ms, above 1 when ctlab is faster. The volume: %dx%dx%d, spacing "
                   "1,1,1.\n\n",
                   have_volpack ? "installed" : "**not installed** (make bench PEERS=1)", cores,
                   have_vtk ? "installed" : "**not installed** (make bench PEERS=1)",
                   peer_runs.c_str(), pass_count, pass_count == 1 ? "" : "es",
                   quick ? ""
                         : text_of("; the targets' step's over %d fresh processes per pass",
                                   cold_processes).c_str(),
                   dims[0],
                   dims[1], dims[2]);
    const Candidate* target_step = nullptr;
    for (const Candidate& candidate : candidates) {
        if (std::stoi(candidate.step.substr(0, 2)) >= first_part3_step) target_step = &candidate;
    }
    // The targets' step's first render: cold_processes - 1 more fresh processes per case,
    // thread count and pass (one render each), so that its median is not one of three.
    for (Candidate& candidate : candidates) {
        if (&candidate != target_step || quick) continue;
        for (int pass = 0; pass < pass_count; ++pass) {
            for (int c = 0; c < peer_case_count; ++c) {
                if (candidate.flags[c].empty()) continue;
                for (int threads : {1, cores}) {
                    std::vector<std::string> flags = volume_flags;
                    flags.insert(flags.end(), candidate.flags[c].begin(),
                                 candidate.flags[c].end());
                    flags.insert(flags.end(), {"--threads", std::to_string(threads)});
                    add_first_renders(threads == 1 ? candidate.one[c] : candidate.all[c],
                                      candidate.step, flags, cold_processes - 1);
                    if (cores == 1) break;
                }
            }
        }
    }
    // Every candidate, every case: what ctlab's choice is made from.
    out << "| case | ctlab step | 1 thread warm (first; lowest-highest) ms | " << cores
        << " threads warm (first; lowest-highest) ms |\n|---|---|---:|---:|\n";
    for (int c = 0; c < peer_case_count; ++c) {
        for (const Candidate& candidate : candidates) {
            if (candidate.flags[c].empty()) continue;
            // The first renders' lowest and highest too: a median hides a split.
            auto cell = [](const PeerFigure& f) {
                if (!f.ran()) return "failed: " + f.error;
                const auto [low, high] = std::minmax_element(f.cold.begin(), f.cold.end());
                return f.cold.size() > 1 ? text_of("%.2f (%.2f; %.2f-%.2f)", f.warm_ms(),
                                                   f.cold_ms(), *low, *high)
                                         : text_of("%.2f (%.2f)", f.warm_ms(), f.cold_ms());
            };
            std::string flags;
            for (const std::string& w : candidate.flags[c]) flags += " " + w;
            out << text_of("| %c | %s%s | %s | %s |\n", peer_cases[c].id, candidate.step.c_str(),
                           flags.c_str(), cell(candidate.one[c]).c_str(),
                           cell(candidate.all[c]).c_str());
            if (!candidate.one[c].error.empty() || !candidate.all[c].error.empty()) {
                // A part-3 step may not take part 2's flags for every case: noted, not fatal.
                if (std::stoi(candidate.step.substr(0, 2)) < first_part3_step) *failed = true;
            }
        }
    }
    // The peer table: ctlab's fastest step per case against the peers.
    out << "\n| case | ctlab's fastest (every core) | ctlab 1 thread ms | ctlab " << cores
        << " threads ms | VolPack ms | VTK ms | VolPack / ctlab 1 thread | VolPack / ctlab "
        << cores << " threads | VTK / ctlab " << cores << " threads |\n"
        << "|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (int c = 0; c < peer_case_count; ++c) {
        const Candidate* best = fastest_for(candidates, c);
        const PeerFigure none;
        const PeerFigure& one = best ? best->one[c] : none;
        const PeerFigure& all = best ? best->all[c] : none;
        out << text_of("| %c %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", peer_cases[c].id,
                       peer_cases[c].what, best ? best->step.c_str() : "none ran",
                       ms_text(one).c_str(), ms_text(all).c_str(),
                       peer_cases[c].id == 'd' ? "none" : ms_text(volpack_figures[c]).c_str(),
                       ms_text(vtk_figures[c]).c_str(),
                       ratio_text(volpack_figures[c], one).c_str(),
                       ratio_text(volpack_figures[c], all).c_str(),
                       ratio_text(vtk_figures[c], all).c_str());
    }
    // First renders in a fresh process, with the precomputation inside them.
    out << "\n| case | VolPack first ms (classification, memory) | VTK first ms (memory) |"
        << " ctlab first ms, " << cores << " threads (step, precomputation, memory) |\n"
        << "|---|---:|---:|---:|\n";
    for (int c = 0; c < peer_case_count; ++c) {
        const Candidate* best = target_step ? target_step : fastest_for(candidates, c);
        const PeerFigure& vp = volpack_figures[c];
        std::string precompute =
            best && !best->all[c].precompute.empty()
                ? text_of("precomputation %.1f ms, ", median_of(best->all[c].precompute))
                : std::string();
        if (best && !best->all[c].precompute_mib.empty()) {
            precompute += text_of("its tables %.2f MiB, ", median_of(best->all[c].precompute_mib));
        }
        out << text_of("| %c | %s | %s | %s |\n", peer_cases[c].id,
                       vp.ran() ? text_of("%.1f (%.1f, %.0f MiB)", vp.cold_ms(),
                                          median_of(vp.precompute), vp.rss_kib / 1024.0).c_str()
                                : ms_text(vp).c_str(),
                       vtk_figures[c].ran() ? text_of("%.1f (%.0f MiB)", vtk_figures[c].cold_ms(),
                                                      vtk_figures[c].rss_kib / 1024.0).c_str()
                                            : ms_text(vtk_figures[c]).c_str(),
                       best && best->all[c].ran()
                           ? text_of("%.1f (%s, %s%.0f MiB)", best->all[c].cold_ms(),
                                     best->step.c_str(), precompute.c_str(),
                                     best->all[c].rss_kib / 1024.0).c_str()
                           : "-");
    }
    // The targets' step: the last part-3 step (until part 3 exists, the fastest per case).
    out << "\n### Issue #30's targets (reported, never enforced)\n\n"
        << (target_step ? "For the last part-3 step, " + target_step->step + ". "
                        : std::string("No part-3 step yet: shown for ctlab's fastest step "
                                      "per case. "))
        << "Each target is a ratio peer ms / ctlab ms, warm medians: met with how much to spare, "
           "or missed by the factor ctlab still has to gain; in brackets the measured ratio over "
           "the target.\n\n"
        << "| target | measured | verdict |\n|---|---:|---|\n";
    auto verdict = [&](const std::string& what, double measured, double target) {
        if (measured <= 0) {
            out << "| " << what << " | - | not measured |\n";
            return;
        }
        // By how much: met with room to spare, or missed by a factor (the speed-up still
        // needed), and the measured ratio over the target.
        const bool met = measured >= target;
        const std::string how_much = met ? text_of("met, %.2fx to spare", measured / target)
                                         : text_of("**missed** by %.2fx", target / measured);
        out << text_of("| %s | %.2fx | %s (%.2fx the target) |\n", what.c_str(), measured,
                       how_much.c_str(), measured / target);
    };
    auto ratio = [](const PeerFigure& peer, const PeerFigure& ours) {
        return peer.ran() && ours.ran() && ours.warm_ms() > 0 ? peer.warm_ms() / ours.warm_ms()
                                                              : 0.0;
    };
    for (int c = 0; c < peer_case_count; ++c) {
        const Candidate* ours = target_step ? target_step : fastest_for(candidates, c);
        const PeerFigure none;
        const PeerFigure& all = ours ? ours->all[c] : none;
        const PeerFigure& one = ours ? ours->one[c] : none;
        const std::string label = text_of("%c %s", peer_cases[c].id, peer_cases[c].what);
        if (volpack_target[c] > 0) {
            verdict(text_of("%s: VolPack (1 thread) / ctlab (%d threads) >= %.1fx", label.c_str(),
                            cores, volpack_target[c]),
                    ratio(volpack_figures[c], all), volpack_target[c]);
        }
        verdict(text_of("%s: VTK (%d threads) / ctlab (%d threads) >= %.1fx", label.c_str(),
                        cores, cores, vtk_target[c]),
                ratio(vtk_figures[c], all), vtk_target[c]);
        if (peer_cases[c].id == 'a' || peer_cases[c].id == 'b') {
            verdict(text_of("%s: VolPack / ctlab, both 1 thread >= %.0fx (the goal)",
                            label.c_str(), volpack_one_thread_goal),
                    ratio(volpack_figures[c], one), volpack_one_thread_goal);
        }
        if (all.ran() && all.warm_ms() > 0) {
            const double cold_ratio = all.cold_ms() / all.warm_ms();
            const bool cold_met = cold_ratio <= peer_cold_ratio_target;
            const std::string how_much =
                cold_met ? text_of("met, %.2fx to spare", peer_cold_ratio_target / cold_ratio)
                         : text_of("**missed** by %.2fx", cold_ratio / peer_cold_ratio_target);
            out << text_of("| %s: ctlab's first render (fresh process) <= %.0fx its warm one | "
                           "%.2fx | %s |\n", label.c_str(), peer_cold_ratio_target, cold_ratio,
                           how_much.c_str());
        }
    }
    if (have_volpack) {
        for (const PeerFigure& f : volpack_figures) *failed = *failed || !f.error.empty();
    }
    if (have_vtk) {
        for (const PeerFigure& f : vtk_figures) *failed = *failed || !f.error.empty();
    }
    return out.str();
}

// The peer section on the phantom at spacing 1,1,1 (quick: the small phantom), written to a
// raw file the peers and ctlab's steps read alike.
std::string peers_on_phantom(int cores, bool quick, int runs, int pass_count,
                             const std::string& only, bool* failed) {
    const int dims[3] = {quick ? quick_dims[0] : cthead_nx, quick ? quick_dims[1] : cthead_ny,
                         quick ? quick_dims[2] : cthead_nz};
    const TempFolder folder("bench_peer_volume");
    const std::string raw = folder.path("phantom.raw");
    {
        Volume phantom = make_phantom_sized(dims[0], dims[1], dims[2], cores);
        phantom.sx = phantom.sy = phantom.sz = 1;
        write_raw_volume(phantom, raw);
    }
    std::printf("bench: the peers, phantom %dx%dx%d at spacing 1,1,1\n", dims[0], dims[1],
                dims[2]);
    std::fflush(stdout);
    return peers_section(raw, dims, runs, pass_count, only, cores, quick, failed);
}

// --peers: the peer table alone, written to `out_path` (exit status 1 when a run failed).
// `only`: --steps, the ctlab steps timed ("" for every candidate).
int peers_report(int cores, bool quick, int runs, int pass_count, const std::string& only,
                 const std::string& out_path) {
    bool failed = false;
    const std::string load_before = load_average();
    const std::string peers =
        peers_on_phantom(cores, quick, quick ? 2 : runs, pass_count, only, &failed);
    std::ostringstream report;
    report << "# ctlab against its peers\n\nWritten by `build/bench --peers` (tools/bench.cpp), "
           << utc_now() << ". Machine: " << cores << " cores, "
           << first_line_of("/proc/cpuinfo", "model name") << ". Load average before: "
           << load_before << ", after: " << load_average() << ".\n\n" << peers;
    const size_t slash = out_path.rfind('/');
    if (slash != std::string::npos) make_folder(out_path.substr(0, slash));
    std::ofstream file(out_path);
    if (!file) throw InputError("--out: cannot write '" + out_path + "'");
    file << report.str();
    std::printf("\n%s\nbench: wrote %s\n", peers.c_str(), out_path.c_str());
    return failed ? 1 : 0;
}

// --- --gain (make gain): what each part-3 trick gains, in CPU time per render ---
// Every part-3 step renders each peer case (part3_rule's flags, the same as in the peer
// table) on the phantom at spacing 1,1,1 on one thread, once with --repeat 1 and once with
// --repeat gain_repeat, and a render costs the difference of the two processes' CPU time
// (user + system, from the child's rusage) over gain_repeat - 1: loading the volume, the
// bricks and any table made once per process cancel out, and CPU time, unlike wall time,
// depends less on what else the shared machine runs (less, not nothing: under a load of 20
// on 2 cores a step measured 10% slower than its next run). Each figure is the median of
// gain_pairs such pairs, the steps taken in turn for each pair. The report has one section
// per step, "gain:NN_name", for tools/measured.cpp to copy into the handout's block: the
// step's figures, its gain over the step before and over the first part-3 step. `only`
// (--steps, "" for all): those part-3 steps alone (say 30,36,37,38 for a new step 37's block
// and the next one's; keep 30 first, the "over step 30" column).
constexpr int gain_repeat = 11;  // renders in the longer process of a pair
constexpr int gain_pairs = 5;    // pairs per figure (the median)
constexpr int gain_side = cthead_nx;  // the top view: one pixel per voxel

int gain_report(const std::string& out_path, const std::string& only) {
    const int dims[3] = {cthead_nx, cthead_ny, cthead_nz};
    const TempFolder folder("bench_gain");
    std::vector<std::string> volume_flags;
    {
        Volume phantom = make_phantom_sized(dims[0], dims[1], dims[2], 1);
        phantom.sx = phantom.sy = phantom.sz = 1;
        volume_flags = write_raw_volume(phantom, folder.path("phantom.raw"));
    }
    std::vector<std::string> steps;
    for (const std::string& step : step_names()) {
        if (std::stoi(step.substr(0, 2)) < first_part3_step || !selected(step, only)) continue;
        if (!file_exists(step_binary(step))) {
            throw InputError("bench --gain: " + step_binary(step) + " is not built (make all)");
        }
        steps.push_back(step);
    }
    if (steps.empty()) throw InputError("bench --gain: no part-3 step in steps/");
    std::set<std::string> axes_only;  // steps that look along an axis only: no case c
    for (const std::string& step : steps) {
        if (looks_along_axes_only(step)) axes_only.insert(step);
    }
    // Does `step` render case c? Not an oblique case when it looks along an axis only.
    auto renders = [&](const std::string& step, int c) {
        return !axes_only.count(step) ||
               std::string(part3_rule.flags[c]).find("{oblique}") == std::string::npos;
    };
    // CPU seconds of one process rendering `flags` `repeat` times.
    auto cpu_of = [&](const std::string& step, const std::vector<std::string>& flags,
                      int repeat) {
        std::vector<std::string> args = volume_flags;
        for (const std::string& word :
             {std::string("--no-window"), std::string("--threads"), std::string("1"),
              std::string("--out"), folder.path("out"), std::string("--repeat"),
              std::to_string(repeat)}) {
            args.push_back(word);
        }
        args.insert(args.end(), flags.begin(), flags.end());
        const RunResult run = run_program(step_binary(step), args, run_timeout_s);
        if (run.status != 0) {
            throw InputError("bench --gain: " + run.command() + " failed: " +
                             run.err.substr(0, run.err.find('\n')));
        }
        return run.cpu_s;
    };
    // Case by case, each pair of runs of every step one after the other: a stretch where the
    // shared machine is slower hits every step of the case alike, not one step's figure.
    std::map<std::string, std::vector<double>> ms;  // step -> CPU ms per render, per case
    for (int c = 0; c < peer_case_count; ++c) {
        const std::vector<std::string> flags =
            case_flags(part3_rule.flags[c], gain_side, oblique_side, dims);
        std::map<std::string, std::vector<double>> per_render;  // step -> one per pair
        for (int pair = 0; pair < gain_pairs; ++pair) {
            for (const std::string& step : steps) {
                if (!renders(step, c)) continue;
                const double one = cpu_of(step, flags, 1);
                const double many = cpu_of(step, flags, gain_repeat);
                per_render[step].push_back(1000 * (many - one) / (gain_repeat - 1));
            }
        }
        for (const std::string& step : steps) {
            if (!renders(step, c)) {
                ms[step].push_back(-1);  // none: the table says why
                std::printf("bench: gain, %s case %c: not rendered (it looks along an axis "
                            "only)\n", step.c_str(), peer_cases[c].id);
                continue;
            }
            ms[step].push_back(median_of(per_render[step]));
            std::printf("bench: gain, %s case %c: %.1f ms CPU per render\n", step.c_str(),
                        peer_cases[c].id, ms[step].back());
        }
        std::fflush(stdout);
    }
    std::string flag_text[peer_case_count];
    for (int c = 0; c < peer_case_count; ++c) {
        for (const std::string& word :
             case_flags(part3_rule.flags[c], gain_side, oblique_side, dims)) {
            flag_text[c] += (flag_text[c].empty() ? "" : " ") + word;
        }
    }
    const std::string when = utc_now(), load = load_average();
    const std::string note = text_of(
        "CPU ms per render on 1 thread (`make gain`, %s; load average %s;\nthe median of %d "
        "pairs of runs, `--repeat 1` and `--repeat %d`; CPU time from each child's rusage).\n",
        when.c_str(), load.c_str(), gain_pairs, gain_repeat);
    std::ostringstream out;
    out << "# Part 3: CPU time per render, 1 thread (build/bench --gain)\n\n"
        << text_of("Measured %s on %s (load average %s): the phantom at spacing 1,1,1, "
                   "--threads 1; each figure the median of %d pairs of runs (--repeat 1 and "
                   "--repeat %d), CPU ms per render = the pair's difference / %d.\n\n",
                   when.c_str(), first_line_of("/proc/cpuinfo", "model name").c_str(),
                   load.c_str(), gain_pairs, gain_repeat, gain_repeat - 1);
    const std::string& first = steps.front();
    for (size_t n = 0; n < steps.size(); ++n) {
        const std::string& step = steps[n];
        const std::string number = step.substr(0, 2);
        out << "<!-- section: gain:" << step << " -->\n";
        if (n == 0) {
            out << "| case | flags | step " << number << ", CPU ms per render |\n|---|---|---|\n";
            for (int c = 0; c < peer_case_count; ++c) {
                out << text_of("| %c %s | `%s` | %.1f |\n", peer_cases[c].id, peer_cases[c].what,
                               flag_text[c].c_str(), ms[step][c]);
            }
        } else {
            const std::string& previous = steps[n - 1];
            const bool short_table = previous == first;  // the gain over both is one column
            const std::string p_number = previous.substr(0, 2), f_number = first.substr(0, 2);
            if (short_table) {
                out << "| case | step " << p_number << " ms | step " << number
                    << " ms | gain over step " << p_number << " |\n|---|---|---|---|\n";
            } else {
                out << "| case | step " << f_number << " ms | step " << p_number << " ms | step "
                    << number << " ms | gain over step " << p_number << " | over step "
                    << f_number << " |\n|---|---|---|---|---|---|\n";
            }
            // A step that does not render a case (-1 ms) shows "-" and no gain.
            auto gain = [](double before, double after) {
                return after > 0 && before > 0 ? text_of("%.2fx", before / after)
                                               : std::string("n/a");
            };
            auto figure = [](double ms_per_render) {
                return ms_per_render < 0 ? std::string("- (along an axis only)")
                                         : text_of("%.1f", ms_per_render);
            };
            for (int c = 0; c < peer_case_count; ++c) {
                const double f = ms[first][c], p = ms[previous][c], t = ms[step][c];
                const std::string name = text_of("%c %s", peer_cases[c].id, peer_cases[c].what);
                if (short_table) {
                    out << text_of("| %s | %s | %s | %s |\n", name.c_str(), figure(p).c_str(),
                                   figure(t).c_str(), gain(p, t).c_str());
                } else {
                    out << text_of("| %s | %s | %s | %s | %s | %s |\n", name.c_str(),
                                   figure(f).c_str(), figure(p).c_str(), figure(t).c_str(),
                                   gain(p, t).c_str(), gain(f, t).c_str());
                }
            }
        }
        out << "\n" << note << "<!-- end section -->\n\n";
    }
    const size_t slash = out_path.rfind('/');
    if (slash != std::string::npos) make_folder(out_path.substr(0, slash));
    std::ofstream file(out_path);
    if (!file) throw InputError("--out: cannot write '" + out_path + "'");
    file << out.str();
    std::printf("bench: wrote %s\n", out_path.c_str());
    return 0;
}

constexpr const char* bench_usage =
    "usage: bench [--volume phantom|PATH] [--runs N>=10] [--out FILE] [--steps NN,NN]\n"
    "             [--flags \"FLAGS\"] [--quick] [--peers] [--gain]\n"
    "Times every step's renders (make bench); --peers: part 3 against VolPack and VTK;\n"
    "--gain: part 3's CPU time per render (make gain). Writes out/bench.md unless --out.\n";

int run(int argc, char** argv) {
    std::string volume_name = "phantom", out_path = "out/bench.md", only;
    std::vector<std::string> extra_flags;  // --flags: given to every step, after its defaults
    int runs = default_runs;
    bool quick = false;
    bool peers_only = false;  // --peers: the peer table alone
    bool gain_only = false;   // --gain: part 3's CPU time per render alone (make gain)
    for (int n = 1; n < argc; ++n) {
        const std::string flag = argv[n];
        const bool has_value = n + 1 < argc;
        if (flag == "--help" || flag == "-h") {
            std::printf("%s", bench_usage);
            return 0;
        } else if (flag == "--quick") {
            quick = true;
        } else if (flag == "--peers") {
            peers_only = true;
        } else if (flag == "--gain") {
            gain_only = true;
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
            throw InputError("unknown flag '" + flag + "' (see bench --help)");
        }
    }
    if (quick) runs = 1;
    const int pass_count = quick ? 1 : passes;
    const unsigned hardware = std::thread::hardware_concurrency();
    const int cores = hardware > 0 ? int(hardware) : 1;
    if (peers_only) return peers_report(cores, quick, runs, pass_count, only, out_path);
    if (gain_only) {
        return gain_report(out_path == "out/bench.md" ? "out/part3_gain.md" : out_path, only);
    }
    // Each volume: its name in the report and the flags that load it.
    std::vector<std::pair<std::string, std::vector<std::string>>> volumes;
    const TempFolder quick_folder("bench_quick");
    if (quick && volume_name == "phantom") {
        const Volume small =
            make_phantom_sized(quick_dims[0], quick_dims[1], quick_dims[2], cores);
        volumes.emplace_back(text_of("phantom %dx%dx%d", small.nx, small.ny, small.nz),
                             write_raw_volume(small, quick_folder.path("phantom.raw")));
    } else {
        volumes.push_back({volume_name, {"--volume", volume_name}});
    }
    if (!quick && volume_name == "phantom" && file_exists("data/CThead")) {
        volumes.push_back({"data/CThead", {"--volume", "data/CThead"}});
    }

    const std::string load_before = load_average();
    const std::string started = utc_now();
    std::vector<Check> checks;
    const machine::OtherLoad others;
    std::ostringstream report;
    report << "# ctlab benchmark\n\n";
    if (quick) {
        report << "**Quick mode** (--quick): a small volume and one render per view, to check "
               << "that the benchmark runs and its pictures agree. Do not quote these figures.\n\n";
    }
    if (!extra_flags.empty()) {
        std::string joined;
        for (const std::string& word : extra_flags) joined += " " + word;
        report << "**Not the default settings:** every step ran with" << joined
               << ". The targets are for the defaults.\n\n";
    }
    report << "Written by `make bench` (tools/bench.cpp). Machine: " << cores << " cores, "
           << first_line_of("/proc/cpuinfo", "model name") << "; compiler " << __VERSION__
           << ", the Makefile's flags (-O2 unless OPT says otherwise). Each step ran as its own "
           << "program with `--repeat " << runs << "`: *cold* is the first render of a view "
           << "(`time_ms=`; on the 256x256 views the median over " << (quick ? 1 : cold_processes)
           << " fresh processes), *warm* the median of the other " << runs - 1
           << " (`warm_ms=`). Every figure is the median of " << pass_count << " pass"
           << (pass_count == 1 ? "" : "es") << " over all steps, made one after the other. "
           << "Load average before the run: " << load_before
           << " (the machine is shared: a load above 0.5 inflates the figures).\n\n";
    std::vector<Row> first_rows;
    int differing = 0;  // step views whose 1- and 2-thread pictures differ
    for (const auto& [name, volume] : volumes) {
        std::printf("bench: %s, %d renders per view, 1 and 2 threads\n", name.c_str(), runs);
        const std::vector<Row> rows = median_of_passes(pass_count, name, checks, [&] {
            return bench_volume_rows(volume, runs, only, extra_flags, "all",
                                     quick ? 1 : cold_processes);
        });
        if (first_rows.empty()) first_rows = rows;
        for (const Row& row : rows) differing += !row.threads_identical;
        report << "## " << name << "\n\n" << table(rows) << "\n";
    }
    // The targets are about every step at its default settings: checked only for such a run,
    // which then also times step 11 --unlit and every step's top view on the large volume.
    const bool defaults = only.empty() && extra_flags.empty();
    std::vector<Row> unlit_rows, large_rows;
    std::vector<Growth> growth;
    std::string large_name;
    if (defaults && !first_rows.empty()) {
        std::printf("bench: %s, step 11 with --unlit\n", volumes[0].first.c_str());
        unlit_rows = median_of_passes(pass_count, "11 --unlit", checks, [&] {
            return bench_volume_rows(volumes[0].second, runs, "11", {"--unlit"}, "all",
                                     quick ? 1 : cold_processes);
        });
        for (const Row& row : unlit_rows) differing += !row.threads_identical;
        report << "## " << volumes[0].first << ", step 11 with --unlit\n\n"
               << table(unlit_rows) << "\n";

        const int n = quick ? quick_large_dims : large_dims;
        std::printf("bench: making the phantom at %d^3\n", n);
        std::fflush(stdout);
        const TempFolder large_folder("bench_large");
        std::vector<std::string> large_flags;
        {
            const Volume large = make_phantom_sized(n, n, n, cores);
            large_flags = write_raw_volume(large, large_folder.path("phantom.raw"));
        }  // the bench's own copy is freed before the steps run
        large_name = text_of("phantom %dx%dx%d", n, n, n);
        const double volume_bytes = double(n) * n * n * sizeof(int16_t);
        const int large_renders = quick ? 1 : large_runs;
        std::printf("bench: %s, top view, %d renders per run\n", large_name.c_str(),
                    large_renders);
        large_rows = median_of_passes(pass_count, large_name, checks, [&] {
            return bench_volume_rows(large_flags, large_renders, "", {}, "top");
        });
        for (const Row& row : large_rows) differing += !row.threads_identical;
        growth = growth_of(large_rows, first_rows, volume_bytes);
        report << "## " << large_name << ", top view (" << large_renders
               << " renders per run)\n\n"
               << growth_table(growth, volume_bytes, volumes[0].first) << "\n";
    }
    // The peers (VolPack, VTK) against ctlab's steps, case by case: at the defaults.
    bool peers_failed = false;
    const std::string peers =
        defaults || quick ? peers_on_phantom(cores, quick, quick ? 2 : runs, pass_count, "",
                                             &peers_failed)
                          : "Not run: the peer table needs the default settings.\n";
    report << "## The peers: VolPack and VTK\n\n" << peers << "\n";
    std::printf("bench: start-up, %d processes per figure\n", quick ? 5 : startup_runs);
    bool startup_met = false;
    const std::string startup = startup_section(quick ? 5 : startup_runs, &startup_met);
    report << "## Start-up\n\n" << startup << "\n";
    checks.push_back(check_speed("at the end"));
    double spread = 1;
    const std::string speed = speed_report(checks, cores, &spread);
    report << "## Machine speed during the run\n\n" << speed << "\n";
    const std::string target_table =
        defaults ? targets(first_rows, unlit_rows, growth, large_name, volumes[0].first)
                 : "Not checked: the targets need every step at its default settings (no "
                   "--steps, no --flags).\n";
    report << "## Targets, on " << volumes[0].first << "\n\n" << target_table << "\n";
    report << text_of("Load average after the run: %s. Other processes used %.0f%% of the %d "
                      "cores during the whole run (last column: during each step's timing); "
                      "figures taken above a few percent are not to be trusted.\n",
                      load_average().c_str(), 100 * others.share(), cores);
    // The handouts quote these (make bench runs build/measured): only full runs of the
    // phantom at default settings, so that a quick or a tuned run never reaches a handout.
    if (!quick && extra_flags.empty() && volume_name == "phantom") {
        report << "\n## Per step, as the handouts quote it\n\n";
        std::vector<std::string> names;
        for (const Row& row : first_rows) {
            if (names.empty() || names.back() != row.step) names.push_back(row.step);
        }
        std::vector<Row> quoted = first_rows;  // step 11's section has its --unlit rows too
        quoted.insert(quoted.end(), unlit_rows.begin(), unlit_rows.end());
        const std::string when =
            "started " + started + ", load average " + load_before + " before it, " +
            load_average() + " after; the speed check's slowest run against its fastest " +
            text_of("%.2fx", spread);
        for (const std::string& name : names) {
            report << step_section(quoted, name, cores, runs, others.share(), when) << "\n";
        }
    }

    const size_t slash = out_path.rfind('/');
    if (slash != std::string::npos) make_folder(out_path.substr(0, slash));
    std::ofstream file(out_path);
    if (!file) throw InputError("--out: cannot write '" + out_path + "'");
    file << report.str();
    std::printf("\n%s", target_table.c_str());
    std::printf("\nbench: start-up\n%s", startup.c_str());
    std::printf("bench: %s", speed.c_str());
    std::printf("bench: other processes used %.0f%% of the cores during the run\n",
                100 * others.share());
    std::printf("bench: wrote %s\n", out_path.c_str());
    std::printf("\nbench: the peers\n%s", peers.c_str());
    if (quick && peers_failed) {
        std::printf("bench: a peer or a ctlab step failed in the peer table\n");
        return 1;
    }
    if (quick && differing > 0) {
        std::printf("bench: %d step views give different pictures with 1 and 2 threads\n",
                    differing);
        return 1;
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    return guarded_main(tool_name, [&] { return run(argc, argv); });
}
