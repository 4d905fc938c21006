// render.h: work counters, timing, per-pixel traces and the parallel pixel loop.
#pragma once
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdarg>
#include <cstdint>
#include <string>
#include <system_error>
#include <thread>
#include <vector>
#include "image.h"
#include "transfer_function.h"
#include "vec3.h"
#include "view.h"

namespace ctlab {

// How much a render did. Every step prints all of these in its summary line.
struct Work {
    uint64_t samples = 0;     // samples visited along rays (voxels read, or interpolated)
    uint64_t skipped = 0;     // samples classified transparent and not shaded
    uint64_t leapt = 0;       // samples never visited: they lay in a brick known to be empty
    uint64_t gradients = 0;   // gradient evaluations
    uint64_t terminated = 0;  // rays stopped early (first hit found, or opacity saturated)
    uint64_t hits = 0;        // rays that met a surface

    void add(const Work& other) {
        samples += other.samples;
        skipped += other.skipped;
        leapt += other.leapt;
        gradients += other.gradients;
        terminated += other.terminated;
        hits += other.hits;
    }
};

class Timer {
public:
    Timer() : start_(std::chrono::steady_clock::now()) {}
    double ms() const {
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_)
            .count();
    }

private:
    std::chrono::steady_clock::time_point start_;
};

// A trace is a list of typed records, one per event along one ray: a sample, a hit, a leap,
// a stop, ... A lesson records each event with its numbers (trace->sample(...), below); the
// printed line, the ray picture (common/ray_plot.h) and make check's ray comparison are all
// made from the records. Nothing reads a printed line back.
enum class TraceKind {
    sample,     // one sample along the ray: where it is, its value, what it gave
    hit,        // the ray met the surface: step 05's crossing, step 17's hit point
    leap,       // samples leapt over (bricks known to be empty)
    stop,       // early ray termination: the samples left are not visited
    ray,        // part 2: the camera ray, origin and direction
    box,        // part 2: where the ray enters and leaves the volume's box, or that it missed
    bisection,  // step 19: one halving of the bracket around the crossing
    shade,      // the light at a hit: gradient and shade, Phong's terms
    note,       // anything else a lesson says, with its numbers named
};

// One number of a record, by name: "t", "value", "rgba.a", "C.r", "voxel.i" ... at full
// precision (the argument itself, not the text printed).
struct TraceField {
    std::string name;
    double number = 0;
};

// One event of a trace: its kind, its numbers, and its line as printed (made from them).
struct TraceRecord {
    TraceKind kind = TraceKind::note;
    std::string text;
    std::vector<TraceField> fields;
    bool hit = false;            // sample: it hit the threshold (steps 02-05)
    bool missed = false;         // box: the ray missed the box

    const TraceField* field(const std::string& name) const;  // nullptr when absent
    bool has(const std::string& name) const { return field(name) != nullptr; }
    double number(const std::string& name, double otherwise) const;
};

// One sample as a lesson records it: where it is (one of four places), its value, and what
// it gave (each optional, printed in this order):
//   trace->sample(TraceSample(n, voxel, value).rgba(sample).colour(r, g, b));
class TraceSample {
public:
    TraceSample(const Voxel& voxel, double value);               // step 00: one voxel
    TraceSample(int n, const Voxel& voxel, double value);        // part 1: sample n, its voxel
    TraceSample(double t, double value);                         // steps 10-11: t on the axis
    TraceSample(double t, const Vec3d& point, double value);     // part 2: t from the camera

    TraceSample& grey(double grey);                          // step 00's grey level
    TraceSample& max(double highest);                        // step 01: the maximum so far
    TraceSample& projection(double highest, double lowest, double mean);  // step 18
    TraceSample& threshold_hit(bool above);                  // "> threshold: hit" when above
    TraceSample& skipped();                                  // "transparent: skipped"
    TraceSample& iso(bool above);                            // step 19: "> iso" or "<= iso"
    TraceSample& rgba(const Rgba& colour);                   // the table's colour and alpha
    // Steps 22-23: light reaching the sample and the shadow ray's work; step 24 adds
    // ambient occlusion (its probes' reads counted with the shadow ray's).
    TraceSample& shadow(double light_transmittance, unsigned long long samples,
                        unsigned long long leapt);
    TraceSample& shadow(double light_transmittance, double occlusion,
                        unsigned long long samples, unsigned long long leapt);
    TraceSample& light(double light);                        // L
    TraceSample& colour(double r, double g, double b);       // C, accumulated so far
    TraceSample& transparency(double transparency);          // T, after this sample

