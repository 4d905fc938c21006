// test_phantom.cpp: the built-in head. Size, spacing, range and determinism, then spot checks
// at places handouts/phantom.md names (voxel i, j, k = mm x - 0.5, y - 0.5, (z - 1) / 2).
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>
#include "error.h"
#include "phantom.h"

using namespace ctlab;

namespace {

// The full phantom, made once for all tests (about 50 ms).
const Volume& phantom() {
    static const Volume volume = make_phantom();
    return volume;
}

// Classic transfer-function classes (numerics.md): the phantom must be unambiguous about them.
bool is_air(int value) { return value < -300; }
bool is_skin(int value) { return value >= -300 && value < 50; }
bool is_bone(int value) { return value >= 400; }

}  // namespace

TEST_CASE("phantom: CThead's dims and spacing, named phantom") {
    const Volume& volume = phantom();
    CHECK(volume.nx == cthead_nx);
    CHECK(volume.ny == cthead_ny);
    CHECK(volume.nz == cthead_nz);
    CHECK(volume.sx == 1.0);
    CHECK(volume.sy == 1.0);
    CHECK(volume.sz == 2.0);
    CHECK(volume.name == "phantom");
    CHECK(volume.data.size() == volume.voxel_count());  // dense
}

TEST_CASE("phantom: deterministic, and make_phantom is make_phantom_sized(256, 256, 113)") {
    const Volume again = make_phantom();
    CHECK(again.data == phantom().data);
    const Volume sized = make_phantom_sized(256, 256, 113);
    CHECK(sized.data == phantom().data);
    CHECK(sized.sz == 2.0);
}

TEST_CASE("phantom: the same voxels on any number of threads") {
    // Slices are painted in parallel (the render threads' pool); each must be its own work.
    CHECK(make_phantom(2).data == phantom().data);
    const Volume one = make_phantom_sized(37, 41, 23, 1);
    for (int threads : {2, 3, 8, 64}) {  // 64: more threads than slices
        CAPTURE(threads);
        const Volume many = make_phantom_sized(37, 41, 23, threads);
        CHECK(many.data == one.data);
        CHECK(many.min_value == one.min_value);
        CHECK(many.max_value == one.max_value);
    }
}

TEST_CASE("phantom: value range like CThead, the maximum is the filling") {
    const Volume& volume = phantom();
    CHECK(volume.min_value >= -1117);
    CHECK(volume.min_value <= -900);
    CHECK(volume.max_value == 2248);
    const std::vector<int16_t> values = dense_values(volume);  // the voxels, no padding
    int16_t low = values[0], high = values[0];
    int filling_voxels = 0;
    for (int16_t value : values) {
        low = std::min(low, value);
        high = std::max(high, value);
        if (value == 2248) ++filling_voxels;
    }
    CHECK(low == volume.min_value);
    CHECK(high == volume.max_value);
    CHECK(filling_voxels > 0);
    CHECK(filling_voxels < 50);  // a small filling, not a slab
    CHECK(volume.at(106, 60, 80) == 2248);  // on an upper molar, where the handout says
}

TEST_CASE("phantom: partial-volume edges, every value between two tissues occurs") {
    // Edges are blurred, so every value from air to cortical bone occurs somewhere, and plenty
    // of voxels sit at each value near the bone threshold 400: a threshold off by one (399,
    // 401, or >= for >) moves the first hit of many rays (handouts/phantom.md).
    std::vector<int> count(65536, 0);
    for (int16_t value : phantom().data) ++count[value + 32768];
    auto occurrences = [&](int value) { return count[value + 32768]; };
    int missing = 0;
    for (int value = -1000; value <= 1700; ++value) missing += occurrences(value) == 0;
    CHECK(missing == 0);
    int fewest = 1 << 30;
    for (int value = 200; value <= 600; ++value) fewest = std::min(fewest, occurrences(value));
    CHECK(fewest >= 50);
    // Nothing outside the tissues' own range: air -1000 - 20 .. the filling 2248.
    for (int value = -32768; value < -1020; ++value) CHECK(occurrences(value) == 0);
    for (int value = 2249; value <= 32767; ++value) CHECK(occurrences(value) == 0);
}

