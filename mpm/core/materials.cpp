// Constitutive models for plane strain (contract: materials.hpp).
//
// Conventions: tension positive; stress (sxx, syy, sxy, szz) in kPa; strain increment
// (dxx, dyy, dgamma_xy, dzz = 0). Isotropic elasticity D = lambda 1 (x) 1 + 2 mu I.
//
// Principal stresses. The in-plane pair is s_a,b = (sxx + syy)/2 +- sqrt(((sxx - syy)/2)^2 +
// sxy^2) with direction cos(2 theta) = (sxx - syy)/2 / R, sin(2 theta) = sxy / R; szz is the
// third principal stress (plane strain). They are ordered s1 >= s2 >= s3. With isotropic
// elasticity and flow potentials that are functions of the principal stresses, the returned
// stress is coaxial with the elastic trial stress (de Souza Neto, Peric & Owen 2008, ch. 8), so
// the return works on the three principal values and rotates back with the trial directions.
//
// Yield planes, in the ordered frame of the trial stress (s1 >= s2 >= s3):
//   shear plane (I, J), I major, J minor:
//     F_IJ = (1 + sin phi) s_I - (1 - sin phi) s_J - 2 c(eps_p) cos phi
//     flow (potential with psi):  n_IJ = (1 + sin psi) e_I - (1 - sin psi) e_J
//   Mohr-Coulomb uses F_13 (main plane), F_23 (right edge, s1 = s2) and F_12 (left edge,
//   s2 = s3). Tresca is the same with phi = psi = 0 and f = F / 2 = (s1 - s3)/2 - c: its
//   multiplier is twice the one of F (reported so by update_with_info).
//   tension plane I:  T_I = s_I - sigma_t,eff(c), associated flow e_I (Rankine cut-off), with
//   sigma_t,eff(c) = min(tension_cutoff, c(eps_p) / tan phi) for phi > 0 (tension_cutoff for
//   phi = 0): the cut-off follows the cone apex down when c softens below tension_cutoff tan phi.
//   Then the hydrostatic tension apex (sigma_t,eff, sigma_t,eff, sigma_t,eff) is always
//   admissible, and the cone apex is reached as the tension apex (any psi, also psi = 0, for
//   which a return to the apex along the shear flow alone would not exist).
//
// Equivalent plastic strain (the softening variable of c):
//   d eps_p = sum over the active shear planes of dgamma_IJ * (n_IJ[I] - n_IJ[J])
//           = 2 * sum dgamma_IJ (Mohr-Coulomb multipliers)  = sum dgamma (Tresca multipliers),
//   i.e. the plastic engineering shear strain eps1^p - eps3^p that each active plane produces.
//   On the main plane it is exactly eps1^p - eps3^p, independent of psi; in simple shear it is
//   gamma_xy^p. The tension cut-off does not soften c (its flow adds nothing to eps_p).
//   With associated Tresca flow c * d eps_p is the plastic dissipation.
//
// Return mapping (backward Euler, closest point in the energy norm for associated flow):
//   sigma = sigma_trial - sum_l dgamma_l D n_l,  F_j(sigma, c(eps_p,n + d eps_p)) = 0 for the
//   active planes j. For a given set of planes and a given c this is linear in the multipliers:
//   dgamma = u - v c, hence d eps_p = U - V c(eps_p,n + d eps_p), one scalar equation. c is
//   piecewise linear, so G(e) = U - V c(eps_p,n + e) - e is linear on each segment of the law
//   (segments are also split where c crosses tension_cutoff tan phi, the kink of
//   sigma_t,eff(c)); its zeros e >= 0 are found exactly, segment by segment from eps_p,n up,
//   so a step that crosses breakpoints lands exactly on the surface. Usually G(0) > 0 and there
//   is one zero; beyond the last breakpoint c is constant and G has slope -1, so a set with
//   G(0) > 0 always has one. A set can be locally in snap-back (1 + V dc/deps_p < 0 on a
//   segment; with the cut-off active the shear planes are much softer, so this happens with
//   thesis-like laws already), and then G may start negative or have several zeros.
//   Sets of active planes are tried in this order, first with the first zero of each set, then
//   with the further zeros, and the first (set, zero) that satisfies the Kuhn-Tucker conditions
//   (all multipliers >= 0, the returned stress inside every plane to round-off) is taken (de
//   Souza Neto et al. Boxes 8.1-8.5 pick main plane / edge / apex the same way, by checking the
//   order of the returned principal stresses):
//     {F13} main plane, {F13, F23} right edge, {F13, F12} left edge,
//     then with a cut-off: {T1}, {F13, T1}, {T1, T2}, {F13, F12, T1}, {F13, T1, T2},
//     {F13, F23, T1}, {T1, T2, T3} (tension apex), {F13, F23, F12} (cone apex, psi > 0).
//   At the corner s1 = s2 = sigma_t on the cone the four planes F13, F23, T1, T2 meet; their
//   multipliers are not unique but the stress and the sum of the shear multipliers (so eps_p)
//   are, and the two 3-plane sets above cover it. Should no set satisfy the conditions (never
//   seen in the tests), the least violating one is used and ReturnInfo::admissible is false.
#include "mpm/core/materials.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace pfm {