    TraceRecord record() const;  // its fields and its line

private:
    enum class Place { voxel, index, axis_t, camera_t } place_;
    enum class Verdict { none, threshold_hit, skipped, above_iso, at_or_below_iso };
    int n_ = 0;
    double t_ = 0;
    Voxel voxel_{0, 0, 0};
    Vec3d point_;
    double value_ = 0;
    Verdict verdict_ = Verdict::none;
    bool has_grey_ = false, has_max_ = false, has_projection_ = false, has_rgba_ = false;
    bool has_shadow_ = false, has_occlusion_ = false, has_light_ = false, has_colour_ = false;
    bool has_transparency_ = false;
    double grey_ = 0, highest_ = 0, lowest_ = 0, mean_ = 0;
    Rgba rgba_;
    double light_transmittance_ = 0, occlusion_ = 0;
    unsigned long long shadow_samples_ = 0, shadow_leapt_ = 0;
    double light_ = 1, r_ = 0, g_ = 0, b_ = 0, transparency_ = 1;
};

// What one ray did, event by event: filled only when a pixel is being debugged.
// A long ray (a tall volume, a tiny step) could add millions of records: the trace keeps the
// first max_first_lines and the last max_last_lines, and counts the ones in between, so its
// memory and output stay bounded whatever the request.
class Trace {
public:
    static constexpr size_t max_first_lines = 1000;
    static constexpr size_t max_last_lines = 20;

    // --- The events a lesson records ---
    void sample(const TraceSample& sample);
    // Step 05: the threshold crossed between samples n and n + 1, a fraction of the way.
    void crossing(int n, double fraction);
    // Step 19: the surface's hit point, its normal, and where the normal came from.
    void surface_hit(double t, const Vec3d& point, const Vec3& normal, const char* from);
    // Step 11: samples from t = from to t = to leapt over, empty bricks up to voxel last_voxel.
    void leap_to_voxel(double from, double to, long long samples, int last_voxel);
    // Part 2: samples from t = from to t = to leapt over, empty bricks of reach `reach`
    // (below_iso: step 17's bricks whose values are all at or below the iso value).
    void leap(double from, double to, long long samples, int reach, bool below_iso = false);
    // Object order, steps 39 on: the cells an intermediate pixel meets from t = from to t = to
    // lie outside their slice rows' runs (cells the table may see): never read.
    void leap_runs(double from, double to, long long cells);
    // Early ray termination at the last sample recorded: T fell below `threshold`.
    void stop(double transparency, double threshold, long long not_visited);
    void ray(const Vec3d& origin, const Vec3d& direction);          // part 2's camera ray
    void box_missed(const Vec3d& high);                              // box (0,0,0)..high
    // Object order (steps 35 on, before the camera ray's records): the pixel is not that
    // ray's but the warp's blend of the (up to four) intermediate pixels around where the ray
    // meets the first slice, each traced after it. The ray's records then say where it lies,
    // never what the pixel shows (a ray that misses the box does not make it background).
    void pixel_from_warp() { pixel_from_warp_ = true; }
    // Where the ray enters (through face entry_axis: 0 i, 1 j, 2 k, -1 it starts inside)
    // and leaves the box (0,0,0)..high, and the step along it.
    void box(const Vec3d& high, double t_entry, const Vec3d& entry, int entry_axis,
             double t_exit, const Vec3d& exit, double step);
    // Step 19: one halving of the bracket [from, to] around the crossing.
    void bisection(int iteration, double t, double value, bool above, double from, double to);
    void gradient(const Vec3& gradient, double shade);  // steps 04-05: the light at the hit
    // Step 20: the Phong terms at the hit (L and V unit vectors towards light and viewer).
    void phong(const Vec3& to_light, const Vec3& to_viewer, double ambient, double diffuse,
               double specular, double shininess);
    // Step 17: the jitter's u (0..1) and how far past the entry the first sample lies.
    void jitter(const std::string& mode, double u, double past_entry);
    // Step 21: the clip plane n.p <= d; the ray's span left by it (from, to), entering
    // through the plane or not, or (cut_away) none of it.
    void clip(const Vec3d& normal, double d, bool cut_away, double from = 0, double to = 0,
              bool entering = false);
    // Step 19: the first crossing lies between t = from and t = to: bisection follows.
    void bracket(double from, double to, double tolerance);
    // Anything else: the line printf-formatted, and its numbers named in `fields`.
    void note(std::vector<TraceField> fields, const char* format, ...)
        __attribute__((format(printf, 3, 4)));

