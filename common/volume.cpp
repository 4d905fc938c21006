// volume.cpp: raw and CThead loading, sample types, value maps and the turn into the lab frame.
// All checks happen before any large allocation; a raw file is read straight into the volume.
#include "volume.h"
#include <sys/stat.h>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <stdexcept>
#include "error.h"
#include "file_input.h"
#include "samples.h"

namespace ctlab {

// --- Layout (volume.h) ----------------------------------------------------------------------

void resize_dense(Volume& volume) {
    volume.data.assign(volume.voxel_count(), 0);
}

std::vector<int16_t> dense_values(const Volume& volume) { return volume.data; }

void update_range(Volume& volume) {
    if (volume.data.empty()) return;
    // A plain loop of min and max: std::minmax_element branches on every value, and
    // update_range took 15-19 ms on the phantom with it, 6.4 ms with this loop.
    int16_t low = volume.data[0], high = volume.data[0];
    for (const int16_t value : volume.data) {
        low = std::min(low, value);
        high = std::max(high, value);
    }
    volume.min_value = low;
    volume.max_value = high;
}

// --- Sample types ------------------------------------------------------------------------

struct TypeInfo {
    SampleType type;
    const char* name;
    size_t size;
};
static const TypeInfo type_table[] = {
    {SampleType::uint8, "uint8", 1},     {SampleType::int8, "int8", 1},
    {SampleType::uint16, "uint16", 2},   {SampleType::int16, "int16", 2},
    {SampleType::uint32, "uint32", 4},   {SampleType::int32, "int32", 4},
    {SampleType::float32, "float32", 4}, {SampleType::float64, "float64", 8},
};

const char* sample_type_name(SampleType type) {
    for (const TypeInfo& info : type_table) {
        if (info.type == type) return info.name;
    }
    return "?";
}

size_t sample_size(SampleType type) {
    for (const TypeInfo& info : type_table) {
        if (info.type == type) return info.size;
    }
    return 1;
}

bool parse_sample_type(const std::string& name, SampleType* type) {
    for (const TypeInfo& info : type_table) {
        if (name == info.name) {
            *type = info.type;
            return true;
        }
    }
    // The collections' other spellings.
    if (name == "float") *type = SampleType::float32;
    else if (name == "double") *type = SampleType::float64;
    else if (name == "uchar") *type = SampleType::uint8;
    else if (name == "ushort") *type = SampleType::uint16;
    else if (name == "short") *type = SampleType::int16;
    else return false;
    return true;
}

static bool host_is_little() {
    const uint16_t probe = 1;
    unsigned char first;
    std::memcpy(&first, &probe, 1);
    return first == 1;
}

// Sample n of a buffer as a double, whatever its type and byte order.
template <typename T>
static inline double sample_value(const unsigned char* bytes, size_t n, bool swap) {
    unsigned char copy[sizeof(T)];
    std::memcpy(copy, bytes + n * sizeof(T), sizeof(T));
    if (swap) std::reverse(copy, copy + sizeof(T));
    T value;
    std::memcpy(&value, copy, sizeof(T));
    return double(value);
}

// Calls body(n, value) for every sample.
template <typename Body>
static void for_each_sample(const unsigned char* bytes, size_t count, SampleType type,
                            Endian endian, Body body) {
    const bool swap = (endian == Endian::little) != host_is_little();
    switch (type) {
        case SampleType::uint8:
            for (size_t n = 0; n < count; ++n) body(n, double(bytes[n]));
            break;
        case SampleType::int8:
            for (size_t n = 0; n < count; ++n) body(n, double(int8_t(bytes[n])));
            break;
        case SampleType::uint16:
            for (size_t n = 0; n < count; ++n) body(n, sample_value<uint16_t>(bytes, n, swap));
            break;
        case SampleType::int16:
            for (size_t n = 0; n < count; ++n) body(n, sample_value<int16_t>(bytes, n, swap));
            break;
        case SampleType::uint32:
            for (size_t n = 0; n < count; ++n) body(n, sample_value<uint32_t>(bytes, n, swap));
            break;
        case SampleType::int32:
            for (size_t n = 0; n < count; ++n) body(n, sample_value<int32_t>(bytes, n, swap));
            break;
        case SampleType::float32:
            for (size_t n = 0; n < count; ++n) body(n, sample_value<float>(bytes, n, swap));
            break;
        case SampleType::float64:
            for (size_t n = 0; n < count; ++n) body(n, sample_value<double>(bytes, n, swap));
            break;
    }
}

void scan_samples(ValueRange& range, const unsigned char* bytes, size_t count,
                  SampleType type, Endian endian, double slope, double inter) {
    for_each_sample(bytes, count, type, endian, [&](size_t, double value) {
        const double file_value = value * slope + inter;
        if (!std::isfinite(file_value)) {
            range.finite = false;
            return;
        }
        range.low = std::min(range.low, file_value);
        range.high = std::max(range.high, file_value);
        if (range.whole && file_value != std::floor(file_value)) range.whole = false;
    });
}

// The map from int16 volume values to file values (see ValueMap).
ValueMap choose_map(const ValueRange& range, const std::string& name) {
    if (!range.finite) throw InputError("'" + name + "' holds NaN or infinite values");
    ValueMap map;
    if (!(range.low <= range.high)) return map;  // no samples
    constexpr double lowest = -32768, highest = 32767, levels = 65535;
    if (range.whole && range.low >= lowest && range.high <= highest) return map;
    if (range.whole && range.high - range.low <= levels) {
        map.offset = range.low - lowest;  // whole numbers shifted: nothing lost
        return map;
    }
    if (range.high == range.low) {
        map.offset = range.low;
        return map;
    }
    // Divided before subtracting: high - low may overflow a double (floats near +-1e308).
    map.scale = range.high / levels - range.low / levels;
    // The two quotients can round to one double although high > low: values a few units in
    // the last place apart, or subnormal values only (found by make fuzz: 0 and 1.4e-321).
    // Then the difference first; where that underflows too, the smallest double: every
    // subnormal is a whole multiple of it, so they map to whole levels without loss.
    if (map.scale == 0)
        map.scale = std::max((range.high - range.low) / levels,
                             std::numeric_limits<double>::denorm_min());
    map.offset = range.low - lowest * map.scale;
    if (!std::isfinite(map.scale) || !(map.scale > 0) || !std::isfinite(map.offset)) {
        throw InputError("'" + name + "' has values over too wide a range to map into int16");
    }
    return map;
}

void convert_samples(int16_t* out, const unsigned char* bytes, size_t count,
                     SampleType type, Endian endian, double slope, double inter,
                     const ValueMap& map) {
    for_each_sample(bytes, count, type, endian, [&](size_t n, double value) {
        const double mapped = std::round(map.to_volume(value * slope + inter));
        // NaN was refused by the scan; a NaN here (a value changed since) gives the lowest.
        out[n] = mapped == mapped ? int16_t(std::clamp(mapped, -32768.0, 32767.0)) : int16_t(-32768);
    });
}

void store_samples(Volume& volume, const unsigned char* bytes, size_t count, SampleType type,
                   Endian endian, double slope, double inter) {
    ValueRange range;
    scan_samples(range, bytes, count, type, endian, slope, inter);
    volume.map = choose_map(range, volume.name);
    convert_samples(volume.data.data(), bytes, count, type, endian, slope, inter, volume.map);
    update_range(volume);
}

// --- Sizes and memory ----------------------------------------------------------------------

// Free memory in bytes (MemAvailable), or 0 when unknown.
static uint64_t available_memory() {
    std::ifstream meminfo("/proc/meminfo");
    std::string key;
    uint64_t kib = 0;
    while (meminfo >> key) {
        if (key == "MemAvailable:" && meminfo >> kib) return kib * 1024;
        meminfo.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
    }
    return 0;
}

static std::string dims_text(uint64_t nx, uint64_t ny, uint64_t nz) {
    return std::to_string(nx) + "x" + std::to_string(ny) + "x" + std::to_string(nz);
}

uint64_t check_volume_size(const std::string& what, uint64_t nx, uint64_t ny, uint64_t nz,
                           uint64_t bytes_per_voxel) {
    if (nx < 1 || ny < 1 || nz < 1) {
        throw InputError(what + " must be at least 1,1,1, got " + dims_text(nx, ny, nz));
    }
    // Checked after each product: three numbers up to 2^31 could wrap 64 bits (2^22 cubed = 0).
    const uint64_t slice = nx > max_voxels || ny > max_voxels ? max_voxels + 1 : nx * ny;
    const uint64_t voxels = slice > max_voxels || nz > max_voxels ? max_voxels + 1 : slice * nz;
    if (voxels > max_voxels) {
        throw InputError(what + " " + dims_text(nx, ny, nz) + " is over the limit of " +
                         std::to_string(max_voxels) + " voxels (2 GiB of int16)");
    }
    const uint64_t needed = voxels * bytes_per_voxel;
    const uint64_t available = available_memory();
    if (available != 0 && needed > available) {
        throw InputError(what + " " + dims_text(nx, ny, nz) + " needs " +
                         std::to_string(needed >> 20) + " MiB of memory, only " +
                         std::to_string(available >> 20) + " MiB are free");
    }
    return voxels;
}

std::vector<unsigned char> read_file_bytes(const std::string& path) {
    // Opened without blocking and checked with fstat first (common/file_input.cpp): a FIFO,
    // a device such as /dev/zero or a folder is refused, never read.
    return read_small_file(path, std::numeric_limits<uint64_t>::max());
}

static std::string dims_text(const RawFormat& format) {
    return std::to_string(format.nx) + "x" + std::to_string(format.ny) + "x" +
           std::to_string(format.nz);
}

// Validates dims, memory and spacing and returns the exact byte count (no header).
static uint64_t expected_bytes(const RawFormat& format) {
    if (format.nx < 1 || format.ny < 1 || format.nz < 1) {
        throw InputError("--dims must be at least 1,1,1, got " + dims_text(format));
    }
    const uint64_t voxels = check_volume_size("--dims", uint64_t(format.nx),
                                              uint64_t(format.ny), uint64_t(format.nz));
    if (!(format.sx > 0 && format.sy > 0 && format.sz > 0)) {
        throw InputError("--spacing must be positive in every direction");
    }
    return voxels * sample_size(format.type);
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

static std::string voxels_text(const RawFormat& format) {
    return dims_text(format) + " " + sample_type_name(format.type) + " voxels";
}

static Volume empty_volume(const RawFormat& format, const std::string& name) {
    Volume volume;
    volume.nx = format.nx;
    volume.ny = format.ny;
    volume.nz = format.nz;
    volume.sx = format.sx;
    volume.sy = format.sy;
    volume.sz = format.sz;
    volume.name = name;
    volume.format = "raw";
    return volume;
}

Volume volume_from_bytes(const std::vector<unsigned char>& bytes, const RawFormat& format,
                         const std::string& name) {
    const uint64_t expected = expected_bytes(format);
    if (bytes.size() != expected) {
        throw InputError(size_mismatch(name, bytes.size(), expected, voxels_text(format)));
    }
    Volume volume = empty_volume(format, name);
    resize_dense(volume);
    store_samples(volume, bytes.data(), volume.data.size(), format.type, format.endian);
    return volume;
}

// Size first (fstat of the open file), so a wrong file is refused without reading it.
static void check_size(const InputFile& file, uint64_t expected, const std::string& what) {
    if (file.size() != expected) {
        throw InputError(size_mismatch(file.path(), file.size(), expected, what));
    }
}

Volume load_raw(const std::string& path, const RawFormat& format) {
    const uint64_t bytes = expected_bytes(format);
    const InputFile file(path);  // a FIFO, a device or a folder is refused here
    check_size(file, bytes, voxels_text(format));
    Volume volume = empty_volume(format, path);
    // int16 straight into the volume; other types in two passes through a 1 MiB buffer.
    const std::unique_ptr<ByteStream> stream = ByteStream::plain(file, 0);
    stream->prefix = "'" + path + "': ";
    read_volume_samples(volume, *stream, format.type, format.endian);
    return volume;
}

Volume load_cthead(const std::string& path) {
    check_size(InputFile(path), cthead_bytes, "CThead (256x256x113 int16)");
    RawFormat format;
    format.nx = cthead_nx;
    format.ny = cthead_ny;
    format.nz = cthead_nz;
    format.sx = cthead_sx;
    format.sy = cthead_sy;
    format.sz = cthead_sz;
    return load_raw(path, format);
}

bool raw_format_from_name(const std::string& path, RawFormat* format) {
    const size_t slash = path.find_last_of('/');
    std::string stem = path.substr(slash == std::string::npos ? 0 : slash + 1);
    const size_t dot = stem.rfind('.');
    if (dot == std::string::npos || stem.substr(dot) != ".raw") return false;
    stem.resize(dot);
    // ..._NXxNYxNZ_type
    const size_t type_start = stem.rfind('_');
    if (type_start == std::string::npos || type_start == 0) return false;
    SampleType type;
    if (!parse_sample_type(stem.substr(type_start + 1), &type)) return false;
    const size_t dims_start = stem.rfind('_', type_start - 1);
    const std::string dims =
        stem.substr(dims_start == std::string::npos ? 0 : dims_start + 1,
                    type_start - (dims_start == std::string::npos ? 0 : dims_start + 1));
    long values[3];
    size_t position = 0;
    for (int n = 0; n < 3; ++n) {
        size_t end = position;
        while (end < dims.size() && dims[end] >= '0' && dims[end] <= '9') ++end;
        if (end == position || end - position > 9) return false;
        values[n] = std::stol(dims.substr(position, end - position));
        if (values[n] < 1) return false;
        if (n < 2) {
            if (end >= dims.size() || dims[end] != 'x') return false;
            position = end + 1;
        } else if (end != dims.size()) {
            return false;
        }
    }
    format->nx = int(values[0]);
    format->ny = int(values[1]);
    format->nz = int(values[2]);
    format->type = type;
    return true;
}

// --- Orientation ---------------------------------------------------------------------------

void reorient_to_lab(Volume& volume, const Directions& directions, PatientFrame frame) {
    // The lab axes in RAS: i towards the right (+x), j backwards (-y), k downwards (-z).
    const double lab[3][3] = {{1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    double unit[3][3];
    for (int a = 0; a < 3; ++a) {
        double d[3] = {directions.axis[a][0], directions.axis[a][1], directions.axis[a][2]};
        if (frame == PatientFrame::lps) {
            d[0] = -d[0];
            d[1] = -d[1];
        }
        const double length = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (!(length > 0) || !std::isfinite(length)) {
            throw InputError("'" + volume.name + "': the direction of file axis " +
                             std::to_string(a + 1) + " is zero or not a number");
        }
        for (int w = 0; w < 3; ++w) unit[a][w] = d[w] / length;
    }
    // The permutation file axis a -> lab axis to[a] that follows the directions best.
    static const int permutations[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                           {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    int best = 0;
    double best_score = -1;
    for (int p = 0; p < 6; ++p) {
        double score = 0;
        for (int a = 0; a < 3; ++a) {
            const double* l = lab[permutations[p][a]];
            score += std::fabs(unit[a][0] * l[0] + unit[a][1] * l[1] + unit[a][2] * l[2]);
        }
        if (score > best_score) {
            best_score = score;
            best = p;
        }
    }
    const int* to = permutations[best];
    bool flip[3];
    for (int a = 0; a < 3; ++a) {
        const double* l = lab[to[a]];
        flip[a] = unit[a][0] * l[0] + unit[a][1] * l[1] + unit[a][2] * l[2] < 0;
    }

    // What was done, in words.
    static const char axis_name[3] = {'i', 'j', 'k'};
    std::string text;
    if (to[0] != 0 || to[1] != 1 || to[2] != 2) {
        text = std::string("axes i,j,k became ") + axis_name[to[0]] + "," + axis_name[to[1]] +
               "," + axis_name[to[2]];
    }
    std::string flipped;
    for (int l = 0; l < 3; ++l) {
        for (int a = 0; a < 3; ++a) {
            if (to[a] == l && flip[a]) flipped += std::string(flipped.empty() ? "" : ",") + axis_name[l];
        }
    }
    if (!flipped.empty()) text += (text.empty() ? "" : ", ") + std::string("flipped ") + flipped;
    if (text.empty()) text = "as stored";
    text += frame == PatientFrame::ras ? " from RAS" : " from LPS";
    if (best_score < 3 - 1e-3) text += " (oblique: nearest axes)";
    volume.orientation = text;
    if (text.rfind("as stored", 0) == 0) return;

    // Reorder: lab axis l reads file axis from[l], backwards when flipped.
    const int file_n[3] = {volume.nx, volume.ny, volume.nz};
    const double file_s[3] = {volume.sx, volume.sy, volume.sz};
    const int64_t file_stride[3] = {1, int64_t(volume.nx), int64_t(volume.nx) * volume.ny};
    int lab_n[3];
    double lab_s[3];
    int64_t stride[3];
    int64_t base = 0;
    for (int a = 0; a < 3; ++a) {
        lab_n[to[a]] = file_n[a];
        lab_s[to[a]] = file_s[a];
        stride[to[a]] = flip[a] ? -file_stride[a] : file_stride[a];
        if (flip[a]) base += int64_t(file_n[a] - 1) * file_stride[a];
    }
    std::vector<int16_t> out(volume.voxel_count());
    size_t n = 0;
    for (int k = 0; k < lab_n[2]; ++k) {
        for (int j = 0; j < lab_n[1]; ++j) {
            const int64_t row = base + k * stride[2] + j * stride[1];
            for (int i = 0; i < lab_n[0]; ++i) out[n++] = volume.data[size_t(row + i * stride[0])];
        }
    }
    volume.data.swap(out);
    volume.nx = lab_n[0];
    volume.ny = lab_n[1];
    volume.nz = lab_n[2];
    volume.sx = lab_s[0];
    volume.sy = lab_s[1];
    volume.sz = lab_s[2];
}

std::string volume_line(const Volume& volume) {
    char text[512];
    std::snprintf(text, sizeof text, " dims=%dx%dx%d spacing=%g,%g,%g min=%d max=%d",
                  volume.nx, volume.ny, volume.nz, volume.sx, volume.sy, volume.sz,
                  volume.min_value, volume.max_value);
    std::string line = "volume=" + printable(volume.name) + text;  // a name is any bytes
    if (volume.format != "raw" && volume.format != "phantom") line += " format=" + volume.format;
    if (!volume.map.identity()) {
        std::snprintf(text, sizeof text, " map=file=%.9g*v%+.9g", volume.map.scale,
                      volume.map.offset);
        line += text;
    }
    if (!volume.orientation.empty()) line += " orientation=" + volume.orientation;
    return line;
}

}  // namespace ctlab
