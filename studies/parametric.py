"""How the loaded soil responds to its parameters and to where the load is (thesis 6.2.2-6.2.4,
6.3, figures 6.28-6.30).

What it measures:

* bearing block (15 m x 5 m, q_v on the centre 5 m, table 6.2), one parameter at a time
  around the base case: Poisson's ratio nu = 0.15, 0.25, 0.35, 0.45; Young's modulus
  E = 1e3, 1e4, 1e5 kPa; strength x1 and x2 (cohesion 20/10/5 -> 40/20/10 kPa);
  q_v = 50, 100, 150 kPa. Read-outs: settlement under the load centre, hole depth under the
  load, and the load-settlement curve against the independent dolfinx model of the same case;
* slope (4 m, 45 degrees) with a 5 m wide load at distances 0-8 m behind the crest: hole
  depth, and the crest and toe displacement added by the load (loaded minus unloaded run).

Why: these are the thesis's qualitative findings (more settlement for soft soil, the hole under
the load, the crest lifting for a load ~6 m behind it); we give them as curves, and the
dolfinx comparison says whether the MPM load-settlement response is right.

Reproduce: ``make study-parametric`` = ``/usr/bin/python3 -m studies parametric [--quick]``.
Block cases start from K0 (so settlements are the load's); the load is ramped over 0.5 s.
Needs ``build/bin/pfm-mpm``, ``cases/bearing_block.json``, ``cases/slope.json`` and
``fem_reference/dolfinx_model`` (static mode writes ``load_settlement.csv``:
load,settlement,settlement_total); MPM runs need ``final_particles.csv``,
``particles.xdmf/.h5`` (load-settlement curve) and ``boundary/index.csv`` (hole depth); the
slope loads need ``apply_on: "detected_boundary"``. The three parts (block sweep,
load-settlement against dolfinx, slope load position) run and are reported independently.
Writes ``block_sweep.csv/.md``, ``slope_load_position.csv/.md``, ``block_<parameter>.png``,
``slope_load_position.png``, ``load_settlement.png``.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from studies.common.cases import base_case, body_polygon, cell_size, derive, inclined_edge
from studies.common.measures import (displacement_near, hole_depth, scale_cohesion,
                                     surface_settlement)
from studies.common.outcome import Metric, StudyOutcome
from studies.common.outputs import need, read_index, read_particles
from studies.common.parallel import parallel_map
from studies.common.paths import PrerequisiteMissing
from studies.common.paths import tool_path
from studies.common.study import run_parts
from studies.common.runner import dolfinx_module_file, run_dolfinx, run_mpm
from studies.common.tables import save_figure, write_table
from studies.metrics import read_loops

BLOCK_BASE = {"poisson_ratio": 0.15, "youngs_modulus": None, "strength": 1.0, "pressure": 100.0}
BLOCK_SWEEPS = {
    "poisson_ratio": (0.15, 0.25, 0.35, 0.45),
    "youngs_modulus": (1.0e3, 1.0e4, 1.0e5),
    "strength": (1.0, 2.0),
    "pressure": (50.0, 100.0, 150.0),
}
SLOPE_LOAD_WIDTH = 5.0                      # m
SLOPE_LOAD_OFFSETS = (0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0)  # m behind the crest
SLOPE_PRESSURE = 100.0                       # kPa
QUICK_BLOCK_SWEEPS = {"pressure": (50.0, 100.0)}
QUICK_SLOPE_OFFSETS = (0.0, 4.0)
LOAD_RAMP_TIME = 0.5                         # s, the load-settlement curve is read on the ramp

EXPECTED_METRICS = ["parametric.block.base.settlement_rel_diff_dolfinx"]


def block_variant(base: dict, parameter: str, value: float) -> dict:
    settings = dict(BLOCK_BASE, **{parameter: value})
    materials = []
    for material in base["materials"]:
        changed = dict(material, poisson_ratio=settings["poisson_ratio"])
        if settings["youngs_modulus"] is not None:
            changed["youngs_modulus"] = settings["youngs_modulus"]
        if "cohesion" in changed:
            changed["cohesion"] = scale_cohesion(changed["cohesion"], settings["strength"])
        materials.append(changed)
    loads = [dict(load, pressure=settings["pressure"],
                  time_function={"type": "ramp", "ramp_time": LOAD_RAMP_TIME})
             for load in base.get("loads", [])]
    return derive(base, {"materials": materials, "loads": loads,
                         "initial_stress": {"method": "k0"},
                         "title": f"parametric block {parameter} = {value:g}"})


def slope_variant(base: dict, offset) -> dict:
    """offset None: the unloaded slope; otherwise a load starting ``offset`` m behind the
    crest, on the detected boundary."""
    if offset is None:
        return derive(base, {"loads": [], "title": "parametric slope unloaded"})
    crest, toe = inclined_edge(body_polygon(base))
    direction = -1.0 if toe[0] > crest[0] else 1.0       # away from the face
    near = crest[0] + direction * offset
    far = near + direction * SLOPE_LOAD_WIDTH
    load = {"type": "vertical_pressure", "pressure": SLOPE_PRESSURE,
            "x_range": [min(near, far), max(near, far)], "apply_on": "detected_boundary"}
    return derive(base, {"loads": [load], "title": f"parametric slope load {offset:g} m"})


def _mpm(case: dict) -> str:
    return str(run_mpm(case, threads=1).out)


def _dolfinx(case: dict) -> str:
    return str(run_dolfinx(case, ["--mode", "static", "--steps", "10", "--no-fields"]).out)


def load_settlement(out: Path, case: dict) -> pd.DataFrame:
    """(time, pressure, settlement) of an MPM run from its particle outputs on the load ramp."""
    load = case["loads"][0]
    x_centre = 0.5 * sum(load["x_range"])
    top = max(p[1] for p in body_polygon(case))
    rows = []
    for row in read_index(out, "particles").itertuples(index=False):
        particles = read_particles(row.file)
        factor = min(1.0, row.time / LOAD_RAMP_TIME)
        rows.append({"time": row.time, "pressure": load["pressure"] * factor,
                     "settlement": surface_settlement(particles, x_centre, top,
                                                      cell_size(case))})
    return pd.DataFrame(rows)


def run(context) -> StudyOutcome:
    context.tools.append(tool_path("pfm-mpm"))
    outcome = StudyOutcome(study="parametric")
    state = {}
    run_parts(outcome, [("bearing block sweep", lambda: _block_part(context, outcome, state)),
                        ("load-settlement against dolfinx",
                         lambda: _dolfinx_part(context, outcome, state)),
                        ("slope load position", lambda: _slope_part(context, outcome))],
              context.folder)
    return outcome


def _block_part(context, outcome: StudyOutcome, state: dict) -> None:
    block, block_path = base_case("bearing_block")
    context.case_files.append(block_path)
    sweeps = QUICK_BLOCK_SWEEPS if context.quick else BLOCK_SWEEPS
    block_cases = [(p, v, block_variant(block, p, v)) for p, values in sweeps.items()
                   for v in values]
    outs = [Path(p) for p in parallel_map(_mpm, [c for _, _, c in block_cases],
                                          context.options.jobs, context.options.scheduler,
                                          "parametric block runs")]
    rows, hole_note = [], ""
    for (parameter, value, case), out in zip(block_cases, outs):
        final = pd.read_csv(need(out / "final_particles.csv"))
        load = case["loads"][0]
        top = max(p[1] for p in body_polygon(case))
        try:
            loops = read_loops(read_index(out, "boundary").iloc[-1]["file"])
            depth = hole_depth(loops, load["x_range"], top)
        except PrerequisiteMissing as missing:
            depth, hole_note = float("nan"), f"hole depth not run: needs {missing.needs}"
        rows.append({"parameter": parameter, "value": value,
                     "settlement_centre_m": surface_settlement(
                         final, 0.5 * sum(load["x_range"]), top, cell_size(case)),
                     "hole_depth_m": depth})
    sweep = pd.DataFrame(rows)
    outcome.tables.append(write_table(context.folder, sweep, "block_sweep",
                                      "Bearing block: one parameter at a time"
                                      + (f" ({hole_note})" if hole_note else "")))
    for parameter, group in sweep.groupby("parameter"):
        outcome.figures.append(save_figure(context.folder, sweep_figure(group, parameter),
                                           f"block_{parameter}", f"Bearing block: {parameter}"))

    base_index = next((i for i, (p, v, _) in enumerate(block_cases)
                       if p == "pressure" and v == BLOCK_BASE["pressure"]), None)
    state["base_out"] = outs[base_index] if base_index is not None else None


def _dolfinx_part(context, outcome: StudyOutcome, state: dict) -> None:
    block, _ = base_case("bearing_block")
    base_block = block_variant(block, "pressure", BLOCK_BASE["pressure"])
    base_out = state.get("base_out") or Path(_mpm(base_block))
    mpm_curve = load_settlement(base_out, base_block)
    dolfinx_module_file()
    reference = Path(_dolfinx(base_block))   # static, P2: load_settlement.csv
    fem_curve = pd.read_csv(need(reference / "load_settlement.csv", "dolfinx_model"))
    outcome.figures.append(save_figure(context.folder, curve_figure(mpm_curve, fem_curve),
                                       "load_settlement", "Bearing block: load-settlement, "
                                       "MPM against dolfinx"))
    mpm_final = float(mpm_curve["settlement"].iloc[-1])
    fem_final = float(fem_curve["settlement"].iloc[-1])
    outcome.metrics.append(Metric("parametric.block.base.settlement_rel_diff_dolfinx",
                                  abs(mpm_final - fem_final) / abs(fem_final), "1",
                                  f"q = {BLOCK_BASE['pressure']} kPa"))


def _slope_part(context, outcome: StudyOutcome) -> None:
    slope, slope_path = base_case("slope")
    context.case_files.append(slope_path)
    offsets = QUICK_SLOPE_OFFSETS if context.quick else SLOPE_LOAD_OFFSETS
    slope_cases = [(o, slope_variant(slope, o)) for o in (None, *offsets)]
    outs = [Path(p) for p in parallel_map(_mpm, [c for _, c in slope_cases],
                                          context.options.jobs, context.options.scheduler,
                                          "parametric slope runs")]
    unloaded = pd.read_csv(need(outs[0] / "final_particles.csv"))
    crest, toe = inclined_edge(body_polygon(slope))
    top = crest[1]
    base_crest, base_toe = displacement_near(unloaded, crest), displacement_near(unloaded, toe)
    rows = []
    for (offset, case), out in zip(slope_cases[1:], outs[1:]):
        final = pd.read_csv(need(out / "final_particles.csv"))
        loops = read_loops(read_index(out, "boundary").iloc[-1]["file"])
        c, t = displacement_near(final, crest), displacement_near(final, toe)
        rows.append({"load_offset_m": offset,
                     "hole_depth_m": hole_depth(loops, case["loads"][0]["x_range"], top),
                     "crest_dux_m": c[0] - base_crest[0], "crest_duy_m": c[1] - base_crest[1],
                     "toe_dux_m": t[0] - base_toe[0], "toe_duy_m": t[1] - base_toe[1]})
    position = pd.DataFrame(rows)
    outcome.tables.append(write_table(context.folder, position, "slope_load_position",
                                      "Slope: effect of the load position (figs. 6.28-6.30)"))
    outcome.figures.append(save_figure(context.folder, position_figure(position),
                                       "slope_load_position", "Slope: load position"))


def sweep_figure(group: pd.DataFrame, parameter: str):
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(5, 3.5))
    axis.plot(group["value"], group["settlement_centre_m"], "o-", label="settlement (centre)")
    axis.plot(group["value"], group["hole_depth_m"], "s--", label="hole depth")
    if parameter == "youngs_modulus":
        axis.set_xscale("log")
    axis.set_xlabel(parameter)
    axis.set_ylabel("m")
    axis.legend()
    return figure


def position_figure(position: pd.DataFrame):
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(6, 4))
    for column in ("hole_depth_m", "crest_dux_m", "crest_duy_m", "toe_dux_m", "toe_duy_m"):
        axis.plot(position["load_offset_m"], position[column], "o-", label=column)
    axis.set_xlabel("distance of the load from the crest [m]")
    axis.set_ylabel("m")
    axis.legend(fontsize=7)
    return figure


def curve_figure(mpm: pd.DataFrame, fem: pd.DataFrame):
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(5, 4))
    axis.plot(mpm["settlement"], mpm["pressure"], "o-", label="MPM")
    axis.plot(fem["settlement"], fem["load"], "k-", label="dolfinx")
    axis.set_xlabel("settlement under the load centre [m]")
    axis.set_ylabel("q [kPa]")
    axis.legend()
    return figure
