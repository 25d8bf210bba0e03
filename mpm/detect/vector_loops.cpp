#include "mpm/detect/vector_loops.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

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

// The vector types of W lanes: four as above, eight in one AVX-512 register.
template <int W>
struct Lanes;
template <>
struct Lanes<4> {
  using V = V4;
  using I = I4;
  using U = U4;
};
template <>
struct Lanes<8> {
  using V = double __attribute__((vector_size(64)));
  using I = std::int64_t __attribute__((vector_size(64)));
  using U = std::uint64_t __attribute__((vector_size(64)));
};

// The body of kernel_sum() for exponent E, W lanes: compiled once for plain x86-64 and AVX2 (4
// lanes) and once for AVX-512 (8 lanes). Lanes past a range's end (reading the arrays' padding
// or the next range) add 0; every operation is a plain IEEE one, so all compilations give the
// same terms.
template <int E, int W>
[[gnu::always_inline]] inline std::uint64_t sum_ranges(const KernelColumns& c, const int* begin,
                                                       const int* end, int n_ranges, double px,
                                                       double py) {
  using V = typename Lanes<W>::V;
  using I = typename Lanes<W>::I;
  using U = typename Lanes<W>::U;
  U acc = {};
  std::uint64_t lanes = 0;
  I lane;
  for (int k = 0; k < W; ++k) lane[k] = k;
  const I no_sign = lane * 0 + INT64_MAX;
  for (int r = 0; r < n_ranges; ++r) {
    const int last = end[r];
    for (int k = begin[r]; k < last; k += W) {
      V x, y, k00, k01, k10, k11, weight;
      std::memcpy(&x, c.x + k, sizeof x);
      std::memcpy(&y, c.y + k, sizeof y);
      std::memcpy(&k00, c.k00 + k, sizeof k00);
      std::memcpy(&k01, c.k01 + k, sizeof k01);
      std::memcpy(&k10, c.k10 + k, sizeof k10);
      std::memcpy(&k11, c.k11 + k, sizeof k11);
      std::memcpy(&weight, c.weight + k, sizeof weight);
      const V dx = px - x, dy = py - y;
      const V ux = k00 * dx + k01 * dy, uy = k10 * dx + k11 * dy;
      const V t = 1.0 - (ux * ux + uy * uy);
      // max(t, 0) = (|t| + t) / 2 exactly, without a branch.
      const V w = 0.5 * ((V)((I)t & no_sign) + t);
      V term;
      if constexpr (E == 1) {
        term = weight * w;
      } else if constexpr (E == 2) {
        term = weight * (w * w);
      } else {
        term = weight * ((w * w) * w);
      }
      const I in_range = (lane + k) < last;  // all ones or zero per lane
      term = (V)((I)term & in_range);
      acc += (U)(term + kMagic);
      lanes += W;
    }
  }
  std::uint64_t total = 0;
  for (int k = 0; k < W; ++k) total += acc[k];
  return total - lanes * kMagicBits;
}

// The sweeps of sweep_positions() and sweep_volumes(), compiled like sum_ranges(). Minima, maxima
// and the sums of zeros that test finiteness are exact in any order, so the vector lanes change
// nothing.
template <bool Cells>
[[gnu::always_inline]] inline PositionTotals position_sweep(const double* x, std::size_t n,
                                                            const CellLattice& g, int* cell) {
  double lo_x = x[0], lo_y = x[1], hi_x = x[0], hi_y = x[1];
  double finite = 0.0;  // stays 0 while every value is finite (v * 0 is NaN for inf and NaN)
  // Truncation is the floor for the offsets in [0, n); the others are outside (converted as 0,
  // then replaced by -1: no branch, so the loop runs in vector lanes). The lattice in locals: the
  // stores to `cell` could otherwise alias it.
  const double upper_i = g.n_x, upper_j = g.n_y;
  const double origin_x = g.origin_x, origin_y = g.origin_y, inverse_size = g.inverse_size;
  const int n_x = g.n_x;
#pragma omp simd reduction(min : lo_x, lo_y) reduction(max : hi_x, hi_y) reduction(+ : finite)
  for (std::size_t p = 0; p < n; ++p) {
    const double px = x[2 * p], py = x[2 * p + 1];
    lo_x = std::min(lo_x, px);
    lo_y = std::min(lo_y, py);
    hi_x = std::max(hi_x, px);
    hi_y = std::max(hi_y, py);
    finite += (px + py) * 0.0;
    if constexpr (Cells) {
      const double ti = (px - origin_x) * inverse_size;
      const double tj = (py - origin_y) * inverse_size;
      const bool in = (ti >= 0.0) & (tj >= 0.0) & (ti < upper_i) & (tj < upper_j);
      const int c = static_cast<int>(in ? tj : 0.0) * n_x + static_cast<int>(in ? ti : 0.0);
      cell[p] = in ? c : -1;
    }
  }
  return {lo_x, lo_y, hi_x, hi_y, finite == 0.0};
}

