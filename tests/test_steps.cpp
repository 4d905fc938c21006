// test_steps.cpp: steps 00-05 against closed-form answers (a linear ramp, a sphere, constant,
// one-voxel-thick and int16-extreme volumes); every step, later ones too, for NaN on those
// volumes, for thread-count independence, and for the debug trace against the image.
//
// Each step is compiled here inside a namespace of its own (tools/all_steps.h), so its lesson
// functions (step04::gradient_at, step05::first_hit, ...) can be called directly; its main()
// becomes an ordinary function. The namespaces sit in an unnamed one, so other test files may
// include the same steps without a clash at link time.
#include <doctest/doctest.h>
#include "common/ctlab.h"
#include <cmath>
#include <cstring>
#include <functional>
#include <string>
#include <vector>
#include "harness.h"

namespace {

// What run_step() gives a step's main() in place of load_volume() and run_views().
const ctlab::Volume* harness_volume = nullptr;
const ctlab_test::RendererUse* harness_use = nullptr;
bool harness_reached_run_views = false;

ctlab::Volume harness_load_volume(const ctlab::Options&) { return *harness_volume; }

int harness_run_views(const ctlab::Options& options, const ctlab::Volume& volume,
                      const ctlab::Renderer& renderer) {
    harness_reached_run_views = true;
    (*harness_use)(options, volume, renderer);
    return 0;
}

}  // namespace

// While the steps are included, load_volume and run_views name the two functions above: a
// step's main() then takes its volume from run_step() and hands its renderer to the test
// instead of writing PNGs. Only the steps' text sees the macros; they end after it.
#define load_volume harness_load_volume
#define run_views harness_run_views
namespace {
#include "tools/all_steps.h"
}  // namespace
#undef load_volume
#undef run_views

namespace ctlab_test {

const std::vector<StepEntry>& included_steps() {
    // A new step: add it to tools/all_steps.h.
    static const std::vector<StepEntry> steps = [] {
        std::vector<StepEntry> entries;
        for (const IncludedStep& step : all_steps) entries.push_back({step.name, step.main});
        return entries;
    }();
    return steps;
}

int run_step(const std::string& name, const std::vector<std::string>& flags,
             const ctlab::Volume& volume, const RendererUse& use) {
    StepMain step_main = nullptr;
    for (const StepEntry& step : included_steps()) {
        if (step.name == name) step_main = step.main;
    }
    const bool known = step_main != nullptr;
    REQUIRE_MESSAGE(known, "no step named " << name << " in the tests");
    harness_volume = &volume;
    harness_use = &use;
    harness_reached_run_views = false;
    FakeArgv argv(flags);
    const int status = step_main(argv.argc(), argv.argv());
    harness_volume = nullptr;
    harness_use = nullptr;
    return status;
}

std::vector<ctlab::Image> render_step(const std::string& name,
                                      const std::vector<std::string>& flags,
                                      const ctlab::Volume& volume) {
    std::vector<ctlab::Image> images;
    const int status =
        run_step(name, flags, volume,
                 [&](const ctlab::Options& options, const ctlab::Volume& loaded,
                     const ctlab::Renderer& renderer) {
                     for (const ctlab::View& view : ctlab::views_named(loaded, options.view)) {
                         ctlab::Work work;
                         images.push_back(ctlab::render_view(options, view, renderer, work));
                     }
                 });
    CHECK_MESSAGE(status == 0, name << " exited with status " << status);
    CHECK_MESSAGE(harness_reached_run_views, name << " did not reach run_views");
    return images;
}

}  // namespace ctlab_test

using namespace ctlab;
using ctlab_test::included_steps;
using ctlab_test::render_step;
using ctlab_test::run_step;

namespace {

constexpr ViewAxis all_axes[] = {ViewAxis::top, ViewAxis::front, ViewAxis::side};

// Where step 05's hit lies along the ray, in samples: its sample index plus the fraction.
double along(const step05::Hit& hit) { return hit.n + double(hit.fraction); }

// A volume whose value at voxel (i, j, k) is value(i, j, k), clamped to int16.
Volume make_volume(int nx, int ny, int nz, const std::function<double(int, int, int)>& value,
                   double sx = 1, double sy = 1, double sz = 1) {
    Volume volume;
    volume.nx = nx;
    volume.ny = ny;
    volume.nz = nz;
    volume.sx = sx;
    volume.sy = sy;
    volume.sz = sz;
    volume.name = "test";
    volume.data.resize(volume.voxel_count());
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                const double v = std::clamp(std::round(value(i, j, k)), -32768.0, 32767.0);
                volume.data[(size_t(k) * ny + j) * nx + i] = int16_t(v);
            }
    update_range(volume);
    return volume;
}

// The linear ramp of numerics.md: f = 3i + 5j + 7k (+ offset).
Volume ramp_volume(int nx, int ny, int nz, double sx = 1, double sy = 1, double sz = 1,
                   int offset = 0) {
    return make_volume(
        nx, ny, nz, [&](int i, int j, int k) { return 3 * i + 5 * j + 7 * k + offset; }, sx, sy,
        sz);
}