double PiecewiseLinear::value(double at) const {
  if (at <= x.front()) return y.front();
  if (at >= x.back()) return y.back();
  const auto k = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(), at) - x.begin());
  const double t = (at - x[k - 1]) / (x[k] - x[k - 1]);
  return y[k - 1] + t * (y[k] - y[k - 1]);
}

double PiecewiseLinear::slope(double at) const {
  if (at < x.front() || at >= x.back()) return 0.0;
  const auto k = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(), at) - x.begin());
  return (y[k] - y[k - 1]) / (x[k] - x[k - 1]);
}

double PiecewiseLinear::min_value() const {
  return *std::min_element(y.begin(), y.end());
}

namespace {

MaterialConstants hooke_constants(const ElasticParameters& elastic) {
  MaterialConstants k;
  k.lambda = elastic.lame_lambda();
  k.mu = elastic.shear_modulus();
  k.compliance = 1.0 / elastic.youngs_modulus;
  k.compliance_coupling = -elastic.poisson_ratio / elastic.youngs_modulus;
  return k;
}

}  // namespace

Stress elastic_stress_increment(const ElasticParameters& elastic, const Strain& d) {
  return elastic_stress_increment(hooke_constants(elastic), d);
}

Tangent elastic_tangent(const MaterialConstants& k) {
  const double lambda = k.lambda, two_mu = 2.0 * k.mu;
  Tangent d = Tangent::Zero();
  for (const int i : {kXX, kYY, kZZ}) {
    for (const int j : {kXX, kYY, kZZ}) d(i, j) = lambda + (i == j ? two_mu : 0.0);
  }
  d(kXY, kXY) = k.mu;  // the strain's shear entry is gamma_xy = 2 eps_xy
  return d;
}

void LinearElastic::update(const Strain& strain_increment, Stress& stress, PointState&) const {
  stress += elastic_stress_increment(elastic, strain_increment);
}

MaterialConstants LinearElastic::constants() const {
  return hooke_constants(elastic);
}

ReturnInfo LinearElastic::update_with_tangent(const Strain& strain_increment, Stress& stress,
                                              PointState& /*state*/, Tangent& tangent) const {
  const MaterialConstants k = constants();
  stress += elastic_stress_increment(k, strain_increment);
  tangent = elastic_tangent(k);
  return ReturnInfo{};
}

const ElasticParameters& elastic_parameters(const Material& material) {
  return std::visit([](const auto& m) -> const ElasticParameters& { return m.elastic; }, material);
}

MaterialConstants material_constants(const Material& material) {
  return std::visit([](const auto& m) { return m.constants(); }, material);
}

namespace {

constexpr double kRadiansPerDegree = std::numbers::pi / 180.0;

PiecewiseLinear divided(PiecewiseLinear law, double factor) {
  for (double& y : law.y) y /= factor;
  return law;
}

double reduced_angle_deg(double angle_deg, double factor) {
  return std::atan(std::tan(angle_deg * kRadiansPerDegree) / factor) / kRadiansPerDegree;
}

}  // namespace

Material reduced_strength(const Material& material, double factor) {
  if (const auto* tresca = std::get_if<Tresca>(&material)) {
    Tresca reduced = *tresca;
    reduced.cohesion = divided(tresca->cohesion, factor);
    return reduced;
  }
  if (const auto* mc = std::get_if<MohrCoulomb>(&material)) {
    MohrCoulomb reduced = *mc;
    reduced.cohesion = divided(mc->cohesion, factor);
    reduced.friction_angle_deg = reduced_angle_deg(mc->friction_angle_deg, factor);
    reduced.dilation_angle_deg = reduced_angle_deg(mc->dilation_angle_deg, factor);
    reduced.tension_cutoff = mc->tension_cutoff / factor;
    return reduced;
  }
  return material;
}

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
// Kuhn-Tucker checks: a multiplier may be negative by this fraction of the largest one, a yield
// function positive by this fraction of the stress scale (round-off only).
constexpr double kMultiplierTolerance = 1e-10;
constexpr double kYieldTolerance = 1e-12;

/// Principal stresses of a plane-strain stress, ordered, with what is needed to rotate back.
struct PrincipalStress {
  double values[3];  ///< s1 >= s2 >= s3
  int source[3];     ///< 0: in-plane major, 1: in-plane minor, 2: zz
  double cos_2theta;
  double sin_2theta;
};

