"""Analyses of a case: initial stress, quasi-static incremental loading (Newton, load control
with step cutting), collapse search, and a lumped-mass explicit dynamic mode; outputs."""
from __future__ import annotations

import csv
import os
import time as wallclock
from dataclasses import dataclass, field

import numpy as np

from .case import read_case, time_function_factor
from .model import Model, NoConvergence


# Why a run refuses a moving support (boundary_conditions[].velocity), by run.
MOVING_SUPPORT_REFUSALS = {
    "load control": "load control holds every support still (a moving support runs under "
    "displacement control: run_driven, the static mode without --collapse)",
    "explicit": "the explicit mode holds supports still (run a moving support with --mode "
    "static)",
}


def refuse_moving_supports(case, run: str) -> None:
    """ValueError '<file>: /boundary_conditions/<k>/velocity: <why>' naming the case's first
    moving support, when it has one and `run` (a key of MOVING_SUPPORT_REFUSALS) holds them.
    """
    for k, bc in enumerate(case.boundary_conditions):
        if bc.velocity is not None:
            raise ValueError(
                f"{case.file}: /boundary_conditions/{k}/velocity: "
                f"{MOVING_SUPPORT_REFUSALS[run]}"
            )


def _case_and_model(case, model, model_options):
    """The case (read when given as a path) and its model (built unless given)."""
    if isinstance(case, (str, os.PathLike)):
        case = read_case(case)
    return case, model if model is not None else Model(case, **model_options)


@dataclass
class StaticResult:
    """Results of run_static. Settlements are downward displacements (m, positive down) of the
    first load's strip centre measured from the start of the load phase."""

    model: Model
    initial_stress: str
    # (load kPa, settlement m, total settlement m)
    curve: list = field(default_factory=list)
    # last converged pressure of the first load (kPa)
    collapse_load: float | None = None
    converged_to_full_load: bool = True
    newton_iterations: int = 0
    runtime: float = 0.0
    # name -> displacement (ux, uy) at the end
    probes: dict = field(default_factory=dict)


def initial_stress(
    model: Model, method: str, k0=None, gravity_steps=1, rtol=1e-8, min_step=1e-3
):
    """Apply the initial-stress procedure. Returns Newton iterations used.

    zero:    unstressed start; gravity is then switched on in `gravity_steps` increments
             and its displacements are kept (the static counterpart of the MPM's sudden gravity).
    k0:      sigma_v = -unit weight x depth below the local surface, sigma_h = sigma_zz = K0 sigma_v
             (K0 = nu / (1 - nu) unless given), u = 0, gravity on (no increment solved unless the
             field is out of balance, e.g. a slope: then one Newton step finds equilibrium and
             its displacements are kept).
    Gravity increments that fail are halved down to min_step (then NoConvergence).
    gravity: gravity applied to the unstressed body in `gravity_steps` increments (elasto-plastic),
             then the displacements are reset to zero (stress and kappa kept; the UL mesh is moved
             back to the initial geometry)."""
    iterations = 0
    if method == "k0":
        model.set_k0_stress(k0)
        try:
            return model.solve_step(1.0, 0.0, rtol=rtol)
        except NoConvergence as err:
            raise NoConvergence(
                f"K0 initial stress: no equilibrium found ({err})"
            ) from err
    factor, step = 0.0, 1.0 / max(gravity_steps, 1)
    while factor < 1.0 - 1e-12:
        trial = min(1.0, factor + step)
        try:
            iterations += model.solve_step(trial, 0.0, rtol=rtol)
        except NoConvergence as err:
            step *= 0.5
            if step < min_step:
                raise NoConvergence(
                    f"gravity loading failed at {100 * factor:.3g} % of gravity (the body cannot "
                    f"carry its weight statically, e.g. strain softening; try explicit mode)"
                ) from err
            continue
        factor = trial
    if method == "gravity":
        model.reset_displacements()
    return iterations


