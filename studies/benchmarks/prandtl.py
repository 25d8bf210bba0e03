"""The Prandtl benchmark: a smooth strip footing on weightless Tresca soil under a ramped pressure on
its detected top, its collapse pressure against (2 + pi) c."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from studies import analytic
from studies.common.measures import surface_settlement_extrapolated
from studies.common.outcome import Metric
from studies.common.outputs import (
    read_index,
    read_particles,
)
from studies.common.paths import PrerequisiteMissing
from studies.common.tables import save_figure, write_table
from studies.benchmarks.common import (
    PRANDTL,
    _block,
    _missing,
)


def prandtl_case(
    cohesion: float,
    half_width: float,
    anti_locking: str = "bbar",
    cells_under_half_width: int = PRANDTL["cells_under_half_width"],
    shape_function: str = "gimp",
    apply_on: str = "detected_boundary",
    ramp_time: float | None = None,
    outputs: int = PRANDTL["outputs"],
) -> dict:
    """Half model of a smooth flexible strip footing of half-width b on weightless Tresca soil:
    the soil is [0, 2.5 B] x [0, 2.5 B] (B = 2 b) as _block (the symmetry plane x = 0 and the
    far side on rollers, the base fixed) with 1.25 B of free grid above; h = b /
    cells_under_half_width. The pressure on x <= b is ramped from 0 to max_factor (2 + pi) c
    over ramp_time (default ramp_per_half_width x b: the same ramp rate in units of the shear
    wave's transit for every width), outputs particle files at `outputs` even intervals.
    """
    p = PRANDTL
    b = half_width
    extent = 2.5 * 2.0 * b
    h = b / cells_under_half_width
    ramp = p["ramp_per_half_width"] * b if ramp_time is None else ramp_time
    material = {
        "name": "clay",
        "model": "tresca",
        "youngs_modulus": p["youngs_modulus"],
        "poisson_ratio": p["poisson_ratio"],
        "unit_weight": 20.0,
        "cohesion": cohesion,
    }
    q_max = p["max_factor"] * analytic.prandtl_bearing_capacity(cohesion)
    case = _block(
        extent,
        extent,
        material,
        [
            {
                "type": "vertical_pressure",
                "pressure": q_max,
                "x_range": [-b if apply_on == "detected_boundary" else 0.0, b],
                "apply_on": apply_on,
                "time_function": {"type": "ramp", "ramp_time": ramp},
            }
        ],
        gravity=False,
        end_time=ramp,
        h=h,
        damping=p["damping"],
        output_interval=ramp / outputs,
        headroom=int(round(extent / h)) // 2,
        shape_function=shape_function,
    )
    case["title"] = (
        f"benchmark Prandtl: c = {cohesion:g} kPa, b = {b:g} m, h = {h:g} m, "
        f"anti_locking {anti_locking}"
    )
    case["solver"]["anti_locking"] = anti_locking
    case["output"]["timeseries_interval"] = ramp / outputs
    return case


def prandtl_curve(out: Path, case: dict) -> pd.DataFrame:
    """Load-settlement curve of a prandtl_case run: the pressure of each particle output and
    the settlement of the footing's centre (x = h / 2, the top row of points extrapolated).
    """
    load = case["loads"][0]
    ramp = load["time_function"]["ramp_time"]
    h = case["grid"]["cell_size"]
    top = case["bodies"][0]["rectangle"][1][1]
    rows = []
    for frame in read_index(out, "particles").itertuples(index=False):
        particles = read_particles(frame.file)
        rows.append(
            {
                "time_s": frame.time,
                "pressure": load["pressure"] * min(1.0, frame.time / ramp),
                "settlement": surface_settlement_extrapolated(
                    particles, 0.5 * h, top, h
                ),
            }
        )
    return pd.DataFrame(rows)


def prandtl_jobs() -> dict:
    """The Prandtl runs by key: the MPM (uGIMP, and quadratic B-splines as mpm_bspline) and
    the UL-FEM with anti-locking (B-bar) for every cohesion and half-width, and the MPM without
    it (c and b the first of each)."""
    p = PRANDTL
    jobs = {}
    for c in p["cohesions"]:
        for b in p["half_widths"]:
            for solver in ("mpm", "ulfem"):
                jobs[f"prandtl/{solver}/c{c:g}/b{b:g}"] = (prandtl_case(c, b), solver)
            jobs[f"prandtl/mpm_bspline/c{c:g}/b{b:g}"] = (
                prandtl_case(c, b, shape_function="quadratic_bspline"),
                "mpm",
            )
    c, b = p["cohesions"][0], p["half_widths"][0]
    jobs[f"prandtl/mpm_none/c{c:g}/b{b:g}"] = (prandtl_case(c, b, "none"), "mpm")
    return jobs


def collapse_pressure(curve: pd.DataFrame, fraction: float):
    """The first pressure at which the tangent stiffness dq/ds between consecutive points of
    the load-settlement curve falls below ``fraction`` of the initial one (the secant over the
    first tenth of the load); None if it never does."""
    q, s = curve["pressure"].to_numpy(), curve["settlement"].to_numpy()
    first = max(1, int(np.searchsorted(q, 0.1 * q.max())))
    initial = q[first] / s[first] if s[first] > 0 else np.inf
    for i in range(first, len(q) - 1):
        ds = s[i + 1] - s[i]
        if ds > 0 and (q[i + 1] - q[i]) / ds < fraction * initial:
            return float(q[i])
    return None


def _prandtl(outs, jobs, outcome, folder):
    """Collapse pressure of every Prandtl run against (2 + pi) c: the table prandtl.md, the
    curves prandtl.png, and the largest |error| per solver with anti-locking as metrics
    (benchmarks.prandtl.collapse_pressure_rel_error for the MPM, ...ulfem_... for the UL-FEM;
    a run that never collapses up to max_factor (2 + pi) c counts as that factor)."""
    import matplotlib.pyplot as plt

    p = PRANDTL
    rows, curves = [], {}
    for key, job in jobs.items():
        if not key.startswith("prandtl/"):
            continue
        case = job[0]
        _, solver, c_label, b_label = key.split("/")
        cohesion = case["materials"][0]["cohesion"]
        q_u = analytic.prandtl_bearing_capacity(cohesion)
        if _missing(outs[key]):
            raise PrerequisiteMissing(outs[key]["missing"])
        curve = outs[key]["curve"]
        curves[key] = (curve, q_u)
        collapse = collapse_pressure(curve, p["stiffness_fraction"])
        rows.append(
            {
                "solver": solver,
                "cohesion_kPa": cohesion,
                "half_width_m": float(b_label[1:]),
                "cell_size_m": case["grid"]["cell_size"],
                "anti_locking": case["solver"]["anti_locking"],
                "collapse_kPa": collapse,
                "prandtl_kPa": q_u,
                "rel_error": (
                    collapse if collapse is not None else p["max_factor"] * q_u
                )
                / q_u
                - 1.0,
            }
        )
    table = pd.DataFrame(rows)
    outcome.tables.append(
        write_table(
            folder,
            table,
            "prandtl",
            "Smooth strip footing on weightless Tresca soil (nu = 0.49): collapse pressure "
            f"(tangent stiffness below {p['stiffness_fraction']:g} x initial) against "
            "(2 + pi) c; a collapse above max_factor (2 + pi) c shows as None",
        )
    )
    for solver, metric in (
        ("mpm", "collapse_pressure_rel_error"),
        ("mpm_bspline", "bspline_collapse_pressure_rel_error"),
        ("ulfem", "ulfem_collapse_pressure_rel_error"),
    ):
        errors = table.loc[table["solver"] == solver, "rel_error"].abs()
        if len(errors):
            outcome.metrics.append(
                Metric(f"benchmarks.prandtl.{metric}", float(errors.max()), "1")
            )
    figure, axis = plt.subplots(figsize=(6, 4.5))
    for key, (curve, q_u) in curves.items():
        axis.plot(
            curve["settlement"] / float(key.split("/")[3][1:]),
            curve["pressure"] / q_u,
            "-",
            label=key.removeprefix("prandtl/"),
        )
    axis.axhline(1.0, color="k", linestyle="--", label="(2 + pi) c")
    axis.set_xlabel("settlement under the centre / b")
    axis.set_ylabel("footing pressure / (2 + pi) c")
    axis.set_xlim(0.0, 0.3)
    axis.legend(fontsize=7)
    outcome.figures.append(
        save_figure(
            folder,
            figure,
            "prandtl",
            "Prandtl: load-settlement of every run, normalised",
        )
    )
