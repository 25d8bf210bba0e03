"""How the loaded soil responds to its parameters and to where the load is (thesis 6.2.2-6.2.4,
6.3, figures 6.28-6.30).

What it measures:

* bearing block (15 m x 5 m, q_v on the centre 5 m on the detected boundary, table 6.2), one
  parameter at a time around the thesis's baseline (table 6.2: nu = 0.15, E = 1000 kPa,
  cohesion 20/10/5 kPa, q_v = 50 kPa): Poisson's ratio nu = 0.15, 0.25, 0.35, 0.45; Young's
  modulus E = 1e3, 1e4, 1e5 kPa; strength x1 and x2 (cohesion 20/10/5 -> 40/20/10 kPa);
  q_v = 50, 100, 150 kPa, also with E = 1e4 kPa (6.2.3, fig. 6.18) and with strength x2 (6.2.4,
  fig. 6.21). Read-outs at t = 2.5 s, or, when a run of the sweep stopped (the
  softest and most loaded blocks collapse and violate the CFL condition), for every run of that
  sweep at the last output all of them reached (the stop times in the table): settlement under
  the load centre and hole depth (the surface under the load at t = 0 minus the lowest detected
  boundary point there, down to 1.5 h above the base: a hole through the block reads 4.25 m);
* load-settlement against the independent dolfinx model: the block with a constant cohesion of
  20 kPa (no softening: the softening soil has no static solution, fem_reference/README.md),
  E = 1e3 and 1e4 kPa, the load ramped from 0 to 100 kPa over 4 s (MPM, damping 0.5) and in
  20 static increments (dolfinx, P2, small strain), both from an isotropic K0 = 1 stress (no
  deviator, so the same admissible state in both codes; from a gravity-loading start the two
  procedures leave different plastic states and the comparison measured those instead);
* slope (4 m, 45 degrees) with a 5 m wide 50 kPa load on the detected boundary at distances
  0-6 m behind the crest, on the face and in front of the toe (the thesis's distances, crest to
  the load's edge, positive towards the face: -6 to 0, 5 and 10 m; figs. 6.26, 6.28-6.30):
  hole depth and the height of its bottom, and the crest and toe displacement added by the load
  (loaded minus unloaded run) at the last output time every run reached (up to 2.5 s; at
  100 kPa every loaded slope collapsed and stopped by 1.6 s); from the gravity-loading state
  and (full study only) from the thesis's zero-stress start (``slope_load_position_zero_start``,
  ``slope_surfaces_zero_start``).

Starts: every other run starts from the gravity-loading state (kinetic-energy ratio 1e-2, see
studies.boundary), not from K0: with K0 = nu / (1 - nu) the Tresca block violates the yield
condition below about 2.4 m for nu = 0.15 (|sxx - syy| / 2 > c), so a K0 start would mix the
response to the load with the collapse of the K0 state. The load sweep is also run from zero
stress (``pressure_zero_start``), as the thesis ran it: gravity and load at once. Detection: improved PFM every step with
a fixed field refinement of 4 (its automatic refinement climbs to 10-32 on the deforming block
and costs ~30 times as much; the boundaries agree within 0.014 m up to 0.625 s).

Why: these are the thesis's qualitative findings (more settlement for soft soil, the hole under
the load, the crest lifting for a load ~6 m behind it); we give them as curves, and the dolfinx
comparison says whether the MPM load-settlement response is right.

Reproduce: ``make study-parametric`` = ``/usr/bin/python3 -m studies parametric [--quick]``
(quick: q_v = 50 and 100 kPa; slope offsets 0 and 4 m; load-settlement at E = 1e4 only).
Needs ``pfm-mpm``, ``cases/thesis62_bearing_dynamic_zero_start.json``, ``cases/thesis55_slope_dynamic_zero_start.json`` and
``fem_reference/dolfinx_model``. The three parts run and are reported independently. Writes
``block_sweep.csv/.md``, ``load_settlement.csv/.md``, ``slope_load_position.csv/.md``,
``block_<sweep>.png``, ``load_settlement.png``, ``slope_load_position.png``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from studies.boundary import EDGE_BAND_CELLS, GRAVITY_START
from studies.common.cases import (
    base_case,
    body_polygon,
    cell_size,
    derive,
    inclined_edge,
)
from studies.common.measures import (
    displacement_near,
    scale_cohesion,
    surface_settlement_extrapolated,
)
from studies.common.outcome import Metric, StudyOutcome
from studies.common.outputs import (
    need,
    read_boundary,
    read_index,
    read_particles,
    row_at_time,
    run_status,
)
from studies.common.parallel import parallel_map
from studies.common.paths import tool_path
from studies.common.runner import dolfinx_module_file, run_dolfinx, run_mpm
from studies.common.study import run_parts
from studies.common.tables import save_figure, write_table
from studies.metrics import grid_edge_band

ZERO_START = {"method": "zero"}  # the thesis's: gravity and load at once from no stress
# The thesis's baseline (table 6.2): q_v = 50 kPa.
BLOCK_BASE = {
    "poisson_ratio": 0.15,
    "youngs_modulus": 1.0e3,
    "strength": 1.0,
    "pressure": 50.0,
}
# name -> (parameter, values, the other settings that differ from BLOCK_BASE, and the start):
# one parameter at a time around the baseline, the thesis's combinations, the load on the
# stiffer soil (6.2.3, fig. 6.18) and on the stronger one (6.2.4, fig. 6.21), and the load
# from the thesis's zero-stress start.
BLOCK_SWEEPS = {
    "poisson_ratio": ("poisson_ratio", (0.15, 0.25, 0.35, 0.45), {}),
    "youngs_modulus": ("youngs_modulus", (1.0e3, 1.0e4, 1.0e5), {}),
    "strength": ("strength", (1.0, 2.0), {}),
    "pressure": ("pressure", (50.0, 100.0, 150.0), {}),
    "pressure_at_E_1e4": ("pressure", (50.0, 100.0, 150.0), {"youngs_modulus": 1.0e4}),
    "pressure_at_strength_x2": ("pressure", (50.0, 100.0, 150.0), {"strength": 2.0}),
    "pressure_zero_start": ("pressure", (50.0, 100.0, 150.0), {"start": ZERO_START}),
}
QUICK_BLOCK_SWEEPS = {"pressure": ("pressure", (50.0, 100.0), {})}
END_TIME = 2.5  # s
QUICK_END_TIME = 0.625  # s
OUTPUT_INTERVAL = 0.625  # s
# The improved detector with a fixed refinement of 4 (field cells h / 4): its automatic
# refinement rises to 10-32 on the deforming block and then costs ~30 times as much per call;
# up to 0.625 s the two boundaries of the block agree within 0.014 m.
DETECTOR_BLOCK = {"method": "improved", "improved": {"refinement": 4}}
SLOPE_LOAD_WIDTH = 5.0  # m
# m behind the crest (the load's edge nearest the crest); the top is 11.875 m long, so a 5 m
# load fits up to 6.875 m behind it. Negative: towards the face, the thesis's positive
# distances (fig. 6.28): -5 covers the face (4 m wide) and 1 m in front of the toe, -10 lies
# on the ground in front of the toe, 1 m from it (fig. 6.26).
SLOPE_LOAD_OFFSETS = (-10.0, -5.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
ON_FACE_OFFSET = -5.0
SLOPE_OUTPUT_INTERVAL = 0.3125  # s
QUICK_SLOPE_OFFSETS = (0.0, 4.0)
# kPa. At 100 kPa every loaded slope (offsets 0-6 m) collapsed and stopped (CFL) by 1.6 s.
SLOPE_PRESSURE = 50.0
CURVE = {
    "cohesion": 20.0,
    "pressure": 100.0,
    "ramp_time": 4.0,
    "end_time": 5.0,
    "interval": 0.25,
    "damping": 0.5,
    "steps": 20,
    "compare_at": 50.0,
}
QUICK_CURVE = dict(CURVE, ramp_time=1.0, end_time=1.25, interval=0.125, steps=5)
# An isotropic initial stress (K0 = 1) has no deviator, so it is inside the Tresca surface at
# every depth and both codes start from the same state. From a gravity-loading start the MPM's
# damped dynamic procedure and dolfinx's static one leave different plastic states (the block
# yields below 2.4 m), and the MPM then answered the load twice as stiffly at first.
CURVE_START = {"method": "k0", "k0": 1.0}
CURVE_MODULI = (1.0e3, 1.0e4)
QUICK_CURVE_MODULI = (1.0e4,)

EXPECTED_METRICS = ["parametric.block.base.settlement_rel_diff_dolfinx"]


def _common(
    base: dict, end_time: float = END_TIME, start: dict = GRAVITY_START
) -> dict:
    return {
        "initial_stress": dict(start),
        "time": {"end_time": end_time},
        "output": {"interval": OUTPUT_INTERVAL, "timeseries_interval": 0.05},
        "detection": dict(DETECTOR_BLOCK),
    }


def block_load(pressure: float, time_function=None) -> dict:
    return {
        "type": "vertical_pressure",
        "pressure": pressure,
        "x_range": [5.0, 10.0],
        "apply_on": "detected_boundary",
        "time_function": time_function or {"type": "constant"},
    }


def block_variant(
    base: dict,
    parameter: str,
    value: float,
    end_time: float = END_TIME,
    others: dict | None = None,
) -> dict:
    """The baseline block with `parameter` = value and the settings in `others` (its "start":
    the initial stress, GRAVITY_START by default)."""
    others = dict(others or {})
    start = others.pop("start", GRAVITY_START)
    settings = dict(BLOCK_BASE, **others, **{parameter: value})
    materials = []
    for material in base["materials"]:
        changed = dict(
            material,
            poisson_ratio=settings["poisson_ratio"],
            youngs_modulus=settings["youngs_modulus"],
        )
        if "cohesion" in changed:
            changed["cohesion"] = scale_cohesion(
                changed["cohesion"], settings["strength"]
            )
        materials.append(changed)
    case = derive(base, _common(base, end_time, start))
    case.update(
        materials=materials,
        loads=[block_load(settings["pressure"])],
        title=f"parametric block {parameter} = {value:g}"
        + "".join(f", {k} = {v:g}" for k, v in others.items())
        + ("" if start == GRAVITY_START else f", {start['method']} start"),
    )
    return case


def curve_case(base: dict, youngs_modulus: float, curve: dict = CURVE) -> dict:
    """The block for the load-settlement comparison: constant cohesion, ramped load."""
    materials = [
        dict(m, youngs_modulus=youngs_modulus, cohesion=curve["cohesion"])
        for m in base["materials"]
    ]
    case = derive(
        base,
        {
            "initial_stress": CURVE_START,
            "time": {"end_time": curve["end_time"]},
            "output": {"interval": curve["interval"]},
            "solver": {"damping": curve["damping"]},
            "detection": dict(DETECTOR_BLOCK),
        },
    )
    case.update(
        materials=materials,
        title=f"parametric load-settlement E = {youngs_modulus:g}",
        loads=[
            block_load(
                curve["pressure"], {"type": "ramp", "ramp_time": curve["ramp_time"]}
            )
        ],
    )
    return case


def dolfinx_case(case: dict) -> dict:
    """The same block for dolfinx: its reader knows the README schema without the detection
    block and the detected-boundary load keys (it loads up-facing facets in x_range)."""
    fem = {k: v for k, v in case.items() if k != "detection"}
    fem["loads"] = [
        {
            "type": "vertical_pressure",
            "pressure": l["pressure"],
            "x_range": l["x_range"],
        }
        for l in case["loads"]
    ]
    fem["initial_stress"] = dict(case["initial_stress"])
    return fem


def slope_variant(
    base: dict, offset, end_time: float = END_TIME, start: dict = GRAVITY_START
) -> dict:
    """offset None: the unloaded slope; otherwise a load starting ``offset`` m behind the
    crest, on the detected boundary; from `start` (the gravity-loading state by default).
    """
    case = derive(base, _common(base, end_time, start))
    if offset is None:
        case.update(loads=[], title="parametric slope unloaded")
        return case
    crest, toe = inclined_edge(body_polygon(base))
    direction = -1.0 if toe[0] > crest[0] else 1.0  # away from the face
    near = crest[0] + direction * offset
    far = near + direction * SLOPE_LOAD_WIDTH
    case.update(
        loads=[
            {
                "type": "vertical_pressure",
                "pressure": SLOPE_PRESSURE,
                "x_range": [min(near, far), max(near, far)],
                "apply_on": "detected_boundary",
            }
        ],
        title=f"parametric slope load {offset:g} m",
    )
    return case


def _mpm(case: dict) -> str:
    """A run that stops early (the thesis soil collapsing under the load: CFL violated) is a
    result: its outputs up to then are read."""
    return str(run_mpm(case, threads=1, allow_stopped=True).out)


def _dolfinx(task) -> str:
    case, steps = task
    return str(
        run_dolfinx(
            case, ["--mode", "static", "--steps", str(steps), "--no-fields"]
        ).out
    )


def surface_under(out: Path, case: dict, step_row) -> tuple[float, float]:
    """(height of the detected surface over the load's x_range at the first output, lowest
    detected point over x_range at ``step_row``): the hole depth is their difference. Points
    within 1.5 h of the grid edges (the base and the sides, where detectors leave artefacts)
    are left out, so a hole is measured down to 1.5 h above the base at most."""
    index = read_index(out, "boundary")
    x0, x1 = case["loads"][0]["x_range"]
    band = grid_edge_band(case["grid"], EDGE_BAND_CELLS * cell_size(case))

    def points(file):
        p = np.vstack([loop.points for loop in read_boundary(file)])
        p = p[
            (p[:, 0] >= x0)
            & (p[:, 0] <= x1)
            & ~np.asarray(band.contains(p), dtype=bool)
        ]
        if not len(p):
            raise ValueError(f"{file}: no boundary point over x in [{x0}, {x1}]")
        return p

    first = points(index.iloc[0]["file"])
    upper = first[
        first[:, 1] >= first[:, 1].max() - 0.5 * cell_size(case)
    ]  # the flat top
    return float(upper[:, 1].mean()), float(points(step_row["file"])[:, 1].min())


def settlement_at_centre(particles: pd.DataFrame, case: dict, x: float) -> float:
    """Settlement of the surface at x, from the particles that started (at t = 0, after the
    gravity loading) in the top cell row there."""
    from studies.common.measures import initial_positions

    start = initial_positions(particles)
    h = cell_size(case)
    near = np.abs(start[:, 0] - x) <= 0.5 * h
    top = float(start[near, 1].max()) + 0.25 * h  # the surface over the top row (2 x 2)
    return surface_settlement_extrapolated(particles, x, top, h)


def run(context) -> StudyOutcome:
    context.tools.append(tool_path("pfm-mpm"))
    outcome = StudyOutcome(study="parametric")
    run_parts(
        outcome,
        [
            ("bearing block sweep", lambda: _block_part(context, outcome)),
            (
                "load-settlement against dolfinx",
                lambda: _dolfinx_part(context, outcome),
            ),
            ("slope load position", lambda: _slope_part(context, outcome)),
            *(
                []
                if context.quick
                else [
                    (
                        "slope load position, zero start",
                        lambda: _slope_part(
                            context, outcome, ZERO_START, "_zero_start"
                        ),
                    )
                ]
            ),
        ],
        context.folder,
    )
    return outcome


def _block_part(context, outcome: StudyOutcome) -> None:
    block, block_path = base_case("thesis62_bearing_dynamic_zero_start")
    context.case_files.append(block_path)
    sweeps = QUICK_BLOCK_SWEEPS if context.quick else BLOCK_SWEEPS
    end_time = QUICK_END_TIME if context.quick else END_TIME
    block_cases = [
        (
            name,
            parameter,
            value,
            block_variant(block, parameter, value, end_time, others),
        )
        for name, (parameter, values, others) in sweeps.items()
        for value in values
    ]
    outs = [
        Path(p)
        for p in parallel_map(
            _mpm,
            [c for *_, c in block_cases],
            context.options.jobs,
            context.options.scheduler,
            "parametric block runs",
        )
    ]
    runs = [
        (name, parameter, value, case, out, read_index(out, "particles"))
        for (name, parameter, value, case), out in zip(block_cases, outs)
    ]
    # Each sweep is read at the last output that every run of it reached: the softest and most
    # loaded blocks collapse and stop early, and reading each run at its own end would mix the
    # stop times into the trend.
    common = {}
    for name, *_, frames in runs:
        common[name] = min(common.get(name, len(frames)), len(frames))
    rows, states = [], {}  # states: sweep -> [(value, case, particles, boundary file)]
    for name, parameter, value, case, out, frames in runs:
        frame = frames.iloc[common[name] - 1]
        boundary = read_index(out, "boundary")
        boundary = boundary[boundary["step"] == frame["step"]].iloc[0]
        load = case["loads"][0]
        top0, lowest = surface_under(out, case, boundary)
        status = run_status(out)
        particles = read_particles(frame["file"])
        states.setdefault(name, []).append((value, case, particles, boundary["file"]))
        rows.append(
            {
                "sweep": name,
                "parameter": parameter,
                "value": value,
                "settlement_centre_m": settlement_at_centre(
                    particles, case, 0.5 * sum(load["x_range"])
                ),
                "hole_depth_m": top0 - lowest,
                "surface_at_t0_m": top0,
                "time_s": float(frame["time"]),
                "last_output_s": float(frames.iloc[-1]["time"]),
                "status": status["status"],
                "note": status["error"][:80],
            }
        )
    sweep = pd.DataFrame(rows)
    outcome.tables.append(
        write_table(
            context.folder,
            sweep,
            "block_sweep",
            f"Bearing block, one parameter at a time around the thesis's baseline (nu "
            f"0.15, E 1000 kPa, strength x1, q 50 kPa; table 6.2), and the load on the "
            f"stiffer and on the stronger soil; each sweep at the last output every run of it "
            f"reached (time_s; up to {end_time:g} s; last_output_s: where each run "
            f"stopped)",
        )
    )
    for name, group in sweep.groupby("sweep", sort=False):
        time = group["time_s"].min()
        outcome.figures.append(
            save_figure(
                context.folder,
                sweep_figure(group, group["parameter"].iloc[0]),
                f"block_{name}",
                f"Bearing block: {name}, at t = {time:.3g} s",
            )
        )
        outcome.figures.append(
            save_figure(
                context.folder,
                regions_figure(states[name], group["parameter"].iloc[0], time),
                f"block_{name}_regions",
                f"Bearing block: {name}, the points' softening stage and the detected "
                f"boundary at t = {time:.3g} s (thesis figs. 6.15-6.22)",
            )
        )


def _dolfinx_part(context, outcome: StudyOutcome) -> None:
    block, _ = base_case("thesis62_bearing_dynamic_zero_start")
    dolfinx_module_file()
    moduli = QUICK_CURVE_MODULI if context.quick else CURVE_MODULI
    curve = QUICK_CURVE if context.quick else CURVE
    cases = [curve_case(block, e, curve) for e in moduli]
    mpm_outs = parallel_map(
        _mpm,
        cases,
        context.options.jobs,
        context.options.scheduler,
        "load-settlement MPM runs",
    )
    fem_outs = parallel_map(
        _dolfinx,
        [(dolfinx_case(c), curve["steps"]) for c in cases],
        context.options.jobs,
        context.options.scheduler,
        "load-settlement dolfinx runs",
    )
    curves, rows = [], []
    for youngs, case, mpm_out, fem_out in zip(moduli, cases, mpm_outs, fem_outs):
        mpm = mpm_curve(Path(mpm_out), case, curve["ramp_time"])
        fem = pd.read_csv(need(Path(fem_out) / "load_settlement.csv", "dolfinx_model"))
        curves.append((youngs, mpm, fem))
        for q in sorted({CURVE["compare_at"], CURVE["pressure"]}):
            ours = float(np.interp(q, mpm["pressure"], mpm["settlement"]))
            theirs = float(np.interp(q, fem["load"], fem["settlement"]))
            rows.append(
                {
                    "youngs_modulus_kpa": youngs,
                    "pressure_kpa": q,
                    "mpm_settlement_m": ours,
                    "dolfinx_settlement_m": theirs,
                    "rel_diff": abs(ours - theirs) / abs(theirs),
                }
            )
    table = pd.DataFrame(rows)
    outcome.tables.append(
        write_table(
            context.folder,
            table,
            "load_settlement",
            "Bearing block (c = 20 kPa, K0 = 1 start): settlement "
            "under the load centre, MPM against dolfinx",
        )
    )
    outcome.figures.append(
        save_figure(
            context.folder,
            curve_figure(curves),
            "load_settlement",
            "Bearing block: load-settlement, MPM against dolfinx",
        )
    )
    base = table[
        (table["youngs_modulus_kpa"] == moduli[-1])
        & (table["pressure_kpa"] == CURVE["compare_at"])
    ]
    outcome.metrics.append(
        Metric(
            "parametric.block.base.settlement_rel_diff_dolfinx",
            float(base["rel_diff"].iloc[0]),
            "1",
            f"E = {moduli[-1]:g} kPa, q = {CURVE['compare_at']:g} kPa",
        )
    )
    for row in table.itertuples(index=False):
        outcome.metrics.append(
            Metric(
                f"parametric.block.e{row.youngs_modulus_kpa:g}.q{row.pressure_kpa:g}."
                f"settlement_rel_diff_dolfinx",
                row.rel_diff,
                "1",
            )
        )


def mpm_curve(out: Path, case: dict, ramp_time: float) -> pd.DataFrame:
    """(time, pressure, settlement) of an MPM run from its particle outputs on the load ramp."""
    load = case["loads"][0]
    x_centre = 0.5 * sum(load["x_range"])
    rows = []
    for row in read_index(out, "particles").itertuples(index=False):
        particles = read_particles(row.file)
        factor = min(1.0, row.time / ramp_time)
        rows.append(
            {
                "time": row.time,
                "pressure": load["pressure"] * factor,
                "settlement": settlement_at_centre(particles, case, x_centre),
            }
        )
    return pd.DataFrame(rows)


def _slope_part(
    context, outcome: StudyOutcome, start: dict = GRAVITY_START, suffix: str = ""
) -> None:
    """The load-position sweep on the slope from `start`; its tables and figures are named
    with `suffix` ("" for the gravity start, "_zero_start" for the thesis's)."""
    slope, slope_path = base_case("thesis55_slope_dynamic_zero_start")
    context.case_files.append(slope_path)
    offsets = QUICK_SLOPE_OFFSETS if context.quick else SLOPE_LOAD_OFFSETS
    end_time = QUICK_END_TIME if context.quick else END_TIME
    slope_cases = [
        (o, slope_variant(slope, o, end_time, start)) for o in (None, *offsets)
    ]
    starting = "zero-stress start" if start == ZERO_START else "gravity start"
    for _, case in slope_cases:
        case["output"]["interval"] = SLOPE_OUTPUT_INTERVAL
    outs = [
        Path(p)
        for p in parallel_map(
            _mpm,
            [c for _, c in slope_cases],
            context.options.jobs,
            context.options.scheduler,
            "parametric slope runs",
        )
    ]
    frames = [read_index(out, "particles") for out in outs]
    # One comparison time for every position: the last output every run reached (a loaded
    # slope that collapses stops early, CFL violated).
    time = min(float(f["time"].max()) for f in frames)
    tolerance = 0.5 * SLOPE_OUTPUT_INTERVAL
    first = read_particles(frames[0].iloc[0]["file"])
    crest, toe = (tuple(p) for p in corner_points(first, slope))
    unloaded_row = row_at_time(frames[0], time, tolerance)
    unloaded = read_particles(unloaded_row["file"])
    c0, t0 = displacement_near(unloaded, crest), displacement_near(unloaded, toe)
    rows = []
    surfaces = [
        (
            "unloaded",
            row_at_time(
                read_index(outs[0], "boundary"), float(unloaded_row["time"]), 1e-9
            )["file"],
            None,
        )
    ]
    propelled = None
    for (offset, case), out, index in zip(slope_cases[1:], outs[1:], frames[1:]):
        row = row_at_time(index, time, tolerance)
        loaded = read_particles(row["file"])
        boundary_row = row_at_time(
            read_index(out, "boundary"), float(row["time"]), 1e-9
        )
        surfaces.append(
            (
                f"load at {0.0 - offset:g} m",
                boundary_row["file"],
                case["loads"][0]["x_range"],
            )
        )
        if offset == ON_FACE_OFFSET:
            propelled = (f"load at {0.0 - offset:g} m (on the face)", loaded)
        top0, lowest = surface_under(out, case, boundary_row)
        c, t = displacement_near(loaded, crest), displacement_near(loaded, toe)
        status = run_status(out)
        rows.append(
            {
                "load_offset_m": offset,
                "thesis_distance_m": 0.0 - offset,
                "x_range": f"{case['loads'][0]['x_range']}",
                "time_s": float(row["time"]),
                "hole_depth_m": top0 - lowest,
                "hole_bottom_y_m": lowest,
                "crest_dux_m": c[0] - c0[0],
                "crest_duy_m": c[1] - c0[1],
                "toe_dux_m": t[0] - t0[0],
                "toe_duy_m": t[1] - t0[1],
                "run_end_s": status["final_time_s"],
                "note": status["error"][:80],
            }
        )
    position = pd.DataFrame(rows)
    outcome.tables.append(
        write_table(
            context.folder,
            position,
            f"slope_load_position{suffix}",
            f"Slope, {starting}, {SLOPE_PRESSURE:g} kPa over 5 m, at t = {time:.3g} s (the "
            f"last output every run reached): effect of the load position (figs. "
            f"6.28-6.30); displacements added by the load (loaded minus unloaded)",
        )
    )
    outcome.figures.append(
        save_figure(
            context.folder,
            surfaces_figure(surfaces, propelled, time),
            f"slope_surfaces{suffix}",
            f"Slope, {starting}: the detected surface for every load position, "
            f"t = {time:.3g} s",
        )
    )
    outcome.figures.append(
        save_figure(
            context.folder,
            position_figure(position),
            f"slope_load_position{suffix}",
            f"Slope, {starting}: load position, t = {time:.3g} s",
        )
    )


def corner_points(particles: pd.DataFrame, case: dict) -> tuple:
    """Crest and toe of the slope at t = 0 (after gravity loading): the particles that started
    nearest to the polygon's crest and toe corners, at their t = 0 positions."""
    crest, toe = inclined_edge(body_polygon(case))
    xy = particles[["x", "y"]].to_numpy()
    found = []
    for corner in (crest, toe):
        i = int(np.argmin(np.hypot(xy[:, 0] - corner[0], xy[:, 1] - corner[1])))
        found.append(xy[i])
    return found[0], found[1]


def sweep_figure(group: pd.DataFrame, parameter: str):
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(5, 3.5))
    axis.plot(
        group["value"], group["settlement_centre_m"], "o-", label="settlement (centre)"
    )
    axis.plot(group["value"], group["hole_depth_m"], "s--", label="hole depth")
    if parameter == "youngs_modulus":
        axis.set_xscale("log")
    axis.set_xlabel(parameter)
    axis.set_ylabel("m")
    axis.legend()
    return figure


