// class_cache.cpp: a class run's shared builds and runs (see class_cache.h).
#include "tools/class_cache.h"
#include <fcntl.h>
#include <sys/file.h>
#include <sys/statvfs.h>
#include <unistd.h>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include "tools/run_step.h"

namespace ctlab {

namespace fs = std::filesystem;

namespace {

const char* const source_file = "source.cpp";  // a build entry: the source, whole
const char* const program_file = "program";    // ... and the binary built from it alone
const char* const key_file = "key.txt";        // a run entry: its key text, whole
const char* const outcome_file = "outcome.txt";
const char* const files_folder = "files";       // what the run left in its output folder
const char* const size_file = "size.txt";      // bytes stored so far, under size.lock
constexpr size_t min_free_bytes = size_t(1) << 30;  // left on the cache's file system

std::string hex(unsigned long long value) {
    char text[17];
    std::snprintf(text, sizeof text, "%016llx", value);
    return text;
}

// The whole file, or nullopt-like false when it cannot be read.
bool read_whole(const fs::path& path, std::string& text) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return false;
    std::ostringstream bytes;
    bytes << in.rdbuf();
    text = bytes.str();
    return !in.bad();
}

bool write_whole(const fs::path& path, const std::string& text) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    return static_cast<bool>(out);
}

// A folder no other writer uses, beside the entries, to fill before publishing it.
fs::path new_entry_folder(const fs::path& parent) {
    static std::atomic<unsigned> counter{0};
    std::ostringstream name;
    name << ".new-" << ::getpid() << "-" << std::this_thread::get_id() << "-" << counter++;
    const fs::path folder = parent / name.str();
    fs::create_directories(folder);
    return folder;
}

// Publishes `made` as `entry` by one rename; when another writer was first, theirs stays.
void publish(const fs::path& made, const fs::path& entry) {
    std::error_code error;
    fs::rename(made, entry, error);
    if (error) fs::remove_all(made, error);
}

// Arguments as text that no other list gives: each one's length, then its bytes.
std::string arguments_text(const std::string& key, const std::vector<std::string>& arguments) {
    std::string text = "build " + key + "\n";
    for (const std::string& argument : arguments) {
        text += std::to_string(argument.size()) + ":" + argument + "\n";
    }
    return text;
}

}  // namespace

CacheLock::~CacheLock() {
    if (fd_ >= 0) ::close(fd_);  // closing releases the flock
}

unsigned long long fnv1a_64(const std::string& bytes, unsigned long long hash) {
    for (unsigned char b : bytes) hash = (hash ^ b) * 1099511628211ULL;
    return hash;
}

ClassCache::ClassCache(const std::string& folder, const std::string& lab, size_t max_bytes)
    : root_((fs::path(folder) / ("lab-" + hex(fnv1a_64(lab)))).string()), max_bytes_(max_bytes) {
    fs::create_directories(fs::path(root_) / "build");
    fs::create_directories(fs::path(root_) / "run");
}

bool ClassCache::reserve(size_t bytes) const {
    struct statvfs space {};
    if (::statvfs(root_.c_str(), &space) != 0 ||
        static_cast<unsigned long long>(space.f_bavail) * space.f_frsize <
            static_cast<unsigned long long>(bytes) + min_free_bytes) {
        return false;
    }
    const fs::path lock_path = fs::path(root_) / "size.lock";
    const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0) return false;
    const CacheLock held(fd);
    while (::flock(fd, LOCK_EX) != 0) {
        if (errno != EINTR) return false;
    }
    std::string text;
    unsigned long long used = 0;
    if (read_whole(fs::path(root_) / size_file, text) && !text.empty()) {
        try {
            used = std::stoull(text);
        } catch (const std::exception&) {
            return false;  // not a count we wrote: store nothing more
        }
    }
    if (used + bytes > max_bytes_) return false;
    return write_whole(fs::path(root_) / size_file, std::to_string(used + bytes) + "\n");
}

std::unique_ptr<CacheLock> ClassCache::lock_build(const std::string& step,
                                                  const std::string& source,
                                                  const volatile std::sig_atomic_t* stop) const {
    constexpr int poll_ms = 20;  // how often a waiting tree looks again (and at `stop`)
    const std::string key = step + "-" + hex(fnv1a_64(step + '\0' + source));
    const fs::path path = fs::path(root_) / "build" / (key + ".lock");
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0) return nullptr;
    while (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
        if (errno != EWOULDBLOCK && errno != EINTR) break;  // no lock here: build anyway
        if (stop && *stop) {
            ::close(fd);
            return nullptr;
        }
        ::usleep(poll_ms * 1000);
    }
    return std::make_unique<CacheLock>(fd);
}

