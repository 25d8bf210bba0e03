"""The rigid footing: pushed into the Prandtl soil through a constraint on the detected top, as a
moving support, on the UL-FEM and on dolfinx; the reaction along the settlement."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from studies import analytic
from studies.common.outcome import Metric, StudyOutcome
from studies.common.outputs import read_timeseries
from studies.common.paths import PrerequisiteMissing
from studies.common.tables import save_figure, write_table
from studies.benchmarks.common import (
    FOOTING,
    PRANDTL,
    _block,
    _missing,
    _out,
)


def footing_case(
    how: str,
    penalty_factor: float | None = None,
    method: str = "penalty",
    speedup: float = 1.0,
    cells: int | None = None,
    shape_function: str | None = "gimp",
) -> dict:
    """The rigid footing of FOOTING: `how` "constraint" (on the detected top, x <= b, with
    `penalty_factor` and `method`) or "support" (the grid's or the mesh's top nodes over
    x <= b: MPM, UL-FEM and dolfinx), pushed at `speedup` times FOOTING's speed (smaller than
    1: slower) to the same settlement, with `cells` cells (or elements) under b (default
    FOOTING's), on the MPM's `shape_function` (uGIMP, on a grid with a 2-cell margin and
    node-set walls; None: the default, quadratic B-splines, whose edge functions hold the walls
    on the grid's edges, with no margin: studies.common.cases.is_bspline). The support is the
    fourth boundary condition (reaction_3_*), the constraint the first (constraint_0_*).
    """
    f = FOOTING
    b = f["half_width"]
    extent = 5.0 * b
    cells = f["cells_under_half_width"] if cells is None else cells
    h = b / cells
    material = {
        "name": "clay",
        "model": "tresca",
        "youngs_modulus": PRANDTL["youngs_modulus"],
        "poisson_ratio": PRANDTL["poisson_ratio"],
        "unit_weight": 20.0,
        "cohesion": f["cohesion"],
    }
    duration = f["duration"] / speedup
    case = _block(
        extent,
        extent,
        material,
        [],
        gravity=False,
        end_time=duration,
        h=h,
        damping=f["damping"],
        output_interval=duration / 4,
        headroom=int(round(extent / h)) // 2,
        shape_function=shape_function,
    )
    case["title"] = f"benchmark footing: {how}" + (
        f", {method}, penalty factor {penalty_factor:g}" if penalty_factor else ""
    )
    if speedup != 1.0:
        case["title"] += f", {speedup:g} times the speed"
    if cells != f["cells_under_half_width"]:
        case["title"] += f", {cells} cells under b"
    if shape_function is None:
        case["title"] += ", default shape functions"
    case["solver"].update(anti_locking="bbar", pic_fraction=f["pic_fraction"])
    case["output"]["timeseries_interval"] = duration / f["samples"]
    ramp = footing_ramp(speedup)
    speed = f["speed"] * speedup
    if how == "constraint":
        case["constraints"] = [
            {
                "apply_on": "detected_boundary",
                "x_range": [-b, b],
                "faces": "top",
                "normal": {"direction": [0.0, 1.0], "max_angle": f["window_angle"]},
                "normal_velocity": -speed,
                "time_function": ramp,
                "method": method,
                "penalty_factor": penalty_factor,
            }
        ]
    else:
        case["node_sets"].append(
            {
                "name": "footing",
                "box": [[-1e3, extent - 1e-9], [b + 1e-9, extent + 1e-9]],
            }
        )
        case["boundary_conditions"].append(
            {
                "where": "footing",
                "fix": "y",
                "velocity": [0.0, -speed],
                "time_function": ramp,
            }
        )
    return case


def footing_ramp(speedup: float = 1.0) -> dict:
    """The time function of the footing's speed: a smooth ramp over ramp_fraction x the
    duration (FOOTING's over `speedup`)."""
    f = FOOTING
    return {
        "type": "smooth_ramp",
        "ramp_time": f["ramp_fraction"] * f["duration"] / speedup,
    }


def footing_jobs() -> dict:
    f = FOOTING
    jobs = {
        f"footing/constraint/f{k:g}": (footing_case("constraint", k), "mpm")
        for k in f["penalty_factors"]
    }
    for k in f["nitsche_factors"]:
        jobs[f"footing/constraint/nitsche_f{k:g}"] = (
            footing_case("constraint", k, "nitsche"),
            "mpm",
        )
    k = f["penalty_factors"][0]
    for speedup in f["rate_check"]:
        jobs[f"footing/constraint/f{k:g}_x{speedup:g}"] = (
            footing_case("constraint", k, speedup=speedup),
            "mpm",
        )
    n = f["refined_cells"]
    jobs[f"footing/constraint/f{k:g}_h{n}"] = (
        footing_case("constraint", k, cells=n),
        "mpm",
    )
    # The same on the default shape functions, at both cell sizes (issue 45 must-show 4).
    jobs[f"footing/constraint/f{k:g}_default"] = (
        footing_case("constraint", k, shape_function=None),
        "mpm",
    )
    jobs[f"footing/constraint/f{k:g}_default_h{n}"] = (
        footing_case("constraint", k, cells=n, shape_function=None),
        "mpm",
    )
    jobs["footing/support/mpm"] = (footing_case("support"), "mpm")
    jobs["footing/support/ulfem"] = (footing_case("support"), "ulfem")
    jobs[f"footing/support/ulfem_h{n}"] = (footing_case("support", cells=n), "ulfem")
    jobs["footing/support/dolfinx"] = (
        footing_case("support"),
        "dolfinx",
        f["dolfinx_steps"],
    )
    return jobs


def footing_speedup(case: dict) -> float:
    """The speed a footing_case pushes at (its constraint's or its moving support's), over
    FOOTING's."""
    if "constraints" in case:
        speed = -case["constraints"][0]["normal_velocity"]
    else:
        (footing,) = [b for b in case["boundary_conditions"] if b["where"] == "footing"]
        speed = -footing["velocity"][1]
    return speed / FOOTING["speed"]


def footing_cells(case: dict) -> int:
    """The cells (or elements) under b of a footing_case."""
    return int(round(FOOTING["half_width"] / case["grid"]["cell_size"]))


def footing_curve(
    out: Path, solver: str, constraint: bool, speedup: float = 1.0
) -> pd.DataFrame:
    """s_over_b (the footing's prescribed settlement over b) and q_over_prandtl (the force
    the footing exerts on the body over b, against (2 + pi) c) of a footing_case run at
    `speedup`."""
    from fem_reference.dolfinx_model.case import time_integral

    f = FOOTING
    b = f["half_width"]
    series = read_timeseries(out)
    column = "constraint_0_fy" if constraint else "reaction_3_fy"
    if solver == "dolfinx":
        settlement = -series["displacement_3_y"]
    else:
        ramp = footing_ramp(speedup)
        settlement = (
            f["speed"] * speedup * series["time"].map(lambda t: time_integral(ramp, t))
        )
    q_u = analytic.prandtl_bearing_capacity(f["cohesion"])
    return pd.DataFrame(
        {"s_over_b": settlement / b, "q_over_prandtl": -series[column] / b / q_u}
    )


def footing_plateau_line(curve: pd.DataFrame) -> tuple[float, float]:
    """The least-squares line q / (2 + pi) c = q0 + k s / b through a footing_curve over
    FOOTING's plateau window: (q0, k). In a large-deformation run the reaction rises along the
    settlement (the footing sinks into its heave); q0, the line at s = 0, is the level without
    that rise, and k the rise."""
    lo, hi = FOOTING["plateau"]
    window = curve[(curve["s_over_b"] >= lo) & (curve["s_over_b"] <= hi)]
    slope, at_0 = np.polyfit(window["s_over_b"], window["q_over_prandtl"], 1)
    return float(at_0), float(slope)


def footing_dip(curve: pd.DataFrame) -> float:
    """The deepest dip of a footing_curve: over FOOTING's dip windows of s / b (from the
    plateau's start to the last settlement reached), the largest drop of a window's mean q
    below the largest mean of the windows before it, relative to that largest mean (0 for a
    reaction that never falls back). The reaction of a footing pushed into perfectly plastic
    soil does not fall as it sinks (it rises with the heave beside it); a drop is the
    discretisation's."""
    step = FOOTING["dip_window"]
    lo, reached = FOOTING["plateau"][0], float(curve["s_over_b"].iloc[-1])
    means = []
    for k in range(int(math.floor((reached - lo) / step + 1e-9))):
        a = lo + k * step
        window = curve[(curve["s_over_b"] >= a) & (curve["s_over_b"] < a + step)]
        if len(window):
            means.append(float(window["q_over_prandtl"].mean()))
    dip, highest = 0.0, -math.inf
    for q in means:
        if highest > 0.0:
            dip = max(dip, (highest - q) / highest)
        highest = max(highest, q)
    return dip


def _largest_window_difference(row: dict, reference: dict) -> float | None:
    """The largest |mean q of row / mean q of reference - 1| over FOOTING's windows both
    reached (rows as in footing.md); None if they share none."""
    names = [f"mean_{a:g}_{z:g}" for a, z in FOOTING["windows"]]
    ratios = [
        abs(row[w] / reference[w] - 1.0)
        for w in names
        if math.isfinite(row[w]) and math.isfinite(reference[w])
    ]
    return max(ratios) if ratios else None


def footing_against_refined(rows: list[dict]) -> dict:
    """Per constraint run at FOOTING's cells under b that has a refined twin (its name with
    _h<refined_cells>): the largest |mean q / mean q of the twin - 1| over the windows both
    reached (rows as in footing.md)."""
    by_name = {r["run"]: r for r in rows}
    out = {}
    for r in rows:
        twin = by_name.get(f"{r['run']}_h{FOOTING['refined_cells']}")
        if twin is None or r["cells"] != FOOTING["cells_under_half_width"]:
            continue
        difference = _largest_window_difference(r, twin)
        if difference is not None:
            out[r["run"]] = difference
    return out


def footing_against_ulfem(rows: list[dict]) -> dict:
    """Per constraint run at FOOTING's speed with a UL-FEM run of the same cells under b: the
    largest |mean q of the constraint / mean q of the UL-FEM - 1| over the windows both
    reached (rows as in footing.md)."""
    ulfem = {r["cells"]: r for r in rows if r["solver"] == "ulfem"}
    out = {}
    for r in rows:
        reference = ulfem.get(r["cells"])
        if not r["run"].startswith("constraint_") or reference is None:
            continue
        if not math.isclose(r["speed"], FOOTING["speed"], rel_tol=1e-12):
            continue
        difference = _largest_window_difference(r, reference)
        if difference is not None:
            out[r["run"]] = difference
    return out


def _footing(outs: dict, jobs: dict, outcome: StudyOutcome, folder: Path):
    """The rigid footing on every code: the table footing.md (per run the plateau's mean,
    least and largest q / (2 + pi) c over FOOTING's plateau window, the mean over each of its
    windows, the plateau's line, the deepest dip, the last settlement reached), the curves
    footing.png, and the metrics benchmarks.footing.<run>_plateau_rel_error (the plateau's
    mean |q / (2 + pi) c - 1|) and <run>_line_at_0_rel_error (|q0 - 1|, footing_plateau_line)
    for each run that reached the plateau's end, <run>_dip (footing_dip) for the constraint
    runs, <run>_vs_ulfem_rel_error (footing_against_ulfem) for the constraint runs at the
    speed, <run>_vs_h<n>_rel_error (footing_against_refined) for those with a refined twin;
    <run> as in the table (constraint_f<factor>, constraint_nitsche_f<factor>,
    constraint_f<factor>_x<k>, constraint_f<factor>_h<n>, constraint_f<factor>_default[_h<n>]
    (the default shape functions), support_mpm, support_ulfem, support_ulfem_h<n>,
    support_dolfinx). A run that stopped is read up to its stop."""
    import matplotlib.pyplot as plt

    f = FOOTING
    lo, hi = f["plateau"]
    rows, curves = [], {}
    for key, job in jobs.items():
        if not key.startswith("footing/"):
            continue
        if _missing(outs[key]):
            continue
        _, how, which = key.split("/")
        speedup = footing_speedup(job[0])
        curve = footing_curve(_out(outs[key]), job[1], how == "constraint", speedup)
        curves[key] = curve
        plateau = curve[(curve["s_over_b"] >= lo) & (curve["s_over_b"] <= hi)]
        q = plateau["q_over_prandtl"]
        reached = float(curve["s_over_b"].iloc[-1])
        name = f"{how}_{which}"
        row = {
            "run": name,
            "solver": job[1],
            "cells": footing_cells(job[0]),
            "speed": f["speed"] * speedup,
            "plateau_mean": float(q.mean()) if reached >= hi else float("nan"),
            "plateau_min": float(q.min()),
            "plateau_max": float(q.max()),
        }
        for a, z in f["windows"]:
            window = curve[(curve["s_over_b"] >= a) & (curve["s_over_b"] <= z)]
            row[f"mean_{a:g}_{z:g}"] = (
                float(window["q_over_prandtl"].mean()) if reached >= z else float("nan")
            )
        line = footing_plateau_line(curve) if reached >= hi else (float("nan"),) * 2
        row["line_at_0"], row["line_slope"] = line
        row["dip"] = footing_dip(curve)
        row["last_s_over_b"] = reached
        rows.append(row)
        if how == "constraint":
            outcome.metrics.append(
                Metric(f"benchmarks.footing.{name}_dip", row["dip"], "1")
            )
        if reached >= hi:
            outcome.metrics.append(
                Metric(
                    f"benchmarks.footing.{name}_plateau_rel_error",
                    abs(float(q.mean()) - 1.0),
                    "1",
                )
            )
            outcome.metrics.append(
                Metric(
                    f"benchmarks.footing.{name}_line_at_0_rel_error",
                    abs(row["line_at_0"] - 1.0),
                    "1",
                )
            )
    # The reaction rises along the settlement on the UL-FEM too (FOOTING's windows): each
    # constraint at the speed against the UL-FEM with the same cells, window by window.
    for name, value in footing_against_ulfem(rows).items():
        outcome.metrics.append(
            Metric(f"benchmarks.footing.{name}_vs_ulfem_rel_error", value, "1")
        )
    # Each constraint at FOOTING's cells against its twin with refined_cells, window by window.
    n = f["refined_cells"]
    for name, value in footing_against_refined(rows).items():
        outcome.metrics.append(
            Metric(f"benchmarks.footing.{name}_vs_h{n}_rel_error", value, "1")
        )
    if not rows:
        raise PrerequisiteMissing("footing outputs")
    outcome.tables.append(
        write_table(
            folder,
            pd.DataFrame(rows),
            "footing",
            f"Rigid smooth footing pushed at {f['speed']:g} m/s into weightless Tresca soil "
            f"(c = {f['cohesion']:g} kPa, b = {f['half_width']:g} m, "
            f"{f['cells_under_half_width']} cells under b): the reaction pressure over "
            f"(2 + pi) c on the plateau s / b in [{lo:g}, {hi:g}] (mean, least, largest), "
            "its mean over each window mean_<from>_<to> of s / b (NaN: the run stopped "
            "before the window's end) and the least-squares line over the plateau, "
            "line_at_0 + line_slope s / b (line_at_0: the level without the rise along the "
            "settlement), through a constraint on the detected top (MPM, per "
            "method and penalty factor; _x<k>: at k times the speed; _h<n>: n cells under b) "
            "and as a moving support on the grid's or mesh's top nodes (MPM, UL-FEM, dolfinx "
            "static)",
        )
    )
    # The constraint's force jumps as particles cross node rows: each curve is drawn as its
    # centred moving mean over `smooth` samples (the table's means are of the raw samples).
    smooth = 15
    width = smooth * f["duration"] / f["samples"] * f["speed"] / f["half_width"]
    k = f["penalty_factors"][0]
    panels = {
        f"at the speed, {f['cells_under_half_width']} cells under b": lambda key: (
            "_x" not in key and "_h" not in key
        ),
        f"the constraint at factor {k:g} against speed and h; the UL-FEM": lambda key: (
            key.startswith(f"footing/constraint/f{k:g}")
            or key.startswith("footing/support/ulfem")
        ),
    }
    figure, axes = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    for axis, (title, shown) in zip(axes, panels.items()):
        for key, curve in curves.items():
            if not shown(key):
                continue
            q = curve["q_over_prandtl"].rolling(smooth, center=True, min_periods=1)
            axis.plot(curve["s_over_b"], q.mean(), label=key[len("footing/") :])
        axis.axhline(1.0, color="0.5", lw=0.8, ls="--")
        axis.axvspan(lo, hi, color="0.9", zorder=0)
        axis.set_ylim(0.8, 1.3)
        axis.set_title(title, fontsize=9)
        axis.set_xlabel("settlement s / b")
        axis.legend(fontsize=7)
    axes[0].set_ylabel(
        f"reaction pressure / (2 + pi) c, moving mean over {width:.4f} b"
    )
    figure.tight_layout()
    outcome.figures.append(
        save_figure(
            folder,
            figure,
            "footing",
            "Rigid footing: reaction pressure against settlement on every code (moving "
            f"mean over {width:.4f} b of settlement; grey: the plateau window)",
        )
    )
