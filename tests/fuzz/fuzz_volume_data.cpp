// fuzz_volume_data.cpp: libFuzzer harness for the loaders' data paths, raw and compressed
// (common/file_input.h). Built and run by `make fuzz`; what it checks is in targets.cpp.
#include "targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    return ctlab_fuzz::run_one(ctlab_fuzz::volume_data, data, size);
}
