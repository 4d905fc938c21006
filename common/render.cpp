// render.cpp: the per-pixel trace, the render threads' pool, and the note when render threads
// are short.
#include "render.h"
#include <cctype>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <cstdarg>
#include <cstring>
#include <cstdio>
#include <utility>

namespace ctlab {

namespace {

// A record being made: its line printed piece by piece, its numbers named as they go.
class RecordWriter {
public:
    explicit RecordWriter(TraceKind kind) { record_.kind = kind; }

    void print(const char* format, ...) __attribute__((format(printf, 2, 3))) {
        char piece[512];
        va_list arguments;
        va_start(arguments, format);
        std::vsnprintf(piece, sizeof piece, format, arguments);
        va_end(arguments);
        record_.text += piece;
    }
    void field(const std::string& name, double number) {
        record_.fields.push_back({name, number});
    }
    void vector(const std::string& name, double i, double j, double k) {
        field(name + ".i", i);
        field(name + ".j", j);
        field(name + ".k", k);
    }
    TraceRecord& record() { return record_; }

private:
    TraceRecord record_;
};

}  // namespace

TraceSample::TraceSample(const Voxel& voxel, double value)
    : place_(Place::voxel), voxel_(voxel), value_(value) {}
TraceSample::TraceSample(int n, const Voxel& voxel, double value)
    : place_(Place::index), n_(n), voxel_(voxel), value_(value) {}
TraceSample::TraceSample(double t, double value) : place_(Place::axis_t), t_(t), value_(value) {}
TraceSample::TraceSample(double t, const Vec3d& point, double value)
    : place_(Place::camera_t), t_(t), point_(point), value_(value) {}

TraceSample& TraceSample::grey(double grey) {
    has_grey_ = true, grey_ = grey;
    return *this;
}
TraceSample& TraceSample::max(double highest) {
    has_max_ = true, highest_ = highest;
    return *this;
}
TraceSample& TraceSample::projection(double highest, double lowest, double mean) {
    has_projection_ = true, highest_ = highest, lowest_ = lowest, mean_ = mean;
    return *this;
}
TraceSample& TraceSample::threshold_hit(bool above) {
    verdict_ = above ? Verdict::threshold_hit : Verdict::none;
    return *this;
}
TraceSample& TraceSample::skipped() {
    verdict_ = Verdict::skipped;
    return *this;
}
TraceSample& TraceSample::iso(bool above) {
    verdict_ = above ? Verdict::above_iso : Verdict::at_or_below_iso;
    return *this;
}
TraceSample& TraceSample::rgba(const Rgba& colour) {
    has_rgba_ = true, rgba_ = colour;
    return *this;
}
TraceSample& TraceSample::shadow(double light_transmittance, unsigned long long samples,
                                 unsigned long long leapt) {
    has_shadow_ = true;
    light_transmittance_ = light_transmittance;
    shadow_samples_ = samples, shadow_leapt_ = leapt;
    return *this;
}
TraceSample& TraceSample::shadow(double light_transmittance, double occlusion,
                                 unsigned long long samples, unsigned long long leapt) {
    shadow(light_transmittance, samples, leapt);
    has_occlusion_ = true, occlusion_ = occlusion;
    return *this;
}
TraceSample& TraceSample::light(double light) {
    has_light_ = true, light_ = light;
    return *this;
}
TraceSample& TraceSample::colour(double r, double g, double b) {
    has_colour_ = true, r_ = r, g_ = g, b_ = b;
    return *this;
}
TraceSample& TraceSample::transparency(double transparency) {
    has_transparency_ = true, transparency_ = transparency;
    return *this;
}

TraceRecord TraceSample::record() const {
    RecordWriter line(TraceKind::sample);
    // Where: the place, then the value, printed as the lesson's samples are (a part 1 value
    // is a whole CT number; an interpolated one has decimals).
    switch (place_) {
        case Place::voxel:
            line.print("voxel (i=%d, j=%d, k=%d) value=%d", voxel_.i, voxel_.j, voxel_.k,
                       int(value_));
            line.vector("voxel", voxel_.i, voxel_.j, voxel_.k);
            break;
        case Place::index:
            line.print("n=%3d voxel (%d, %d, %d) value=%5d", n_, voxel_.i, voxel_.j, voxel_.k,
                       int(value_));
            line.field("n", n_);
            line.vector("voxel", voxel_.i, voxel_.j, voxel_.k);
            break;
        case Place::axis_t:
            line.print("t=%7.2f value=%8.2f", t_, value_);
            line.field("t", t_);
            break;
        case Place::camera_t:
            line.print("t=%9.4f p=(%.6f, %.6f, %.6f) value=%9.4f", t_, point_.i, point_.j,
                       point_.k, value_);
            line.field("t", t_);
            line.vector("p", point_.i, point_.j, point_.k);
            break;
    }
    line.field("value", value_);
    if (has_grey_) {
        line.print(" grey=%.6f", grey_);
        line.field("grey", grey_);
    }
    if (has_max_) {
        line.print(" max=%5d", int(highest_));
        line.field("max", highest_);
    }
    if (has_projection_) {
        line.print(" max=%9.4f min=%9.4f mean=%9.4f", highest_, lowest_, mean_);
        line.field("max", highest_);
        line.field("min", lowest_);
        line.field("mean", mean_);
    }
    switch (verdict_) {
        case Verdict::none: break;
        case Verdict::threshold_hit:
            line.print("  > threshold: hit");
            line.record().hit = true;
            break;
        case Verdict::skipped: line.print(" transparent: skipped"); break;
        case Verdict::above_iso: line.print(" > iso"); break;
        case Verdict::at_or_below_iso: line.print(" <= iso"); break;
    }
    if (has_rgba_) {
        line.print(" rgba=(%.3f, %.3f, %.3f, %.4f)", rgba_.r, rgba_.g, rgba_.b, rgba_.a);
        line.field("rgba.r", rgba_.r);
        line.field("rgba.g", rgba_.g);
        line.field("rgba.b", rgba_.b);
        line.field("rgba.a", rgba_.a);
    }
    if (has_shadow_) {
        line.print(" light_T=%.6f", light_transmittance_);
        line.field("light_T", light_transmittance_);
        if (has_occlusion_) {
            line.print(" ao=%.6f", occlusion_);
            line.field("ao", occlusion_);
        }
        line.print(" (%llu shadow samples, %llu leapt)", shadow_samples_, shadow_leapt_);
        line.field("shadow_samples", double(shadow_samples_));
        line.field("shadow_leapt", double(shadow_leapt_));
    }
    if (has_light_) {
        line.print(" L=%.4f", light_);
        line.field("L", light_);
    }
    if (has_colour_) {
        line.print(" C=(%.6f, %.6f, %.6f)", r_, g_, b_);
        line.field("C.r", r_);
        line.field("C.g", g_);
        line.field("C.b", b_);
    }
    if (has_transparency_) {
        line.print(" T=%.6g", transparency_);
        line.field("T", transparency_);
    }
    return line.record();
}

const TraceField* TraceRecord::field(const std::string& name) const {
    for (const TraceField& f : fields) {
        if (f.name == name) return &f;
    }
    return nullptr;
}

double TraceRecord::number(const std::string& name, double otherwise) const {
    const TraceField* f = field(name);
    return f ? f->number : otherwise;
}

void Trace::keep(TraceRecord record) {
    ++added_;
    if (first_.size() < max_first_lines) {
        first_.push_back(std::move(record));
    } else if (last_.size() < max_last_lines) {
        last_.push_back(std::move(record));
    } else {
        last_[last_next_] = std::move(record);
        last_next_ = (last_next_ + 1) % max_last_lines;
    }
}

void Trace::sample(const TraceSample& sample) {
    TraceRecord record = sample.record();
    last_place_ = record;
    keep(std::move(record));
}

void Trace::crossing(int n, double fraction) {
    RecordWriter line(TraceKind::hit);
    line.print("crossing between n=%d and n=%d: hit at %d + %.6f", n, n + 1, n, fraction);
    line.field("n", n);
    line.field("fraction", fraction);
    keep(std::move(line.record()));
}

void Trace::surface_hit(double t, const Vec3d& point, const Vec3& normal, const char* from) {
    RecordWriter line(TraceKind::hit);
    line.print("hit t=%.7f p=(%.6f, %.6f, %.6f) normal=(%.6f, %.6f, %.6f) from %s", t, point.i,
               point.j, point.k, normal.i, normal.j, normal.k, from);
    line.field("t", t);
    line.vector("p", point.i, point.j, point.k);
    line.vector("normal", normal.i, normal.j, normal.k);
    keep(std::move(line.record()));
}

void Trace::leap_to_voxel(double from, double to, long long samples, int last_voxel) {
    RecordWriter line(TraceKind::leap);
    line.print("t=%7.2f..%.2f empty bricks up to voxel %d: %lld samples leapt over", from, to,
               last_voxel, samples);
    line.field("t", from);
    line.field("t_end", to);
    line.field("voxel", last_voxel);
    line.field("leapt", double(samples));
    keep(std::move(line.record()));
}

void Trace::leap(double from, double to, long long samples, int reach, bool below_iso) {
    RecordWriter line(TraceKind::leap);
    line.print("t=%9.4f..%.4f %s (reach %d): %lld samples leapt over", from, to,
               below_iso ? "bricks at or below iso" : "empty bricks", reach, samples);
    line.field("t", from);
    line.field("t_end", to);
    line.field("reach", reach);
    line.field("leapt", double(samples));
    keep(std::move(line.record()));
}

void Trace::leap_runs(double from, double to, long long cells) {
    RecordWriter line(TraceKind::leap);
    line.print("t=%9.4f..%.4f outside the runs: %lld cells never read", from, to, cells);
    line.field("t", from);
    line.field("t_end", to);
    line.field("leapt", double(cells));
    keep(std::move(line.record()));
}

void Trace::stop(double transparency, double threshold, long long not_visited) {
    RecordWriter line(TraceKind::stop);
    line.print("T=%.3g < %.3g: early ray termination at ", transparency, threshold);
    line.field("T", transparency);
    line.field("ert", threshold);
    // Where the last sample was, printed as it printed its place.
    if (const TraceField* n = last_place_.field("n")) {
        line.print("n=%d", int(n->number));
        line.field("n", n->number);
    } else if (const TraceField* t = last_place_.field("t")) {
        line.print(last_place_.has("p.i") ? "t=%.4f" : "t=%.2f", t->number);
        line.field("t", t->number);
    }
    line.print(", %lld samples not visited", not_visited);
    line.field("not_visited", double(not_visited));
    keep(std::move(line.record()));
}

void Trace::ray(const Vec3d& origin, const Vec3d& direction) {
    RecordWriter line(TraceKind::ray);
    line.print("ray origin=(%.6g, %.6g, %.6g) direction=(%.6g, %.6g, %.6g)", origin.i,
               origin.j, origin.k, direction.i, direction.j, direction.k);
    line.vector("origin", origin.i, origin.j, origin.k);
    line.vector("direction", direction.i, direction.j, direction.k);
    keep(std::move(line.record()));
}

void Trace::box_missed(const Vec3d& high) {
    RecordWriter line(TraceKind::box);
    // In object order the pixel is the warp's blend of intermediate pixels traced below it.
    line.print("box (0, 0, 0)..(%g, %g, %g): missed, %s", high.i, high.j, high.k,
               pixel_from_warp_ ? "but the pixel is the warp's blend of the intermediate "
                                  "pixels traced below"
                                : "the pixel shows the background");
    line.vector("box", high.i, high.j, high.k);
    line.record().missed = true;
    keep(std::move(line.record()));
}

void Trace::box(const Vec3d& high, double t_entry, const Vec3d& entry, int entry_axis,
                double t_exit, const Vec3d& exit, double step) {
    static const char* through[] = {"the i face", "the j face", "the k face"};
    RecordWriter line(TraceKind::box);
    line.print("box (0, 0, 0)..(%g, %g, %g): entry t=%.6f at (%.4f, %.4f, %.4f) through %s, "
               "exit t=%.6f at (%.4f, %.4f, %.4f), step %g", high.i, high.j, high.k, t_entry,
               entry.i, entry.j, entry.k,
               entry_axis >= 0 && entry_axis < 3 ? through[entry_axis] : "none (starts inside)",
               t_exit, exit.i, exit.j, exit.k, step);
    line.vector("box", high.i, high.j, high.k);
    line.field("t", t_entry);
    line.vector("entry", entry.i, entry.j, entry.k);
    line.field("t_exit", t_exit);
    line.vector("exit", exit.i, exit.j, exit.k);
    line.field("step", step);
    keep(std::move(line.record()));
}

void Trace::bisection(int iteration, double t, double value, bool above, double from,
                      double to) {
    RecordWriter line(TraceKind::bisection);
    line.print("  bisection %2d: t=%.7f value=%9.4f %s iso: bracket t=%.7f..%.7f", iteration, t,
               value, above ? "> " : "<=", from, to);
    line.field("bisection", iteration);
    line.field("t", t);
    line.field("value", value);
    line.field("t_below", from);
    line.field("t_above", to);
    keep(std::move(line.record()));
}

void Trace::gradient(const Vec3& gradient, double shade) {
    RecordWriter line(TraceKind::shade);
    line.print("gradient=(%.2f, %.2f, %.2f) shade=%.6f", gradient.i, gradient.j, gradient.k,
               shade);
    line.vector("gradient", gradient.i, gradient.j, gradient.k);
    line.field("shade", shade);
    keep(std::move(line.record()));
}

void Trace::phong(const Vec3& to_light, const Vec3& to_viewer, double ambient, double diffuse,
                  double specular, double shininess) {
    RecordWriter line(TraceKind::shade);
    line.print("phong L=(%.6f, %.6f, %.6f) V=(%.6f, %.6f, %.6f) ambient=%.6f diffuse=%.6f "
               "specular=%.6f shininess=%g", to_light.i, to_light.j, to_light.k, to_viewer.i,
               to_viewer.j, to_viewer.k, ambient, diffuse, specular, shininess);
    line.vector("L", to_light.i, to_light.j, to_light.k);
    line.vector("V", to_viewer.i, to_viewer.j, to_viewer.k);
    line.field("ambient", ambient);
    line.field("diffuse", diffuse);
    line.field("specular", specular);
    line.field("shininess", shininess);
    keep(std::move(line.record()));
}

void Trace::jitter(const std::string& mode, double u, double past_entry) {
    RecordWriter line(TraceKind::note);
    line.print("jitter %s: u=%.6f, the first sample %.6f units past the entry", mode.c_str(), u,
               past_entry);
    line.field("u", u);
    line.field("past_entry", past_entry);
    keep(std::move(line.record()));
}

void Trace::clip(const Vec3d& normal, double d, bool cut_away, double from, double to,
                 bool entering) {
    RecordWriter line(TraceKind::note);
    line.print("clip n=(%.4g, %.4g, %.4g) d=%g keeps n.p <= d: ", normal.i, normal.j, normal.k, d);
    line.vector("normal", normal.i, normal.j, normal.k);
    line.field("d", d);
    if (cut_away) {
        line.print("the ray is cut away there, the pixel shows the background");
    } else {
        line.print("t=%.6f..%.6f%s", from, to, entering ? ", entering through the plane" : "");
        line.field("t", from);
        line.field("t_end", to);
    }
    keep(std::move(line.record()));
}

void Trace::bracket(double from, double to, double tolerance) {
    RecordWriter line(TraceKind::note);
    line.print("crossing between t=%.4f and t=%.4f: bisection to %g voxel", from, to, tolerance);
    line.field("t", from);
    line.field("t_end", to);
    line.field("tolerance", tolerance);
    keep(std::move(line.record()));
}

void Trace::note(std::vector<TraceField> fields, const char* format, ...) {
    TraceRecord record;
    record.kind = TraceKind::note;
    char text[512];
    va_list arguments;
    va_start(arguments, format);
    std::vsnprintf(text, sizeof text, format, arguments);
    va_end(arguments);
    record.text = text;
    record.fields = std::move(fields);
    keep(std::move(record));
}

std::vector<TraceRecord> Trace::last_records() const {
    std::vector<TraceRecord> records;
    for (size_t n = 0; n < last_.size(); ++n) {
        records.push_back(last_[(last_next_ + n) % last_.size()]);
    }
    return records;
}

std::vector<TraceRecord> Trace::records() const {
    std::vector<TraceRecord> records = first_;
    for (TraceRecord& record : last_records()) records.push_back(std::move(record));
    return records;
}

std::vector<std::string> Trace::first_lines() const {
    std::vector<std::string> lines;
    for (const TraceRecord& record : first_) lines.push_back(record.text);
    return lines;
}

std::vector<std::string> Trace::last_lines() const {
    std::vector<std::string> lines;
    for (const TraceRecord& record : last_records()) lines.push_back(record.text);
    return lines;
}

std::vector<std::string> Trace::lines() const {
    std::vector<std::string> lines = first_lines();
    for (std::string& line : last_lines()) lines.push_back(std::move(line));
    return lines;
}

void note_fewer_threads(int started, int wanted) {
    static std::atomic<bool> said{false};
    if (said.exchange(true)) return;
    std::fprintf(stderr,
                 "note: only %d of %d render threads could be started (ulimit -u?); rendering "
                 "with %d\n",
                 started, wanted, started);
}

namespace {

// The render threads: made once, woken per render (common/render.h, parallel_rows). One
// render at a time: a parallel_rows called while another runs (from a row, or from another
// thread) does its rows on its own thread, the same picture.
class RenderPool {
public:
    // Makes workers until there are `wanted`; returns how many there are.
    // Waits for them to be ready (their stacks faulted in): what a thread costs to start is
    // paid here, by warm_up(), not by a render.
    int start(int wanted) {
        std::unique_lock<std::mutex> lock(mutex_);
        while (int(workers_.size()) < wanted && !start_failed_) {
            try {
                // It joins renders from the next one on: one started now has counted it in.
                workers_.emplace_back([this, seen = render_.load()] { work(seen); });
            } catch (const std::system_error&) {
                // ulimit -u, out of memory: fewer threads, the same picture, one note; never
                // tried again in this process.
                start_failed_ = true;
                note_fewer_threads(int(workers_.size()) + 1, wanted + 1);
            }
        }
        ready_.wait(lock, [this] { return ready_workers_ == int(workers_.size()); });
        return int(workers_.size());
    }