std::string ClassCache::take_build(const std::string& step, const std::string& source,
                                   const std::string& binary) const {
    const std::string key = step + "-" + hex(fnv1a_64(step + '\0' + source));
    const fs::path entry = fs::path(root_) / "build" / key;
    std::string stored;
    if (!read_whole(entry / source_file, stored) || stored != source) return "";
    std::error_code error;
    fs::copy_file(entry / program_file, binary, fs::copy_options::overwrite_existing, error);
    return error ? "" : key;
}

void ClassCache::store_build(const std::string& step, const std::string& source,
                             const std::string& binary) const {
    const std::string key = step + "-" + hex(fnv1a_64(step + '\0' + source));
    const fs::path entry = fs::path(root_) / "build" / key;
    std::error_code error;
    if (fs::exists(entry, error)) return;
    const uintmax_t binary_bytes = fs::file_size(binary, error);
    if (error || !reserve(static_cast<size_t>(binary_bytes) + source.size())) return;
    const fs::path made = new_entry_folder(fs::path(root_) / "build");
    fs::copy_file(binary, made / program_file, error);
    if (error || !write_whole(made / source_file, source)) {
        fs::remove_all(made, error);
        return;
    }
    publish(made, entry);
}

bool ClassCache::reusable(const ProcessResult& outcome) {
    return outcome.started && !outcome.timed_out && !outcome.output_exceeded &&
           !outcome.interrupted && outcome.signal != SIGKILL && outcome.signal != SIGXCPU &&
           outcome.signal != SIGXFSZ;
}

bool ClassCache::take_run(const std::string& key, const std::vector<std::string>& arguments,
                          const std::string& folder, ProcessResult& outcome) const {
    const std::string text = arguments_text(key, arguments);
    const fs::path entry = fs::path(root_) / "run" / hex(fnv1a_64(text));
    std::string stored, fields_line, out, err;
    if (!read_whole(entry / key_file, stored) || stored != text ||
        !read_whole(entry / outcome_file, fields_line) || !read_whole(entry / "stdout.txt", out) ||
        !read_whole(entry / "stderr.txt", err)) {
        return false;
    }
    Summary fields = parse_summary(fields_line);
    for (const char* name : {"status", "exit_status", "signal", "seconds", "max_rss_kib"}) {
        if (!fields.count(name)) return false;
    }
    std::error_code error;
    for (const fs::directory_entry& file : fs::directory_iterator(entry / files_folder, error)) {
        fs::copy_file(file.path(), fs::path(folder) / file.path().filename(),
                      fs::copy_options::overwrite_existing, error);
        if (error) return false;
    }
    if (error) return false;
    outcome.started = true;
    outcome.status = std::stoi(fields["status"]);
    outcome.exit_status = std::stoi(fields["exit_status"]);
    outcome.signal = std::stoi(fields["signal"]);
    outcome.seconds = std::stod(fields["seconds"]);
    outcome.max_rss_kib = std::stol(fields["max_rss_kib"]);
    outcome.out = out;
    outcome.err = err;
    return true;
}

void ClassCache::store_run(const std::string& key, const std::vector<std::string>& arguments,
                           const ProcessResult& outcome, const std::string& folder,
                           const std::vector<std::string>& names) const {
    if (!reusable(outcome)) return;
    const std::string text = arguments_text(key, arguments);
    const fs::path entry = fs::path(root_) / "run" / hex(fnv1a_64(text));
    std::error_code error;
    if (fs::exists(entry, error)) return;
    size_t bytes = text.size() + outcome.out.size() + outcome.err.size();
    for (const std::string& name : names) {
        bytes += static_cast<size_t>(fs::file_size(fs::path(folder) / name, error));
        if (error) return;
    }
    if (!reserve(bytes)) return;
    const fs::path made = new_entry_folder(fs::path(root_) / "run");
    fs::create_directory(made / files_folder, error);
    bool whole = !error;
    for (const std::string& name : names) {
        fs::copy_file(fs::path(folder) / name, made / files_folder / name, error);
        whole = whole && !error;
    }
    char fields[200];
    std::snprintf(fields, sizeof fields,
                  "status=%d exit_status=%d signal=%d seconds=%.3f max_rss_kib=%ld\n",
                  outcome.status, outcome.exit_status, outcome.signal, outcome.seconds,
                  outcome.max_rss_kib);
    whole = whole && write_whole(made / "stdout.txt", outcome.out) &&
            write_whole(made / "stderr.txt", outcome.err) && write_whole(made / outcome_file, fields) &&
            write_whole(made / key_file, text);  // last: an entry without it is never read
    if (!whole) {
        fs::remove_all(made, error);
        return;
    }
    publish(made, entry);
}

}  // namespace ctlab