bool finite(const Rgb& pixel) {
    return std::isfinite(pixel.r) && std::isfinite(pixel.g) && std::isfinite(pixel.b);
}
bool finite(const Vec3& v) {
    return std::isfinite(v.i) && std::isfinite(v.j) && std::isfinite(v.k);
}

// Steps 00-05 show a grey in 0..1; later ones may leave values above 1 to the PNG's clamp.
bool shows_unit_grey(const std::string& step) { return step < "06"; }

// Counts pixels that are not finite, or outside 0..1 when must_be_unit.
int bad_pixels(const Image& image, bool must_be_unit) {
    int bad = 0;
    for (const Rgb& p : image.pixels) {
        const bool in_unit = p.r >= 0 && p.r <= 1 && p.g >= 0 && p.g <= 1 && p.b >= 0 && p.b <= 1;
        if (!finite(p) || (must_be_unit && !in_unit)) ++bad;
    }
    return bad;
}

// Physical position of a voxel centre: index times spacing (voxel centres at whole indices).
struct Point {
    double x, y, z;
};
Point position(const Volume& volume, const Voxel& voxel) {
    return {voxel.i * volume.sx, voxel.j * volume.sy, voxel.k * volume.sz};
}

// The sphere f = 400 + 100 (R - |p - c|), rounded to int16, p in physical units.
struct Sphere {
    Point centre;
    double radius;
    double distance(const Point& p) const {
        return std::sqrt((p.x - centre.x) * (p.x - centre.x) + (p.y - centre.y) * (p.y - centre.y) +
                         (p.z - centre.z) * (p.z - centre.z));
    }
    double value(const Point& p) const { return 400 + 100 * (radius - distance(p)); }
};

// The unit outward normal the surface would have at p, as (p - c)/|p - c|, per volume axis.
Vec3 analytic_normal(const Sphere& sphere, const Point& p) {
    const double d = sphere.distance(p);
    return {float((p.x - sphere.centre.x) / d), float((p.y - sphere.centre.y) / d),
            float((p.z - sphere.centre.z) / d)};
}

Vec3 outward_normal(const Vec3& gradient) { return (-1.0f / length(gradient)) * gradient; }

double angle_degrees(const Vec3& a, const Vec3& b) {
    const double cosine = std::clamp(double(dot(a, b)) / (length(a) * length(b)), -1.0, 1.0);
    return std::acos(cosine) * 180 / 3.14159265358979323846;
}

// Where the ray through pixel (x, y) meets the sphere, in samples along the ray:
// t* = (along - sqrt(R^2 - rho^2)) / ray_spacing, rho = the ray's distance from the centre.
struct RayMeeting {
    double rho;        // distance between the ray and the centre, physical units
    double t_surface;  // t*, valid when rho <= R
};
RayMeeting meet_sphere(const Volume& volume, const View& view, const Sphere& sphere, int x, int y) {
    const Point p0 = position(volume, view.voxel(x, y, 0));
    const Point p1 = position(volume, view.voxel(x, y, 1 < view.ray_length ? 1 : 0));
    const double step = view.ray_spacing;
    const Point direction = {(p1.x - p0.x) / step, (p1.y - p0.y) / step, (p1.z - p0.z) / step};
    const Point to_centre = {sphere.centre.x - p0.x, sphere.centre.y - p0.y,
                             sphere.centre.z - p0.z};
    const double along =
        to_centre.x * direction.x + to_centre.y * direction.y + to_centre.z * direction.z;
    const double rho2 = to_centre.x * to_centre.x + to_centre.y * to_centre.y +
                        to_centre.z * to_centre.z - along * along;
    const double r2 = sphere.radius * sphere.radius;
    RayMeeting meeting;
    meeting.rho = std::sqrt(std::max(0.0, rho2));
    meeting.t_surface = rho2 <= r2 ? (along - std::sqrt(r2 - rho2)) / step : 0;
    return meeting;
}

}  // namespace

// --- The linear ramp -----------------------------------------------------------------------

TEST_CASE("ramp: step 04/05 gradient is exactly (3, 5, 7)/spacing everywhere, borders too") {
    struct Spacing {
        double sx, sy, sz;
    };
    for (Spacing s : {Spacing{1, 1, 1}, Spacing{1, 1, 2}, Spacing{0.5, 2, 4}}) {
        CAPTURE(s.sx);
        CAPTURE(s.sy);
        CAPTURE(s.sz);
        const Volume volume = ramp_volume(9, 7, 5, s.sx, s.sy, s.sz, -60);
        const Vec3 expected = {float(3 / s.sx), float(5 / s.sy), float(7 / s.sz)};
        Work work;
        int checked = 0;
        for (int k = 0; k < volume.nz; ++k)
            for (int j = 0; j < volume.ny; ++j)
                for (int i = 0; i < volume.nx; ++i) {
                    const Vec3 g4 = step04::gradient_at(volume, {i, j, k}, work);
                    const Vec3 g5 = step05::gradient_at(volume, {i, j, k}, work);
                    // Exact: small whole differences divided by powers of two.
                    CHECK(g4.i == expected.i);
                    CHECK(g4.j == expected.j);
                    CHECK(g4.k == expected.k);
                    CHECK(g5.i == expected.i);
                    CHECK(g5.j == expected.j);
                    CHECK(g5.k == expected.k);
                    ++checked;
                }
        CHECK(checked == 9 * 7 * 5);
        CHECK(work.gradients == uint64_t(2 * checked));
        // Interpolated between two voxels, as step 05 does at a sub-voxel hit.
        for (ViewAxis axis : all_axes) {
            const View view = make_view(volume, axis);
            for (float t : {0.0f, 0.25f, 1.5f, float(view.ray_length - 1) - 0.125f}) {
                const Vec3 g = step05::gradient_along_ray(volume, view, 1, 2, int(t),
                                                          t - float(int(t)), work);
                CHECK(g.i == doctest::Approx(expected.i).epsilon(1e-6));
                CHECK(g.j == doctest::Approx(expected.j).epsilon(1e-6));
                CHECK(g.k == doctest::Approx(expected.k).epsilon(1e-6));
            }
        }
    }
}

