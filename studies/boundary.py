"""How far the detected boundary is from the true one (thesis 5.5.2, 6.2.5, 6.3.1).

What it measures: the distance between a detected boundary and the boundary of the
updated-Lagrangian FEM (UL-FEM: the MPM's own step without the Eulerian reset; its outer mesh
boundary is exact) for the slope and the bearing block (q_v = 100 kPa on [5, 10] m, applied on
the detected boundary), each from a zero-stress start (the thesis's), a K0 and a
gravity-loading start, and the slope with 50 kPa on 5 m of its top from 1 m behind the crest,
applied at once on the detected boundary from zero stress (6.3.1, fig. 6.31), at
t = 0, 0.625, 1.25 s (the thesis's comparison times; the full study adds 1.875 and 2.5 s for
the slope; the loaded block collapses soon after 1.25 s, its runs end there): mean,
RMS and max (Hausdorff), overall and per region (top, face, crest, toe, loaded strip, bottom;
see studies.metrics), in metres and in units of the cell size h, over the free surface: the
parts of both boundaries within 1.5 h of the grid edges (the fixed base and roller sides, where
the body rests on the edge of the detectors' field grid) are left out. Two measures are kept apart:

* ``detector_only``: the detector run on the UL-FEM's own material points (its Gauss points,
  from particles.h5, through ``pfm-mpm detect``) against the UL-FEM mesh boundary: the error of
  the detector alone;
* ``total``: the boundary the MPM run detects on its own points (``boundary_<step>.csv``)
  against the UL-FEM boundary: detector error plus the difference between MPM and FEM motion.

For every detector: the thesis PFM plain (fixed kernels, no filter, contour level 0) and as the
thesis ran it (deformed kernels within the size limits, Gaussian filter, lowered contour level:
studies.common.detectors.THESIS_FINAL_PFM), improved PFM, SMM, VOF, density and the library
baseline (scikit-image; it does not run inside pfm-mpm, so its "total" is computed on the
particles of the improved-PFM run). The loaded block and slope detect every step (their load
follows the boundary); the unloaded slope only at the output steps (same boundaries, a fraction
of the cost). Loaded runs also give the traction error from ``timeseries.csv``: the applied
vertical force against the exact resultant of the load on the detected curve, that resultant
against q (x1 - x0) (eq. 6.13), and the force lost on nodes of empty cells (6.2); the block
runs the nodal forces at the outputs (figs. 6.6, 6.14, ``nodal_forces_<case>_<detector>.png``,
and from zero stress once more with the points at the cells' Gauss points, fig. 6.13);
and the detection cost per call (run.json ``summary.detection``).

Constraints (issue 25): the benchmarks study's block turned 30 degrees to the grid, compressed
by 0.01 m through constraints on its detected faces (penalty factor 100, h = L / 16), held on
each in-run detector's boundary in turn: the loaded and opposite faces' reactions and the
interior stress against uniaxial strain, the rms gap and the costs per step
(``constraint.csv/.md``, metrics ``boundary.constraint.<detector>.reaction_rel_error``). A
detector's boundary off the material by delta moves the held face: about delta / L of error.

Starts. ``zero``: the thesis's, no initial stress: gravity acts from t = 0 and the body settles
under it while it is compared (the thesis's figures are for this start). ``k0``: the K0 stress
of the case reader; on the thesis's soils the K0 state violates Tresca below about 2.4 m (block,
nu = 0.15) and 3.9 m (slope), so the first steps yield there. ``gravity``: the damped
gravity-loading procedure, stopped at a kinetic-energy ratio of 1e-2: with the softening soil
(cohesion 20 -> 10 -> 5 kPa) the MPM's ratio levels off near 5e-3 and never reaches the default
1e-6 (there is no static equilibrium once softening starts, see fem_reference/README.md), and
the deformed state it reaches is the start (t = 0). The two solvers stop at different stages of
that collapse: on the slope the MPM reaches the ratio after ~240 steps (crest still near 9.3 m),
the UL-FEM after ~2100 steps (crest down to ~8.6 m), so the ``total`` measure of the gravity
cases compares two different starting states (about 1.4 m apart at t = 0); ``detector_only`` is
not affected.

Why: the thesis judged its boundary by eye (figures 5.33, 5.34: ~0.3 m on the face at t = 0,
~0.15-0.2 m at 0.625 s); this study gives the numbers, per region, and separates the detector's
own error from the solver's.

Reproduce: ``make study-boundary`` = ``/usr/bin/python3 -m studies boundary [--quick]``
(quick: slope and block from K0, the thesis PFM plain and as run and the improved PFM, t = 0
and 0.625 s). Needs
``pfm-mpm`` (``run`` with a detection block, ``run --solver ulfem`` or ``pfm-ulfem``,
``detect``), ``cases/thesis55_slope_dynamic_zero_start.json`` and ``cases/thesis62_bearing_dynamic_zero_start.json``. Writes
``boundary_errors.csv/.md`` (one row per case, detector, measure, time, region),
``summary.csv/.md`` (overall max and RMS in h), ``traction.csv/.md``, ``detectors.csv/.md``
(which detectors ran), ``constraint.csv/.md`` and ``overlay_<case>_t<time>.png``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from studies import benchmarks
from studies.common import detectors as det
from studies.common.cases import (
    base_case,
    body_polygon,
    cell_size,
    derive,
    inclined_edge,
)
from studies.common.outcome import Headline, Metric, StudyOutcome
from studies.common.outputs import (
    read_boundary,
    read_run,
    read_index,
    read_particles,
    read_summary,
    read_timeseries,
    run_status,
    row_at_time,
    write_detect_input,
)
from studies.common.parallel import parallel_map
from studies.common.paths import tool_path
from studies.common.runner import run_detect, run_mpm
from studies.common.study import missing_reason
from studies.common.tables import save_figure, write_table
from studies.metrics import (
    block_regions,
    boundary_distance,
    grid_edge_band,
    slope_regions,
)
from studies.report.headline import (
    BOUNDARY_CASES,
    COMPARISON_TIMES,
    DETECTORS,
    boundary_key,
    time_key,
)

EXTRA_TIMES = (1.875, 2.5)  # s, full study, slope only: the table, not the headline
# The loaded block collapses: its MPM runs stop (CFL) between 1.3 and 2.4 s and the UL-FEM
# inverts an element near 1.1-1.5 s, so it runs to the thesis's last comparison time only.
BLOCK_END_TIME = 1.25  # s
OUTPUT_INTERVAL = 0.625  # s; every comparison time is a multiple
# Outputs land on the first step at or past a multiple of the interval (dt ~0.004-0.011 s);
# a run that stopped early has its last output at the stop, which must not stand in for a
# later comparison time.
TIME_TOLERANCE = 0.05  # s
BLOCK_PRESSURE = 100.0  # kPa, the middle q_v of table 6.2
# The boundary on the grid edges (fixed base, roller sides) is left out: the detectors' field
# grid ends there (their contours end on it, or show scallops along it) while the UL-FEM mesh
# boundary runs along it; 1.5 h also covers the detectors' corner artefacts.
EDGE_BAND_CELLS = 1.5
GRAVITY_START = {"method": "gravity", "kinetic_energy_ratio": 1e-2}
K0_START = {"method": "k0"}
OUTPUTS_ONLY = 1_000_000  # detection.every_steps: only the output steps detect


@dataclass
class BoundaryCase:
    name: str
    base: str  # cases/<base>.json
    kind: str  # "slope" or "block"
    overrides: dict = field(default_factory=dict)
    # slope: a SLOPE_PRESSURE load over SLOPE_LOAD_WIDTH on the detected top, its near edge this
    # far (m) behind the crest (thesis 6.3.1); None: unloaded
    load_behind_crest: float | None = None

    @property
    def loaded(self) -> bool:
        return self.kind == "block" or self.load_behind_crest is not None


SLOPE_PRESSURE = 50.0  # kPa, table 6.3
SLOPE_LOAD_WIDTH = 5.0  # m


SLOPE = "thesis55_slope_dynamic_zero_start"  # the thesis cases, chapter 5 and 6.2
BLOCK = "thesis62_bearing_dynamic_zero_start"
CASES = [
    BoundaryCase("slope_zero", SLOPE, "slope"),  # the base cases start from zero stress
    BoundaryCase("slope_k0", SLOPE, "slope", {"initial_stress": K0_START}),
    BoundaryCase("slope_gravity", SLOPE, "slope", {"initial_stress": GRAVITY_START}),
    BoundaryCase("slope_loaded_zero", SLOPE, "slope", load_behind_crest=1.0),
    BoundaryCase("block_zero", BLOCK, "block"),
    BoundaryCase("block_k0", BLOCK, "block", {"initial_stress": K0_START}),
    BoundaryCase("block_gravity", BLOCK, "block", {"initial_stress": GRAVITY_START}),
]
assert [c.name for c in CASES] == [name for name, _ in BOUNDARY_CASES]
QUICK_CASES = ("slope_k0", "block_k0")
NODAL_FORCE_DETECTOR = "pfm_thesis_final"  # the thesis's fig. 6.6 came from its PFM
PLACEMENT_CASE = "block_zero"  # the thesis's figs. 6.13, 6.14 compare on its own start
QUICK_DETECTORS = ("pfm_thesis", "pfm_thesis_final", "pfm_improved")
QUICK_TIMES = (0.0, 0.625)

EXPECTED_METRICS = [
    f"boundary.{c.name}.{m}.{time_key(t)}.{d}.max_h"
    for c in CASES
    for m in ("detector_only", "total")
    for t in COMPARISON_TIMES
    for d, _ in DETECTORS
] + [
    f"boundary.{c.name}.traction.{d}.total_force_rel_error"
    for c in CASES
    if c.loaded
    for d, _ in DETECTORS
    if det.in_run(d)
]


def block_load(pressure: float = BLOCK_PRESSURE) -> dict:
    """The bearing block's q_v on [5, 10] m, on the detected boundary (linear curve, exact
    integration, the thesis's fixed interval), applied at once as in the thesis."""
    return {
        "type": "vertical_pressure",
        "pressure": pressure,
        "x_range": [5.0, 10.0],
        "apply_on": "detected_boundary",
        "time_function": {"type": "constant"},
    }


