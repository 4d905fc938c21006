// output_files.h: all pictures or none. While an OutputFiles set is open, every output a step
// writes (write_png, and any writer that goes through add()) lands in an exclusive temporary
// file beside its target, ".NAME.tmpXXXXXX"; commit() renames them all into place only when
// every one was written. An error (the set destroyed uncommitted) or a signal (SIGINT, SIGTERM,
// SIGHUP, SIGQUIT, SIGPIPE, SIGALRM, SIGUSR1/2, SIGXCPU, SIGVTALRM, SIGPROF) removes the
// temporaries, so the output folder is exactly as it was before the run; SIGXFSZ is ignored
// meanwhile, so a file over `ulimit -f` fails as a write error (EFBIG) and is removed too.
#pragma once
#include <cstdio>
#include <functional>
#include <string>

namespace ctlab {

class OutputFiles {
public:
    // Opens the set (at most one at a time) and installs the signal handlers that clean up.
    OutputFiles();
    // Removes every temporary not committed and restores the signal handlers.
    ~OutputFiles();
    OutputFiles(const OutputFiles&) = delete;
    OutputFiles& operator=(const OutputFiles&) = delete;

    // Creates a temporary beside `path` and calls write(file): it returns false when the
    // encoder failed. Throws InputError "cannot write 'PATH': REASON" on any failure (the
    // temporary is removed then).
    void add(const std::string& path, const std::function<bool(std::FILE*)>& write);

    // Renames every temporary to its target, with the signals held back until all are done.
    void commit();

    // The set write_png() and other writers add to, or nullptr when none is open.
    static OutputFiles* active();
};

// Writes one file through a temporary renamed into place: into the active set when one is
// open (renamed at its commit), else on its own at once.
void write_output_file(const std::string& path, const std::function<bool(std::FILE*)>& write);

// Tests only: CTLAB_TEST_FAIL_WRITE=N makes the Nth file written by this process fail as if the
// disk were full (ENOSPC), so a test can simulate a full disk on the third view.
constexpr const char* fail_write_variable = "CTLAB_TEST_FAIL_WRITE";

}  // namespace ctlab
