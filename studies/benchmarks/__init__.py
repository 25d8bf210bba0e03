"""Problems with known answers: is the loaded MPM right where we can know it exactly?

What it measures:

* ``column``: an elastic column (1 m x 5 m, rollers on the sides, fixed base) loaded from zero
  stress by its weight and a 50 kPa surcharge (both ramped over 0.5 s, damped to rest): top
  settlement against q H / M + gamma H^2 / (2 M) (small strain; the large-strain value of the
  Jaumann-rate model is shown beside it) and syy against -(q + gamma (H - y0)) at every point
  (y0 its initial height: the weight above a material point does not change);
* ``strip``: a weightless elastic block (20 m x 10 m) under a 2 m strip of 10 kPa: sigma_z under
  the centre at depths b..4b against the elastic half-space strip solution
  q / pi (alpha + sin alpha) (the finite, fixed-base block differs most at depth);
* ``prandtl``: a smooth strip footing of half-width b on weightless, nearly incompressible
  Tresca soil (nu = 0.49, E = 1e4 kPa), half model, 8 cells under b, the pressure ramped on
  the detected top from 0 to 1.2 (2 + pi) c over 16 s per m of b: the collapse pressure (where
  the tangent stiffness dq/ds falls below 5 % of its initial value) against Prandtl's
  (2 + pi) c, for c = 10 and 20 kPa and b = 1 and 2 m, on the MPM (uGIMP, and quadratic
  B-splines on a grid whose edges are the symmetry plane, base and far side) and the UL-FEM,
  all with anti-locking (``solver.anti_locking: "bbar"``), and once on the MPM without it;
* ``softening``: a plane-strain compression test of a softening specimen (1 m x 2 m, Tresca,
  c 20 -> 10 kPa over a plastic strain of 0.2, a weaker square of c 18 kPa at a base corner to
  start the shear band; smooth platens, the top one moving down 0.08 m over 2 s: displacement
  control, moving supports) on grids of h = 1/16, 1/32, 1/64 m (quadratic B-splines, the
  platens on the grid's edges): with one law on every grid the band that localises thins with h
  and the specimen softens faster per metre of shortening (mesh dependence); with
  ``materials[].softening_length`` = 1/32 m the law's plastic strains are scaled by L / h (the
  fracture-energy regularisation). The force-shortening curves of both, the peak (2 c W), and
  each law's spread over the grids of the shortening at which the force has fallen halfway
  from the peak to the residual 2 c_r W. The same test on the dolfinx model (P2 triangles of
  h = 1/16, 1/32, 1/48 m, static, the top platen's displacement prescribed on its mesh nodes:
  ``run_driven``), the same two laws (its regularisation scales by L / element size);
* ``constraint``: a 1 m square block turned 30 degrees to the grid (a lattice of 2 x 2 points
  per cell area, turned with it), 0.01 m of normal displacement on one face and zero on the
  three others through constraints on the detected boundary (``constraints[]``, the penalty
  method and Nitsche's): uniaxial strain, sigma_nn = (lambda + 2 mu) ln(0.99) (the solver's
  rate form integrates the stretching; small strain's -0.01 is 0.5 % less). The interior's
  mean sigma_nn and the loaded face's reaction against it, for penalty factors 1 to 1000 at
  h = L / 16 with each method (the penalty method's error, about h / (factor L), falling as
  the penalty grows; Nitsche's, consistent, flat from factor 4) and for h = L / 8, L / 16,
  L / 32 with each method at the default factor 100, with the constraints' cost per step;
* ``footing``: a rigid smooth strip footing (b = 1 m, 8 cells under b) pushed at 0.0375 m/s
  into the Prandtl benchmark's weightless Tresca soil (c = 10 kPa) to s = 0.14 b: through a
  constraint on the detected top under it (normal velocity; the penalty method at factors 16
  and 100, Nitsche's at 16; the first again at 1/2, 1/4 and 1/8 of the speed and with 16
  cells under b), as a moving support on the grid's top nodes, on the UL-FEM (its mesh nodes;
  also with 16 elements under b) and on the dolfinx model (static): the reaction pressure
  against (2 + pi) c along the settlement, its plateau's mean over s / b in [0.03, 0.12]
  (issue 25 must-show 2) and its mean over windows of s / b, where the constraint is compared
  with the UL-FEM of the same h (the reaction rises along the settlement on both: the footing
  sinks into its heave); the constraint at factor 16 also on the default shape functions, at 8
  and 16 cells under b; per constraint run the deepest dip of the reaction, and each 8-cell run
  against its 16-cell twin window by window (issue 45 must-show 4);
* ``disk``: a plane-strain elastic disk (R = 2 m, centre node fixed) under a uniform pressure
  of 10 kPa applied as a follower pressure on its detected boundary (improved detector, every
  step): the uniform radial strain against the closed form -p (1 + nu)(1 - 2 nu) / E, the test
  of traction on a curved boundary; and the net force of the pressure (0 on a closed curve).

Why: they check the loading and the solver apart from the boundary detection's accuracy
(column, strip and footing loaded on the grid-aligned top), then with it (disk).

Reproduce: ``make study-benchmarks`` = ``/usr/bin/python3 -m studies benchmarks [--quick]``
(quick: column, disk and the constraint at the default penalty). Cases are built by this package from the README's case schema
(h = 0.25 m but for the footings). Writes ``benchmarks.csv/.md``, ``prandtl.csv/.md``, ``column_stress.png``,
``strip_sigma_z.png``, ``prandtl.png``, ``softening.csv/.md``, ``softening.png``,
``footing.csv/.md``, ``footing.png`` and
``energy_ledger.png`` (the energy ledger of each
run, with the metric ``benchmarks.<name>.energy_identity_rel``).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from studies.common.ledger import plot_energy_ledger, relative_energy_error
from studies.common.outcome import Metric, StudyOutcome
from studies.common.outputs import read_timeseries
from studies.common.parallel import parallel_map
from studies.common.paths import PrerequisiteMissing, tool_path
from studies.common.runner import RunFailed, run_dolfinx, run_mpm
from studies.common.study import missing_reason
from studies.common.tables import save_figure, write_table
from studies.benchmarks.common import (
    H,
    ELASTIC,
    COLUMN,
    STRIP,
    PRANDTL,
    SOFTENING,
    FOOTING,
    DISK,
    CONSTRAINT,
    QUICK_BENCHMARKS,
    ALL_BENCHMARKS,
    EXPECTED_METRICS,
    _missing,
)
from studies.benchmarks.elastic import (
    column_case,
    strip_case,
    disk_case,
    column_read_outs,
    _column,
    _strip,
    _disk,
)
from studies.benchmarks.prandtl import (
    prandtl_case,
    prandtl_curve,
    prandtl_jobs,
    collapse_pressure,
    _prandtl,
)
from studies.benchmarks.footing import (
    footing_case,
    footing_ramp,
    footing_jobs,
    footing_speedup,
    footing_cells,
    footing_curve,
    footing_plateau_line,
    footing_against_ulfem,
    footing_against_refined,
    footing_dip,
    _footing,
)
from studies.benchmarks.constraint import (
    constraint_lattice,
    constraint_case,
    constraint_jobs,
    constraint_exact,
    constraint_measures,
    _constraint,
)
from studies.benchmarks.softening import (
    softening_case,
    softening_speed,
    softening_curve,
    dolfinx_softening_curve,
    half_softening_shortening,
    softening_jobs,
    _softening,
)


# The benchmarks' cases, parameters and measures, as the other studies and the tests use them.
__all__ = [
    "H",
    "ELASTIC",
    "COLUMN",
    "STRIP",
    "PRANDTL",
    "SOFTENING",
    "FOOTING",
    "DISK",
    "CONSTRAINT",
    "QUICK_BENCHMARKS",
    "ALL_BENCHMARKS",
    "EXPECTED_METRICS",
    "column_case",
    "strip_case",
    "disk_case",
    "column_read_outs",
    "prandtl_case",
    "prandtl_curve",
    "prandtl_jobs",
    "collapse_pressure",
    "footing_case",
    "footing_ramp",
    "footing_jobs",
    "footing_speedup",
    "footing_cells",
    "footing_curve",
    "footing_plateau_line",
    "footing_against_ulfem",
    "footing_against_refined",
    "footing_dip",
    "constraint_lattice",
    "constraint_case",
    "constraint_jobs",
    "constraint_exact",
    "constraint_measures",
    "softening_case",
    "softening_speed",
    "softening_curve",
    "dolfinx_softening_curve",
    "half_softening_shortening",
    "softening_jobs",
    "run",
]


def _run(job):
    """The output folder of a (case, solver) job, or {"missing": what} when pfm-mpm rejects a
    key it does not support yet, so the other benchmarks still run. A footing run gives
    {"curve": its prandtl_curve, "timeseries": ...} at once: its outputs (about 250 MB) are
    more than the run cache keeps (PFM_CACHE_MAX_MB), which may drop them before the study reads
    them. A footing run that stops (a UL-FEM element inverted past the collapse, a rigid
    footing's run past its stable settlement) is a result: its outputs up to the stop. A job
    (case, "dolfinx", steps) runs the dolfinx model in static mode."""
    case, solver = job[:2]
    footing = case["title"].startswith("benchmark Prandtl")
    stop_is_result = footing or case["title"].startswith("benchmark footing")
    try:
        if solver == "dolfinx":  # a stop (exit 3: Newton failed) is a result up to then
            arguments = ["--mode", "static", "--no-fields", "--min-step", "1e-5"]
            arguments += ["--steps", job[2]]
            return str(run_dolfinx(case, arguments, accept=(0, 3)).out)
        out = run_mpm(case, threads=1, solver=solver, allow_stopped=stop_is_result).out
        if footing:
            return {
                "curve": prandtl_curve(out, case),
                "timeseries": read_timeseries(out),
            }
        return str(out)
    except (RunFailed, PrerequisiteMissing) as failure:
        reason = missing_reason(failure)
        if reason is not None:
            return {"missing": reason}
        raise


def run(context) -> StudyOutcome:
    context.tools.append(tool_path("pfm-mpm"))
    names = QUICK_BENCHMARKS if context.quick else ALL_BENCHMARKS
    builders = {"column": column_case, "strip": strip_case, "disk": disk_case}
    jobs = {}
    for name in names:
        if name == "prandtl":
            jobs.update(prandtl_jobs())
        elif name == "softening":
            jobs.update(softening_jobs())
        elif name == "constraint":
            jobs.update(constraint_jobs(context.quick))
        elif name == "footing":
            jobs.update(footing_jobs())
        else:
            jobs[name] = (builders[name](), "mpm")
    outs = dict(
        zip(
            jobs,
            parallel_map(
                _run,
                list(jobs.values()),
                context.options.jobs,
                context.options.scheduler,
                "benchmark runs",
            ),
        )
    )
    outcome = StudyOutcome(study="benchmarks")
    rows, not_run = [], []

    def add(benchmark, quantity, ours, exact, unit, metric=None):
        error = abs(ours - exact) / abs(exact)
        rows.append(
            {
                "benchmark": benchmark,
                "quantity": quantity,
                "mpm": ours,
                "analytic": exact,
                "unit": unit,
                "rel_error": error,
            }
        )
        if metric:
            outcome.metrics.append(
                Metric(f"benchmarks.{benchmark}.{metric}", error, "1")
            )

    functions = {"column": _column, "strip": _strip, "disk": _disk}  # prandtl: below
    for name in names:
        try:
            if name == "prandtl":
                _prandtl(outs, jobs, outcome, context.folder)
            elif name == "softening":
                _softening(outs, outcome, context.folder)
            elif name == "constraint":
                _constraint(outs, jobs, add, outcome, context.folder)
            elif name == "footing":
                _footing(outs, jobs, outcome, context.folder)
            else:
                functions[name](outs[name], add, outcome, context.folder)
        except PrerequisiteMissing as missing:
            not_run.append(f"{name}: needs {missing.needs}")
    if not rows:
        raise PrerequisiteMissing("; ".join(not_run) or "benchmark outputs")
    # One energy ledger per benchmark (the Prandtl MPM run of the first c and b).
    first = {}
    for key, run in outs.items():
        first.setdefault(key.split("/")[0], run)
    _energy_ledgers(first, outcome, context.folder)
    outcome.tables.append(
        write_table(
            context.folder,
            pd.DataFrame(rows),
            "benchmarks",
            "Benchmarks against closed-form solutions",
        )
    )
    if not_run:
        outcome.reason = "partly not run: " + "; ".join(not_run)
    return outcome


def _energy_ledgers(outs: dict, outcome: StudyOutcome, folder: Path):
    """energy_ledger.png, a panel per benchmark run, and the identity's closure of each run
    (largest |energy_error| over the largest term, every time-series row)."""
    import matplotlib.pyplot as plt

    series = {
        name: run["timeseries"] if isinstance(run, dict) else read_timeseries(run)
        for name, run in outs.items()
        if not _missing(run)
    }
    if not series:
        return
    figure, axes = plt.subplots(
        len(series), 1, figsize=(7, 3.2 * len(series)), squeeze=False
    )
    for axis, (name, table) in zip(axes[:, 0], series.items()):
        plot_energy_ledger(axis, table, name)
        outcome.metrics.append(
            Metric(
                f"benchmarks.{name}.energy_identity_rel",
                relative_energy_error(table),
                "1",
                "largest |energy_error| / largest ledger term",
            )
        )
    figure.tight_layout()
    outcome.figures.append(
        save_figure(
            folder, figure, "energy_ledger", "Energy ledger of each benchmark run"
        )
    )