def run_static(
    case,
    steps=10,
    collapse=False,
    max_factor=10.0,
    min_step=1e-3,
    initial_stress_method=None,
    gravity_steps=1,
    rtol=1e-8,
    max_iterations=25,
    model=None,
    on_step=None,
    **model_options,
):
    """Quasi-static incremental analysis of a case (load control with Newton).

    The loads (all case loads together, factor lambda times their pressure) go from 0 to 1 in
    `steps` equal increments; a failed increment is halved (down to `min_step`).
    collapse=True: keep increasing lambda past 1 (increments of 1/steps, halved on failure)
    until an increment smaller than min_step fails or lambda reaches max_factor; the collapse
    load is the last converged pressure of the first load (a lower bound of the FE limit load).
    model_options go to Model (degree, element_size, refine_size, refine_distance, quads,
    updated_lagrangian, kappa_measure)."""
    start = wallclock.perf_counter()
    case, model = _case_and_model(case, model, model_options)
    refuse_moving_supports(case, "load control")
    method = initial_stress_method or case.initial_stress
    k0 = case.k0
    result = StaticResult(model, method)
    result.newton_iterations += initial_stress(
        model, method, k0, gravity_steps, rtol, min_step
    )
    probe = "load0_centre" if "load0_centre" in model.probes else None
    base = model.probe_displacement(probe)[1] if probe else 0.0
    q_ref = case.loads[0].magnitude if case.loads else 0.0

    def record(factor):
        if probe:
            uy = model.probe_displacement(probe)[1]
            result.curve.append((factor * q_ref, base - uy + 0.0, -uy + 0.0))
        if on_step:
            on_step(model, factor)

    record(0.0)
    factor, step = 0.0, 1.0 / max(steps, 1)
    target = max_factor if collapse else 1.0
    while case.loads and factor < target - 1e-12:
        trial = min(factor + step, target)
        try:
            result.newton_iterations += model.solve_step(
                1.0, trial, rtol, max_iterations
            )
        except NoConvergence:
            step *= 0.5
            if step < min_step:
                if not collapse:
                    result.converged_to_full_load = False
                break
            continue
        factor = trial
        record(factor)
    result.collapse_load = factor * q_ref if collapse else None
    result.runtime = wallclock.perf_counter() - start
    result.probes = {name: model.probe_displacement(name) for name in model.probes}
    return result


@dataclass
class StrengthReductionResult:
    """Results of run_strength_reduction: the factor of safety lies between the last converged
    strength factor and the failed one (None when max_factor was reached)."""

    last_converged_factor: float
    failed_factor: float | None
    # (factor, then per probe of model.probes its ux, uy in m) after each converged factor
    curve: list = field(default_factory=list)
    newton_iterations: int = 0
    runtime: float = 0.0


def run_strength_reduction(
    case,
    max_factor,
    steps=20,
    min_step=1e-3,
    load_steps=10,
    rtol=1e-8,
    max_iterations=25,
    model=None,
    on_step=None,
    **static_options,
):
    """The shear strength reduction method (Griffiths & Lane 1999) from equilibrium: the case's
    initial stress and loads as run_static brings them to full load, then the strength of every
    material divided by a factor F (Material.reduced) rising from 1 towards max_factor in
    increments of (max_factor - 1) / steps, each a Newton solve from the last equilibrium; an
    increment that fails is halved, and once it is below min_step the last converged F is a
    lower bound of the factor of safety. The MPM does the same over its pseudo-time
    (implicit.strength_reduction). static_options go to run_static: its initial_stress_method
    and gravity_steps, and the Model options with which it builds the model unless one is
    given."""
    start = wallclock.perf_counter()
    static = run_static(
        case,
        steps=load_steps,
        min_step=min_step,
        rtol=rtol,
        max_iterations=max_iterations,
        model=model,
        **static_options,
    )
    model = static.model
    if not static.converged_to_full_load:
        raise NoConvergence(
            "strength reduction: the loads could not be applied in full"
        )
    result = StrengthReductionResult(
        1.0, None, newton_iterations=static.newton_iterations
    )

    def record(factor):
        row = [factor]
        for name in model.probes:
            row.extend(float(v) for v in model.probe_displacement(name))
        result.curve.append(tuple(row))
        if on_step:
            on_step(model, factor)

    record(1.0)
    factor, step = 1.0, (max_factor - 1.0) / max(steps, 1)
    while factor < max_factor - 1e-12:
        trial = min(factor + step, max_factor)
        model.set_strength_factor(trial)
        try:
            result.newton_iterations += model.solve_step(
                1.0, model.load_factor, rtol, max_iterations
            )
        except NoConvergence:
            result.failed_factor = trial
            step *= 0.5
            if step < min_step:
                break
            continue
        factor = trial
        if result.failed_factor is not None and result.failed_factor <= factor:
            result.failed_factor = None
        record(factor)
    model.set_strength_factor(factor)
    result.last_converged_factor = factor
    result.runtime = wallclock.perf_counter() - start
    return result


@dataclass
class DrivenResult:
    """Results of run_driven: one row per converged increment, (time s, then per moving support
    k of model.moving_supports its displacement ux, uy (m) and reaction fx, fy (kN/m)).
    """

    model: Model
    columns: list
    series: list = field(default_factory=list)
    converged_to_end: bool = True
    newton_iterations: int = 0
    runtime: float = 0.0


