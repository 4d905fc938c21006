// test_class_cache.cpp: the class cache (tools/class_cache.h) hands a build or a run only to
// the very same source and arguments: an entry whose folder name (a hash) matches but whose
// key text differs is never taken, a run stopped by a limit is never stored, and two argument
// lists never share a key text.
#include <doctest/doctest.h>
#include <signal.h>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include "tools/class_cache.h"
#include "tools/run_step.h"

using namespace ctlab;
namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

void write_text(const fs::path& path, const std::string& text) {
    std::ofstream out(path, std::ios::binary);
    out << text;
}

// The one folder under `parent` (a cache's lab-*/build or lab-*/run).
fs::path only_entry(const fs::path& parent) {
    fs::path found;
    int count = 0;
    for (const fs::directory_entry& entry : fs::directory_iterator(parent)) {
        found = entry.path();
        ++count;
    }
    REQUIRE(count == 1);
    return found;
}

fs::path lab_folder(const TempFolder& cache) { return only_entry(cache.path()); }

ProcessResult exited(int status, const std::string& out) {
    ProcessResult result;
    result.started = true;
    result.status = result.exit_status = status;
    result.out = out;
    result.err = "err of " + out;
    result.seconds = 0.25;
    return result;
}

}  // namespace

TEST_CASE("class cache: a build is taken for the same step and source only") {
    const TempFolder cache("class_cache_test");
    const TempFolder work("class_cache_work");
    const ClassCache classes(cache.path(), "lab one");
    const std::string source = "int main() { return 0; }\n";
    const std::string binary = work.text_file("built", "the binary's bytes");
    CHECK(classes.take_build("02_threshold", source, work.path("out")).empty());
    classes.store_build("02_threshold", source, binary);

    const std::string key = classes.take_build("02_threshold", source, work.path("out"));
    CHECK(!key.empty());
    CHECK(read_text(work.path("out")) == "the binary's bytes");
    // One byte more, another step's name, another lab: nothing.
    CHECK(classes.take_build("02_threshold", source + " ", work.path("other")).empty());
    CHECK(classes.take_build("03_depth_shading", source, work.path("other")).empty());
    CHECK(!fs::exists(work.path("other")));

    // A second store of the same source keeps the first binary.
    classes.store_build("02_threshold", source, work.text_file("built2", "another build"));
    classes.take_build("02_threshold", source, work.path("out"));
    CHECK(read_text(work.path("out")) == "the binary's bytes");

    // An entry folder of the same name holding another source (a hash collision, made
    // here by hand) is not taken for this one.
    const fs::path entry = only_entry(lab_folder(cache) / "build");
    write_text(entry / "source.cpp", "int main() { return 1; }\n");
    CHECK(classes.take_build("02_threshold", source, work.path("collided")).empty());
    CHECK(!fs::exists(work.path("collided")));

    // Another lab (instructor's inputs) in the same folder: another cache.
    classes.store_build("01_ray_loops", source, binary);
    CHECK(ClassCache(cache.path(), "lab two").take_build("01_ray_loops", source,
                                                          work.path("other")).empty());
    CHECK(!fs::exists(work.path("other")));
}

TEST_CASE("class cache: a run is taken for the same build and arguments only") {
    const TempFolder cache("class_cache_test");
    const TempFolder work("class_cache_work");
    const ClassCache classes(cache.path(), "lab");
    const std::vector<std::string> arguments = {"--volume", "phantom", "--out", "/out"};
    const fs::path ran = work.path("ran");
    fs::create_directory(ran);
    write_text(ran / "02_threshold_top.png", "picture bytes");
    classes.store_run("02_threshold-1", arguments, exited(3, "step=02 view=top"), ran.string(),
                      {"02_threshold_top.png"});

    const fs::path again = work.path("again");
    fs::create_directory(again);
    ProcessResult outcome;
    REQUIRE(classes.take_run("02_threshold-1", arguments, again.string(), outcome));
    CHECK(outcome.exit_status == 3);
    CHECK(outcome.status == 3);
    CHECK(outcome.signal == 0);
    CHECK(outcome.out == "step=02 view=top");
    CHECK(outcome.err == "err of step=02 view=top");
    CHECK(outcome.seconds == doctest::Approx(0.25));
    CHECK(read_text(again / "02_threshold_top.png") == "picture bytes");

    ProcessResult none;
    const fs::path empty = work.path("empty");
    fs::create_directory(empty);
    CHECK(!classes.take_run("02_threshold-2", arguments, empty.string(), none));
    CHECK(!classes.take_run("02_threshold-1", {"--volume", "phantom", "--out"}, empty.string(),
                            none));
    // Words are kept apart: "a b" as one argument is not "a", "b".
    classes.store_run("k", {"a b"}, exited(0, "one"), ran.string(), {});
    CHECK(!classes.take_run("k", {"a", "b"}, empty.string(), none));
    CHECK(fs::is_empty(empty));

    // A run entry whose key text is another's (a collision, made by hand) is not taken.
    const TempFolder cache2("class_cache_test");
    const ClassCache other(cache2.path(), "lab");
    other.store_run("02_threshold-1", arguments, exited(0, "x"), ran.string(), {});
    const fs::path entry = only_entry(lab_folder(cache2) / "run");
    write_text(entry / "key.txt", "build 02_threshold-9\n");
    CHECK(!other.take_run("02_threshold-1", arguments, empty.string(), none));
}

