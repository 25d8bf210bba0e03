// Essential conditions on the detected boundary in the implicit step (case-file "constraints",
// issue 47): penalty, Nitsche's method and the Implicit Boundary Method on the boundary detected
// at the step's start.
//
// At a quadrature point x of a constraint's part (BoundaryLoadIntegrator::quadrature_points, the
// loads' rule), with n the curve's outward normal:
//   a particle's share in the part, a_p: 1 over the part's x_range, fading to 0 over the last
//     half cell inside its ends (smoothstep); 1 for every particle of a part without one (the
//     explicit step's, mpm/solver/boundary_constraint.hpp);
//   the weighted least-squares linear fit to the particles with weights
//     a_p V_p phi((x_p - x) / h) (phi the quadratic B-spline, product in x and y: support 1.5 h):
//     its coefficients c_p at x (where the particles within reach lie on a line, the weighted
//     mean's); the fit is exact for an affine field;
//   the gap at the step's end, g = P (u_n(x) + sum_I s_I(x) du_I - u_bar(t_n+1)), with the
//     shares s_I(x) = N_I(x) r_I / sum_J N_J(x) r_J over the nodes with material: N_I the loads'
//     grid functions (bilinear for linear and uGIMP, the B-splines otherwise), r_I the node's
//     share of the part's material, sum_p a_p V_p N_I(x_p) / sum_p V_p N_I(x_p) (the explicit
//     step's): a node that carries mostly the material beside the part moves what the part does
//     not (the B-splines reach one and a half cells past a footing's edge, and a force there
//     widens the footing); and P = n_w n_w^T for normal_only (n_w the part's normal-window
//     direction, else the curve's normal), the identity otherwise;
//   u_n(x), the material's displacement at t_n, enters as the gap the last step converged to:
//     each of its points, moved by its sum_I s_I du_I, keeps its gap g_n, and x takes the gap
//     interpolated between the two nearest of them along the part (the nearest's beyond its
//     ends), so g = P (g_n(x) + u_bar(t_n) - u_bar(t_n+1) + sum_I s_I(x) du_I). A step thus
//     starts from the balance the last one reached. Measured afresh by the fit,
//     sum_p c_p (x_p - X_p), the gap would differ from g_n by the difference between the grid's
//     motion at the boundary and the particles' around it (largest at a footing's edge, where
//     the displacement is far from affine), which beta turns into a force of many times the
//     stress: each step would start far from balance, and Newton stalls there in perfectly
//     plastic soil (test_implicit_constraints holds a footing to see it). The fit
//     measures it where no point of the last step lies within a cell of x (the first step, a
//     part grown by more than a cell);
//   the force on the body, weight x (share t - S g) shared by the nodes as s_I(x) (Galerkin: the
//     internal force of a uniform stress has the same shares where every r_I is 1, the patch
//     test), with
//     t = P sigma(x) n, sigma(x) = sum_p c_p sigma_p the same fit to the particles' stresses at
//     the iterate:
//     penalty: share 0, S = beta P;
//     Nitsche: share 1, S = beta P (the non-symmetric "incomplete" form: consistent, beta its
//       stabilisation; Nitsche 1971, Hansbo 2005);
//     the Implicit Boundary Method (thesis 3.3.3 and appendix A; Burla and Kumar 2008, Cortis et
//       al.): the displacement is D u_grid + u_a with the Dirichlet function D = 2 s / delta -
//       s^2 / delta^2 rising over a band of depth s in [0, delta] inside the boundary (eq. A.3)
//       on the constrained components, 1 on the free ones (A.4). With u_a the prescribed value,
//       the band's strain is D eps(u) + D' sym(n x g): its energy's cross term (K2 and K2^T,
//       eq. A.7) and square term (K3, A.8), integrated across the band (int D D' = 1/2, int D'^2
//       = 4 / (3 delta), band_integrals), give share 1/2 with the symmetric counterpart weight
//       x 1/2 (d sigma(x) / d du)^T n . g on the fit's particles' unknowns, and the band's
//       stiffness S = 4 / (3 delta) P^T (n.C.n) P, C the elastic moduli of the material there.
//       N, grad N and sigma are taken at the boundary (the band is delta = band_factor x h thin;
//       the default 1e-3 h changes them by 1e-3 of a cell's variation), and sigma(V) of the
//       test functions is the fit's d sigma / d du (for an elastic material C B, eq. A.7's; for a
//       plastic one its consistent tangent).
// The nodes' forces and stiffness reach the unknowns through each node's map, so a tied node's
// go to the inner nodes it is tied to (the ties are on by default here: a node over a sliver of
// perfectly plastic points left free makes the tangent near singular).
// The stiffness of every term is in the tangent: S s_I s_J P, -share w s_I P (d sigma(x) / d du) n
// through each fitted particle's D (B + the Jaumann rotation's part), and the IBM's transposed
// term's derivative along g (its change of d sigma / d du with the iterate, times g, is left out:
// g is O(delta)). beta is the constraint's penalty (penalty_factor x the largest constrained
// modulus / h unless given). The gap is the total one (g_n enters), so a penalty's error does
// not accumulate over the steps. u_bar: a displacement's value x time function at t_n+1, or a
// velocity's integral (the value at mid-step times dt per step).
// Units: kN, m, s, t, kPa.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "mpm/boundary/bezier.hpp"
#include "mpm/boundary/surface_load.hpp"
#include "mpm/implicit/implicit_internal.hpp"
#include "mpm/implicit/implicit_solver.hpp"

