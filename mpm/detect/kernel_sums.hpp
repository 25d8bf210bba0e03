// The improved detector's kernel sums, phi(x) = sum_k w_k (1 - q_k(x))_+^E, four slots at a
// time in vector registers.
//
// Each term is rounded to an integer multiple of 2^-s (s fixed per detection by the largest
// kernel weight, ImprovedField::fixed_point_bits()) and the integers are added: an integer sum
// does not depend on the order of its terms, so the sums may be split into vector lanes, and a
// field built on part of the particles (the narrow band), an evaluation over a few slots (the
// edge roots) and one over the bins give bitwise the same value wherever they hold the same
// nonzero terms. A term of the largest weight is below 2^45 units, so a sum of up to 2^18 such
// terms stays exact in 64 bits. The resolution, 2^-s, is below 1e-12 of the largest weight.
#pragma once

#include <cstdint>

namespace pfm::detail {

/// Slots past the end of every kernel array that the sums may read (filled with zeros).
inline constexpr int kKernelPadding = 4;

/// Kernel data by slot (one array per quantity): centre x, y (m), the inverse shape matrix
/// S^-1 = [k00 k01; k10 k11] (1/m) and the weight V_p C_p scaled by 2^s.
struct KernelColumns {
  const double *x, *y, *k00, *k01, *k10, *k11, *weight;
};

/// The integer sum of round(weight_k (1 - q_k)_+^exponent), q_k = |S_k^-1 (p - x_k)|^2, over
/// the slots of the ranges [begin[r], end[r]), r < n_ranges (exponent 1, 2 or 3). Runs with AVX2
/// where the processor has it; the result is the same without (no fused multiply-add).
std::uint64_t kernel_sum(int exponent, const KernelColumns& columns, const int* begin,
                         const int* end, int n_ranges, double px, double py);

/// Whether kernel_sum() uses AVX2; tests switch it off to compare (false: 2 x 2 lanes of SSE2
/// or plain code).
bool kernel_sum_uses_avx2();
void set_kernel_sum_avx2(bool on);

}  // namespace pfm::detail
