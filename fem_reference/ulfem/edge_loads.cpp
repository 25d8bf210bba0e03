#include "fem_reference/ulfem/edge_loads.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "mpm/core/json_input.hpp"

namespace pfm::ulfem {

bool mesh_node_held(const Case& c, const BoundaryCondition& bc, const Vec2& x) {
  const Grid& grid = c.grid;
  const double tol = 1e-9 * grid.cell_size;
  const Vec2 lo = grid.origin, hi = grid.upper_corner();
  if (bc.where == "left") return std::abs(x.x() - lo.x()) <= tol;
  if (bc.where == "right") return std::abs(x.x() - hi.x()) <= tol;
  if (bc.where == "bottom") return std::abs(x.y() - lo.y()) <= tol;
  if (bc.where == "top") return std::abs(x.y() - hi.y()) <= tol;
  bool selected = false;
  for (const NodeSet& set : c.node_sets) {
    if (set.name == bc.where) selected = set.contains(x, tol);
  }
  return selected;
}

std::vector<EdgeLoad> edge_loads(const Case& c) {
  std::vector<EdgeLoad> out;
  for (std::size_t k = 0; k < c.loads.size(); ++k) {
    const LoadSpec& load = c.loads[k];
    const std::string where = c.file + ": /loads/" + std::to_string(k);
    EdgeLoad e;
    e.case_index = k;
    e.time_function = load.time_function;
    if (load.apply_on == LoadTarget::kGridTopNodes) {
      if (load.type != "vertical_pressure") {
        throw InputError(where + "/type: \"" + load.type +
                         "\" is not a load the UL-FEM can apply on grid_top_nodes");
      }
      e.normal_scale = Vec2(0.0, -load.pressure);
      e.has_range = true;
      e.x0 = load.x0;
      e.x1 = load.x1;
      e.faces = boundary::LoadedFaces::kTop;
    } else {
      if (!load.surface) {
        throw InputError(where + ": a detected_boundary load without its specification");
      }
      const boundary::BoundaryLoadSpec& spec = *load.surface;
      if (spec.normal_window) {
        throw InputError(where +
                         "/normal: the UL-FEM selects a load's faces by x_range and faces only");
      }
      const boundary::TractionLaw law = spec.traction_law(1.0);
      e.normal_scale = law.normal_scale;
      e.fixed_traction = law.fixed_traction;
      if (spec.x_range) {
        e.has_range = true;
        e.x0 = spec.x_range->x();
        e.x1 = spec.x_range->y();
      }
      e.faces = spec.faces;
      e.material_interval = spec.interval == boundary::LoadInterval::kMaterial;
    }
    out.push_back(e);
  }
  return out;
}

EdgeLoading::EdgeLoading(const Case& c, const QuadMesh& mesh)
    : loads_(edge_loads(c)), tolerance_(1e-9 * c.grid.cell_size) {
  for (const auto& edge : boundary_edges(mesh)) edges_.push_back({edge[0], edge[1]});
}

bool EdgeLoading::shadowed(const std::vector<Vec2>& position, double x, double y) const {
  // Another boundary edge crossing the vertical line through x above y (x is never a node's x).
  for (const LoadedEdge& edge : edges_) {
    const Vec2& a = position[static_cast<std::size_t>(edge.from)];
    const Vec2& b = position[static_cast<std::size_t>(edge.to)];
    if ((x - a.x()) * (x - b.x()) >= 0.0) continue;
    const double y_edge = a.y() + (x - a.x()) / (b.x() - a.x()) * (b.y() - a.y());
    if (y_edge > y + tolerance_) return true;
  }
  return false;
}

bool EdgeLoading::add(double t, const std::vector<Vec2>& position,
                      const std::vector<Vec2>& reference, std::vector<Vec2>& force,
                      EdgeLoadDiagnostics& d, LoadWorkRecorder* recorder) {
  forces_.resize(force.size(), Vec2::Zero());
  EdgeLoadDiagnostics summed;
  if (!integrate(t, position, reference, forces_, summed, recorder)) return false;
  for (std::size_t n = 0; n < forces_.size(); ++n) {
    const Vec2& f = forces_[n];
    if (f.x() == 0.0 && f.y() == 0.0) continue;
    force[n] += f;
    summed.applied += f;
    ++summed.loaded_nodes;
    forces_[n] = Vec2::Zero();
  }
  d = summed;
  return true;
}

bool EdgeLoading::integrate(double t, const std::vector<Vec2>& position,
                            const std::vector<Vec2>& reference, std::vector<Vec2>& force,
                            EdgeLoadDiagnostics& d, LoadWorkRecorder* recorder) {
  bool any = false;
  bool have_boundary_x = false;
  for (const EdgeLoad& load : loads_) {
    const double factor = load.time_function.factor(t);
    if (factor == 0.0) continue;
    any = true;
    const Vec2 normal_scale = factor * load.normal_scale;
    const Vec2 fixed_traction = factor * load.fixed_traction;
    const bool upward_only = load.faces != boundary::LoadedFaces::kAll;
    const bool top_only = load.faces == boundary::LoadedFaces::kTop;
    if (top_only && !have_boundary_x) {
      boundary_x_.clear();
      for (const LoadedEdge& edge : edges_)
        boundary_x_.push_back(position[static_cast<std::size_t>(edge.from)].x());
      std::sort(boundary_x_.begin(), boundary_x_.end());
      boundary_x_.erase(std::unique(boundary_x_.begin(), boundary_x_.end()), boundary_x_.end());
      have_boundary_x = true;
    }
    for (const LoadedEdge& edge : edges_) {
      const auto from = static_cast<std::size_t>(edge.from);
      const auto to = static_cast<std::size_t>(edge.to);
      const Vec2& a_current = position[from];
      const Vec2 d_current = position[to] - a_current;
      const double length = d_current.norm();
      // Upward faces: current outward normal (d_y, -d_x) / L with n_y > 0.
      if (upward_only && !(-d_current.x() > 1e-12 * length)) continue;
      // Loaded part s in [s0, s1]: x(s) = a.x + s d.x within [x0, x1] on the current (fixed
      // interval) or the reference (material interval) edge.
      double s0 = 0.0, s1 = 1.0;
      if (load.has_range) {
        const Vec2& a = load.material_interval ? reference[from] : a_current;
        const double dx = load.material_interval ? reference[to].x() - a.x() : d_current.x();
        if (dx != 0.0) {
          const double t0 = (load.x0 - a.x()) / dx, t1 = (load.x1 - a.x()) / dx;
          s0 = std::max(0.0, std::min(t0, t1));
          s1 = std::min(1.0, std::max(t0, t1));
        } else if (a.x() < load.x0 || a.x() > load.x1) {
          continue;
        }
      }
      if (s1 <= s0) continue;
      // t L, constant along the straight edge.
      const Vec2 force_per_unit =
          normal_scale.cwiseProduct(Vec2(d_current.y(), -d_current.x())) + length * fixed_traction;
      auto add_piece = [&](double p0, double p1) {
        const double integral_s = 0.5 * (p1 * p1 - p0 * p0);  // int s ds
        const double integral_1ms = (p1 - p0) - integral_s;   // int (1 - s) ds
        force[from] += integral_1ms * force_per_unit;
        force[to] += integral_s * force_per_unit;
        if (recorder) {
          recorder->add(load.case_index, from, integral_1ms * force_per_unit);
          recorder->add(load.case_index, to, integral_s * force_per_unit);
        }
        d.target += (p1 - p0) * force_per_unit;
      };
      if (!top_only) {
        add_piece(s0, s1);
        continue;
      }
      // Faces "top": cut [s0, s1] at the boundary nodes' x (d_x < 0 here: x decreases with s),
      // keep the pieces that nothing lies above; adjacent kept pieces are merged.
      const double xa = a_current.x() + s0 * d_current.x();
      const double xb = a_current.x() + s1 * d_current.x();
      auto it = std::upper_bound(boundary_x_.begin(), boundary_x_.end(), xb);
      const auto stop = std::lower_bound(boundary_x_.begin(), boundary_x_.end(), xa);
      double piece_start = s0, run_start = -1.0, run_end = -1.0;
      // Walk the cuts from xa (s0) down to xb (s1): the cut x values in (xb, xa), descending.
      std::vector<double>& cuts = cuts_;
      cuts.clear();
      for (; it < stop; ++it) cuts.push_back((*it - a_current.x()) / d_current.x());
      std::reverse(cuts.begin(), cuts.end());
      cuts.push_back(s1);
      for (const double piece_end : cuts) {
        if (piece_end <= piece_start) continue;
        const double mid = 0.5 * (piece_start + piece_end);
        const Vec2 x_mid = a_current + mid * d_current;
        if (!shadowed(position, x_mid.x(), x_mid.y())) {
          if (run_end == piece_start) {
            run_end = piece_end;
          } else {
            if (run_end > run_start) add_piece(run_start, run_end);
            run_start = piece_start;
            run_end = piece_end;
          }
        }
        piece_start = piece_end;
      }
      if (run_end > run_start) add_piece(run_start, run_end);
    }
  }
  return any;
}

}  // namespace pfm::ulfem
