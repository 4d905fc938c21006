// format_nrrd.cpp: NRRD through teem (Debian libteem-dev: teem/nrrd.h, -lteem).
#include <sys/stat.h>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <teem/nrrd.h>
#include "error.h"
#include "formats.h"

namespace ctlab {

namespace {
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
        if (c == '\r' || c == '\t') c = ' ';
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
}  // namespace

Volume load_nrrd(const std::string& path) {
    struct stat info {};
    if (stat(path.c_str(), &info) != 0) {
        throw InputError("cannot open '" + path + "': " + std::strerror(errno));
    }
    if (!S_ISREG(info.st_mode)) throw InputError("'" + path + "' is not an ordinary file");
    const std::string prefix = "'" + path + "' (NRRD): ";

    // The header first, without the data: sizes are checked before teem allocates them.
    {
        NrrdHolder header;
        IoHolder io;
        io.io->skipData = AIR_TRUE;
        if (nrrdLoad(header.nrrd, path.c_str(), io.io) != 0) throw InputError(prefix + teem_error());
        const Nrrd* n = header.nrrd;
        if (n->dim < 2 || n->dim > 3) {
            throw InputError(prefix + "has " + std::to_string(n->dim) +
                             " dimensions; ctlab reads 2-D or 3-D");
        }
        SampleType type;
        if (!sample_type_of(n->type, &type)) {
            throw InputError(prefix + "type " + airEnumStr(nrrdType, n->type) + " is not read");
        }
        // teem keeps the file's copy while it is converted: both must fit.
        const uint64_t voxels = check_volume_size(prefix + "sizes", n->axis[0].size,
                                                  n->axis[1].size,
                                                  n->dim == 3 ? n->axis[2].size : 1,
                                                  2 + sample_size(type));
        // Raw data in this file: it must be there before teem allocates room for it.
        const bool inline_data = io.io->dataFNArr == nullptr || io.io->dataFNArr->len == 0;
        if (io.io->encoding == nrrdEncodingRaw && inline_data &&
            uint64_t(info.st_size) < voxels * sample_size(type)) {
            throw InputError(prefix + "has " + std::to_string(info.st_size) +
                             " bytes, its header needs more than " +
                             std::to_string(voxels * sample_size(type)));
        }
    }
    NrrdHolder holder;
    if (nrrdLoad(holder.nrrd, path.c_str(), nullptr) != 0) throw InputError(prefix + teem_error());
    const Nrrd* n = holder.nrrd;
    SampleType type;
    if (n->dim < 2 || n->dim > 3 || !sample_type_of(n->type, &type) || !n->data) {
        throw InputError(prefix + "changed while it was read");
    }
    Volume volume;
    volume.name = path;
    volume.format = "nrrd";
    const size_t sizes[3] = {n->axis[0].size, n->axis[1].size, n->dim == 3 ? n->axis[2].size : 1};
    const uint64_t voxels = check_volume_size(prefix + "sizes", sizes[0], sizes[1], sizes[2]);
    volume.nx = int(sizes[0]);
    volume.ny = int(sizes[1]);
    volume.nz = int(sizes[2]);

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
    resize_dense(volume);
    const uint16_t probe = 1;
    const Endian host = *reinterpret_cast<const unsigned char*>(&probe) ? Endian::little
                                                                        : Endian::big;
    store_samples(volume, static_cast<const unsigned char*>(n->data), size_t(voxels), type, host);

    int space = n->space;
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
