// format_metaimage.cpp: MetaImage (.mhd + .raw/.zraw, .mha), read here: Debian packages no
// small C or C++ library for it (MetaIO comes inside ITK and VTK, far too large for a lab).
// The header is text "Key = Value" lines, ElementDataFile last; the data follows it (.mha,
// "LOCAL") or is in the named file, raw or zlib-compressed (CompressedData = True).
// TransformMatrix lists each file axis's direction in turn (axis 0 first), in LPS, as ITK
// writes it.
#include <sys/stat.h>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <sstream>
#include "error.h"
#include "file_input.h"
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
    const InputFile file(path);  // a FIFO, a device or a folder is refused here
    // Header lines up to and including ElementDataFile, within the first 64 KiB: only those
    // are read (a huge file without a newline is not read whole looking for one).
    std::vector<char> head(size_t(std::min<uint64_t>(file.size(), max_header_bytes)));
    if (file.read_at(0, head.data(), head.size()) != head.size()) {
        throw InputError(prefix + "it changed while it was read");
    }
    std::map<std::string, std::string> fields;  // lower-case key -> value
    size_t position = 0;
    bool found_data = false;
    while (position < head.size() && !found_data) {
        size_t end = position;
        while (end < head.size() && head[end] != '\n') ++end;
        if (end == head.size() && file.size() > head.size()) break;  // a line past 64 KiB
        const std::string line(head.begin() + long(position), head.begin() + long(end));
        position = std::min(end + 1, head.size());
        if (trim(line).empty()) continue;
        const size_t equals = line.find('=');
        if (equals == std::string::npos) {
            throw InputError(prefix + "expected 'Key = Value', got '" + shown(line) + "'");
        }
        const std::string key = lower(trim(line.substr(0, equals)));
        fields[key] = trim(line.substr(equals + 1));
        found_data = key == "elementdatafile";
    }
    if (!found_data) {
        throw InputError(prefix + "no ElementDataFile line" +
                         (file.size() > head.size() ? " in the first 64 KiB" : ""));
    }
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
    std::unique_ptr<InputFile> external;
    uint64_t offset = position;
    std::string data_prefix = prefix;
    if (lower(data_name) != "local") {
        if (data_name.empty() || lower(data_name) == "list" || data_name.find('%') != std::string::npos) {
            throw InputError(prefix + "ElementDataFile '" + shown(data_name) +
                             "': ctlab reads LOCAL or one data file");
        }
        const std::string data_path = data_name[0] == '/' ? data_name : folder_of(path) + data_name;
        try {
            external.reset(new InputFile(data_path));
        } catch (const InputError& error) {
            // The name came from the file: shown with its control characters replaced.
            const std::string why = error.what();
            const size_t is = why.rfind("' is ");
            if (is != std::string::npos) {  // "'P' is a FIFO (named pipe), not an ordinary file"
                throw InputError(prefix + "its ElementDataFile '" + shown(data_name) + "'" +
                                 why.substr(is + 1));
            }
            const size_t colon = why.rfind("': ");  // "cannot open 'P': No such file..."
            throw InputError(prefix + "cannot read its ElementDataFile '" + shown(data_name) +
                             "'" + (colon == std::string::npos ? "" : why.substr(colon + 1)));
        }
        data_prefix = prefix + "its ElementDataFile '" + shown(data_name) + "': ";
        offset = 0;
    }
    const InputFile& data_file = external ? *external : file;
    const uint64_t needed = voxels * sample_size(type);
    const std::string header_size = field("headersize");
    if (external && !header_size.empty()) {
        const double skip = numbers(prefix, "HeaderSize", header_size, 1)[0];
        if (skip == -1 && !compressed) {  // -1: the data is at the end of the file
            offset = data_file.size() >= needed ? data_file.size() - needed : 0;
        } else if (skip >= 0 && skip <= double(data_file.size()) && skip == std::floor(skip)) {
            offset = uint64_t(skip);
        } else {
            throw InputError(prefix + "HeaderSize " + shown(header_size) + " is past the data");
        }
    }
    if (!compressed && data_file.size() - offset != needed) {
        throw InputError(data_prefix + "the data has " + bytes_text(data_file.size() - offset) +
                         ", expected exactly " + std::to_string(needed) + " for " +
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
    {
        // A zlib (or gzip) stream inflated straight into the volume, or the bytes themselves;
        // either must hold exactly the volume's bytes.
        const std::unique_ptr<ByteStream> stream = compressed
                                                       ? ByteStream::inflated(data_file, offset)
                                                       : ByteStream::plain(data_file, offset);
        stream->prefix = data_prefix;
        read_volume_samples(volume, *stream, type, endian);
    }

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
        check_axes_independent(directions, prefix, "its TransformMatrix");
        reorient_to_lab(volume, directions, PatientFrame::lps);
    } else {
        volume.orientation = "none in the file: taken as stored";
    }
    return volume;
}

}  // namespace ctlab
