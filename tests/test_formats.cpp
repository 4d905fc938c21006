// test_formats.cpp: every volume format, sample type and orientation against files written by
// independent writers (tests/formats/write_volumes.py: nibabel, pydicom, numpy), and bad files
// of each format refused with one line.
//
// The answer is a 5x4x3 head in the lab frame with value L(i, j, k) = 100k + 10j + i - 50 and
// spacing 0.5, 0.75, 2; each file holds a*L + b in its own units, in one of the 48 axis orders
// and flips, with the affine or directions that describe it.
#include <doctest/doctest.h>
#include <sys/wait.h>
#include <unistd.h>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <iterator>
#include <map>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include "common/args.h"
#include "common/error.h"
#include "common/formats.h"
#include "common/volume.h"
#include "harness.h"
#include "tools/process.h"

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
    // On a memory file system where there is one (harness.h): ~500 step runs write here.
    TempFolder folder{"formats", ctlab_test::scratch_parent()};
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
        REQUIRE(volume.voxel_count() == 60);
        REQUIRE(volume.data.size() == 60);  // dense: (k*ny + j)*nx + i
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
        // Dense (volume.h) like a raw file's volume, its range over the voxels.
        const std::vector<int16_t> values = dense_values(volume);
        CHECK(*std::min_element(values.begin(), values.end()) == volume.min_value);
        CHECK(*std::max_element(values.begin(), values.end()) == volume.max_value);
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

