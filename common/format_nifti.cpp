// format_nifti.cpp: NIfTI-1 (.nii, .nii.gz, .hdr + .img) with nifticlib (Debian
// libnifti2-dev: nifti1_io.h, -lniftiio) for the header's meaning (qform quaternion, sform).
// The 348-byte header and the data are read here, through common/file_input.h: the files are
// opened without blocking and must be ordinary files, extensions are skipped without being
// kept, a .nii.gz is inflated straight into the volume, and the data must be exactly what the
// header promises. (nifticlib's own reading allocates whatever the header says first, reads
// a FIFO, and fills a short file's tail with zeros.)
#include <sys/stat.h>
#include <cctype>
#include <cmath>
#include <cstring>
#include <memory>
#include <nifti1_io.h>
#include "error.h"
#include "file_input.h"
#include "formats.h"

namespace ctlab {

namespace {
constexpr int nifti1_header_bytes = 348;
constexpr uint64_t nifti1_single_offset = 352;  // header + 4 extension flag bytes
// Deflate packs at most 1032 bytes into one: a .nii.gz of N bytes unpacks to at most 1032 N
// (a 358-byte file asked for 1 GB: found by `make fuzz`).
constexpr uint64_t deflate_max_ratio = 1032;

struct NiftiFree {
    void operator()(nifti_image* image) const { nifti_image_free(image); }
};
using NiftiImage = std::unique_ptr<nifti_image, NiftiFree>;

bool sample_type_of(int datatype, SampleType* type) {
    switch (datatype) {
        case DT_UINT8: *type = SampleType::uint8; return true;
        case DT_INT8: *type = SampleType::int8; return true;
        case DT_UINT16: *type = SampleType::uint16; return true;
        case DT_INT16: *type = SampleType::int16; return true;
        case DT_UINT32: *type = SampleType::uint32; return true;
        case DT_INT32: *type = SampleType::int32; return true;
        case DT_FLOAT32: *type = SampleType::float32; return true;
        case DT_FLOAT64: *type = SampleType::float64; return true;
        default: return false;
    }
}

bool ends_with(const std::string& text, const std::string& end) {
    if (text.size() < end.size()) return false;
    for (size_t n = 0; n < end.size(); ++n) {
        const char c = text[text.size() - end.size() + n];
        if ((c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c) != end[n]) return false;
    }
    return true;
}

bool is_gzip(const InputFile& file) {
    unsigned char magic[2] = {0, 0};
    return file.read_at(0, magic, 2) == 2 && magic[0] == 0x1f && magic[1] == 0x8b;
}

std::unique_ptr<ByteStream> stream_of(const InputFile& file, const std::string& prefix) {
    std::unique_ptr<ByteStream> stream =
        is_gzip(file) ? ByteStream::inflated(file, 0) : ByteStream::plain(file, 0);
    stream->prefix = prefix;
    return stream;
}

// The data file of a header/image pair: NAME.img (or NAME.img.gz) beside NAME.hdr, whatever
// it is (a FIFO is then refused by InputFile); "" when there is none.
std::string image_file_of(const std::string& header_path) {
    const std::string stem = header_path.substr(0, header_path.size() - 4);
    const bool upper = header_path.back() == 'R';
    for (const char* end : {".img", ".img.gz"}) {
        std::string name = stem + end;
        if (upper) {
            for (size_t n = stem.size(); n < name.size(); ++n) name[n] = char(std::toupper(name[n]));
        }
        struct stat info {};
        if (lstat(name.c_str(), &info) == 0) return name;
    }
    return "";
}
}  // namespace

Volume load_nifti(const std::string& path) {
    const std::string prefix = "'" + path + "' (NIfTI): ";
    const InputFile header_file(path);  // a FIFO, a device or a folder is refused here
    const bool pair = ends_with(path, ".hdr");

    // The header, byte-swapped when the file's order is not this machine's.
    nifti_1_header header;
    std::memset(&header, 0, sizeof header);
    {
        const std::unique_ptr<ByteStream> stream = stream_of(header_file, prefix);
        const size_t got = stream->read_all(&header, nifti1_header_bytes);
        if (got < size_t(nifti1_header_bytes)) {
            throw InputError(prefix + "not a NIfTI-1 file: " + bytes_text(got) +
                             ", shorter than the 348-byte header");
        }
    }
    bool swapped = false;
    if (header.sizeof_hdr != nifti1_header_bytes) {
        swap_nifti_header(&header, 1);
        swapped = true;
        if (header.sizeof_hdr != nifti1_header_bytes) {
            throw InputError(prefix + "not a NIfTI-1 file (its first 4 bytes are not 348: " +
                             "sizeof_hdr)");
        }
    }
    const bool single = std::memcmp(header.magic, "n+1", 4) == 0;
    if (!single && !pair) {
        throw InputError(prefix + "not a NIfTI-1 file: its magic is not \"n+1\" (a .hdr/.img "
                         "pair says \"ni1\")");
    }
    if (single && pair) {
        throw InputError(prefix + "its magic \"n+1\" says the data is in this file, but a .hdr "
                         "holds only a header");
    }

    // Dimensions: a zero or negative one is refused, not taken as 1.
    const int dims = header.dim[0];
    if (dims < 1 || dims > 7) {
        throw InputError(prefix + "dim[0] = " + std::to_string(dims) + ", expected 1 to 7");
    }
    for (int d = 1; d <= dims; ++d) {
        if (header.dim[d] < 1) {
            throw InputError(prefix + "dim[" + std::to_string(d) + "] = " +
                             std::to_string(header.dim[d]) + ": every size must be at least 1");
        }
        if (d >= 4 && header.dim[d] > 1) {
            throw InputError(prefix + "has " + std::to_string(header.dim[d]) +
                             " volumes along dimension " + std::to_string(d) +
                             "; ctlab reads one 3-D volume");
        }
    }
    const uint64_t nx = uint64_t(header.dim[1]), ny = dims >= 2 ? uint64_t(header.dim[2]) : 1,
                   nz = dims >= 3 ? uint64_t(header.dim[3]) : 1;
    SampleType type;
    if (!sample_type_of(header.datatype, &type)) {
        const char* name = nifti_datatype_string(header.datatype);
        if (std::strcmp(name, "DT_UNKNOWN") == 0 || name[0] == '*') {
            throw InputError(prefix + "bad datatype " + std::to_string(header.datatype) +
                             ": no NIfTI-1 type has that code");
        }
        throw InputError(prefix + "data type " + name +
                         " is not read (uint8, int8, uint16, int16, uint32, int32, float32, "
                         "float64 are)");
    }
    const uint64_t voxels = check_volume_size(prefix + "dims", nx, ny, nz);
    const uint64_t data_bytes = voxels * sample_size(type);

    // Scaling: slope 0 (or not a number) means none; with a slope, the intercept must be a
    // number (nibabel refuses such a file too).
    const double slope = header.scl_slope, inter = header.scl_inter;
    const bool scaled = slope != 0 && std::isfinite(slope);
    if (scaled && !std::isfinite(inter)) {
        throw InputError(prefix + "scl_inter is " + (std::isnan(inter) ? "NaN" : "infinite") +
                         " while scl_slope is " + std::to_string(slope) +
                         ": the values' meaning is unknown");
    }

    // nifticlib turns the header into matrices (the qform's quaternion, the sform's rows).
    NiftiImage image;
    nifti_set_debug_level(0);
    const std::string said = capture_stderr(
        [&] { image.reset(nifti_convert_nhdr2nim(header, path.c_str())); });
    if (!image) {
        throw InputError(prefix + "nifticlib cannot read its header (" +
                         (said.empty() ? std::string("bad header") : said) + ")");
    }
    const double dx = std::fabs(image->dx), dy = std::fabs(image->dy), dz = std::fabs(image->dz);
    if (!(dx > 0 && dy > 0 && dz > 0) || !std::isfinite(dx + dy + dz)) {
        throw InputError(prefix + "pixdim spacing must be positive, got " + std::to_string(dx) +
                         "," + std::to_string(dy) + "," + std::to_string(dz));
    }

    // Where the data starts: vox_offset, a whole number of bytes (at least 352 in a .nii).
    const double offset_value = header.vox_offset;
    if (!(offset_value >= 0) || offset_value != std::floor(offset_value) ||
        offset_value > 1e15 || (single && offset_value < double(nifti1_header_bytes))) {
        throw InputError(prefix + "vox_offset " + std::to_string(offset_value) +
                         " is not where data can start");
    }
    const uint64_t offset = uint64_t(offset_value);

    // The data file: this one, or the .img beside the .hdr.
    std::unique_ptr<InputFile> image_file;
    if (pair) {
        const std::string image_path = image_file_of(path);
        if (image_path.empty()) {
            throw InputError(prefix + "its data file '" + path.substr(0, path.size() - 4) +
                             ".img' is missing (a .hdr holds only the header)");
        }
        image_file.reset(new InputFile(image_path));
    }
    const InputFile& data_file = pair ? *image_file : header_file;
    const std::string data_prefix =
        pair ? "'" + data_file.path() + "' (NIfTI data of '" + path + "'): " : prefix;
    const bool gzip = is_gzip(data_file);
    const uint64_t needed = offset + data_bytes;
    if (!gzip && data_file.size() != needed) {
        throw InputError(data_prefix + "has " + bytes_text(data_file.size()) +
                         ", its header needs exactly " + std::to_string(needed) + " (" +
                         std::to_string(offset) + " before the data, then " + std::to_string(nx) +
                         "x" + std::to_string(ny) + "x" + std::to_string(nz) + " " +
                         sample_type_name(type) + " voxels)");
    }
    if (gzip && data_file.size() * deflate_max_ratio < needed) {
        throw InputError(data_prefix + "has " + bytes_text(data_file.size()) +
                         " of gzip (at most " +
                         std::to_string(data_file.size() * deflate_max_ratio) +
                         " unpacked), its header needs " + std::to_string(needed));
    }

    Volume volume;
    volume.name = path;
    volume.format = "nifti";
    volume.nx = int(nx);
    volume.ny = int(ny);
    volume.nz = int(nz);
    volume.sx = dx;
    volume.sy = dy;
    volume.sz = dz;
    {
        const std::unique_ptr<ByteStream> stream = stream_of(data_file, data_prefix);
        stream->skip_start(offset);  // the rest of the header and any extensions, not kept
        const Endian endian = swapped ? (host_endian() == Endian::little ? Endian::big
                                                                         : Endian::little)
                                      : host_endian();
        read_volume_samples(volume, *stream, type, endian, scaled ? slope : 1.0,
                            scaled ? inter : 0.0);
    }

    // Orientation: sform when its code is set, else qform, else none (taken as stored).
    const mat44* matrix = image->sform_code > 0   ? &image->sto_xyz
                          : image->qform_code > 0 ? &image->qto_xyz
                                                  : nullptr;
    const char* source = image->sform_code > 0 ? "sform" : "qform";
    if (!matrix) {
        volume.orientation = "none in the file: taken as stored";
        return volume;
    }
    Directions directions{};
    // The spacing is the length of each axis's column: pixdim may disagree with an sform.
    double* spacing[3] = {&volume.sx, &volume.sy, &volume.sz};
    for (int a = 0; a < 3; ++a) {
        double length = 0;
        for (int w = 0; w < 3; ++w) {
            directions.axis[a][w] = matrix->m[w][a];
            length += directions.axis[a][w] * directions.axis[a][w];
        }
        *spacing[a] = std::sqrt(length);
    }
    check_axes_independent(directions, prefix, std::string("its ") + source);
    reorient_to_lab(volume, directions, PatientFrame::ras);
    volume.orientation += std::string(" (") + source + ")";
    return volume;
}

}  // namespace ctlab