    // each: not rows but one call per thread, callback(context, n, work), n = 0 here and
    // 1..threads-1 on the workers, each on a thread of its own.
    void run(int height, int threads, Work& total, RowCallback callback, void* context,
             bool each = false) {
        const int workers = start(threads - 1);
        int places = 0;
        bool wake_all = false;
        bool alone = false;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            alone = busy_ || workers == 0 || (each && workers < threads - 1);
            if (!alone) busy_ = true;
        }
        if (alone) {  // unlocked: a row may start a render of its own
            for (int y = 0; y < height; ++y) callback(context, y, total);
            return;
        }
        {
            std::lock_guard<std::mutex> lock(mutex_);
            ++render_;
            open_places_ = std::min(threads - 1, workers);
            callback_ = callback;
            context_ = context;
            height_ = height;
            total_ = &total;
            next_row_.store(0, std::memory_order_relaxed);
            each_ = each;
            joined_ = 0;
            places = open_places_;
            wake_all = places == int(workers_.size());
        }
        if (wake_all) {
            wake_.notify_all();
        } else {
            for (int n = 0; n < places; ++n) wake_.notify_one();  // the others sleep on
        }
        Work own;  // this thread's counts, in its own cache lines
        if (each) {
            callback(context, 0, own);
            std::unique_lock<std::mutex> lock(mutex_);
            finished_.wait(lock, [this] { return open_places_ == 0 && active_.load() == 0; });
            total.add(own);
            busy_ = false;
            return;
        }
        take_rows(callback, context, height, own);
        std::unique_lock<std::mutex> lock(mutex_);
        open_places_ = 0;  // a worker that wakes from now on finds no render to join
        if (active_.load(std::memory_order_relaxed) != 0) {
            // A worker is in its last row, most likely a short one: wait for it awake, since
            // being woken from a sleep can cost more than a small render (tens of us).
            lock.unlock();
            const Timer waiting;
            while (active_.load(std::memory_order_acquire) != 0 && waiting.ms() < spin_ms) {
                std::this_thread::yield();
            }
            lock.lock();
            finished_.wait(lock, [this] { return active_.load() == 0; });
        }
        total.add(own);
        busy_ = false;
    }

private:
    // How long the caller waits awake for the workers' last rows, at most.
    static constexpr double spin_ms = 0.2;
    // The stack a render uses, touched once, so a worker's first rows take no page fault
    // (about 10 us each on the lab's VM).
    static constexpr size_t stack_bytes_used = 64 * 1024;

