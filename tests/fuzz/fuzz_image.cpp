// fuzz_image.cpp: libFuzzer harness for the checker's image reader, read_image_bytes.
// Built and run by `make fuzz`; what it checks is in targets.cpp.
#include "targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    return ctlab_fuzz::run_one(ctlab_fuzz::image_file, data, size);
}
