// The improved detector's loops that run in vector registers: the kernel sums, the one sweep
// over every particle of the cloud and the search for the runs of particles in one cell. Each is
// compiled for plain x86-64, AVX2 and AVX-512, chosen at run time; all give the same bits (plain
// IEEE operations, no fused multiply-add).
//
// Kernel sums, phi(x) = sum_k w_k (1 - q_k(x))_+^E, four or eight slots at a time: each term is
// rounded to an integer multiple of 2^-s (s fixed per detection by the largest kernel weight,
// ImprovedField::fixed_point_bits()) and the integers are added. An integer sum does not depend
// on the order of its terms, so the sums may be split into vector lanes, and a field built on
// part of the particles (the narrow band), an evaluation over a few slots (the edge roots) and
// one over the bins give bitwise the same value wherever they hold the same nonzero terms. A term
// of the largest weight is below 2^45 units, and the weights of all slots of the cloud together
// below 2^63 units, so no sum can overflow. The resolution, 2^-s, is below 1e-12 of the largest
// weight up to about 2^16 particles and about 2^-61 of the bound of all weights together beyond
// (6e-14 in volume fraction at 338k points).
#pragma once

#include <cstddef>
#include <cstdint>

namespace pfm::detail {

/// Slots past the end of every kernel array that the sums may read (filled with zeros): the
/// eight lanes of AVX-512.
inline constexpr int kKernelPadding = 8;

/// Kernel data by slot (one array per quantity): centre x, y (m), the inverse shape matrix
/// S^-1 = [k00 k01; k10 k11] (1/m) and the weight V_p C_p scaled by 2^s.
struct KernelColumns {
  const double *x, *y, *k00, *k01, *k10, *k11, *weight;
};

/// The integer sum of round(weight_k (1 - q_k)_+^exponent), q_k = |S_k^-1 (p - x_k)|^2, over
/// the slots of the ranges [begin[r], end[r]), r < n_ranges (exponent 1, 2 or 3).
std::uint64_t kernel_sum(int exponent, const KernelColumns& columns, const int* begin,
                         const int* end, int n_ranges, double px, double py);

/// The grid whose cell each particle is found in: cell (i, j) = j n_x + i holds
/// origin + ([i, i + 1), [j, j + 1)) / inverse_size.
struct CellLattice {
  double origin_x, origin_y, inverse_size;
  int n_x, n_y;
};

/// What a sweep over the positions gathers.
struct PositionTotals {
  double lo_x, lo_y, hi_x, hi_y;  ///< bounding box of the positions, m
  bool finite;                    ///< every coordinate finite
};

/// What a sweep over the volumes and deformation gradients gathers.
struct VolumeTotals {
  double largest_volume;   ///< m^2
  double largest_squared;  ///< largest sigma_max(F)^2 (1 without F)
  double smallest_det;     ///< smallest det F (1 without F)
  bool valid;              ///< every value finite, every volume and det F > 0
};

/// What one sweep over every particle gathers.
struct CloudTotals {
  PositionTotals positions;
  VolumeTotals volumes;
  bool valid() const { return positions.finite && volumes.valid; }
};

/// The totals of two parts of a cloud together (minima and maxima: exact in any order).
void include(PositionTotals& totals, const PositionTotals& part);
void include(VolumeTotals& totals, const VolumeTotals& part);

/// The positions x0 y0 x1 y1 ... of n >= 1 particles; with `cell`, the cell of `lattice` holding
/// each particle, or -1 outside it.
PositionTotals sweep_positions(const double* position, std::size_t n, const CellLattice& lattice,
                               int* cell);
/// The volumes and deformation gradients, column-major (f00 f10 f01 f11 ...; nullptr: none), of
/// n >= 1 particles.
VolumeTotals sweep_volumes(const double* volume, const double* deformation, std::size_t n);
/// The volumes of n particles as the stretch cap `cap` shrinks them, never raised (the narrow
/// band's measure of the space its cells' particles fill): out[p] = volume[p] min(1, det F' /
/// det F), F' the deformation gradient (column-major, as above) with its singular values
/// clamped to [1 / cap, cap].
void shrink_volumes(const double* volume, const double* deformation, std::size_t n, double cap,
                    double* out);
/// Both sweeps.
CloudTotals sweep_cloud(const double* position, const double* volume, const double* deformation,
                        std::size_t n, const CellLattice& lattice, int* cell);

/// The indices q of [begin, end), begin >= 1, where cell[q] != cell[q - 1] (a new run of
/// particles in one cell starts), in increasing order, written to `out` (room for end - begin
/// indices); returns how many. The cells are compared 16, 8 or 4 at a time, and every instruction
/// set gives the same indices.
std::size_t cell_changes(const int* cell, std::size_t begin, std::size_t end, std::uint32_t* out);

/// The instruction sets these loops are compiled for: plain x86-64 (two lanes of SSE2 where four
/// are written), AVX2 (four lanes) and AVX-512 (eight lanes in the kernel sums). All give the
/// same bits; the widest the processor has is used.
enum class VectorLanes { kPlain, kAvx2, kAvx512 };
/// The set in use, and the widest this processor has.
VectorLanes vector_lanes();
VectorLanes widest_vector_lanes();
/// Uses `lanes`, or the widest the processor has if that is narrower (tests compare them).
void set_vector_lanes(VectorLanes lanes);

}  // namespace pfm::detail