/// The ordered principal values (and their sources) only; principal_directions() adds the rest.
/// Split so that an elastic step, which needs only the values, skips the two divisions.
inline PrincipalStress principal_values(const Stress& s) {
  const double center = 0.5 * (s[kXX] + s[kYY]);
  const double half_difference = 0.5 * (s[kXX] - s[kYY]);
  const double radius = std::sqrt(half_difference * half_difference + s[kXY] * s[kXY]);
  PrincipalStress p;
  p.cos_2theta = 1.0;
  p.sin_2theta = 0.0;
  const double major = center + radius, minor = center - radius, zz = s[kZZ];
  if (zz >= major) {
    p.values[0] = zz, p.values[1] = major, p.values[2] = minor;
    p.source[0] = 2, p.source[1] = 0, p.source[2] = 1;
  } else if (zz >= minor) {
    p.values[0] = major, p.values[1] = zz, p.values[2] = minor;
    p.source[0] = 0, p.source[1] = 2, p.source[2] = 1;
  } else {
    p.values[0] = major, p.values[1] = minor, p.values[2] = zz;
    p.source[0] = 0, p.source[1] = 1, p.source[2] = 2;
  }
  return p;
}

/// Fills in the directions of p = principal_values(s).
inline void principal_directions(const Stress& s, PrincipalStress& p) {
  const double half_difference = 0.5 * (s[kXX] - s[kYY]);
  const double radius = std::sqrt(half_difference * half_difference + s[kXY] * s[kXY]);
  if (radius > 0.0) {
    p.cos_2theta = half_difference / radius;
    p.sin_2theta = s[kXY] / radius;
  }
}

inline PrincipalStress principal_stress(const Stress& s) {
  PrincipalStress p = principal_values(s);
  principal_directions(s, p);
  return p;
}

/// Stress with the principal values `ordered` (in the order of p.values) and p's directions.
inline void assemble_stress(const PrincipalStress& p, const double ordered[3], Stress& s) {
  double by_source[3];
  for (int k = 0; k < 3; ++k) by_source[p.source[k]] = ordered[k];
  const double center = 0.5 * (by_source[0] + by_source[1]);
  const double radius = 0.5 * (by_source[0] - by_source[1]);
  s[kXX] = center + radius * p.cos_2theta;
  s[kYY] = center - radius * p.cos_2theta;
  s[kXY] = radius * p.sin_2theta;
  s[kZZ] = by_source[2];
}

/// Constants of the plane-type surfaces (Tresca: phi = psi = 0, no cut-off).
struct PlaneModel {
  double sin_phi;
  double cos_phi;
  double sin_psi;
  double tension_cutoff;  ///< sigma_t as given; +inf: none
  double lambda;
  double two_mu;
  /// sigma_t,eff(c) = min(sigma_t, c cot phi): the cut-off never above the current cone apex.
  double effective_cutoff(double c) const {
    return sin_phi > 0.0 ? std::min(tension_cutoff, c * cos_phi / sin_phi) : tension_cutoff;
  }
  /// The cohesion below which the cone apex is the binding cut-off (-inf: never).
  double cap_cohesion() const {
    if (sin_phi <= 0.0) return -kInfinity;  // no cone apex: always sigma_t
    return tension_cutoff < kInfinity ? tension_cutoff * sin_phi / cos_phi : kInfinity;
  }
};

/// One plane in the ordered principal frame:
///   f = gradient . s - cohesion_factor c - cutoff_factor sigma_t,eff(c).
struct PlaneData {
  double gradient[3];
  double stiff_flow[3];    ///< D n, n the flow direction
  double cohesion_factor;  ///< 2 cos(phi) for shear planes, 0 for tension
  double cutoff_factor;    ///< 1 for tension planes, 0 for shear
  double shear_strain;     ///< d eps_p per unit multiplier: 2 for shear planes, 0 for tension
};

PlaneData make_plane(const PlaneModel& m, YieldPlane id) {
  PlaneData p{};
  double flow[3] = {0.0, 0.0, 0.0};
  if (id == YieldPlane::kShear13 || id == YieldPlane::kShear23 || id == YieldPlane::kShear12) {
    const int major = id == YieldPlane::kShear23 ? 1 : 0;
    const int minor = id == YieldPlane::kShear12 ? 1 : 2;
    p.gradient[major] = 1.0 + m.sin_phi;
    p.gradient[minor] = -(1.0 - m.sin_phi);
    flow[major] = 1.0 + m.sin_psi;
    flow[minor] = -(1.0 - m.sin_psi);
    p.cohesion_factor = 2.0 * m.cos_phi;
    p.cutoff_factor = 0.0;
    p.shear_strain = 2.0;
  } else {
    const int i = static_cast<int>(id) - static_cast<int>(YieldPlane::kTension1);
    p.gradient[i] = 1.0;
    flow[i] = 1.0;
    p.cohesion_factor = 0.0;
    p.cutoff_factor = 1.0;
    p.shear_strain = 0.0;
  }
  const double trace = flow[0] + flow[1] + flow[2];
  for (int k = 0; k < 3; ++k) p.stiff_flow[k] = m.lambda * trace + m.two_mu * flow[k];
  return p;
}

struct ActiveSet {
  int n;
  YieldPlane planes[3];
};

