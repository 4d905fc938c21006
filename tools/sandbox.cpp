// sandbox.cpp: bubblewrap's command line, and whether it works here.
#include "sandbox.h"
#include <sys/stat.h>
#include <unistd.h>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include "process.h"

namespace ctlab {

namespace {
const char* const bwrap = "/usr/bin/bwrap";
constexpr unsigned first_sandbox_uid = 61000;  // above Debian's dynamic users, below nobody
constexpr unsigned sandbox_uids = 2000;
}  // namespace

std::vector<std::string> sandbox_command(const Sandbox& sandbox) {
    std::vector<std::string> words = {
        bwrap,
        "--unshare-all",        // user, pid, network, ipc, uts and cgroup namespaces
        "--die-with-parent",    // killing bwrap (a timeout) kills everything inside
        "--new-session",        // no way back to the grader's terminal
        "--cap-drop", "ALL",
        "--clearenv", "--setenv", "PATH", "/usr/bin:/bin", "--setenv", "TMPDIR", "/tmp",
        "--setenv", "LC_ALL", "C",
        "--ro-bind", "/usr", "/usr",
        "--symlink", "usr/bin", "/bin", "--symlink", "usr/sbin", "/sbin",
        "--symlink", "usr/lib", "/lib", "--symlink", "usr/lib64", "/lib64",
        "--proc", "/proc", "--dev", "/dev",
        "--size", std::to_string(sandbox.tmp_bytes), "--tmpfs", "/tmp"};
    for (const Mount& mount : sandbox.mounts) {
        words.insert(words.end(), {mount.writable ? "--bind" : "--ro-bind", mount.outside,
                                   mount.inside});
    }
    // Its root (bwrap's tmpfs, holding the mount points) read-only too: only the writable
    // mounts and /tmp take writes.
    words.insert(words.end(), {"--remount-ro", "/", "--chdir", sandbox.folder, "--"});
    return words;
}

const std::string& sandbox_problem() {
    static const std::string problem = [] {
        if (access(bwrap, X_OK) != 0) {
            return std::string(bwrap) + " is not installed (Debian's package bubblewrap)";
        }
        ProcessOptions options;
        options.prefix = sandbox_command({});
        options.limits.wall_s = 10;
        options.uid = sandbox_uid();
        try {
            const ProcessResult result = run_process("/usr/bin/true", {}, options);
            if (result.status == 0) return std::string();
            std::string why = result.err.substr(0, result.err.find('\n'));
            if (why.empty()) why = "it exited with status " + std::to_string(result.status);
            return "bwrap cannot make a sandbox here (user namespaces off?): " + why;
        } catch (const std::exception& error) {
            return std::string("bwrap cannot start: ") + error.what();
        }
    }();
    return problem;
}

unsigned sandbox_uid() {
    if (geteuid() != 0) return 0;
    return first_sandbox_uid + unsigned(getpid()) % sandbox_uids;
}

void give_to_sandbox(const std::string& folder) {
    const unsigned uid = sandbox_uid();
    if (uid == 0) return;
    namespace fs = std::filesystem;
    auto own = [&](const fs::path& path) {
        if (lchown(path.c_str(), uid, uid) != 0) {
            throw std::runtime_error("cannot give " + path.string() + " to the sandbox: " +
                                     std::strerror(errno));
        }
    };
    own(folder);
    for (const fs::directory_entry& entry : fs::recursive_directory_iterator(folder)) {
        own(entry.path());
    }
}

}  // namespace ctlab