def run_driven(
    case,
    steps=10,
    end_time=None,
    min_step=1e-3,
    initial_stress_method=None,
    gravity_steps=1,
    rtol=1e-8,
    max_iterations=25,
    model=None,
    on_step=None,
    **model_options,
):
    """Quasi-static analysis under displacement control: the moving supports
    (boundary_conditions with a velocity) reach their displacement at each time t of
    (0, end_time] (velocity times the integral of the time function) in `steps` equal increments
    of time; loads act with their time functions' factors at t, gravity in full after the
    initial-stress procedure. A failed increment is halved (down to min_step x end_time, then
    the run stops: converged_to_end False), and a converged one lets the next double again up
    to the nominal increment. The reactions are those of the supports on the body (MPM: the
    columns reaction_<k>_fx/_fy of timeseries.csv, k the boundary condition's index)."""
    start = wallclock.perf_counter()
    case, model = _case_and_model(case, model, model_options)
    if not model.moving_supports:
        raise ValueError(
            f"{case.file}: /boundary_conditions: no support has a velocity "
            "(displacement control needs a moving support)"
        )
    end_time = end_time or case.end_time
    method = initial_stress_method or case.initial_stress
    columns = ["time"]
    for k in model.moving_supports:
        columns += [f"displacement_{k}_{c}" for c in "xy"]
        columns += [f"reaction_{k}_f{c}" for c in "xy"]
    result = DrivenResult(model, columns)
    result.newton_iterations += initial_stress(
        model, method, case.k0, gravity_steps, rtol, min_step
    )

    def record():
        row = [model.time]
        reactions = model.reactions()
        for k in model.moving_supports:
            row += list(case.boundary_conditions[k].displacement(model.time))
            row += list(reactions[k])
        result.series.append(row)
        if on_step:
            on_step(model, model.time)

    record()
    nominal = end_time / max(steps, 1)
    step = nominal
    while model.time < end_time - 1e-12 * end_time:
        trial = min(model.time + step, end_time)
        for k, load in enumerate(case.loads):
            model.load_fractions[k] = time_function_factor(load.time_function, trial)
        try:
            result.newton_iterations += model.solve_step(
                1.0, 1.0, rtol, max_iterations, time=trial
            )
        except NoConvergence:
            step *= 0.5
            if step < min_step * end_time:
                result.converged_to_end = False
                break
            continue
        record()
        step = min(2.0 * step, nominal)
    result.runtime = wallclock.perf_counter() - start
    return result


# ---------------------------------------------------------------------------- explicit dynamics
@dataclass
class ExplicitResult:
    model: Model
    dt: float
    n_steps: int
    # (t, load kPa, settlement m, kinetic energy kJ)
    series: list = field(default_factory=list)
    runtime: float = 0.0
    snapshots: dict = field(default_factory=dict)  # time -> boundary loops
    probe_history: dict = field(default_factory=dict)  # probe name -> [(t, ux, uy)]