constexpr int kShearOnlySets = 3;
constexpr ActiveSet kActiveSets[] = {
    {1, {YieldPlane::kShear13}},
    {2, {YieldPlane::kShear13, YieldPlane::kShear23}},
    {2, {YieldPlane::kShear13, YieldPlane::kShear12}},
    {1, {YieldPlane::kTension1}},
    {2, {YieldPlane::kShear13, YieldPlane::kTension1}},
    {2, {YieldPlane::kTension1, YieldPlane::kTension2}},
    {3, {YieldPlane::kShear13, YieldPlane::kShear12, YieldPlane::kTension1}},
    {3, {YieldPlane::kShear13, YieldPlane::kTension1, YieldPlane::kTension2}},
    {3, {YieldPlane::kShear13, YieldPlane::kShear23, YieldPlane::kTension1}},
    {3, {YieldPlane::kTension1, YieldPlane::kTension2, YieldPlane::kTension3}},
    {3, {YieldPlane::kShear13, YieldPlane::kShear23, YieldPlane::kShear12}},
};
constexpr int kAllSets = static_cast<int>(sizeof(kActiveSets) / sizeof(kActiveSets[0]));

/// Solves a x = b in place (b <- x) for n <= 3 and three right-hand sides, partial pivoting.
/// Returns false if a is singular to round-off.
bool solve_small(int n, double a[3][3], double b[3][3]) {
  double scale = 0.0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) scale = std::max(scale, std::abs(a[i][j]));
  for (int col = 0; col < n; ++col) {
    int pivot = col;
    for (int r = col + 1; r < n; ++r)
      if (std::abs(a[r][col]) > std::abs(a[pivot][col])) pivot = r;
    if (!(std::abs(a[pivot][col]) > 1e-12 * scale)) return false;
    if (pivot != col) {
      for (int j = 0; j < n; ++j) std::swap(a[col][j], a[pivot][j]);
      for (int q = 0; q < 3; ++q) std::swap(b[col][q], b[pivot][q]);
    }
    for (int r = col + 1; r < n; ++r) {
      const double factor = a[r][col] / a[col][col];
      for (int j = col; j < n; ++j) a[r][j] -= factor * a[col][j];
      for (int q = 0; q < 3; ++q) b[r][q] -= factor * b[col][q];
    }
  }
  for (int r = n - 1; r >= 0; --r) {
    for (int j = r + 1; j < n; ++j)
      for (int q = 0; q < 3; ++q) b[r][q] -= a[r][j] * b[j][q];
    for (int q = 0; q < 3; ++q) b[r][q] /= a[r][r];
  }
  return true;
}

/// d eps_p as a function of c: u - v c, with (u, v) = (u_above, v_above) for c >= c_cap and
/// (u_below, v_below) below (the cut-off follows the cone apex there); continuous at c_cap.
struct StrainOfCohesion {
  double u_above, v_above, u_below, v_below, c_cap;
};

constexpr int kMaxRoots = 16;

/// The zeros e >= 0, in increasing order, of G(e) = u - v c(eps_n + e) - e with c piecewise
/// linear: the plastic strain increments of one active set. Usually one; more when the set is
/// locally in snap-back (1 + v dc/de < 0 on a segment: with the cut-off active the shear planes
/// are much softer, so this happens with thesis-like laws already) and G rises and falls again.
/// Walks the segments of the law from eps_n (split where c crosses c_cap); G is linear on each
/// piece, so each root is exact. Writes at most kMaxRoots; returns how many.
int plastic_strain_roots(const PiecewiseLinear& law, double eps_n, const StrainOfCohesion& g,
                         double increments[kMaxRoots], double cohesions[kMaxRoots]) {
  int n_roots = 0;
  // One piece [e_a, e_b] on which c = c_a + slope (e - e_a) and the regime is fixed.
  auto piece = [&](double e_a, double c_a, double e_b, double slope) {
    if (n_roots >= kMaxRoots) return;
    const bool finite = std::isfinite(e_b);
    const double c_inside = finite ? c_a + 0.5 * slope * (e_b - e_a) : c_a;
    const bool above = c_inside >= g.c_cap;
    const double u = above ? g.u_above : g.u_below, v = above ? g.v_above : g.v_below;
    const double at_start = u - v * c_a - e_a;  // G(e_a)
    const double decay = 1.0 + v * slope;       // -dG/de
    double step = -1.0;
    if (at_start == 0.0) {
      step = 0.0;
    } else if (decay != 0.0) {
      step = at_start / decay;  // zero of the linear G
      if (finite && step > e_b - e_a) step = -1.0;
    }
    if (step >= 0.0) {
      increments[n_roots] = e_a + step;
      cohesions[n_roots] = c_a + slope * step;
      ++n_roots;
    }
  };
  const std::size_t n_points = law.x.size();
  std::size_t k =
      static_cast<std::size_t>(std::upper_bound(law.x.begin(), law.x.end(), eps_n) - law.x.begin());
  double e_start = 0.0, c_start = law.value(eps_n);
  while (true) {
    const bool last = k >= n_points;  // beyond the last point: c constant, G slope -1
    const double e_end = last ? kInfinity : law.x[k] - eps_n;
    const double c_end = last ? c_start : law.y[k];
    const double slope =
        (last || k == 0) ? 0.0 : (law.y[k] - law.y[k - 1]) / (law.x[k] - law.x[k - 1]);
    if ((c_start - g.c_cap) * (c_end - g.c_cap) < 0.0) {
      const double e_split = e_start + (g.c_cap - c_start) / slope;
      piece(e_start, c_start, e_split, slope);
      piece(e_split, g.c_cap, e_end, slope);
    } else {
      piece(e_start, c_start, e_end, slope);
    }
    if (last) break;
    e_start = e_end, c_start = c_end, ++k;
  }
  return n_roots;
}

