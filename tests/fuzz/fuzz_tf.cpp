// fuzz_tf.cpp: libFuzzer harness for the transfer-function parser.
// Built and run by `make fuzz`; what it checks is in targets.cpp.
#include "targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    return ctlab_fuzz::run_one(ctlab_fuzz::transfer_function, data, size);
}
