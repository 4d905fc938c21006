// process.cpp: starting a child process with limits, reading its output within a cap.
#include "process.h"
#include <dirent.h>
#include <fcntl.h>
#include <grp.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
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
    const auto start = std::chrono::steady_clock::now();
    const pid_t child = fork();
    if (child < 0) throw std::runtime_error("fork: " + std::string(strerror(errno)));
    if (child == 0) {
        setpgid(0, 0);  // its own group: a timeout stops its children too
        const int null_in = open("/dev/null", O_RDONLY);
        if (null_in >= 0) dup2(null_in, 0);
        dup2(out_pipe[1], 1);
        dup2(err_pipe[1], 2);
        auto fail = [&](const std::string& what) {
            const int error = errno;
            const std::string message = "cannot run " + program + ": " + what + ": " +
                                        strerror(error) + "\n";
            if (write(2, message.data(), message.size()) < 0) _exit(127);
            if (write(exec_pipe[1], &error, sizeof error) < 0) _exit(127);
            _exit(127);
        };
        if (!options.folder.empty() && chdir(options.folder.c_str()) != 0) fail(options.folder);
        set_limit(RLIMIT_CPU, rlim_t(std::ceil(limits.cpu_s)), 1);
        set_limit(RLIMIT_AS, limits.address_space);
        set_limit(RLIMIT_FSIZE, limits.file_size);
        set_limit(RLIMIT_NOFILE, limits.open_files);
        set_limit(RLIMIT_NPROC, processes);
        set_limit(RLIMIT_CORE, 1);  // 1 byte: no core files
        if (change_user && (setgroups(0, nullptr) != 0 || setgid(user) != 0 ||
                            setuid(user) != 0)) {
            fail("cannot change to user " + std::to_string(user));
        }
        execvp(argv[0], argv.data());
        fail("exec");
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
    while (!exited) {
        if (options.stop && *options.stop) {
            result.interrupted = true;
            kill(-child, SIGTERM);  // a grader below us removes its stage first
            for (int n = 0; n < 100 && wait4(child, &wait_status, WNOHANG, &usage) == 0; ++n) {
                poll(nullptr, 0, 10);
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
        pollfd fds[2] = {{out_open ? out_pipe[0] : -1, POLLIN, 0},
                         {err_open ? err_pipe[0] : -1, POLLIN, 0}};
        // With both pipes closed, poll only waits: check for the exit every 10 ms.
        const int wait_ms = out_open || err_open ? int(std::min(left, 100.0)) + 1 : 10;
        const int ready = poll(fds, 2, wait_ms);
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
    }
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
