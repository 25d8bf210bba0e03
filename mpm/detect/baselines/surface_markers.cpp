// Surface Marker Method (thesis 3.4.1, 4.2; eq. 4.6-4.7): massless markers placed on the initial
// boundary and carried by the grid velocities, connected to the same neighbours for ever.
#include <algorithm>
#include <cmath>
#include <string>

#include "mpm/detect/detect_internal.hpp"

namespace pfm {

std::vector<Vec2> resample_polyline(std::span<const Vec2> points, bool closed, double spacing) {
  const std::size_t n = points.size();
  if (n == 0) return {};
  if (!(spacing > 0.0)) throw InputError("resample_polyline: spacing must be > 0");
  // Cumulative arc length over the segments (the closing segment too for a closed polyline).
  const std::size_t n_segments = closed ? n : n - 1;
  std::vector<double> length(n_segments + 1, 0.0);
  for (std::size_t k = 0; k < n_segments; ++k) {
    length[k + 1] = length[k] + (points[(k + 1) % n] - points[k]).norm();
  }
  const double total = length.back();
  if (n_segments == 0 || !(total > 0.0)) return {points[0]};
  const int n_intervals =
      std::max(closed ? 3 : 1, static_cast<int>(std::ceil(total / spacing - 1e-9)));
  const double step = total / n_intervals;
  std::vector<Vec2> out;
  out.reserve(static_cast<std::size_t>(n_intervals) + 1);
  std::size_t segment = 0;
  const int n_out = closed ? n_intervals : n_intervals + 1;
  for (int k = 0; k < n_out; ++k) {
    if (!closed && k == n_intervals) {
      out.push_back(points[n - 1]);  // the end point exactly
      break;
    }
    const double s = k * step;
    while (segment + 1 < n_segments && length[segment + 1] <= s) ++segment;
    const Vec2& a = points[segment];
    const Vec2& b = points[(segment + 1) % n];
    const double piece = length[segment + 1] - length[segment];
    const double t = piece > 0.0 ? std::clamp((s - length[segment]) / piece, 0.0, 1.0) : 0.0;
    out.push_back(a + t * (b - a));
  }
  return out;
}

void advect_surface_markers(DetectorState& state, const Grid& grid,
                            std::span<const Vec2> node_velocity, std::span<const double> node_mass,
                            double dt) {
  const std::size_t n_nodes = static_cast<std::size_t>(grid.n_nodes());
  if (node_velocity.size() != n_nodes || node_mass.size() != n_nodes) {
    throw InputError("advect_surface_markers: " + std::to_string(node_velocity.size()) +
                     " nodal velocities and " + std::to_string(node_mass.size()) +
                     " nodal masses for a grid of " + std::to_string(n_nodes) + " nodes");
  }
  if (!std::isfinite(dt) || dt < 0.0) {
    throw InputError("advect_surface_markers: dt must be finite and >= 0");
  }
  const double h = grid.cell_size;
  const bool renormalise = state.massless_nodes == MasslessNodes::kRenormalise;
  for (auto& polyline : state.markers) {
    for (Vec2& x : polyline) {
      // Bilinear shape functions of the cell holding the marker (eq. 4.7, N_i(x_m^t)); a marker
      // on the upper or right edge of the grid belongs to the last cell.
      const double gx = (x.x() - grid.origin.x()) / h, gy = (x.y() - grid.origin.y()) / h;
      int i = static_cast<int>(std::floor(gx)), j = static_cast<int>(std::floor(gy));
      if (gx == grid.n_cells_x) i = grid.n_cells_x - 1;
      if (gy == grid.n_cells_y) j = grid.n_cells_y - 1;
      if (!(gx >= 0.0 && gy >= 0.0) || i < 0 || j < 0 || i >= grid.n_cells_x ||
          j >= grid.n_cells_y) {
        continue;  // outside the grid: no velocity
      }
      const double xi = gx - i, eta = gy - j;
      const int node[4] = {grid.node_index(i, j), grid.node_index(i + 1, j),
                           grid.node_index(i + 1, j + 1), grid.node_index(i, j + 1)};
      const double weight[4] = {(1.0 - xi) * (1.0 - eta), xi * (1.0 - eta), xi * eta,
                                (1.0 - xi) * eta};
      Vec2 velocity = Vec2::Zero();
      double weight_with_mass = 0.0;
      for (int k = 0; k < 4; ++k) {
        if (!(node_mass[node[k]] > 0.0)) continue;  // (mv)_i / m_i undefined: left out or zero
        velocity += weight[k] * node_velocity[node[k]];
        weight_with_mass += weight[k];
      }
      if (renormalise) {
        if (!(weight_with_mass > 0.0)) continue;
        velocity /= weight_with_mass;
      }
      x += dt * velocity;  // eq. 4.6
    }
  }
}

namespace detail {

DetectedBoundary detect_surface_markers(const ParticleCloud& cloud, const Grid& grid,
                                        const DetectorConfig& config, DetectorState& state,
                                        DetectionTimings& timings) {
  if (!state.markers_placed) {
    // Initiation stage (4.2.1): markers on the contour of the initial particles.
    DetectorState scratch;
    const DetectedBoundary initial =
        config.smm.initial_contour == DetectorMethod::kPfm
            ? detect_thesis_pfm(cloud, grid, config.pfm, scratch, timings)
            : detect_improved(cloud, grid, config.improved, timings);
    const auto start = std::chrono::steady_clock::now();
    const double spacing = config.smm.marker_spacing * grid.cell_size;
    state.markers.clear();
    state.markers_closed.clear();
    for (const auto& contour : initial.contours) {
      state.markers.push_back(resample_polyline(contour.points, contour.closed, spacing));
      state.markers_closed.push_back(contour.closed);
    }
    state.markers_placed = true;
    state.massless_nodes = config.smm.massless_nodes;
    timings.filters = seconds_since(start);
  }
  // Reporting stage: the markers in their fixed order, as contours in the canonical order.
  const auto start = std::chrono::steady_clock::now();
  DetectedBoundary boundary;
  long n_markers = 0;
  for (std::size_t k = 0; k < state.markers.size(); ++k) {
    boundary.contours.push_back(
        Contour{state.markers[k], static_cast<bool>(state.markers_closed[k])});
    n_markers += static_cast<long>(state.markers[k].size());
  }
  canonicalize(boundary);
  timings.connection += seconds_since(start);
  timings.edge_point_count = n_markers;
  return boundary;
}

}  // namespace detail
}  // namespace pfm
