// Constitutive models: Hooke's law by hand, Tresca and Mohr-Coulomb returns checked against the
// Kuhn-Tucker conditions computed independently here (Eigen eigen-decomposition of the trial
// stress), analytic simple-shear curves across peak and residual, step-size independence, the
// phi = 0 limit, the tension cut-off and the apex; the consistent tangents against central
// differences of the updates.
//
// Material used throughout: E = 1e4 kPa, nu = 0.25, so lambda = mu = 4000 kPa.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <string>
#include <variant>
#include <vector>

#include "mpm/core/materials.hpp"

namespace pfm {
namespace {

using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;

constexpr double kLambda = 4000.0;  // E nu / ((1 + nu)(1 - 2 nu)) = 2500 / 0.625
constexpr double kMu = 4000.0;      // E / (2 (1 + nu)) = 1e4 / 2.5
constexpr double kInf = std::numeric_limits<double>::infinity();

ElasticParameters soil_elastic() {
  return ElasticParameters{1e4, 0.25};
}

/// Thesis-like softening: initial 20, then 10, residual 5 kPa (Tables 5.1, 6.2).
PiecewiseLinear thesis_cohesion() {
  return PiecewiseLinear{{0.0, 0.01, 0.03}, {20.0, 10.0, 5.0}};
}

/// Hardening, plateau, then a drop steeper than the elastic shear stiffness (snap-back at the
/// material level: 1 + v H < 0 in the segment solve).
PiecewiseLinear hardening_then_snap_cohesion() {
  return PiecewiseLinear{{0.0, 0.005, 0.02, 0.021, 0.05}, {10.0, 20.0, 20.0, 8.0, 5.0}};
}

Mat3 tensor(const Stress& s) {
  Mat3 t;
  t << s[kXX], s[kXY], 0.0, s[kXY], s[kYY], 0.0, 0.0, 0.0, s[kZZ];
  return t;
}

/// D : n for a symmetric tensor n.
Mat3 stiffness_times(const Mat3& n) {
  return kLambda * n.trace() * Mat3::Identity() + 2.0 * kMu * n;
}

/// Ordered principal frame of the trial stress: e[0] major, e[2] minor (independent of the code).
struct Frame {
  Vec3 values;  // s1 >= s2 >= s3
  std::array<Vec3, 3> e;
};

Frame principal_frame(const Stress& s) {
  Eigen::SelfAdjointEigenSolver<Mat3> solver(tensor(s));
  Frame f;
  for (int k = 0; k < 3; ++k) {
    f.values[k] = solver.eigenvalues()[2 - k];
    f.e[k] = solver.eigenvectors().col(2 - k);
  }
  return f;
}

struct PlaneConstants {
  double sin_phi = 0.0, cos_phi = 1.0, sin_psi = 0.0, cutoff = kInf;
  /// sigma_t,eff(c) = min(sigma_t, c cot phi) (the model's definition, materials.cpp).
  double tension(double c) const {
    return sin_phi > 0.0 ? std::min(cutoff, c * cos_phi / sin_phi) : cutoff;
  }
};

/// Yield function and flow tensor of one plane in the trial frame `f`, in Mohr-Coulomb form
/// (F = 2 f_Tresca for phi = 0).
double plane_value(const PlaneConstants& m, YieldPlane id, const Frame& f, const Stress& s,
                   double c) {
  auto component = [&](int i) { return f.e[i].dot(tensor(s) * f.e[i]); };
  switch (id) {
    case YieldPlane::kShear13:
      return (1 + m.sin_phi) * component(0) - (1 - m.sin_phi) * component(2) - 2 * m.cos_phi * c;
    case YieldPlane::kShear23:
      return (1 + m.sin_phi) * component(1) - (1 - m.sin_phi) * component(2) - 2 * m.cos_phi * c;
    case YieldPlane::kShear12:
      return (1 + m.sin_phi) * component(0) - (1 - m.sin_phi) * component(1) - 2 * m.cos_phi * c;
    case YieldPlane::kTension1:
      return component(0) - m.tension(c);
    case YieldPlane::kTension2:
      return component(1) - m.tension(c);
    case YieldPlane::kTension3:
      return component(2) - m.tension(c);
  }
  return 0.0;
}

Mat3 plane_flow(const PlaneConstants& m, YieldPlane id, const Frame& f) {
  auto dyad = [&](int i) -> Mat3 { return f.e[i] * f.e[i].transpose(); };
  switch (id) {
    case YieldPlane::kShear13:
      return (1 + m.sin_psi) * dyad(0) - (1 - m.sin_psi) * dyad(2);
    case YieldPlane::kShear23:
      return (1 + m.sin_psi) * dyad(1) - (1 - m.sin_psi) * dyad(2);
    case YieldPlane::kShear12:
      return (1 + m.sin_psi) * dyad(0) - (1 - m.sin_psi) * dyad(1);
    case YieldPlane::kTension1:
      return dyad(0);
    case YieldPlane::kTension2:
      return dyad(1);
    case YieldPlane::kTension3:
      return dyad(2);
  }
  return Mat3::Zero();
}

bool is_shear(YieldPlane id) {
  return static_cast<int>(id) <= static_cast<int>(YieldPlane::kShear12);
}

std::string set_name(const ReturnInfo& info) {
  static const char* names[] = {"F13", "F23", "F12", "T1", "T2", "T3"};
  std::string s;
  for (int l = 0; l < info.n_active; ++l) {
    s += (l ? "+" : "");
    s += names[static_cast<int>(info.planes[l])];
  }
  return s.empty() ? "elastic" : s;
}

/// Figures gathered by a random test.
struct KuhnTuckerFigures {
  double max_active_residual = 0.0;  // max |f_j| / c over the active planes
  double max_yield_value = -kInf;    // max over all planes of f / c (must be <= ~0)
  double max_flow_mismatch = 0.0;    // |dsigma - sum dgamma D n| / |dsigma|
  double min_multiplier = kInf;      // relative to the largest of the same return
  double max_strain_mismatch = 0.0;  // |d eps_p - sum kappa dgamma|
  int n_plastic = 0;
  int n_inadmissible = 0;
  std::map<std::string, int> counts;
};

/// Checks one plastic return of a Mohr-Coulomb-form model against the Kuhn-Tucker conditions,
/// evaluated here in the trial frame. `multiplier_scale` converts the reported multipliers to
/// the Mohr-Coulomb form (1/2 for Tresca).
void check_return(const PlaneConstants& m, const PiecewiseLinear& law, const Stress& trial,
                  const Stress& result, double eps_before, double eps_after, const ReturnInfo& info,
                  double multiplier_scale, KuhnTuckerFigures& fig) {
  ++fig.counts[set_name(info)];
  if (info.n_active == 0) return;
  ++fig.n_plastic;
  if (!info.admissible) ++fig.n_inadmissible;
  const Frame frame = principal_frame(trial);
  const double c = law.value(eps_after);
  const double normal = is_shear(info.planes[0]) ? 2.0 * m.cos_phi : 1.0;
  Mat3 expected_correction = Mat3::Zero();
  double largest = 0.0, smallest = 0.0, shear_sum = 0.0;
  for (int l = 0; l < info.n_active; ++l) {
    const double gamma = info.multipliers[l] * multiplier_scale;
    const double scale = is_shear(info.planes[l]) ? 2.0 * m.cos_phi : 1.0;
    fig.max_active_residual =
        std::max(fig.max_active_residual,
                 std::abs(plane_value(m, info.planes[l], frame, result, c)) / (scale * c));
    expected_correction += gamma * stiffness_times(plane_flow(m, info.planes[l], frame));
    largest = std::max(largest, std::abs(gamma));
    smallest = std::min(smallest, gamma);
    if (is_shear(info.planes[l])) shear_sum += 2.0 * gamma;
  }
  (void)normal;
  fig.min_multiplier = std::min(fig.min_multiplier, smallest / largest);
  // All six planes, in the frame of the result itself (the order may differ from the trial's).
  const Frame result_frame = principal_frame(result);
  for (int p = 0; p < 6; ++p) {
    const auto id = static_cast<YieldPlane>(p);
    if (id == YieldPlane::kTension1 && m.tension(c) == kInf) break;
    const double scale = is_shear(id) ? 2.0 * m.cos_phi : 1.0;
    fig.max_yield_value =
        std::max(fig.max_yield_value, plane_value(m, id, result_frame, result, c) / (scale * c));
  }
  const Mat3 correction = tensor(trial) - tensor(result);
  fig.max_flow_mismatch = std::max(fig.max_flow_mismatch,
                                   (correction - expected_correction).norm() / correction.norm());
  fig.max_strain_mismatch =
      std::max(fig.max_strain_mismatch, std::abs((eps_after - eps_before) - shear_sum));
}

/// A random admissible stress for a Mohr-Coulomb-form surface: mean stress p and a deviator
/// scaled into the surface and below the cut-off.
Stress random_admissible_stress(std::mt19937_64& rng, const PlaneConstants& m, double c) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double top = std::min(m.tension(c), 20.0);
  const double p = top - (top + 60.0) * 0.5 * (1.0 + unit(rng));  // in (-60, top)
  Stress dev(unit(rng), unit(rng), unit(rng), unit(rng));
  const double mean = (dev[kXX] + dev[kYY] + dev[kZZ]) / 3.0;
  dev[kXX] -= mean, dev[kYY] -= mean, dev[kZZ] -= mean;
  const Frame f = principal_frame(dev);
  // F(p + a d) = a ((d1 - d3) + (d1 + d3) sin phi) + 2 p sin phi - 2 c cos phi <= 0
  const double slope = (f.values[0] - f.values[2]) + (f.values[0] + f.values[2]) * m.sin_phi;
  const double room = 2.0 * c * m.cos_phi - 2.0 * p * m.sin_phi;
  double a = 0.999 * room / slope * 0.5 * (1.0 + unit(rng));
  if (m.tension(c) < kInf && f.values[0] > 0.0) {
    a = std::min(a, 0.999 * (m.tension(c) - p) / f.values[0]);
  }
  return Stress(p + a * dev[kXX], p + a * dev[kYY], a * dev[kXY], p + a * dev[kZZ]);
}

Strain random_strain_increment(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double size = std::pow(10.0, -4.0 + 2.5 * 0.5 * (1.0 + unit(rng)));  // 1e-4 .. 3e-2
  return Strain(size * unit(rng), size * unit(rng), size * unit(rng), 0.0);
}

// -------------------------------------------------------------------------------------------

TEST(Materials, ElasticIncrementByHand) {
  // lambda = mu = 4000 kPa. d = (1e-3, -2e-3, gamma 3e-3, 0), volumetric -1e-3:
  //   dsxx = 4000 (-1e-3) + 8000 (1e-3)  =   4
  //   dsyy = 4000 (-1e-3) + 8000 (-2e-3) = -20
  //   dsxy = 4000 (3e-3)                 =  12
  //   dszz = 4000 (-1e-3)                =  -4
  const ElasticParameters e = soil_elastic();
  EXPECT_NEAR(e.lame_lambda(), 4000.0, 1e-9);
  EXPECT_NEAR(e.shear_modulus(), 4000.0, 1e-9);
  const Strain d(1e-3, -2e-3, 3e-3, 0.0);
  const Stress expected(4.0, -20.0, 12.0, -4.0);
  Stress s = Stress::Zero();
  PointState state;
  LinearElastic{e}.update(d, s, state);
  EXPECT_LT((s - expected).cwiseAbs().maxCoeff(), 1e-12);
  // Inside the Tresca surface ((s1 - s3)/2 = sqrt(12^2 + 12^2) = 16.97 < 20) the plastic models
  // give the same increment and leave eps_p alone.
  Stress s_tresca = Stress::Zero();
  const ReturnInfo info = Tresca{e, thesis_cohesion()}.update_with_info(d, s_tresca, state);
  EXPECT_EQ(info.n_active, 0);
  EXPECT_LT((s_tresca - expected).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(state.plastic_strain, 0.0);
}

void run_tresca_random(const PiecewiseLinear& law, std::uint64_t seed, const char* label) {
  const Tresca tresca{soil_elastic(), law};
  const PlaneConstants m{};  // phi = psi = 0, no cut-off
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> eps_dist(0.0, 0.06);
  KuhnTuckerFigures fig;
  double max_softening_mismatch = 0.0;
  for (int k = 0; k < 20000; ++k) {
    PointState state{eps_dist(rng)};
    Stress s = random_admissible_stress(rng, m, law.value(state.plastic_strain));
    const Strain d = random_strain_increment(rng);
    const Stress trial = s + elastic_stress_increment(soil_elastic(), d);
    const double eps_before = state.plastic_strain;
    const ReturnInfo info = tresca.update_with_info(d, s, state);
    check_return(m, law, trial, s, eps_before, state.plastic_strain, info, 0.5, fig);
    if (info.n_active > 0) {
      const double f = tresca.yield_function(s, state);
      max_softening_mismatch =
          std::max(max_softening_mismatch, std::abs(f) / law.value(state.plastic_strain));
    }
  }
  std::printf(
      "[%s] plastic %d of 20000; max |f|/c active %.2e, max f/c %.2e, flow %.2e, "
      "min multiplier %.2e, eps_p %.2e, |f_Tresca|/c %.2e\n",
      label, fig.n_plastic, fig.max_active_residual, fig.max_yield_value, fig.max_flow_mismatch,
      fig.min_multiplier, fig.max_strain_mismatch, max_softening_mismatch);
  for (const auto& [name, count] : fig.counts) std::printf("    %-12s %d\n", name.c_str(), count);
  EXPECT_EQ(fig.n_inadmissible, 0);
  EXPECT_LE(fig.max_active_residual, 1e-10);
  EXPECT_LE(fig.max_yield_value, 1e-10);
  EXPECT_LE(max_softening_mismatch, 1e-10);
  EXPECT_LE(fig.max_flow_mismatch, 1e-9);
  EXPECT_GE(fig.min_multiplier, -1e-10);
  EXPECT_LE(fig.max_strain_mismatch, 1e-14);
  EXPECT_GE(fig.counts["F13"], 1000);
  EXPECT_GE(fig.counts["F13+F23"], 100);  // right edge s1 = s2
  EXPECT_GE(fig.counts["F13+F12"], 100);  // left edge s2 = s3
}

TEST(Materials, TrescaRandomReturnsSatisfyKuhnTucker) {
  run_tresca_random(thesis_cohesion(), 12345, "Tresca thesis softening");
}

TEST(Materials, TrescaRandomReturnsWithHardeningAndSnapBack) {
  run_tresca_random(hardening_then_snap_cohesion(), 777, "Tresca hardening + snap-back");
}

void run_mohr_coulomb_random(double phi_deg, double psi_deg, double cutoff, std::uint64_t seed,
                             const char* label, const std::vector<std::string>& must_hit,
                             int min_hits) {
  const MohrCoulomb mc{soil_elastic(), thesis_cohesion(), phi_deg, psi_deg, cutoff};
  const double phi = phi_deg * std::numbers::pi / 180.0;
  const PlaneConstants m{std::sin(phi), std::cos(phi), std::sin(psi_deg * std::numbers::pi / 180.0),
                         cutoff};
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> eps_dist(0.0, 0.06);
  KuhnTuckerFigures fig;
  for (int k = 0; k < 20000; ++k) {
    PointState state{eps_dist(rng)};
    Stress s = random_admissible_stress(rng, m, mc.cohesion.value(state.plastic_strain));
    const Strain d = random_strain_increment(rng);
    const Stress trial = s + elastic_stress_increment(soil_elastic(), d);
    const double eps_before = state.plastic_strain;
    const ReturnInfo info = mc.update_with_info(d, s, state);
    check_return(m, mc.cohesion, trial, s, eps_before, state.plastic_strain, info, 1.0, fig);
  }
  std::printf(
      "[%s] plastic %d of 20000; max |f|/c active %.2e, max f/c "
      "%.2e, flow %.2e, min multiplier %.2e, eps_p %.2e, inadmissible %d\n",
      label, fig.n_plastic, fig.max_active_residual, fig.max_yield_value, fig.max_flow_mismatch,
      fig.min_multiplier, fig.max_strain_mismatch, fig.n_inadmissible);
  for (const auto& [name, count] : fig.counts) std::printf("    %-12s %d\n", name.c_str(), count);
  EXPECT_EQ(fig.n_inadmissible, 0);
  EXPECT_LE(fig.max_active_residual, 1e-10);
  EXPECT_LE(fig.max_yield_value, 1e-10);
  EXPECT_LE(fig.max_flow_mismatch, 1e-9);
  EXPECT_GE(fig.min_multiplier, -1e-10);
  EXPECT_LE(fig.max_strain_mismatch, 1e-14);
  for (const auto& name : must_hit) EXPECT_GE(fig.counts[name], min_hits) << name;
}

TEST(Materials, MohrCoulombRandomReturnsSatisfyKuhnTucker) {
  run_mohr_coulomb_random(
      30.0, 10.0, 3.0, 2024, "MC phi 30 psi 10 cut-off 3",
      {"F13", "F13+F23", "F13+F12", "T1", "F13+T1", "T1+T2", "T1+T2+T3", "F13+F12+T1", "F13+T1+T2"},
      100);
}

TEST(Materials, MohrCoulombRandomReturnsAssociatedWithApexCutoff) {
  // Cut-off at the apex of the residual cone (README default is the initial apex; it is capped).
  run_mohr_coulomb_random(25.0, 25.0, 1e9, 99, "MC phi 25 psi 25 cut-off at apex",
                          {"F13", "F13+F23", "F13+F12", "F13+F12+T1", "F13+T1+T2", "T1+T2+T3"}, 5);
}

TEST(Materials, MohrCoulombRandomReturnsWithoutDilationApexCutoff) {
  // psi = 0: no volume change on the shear planes; the apex is reached through the cut-off.
  run_mohr_coulomb_random(35.0, 0.0, 1e9, 4242, "MC phi 35 psi 0 cut-off at apex",
                          {"F13", "F13+F23", "F13+F12", "F13+F12+T1", "F13+T1+T2"}, 5);
}

/// Plastic shear strain g_p at total engineering shear strain g under simple shear from zero
/// stress: mu (g - g_p) = k c(g_p) (k = 1 Tresca, cos phi MC with psi = 0), by bisection
/// (independent of the segment solver; needs mu + k dc/dg_p > 0, true for the thesis law).
double simple_shear_plastic_strain(const PiecewiseLinear& law, double k, double g) {
  if (kMu * g <= k * law.value(0.0)) return 0.0;
  double lo = 0.0, hi = g;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (kMu * (g - mid) - k * law.value(mid) > 0.0)
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

TEST(Materials, TrescaSimpleShearFollowsSofteningAtAnyStepSize) {
  // Simple shear from zero stress: s = (0, 0, tau, 0), principal pair +-tau at 45 degrees,
  // s2 = szz = 0. On the surface tau = c(eps_p) with eps_p = gamma_xy^p (the definition), and
  // tau = mu (gamma - gamma^p). The step crosses the breakpoints 0.01 and 0.03 of eps_p.
  const PiecewiseLinear law = thesis_cohesion();
  const Tresca tresca{soil_elastic(), law};
  const double gamma_end = 0.06;
  double final_tau[3] = {};
  const int steps[3] = {7, 60, 6000};
  double max_error = 0.0, max_normal = 0.0, max_eps_error = 0.0;
  for (int run = 0; run < 3; ++run) {
    Stress s = Stress::Zero();
    PointState state;
    for (int k = 1; k <= steps[run]; ++k) {
      tresca.update(Strain(0.0, 0.0, gamma_end / steps[run], 0.0), s, state);
      const double gamma = gamma_end * k / steps[run];
      const double gp = simple_shear_plastic_strain(law, 1.0, gamma);
      max_error = std::max(max_error, std::abs(s[kXY] - kMu * (gamma - gp)));
      max_eps_error = std::max(max_eps_error, std::abs(state.plastic_strain - gp));
      max_normal = std::max({max_normal, std::abs(s[kXX]), std::abs(s[kYY]), std::abs(s[kZZ])});
    }
    final_tau[run] = s[kXY];
    // Unloading is elastic with slope mu.
    tresca.update(Strain(0.0, 0.0, -0.001, 0.0), s, state);
    EXPECT_NEAR(s[kXY], final_tau[run] - kMu * 0.001, 1e-9);
  }
  std::printf(
      "simple shear Tresca: max |tau - analytic| %.2e kPa, max |eps_p - analytic| %.2e, "
      "max |normal stress| %.2e, tau(0.06) = %.12f / %.12f / %.12f\n",
      max_error, max_eps_error, max_normal, final_tau[0], final_tau[1], final_tau[2]);
  EXPECT_LE(max_error, 1e-9);  // kPa (bisection to 1e-15 in g_p times mu)
  EXPECT_LE(max_eps_error, 1e-12);
  EXPECT_LE(max_normal, 1e-10);
  EXPECT_NEAR(final_tau[0], 5.0, 1e-10);  // residual reached: gamma^p = 0.06 - 5/4000 > 0.03
  EXPECT_NEAR(final_tau[0], final_tau[2], 1e-10);
  EXPECT_NEAR(final_tau[1], final_tau[2], 1e-10);
}

TEST(Materials, MohrCoulombSimpleShearFollowsSoftening) {
  // psi = 0: the flow (1, 0, -1) has no volume change, the stress stays pure shear and
  // F = 2 tau - 2 c cos(phi): tau = cos(phi) c(eps_p), eps_p = gamma_xy^p.
  const PiecewiseLinear law = thesis_cohesion();
  const double phi_deg = 30.0;
  const MohrCoulomb mc{soil_elastic(), law, phi_deg, 0.0, 1e9};
  const double k = std::cos(phi_deg * std::numbers::pi / 180.0);
  double max_error = 0.0;
  for (int n : {9, 900}) {
    Stress s = Stress::Zero();
    PointState state;
    for (int i = 1; i <= n; ++i) {
      mc.update(Strain(0.0, 0.0, 0.06 / n, 0.0), s, state);
      const double gamma = 0.06 * i / n;
      const double gp = simple_shear_plastic_strain(law, k, gamma);
      max_error = std::max(max_error, std::abs(s[kXY] - kMu * (gamma - gp)));
      max_error = std::max(max_error, std::abs(state.plastic_strain - gp) * kMu);
    }
  }
  std::printf("simple shear MC phi 30 psi 0: max |tau - analytic| %.2e kPa\n", max_error);
  EXPECT_LE(max_error, 1e-9);
}

TEST(Materials, MohrCoulombDilatantSimpleShearIsStepSizeIndependent) {
  // psi > 0: the mean stress changes, no closed form used; the principal axes stay fixed, so
  // the backward-Euler return integrates the path exactly and coarse and fine steps agree.
  const MohrCoulomb mc{soil_elastic(), thesis_cohesion(), 30.0, 10.0, 1e9};
  Stress coarse = Stress::Zero(), fine = Stress::Zero();
  PointState coarse_state, fine_state;
  for (int i = 0; i < 6; ++i) mc.update(Strain(0.0, 0.0, 0.01, 0.0), coarse, coarse_state);
  for (int i = 0; i < 6000; ++i) mc.update(Strain(0.0, 0.0, 1e-5, 0.0), fine, fine_state);
  const double difference = (coarse - fine).cwiseAbs().maxCoeff();
  std::printf("dilatant simple shear: coarse vs fine max |dsigma| %.2e kPa, eps_p %.6f / %.6f\n",
              difference, coarse_state.plastic_strain, fine_state.plastic_strain);
  EXPECT_LE(difference, 1e-8);
  EXPECT_NEAR(coarse_state.plastic_strain, fine_state.plastic_strain, 1e-12);
  EXPECT_NEAR(mc.yield_function(coarse, coarse_state), 0.0, 1e-10 * 5.0);
}

TEST(Materials, TrescaSofteningFollowedAlongRandomPath) {
  // A random strain path: at every plastic step (s1 - s3)/2 = c(eps_p) and eps_p never drops.
  const PiecewiseLinear law = thesis_cohesion();
  const Tresca tresca{soil_elastic(), law};
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Stress s = Stress::Zero();
  PointState state;
  double max_mismatch = 0.0, previous_eps = 0.0;
  int n_plastic = 0;
  for (int k = 0; k < 2000; ++k) {
    const Strain d(2e-3 * unit(rng), 2e-3 * unit(rng) - 5e-4, 3e-3 * unit(rng) + 1e-3, 0.0);
    const ReturnInfo info = tresca.update_with_info(d, s, state);
    EXPECT_GE(state.plastic_strain, previous_eps);
    previous_eps = state.plastic_strain;
    if (info.n_active == 0) continue;
    ++n_plastic;
    const Frame f = principal_frame(s);
    max_mismatch = std::max(max_mismatch, std::abs(0.5 * (f.values[0] - f.values[2]) -
                                                   law.value(state.plastic_strain)) /
                                              law.value(state.plastic_strain));
  }
  std::printf("random path: %d plastic steps, final eps_p %.4f, max |(s1-s3)/2 - c|/c %.2e\n",
              n_plastic, state.plastic_strain, max_mismatch);
  EXPECT_GT(state.plastic_strain, 0.03);  // went through peak to residual
  EXPECT_LE(max_mismatch, 1e-10);
}

TEST(Materials, MohrCoulombWithZeroFrictionIsTresca) {
  const PiecewiseLinear law = thesis_cohesion();
  const Tresca tresca{soil_elastic(), law};
  const MohrCoulomb mc{soil_elastic(), law, 0.0, 0.0, kInf};
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> eps_dist(0.0, 0.06);
  double max_stress_difference = 0.0, max_eps_difference = 0.0, max_yield_difference = 0.0;
  int n_plastic = 0;
  for (int k = 0; k < 20000; ++k) {
    PointState a{eps_dist(rng)};
    PointState b = a;
    Stress sa = random_admissible_stress(rng, PlaneConstants{}, law.value(a.plastic_strain));
    Stress sb = sa;
    const Strain d = random_strain_increment(rng);
    n_plastic += tresca.update_with_info(d, sa, a).n_active > 0;
    mc.update(d, sb, b);
    max_stress_difference = std::max(max_stress_difference, (sa - sb).cwiseAbs().maxCoeff());
    max_eps_difference =
        std::max(max_eps_difference, std::abs(a.plastic_strain - b.plastic_strain));
    max_yield_difference =
        std::max(max_yield_difference,
                 std::abs(mc.yield_function(sb, b) - 2.0 * tresca.yield_function(sa, a)));
  }
  std::printf("phi = 0: %d plastic; max |s_MC - s_Tresca| %.2e kPa, eps_p %.2e, |F - 2f| %.2e\n",
              n_plastic, max_stress_difference, max_eps_difference, max_yield_difference);
  EXPECT_GT(n_plastic, 5000);
  EXPECT_LE(max_stress_difference, 1e-12 * 100.0);  // stresses up to ~100 kPa
  EXPECT_LE(max_eps_difference, 1e-15);
  EXPECT_LE(max_yield_difference, 1e-12 * 100.0);
}

TEST(Materials, MohrCoulombConfinementIncreasesStrength) {
  // Tension positive: with s1 = s2 = -p (confinement) the failure value of s3 from F = 0 is
  // s3 = ((1 + sin phi)(-p) - 2 c cos phi) / (1 - sin phi) = -3 p - 40 sqrt(3) (phi 30, c 20):
  // the deviator at failure grows by 2 p sin(phi) / (1 - sin(phi)) = 2 p.
  const MohrCoulomb mc{soil_elastic(), thesis_cohesion(), 30.0, 10.0, 1e9};
  const PointState intact;
  for (double p : {0.0, 10.0, 100.0}) {
    const double s3 = -3.0 * p - 40.0 * std::sqrt(3.0);
    EXPECT_NEAR(mc.yield_function(Stress(-p, s3, 0.0, -p), intact), 0.0, 1e-12);
    EXPECT_GT(mc.yield_function(Stress(-p, s3 - 0.01, 0.0, -p), intact), 0.0);
    EXPECT_LT(mc.yield_function(Stress(-p, s3 + 0.01, 0.0, -p), intact), 0.0);
  }
  // The same through update(): an isochoric in-plane shear (dxx = -dyy = 0.01) from
  // (-p, -p, 0, -p) gives the trial deviator 160 kPa, beyond the failure deviator
  // 2 q_f = p + 40 sqrt(3) - (softening); the returned deviator grows with p.
  double deviator[2];
  for (int k = 0; k < 2; ++k) {
    const double p = k == 0 ? 10.0 : 100.0;
    Stress s(-p, -p, 0.0, -p);
    PointState state;
    mc.update(Strain(0.01, -0.01, 0.0, 0.0), s, state);
    const Frame f = principal_frame(s);
    deviator[k] = f.values[0] - f.values[2];
    EXPECT_NEAR(mc.yield_function(s, state), 0.0, 1e-10 * 20.0);
  }
  std::printf("confinement: deviator at failure %.4f (p 10) < %.4f (p 100) kPa\n", deviator[0],
              deviator[1]);
  EXPECT_GT(deviator[1], deviator[0] + 50.0);
}

TEST(Materials, MohrCoulombTensionCutoffRespected) {
  // Plane-strain extension along x from zero stress (phi 30, psi 10, c = 20, cut-off 4 kPa):
  // s1 = sxx reaches the cut-off, stays there, and the cut-off does not soften c.
  const MohrCoulomb mc{soil_elastic(), thesis_cohesion(), 30.0, 10.0, 4.0};
  Stress s = Stress::Zero();
  PointState state;
  double max_excess = -kInf;
  int n_on_cutoff = 0;
  for (int k = 0; k < 400; ++k) {
    const ReturnInfo info = mc.update_with_info(Strain(1e-5, 0.0, 0.0, 0.0), s, state);
    max_excess = std::max(max_excess, mc.tension_function(s, state));
    if (info.n_active > 0) {
      ++n_on_cutoff;
      EXPECT_NEAR(s[kXX], 4.0, 1e-12);
    }
  }
  std::printf(
      "tension cut-off: %d steps on the cut-off, max (s1 - sigma_t) %.2e kPa, sxx %.6f, "
      "syy %.6f\n",
      n_on_cutoff, max_excess, s[kXX], s[kYY]);
  EXPECT_GT(n_on_cutoff, 300);
  EXPECT_LE(max_excess, 1e-12);
  EXPECT_EQ(state.plastic_strain, 0.0);
  // Rankine flow D e1 = (lambda + 2 mu, lambda, lambda) t takes back exactly the elastic syy
  // increment lambda dxx of each plastic step, so syy keeps its value at first yield:
  // syy = lambda / (lambda + 2 mu) * 4 = 4/3 kPa.
  EXPECT_NEAR(s[kYY], 4.0 / 3.0, 1e-10);
}

TEST(Materials, MohrCoulombApexReturnsOfHydrostaticTension) {
  PointState state;
  // (a) cut-off below the cone apex: the hydrostatic trial goes to the tension apex.
  const MohrCoulomb low{soil_elastic(), thesis_cohesion(), 30.0, 10.0, 3.0};
  Stress s(30.0, 30.0, 0.0, 30.0);
  ReturnInfo info = low.update_with_info(Strain::Zero(), s, state);
  EXPECT_EQ(set_name(info), "T1+T2+T3");
  EXPECT_LT((s - Stress(3.0, 3.0, 0.0, 3.0)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(state.plastic_strain, 0.0);
  // (b) cut-off requested above the apex: capped at the residual apex c_r / tan(phi) = 5 sqrt(3).
  // At residual cohesion the result is the cone apex itself: F = 0 there.
  const MohrCoulomb high{soil_elastic(), thesis_cohesion(), 30.0, 30.0, 1e9};
  const double apex = 5.0 * std::sqrt(3.0);
  PointState residual{0.05};
  EXPECT_NEAR(high.effective_tension_cutoff(residual), apex, 1e-12);
  Stress t(100.0, 100.0, 0.0, 100.0);
  info = high.update_with_info(Strain::Zero(), t, residual);
  std::printf("apex: set %s, stress (%.12f %.12f %.2e %.12f), F/c %.2e\n", set_name(info).c_str(),
              t[kXX], t[kYY], t[kXY], t[kZZ], high.yield_function(t, residual) / 5.0);
  EXPECT_LT((t - Stress(apex, apex, 0.0, apex)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE(std::abs(high.yield_function(t, residual)) / 5.0, 1e-12);
  EXPECT_TRUE(info.admissible);
}

TEST(Materials, PiecewiseSegmentsLandExactlyAcrossBreakpoints) {
  // One huge simple-shear step from the initial state to far beyond residual: the root is in
  // the last (constant) segment, reached by walking through both breakpoints.
  const Tresca tresca{soil_elastic(), thesis_cohesion()};
  Stress s = Stress::Zero();
  PointState state;
  const ReturnInfo info = tresca.update_with_info(Strain(0.0, 0.0, 0.5, 0.0), s, state);
  EXPECT_EQ(info.n_active, 1);
  EXPECT_NEAR(s[kXY], 5.0, 1e-12);
  EXPECT_NEAR(state.plastic_strain, 0.5 - 5.0 / kMu, 1e-15);
  // A step ending just after the first breakpoint: gamma^p = 0.0100001 on slope -250.
  Stress s2 = Stress::Zero();
  PointState state2;
  const double gp = 0.0100001, tau = 10.0 - 250.0 * (gp - 0.01);
  tresca.update(Strain(0.0, 0.0, gp + tau / kMu, 0.0), s2, state2);
  EXPECT_NEAR(state2.plastic_strain, gp, 1e-15);
  EXPECT_NEAR(s2[kXY], tau, 1e-11);
}

// -------------------------------------------------------------------------------------------
// Consistent tangents: update_with_tangent() against central differences of update().

/// The segment of the piecewise-linear law that holds eps (its slope's interval).
std::size_t law_segment(const PiecewiseLinear& law, double eps) {
  return static_cast<std::size_t>(std::upper_bound(law.x.begin(), law.x.end(), eps) -
                                  law.x.begin());
}

struct TangentFigures {
  double worst = 0.0;  // max |tangent - difference quotient| / max |Hooke|
  int compared = 0;
  int skipped = 0;  // a difference that changes the active set or the law's segment
  std::map<std::string, int> counts;
};

/// Random returns of `material` (admissible start stress for the surface `m`, random state and
/// increment), each tangent compared with the central difference quotient of the update with a
/// strain step `delta` in each of the four strain entries.
template <class Model>
TangentFigures tangents_against_differences(const Model& model, const PlaneConstants& m,
                                            std::uint64_t seed, int samples) {
  const double hooke = elastic_tangent(model.constants()).cwiseAbs().maxCoeff();
  const double delta = 1e-8;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> eps_dist(0.0, 0.06);
  TangentFigures fig;
  for (int k = 0; k < samples; ++k) {
    const PointState start{eps_dist(rng)};
    const Stress s0 = random_admissible_stress(rng, m, model.cohesion.value(start.plastic_strain));
    const Strain d = random_strain_increment(rng);
    Stress s = s0;
    PointState state = start;
    Tangent tangent;
    const ReturnInfo info = model.update_with_tangent(d, s, state, tangent);
    const std::string set = set_name(info);
    const std::size_t segment = law_segment(model.cohesion, state.plastic_strain);
    Tangent differences;
    bool same = true;
    for (int j = 0; j < 4 && same; ++j) {
      Stress ends[2];
      for (int side = 0; side < 2; ++side) {
        Strain dj = d;
        dj[j] += side == 0 ? delta : -delta;
        ends[side] = s0;
        PointState state_j = start;
        const ReturnInfo info_j = model.update_with_info(dj, ends[side], state_j);
        same = same && set_name(info_j) == set &&
               law_segment(model.cohesion, state_j.plastic_strain) == segment;
      }
      differences.col(j) = (ends[0] - ends[1]) / (2.0 * delta);
    }
    if (!same) {
      ++fig.skipped;
      continue;
    }
    ++fig.counts[set];
    ++fig.compared;
    fig.worst = std::max(fig.worst, (tangent - differences).cwiseAbs().maxCoeff() / hooke);
  }
  return fig;
}

TEST(Materials, LinearElasticTangentIsHookesLaw) {
  const LinearElastic elastic{soil_elastic()};
  Stress s(-10.0, -20.0, 3.0, -15.0);
  PointState state;
  Tangent tangent;
  elastic.update_with_tangent(Strain(1e-3, -2e-3, 3e-3, 0.0), s, state, tangent);
  Tangent expected;
  expected << kLambda + 2 * kMu, kLambda, 0, kLambda, kLambda, kLambda + 2 * kMu, 0, kLambda, 0, 0,
      kMu, 0, kLambda, kLambda, 0, kLambda + 2 * kMu;
  EXPECT_EQ(tangent, expected);
}

TEST(Materials, TrescaTangentIsTheDerivativeOfTheReturn) {
  // Softening (thesis law) and hardening then snap-back: every return the update makes, the
  // main plane and both edges, with the slope of the law at the new eps_p.
  for (const PiecewiseLinear& law : {thesis_cohesion(), hardening_then_snap_cohesion()}) {
    const Tresca tresca{soil_elastic(), law};
    TangentFigures fig = tangents_against_differences(tresca, PlaneConstants{}, 7, 4000);
    EXPECT_LE(fig.worst, 1e-6);
    EXPECT_GE(fig.compared, 3600);
    for (const char* set : {"elastic", "F13", "F13+F23", "F13+F12"})
      EXPECT_GE(fig.counts[set], 50) << set;
  }
}

TEST(Materials, MohrCoulombTangentIsTheDerivativeOfTheReturn) {
  struct Model {
    double phi, psi, cutoff;
    std::vector<std::string> sets;
  };
  // Non-associated with a cut-off (every set but the cone apex), associated and psi = 0 with the
  // cut-off at the apex (the cone apex reached as the tension apex), as the Kuhn-Tucker tests.
  const Model models[] = {
      {30.0, 10.0, 3.0, {"F13", "F13+F23", "F13+F12", "T1", "F13+T1", "T1+T2", "T1+T2+T3"}},
      {25.0, 25.0, 1e9, {"F13", "F13+F23", "F13+F12", "F13+F12+T1", "F13+T1+T2"}},
      {35.0, 0.0, 1e9, {"F13", "F13+F23", "F13+F12", "F13+F12+T1", "F13+T1+T2"}}};
  for (const Model& model : models) {
    const MohrCoulomb mc{soil_elastic(), thesis_cohesion(), model.phi, model.psi, model.cutoff};
    const double phi = model.phi * std::numbers::pi / 180.0;
    const PlaneConstants m{std::sin(phi), std::cos(phi),
                           std::sin(model.psi * std::numbers::pi / 180.0), model.cutoff};
    TangentFigures fig = tangents_against_differences(mc, m, 11, 8000);
    EXPECT_LE(fig.worst, 1e-6) << model.phi << " " << model.psi;
    EXPECT_GE(fig.compared, 7000) << model.phi << " " << model.psi;
    for (const std::string& set : model.sets) EXPECT_GE(fig.counts[set], 5) << set;
  }
}

TEST(Materials, ReducedStrengthDividesTheShearStrengthOnEveryPlane) {
  // Strength reduction by F: the Coulomb line tau = c + sigma' tan(phi) (compression positive
  // sigma') becomes tau = c / F + sigma' tan(phi) / F. A Mohr circle of centre -p and radius r
  // touches it where r = c' cos(phi') + p sin(phi') with tan(phi') = tan(phi) / F, c' = c / F.
  const double factor = 1.7, phi = 30.0 * std::numbers::pi / 180.0;
  const MohrCoulomb mc{soil_elastic(), thesis_cohesion(), 30.0, 10.0, 6.0};
  const Material reduced_material = reduced_strength(Material(mc), factor);
  const auto& reduced = std::get<MohrCoulomb>(reduced_material);
  const double phi_r = std::atan(std::tan(phi) / factor);
  EXPECT_NEAR(std::tan(reduced.friction_angle_deg * std::numbers::pi / 180.0),
              std::tan(phi) / factor, 1e-14);
  EXPECT_NEAR(std::tan(reduced.dilation_angle_deg * std::numbers::pi / 180.0),
              std::tan(10.0 * std::numbers::pi / 180.0) / factor, 1e-14);
  EXPECT_DOUBLE_EQ(reduced.tension_cutoff, 6.0 / factor);
  EXPECT_EQ(reduced.elastic.youngs_modulus, mc.elastic.youngs_modulus);
  EXPECT_EQ(reduced.elastic.poisson_ratio, mc.elastic.poisson_ratio);
  ASSERT_EQ(reduced.cohesion.y.size(), mc.cohesion.y.size());
  for (std::size_t k = 0; k < mc.cohesion.y.size(); ++k) {
    EXPECT_EQ(reduced.cohesion.x[k], mc.cohesion.x[k]);
    EXPECT_DOUBLE_EQ(reduced.cohesion.y[k], mc.cohesion.y[k] / factor);
  }
  const PointState intact;
  const double c = mc.cohesion.value(0.0) / factor;
  for (double p : {5.0, 50.0, 200.0}) {
    // In-plane circle (sxx, syy), szz = -p in between.
    const double r = c * std::cos(phi_r) + p * std::sin(phi_r);
    const Stress on(-p + r, -p - r, 0.0, -p);
    EXPECT_NEAR(reduced.yield_function(on, intact), 0.0, 1e-12 * (p + c));
    EXPECT_LT(mc.yield_function(on, intact), 0.0);  // the full strength holds it
  }
  // Tresca: the cohesion law over F; the elastic material as it is.
  const Tresca tresca{soil_elastic(), thesis_cohesion()};
  const Material reduced_tresca_material = reduced_strength(Material(tresca), factor);
  const auto& reduced_tresca = std::get<Tresca>(reduced_tresca_material);
  EXPECT_NEAR(reduced_tresca.yield_function(Stress(c, -c, 0.0, 0.0), intact), 0.0, 1e-12);
  const Material elastic = LinearElastic{soil_elastic()};
  EXPECT_EQ(std::get<LinearElastic>(reduced_strength(elastic, factor)).elastic.youngs_modulus,
            soil_elastic().youngs_modulus);
}

TEST(Materials, TangentOfTheMaterialVariantIsTheModels) {
  const Material material = MohrCoulomb{soil_elastic(), thesis_cohesion(), 30.0, 10.0, 3.0};
  const Strain d(-2e-3, 1e-3, 2e-2, 0.0);
  Stress a(-30.0, -40.0, 5.0, -35.0), b = a;
  PointState sa, sb;
  Tangent ta, tb;
  update_with_tangent(material, material_constants(material), d, a, sa, ta);
  std::get<MohrCoulomb>(material).update_with_tangent(d, b, sb, tb);
  EXPECT_EQ(ta, tb);
  EXPECT_EQ(a, b);
  EXPECT_GT(sa.plastic_strain, 0.0);  // a plastic step
}

}  // namespace
}  // namespace pfm