TEST_CASE("ramp: step 05's crossing is the analytic one; steps 02/03 stop at the next sample") {
    // Along any ray the ramp is f0 + slope * t, so the surface f = tau is at
    // t* = (tau - f0) / slope; step 03 hits the first whole t above it.
    const Volume volume = ramp_volume(10, 12, 14);
    const int coefficient[3] = {7, 5, 3};  // the slope along the ray: top k, front j, side i
    for (int threshold : {100, 101, 97, 0, -5, 172, 173}) {
        CAPTURE(threshold);
        int crossings = 0, misses = 0, at_edge = 0;
        for (ViewAxis axis : all_axes) {
            const View view = make_view(volume, axis);
            CAPTURE(view.name);
            const int slope = coefficient[int(axis)];
            for (int y = 0; y < view.height; ++y) {
                for (int x = 0; x < view.width; ++x) {
                    const Voxel first = view.voxel(x, y, 0);
                    const int f0 = 3 * first.i + 5 * first.j + 7 * first.k;
                    const int f_last = f0 + slope * (view.ray_length - 1);
                    Work work3, work5;
                    const auto hit2 =
                        step02::first_hit(volume, view, x, y, threshold, work3, nullptr);
                    const auto hit3 =
                        step03::first_hit(volume, view, x, y, threshold, work3, nullptr);
                    const auto hit5 =
                        step05::first_hit(volume, view, x, y, threshold, work5, nullptr);
                    if (f_last <= threshold) {  // never above: no hit, every sample read
                        CHECK_FALSE(hit2.found);
                        CHECK_FALSE(hit3.found);
                        CHECK_FALSE(hit5.found);
                        CHECK(work5.samples == uint64_t(view.ray_length));
                        CHECK(step03::shade(hit3, view.ray_length) == 0.0f);
                        ++misses;
                        continue;
                    }
                    REQUIRE(hit3.found);
                    REQUIRE(hit5.found);
                    CHECK(hit2.found);
                    if (f0 > threshold) {  // already above at the volume's edge
                        CHECK(hit3.n == 0);
                        CHECK(along(hit5) == 0.0);
                        CHECK(step03::shade(hit3, view.ray_length) == 1.0f);
                        ++at_edge;
                        continue;
                    }
                    const double t_surface = double(threshold - f0) / slope;
                    const int t_first_above = (threshold - f0) / slope + 1;  // whole division
                    CHECK(hit2.n == t_first_above);
                    CHECK(hit3.n == t_first_above);
                    CHECK(along(hit5) == doctest::Approx(t_surface).epsilon(1e-6));
                    CHECK(std::abs(along(hit5) - t_surface) < 1e-5);
                    CHECK(step03::shade(hit3, view.ray_length) ==
                          doctest::Approx(1.0 - double(t_first_above) / view.ray_length));
                    // Both stop at the first sample above: t + 1 samples read, one hit.
                    CHECK(work5.samples == uint64_t(t_first_above + 1));
                    CHECK(work5.hits == 1);
                    CHECK(work5.terminated == (t_first_above + 1 < view.ray_length ? 1u : 0u));
                    ++crossings;
                }
            }
        }
        // Every threshold above crosses some rays, except the ones past the ramp's range.
        CHECK(crossings + misses + at_edge == 10 * 12 + 10 * 14 + 12 * 14);
        if (threshold >= 0 && threshold < 170) CHECK(crossings > 0);
    }
}

// --- The sphere ----------------------------------------------------------------------------

