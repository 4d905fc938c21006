// class_cache.h: what one class run (build/grade --class) builds and runs once and shares among
// its students' build/check processes. In a class most step sources are byte-identical across
// trees (every tree starts from the same kit; generated trees differ in one step), so:
//   - a build entry is one step's binary, built in a sandbox of its own that saw only that
//     source and the instructor's inputs (Makefile, common/, library, modules). Its key is the
//     step's name and source bytes; a tree whose source is the same byte for byte takes the
//     binary instead of compiling it again.
//   - a run entry is what one run of such a binary did (its exit, stdout, stderr and the files
//     it left in its output folder), keyed by the build entry and the run's exact arguments.
//     Every run's sandbox shows the same files (its binary, the modules, data/, the volume, an
//     empty /out), so the same program with the same arguments sees the same inputs. A run
//     stopped by a limit (wall time, CPU, output, file size, a kill) is never stored: its end
//     depends on the machine's load, not on the program alone.
// Poisoning: an entry is written by the trusted grader (never by a sandbox: the cache folder is
// mounted in none), published whole by one rename, and read only after its key text (the
// whole source, the whole argument list) is compared byte for byte; a key's hash only names
// its folder. So a program's binary or output is only ever reused for the very same source.
// With --no-sandbox nothing may be cached: an unconfined program could write into the cache.
//
// Entries live under FOLDER/<lab fingerprint>/: a cache given to another lab is another cache.
// Its size is bounded (a step binary is some 9 MB, and a real class's sources are mostly its
// students' own): past max_bytes, or with less than a GiB left on its file system, nothing more
// is stored; grading goes on without it, slower, never otherwise.
#pragma once
#include <csignal>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>
#include "tools/process.h"

namespace ctlab {

// FNV-1a, 64 bits: names cache folders (never trusted alone: keys are compared whole).
unsigned long long fnv1a_64(const std::string& bytes,
                            unsigned long long hash = 1469598103934665603ULL);

// A build entry's lock (flock on its .lock file), held while one tree looks for, builds and
// publishes a source: another tree with the same source waits, then takes the binary.
class CacheLock {
public:
    explicit CacheLock(int fd) : fd_(fd) {}
    ~CacheLock();
    CacheLock(const CacheLock&) = delete;
    CacheLock& operator=(const CacheLock&) = delete;

private:
    int fd_;
};

class ClassCache {
public:
    // `folder` exists (build/grade made it); `lab` is the instructor's inputs as text (their
    // bytes, or names, sizes and times): it picks the subfolder this lab's entries live in.
    static constexpr size_t default_max_bytes = size_t(4) << 30;
    ClassCache(const std::string& folder, const std::string& lab,
               size_t max_bytes = default_max_bytes);

    // Waits until this step and source are no other tree's to build (null when `stop` became
    // nonzero first, or no lock file can be made: then nothing is waited for).
    std::unique_ptr<CacheLock> lock_build(const std::string& step, const std::string& source,
                                          const volatile std::sig_atomic_t* stop) const;
    // The build entry of this step and source: its key, and its binary copied to `binary`;
    // "" when there is none (or a folder of that hash holds another source).
    std::string take_build(const std::string& step, const std::string& source,
                           const std::string& binary) const;
    // Publishes `binary`, built from `source` alone, unless an entry is there already.
    void store_build(const std::string& step, const std::string& source,
                     const std::string& binary) const;

    // A stored run of build `key` with exactly these arguments: its outcome, and the files it
    // left copied into `folder`. False when there is none.
    bool take_run(const std::string& key, const std::vector<std::string>& arguments,
                  const std::string& folder, ProcessResult& outcome) const;
    // Stores a run that ended on its own (see above; others are left out): its outcome and the
    // files `names` it left, as copied into `folder`.
    void store_run(const std::string& key, const std::vector<std::string>& arguments,
                   const ProcessResult& outcome, const std::string& folder,
                   const std::vector<std::string>& names) const;

    // Whether a run that ended so may be stored.
    static bool reusable(const ProcessResult& outcome);

private:
    // Counts `bytes` against the size (FOLDER/<lab>/size.txt, under a lock), or false when they
    // would go past max_bytes_ or leave the file system too little.
    bool reserve(size_t bytes) const;

    std::string root_;  // FOLDER/<lab fingerprint>
    size_t max_bytes_;
};

}  // namespace ctlab
