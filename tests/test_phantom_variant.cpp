// test_phantom_variant.cpp: --volume phantom:SEED, the volume a class is graded on
// (common/phantom.h): the same grid as the kit's phantom, determined by the seed alone (not by
// the thread count), other voxels than the kit's, and the anatomy mirrored for some seeds and
// resized within the stated 88% to 104%.
#include <doctest/doctest.h>
#include <cstdint>
#include <vector>
#include "phantom.h"
#include "volume.h"

using namespace ctlab;

namespace {

constexpr int bone_value = 300;    // CT value: the classic transfer function's bone
constexpr int filling_value = 2248;  // the amalgam filling, the phantom's maximum

struct Census {
    long long bone = 0;        // voxels at or above bone_value
    double filling_i = 0;      // mean i of the filling's voxels
    long long filling = 0;
};

Census census(const Volume& volume) {
    Census c;
    for (int k = 0; k < volume.nz; ++k)
        for (int j = 0; j < volume.ny; ++j)
            for (int i = 0; i < volume.nx; ++i) {
                const int value = volume.at(i, j, k);
                c.bone += value >= bone_value;
                if (value == filling_value) {
                    c.filling_i += i;
                    ++c.filling;
                }
            }
    if (c.filling) c.filling_i /= double(c.filling);
    return c;
}

}  // namespace

TEST_CASE("phantom:SEED: the kit's grid, the seed's voxels, mirrored and resized") {
    const Volume kit = make_phantom(2);
    const Census kit_census = census(kit);
    REQUIRE(kit_census.filling > 0);
    CHECK(kit_census.filling_i < kit.nx / 2.0);  // the filling sits at x < 128 mm

    int mirrored = 0, kept = 0;
    for (uint64_t seed = 1; seed <= 6; ++seed) {
        CAPTURE(seed);
        const Volume variant = make_phantom_variant(seed, 2);
        CHECK(variant.nx == kit.nx);
        CHECK(variant.ny == kit.ny);
        CHECK(variant.nz == kit.nz);
        CHECK(variant.sx == kit.sx);
        CHECK(variant.sz == kit.sz);
        CHECK(variant.name == "phantom:" + std::to_string(seed));
        const std::vector<int16_t> values = dense_values(variant);
        CHECK(values != dense_values(kit));
        if (seed <= 2) {  // the seed alone decides: one thread or three, twice
            CHECK(values == dense_values(make_phantom_variant(seed, 1)));
            CHECK(values == dense_values(make_phantom_variant(seed, 3)));
        }
        const Census c = census(variant);
        REQUIRE(c.filling > 0);
        (c.filling_i > variant.nx / 2.0 ? mirrored : kept) += 1;
        // Bone scales with the volume, size^3, for sizes 0.88 to 1.04 (a little slack for
        // the blurred edges and the voxels moved past the box's faces).
        const double ratio = double(c.bone) / double(kit_census.bone);
        CHECK(ratio > 0.88 * 0.88 * 0.88 * 0.95);
        CHECK(ratio < 1.04 * 1.04 * 1.04 * 1.05);
    }
    CHECK(mirrored > 0);
    CHECK(kept > 0);
    CHECK(dense_values(make_phantom_variant(1, 2)) != dense_values(make_phantom_variant(2, 2)));
}