    // --- What was recorded ---
    // The lines kept: the first ones, then the last ones (in order) when lines were dropped.
    std::vector<std::string> lines() const;
    std::vector<std::string> first_lines() const;
    std::vector<std::string> last_lines() const;  // empty unless more than max_first_lines
    // The same, as records.
    const std::vector<TraceRecord>& first_records() const { return first_; }
    std::vector<TraceRecord> last_records() const;
    std::vector<TraceRecord> records() const;  // first, then last
    uint64_t not_shown() const { return added_ - first_.size() - last_.size(); }

private:
    void keep(TraceRecord record);

    std::vector<TraceRecord> first_;
    std::vector<TraceRecord> last_;  // a ring of up to max_last_lines, oldest at last_next_
    size_t last_next_ = 0;
    uint64_t added_ = 0;
    // The last sample's place, for a stop: "at n=50" or "at t=44.00" as its samples print.
    TraceRecord last_place_;
    bool pixel_from_warp_ = false;  // pixel_from_warp(): the pixel is the warp's blend
};

// Prints once per process "note: only STARTED of WANTED render threads could be started ...".
void note_fewer_threads(int started, int wanted);

// The pool's side of parallel_rows: calls callback(context, y, work) for every row, rows
// handed out one at a time to this thread and up to threads - 1 of the pool's workers.
using RowCallback = void (*)(void* context, int y, Work& work);
void pool_rows(int height, int threads, Work& total, RowCallback callback, void* context);

// Starts the pool's workers for `threads` render threads now (they are otherwise started by
// the first parallel render). Returns how many render threads the pool can give, this one
// included: fewer than `threads` only when a thread could not be created.
int start_render_threads(int threads);

// Calls callback(context, n, work) once on each of `threads` threads, n = 0 on this one and
// 1..threads-1 on the pool's workers (warm_up(): each core reads the volume it will render).
// Without enough workers, every call is made on this thread.
void pool_each(int threads, RowCallback callback, void* context);

// Calls row(y, work) for every image row, rows shared among `threads` threads. Each thread
// counts into its own Work, summed at the end, so the result does not depend on threads.
// The threads are a pool made once per process (the first parallel render, or warm_up()) and
// woken per render: starting and joining threads per render cost more than a small render
// (00_slices: 0.3 ms on 1 thread, 0.7 ms on 2 with threads made per render). The calling
// thread takes rows from the first moment; a worker that wakes late finds fewer rows, or
// none, so a tiny render costs about what it costs on one thread.
// Speed: a thread's Work lives on its own stack while it runs; Works side by side in one
// vector share a cache line, and the two cores would fight over it at every sample counted.
template <class RowFunction>
void parallel_rows(int height, int threads, Work& total, RowFunction row) {
    threads = std::max(1, std::min(threads, height));
    if (threads == 1) {
        for (int y = 0; y < height; ++y) row(y, total);
        return;
    }
    const RowCallback call_row = [](void* context, int y, Work& work) {
        (*static_cast<RowFunction*>(context))(y, work);
    };
    pool_rows(height, threads, total, call_row, &row);
}

// Every pixel of a view: pixel(x, y, work) -> Rgb, rows in parallel.
template <class PixelFunction>
Image render_image(const View& view, int threads, Work& work, PixelFunction pixel) {
    Image image(view.width, view.height);
    parallel_rows(view.height, threads, work, [&](int y, Work& row_work) {
        for (int x = 0; x < view.width; ++x) image.at(x, y) = pixel(x, y, row_work);
    });
    return image;
}

}  // namespace ctlab
