// format_nrrd.cpp: NRRD through teem (Debian libteem-dev: teem/nrrd.h, -lteem).
// teem reads the header (fields, space directions, the data file's name); the data of raw and
// gzip encodings is read here (common/file_input.h): the files opened without blocking and
// required to be ordinary files, gzip inflated straight into the volume, the data exactly what
// the header promises. teem itself reads only text encodings (ascii, hex), whose data it holds
// is in proportion to the file.
#include <sys/stat.h>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <teem/nrrd.h>
#include "error.h"
#include "file_input.h"
#include "formats.h"

namespace ctlab {

namespace {
constexpr uint64_t max_header_bytes = uint64_t(1) << 20;  // a NRRD header is a few hundred
constexpr uint64_t max_skip_line_bytes = uint64_t(1) << 20;  // each of "line skip"'s lines

// teem's error text (biff), made one line: its last non-empty line says what was wrong.
std::string teem_error() {
    char* text = biffGetDone(NRRD);
    std::string all = text ? text : "";
    std::free(text);
    std::string last;
    size_t start = 0;
    while (start < all.size()) {
        size_t end = all.find('\n', start);
        if (end == std::string::npos) end = all.size();
        std::string line = all.substr(start, end - start);
        const size_t first = line.find_first_not_of(" \t[]");
        if (first != std::string::npos) last = line;
        start = end + 1;
    }
    // "[nrrd] _nrrdRead: ..." -> "..."
    const size_t colon = last.find(": ");
    if (colon != std::string::npos) last = last.substr(colon + 2);
    for (char& c : last) {
        if (static_cast<unsigned char>(c) < 32) c = ' ';
    }
    return last.empty() ? "teem could not read it" : last;
}

struct NrrdHolder {
    Nrrd* nrrd = nrrdNew();
    ~NrrdHolder() { nrrdNuke(nrrd); }
};
struct IoHolder {
    NrrdIoState* io = nrrdIoStateNew();
    ~IoHolder() { nrrdIoStateNix(io); }
};

bool sample_type_of(int type, SampleType* out) {
    switch (type) {
        case nrrdTypeUChar: *out = SampleType::uint8; return true;
        case nrrdTypeChar: *out = SampleType::int8; return true;
        case nrrdTypeUShort: *out = SampleType::uint16; return true;
        case nrrdTypeShort: *out = SampleType::int16; return true;
        case nrrdTypeUInt: *out = SampleType::uint32; return true;
        case nrrdTypeInt: *out = SampleType::int32; return true;
        case nrrdTypeFloat: *out = SampleType::float32; return true;
        case nrrdTypeDouble: *out = SampleType::float64; return true;
        default: return false;
    }
}

// An axis ctlab can take as a spatial one: its kind unset, a domain, space or time axis, or a
// placeholder. Colour, vector, tensor and list axes hold several values per voxel.
bool spatial_kind(int kind) {
    return kind == nrrdKindUnknown || kind == nrrdKindDomain || kind == nrrdKindSpace ||
           kind == nrrdKindTime || kind == nrrdKindStub || kind == nrrdKindScalar;
}

std::string folder_of(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

bool ends_with(const std::string& text, const std::string& end) {
    return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

// The header's "data file:" field ("" when none), from its text.
std::string data_file_field(const std::vector<char>& text, size_t end) {
    size_t start = 0;
    while (start < end) {
        size_t stop = start;
        while (stop < end && text[stop] != '\n') ++stop;
        std::string line(text.begin() + long(start), text.begin() + long(stop));
        while (!line.empty() && line.back() == '\r') line.pop_back();
        for (const char* key : {"data file:", "datafile:"}) {
            if (line.compare(0, std::strlen(key), key) == 0) {
                const std::string value = line.substr(std::strlen(key));
                const size_t first = value.find_first_not_of(" \t");
                return first == std::string::npos ? "" : value.substr(first);
            }
        }
        start = stop + 1;
    }
    return "";
}

// Where the data of a .nrrd starts: after the header's first empty line. Throws when there is
// none within max_header_bytes (teem would read a long line whole, however long). Also checks
// the file "data file:" names before teem opens it (teem would wait on a FIFO for ever).
uint64_t header_end(const InputFile& file, const std::string& prefix) {
    const size_t length = size_t(std::min<uint64_t>(file.size(), max_header_bytes));
    std::vector<char> text(length);
    if (file.read_at(0, text.data(), length) != length) {
        throw InputError(prefix + "it changed while it was read");
    }
    size_t end = length;
    for (size_t n = 0; n + 1 < length; ++n) {
        if (text[n] == '\n' && (text[n + 1] == '\n' || text[n + 1] == '\r')) {
            end = n;
            break;
        }
    }
    const std::string data_name = data_file_field(text, end);
    if (!data_name.empty()) {
        if (data_name.compare(0, 4, "LIST") == 0 || data_name.find('%') != std::string::npos ||
            data_name.find(' ') != std::string::npos) {
            throw InputError(prefix + "its data is in several files (\"data file: " +
                             printable(data_name.substr(0, 40)) + "\"); ctlab reads one data file");
        }
        const std::string data_path =
            data_name[0] == '/' ? data_name : folder_of(file.path()) + data_name;
        try {
            InputFile check(data_path);
        } catch (const InputError& error) {
            throw InputError(prefix + "its data file: " + error.what());
        }
    }
    for (size_t n = 0; n + 1 < length; ++n) {
        if (text[n] != '\n') continue;
        if (text[n + 1] == '\n') return n + 2;
        if (text[n + 1] == '\r' && n + 2 < length && text[n + 2] == '\n') return n + 3;
    }
    if (file.size() > max_header_bytes) {
        throw InputError(prefix + "no empty line ends the header in its first " +
                         bytes_text(max_header_bytes));
    }
    return file.size();  // a header without data (the data in its own file)
}

// Skips `lines` lines of a plain file from `offset`; returns where the data starts.
uint64_t skip_lines(const InputFile& file, uint64_t offset, long lines, const std::string& prefix) {
    char buffer[4096];
    uint64_t line_start = offset;
    while (lines > 0) {
        const size_t got = file.read_at(offset, buffer, sizeof buffer);
        if (got == 0) throw InputError(prefix + "the file ends inside its \"line skip\" lines");
        for (size_t n = 0; n < got && lines > 0; ++n) {
            if (buffer[n] == '\n') {
                --lines;
                line_start = offset + n + 1;
            }
        }
        offset += got;
        if (lines > 0 && offset - line_start > max_skip_line_bytes) {
            throw InputError(prefix + "a \"line skip\" line is longer than " +
                             bytes_text(max_skip_line_bytes));
        }
    }
    return line_start;
}
}  // namespace

Volume load_nrrd(const std::string& path) {
    const std::string prefix = "'" + path + "' (NRRD): ";
    const InputFile file(path);  // a FIFO, a device or a folder is refused here
    if (ends_with(path, ".nhdr") && file.size() > max_header_bytes) {
        throw InputError(prefix + "a .nhdr holds only a header, and this one has " +
                         bytes_text(file.size()) + " (over " + bytes_text(max_header_bytes) + ")");
    }
    const uint64_t data_start = header_end(file, prefix);

    // The header, without the data (teem's own warnings are captured, not printed).
    NrrdHolder header;
    IoHolder io;
    io.io->skipData = AIR_TRUE;
    int status = 0;
    capture_stderr([&] { status = nrrdLoad(header.nrrd, path.c_str(), io.io); });
    if (status != 0) throw InputError(prefix + teem_error());
    const Nrrd* n = header.nrrd;
    if (n->dim < 2 || n->dim > 3) {
        throw InputError(prefix + "has " + std::to_string(n->dim) +
                         " dimensions; ctlab reads 2-D or 3-D");
    }
    for (unsigned a = 0; a < n->dim; ++a) {
        if (!spatial_kind(n->axis[a].kind)) {
            throw InputError(prefix + "axis " + std::to_string(a + 1) + " is of kind \"" +
                             airEnumStr(nrrdKind, n->axis[a].kind) +
                             "\", not a space axis: ctlab reads one grey value per voxel");
        }
    }
    SampleType type;
    if (!sample_type_of(n->type, &type)) {
        throw InputError(prefix + "type " + airEnumStr(nrrdType, n->type) + " is not read");
    }
    const size_t sizes[3] = {n->axis[0].size, n->axis[1].size, n->dim == 3 ? n->axis[2].size : 1};
    const uint64_t voxels = check_volume_size(prefix + "sizes", sizes[0], sizes[1], sizes[2]);
    const uint64_t needed = voxels * sample_size(type);
    const NrrdEncoding* encoding = io.io->encoding;
    const bool ours = encoding == nrrdEncodingRaw || encoding == nrrdEncodingGzip;
    const bool text = encoding && (std::strcmp(encoding->name, "ascii") == 0 ||
                                   std::strcmp(encoding->name, "hex") == 0);
    if (!ours && !text) {
        throw InputError(prefix + "encoding " + (encoding ? encoding->name : "?") +
                         " is not read (raw, gzip, ascii and hex are)");
    }

    // The data file: this one after its header, or the one "data file:" names.
    const unsigned data_files = io.io->dataFNArr ? io.io->dataFNArr->len : 0;
    if (data_files > 1) {
        throw InputError(prefix + "its data is in " + std::to_string(data_files) +
                         " files; ctlab reads one data file");
    }
    std::unique_ptr<InputFile> detached;
    std::string data_prefix = prefix;
    if (data_files == 1) {
        const std::string name = io.io->dataFN[0];
        const std::string data_path = name.empty() || name[0] == '/' ? name : folder_of(path) + name;
        data_prefix = prefix + "its data file: ";
        try {
            detached.reset(new InputFile(data_path));
        } catch (const InputError& error) {
            throw InputError(data_prefix + error.what());
        }
    }
    const InputFile& data_file = detached ? *detached : file;
    uint64_t offset = detached ? 0 : data_start;
    offset = skip_lines(data_file, offset, std::max(0L, long(io.io->lineSkip)), data_prefix);
    const long byte_skip = io.io->byteSkip;
    if (encoding == nrrdEncodingRaw) {
        if (byte_skip == -1) {  // the data is the file's last bytes
            if (data_file.size() < offset + needed) {
                throw InputError(data_prefix + "has " + bytes_text(data_file.size()) +
                                 ", its header needs at least " + std::to_string(offset + needed));
            }
            offset = data_file.size() - needed;
        } else {
            offset += uint64_t(std::max(0L, byte_skip));
        }
        if (data_file.size() != offset + needed) {
            throw InputError(data_prefix + "has " + bytes_text(data_file.size()) +
                             ", its header needs exactly " + std::to_string(offset + needed) +
                             " (" + std::to_string(offset) + " before the data, then " +
                             std::to_string(sizes[0]) + "x" + std::to_string(sizes[1]) + "x" +
                             std::to_string(sizes[2]) + " " + sample_type_name(type) +
                             " voxels)");
        }
    }

    Volume volume;
    volume.name = path;
    volume.format = "nrrd";
    volume.nx = int(sizes[0]);
    volume.ny = int(sizes[1]);
    volume.nz = int(sizes[2]);
    const Endian file_endian = io.io->endian == airEndianBig ? Endian::big : Endian::little;
    if (ours) {
        std::unique_ptr<ByteStream> stream = encoding == nrrdEncodingRaw
                                                 ? ByteStream::plain(data_file, offset)
                                                 : ByteStream::inflated(data_file, offset);
        stream->prefix = data_prefix;
        // gzip: "byte skip" counts unpacked bytes.
        const uint64_t unpacked_skip =
            encoding == nrrdEncodingGzip ? uint64_t(std::max(0L, byte_skip)) : 0;
        stream->skip_start(unpacked_skip);
        read_volume_samples(volume, *stream, type, file_endian);
    } else {
        // Text: at least one character and a separator per value, so teem's copy is at most
        // a few times the file's size.
        if (data_file.size() - std::min(data_file.size(), offset) < voxels) {
            throw InputError(data_prefix + "its " + encoding->name + " data has " +
                             bytes_text(data_file.size() - std::min(data_file.size(), offset)) +
                             ", too few for " + std::to_string(voxels) + " values");
        }
        NrrdHolder holder;
        capture_stderr([&] { status = nrrdLoad(holder.nrrd, path.c_str(), nullptr); });
        if (status != 0) throw InputError(prefix + teem_error());
        const Nrrd* full = holder.nrrd;
        if (full->dim != n->dim || full->type != n->type || !full->data ||
            full->axis[0].size != sizes[0] || full->axis[1].size != sizes[1] ||
            (n->dim == 3 && full->axis[2].size != sizes[2])) {
            throw InputError(prefix + "changed while it was read");
        }
        resize_dense(volume);
        store_samples(volume, static_cast<const unsigned char*>(full->data), size_t(voxels),
                      type, host_endian());
    }

    // Spacing and directions: space directions (with a space) or spacings, else 1.
    const bool has_space = n->spaceDim == 3;
    Directions directions{};
    double spacing[3] = {1, 1, 1};
    for (unsigned a = 0; a < n->dim; ++a) {
        if (has_space) {
            double length = 0;
            for (int w = 0; w < 3; ++w) {
                directions.axis[a][w] = n->axis[a].spaceDirection[w];
                length += directions.axis[a][w] * directions.axis[a][w];
            }
            spacing[a] = std::sqrt(length);
        } else if (std::isfinite(n->axis[a].spacing) && n->axis[a].spacing != 0) {
            spacing[a] = std::fabs(n->axis[a].spacing);
        }
        if (!(spacing[a] > 0) || !std::isfinite(spacing[a])) {
            throw InputError(prefix + "axis " + std::to_string(a + 1) +
                             " has no usable spacing or space direction");
        }
    }
    if (n->dim == 2 && has_space) {  // a single slice: its normal is the third axis
        const double* u = directions.axis[0];
        const double* v = directions.axis[1];
        directions.axis[2][0] = u[1] * v[2] - u[2] * v[1];
        directions.axis[2][1] = u[2] * v[0] - u[0] * v[2];
        directions.axis[2][2] = u[0] * v[1] - u[1] * v[0];
    }
    volume.sx = spacing[0];
    volume.sy = spacing[1];
    volume.sz = spacing[2];
    if (has_space) check_axes_independent(directions, prefix, "its space directions");

    const int space = n->space;
    if (has_space && (space == nrrdSpaceRightAnteriorSuperior ||
                      space == nrrdSpaceLeftPosteriorSuperior || space == nrrdSpaceScannerXYZ)) {
        reorient_to_lab(volume, directions,
                        space == nrrdSpaceRightAnteriorSuperior ? PatientFrame::ras
                                                                : PatientFrame::lps);
    } else if (has_space && space == nrrdSpaceLeftAnteriorSuperior) {
        // LAS = RAS with x negated.
        for (auto& axis : directions.axis) axis[0] = -axis[0];
        reorient_to_lab(volume, directions, PatientFrame::ras);
        volume.orientation += " (via LAS)";
    } else {
        volume.orientation = "none in the file: taken as stored";
    }
    return volume;
}

}  // namespace ctlab
