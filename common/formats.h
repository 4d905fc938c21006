// formats.h: the volume file formats beyond raw: NIfTI-1, NRRD, MetaImage and DICOM series.
//
// Every loader gives the same Volume as the raw loader: int16 values (a ValueMap when the
// file's values do not fit), turned into the lab's anatomical frame (i towards the patient's
// right, j from the face backwards, k from the crown down; volume.orientation says what was
// done). Bad files throw InputError with one line naming the file and the problem.
#pragma once
#include <string>
#include "volume.h"

namespace ctlab {

// NIfTI-1 (.nii, .nii.gz, .hdr/.img) through nifticlib: data types, scl_slope/scl_inter,
// pixdim spacing, sform (else qform) orientation.
Volume load_nifti(const std::string& path);

// NRRD (.nrrd, .nhdr + data file) through teem: raw/gzip/ascii encodings, endianness,
// spacings or space directions (RAS or LPS spaces).
Volume load_nrrd(const std::string& path);

// MetaImage (.mhd + .raw/.zraw, .mha): a reader of our own (README: why).
Volume load_metaimage(const std::string& path);

// A folder of DICOM slices of one series, through GDCM: sorted by position along the slice
// normal, rescale slope/intercept applied (CT in Hounsfield units).
Volume load_dicom_series(const std::string& folder);

// The loaders above, through the format module (build/ctlab_formats.so, module.h): a step
// maps GDCM, nifticlib, teem and zlib only when it reads such a file. `format` is what
// volume_format_of says ("nifti", "nrrd", "metaimage" or "dicom").
Volume load_volume_file(const std::string& format, const std::string& path);

// What the format module hands out: the loader of one format, or nullptr for an unknown name.
using VolumeReader = Volume (*)(const std::string& path);

// Which loader a path needs: "nifti", "nrrd", "metaimage", "dicom" (a folder), "raw" (any
// other name), by its name (and for a folder, by being one).
std::string volume_format_of(const std::string& path);

// The file formats and examples, for --help.
const char* volume_formats_help();

}  // namespace ctlab