    // How long a worker stays awake for the next render after one (or after it started):
    // renders of --repeat, of a turning knob, and the first render after warm_up() then find
    // it awake. Woken from a sleep, a worker came 0.1-0.2 ms late on the lab's VM, longer than
    // a small render.
    static constexpr double stay_awake_ms = 2;

    static void fault_in_stack() {
        char stack[stack_bytes_used];
        volatile char* touch = stack;
        for (size_t n = 0; n < stack_bytes_used; n += 1024) touch[n] = 0;
    }

    void take_rows(RowCallback callback, void* context, int height, Work& work) {
        for (int y = next_row_.fetch_add(1, std::memory_order_relaxed); y < height;
             y = next_row_.fetch_add(1, std::memory_order_relaxed)) {
            callback(context, y, work);
        }
    }

    // A worker: sleeps until a render starts, joins it while it has places, takes rows until
    // none is left, adds its counts to the render's total.
    void work(uint64_t seen) {
        fault_in_stack();
        std::unique_lock<std::mutex> lock(mutex_);
        ++ready_workers_;
        ready_.notify_all();
        for (;;) {
            lock.unlock();
            const Timer awake;
            while (render_.load(std::memory_order_relaxed) == seen && awake.ms() < stay_awake_ms) {
                std::this_thread::yield();  // another process that wants this core gets it
            }
            lock.lock();
            wake_.wait(lock, [&] { return render_ != seen; });
            seen = render_;
            if (open_places_ == 0) continue;  // late: the render is full or over
            --open_places_;
            ++active_;
            const int index = each_ ? ++joined_ : 0;
            const bool each = each_;
            const RowCallback callback = callback_;
            void* const context = context_;
            const int height = height_;
            lock.unlock();
            Work own;
            if (each) {
                callback(context, index, own);
            } else {
                take_rows(callback, context, height, own);
            }
            lock.lock();
            total_->add(own);
            if (active_.fetch_sub(1) == 1) finished_.notify_one();
        }
    }