/// Return of the ordered principal trial stress `trial` onto the planes of `model`, trying the
/// first `n_sets` active sets. Writes the ordered principal result and returns what was done
/// (multipliers of the F / T planes as written in the header comment).
ReturnInfo principal_return(const PlaneModel& model, const PiecewiseLinear& cohesion, int n_sets,
                            double eps_n, const double trial[3], double result[3]) {
  // The planes are built when a set first needs them (usually only the main plane is).
  PlaneData planes[6];
  bool built[6] = {false, false, false, false, false, false};
  const int n_planes = n_sets > kShearOnlySets ? 6 : 3;

  const double c_cap = model.cap_cohesion();
  ReturnInfo best;  // if nothing is found at all (NaN input): the trial stress, flagged
  best.admissible = false;
  for (int k = 0; k < 3; ++k) result[k] = trial[k];
  double best_violation = kInfinity;
  // Pass 0 tries the first root of each set, pass 1 the further roots (snap-back only): the
  // smallest admissible plastic strain increment is preferred.
  for (int pass = 0; pass < 2; ++pass) {
    for (int set_index = 0; set_index < n_sets; ++set_index) {
      const ActiveSet& set = kActiveSets[set_index];
      const int n = set.n;
      for (int j = 0; j < n; ++j) {
        const int id = static_cast<int>(set.planes[j]);
        if (!built[id]) planes[id] = make_plane(model, set.planes[j]), built[id] = true;
      }
      // multipliers = b0 - b1 c - b2 sigma_t,eff(c)
      double a[3][3], b[3][3];
      for (int j = 0; j < n; ++j) {
        const PlaneData& pj = planes[static_cast<int>(set.planes[j])];
        for (int l = 0; l < n; ++l) {
          const PlaneData& pl = planes[static_cast<int>(set.planes[l])];
          a[j][l] = pj.gradient[0] * pl.stiff_flow[0] + pj.gradient[1] * pl.stiff_flow[1] +
                    pj.gradient[2] * pl.stiff_flow[2];
        }
        b[j][0] = pj.gradient[0] * trial[0] + pj.gradient[1] * trial[1] + pj.gradient[2] * trial[2];
        b[j][1] = pj.cohesion_factor;
        b[j][2] = pj.cutoff_factor;
      }
      if (!solve_small(n, a, b)) continue;
      double w[3] = {0.0, 0.0, 0.0};  // d eps_p = w0 - w1 c - w2 sigma_t,eff(c)
      for (int l = 0; l < n; ++l) {
        const double kappa = planes[static_cast<int>(set.planes[l])].shear_strain;
        for (int q = 0; q < 3; ++q) w[q] += kappa * b[l][q];
      }
      const double cot_phi = model.sin_phi > 0.0 ? model.cos_phi / model.sin_phi : 0.0;
      const double cutoff = std::isfinite(model.tension_cutoff) ? model.tension_cutoff : 0.0;
      const StrainOfCohesion g{w[0] - w[2] * cutoff, w[1], w[0], w[1] + w[2] * cot_phi,
                               w[2] != 0.0 ? c_cap : -kInfinity};
      double increments[kMaxRoots], cohesions[kMaxRoots];
      const int n_roots = plastic_strain_roots(cohesion, eps_n, g, increments, cohesions);
      for (int root = pass == 0 ? 0 : 1; root < (pass == 0 ? std::min(n_roots, 1) : n_roots);
           ++root) {
        const double c = cohesions[root];
        const double tension = model.effective_cutoff(c);
        const double tension_term = n_planes > 3 ? tension : 0.0;
        ReturnInfo info;
        info.n_active = n;
        info.plastic_strain_increment = increments[root];
        double s[3] = {trial[0], trial[1], trial[2]};
        double largest_multiplier = 0.0, smallest_multiplier = 0.0;
        for (int l = 0; l < n; ++l) {
          const PlaneData& pl = planes[static_cast<int>(set.planes[l])];
          const double multiplier = b[l][0] - b[l][1] * c - b[l][2] * tension_term;
          info.planes[l] = set.planes[l];
          info.multipliers[l] = multiplier;
          largest_multiplier = std::max(largest_multiplier, std::abs(multiplier));
          smallest_multiplier = std::min(smallest_multiplier, multiplier);
          for (int k = 0; k < 3; ++k) s[k] -= multiplier * pl.stiff_flow[k];
        }
        // Kuhn-Tucker: multipliers >= 0, the result inside every plane (the order may change).
        const double s_max = std::max({s[0], s[1], s[2]});
        const double s_min = std::min({s[0], s[1], s[2]});
        const double stress_scale = std::abs(s_max) + std::abs(s_min) + std::abs(c) + 1e-300;
        const double multiplier_violation =
            -smallest_multiplier / (largest_multiplier + 1e-300) - kMultiplierTolerance;
        double yield_violation =
            (1.0 + model.sin_phi) * s_max - (1.0 - model.sin_phi) * s_min - 2.0 * model.cos_phi * c;
        yield_violation = yield_violation / stress_scale - kYieldTolerance;
        if (n_planes > 3) {
          yield_violation =
              std::max(yield_violation,
                       (s_max - tension) / (stress_scale + std::abs(tension)) - kYieldTolerance);
        }
        if (std::max(multiplier_violation, yield_violation) <= 0.0) {
          for (int k = 0; k < 3; ++k) result[k] = s[k];
          return info;
        }
        // No admissible set (only seen with softening steeper than the elastic stiffness, where
        // the local problem may have no solution): prefer a stress on the surface, then the
        // least negative multiplier.
        const double rank = yield_violation > 0.0 ? 1.0 + yield_violation : multiplier_violation;
        if (rank < best_violation) {
          best_violation = rank;
          best = info;
          best.admissible = false;
          for (int k = 0; k < 3; ++k) result[k] = s[k];
        }
      }
    }
  }
  return best;
}

