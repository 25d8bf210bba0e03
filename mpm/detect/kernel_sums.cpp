#include "mpm/detect/kernel_sums.hpp"

#include <cstring>

namespace pfm::detail {

namespace {

// Four lanes (GCC vector extensions: one AVX2 register, or two SSE2 registers without AVX2).
using V4 = double __attribute__((vector_size(32)));
using I4 = std::int64_t __attribute__((vector_size(32)));
using U4 = std::uint64_t __attribute__((vector_size(32)));

// 2^52: a double in [2^52, 2^53) is an integer and its bits less those of 2^52 are that integer,
// so round(v) of 0 <= v < 2^51 is bits(v + 2^52) - bits(2^52).
constexpr double kMagic = 0x1p52;
constexpr std::uint64_t kMagicBits = 0x4330000000000000ULL;

// The body of kernel_sum() for exponent E: compiled once for plain x86-64 and once for AVX2.
// Lanes past a range's end (reading the arrays' padding or the next range) add 0; every
// operation is a plain IEEE one, so both compilations give the same terms.
template <int E>
[[gnu::always_inline]] inline std::uint64_t sum_ranges(const KernelColumns& c, const int* begin,
                                                       const int* end, int n_ranges, double px,
                                                       double py) {
  U4 acc = {0, 0, 0, 0};
  std::uint64_t lanes = 0;
  const I4 lane = {0, 1, 2, 3};
  const I4 no_sign = {INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX};
  for (int r = 0; r < n_ranges; ++r) {
    const int last = end[r];
    for (int k = begin[r]; k < last; k += 4) {
      V4 x, y, k00, k01, k10, k11, weight;
      std::memcpy(&x, c.x + k, sizeof x);
      std::memcpy(&y, c.y + k, sizeof y);
      std::memcpy(&k00, c.k00 + k, sizeof k00);
      std::memcpy(&k01, c.k01 + k, sizeof k01);
      std::memcpy(&k10, c.k10 + k, sizeof k10);
      std::memcpy(&k11, c.k11 + k, sizeof k11);
      std::memcpy(&weight, c.weight + k, sizeof weight);
      const V4 dx = px - x, dy = py - y;
      const V4 ux = k00 * dx + k01 * dy, uy = k10 * dx + k11 * dy;
      const V4 t = 1.0 - (ux * ux + uy * uy);
      // max(t, 0) = (|t| + t) / 2 exactly, without a branch.
      const V4 w = 0.5 * ((V4)((I4)t & no_sign) + t);
      V4 term;
      if constexpr (E == 1) {
        term = weight * w;
      } else if constexpr (E == 2) {
        term = weight * (w * w);
      } else {
        term = weight * ((w * w) * w);
      }
      const I4 in_range = (lane + k) < last;  // all ones or zero per lane
      term = (V4)((I4)term & in_range);
      acc += (U4)(term + kMagic);
      lanes += 4;
    }
  }
  return acc[0] + acc[1] + acc[2] + acc[3] - lanes * kMagicBits;
}

template <int E>
std::uint64_t sum_plain(const KernelColumns& c, const int* begin, const int* end, int n_ranges,
                        double px, double py) {
  return sum_ranges<E>(c, begin, end, n_ranges, px, py);
}

#if defined(__x86_64__) && defined(__GNUC__)
#define PFM_KERNEL_SUM_AVX2 1
// No "fma" in the target: a fused multiply-add would round the terms differently from the plain
// version.
template <int E>
[[gnu::target("avx2")]] std::uint64_t sum_avx2(const KernelColumns& c, const int* begin,
                                               const int* end, int n_ranges, double px, double py) {
  return sum_ranges<E>(c, begin, end, n_ranges, px, py);
}
#endif

using SumFunction = std::uint64_t (*)(const KernelColumns&, const int*, const int*, int, double,
                                      double);

bool detect_avx2() {
#ifdef PFM_KERNEL_SUM_AVX2
  return __builtin_cpu_supports("avx2") != 0;
#else
  return false;
#endif
}

bool avx2_on = detect_avx2();

}  // namespace

std::uint64_t kernel_sum(int exponent, const KernelColumns& columns, const int* begin,
                         const int* end, int n_ranges, double px, double py) {
#ifdef PFM_KERNEL_SUM_AVX2
  static constexpr SumFunction kAvx2[3] = {sum_avx2<1>, sum_avx2<2>, sum_avx2<3>};
  if (avx2_on) return kAvx2[exponent - 1](columns, begin, end, n_ranges, px, py);
#endif
  static constexpr SumFunction kPlain[3] = {sum_plain<1>, sum_plain<2>, sum_plain<3>};
  return kPlain[exponent - 1](columns, begin, end, n_ranges, px, py);
}

bool kernel_sum_uses_avx2() {
  return avx2_on;
}

void set_kernel_sum_avx2(bool on) {
  avx2_on = on && detect_avx2();
}

}  // namespace pfm::detail
