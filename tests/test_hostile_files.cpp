// test_hostile_files.cpp: memory in proportion to the volume (issue 28, class 2).
//
// Each loader must take no more address space than the volume it returns plus a bounded
// buffer, whatever its file holds or claims. Each file of tests/formats/write_hostile.py --big
// (nibabel, numpy and hand-made headers: 256x256x64 float32 or int16, raw, gzip and zlib, a
// .nii.gz with 64 MiB of extension before its data) is loaded in a child process whose
// address space is limited (RLIMIT_AS, as `ulimit -v` sets it) to what it already uses plus
// the volume plus 12 MiB: a loader that kept the file's 16 MiB of float32 samples, or inflated
// the extension, would fail there. A control run with room for less than the volume must fail
// with a message naming the memory, not the file.
// The sanitizer build reserves terabytes of shadow memory: no address-space limit there, the
// files are still loaded and checked.
#include <doctest/doctest.h>
#include <malloc.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>
#include "common/error.h"
#include "common/formats.h"
#include "common/volume.h"
#include "tools/run_step.h"

using namespace ctlab;

namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool can_limit_memory = false;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool can_limit_memory = false;
#else
constexpr bool can_limit_memory = true;
#endif
#else
constexpr bool can_limit_memory = true;
#endif

constexpr uint64_t buffer_allowance = uint64_t(12) << 20;  // bytes beyond the volume
constexpr uint64_t big_voxels = 256 * 256 * 64;
// The int16 volume, dense (volume.h) and reserved in one piece.
const uint64_t big_volume_bytes = big_voxels * sizeof(int16_t);

Volume load_any(const std::string& path) {
    const std::string format = volume_format_of(path);
    if (format == "nifti") return load_nifti(path);
    if (format == "nrrd") return load_nrrd(path);
    if (format == "metaimage") return load_metaimage(path);
    if (format == "dicom") return load_dicom_series(path);
    RawFormat raw;
    REQUIRE(raw_format_from_name(path, &raw));
    return load_raw(path, raw);
}

// This process's address space in bytes.
uint64_t address_space() {
    std::ifstream statm("/proc/self/statm");
    unsigned long long pages = 0;
    statm >> pages;
    return uint64_t(pages) * uint64_t(sysconf(_SC_PAGESIZE));
}

struct ChildResult {
    int status = -1;      // 0 loaded as expected, 1 InputError, 2 another exception, 3 wrong
    std::string message;  // the InputError's text
};

// Loads `path` in a child limited to its address space now plus `extra` bytes (no limit when
// extra is 0); the child checks the volume's dims and that its values are not all equal.
ChildResult load_limited(const std::string& path, uint64_t extra) {
    int pipe_ends[2];
    REQUIRE(pipe(pipe_ends) == 0);
    std::fflush(nullptr);
    const pid_t child = fork();
    REQUIRE(child >= 0);
    if (child == 0) {
        close(pipe_ends[0]);
        if (extra > 0) {
            // Large blocks from fresh mappings, never from free room an earlier test left in
            // the heap (glibc raises its mmap threshold after large frees): every large
            // allocation the loader makes then counts against the limit.
            mallopt(M_MMAP_THRESHOLD, 128 * 1024);
            malloc_trim(0);
            const rlimit limit = {rlim_t(address_space() + extra), RLIM_INFINITY};
            setrlimit(RLIMIT_AS, &limit);
        }
        int status = 0;
        std::string message;
        try {
            const Volume volume = load_any(path);
            if (volume.nx != 256 || volume.ny != 256 || volume.nz != 64 ||
                volume.min_value == volume.max_value) {
                status = 3;
                message = volume_line(volume);
            }
        } catch (const InputError& error) {
            status = 1;
            message = error.what();
        } catch (const std::exception& error) {
            status = 2;
            message = error.what();
        }
        if (write(pipe_ends[1], message.data(), message.size()) < 0) status = 4;
        _exit(status);
    }
    close(pipe_ends[1]);
    ChildResult result;
    char buffer[4096];
    ssize_t got;
    while ((got = read(pipe_ends[0], buffer, sizeof buffer)) > 0) result.message.append(buffer, size_t(got));
    close(pipe_ends[0]);
    int status = 0;
    waitpid(child, &status, 0);
    result.status = WIFEXITED(status) ? WEXITSTATUS(status) : 100 + WTERMSIG(status);
    return result;
}

}  // namespace

TEST_CASE("hostile files: no loader takes more than its volume plus a bounded buffer") {
    if (std::system("/usr/bin/python3 -c 'import numpy, nibabel, pydicom' 2>/dev/null") != 0) {
        MESSAGE("skipped: python3-numpy, python3-nibabel or python3-pydicom is missing");
        return;
    }
    TempFolder folder("hostile_big");
    const std::string command = "/usr/bin/python3 tests/formats/write_hostile.py '" +
                                folder.path() + "' --big > /dev/null";
    REQUIRE(std::system(command.c_str()) == 0);
    std::ifstream list(folder.path("big.txt"));
    std::vector<std::string> names;
    for (std::string name; std::getline(list, name);) names.push_back(name);
    REQUIRE(names.size() >= 8);
    const uint64_t extra = can_limit_memory ? big_volume_bytes + buffer_allowance : 0;
    if (!can_limit_memory) MESSAGE("sanitizer build: loaded without an address-space limit");
    for (const std::string& name : names) {
        CAPTURE(name);
        const ChildResult result = load_limited(folder.path(name), extra);
        CHECK_MESSAGE(result.status == 0, result.message);
    }
    if (!can_limit_memory) return;
    // The control: room for the buffers but not the volume. Refused, naming the memory.
    for (const std::string& name : {std::string("big_gz.nrrd"), std::string("big_float.raw")}) {
        const std::string path = folder.path(name == "big_float.raw"
                                                 ? "big_256x256x64_float32.raw" : name);
        CAPTURE(path);
        const ChildResult result = load_limited(path, big_volume_bytes / 2);
        CHECK(result.status == 1);
        CHECK_MESSAGE(result.message.find("more memory than this process may take") !=
                          std::string::npos,
                      result.message);
    }
    (void)big_voxels;
}