/// The Jacobian d result / d trial (ordered frame, jacobian[a][b] = d result_a / d trial_b) of
/// principal_return's answer `info` on `cohesion` from eps_n: the linearisation of
///   result = trial - sum_l dgamma_l D n_l,  F_j(result, c(eps_n + d eps_p)) = 0 (active j),
///   d eps_p = sum_l kappa_l dgamma_l,
/// at the answer: sum_l (a_j . D n_l + h_j kappa_l) d dgamma_l = a_j . d trial with a_j the
/// plane's gradient, kappa_l its shear_strain and h_j = (cohesion_factor_j + cutoff_factor_j
/// d sigma_t,eff / dc) dc/d eps_p (the slope of the law at the new eps_p, from the right at a
/// breakpoint), so d result = (I - sum_lj D n_l (M^-1)_lj a_j^T) d trial. The identity for an
/// elastic answer.
void principal_jacobian(const PlaneModel& model, const PiecewiseLinear& cohesion, double eps_n,
                        const ReturnInfo& info, double jacobian[3][3]) {
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) jacobian[a][b] = a == b ? 1.0 : 0.0;
  const int n = info.n_active;
  if (n == 0) return;
  const double eps = eps_n + info.plastic_strain_increment;
  const double c = cohesion.value(eps);
  const double cot_phi = model.sin_phi > 0.0 ? model.cos_phi / model.sin_phi : 0.0;
  // sigma_t,eff = c cot(phi) below the cap cohesion (the cone apex binds), else constant.
  const double cutoff_slope = c < model.cap_cohesion() ? cot_phi : 0.0;
  const double softening = cohesion.slope(eps);
  PlaneData planes[3];
  for (int l = 0; l < n; ++l) planes[l] = make_plane(model, info.planes[l]);
  double m[3][3], x[3][3];  // x <- M^-1 [a_1 .. a_n]^T
  for (int j = 0; j < n; ++j) {
    const PlaneData& pj = planes[j];
    const double h = (pj.cohesion_factor + pj.cutoff_factor * cutoff_slope) * softening;
    for (int l = 0; l < n; ++l) {
      const PlaneData& pl = planes[l];
      m[j][l] = pj.gradient[0] * pl.stiff_flow[0] + pj.gradient[1] * pl.stiff_flow[1] +
                pj.gradient[2] * pl.stiff_flow[2] + h * pl.shear_strain;
    }
    for (int q = 0; q < 3; ++q) x[j][q] = pj.gradient[q];
  }
  if (!solve_small(n, m, x)) return;  // planes that do not fix the answer: the elastic Jacobian
  for (int l = 0; l < n; ++l)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) jacobian[a][b] -= planes[l].stiff_flow[a] * x[l][b];
}

