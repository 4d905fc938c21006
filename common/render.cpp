// render.cpp: the per-pixel trace, the render threads' pool, and the note when render threads
// are short.
#include "render.h"
#include <cctype>
#include <condition_variable>
#include <mutex>
#include <cstdarg>
#include <cstring>
#include <cstdio>
#include <utility>

namespace ctlab {

namespace {

bool is_name_char(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
}

// The identifier that ends `text` at position end (exclusive), or "".
std::string name_before(const std::string& text, size_t end) {
    size_t begin = end;
    while (begin > 0 && is_name_char(text[begin - 1])) --begin;
    return text.substr(begin, end - begin);
}

// What the literal text before a conversion says its name is. Updates the open tuple.
struct Namer {
    std::string tuple;      // the open tuple's base name ("" when unnamed)
    bool in_tuple = false;
    int tuple_index = 0;
    int tuple_id = 0;       // counts tuples, to tell them apart when named alike

    // Returns the name, or "" (unnamed); sets *component to the tuple index or -1.
    std::string name(const std::string& literal, int* component) {
        *component = -1;
        if (in_tuple && literal.find(')') != std::string::npos) in_tuple = false;
        if (in_tuple) {
            ++tuple_index;
            *component = tuple_index;
            return tuple;
        }
        const size_t size = literal.size();
        if (size >= 1 && literal[size - 1] == '=') return name_before(literal, size - 1);
        if (size >= 1 && literal[size - 1] == '(') {
            // "C=(" or "voxel (" name a tuple; "..(" or "(" alone leave it unnamed.
            size_t end = size - 1;
            if (end > 0 && (literal[end - 1] == '=' || literal[end - 1] == ' ')) --end;
            tuple = name_before(literal, end);
            in_tuple = true;
            tuple_index = 0;
            ++tuple_id;
            *component = 0;
            return tuple;
        }
        if (size >= 2 && literal.compare(size - 2, 2, "..") == 0) {
            const std::string before = previous_name;
            return before.empty() ? "" : before + "_end";
        }
        return "";
    }
    std::string previous_name;  // the last named scalar, for "t=%f..%f"
};

struct PendingField {
    TraceField field;
    std::string base;  // tuple base ("" for a scalar)
    int component = -1;
    int tuple_id = 0;
};

std::string component_name(const std::string& base, int index, int count) {
    static const char* rgba[] = {"r", "g", "b", "a"};
    static const char* ijk[] = {"i", "j", "k"};
    const bool colour = base == "C" || base == "rgb" || base == "colour" || base == "color";
    if (count == 4) return rgba[index];
    if (count == 3) return colour ? rgba[index] : ijk[index];
    return std::to_string(index);
}

}  // namespace

std::vector<TraceField> trace_fields(const char* format, va_list arguments) {
    std::vector<PendingField> pending;
    Namer namer;
    std::string literal;
    int conversions = 0;
    for (const char* c = format; *c; ++c) {
        if (*c != '%') {
            literal += *c;
            continue;
        }
        ++c;
        if (*c == '%') {
            literal += '%';
            continue;
        }
        while (*c && std::strchr("-+ #0'", *c)) ++c;  // flags
        if (*c == '*') {
            (void)va_arg(arguments, int);
            ++c;
        }
        while (std::isdigit(static_cast<unsigned char>(*c))) ++c;  // width
        if (*c == '.') {
            ++c;
            if (*c == '*') {
                (void)va_arg(arguments, int);
                ++c;
            }
            while (std::isdigit(static_cast<unsigned char>(*c))) ++c;
        }
        int longs = 0;
        bool size_t_length = false, long_double = false;
        while (*c && std::strchr("hlLzjt", *c)) {
            if (*c == 'l') ++longs;
            if (*c == 'z' || *c == 'j' || *c == 't') size_t_length = true;
            if (*c == 'L') long_double = true;
            ++c;
        }
        if (!*c) break;
        ++conversions;
        PendingField entry;
        int component = -1;
        std::string name = namer.name(literal, &component);
        literal.clear();
        entry.component = component;
        entry.tuple_id = namer.tuple_id;
        if (component >= 0) entry.base = name;
        TraceField& field = entry.field;
        switch (*c) {
            case 'd': case 'i':
                field.number = longs >= 2 ? double(va_arg(arguments, long long))
                               : longs == 1 || size_t_length ? double(va_arg(arguments, long))
                                                             : double(va_arg(arguments, int));
                break;
            case 'u': case 'o': case 'x': case 'X':
                field.number =
                    longs >= 2 ? double(va_arg(arguments, unsigned long long))
                    : longs == 1 || size_t_length ? double(va_arg(arguments, unsigned long))
                                                  : double(va_arg(arguments, unsigned));
                break;
            case 'c': field.number = va_arg(arguments, int); break;
            case 'f': case 'F': case 'e': case 'E': case 'g': case 'G': case 'a': case 'A':
                field.number = long_double ? double(va_arg(arguments, long double))
                                           : va_arg(arguments, double);
                break;
            case 's': {
                const char* text = va_arg(arguments, const char*);
                field.text = text ? text : "";
                field.is_text = true;
                break;
            }
            case 'p': (void)va_arg(arguments, void*); continue;
            default: continue;  // %n and unknown conversions: nothing read, nothing kept
        }
        if (component < 0 && !name.empty()) namer.previous_name = name;
        field.name = name.empty() && component < 0 ? "#" + std::to_string(conversions) : name;
        pending.push_back(entry);
    }
    // Tuple components get their names once each tuple's size is known.
    std::vector<TraceField> fields;
    for (size_t n = 0; n < pending.size(); ++n) {
        PendingField& entry = pending[n];
        if (entry.component >= 0) {
            int count = 0;
            for (const PendingField& other : pending) {
                if (other.component >= 0 && other.tuple_id == entry.tuple_id) ++count;
            }
            const std::string suffix = component_name(entry.base, entry.component, count);
            entry.field.name = entry.base.empty() ? "#(" + std::to_string(entry.tuple_id) + ")." +
                                                        suffix
                                                  : entry.base + "." + suffix;
        }
        // A name already used in this line: "n", then "n#2".
        int seen = 1;
        for (const TraceField& earlier : fields) {
            const std::string& e = earlier.name;
            if (e == entry.field.name || e.rfind(entry.field.name + "#", 0) == 0) ++seen;
        }
        if (seen > 1 && entry.field.name[0] != '#') {
            entry.field.name += "#" + std::to_string(seen);
        }
        fields.push_back(entry.field);
    }
    return fields;
}

const TraceField* TraceRecord::field(const std::string& name) const {
    for (const TraceField& f : fields) {
        if (f.name == name) return &f;
    }
    return nullptr;
}

double TraceRecord::number(const std::string& name, double otherwise) const {
    const TraceField* f = field(name);
    return f && !f->is_text ? f->number : otherwise;
}

void Trace::add(const char* format, ...) {
    char line[512];
    va_list arguments;
    va_start(arguments, format);
    va_list again;
    va_copy(again, arguments);
    std::vsnprintf(line, sizeof line, format, arguments);
    va_end(arguments);
    TraceRecord record;
    record.text = line;
    record.fields = trace_fields(format, again);
    va_end(again);
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
