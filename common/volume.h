// volume.h: a CT volume in memory and the loaders for it.
//
// Layout convention used everywhere in ctlab: value(i, j, k) = cthead[k][j][i], i fastest,
// k the slice (k = 0 at the crown for CThead). In memory the slices are padded ("pitched"):
// value(i, j, k) = data[k*slice_stride + j*row_stride + i] = data[volume.index(i, j, k)],
// with row_stride = nx and slice_stride = nx*ny rounded up to a whole, odd number of 64-byte
// cache lines. Why: a dense CThead slice is 128 KiB, a multiple of 4 KiB, so every sample of a
// top-view ray (one per slice) falls in the same set of the 48 KiB, 12-way L1 cache and the
// ray misses L1 at each sample; an odd number of lines from slice to slice spreads a ray over
// every set (CThead: 64 bytes more per slice, 7 KiB in all). Read values through at() or
// index(), never through a hand-made (k*ny + j)*nx + i. The padding is never a voxel: it holds
// copies of its row's last value and is left out of min/max, histograms and files written.
// Loaders and tests may fill data densely (nx*ny*nz values, i fastest: resize_dense) and call
// update_range, which lays the slices out in place at that one point. resize_dense and
// allocate_pitched ask the kernel for 2 MiB ("huge") pages for data, where it has them: a
// top-view ray steps from slice to slice, a page apart, and a large volume's 4 KiB pages are
// more than the processor keeps address translations for (common/volume.cpp).
// Files of other formats (NIfTI, NRRD, MetaImage, DICOM: common/formats.h) and raw files of
// other sample types end up in the same int16 layout, turned into the lab's anatomical frame.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ctlab {

// How the volume's int16 values relate to the file's own values (its "units"):
// file value = scale * volume value + offset. The identity for CT and every file whose values
// are whole numbers that fit int16; a linear map for uint16 above 32767 and for floats.
// Thresholds and transfer-function files are given in file units and converted through it.
struct ValueMap {
    double scale = 1.0, offset = 0.0;
    bool identity() const { return scale == 1.0 && offset == 0.0; }
    double to_file(double volume_value) const { return scale * volume_value + offset; }
    double to_volume(double file_value) const { return (file_value - offset) / scale; }
};

struct Volume {
    int nx = 0, ny = 0, nz = 0;                 // voxels along i, j, k
    double sx = 1.0, sy = 1.0, sz = 1.0;        // voxel spacing along i, j, k (CThead: 1, 1, 2)
    std::vector<int16_t> data;                  // signed 16-bit CT values, pitched (above)
    size_t row_stride = 0;                      // values from (i, j, k) to (i, j + 1, k)
    size_t slice_stride = 0;                    // values from (i, j, k) to (i, j, k + 1);
                                                // both 0 while data is still dense
    int16_t min_value = 0, max_value = 0;       // over the whole volume
    std::string name;                           // "phantom", or the file it came from
    ValueMap map;                               // volume value -> file value
    std::string format = "raw";                 // raw, nifti, nrrd, metaimage, dicom, phantom
    std::string orientation;                    // what was done to reach the lab frame ("" = none)

    size_t index(int i, int j, int k) const {
#ifdef __SANITIZE_ADDRESS__
        // SAN=1 builds (every test runs under one in CI): a volume whose slices were never laid
        // out (no update_range or allocate_pitched) has zero strides, and every (i, j, k) would
        // silently read row 0 of slice 0. The release build leaves the check out of its loops.
        if (row_stride == 0 && (j != 0 || k != 0)) strides_not_set(i, j, k);
#endif
        return static_cast<size_t>(k) * slice_stride + static_cast<size_t>(j) * row_stride +
               static_cast<size_t>(i);
    }
    int16_t at(int i, int j, int k) const { return data[index(i, j, k)]; }
    const int16_t* slice(int k) const { return data.data() + static_cast<size_t>(k) * slice_stride; }
    const int16_t* row(int j, int k) const { return data.data() + index(0, j, k); }
    int16_t* row(int j, int k) { return data.data() + index(0, j, k); }
    size_t voxel_count() const { return static_cast<size_t>(nx) * ny * nz; }

    // Throws std::logic_error naming the voxel: index() was asked for one before the strides
    // were set (see index()).
    [[noreturn]] void strides_not_set(int i, int j, int k) const;
};

// The padded slice stride (in int16 values) for slices of nx*ny values: a whole, odd number
// of 64-byte cache lines at least nx*ny values long (see the layout comment above); nx*ny
// itself for a slice under 4 KiB, whose padding would cost more than 3% of it.
size_t pitched_slice_stride(int nx, int ny);
// The number of values data holds once laid out: nz slice strides.
size_t pitched_size(int nx, int ny, int nz);

