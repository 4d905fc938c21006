// process.cpp: starting a child process with limits, reading its output within a cap.
#include "process.h"
#include <dirent.h>
#include <fcntl.h>
#include <grp.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace ctlab {

std::string ProcessResult::command() const {
    std::string text = program;
    for (const std::string& arg : args) text += " " + arg;
    return text;
}

std::string readable_size(size_t bytes) {
    const char* units[] = {"bytes", "KiB", "MiB", "GiB", "TiB"};
    double value = double(bytes);
    int unit = 0;
    while (value >= 1024 && unit < 4) {
        value /= 1024;
        ++unit;
    }
    char text[40];
    if (unit == 0 || value == std::floor(value)) {
        std::snprintf(text, sizeof text, "%.0f %s", value, units[unit]);
    } else {
        std::snprintf(text, sizeof text, "%.1f %s", value, units[unit]);
    }
    return text;
}

std::string ProcessResult::stop_reason() const {
    if (timed_out) {
        char text[80];
        std::snprintf(text, sizeof text, "stopped after %.3g s of wall-clock time", seconds);
        return text;
    }
    if (output_exceeded) return "stopped: it printed more than the output cap";
    if (interrupted) return "stopped: the grader was interrupted";
    switch (signal) {
        case 0: return "";
        case SIGXCPU: return "killed by SIGXCPU: it used up its CPU seconds";
        case SIGXFSZ: return "killed by SIGXFSZ: it wrote a file larger than the file size limit";
        case SIGKILL: return "killed by SIGKILL (out of memory?)";
        default: {
            const char* name = strsignal(signal);
            return "killed by signal " + std::to_string(signal) +
                   (name ? std::string(" (") + name + ")" : std::string());
        }
    }
}

