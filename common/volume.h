// volume.h: a CT volume in memory and the loaders for it.
//
// Layout convention used everywhere in ctlab: value(i, j, k) = cthead[k][j][i], i fastest,
// k the slice (k = 0 at the crown for CThead). In memory the volume is dense, exactly as the
// coursework indexes it: value(i, j, k) = data[(k*ny + j)*nx + i] = volume.at(i, j, k), for
// every volume (loaded, converted, the phantom, built by a test). No padding, no strides:
// speed tricks on the layout belong to part 3's own steps.
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
    std::vector<int16_t> data;                  // signed 16-bit CT values, dense (above)
    int16_t min_value = 0, max_value = 0;       // over the whole volume
    std::string name;                           // "phantom", or the file it came from
    ValueMap map;                               // volume value -> file value
    std::string format = "raw";                 // raw, nifti, nrrd, metaimage, dicom, phantom
    std::string orientation;                    // what was done to reach the lab frame ("" = none)

    // (k*ny + j)*nx + i: where voxel (i, j, k) is in data.
    size_t index(int i, int j, int k) const {
        return (static_cast<size_t>(k) * ny + static_cast<size_t>(j)) * nx +
               static_cast<size_t>(i);
    }
    int16_t at(int i, int j, int k) const { return data[index(i, j, k)]; }
    size_t voxel_count() const { return static_cast<size_t>(nx) * ny * nz; }
};

// Sizes data for nx*ny*nz values, every one 0: for loaders and tests that write the voxels.
// Call update_range when done.
void resize_dense(Volume& volume);

// The values as a file holds them, i fastest: (k*ny + j)*nx + i, that is volume.data.
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

// Sets min_value and max_value over the voxels. Every loader, the phantom and hand-built test
// volumes end with it.
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
// volume.data (already sized: resize_dense), choosing volume.map: identity when every value is a whole
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
