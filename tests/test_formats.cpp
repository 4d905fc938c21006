// test_formats.cpp: every volume format, sample type and orientation against files written by
// independent writers (tests/formats/write_volumes.py: nibabel, pydicom, numpy), and bad files
// of each format refused with one line.
//
// The answer is a 5x4x3 head in the lab frame with value L(i, j, k) = 100k + 10j + i - 50 and
// spacing 0.5, 0.75, 2; each file holds a*L + b in its own units, in one of the 48 axis orders
// and flips, with the affine or directions that describe it.
#include <doctest/doctest.h>
#include <sys/wait.h>
#include <cmath>
#include <iterator>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include "common/args.h"
#include "common/error.h"
#include "common/formats.h"
#include "common/volume.h"
#include "harness.h"

using namespace ctlab;
using ctlab_test::TempFolder;
using ctlab_test::capture_stdout;

namespace {

struct Expected {
    std::string path;
    double a = 1, b = 0;
    bool exact = false, oriented = false;
};

// Runs the writer into `folder`. "" when it wrote the files; the note naming the package when
// a Python package is missing (the writer's exit status 3). Any other failure fails the test.
std::string write_volumes(const std::string& folder) {
    if (std::system("test -x /usr/bin/python3") != 0) return "missing python3";
    const std::string command = "/usr/bin/python3 tests/formats/write_volumes.py '" + folder +
                                "' > '" + folder + "/writer.log' 2>&1";
    const int status = std::system(command.c_str());
    std::ifstream log(folder + "/writer.log");
    std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    if (WIFEXITED(status) && WEXITSTATUS(status) == 3) return text.substr(0, text.find('\n'));
    if (status != 0) FAIL("tests/formats/write_volumes.py failed (status " << status << "): " << text);
    return "";
}

std::vector<Expected> read_manifest(const std::string& folder) {
    std::ifstream in(folder + "/manifest.txt");
    std::vector<Expected> all;
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream fields(line);
        Expected e;
        int exact = 0, oriented = 0;
        if (fields >> e.path >> e.a >> e.b >> exact >> oriented) {
            e.exact = exact;
            e.oriented = oriented;
            e.path = folder + "/" + e.path;
            all.push_back(e);
        }
    }
    return all;
}

// The lab value L of voxel (i, j, k), computed here, independent of any loader.
double lab_value(int i, int j, int k) { return 100.0 * k + 10.0 * j + i - 50.0; }

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

// Shared by the test cases: the volumes are written once.
struct Written {
    TempFolder folder{"formats"};
    std::string skipped;
    std::vector<Expected> volumes;
    Written() {
        skipped = write_volumes(folder.path());
        if (skipped.empty()) volumes = read_manifest(folder.path());
    }
};
Written& written() {
    static Written instance;
    return instance;
}

bool skip_note() {
    if (written().skipped.empty()) return false;
    MESSAGE("skipped: " << written().skipped << " (tools/install-deps.sh installs it)");
    return true;
}

}  // namespace