[[gnu::always_inline]] inline VolumeTotals volume_sweep(const double* volume, const double* f,
                                                        std::size_t n) {
  double largest_volume = 0.0, finite = 0.0;
  int positive = 1;
#pragma omp simd reduction(max : largest_volume) reduction(+ : finite) reduction(& : positive)
  for (std::size_t p = 0; p < n; ++p) {
    const double v = volume[p];
    largest_volume = std::max(largest_volume, v);
    finite += v * 0.0;
    positive &= v > 0.0 ? 1 : 0;
  }
  double largest_squared = 1.0, smallest_det = 1.0;
  if (f != nullptr) {
    // sigma_max^2, the larger eigenvalue of F^T F = [a b; b c]: (a + c + sqrt((a - c)^2 + 4 b^2))
    // / 2.
    largest_squared = 0.0;
    smallest_det = std::numeric_limits<double>::infinity();
#pragma omp simd reduction(max : largest_squared) reduction(min : smallest_det) \
    reduction(+ : finite) reduction(& : positive)
    for (std::size_t p = 0; p < n; ++p) {
      const double f00 = f[4 * p], f10 = f[4 * p + 1], f01 = f[4 * p + 2], f11 = f[4 * p + 3];
      const double a = f00 * f00 + f10 * f10, c = f01 * f01 + f11 * f11;
      const double b = f00 * f01 + f10 * f11, d = f00 * f11 - f01 * f10;
      finite += (a + c) * 0.0;
      positive &= d > 0.0 ? 1 : 0;
      smallest_det = std::min(smallest_det, d);
      largest_squared =
          std::max(largest_squared, 0.5 * (a + c + std::sqrt((a - c) * (a - c) + 4.0 * b * b)));
    }
  }
  return {largest_volume, largest_squared, smallest_det, finite == 0.0 && positive != 0};
}

// The body of shrink_volumes(): sigma_1^2 is the larger eigenvalue of F^T F = [a b; b c],
// sigma_2 = det F / sigma_1, and the factor the product of the clamped over the raw ones, at most
// 1 (plain IEEE operations: every compilation gives the same bits).
[[gnu::always_inline]] inline void shrink_sweep(const double* volume, const double* f,
                                                std::size_t n, double cap, double* out) {
  const double floor = 1.0 / cap;
#pragma omp simd
  for (std::size_t p = 0; p < n; ++p) {
    const double f00 = f[4 * p], f10 = f[4 * p + 1], f01 = f[4 * p + 2], f11 = f[4 * p + 3];
    const double a = f00 * f00 + f10 * f10, c = f01 * f01 + f11 * f11;
    const double b = f00 * f01 + f10 * f11, d = f00 * f11 - f01 * f10;
    const double s1 = std::sqrt(0.5 * (a + c + std::sqrt((a - c) * (a - c) + 4.0 * b * b)));
    const double s2 = d / s1;
    const double c1 = s1 > cap ? cap : (s1 < floor ? floor : s1);
    const double c2 = s2 > cap ? cap : (s2 < floor ? floor : s2);
    const double k = (c1 / s1) * (c2 / s2);
    out[p] = volume[p] * (k < 1.0 ? k : 1.0);
  }
}

void shrink_plain(const double* v, const double* f, std::size_t n, double cap, double* out) {
  shrink_sweep(v, f, n, cap, out);
}

template <int E>
std::uint64_t sum_plain(const KernelColumns& c, const int* begin, const int* end, int n_ranges,
                        double px, double py) {
  return sum_ranges<E, 4>(c, begin, end, n_ranges, px, py);
}

template <bool Cells>
PositionTotals positions_plain(const double* x, std::size_t n, const CellLattice& g, int* cell) {
  return position_sweep<Cells>(x, n, g, cell);
}

VolumeTotals volumes_plain(const double* v, const double* f, std::size_t n) {
  return volume_sweep(v, f, n);
}

// cell_changes() from index q on, k indices found so far: each index is written at the next free
// place, which only a change keeps (no branch; the place is within the room for end - begin).
std::size_t changes_from(const int* cell, std::size_t q, std::size_t end, std::uint32_t* out,
                         std::size_t k) {
  for (; q < end; ++q) {
    out[k] = static_cast<std::uint32_t>(q);
    k += cell[q] != cell[q - 1] ? 1 : 0;
  }
  return k;
}

