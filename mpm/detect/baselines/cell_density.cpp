// Cell-density threshold: the free-surface test of cb-geo/mpm (cells whose volume fraction
// sum V_p / V_cell falls below a tolerance, then a nodal density ratio) and of GeoTaichi
// (particles whose interpolated density ratio falls below 0.76), turned into contours: the
// volume fraction on the grid nodes is contoured at the threshold by marching squares.
#include <algorithm>
#include <cmath>

#include "mpm/detect/detect_internal.hpp"

namespace pfm::detail {

DetectedBoundary detect_cell_density(const ParticleCloud& cloud, const Grid& grid,
                                     const DensityConfig& config, DetectionTimings& timings) {
  using Clock = std::chrono::steady_clock;
  const auto field_start = Clock::now();
  const int r = config.refinement;
  timings.refinement = r;
  NodalField field;
  field.origin = grid.origin;
  field.spacing = grid.cell_size / r;
  const int nx = grid.n_cells_x * r, ny = grid.n_cells_y * r;
  field.n_x = nx + 1;
  field.n_y = ny + 1;
  field.values.assign(static_cast<std::size_t>(field.n_x) * field.n_y, 0.0);
  const double h = field.spacing, area = h * h;
  // Cell of a particle; particles on the upper or right grid edge belong to the last cell,
  // particles outside the grid are left out.
  const auto locate = [&](const Vec2& x, int& i, int& j, double& xi, double& eta) {
    const double gx = (x.x() - field.origin.x()) / h, gy = (x.y() - field.origin.y()) / h;
    if (!(gx >= 0.0 && gy >= 0.0 && gx <= nx && gy <= ny)) return false;
    i = std::min(static_cast<int>(std::floor(gx)), nx - 1);
    j = std::min(static_cast<int>(std::floor(gy)), ny - 1);
    xi = gx - i;
    eta = gy - j;
    return true;
  };
  if (config.field == DensityField::kNodal) {
    // m_i / (rho A_i) = sum_p V_p N_i(x_p) / A_i with bilinear hat functions and A_i the part of
    // the node's tributary area h^2 inside the grid (h^2 / 2 on an edge, h^2 / 4 at a corner:
    // the grid edge is a wall, not a free surface): 1 inside the body, 1/2 on a flat face
    // through the nodes (the points integrate N_i exactly there).
    for (std::size_t p = 0; p < cloud.position.size(); ++p) {
      int i = 0, j = 0;
      double xi = 0.0, eta = 0.0;
      if (!locate(cloud.position[p], i, j, xi, eta)) continue;
      const double v = cloud.volume[p] / area;
      double* row0 = &field.values[static_cast<std::size_t>(j) * field.n_x + i];
      double* row1 = row0 + field.n_x;
      row0[0] += v * (1.0 - xi) * (1.0 - eta);
      row0[1] += v * xi * (1.0 - eta);
      row1[0] += v * (1.0 - xi) * eta;
      row1[1] += v * xi * eta;
    }
    for (int j = 0; j <= ny; ++j) {
      const double fy = (j == 0 || j == ny) ? 0.5 : 1.0;
      for (int i = 0; i <= nx; ++i) {
        const double fx = (i == 0 || i == nx) ? 0.5 : 1.0;
        field.values[static_cast<std::size_t>(j) * field.n_x + i] /= fx * fy;
      }
    }
  } else {
    // Cell volume fraction (cb-geo/mpm), then the mean over the (up to four) grid cells around
    // each node.
    std::vector<double> cell(static_cast<std::size_t>(nx) * ny, 0.0);
    for (std::size_t p = 0; p < cloud.position.size(); ++p) {
      int i = 0, j = 0;
      double xi = 0.0, eta = 0.0;
      if (!locate(cloud.position[p], i, j, xi, eta)) continue;
      cell[static_cast<std::size_t>(j) * nx + i] += cloud.volume[p] / area;
    }
    for (int j = 0; j <= ny; ++j) {
      for (int i = 0; i <= nx; ++i) {
        double sum = 0.0;
        int n_cells = 0;
        for (int dj = -1; dj <= 0; ++dj) {
          for (int di = -1; di <= 0; ++di) {
            const int ci = i + di, cj = j + dj;
            if (ci >= 0 && cj >= 0 && ci < nx && cj < ny) {
              sum += cell[static_cast<std::size_t>(cj) * nx + ci];
              ++n_cells;
            }
          }
        }
        field.values[static_cast<std::size_t>(j) * field.n_x + i] = sum / n_cells;
      }
    }
  }
  timings.field = seconds_since(field_start);
  timings.field_evaluations = static_cast<long>(field.values.size());
  const auto contour_start = Clock::now();
  DetectedBoundary boundary = marching_squares(field, config.threshold);
  timings.connection = seconds_since(contour_start);
  timings.processed_cells = static_cast<long>(nx) * ny;
  for (const auto& c : boundary.contours) {
    timings.edge_point_count += static_cast<long>(c.points.size());
  }
  return boundary;
}

}  // namespace pfm::detail
