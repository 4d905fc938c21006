// sandbox.h: a student's build or run inside bubblewrap (bwrap, Debian's `bubblewrap`): a
// file system of its own made of /usr read-only and the folders a grader names (the
// student's sources and the volume read-only, one writable output folder), a small /tmp,
// no network (its own empty network namespace: not even the host's 127.0.0.1), no other
// processes in sight, no $HOME, no capabilities. The limits on CPU, memory, files and
// processes are tools/process.h's. Works unprivileged (user namespaces) and as root; as
// root the sandbox runs as a user id of its own (sandbox_uid()), since the kernel does not
// count root's processes against RLIMIT_NPROC.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace ctlab {

struct Mount {
    std::string outside;    // an absolute path on the host
    std::string inside;     // where the sandbox sees it
    bool writable = false;  // otherwise read-only
};

struct Sandbox {
    std::vector<Mount> mounts;      // besides /usr and its /bin, /lib links, /proc, /dev
    std::string folder = "/";       // the working folder inside
    size_t tmp_bytes = 64u << 20;   // the size of the sandbox's own /tmp (tmpfs)
};

// bwrap's command line for this sandbox, to put before the program's (ProcessOptions::prefix).
std::vector<std::string> sandbox_command(const Sandbox& sandbox);

// "" when a sandbox can be made here (bwrap is installed and starts a program), else one line
// saying why not. Found out once per process by starting /usr/bin/true in one.
const std::string& sandbox_problem();

// The user id a sandbox runs as when we are root (ProcessOptions::uid): one of its own for
// each grading process, so that two graders never share a process limit. 0 when not root.
unsigned sandbox_uid();

// Makes `folder` (and what is in it) writable by the sandbox's user: as root, owned by
// sandbox_uid(); otherwise nothing to do. Throws std::runtime_error when it cannot.
void give_to_sandbox(const std::string& folder);

}  // namespace ctlab
