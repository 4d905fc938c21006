// object_order.h: the wiring of the object-order steps (35 on), as cast_camera_rays() is ray
// order's: the intermediate image's rows handed to the threads, the warp's map and its loop
// over the output image, one output pixel alone with the records of its trace through the
// warp, the runs' storage (and from step 43 their records' starts and light), and the
// "precompute" line. Wiring, and two given loops of part 3's speed (vector stretches for the
// maximum and for the runs): compositing a slice row, the shear, finding the runs, packing
// their records and the warp's bilinear read are the steps' lessons.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <limits>
#include <mutex>
#include <string>
#include <utility>
#include <vector>
#include "error.h"
#include "huge_pages.h"
#include "image.h"
#include "render.h"
#include "step.h"
#include "transfer_function.h"
#include "vec3.h"
#include "view.h"
#include "volume.h"
#if defined(__SSE2__)
#include <emmintrin.h>  // mask_bits(): SSE2, in every x86-64 processor
#endif

namespace ctlab {

// The warp: where the intermediate image is read for output pixel (x, y), in its pixels. It is
// affine in x and y (the shear's inverse composed with the camera's map): u = u0 + x * du_dx
// + y * du_dy, the same for v.
struct WarpMap {
    double u0 = 0, du_dx = 0, du_dy = 0;
    double v0 = 0, dv_dx = 0, dv_dy = 0;
};
struct WarpPoint {
    double u = 0, v = 0;
};

inline WarpPoint warp_at(const WarpMap& warp, int x, int y) {
    return {warp.u0 + x * warp.du_dx + y * warp.du_dy, warp.v0 + x * warp.dv_dx + y * warp.dv_dy};
}

// The affine map from three pixels' points, point(x, y): one step along x and one along y.
template <class Point>
WarpMap affine_warp(Point point) {
    const WarpPoint origin = point(0, 0), along_x = point(1, 0), along_y = point(0, 1);
    return {origin.u, along_x.u - origin.u, along_y.u - origin.u,
            origin.v, along_x.v - origin.v, along_y.v - origin.v};
}

// The warp's affine map from the camera's rays: output pixel (x, y)'s ray, ray_of(x, y)
// (origin and direction, physical), meets the first slice at voxel (a, b) of the slice, which
// is intermediate pixel (a - base_a, b - base_b): the ray there is that pixel's ray.
template <class Shear, class RayOf>
WarpMap slice_warp(const Volume& volume, const Shear& shear, double base_a, double base_b,
                   RayOf ray_of) {
    const double spacing[3] = {volume.sx, volume.sy, volume.sz};
    auto in_voxels = [&](const Vec3d& p, int axis) { return p[axis] / spacing[axis]; };
    return affine_warp([&](int x, int y) {
        const auto ray = ray_of(x, y);
        const double t = (shear.first_slice - in_voxels(ray.origin, shear.c)) /
                         in_voxels(ray.direction, shear.c);  // to the first slice
        return WarpPoint{
            in_voxels(ray.origin, shear.a) + t * in_voxels(ray.direction, shear.a) - base_a,
            in_voxels(ray.origin, shear.b) + t * in_voxels(ray.direction, shear.b) - base_b};
    });
}

// The intermediate image, width x height, its rows handed to the threads (the rows' work
// summed into `work`). Each row starts as `width` copies of `blank`; row(scene, v, values,
// row_work) composites row v into them, and colour(value) turns each into its pixel.
template <class Scene, class Value, class Row, class Colour>
Image intermediate_image(const Scene& scene, int width, int height, int threads, Work& work,
                         Value blank, Row row, Colour colour) {
    Image image(width, height);
    parallel_rows(height, threads, work, [&](int v, Work& row_work) {
        std::vector<Value> values(size_t(width), blank);
        row(scene, v, values.data(), row_work);
        for (int u = 0; u < width; ++u) image.at(u, v) = colour(values[u]);
    });
    return image;
}

// The camera's image, its rows handed to the threads: output pixel (x, y) is pixel_at(p), p
// its warp point (the step's bilinear read of the intermediate image there).
template <class PixelAt>
Image warp_image(const View& view, int threads, Work& work, const WarpMap& warp,
                 PixelAt pixel_at) {
    Image image(view.width, view.height);
    parallel_rows(view.height, threads, work, [&](int y, Work&) {
        for (int x = 0; x < view.width; ++x) image.at(x, y) = pixel_at(warp_at(warp, x, y));
    });
    return image;
}

// The camera's image from the intermediate one (warp_image()): output pixel p is the step's
// warp_pixel(p, width, height, pixel), except where the four intermediate pixels around p all
// lie inside the image: those are read directly and blended by the step's mix(p, q, f), as
// warp_pixel() blends them (the same numbers in the same order: the same float), 10 M
// instructions less per 256x256 render than through a pixel(u, v) (callgrind, 1 thread).
template <class WarpPixel, class Mix>
Image warp_intermediate(const View& view, int threads, Work& work, const WarpMap& warp,
                        const Image& image, WarpPixel warp_pixel, Mix mix) {
    return warp_image(view, threads, work, warp, [&](const WarpPoint& p) {
        if (!(p.u >= 0 && p.u < image.width - 1 && p.v >= 0 && p.v < image.height - 1)) {
            return warp_pixel(p, image.width, image.height, [&](int u, int v) {
                return image.pixels[size_t(v) * image.width + u];
            });
        }
        const int u = int(p.u), v = int(p.v);  // >= 0: int() rounds down
        const float fu = float(p.u - u), fv = float(p.v - v);
        const Rgb* low = &image.pixels[size_t(v) * image.width + u];
        const Rgb* high = low + image.width;
        return mix(mix(low[0], low[1], fu), mix(high[0], high[1], fu), fv);
    });
}

// The trace's note of where output pixel's ray meets the first slice (slice `first_slice`
// across `axis`, 0 i, 1 j, 2 k) in intermediate pixels, and the samples' spacing along it.
inline void trace_warp_point(Trace* trace, const WarpPoint& p, int axis, int first_slice,
                             double spacing) {
    if (!trace) return;
    trace->note({{"u", p.u}, {"v", p.v}, {"principal_axis", double(axis)},
                 {"spacing", spacing}},
                "warp: the ray meets the first slice (%c = %d) at intermediate pixel "
                "u=%.4f v=%.4f; samples one slice apart, %.4f along the ray",
                "ijk"[axis], first_slice, p.u, p.v, spacing);
}

// One output pixel alone, at warp point p: the (up to) four intermediate pixels around it
// inside the width x height image, in order, each made by column(u, v) (which traces its
// samples) between two notes, its weight in the blend and its colour; then the step's
// warp_pixel(p, width, height, pixel) blends them, the image's pixel to the bit.
template <class Column, class WarpPixel>
Rgb warp_traced(const WarpPoint& p, int width, int height, Trace* trace, Column column,
                WarpPixel warp_pixel) {
    const int low_u = int(std::floor(p.u)), low_v = int(std::floor(p.v));
    const double fu = p.u - low_u, fv = p.v - low_v;
    Rgb colours[4];
    for (int n = 0; n < 4; ++n) {
        const int u = low_u + (n & 1), v = low_v + (n >> 1);
        if (u < 0 || u >= width || v < 0 || v >= height) continue;
        if (trace) {
            const double weight = ((n & 1) ? fu : 1 - fu) * ((n >> 1) ? fv : 1 - fv);
            trace->note({{"u", double(u)}, {"v", double(v)}, {"weight", weight}},
                        "intermediate pixel %d,%d, weight %.4f in the warp: its ray", u, v,
                        weight);
        }
        colours[n] = column(u, v);
        if (trace) {
            trace->note({{"u", double(u)}, {"v", double(v)}, {"r", colours[n].r},
                         {"g", colours[n].g}, {"b", colours[n].b}},
                        "intermediate pixel %d,%d: rgb=(%.6f, %.6f, %.6f)", u, v, colours[n].r,
                        colours[n].g, colours[n].b);
        }
    }
    auto pixel = [&](int u, int v) { return colours[(u - low_u) + 2 * (v - low_v)]; };
    return warp_pixel(p, width, height, pixel);
}

// One intermediate pixel's sample in one slice, for the one-pixel path below.
struct ColumnSample {
    bool inside = false;  // the pixel's cell lies in the slice (else no sample there)
    Vec3d point;          // the sample's place, physical units (its trace record's)
    float value = 0;      // its value
    bool read = true;     // false: the cell lies outside its slice row's runs (steps 39 on),
                          // which the rows never read: leapt over
};

// Intermediate pixel alone, slices 0 .. slices - 1 front to back, as the step's row function
// composites it (to the bit, the same counters): at(m) is its ColumnSample in slice m;
// lut[value - lowest_ct_value] its RGBA; light(m) the light of a sample that is not
// transparent; add(pixel, rgba, light) composites it. It stops once pixel.transparency is
// below stop_below. Each sample is traced (when `trace`) at its distance along `ray` (the
// output pixel's ray); a stretch of cells outside the runs (not read) as one leap.
template <class Pixel, class Ray, class At, class Light, class Add>
Pixel composite_column(int slices, const Rgba* lut, double stop_below, const Ray& ray,
                       Work& work, Trace* trace, At at, Light light, Add add) {
    Pixel pixel;
    long long unread = 0;  // the stretch of cells not read so far, from t = unread_from
    double unread_from = 0, unread_to = 0;
    auto end_unread = [&] {
        if (trace && unread > 0) trace->leap_runs(unread_from, unread_to, unread);
        unread = 0;
    };
    for (int m = 0; m < slices; ++m) {
        const ColumnSample s = at(m);
        if (!s.inside) continue;
        if (!s.read) {
            ++work.leapt;
            unread_to = dot(s.point - ray.origin, ray.direction);
            if (unread++ == 0) unread_from = unread_to;
            continue;
        }
        end_unread();
        const Rgba& sample = lut[int(double(s.value) - lowest_ct_value)];
        ++work.samples;
        TraceSample record(dot(s.point - ray.origin, ray.direction), s.point, s.value);
        if (sample.a == 0.0f) {
            ++work.skipped;
            if (trace) trace->sample(record.skipped());
            continue;
        }
        const double sample_light = light(m);
        add(pixel, sample, sample_light);
        if (trace) {
            record.rgba(sample).light(sample_light);  // what it gave, and the pixel after it
            record.colour(pixel.r, pixel.g, pixel.b).transparency(pixel.transparency);
            trace->sample(record);
        }
        if (pixel.transparency < stop_below) {
            ++work.terminated;
            if (trace) {
                long long left = 0;  // the slices after this one the pixel would have met
                for (int later = m + 1; later < slices; ++later) left += at(later).inside;
                trace->stop(pixel.transparency, stop_below, left);
            }
            return pixel;
        }
    }
    end_unread();
    return pixel;
}

// The maximum of the same samples (as the step's mip row keeps it), traced the same way;
// -infinity when the pixel meets no slice.
template <class Ray, class At>
float maximum_column(int slices, const Ray& ray, Work& work, Trace* trace, At at) {
    float highest = -std::numeric_limits<float>::infinity();
    for (int m = 0; m < slices; ++m) {
        const ColumnSample s = at(m);
        if (!s.inside) continue;
        highest = std::max(highest, s.value);
        ++work.samples;
        if (trace) {
            trace->sample(TraceSample(dot(s.point - ray.origin, ray.direction), s.point, s.value)
                              .max(highest));
        }
    }
    return highest;
}

// The maximum intensity's speed trick (given, part 3): a slice row of cells contiguous in
// memory (cell u's corners low[u], low[u + da], low[u + db], low[u + da + db]) sampled in
// stretches of max_stretch pixels from u, while a whole stretch lies before u_high: a loop of
// fixed length over neighbouring values, which the compiler turns into vector instructions
// (SSE2's four floats at a time). Each pixel keeps the higher of highest[u] and its bilinear
// sample, the step's lerp(lerp(p, q, fa), lerp(r, t, fa), fb) to the bit. Returns the first
// pixel not done, for the step's own loop.
constexpr int max_stretch = 16;  // pixels per vector loop
inline int max_in_stretches(float* highest, int u, int u_high, const int16_t* low, size_t da,
                            size_t db, float fa, float fb) {
    auto lerp = [](float a, float b, float f) { return a + f * (b - a); };  // the step's
    const int16_t* low_next = low + da;
    const int16_t* high = low + db;
    const int16_t* high_next = high + da;
    for (; u + max_stretch <= u_high; u += max_stretch) {
        float* h = highest + u;
        const int16_t *p = low + u, *q = low_next + u, *r = high + u, *t = high_next + u;
        for (int n = 0; n < max_stretch; ++n) {  // a fixed length: vector instructions
            h[n] = std::max(h[n], lerp(lerp(p[n], q[n], fa), lerp(r[n], t[n], fa), fb));
        }
    }
    return u;
}

// The runs' speed trick (given, part 3): cell_stretch cells of a slice row at a time, from
// cell `from` of na. Cell n's corners are low_row[n], low_row[n + 1], high_row[n] and
// high_row[n + 1] (voxels sa apart along the row; the last voxel repeated at its end). Each
// cell's lowest and highest corner, then the stretch's (halves folded onto each other), in
// loops of fixed length over neighbouring values, which the compiler turns into vector
// instructions: most stretches of a slice are air or soft tissue, clear as a whole.
constexpr int cell_stretch = 16;  // cells; the folds in read() are written for 16
struct CellStretch {
    int count = 0;                                  // cells in it: fewer at the row's end
    int16_t low[cell_stretch], high[cell_stretch];  // each cell's lowest and highest corner
    int16_t lowest = 0, highest = 0;                // the whole stretch's