TEST_CASE("class cache: a run stopped by a limit or a kill is not stored") {
    const TempFolder cache("class_cache_test");
    const TempFolder work("class_cache_work");
    const ClassCache classes(cache.path(), "lab");
    ProcessResult timed_out = exited(0, "");
    timed_out.timed_out = true;
    ProcessResult printed = exited(0, "");
    printed.output_exceeded = true;
    ProcessResult interrupted = exited(0, "");
    interrupted.interrupted = true;
    ProcessResult never_started;
    int n = 0;
    for (ProcessResult stopped : {timed_out, printed, interrupted, never_started}) {
        CHECK(!ClassCache::reusable(stopped));
        classes.store_run("k", {std::to_string(n++)}, stopped, work.path(), {});
    }
    for (int signal : {SIGKILL, SIGXCPU, SIGXFSZ}) {
        ProcessResult killed = exited(-1, "");
        killed.exit_status = -1;
        killed.signal = signal;
        CHECK(!ClassCache::reusable(killed));
        classes.store_run("k", {std::to_string(n++)}, killed, work.path(), {});
    }
    CHECK(fs::is_empty(lab_folder(cache) / "run"));
    // A crash of its own (a segmentation fault) is the program's: the same each time.
    ProcessResult crashed = exited(-1, "");
    crashed.exit_status = -1;
    crashed.signal = SIGSEGV;
    CHECK(ClassCache::reusable(crashed));
    CHECK(ClassCache::reusable(exited(1, "")));
}

TEST_CASE("class cache: one tree at a time builds a source, the others wait for it") {
    const TempFolder cache("class_cache_test");
    const ClassCache classes(cache.path(), "lab");
    std::unique_ptr<CacheLock> held = classes.lock_build("02_threshold", "source", nullptr);
    REQUIRE(held);
    // Told to stop while another holds the lock: it gives up instead of waiting on.
    volatile std::sig_atomic_t stop = 1;
    CHECK(classes.lock_build("02_threshold", "source", &stop) == nullptr);
    CHECK(classes.lock_build("02_threshold", "another source", &stop) != nullptr);
    held.reset();
    CHECK(classes.lock_build("02_threshold", "source", &stop) != nullptr);
}

TEST_CASE("class cache: past its size nothing more is stored, and grading goes on") {
    const TempFolder cache("class_cache_test");
    const TempFolder work("class_cache_work");
    const ClassCache classes(cache.path(), "lab", 100);  // bytes
    const std::string small = work.text_file("small", std::string(40, 'a'));
    const std::string large = work.text_file("large", std::string(70, 'b'));
    classes.store_build("02_threshold", "s1", small);  // 42 bytes: kept
    CHECK(!classes.take_build("02_threshold", "s1", work.path("out1")).empty());
    classes.store_build("02_threshold", "s2", large);  // 72 more: past 100
    CHECK(classes.take_build("02_threshold", "s2", work.path("out2")).empty());
    classes.store_build("03_depth_shading", "s3", small);  // 42 more: 84, still within
    CHECK(!classes.take_build("03_depth_shading", "s3", work.path("out3")).empty());
    CHECK(read_text(fs::path(cache.path()) / lab_folder(cache).filename() / "size.txt") ==
          "84\n");
}
