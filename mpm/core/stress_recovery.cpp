#include "mpm/core/stress_recovery.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace pfm {

namespace {

// Items binned on a uniform grid of square bins of side `size` over their bounding box.
class Bins {
 public:
  template <class Position>
  Bins(std::size_t n, Position&& position, double size) : size_(size) {
    if (n == 0) return;
    Vec2 lo = position(0), hi = position(0);
    for (std::size_t k = 1; k < n; ++k) {
      lo = lo.cwiseMin(position(k));
      hi = hi.cwiseMax(position(k));
    }
    origin_ = lo;
    nx_ = static_cast<int>((hi.x() - lo.x()) / size) + 1;
    ny_ = static_cast<int>((hi.y() - lo.y()) / size) + 1;
    start_.assign(static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_) + 1, 0);
    std::vector<int> bin(n);
    for (std::size_t k = 0; k < n; ++k) {
      bin[k] = index(position(k));
      ++start_[static_cast<std::size_t>(bin[k]) + 1];
    }
    for (std::size_t b = 1; b < start_.size(); ++b) start_[b] += start_[b - 1];
    items_.resize(n);
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    for (std::size_t k = 0; k < n; ++k) {
      items_[static_cast<std::size_t>(fill[static_cast<std::size_t>(bin[k])]++)] =
          static_cast<int>(k);
    }
  }
  /// visit(item) for the items in the bins that reach within r of x (a superset of the disk).
  template <class Visit>
  void near(const Vec2& x, double r, Visit&& visit) const {
    if (items_.empty()) return;
    const int i0 = std::max(0, static_cast<int>(std::floor((x.x() - r - origin_.x()) / size_)));
    const int i1 =
        std::min(nx_ - 1, static_cast<int>(std::floor((x.x() + r - origin_.x()) / size_)));
    const int j0 = std::max(0, static_cast<int>(std::floor((x.y() - r - origin_.y()) / size_)));
    const int j1 =
        std::min(ny_ - 1, static_cast<int>(std::floor((x.y() + r - origin_.y()) / size_)));
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        const auto b = static_cast<std::size_t>(j) * static_cast<std::size_t>(nx_) +
                       static_cast<std::size_t>(i);
        for (int k = start_[b]; k < start_[b + 1]; ++k) visit(items_[static_cast<std::size_t>(k)]);
      }
    }
  }

 private:
  int index(const Vec2& x) const {
    const int i = std::min(nx_ - 1, static_cast<int>((x.x() - origin_.x()) / size_));
    const int j = std::min(ny_ - 1, static_cast<int>((x.y() - origin_.y()) / size_));
    return j * nx_ + i;
  }
  double size_ = 1.0;
  Vec2 origin_ = Vec2::Zero();
  int nx_ = 0, ny_ = 0;
  std::vector<int> start_{0};
  std::vector<int> items_;
};

using Matrix9 = Eigen::Matrix<double, 9, 9>;
using Vector9 = Eigen::Matrix<double, 9, 1>;

}  // namespace