    std::mutex mutex_;                   // guards all below but next_row_
    std::condition_variable wake_;       // workers wait here for a render
    std::condition_variable finished_;   // the render's caller waits here for its workers
    std::vector<std::thread> workers_;
    bool start_failed_ = false;
    int ready_workers_ = 0;              // workers that have started
    std::condition_variable ready_;      // start() waits here for new workers
    bool busy_ = false;                  // a render is running
    std::atomic<uint64_t> render_{0};    // counts renders (changed locked): a worker wakes
                                         // when it changes
    int open_places_ = 0;                // workers that may still join the running render
    std::atomic<int> active_{0};         // workers in the running render (changed locked)
    RowCallback callback_ = nullptr;
    void* context_ = nullptr;
    int height_ = 0;
    Work* total_ = nullptr;
    bool each_ = false;                  // one call per thread, not rows
    int joined_ = 0;                     // workers that joined the running call per thread
    std::atomic<int> next_row_{0};       // the next row to hand out
};

// Made on first use and never destroyed: its workers sleep until the process exits (joining
// them from a static destructor could wait on a thread a fork()ed child does not have).
RenderPool& render_pool() {
    static RenderPool* pool = new RenderPool;
    return *pool;
}

}  // namespace

void pool_rows(int height, int threads, Work& total, RowCallback callback, void* context) {
    render_pool().run(height, threads, total, callback, context);
}

void pool_each(int threads, RowCallback callback, void* context) {
    Work ignored;
    render_pool().run(threads, threads, ignored, callback, context, true);
}

int start_render_threads(int threads) {
    return std::min(threads, render_pool().start(threads - 1) + 1);
}

}  // namespace ctlab
