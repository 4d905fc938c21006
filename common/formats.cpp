// formats.cpp: which loader a path needs, and the formats' help text.
#include <sys/stat.h>
#include "formats.h"
#include "error.h"
#include "module.h"

namespace ctlab {

static bool ends_with(const std::string& text, const std::string& end) {
    if (text.size() < end.size()) return false;
    for (size_t n = 0; n < end.size(); ++n) {
        const char c = text[text.size() - end.size() + n];
        if ((c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c) != end[n]) return false;
    }
    return true;
}

std::string volume_format_of(const std::string& path) {
    struct stat info {};
    if (stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode)) return "dicom";
    if (ends_with(path, ".nii") || ends_with(path, ".nii.gz") || ends_with(path, ".hdr")) {
        return "nifti";
    }
    if (ends_with(path, ".nrrd") || ends_with(path, ".nhdr")) return "nrrd";
    if (ends_with(path, ".mhd") || ends_with(path, ".mha")) return "metaimage";
    return "raw";
}

Volume load_volume_file(const std::string& format, const std::string& path) {
    using Entry = VolumeReader (*)(const char* format);
    // DICOM's GDCM builds its dictionaries when loaded (~60 million instructions, most of a
    // small run): a module of its own, opened for a DICOM series only.
    const bool dicom = format == "dicom";
    const auto entry = reinterpret_cast<Entry>(
        module_entry(dicom ? "ctlab_dicom.so" : "ctlab_formats.so",
                     dicom ? "ctlab_dicom_reader" : "ctlab_volume_reader",
                     "to read " + format + " files"));
    const VolumeReader reader = entry(format.c_str());
    if (!reader) throw InputError("no reader for the volume format '" + printable(format) + "'");
    return reader(path);
}

const char* volume_formats_help() {
    return "volume formats (--volume PATH; the kind is told by the name):\n"
           "  NIfTI-1     head.nii, head.nii.gz        (sform/qform orientation, scl_slope)\n"
           "  NRRD        head.nrrd, head.nhdr + data  (raw/gzip, space directions)\n"
           "  MetaImage   head.mhd + head.raw|.zraw, head.mha\n"
           "  DICOM       a folder of one series' slices (sorted by position, rescaled)\n"
           "  raw         foot_256x256x256_uint8.raw   (dims and type from the name), or\n"
           "              any file with --dims NX,NY,NZ [--type T] [--endian E] [--spacing S]\n"
           "  CThead      data/CThead (256x256x113 int16, the default when present)\n"
           "  Values that do not fit int16 are mapped linearly (map= on the volume line);\n"
           "  --threshold and --tf files stay in the file's own units. Oriented files are\n"
           "  turned so that i points to the patient's right, j backwards from the face, k down\n"
           "  from the crown.\n";
}

}  // namespace ctlab