TEST_CASE("sphere: hits, depth and normals of steps 03/04/05 against the closed form") {
    // Spacing 1:1:2 like CThead, a centre off the voxel grid. Positions are index * spacing.
    const Sphere sphere{{31.3, 29.6, 31.7}, 20.0};
    const Volume volume = make_volume(
        64, 64, 32,
        [&](int i, int j, int k) {
            return sphere.value({i * 1.0, j * 1.0, k * 2.0});
        },
        1, 1, 2);
    const int threshold = 400;  // the steps' default, so their pictures can be checked too
    const std::vector<Image> lit4 = render_step("04_gradient_lighting", {}, volume);
    const std::vector<Image> lit5 = render_step("05_interpolated_hits", {}, volume);
    REQUIRE(lit4.size() == 3);
    REQUIRE(lit5.size() == 3);
    for (ViewAxis axis : all_axes) {
        const View view = make_view(volume, axis);
        CAPTURE(view.name);
        // Diffuse + ambient with the analytic normal: what the pictures should show.
        const Vec3 light = step05::light_direction(view, step05::default_light_angle);
        auto expected_shade = [&](const Vec3& normal) {
            return step05::ambient + (1 - step05::ambient) * std::max(0.0f, dot(normal, light));
        };
        double error3_sum = 0, error5_sum = 0, normal4_sum = 0, normal5_sum = 0;
        double error5_max = 0, normal5_max = 0;
        int measured = 0, hits = 0, misses = 0, unsure = 0;
        for (int y = 0; y < view.height; ++y) {
            for (int x = 0; x < view.width; ++x) {
                const RayMeeting meeting = meet_sphere(volume, view, sphere, x, y);
                // Expected: a hit iff some sample lies inside the sphere. A sample within
                // 0.01 of the surface may round either way (int16 values): not counted.
                bool inside = false, near_surface = false;
                for (int t = 0; t < view.ray_length; ++t) {
                    const double d = sphere.distance(position(volume, view.voxel(x, y, t)));
                    inside = inside || d < sphere.radius - 0.01;
                    near_surface = near_surface || std::abs(d - sphere.radius) <= 0.01;
                }
                Work work;
                const auto hit3 = step03::first_hit(volume, view, x, y, threshold, work, nullptr);
                const auto hit4 = step04::first_hit(volume, view, x, y, threshold, work, nullptr);
                const auto hit5 = step05::first_hit(volume, view, x, y, threshold, work, nullptr);
                if (meeting.rho > sphere.radius) {  // rays that pass the sphere never hit
                    CHECK_FALSE(hit3.found);
                    CHECK_FALSE(hit5.found);
                }
                if (near_surface && !inside) {
                    ++unsure;
                    continue;
                }
                CHECK(hit3.found == inside);
                CHECK(hit4.found == inside);
                CHECK(hit5.found == inside);
                if (!inside) {
                    ++misses;
                    continue;
                }
                ++hits;
                CHECK(meeting.rho <= sphere.radius);
                // Depth: step 03 is up to one sample late, plus what rounding to int16 moves
                // the surface (0.005 in distance, about 0.005 R / h along a ray of half-chord h).
                const double error3 = hit3.n - meeting.t_surface;
                const double error5 = along(hit5) - meeting.t_surface;
                const double half_chord = std::sqrt(std::max(0.0, sphere.radius * sphere.radius -
                                                                      meeting.rho * meeting.rho)) /
                                          view.ray_spacing;
                CHECK(error3 > -0.01);
                CHECK(error3 < 1 + 0.01 * sphere.radius / std::max(half_chord, 0.01));
                if (meeting.rho > 0.8 * sphere.radius) continue;  // near grazing: depth only
                ++measured;
                error3_sum += std::abs(error3);
                error5_sum += std::abs(error5);
                error5_max = std::max(error5_max, std::abs(error5));
                // Normals: step 04 at the hit voxel, step 05 at the sub-voxel hit point.
                const Voxel voxel4 = view.voxel(x, y, hit4.n);
                const Vec3 normal4 = outward_normal(step04::gradient_at(volume, voxel4, work));
                const double angle4 =
                    angle_degrees(normal4, analytic_normal(sphere, position(volume, voxel4)));
                const Point p0 = position(volume, view.voxel(x, y, 0));
                const Vec3 unit_ray = volume_direction(view, 0, 0, 1);
                const double distance = along(hit5) * view.ray_spacing;
                const Point p5 = {p0.x + distance * unit_ray.i, p0.y + distance * unit_ray.j,
                                  p0.z + distance * unit_ray.k};
                const Vec3 normal5 =
                    outward_normal(step05::gradient_along_ray(volume, view, x, y, hit5.n,
                                                              hit5.fraction, work));
                const double angle5 = angle_degrees(normal5, analytic_normal(sphere, p5));
                normal4_sum += angle4;
                normal5_sum += angle5;
                normal5_max = std::max(normal5_max, angle5);
                CHECK(angle4 < 1.0);
                CHECK(angle5 < 1.0);
                // The rendered pixels: within what a 1 degree normal error changes (0.016).
                const Vec3 true_normal4 = analytic_normal(sphere, position(volume, voxel4));
                CHECK(std::abs(lit4[int(axis)].at(x, y).r - expected_shade(true_normal4)) < 0.02);
                const Vec3 true_normal5 = analytic_normal(sphere, p5);
                CHECK(std::abs(lit5[int(axis)].at(x, y).r - expected_shade(true_normal5)) < 0.02);
            }
        }
        CHECK(hits > 500);
        CHECK(misses > 500);
        CHECK(unsure < hits / 100);
        REQUIRE(measured > 300);
        const double mean3 = error3_sum / measured, mean5 = error5_sum / measured;
        MESSAGE("sphere " << view.name << ": mean |depth error| step 03 = " << mean3
                          << ", step 05 = " << mean5 << " (max " << error5_max
                          << ") samples; mean normal error step 04 = " << normal4_sum / measured
                          << " deg, step 05 = " << normal5_sum / measured << " deg (max "
                          << normal5_max << ")");
        CHECK(mean5 * 5 <= mean3);
        CHECK(error5_max < 0.05);
        CHECK(normal5_sum / measured < 0.5);
    }
}