def slope_load(base: dict, behind_crest: float) -> dict:
    """SLOPE_PRESSURE over SLOPE_LOAD_WIDTH on the slope's detected top, its near edge
    `behind_crest` m behind the crest, applied at once (thesis 6.3, table 6.3)."""
    crest, toe = inclined_edge(body_polygon(base))
    away = 1.0 if crest[0] > toe[0] else -1.0  # from the face into the top
    near = crest[0] + away * behind_crest
    far = near + away * SLOPE_LOAD_WIDTH
    return {
        "type": "vertical_pressure",
        "pressure": SLOPE_PRESSURE,
        "x_range": [min(near, far), max(near, far)],
        "apply_on": "detected_boundary",
        "time_function": {"type": "constant"},
    }


def study_case(spec: BoundaryCase, detector, end_time: float) -> dict:
    """The case of one run; ``detector`` None gives the UL-FEM reference (no detection)."""
    base, _ = base_case(spec.base)
    overrides = derive(
        spec.overrides,
        {
            "time": {"end_time": end_time},
            "output": {"interval": OUTPUT_INTERVAL, "timeseries_interval": 0.025},
        },
    )
    if spec.kind == "block":
        overrides["loads"] = [block_load()]
        # The nodal forces of the load at the outputs, for the figure of thesis fig. 6.6.
        overrides["output"]["nodal_loads"] = True
    if spec.load_behind_crest is not None:
        overrides["loads"] = [slope_load(base, spec.load_behind_crest)]
    if detector is not None:
        # An unloaded slope's boundary does not act on its motion: detect at the outputs
        # only (every step would cost ~20 MPM steps per step with the improved detector).
        every = 1 if spec.loaded else OUTPUTS_ONLY
        overrides["detection"] = det.detection_block(detector, every_steps=every)
    case = derive(base, overrides)
    case["title"] = f"boundary study: {spec.name}" + (
        f", {detector}" if detector else ", UL-FEM reference"
    )
    return case


