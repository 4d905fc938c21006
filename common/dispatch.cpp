// dispatch.cpp: which copy of a vector loop runs (dispatch.h).
#include "dispatch.h"
#include <cstdlib>
#include <cstring>

namespace ctlab {

bool avx2_vectors() {
#if defined(__x86_64__) && defined(__GNUC__)
    static const bool chosen = [] {
        const char* forced = std::getenv("CTLAB_VECTORS");  // "sse2": the baseline copy
        if (forced != nullptr && std::strcmp(forced, "sse2") == 0) return false;
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2") != 0;
    }();
    return chosen;
#else
    return false;
#endif
}

}  // namespace ctlab