/// The tangent d stress / d strain increment of a return whose principal answer `ordered` (with
/// Jacobian `jacobian`, principal_jacobian) was found from the trial stress `trial` (principal
/// values and directions `p`): the stress is an isotropic function of the trial stress, so
/// (de Souza Neto, Peric & Owen 2008, appendix A.5) in the plane
///   d sigma = sum_ab d sigma_a / d x_b m_a (m_b : d trial)
///             + (sigma_A - sigma_B) / (x_A - x_B) (d trial - sum_a m_a (m_a : d trial))
/// with m_a the trial's in-plane eigenprojections (the second term turns the answer with the
/// trial directions; its factor tends to d sigma_A / d x_A - d sigma_A / d x_B as x_A -> x_B),
/// and zz as the third principal direction; times Hooke's law, d trial = D d strain.
Tangent spectral_tangent(const MaterialConstants& k, const PrincipalStress& p,
                         const double ordered[3], const double jacobian[3][3]) {
  // Principal values and Jacobian by source (0: in-plane major A, 1: in-plane minor B, 2: zz).
  double x[3], sigma[3], d[3][3];
  for (int a = 0; a < 3; ++a) {
    x[p.source[a]] = p.values[a];
    sigma[p.source[a]] = ordered[a];
    for (int b = 0; b < 3; ++b) d[p.source[a]][p.source[b]] = jacobian[a][b];
  }
  // Eigenprojections as 4-vectors (xx, yy, xy, zz), and the rows that contract them with a
  // stress in the same order (m : s counts xy twice).
  const double c2 = p.cos_2theta, s2 = p.sin_2theta;
  Eigen::Vector4d m[3];
  m[0] = Eigen::Vector4d(0.5 * (1.0 + c2), 0.5 * (1.0 - c2), 0.5 * s2, 0.0);
  m[1] = Eigen::Vector4d(0.5 * (1.0 - c2), 0.5 * (1.0 + c2), -0.5 * s2, 0.0);
  m[2] = Eigen::Vector4d(0.0, 0.0, 0.0, 1.0);
  const Eigen::Vector4d weight(1.0, 1.0, 2.0, 1.0);
  Tangent of_trial = Tangent::Zero();  // d sigma / d trial
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) of_trial += d[a][b] * m[a] * m[b].cwiseProduct(weight).transpose();
  const double gap = x[0] - x[1];
  const double scale = std::abs(x[0]) + std::abs(x[1]) + 1e-300;
  const double turn =
      std::abs(gap) > 1e-12 * scale ? (sigma[0] - sigma[1]) / gap : d[0][0] - d[0][1];
  Tangent in_plane = Tangent::Zero();
  in_plane(kXX, kXX) = in_plane(kYY, kYY) = in_plane(kXY, kXY) = 1.0;
  for (int a = 0; a < 2; ++a) in_plane -= m[a] * m[a].cwiseProduct(weight).transpose();
  of_trial += turn * in_plane;
  return of_trial * elastic_tangent(k);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Tresca

double Tresca::yield_function(const Stress& stress, const PointState& state) const {
  const PrincipalStress p = principal_stress(stress);
  return 0.5 * (p.values[0] - p.values[2]) - cohesion.value(state.plastic_strain);
}

MaterialConstants Tresca::constants() const {
  return hooke_constants(elastic);
}

namespace {

/// Tresca::update_with_info with the constants given. The elastic case (the common one) returns
/// right after the trial check.
/// With `tangent`, also the consistent tangent there.
inline ReturnInfo tresca_update(const Tresca& m, const MaterialConstants& k,
                                const Strain& strain_increment, Stress& stress, PointState& state,
                                Tangent* tangent = nullptr) {
  stress += elastic_stress_increment(k, strain_increment);  // elastic trial
  PrincipalStress p = principal_values(stress);
  const double eps_n = state.plastic_strain;
  if (0.5 * (p.values[0] - p.values[2]) - m.cohesion.value(eps_n) <= 0.0) {
    if (tangent != nullptr) *tangent = elastic_tangent(k);
    return ReturnInfo{};
  }
  principal_directions(stress, p);

  const PlaneModel model{0.0, 1.0, 0.0, kInfinity, k.lambda, 2.0 * k.mu};
  double ordered[3];
  ReturnInfo info = principal_return(model, m.cohesion, kShearOnlySets, eps_n, p.values, ordered);
  if (tangent != nullptr) {
    double jacobian[3][3];
    principal_jacobian(model, m.cohesion, eps_n, info, jacobian);
    *tangent = spectral_tangent(k, p, ordered, jacobian);
  }
  for (int l = 0; l < info.n_active; ++l) info.multipliers[l] *= 2.0;  // f = F / 2
  assemble_stress(p, ordered, stress);
  state.plastic_strain = eps_n + info.plastic_strain_increment;
  return info;
}

}  // namespace

ReturnInfo Tresca::update_with_info(const Strain& strain_increment, Stress& stress,
                                    PointState& state) const {
  return tresca_update(*this, constants(), strain_increment, stress, state);
}

ReturnInfo Tresca::update_with_tangent(const Strain& strain_increment, Stress& stress,
                                       PointState& state, Tangent& tangent) const {
  return tresca_update(*this, constants(), strain_increment, stress, state, &tangent);
}

void Tresca::update(const Strain& strain_increment, Stress& stress, PointState& state) const {
  tresca_update(*this, constants(), strain_increment, stress, state);
}

void Tresca::update(const Strain& strain_increment, Stress& stress, PointState& state,
                    const MaterialConstants& constants) const {
  tresca_update(*this, constants, strain_increment, stress, state);
}