def case_end(spec: BoundaryCase, end_time: float) -> float:
    return min(end_time, BLOCK_END_TIME) if spec.kind == "block" else end_time


def regions_of(case: dict, kind: str, h: float):
    polygon = body_polygon(case)
    load = case["loads"][0]["x_range"] if case.get("loads") else None
    if kind == "slope":
        crest, toe = inclined_edge(polygon)
        return slope_regions(crest, toe, radius=2 * h, load_range=load)
    top = max(p[1] for p in polygon)
    # A vertical window of half the strip's width: the hole under the load sinks metres below
    # the initial top, and the loaded strip must still hold it.
    load = load or (0.0, 0.0)
    return block_regions(top, load, band=max(2 * h, 0.5 * (load[1] - load[0])))


def _guarded(function, task):
    """{"value": result} or {"error": text, "missing": bool}: one failed run must not stop a
    sweep; a missing prerequisite (a detector pfm-mpm does not know yet) is kept apart.
    """
    try:
        return {"value": function(task)}
    except (
        Exception
    ) as error:  # noqa: BLE001 - returned to the caller, which records it
        reason = missing_reason(error)
        text = reason if reason is not None else f"{type(error).__name__}: {error}"
        return {
            "error": str(text).splitlines()[0][:300],
            "missing": reason is not None,
            "stderr": getattr(error, "stderr", "")[-1500:],
        }


def _run_task(task: dict):
    """A run that stops early (exit code 3: an inverted UL-FEM element, a CFL violation) keeps
    its outputs up to then: the later comparison times are simply missing."""
    return _guarded(
        lambda t: str(
            run_mpm(t["case"], threads=1, solver=t["solver"], allow_stopped=True).out
        ),
        task,
    )


def _detect_task(task: dict):
    return _guarded(
        lambda t: str(
            run_detect(Path(t["particles"]), t["config"], library=t["library"]).out
            / "boundary.csv"
        ),
        task,
    )


@dataclass
class _Plan:
    """What one run of the study compares: the cases, the detectors, the comparison times and
    the detectors that run inside pfm-mpm (hosts; the library's runs on its host's points).
    """

    cases: list
    detectors: list
    times: tuple
    end_time: float
    hosts: list