// The changes whose bit is set in `mask` (bit i: cell q + i), appended to out from place k.
[[gnu::always_inline]] inline std::size_t append_changes(unsigned mask, std::size_t q,
                                                         std::uint32_t* out, std::size_t k) {
  while (mask != 0) {
    out[k++] = static_cast<std::uint32_t>(q + static_cast<std::size_t>(__builtin_ctz(mask)));
    mask &= mask - 1;
  }
  return k;
}

#if defined(__x86_64__) && defined(__GNUC__)
#define PFM_VECTOR_LOOPS_X86 1
// Fused multiply-adds would round differently from the plain version: the file is compiled
// with -ffp-contract=off (AVX-512 brings FMA instructions with it).
template <int E>
[[gnu::target("avx2")]] std::uint64_t sum_avx2(const KernelColumns& c, const int* begin,
                                               const int* end, int n_ranges, double px, double py) {
  return sum_ranges<E, 4>(c, begin, end, n_ranges, px, py);
}

template <bool Cells>
[[gnu::target("avx2")]] PositionTotals positions_avx2(const double* x, std::size_t n,
                                                      const CellLattice& g, int* cell) {
  return position_sweep<Cells>(x, n, g, cell);
}

[[gnu::target("avx2")]] VolumeTotals volumes_avx2(const double* v, const double* f, std::size_t n) {
  return volume_sweep(v, f, n);
}

[[gnu::target("avx2")]] void shrink_avx2(const double* v, const double* f, std::size_t n,
                                         double cap, double* out) {
  shrink_sweep(v, f, n, cap, out);
}

// Four cells at a time in SSE2, which every x86-64 processor has.
std::size_t changes_sse2(const int* cell, std::size_t begin, std::size_t end, std::uint32_t* out) {
  std::size_t q = begin, k = 0;
  for (; q + 4 <= end; q += 4) {
    const __m128i a = _mm_loadu_si128(reinterpret_cast<const __m128i*>(cell + q));
    const __m128i b = _mm_loadu_si128(reinterpret_cast<const __m128i*>(cell + q - 1));
    const unsigned same =
        static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(a, b))));
    k = append_changes(~same & 0xFu, q, out, k);
  }
  return changes_from(cell, q, end, out, k);
}

[[gnu::target("avx2")]] std::size_t changes_avx2(const int* cell, std::size_t begin,
                                                 std::size_t end, std::uint32_t* out) {
  std::size_t q = begin, k = 0;
  for (; q + 8 <= end; q += 8) {
    const __m256i a = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cell + q));
    const __m256i b = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cell + q - 1));
    const unsigned same =
        static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(a, b))));
    k = append_changes(~same & 0xFFu, q, out, k);
  }
  return changes_from(cell, q, end, out, k);
}

#define PFM_AVX512 "avx512f,avx512dq,avx512vl"
[[gnu::target(PFM_AVX512)]] std::size_t changes_avx512(const int* cell, std::size_t begin,
                                                       std::size_t end, std::uint32_t* out) {
  std::size_t q = begin, k = 0;
  for (; q + 16 <= end; q += 16) {
    const __m512i a = _mm512_loadu_si512(cell + q);
    const __m512i b = _mm512_loadu_si512(cell + q - 1);
    k = append_changes(_mm512_cmpneq_epi32_mask(a, b), q, out, k);
  }
  return changes_from(cell, q, end, out, k);
}

template <int E>
[[gnu::target(PFM_AVX512)]] std::uint64_t sum_avx512(const KernelColumns& c, const int* begin,
                                                     const int* end, int n_ranges, double px,
                                                     double py) {
  return sum_ranges<E, 8>(c, begin, end, n_ranges, px, py);
}

template <bool Cells>
[[gnu::target(PFM_AVX512)]] PositionTotals positions_avx512(const double* x, std::size_t n,
                                                            const CellLattice& g, int* cell) {
  return position_sweep<Cells>(x, n, g, cell);
}

[[gnu::target(PFM_AVX512)]] VolumeTotals volumes_avx512(const double* v, const double* f,
                                                        std::size_t n) {
  return volume_sweep(v, f, n);
}

[[gnu::target(PFM_AVX512)]] void shrink_avx512(const double* v, const double* f, std::size_t n,
                                               double cap, double* out) {
  shrink_sweep(v, f, n, cap, out);
}
#undef PFM_AVX512
#endif

using SumFunction = std::uint64_t (*)(const KernelColumns&, const int*, const int*, int, double,
                                      double);

VectorLanes best_lanes() {
#ifdef PFM_VECTOR_LOOPS_X86
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
      __builtin_cpu_supports("avx512vl")) {
    return VectorLanes::kAvx512;
  }
  if (__builtin_cpu_supports("avx2")) return VectorLanes::kAvx2;
