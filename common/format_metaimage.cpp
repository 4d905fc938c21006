// format_metaimage.cpp: MetaImage (.mhd + .raw/.zraw, .mha), read here: Debian packages no
// small C or C++ library for it (MetaIO comes inside ITK and VTK, far too large for a lab).
// The header is text "Key = Value" lines, ElementDataFile last; the data follows it (.mha,
// "LOCAL") or is in the named file, raw or zlib-compressed (CompressedData = True).
// TransformMatrix lists each file axis's direction in turn (axis 0 first), in LPS, as ITK
// writes it.
#include <sys/stat.h>
#include <zlib.h>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>
#include "error.h"
#include "formats.h"

namespace ctlab {

namespace {
constexpr size_t max_header_bytes = 1 << 16;  // a MetaImage header is a few hundred bytes

std::string lower(std::string text) {
    for (char& c : text) c = char(std::tolower(static_cast<unsigned char>(c)));
    return text;
}

std::string trim(const std::string& text) {
    const size_t first = text.find_first_not_of(" \t\r");
    if (first == std::string::npos) return "";
    const size_t last = text.find_last_not_of(" \t\r");
    return text.substr(first, last - first + 1);
}

// Shown in a message: at most 40 characters, control characters as '?'.
std::string shown(const std::string& text) {
    std::string out = text.substr(0, 40);
    for (char& c : out) {
        if (static_cast<unsigned char>(c) < 32 || c == 127) c = '?';
    }
    return text.size() > 40 ? out + "..." : out;
}

std::vector<double> numbers(const std::string& prefix, const std::string& key,
                            const std::string& text, size_t count) {
    std::istringstream stream(text);
    std::vector<double> values;
    std::string word;
    while (stream >> word) {
        char* end = nullptr;
        errno = 0;
        const double value = std::strtod(word.c_str(), &end);
        if (*end != '\0' || errno == ERANGE || !std::isfinite(value)) {
            throw InputError(prefix + key + ": expected numbers, got '" + shown(text) + "'");
        }
        values.push_back(value);
    }
    if (values.size() != count) {
        throw InputError(prefix + key + ": expected " + std::to_string(count) + " numbers, got '" +
                         shown(text) + "'");
    }
    return values;
}

bool sample_type_of(const std::string& name, SampleType* type) {
    static const std::pair<const char*, SampleType> table[] = {
        {"MET_UCHAR", SampleType::uint8},   {"MET_CHAR", SampleType::int8},
        {"MET_USHORT", SampleType::uint16}, {"MET_SHORT", SampleType::int16},
        {"MET_UINT", SampleType::uint32},   {"MET_INT", SampleType::int32},
        {"MET_FLOAT", SampleType::float32}, {"MET_DOUBLE", SampleType::float64},
    };
    for (const auto& entry : table) {
        if (name == entry.first) {
            *type = entry.second;
            return true;
        }
    }
    return false;
}

bool truth(const std::string& text) { return lower(text) == "true" || text == "1"; }

std::string folder_of(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}
}  // namespace

Volume load_metaimage(const std::string& path) {
    const std::string prefix = "'" + path + "' (MetaImage): ";
    const std::vector<unsigned char> file = read_file_bytes(path);
    // Header lines up to and including ElementDataFile.
    std::map<std::string, std::string> fields;  // lower-case key -> value
    size_t position = 0;
    bool found_data = false;
    while (position < file.size() && !found_data) {
        if (position > max_header_bytes) {
            throw InputError(prefix + "no ElementDataFile line in the first 64 KiB");
        }
        size_t end = position;
        while (end < file.size() && file[end] != '\n') ++end;
        const std::string line(file.begin() + long(position), file.begin() + long(end));
        position = std::min(end + 1, file.size());
        if (trim(line).empty()) continue;
        const size_t equals = line.find('=');
        if (equals == std::string::npos) {
            throw InputError(prefix + "expected 'Key = Value', got '" + shown(line) + "'");
        }
        const std::string key = lower(trim(line.substr(0, equals)));
        fields[key] = trim(line.substr(equals + 1));
        found_data = key == "elementdatafile";
    }
    if (!found_data) throw InputError(prefix + "no ElementDataFile line");
    auto field = [&](const std::string& key) -> std::string {
        const auto it = fields.find(key);
        return it == fields.end() ? "" : it->second;
    };

    const std::string ndims = field("ndims");
    if (ndims != "3" && ndims != "2") {
        throw InputError(prefix + "NDims must be 2 or 3, got '" + shown(ndims) + "'");
    }
    const size_t dimensions = ndims == "3" ? 3 : 2;
    const std::vector<double> sizes = numbers(prefix, "DimSize", field("dimsize"), dimensions);
    for (double size : sizes) {
        if (size < 1 || size != std::floor(size) || size > 1e9) {
            throw InputError(prefix + "DimSize must be whole numbers of at least 1, got '" +
                             shown(field("dimsize")) + "'");
        }
    }
    const uint64_t nx = uint64_t(sizes[0]), ny = uint64_t(sizes[1]),
                   nz = dimensions == 3 ? uint64_t(sizes[2]) : 1;
    const uint64_t voxels = check_volume_size(prefix + "DimSize", nx, ny, nz);
    if (!field("elementnumberofchannels").empty() && field("elementnumberofchannels") != "1") {
        throw InputError(prefix + "ElementNumberOfChannels must be 1 (one value per voxel)");
    }
    SampleType type;
    if (!sample_type_of(field("elementtype"), &type)) {
        throw InputError(prefix + "ElementType '" + shown(field("elementtype")) +
                         "' is not read (MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, "
                         "MET_INT, MET_FLOAT, MET_DOUBLE are)");
    }
    double spacing[3] = {1, 1, 1};
    const std::string spacing_text =
        !field("elementspacing").empty() ? field("elementspacing") : field("elementsize");
    if (!spacing_text.empty()) {
        const std::vector<double> values = numbers(prefix, "ElementSpacing", spacing_text, dimensions);
        for (size_t a = 0; a < dimensions; ++a) {
            if (!(values[a] != 0)) throw InputError(prefix + "ElementSpacing must not be 0");
            spacing[a] = std::fabs(values[a]);
        }
    }
    const std::string order = !field("binarydatabyteordermsb").empty()
                                  ? field("binarydatabyteordermsb")
                                  : field("elementbyteordermsb");
    const Endian endian = truth(order) ? Endian::big : Endian::little;
    const bool compressed = truth(field("compresseddata"));

    // The data: after the header (LOCAL) or in its own file beside the header.
    const std::string data_name = field("elementdatafile");
    std::vector<unsigned char> external;
    const unsigned char* data = nullptr;
    size_t data_size = 0;
    if (lower(data_name) == "local") {
        data = file.data() + position;
        data_size = file.size() - position;
    } else {
        if (data_name.empty() || lower(data_name) == "list" || data_name.find('%') != std::string::npos) {
            throw InputError(prefix + "ElementDataFile '" + shown(data_name) +
                             "': ctlab reads LOCAL or one data file");
        }
        const std::string data_path = data_name[0] == '/' ? data_name : folder_of(path) + data_name;
        try {
            external = read_file_bytes(data_path);
        } catch (const InputError& error) {
            // The name came from the file: shown with its control characters replaced.
            const std::string why = error.what();
            const size_t colon = why.rfind(": ");
            throw InputError(prefix + "cannot read its ElementDataFile '" + shown(data_name) +
                             "'" + (colon == std::string::npos ? "" : why.substr(colon)));
        }
        data = external.data();
        data_size = external.size();
        const std::string header_size = field("headersize");
        if (!header_size.empty()) {
            const double skip = numbers(prefix, "HeaderSize", header_size, 1)[0];
            if (skip == -1 && !compressed) {  // -1: the data is at the end of the file
                const uint64_t needed = voxels * sample_size(type);
                if (data_size >= needed) {
                    data += data_size - needed;
                    data_size = needed;
                }
            } else if (skip >= 0 && skip <= double(data_size) && skip == std::floor(skip)) {
                data += size_t(skip);
                data_size -= size_t(skip);
            } else {
                throw InputError(prefix + "HeaderSize " + shown(header_size) + " is past the data");
            }
        }
    }

    const uint64_t needed = voxels * sample_size(type);
    std::vector<unsigned char> inflated;
    if (compressed) {
        // zlib (or gzip) stream of exactly `needed` bytes.
        inflated.resize(size_t(needed));
        z_stream stream{};
        if (inflateInit2(&stream, 15 + 32) != Z_OK) throw InputError(prefix + "zlib failed to start");
        stream.next_in = const_cast<unsigned char*>(data);
        stream.avail_in = 0;
        stream.next_out = inflated.data();
        size_t in_left = data_size, out_left = inflated.size();
        int status = Z_OK;
        while (status == Z_OK) {
            if (stream.avail_in == 0 && in_left > 0) {
                stream.avail_in = uInt(std::min<size_t>(in_left, 1u << 30));
                in_left -= stream.avail_in;
            }
            if (stream.avail_out == 0 && out_left > 0) {
                stream.avail_out = uInt(std::min<size_t>(out_left, 1u << 30));
                out_left -= stream.avail_out;
            }
            const uInt before_in = stream.avail_in, before_out = stream.avail_out;
            status = inflate(&stream, Z_NO_FLUSH);
            if (status == Z_BUF_ERROR || (status == Z_OK && before_in == stream.avail_in &&
                                          before_out == stream.avail_out)) {
                break;
            }
        }
        const bool complete = status == Z_STREAM_END && stream.total_out == needed;
        const uint64_t got = stream.total_out;
        inflateEnd(&stream);
        if (!complete) {
            throw InputError(prefix + "compressed data gives " +
                             (status == Z_STREAM_END || status == Z_BUF_ERROR || status == Z_OK
                                  ? std::to_string(got) + " bytes"
                                  : std::string("a zlib error")) +
                             ", expected exactly " + std::to_string(needed));
        }
        data = inflated.data();
        data_size = inflated.size();
    }
    if (data_size != needed) {
        throw InputError(prefix + "the data has " + std::to_string(data_size) +
                         " bytes, expected exactly " + std::to_string(needed) + " for " +
                         std::to_string(nx) + "x" + std::to_string(ny) + "x" + std::to_string(nz) +
                         " " + sample_type_name(type) + " voxels");
    }

    Volume volume;
    volume.name = path;
    volume.format = "metaimage";
    volume.nx = int(nx);
    volume.ny = int(ny);
    volume.nz = int(nz);
    volume.sx = spacing[0];
    volume.sy = spacing[1];
    volume.sz = spacing[2];
    resize_dense(volume);
    store_samples(volume, data, size_t(voxels), type, endian);
    external = {};
    inflated = {};

    std::string matrix = field("transformmatrix");
    if (matrix.empty()) matrix = field("rotation");
    if (matrix.empty()) matrix = field("orientation");
    if (!matrix.empty()) {
        const std::vector<double> values =
            numbers(prefix, "TransformMatrix", matrix, dimensions * dimensions);
        Directions directions{};
        for (size_t a = 0; a < dimensions; ++a) {
            for (size_t w = 0; w < dimensions; ++w) directions.axis[a][w] = values[a * dimensions + w];
        }
        if (dimensions == 2) directions.axis[2][2] = 1;
        reorient_to_lab(volume, directions, PatientFrame::lps);
    } else {
        volume.orientation = "none in the file: taken as stored";
    }
    return volume;
}

}  // namespace ctlab