REGION_COLOURS = ("#c8c8c8", "#f2c14e", "#f78154", "#9b1d20")


def softening_regions(eps_p: np.ndarray, cohesion) -> tuple[np.ndarray, list[str]]:
    """Each point's stage of the cohesion law (thesis figs. 6.19-6.21): 0 elastic so far (eps_p
    = 0), 1 softening towards the peak cohesion, 2 towards the residual one, 3 residual; the
    labels. A constant cohesion has stages 0 and 1 (yielded) only."""
    if not isinstance(cohesion, dict) or "peak_plastic_strain" not in cohesion:
        return (eps_p > 0).astype(int), ["elastic", "yielded"]
    peak, residual = (
        cohesion["peak_plastic_strain"],
        cohesion["residual_plastic_strain"],
    )
    stage = np.where(
        eps_p <= 0, 0, np.where(eps_p < peak, 1, np.where(eps_p < residual, 2, 3))
    )
    return stage, [
        "elastic",
        f"to peak c (eps_p < {peak:g})",
        f"to residual c (eps_p < {residual:g})",
        "residual c",
    ]


def regions_figure(states: list, parameter: str, time: float):
    """One panel per run of a sweep: the points coloured by their stage of the cohesion law
    and the detected boundary (thesis figs. 6.15-6.22 show these fields)."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    figure, axes = plt.subplots(
        len(states), 1, figsize=(9, 2.6 * len(states)), squeeze=False
    )
    for axis, (value, case, particles, boundary_file) in zip(axes[:, 0], states):
        stage, labels = softening_regions(
            particles["eps_p"].to_numpy(), case["materials"][0].get("cohesion")
        )
        axis.scatter(
            particles["x"],
            particles["y"],
            c=[REGION_COLOURS[k] for k in stage],
            s=3,
            linewidths=0,
        )
        for loop in read_boundary(boundary_file):
            closed = loop.drawn()
            axis.plot(closed[:, 0], closed[:, 1], color="tab:blue", linewidth=0.8)
        axis.set_aspect("equal")
        axis.set_title(f"{parameter} = {value:g}, t = {time:.3g} s", fontsize=9)
    axes[0, 0].legend(
        handles=[
            Patch(color=REGION_COLOURS[k], label=label)
            for k, label in enumerate(labels)
        ],
        fontsize=7,
        loc="lower left",
        ncol=4,
    )
    figure.tight_layout()
    return figure


def surfaces_figure(surfaces: list, propelled, time: float):
    """The detected surface of the slope for every load position against the unloaded one
    (thesis figs. 6.24-6.26), and the points of the load on the face (fig. 6.27)."""
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(
        2 if propelled is not None else 1, 1, figsize=(11, 8), squeeze=False
    )
    top = axes[0, 0]
    for k, (label, boundary_file, load) in enumerate(surfaces):
        loops = read_boundary(boundary_file)
        style = {"color": "black", "linewidth": 2.0} if load is None else {"lw": 0.9}
        for i, loop in enumerate(loops):
            closed = loop.drawn()
            (line,) = top.plot(
                closed[:, 0], closed[:, 1], label=label if i == 0 else None, **style
            )
            style = {"color": line.get_color(), "lw": style.get("lw", 2.0)}
        if load is not None:
            bar = 10.4 + 0.15 * k
            top.plot(load, [bar, bar], color=line.get_color(), lw=3)
    top.set_ylim(4.5, 12.0)
    top.set_aspect("equal")
    top.legend(fontsize=7, ncol=3)
    top.set_title(
        f"detected surfaces at t = {time:.3g} s; bars: the loads (thesis figs. 6.24-6.26)"
    )
    if propelled is not None:
        label, particles = propelled
        points = axes[1, 0]
        points.plot(particles["x"], particles["y"], ".", markersize=2, color="0.3")
        points.set_aspect("equal")
        points.set_title(f"{label}: the points at t = {time:.3g} s (thesis fig. 6.27)")
    figure.tight_layout()
    return figure


def position_figure(position: pd.DataFrame):
    """Against the thesis's distance (crest to the load's edge, positive towards the face): the
    hole (fig. 6.28) and the crest and toe displacements the load adds (figs. 6.29, 6.30).
    """
    import matplotlib.pyplot as plt

    position = position.sort_values("thesis_distance_m")
    x = position["thesis_distance_m"]
    figure, (hole, moved) = plt.subplots(1, 2, figsize=(11, 4))
    hole.plot(x, position["hole_depth_m"], "o-", label="hole depth")
    hole.plot(x, position["hole_bottom_y_m"], "s--", label="height of its bottom")
    hole.set_ylabel("m")
    hole.set_title("hole under the load (fig. 6.28)")
    for column in ("crest_dux_m", "crest_duy_m", "toe_dux_m", "toe_duy_m"):
        moved.plot(x, position[column], "o-", label=column)
    moved.set_ylabel("m, loaded minus unloaded")
    moved.set_title("crest and toe (figs. 6.29, 6.30)")
    for axis in (hole, moved):
        axis.set_xlabel("distance crest to load [m], > 0 towards the face")
        axis.axvline(0.0, color="0.6", lw=0.8)
        axis.legend(fontsize=7)
    figure.tight_layout()
    return figure


def curve_figure(curves):
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(
        1, len(curves), figsize=(5 * len(curves), 4), squeeze=False
    )
    for axis, (youngs, mpm, fem) in zip(axes[0], curves):
        axis.plot(mpm["settlement"], mpm["pressure"], "o-", markersize=3, label="MPM")
        axis.plot(fem["settlement"], fem["load"], "k--", label="dolfinx (P2, static)")
        axis.set_title(f"E = {youngs:g} kPa, c = {CURVE['cohesion']:g} kPa", fontsize=9)
        axis.set_xlabel("settlement under the load centre [m]")
        axis.set_ylabel("q [kPa]")
        axis.legend(fontsize=7)
    return figure