// --- Lighting ------------------------------------------------------------------------------

TEST_CASE("lighting: diffuse + ambient, and no normal for a zero gradient") {
    const float ambient = step04::ambient;
    const Vec3 to_light = {0, 0.6f, -0.8f};
    // The outward normal is -gradient/|gradient|: a gradient of any size against the light.
    CHECK(step04::shade({0, -3.0f, 4.0f}, to_light) == doctest::Approx(1.0));
    CHECK(step05::shade({0, -300.0f, 400.0f}, to_light) == doctest::Approx(1.0));
    CHECK(step04::shade({0, 3.0f, -4.0f}, to_light) == ambient);  // facing away
    CHECK(step04::shade({7.0f, 0, 0}, to_light) == ambient);      // lit edge-on
    CHECK(step04::shade({0, 0, 0}, to_light) == ambient);         // no normal: no NaN
    CHECK(step05::shade({0, 0, 0}, to_light) == ambient);
    // 60 degrees between normal and light: ambient + (1 - ambient) cos 60.
    const Vec3 normal_60 = {0, 0.6f * 0.5f + 0.8f * 0.8660254f, -0.8f * 0.5f + 0.6f * 0.8660254f};
    CHECK(step04::shade(-1.0f * normal_60, to_light) ==
          doctest::Approx(ambient + (1 - ambient) * 0.5).epsilon(1e-5));

    // The light: unit length; angle 0 comes from the viewer's side, 20 degrees from above.
    Volume volume = ramp_volume(4, 5, 6);
    for (ViewAxis axis : all_axes) {
        const View view = make_view(volume, axis);
        for (double angle : {-180.0, -45.0, 0.0, 30.0, 90.0}) {
            CHECK(length(step04::light_direction(view, angle)) == doctest::Approx(1.0));
        }
        const double rad = 3.14159265358979323846 / 180;
        const Vec3 expected =
            volume_direction(view, 0, float(-std::sin(20 * rad)), float(-std::cos(20 * rad)));
        const Vec3 light = step05::light_direction(view, 0);
        CHECK(light.i == doctest::Approx(expected.i));
        CHECK(light.j == doctest::Approx(expected.j));
        CHECK(light.k == doctest::Approx(expected.k));
    }
}

// --- Constant, thin and extreme volumes ----------------------------------------------------

TEST_CASE("constant volume: every step, every view, the known value and never NaN") {
    // min = max: step 00/01's display has no range; every gradient is zero.
    struct Expected {
        const char* step;
        float above;  // volume 500: above the threshold 400 everywhere
        float below;  // volume -1000: nothing above
    };
    const Expected expected[] = {
        {"00_slices", 0.0f, 0.0f},                        // min..max display of a zero range: 0
        {"01_ray_loops", 0.0f, 0.0f},                     // same mapping
        {"02_threshold", 1.0f, 0.0f},                     // hit / miss
        {"03_depth_shading", 1.0f, 0.0f},                 // hit at t = 0: 1 - 0/N
        {"04_gradient_lighting", step04::ambient, 0.0f},  // zero gradient: ambient only
        {"05_interpolated_hits", step05::ambient, 0.0f},
    };
    for (int value : {500, -1000}) {
        const Volume volume = make_volume(8, 6, 4, [&](int, int, int) { return value; });
        CHECK(volume.min_value == volume.max_value);
        for (const auto& step : included_steps()) {
            CAPTURE(step.name);
            CAPTURE(value);
            const std::vector<Image> images = render_step(step.name, {"--no-window"}, volume);
            REQUIRE(images.size() == 3);
            for (const Image& image : images) {
                CHECK(bad_pixels(image, shows_unit_grey(step.name)) == 0);
                for (const Expected& known : expected) {
                    if (step.name != known.step) continue;
                    const float want = value > 400 ? known.above : known.below;
                    for (const Rgb& pixel : image.pixels) {
                        CHECK(pixel.r == want);
                        CHECK(pixel.g == want);
                        CHECK(pixel.b == want);
                    }
                }
            }
        }
        // Step 00's tables: a single grey; equalised, all voxels are at or below the value.
        CHECK(step00::linear_display(volume).grey_of == std::vector<float>{0.0f});
        CHECK(step00::equalised_display(volume).grey_of == std::vector<float>{1.0f});
        const std::vector<Image> equalised = render_step("00_slices", {"--equalise"}, volume);
        for (const Image& image : equalised) CHECK(image.at(0, 0).r == 1.0f);
    }
}

