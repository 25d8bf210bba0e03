// Uniform binning of particles so a field evaluation visits only the particles whose kernel can
// reach the evaluation point: O(neighbours) per evaluation instead of O(particles). Used by the
// detectors (mpm/detect) and the stress recovery (stress_recovery.hpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <span>
#include <vector>

#include "mpm/core/types.hpp"

namespace pfm {

class ParticleBins {
 public:
  ParticleBins() = default;
  /// Bins of side `bin_size` (m, > 0) covering the bounding box of `positions`. A kernel whose
  /// reach is <= bin_size is fully found by for_each_near().
  ParticleBins(std::span<const Vec2> positions, double bin_size);

  /// Calls visit(p) for every particle in the 3 x 3 bins around x, in a fixed order (bins row by
  /// row, particles by increasing index), so sums over the visits are bitwise reproducible.
  template <class Visitor>
  void for_each_near(const Vec2& x, Visitor&& visit) const {
    if (n_x_ == 0) return;
    const int bi = bin_i(x.x()), bj = bin_j(x.y());
    for (int j = std::max(bj - 1, 0); j <= std::min(bj + 1, n_y_ - 1); ++j) {
      for (int i = std::max(bi - 1, 0); i <= std::min(bi + 1, n_x_ - 1); ++i) {
        const int b = j * n_x_ + i;
        for (int k = start_[b]; k < start_[b + 1]; ++k) visit(particle_[k]);
      }
    }
  }

  /// Calls visit(k) with the slot k (position in bin order, see particle_at()) of every particle
  /// in the (2 rings + 1)^2 bins around x, bins row by row and slots increasing: a kernel whose
  /// reach is <= rings * bin_size is fully found. Arrays kept in slot order are read in sequence.
  template <class Visitor>
  void for_each_slot_near(const Vec2& x, int rings, Visitor&& visit) const {
    if (n_x_ == 0) return;
    const int bi = bin_i(x.x()), bj = bin_j(x.y());
    const int i0 = std::max(bi - rings, 0), i1 = std::min(bi + rings, n_x_ - 1);
    for (int j = std::max(bj - rings, 0); j <= std::min(bj + rings, n_y_ - 1); ++j) {
      if (i0 > i1) break;
      // Bins i0..i1 of a row are contiguous in slot order.
      const int end = start_[j * n_x_ + i1 + 1];
      for (int k = start_[j * n_x_ + i0]; k < end; ++k) visit(k);
    }
  }

  /// The slots of for_each_slot_near(x, rings) as ranges [begin[r], end[r]), one per bin row
  /// (the arrays hold 2 rings + 1); returns the number of ranges.
  int slot_rows_near(const Vec2& x, int rings, int* begin, int* end) const {
    if (n_x_ == 0) return 0;
    const int bi = bin_i(x.x()), bj = bin_j(x.y());
    const int i0 = std::max(bi - rings, 0), i1 = std::min(bi + rings, n_x_ - 1);
    if (i0 > i1) return 0;
    int rows = 0;
    for (int j = std::max(bj - rings, 0); j <= std::min(bj + rings, n_y_ - 1); ++j) {
      begin[rows] = start_[j * n_x_ + i0];
      end[rows] = start_[j * n_x_ + i1 + 1];
      ++rows;
    }
    return rows;
  }

  /// Calls visit(k) for the slots of every bin that overlaps the box [lo, hi], in increasing
  /// slot order.
  template <class Visitor>
  void for_each_slot_in_box(const Vec2& lo, const Vec2& hi, Visitor&& visit) const {
    if (n_x_ == 0) return;
    const int i0 = std::max(bin_i(lo.x()), 0);
    const int i1 = std::min(bin_i(hi.x()), n_x_ - 1);
    const int j0 = std::max(bin_j(lo.y()), 0);
    const int j1 = std::min(bin_j(hi.y()), n_y_ - 1);
    if (i0 > i1) return;
    for (int j = j0; j <= j1; ++j) {
      const int end = start_[j * n_x_ + i1 + 1];
      for (int k = start_[j * n_x_ + i0]; k < end; ++k) visit(k);
    }
  }

  /// Particle index of slot k, and slot of particle p.
  int particle_at(int k) const { return particle_[k]; }
  int slot_of(int p) const { return slot_[p]; }
  std::size_t size() const { return particle_.size(); }

  /// Calls visit(p) for particles in rings of bins around x, ring by ring, until two rings past
  /// the first ring with a particle have been searched (the closest particle by Euclidean distance
  /// is then among the visited ones unless it is more than ~1.4 times farther than that ring). Used
  /// by nearest().
  template <class Visitor>
  void for_each_nearest_rings(const Vec2& x, Visitor&& visit) const {
    if (n_x_ == 0) return;
    const int bi = bin_i(x.x()), bj = bin_j(x.y());
    int first_hit_ring = -1;
    const int max_ring = std::max(n_x_, n_y_) + std::abs(bi) + std::abs(bj) + 2;
    for (int ring = 0; ring <= max_ring; ++ring) {
      for (int j = bj - ring; j <= bj + ring; ++j) {
        for (int i = bi - ring; i <= bi + ring; ++i) {
          if (std::max(std::abs(i - bi), std::abs(j - bj)) != ring) continue;
          if (i < 0 || j < 0 || i >= n_x_ || j >= n_y_) continue;
          const int b = j * n_x_ + i;
          for (int k = start_[b]; k < start_[b + 1]; ++k) {
            visit(particle_[k]);
            if (first_hit_ring < 0) first_hit_ring = ring;
          }
        }
      }
      // Two rings past the first hit: close to exact for the nearest particle (a particle in
      // ring r is at most (r + 1) sqrt(2) bins away, one in ring r + k at least r + k - 1).
      if (first_hit_ring >= 0 && ring >= first_hit_ring + 2) return;
    }
  }

  /// The particle nearest to x among those for_each_nearest_rings() visits (the first visited
  /// of equally near ones), by `position` (the positions the bins were built from); -1 if there
  /// is none.
  int nearest(const Vec2& x, std::span<const Vec2> position) const {
    double best = std::numeric_limits<double>::infinity();
    int nearest = -1;
    for_each_nearest_rings(x, [&](int p) {
      const double d = (position[static_cast<std::size_t>(p)] - x).squaredNorm();
      if (d < best) {
        best = d;
        nearest = p;
      }
    });
    return nearest;
  }

  double bin_size() const { return bin_size_; }

 private:
  // Bin column and row of a coordinate, counted from origin_ (the lower corner of the positions).
  int bin_i(double x) const { return bin_coordinate(x - origin_.x()); }
  int bin_j(double y) const { return bin_coordinate(y - origin_.y()); }
  int bin_coordinate(double offset) const {
    const double c = std::floor(offset / bin_size_);
    return c < -1e9 ? -1000000000 : (c > 1e9 ? 1000000000 : static_cast<int>(c));
  }
  Vec2 origin_ = Vec2::Zero();
  double bin_size_ = 1.0;
  int n_x_ = 0, n_y_ = 0;
  std::vector<int> start_;     ///< CSR offsets, size n_x * n_y + 1
  std::vector<int> particle_;  ///< particle indices, bin by bin, increasing within a bin
  std::vector<int> slot_;      ///< inverse of particle_
};

}  // namespace pfm
