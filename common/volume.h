// volume.h: a CT volume in memory and the loaders for it.
//
// Layout convention used everywhere in ctlab: value(i, j, k) = data[(k*ny + j)*nx + i],
// i fastest, i.e. cthead[k][j][i]. k is the slice (k = 0 at the crown for CThead).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ctlab {

struct Volume {
    int nx = 0, ny = 0, nz = 0;                 // voxels along i, j, k
    double sx = 1.0, sy = 1.0, sz = 1.0;        // voxel spacing along i, j, k (CThead: 1, 1, 2)
    std::vector<int16_t> data;                  // signed 16-bit CT values, i fastest
    int16_t min_value = 0, max_value = 0;       // over the whole volume
    std::string name;                           // "phantom", or the file it came from

    int16_t at(int i, int j, int k) const {
        return data[(static_cast<size_t>(k) * ny + j) * nx + i];
    }
    size_t voxel_count() const { return static_cast<size_t>(nx) * ny * nz; }
};

// CThead facts: 256 x 256 x 113, signed 16-bit little-endian, no header.
constexpr int cthead_nx = 256, cthead_ny = 256, cthead_nz = 113;
constexpr double cthead_sx = 1.0, cthead_sy = 1.0, cthead_sz = 2.0;
constexpr size_t cthead_bytes = size_t(cthead_nx) * cthead_ny * cthead_nz * 2;  // 14,811,136

// Refuse volumes above this many voxels before allocating anything (2^31 voxels = 4 GiB).
constexpr uint64_t max_voxels = uint64_t(1) << 31;

enum class Endian { little, big };

struct RawFormat {
    int nx = 0, ny = 0, nz = 0;
    Endian endian = Endian::little;
    double sx = 1.0, sy = 1.0, sz = 1.0;
};

// Sets min_value and max_value from data.
void update_range(Volume& volume);

// Builds a volume from raw bytes (validated: size must be exactly nx*ny*nz*2).
Volume volume_from_bytes(const std::vector<unsigned char>& bytes, const RawFormat& format,
                         const std::string& name);

// Loads a raw int16 file. Throws InputError naming the file and the problem.
Volume load_raw(const std::string& path, const RawFormat& format);

// Loads the CThead file: exact size, little-endian. Throws InputError.
Volume load_cthead(const std::string& path);

// Reads a whole file (throws InputError when missing, a directory or unreadable).
std::vector<unsigned char> read_file_bytes(const std::string& path);

}  // namespace ctlab
