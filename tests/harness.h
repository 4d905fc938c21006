// harness.h: what several test files share: a temporary folder, stdout capture, a fake argv,
// and the steps run as processes on analytic volumes (harness.cpp, over tools/run_step.h).
#pragma once
#include <unistd.h>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>
#include "args.h"
#include "image.h"
#include "tools/run_step.h"
#include "view.h"
#include "volume.h"

namespace ctlab_test {

// A folder of its own under the system temp folder, removed with everything in it
// (tools/run_step.h: created exclusively with mkdtemp).
using TempFolder = ctlab::TempFolder;

// Everything body() printed to stdout (printf and std::cout both go through file 1).
// Do not put doctest checks inside body: their report would be captured too.
inline std::string capture_stdout(const std::function<void()>& body) {
    std::fflush(stdout);
    std::FILE* sink = std::tmpfile();
    const int saved = dup(1);
    dup2(fileno(sink), 1);
    try {
        body();
    } catch (...) {
        std::fflush(stdout);
        dup2(saved, 1);
        close(saved);
        std::fclose(sink);
        throw;
    }
    std::fflush(stdout);
    dup2(saved, 1);
    close(saved);
    std::string text;
    std::rewind(sink);
    char buffer[4096];
    size_t count;
    while ((count = std::fread(buffer, 1, sizeof buffer, sink)) > 0) text.append(buffer, count);
    std::fclose(sink);
    return text;
}

// argv for Args::parse or a step's main: {"test", words...}, kept alive with the object.
class FakeArgv {
public:
    explicit FakeArgv(std::vector<std::string> words) : words_(std::move(words)) {
        words_.insert(words_.begin(), "ctlab_test");
        for (std::string& word : words_) pointers_.push_back(word.data());
        pointers_.push_back(nullptr);
    }
    int argc() const { return int(words_.size()); }
    char** argv() { return pointers_.data(); }

private:
    std::vector<std::string> words_;
    std::vector<char*> pointers_;
};

// --- The steps, run as processes (tools/run_step.h) ---------------------------------------

// Every step in steps/ by name ("03_depth_shading"), sorted: each has a binary in the build
// folder beside the test program. Part 1's steps (00..09) render the three axis views; part
// 2's (10 on) one orbit-camera picture, "camera".
const std::vector<std::string>& step_names();
const std::vector<std::string>& part1_step_names();  // 00..09 only
bool is_camera_step(const std::string& name);        // 10 on

// The "every step" tests run part 2's steps at a small picture size, not square (a swapped
// width and height shows): `--size` with it. Part 1's steps get no flags.
constexpr int camera_width = 24, camera_height = 17;  // pixels
std::vector<std::string> size_flags(const std::string& name);

// The built-in phantom as a step's flags, "--volume PATH --dims 256,256,113 --spacing 1,1,2":
// make_phantom() painted once in this process and written as a raw int16 file (removed at
// exit). The same voxels, values and spacing as `--volume phantom`, so the same pictures
// and traces, without each step process painting the head again (0.12 s of CPU a run,
// most of a small picture's run). Only the volume line differs: "volume=PATH".
const std::vector<std::string>& phantom_flags();
// `flags` with "--volume phantom" (if there) replaced by phantom_flags().
std::vector<std::string> phantom_from_file(std::vector<std::string> flags);

// What a step renders of `volume` in its default run: part 1, views_named(volume, "all");
// part 2, one view "camera" of camera_width x camera_height (with size_flags).
std::vector<ctlab::View> default_views(const std::string& name, const ctlab::Volume& volume);

// One run of a step with --pfm: what it printed and the float images it wrote.
struct StepRender {
    ctlab::RunResult run;
    std::vector<std::string> views;    // in the order rendered (top, front, side)
    std::vector<ctlab::Image> images;  // the --pfm image of each, float RGB, before rounding
    const ctlab::Image& image(const std::string& view) const;
    const ctlab::Summary& summary(const std::string& view) const { return run.summary(view); }
};

// Where the tests that start hundreds of step processes keep their scratch files (for
// TempFolder's `parent`): /dev/shm when it is a memory file system (tmpfs) with at least
// 256 MiB free and TMPDIR is not set, else "" (the system temp folder). Creating, renaming and
// removing each run's files on a disk's file system (ext4) was ~15% of such a test's CPU.
const std::string& scratch_parent();

// Runs step `name` with these flags plus --pfm and --out (a temporary folder) and reads every
// view's float image. With a volume, it is written to a temporary raw file first and loaded
// with --volume/--dims/--spacing; without one, the flags say which volume. Checks (doctest)
// that the step exits with status 0 and wrote a summary line and image per view.
StepRender render(const std::string& name, const std::vector<std::string>& flags);
StepRender render(const std::string& name, const std::vector<std::string>& flags,
                  const ctlab::Volume& volume);

// The same with --out `folder`, the caller's (a new one for each run: a picture left there by
// an earlier run would be read as this one's).
StepRender render_in(const TempFolder& folder, const std::string& name,
                     std::vector<std::string> flags);

// The images alone, in top, front, side order as rendered.
std::vector<ctlab::Image> render_step(const std::string& name,
                                      const std::vector<std::string>& flags,
                                      const ctlab::Volume& volume);

}  // namespace ctlab_test