TEST_CASE("1x1x1 and one-voxel-thick volumes: every step and view, finite, right size") {
    struct Dims {
        int nx, ny, nz;
    };
    for (Dims dims : {Dims{1, 1, 1}, Dims{1, 16, 16}, Dims{16, 1, 16}, Dims{16, 16, 1}}) {
        CAPTURE(dims.nx);
        CAPTURE(dims.ny);
        CAPTURE(dims.nz);
        // A ramp that crosses the threshold 400 inside the volume (500 for 1x1x1).
        const Volume volume = make_volume(
            dims.nx, dims.ny, dims.nz,
            [](int i, int j, int k) {
                return 300 + 20 * i + 10 * j + 15 * k + 200 * (i + j + k == 0);
            },
            1, 1, 2);
        // Gradients: finite everywhere; zero along a one-voxel axis, exact elsewhere.
        Work work;
        for (int k = 0; k < dims.nz; ++k)
            for (int j = 0; j < dims.ny; ++j)
                for (int i = 0; i < dims.nx; ++i) {
                    if (i + j + k <= 1) continue;  // the corner voxel breaks the ramp
                    const Vec3 g = step04::gradient_at(volume, {i, j, k}, work);
                    CHECK(finite(g));
                    CHECK(g.i == (dims.nx > 1 ? 20.0f : 0.0f));
                    CHECK(g.j == (dims.ny > 1 ? 10.0f : 0.0f));
                    CHECK(g.k == (dims.nz > 1 ? 7.5f : 0.0f));
                }
        const Vec3 corner = step05::gradient_at(volume, {0, 0, 0}, work);
        CHECK(finite(corner));

        for (const auto& step : included_steps()) {
            CAPTURE(step.name);
            const std::vector<Image> images = render_step(step.name, {}, volume);
            const std::vector<View> views = views_named(volume, "all");
            REQUIRE(images.size() == 3);
            for (size_t n = 0; n < views.size(); ++n) {
                CAPTURE(views[n].name);
                CHECK(images[n].width == views[n].width);
                CHECK(images[n].height == views[n].height);
                CHECK(bad_pixels(images[n], shows_unit_grey(step.name)) == 0);
            }
        }
        // Every ray of the surface steps on these volumes: gradients at the hits are finite.
        for (ViewAxis axis : all_axes) {
            const View view = make_view(volume, axis);
            for (int y = 0; y < view.height; ++y)
                for (int x = 0; x < view.width; ++x) {
                    const auto hit = step05::first_hit(volume, view, x, y, 400, work, nullptr);
                    if (!hit.found) continue;
                    CHECK(finite(step05::gradient_along_ray(volume, view, x, y, hit.n, hit.fraction,
                                                            work)));
                    CHECK(along(hit) >= 0.0);
                    CHECK(along(hit) <= double(view.ray_length - 1));
                }
        }
    }
    // 1x1x1 with 500 > 400: a hit at t = 0 in every view: white in step 02, 1 - 0/1 in 03.
    const Volume single = make_volume(1, 1, 1, [](int, int, int) { return 500; });
    for (const char* name : {"02_threshold", "03_depth_shading"}) {
        for (const Image& image : render_step(name, {}, single)) CHECK(image.at(0, 0).r == 1.0f);
    }
}

TEST_CASE("int16 extremes: MIP and display reach exactly 1, thresholds at the extremes") {
    // 4x4x4: -32768 for k < 2, 32767 for k >= 2; and one 32767 voxel at k = 0.
    const Volume volume = make_volume(4, 4, 4, [](int i, int j, int k) {
        return (k >= 2 || (i == 3 && j == 3 && k == 0)) ? 32767 : -32768;
    });
    REQUIRE(volume.min_value == -32768);
    REQUIRE(volume.max_value == 32767);
    CHECK(step01::display_grey(volume, 32767) == 1.0f);
    CHECK(step01::display_grey(volume, -32768) == 0.0f);

    // MIP: every top ray meets 32767. Front (x = i) and side (x = j) rows y = k >= 2 are
    // 32767; of the rows k < 2 only the ray through the bright voxel (3, 3, 0) is: x 3, y 0.
    const std::vector<Image> mip = render_step("01_ray_loops", {}, volume);
    REQUIRE(mip.size() == 3);
    for (const Rgb& pixel : mip[0].pixels) CHECK(pixel.r == 1.0f);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) {
            const float expected = (y >= 2 || (y == 0 && x == 3)) ? 1.0f : 0.0f;
            CHECK(mip[1].at(x, y).r == expected);
            CHECK(mip[2].at(x, y).r == expected);
        }
    // Step 00's display of the two extremes, linear and equalised.
    const step00::Display display = step00::linear_display(volume);
    CHECK(display.grey_of.size() == 65536);
    CHECK(display.grey_of.front() == 0.0f);
    CHECK(display.grey_of.back() == 1.0f);
    const step00::Display equalised = step00::equalised_display(volume);
    CHECK(equalised.grey_of.front() == doctest::Approx(31.0 / 64));  // 31 of 64 voxels lowest
    CHECK(equalised.grey_of.back() == 1.0f);

    // Threshold 32767: nothing is above it; -32768: everything but the lowest value is.
    for (const Image& image : render_step("02_threshold", {"--threshold", "32767"}, volume)) {
        for (const Rgb& pixel : image.pixels) CHECK(pixel.r == 0.0f);
    }
    const std::vector<Image> lowest =
        render_step("03_depth_shading", {"--threshold=-32768"}, volume);
    CHECK(lowest[0].at(0, 0).r == 0.5f);  // top ray: first above at k = 2 of 4
    CHECK(lowest[0].at(3, 3).r == 1.0f);  // the bright voxel at k = 0
    // Step 05 between -32768 and 32767: the fraction (tau - v0)/(v1 - v0) over 65535.
    const View top = make_view(volume, ViewAxis::top);
    Work work;
    CHECK(along(step05::first_hit(volume, top, 0, 0, -32768, work, nullptr)) == 1.0);
    CHECK(along(step05::first_hit(volume, top, 0, 0, 32766, work, nullptr)) ==
          doctest::Approx(1.0 + 65534.0 / 65535.0).epsilon(1e-7));
    CHECK(along(step05::first_hit(volume, top, 0, 0, 0, work, nullptr)) ==
          doctest::Approx(1.0 + 32768.0 / 65535.0).epsilon(1e-7));
    CHECK_FALSE(step05::first_hit(volume, top, 0, 0, 32767, work, nullptr).found);
    // Step 04 at that hit: gradient (f(k=3) - f(k=1)) / 2 along +k, normal -k, towards the
    // viewer; the light at angle 30, elevation 20 gives N.L = cos 30 cos 20.
    const std::vector<Image> lit = render_step("04_gradient_lighting", {"--view", "top"}, volume);
    const Vec3 gradient = step04::gradient_at(volume, {1, 1, 2}, work);
    CHECK(gradient.k == 65535.0f / 2);
    const double rad = 3.14159265358979323846 / 180;
    CHECK(lit[0].at(1, 1).r ==
          doctest::Approx(step04::ambient +
                          (1 - step04::ambient) * std::cos(30 * rad) * std::cos(20 * rad))
              .epsilon(1e-5));
    for (const auto& step : included_steps()) {
        for (const char* threshold : {"-32768", "32767"}) {
            std::vector<std::string> flags;
            const bool has_threshold = step.name >= "02" && step.name < "06";
            if (has_threshold) flags = {"--threshold", threshold};
            for (const Image& image : render_step(step.name, flags, volume)) {
                CHECK(bad_pixels(image, shows_unit_grey(step.name)) == 0);
            }
        }
    }
}