std::vector<Stress> recover_stress(std::span<const Vec2> position, std::span<const Stress> stress,
                                   std::span<const TractionSample> samples, double h,
                                   const StressRecoveryOptions& options) {
  const std::size_t n = position.size();
  std::vector<Stress> recovered(stress.begin(), stress.end());
  if (n == 0 || samples.empty()) return recovered;
  const Bins sample_bins(
      samples.size(), [&](std::size_t k) { return samples[k].x; }, h);
  // The points within `band` cells of a known traction are recovered; the others are trusted.
  const double band = options.band * h;
  std::vector<char> in_band(n, 0);
  for (std::size_t p = 0; p < n; ++p) {
    sample_bins.near(position[p], band, [&](int k) {
      if ((samples[static_cast<std::size_t>(k)].x - position[p]).squaredNorm() < band * band)
        in_band[p] = 1;
    });
  }
  std::vector<int> trusted;
  for (std::size_t p = 0; p < n; ++p) {
    if (!in_band[p]) trusted.push_back(static_cast<int>(p));
  }
  if (trusted.empty()) return recovered;
  const Bins trusted_bins(
      trusted.size(), [&](std::size_t k) { return position[static_cast<std::size_t>(trusted[k])]; },
      h);

  const auto n_signed = static_cast<long>(n);
#pragma omp parallel for schedule(dynamic, 64)
  for (long ps = 0; ps < n_signed; ++ps) {
    const auto p = static_cast<std::size_t>(ps);
    if (!in_band[p]) continue;
    const Vec2 x0 = position[p];
    // The patch: the trusted points within r, r grown a cell at a time for min_points.
    std::vector<int> patch;
    double r = options.radius * h;
    for (;; r += h) {
      patch.clear();
      trusted_bins.near(x0, r, [&](int k) {
        const auto q = static_cast<std::size_t>(trusted[static_cast<std::size_t>(k)]);
        if ((position[q] - x0).squaredNorm() <= r * r) patch.push_back(static_cast<int>(q));
      });
      if (static_cast<int>(patch.size()) >= options.min_points ||
          r + h > options.max_radius * h + 1e-12 * h)
        break;
    }
    if (patch.size() < 3) continue;
    std::sort(patch.begin(), patch.end());  // the sums in one order: the same bits every run
    // Unknowns: (a, G_x, G_y) for sxx, syy, sxy, with d = (x - x0) / h.
    Matrix9 normal = Matrix9::Zero();
    Vector9 rhs = Vector9::Zero();
    Eigen::Matrix3d normal_zz = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs_zz = Eigen::Vector3d::Zero();
    for (const int q : patch) {
      const auto qs = static_cast<std::size_t>(q);
      const Vec2 d = (position[qs] - x0) / h;
      const Eigen::Vector3d phi(1.0, d.x(), d.y());
      const Eigen::Matrix3d outer = phi * phi.transpose();
      for (int c = 0; c < 3; ++c) {
        normal.block<3, 3>(3 * c, 3 * c) += outer;
        rhs.segment<3>(3 * c) += phi * stress[qs][c];
      }
      normal_zz += outer;
      rhs_zz += phi * stress[qs][3];
    }
    std::vector<int> near_samples;
    sample_bins.near(x0, r, [&](int k) {
      if ((samples[static_cast<std::size_t>(k)].x - x0).squaredNorm() <= r * r)
        near_samples.push_back(k);
    });
    std::sort(near_samples.begin(), near_samples.end());
    for (const int k : near_samples) {
      const TractionSample& s = samples[static_cast<std::size_t>(k)];
      const Vec2 d = (s.x - x0) / h;
      const Eigen::Vector3d phi(1.0, d.x(), d.y());
      const double w2 = options.boundary_weight * options.boundary_weight * s.length / h;
      // The rows t_x = sxx n_x + sxy n_y and t_y = sxy n_x + syy n_y, squared, by blocks
      // (sxx, syy, sxy) of phi phi^T.
      const double nx = s.normal.x(), ny = s.normal.y();
      const Eigen::Matrix3d outer = w2 * phi * phi.transpose();
      normal.block<3, 3>(0, 0) += nx * nx * outer;
      normal.block<3, 3>(3, 3) += ny * ny * outer;
      normal.block<3, 3>(6, 6) += (nx * nx + ny * ny) * outer;
      normal.block<3, 3>(0, 6) += nx * ny * outer;
      normal.block<3, 3>(6, 0) += nx * ny * outer;
      normal.block<3, 3>(3, 6) += nx * ny * outer;
      normal.block<3, 3>(6, 3) += nx * ny * outer;
      const Eigen::Vector3d wphi = w2 * phi;
      rhs.segment<3>(0) += nx * s.traction.x() * wphi;
      rhs.segment<3>(3) += ny * s.traction.y() * wphi;
      rhs.segment<3>(6) += (ny * s.traction.x() + nx * s.traction.y()) * wphi;
    }
    const Eigen::ColPivHouseholderQR<Matrix9> solve(normal);
    if (solve.rank() == 9) {
      const Vector9 a = solve.solve(rhs);
      recovered[p][0] = a[0];
      recovered[p][1] = a[3];
      recovered[p][2] = a[6];
    }
    const Eigen::ColPivHouseholderQR<Eigen::Matrix3d> solve_zz(normal_zz);
    if (solve_zz.rank() == 3) recovered[p][3] = solve_zz.solve(rhs_zz)[0];
  }
  return recovered;
}

}  // namespace pfm
