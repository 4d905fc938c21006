// fuzz_metaimage.cpp: libFuzzer harness for the metaimage loader (common/formats.h).
// Built and run by `make fuzz`; what it checks is in targets.cpp.
#include "targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    return ctlab_fuzz::run_one(ctlab_fuzz::metaimage_file, data, size);
}
