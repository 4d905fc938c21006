// volume.cpp: raw and CThead loading. All checks happen before any large allocation.
#include "volume.h"
#include <sys/stat.h>
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include "error.h"

namespace ctlab {

void update_range(Volume& volume) {
    if (volume.data.empty()) return;
    const auto [low, high] = std::minmax_element(volume.data.begin(), volume.data.end());
    volume.min_value = *low;
    volume.max_value = *high;
}

std::vector<unsigned char> read_file_bytes(const std::string& path) {
    struct stat info {};
    if (stat(path.c_str(), &info) != 0) {
        throw InputError("cannot open '" + path + "': " + std::strerror(errno));
    }
    if (S_ISDIR(info.st_mode)) throw InputError("'" + path + "' is a folder, not a file");
    // A device such as /dev/zero never ends: only ordinary files are read.
    if (!S_ISREG(info.st_mode)) throw InputError("'" + path + "' is not an ordinary file");
    std::FILE* file = std::fopen(path.c_str(), "rb");
    if (!file) throw InputError("cannot open '" + path + "': " + std::strerror(errno));
    std::vector<unsigned char> bytes;
    bytes.reserve(size_t(info.st_size));  // one allocation, not a doubling series
    unsigned char buffer[1 << 16];
    size_t count;
    while ((count = std::fread(buffer, 1, sizeof buffer, file)) > 0) {
        bytes.insert(bytes.end(), buffer, buffer + count);
    }
    const bool failed = std::ferror(file);
    std::fclose(file);
    if (failed) throw InputError("cannot read '" + path + "'");
    return bytes;
}

static std::string dims_text(const RawFormat& format) {
    return std::to_string(format.nx) + "x" + std::to_string(format.ny) + "x" +
           std::to_string(format.nz);
}

// Validates dims and spacing and returns the exact byte count (int16, no header).
static uint64_t expected_bytes(const RawFormat& format) {
    if (format.nx < 1 || format.ny < 1 || format.nz < 1) {
        throw InputError("--dims must be at least 1,1,1, got " + dims_text(format));
    }
    // Checked after each product: three ints up to 2^31 could wrap 64 bits (2^22 cubed = 0).
    const uint64_t slice = uint64_t(format.nx) * uint64_t(format.ny);
    const uint64_t voxels = slice > max_voxels ? max_voxels + 1 : slice * uint64_t(format.nz);
    if (voxels > max_voxels) {
        throw InputError("--dims " + dims_text(format) + " is over the limit of " +
                         std::to_string(max_voxels) + " voxels");
    }
    if (!(format.sx > 0 && format.sy > 0 && format.sz > 0)) {
        throw InputError("--spacing must be positive in every direction");
    }
    return voxels * 2;
}

// "1 byte", "48 bytes".
static std::string byte_count(uint64_t count) {
    return std::to_string(count) + (count == 1 ? " byte" : " bytes");
}

// "'F' has 48 bytes, expected exactly 72 for 4x3x3 int16 voxels".
static std::string size_mismatch(const std::string& name, uint64_t size, uint64_t expected,
                                 const std::string& what) {
    return "'" + name + "' has " + byte_count(size) + ", expected exactly " +
           std::to_string(expected) + " for " + what;
}

Volume volume_from_bytes(const std::vector<unsigned char>& bytes, const RawFormat& format,
                         const std::string& name) {
    const uint64_t expected = expected_bytes(format);
    if (bytes.size() != expected) {
        throw InputError(size_mismatch(name, bytes.size(), expected,
                                       dims_text(format) + " int16 voxels"));
    }
    const size_t voxels = expected / 2;
    Volume volume;
    volume.nx = format.nx;
    volume.ny = format.ny;
    volume.nz = format.nz;
    volume.sx = format.sx;
    volume.sy = format.sy;
    volume.sz = format.sz;
    volume.name = name;
    volume.data.resize(voxels);
    // Assemble each value from its two bytes explicitly: correct on any host byte order.
    const bool little = format.endian == Endian::little;
    for (size_t n = 0; n < voxels; ++n) {
        const unsigned low = bytes[2 * n + (little ? 0 : 1)];
        const unsigned high = bytes[2 * n + (little ? 1 : 0)];
        volume.data[n] = static_cast<int16_t>(static_cast<uint16_t>(low | (high << 8)));
    }
    update_range(volume);
    return volume;
}

// Size first (stat), so a wrong file is refused without reading it.
static void check_size(const std::string& path, uint64_t expected, const std::string& what) {
    struct stat info {};
    if (stat(path.c_str(), &info) != 0) {
        throw InputError("cannot open '" + path + "': " + std::strerror(errno));
    }
    if (S_ISDIR(info.st_mode)) throw InputError("'" + path + "' is a folder, not a file");
    if (uint64_t(info.st_size) != expected) {
        throw InputError(size_mismatch(path, uint64_t(info.st_size), expected, what));
    }
}

Volume load_raw(const std::string& path, const RawFormat& format) {
    check_size(path, expected_bytes(format), dims_text(format) + " int16 voxels");
    return volume_from_bytes(read_file_bytes(path), format, path);
}

Volume load_cthead(const std::string& path) {
    check_size(path, cthead_bytes, "CThead (256x256x113 int16)");
    RawFormat format;
    format.nx = cthead_nx;
    format.ny = cthead_ny;
    format.nz = cthead_nz;
    format.sx = cthead_sx;
    format.sy = cthead_sy;
    format.sz = cthead_sz;
    return volume_from_bytes(read_file_bytes(path), format, path);
}

}  // namespace ctlab
