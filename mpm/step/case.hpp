// A validated case: everything a run needs, read from a JSON case file (schema in README.md).
// Units: kN, m, s, t, kPa; angles converted to degrees-in-struct as documented per field.
#pragma once

#include <algorithm>
#include <array>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "mpm/boundary/surface_load.hpp"
#include "mpm/core/grid.hpp"
#include "mpm/core/manufactured.hpp"
#include "mpm/core/materials.hpp"
#include "mpm/core/polygon.hpp"
#include "mpm/core/shape_functions.hpp"
#include "mpm/detect/detector_config.hpp"
#include "mpm/step/energy_ledger.hpp"

namespace pfm {

/// The Poisson ratio from which solver.anti_locking defaults to "bbar" (a material at or above
/// it is nearly incompressible).
inline constexpr double kBbarPoissonRatio = 0.45;

struct MaterialRecord {
  std::string name;
  Material model;
  double unit_weight = 0.0;  ///< kN/m^3
  /// materials[].softening_length, m, when given: `model`'s cohesion law is then
  /// written_cohesion with its plastic strains scaled by softening_length / cell size.
  std::optional<double> softening_length;
  PiecewiseLinear written_cohesion;  ///< the cohesion law as written (Tresca, Mohr-Coulomb)
};

enum class Placement { kEqual, kGauss, kConforming };

struct BodySpec {
  std::string name;
  int material = 0;           ///< index into Case::materials
  std::vector<Vec2> polygon;  ///< counter-clockwise, not closed (first point not repeated), m
  int points_per_cell = 2;    ///< n: n x n points per cell
  Placement placement = Placement::kEqual;
  /// A body read from a particle file (bodies[].particles: x, y, volume, optionally the stress
  /// and the material; mpm/step/particle_input.hpp): its points as they are, each a square of
  /// its volume (polygon empty, points_per_cell and placement unused). Empty for a rectangle or
  /// polygon body.
  std::vector<Vec2> point_position;  ///< m
  std::vector<double> point_volume;  ///< m^2 per m
  std::vector<Stress> point_stress;  ///< kPa, the initial stress; empty: none given (zero)
  std::vector<int> point_material;   ///< index into Case::materials; empty: `material`
  bool from_file() const { return !point_position.empty(); }
  /// A body given as a gmsh mesh (bodies[].mesh): the file and its physical group (empty: all
  /// 2D elements); polygon is the mesh's outline (mpm/step/gmsh_surface.hpp). The UL-FEM
  /// meshes such a body with the file's elements.
  std::string mesh_file;
  std::string physical_group;
};

struct GravitySpec {
  double g = 9.81;         ///< m/s^2, acting along -y
  double ramp_time = 0.0;  ///< s; 0 = applied at once
};

enum class InitialStressMethod { kZero, kK0, kGravity };

struct InitialStressSpec {
  InitialStressMethod method = InitialStressMethod::kZero;
  std::optional<double> k0;  ///< default nu / (1 - nu) of each point's material
  double kinetic_energy_ratio = 1e-6;
  double damping = 0.7;
  double max_time = 20.0;  ///< s
};

/// A named set of nodes for boundary conditions: the grid nodes (MPM) or mesh nodes (UL-FEM)
/// in a closed box ("box"), or on the curves and points of a gmsh physical group ("mesh",
/// "physical_group").
struct NodeSet {
  std::string name;
  Vec2 box_min, box_max;  ///< m, closed box (when `segments` is empty)
  /// The group's line elements, its points as segments of zero length, m.
  std::vector<std::array<Vec2, 2>> segments;
  std::string mesh_file, physical_group;
  /// Whether a node at x belongs to the set: in the box, or within `tolerance` (m) of a
  /// segment.
  bool contains(const Vec2& x, double tolerance) const;
};

enum class TimeFunctionKind { kConstant, kRamp, kSmoothRamp };

struct TimeFunction {
  TimeFunctionKind kind = TimeFunctionKind::kConstant;
  double ramp_time = 0.0;  ///< s
  /// Factor in [0, 1] at time t: 1 (constant), t / t_r (ramp), or 10 u^3 - 15 u^4 + 6 u^5 with
  /// u = t / t_r (smooth ramp: its first and second derivatives vanish at both ends), up to t_r
  /// and 1 after (smooth_ramp_factor, mpm/core/manufactured.hpp).
  double factor(double t) const {
    if (kind == TimeFunctionKind::kConstant || ramp_time <= 0.0) return 1.0;
    if (kind == TimeFunctionKind::kSmoothRamp) return smooth_ramp_factor(t, ramp_time).value;
    return t >= ramp_time ? 1.0 : t / ramp_time;
  }
};

/// Nodes whose velocity components `fix` are prescribed: zero (a support), or `velocity` times
/// the time function (a moving support: a rigid footing pushed, a platen; the displacement
/// control of a test). The force it takes to hold them is the reaction (prescribed_velocity.hpp).
struct BoundaryCondition {
  std::string where;  ///< left, right, bottom, top or a node-set name
  unsigned fix = kFixNone;
  Vec2 velocity = Vec2::Zero();  ///< m/s, of the fixed components (zero for the others)
  bool moving = false;           ///< "velocity" given: the reaction goes to the time series
  TimeFunction time_function;
  /// The prescribed velocity at time t, m/s.
  Vec2 velocity_at(double t) const { return time_function.factor(t) * velocity; }
};

enum class LoadTarget { kGridTopNodes, kDetectedBoundary };

struct LoadSpec {
  std::string type = "vertical_pressure";  ///< vertical_pressure, follower_pressure, traction
  double pressure = 0.0;                   ///< kPa (the two pressures)
  double x0 = 0.0, x1 = 0.0;               ///< m, the loaded interval (when given)
  LoadTarget apply_on = LoadTarget::kGridTopNodes;
  TimeFunction time_function;
  /// Loads on the detected boundary: the full specification (mpm/boundary/load_input.hpp).
  std::optional<boundary::BoundaryLoadSpec> surface;
  nlohmann::json raw;  ///< the entry as written
};

/// An essential condition on a part of the detected boundary (case-file "constraints",
/// mpm/solver/boundary_constraint.hpp): the displacement of the material on the part is held at
/// a prescribed value, in the normal direction only (a smooth contact) or in full (a rough one),
/// by penalty, by Nitsche's method or (implicit solver only) by the Implicit Boundary Method.
enum class ConstraintMethod { kPenalty, kNitsche, kImplicitBoundary };

struct ConstraintSpec {
  /// The part of the boundary (x_range, faces, normal window, curve, interval), as for a load,
  /// and its rule (gauss_points, default 2: exact for N_I times an affine gap on a straight
  /// piece); the load's type and pressures are unused.
  boundary::BoundaryLoadSpec part;
  bool normal_only = false;  ///< the normal component (a smooth constraint) or the full vector
  bool velocity = false;     ///< the value is a velocity (m/s), else a displacement (m)
  /// The prescribed displacement (m) or velocity (m/s) at full time function: the vector, or
  /// (value along the outward normal, 0) with normal_only.
  Vec2 value = Vec2::Zero();
  TimeFunction time_function;
  ConstraintMethod method = ConstraintMethod::kPenalty;
  /// beta, kPa/m (traction per metre of gap): penalty_factor x the largest constrained modulus
  /// (lambda + 2 mu) of the materials / h, unless given.
  double penalty = 0.0;
  double penalty_factor = 100.0;
  /// The Implicit Boundary Method's band: delta = band_factor x h (m), the thickness over which
  /// its Dirichlet function rises from 0 to 1. The thin band leaves a gap of 3 delta / 8 times
  /// the normal stress over n.C.n; a thinner one stiffens the matrix and raises the solve's
  /// round-off towards Newton's tolerance (README: constraints[].band_factor).
  double band_factor = 1e-3;
  nlohmann::json raw;  ///< the entry as written
};

enum class Scheme { kMUSL, kUSL };

/// solver.outer_node_fraction's default with uGIMP and B-splines (linear functions: 0).
inline constexpr double kDefaultOuterNodeFraction = 0.05;
/// solver.ghost_penalty's default in an implicit case with ties (otherwise 0).
inline constexpr double kDefaultGhostPenalty = 1e-3;

/// solver.type: the explicit dynamic MPM (mpm/solver/mpm_solver.hpp) or the implicit
/// quasi-static one (mpm/implicit/implicit_solver.hpp).
enum class SolverType { kExplicit, kImplicit };

/// The "implicit" block (solver.type "implicit"): the load steps and the Newton iteration.
/// The shear strength reduction method ("implicit"."strength_reduction"): the strength of every
/// material divided by a factor F(t) (reduced_strength, mpm/core/materials.hpp) that is 1 up to
/// start_time and rises linearly to final_factor at time.end_time. A load step after start_time
/// that cannot be completed (max_cuts halvings in a row, or none left above the first step /
/// 2^max_cuts) ends the run as its answer: the factor of safety lies between the last
/// converged F and the F of the last attempt (run.json summary.strength_reduction).
struct StrengthReduction {
  double start_time = 0.0;    ///< s (pseudo-time), in [0, time.end_time)
  double final_factor = 2.0;  ///< F at time.end_time, > 1
  /// F at time t of a run that ends at end_time.
  double factor(double t, double end_time) const {
    if (t <= start_time) return 1.0;
    return 1.0 + (final_factor - 1.0) * std::min(1.0, (t - start_time) / (end_time - start_time));
  }
};

struct ImplicitSpec {
  int load_steps = 20;      ///< the first step's size is time.end_time / load_steps
  double tolerance = 1e-9;  ///< on the relative out-of-balance force
  int max_iterations = 25;  ///< Newton iterations per attempt of a step
  int max_cuts = 8;         ///< halvings of a step in a row before the run stops
  std::optional<StrengthReduction> strength_reduction;
};

/// Largest solver.xpic_order a case may ask for (each order is one more pass per step).
inline constexpr int kMaxXpicOrder = 8;

struct SolverSpec {
  SolverType type = SolverType::kExplicit;
  Scheme scheme = Scheme::kMUSL;
  ShapeFunctionKind shape_function = ShapeFunctionKind::kQuadraticBspline;
  double damping = 0.0;  ///< local (Cundall) damping coefficient
  DampingForm damping_form = DampingForm::kAlongVelocity;
  /// beta of the particle velocity update v_p' = (1 - beta) (v_p + dt sum N a) + beta sum N v':
  /// 0 = FLIP (the thesis), 1 = PIC. FLIP keeps velocity the grid cannot see (it moves no
  /// particle: jitter), PIC removes it each step at the cost of dissipation.
  double pic_fraction = 0.0;
  /// m of the PIC part above, XPIC(m) (Hammerquist and Nairn 2017): the update takes
  /// beta (I - P)^m V off the FLIP velocities V_FLIP, where P = S S+ is the particles-to-grid-
  /// to-particles projection of the particle velocities V. m = 1 is the blend above; a larger m
  /// removes what the grid cannot see (P's null space, where (I - P)^m = I) as PIC does while
  /// it damps the resolved motion (P's eigenvalues near 1) by (1 - lambda)^m instead of
  /// (1 - lambda). Each order above 1 costs one more grid-to-particle-to-grid pass per step.
  int xpic_order = 1;
  /// Anti-locking: the mean dilatation (B-bar) over each cell (MPM) or element (UL-FEM) in the
  /// stress update and the internal force (mean_dilatation_gradient, mpm/core/kinematics.hpp).
  /// Set by the case reader: on by default when a material has nu >= kBbarPoissonRatio.
  bool mean_dilatation = false;
  /// Nodes whose mass is below this share of a full support's are tied to their interior
  /// neighbours (mpm/core/basis_extension.hpp); 0 leaves every node free. Set by the case
  /// reader: kDefaultOuterNodeFraction with uGIMP and B-splines, 0 with linear functions.
  double outer_node_fraction = 0.0;
  /// The implicit step's ghost penalty (implicit_solver.hpp): gamma, the stiffness gamma M on a
  /// light node's deviation from its array's extrapolation; 0 for none. Set by the case reader:
  /// kDefaultGhostPenalty in an implicit case with ties, 0 otherwise.
  double ghost_penalty = 0.0;
};

struct TimeSpec {
  double end_time = 0.0;
  double cfl = 0.5;
  std::optional<double> dt;
  /// Most time steps a run may take (check_run_length()): more is taken for a unit mistake.
  double max_steps = 1e7;
};

struct OutputSpec {
  double interval = 0.0;                                           ///< s
  double timeseries_interval = 0.0;                                ///< s
  bool interval_given = false, timeseries_interval_given = false;  ///< in the case file
  /// Write the nodal forces of the detected-boundary loads at each output step
  /// (nodal_loads_<step>.csv, thesis figure 6.6).
  bool nodal_loads = false;
  /// gzip (level 1) + byte shuffle on the HDF5 datasets ("compression": "gzip"); off by default:
  /// it trades time at every output for fewer bytes (README "Outputs").
  bool compress = false;
  /// Also particles_<step>.vtu at each output step and particles.pvd (mpm/step/vtk_output.hpp).
  bool vtk = false;
};

/// The "detection" block: the detector configuration of parse_detector_config (mpm/detect)
/// plus how often it runs.
struct DetectionSpec {
  int every_steps = 1;  ///< detect every k steps (and at every output step)
  /// In units of the cell size h: a due detection runs only when some point has moved more
  /// than max_motion x h since the last one; otherwise the last boundary stays (it lags the
  /// body by at most that). The default 1e-3 is below the improved detector's own error on flat
  /// faces (mpm/detect/README.md, "Accuracy"); 0 detects at every due step.
  double max_motion = 1e-3;
  DetectorConfig detector;
};

struct Case {
  std::string file;  ///< path it was read from
  nlohmann::json source;
  std::string title;
  Grid grid;
  /// Most grid nodes (grid.max_nodes): more is taken for a unit mistake.
  double max_grid_nodes = 1e7;
  std::vector<MaterialRecord> materials;
  std::vector<BodySpec> bodies;
  GravitySpec gravity;
  InitialStressSpec initial_stress;
  std::vector<NodeSet> node_sets;
  std::vector<BoundaryCondition> boundary_conditions;
  std::vector<LoadSpec> loads;
  /// Essential conditions on the detected boundary ("constraints"; MPM only).
  std::vector<ConstraintSpec> constraints;
  SolverSpec solver;
  ImplicitSpec implicit;  ///< read with solver.type "implicit"
  TimeSpec time;
  OutputSpec output;
  /// Boundary detection during the run ("detection" block; required by detected-boundary
  /// loads, which default it to the improved detector every step).
  std::optional<DetectionSpec> detection;
  /// A manufactured solution whose body force drives the run (verification of convergence;
  /// "manufactured_solution" block, mpm/core/manufactured.hpp).
  std::optional<ManufacturedSolution> manufactured;
};

/// Memory of the MPM's arrays, per grid node (GridState's mass, momentum, forces (internal,
/// external, body), velocity,
/// acceleration and fixity, and the MUSL remap's velocity and momentum) and per material point
/// (Particles' fields, the shape-function stencils, binning and energy blocks), bytes. Their
/// sum estimates a run's memory before it is allocated (estimated_memory_bytes()).
inline constexpr double kBytesPerGridNode = 140.0;
inline constexpr double kBytesPerParticle = 400.0;
/// Material points the bodies will hold (area / h^2 x points_per_cell^2).
double estimated_particles(const Case& c);
double estimated_memory_bytes(const Case& c);

/// Read and validate a case file. Throws InputError naming the file and JSON pointer. Refuses a
/// grid of more than grid.max_nodes nodes, and a case whose estimated memory exceeds what the
/// machine has available (available_memory_bytes()).
Case read_case(const std::string& path);
/// Validate an already-parsed document (file is used in messages only).
Case parse_case(const nlohmann::json& document, const std::string& file);

/// The case as the solvers take it, as JSON: every value resolved (defaults applied, rectangles
/// and meshes as counter-clockwise polygons, angles in degrees, units as in the case file), for
/// readers in other languages that must not parse the schema again (the Python module,
/// python/README.md; the dolfinx model). Keys: title, file, grid {origin, cell_size, n_cells,
/// max_nodes}, materials [{name, model, youngs_modulus, poisson_ratio, unit_weight, and for the
/// plastic models cohesion {plastic_strain, cohesion} (as written), softening_length (null: none),
/// friction_angle, dilation_angle, tension_cutoff (null: none besides the apex)}], bodies [{name,
/// material (index), source (polygon, mesh, particles), polygon, points_per_cell, placement,
/// mesh, physical_group, n_points}], gravity {g, ramp_time}, initial_stress {method, k0 (null:
/// nu / (1 - nu)), kinetic_energy_ratio, damping, max_time}, node_sets [{name, box (null: from a
/// mesh), mesh, physical_group, segments}], boundary_conditions [{where, fix}], loads [{apply_on,
/// type, pressure, traction, x_range (null: the whole boundary), faces, interval, time_function
/// {type, ramp_time}, and normal {direction, max_angle} when given}], constraints [{x_range, faces,
/// normal (null or {direction, max_angle}), quantity (displacement, velocity), normal_only,
/// value (a number with normal_only, else [x, y]), time_function, method, penalty}], solver
/// {type, scheme, shape_function, damping, damping_form, pic_fraction, xpic_order, anti_locking},
/// implicit
/// (null, or with solver.type "implicit" {load_steps, tolerance, max_iterations, max_cuts,
/// strength_reduction (null or {start_time, final_factor})}), time
/// {end_time, cfl, dt (null: from cfl), max_steps}, output {interval, timeseries_interval,
/// nodal_loads, compression, vtk}, detection (null or {every_steps, method}), manufactured_solution
/// (bool).
nlohmann::json resolved_case(const Case& c);

/// Refuses (InputError naming the file and the JSON path) a run that cannot be useful with its
/// time step `dt` (s, from the case's dt or its CFL number): a step that is not a positive finite
/// number, an end time needing more than time.max_steps steps or less than one, an output
/// interval given below the
/// step, a time-series interval given below a hundredth of it (one below the time's rounding
/// never advanced: the run hung).
void check_run_length(const Case& c, double dt);

/// The largest constrained modulus M = lambda + 2 mu of the case's materials, kPa: the scale of
/// the constraints' default penalty and of the implicit step's ghost penalty.
double largest_constrained_modulus(const std::vector<MaterialRecord>& materials);

/// The largest P-wave speed sqrt(M / rho) of the case's materials at their initial density
/// rho = unit weight / g (g = 9.81 m/s^2 when gravity is off), m/s: with the cell or element size
/// it gives the critical time step of both solvers. Throws InputError when every material is
/// weightless (no critical time step).
double largest_wave_speed(const Case& c);

/// True if two non-adjacent edges of the closed polygon intersect or touch.
bool polygon_self_intersects(const std::vector<Vec2>& polygon);

}  // namespace pfm