    // Inlined always: a call per stretch cost 12 M instructions more per find_runs() of the
    // phantom (callgrind, step 39 along k), the folds' arrays kept in registers no longer.
    [[gnu::always_inline]] void read(const int16_t* low_row, const int16_t* high_row, size_t sa,
                                     int na, int from) {
        count = std::min(from + cell_stretch, na) - from;
        const int16_t* p = &low_row[from];
        const int16_t* q = &high_row[from];
        int16_t row_low[cell_stretch + 1], row_high[cell_stretch + 1];
        if (sa != 1 || from + cell_stretch > na - 1) {  // copied, the edge repeated
            for (int n = 0; n <= cell_stretch; ++n) {
                const size_t a = size_t(std::min(from + n, na - 1)) * sa;
                row_low[n] = low_row[a];
                row_high[n] = high_row[a];
            }
            p = row_low;
            q = row_high;
        }
        for (int n = 0; n < cell_stretch; ++n) {
            low[n] = std::min(std::min(p[n], p[n + 1]), std::min(q[n], q[n + 1]));
            high[n] = std::max(std::max(p[n], p[n + 1]), std::max(q[n], q[n + 1]));
        }
        for (int n = count; n < cell_stretch; ++n) {  // past the row's end: the first cell's
            low[n] = low[0];
            high[n] = high[0];
        }
        int16_t l[cell_stretch / 2], h[cell_stretch / 2];
        for (int n = 0; n < cell_stretch / 2; ++n) {
            l[n] = std::min(low[n], low[n + cell_stretch / 2]);
            h[n] = std::max(high[n], high[n + cell_stretch / 2]);
        }
        for (int n = 0; n < cell_stretch / 4; ++n) {
            l[n] = std::min(l[n], l[n + cell_stretch / 4]);
            h[n] = std::max(h[n], h[n + cell_stretch / 4]);
        }
        for (int n = 0; n < cell_stretch / 8; ++n) {
            l[n] = std::min(l[n], l[n + cell_stretch / 8]);
            h[n] = std::max(h[n], h[n + cell_stretch / 8]);
        }
        lowest = std::min(l[0], l[1]);
        highest = std::max(h[0], h[1]);
    }
};

// The cells of each slice row that the transfer function may see (a step's find_runs()), as
// runs of cells [begin, end) along a, slice after slice. Made once per transfer function and
// principal axis; a step names it Runs (and from step 43 on adds the runs' records to it).
struct SliceRuns {
    int axis = -1;                // the principal axis they are for; -1: not made
    int nb = 0;                   // cell rows per slice
    TableVector<uint32_t> first;  // per slice row c * nb + b: its first run; one past the end
    TableVector<int32_t> bounds;  // begin, end of every run, in cells along a (tables:
                                  // common/huge_pages.h says where and why)
    size_t cells = 0;             // cells in runs, all slices

