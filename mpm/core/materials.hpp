// Constitutive models for plane strain, shared by the MPM and the updated-Lagrangian FEM.
//
// Materials are stateless: the per-point state (stress, equivalent plastic strain) is data
// passed in and out of update(). Units: kPa for moduli, stresses and cohesion; degrees for
// angles in the parameter structs. Tension positive. Strain increments are (dxx, dyy,
// dgamma_xy = 2 deps_xy, dzz = 0); the increment is the objective (rotation-free) part, the
// Jaumann rotation of the stress is done by the caller (mpm/core/kinematics.hpp).
//
// Models (every detail of the plastic ones is stated in materials.cpp's header comment and
// repeated here in brief):
//  * LinearElastic: isotropic Hooke's law.
//  * Tresca: f = (s1 - s3) / 2 - c(eps_p) with s1 >= s2 >= s3 the principal stresses of the
//    full 3D plane-strain stress (sigma_zz included), associated flow, cohesion piecewise linear
//    in the equivalent plastic strain eps_p; return mapping in principal stress space with the
//    main plane and the two edge (corner) returns.
//  * MohrCoulomb: f = (s1 - s3) + (s1 + s3) sin(phi) - 2 c(eps_p) cos(phi), non-associated flow
//    with dilation angle psi, tension cut-off s1 <= sigma_t, the same softening of c.
//    The cut-off used is sigma_t,eff = min(sigma_t, c(eps_p) / tan(phi)): it follows the cone
//    apex down when c softens, so the hydrostatic tension apex always exists.
//  * eps_p is the accumulated plastic shear strain of the shear planes: per step the sum over the
//    active shear planes of (eps1^p - eps3^p) of that plane's flow; the tension cut-off does not
//    add to it. In simple shear eps_p is the plastic engineering shear strain gamma_xy^p.
//
// update() is the hot path (no allocation, no exception, no virtual call); update_with_info()
// does the same and also says which return was used (for tests and diagnostics);
// update_with_tangent() also gives the consistent (algorithmic) tangent of the update, the
// derivative of the returned stress with respect to the strain increment (Simo & Taylor 1985),
// which an implicit solver's Newton iterations need for quadratic convergence. Hot loops
// compute a model's constants() (Hooke constants, sines of the angles) once and pass them to
// update(..., constants): bitwise the same result without recomputing them per point.
#pragma once

#include <variant>
#include <vector>

#include "mpm/core/types.hpp"