// --- Step 00 and 01 ------------------------------------------------------------------------

TEST_CASE("step 00: slices read the documented voxels; equalisation uses the whole volume") {
    // Value = unique per voxel, so each pixel tells which voxel it showed.
    const Volume volume =
        make_volume(7, 5, 3, [](int i, int j, int k) { return 100 * k + 10 * j + i; });
    const step00::Display display = step00::linear_display(volume);
    const float range = float(volume.max_value - volume.min_value);
    CHECK(display.grey_of[1] == 1.0f / range);  // float division, not integer
    const std::vector<Image> images = render_step("00_slices", {"--slice", "1"}, volume);
    REQUIRE(images.size() == 3);
    const View views[3] = {make_view(volume, ViewAxis::top), make_view(volume, ViewAxis::front),
                           make_view(volume, ViewAxis::side)};
    for (int n = 0; n < 3; ++n) {
        for (int y = 0; y < views[n].height; ++y)
            for (int x = 0; x < views[n].width; ++x) {
                const Voxel voxel = views[n].voxel(x, y, 1);
                const float want =
                    float(volume.at(voxel.i, voxel.j, voxel.k) - volume.min_value) / range;
                CHECK(images[n].at(x, y).r == want);
            }
    }

    // 2x2x2: slice k = 0 holds 0, 0, 1, 3; slice k = 1 is all 3. Cumulative fractions over
    // all 8 voxels: value 0 -> 2/8, 1 -> 3/8, 2 -> 3/8 (absent), 3 -> 8/8.
    const int values[8] = {0, 0, 1, 3, 3, 3, 3, 3};
    const Volume small =
        make_volume(2, 2, 2, [&](int i, int j, int k) { return values[(k * 2 + j) * 2 + i]; });
    const step00::Display cdf = step00::equalised_display(small);
    CHECK(cdf.min_value == 0);
    CHECK(cdf.grey_of == std::vector<float>{0.25f, 0.375f, 0.375f, 1.0f});
    const std::vector<Image> top =
        render_step("00_slices", {"--equalise", "--view", "top", "--slice", "0"}, small);
    REQUIRE(top.size() == 1);
    // One slice's own histogram would give 0.5, 0.5, 0.75, 1.
    CHECK(top[0].at(0, 0).r == 0.25f);
    CHECK(top[0].at(1, 0).r == 0.25f);
    CHECK(top[0].at(0, 1).r == 0.375f);
    CHECK(top[0].at(1, 1).r == 1.0f);
    const std::vector<Image> linear = render_step("00_slices", {"--view=top", "--slice=0"}, small);
    CHECK(linear[0].at(0, 1).r == 1.0f / 3);
}