def run_explicit(
    case,
    end_time=None,
    initial_stress_method=None,
    snapshot_times=(),
    series_interval=None,
    model=None,
    **model_options,
):
    """Lumped-mass explicit dynamics (central differences), P1 triangles (one point per cell)
    or Q1 quadrilaterals (2 x 2 points) by default.

    The initial stress is found statically (zero: none; k0: K0 field; gravity: static gravity
    loading on the same mesh, displacements reset). The loads follow their time functions
    (constant or ramp); gravity follows gravity.ramp_time when the method is zero. Local
    (Cundall) damping with solver.damping. Time step: time.dt or cfl x (smallest element
    height: triangles 2 A / longest edge, quads A / longest edge) / c_p. Small strain unless
    updated_lagrangian=True (mesh moved every step). Degree 2 is refused: the row-sum lumped
    mass of P2 triangles has zero and negative entries."""
    import ufl
    from dolfinx import fem

    start = wallclock.perf_counter()
    model_options.setdefault("degree", 1)
    case, model = _case_and_model(case, model, model_options)
    if model.degree != 1:
        raise ValueError("explicit mode needs degree 1 (lumped mass)")
    refuse_moving_supports(case, "explicit")
    method = initial_stress_method or case.initial_stress
    if method != "zero":
        initial_stress(model, method, case.k0, 1)
    v_test = ufl.TestFunction(model.V)
    ones = fem.Function(model.V)
    ones.x.array[:] = 1.0
    mass_form = fem.form(model.rho * ufl.inner(ones, v_test) * model.dx)
    mass = fem.petsc.assemble_vector(
        mass_form
    ).array.copy()  # row sums of the consistent mass
    # critical time step
    height = model.cell_heights()
    g = case.g if case.g > 0 else 9.81
    cp = max(
        np.sqrt(m.material.constrained_modulus / (m.material.unit_weight / g))
        for m in model.models
        if m.material.unit_weight > 0
    )
    dt = case.dt if case.dt else case.cfl * height.min() / cp
    end_time = end_time or case.end_time
    n_steps = int(np.ceil(end_time / dt - 1e-9))
    dt = end_time / n_steps
    velocity = np.zeros_like(model.u.x.array)
    fixed = model.constrained
    alpha = case.damping
    result = ExplicitResult(model, dt, n_steps)
    probe = "load0_centre" if "load0_centre" in model.probes else None
    base = model.probe_displacement(probe)[1] if probe else 0.0
    snapshot_steps = {int(round(t / dt)): t for t in snapshot_times}
    series_every = max(1, int(round((series_interval or end_time / 200) / dt)))
    grav_now = 1.0 if method != "zero" else None

    def gravity_at(t):
        if grav_now is not None:
            return grav_now
        return (
            min(1.0, t / case.gravity_ramp_time) if case.gravity_ramp_time > 0 else 1.0
        )

    model.load_factor = 1.0  # each load follows its own time function

    for n in range(n_steps + 1):
        t = n * dt
        model.gravity_factor.value = gravity_at(t)
        for k, load in enumerate(case.loads):
            model.load_fractions[k] = time_function_factor(load.time_function, t)
        model._to_quadrature(model.sig_q, model.stress, 4)
        # f_int - f_ext (zero on fixed dofs)
        residual = model._assemble_residual().array
        force = -residual
        if n % series_every == 0 or n == n_steps:
            ke = 0.5 * np.sum(mass * velocity**2)
            settle = base - model.probe_displacement(probe)[1] if probe else 0.0
            first_load = (
                case.loads[0].magnitude * model.load_fractions[0] if case.loads else 0.0
            )
            result.series.append((t, first_load, settle, ke))
            for name in model.probes:
                ux, uy = model.probe_displacement(name)
                result.probe_history.setdefault(name, []).append((t, ux, uy))
        if n in snapshot_steps:
            result.snapshots[snapshot_steps[n]] = model.boundary_loops()
        if n == n_steps:
            break
        if alpha > 0:
            force = force - alpha * np.abs(force) * np.sign(velocity)
        velocity += dt * force / mass
        velocity[fixed] = 0.0
        model.du.x.array[:] = dt * velocity
        grad = model._increment_gradient()
        stress, kappa, _ = model._constitutive(grad)
        model._commit(stress, kappa)
    result.runtime = wallclock.perf_counter() - start
    return result


# ---------------------------------------------------------------------------- outputs
def write_boundary_csv(loops, path):
    """`loop,x,y`: counter-clockwise outer loops, first point lowest-then-leftmost."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["loop", "x", "y"])
        for k, pts in enumerate(loops):
            for x, y in pts:
                w.writerow([k, f"{x:.10g}", f"{y:.10g}"])


def write_table_csv(columns, rows, path):
    """A header of `columns`, then each row's numbers to 10 significant digits."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        for row in rows:
            w.writerow([f"{v:.10g}" for v in row])


def write_curve_csv(curve, path):
    write_table_csv(["load", "settlement", "settlement_total"], curve, path)


def write_series_csv(series, path):
    write_table_csv(["time", "load", "settlement", "kinetic_energy"], series, path)


class FieldWriter:
    """XDMF (HDF5) fields: displacement (P1 nodal), stress and kappa (cell averages)."""

    def __init__(self, model: Model, path):
        from dolfinx import fem, io
        from mpi4py import MPI

        self.model = model
        msh = model.mesh
        self.V1 = fem.VectorFunctionSpace(msh, ("CG", 1))
        self.u1 = fem.Function(self.V1, name="displacement")
        dg0v = fem.VectorFunctionSpace(msh, ("DG", 0), dim=4)
        self.sig = fem.Function(dg0v, name="stress_xx_yy_xy_zz")
        self.kap = fem.Function(
            fem.FunctionSpace(msh, ("DG", 0)), name="plastic_strain"
        )
        self.sig_dofs = dg0v.dofmap.list.array.reshape(model.n_cells)
        self.kap_dofs = self.kap.function_space.dofmap.list.array.reshape(model.n_cells)
        self.file = io.XDMFFile(MPI.COMM_SELF, str(path), "w")
        self.file.write_mesh(msh)

    def write(self, t):
        m = self.model
        self.u1.interpolate(m.u)
        self.sig.x.array.reshape(-1, 4)[self.sig_dofs] = m.cell_average(m.stress)
        self.kap.x.array[self.kap_dofs] = m.cell_average(m.kappa[:, None])[:, 0]
        for func in (self.u1, self.sig, self.kap):
            self.file.write_function(func, t)

    def close(self):
        self.file.close()
