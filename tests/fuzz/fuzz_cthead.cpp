// fuzz_cthead.cpp: libFuzzer harness for the CThead path of load_volume, through a file.
// Built and run by `make fuzz`; what it checks is in targets.cpp.
#include "targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    return ctlab_fuzz::run_one(ctlab_fuzz::cthead_file, data, size);
}
