// format_nifti.cpp: NIfTI-1 through nifticlib (Debian libnifti2-dev: nifti1_io.h, -lniftiio).
#include <sys/stat.h>
#include <unistd.h>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <memory>
#include <nifti1_io.h>
#include "error.h"
#include "formats.h"

namespace ctlab {

namespace {
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

// nifticlib prints some of its errors on stderr whatever its debug level: they are caught
// here (stderr goes to a temporary file during the call) and become part of our one line.
template <typename Call>
auto quietly(std::string* said, Call call) -> decltype(call()) {
    std::fflush(stderr);
    std::FILE* sink = std::tmpfile();
    const int saved = sink ? dup(2) : -1;
    if (saved >= 0) dup2(fileno(sink), 2);
    auto result = call();
    if (saved >= 0) {
        std::fflush(stderr);
        dup2(saved, 2);
        close(saved);
        std::rewind(sink);
        char line[256];
        while (std::fgets(line, sizeof line, sink)) {
            std::string text = line;
            while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
            if (text.rfind("** ERROR: ", 0) == 0) text = text.substr(10);
            for (char& c : text) {
                if (static_cast<unsigned char>(c) < 32) c = ' ';
            }
            if (!text.empty()) *said = text;
        }
    }
    if (sink) std::fclose(sink);
    return result;
}

bool ends_with(const std::string& text, const std::string& end) {
    return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}
}  // namespace

Volume load_nifti(const std::string& path) {
    struct stat info {};
    if (stat(path.c_str(), &info) != 0) {
        throw InputError("cannot open '" + path + "': " + std::strerror(errno));
    }
    if (!S_ISREG(info.st_mode)) throw InputError("'" + path + "' is not an ordinary file");
    nifti_set_debug_level(0);  // nifticlib's own messages would go to stderr: ours say it
    std::string said;
    NiftiImage image(quietly(&said, [&] { return nifti_image_read(path.c_str(), 0); }));  // header
    if (!image) {
        throw InputError("'" + path + "' is not a NIfTI-1 file nifticlib can read (" +
                         (said.empty() ? std::string("bad header") : said) + ")");
    }
    const std::string prefix = "'" + path + "' (NIfTI): ";
    if (image->dim[0] < 1 || image->dim[0] > 7) {
        throw InputError(prefix + "dim[0] = " + std::to_string(image->dim[0]) + ", expected 1 to 7");
    }
    for (int d = 4; d <= image->dim[0]; ++d) {
        if (image->dim[d] > 1) {
            throw InputError(prefix + "has " + std::to_string(image->dim[d]) +
                             " volumes along dimension " + std::to_string(d) +
                             "; ctlab reads one 3-D volume");
        }
    }
    SampleType type;
    if (!sample_type_of(image->datatype, &type)) {
        throw InputError(prefix + "data type " + nifti_datatype_string(image->datatype) +
                         " is not read (uint8, int8, uint16, int16, uint32, int32, float32, "
                         "float64 are)");
    }
    // nifticlib keeps the file's copy while it is converted: both must fit.
    const uint64_t voxels = check_volume_size(prefix + "dims", uint64_t(std::max(image->nx, 0)),
                                              uint64_t(std::max(image->ny, 0)),
                                              uint64_t(std::max(image->nz, 0)),
                                              2 + sample_size(type));
    const double dx = std::fabs(image->dx), dy = std::fabs(image->dy), dz = std::fabs(image->dz);
    if (!(dx > 0 && dy > 0 && dz > 0) || !std::isfinite(dx + dy + dz)) {
        throw InputError(prefix + "pixdim spacing must be positive, got " + std::to_string(dx) +
                         "," + std::to_string(dy) + "," + std::to_string(dz));
    }
    // A single file (.nii, .nii.gz) must be able to hold all its data: checked before
    // nifticlib allocates what the header says. Uncompressed (zlib also reads a .nii.gz that
    // is not gzip as it is): the bytes themselves. Gzip: deflate packs at most 1032 bytes into
    // one, so a file of N bytes holds at most 1032 N (a 358-byte file asked for 1 GB: found by
    // `make fuzz`).
    if (ends_with(path, ".nii") || ends_with(path, ".nii.gz")) {
        constexpr uint64_t deflate_max_ratio = 1032;
        unsigned char magic[2] = {0, 0};
        if (FILE* file = std::fopen(path.c_str(), "rb")) {
            if (std::fread(magic, 1, 2, file) != 2) magic[0] = 0;
            std::fclose(file);
        }
        const bool gzip = magic[0] == 0x1f && magic[1] == 0x8b;
        const uint64_t needed = uint64_t(image->iname_offset) + voxels * sample_size(type);
        const uint64_t most = uint64_t(info.st_size) * (gzip ? deflate_max_ratio : 1);
        if (most < needed) {
            throw InputError(prefix + "has " + std::to_string(info.st_size) + " bytes" +
                             (gzip ? " of gzip (at most " + std::to_string(most) + " unpacked)"
                                   : std::string()) +
                             ", its header needs " + std::to_string(needed));
        }
    }
    if (quietly(&said, [&] { return nifti_image_load(image.get()); }) != 0 || !image->data) {
        throw InputError(prefix + "the data could not be read (" +
                         (said.empty() ? std::string("the file ends early?") : said) + ")");
    }

    Volume volume;
    volume.name = path;
    volume.format = "nifti";
    volume.nx = image->nx;
    volume.ny = image->ny;
    volume.nz = image->nz;
    volume.sx = dx;
    volume.sy = dy;
    volume.sz = dz;
    const bool scaled = image->scl_slope != 0 && std::isfinite(image->scl_slope) &&
                        std::isfinite(image->scl_inter);
    resize_dense(volume);
    // nifticlib has swapped the data into this machine's byte order.
    const uint16_t probe = 1;
    const Endian host = *reinterpret_cast<const unsigned char*>(&probe) ? Endian::little
                                                                        : Endian::big;
    store_samples(volume, static_cast<const unsigned char*>(image->data), size_t(voxels), type,
                  host, scaled ? image->scl_slope : 1.0, scaled ? image->scl_inter : 0.0);
    // Orientation: sform when its code is set, else qform, else none (taken as stored).
    const mat44* matrix = image->sform_code > 0   ? &image->sto_xyz
                          : image->qform_code > 0 ? &image->qto_xyz
                                                  : nullptr;
    Directions directions{};
    if (matrix) {
        // The spacing is the length of each axis's column: pixdim may disagree with an sform.
        double* spacing[3] = {&volume.sx, &volume.sy, &volume.sz};
        for (int a = 0; a < 3; ++a) {
            double length = 0;
            for (int w = 0; w < 3; ++w) {
                directions.axis[a][w] = matrix->m[w][a];
                length += directions.axis[a][w] * directions.axis[a][w];
            }
            length = std::sqrt(length);
            if (!(length > 0) || !std::isfinite(length)) {
                throw InputError(prefix + "its " + (image->sform_code > 0 ? "sform" : "qform") +
                                 " gives file axis " + std::to_string(a + 1) + " no length");
            }
            *spacing[a] = length;
        }
    }
    const char* source = image->sform_code > 0 ? "sform" : "qform";
    const bool oriented = matrix != nullptr;
    image.reset();  // the file's copy goes before the turn allocates its own
    if (oriented) {
        reorient_to_lab(volume, directions, PatientFrame::ras);
        volume.orientation += std::string(" (") + source + ")";
    } else {
        volume.orientation = "none in the file: taken as stored";
    }
    return volume;
}

}  // namespace ctlab