@dataclass
class _Problems:
    """The comparisons that could not be made: per (case, detector, measure) the reason, the
    times without a reference output, and the rows of the detectors table; failures go to
    error.log in `folder`."""

    folder: Path
    reasons: dict = field(default_factory=dict)  # (case, detector, measure) -> reason
    missing_times: list = field(
        default_factory=list
    )  # (case, detector, measure, time, reason)
    status_rows: list = field(default_factory=list)

    def add(self, case, detector, measure, result):
        kind = "not run" if result.get("missing") else "failed"
        self.reasons[(case, detector, measure)] = f"{kind}: {result['error']}"
        self.status_rows.append(
            {
                "case": case,
                "detector": detector,
                "measure": measure,
                "status": kind,
                "reason": result["error"],
            }
        )
        if not result.get("missing"):
            with open(self.folder / "error.log", "a") as log:
                log.write(
                    f"--- {case} {detector} {measure}\n{result['error']}\n"
                    f"{result.get('stderr', '')}\n"
                )


@dataclass
class _Rows:
    """What the comparisons of every case collect: the distance rows, the traction rows and
    the overlays per (case, time)."""

    errors: list = field(default_factory=list)
    traction: list = field(default_factory=list)
    overlays: dict = field(default_factory=dict)


def run(context) -> StudyOutcome:
    context.tools.append(tool_path("pfm-mpm"))
    plan = _plan(context)
    tasks, keys = _simulation_tasks(plan)
    runs = dict(
        zip(
            keys,
            parallel_map(
                _run_task,
                tasks,
                context.options.jobs,
                context.options.scheduler,
                "boundary runs",
            ),
        )
    )
    outcome = StudyOutcome(study="boundary")
    problems = _Problems(context.folder)
    rows = _Rows()
    work = context.folder / "work"
    work.mkdir(exist_ok=True)
    for spec in plan.cases:
        _compare_case(context, plan, spec, runs, work, problems, rows, outcome)
    _headlines_not_run(plan.times, problems, outcome)
    _tables(context.folder, rows, _stopped_runs(runs), problems, outcome)
    _figures(context.folder, plan.cases, runs, dict(zip(keys, tasks)), rows, outcome)
    _constraints(runs, plan.hosts, outcome, context.folder)
    return outcome


def _plan(context) -> _Plan:
    """The cases, detectors and times of the full study or of its quick variant; the case
    files they come from go to the context."""
    quick = context.quick
    cases = [c for c in CASES if not quick or c.name in QUICK_CASES]
    detectors = [d for d, _ in DETECTORS if not quick or d in QUICK_DETECTORS]
    times = QUICK_TIMES if quick else COMPARISON_TIMES + EXTRA_TIMES
    for path in {base_case(c.base)[1] for c in cases}:
        context.case_files.append(path)
    hosts = [d for d in detectors if det.in_run(d)]
    if det.LIBRARY in detectors and det.LIBRARY_HOST not in hosts:
        hosts.append(det.LIBRARY_HOST)
    return _Plan(cases, detectors, times, max(times), hosts)


def _simulation_tasks(plan: _Plan) -> tuple[list, list]:
    """The simulations (tasks for _run_task) and their keys (case, run): one UL-FEM reference
    and one MPM run per in-run detector per case, the constraint block on each detector's
    boundary, and the placement case from the cells' Gauss points."""
    tasks, keys = [], []
    for spec in plan.cases:
        tasks.append(
            {
                "case": study_case(spec, None, case_end(spec, plan.end_time)),
                "solver": "ulfem",
            }
        )
        keys.append((spec.name, "reference"))
        for detector in plan.hosts:
            tasks.append(
                {
                    "case": study_case(spec, detector, case_end(spec, plan.end_time)),
                    "solver": "mpm",
                }
            )
            keys.append((spec.name, detector))
    # Constraints held on each detector's boundary (the benchmarks study's turned block).
    for detector in plan.hosts:
        tasks.append({"case": constraint_case(detector), "solver": "mpm"})
        keys.append(("constraint", detector))
    # Thesis fig. 6.13: the block from zero stress with its points at the cells' Gauss points
    # instead of equally spaced, for the nodal forces of the thesis's PFM.
    gauss = [c for c in plan.cases if c.name == PLACEMENT_CASE]
    if gauss and NODAL_FORCE_DETECTOR in plan.hosts:
        case = study_case(
            gauss[0], NODAL_FORCE_DETECTOR, case_end(gauss[0], plan.end_time)
        )
        case["bodies"][0]["placement"] = "gauss"
        tasks.append({"case": case, "solver": "mpm"})
        keys.append((f"{PLACEMENT_CASE}_gauss", NODAL_FORCE_DETECTOR))
    return tasks, keys


def _stopped_runs(runs: dict) -> list:
    """The rows of the runs that stopped before their end time."""
    return [
        {
            "case": case_name,
            "run": run_name,
            "final_time_s": status["final_time_s"],
            "error": status["error"],
        }
        for (case_name, run_name), result in runs.items()
        if "value" in result
        for status in [run_status(Path(result["value"]))]
        if status["status"] != "completed"
    ]