namespace {

// Tasks (processes and threads) that `uid` runs now: RLIMIT_NPROC counts them all, so a
// limit for one child is what it may add to these.
size_t tasks_of(unsigned uid) {
    size_t count = 0;
    DIR* proc = opendir("/proc");
    if (!proc) return 0;
    while (const dirent* entry = readdir(proc)) {
        if (entry->d_name[0] < '0' || entry->d_name[0] > '9') continue;
        std::ifstream status(std::string("/proc/") + entry->d_name + "/status");
        unsigned real_uid = ~0u;
        size_t threads = 1;
        for (std::string line; std::getline(status, line);) {
            if (line.rfind("Uid:", 0) == 0) real_uid = unsigned(std::strtoul(line.c_str() + 4,
                                                                           nullptr, 10));
            if (line.rfind("Threads:", 0) == 0) threads = std::strtoul(line.c_str() + 8,
                                                                        nullptr, 10);
        }
        if (real_uid == uid) count += threads;
    }
    closedir(proc);
    return count;
}

// `hard_extra`: the hard limit that far above the soft one (CPU: SIGXCPU, then a second later
// SIGKILL for a program that catches it).
void set_limit(int resource, rlim_t value, rlim_t hard_extra = 0) {
    if (value == 0) return;
    rlimit limit {};
    if (getrlimit(resource, &limit) != 0) return;
    // Never above the hard limit we were given (an unprivileged process cannot raise it).
    const rlim_t ceiling = limit.rlim_max;
    limit.rlim_cur = ceiling != RLIM_INFINITY ? std::min(value, ceiling) : value;
    limit.rlim_max = ceiling != RLIM_INFINITY ? std::min(value + hard_extra, ceiling)
                                              : value + hard_extra;
    setrlimit(resource, &limit);
}

// Reads what is there; false at end of file. Past `cap` bytes the rest is counted, not kept.
bool drain(int fd, std::string& text, size_t cap, bool& exceeded) {
    char buffer[65536];
    const ssize_t count = read(fd, buffer, sizeof buffer);
    if (count > 0) {
        const size_t room = text.size() < cap ? cap - text.size() : 0;
        text.append(buffer, std::min(room, size_t(count)));
        if (size_t(count) > room) exceeded = true;
        return true;
    }
    return count < 0 && (errno == EINTR || errno == EAGAIN);
}

// A descriptor that becomes readable when `child` exits (Linux 5.3's pidfd_open), so that a
// wait for the exit is one poll with no tick; -1 where the kernel has none.
int open_exit_fd(pid_t child) {
#ifdef SYS_pidfd_open
    const long fd = syscall(SYS_pidfd_open, child, 0);
    if (fd >= 0) {
        fcntl(int(fd), F_SETFD, FD_CLOEXEC);  // another thread's child must not inherit it
        return int(fd);
    }
#else
    (void)child;
#endif
    return -1;
}

// What the child needs between its start and exec, prepared by the parent: the child shares
// the parent's memory and may only make system calls (no allocation, no locks, no errno the
// parent reads).
struct ChildSetup {
    char** argv;
    const char* program;
    const char* folder;  // nullptr: the parent's
    int out_fd, err_fd, exec_fd;  // the pipes' write ends
    rlim_t cpu_s, address_space, file_size, open_files, processes;  // 0: no limit
    bool change_user;
    unsigned user;
    char user_text[48];  // "cannot change to user N", for the message
    const sigset_t* signal_mask;  // the parent's, restored just before exec
};
constexpr size_t child_stack_bytes = 64 * 1024;  // child_main and execvp's path buffer
#if defined(__SANITIZE_ADDRESS__)
constexpr bool sanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool sanitized = true;
#else
constexpr bool sanitized = false;
#endif
#else
constexpr bool sanitized = false;
#endif

// Writes "cannot run PROGRAM: WHAT: ERROR" and the error number for the parent; exit 127.
[[noreturn]] void child_fails(const ChildSetup& setup, const char* what, int error) {
    const char* parts[] = {"cannot run ", setup.program, ": ", what, ": ", strerror(error), "\n"};
    for (const char* part : parts) {
        if (write(2, part, strlen(part)) < 0) break;
    }
    if (write(setup.exec_fd, &error, sizeof error) < 0) _exit(127);
    _exit(127);
}

int child_main(void* argument) {
    const ChildSetup& setup = *static_cast<const ChildSetup*>(argument);
    // The parent's handlers back to the default: a signal now must not run them here.
    for (int number = 1; number < NSIG; ++number) {
        struct sigaction action {};
        if (sigaction(number, nullptr, &action) != 0) continue;
        if (action.sa_handler == SIG_IGN || action.sa_handler == SIG_DFL) continue;
        action = {};
        action.sa_handler = SIG_DFL;
        sigaction(number, &action, nullptr);
    }
    setpgid(0, 0);  // its own group: a timeout stops its children too
    const int null_in = open("/dev/null", O_RDONLY | O_CLOEXEC);
    if (null_in >= 0) dup2(null_in, 0);
    dup2(setup.out_fd, 1);
    dup2(setup.err_fd, 2);
    if (setup.folder && chdir(setup.folder) != 0) child_fails(setup, setup.folder, errno);
    set_limit(RLIMIT_CPU, setup.cpu_s, 1);
    set_limit(RLIMIT_AS, setup.address_space);
    set_limit(RLIMIT_FSIZE, setup.file_size);
    set_limit(RLIMIT_NOFILE, setup.open_files);
    set_limit(RLIMIT_NPROC, setup.processes);
    set_limit(RLIMIT_CORE, 1);  // 1 byte: no core files
    // The system calls themselves: the C library's setuid() would also change the parent's
    // other threads, whose memory this child shares.
    if (setup.change_user && (syscall(SYS_setgroups, 0, nullptr) != 0 ||
                              syscall(SYS_setgid, setup.user) != 0 ||
                              syscall(SYS_setuid, setup.user) != 0)) {
        child_fails(setup, setup.user_text, errno);
    }
    pthread_sigmask(SIG_SETMASK, setup.signal_mask, nullptr);
    execvp(setup.argv[0], setup.argv);
    child_fails(setup, "exec", errno);
}

}  // namespace

