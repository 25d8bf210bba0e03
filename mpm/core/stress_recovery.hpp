// Stresses recovered next to a boundary whose traction is known. Shared by every solver on
// particles (the explicit MPM's outputs; the implicit one's).
//
// A point's own stress is least accurate within a cell or two of a loaded or free boundary: the
// grid functions there are cut by the boundary, and the load reaches the points through nodes
// that the interior's balance does not hold (make study-near_boundary measures the error by the
// distance from the boundary). The boundary itself says what the stress there is, sigma n = t. The
// recovery fits, for each point p within `band` cells of a boundary sample with a known traction,
// the linear field
//   sigma(x) = a + G (x - x_p)   (sxx, syy, sxy: 9 coefficients)
// in the weighted least-squares sense to
//   * the stresses of the points farther than `band` cells from every such sample (the
//     trusted points) within `radius` cells of x_p (grown a cell at a time up to max_radius
//     until at least min_points are found), weight 1 each, and
//   * the tractions sigma(x_b) n_b = t_b at the samples within the same radius, each equation
//     weighted by boundary_weight x sqrt(length_b / h) (a length of boundary counts as much as
//     boundary_weight^2 points per cell of it: the condition is nearly exact),
// and takes a: the superconvergent patch recovery of Zienkiewicz & Zhu (IJNME 33, 1992) with the
// boundary's tractions among its conditions (Wiberg & Abdulwahab, IJNME 36, 1993; Boroomand &
// Zienkiewicz, IJNME 40, 1997). szz, which no traction constrains, is fitted to the trusted points
// alone. Points farther than `band` cells from every known traction keep their stress, and so do
// points with fewer than 3 trusted points in reach (a body too thin for an interior).
//
// Exactness: a linear stress field is recovered exactly where the trusted points carry it and
// the tractions are those of that field (tests/cpp/core/test_stress_recovery.cpp). The band of
// 3 cells and the patch of 4: the points' own errors reach into the third cell (make
// study-near_boundary), and a band of 2 cells would take them into the fit as trusted points.
// Cost: one fit of a 9 x 9 normal system per point in the band, at output steps only (run.json's
// summary.stress_recovery: calls and seconds).
#pragma once

#include <span>
#include <vector>

#include "mpm/core/types.hpp"

namespace pfm {

/// A point of the boundary where the traction is known: position (m), outward unit normal,
/// traction (kPa) and the boundary length it stands for (m).
struct TractionSample {
  Vec2 x = Vec2::Zero();
  Vec2 normal = Vec2::Zero();
  Vec2 traction = Vec2::Zero();
  double length = 0.0;
};

struct StressRecoveryOptions {
  double band = 3.0;        ///< cells: the points recovered, and no trusted point nearer
  double radius = 4.0;      ///< cells: the patch
  double max_radius = 6.0;  ///< cells: the patch grown up to this for min_points
  int min_points = 6;
  double boundary_weight = 20.0;
};

/// The recovered stress of every point (header comment); `h`: the cell size, m.
std::vector<Stress> recover_stress(std::span<const Vec2> position, std::span<const Stress> stress,
                                   std::span<const TractionSample> samples, double h,
                                   const StressRecoveryOptions& options = {});

}  // namespace pfm
