// targets.h: what each fuzz harness does with one input, shared by the libFuzzer binaries
// (tests/fuzz/fuzz_*.cpp, `make fuzz`) and the doctest that replays every committed crash
// input (tests/test_fuzz_regressions.cpp, `make test`).
//
// A target feeds the bytes to a loader or parser. Bad input must end in an InputError whose
// message is one line; good input must give a value that keeps its promises (sizes, ranges,
// no NaN). Anything else throws Broken (or, under the sanitizers, crashes).
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

namespace ctlab_fuzz {

// A promise of the code under test was broken by this input.
struct Broken : std::logic_error {
    explicit Broken(const std::string& what) : std::logic_error(what) {}
};

// Raw loader: volume_from_bytes with dims, byte order and spacing taken from the first bytes.
void raw_volume(const uint8_t* data, size_t size);

// CThead path: load_volume() on a temporary file made from the input (often exactly the
// CThead size, by repeating the input), with or without --endian and --spacing.
void cthead_file(const uint8_t* data, size_t size);

// The transfer-function parser on the input as text, then the lookup table steps 07-10 build.
void transfer_function(const uint8_t* data, size_t size);

// The checker's image reader (read_image_bytes), then a comparison of the picture with itself.
void image_file(const uint8_t* data, size_t size);

// The format loaders on the input as a file: NIfTI (byte 0 bit 0: .nii.gz, else .nii; the
// rest is the file), NRRD (.nrrd), MetaImage (.mha), DICOM (a folder of one slice).
void nifti_file(const uint8_t* data, size_t size);
void nrrd_file(const uint8_t* data, size_t size);
void metaimage_file(const uint8_t* data, size_t size);
void dicom_file(const uint8_t* data, size_t size);

// The data paths of every format (raw and compressed): a valid NIfTI, NRRD (inline or
// detached), MetaImage (LOCAL or a data file) or raw-by-name header made from the first six
// bytes (container, sample type, byte order, compress here or not, exact size or not, dims up
// to 16^3), the rest of the input its data. Data of exactly the promised size loads (finite
// values; int16 value for value), data of another size is refused.
void volume_data(const uint8_t* data, size_t size);

struct Target {
    const char* name;  // the harness: tests/fuzz/seeds/NAME/, tests/fuzz/regressions/NAME/
    void (*run)(const uint8_t* data, size_t size);
};

// Every target, by harness name: raw, cthead, tf, image, nifti, nrrd, metaimage, dicom,
// volume_data.
const std::vector<Target>& targets();

// libFuzzer's entry for one target: a broken promise aborts, so the fuzzer keeps the input.
inline int run_one(void (*target)(const uint8_t*, size_t), const uint8_t* data, size_t size) {
    try {
        target(data, size);
    } catch (const Broken& broken) {
        std::fprintf(stderr, "ctlab fuzz: broken promise: %s\n", broken.what());
        std::abort();
    }
    return 0;
}

}  // namespace ctlab_fuzz