TEST_CASE("step 01: MIP starts from the first sample (an all-negative volume keeps its max)") {
    // f = -1000 + i + 2j + 3k: the largest value of each ray is at its far end.
    const Volume volume =
        make_volume(5, 4, 3, [](int i, int j, int k) { return -1000 + i + 2 * j + 3 * k; });
    for (ViewAxis axis : all_axes) {
        const View view = make_view(volume, axis);
        CAPTURE(view.name);
        for (int y = 0; y < view.height; ++y)
            for (int x = 0; x < view.width; ++x) {
                const Voxel far = view.voxel(x, y, view.ray_length - 1);
                Work work;
                Trace trace;
                const int highest = step01::mip_ray(volume, view, x, y, work, &trace);
                CHECK(highest == -1000 + far.i + 2 * far.j + 3 * far.k);
                CHECK(work.samples == uint64_t(view.ray_length));
                CHECK(trace.lines().size() == size_t(view.ray_length));
            }
    }
    // A ray of -5 everywhere except one -3 in the middle: max -3, never 0.
    const Volume dip = make_volume(1, 1, 3, [](int, int, int k) { return k == 1 ? -3 : -5; });
    Work work;
    CHECK(step01::mip_ray(dip, make_view(dip, ViewAxis::top), 0, 0, work, nullptr) == -3);
}

// --- Threads and the debug trace -----------------------------------------------------------

TEST_CASE("threads: --threads 1 and --threads 2 give identical images and work counts") {
    const Volume phantom = make_phantom_sized(128, 128, 57);
    for (const auto& step : included_steps()) {
        CAPTURE(step.name);
        std::vector<Image> images[2];
        std::vector<Work> works[2];
        for (int n = 0; n < 2; ++n) {
            const std::string threads = n == 0 ? "1" : "2";
            run_step(step.name, {"--threads", threads}, phantom,
                     [&](const Options& options, const Volume& volume, const Renderer& renderer) {
                         for (const View& view : views_named(volume, "all")) {
                             Work work;
                             images[n].push_back(render_view(options, view, renderer, work));
                             works[n].push_back(work);
                         }
                     });
        }
        REQUIRE(images[0].size() == 3);
        REQUIRE(images[1].size() == 3);
        for (int v = 0; v < 3; ++v) {
            REQUIRE(images[0][v].pixels.size() == images[1][v].pixels.size());
            CHECK(std::memcmp(images[0][v].pixels.data(), images[1][v].pixels.data(),
                              images[0][v].pixels.size() * sizeof(Rgb)) == 0);
            CHECK(works[0][v].samples == works[1][v].samples);
            CHECK(works[0][v].leapt == works[1][v].leapt);
            CHECK(works[0][v].hits == works[1][v].hits);
            CHECK(works[0][v].gradients == works[1][v].gradients);
            CHECK(works[0][v].terminated == works[1][v].terminated);
            CHECK(works[0][v].samples > 0);
        }
    }
}

TEST_CASE("debug trace: the traced ray gives the image's pixel, and print_trace prints it") {
    const Volume phantom = make_phantom_sized(48, 48, 22);
    for (const auto& step : included_steps()) {
        CAPTURE(step.name);
        run_step(step.name, {"--threads", "2"}, phantom,
                 [&](const Options& options, const Volume& volume, const Renderer& renderer) {
                     for (const View& view : views_named(volume, "all")) {
                         CAPTURE(view.name);
                         Work image_work;
                         const Image image = render_view(options, view, renderer, image_work);
                         // Every pixel: the ray with a trace is the same code and gives the same
                         // value.
                         Work ray_work;
                         int different = 0, untraced = 0;
                         for (int y = 0; y < view.height; ++y)
                             for (int x = 0; x < view.width; ++x) {
                                 Work work;
                                 Trace trace;
                                 const Rgb pixel = renderer.ray(view, x, y, work, &trace);
                                 const Rgb& drawn = image.at(x, y);
                                 if (pixel.r != drawn.r || pixel.g != drawn.g || pixel.b != drawn.b)
                                     ++different;
                                 // A line per sample read; a ray that only leapt over empty
                                 // bricks (09) still says so.
                                 if (trace.lines().size() < work.samples ||
                                     trace.lines().empty())
                                     ++untraced;
                                 ray_work.add(work);
                             }
                         CHECK(different == 0);
                         CHECK(untraced == 0);
                         CHECK(ray_work.samples == image_work.samples);
                         CHECK(ray_work.leapt == image_work.leapt);
                         CHECK(ray_work.hits == image_work.hits);
                         CHECK(ray_work.gradients == image_work.gradients);

                         // What --debug-pixel prints: the header, the samples, then this pixel.
                         const int x = view.width / 2, y = view.height / 2;
                         const std::string printed = ctlab_test::capture_stdout(
                             [&] { print_trace(options, view, renderer, x, y); });
                         const Rgb& drawn = image.at(x, y);
                         char last[200];
                         std::snprintf(last, sizeof last,
                                       "pixel x=%d y=%d rgb=(%.6f, %.6f, %.6f) png=(%d, %d, %d)", x,
                                       y, drawn.r, drawn.g, drawn.b, to_byte(drawn.r),
                                       to_byte(drawn.g), to_byte(drawn.b));
                         const size_t last_start = printed.rfind('\n', printed.size() - 2) + 1;
                         const std::string last_line = printed.substr(last_start);
                         CHECK(last_line.rfind(last, 0) == 0);
                         CHECK(printed.rfind("debug pixel x=" + std::to_string(x) +
                                                 " y=" + std::to_string(y) + " view=" + view.name,
                                             0) == 0);
                     }
                 });
    }
}
