#include "mpm/solver/body_fill.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace pfm {

void Particles::reserve(std::size_t n) {
  position.reserve(n);
  reference_position.reserve(n);
  velocity.reserve(n);
  mass.reserve(n);
  volume.reserve(n);
  initial_volume.reserve(n);
  half_length.reserve(n);
  stress.reserve(n);
  state.reserve(n);
  deformation_gradient.reserve(n);
  material.reserve(n);
  body.reserve(n);
}

void Particles::add(const Vec2& x, double particle_volume, double density, const Vec2& half_size,
                    int material_index, int body_index) {
  position.push_back(x);
  reference_position.push_back(x);
  velocity.push_back(Vec2::Zero());
  mass.push_back(density * particle_volume);
  volume.push_back(particle_volume);
  initial_volume.push_back(particle_volume);
  half_length.push_back(half_size);
  stress.push_back(Stress::Zero());
  state.push_back(PointState{});
  deformation_gradient.push_back(Mat2::Identity());
  material.push_back(material_index);
  body.push_back(body_index);
}

double polygon_top(const std::vector<Vec2>& polygon, double x) {
  double top = std::numeric_limits<double>::quiet_NaN();
  const std::size_t n = polygon.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Vec2& a = polygon[i];
    const Vec2& b = polygon[j];
    const double lo = std::min(a.x(), b.x()), hi = std::max(a.x(), b.x());
    if (x < lo || x > hi) continue;
    double y;
    if (hi == lo) {
      y = std::max(a.y(), b.y());  // vertical edge
    } else {
      y = a.y() + (x - a.x()) * (b.y() - a.y()) / (b.x() - a.x());
    }
    if (std::isnan(top) || y > top) top = y;
  }
  return top;
}

void placement_points_1d(Placement placement, int n, std::vector<double>& position,
                         std::vector<double>& weight) {
  position.assign(static_cast<std::size_t>(n), 0.0);
  weight.assign(static_cast<std::size_t>(n), 1.0 / n);
  if (placement == Placement::kEqual) {
    for (int a = 0; a < n; ++a) position[static_cast<std::size_t>(a)] = (a + 0.5) / n;
    return;
  }
  // Gauss-Legendre points on [-1, 1] by Newton on P_n (Golub-Welsch is overkill for n <= 8).
  for (int a = 0; a < n; ++a) {
    double t = std::cos(M_PI * (a + 0.75) / (n + 0.5));
    double derivative = 1.0;
    for (int iteration = 0; iteration < 100; ++iteration) {
      double p0 = 1.0, p1 = t;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * t * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      derivative = n * (t * p1 - p0) / (t * t - 1.0);
      const double dt = p1 / derivative;
      t -= dt;
      if (std::abs(dt) < 1e-16) break;
    }
    // Newton converges to the roots in descending order; store ascending.
    const std::size_t slot = static_cast<std::size_t>(n - 1 - a);
    position[slot] = 0.5 * (t + 1.0);
    weight[slot] = 1.0 / ((1.0 - t * t) * derivative * derivative);  // 2 / (...) on [-1,1], /2
  }
}

Particles fill_bodies(const Case& c) {
  Particles particles;
  const Grid& grid = c.grid;
  const double h = grid.cell_size;
  const double g = c.gravity.g > 0.0 ? c.gravity.g : 9.81;
  for (std::size_t b = 0; b < c.bodies.size(); ++b) {
    const BodySpec& body = c.bodies[b];
    const double density = c.materials[static_cast<std::size_t>(body.material)].unit_weight / g;
    std::vector<double> local, weight;
    placement_points_1d(body.placement, body.points_per_cell, local, weight);
    const Vec2 half_size(0.5 * h / body.points_per_cell, 0.5 * h / body.points_per_cell);
    Vec2 lo = body.polygon.front(), hi = body.polygon.front();
    for (const Vec2& v : body.polygon) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
    const int i0 = std::max(0, grid.cell_i(lo.x())),
              i1 = std::min(grid.n_cells_x - 1, grid.cell_i(hi.x()));
    const int j0 = std::max(0, grid.cell_j(lo.y())),
              j1 = std::min(grid.n_cells_y - 1, grid.cell_j(hi.y()));
    // Cell by cell, row by row, so particle ids follow the cells (good memory locality).
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        const Vec2 corner = grid.node_position(i, j);
        for (int bj = 0; bj < body.points_per_cell; ++bj) {
          for (int ai = 0; ai < body.points_per_cell; ++ai) {
            const Vec2 x = corner + h * Vec2(local[static_cast<std::size_t>(ai)],
                                             local[static_cast<std::size_t>(bj)]);
            if (!point_in_polygon(body.polygon, x)) continue;
            bool taken = false;
            for (std::size_t other = 0; other < b; ++other) {
              taken = taken || point_in_polygon(c.bodies[other].polygon, x);
            }
            if (taken) continue;
            const double v =
                h * h * weight[static_cast<std::size_t>(ai)] * weight[static_cast<std::size_t>(bj)];
            particles.add(x, v, density, half_size, body.material, static_cast<int>(b));
          }
        }
      }
    }
  }
  return particles;
}

void apply_k0_stress(const Case& c, Particles& particles) {
  for (std::size_t p = 0; p < particles.size(); ++p) {
    const BodySpec& body = c.bodies[static_cast<std::size_t>(particles.body[p])];
    const MaterialRecord& m = c.materials[static_cast<std::size_t>(particles.material[p])];
    const double nu = elastic_parameters(m.model).poisson_ratio;
    const double k0 = c.initial_stress.k0 ? *c.initial_stress.k0 : nu / (1.0 - nu);
    const Vec2& x = particles.position[p];
    const double depth = polygon_top(body.polygon, x.x()) - x.y();
    const double sigma_v = -m.unit_weight * std::max(depth, 0.0);
    particles.stress[p] = Stress(k0 * sigma_v, sigma_v, 0.0, k0 * sigma_v);
  }
}

}  // namespace pfm