def _compare_case(context, plan, spec, runs, work, problems, rows, outcome):
    """One case: every detector on the UL-FEM's points and the MPM runs' own boundaries against
    the UL-FEM boundary at each time, and the MPM runs' traction and detection cost."""
    reference_run = runs[(spec.name, "reference")]
    if "error" in reference_run:
        for detector in plan.detectors:
            for measure in ("detector_only", "total"):
                problems.add(
                    spec.name,
                    detector,
                    measure,
                    dict(
                        reference_run,
                        error=f"UL-FEM reference: " f"{reference_run['error']}",
                    ),
                )
        return
    reference_out = Path(reference_run["value"])
    case = study_case(spec, None, case_end(spec, plan.end_time))
    detected_only = _detect_on_reference(context, plan, spec, case, reference_out, work)
    totals = _run_boundaries(context, plan, spec, case, runs, work, problems)
    _distances(
        plan, spec, case, reference_out, detected_only, totals, problems, rows, outcome
    )
    _traction(plan, spec, case, runs, rows, outcome)


def _spacing(case: dict) -> float:
    return cell_size(case) / case["bodies"][0].get("points_per_cell", 2)


def _detect_on_reference(context, plan, spec, case, reference_out, work) -> dict:
    """Detector only: every detector on the UL-FEM's material points at each time; by
    (time, detector), as _detect_task gives them."""
    reference_particles = read_index(reference_out, "particles")
    detect_tasks, detect_keys = [], []
    for time in plan.times:
        row = row_at_time(reference_particles, time, TIME_TOLERANCE)
        if row is None:
            continue
        particles = work / f"{spec.name}_ulfem_points_{time_key(time)}.csv"
        write_detect_input(read_particles(row["file"]), particles)
        for detector in plan.detectors:
            detect_tasks.append(
                {
                    "particles": str(particles),
                    "library": not det.in_run(detector),
                    "config": det.detect_config(detector, case["grid"], _spacing(case)),
                }
            )
            detect_keys.append((time, detector))
    return dict(
        zip(
            detect_keys,
            parallel_map(
                _detect_task,
                detect_tasks,
                context.options.jobs,
                context.options.scheduler,
                f"{spec.name} detect",
            ),
        )
    )


def _run_boundaries(context, plan, spec, case, runs, work, problems) -> dict:
    """Total: the MPM runs' own boundaries at each time (the library's: detected on the host
    run's particles); by (time, detector)."""
    totals, total_tasks, total_keys = {}, [], []
    for detector in plan.detectors:
        host = runs.get(
            (spec.name, detector if det.in_run(detector) else det.LIBRARY_HOST)
        )
        if "error" in host:
            problems.add(spec.name, detector, "total", host)
            continue
        out = Path(host["value"])
        if det.in_run(detector):
            index = read_index(out, "boundary")
            for time in plan.times:
                row = row_at_time(index, time, TIME_TOLERANCE)
                if row is not None:
                    totals[(time, detector)] = {"value": row["file"]}
            continue
        index = read_index(out, "particles")
        for time in plan.times:
            row = row_at_time(index, time, TIME_TOLERANCE)
            if row is None:
                continue
            particles = work / f"{spec.name}_mpm_points_{time_key(time)}.csv"
            write_detect_input(read_particles(row["file"]), particles)
            total_tasks.append(
                {
                    "particles": str(particles),
                    "library": True,
                    "config": det.detect_config(detector, case["grid"], _spacing(case)),
                }
            )
            total_keys.append((time, detector))
    totals.update(
        zip(
            total_keys,
            parallel_map(
                _detect_task,
                total_tasks,
                context.options.jobs,
                context.options.scheduler,
                f"{spec.name} library on MPM points",
            ),
        )
    )
    return totals


def _distances(
    plan, spec, case, reference_out, detected_only, totals, problems, rows, outcome
):
    """The distances of both measures to the UL-FEM boundary at each time: the rows, the
    headline and the metrics at the comparison times, the overlays; a time the reference
    did not reach is recorded as missing with the reason."""
    h = cell_size(case)
    regions = regions_of(case, spec.kind, h)
    ignore = grid_edge_band(case["grid"], EDGE_BAND_CELLS * h)
    reference_boundaries = read_index(reference_out, "boundary")
    reference_status = run_status(reference_out)
    for time in plan.times:
        reference_row = row_at_time(reference_boundaries, time, TIME_TOLERANCE)
        if reference_row is None:
            if time <= case["time"]["end_time"] and reference_status["error"]:
                reason = (
                    f"the UL-FEM reference stopped at t = "
                    f"{reference_status['final_time_s']:.4g} s "
                    f"({reference_status['error'].split(':')[0]})"
                )
                for detector in plan.detectors:
                    for measure in ("detector_only", "total"):
                        problems.missing_times.append(
                            (spec.name, detector, measure, time, reason)
                        )
            continue
        reference = read_boundary(reference_row["file"])
        overlay = {"detector_only": {}, "total": {}}
        for detector in plan.detectors:
            for measure, found in (
                ("detector_only", detected_only.get((time, detector))),
                ("total", totals.get((time, detector))),
            ):
                if found is None:
                    continue
                if "error" in found:
                    problems.add(spec.name, detector, measure, found)
                    continue
                loops = read_boundary(found["value"])
                overlay[measure][detector] = loops
                result = boundary_distance(
                    loops, reference, h=h, regions=regions, ignore=ignore
                )
                for row in result.rows():
                    rows.errors.append(
                        {
                            "case": spec.name,
                            "detector": detector,
                            "measure": measure,
                            "time_s": time,
                            **row,
                        }
                    )
                if time in COMPARISON_TIMES:
                    _distance_headline(
                        spec.name, measure, time, detector, h, result, outcome
                    )
        rows.overlays[(spec.name, time)] = (reference, overlay, ignore)


