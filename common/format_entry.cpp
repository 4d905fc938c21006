// format_entry.cpp: the format module's one entry point (module.h, formats.h). Built with
// common/format_*.cpp but DICOM's into build/ctlab_formats.so, which alone links nifticlib,
// teem and zlib; the steps open it through load_volume_file() when a file needs it. DICOM
// (GDCM) is a module of its own: common/format_dicom_entry.cpp.
#include <cstring>
#include "formats.h"

extern "C" __attribute__((visibility("default")))
ctlab::VolumeReader ctlab_volume_reader(const char* format) {
    if (std::strcmp(format, "nifti") == 0) return ctlab::load_nifti;
    if (std::strcmp(format, "nrrd") == 0) return ctlab::load_nrrd;
    if (std::strcmp(format, "metaimage") == 0) return ctlab::load_metaimage;
    return nullptr;
}
