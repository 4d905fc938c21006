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

// One number (or string) a trace line printed, named by the label before it in the format:
// "value=%5d" gives "value"; a tuple "C=(%.6f, %.6f, %.6f)" gives "C.r", "C.g", "C.b" (four
// components: .r .g .b .a; three: .r .g .b for a colour named C, rgb or colour, else .i .j .k;
// other counts .0 .1 ...); "t=%7.2f..%.2f" gives "t" and "t_end"; a conversion without a label
// is "#N" (its place among the line's conversions, from 1). A name repeated in one line gets
// "#2", "#3" ... appended ("n", "n#2"). The number is the argument itself, at full precision,
// not the text printed.
struct TraceField {
    std::string name;
    double number = 0;  // numeric conversions (d i u x c f e g ...)
    std::string text;   // %s conversions (number stays 0)
    bool is_text = false;
};

// One line of a trace: its text as printed, and the fields it was printed from. The ray
// picture (common/ray_plot.h) and the checker's trace comparison read the fields, never the
// text.
struct TraceRecord {
    std::string text;
    std::vector<TraceField> fields;

    const TraceField* field(const std::string& name) const;  // nullptr when absent
    bool has(const std::string& name) const { return field(name) != nullptr; }
    double number(const std::string& name, double otherwise) const;
};

// What one ray did, sample by sample: filled only when a pixel is being debugged.
// A long ray (a tall volume, a tiny step) could add millions of lines: the trace keeps the
// first max_first_lines and the last max_last_lines, and counts the ones in between, so its
// memory and output stay bounded whatever the request.
class Trace {
public:
    static constexpr size_t max_first_lines = 1000;
    static constexpr size_t max_last_lines = 20;

    // printf-like; besides the text it keeps each conversion's value as a TraceField.
    void add(const char* format, ...) __attribute__((format(printf, 2, 3)));
    // The lines kept: the first ones, then the last ones (in order) when lines were dropped.
    std::vector<std::string> lines() const;
    std::vector<std::string> first_lines() const;
    std::vector<std::string> last_lines() const;  // empty unless more than max_first_lines
    // The same lines with their fields.
    const std::vector<TraceRecord>& first_records() const { return first_; }
    std::vector<TraceRecord> last_records() const;
    std::vector<TraceRecord> records() const;  // first, then last
    uint64_t not_shown() const { return added_ - first_.size() - last_.size(); }

private:
    std::vector<TraceRecord> first_;
    std::vector<TraceRecord> last_;  // a ring of up to max_last_lines, oldest at last_next_
    size_t last_next_ = 0;
    uint64_t added_ = 0;
};

// The fields of one printf call: `format` and its arguments (the parser behind Trace::add;
// public for the tests).
std::vector<TraceField> trace_fields(const char* format, va_list arguments);

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
