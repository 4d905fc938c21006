// harness.h: what several test files share: a temporary folder, stdout capture, a fake argv,
// and the steps' main() functions run in-process (defined in test_steps.cpp).
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
#include "step.h"
#include "volume.h"

namespace ctlab_test {

// A folder of its own under the system temp folder, removed with everything in it.
class TempFolder {
public:
    explicit TempFolder(const std::string& tag) {
        static int count = 0;
        path_ = std::filesystem::temp_directory_path() /
                ("ctlab_" + tag + "_" + std::to_string(getpid()) + "_" + std::to_string(++count));
        std::filesystem::create_directories(path_);
    }
    ~TempFolder() {
        std::error_code ignored;
        std::filesystem::remove_all(path_, ignored);
    }
    std::string path() const { return path_.string(); }
    std::string path(const std::string& name) const { return (path_ / name).string(); }

    // Writes a file of exactly these bytes and returns its path.
    std::string file(const std::string& name, const std::vector<unsigned char>& bytes) const {
        std::ofstream out(path(name), std::ios::binary);
        out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
        return path(name);
    }

private:
    std::filesystem::path path_;
};

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

// --- The steps, run in-process (test_steps.cpp includes tools/all_steps.h) -----------------

using StepMain = int (*)(int argc, char** argv);

struct StepEntry {
    std::string name;  // "03_depth_shading", the step's own step_name
    StepMain main;     // the step's main(), compiled inside a namespace of its own
};

// Every step the tests include, in order. test_golden.cpp checks it against steps/*.cpp.
const std::vector<StepEntry>& included_steps();

// What a step's main() hands to run_views: its parsed options, volume and renderer.
using RendererUse =
    std::function<void(const ctlab::Options&, const ctlab::Volume&, const ctlab::Renderer&)>;

// Runs step `name`'s main() in-process with these flags. Its load_volume() returns `volume`
// instead of reading --volume, and where it would call run_views() it calls use() with the
// renderer it built (valid only during the call). Returns main()'s exit status.
int run_step(const std::string& name, const std::vector<std::string>& flags,
             const ctlab::Volume& volume, const RendererUse& use);

// Renders every view of a step as run_views would (render_view); images in top, front,
// side order. Fails the test when main() does not reach run_views.
std::vector<ctlab::Image> render_step(const std::string& name,
                                      const std::vector<std::string>& flags,
                                      const ctlab::Volume& volume);

}  // namespace ctlab_test
