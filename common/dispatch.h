// dispatch.h: run-time dispatch for part 3's vector loops (given code, no lesson). A loop of
// fixed length that the compiler makes vector instructions is compiled twice from one body:
// for SSE2 (128-bit vectors, in every x86-64 processor: the build's own target) and for AVX2
// (256-bit vectors: eight floats at once, and integer min, max, multiply and packing in one
// instruction each); the processor running the program picks one, once, at run time. Only
// GCC's (and Clang's) target attribute, no package: elsewhere the body is compiled once.
// Neither copy uses FMA, so both give the same floats, to the bit (tests/test_part3.cpp
// compares them, forcing the SSE2 copy with CTLAB_VECTORS=sse2 in the environment).
#pragma once

namespace ctlab {

// True when with_vectors() runs its AVX2 copy: the processor has AVX2 and the environment
// does not say CTLAB_VECTORS=sse2. Decided on the first call; the same for the whole run.
bool avx2_vectors();

#if defined(__x86_64__) && defined(__GNUC__)
// Marks the body a lambda given to with_vectors() (`[&]() CTLAB_VECTOR_BODY { ... }`): it is
// inlined, so it is compiled again inside the AVX2 copy with that copy's instructions.
#define CTLAB_VECTOR_BODY __attribute__((always_inline))
// Marks a function that such a body calls the same way (inlined, so in both copies).
#define CTLAB_VECTOR_CODE __attribute__((always_inline)) inline

template <class Body>
__attribute__((target("avx2"))) auto avx2_copy(const Body& body) {
    return body();
}

// body()'s result: its AVX2 copy where avx2_vectors() says so, else its SSE2 one.
template <class Body>
auto with_vectors(const Body& body) {
    return avx2_vectors() ? avx2_copy(body) : body();
}

// A function that calls body(arguments...) through with_vectors(): for a loop's body given
// to another function (parallel_rows()), which then runs each call's AVX2 or SSE2 copy.
template <class Body>
auto vectorized(const Body& body) {
    return [body](auto&&... arguments) {
        return with_vectors([&]() CTLAB_VECTOR_BODY { return body(arguments...); });
    };
}
#else
#define CTLAB_VECTOR_BODY
#define CTLAB_VECTOR_CODE inline

template <class Body>
auto with_vectors(const Body& body) {
    return body();
}

template <class Body>
auto vectorized(const Body& body) {
    return body;
}
#endif

}  // namespace ctlab