ProcessResult run_process(const std::string& program, const std::vector<std::string>& args,
                          const ProcessOptions& options) {
    ProcessResult result;
    result.program = program;
    result.args = args;
    const Limits& limits = options.limits;
    std::vector<std::string> words = options.prefix;
    words.push_back(program);
    words.insert(words.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& word : words) argv.push_back(word.data());
    argv.push_back(nullptr);
    const bool change_user = options.uid != 0 && geteuid() == 0;
    const unsigned user = change_user ? options.uid : unsigned(getuid());
    const size_t processes = limits.processes ? tasks_of(user) + limits.processes : 0;

    // Close-on-exec: a child started at the same time by another thread never holds them.
    int out_pipe[2], err_pipe[2], exec_pipe[2];
    if (pipe2(out_pipe, O_CLOEXEC) != 0) throw std::runtime_error("pipe: " +
                                                                 std::string(strerror(errno)));
    if (pipe2(err_pipe, O_CLOEXEC) != 0 || pipe2(exec_pipe, O_CLOEXEC) != 0) {
        close(out_pipe[0]);
        close(out_pipe[1]);
        throw std::runtime_error("pipe: " + std::string(strerror(errno)));
    }
    std::fflush(nullptr);  // nothing buffered here may be written twice by the child
    ChildSetup setup;
    setup.argv = argv.data();
    setup.program = program.c_str();
    setup.folder = options.folder.empty() ? nullptr : options.folder.c_str();
    setup.out_fd = out_pipe[1];
    setup.err_fd = err_pipe[1];
    setup.exec_fd = exec_pipe[1];
    setup.cpu_s = rlim_t(std::ceil(limits.cpu_s));
    setup.address_space = limits.address_space;
    setup.file_size = limits.file_size;
    setup.open_files = limits.open_files;
    setup.processes = processes;
    setup.change_user = change_user;
    setup.user = user;
    std::snprintf(setup.user_text, sizeof setup.user_text, "cannot change to user %u", user);
    // The child runs on a stack of its own in this process's memory until it execs (as
    // posix_spawn does): no copy of the parent's page tables, which a fork of a large test
    // binary paid for every step it ran. Every signal is held back meanwhile, so that no
    // handler of ours runs in the child. A sanitizer build forks: there the child's system
    // calls go through the sanitizer's interceptors, which must not run in shared memory.
    const size_t stack_bytes = child_stack_bytes + sizeof(char*) * argv.size();
    void* stack = sanitized ? MAP_FAILED
                            : mmap(nullptr, stack_bytes, PROT_READ | PROT_WRITE,
                                   MAP_PRIVATE | MAP_ANONYMOUS | MAP_STACK, -1, 0);
    sigset_t all, before;
    sigfillset(&all);
    pthread_sigmask(SIG_SETMASK, &all, &before);
    setup.signal_mask = &before;
    const auto start = std::chrono::steady_clock::now();
    pid_t child = -1;
    if (stack != MAP_FAILED) {
        child = clone(child_main, static_cast<char*>(stack) + stack_bytes,
                      CLONE_VM | CLONE_VFORK | SIGCHLD, &setup);
    } else {
        child = fork();
        if (child == 0) child_main(&setup);
    }
    const int clone_error = errno;
    pthread_sigmask(SIG_SETMASK, &before, nullptr);
    if (stack != MAP_FAILED) munmap(stack, stack_bytes);
    if (child < 0) {
        for (int fd : {out_pipe[0], out_pipe[1], err_pipe[0], err_pipe[1], exec_pipe[0],
                       exec_pipe[1]}) {
            close(fd);
        }
        throw std::runtime_error("cannot start a process: " +
                                 std::string(strerror(clone_error)));
    }
    setpgid(child, child);
    close(out_pipe[1]);
    close(err_pipe[1]);
    close(exec_pipe[1]);
    int exec_error = 0;
    result.started = read(exec_pipe[0], &exec_error, sizeof exec_error) <= 0;
    close(exec_pipe[0]);

    using clock = std::chrono::steady_clock;
    const auto deadline = start + std::chrono::duration<double>(limits.wall_s);
    bool out_open = true, err_open = true, exited = false;
    int wait_status = 0;
    rusage usage {};
    auto kill_all = [&] {
        kill(-child, SIGKILL);
        kill(child, SIGKILL);
    };
    // The exit is one more thing to poll for: a child that closed its pipes (or exited: they
    // close just before it does) wakes us the moment it ends, not at the next tick.
    const int exit_fd = options.wait_on_exit_fd ? open_exit_fd(child) : -1;
    // Without it, a wait with both pipes closed sleeps in short naps that grow from 0.2 ms to
    // 10 ms: a quick child is seen quickly, a long one costs ~100 wake-ups a second.
    constexpr long first_nap_ns = 200'000, longest_nap_ns = 10'000'000;
    long nap_ns = first_nap_ns;
    while (!exited) {
        if (options.stop && *options.stop) {
            result.interrupted = true;
            kill(-child, SIGTERM);  // a grader below us removes its stage first
            for (int n = 0; n < 100 && wait4(child, &wait_status, WNOHANG, &usage) == 0; ++n) {
                pollfd exit_poll = {exit_fd, POLLIN, 0};
                poll(&exit_poll, 1, 10);  // exit_fd -1: a plain 10 ms nap
            }
            kill_all();
            break;
        }
        const double left =
            std::chrono::duration<double, std::milli>(deadline - clock::now()).count();
        if (left <= 0) {
            result.timed_out = true;
            kill_all();
            break;
        }
        pollfd fds[3] = {{out_open ? out_pipe[0] : -1, POLLIN, 0},
                         {err_open ? err_pipe[0] : -1, POLLIN, 0},
                         {exit_fd, POLLIN, 0}};
        int ready = 0;
        if (out_open || err_open || exit_fd >= 0) {
            // At most 100 ms at a time: a stop flag set by a signal that came just before
            // the poll (so did not interrupt it) is seen within that.
            ready = poll(fds, 3, int(std::min(left, 100.0)) + 1);
        } else {
            const long nap = std::min(nap_ns, long(left * 1e6) + 1);
            const timespec pause = {nap / 1'000'000'000, nap % 1'000'000'000};
            nanosleep(&pause, nullptr);  // a signal ends it early: the flag is seen next
            nap_ns = std::min(2 * nap_ns, longest_nap_ns);
        }
        if (ready > 0) {
            bool exceeded = false;
            if (out_open && (fds[0].revents & (POLLIN | POLLHUP | POLLERR))) {
                out_open = drain(out_pipe[0], result.out, limits.output_bytes, exceeded);
            }
            if (err_open && (fds[1].revents & (POLLIN | POLLHUP | POLLERR))) {
                err_open = drain(err_pipe[0], result.err, limits.output_bytes, exceeded);
            }
            if (exceeded) {
                result.output_exceeded = true;
                kill_all();
                break;
            }
        }
        const pid_t done = wait4(child, &wait_status, WNOHANG, &usage);
        if (done == child) exited = true;
        // Reaped by someone else (SIGCHLD ignored): its exit fd stays readable, never spin.
        if (done < 0 && errno == ECHILD) break;
    }
    if (exit_fd >= 0) close(exit_fd);
    if (!exited) {
        while (wait4(child, &wait_status, 0, &usage) < 0 && errno == EINTR) {
        }
    }
    kill(-child, SIGKILL);  // whatever it left running in its group
    // What is still in the pipes (a child that exited with output unread).
    for (int fd : {out_pipe[0], err_pipe[0]}) {
        fcntl(fd, F_SETFL, O_NONBLOCK);
        std::string& text = fd == out_pipe[0] ? result.out : result.err;
        char buffer[65536];
        for (ssize_t count; (count = read(fd, buffer, sizeof buffer)) > 0;) {
            const size_t room = text.size() < limits.output_bytes
                                    ? limits.output_bytes - text.size() : 0;
            text.append(buffer, std::min(room, size_t(count)));
            if (size_t(count) > room) {
                result.output_exceeded = true;
                break;
            }
        }
        close(fd);
    }
    result.seconds = std::chrono::duration<double>(clock::now() - start).count();
    result.max_rss_kib = usage.ru_maxrss;  // Linux: kibibytes
    result.cpu_s = double(usage.ru_utime.tv_sec) + double(usage.ru_stime.tv_sec) +
                   1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
    if (WIFEXITED(wait_status)) {
        result.exit_status = WEXITSTATUS(wait_status);
        result.status = result.exit_status;
    }
    if (WIFSIGNALED(wait_status)) {
        result.signal = WTERMSIG(wait_status);
        result.status = 128 + result.signal;
    }
    return result;
}

}  // namespace ctlab
