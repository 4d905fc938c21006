// format_dicom_entry.cpp: the DICOM module's one entry point (module.h, formats.h). Built with
// common/format_dicom.cpp into build/ctlab_dicom.so, which alone links GDCM: GDCM builds its
// dictionaries when it is loaded (most of a run's start-up), so a NIfTI, NRRD or MetaImage
// file (build/ctlab_formats.so) does not load it.
#include <cstring>
#include "formats.h"

extern "C" __attribute__((visibility("default")))
ctlab::VolumeReader ctlab_dicom_reader(const char* format) {
    if (std::strcmp(format, "dicom") == 0) return ctlab::load_dicom_series;
    return nullptr;
}