def _distance_headline(case_name, measure, time, detector, h, result, outcome):
    """The headline's max and rms and the metric max / h of one comparison."""
    stats = result.overall
    outcome.headline += [
        Headline(
            boundary_key(case_name, measure, time, "max"), detector, stats.max, "m"
        ),
        Headline(
            boundary_key(case_name, measure, time, "rms"), detector, stats.rms, "m"
        ),
    ]
    outcome.metrics.append(
        Metric(
            f"boundary.{case_name}.{measure}.{time_key(time)}.{detector}.max_h",
            stats.max / h,
            "h",
        )
    )


def _traction(plan, spec, case, runs, rows, outcome):
    """The traction error (loaded cases) and the detection cost of the case's MPM runs."""
    for detector in [d for d in plan.detectors if det.in_run(d)]:
        host = runs[(spec.name, detector)]
        if "error" in host:
            continue
        out = Path(host["value"])
        detection = read_summary(out).get("detection", {})
        row = {
            "case": spec.name,
            "detector": detector,
            "detect_calls": detection.get("calls"),
            "detect_seconds_per_call": detection.get("seconds_per_call"),
        }
        if spec.loaded:
            row.update(traction_errors(read_timeseries(out), case["loads"][0]))
            if row.get("total_force_rel_error") is not None:
                outcome.metrics.append(
                    Metric(
                        f"boundary.{spec.name}.traction.{detector}.total_force_rel_error",
                        row["total_force_rel_error"],
                        "1",
                    )
                )
                for key in ("total_force_rel_error", "lost_force_rel"):
                    outcome.headline.append(
                        Headline(f"traction.{spec.name}.{key}", detector, row[key], "1")
                    )
        rows.traction.append(row)


def _headlines_not_run(times, problems, outcome):
    """Headline cells of detectors that could not run: "not run" with the reason."""
    have = {(h.quantity, h.detector) for h in outcome.headline}
    for case_name, detector, measure, time, reason in problems.missing_times:
        if time in COMPARISON_TIMES:
            for statistic in ("max", "rms"):
                key = boundary_key(case_name, measure, time, statistic)
                if (key, detector) not in have:
                    outcome.headline.append(
                        Headline(key, detector, None, "m", f"not run: {reason}")
                    )
                    have.add((key, detector))
    for (case_name, detector, measure), reason in problems.reasons.items():
        for time in [t for t in times if t in COMPARISON_TIMES]:
            for statistic in ("max", "rms"):
                key = boundary_key(case_name, measure, time, statistic)
                if (key, detector) not in have:
                    outcome.headline.append(
                        Headline(
                            key,
                            detector,
                            None,
                            "m",
                            reason
                            if reason.startswith("not run")
                            else f"not run: {reason}",
                        )
                    )


def _tables(folder, rows, stopped, problems, outcome):
    """boundary_errors, summary (max and rms in h per time), traction, stopped and detectors;
    the outcome's reason when some comparisons could not be made."""
    if not rows.errors:
        raise RuntimeError(
            "no boundary could be compared: "
            + "; ".join(
                f"{c}/{d}/{m}: {r}"
                for (c, d, m), r in list(problems.reasons.items())[:6]
            )
        )
    errors = pd.DataFrame(rows.errors)
    outcome.tables.append(
        write_table(
            folder,
            errors,
            "boundary_errors",
            "Boundary distance to the UL-FEM boundary, per region",
        )
    )
    overall = errors[errors["region"] == "all"]
    summary = overall.pivot_table(
        index=["case", "measure", "detector"],
        columns="time_s",
        values="max_h",
        aggfunc="first",
    )
    summary.columns = [f"max_h t={c:g}" for c in summary.columns]
    rms = overall.pivot_table(
        index=["case", "measure", "detector"],
        columns="time_s",
        values="rms_h",
        aggfunc="first",
    )
    rms.columns = [f"rms_h t={c:g}" for c in rms.columns]
    outcome.tables.append(
        write_table(
            folder,
            summary.join(rms).reset_index(),
            "summary",
            "Overall max (Hausdorff) and RMS distance, " "in cell sizes h",
        )
    )
    if rows.traction:
        outcome.tables.append(
            write_table(
                folder,
                pd.DataFrame(rows.traction),
                "traction",
                "Traction error and detection cost of " "the MPM runs",
            )
        )
    if stopped:
        outcome.tables.append(
            write_table(
                folder,
                pd.DataFrame(stopped),
                "stopped",
                "Runs that stopped before the end time (their later "
                "comparison times are missing)",
            )
        )
    if problems.status_rows:
        outcome.tables.append(
            write_table(
                folder,
                pd.DataFrame(problems.status_rows).drop_duplicates(),
                "detectors",
                "Detectors or runs that could not be compared",
            )
        )
        missing = sorted({f"{d} ({m})" for (_, d, m), r in problems.reasons.items()})
        failed = [r for r in problems.reasons.values() if r.startswith("failed")]
        outcome.reason = "partly not run: " + ", ".join(missing)
        if failed:
            outcome.reason += " (some failed, see error.log)"


