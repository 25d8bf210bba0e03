// Seeded random particle clouds for the invariant tests: perturbed lattices, affine-deformed
// blocks, bodies with holes, separated blobs and thin filaments. Small (tens to ~150 points).
#pragma once

#include <random>

#include "detect_test_support.hpp"

namespace pfm::test {

struct RandomCase {
  OwnedCloud cloud;
  Grid grid;
  const char* kind = "";
};

inline Mat2 rotation_matrix(double angle) {
  Mat2 r;
  r << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  return r;
}

inline RandomCase random_case(std::uint64_t seed) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL + 12345);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const auto uniform = [&](double a, double b) { return a + (b - a) * u01(rng); };
  const auto integer = [&](int a, int b) { return a + static_cast<int>(u01(rng) * (b - a + 1)); };
  const double h = 0.5, dx = h / 2.0;
  RandomCase rc;
  OwnedCloud& c = rc.cloud;
  c.initial_spacing = dx;
  const Placement placement = u01(rng) < 0.5 ? Placement::kEqualSpacing : Placement::kGaussPoints;
  const auto add_block = [&](Vec2 lo, int nx, int ny, const std::function<bool(const Vec2&)>& in,
                             const Mat2& f, const Vec2& centre, double jitter) {
    const auto block = lattice_cloud(h, placement, lo, lo + Vec2(nx * h, ny * h), in, f, centre);
    for (std::size_t p = 0; p < block.position.size(); ++p) {
      c.position.push_back(block.position[p] +
                           jitter * dx * Vec2(uniform(-1.0, 1.0), uniform(-1.0, 1.0)));
      c.volume.push_back(block.volume[p]);
      if (!f.isIdentity()) c.deformation_gradient.push_back(f);
    }
  };
  const auto all = [](const Vec2&) { return true; };
  const int kind = static_cast<int>(seed % 5);
  switch (kind) {
    case 0: {  // perturbed lattice
      rc.kind = "perturbed lattice";
      add_block(Vec2(0, 0), integer(1, 5), integer(1, 5), all, Mat2::Identity(), Vec2::Zero(),
                uniform(0.0, 0.3));
      break;
    }
    case 1: {  // affine deformation: J in [0.5, 2], stretch ratio up to 4
      rc.kind = "affine";
      const double j = std::exp(uniform(std::log(0.5), std::log(2.0)));
      const double ratio = uniform(1.0, 4.0);
      const double s1 = std::sqrt(j * ratio), s2 = std::sqrt(j / ratio);
      const Mat2 f = rotation_matrix(uniform(0, std::numbers::pi)) * Vec2(s1, s2).asDiagonal() *
                     rotation_matrix(uniform(0, std::numbers::pi));
      const int nx = integer(1, 3), ny = integer(1, 3);
      add_block(Vec2(0, 0), nx, ny, all, f, Vec2(0.5 * nx * h, 0.5 * ny * h), 0.0);
      break;
    }
    case 2: {  // body with a hole
      rc.kind = "hole";
      const int n = integer(4, 6);
      const double radius = uniform(0.4, 0.25 * n * h);
      const Vec2 centre(0.5 * n * h + uniform(-0.2, 0.2), 0.5 * n * h + uniform(-0.2, 0.2));
      add_block(
          Vec2(0, 0), n, n, [&](const Vec2& x) { return (x - centre).norm() > radius; },
          Mat2::Identity(), Vec2::Zero(), uniform(0.0, 0.15));
      break;
    }
    case 3: {  // separated blobs
      rc.kind = "blobs";
      const int n_blobs = integer(2, 3);
      for (int b = 0; b < n_blobs; ++b) {
        const Vec2 lo(b * uniform(1.5, 2.5), uniform(-1.0, 1.0));
        add_block(Vec2(std::round(lo.x() / h) * h, std::round(lo.y() / h) * h), integer(1, 2),
                  integer(1, 2), all, Mat2::Identity(), Vec2::Zero(), uniform(0.0, 0.2));
      }
      break;
    }
    default: {  // thin filament, one or two points wide, straight or bent
      rc.kind = "filament";
      const int width = integer(1, 2), length = integer(4, 14);
      const double bend = uniform(-0.3, 0.3), angle = uniform(0, 2 * std::numbers::pi);
      Vec2 x(0, 0), t(std::cos(angle), std::sin(angle));
      for (int k = 0; k < length; ++k) {
        const Vec2 n(-t.y(), t.x());
        for (int w = 0; w < width; ++w) {
          c.position.push_back(x + (w - 0.5 * (width - 1)) * dx * n +
                               0.1 * dx * Vec2(uniform(-1, 1), uniform(-1, 1)));
          c.volume.push_back(dx * dx);
        }
        x += dx * t;
        t = rotation_matrix(bend) * t;
      }
      break;
    }
  }
  // Field grid: the particles' box plus the largest kernel reach and a cell.
  Vec2 lo = c.position[0], hi = c.position[0];
  for (const auto& p : c.position) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  double stretch = 1.0;
  for (const auto& f : c.deformation_gradient) {
    stretch = std::max(stretch, f.norm());
  }
  const double margin = 3.0 * dx * stretch + h;
  rc.grid.cell_size = h;
  rc.grid.origin =
      Vec2(std::floor((lo.x() - margin) / h) * h, std::floor((lo.y() - margin) / h) * h);
  rc.grid.n_cells_x = static_cast<int>(std::ceil((hi.x() + margin - rc.grid.origin.x()) / h));
  rc.grid.n_cells_y = static_cast<int>(std::ceil((hi.y() + margin - rc.grid.origin.y()) / h));
  return rc;
}

}  // namespace pfm::test
