// targets.cpp: the fuzz targets (see targets.h). Each decides from the input alone whether
// the code under test must accept it or refuse it, and checks that it did.
#include "targets.h"
#include <sys/stat.h>
#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <zlib.h>
#include "common/args.h"
#include "tools/compare.h"
#include "common/error.h"
#include "common/formats.h"
#include "common/image.h"
#include "common/transfer_function.h"
#include "common/volume.h"

// The targets' own checking loops, run over every voxel of a CThead, need no coverage
// feedback: without it they run many times faster in the fuzzer (clang only).
#if defined(__clang__)
#define NOT_FUZZED __attribute__((no_sanitize("coverage")))
#else
#define NOT_FUZZED
#endif

namespace ctlab_fuzz {

namespace {

// Checks a promise; the text says which one. (A literal stays a literal: no string is built
// for a promise kept, in loops that run for every voxel or table entry.)
void require(bool kept, const char* promise) {
    if (!kept) throw Broken(promise);
}
void require(bool kept, const std::string& promise) {
    if (!kept) throw Broken(promise);
}

// What every refusal must look like: one line, something said.
void check_message(const ctlab::InputError& error, const std::string& starts_with = "") {
    const std::string message = error.what();
    require(!message.empty(), "an InputError with an empty message");
    require(message.find_first_of("\n\r") == std::string::npos,
            "an InputError message over more than one line: " + message);
    require(message.rfind(starts_with, 0) == 0,
            "an InputError message not starting with '" + starts_with + "': " + message);
}

// The next byte of the input, 0 when it is used up.
struct Bytes {
    const uint8_t* data;
    size_t size;
    size_t next = 0;
    uint8_t byte() { return next < size ? data[next++] : 0; }
    int32_t int32() {
        uint32_t value = 0;
        for (int n = 0; n < 4; ++n) value |= uint32_t(byte()) << (8 * n);
        return int32_t(value);
    }
    double spacing() { return int8_t(byte()) / 16.0; }  // -8 .. 7.9375, zero and negatives too
    std::vector<unsigned char> rest() const {
        return next < size ? std::vector<unsigned char>(data + next, data + size)
                           : std::vector<unsigned char>();
    }
};

NOT_FUZZED int16_t voxel_value(const std::vector<unsigned char>& bytes, size_t n, ctlab::Endian endian) {
    const unsigned low = bytes[2 * n + (endian == ctlab::Endian::little ? 0 : 1)];
    const unsigned high = bytes[2 * n + (endian == ctlab::Endian::little ? 1 : 0)];
    return int16_t(uint16_t(low | (high << 8)));
}

// A loaded volume against the bytes it came from: size, every value, min and max.
NOT_FUZZED void check_volume(const ctlab::Volume& volume, const ctlab::RawFormat& format,
                  const std::vector<unsigned char>& bytes) {
    require(volume.nx == format.nx && volume.ny == format.ny && volume.nz == format.nz,
            "the volume's dims differ from the format's");
    require(volume.sx == format.sx && volume.sy == format.sy && volume.sz == format.sz,
            "the volume's spacing differs from the format's");
    require(volume.data.size() == volume.voxel_count(), "data size != nx*ny*nz (dense)");
    const std::vector<int16_t> values = ctlab::dense_values(volume);
    require(values.size() * 2 == bytes.size(), "voxel count != bytes / 2");
    int low = 32767, high = -32768;
    for (size_t n = 0; n < values.size(); ++n) {
        const int16_t value = voxel_value(bytes, n, format.endian);
        if (values[n] != value) throw Broken("voxel " + std::to_string(n) + " is wrong");
        low = std::min(low, int(value));
        high = std::max(high, int(value));
    }
    require(volume.min_value == low && volume.max_value == high, "wrong min or max");
    // The last voxel through at(): the index arithmetic reaches the end exactly.
    require(volume.at(volume.nx - 1, volume.ny - 1, volume.nz - 1) == values.back(),
            "at(nx-1, ny-1, nz-1) is not the last value");
}

// Whether dims and spacing are valid, as the loader documents it (volume.h, args.h).
bool valid_format(const ctlab::RawFormat& format) {
    if (format.nx < 1 || format.ny < 1 || format.nz < 1) return false;
    const double voxels = double(format.nx) * format.ny * format.nz;  // exact below 2^53
    return voxels <= double(ctlab::max_voxels) && format.sx > 0 && format.sy > 0 &&
           format.sz > 0;
}

// A folder of this process for the CThead target's files: in memory (/dev/shm) when it can.
std::string scratch_folder() {
    static std::string folder;
    if (!folder.empty()) return folder;
    struct stat info {};
    const char* base = stat("/dev/shm", &info) == 0 && S_ISDIR(info.st_mode) &&
                               access("/dev/shm", W_OK) == 0
                           ? "/dev/shm"
                           : (std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp");
    folder = std::string(base) + "/ctlab_fuzz_" + std::to_string(getpid());
    mkdir(folder.c_str(), 0700);
    mkdir((folder + "/a_folder").c_str(), 0700);
    std::atexit([] {
        std::remove((folder + "/CThead").c_str());
        rmdir((folder + "/a_folder").c_str());
        rmdir(folder.c_str());
    });
    return folder;
}

// Writes `bytes`, then extends or cuts the file to `size` bytes (a sparse tail reads as
// zeros: the size is all the loader may look at before it refuses the file).
void write_file(const std::string& path, const std::vector<unsigned char>& bytes, size_t size) {
    std::FILE* file = std::fopen(path.c_str(), "wb");
    require(file != nullptr, "cannot write the scratch file " + path);
    const size_t written = std::fwrite(bytes.data(), 1, bytes.size(), file);
    const bool sized = std::fflush(file) == 0 && ftruncate(fileno(file), off_t(size)) == 0;
    std::fclose(file);
    require(written == bytes.size() && sized, "cannot write the scratch file " + path);
}

// `pattern` repeated to `size` bytes (zeros when it is empty). Doubling copies: a loop of
// two-byte copies would take seconds under the sanitizers.
NOT_FUZZED std::vector<unsigned char> repeated(const std::vector<unsigned char>& pattern, size_t size) {
    std::vector<unsigned char> bytes(size);
    if (pattern.empty() || size == 0) return bytes;
    size_t filled = std::min(pattern.size(), size);
    std::memcpy(bytes.data(), pattern.data(), filled);
    while (filled < size) {
        const size_t copy = std::min(filled, size - filled);
        std::memcpy(bytes.data() + filled, bytes.data(), copy);
        filled += copy;
    }
    return bytes;
}

}  // namespace

void raw_volume(const uint8_t* data, size_t size) {
    // Byte 0: bit 0 big-endian; bit 1 dims as three int32 (any value: zero, negative, huge);
    // bit 2 dims that fit the data (nz from the size); bit 3 spacing from three bytes.
    Bytes input{data, size};
    const uint8_t flags = input.byte();
    ctlab::RawFormat format;
    format.endian = flags & 1 ? ctlab::Endian::big : ctlab::Endian::little;
    if (flags & 2) {
        format.nx = input.int32();
        format.ny = input.int32();
        format.nz = input.int32();
    } else {
        format.nx = input.byte();
        format.ny = input.byte();
        format.nz = input.byte();
    }
    if (flags & 8) {
        format.sx = input.spacing();
        format.sy = input.spacing();
        format.sz = input.spacing();
    }
    std::vector<unsigned char> bytes = input.rest();
    if ((flags & 4) && format.nx > 0 && format.ny > 0) {
        const size_t slice = size_t(format.nx) * size_t(format.ny);
        format.nz = int(std::min<size_t>(bytes.size() / 2 / slice, 1 << 20));
        bytes.resize(std::min(bytes.size(), slice * size_t(format.nz) * 2));
    }
    const bool valid = valid_format(format) &&
                       bytes.size() == 2 * size_t(format.nx) * format.ny * format.nz;
    try {
        const ctlab::Volume volume = ctlab::volume_from_bytes(bytes, format, "fuzz.raw");
        require(valid, "volume_from_bytes accepted invalid dims, spacing or size");
        check_volume(volume, format, bytes);
    } catch (const ctlab::InputError& error) {
        check_message(error);
        require(!valid, std::string("volume_from_bytes refused a valid input: ") + error.what());
    }
}

void cthead_file(const uint8_t* data, size_t size) {
    // Byte 0: bits 0-1 the file size: 0 the rest of the input as it is, 1 exactly CThead's
    // (the rest repeated), 2 one byte short, 3 one byte long; bit 2 --endian big; bit 3
    // --spacing from three bytes; bit 4 the path is a folder; bit 5 the path is missing.
    Bytes input{data, size};
    const uint8_t flags = input.byte();
    ctlab::Options options;
    options.has_endian = (flags & 4) != 0;
    options.raw.endian = options.has_endian ? ctlab::Endian::big : ctlab::Endian::little;
    ctlab::RawFormat expected;
    expected.nx = ctlab::cthead_nx;
    expected.ny = ctlab::cthead_ny;
    expected.nz = ctlab::cthead_nz;
    expected.sx = ctlab::cthead_sx;
    expected.sy = ctlab::cthead_sy;
    expected.sz = ctlab::cthead_sz;
    expected.endian = options.raw.endian;
    if (flags & 8) {
        options.has_spacing = true;
        expected.sx = options.raw.sx = input.spacing();
        expected.sy = options.raw.sy = input.spacing();
        expected.sz = options.raw.sz = input.spacing();
    }
    // Only an exact-size file is read: the others are written as the pattern, then cut or
    // extended to their size.
    std::vector<unsigned char> bytes = input.rest();
    size_t file_size = bytes.size();
    const int size_mode = flags & 3;
    if (size_mode == 1) bytes = repeated(bytes, ctlab::cthead_bytes);
    if (size_mode != 0) file_size = ctlab::cthead_bytes - (size_mode == 2) + (size_mode == 3);
    const std::string folder = scratch_folder();
    const std::string file = folder + "/CThead";
    options.volume = flags & 16 ? folder + "/a_folder" : flags & 32 ? folder + "/missing" : file;
    write_file(file, bytes, file_size);
    const bool valid = !(flags & 48) && file_size == ctlab::cthead_bytes &&
                       expected.sx > 0 && expected.sy > 0 && expected.sz > 0;
    try {
        const ctlab::Volume volume = ctlab::load_volume(options);
        require(valid, "load_volume accepted a wrong file or spacing");
        check_volume(volume, expected, bytes);
    } catch (const ctlab::InputError& error) {
        check_message(error);
        require(!valid, std::string("load_volume refused a valid CThead: ") + error.what());
    }
}

void transfer_function(const uint8_t* data, size_t size) {
    const std::string source = "fuzz.tf";
    const std::string text(reinterpret_cast<const char*>(data), size);
    // The same text for a float volume (a scale map) and a uint16 one (a shift): FROM and TO
    // in file units may be decimals and clamp to int16; the ranges keep their order and can
    // only narrow to empty, never reverse. Before the identity's parse, which may refuse a
    // decimal that a map takes.
    ctlab::ValueMap scale, shift;
    scale.scale = 3.5 / 65535;
    scale.offset = 1.25;
    shift.offset = 40000;
    for (const ctlab::ValueMap& map : {scale, shift}) {
        ctlab::TransferFunction mapped;
        try {
            mapped = ctlab::parse_transfer_function(text, source, map);
        } catch (const ctlab::InputError& error) {
            check_message(error, source + ":");
            continue;
        }
        for (size_t n = 0; n < mapped.ranges.size(); ++n) {
            const ctlab::TfRange& range = mapped.ranges[n];
            require(range.from >= ctlab::lowest_ct_value && range.to <= ctlab::ct_value_end,
                    "a mapped range outside the int16 values");
            require(range.from <= range.to, "a reversed mapped range");
            if (n > 0) require(range.from >= mapped.ranges[n - 1].to, "mapped ranges overlap");
        }
    }
    ctlab::TransferFunction tf;
    try {
        tf = ctlab::parse_transfer_function(text, source);
    } catch (const ctlab::InputError& error) {
        check_message(error, source + ":");
        const std::string after = std::string(error.what()).substr(source.size() + 1);
        require(!after.empty() && after[0] >= '1' && after[0] <= '9',
                std::string("no line number in: ") + error.what());
        return;
    }
    // Sorted, not overlapping, inside the int16 values, colours and opacities in 0..1.
    auto unit = [](float v) { return std::isfinite(v) && v >= 0 && v <= 1; };
    auto unit_rgba = [&](const ctlab::Rgba& c) {
        return unit(c.r) && unit(c.g) && unit(c.b) && unit(c.a);
    };
    for (size_t n = 0; n < tf.ranges.size(); ++n) {
        const ctlab::TfRange& range = tf.ranges[n];
        require(range.from >= ctlab::lowest_ct_value && range.to <= ctlab::ct_value_end,
                "a range outside the int16 values");
        require(range.from < range.to, "an empty or reversed range");
        require(unit_rgba(range.start) && unit_rgba(range.end), "a colour outside 0..1");
        require(range.line >= 1, "a range without its line");
        if (n > 0) {
            require(range.from >= tf.ranges[n - 1].to, "overlapping or unsorted ranges");
            require(range.line > tf.ranges[n - 1].line, "ranges out of line order");
        }
        if (!range.label.empty()) {
            require(ctlab::find_range(tf, range.label) == &range, "a label used twice");
        }
    }
    // A lookup table built from these ranges (step 07's lesson, not repeated here) reads only
    // indices inside int16 and holds colours in 0..1: both follow from the checks above, since
    // every range lies inside int16 and a ramp's entries lie between its two ends.
    // --skin-opacity on the first labelled range, and on a label that is not there.
    for (const ctlab::TfRange& range : tf.ranges) {
        if (range.label.empty()) continue;
        ctlab::set_opacity(tf, range.label, 0.5, "--fuzz");
        require(ctlab::find_range(tf, range.label)->start.a == 0.5f, "set_opacity did not set");
        break;
    }
    try {
        ctlab::set_opacity(tf, "no such label!", 0.5, "--fuzz");
        throw Broken("set_opacity found a label no range can have");
    } catch (const ctlab::InputError& error) {
        check_message(error, "--fuzz: ");
    }
}

void image_file(const uint8_t* data, size_t size) {
    const std::string name = "fuzz.image";
    const std::vector<unsigned char> bytes(data, data + size);
    ctlab::Image image;
    try {
        image = ctlab::read_image_bytes(bytes, name);
    } catch (const ctlab::InputError& error) {
        check_message(error, "'" + name + "': ");
        return;
    }
    constexpr int max_side = 16384;
    require(image.width >= 1 && image.height >= 1 && image.width <= max_side &&
                image.height <= max_side,
            "a picture size outside 1..16384");
    require(image.pixels.size() == size_t(image.width) * size_t(image.height),
            "pixels != width * height");
    for (const ctlab::Rgb& p : image.pixels) {
        require(std::isfinite(p.r) && std::isfinite(p.g) && std::isfinite(p.b) && p.r >= 0 &&
                    p.g >= 0 && p.b >= 0 && p.r <= 1 && p.g <= 1 && p.b <= 1,
                "a pixel outside 0..1");
    }
    // What the checker does next: compare, and draw the heat map (small pictures only).
    constexpr size_t heat_map_pixels = 1 << 16;
    const ctlab::Comparison same = ctlab::compare_images(image, image, 2);
    require(same.pass && same.max_abs == 0, "a picture differs from itself");
    if (image.pixels.size() <= heat_map_pixels) {
        const ctlab::Image heat = ctlab::diff_heat_map(image, image, 2, true);
        require(heat.width == image.width && heat.height >= image.height,
                "a heat map of the wrong size");
    }
    // A picture of another size is refused, naming both.
    const ctlab::Image other(image.width == 1 ? 2 : 1, 1);
    try {
        ctlab::compare_images(other, image, 2, "a", "b");
        throw Broken("compare_images accepted pictures of different sizes");
    } catch (const ctlab::InputError& error) {
        check_message(error);
    }
}

// A loaded volume of any format keeps the Volume's promises.
NOT_FUZZED void check_loaded(const ctlab::Volume& volume) {
    require(volume.nx >= 1 && volume.ny >= 1 && volume.nz >= 1, "a volume without voxels");
    require(volume.voxel_count() <= ctlab::max_voxels, "a volume over the voxel limit");
    require(volume.data.size() == volume.voxel_count(), "data size != nx*ny*nz (dense)");
    require(std::isfinite(volume.sx) && std::isfinite(volume.sy) && std::isfinite(volume.sz) &&
                volume.sx > 0 && volume.sy > 0 && volume.sz > 0,
            "a spacing that is not a positive number");
    require(std::isfinite(volume.map.scale) && volume.map.scale > 0 &&
                std::isfinite(volume.map.offset),
            "a value map that is not a positive finite line");
    int16_t low = 32767, high = -32768;
    for (int16_t value : ctlab::dense_values(volume)) {
        low = std::min(low, value);
        high = std::max(high, value);
    }
    require(low == volume.min_value && high == volume.max_value, "min or max wrong");
}

// The input as a file named NAME in the scratch folder, given to `load`.
void volume_file(const uint8_t* data, size_t size, const std::string& name,
                 ctlab::Volume (*load)(const std::string&), const std::string& loaded_path) {
    const std::string folder = scratch_folder();
    const std::vector<unsigned char> bytes(data, data + size);
    write_file(folder + "/" + name, bytes, bytes.size());
    try {
        check_loaded(load(folder + "/" + loaded_path));
    } catch (const ctlab::InputError& error) {
        check_message(error);
    }
}

void nifti_file(const uint8_t* data, size_t size) {
    // Byte 0 bit 0: gzipped (.nii.gz, as nifticlib reads it) or not (.nii).
    const bool gz = size > 0 && (data[0] & 1);
    const std::string name = gz ? "fuzz.nii.gz" : "fuzz.nii";
    volume_file(size > 0 ? data + 1 : data, size > 0 ? size - 1 : 0, name, ctlab::load_nifti, name);
}

void nrrd_file(const uint8_t* data, size_t size) {
    volume_file(data, size, "fuzz.nrrd", ctlab::load_nrrd, "fuzz.nrrd");
}

void metaimage_file(const uint8_t* data, size_t size) {
    volume_file(data, size, "fuzz.mha", ctlab::load_metaimage, "fuzz.mha");
}

void dicom_file(const uint8_t* data, size_t size) {
    // A series of one slice: a folder holding the input as its only file.
    const std::string folder = scratch_folder() + "/series";
    mkdir(folder.c_str(), 0700);
    volume_file(data, size, "series/slice.dcm", ctlab::load_dicom_series, "series");
}


// --- The data paths: a valid header made from a few bytes, the rest of the input as data ----

namespace {

const char* const nrrd_types[] = {"uint8", "int8", "uint16", "int16", "uint32", "int32", "float",
                                  "double"};
const char* const meta_types[] = {"MET_UCHAR", "MET_CHAR", "MET_USHORT", "MET_SHORT",
                                  "MET_UINT", "MET_INT", "MET_FLOAT", "MET_DOUBLE"};
const char* const raw_types[] = {"uint8", "int8", "uint16", "int16", "uint32", "int32",
                                 "float32", "float64"};
const ctlab::SampleType sample_types[] = {
    ctlab::SampleType::uint8,  ctlab::SampleType::int8,    ctlab::SampleType::uint16,
    ctlab::SampleType::int16,  ctlab::SampleType::uint32,  ctlab::SampleType::int32,
    ctlab::SampleType::float32, ctlab::SampleType::float64};
const int16_t nifti_codes[] = {2, 256, 512, 4, 768, 8, 16, 64};  // DT_UINT8 ... DT_FLOAT64

// zlib (gzip when `gzip`) of the bytes, made here so that the loaders' inflating path sees
// well-formed streams as well as the fuzzer's own bytes.
std::vector<unsigned char> deflated(const std::vector<unsigned char>& bytes, bool gzip) {
    z_stream stream{};
    require(deflateInit2(&stream, 1, Z_DEFLATED, gzip ? 15 + 16 : 15, 8,
                         Z_DEFAULT_STRATEGY) == Z_OK, "deflateInit2 failed");
    std::vector<unsigned char> out(deflateBound(&stream, uLong(bytes.size())) + 32);
    stream.next_in = const_cast<unsigned char*>(bytes.data());
    stream.avail_in = uInt(bytes.size());
    stream.next_out = out.data();
    stream.avail_out = uInt(out.size());
    const int status = deflate(&stream, Z_FINISH);
    out.resize(stream.total_out);
    deflateEnd(&stream);
    require(status == Z_STREAM_END, "deflate did not finish");
    return out;
}

void append(std::vector<unsigned char>& bytes, const std::string& text) {
    bytes.insert(bytes.end(), text.begin(), text.end());
}

template <typename T>
void append_value(std::vector<unsigned char>& bytes, T value) {
    unsigned char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    bytes.insert(bytes.end(), raw, raw + sizeof(T));
}

// A 352-byte NIfTI-1 header (little-endian host) for the dims and type, no orientation.
std::vector<unsigned char> nifti_header(int nx, int ny, int nz, int type_index) {
    std::vector<unsigned char> h(352, 0);
    const int32_t size = 348;
    std::memcpy(h.data(), &size, 4);
    const int16_t dims[8] = {3, int16_t(nx), int16_t(ny), int16_t(nz), 1, 1, 1, 1};
    std::memcpy(h.data() + 40, dims, sizeof dims);
    const int16_t code = nifti_codes[type_index];
    const int16_t bits = int16_t(8 * ctlab::sample_size(sample_types[type_index]));
    std::memcpy(h.data() + 70, &code, 2);
    std::memcpy(h.data() + 72, &bits, 2);
    const float pixdim[8] = {1, 1, 1, 1, 1, 1, 1, 1};
    std::memcpy(h.data() + 76, pixdim, sizeof pixdim);
    const float offset = 352;
    std::memcpy(h.data() + 108, &offset, 4);
    std::memcpy(h.data() + 344, "n+1\0", 4);
    return h;
}

}  // namespace

void volume_data(const uint8_t* data, size_t size) {
    // Byte 0: the container (below); byte 1: the sample type (of 8); byte 2: bit 0 big-endian
    // (NRRD, MetaImage), bit 1 compress the data here (else the input's bytes are the
    // compressed stream), bit 2 make the data exactly the size the header promises; bytes 3-5:
    // nx, ny, nz (1..16); the rest: the data.
    Bytes input{data, size};
    const int container = input.byte() % 9;
    const int type_index = input.byte() % 8;
    const uint8_t flags = input.byte();
    const bool big = flags & 1, compress_here = flags & 2, exact = flags & 4;
    const int nx = input.byte() % 16 + 1, ny = input.byte() % 16 + 1, nz = input.byte() % 16 + 1;
    const ctlab::SampleType type = sample_types[type_index];
    const size_t needed = size_t(nx) * ny * nz * ctlab::sample_size(type);
    std::vector<unsigned char> payload = input.rest();
    if (exact) payload = repeated(payload, needed);
    // 0 .nii, 1 .nii.gz, 2 NRRD raw, 3 NRRD gzip, 4 .mha raw, 5 .mha zlib, 6 raw by name,
    // 7 .nhdr + raw data file, 8 .mhd + zlib data file.
    const bool compressed = container == 1 || container == 3 || container == 5 || container == 8;
    const std::string dims = std::to_string(nx) + " " + std::to_string(ny) + " " + std::to_string(nz);
    const std::string folder = scratch_folder();
    std::vector<unsigned char> file, data_file;
    std::string name, data_name;
    std::vector<unsigned char> stream = compressed && compress_here
                                            ? deflated(payload, container == 1 || container == 3)
                                            : payload;
    switch (container) {
        case 0:
        case 1:
            name = container == 0 ? "data.nii" : "data.nii.gz";
            file = nifti_header(nx, ny, nz, type_index);
            file.insert(file.end(), payload.begin(), payload.end());
            if (container == 1) file = compress_here ? deflated(file, true) : stream;
            break;
        case 2:
        case 3:
        case 7: {
            name = container == 7 ? "data.nhdr" : "data.nrrd";
            append(file, std::string("NRRD0004\ntype: ") + nrrd_types[type_index] +
                             "\ndimension: 3\nsizes: " + dims + "\nendian: " +
                             (big ? "big" : "little") + "\nencoding: " +
                             (container == 3 ? "gzip" : "raw") + "\n");
            if (container == 7) {
                append(file, "data file: data.bin\n");
                data_name = "data.bin";
                data_file = payload;
            } else {
                append(file, "\n");
                file.insert(file.end(), stream.begin(), stream.end());
            }
            break;
        }
        case 4:
        case 5:
        case 8: {
            name = container == 8 ? "data.mhd" : "data.mha";
            append(file, "NDims = 3\nDimSize = " + dims + "\nElementType = " +
                             meta_types[type_index] + "\nBinaryDataByteOrderMSB = " +
                             (big ? "True" : "False") + "\nCompressedData = " +
                             (compressed ? "True" : "False") + "\nElementDataFile = " +
                             (container == 8 ? "data.zraw" : "LOCAL") + "\n");
            if (container == 8) {
                data_name = "data.zraw";
                data_file = stream;
            } else {
                file.insert(file.end(), stream.begin(), stream.end());
            }
            break;
        }
        default:
            name = "data_" + std::to_string(nx) + "x" + std::to_string(ny) + "x" +
                   std::to_string(nz) + "_" + raw_types[type_index] + ".raw";
            file = payload;
            break;
    }
    write_file(folder + "/" + name, file, file.size());
    if (!data_name.empty()) write_file(folder + "/" + data_name, data_file, data_file.size());
    // Must load: the data exactly the header's size (compressed here when compressed at all),
    // and every value a finite number.
    bool finite = true;
    if (type == ctlab::SampleType::float32 || type == ctlab::SampleType::float64) {
        const size_t sample = ctlab::sample_size(type);
        for (size_t n = 0; n + sample <= payload.size(); n += sample) {
            unsigned char raw[8];
            std::memcpy(raw, payload.data() + n, sample);
            if (big && container >= 2 && container != 6) std::reverse(raw, raw + sample);
            double value;
            if (sample == 4) {
                float single;
                std::memcpy(&single, raw, 4);
                value = single;
            } else {
                std::memcpy(&value, raw, 8);
            }
            finite = finite && std::isfinite(value);
        }
    }
    const bool must_load = payload.size() == needed && (!compressed || compress_here) && finite;
    const bool must_refuse = payload.size() != needed && (!compressed || compress_here);
    const std::string path = folder + "/" + name;
    try {
        ctlab::Volume volume;
        const std::string format = ctlab::volume_format_of(path);
        if (format == "nifti") volume = ctlab::load_nifti(path);
        else if (format == "nrrd") volume = ctlab::load_nrrd(path);
        else if (format == "metaimage") volume = ctlab::load_metaimage(path);
        else {
            ctlab::RawFormat raw;
            require(ctlab::raw_format_from_name(path, &raw), "a raw name not understood");
            volume = ctlab::load_raw(path, raw);
        }
        require(!must_refuse, "data of the wrong size loaded: " + name);
        check_loaded(volume);
        require(volume.nx == nx && volume.ny == ny && volume.nz == nz,
                "a volume of other dims than its header's");
        // int16 little-endian data is the volume itself, value for value.
        if (type == ctlab::SampleType::int16 && !big && volume.map.identity()) {
            const std::vector<int16_t> values = ctlab::dense_values(volume);
            for (size_t n = 0; n < values.size(); ++n) {
                int16_t expected;
                std::memcpy(&expected, payload.data() + 2 * n, 2);
                require(values[n] == expected, "an int16 voxel differs from its data");
            }
        }
    } catch (const ctlab::InputError& error) {
        check_message(error);
        require(!must_load, std::string("good data refused: ") + name + ": " + error.what());
    }
    std::remove(path.c_str());
    if (!data_name.empty()) std::remove((folder + "/" + data_name).c_str());
}

const std::vector<Target>& targets() {
    static const std::vector<Target> all = {{"raw", raw_volume},
                                            {"cthead", cthead_file},
                                            {"tf", transfer_function},
                                            {"image", image_file},
                                            {"nifti", nifti_file},
                                            {"nrrd", nrrd_file},
                                            {"metaimage", metaimage_file},
                                            {"dicom", dicom_file},
                                            {"volume_data", volume_data}};
    return all;
}

}  // namespace ctlab_fuzz