namespace {

std::vector<unsigned char> bytes_of(const std::string& path) { return read_file_bytes(path); }

void write_bytes(const std::string& path, const std::vector<unsigned char>& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

void write_text(const std::string& path, const std::string& text) {
    std::ofstream out(path, std::ios::binary);
    out << text;
}

}  // namespace

TEST_CASE("formats: a bad file of each format gets one line naming it, and exit status 2") {
    if (skip_note()) return;
    TempFolder bad("formats_bad");
    const std::string good = written().folder.path();
    std::vector<std::pair<std::string, std::string>> cases;  // path, a part of the message
    auto add = [&](const std::string& name, const std::vector<unsigned char>& bytes,
                   const std::string& says) {
        write_bytes(bad.path(name), bytes);
        cases.push_back({bad.path(name), says});
    };
    auto cut = [](std::vector<unsigned char> bytes, size_t size) {
        bytes.resize(std::min(size, bytes.size()));
        return bytes;
    };
    const auto nifti = bytes_of(good + "/nifti_ijk_sfs.nii");
    add("short.nii", cut(nifti, nifti.size() - 7), "bytes, its header needs");
    add("header_only.nii", cut(nifti, 200), "not a NIfTI-1 file");
    add("empty.nii", {}, "not a NIfTI-1 file");
    auto no_dims = nifti;
    no_dims[40] = 0;  // dim[0] = 0: no dimensions
    no_dims[41] = 0;
    add("dim0.nii", no_dims, "NIfTI");
    auto datatype = nifti;
    datatype[70] = 128;  // DT_RGB24
    datatype[71] = 0;
    add("rgb.nii", datatype, "data type");
    auto invalid = nifti;  // datatype 3 is no type at all: nifticlib says so on stderr itself
    invalid[70] = 3;
    invalid[71] = 0;
    add("datatype3.nii", invalid, "bad datatype");
    const auto gz = bytes_of(good + "/nifti_ijk_sss.nii.gz");
    add("cut.nii.gz", cut(gz, gz.size() / 2), "NIfTI");

    const auto nrrd = bytes_of(good + "/nrrd_ijk_sss_int16.nrrd");
    add("short.nrrd", cut(nrrd, nrrd.size() - 3), "(NRRD)");
    add("noheader.nrrd", {'N', 'R', 'R', 'D', '0', '0', '0', '4', '\n'}, "(NRRD)");
    add("garbage.nrrd", {'h', 'e', 'l', 'l', 'o'}, "(NRRD)");
    write_text(bad.path("four.nrrd"), "NRRD0004\ntype: short\ndimension: 4\nsizes: 2 2 2 2\n"
                                      "encoding: raw\nendian: little\n\n" + std::string(32, '\0'));
    cases.push_back({bad.path("four.nrrd"), "dimensions"});
    write_text(bad.path("missing.nhdr"), "NRRD0004\ntype: short\ndimension: 3\nsizes: 2 2 2\n"
                                         "encoding: raw\nendian: little\ndata file: nothing.raw\n");
    cases.push_back({bad.path("missing.nhdr"), "(NRRD)"});

    write_text(bad.path("short.mha"), "NDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\n"
                                      "ElementDataFile = LOCAL\n" + std::string(15, '\0'));
    cases.push_back({bad.path("short.mha"), "expected exactly 16"});
    write_text(bad.path("type.mha"), "NDims = 3\nDimSize = 2 2 2\nElementType = MET_RGB\n"
                                     "ElementDataFile = LOCAL\n");
    cases.push_back({bad.path("type.mha"), "ElementType"});
    write_text(bad.path("missing.mhd"), "NDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\n"
                                        "ElementDataFile = nothing.raw\n");
    cases.push_back({bad.path("missing.mhd"), "nothing.raw"});
    write_text(bad.path("huge.mhd"), "NDims = 3\nDimSize = 100000 100000 100000\n"
                                     "ElementType = MET_SHORT\nElementDataFile = LOCAL\n");
    cases.push_back({bad.path("huge.mhd"), "over the limit"});
    write_text(bad.path("zlib.mha"), "NDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\n"
                                     "CompressedData = True\nElementDataFile = LOCAL\nnot zlib");
    cases.push_back({bad.path("zlib.mha"), "compressed data"});
    write_text(bad.path("nodata.mhd"), "NDims = 3\nDimSize = 2 2 2\n");
    cases.push_back({bad.path("nodata.mhd"), "no ElementDataFile"});

    std::filesystem::create_directories(bad.path("dicom_mixed"));
    std::filesystem::create_directories(bad.path("dicom_notes"));
    std::filesystem::create_directories(bad.path("dicom_empty"));
    for (const auto& entry : std::filesystem::directory_iterator(good + "/dicom_ijk_sss")) {
        std::filesystem::copy(entry.path(), bad.path("dicom_mixed") + "/a_" + entry.path().filename().string());
        std::filesystem::copy(entry.path(), bad.path("dicom_notes") + "/" + entry.path().filename().string());
    }
    for (const auto& entry : std::filesystem::directory_iterator(good + "/dicom_jik_sff")) {
        std::filesystem::copy(entry.path(), bad.path("dicom_mixed") + "/b_" + entry.path().filename().string());
    }
    write_text(bad.path("dicom_notes") + "/notes.txt", "scanned on Tuesday\n");
    cases.push_back({bad.path("dicom_mixed"), "more than one series"});
    cases.push_back({bad.path("dicom_notes"), "is not a DICOM image"});
    cases.push_back({bad.path("dicom_empty"), "holds no DICOM slices"});

    add("head_4x4x4_uint8.raw", std::vector<unsigned char>(63), "expected exactly 64 for 4x4x4 uint8");
    std::vector<unsigned char> nan_file(32, 0);  // 2x2x2 float32, the first a quiet NaN
    nan_file[2] = 0xC0;                          // 0x7FC00000, little-endian
    nan_file[3] = 0x7F;
    add("head_2x2x2_float32.raw", nan_file, "NaN");

    const std::string step = build_folder() + "/02_threshold";
    const bool have_step = std::filesystem::exists(step);
    if (!have_step) MESSAGE("not built: " << step << " (only the loaders are checked)");
    for (const auto& [path, says] : cases) {
        CAPTURE(path);
        std::string message;
        try {
            load_any(path);
            FAIL_CHECK("no InputError");
        } catch (const InputError& error) {
            message = error.what();
        }
        CHECK_MESSAGE(message.find(says) != std::string::npos, message);
        CHECK_MESSAGE(message.find('\n') == std::string::npos, message);
        CHECK_MESSAGE(message.find(path) != std::string::npos, message);
        if (!have_step) continue;
        // The step: exit status 2, one line on stderr (no library's own messages), no PNG.
        const std::string out = bad.path("out");
        std::filesystem::remove_all(out);
        const std::string command = "'" + step + "' --volume '" + path +
                                    "' --no-window --view top --out '" + out + "' > '" +
                                    bad.path("stdout") + "' 2> '" + bad.path("stderr") + "'";
        const int status = std::system(command.c_str());
        CHECK(WIFEXITED(status));
        CHECK(WEXITSTATUS(status) == 2);
        std::ifstream err(bad.path("stderr"));
        const std::string text((std::istreambuf_iterator<char>(err)), std::istreambuf_iterator<char>());
        CHECK_MESSAGE(std::count(text.begin(), text.end(), '\n') == 1, text);
        CHECK(text.rfind("02_threshold: error: ", 0) == 0);
        CHECK(!std::filesystem::exists(out + "/02_threshold_top.png"));
    }
}

namespace {

std::string file_text(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The steps of the tree: steps/NN_name.cpp -> "NN_name", in order.
std::vector<std::string> step_names() {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator("steps")) {
        const std::string name = entry.path().stem().string();
        if (entry.path().extension() == ".cpp" && name.size() > 3 && std::isdigit(name[0]) &&
            std::isdigit(name[1]) && name[2] == '_') {
            names.push_back(name);
        }
    }
    std::sort(names.begin(), names.end());
    return names;
}

}  // namespace

TEST_CASE("formats: every format and raw type loads in every step; same head, same picture") {
    if (skip_note()) return;
    const TempFolder& files = written().folder;
    // One file of each kind. `same`: the values of the raw int16 head exactly (a = 1, b = 0),
    // so every picture must be the raw head's, byte for byte.
    struct Case {
        std::string name, format;
        bool same;
    };
    const std::vector<Case> cases = {
        {"head_5x4x3_int16.raw", "raw", true},  // the reference: first
        {"nifti_kji_fff.nii", "nifti", true},
        {"nifti_jik_sfs.nii.gz", "nifti", true},
        {"nifti_type_float64.nii", "nifti", false},
        {"nrrd_jik_fss_int16.nrrd", "nrrd", true},
        {"nrrd_ikj_fff_uint8.nhdr", "nrrd", false},
        {"meta_ijk_ssf_int16.mha", "metaimage", true},
        {"meta_jki_ssf_int16.mhd", "metaimage", true},
        {"meta_kij_fsf_float32.mha", "metaimage", false},
        {"dicom_jik_sff", "dicom", false},
        {"head_5x4x3_uint8.raw", "raw", false},
        {"head_5x4x3_int8.raw", "raw", false},
        {"head_5x4x3_uint16.raw", "raw", false},
        {"head_5x4x3_float32.raw", "raw", false},
    };
    const std::vector<std::string> steps = step_names();
    REQUIRE(steps.size() >= 11);  // 00 .. 25_free_leaping at least
    int runs = 0, compared = 0;
    for (const std::string& step : steps) {
        CAPTURE(step);
        const std::string binary = build_folder() + "/" + step;
        REQUIRE_MESSAGE(std::filesystem::exists(binary), "not built: " << binary);
        // A threshold inside the head's values (-50 .. 184), where the step has one.
        const std::string help = files.path(step + "_help.txt");
        REQUIRE(std::system(("'" + binary + "' --help > '" + help + "' 2>&1").c_str()) == 0);
        const std::string usage = file_text(help);
        const size_t own = usage.find("this step:");
        const bool has_threshold =
            own != std::string::npos && usage.find("  --threshold ", own) != std::string::npos;
        // A step whose jitter can be a blue-noise tile (step 17's default) runs with the hash's
        // offsets here: the tile is made at start-up (~0.2 s of CPU a run, a third of this
        // test's time with it) and has nothing to do with loading; test_jitter and
        // test_extremes run it.
        const size_t jitter = usage.find("  --jitter ");
        const bool blue_noise =
            jitter != std::string::npos &&
            usage.substr(jitter, usage.find('\n', jitter) - jitter).find("blue") !=
                std::string::npos;
        for (const Case& each : cases) {
            CAPTURE(each.name);
            const std::string out = files.path("every_step/" + step + "/" + each.name);
            std::filesystem::create_directories(out);
            std::vector<std::string> args = {"--volume", files.path(each.name), "--no-window",
                                             "--threads", "1", "--out", out};
            if (each.format == "raw") {  // as the files say
                args.insert(args.end(), {"--spacing", "0.5,0.75,2"});
            }
            if (has_threshold) args.insert(args.end(), {"--threshold", "100"});
            if (blue_noise) args.insert(args.end(), {"--jitter", "hash"});
            // Part 2 and 3 at the tests' small camera picture: the loading is what is tested
            // (a default 512x512 picture per file was most of this test's time).
            for (const std::string& flag : ctlab_test::size_flags(step)) args.push_back(flag);
            // Started directly (tools/process.h), not through a shell: ~500 runs.
            const ProcessResult run = run_process(binary, args);
            const std::string printed = run.out + run.err;
            ++runs;
            CHECK_MESSAGE(run.exit_status >= 0, run.command() << ": " << run.stop_reason()
                                                              << "\n" << printed);
            CHECK_MESSAGE(run.exit_status == 0, run.command() << "\n" << printed);
            // The volume line names the format (raw files: none, as CThead's).
            const bool named = printed.find(" format=") != std::string::npos;
            CHECK_MESSAGE(printed.rfind("volume=", 0) == 0, printed);
            CHECK_MESSAGE((each.format == "raw" ? !named
                                                : printed.find(" format=" + each.format) !=
                                                      std::string::npos),
                          printed);
            CHECK_MESSAGE(printed.find("\nstep=" + step + " ") != std::string::npos, printed);
            if (!each.same || each.name == cases[0].name) continue;
            // The same head: the same PNGs as the raw int16 file's.
            const std::string reference = files.path("every_step/" + step + "/" + cases[0].name);
            int pictures = 0;
            for (const auto& png : std::filesystem::directory_iterator(reference)) {
                const std::string name = png.path().filename().string();
                CAPTURE(name);
                CHECK(file_text(out + "/" + name) == file_text(png.path().string()));
                ++pictures;
                ++compared;
            }
            CHECK(pictures >= 1);
        }
    }
    MESSAGE(runs << " runs of " << steps.size() << " steps, " << compared
                 << " pictures compared with the raw int16 head's");
}

TEST_CASE("formats: each preset runs on a volume of its kind in a threshold, a table and a camera step") {
    if (skip_note()) return;
    const TempFolder& files = written().folder;
    // The volume each preset is for (cthead: the phantom stands in when data/CThead is absent;
    // the command line's --volume wins over the preset's).
    const std::map<std::string, std::string> volume_for = {
        {"ct", files.path("nrrd_jik_fss_int16.nrrd")},
        {"cthead", "phantom"},
        {"phantom", "phantom"},
        {"eight_bit", files.path("head_5x4x3_uint8.raw")},
        {"uint16_ct", files.path("head_5x4x3_uint16.raw")},
        {"float", files.path("head_5x4x3_float32.raw")},
    };
    const std::vector<std::string> presets = preset_names();
    REQUIRE(presets.size() >= volume_for.size());
    for (const std::string& preset : presets) {
        CAPTURE(preset);
        REQUIRE_MESSAGE(volume_for.count(preset), "a preset without a test volume: add one here");
        for (const std::string step : {"02_threshold", "07_back_to_front", "25_free_leaping"}) {
            CAPTURE(step);
            const std::string log = files.path("preset.log");
            std::string command = "'" + build_folder() + "/" + step + "' --preset " + preset +
                                  " --volume '" + volume_for.at(preset) +
                                  "' --no-window --threads 1 --out '" + files.path("preset_out") +
                                  "'";
            if (step == "25_free_leaping") command += " --size 64x64";
            const int status = std::system((command + " > '" + log + "' 2>&1").c_str());
            const std::string printed = file_text(log);
            CHECK_MESSAGE(WIFEXITED(status), printed);
            CHECK_MESSAGE(WEXITSTATUS(status) == 0, printed);
            CHECK_MESSAGE(printed.find("\nstep=" + step + " ") != std::string::npos, printed);
        }
    }
}

// `make fuzz` found an 860-byte DICOM slice whose damaged length field made GDCM allocate
// 900 MB (33 s on a loaded machine). The child read's memory limit refuses it at once. Not
// under the sanitizers, which cannot run with an address-space limit (the child has none).
#if !defined(__SANITIZE_ADDRESS__)
TEST_CASE("formats: a DICOM slice whose length field asks for 900 MB is refused in one line") {
    const TempFolder folder("dicom_length");
    std::filesystem::create_directories(folder.path("series"));
    std::filesystem::copy_file("tests/formats/bad/dicom_length_900mb.dcm",
                               folder.path("series/slice.dcm"));
    std::string message;
    try {
        load_dicom_series(folder.path("series"));
        FAIL_CHECK("no InputError");
    } catch (const InputError& error) {
        message = error.what();
    }
    CHECK_MESSAGE(message.find("is not a DICOM image GDCM can read") != std::string::npos,
                  message);
}
#endif
