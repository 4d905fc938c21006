// format_entry.cpp: the format module's one entry point (module.h, formats.h). Built with
// common/format_*.cpp into build/ctlab_formats.so, which alone links GDCM, nifticlib, teem
// and zlib; the steps open it through load_volume_file() when a file needs it.
#include <cstring>
#include "formats.h"

extern "C" __attribute__((visibility("default")))
ctlab::VolumeReader ctlab_volume_reader(const char* format) {
    if (std::strcmp(format, "nifti") == 0) return ctlab::load_nifti;
    if (std::strcmp(format, "nrrd") == 0) return ctlab::load_nrrd;
    if (std::strcmp(format, "metaimage") == 0) return ctlab::load_metaimage;
    if (std::strcmp(format, "dicom") == 0) return ctlab::load_dicom_series;
    return nullptr;
}