namespace pfm {

/// Per-point material state besides the stress.
struct PointState {
  double plastic_strain = 0.0;  ///< equivalent plastic strain eps_p (-), see materials.cpp
};

/// Piecewise linear function y(x) through the points (x[k], y[k]), x strictly increasing,
/// constant beyond the first and last point. Used for cohesion against eps_p
/// (thesis Tables 5.1, 6.2: initial, peak and residual cohesion).
struct PiecewiseLinear {
  std::vector<double> x;
  std::vector<double> y;
  double value(double at) const;
  /// dy/dx on the segment holding `at`, taken from the right at a breakpoint; 0 outside.
  double slope(double at) const;
  /// Smallest y[k] (the weakest cohesion the law can reach).
  double min_value() const;
};

struct ElasticParameters {
  double youngs_modulus = 0.0;  ///< E, kPa
  double poisson_ratio = 0.0;   ///< nu, -
  double shear_modulus() const { return youngs_modulus / (2.0 * (1.0 + poisson_ratio)); }
  double bulk_modulus() const { return youngs_modulus / (3.0 * (1.0 - 2.0 * poisson_ratio)); }
  double lame_lambda() const {
    return youngs_modulus * poisson_ratio / ((1.0 + poisson_ratio) * (1.0 - 2.0 * poisson_ratio));
  }
  /// Constrained (oedometric, P-wave) modulus M = E (1 - nu) / ((1 + nu)(1 - 2 nu)), kPa.
  double constrained_modulus() const { return lame_lambda() + 2.0 * shear_modulus(); }
};

/// Constants of a model that update() would otherwise recompute at every call, exactly as it
/// computes them: lambda = lame_lambda(), mu = shear_modulus(), and for Mohr-Coulomb the sines
/// and cosine of the angles (the other models leave them at phi = psi = 0).
struct MaterialConstants {
  double lambda = 0.0;   ///< kPa
  double mu = 0.0;       ///< kPa
  double sin_phi = 0.0;  ///< sin(friction angle)
  double cos_phi = 1.0;  ///< cos(friction angle)
  double sin_psi = 0.0;  ///< sin(dilation angle)
  // Compliance of the same Hooke's law (the energy ledger's elastic energy): 1 / E and -nu / E,
  // 1/kPa.
  double compliance = 0.0;
  double compliance_coupling = 0.0;
};

/// d stress / d strain increment, 4 x 4: rows in the order of Stress, columns in the order of
/// Strain (gamma_xy, so the shear entry of Hooke's law is mu), kPa.
using Tangent = Eigen::Matrix4d;

/// Stress increment of Hooke's law for a plane-strain strain increment.
Stress elastic_stress_increment(const ElasticParameters& elastic, const Strain& strain_increment);

/// The same with lambda and mu taken from `constants` (inline: the elastic hot path).
inline Stress elastic_stress_increment(const MaterialConstants& constants, const Strain& d) {
  const double lambda = constants.lambda;
  const double mu = constants.mu;
  const double volumetric = d[kXX] + d[kYY] + d[kZZ];
  return Stress(lambda * volumetric + 2.0 * mu * d[kXX], lambda * volumetric + 2.0 * mu * d[kYY],
                mu * d[kXY], lambda * volumetric + 2.0 * mu * d[kZZ]);
}

/// Hooke's law as a Tangent: lambda + 2 mu on the normal diagonal (zz included), lambda off it,
/// mu for the shear.
Tangent elastic_tangent(const MaterialConstants& constants);

/// Elastic strain energy per unit volume psi = 1/2 sigma : C^-1 : sigma of the full 3D stress
/// (sigma_zz included), kJ/m^3 = kPa:
///   psi = [sxx^2 + syy^2 + szz^2 - 2 nu (sxx syy + syy szz + szz sxx)] / (2 E) + sxy^2 / (2 mu).
/// psi is quadratic, so psi(b) - psi(a) = 1/2 (a + b) : C^-1 (b - a) exactly: the energy
/// ledger's elastic energy changes by the stress power of the elastic part of each increment.
inline double elastic_energy_density(const MaterialConstants& c, const Stress& s) {
  const double normal = s[kXX] * s[kXX] + s[kYY] * s[kYY] + s[kZZ] * s[kZZ];
  const double coupling = s[kXX] * s[kYY] + s[kYY] * s[kZZ] + s[kZZ] * s[kXX];
  return 0.5 * (c.compliance * normal + 2.0 * c.compliance_coupling * coupling) +
         0.5 * s[kXY] * s[kXY] / c.mu;
}

/// Elastic strain of a stress (increment): C^-1 s, as (xx, yy, gamma_xy, zz).
inline Strain elastic_compliance(const MaterialConstants& c, const Stress& s) {
  return Strain(c.compliance * s[kXX] + c.compliance_coupling * (s[kYY] + s[kZZ]),
                c.compliance * s[kYY] + c.compliance_coupling * (s[kXX] + s[kZZ]), s[kXY] / c.mu,
                c.compliance * s[kZZ] + c.compliance_coupling * (s[kXX] + s[kYY]));
}

/// The planes of the principal-stress-space return, in the ordered frame s1 >= s2 >= s3 of the
/// elastic trial stress. kShearIJ: the Mohr-Coulomb (Tresca for phi = 0) plane with s_I as the
/// major and s_J as the minor principal stress; kTensionI: s_I <= sigma_t.
enum class YieldPlane : unsigned char {
  kShear13,
  kShear23,
  kShear12,
  kTension1,
  kTension2,
  kTension3
};

/// What a stress update did. n_active == 0: elastic step. The multipliers belong to the
/// yield functions as defined for the model (Tresca: f = (s1 - s3)/2 - c; Mohr-Coulomb:
/// f = (s1 - s3) + (s1 + s3) sin(phi) - 2 c cos(phi); tension: f = s1 - sigma_t).
struct ReturnInfo {
  int n_active = 0;                       ///< number of active planes (0..3)
  YieldPlane planes[3] = {};              ///< the active planes
  double multipliers[3] = {};             ///< their plastic multipliers (>= 0)
  double plastic_strain_increment = 0.0;  ///< increment of eps_p
  bool admissible = true;  ///< false only if no return satisfied the Kuhn-Tucker conditions
                           ///< (never seen in the tests; the least violating one is used)
};

struct LinearElastic {
  ElasticParameters elastic;
  void update(const Strain& strain_increment, Stress& stress, PointState& state) const;
  /// update() with constants() computed once by the caller.
  void update(const Strain& strain_increment, Stress& stress, PointState& /*state*/,
              const MaterialConstants& constants) const {
    stress += elastic_stress_increment(constants, strain_increment);
  }
  MaterialConstants constants() const;
  /// update() and Hooke's law as the tangent.
  ReturnInfo update_with_tangent(const Strain& strain_increment, Stress& stress, PointState& state,
                                 Tangent& tangent) const;
};

struct Tresca {
  ElasticParameters elastic;
  PiecewiseLinear cohesion;  ///< c(eps_p), kPa
  void update(const Strain& strain_increment, Stress& stress, PointState& state) const;
  /// update() with constants() computed once by the caller.
  void update(const Strain& strain_increment, Stress& stress, PointState& state,
              const MaterialConstants& constants) const;
  MaterialConstants constants() const;
  ReturnInfo update_with_info(const Strain& strain_increment, Stress& stress,
                              PointState& state) const;
  /// update_with_info() and the consistent tangent d stress / d strain_increment at this
  /// increment: Hooke's law for an elastic step; for a return, the linearised return on its
  /// active planes (the softening slope of the law at the new eps_p included) turned with the
  /// trial stress's principal directions (materials.cpp, spectral_tangent). Not symmetric for
  /// non-associated flow.
  ReturnInfo update_with_tangent(const Strain& strain_increment, Stress& stress, PointState& state,
                                 Tangent& tangent) const;
  /// Yield function at the given stress and state (kPa); <= 0 inside the elastic region.
  double yield_function(const Stress& stress, const PointState& state) const;
};

struct MohrCoulomb {
  ElasticParameters elastic;
  PiecewiseLinear cohesion;         ///< c(eps_p), kPa
  double friction_angle_deg = 0.0;  ///< phi
  double dilation_angle_deg = 0.0;  ///< psi <= phi
  double tension_cutoff = 0.0;      ///< largest allowed principal stress sigma_t, kPa (>= 0)
  void update(const Strain& strain_increment, Stress& stress, PointState& state) const;
  /// update() with constants() computed once by the caller.
  void update(const Strain& strain_increment, Stress& stress, PointState& state,
              const MaterialConstants& constants) const;
  MaterialConstants constants() const;
  ReturnInfo update_with_info(const Strain& strain_increment, Stress& stress,
                              PointState& state) const;
  /// update_with_info() and the consistent tangent d stress / d strain_increment at this
  /// increment: Hooke's law for an elastic step; for a return, the linearised return on its
  /// active planes (the softening slope of the law at the new eps_p included) turned with the
  /// trial stress's principal directions (materials.cpp, spectral_tangent). Not symmetric for
  /// non-associated flow.
  ReturnInfo update_with_tangent(const Strain& strain_increment, Stress& stress, PointState& state,
                                 Tangent& tangent) const;
  /// Shear yield function f = (s1 - s3) + (s1 + s3) sin(phi) - 2 c(eps_p) cos(phi), kPa.
  double yield_function(const Stress& stress, const PointState& state) const;
  /// Tension cut-off function s1 - sigma_t,eff, kPa; the elastic region is where both are <= 0.
  double tension_function(const Stress& stress, const PointState& state) const;
  /// sigma_t,eff = min(tension_cutoff, c(eps_p) / tan(phi)) (phi > 0), else tension_cutoff.
  /// tension_cutoff may be +infinity (no cut-off besides the apex).
  double effective_tension_cutoff(const PointState& state) const;
};

using Material = std::variant<LinearElastic, Tresca, MohrCoulomb>;

const ElasticParameters& elastic_parameters(const Material& material);

/// The constants() of whichever model `material` holds.
MaterialConstants material_constants(const Material& material);

/// `material` with its strength divided by `factor` (>= 1), as the shear strength reduction
/// method does (Zienkiewicz, Humpheson & Lewis 1975; Griffiths & Lane 1999): every cohesion of
/// the law c(eps_p) over factor, tan(phi) and tan(psi) over factor, the tension cut-off over
/// factor; the elastic parameters kept. A linear elastic material is returned as it is.
Material reduced_strength(const Material& material, double factor);

/// update_with_tangent() of whichever model `material` holds, with its constants() computed once
/// by the caller (the hot path of an implicit solver's iterations).
ReturnInfo update_with_tangent(const Material& material, const MaterialConstants& constants,
                               const Strain& strain_increment, Stress& stress, PointState& state,
                               Tangent& tangent);

}  // namespace pfm
