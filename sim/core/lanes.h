// Scalars in vector lanes (GCC's vector extension) and the instruction sets the hot loops are
// compiled for, chosen at run time so that one binary runs on any x86-64.
#pragma once

namespace snowsim {

// Sanitized builds leave it out: instrumented, the flattened transfers take GCC over 11 minutes
// to compile (CMakeLists.txt). Inlining changes no result.
#ifdef SNOWSIM_SANITIZED
#define SNOWSIM_FLATTEN
#else
#define SNOWSIM_FLATTEN [[gnu::flatten]]
#endif

// The builds beside the baseline (x86-64-v2). AVX-512 for its 32 registers, its loops vectorised
// 256 bits wide (some processors slow down for 512-bit vectors); a 512-bit lane type, eight
// doubles, still takes one 512-bit register there.
#define SNOWSIM_TARGET_AVX2 [[gnu::target("avx2")]]
#define SNOWSIM_TARGET_AVX512 [[gnu::target("avx512f,avx512vl,prefer-vector-width=256")]]

// Four scalars in one value (GCC's vector extension), loaded from and stored to any scalar array:
// the compiler keeps one in a single vector register where the target has registers that wide,
// else in two. Lane-wise arithmetic rounds as scalar arithmetic does (no contraction into fused
// multiply-adds: -ffp-contract=off, CMakeLists.txt), so a loop on them gives the same result on
// every target.
template <class T>
struct Lanes4;
template <>
struct Lanes4<double> {
  typedef double type __attribute__((vector_size(32), aligned(8), may_alias));
};
template <>
struct Lanes4<float> {
  typedef float type __attribute__((vector_size(16), aligned(4), may_alias));
};
// Eight: one particle per lane in the 3D return mapping (snow_material.cpp).
template <class T>
struct Lanes8;
template <>
struct Lanes8<double> {
  typedef double type __attribute__((vector_size(64), aligned(8), may_alias));
};
template <>
struct Lanes8<float> {
  typedef float type __attribute__((vector_size(32), aligned(4), may_alias));
};

// The widest vector instructions the transfers and the return mapping are compiled for that the
// processor runs: the solvers call that build of them (the four-lane loops of TensorStencil in one
// register each; AVX-512's 32 registers keep the 3D transfers' sums out of memory). Found at the
// first call; tests set it to compare the builds.
enum class VectorIsa { baseline, avx2, avx512 };  // narrowest to widest

inline VectorIsa& vectorIsa() {
  static VectorIsa isa = [] {
    __builtin_cpu_init();
    if (!__builtin_cpu_supports("avx2")) return VectorIsa::baseline;
    // GCC's avx512f target includes AVX2: a virtual machine could offer one without the other.
    const bool avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl");
    return avx512 ? VectorIsa::avx512 : VectorIsa::avx2;
  }();
  return isa;
}

// f() in the build for isa: f and everything it calls inlined into a function compiled for that
// instruction set. The same arithmetic on every build (no contraction into fused multiply-adds),
// so the same results.
template <class F>
SNOWSIM_TARGET_AVX2 SNOWSIM_FLATTEN void runForAvx2(const F& f) {
  f();
}
template <class F>
SNOWSIM_TARGET_AVX512 SNOWSIM_FLATTEN void runForAvx512(const F& f) {
  f();
}
template <class F>
inline void runFor(VectorIsa isa, const F& f) {
  switch (isa) {
    case VectorIsa::avx512:
      return runForAvx512(f);
    case VectorIsa::avx2:
      return runForAvx2(f);
    case VectorIsa::baseline:
      break;
  }
  f();
}

}  // namespace snowsim