TEST_CASE("phantom: anatomy where the handout says it is") {
    const Volume& v = phantom();
    SUBCASE("corners are air") {
        CHECK(is_air(v.at(0, 0, 0)));
        CHECK(is_air(v.at(255, 0, 0)));
        CHECK(is_air(v.at(0, 255, 112)));
        CHECK(is_air(v.at(255, 255, 112)));
    }
    SUBCASE("the slice at the crown, k = 0, is almost all air") {
        int air_voxels = 0;
        for (int j = 0; j < v.ny; ++j)
            for (int i = 0; i < v.nx; ++i) air_voxels += is_air(v.at(i, j, 0));
        CHECK(air_voxels > 0.98 * v.nx * v.ny);
    }
    SUBCASE("brain in the middle, ventricles beside it") {
        CHECK(v.at(128, 128, 50) >= 0);
        CHECK(v.at(128, 128, 50) < 50);
        CHECK(v.at(118, 122, 40) >= 5);   // left lateral ventricle: CSF about 10
        CHECK(v.at(118, 122, 40) <= 15);
    }
    SUBCASE("skull: bone at the crown, outer and inner tables denser than the diploe") {
        for (int k = 7; k <= 11; ++k) CHECK(is_bone(v.at(128, 128, k)));
        CHECK(is_skin(v.at(128, 128, 5)));  // scalp above the skull
        CHECK(v.at(128, 128, 12) < 400);     // the inner table's blurred lower edge
        CHECK(is_skin(v.at(128, 128, 13)));  // fluid and brain below it
        // Across the side of the skull at mid height (1 mm voxels): the tables' middles.
        const int outer = v.at(58, 128, 50), diploe = v.at(61, 128, 50);
        const int inner = v.at(64, 128, 50);
        CHECK(outer >= 1600);
        CHECK(diploe >= 800);
        CHECK(diploe <= 1000);
        CHECK(inner >= 1600);
    }
    SUBCASE("eye balls near the face (small j), about 15") {
        for (int i : {95, 160}) {
            CHECK(v.at(i, 51, 51) >= 10);
            CHECK(v.at(i, 51, 51) <= 20);
        }
    }
    SUBCASE("a ray into the face meets skin before anything dense") {
        int first = 0;
        while (first < v.ny && is_air(v.at(128, first, 52))) ++first;
        REQUIRE(first < 60);
        CHECK(is_skin(v.at(128, first, 52)));
        CHECK(is_skin(v.at(128, first + 1, 52)));
    }
    SUBCASE("maxillary sinus: air inside the face bones") {
        CHECK(v.at(107, 67, 66) <= -880);
        CHECK(v.at(107, 67, 66) >= -920);
    }
    SUBCASE("spine: a vertebral body in the neck at large k") {
        CHECK(is_bone(v.at(128, 139, 105)));
        CHECK(is_bone(v.at(128, 139, 112)));
    }
    SUBCASE("head rest behind the head at large j, transparent to the classic TF") {
        CHECK(v.at(128, 227, 50) >= 100);
        CHECK(v.at(128, 227, 50) < 300);
        CHECK(is_air(v.at(128, 232, 50)));
    }
}

TEST_CASE("phantom: the bone surface found by interpolation is smooth, no voxel terraces") {
    // Rays down from the crown at j = 128: where linear interpolation between samples crosses
    // 400 against where the outer table's ellipsoid (centre 128, 128, 100 mm; semi-axes 72,
    // 89, 86 mm) really is. The blurred edge puts the 400 level about half a slice outside
    // the geometric surface (cortical bone 1700 over soft tissue 25: 400 is 22% of the way
    // up the edge); what matters is that the offset is the same everywhere. Sharp voxel edges
    // would make it jump by up to a whole slice between neighbouring rays (terraces).
    const Volume& v = phantom();
    const double y = 128.5;  // mm, the centre of row j = 128
    std::vector<double> offsets;
    for (int i = 70; i <= 186; ++i) {
        int k = 0;
        while (v.at(i, 128, k) <= 400) ++k;
        const double before = v.at(i, 128, k - 1), after = v.at(i, 128, k);
        const double t = k - 1 + (400 - before) / (after - before);
        const double x = i + 0.5;  // mm
        const double z = 100 - 86 * std::sqrt(1 - std::pow((x - 128) / 72, 2) -
                                               std::pow((y - 128) / 89, 2));
        offsets.push_back(t - (z - 1) / 2);  // slices: voxel k is at z = 2k + 1 mm
    }
    double mean = 0;
    for (double offset : offsets) mean += offset / double(offsets.size());
    CHECK(mean < -0.3);  // outside the surface: towards k = 0
    CHECK(mean > -0.8);
    double largest = 0;
    for (double offset : offsets) largest = std::max(largest, std::fabs(offset - mean));
    CHECK(largest < 0.2);  // slices: measured 0.12
}

TEST_CASE("phantom: other sizes keep the head's physical size and never crash") {
    const int sizes[][3] = {{1, 1, 1}, {2, 3, 4}, {1, 256, 113}, {32, 32, 16}};
    for (const auto& size : sizes) {
        const Volume v = make_phantom_sized(size[0], size[1], size[2]);
        CAPTURE(size[0]);
        CAPTURE(size[1]);
        CAPTURE(size[2]);
        CHECK(v.nx == size[0]);
        CHECK(v.ny == size[1]);
        CHECK(v.nz == size[2]);
        CHECK(v.data.size() == v.voxel_count());
        CHECK(v.nx * v.sx == doctest::Approx(256));
        CHECK(v.ny * v.sy == doctest::Approx(256));
        CHECK(v.nz * v.sz == doctest::Approx(226));
        CHECK(v.min_value <= v.max_value);
    }
    // One voxel: the centre of the head, which is brain.
    const Volume one = make_phantom_sized(1, 1, 1);
    CHECK(is_skin(one.at(0, 0, 0)));
    // One column on the mid-sagittal plane x = 128 mm: the spine is still there.
    const Volume column = make_phantom_sized(1, 256, 113);
    CHECK(is_bone(column.at(0, 139, 105)));
    CHECK_THROWS_AS(make_phantom_sized(0, 1, 1), InputError);
    CHECK_THROWS_AS(make_phantom_sized(1, -5, 1), InputError);
}
