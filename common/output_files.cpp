// output_files.cpp: temporaries renamed together, removed on errors and on signals.
//
// The signal handler may only call async-signal-safe functions (unlink, sigaction, raise), so
// the temporaries' names live in fixed arrays it can read at any moment, not in std::strings.
#include "output_files.h"
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <vector>
#include "error.h"
#include "image.h"

namespace ctlab {

namespace {

// Files in one set: views, diffs, float images, and two per ray traced in each view (up to
// max_debug_pixels pixels, common/args.h). Only the names in use are ever touched.
constexpr int max_pending = 512;
constexpr size_t max_path = 4096;     // bytes, with the terminating NUL (Linux PATH_MAX)
// Every signal a shell or the kernel can send that ends a process by default, but the ones
// that cannot be caught (SIGKILL, SIGSTOP) and the faults (SIGSEGV...: a sanitizer reports
// those). SIGPIPE: `step | head -c 1` closes our stdout while the pictures are being written.
const int cleanup_signals[] = {SIGINT,  SIGTERM, SIGHUP,  SIGQUIT,   SIGPIPE, SIGALRM,
                               SIGUSR1, SIGUSR2, SIGXCPU, SIGVTALRM, SIGPROF};
constexpr int signal_count = sizeof cleanup_signals / sizeof cleanup_signals[0];

char pending_paths[max_pending][max_path];  // the temporaries' names
volatile sig_atomic_t pending_live[max_pending];  // 1 while that temporary exists
volatile sig_atomic_t pending_count = 0;
std::vector<std::string> pending_targets;  // where each temporary goes at commit()
OutputFiles* active_set = nullptr;
struct sigaction previous_actions[signal_count];
bool installed[signal_count];
// SIGXFSZ (a file over `ulimit -f`) is ignored while a set is open: the write then fails
// with EFBIG, and the step says "cannot write 'F': File too large" and removes its files.
struct sigaction previous_file_size_action;
bool file_size_ignored = false;
int files_written = 0;  // by this process, for CTLAB_TEST_FAIL_WRITE

// Removes every live temporary, then lets the signal do what it would have done.
void on_signal(int signal_number) {
    for (int n = 0; n < pending_count; ++n) {
        if (pending_live[n]) unlink(pending_paths[n]);
        pending_live[n] = 0;
    }
    struct sigaction default_action {};
    default_action.sa_handler = SIG_DFL;
    sigemptyset(&default_action.sa_mask);
    sigaction(signal_number, &default_action, nullptr);
    raise(signal_number);  // delivered when this handler returns: the process ends as signalled
}

// Holds the cleanup signals back while the arrays change or the renames run.
class SignalsHeld {
public:
    SignalsHeld() {
        sigset_t held;
        sigemptyset(&held);
        for (int signal_number : cleanup_signals) sigaddset(&held, signal_number);
        pthread_sigmask(SIG_BLOCK, &held, &before_);
    }
    ~SignalsHeld() { pthread_sigmask(SIG_SETMASK, &before_, nullptr); }

private:
    sigset_t before_;
};

void remove_live_temporaries() {
    const SignalsHeld held;
    for (int n = 0; n < pending_count; ++n) {
        if (pending_live[n]) unlink(pending_paths[n]);
        pending_live[n] = 0;
    }
    pending_count = 0;
    pending_targets.clear();
}

mode_t file_mode() {
    const mode_t mask = umask(0);  // the only way to read it; put back at once
    umask(mask);
    return 0666 & ~mask;
}

int fail_write_at() {
    const char* text = std::getenv(fail_write_variable);
    return text ? std::atoi(text) : 0;
}

}  // namespace

OutputFiles::OutputFiles() {
    if (active_set) throw std::logic_error("OutputFiles: a set is already open");
    active_set = this;
    pending_count = 0;
    pending_targets.clear();
    for (int n = 0; n < signal_count; ++n) {
        installed[n] = false;
        struct sigaction current {};
        if (sigaction(cleanup_signals[n], nullptr, &current) != 0) continue;
        if (current.sa_handler == SIG_IGN) continue;  // e.g. SIGHUP under nohup: stays ignored
        struct sigaction action {};
        action.sa_handler = on_signal;
        sigemptyset(&action.sa_mask);
        for (int signal_number : cleanup_signals) sigaddset(&action.sa_mask, signal_number);
        installed[n] = sigaction(cleanup_signals[n], &action, &previous_actions[n]) == 0;
    }
    struct sigaction ignore {};
    ignore.sa_handler = SIG_IGN;
    sigemptyset(&ignore.sa_mask);
    file_size_ignored = sigaction(SIGXFSZ, &ignore, &previous_file_size_action) == 0;
}

OutputFiles::~OutputFiles() {
    remove_live_temporaries();
    for (int n = 0; n < signal_count; ++n) {
        if (installed[n]) sigaction(cleanup_signals[n], &previous_actions[n], nullptr);
    }
    if (file_size_ignored) sigaction(SIGXFSZ, &previous_file_size_action, nullptr);
    active_set = nullptr;
}

OutputFiles* OutputFiles::active() { return active_set; }

void OutputFiles::add(const std::string& path, const std::function<bool(std::FILE*)>& write) {
    const size_t slash = path.rfind('/');
    const std::string folder = slash == std::string::npos ? "" : path.substr(0, slash + 1);
    if (!folder.empty()) make_folder(folder.substr(0, folder.size() - 1));
    const std::string name = path.substr(folder.size());
    const std::string pattern = folder + "." + name + ".tmpXXXXXX";
    if (name.empty() || pattern.size() >= max_path) {
        throw InputError("cannot write '" + path + "': not a file name of up to " +
                         std::to_string(max_path - 20) + " bytes");
    }
    if (pending_count >= max_pending) throw std::length_error("OutputFiles: too many files");

    int fd = -1, index = -1, error = 0;
    {
        const SignalsHeld held;  // the handler sees the name as soon as the file exists
        index = pending_count;
        std::memcpy(pending_paths[index], pattern.c_str(), pattern.size() + 1);
        fd = mkstemp(pending_paths[index]);  // O_EXCL: never an existing file or link
        error = errno;
        if (fd >= 0) {
            pending_live[index] = 1;
            pending_targets.push_back(path);
            pending_count = index + 1;
        }
    }
    if (fd < 0) throw InputError("cannot write '" + path + "': " + std::strerror(error));
    fchmod(fd, file_mode());  // mkstemp makes 0600; a PNG is as readable as any other file

    errno = 0;
    std::FILE* file = fdopen(fd, "wb");
    bool written = file && write(file);
    if (!written || std::ferror(file)) error = errno;
    if (file && std::fflush(file) != 0 && error == 0) error = errno;
    written = written && file && !std::ferror(file);
    if (file ? std::fclose(file) != 0 : close(fd) != 0) {
        if (error == 0) error = errno;
        written = false;
    }
    const int fail_at = fail_write_at();
    if (fail_at > 0 && ++files_written == fail_at) {
        written = false;
        error = ENOSPC;
    }
    if (!written) {
        const SignalsHeld held;
        unlink(pending_paths[index]);
        pending_live[index] = 0;
        throw InputError("cannot write '" + path + "': " +
                         (error ? std::strerror(error) : "disk full or no permission?"));
    }
}

void OutputFiles::commit() {
    std::string failure;
    {
        const SignalsHeld held;  // a Ctrl-C now waits until every file is in place
        for (int n = 0; n < pending_count; ++n) {
            if (!pending_live[n] || !failure.empty()) continue;
            if (std::rename(pending_paths[n], pending_targets[n].c_str()) != 0) {
                failure = "cannot write '" + pending_targets[n] + "': " + std::strerror(errno);
                continue;
            }
            pending_live[n] = 0;
        }
    }
    remove_live_temporaries();
    if (!failure.empty()) throw InputError(failure);
}

void write_output_file(const std::string& path, const std::function<bool(std::FILE*)>& write) {
    if (OutputFiles* set = OutputFiles::active()) {
        set->add(path, write);
        return;
    }
    OutputFiles own;
    own.add(path, write);
    own.commit();
}

}  // namespace ctlab