// Sizes data for nx*ny*nz values written densely (i fastest), with room reserved for the
// padding, so that laying the slices out later (update_range) needs no second allocation.
void resize_dense(Volume& volume);

// Sizes data for the pitched layout and sets the strides: for code that writes voxels through
// index() or row(). Values are 0 until written; call update_range when done.
void allocate_pitched(Volume& volume);

// Dense data (nx*ny*nz values, i fastest) -> the pitched layout, in place; the strides set.
// A volume already laid out is left as it is.
void lay_out_slices(Volume& volume);

// The values without padding, i fastest: (k*ny + j)*nx + i. For writing files and hashing.
std::vector<int16_t> dense_values(const Volume& volume);

// CThead facts: 256 x 256 x 113, signed 16-bit little-endian, no header.
constexpr int cthead_nx = 256, cthead_ny = 256, cthead_nz = 113;
constexpr double cthead_sx = 1.0, cthead_sy = 1.0, cthead_sz = 2.0;
constexpr size_t cthead_bytes = size_t(cthead_nx) * cthead_ny * cthead_nz * 2;  // 14,811,136

// Refuse volumes above this many voxels before allocating anything: 2^30 voxels, 2 GiB of
// int16 in memory (a 1024^3 volume; CThead has 7.4 million). A volume is also refused when
// the machine does not have the memory it needs free (check_volume_memory).
constexpr uint64_t max_voxels = uint64_t(1) << 30;

enum class Endian { little, big };

// The sample types of files. Everything becomes int16 in memory (see ValueMap).
enum class SampleType { uint8, int8, uint16, int16, uint32, int32, float32, float64 };

// "uint8", "int16", "float32"...; parse_sample_type returns false for an unknown name.
const char* sample_type_name(SampleType type);
bool parse_sample_type(const std::string& name, SampleType* type);
size_t sample_size(SampleType type);

struct RawFormat {
    int nx = 0, ny = 0, nz = 0;
    Endian endian = Endian::little;
    double sx = 1.0, sy = 1.0, sz = 1.0;
    SampleType type = SampleType::int16;
};

// Lays dense data out (lay_out_slices), then sets min_value and max_value over the voxels
// (padding left out). Every loader, the phantom and hand-built test volumes end with it.
void update_range(Volume& volume);

// Checks dims against max_voxels and the free memory, before anything is allocated.
// `what` starts the message, e.g. "--dims" or "'head.nii'". bytes_per_voxel: what loading
// takes in all (2 for the int16 volume, plus the sample size when a library keeps the file's
// own copy while we convert). Returns the voxel count.
uint64_t check_volume_size(const std::string& what, uint64_t nx, uint64_t ny, uint64_t nz,
                           uint64_t bytes_per_voxel = 2);

// Builds a volume from raw bytes (validated: size must be exactly nx*ny*nz*sample size).
Volume volume_from_bytes(const std::vector<unsigned char>& bytes, const RawFormat& format,
                         const std::string& name);

// Loads a raw file of format.type. Throws InputError naming the file and the problem.
// int16 files are read straight into the volume (no second copy); others in chunks.
Volume load_raw(const std::string& path, const RawFormat& format);

// Loads the CThead file: exact size, little-endian. Throws InputError.
Volume load_cthead(const std::string& path);

// Reads a whole file (throws InputError when missing, a directory or unreadable).
std::vector<unsigned char> read_file_bytes(const std::string& path);

// Reads dims and type from a name following `name_NXxNYxNZ_type.raw` (e.g.
// foot_256x256x256_uint8.raw). False when the name does not follow it.
bool raw_format_from_name(const std::string& path, RawFormat* format);

// --- For the format loaders (common/format_*.cpp) -------------------------------------------

// Stores `count` samples of `type` (byte order `endian`), each times slope plus inter, into
// volume.data (already sized densely: resize_dense), choosing volume.map: identity when every value is a whole
// number in int16's range, else a linear map onto the whole int16 range. Refuses NaN and
// infinities. Sets min_value and max_value.
void store_samples(Volume& volume, const unsigned char* bytes, size_t count, SampleType type,
                   Endian endian, double slope = 1.0, double inter = 0.0);

// The world direction of each file axis (columns: axis 0, 1, 2), in RAS (x right, y anterior,
// z superior) or LPS (x left, y posterior, z superior) patient coordinates.
enum class PatientFrame { ras, lps };
struct Directions {
    double axis[3][3];  // axis[a] = world direction of file axis a (any length but zero)
};

// Turns a volume whose file axes point along `directions` into the lab frame: i towards the
// patient's right, j from the face backwards, k from the crown down. Permutes the dims and
// spacing, flips axes, and sets volume.orientation to what was done.
void reorient_to_lab(Volume& volume, const Directions& directions, PatientFrame frame);

// The "key=value ..." line every loader prints.
std::string volume_line(const Volume& volume);

}  // namespace ctlab
