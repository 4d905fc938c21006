// process.h: the one way the tools and tests start a child process. A program runs with no
// shell, stdin from /dev/null, stdout and stderr read through pipes up to a cap, inside a
// process group of its own (a timeout stops its children too), under setrlimit limits, and,
// for a student's code, inside a sandbox (tools/sandbox.h) whose command line is put before
// the program's.
//
// Compiled into build/libctlab_tools.a, never into a step.
#pragma once
#include <csignal>
#include <cstddef>
#include <string>
#include <vector>

namespace ctlab {

// What a child may use. A zero means "no limit of this kind" (the limit it inherited).
struct Limits {
    double wall_s = 120;           // wall-clock seconds, then the whole group is killed
    double cpu_s = 0;              // CPU seconds of each process (RLIMIT_CPU)
    size_t address_space = 0;      // bytes of virtual memory of each process (RLIMIT_AS)
    size_t file_size = 0;          // bytes of the largest file it may write (RLIMIT_FSIZE)
    size_t open_files = 0;         // open file descriptors (RLIMIT_NOFILE)
    size_t processes = 0;          // processes and threads it may add (RLIMIT_NPROC)
    size_t output_bytes = 64u << 20;  // of stdout, and of stderr: past this it is killed
};

struct ProcessOptions {
    std::string folder;               // the working folder ("" = this process's)
    Limits limits;
    std::vector<std::string> prefix;  // a sandbox's command (sandbox_command()), or empty
    // As root, run the sandbox as this user and group (a uid of its own, so that the process
    // limit holds: the kernel never counts root's processes). 0: as whoever runs us.
    unsigned uid = 0;
    // When this becomes nonzero (a signal handler's flag), the child is stopped: SIGTERM to
    // its group, SIGKILL a second later.
    const volatile std::sig_atomic_t* stop = nullptr;
    // Wait for the exit on a pidfd (Linux 5.3). false: the fallback for older kernels, short
    // naps once the pipes are closed; for the tests, which check both ways.
    bool wait_on_exit_fd = true;
};

struct ProcessResult {
    std::string program;             // the path that ran (without the prefix)
    std::vector<std::string> args;
    bool started = false;            // it started and exec succeeded (127 with a message otherwise)
    int status = -1;                 // exit status; 128 + N when killed by signal N
    int exit_status = -1;            // when it exited
    int signal = 0;                  // when a signal ended it (a timeout: SIGKILL)
    bool timed_out = false;          // killed after limits.wall_s
    bool output_exceeded = false;    // killed for printing more than limits.output_bytes
    bool interrupted = false;        // stopped because *options.stop was set
    std::string out, err;            // what it printed, at most limits.output_bytes each
    double seconds = 0;              // wall-clock time it took
    long max_rss_kib = 0;            // peak resident memory of the child (ru_maxrss), KiB
    double cpu_s = 0;                // CPU time of the child, user + system (rusage), seconds

    // The command line, for messages: "build/03_depth_shading --view top ...".
    std::string command() const;
    // One line saying why it did not exit normally ("" when it exited, whatever its status):
    // "stopped after 5 s", "printed more than 1 MiB", "killed by SIGXCPU (CPU limit)", ...
    std::string stop_reason() const;
};

// Runs `program` with `args`. Throws std::runtime_error only when no process can be made.
ProcessResult run_process(const std::string& program, const std::vector<std::string>& args,
                          const ProcessOptions& options = {});

// "12 MiB", "1.5 GiB": a byte count for messages.
std::string readable_size(size_t bytes);

}  // namespace ctlab