// ---------------------------------------------------------------------------------------------
// Mohr-Coulomb

double MohrCoulomb::effective_tension_cutoff(const PointState& state) const {
  const double c = cohesion.value(state.plastic_strain);
  if (friction_angle_deg <= 0.0) return tension_cutoff;
  const double phi = friction_angle_deg * kRadiansPerDegree;
  return std::min(tension_cutoff, c * std::cos(phi) / std::sin(phi));
}

double MohrCoulomb::yield_function(const Stress& stress, const PointState& state) const {
  const PrincipalStress p = principal_stress(stress);
  const double phi = friction_angle_deg * kRadiansPerDegree;
  const double s1 = p.values[0], s3 = p.values[2];
  return (s1 - s3) + (s1 + s3) * std::sin(phi) -
         2.0 * cohesion.value(state.plastic_strain) * std::cos(phi);
}

double MohrCoulomb::tension_function(const Stress& stress, const PointState& state) const {
  return principal_stress(stress).values[0] - effective_tension_cutoff(state);
}

MaterialConstants MohrCoulomb::constants() const {
  MaterialConstants k = hooke_constants(elastic);
  const double phi = friction_angle_deg * kRadiansPerDegree;
  k.sin_phi = std::sin(phi);
  k.cos_phi = std::cos(phi);
  k.sin_psi = std::sin(dilation_angle_deg * kRadiansPerDegree);
  return k;
}

namespace {

/// MohrCoulomb::update_with_info with the constants given.
/// With `tangent`, also the consistent tangent there.
inline ReturnInfo mohr_coulomb_update(const MohrCoulomb& m, const MaterialConstants& k,
                                      const Strain& strain_increment, Stress& stress,
                                      PointState& state, Tangent* tangent = nullptr) {
  stress += elastic_stress_increment(k, strain_increment);  // elastic trial
  PrincipalStress p = principal_values(stress);
  const double eps_n = state.plastic_strain;
  const double sin_phi = k.sin_phi, cos_phi = k.cos_phi;
  const double s1 = p.values[0], s3 = p.values[2];
  const double shear =
      (1.0 + sin_phi) * s1 - (1.0 - sin_phi) * s3 - 2.0 * cos_phi * m.cohesion.value(eps_n);
  // Inside the cone s1 <= c cot(phi), so s1 <= sigma_t is the whole cut-off check here.
  if (shear <= 0.0 && s1 <= m.tension_cutoff) {
    if (tangent != nullptr) *tangent = elastic_tangent(k);
    return ReturnInfo{};
  }
  principal_directions(stress, p);

  const PlaneModel model{sin_phi, cos_phi, k.sin_psi, m.tension_cutoff, k.lambda, 2.0 * k.mu};
  double ordered[3];
  const int n_sets =
      (model.tension_cutoff < kInfinity || sin_phi > 0.0) ? kAllSets : kShearOnlySets;
  const ReturnInfo info = principal_return(model, m.cohesion, n_sets, eps_n, p.values, ordered);
  if (tangent != nullptr) {
    double jacobian[3][3];
    principal_jacobian(model, m.cohesion, eps_n, info, jacobian);
    *tangent = spectral_tangent(k, p, ordered, jacobian);
  }
  assemble_stress(p, ordered, stress);
  state.plastic_strain = eps_n + info.plastic_strain_increment;
  return info;
}

}  // namespace

ReturnInfo MohrCoulomb::update_with_info(const Strain& strain_increment, Stress& stress,
                                         PointState& state) const {
  return mohr_coulomb_update(*this, constants(), strain_increment, stress, state);
}

ReturnInfo MohrCoulomb::update_with_tangent(const Strain& strain_increment, Stress& stress,
                                            PointState& state, Tangent& tangent) const {
  return mohr_coulomb_update(*this, constants(), strain_increment, stress, state, &tangent);
}

void MohrCoulomb::update(const Strain& strain_increment, Stress& stress, PointState& state) const {
  mohr_coulomb_update(*this, constants(), strain_increment, stress, state);
}

void MohrCoulomb::update(const Strain& strain_increment, Stress& stress, PointState& state,
                         const MaterialConstants& constants) const {
  mohr_coulomb_update(*this, constants, strain_increment, stress, state);
}

ReturnInfo update_with_tangent(const Material& material, const MaterialConstants& constants,
                               const Strain& strain_increment, Stress& stress, PointState& state,
                               Tangent& tangent) {
  if (const auto* tresca = std::get_if<Tresca>(&material)) {
    return tresca_update(*tresca, constants, strain_increment, stress, state, &tangent);
  }
  if (const auto* mc = std::get_if<MohrCoulomb>(&material)) {
    return mohr_coulomb_update(*mc, constants, strain_increment, stress, state, &tangent);
  }
  stress += elastic_stress_increment(constants, strain_increment);
  tangent = elastic_tangent(constants);
  return ReturnInfo{};
}

}  // namespace pfm