TEST_CASE("formats: every file of every format, type and orientation loads to the lab head") {
    if (skip_note()) return;
    const auto& volumes = written().volumes;
    REQUIRE(volumes.size() >= 48 + 8 + 10 + 8 + 4 + 5);
    int nifti_orientations = 0;
    for (const Expected& e : volumes) {
        CAPTURE(e.path);
        const Volume volume = load_any(e.path);
        REQUIRE(volume.nx == 5);
        REQUIRE(volume.ny == 4);
        REQUIRE(volume.nz == 3);
        REQUIRE(volume.data.size() == 60);
        if (e.oriented || volume_format_of(e.path) != "raw") {
            CHECK(volume.sx == doctest::Approx(0.5).epsilon(1e-5));
            CHECK(volume.sy == doctest::Approx(0.75).epsilon(1e-5));
            CHECK(volume.sz == doctest::Approx(2.0).epsilon(1e-5));
        }
        CHECK(volume.orientation.empty() == (volume_format_of(e.path) == "raw"));
        if (e.oriented) CHECK(volume.orientation.find("none") == std::string::npos);
        CHECK(volume.map.identity() == e.exact);
        // Half a step of the map: the most a rounded value can be off.
        const double tolerance = volume.map.scale / 2 * (1 + 1e-9) + 1e-9;
        int wrong = 0;
        for (int k = 0; k < 3; ++k) {
            for (int j = 0; j < 4; ++j) {
                for (int i = 0; i < 5; ++i) {
                    const double expected = e.a * lab_value(i, j, k) + e.b;
                    const double got = volume.map.to_file(volume.at(i, j, k));
                    const bool ok = e.exact ? got == expected
                                            : std::fabs(got - expected) <= tolerance;
                    if (!ok && wrong++ == 0) {
                        FAIL_CHECK("voxel " << i << "," << j << "," << k << ": expected "
                                            << expected << ", got " << got);
                    }
                }
            }
        }
        CHECK(wrong == 0);
        if (e.path.find("/nifti_") != std::string::npos && e.path.find("_type_") == std::string::npos &&
            e.oriented) {
            ++nifti_orientations;
        }
    }
    CHECK(nifti_orientations == 48);
}

TEST_CASE("formats: a map keeps the order of values and spans int16 for floats") {
    if (skip_note()) return;
    const Volume volume = load_any(written().folder.path("head_5x4x3_float32.raw"));
    CHECK(!volume.map.identity());
    CHECK(volume.min_value == -32768);
    CHECK(volume.max_value == 32767);
    CHECK(volume.map.to_file(volume.min_value) == doctest::Approx(0.01 * -50 + 0.5));
    CHECK(volume.map.to_file(volume.max_value) == doctest::Approx(0.01 * 184 + 0.5));
    // uint16 whole numbers over 32767: shifted, not scaled (nothing lost).
    const Volume shifted = load_any(written().folder.path("head_5x4x3_uint16.raw"));
    CHECK(shifted.map.scale == 1.0);
    CHECK(shifted.map.offset == 100 * -50 + 30000 + 32768);
}

TEST_CASE("formats: --threshold in file units becomes the volume value with the same hits") {
    if (skip_note()) return;
    const std::string path = written().folder.path("head_5x4x3_float32.raw");
    int threshold = 400;
    Args args("02_threshold", "test");
    args.add_int("--threshold", &threshold, -32768, 32767, "test");
    std::vector<std::string> words = {"step", "--volume", path, "--threshold", "1.005"};
    std::vector<char*> argv;
    for (std::string& word : words) argv.push_back(word.data());
    const Options options = args.parse(int(argv.size()), argv.data());
    Volume volume;
    const std::string printed = capture_stdout([&] { volume = load_volume(options); });
    CHECK(printed.find("map=") != std::string::npos);
    CHECK(printed.find("units: --threshold 1.005") != std::string::npos);
    // Every voxel: above the converted threshold exactly when its file value is above 1.005.
    int above = 0;
    for (int k = 0; k < 3; ++k) {
        for (int j = 0; j < 4; ++j) {
            for (int i = 0; i < 5; ++i) {
                const bool file_above = 0.01 * lab_value(i, j, k) + 0.5 > 1.005;
                CHECK((volume.at(i, j, k) > threshold) == file_above);
                above += file_above;
            }
        }
    }
    CHECK(above > 0);
    CHECK(above < 60);
}

TEST_CASE("formats: the volume line names the format, the map and the orientation") {
    if (skip_note()) return;
    const Volume volume = load_any(written().folder.path("nifti_type_uint16.nii"));
    const std::string line = volume_line(volume);
    CHECK(line.find("format=nifti") != std::string::npos);
    CHECK(line.find("map=file=1*v+") != std::string::npos);
    CHECK(line.find("orientation=flipped j,k from RAS") != std::string::npos);
}
