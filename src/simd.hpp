#pragma once
// Run-time choice of vector width for the few kernels where a wider instruction set pays
// (Gain::left_l1's): the portable build targets SSE2; where the processor has AVX (and the
// operating system saves its registers) the kernels run four doubles wide. Both widths give
// the same bits (each lane sums in the same order, with separate multiplies and adds), so
// results do not depend on the machine. No -march flag is needed.

#include <atomic>

#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__)
#define DBBKIT_WIDE_VECTORS 1
#else
#define DBBKIT_WIDE_VECTORS 0
#endif

namespace dbbkit::detail {

// Whether the wide kernels may run at all (tests turn them off to compare both widths).
inline std::atomic<bool>& wide_vectors_allowed() {
  static std::atomic<bool> allowed{true};
  return allowed;
}

inline bool use_wide_vectors() {
#if DBBKIT_WIDE_VECTORS
  static const bool avx = __builtin_cpu_supports("avx");
  return avx && wide_vectors_allowed().load(std::memory_order_relaxed);
#else
  return false;
#endif
}

}  // namespace dbbkit::detail
