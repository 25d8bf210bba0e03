#include "mpm/core/stress_recovery.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "mpm/core/particle_bins.hpp"

namespace pfm {

namespace {

using Matrix9 = Eigen::Matrix<double, 9, 9>;
using Vector9 = Eigen::Matrix<double, 9, 1>;

}  // namespace

std::vector<Stress> recover_stress(std::span<const Vec2> position, std::span<const Stress> stress,
                                   std::span<const TractionSample> samples, double h,
                                   const StressRecoveryOptions& options) {
  const std::size_t n = position.size();
  std::vector<Stress> recovered(stress.begin(), stress.end());
  if (n == 0 || samples.empty()) return recovered;
  std::vector<Vec2> sample_x(samples.size());
  for (std::size_t k = 0; k < samples.size(); ++k) sample_x[k] = samples[k].x;
  const ParticleBins sample_bins(sample_x, h);
  // Visits the items of `bins` (built from `x`) within r of x0, as their indices.
  const auto within = [](const ParticleBins& bins, std::span<const Vec2> x, const Vec2& x0,
                         double r, auto&& visit) {
    bins.for_each_slot_near(x0, static_cast<int>(std::ceil(r / bins.bin_size())), [&](int slot) {
      const int k = bins.particle_at(slot);
      if ((x[static_cast<std::size_t>(k)] - x0).squaredNorm() <= r * r) visit(k);
    });
  };
  // The points within `band` cells of a known traction are recovered; the others are trusted.
  const double band = options.band * h;
  std::vector<char> in_band(n, 0);
  for (std::size_t p = 0; p < n; ++p) {
    within(sample_bins, sample_x, position[p], band, [&](int) { in_band[p] = 1; });
  }
  std::vector<int> trusted;
  std::vector<Vec2> trusted_x;
  for (std::size_t p = 0; p < n; ++p) {
    if (in_band[p]) continue;
    trusted.push_back(static_cast<int>(p));
    trusted_x.push_back(position[p]);
  }
  if (trusted.empty()) return recovered;
  const ParticleBins trusted_bins(trusted_x, h);

  const auto n_signed = static_cast<long>(n);
#pragma omp parallel
  {
    std::vector<int> patch, near_samples;  // per thread, reused
#pragma omp for schedule(dynamic, 64)
    for (long ps = 0; ps < n_signed; ++ps) {
      const auto p = static_cast<std::size_t>(ps);
      if (!in_band[p]) continue;
      const Vec2 x0 = position[p];
      // The patch: the trusted points within r, r grown a cell at a time for min_points.
      double r = options.radius * h;
      for (;; r += h) {
        patch.clear();
        within(trusted_bins, trusted_x, x0, r,
               [&](int k) { patch.push_back(trusted[static_cast<std::size_t>(k)]); });
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
      near_samples.clear();
      within(sample_bins, sample_x, x0, r, [&](int k) { near_samples.push_back(k); });
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
  }
  return recovered;
}

}  // namespace pfm