    // Slice c's row b: its runs, and how many (none for a row it does not hold: runs not
    // made yet, as in a student's kit before find_runs() is written).
    const int32_t* row(int c, int b, int* count) const {
        const size_t r = size_t(c) * nb + b;
        *count = r + 1 < first.size() ? int(first[r + 1] - first[r]) : 0;
        return *count > 0 ? &bounds[2 * size_t(first[r])] : nullptr;
    }
    // Whether cell a of slice c's row b lies in one of its runs.
    bool holds(int c, int b, int a) const {
        int count = 0;
        const int32_t* run = row(c, b, &count);
        for (int r = 0; r < count; ++r) {
            if (a >= run[2 * r] && a < run[2 * r + 1]) return true;
        }
        return false;
    }
};

// The runs a step's find_runs() found slice by slice, joined into its Runs (a SliceRuns) for
// principal axis `axis`: counts[c][b], how many runs slice c's row b has (nb rows a slice);
// bounds[c], their begin and end, row after row.
template <class Runs>
Runs join_runs(int axis, int nb, const std::vector<std::vector<uint32_t>>& counts,
               const std::vector<std::vector<int32_t>>& bounds) {
    Runs runs;
    runs.axis = axis;
    runs.nb = nb;
    runs.first.reserve(counts.size() * nb + 1);
    size_t bound_count = 0;  // sized once: no copies while it grows, no freed blocks left
    for (const std::vector<int32_t>& slice : bounds) bound_count += slice.size();
    runs.bounds.reserve(bound_count);
    uint32_t total = 0;
    for (size_t c = 0; c < counts.size(); ++c) {
        for (uint32_t n : counts[c]) {
            runs.first.push_back(total);
            total += n;
        }
        runs.bounds.insert(runs.bounds.end(), bounds[c].begin(), bounds[c].end());
    }
    runs.first.push_back(total);
    for (size_t n = 0; n < runs.bounds.size(); n += 2) {
        runs.cells += size_t(runs.bounds[n + 1] - runs.bounds[n]);
    }
    return runs;
}

// From step 43 on, a step's Runs (a SliceRuns) also holds each slice's records (its runs'
// voxels, packed by the step's pack_slice()): records[c], slice c's; start[r], run r's first
// record; record_count, all slices'. Each run's first record, then (none when a slice's
// records were not written, as in a student's kit before pack_slice()), and the count.
template <class Shear, class Runs>
void find_starts(const Shear& shear, Runs& runs) {
    runs.start.clear();
    runs.start.reserve(runs.bounds.size() / 2);  // one per run
    for (int c = 0; c < shear.nc; ++c) {
        const auto* next = runs.records[c].get();
        const uint32_t end = runs.first[size_t(c + 1) * shear.nb];  // past its last run
        for (uint32_t r = runs.first[size_t(c) * shear.nb]; r < end; ++r) {
            if (!next) return runs.start.clear();  // not packed
            runs.start.push_back(next);
            next += runs.bounds[2 * r + 1] - runs.bounds[2 * r] + 1;
        }
    }
    runs.record_count = runs.cells + runs.bounds.size() / 2;  // a run: one column more than cells
}

// A sample's light from its cell's records (p: the low corner's; p[1] the next column's): the
// four corners' light from the shading table (by their normal indices), blended as the values
// are (the fractions s.fa, s.fb; the steps' lerp()): the step's slice_light()'s float.
template <class Record, class Shift>
inline float record_light(const float* light, const Record* p, const Shift& s) {
    auto lerp = [](float a, float b, float f) { return a + f * (b - a); };  // the step's
    const float low = lerp(light[p[0].low_normal], light[p[1].low_normal], s.fa);
    const float high = lerp(light[p[0].high_normal], light[p[1].high_normal], s.fa);
    return lerp(low, high, s.fb);
}

// Given (step 46): the voxels of a stretch's two slice rows (low_row and high_row from
// `from`, one more than its cells) at p and q, contiguous: the rows themselves where they
// are, else copied into `copies` (strided rows, or at a row's end with the last voxel
// repeated, as CellStretch::read() does). Step 47 takes 64 cells at a time (cells = 64).
template <int cells = cell_stretch>
inline void stretch_rows(const int16_t* low_row, const int16_t* high_row, size_t sa, int na,
                         int from, int16_t (&copies)[2][cells + 1], const int16_t** p,
                         const int16_t** q) {
    *p = low_row + from;
    *q = high_row + from;
    if (sa == 1 && from + cells <= na - 1) return;
    const int inside = std::min(cells + 1, na - from);  // voxels in the row
    if (sa == 1) {  // the row's end: copied at once (most rows' last stretch)
        std::memcpy(copies[0], *p, size_t(inside) * sizeof(int16_t));
        std::memcpy(copies[1], *q, size_t(inside) * sizeof(int16_t));
    }
    for (int n = sa == 1 ? inside : 0; n <= cells; ++n) {
        copies[0][n] = low_row[size_t(from + std::min(n, inside - 1)) * sa];
        copies[1][n] = high_row[size_t(from + std::min(n, inside - 1)) * sa];
    }
    *p = copies[0];
    *q = copies[1];
}

// Given (step 46): whether all cell_stretch masks (each 0 or -1, 16 bits) are `value`, read as
// 64-bit words at once.
inline bool all_masks(const int16_t (&mask)[cell_stretch], int16_t value) {
    static_assert(cell_stretch == 16, "four words");
    uint64_t w[4];
    std::memcpy(w, mask, sizeof w);
    return value ? (w[0] & w[1] & w[2] & w[3]) == ~uint64_t(0)
                 : (w[0] | w[1] | w[2] | w[3]) == 0;
}

// Given (step 47): masks (each 0 or -1, 16 bits; 16 or 64 of them) as bits, mask n's as bit
// n. The same in a plain loop, for a processor without SSE2 (tests compare the two).
template <int count>
inline uint64_t mask_bits_portable(const int16_t (&mask)[count]) {
    static_assert(count <= 64, "a word");
    uint64_t bits = 0;
    for (int n = 0; n < count; ++n) bits |= uint64_t(mask[n] & 1) << n;
    return bits;
}

// On x86, two instructions per sixteen: the masks packed to bytes, then each byte's top bit
// gathered (movemask). GCC makes no such instruction of the loop above.
template <int count>
inline uint64_t mask_bits(const int16_t (&mask)[count]) {
    static_assert(count % 16 == 0 && count <= 64, "sixteen at a time, a word");
#if defined(__SSE2__)
    uint64_t bits = 0;
    for (int n = 0; n < count; n += 16) {
        const __m128i low = _mm_loadu_si128(reinterpret_cast<const __m128i*>(mask + n));
        const __m128i high = _mm_loadu_si128(reinterpret_cast<const __m128i*>(mask + n + 8));
        bits |= uint64_t(uint32_t(_mm_movemask_epi8(_mm_packs_epi16(low, high)))) << n;
    }
    return bits;
#else
    return mask_bits_portable(mask);
#endif
}

// Given (step 47): bit scans on 64-bit words of bits (bit n of word w: item 64 * w + n).
// The lowest set bit's position in a word that is not 0 (count trailing zeros).
inline int first_bit(uint64_t word) {
#if defined(__GNUC__)
    return __builtin_ctzll(word);
#else
    int n = 0;
    for (; !(word & 1); word >>= 1) ++n;
    return n;
#endif
}

// How many bits of a word are set.
inline int bit_count(uint64_t word) {
#if defined(__GNUC__)
    return __builtin_popcountll(word);
#else
    int n = 0;
    for (; word; word &= word - 1) ++n;
    return n;
#endif
}

// Item n's bit.
inline bool bit_at(const uint64_t* words, int n) {
    return (words[n / 64] >> (n % 64)) & 1;
}

// Items n .. n + 15's bits, item n's lowest (the next word must exist when they cross one).
inline uint32_t sixteen_bits_at(const uint64_t* words, int n) {
    const int shift = n % 64;
    uint64_t bits = words[n / 64] >> shift;
    if (shift > 64 - 16) bits |= words[n / 64 + 1] << (64 - shift);
    return uint32_t(bits & 0xffff);
}

// A table made once per transfer function and principal axis, and its cost, on a line of its
// own (the summary lines are the renders'): make() makes it, what() says what it holds, and
// the line adds the time it took, wall clock and CPU (the machine may be shared):
// "precompute axis=k <what> ms=47.8 cpu_ms=11.6". Returns the wall clock ms.
template <class Make, class What>
double timed_precompute(int axis, Make make, What what) {
    const Timer timer;
    const std::clock_t cpu_start = std::clock();
    make();
    const double ms = timer.ms();
    const std::string held = what();
    std::printf("precompute axis=%c %s ms=%.1f cpu_ms=%.1f\n", "ijk"[axis], held.c_str(), ms,
                1000.0 * double(std::clock() - cpu_start) / CLOCKS_PER_SEC);
    return ms;
}

// The runs' part of that line: the cells in runs of the volume's voxels, the runs, their MB.
template <class Runs>
std::string runs_held(const Runs& runs, size_t voxels) {
    char text[200];
    std::snprintf(text, sizeof text, "run_cells=%zu of %zu runs=%zu runs_mb=%.2f", runs.cells,
                  voxels, runs.bounds.size() / 2,
                  (runs.bounds.size() * sizeof(runs.bounds[0]) +
                   runs.first.size() * sizeof(runs.first[0])) / 1048576.0);
    return text;
}

// Voxel (a, b, c) along the slices' axes as (i, j, k): `axes` names them (axes.a, axes.b and
// axes.c are each 0 for i, 1 for j or 2 for k).
template <class Axes>
Voxel voxel_of(const Axes& axes, int a, int b, int c) {
    int ijk[3] = {0, 0, 0};
    ijk[axes.a] = a;
    ijk[axes.b] = b;
    ijk[axes.c] = c;
    return Voxel{ijk[0], ijk[1], ijk[2]};
}

// The one-pixel path's note of what a lit sample's light blends (steps 41 on, before the
// sample's own line): its cell's four corners' normal indices (`normal_of(volume, voxel)`) and
// their light in the render's shading table, corner a + 2b as slice_light() takes them.
template <class Scene, class Shift, class NormalOf>
void trace_normals(const Scene& scene, const Shift& s, int a, int b, NormalOf normal_of,
                   Trace* trace) {
    if (!trace) return;
    const int step_a = s.da ? 1 : 0, step_b = s.db ? 1 : 0;  // the high corner's offset
    unsigned index[4];
    float light[4];
    std::vector<TraceField> fields;
    for (int n = 0; n < 4; ++n) {
        const Voxel voxel =
            voxel_of(scene.shear, a + (n & 1) * step_a, b + (n >> 1) * step_b, s.slice);
        index[n] = normal_of(scene.volume, voxel);
        light[n] = scene.shading[index[n]];
        fields.push_back({"index." + std::to_string(n), double(index[n])});
        fields.push_back({"light." + std::to_string(n), double(light[n])});
    }
    trace->note(fields,
                "normals: the corners' indices %u %u %u %u, the table's light %.4f %.4f %.4f "
                "%.4f", index[0], index[1], index[2], index[3], light[0], light[1], light[2],
                light[3]);
}

// The physical point at (a, b, c) along the slices' axes, in voxels: a trace record's place.
template <class Axes>
Vec3d slice_point(const Volume& volume, const Axes& axes, double a, double b, double c) {
    const double spacing[3] = {volume.sx, volume.sy, volume.sz};
    double place[3];
    place[axes.a] = a * spacing[axes.a];
    place[axes.b] = b * spacing[axes.b];
    place[axes.c] = c * spacing[axes.c];
    return {place[0], place[1], place[2]};
}

// An object-order step takes a camera along an axis only (two of forward's components exactly
// 0; its main refuses other angles first): any other is an error naming `step`.
inline void require_along_an_axis(const Vec3d& forward, const std::string& step) {
    int zeros = 0;
    for (int axis = 0; axis < 3; ++axis) zeros += forward[axis] == 0;
    if (zeros != 2) throw InputError(step + ": the camera is not along an axis");
}

// The summary's and trace header's sample spacing: "one sample per slice of k, 2 physical
// units apart along the ray".
inline std::string slice_samples(int axis, double spacing) {
    return "one sample per slice of " + std::string(1, "ijk"[axis]) + ", " +
           summary_number(spacing) + " physical units apart along the ray";
}

// Whether a camera looks along an axis (two of forward's components exactly 0): the views an
// object-order step takes (steps 35 and 36 hand the others to step 30's rays).
inline bool along_an_axis(const Vec3d& forward) {
    int zeros = 0;
    for (int axis = 0; axis < 3; ++axis) zeros += forward[axis] == 0;
    return zeros == 2;
}

// One output pixel alone for a camera along an axis (steps 35 and 36: intermediate pixel
// (u, v) meets slice c at voxel (a, b) = (u, v)), as warp_traced() makes it: the note of its
// warp point, then each of the (up to) four intermediate pixels around it, column(u, v, at),
// at(m) that pixel's ColumnSample in slice m (front to back); warp_pixel blends them.
template <class Shear, class Column, class WarpPixel>
Rgb axis_pixel_traced(const Volume& volume, const Shear& shear, const WarpMap& warp, int x,
                      int y, Trace* trace, Column column, WarpPixel warp_pixel) {
    const WarpPoint p = warp_at(warp, x, y);
    trace_warp_point(trace, p, shear.c, shear.first_slice, shear.spacing);
    auto pixel = [&](int u, int v) {
        auto at = [&](int m) {  // its voxel in slice m
            const int c = shear.first_slice + m * shear.slice_step;
            const Voxel voxel = voxel_of(shear, u, v, c);
            return ColumnSample{true, slice_point(volume, shear, u, v, c),
                                float(volume.at(voxel.i, voxel.j, voxel.k))};
        };
        return column(u, v, at);
    };
    return warp_traced(p, shear.width, shear.height, trace, pixel, warp_pixel);
}

// The renderer of an object-order step that hands the views it does not take to step 30's
// rays (steps 35 on), as cast_camera_rays() wires ray order's. For a view whose camera,
// camera_for(view), by_rays(camera) names, renderer.image, .ray and .ray_samples are those of
// `rays` (a Renderer that cast_camera_rays() filled; kept by reference: it must outlive
// renderer). For the others, with shear_for(camera) the view's slices and scene_for(camera,
// shear) what its pixels share: slices(view, scene, work) is its image, pixel(scene, x, y,
// work, trace) one output pixel alone (its trace told first: Trace::pixel_from_warp()), and
// the trace header says slice_samples().
template <class CameraFor, class ByRays, class ShearFor, class SceneFor, class Slices,
          class Pixel>
void slices_or_rays(Renderer& renderer, const Renderer& rays, CameraFor camera_for,
                    ByRays by_rays, ShearFor shear_for, SceneFor scene_for, Slices slices,
                    Pixel pixel) {
    renderer.image = [=, &rays](const View& view, Work& work) {
        const auto camera = camera_for(view);
        if (by_rays(camera)) return rays.image(view, work);
        const auto shear = shear_for(camera);
        return slices(view, scene_for(camera, shear), work);
    };
    // scene_for() remakes what a view's pixels share in the step's own variables (the slices'
    // shifts, the table for their spacing, the runs the first time): one output pixel at a
    // time, since a ray picture's pixels are cast on several threads (--trace-only).
    static std::mutex one_pixel;
    renderer.ray = [=, &rays](const View& view, int x, int y, Work& work, Trace* trace) {
        const auto camera = camera_for(view);
        if (by_rays(camera)) return rays.ray(view, x, y, work, trace);
        if (trace) trace->pixel_from_warp();  // its camera ray's miss is not the verdict
        const auto shear = shear_for(camera);
        const std::lock_guard<std::mutex> alone(one_pixel);
        return pixel(scene_for(camera, shear), x, y, work, trace);
    };
    renderer.ray_samples = [=, &rays](const View& view) {
        const auto camera = camera_for(view);
        if (by_rays(camera)) return rays.ray_samples(view);
        const auto shear = shear_for(camera);
        return slice_samples(shear.c, shear.spacing);
    };
}

// A slice shift's fractions past its cell's low corner along a and b, where a sample lies: its
// fa and fb when it keeps them (bilinear samples, step 38 on), else none (whole voxels, 37).
// Called as shift_fractions(s, 0): the first overload where s has fa (0 is an int), else the
// second.
template <class Shift>
auto shift_fractions(const Shift& s, int) -> decltype(s.fa, std::pair<double, double>()) {
    return {s.fa, s.fb};
}
template <class Shift>
std::pair<double, double> shift_fractions(const Shift&, long) {
    return {0, 0};
}

// The sample of a whole voxel (step 37): the voxel itself (p: the voxel in the volume's data).
struct WholeVoxel {
    template <class Shift>
    float operator()(const int16_t* p, const Shift&) const { return *p; }
};

// One output pixel alone for the slices shifted by the shear (steps 37 on), as
// axis_pixel_traced() makes it: intermediate pixel (u, v) meets slice m (shifts[m], front to
// back) in the cell whose low corner is voxel (u + ia, v + ib) of the slice (no sample where
// the slice does not hold it, up to last_a and last_b). Its value is sample(p, shifts[m]), p
// that voxel in the volume's data: the step's own (step 38's slice_value()), by default the
// voxel itself; its place the corner plus the shift's fractions (shift_fractions()). Given
// `runs` (steps 39 on, the composite), a cell outside them is not read (ColumnSample::read).
template <class Shear, class Shift, class Column, class WarpPixel, class Sample = WholeVoxel>
Rgb shifted_pixel_traced(const Volume& volume, const Shear& shear,
                         const std::vector<Shift>& shifts, const WarpMap& warp, int x, int y,
                         Trace* trace, Column column, WarpPixel warp_pixel,
                         Sample sample = WholeVoxel{}, const SliceRuns* runs = nullptr) {
    const WarpPoint p = warp_at(warp, x, y);
    trace_warp_point(trace, p, shear.c, shear.first_slice, shear.spacing);
    auto pixel = [&](int u, int v) {
        auto at = [&](int m) {  // its cell in slice m, if the slice holds it
            const Shift& s = shifts[m];
            const int a = u + s.ia, b = v + s.ib;
            if (a < 0 || a > s.last_a || b < 0 || b > s.last_b) return ColumnSample{};
            const size_t index =
                s.slice * shear.stride_c + b * shear.stride_b + a * shear.stride_a;
            const std::pair<double, double> past = shift_fractions(s, 0);
            return ColumnSample{
                true, slice_point(volume, shear, a + past.first, b + past.second, s.slice),
                sample(&volume.data[index], s), !runs || runs->holds(s.slice, b, a)};
        };
        return column(u, v, at);
    };
    return warp_traced(p, shear.width, shear.height, trace, pixel, warp_pixel);
}

}  // namespace ctlab