def _figures(folder, cases, runs, task_of, rows, outcome):
    """The load's nodal forces (thesis figs. 6.6, 6.13, 6.14: the block with the thesis's PFM
    as run on every start; on the zero start also with the plain PFM, no filter, fig. 6.14,
    and with the points at the Gauss points, fig. 6.13) and the overlays."""
    figures = [(c.name, NODAL_FORCE_DETECTOR) for c in cases if c.kind == "block"]
    figures += [
        (PLACEMENT_CASE, "pfm_thesis"),
        (f"{PLACEMENT_CASE}_gauss", NODAL_FORCE_DETECTOR),
    ]
    for name, detector in figures:
        if "value" not in runs.get((name, detector), {}):
            continue
        figure = nodal_force_figure(
            Path(runs[(name, detector)]["value"]),
            task_of[(name, detector)]["case"],
            name,
            detector,
        )
        if figure is None:
            continue
        outcome.figures.append(
            save_figure(
                folder,
                figure,
                f"nodal_forces_{name}_{detector}",
                f"{name}, {detector}: the load's nodal forces at the outputs "
                f"(thesis figs. 6.6, 6.13, 6.14); red: nodes too light to carry a load",
            )
        )
    for (name, time), (reference, overlay, ignore) in rows.overlays.items():
        outcome.figures.append(
            save_figure(
                folder,
                overlay_figure(reference, overlay, name, time, ignore),
                f"overlay_{name}_{time_key(time)}",
                f"{name}: detected boundaries and the UL-FEM boundary at t = {time:g} s",
            )
        )


def constraint_case(detector: str) -> dict:
    """The benchmarks study's turned block (its default penalty factor and cell size) with
    `detector` finding the boundary its constraints hold."""
    c = benchmarks.CONSTRAINT
    case = benchmarks.constraint_case(c["default_factor"], c["default_cells"])
    case["detection"] = det.detection_block(detector)
    case["title"] += f", {detector}"
    return case


def _constraints(runs: dict, detectors, outcome: StudyOutcome, folder: Path) -> None:
    """constraint.csv/.md: per detector the turned block's errors and costs
    (benchmarks.constraint_measures), or why there are none (the run failed or stopped), and
    the metrics boundary.constraint.<detector>.reaction_rel_error (|loaded face's reaction /
    exact - 1|)."""
    rows = []
    for detector in detectors:
        result = runs[("constraint", detector)]
        row = {"detector": detector}
        if "error" in result:
            kind = "not run" if result.get("missing") else "failed"
            row["status"] = f"{kind}: {result['error']}"
        else:
            out = Path(result["value"])
            status = run_status(out)
            if status["status"] != "completed":
                row["status"] = (
                    f"stopped at t = {status['final_time_s']:.3g} s: "
                    f"{status['error'][:100]}"
                )
            else:
                row["status"] = "completed"
                row.update(benchmarks.constraint_measures(out))
                outcome.metrics.append(
                    Metric(
                        f"boundary.constraint.{detector}.reaction_rel_error",
                        abs(row["reaction_rel_error"]),
                        "1",
                    )
                )
        rows.append(row)
    outcome.tables.append(
        write_table(
            folder,
            pd.DataFrame(rows),
            "constraint",
            "Constraints held on each detector's boundary: a 1 m block turned 30 degrees, "
            "0.01 m of normal displacement on one face (penalty factor 100, h = L / 16), "
            "errors against uniaxial strain (the rate form's, ln 0.99)",
        )
    )


def traction_errors(series: pd.DataFrame, load: dict) -> dict:
    """Traction diagnostics of a loaded run over the loaded times (|target| at least half its
    largest value): the largest |applied - target| / |target| (quadrature and loss on the
    grid), |target - q (x1 - x0)| / (q (x1 - x0)) (eq. 6.13 on the detected curve) and
    |lost| / |target|."""
    columns = ("load_target_fy", "load_applied_fy", "load_lost_fy")
    if any(c not in series for c in columns):
        return {
            "total_force_rel_error": None,
            "note": "timeseries.csv has no load_* columns",
        }
    loaded = series[
        series["load_target_fy"].abs() >= 0.5 * series["load_target_fy"].abs().max()
    ]
    if loaded.empty or loaded["load_target_fy"].abs().max() == 0.0:
        return {"total_force_rel_error": None, "note": "no load applied"}
    target = loaded["load_target_fy"].abs()
    nominal = load["pressure"] * (load["x_range"][1] - load["x_range"][0])
    return {
        "total_force_rel_error": float(
            (
                (loaded["load_applied_fy"] - loaded["load_target_fy"]).abs() / target
            ).max()
        ),
        "target_vs_nominal_rel": float(((target - nominal).abs() / nominal).max()),
        "lost_force_rel": float((loaded["load_lost_fy"].abs() / target).max()),
        "nominal_kn_per_m": nominal,
    }