#endif
  return VectorLanes::kPlain;
}

VectorLanes lanes_in_use = best_lanes();

}  // namespace

std::uint64_t kernel_sum(int exponent, const KernelColumns& columns, const int* begin,
                         const int* end, int n_ranges, double px, double py) {
#ifdef PFM_VECTOR_LOOPS_X86
  static constexpr SumFunction kAvx512[3] = {sum_avx512<1>, sum_avx512<2>, sum_avx512<3>};
  static constexpr SumFunction kAvx2[3] = {sum_avx2<1>, sum_avx2<2>, sum_avx2<3>};
  if (lanes_in_use == VectorLanes::kAvx512) {
    return kAvx512[exponent - 1](columns, begin, end, n_ranges, px, py);
  }
  if (lanes_in_use == VectorLanes::kAvx2) {
    return kAvx2[exponent - 1](columns, begin, end, n_ranges, px, py);
  }
#endif
  static constexpr SumFunction kPlain[3] = {sum_plain<1>, sum_plain<2>, sum_plain<3>};
  return kPlain[exponent - 1](columns, begin, end, n_ranges, px, py);
}

void include(PositionTotals& totals, const PositionTotals& part) {
  totals.lo_x = std::min(totals.lo_x, part.lo_x);
  totals.lo_y = std::min(totals.lo_y, part.lo_y);
  totals.hi_x = std::max(totals.hi_x, part.hi_x);
  totals.hi_y = std::max(totals.hi_y, part.hi_y);
  totals.finite = totals.finite && part.finite;
}

void include(VolumeTotals& totals, const VolumeTotals& part) {
  totals.largest_volume = std::max(totals.largest_volume, part.largest_volume);
  totals.largest_squared = std::max(totals.largest_squared, part.largest_squared);
  totals.smallest_det = std::min(totals.smallest_det, part.smallest_det);
  totals.valid = totals.valid && part.valid;
}

PositionTotals sweep_positions(const double* position, std::size_t n, const CellLattice& lattice,
                               int* cell) {
  const double* x = position;
#ifdef PFM_VECTOR_LOOPS_X86
  if (lanes_in_use == VectorLanes::kAvx512) {
    return cell != nullptr ? positions_avx512<true>(x, n, lattice, cell)
                           : positions_avx512<false>(x, n, lattice, cell);
  }
  if (lanes_in_use == VectorLanes::kAvx2) {
    return cell != nullptr ? positions_avx2<true>(x, n, lattice, cell)
                           : positions_avx2<false>(x, n, lattice, cell);
  }
#endif
  return cell != nullptr ? positions_plain<true>(x, n, lattice, cell)
                         : positions_plain<false>(x, n, lattice, cell);
}

VolumeTotals sweep_volumes(const double* volume, const double* deformation, std::size_t n) {
#ifdef PFM_VECTOR_LOOPS_X86
  if (lanes_in_use == VectorLanes::kAvx512) return volumes_avx512(volume, deformation, n);
  if (lanes_in_use == VectorLanes::kAvx2) return volumes_avx2(volume, deformation, n);
#endif
  return volumes_plain(volume, deformation, n);
}

void shrink_volumes(const double* volume, const double* deformation, std::size_t n, double cap,
                    double* out) {
#ifdef PFM_VECTOR_LOOPS_X86
  if (lanes_in_use == VectorLanes::kAvx512) return shrink_avx512(volume, deformation, n, cap, out);
  if (lanes_in_use == VectorLanes::kAvx2) return shrink_avx2(volume, deformation, n, cap, out);
#endif
  shrink_plain(volume, deformation, n, cap, out);
}

std::size_t cell_changes(const int* cell, std::size_t begin, std::size_t end, std::uint32_t* out) {
#ifdef PFM_VECTOR_LOOPS_X86
  if (lanes_in_use == VectorLanes::kAvx512) return changes_avx512(cell, begin, end, out);
  if (lanes_in_use == VectorLanes::kAvx2) return changes_avx2(cell, begin, end, out);
  return changes_sse2(cell, begin, end, out);
#else
  return changes_from(cell, begin, end, out, 0);
#endif
}

CloudTotals sweep_cloud(const double* position, const double* volume, const double* deformation,
                        std::size_t n, const CellLattice& lattice, int* cell) {
  return {sweep_positions(position, n, lattice, cell), sweep_volumes(volume, deformation, n)};
}

VectorLanes vector_lanes() {
  return lanes_in_use;
}

VectorLanes widest_vector_lanes() {
  return best_lanes();
}

void set_vector_lanes(VectorLanes lanes) {
  lanes_in_use = std::min(lanes, best_lanes());
}

}  // namespace pfm::detail
