// Filling bodies with material points (thesis 3.2, 5.3.3), and the initial stress procedures
// (K0, gravity loading) with the step counters that the MPM and the UL-FEM share.
#pragma once

#include <functional>
#include <vector>

#include "mpm/solver/case.hpp"
#include "mpm/solver/particles.hpp"

namespace pfm {

/// Even-odd point-in-polygon test (points exactly on an edge count as inside the half-open
/// region below/left of it, consistently for neighbouring polygons).
bool point_in_polygon(const std::vector<Vec2>& polygon, const Vec2& x);

/// Height of the polygon's top above x: the largest y of the polygon boundary on the vertical
/// line through x, or NaN if the line misses the polygon. Used as the local surface for K0.
double polygon_top(const std::vector<Vec2>& polygon, double x);

/// The K0 procedure (shared by the MPM and the UL-FEM): sigma_v = -unit weight x depth below
/// the local surface of the point's body polygon (polygon_top), sigma_xx = sigma_zz = K0
/// sigma_v, sigma_xy = 0; K0 from the case or nu / (1 - nu) of the point's material.
void apply_k0_stress(const Case& c, Particles& particles);

/// The scalars an explicit solver (the MPM or the UL-FEM) carries from step to step besides
/// its particles; checkpoints save them.
struct SolverCounters {
  double time = 0.0;              ///< s
  long step = 0;                  ///< steps taken since time 0
  double dt = 0.0;                ///< s
  double damping = 0.0;           ///< local damping coefficient in force
  bool loads_active = true;       ///< surface loads applied (off during gravity loading)
  bool gravity_full = false;      ///< gravity at its full value from the start (no ramp)
  long initial_stress_steps = 0;  ///< steps of the gravity loading (0 for zero and K0)
  double external_work = 0.0, internal_work = 0.0, damping_work = 0.0;  ///< kJ (per m thickness)
};

/// The initial stress procedure of the case (shared by the MPM and the UL-FEM). Zero: nothing.
/// K0: apply_k0_stress(), full gravity from the start. Gravity loading: full gravity, the
/// procedure's damping and no surface loads; `step()` until the kinetic energy
/// (`kinetic_energy()`) falls below spec.kinetic_energy_ratio x its peak (after at least 10
/// steps; SimulationError when spec.max_time passes first); then the damping and the loads are
/// restored, the velocities zeroed, the reference positions set to the current ones, and time,
/// step and works reset (initial_stress_steps keeps the count). Returns true after gravity
/// loading: the caller resets what else measures displacement.
bool initialise_stress(const Case& c, Particles& particles, SolverCounters& counters,
                       const std::function<void()>& step,
                       const std::function<double()>& kinetic_energy);

/// Natural positions in [0, 1] and weights (summing to 1) of the n points of a placement.
void placement_points_1d(Placement placement, int n, std::vector<double>& position,
                         std::vector<double>& weight);

/// Fill every body with n x n points per cell whose point lies inside the body polygon; a point
/// inside several bodies belongs to the first. Volume = cell area x the point's weight
/// (1/n^2 for equal spacing, the Gauss weight product for Gauss placement); mass = density x
/// volume with density = unit weight / g (g = 9.81 m/s^2 when gravity is 0).
Particles fill_bodies(const Case& c);

}  // namespace pfm