def nodal_force_figure(out: Path, case: dict, name: str, detector: str):
    """One panel per output (thesis fig. 6.6): the points near the load, the detected boundary
    and the load's nodal forces as arrows; nodes of mass <= 0.01 of a full cell (those the
    load may not act on: mpm/solver/boundary_coupling.hpp) in red. None when the run wrote no
    nodal forces."""
    import matplotlib.pyplot as plt

    h = float(case["grid"]["cell_size"])
    x0, x1 = case["loads"][0]["x_range"]
    outputs = [
        (o, forces)
        for o in read_run(out).get("outputs", [])
        if "nodal_loads" in o
        for forces in [pd.read_csv(out / o["nodal_loads"])]
        if len(forces)  # none before the first step
    ][:4]
    if not outputs:
        return None
    # t/m^3: the densest material's, unit weight / g (g = 9.81 when gravity is off, as the
    # solver's mass)
    g = float(case.get("gravity", {}).get("g", 9.81)) or 9.81
    density = max(float(m["unit_weight"]) for m in case["materials"]) / g
    particles = read_index(out, "particles")
    figure, axes = plt.subplots(
        len(outputs), 1, figsize=(10, 3.2 * len(outputs)), squeeze=False
    )
    for axis, (entry, forces) in zip(axes[:, 0], outputs):
        frame = particles[particles["step"] == entry["step"]].iloc[0]
        points = read_particles(frame["file"])
        axis.plot(points["x"], points["y"], ".", color="0.7", markersize=2)
        for loop in read_boundary(out / entry["boundary"]):
            closed = loop.drawn()
            axis.plot(closed[:, 0], closed[:, 1], color="tab:blue", linewidth=0.9)
        scale = forces[["fx", "fy"]].abs().to_numpy().max() or 1.0
        light = forces["mass"] <= 0.01 * density * h * h
        for mask, colour in ((~light, "black"), (light, "red")):
            f = forces[mask]
            axis.quiver(
                f["x"],
                f["y"],
                f["fx"] / scale,
                f["fy"] / scale,
                color=colour,
                angles="xy",
                scale_units="xy",
                scale=1.0 / h,
                width=0.002,
            )
        axis.set_xlim(x0 - 2.0, x1 + 2.0)
        top = float(points["y"].max())
        axis.set_ylim(top - 3.0, top + 0.75)
        axis.set_aspect("equal")
        axis.set_title(
            f"{name}, {detector}, t = {entry['time']:.3g} s (largest force "
            f"{scale:.3g} kN/m = one cell)"
        )
    axes[-1, 0].set_xlabel("x [m]")
    figure.tight_layout()
    return figure


def overlay_figure(reference, overlay: dict, name: str, time: float, ignore=None):
    """Two panels (detector only, total), zoomed on the free surface: the reference's points
    outside ``ignore`` with a 1 m margin below and 0.5 m above."""
    import matplotlib.pyplot as plt
    import numpy as np

    figure, axes = plt.subplots(2, 1, figsize=(12, 7.5), sharex=True)
    points = np.vstack([loop.points for loop in reference])
    if ignore is not None:
        free = points[~np.asarray(ignore.contains(points), dtype=bool)]
        points = free if len(free) else points
    for axis, measure in zip(axes, ("detector_only", "total")):
        for label, loops, style in [
            ("UL-FEM", reference, {"color": "black", "linewidth": 2.2})
        ] + [(d, l, {"linewidth": 0.9}) for d, l in overlay[measure].items()]:
            color = None
            for i, loop in enumerate(loops):
                points = loop.drawn()
                (line,) = axis.plot(
                    points[:, 0],
                    points[:, 1],
                    label=label if i == 0 else None,
                    **({"color": color} if color else {}),
                    **style,
                )
                color = line.get_color()
        axis.set_aspect("equal")
        axis.set_xlim(points[:, 0].min() - 0.5, points[:, 0].max() + 0.5)
        axis.set_ylim(points[:, 1].min() - 1.0, points[:, 1].max() + 0.5)
        axis.set_xlabel("x [m]")
        axis.set_title(
            f"{name}, t = {time:g} s: "
            + (
                "detector on UL-FEM points"
                if measure == "detector_only"
                else "MPM + detector"
            ),
            fontsize=9,
        )
        axis.set_ylabel("y [m]")
        axis.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return figure