namespace pfm {

using implicit_detail::ConstraintPoint;

namespace {

// The quadratic B-spline of r (in cells): support |r| < 1.5.
double quadratic_kernel(double r) {
  r = std::abs(r);
  if (r < 0.5) return 0.75 - r * r;
  if (r < 1.5) return 0.5 * (1.5 - r) * (1.5 - r);
  return 0.0;
}

// The particles in each cell, for the fits' neighbourhoods.
struct CellLists {
  std::vector<std::vector<int>> cells;
  CellLists(const Grid& grid, const Particles& particles) {
    cells.resize(static_cast<std::size_t>(grid.n_cells()));
    for (std::size_t p = 0; p < particles.size(); ++p) {
      const Vec2& x = particles.position[p];
      const int i = std::clamp(grid.cell_i(x.x()), 0, grid.n_cells_x - 1);
      const int j = std::clamp(grid.cell_j(x.y()), 0, grid.n_cells_y - 1);
      cells[static_cast<std::size_t>(grid.cell_index(i, j))].push_back(static_cast<int>(p));
    }
  }
};

// The weighted least-squares linear fit at x (header comment): its coefficients c_p, empty when
// no particle is within reach.
std::vector<std::pair<int, double>> linear_fit(const Grid& grid, const CellLists& lists,
                                               const Particles& particles, const Vec2& x,
                                               const std::optional<Vec2>& x_range) {
  const double h = grid.cell_size;
  std::vector<std::pair<int, double>> fit;
  const int ci = grid.cell_i(x.x()), cj = grid.cell_j(x.y());
  Eigen::Matrix3d moments = Eigen::Matrix3d::Zero();
  double total = 0.0;
  for (int j = std::max(cj - 2, 0); j <= std::min(cj + 2, grid.n_cells_y - 1); ++j) {
    for (int i = std::max(ci - 2, 0); i <= std::min(ci + 2, grid.n_cells_x - 1); ++i) {
      for (const int p : lists.cells[static_cast<std::size_t>(grid.cell_index(i, j))]) {
        const Vec2& xp = particles.position[static_cast<std::size_t>(p)];
        const Vec2 d = (xp - x) / h;
        const double w = boundary::part_share(xp.x(), x_range, 0.5 * h) *
                         particles.volume[static_cast<std::size_t>(p)] * quadratic_kernel(d.x()) *
                         quadratic_kernel(d.y());
        if (w <= 0.0) continue;
        const Eigen::Vector3d e(1.0, d.x(), d.y());
        moments += w * e * e.transpose();
        total += w;
        fit.emplace_back(p, w);
      }
    }
  }
  if (fit.empty()) return fit;
  // The linear fit where the moments are well conditioned, else the weighted mean.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(moments / total);
  if (eigen.eigenvalues().minCoeff() > 1e-6) {
    const Eigen::Vector3d row = (moments.inverse()).col(0);  // symmetric: e1^T M^-1
    for (auto& [p, w] : fit) {
      const Vec2 d = (particles.position[static_cast<std::size_t>(p)] - x) / h;
      w *= row.dot(Eigen::Vector3d(1.0, d.x(), d.y()));
    }
  } else {
    for (auto& [p, w] : fit) w /= total;
  }
  return fit;
}

// The Implicit Boundary Method's Dirichlet function across its band, D(s) = 2 s / delta -
// s^2 / delta^2 for the depth s in [0, delta] (thesis eq. A.3; 1 deeper): the integrals over the
// band that its K2 and K3 take (eqs. A.7, A.8), by 2-point Gauss (exact: D D' is cubic, D'^2
// quadratic in s): rise = int D D' ds = 1/2, slope_squared = int D'^2 ds = 4 / (3 delta).
struct BandIntegrals {
  double rise = 0.0;           // -
  double slope_squared = 0.0;  // 1/m
};

BandIntegrals band_integrals(double delta) {
  BandIntegrals b;
  for (const double xi : {-1.0 / std::sqrt(3.0), 1.0 / std::sqrt(3.0)}) {
    const double s = 0.5 * delta * (1.0 + xi), weight = 0.5 * delta;
    const double d = 2.0 * s / delta - s * s / (delta * delta);
    const double slope = 2.0 / delta - 2.0 * s / (delta * delta);
    b.rise += weight * d * slope;
    b.slope_squared += weight * slope * slope;
  }
  return b;
}

// n . C . n of an isotropic elastic material (plane strain), kPa: the stiffness of the band
// against a displacement u at its inner side, (n x u) : C : (n x u) = u . (n . C . n) . u.
Mat2 normal_stiffness(const ElasticParameters& e, const Vec2& n) {
  const double mu = e.shear_modulus(), lambda = e.lame_lambda();
  return mu * Mat2::Identity() + (lambda + mu) * n * n.transpose();
}

}  // namespace

const ElasticParameters& ImplicitSolver::band_material(
    const std::vector<std::pair<int, double>>& fit) const {
  const auto largest = std::max_element(fit.begin(), fit.end(), [](const auto& a, const auto& b) {
    return std::abs(a.second) < std::abs(b.second);
  });
  const auto p = static_cast<std::size_t>(largest->first);
  return elastic_parameters(
      case_.materials[static_cast<std::size_t>(particles_.material[p])].model);
}

std::optional<Vec2> ImplicitSolver::carried_gap(std::size_t k, const Vec2& x) const {
  if (k >= carried_gaps_.size()) return std::nullopt;
  const std::vector<CarriedGap>& carried = carried_gaps_[k];
  const double h = case_.grid.cell_size;
  std::size_t nearest = carried.size();
  double closest = h * h;
  for (std::size_t a = 0; a < carried.size(); ++a) {
    const double d = (carried[a].position - x).squaredNorm();
    if (d <= closest) {
      nearest = a;
      closest = d;
    }
  }
  if (nearest == carried.size()) return std::nullopt;
  // Between the nearest point and the neighbour along the part whose segment x projects onto.
  const CarriedGap& a = carried[nearest];
  for (const std::size_t b : {nearest - 1, nearest + 1}) {
    if (b >= carried.size()) continue;  // also nearest - 1 at the first point
    const Vec2 segment = carried[b].position - a.position;
    const double length_squared = segment.squaredNorm();
    if (!(length_squared > 0.0) || length_squared > 4.0 * h * h) continue;
    const double t = (x - a.position).dot(segment) / length_squared;
    if (t >= 0.0 && t <= 1.0) return (1.0 - t) * a.gap + t * carried[b].gap;
  }
  return a.gap;
}

void ImplicitSolver::place_constraints(Prepared& s) {
  s.points.clear();
  s.constraint_target = constraint_target_;
  if (case_.constraints.empty()) return;
  const Grid& grid = case_.grid;
  const int degree = shape_degree(case_.solver.shape_function);
  const DetectedBoundary& boundary = detected(s);
  boundary::BoundaryLoadIntegrator integrator(grid, degree);
  const CellLists lists(grid, particles_);
  std::vector<boundary::CurvePoint> points;
  for (std::size_t k = 0; k < case_.constraints.size(); ++k) {
    const ConstraintSpec& spec = case_.constraints[k];
    const Vec2 u_bar = constraint_target(k, s.dt);
    s.constraint_target[k] = u_bar;
    const bool nitsche = spec.method == ConstraintMethod::kNitsche;
    const bool ibm = spec.method == ConstraintMethod::kImplicitBoundary;
    const BandIntegrals band = band_integrals(spec.band_factor * grid.cell_size);
    const auto curves = boundary::make_composite_beziers(boundary.contours, spec.part.curve);
    integrator.quadrature_points(curves, spec.part, points);
    // Each node's share of the part's material, r_I = sum_p a_p V_p N_I(x_p) / sum_p V_p
    // N_I(x_p) (a_p: boundary::part_share), as the explicit step's.
    std::vector<double> shares(n_nodes_, 1.0);
    if (spec.part.x_range) {
      std::vector<double> inside(n_nodes_, 0.0);
      for (std::size_t p = 0; p < particles_.size(); ++p) {
        const double a = boundary::part_share(particles_.position[p].x(), spec.part.x_range,
                                              0.5 * grid.cell_size);
        for (const implicit_detail::NodeWeight& w : s.nodes[p])
          inside[static_cast<std::size_t>(w.node)] += a * w.value * particles_.volume[p];
      }
      for (std::size_t n = 0; n < n_nodes_; ++n)
        shares[n] = s.material[n] > 0.0 ? inside[n] / s.material[n] : 0.0;
    }
    for (const boundary::CurvePoint& point : points) {
      if (!grid.contains(point.x)) continue;
      ConstraintPoint q;
      q.constraint = static_cast<int>(k);
      q.x = point.x;
      q.weight = point.weight;
      q.normal = point.normal;
      // The loads' grid functions at x over the nodes with material.
      const ShapeStencil st =
          degree > 1 ? bspline_stencil(grid, degree, point.x) : linear_stencil(grid, point.x);
      double sum = 0.0;
      for (const implicit_detail::NodeWeight& w : implicit_detail::grid_nodes(grid, st)) {
        if (w.value == 0.0 || !s.map[2 * static_cast<std::size_t>(w.node)].used) continue;
        const double share = w.value * shares[static_cast<std::size_t>(w.node)];
        if (share == 0.0) continue;
        q.nodes.emplace_back(w.node, share);
        sum += share;
      }
      if (!(sum > 0.0)) continue;
      for (auto& node : q.nodes) node.second /= sum;
      std::vector<std::pair<int, double>> fit =
          linear_fit(grid, lists, particles_, point.x, spec.part.x_range);
      if (fit.empty()) continue;
      Vec2 target = u_bar, previous = constraint_target_[k];
      if (spec.normal_only) {
        const Vec2 n = spec.part.normal_window ? spec.part.normal_window->direction : q.normal;
        q.projector = n * n.transpose();
        target = u_bar.x() * n;
        previous = constraint_target_[k].x() * n;
      }
      if (const std::optional<Vec2> gap = carried_gap(k, point.x)) {
        q.offset = q.projector * (*gap + previous - target);
      } else {
        Vec2 u_n = Vec2::Zero();
        for (const auto& [p, c] : fit) {
          const auto i = static_cast<std::size_t>(p);
          u_n += c * (particles_.position[i] - particles_.reference_position[i]);
        }
        q.offset = q.projector * (u_n - target);
      }
      if (ibm) {
        q.share = band.rise;
        q.spring = band.slope_squared * q.projector.transpose() *
                   normal_stiffness(band_material(fit), q.normal) * q.projector;
        q.symmetric = true;
      } else {
        q.share = nitsche ? 1.0 : 0.0;
        q.spring = spec.penalty * q.projector;
      }
      if (q.share > 0.0) {
        if (s.fitted.empty()) s.fitted.assign(particles_.size(), 0);
        for (const auto& [p, c] : fit) s.fitted[static_cast<std::size_t>(p)] = 1;
        q.fit = std::move(fit);
      }
      s.points.push_back(std::move(q));
    }
  }
}

void ImplicitSolver::add_constraint_pairs(Prepared& s, std::vector<Eigen::Triplet<double>>& pairs) {
  for (ConstraintPoint& q : s.points) {
    q.rows.clear();
    for (const auto& [node, value] : q.nodes) {
      for (int d = 0; d < 2; ++d) {
        for (const auto& [dof, w] :
             s.map[2 * static_cast<std::size_t>(node) + static_cast<std::size_t>(d)].terms)
          q.rows.push_back(dof);
      }
    }
    std::sort(q.rows.begin(), q.rows.end());
    q.rows.erase(std::unique(q.rows.begin(), q.rows.end()), q.rows.end());
    q.cols = q.rows;
    for (const auto& [p, c] : q.fit) {
      const std::vector<int>& own = s.unknowns[static_cast<std::size_t>(p)];
      q.cols.insert(q.cols.end(), own.begin(), own.end());
    }
    std::sort(q.cols.begin(), q.cols.end());
    q.cols.erase(std::unique(q.cols.begin(), q.cols.end()), q.cols.end());
    for (const int i : q.rows)
      for (const int j : q.cols) pairs.emplace_back(i, j, 0.0);
    if (!q.symmetric) continue;
    for (const auto& [p, c] : q.fit) {
      for (const int i : s.unknowns[static_cast<std::size_t>(p)])
        for (const int j : q.rows) pairs.emplace_back(i, j, 0.0);
    }
  }
}

void ImplicitSolver::place_constraint_pairs(Prepared& s) {
  const auto place = [&](int row, int column) {
    return implicit_detail::place(s.pattern, row, column);
  };
  for (ConstraintPoint& q : s.points) {
    q.position.resize(q.rows.size() * q.cols.size());
    for (std::size_t a = 0; a < q.rows.size(); ++a) {
      for (std::size_t b = 0; b < q.cols.size(); ++b)
        q.position[a * q.cols.size() + b] = place(q.rows[a], q.cols[b]);
    }
    q.transposed.clear();
    if (!q.symmetric) continue;
    for (const auto& [p, c] : q.fit) {
      for (const int i : s.unknowns[static_cast<std::size_t>(p)])
        for (const int j : q.rows) q.transposed.push_back(place(i, j));
    }
  }
}

void ImplicitSolver::add_constraints(const Prepared& s, bool tangent, Iterate& it,
                                     Eigen::VectorXd& residual) const {
  std::vector<double> gap_squared(it.reports.size(), 0.0);
  for (ConstraintReport& r : it.reports) r = ConstraintReport{};
  double* values = tangent ? it.tangent.valuePtr() : nullptr;
  Eigen::MatrixXd stiffness;  // d (share t - S g) / d (the point's columns), 2 x cols
  Eigen::MatrixXd opening;    // d g / d (the point's rows), 2 x rows
  for (const ConstraintPoint& q : s.points) {
    if (q.symmetric && !tangent) {
      throw std::logic_error("add_constraints: the IBM's term needs the stress Jacobians");
    }
    Vec2 du = Vec2::Zero();
    for (const auto& [node, value] : q.nodes)
      du += value * it.increment[static_cast<std::size_t>(node)];
    const Vec2 gap = q.offset + q.projector * du;
    Vec2 traction = Vec2::Zero();
    if (!q.fit.empty()) {
      Stress sigma = Stress::Zero();
      for (const auto& [p, c] : q.fit) sigma += c * it.stress[static_cast<std::size_t>(p)];
      traction = q.projector * Vec2(sigma[kXX] * q.normal.x() + sigma[kXY] * q.normal.y(),
                                    sigma[kXY] * q.normal.x() + sigma[kYY] * q.normal.y());
    }
    const Vec2 force = q.weight * (q.share * traction - q.spring * gap);
    ConstraintReport& report = it.reports[static_cast<std::size_t>(q.constraint)];
    report.force += force;
    report.length += q.weight;
    gap_squared[static_cast<std::size_t>(q.constraint)] += q.weight * gap.squaredNorm();
    for (const auto& [node, value] : q.nodes) {
      for (int d = 0; d < 2; ++d) {
        for (const auto& [dof, w] :
             s.map[2 * static_cast<std::size_t>(node) + static_cast<std::size_t>(d)].terms)
          residual[dof] += w * value * force[d];
      }
    }
    if (!tangent) continue;
    const auto column = [&](int dof) {
      return std::lower_bound(q.cols.begin(), q.cols.end(), dof) - q.cols.begin();
    };
    const auto row_of = [&](int dof) {
      return std::lower_bound(q.rows.begin(), q.rows.end(), dof) - q.rows.begin();
    };
    stiffness.setZero(2, static_cast<Eigen::Index>(q.cols.size()));
    opening.setZero(2, static_cast<Eigen::Index>(q.rows.size()));
    const Mat2 spring_opening = q.spring * q.projector;
    for (const auto& [node, value] : q.nodes) {
      for (int d = 0; d < 2; ++d) {
        for (const auto& [dof, w] :
             s.map[2 * static_cast<std::size_t>(node) + static_cast<std::size_t>(d)].terms) {
          stiffness.col(column(dof)) -= w * value * spring_opening.col(d);
          opening.col(row_of(dof)) += w * value * q.projector.col(d);
        }
      }
    }
    // The traction's change through each fitted particle's stress, and the IBM's transposed
    // term: weight share (d sigma_p / d x_b) n . g on the particle's unknown b (a force on
    // the fit's particles), its derivative weight share c_p (d sigma_p / d x_b) n . d g / d x.
    std::size_t k = 0;
    for (const auto& [p, c] : q.fit) {
      const auto i = static_cast<std::size_t>(p);
      const Eigen::MatrixXd& jacobian = it.stress_jacobian[i];
      const std::vector<int>& own = s.unknowns[i];
      for (std::size_t b = 0; b < own.size(); ++b) {
        const auto kb = static_cast<Eigen::Index>(b);
        const Vec2 change(jacobian(kXX, kb) * q.normal.x() + jacobian(kXY, kb) * q.normal.y(),
                          jacobian(kXY, kb) * q.normal.x() + jacobian(kYY, kb) * q.normal.y());
        stiffness.col(column(own[b])) += q.share * c * (q.projector * change);
        if (!q.symmetric) continue;
        const double scale = q.weight * q.share * c;
        residual[own[b]] += scale * change.dot(gap);
        for (Eigen::Index a = 0; a < opening.cols(); ++a)
          values[q.transposed[k++]] -= scale * change.dot(opening.col(a));
      }
    }
    // K = -d R / d x: the rows of the point's nodes take -w N_I times the force's derivative.
    const std::size_t n_cols = q.cols.size();
    for (const auto& [node, value] : q.nodes) {
      for (int d = 0; d < 2; ++d) {
        for (const auto& [dof, w] :
             s.map[2 * static_cast<std::size_t>(node) + static_cast<std::size_t>(d)].terms) {
          const auto row = static_cast<std::size_t>(row_of(dof));
          const double scale = q.weight * w * value;
          for (std::size_t b = 0; b < n_cols; ++b)
            values[q.position[row * n_cols + b]] -=
                scale * stiffness(d, static_cast<Eigen::Index>(b));
        }
      }
    }
  }
  for (std::size_t k = 0; k < it.reports.size(); ++k) {
    ConstraintReport& r = it.reports[k];
    r.rms_gap = r.length > 0.0 ? std::sqrt(gap_squared[k] / r.length) : 0.0;
  }
}

}  // namespace pfm
