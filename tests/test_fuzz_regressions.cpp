// test_fuzz_regressions.cpp: every input `make fuzz` ever crashed on, kept in
// tests/fuzz/regressions/NAME/, and every seed in tests/fuzz/seeds/NAME/, fed again to the
// same fuzz target (tests/fuzz/targets.cpp). Under `make test SAN=1` the sanitizers watch too.
#include <doctest/doctest.h>
#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>
#include "fuzz/targets.h"
#include "harness.h"
#include "volume.h"

namespace fs = std::filesystem;

namespace {

// The files directly in `folder` (none when it does not exist), sorted.
std::vector<fs::path> files_in(const fs::path& folder) {
    std::vector<fs::path> files;
    std::error_code error;
    for (const fs::directory_entry& entry : fs::directory_iterator(folder, error)) {
        if (entry.is_regular_file()) files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    return files;
}

// Runs the target on each file; returns how many ran. A broken promise fails the test.
int replay(const ctlab_fuzz::Target& target, const fs::path& folder) {
    int count = 0;
    for (const fs::path& file : files_in(folder)) {
        CAPTURE(file.string());
        const std::vector<unsigned char> bytes = ctlab::read_file_bytes(file.string());
        std::string failure;
        // The CThead target prints load_volume's line: keep it out of the test's output.
        ctlab_test::capture_stdout([&] {
            try {
                target.run(bytes.data(), bytes.size());
            } catch (const ctlab_fuzz::Broken& broken) {
                failure = broken.what();
            }
        });
        CHECK_MESSAGE(failure.empty(), target.name << ": " << failure);
        ++count;
    }
    return count;
}

}  // namespace

TEST_CASE("fuzz: every kept crash input and every seed passes its target again") {
    REQUIRE_MESSAGE(fs::is_directory("tests/fuzz/seeds"), "run from the repository root");
    for (const ctlab_fuzz::Target& target : ctlab_fuzz::targets()) {
        CAPTURE(target.name);
        const int seeds = replay(target, fs::path("tests/fuzz/seeds") / target.name);
        CHECK_MESSAGE(seeds > 0, "no seeds in tests/fuzz/seeds/" << target.name);
        replay(target, fs::path("tests/fuzz/regressions") / target.name);
    }
}
