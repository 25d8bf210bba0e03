"""The constraint benchmark: a block turned 30 degrees to the grid brought to uniaxial strain by
constraints on its detected faces."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from studies.common.outputs import read_timeseries
from studies.common.tables import save_figure, write_table
from studies.benchmarks.common import (
    CONSTRAINT,
    _out,
    _particles,
)


def constraint_lattice(cells_per_side: int) -> Path:
    """The particle file of the turned block: (2 cells_per_side)^2 points of equal volume on a
    lattice turned with the block, centred at (1.5, 1.5) m. Written once (atomically) to the
    system's temporary folder; the same bytes every time."""
    import tempfile

    c = CONSTRAINT
    path = (
        Path(tempfile.gettempdir())
        / "pfm-mpm-lattices"
        / f"block{c['angle']:g}_{cells_per_side}.csv"
    )
    if path.exists():
        return path
    n = 2 * cells_per_side
    spacing = c["side"] / n
    local = (np.arange(n) + 0.5) * spacing - 0.5 * c["side"]
    u, v = np.meshgrid(local, local)
    a = np.radians(c["angle"])
    x = 1.5 + np.cos(a) * u - np.sin(a) * v
    y = 1.5 + np.sin(a) * u + np.cos(a) * v
    lines = ["x,y,volume"] + [
        f"{xi!r},{yi!r},{spacing * spacing!r}" for xi, yi in zip(x.ravel(), y.ravel())
    ]
    path.parent.mkdir(parents=True, exist_ok=True)
    scratch = path.with_suffix(f".{os.getpid()}.tmp")
    scratch.write_text("\n".join(lines) + "\n")
    scratch.replace(path)
    return path


def constraint_case(
    penalty_factor: float, cells_per_side: int, method: str = "penalty"
) -> dict:
    """cases/constraint_inclined_block.json at another penalty factor, cell size and method."""
    c = CONSTRAINT
    h = c["side"] / cells_per_side
    a = np.radians(c["angle"])

    def face(nx, ny, value):
        direction = [np.cos(a) * nx - np.sin(a) * ny, np.sin(a) * nx + np.cos(a) * ny]
        entry = {
            "apply_on": "detected_boundary",
            "normal": {"direction": direction, "max_angle": 45.0},
            "normal_displacement": value,
            "method": method,
            "penalty_factor": penalty_factor,
        }
        if value:
            entry["time_function"] = {"type": "smooth_ramp", "ramp_time": 0.1}
        return entry

    return {
        "title": f"benchmark constraint: {method}, factor {penalty_factor:g}, h = {h:g} m",
        "grid": {
            "origin": [0.0, 0.0],
            "cell_size": h,
            "n_cells": [3 * cells_per_side] * 2,
        },
        "materials": [
            {
                "name": "block",
                "model": "linear_elastic",
                "youngs_modulus": c["youngs_modulus"],
                "poisson_ratio": c["poisson_ratio"],
                "unit_weight": 20.0,
            }
        ],
        "bodies": [
            {
                "name": "block",
                "material": "block",
                "particles": str(constraint_lattice(cells_per_side)),
            }
        ],
        "gravity": {"g": 0.0},
        "constraints": [
            face(1, 0, c["displacement"]),
            face(-1, 0, 0.0),
            face(0, 1, 0.0),
            face(0, -1, 0.0),
        ],
        "solver": {
            "damping": 0.05,
            "damping_form": "along_velocity",
            "pic_fraction": 0.05,
        },
        "time": {"end_time": 0.4, "cfl": 0.5},
        "output": {"interval": 0.4},
    }


def constraint_jobs(quick: bool) -> dict:
    c = CONSTRAINT
    runs = {("penalty", c["default_factor"], c["default_cells"])}
    if not quick:
        for method in ("penalty", "nitsche"):
            runs |= {(method, f, c["default_cells"]) for f in c["factors"]}
        for method in ("penalty", "nitsche"):
            runs |= {(method, c["default_factor"], n) for n in c["cells_per_side"]}
    return {
        f"constraint/{m}/{f:g}/{n}": (constraint_case(f, n, m), "mpm")
        for m, f, n in sorted(runs)
    }


def constraint_exact() -> tuple:
    """(sigma_nn, sigma_tt) in kPa of the turned block of CONSTRAINT: uniaxial strain along the
    loaded face's normal, ln(1 + d / L) (the rate form integrates the stretching: ln(L / L0),
    not the small strain d / L)."""
    c = CONSTRAINT
    e, nu = c["youngs_modulus"], c["poisson_ratio"]
    lam = e * nu / ((1 + nu) * (1 - 2 * nu))
    strain = float(np.log1p(c["displacement"] / c["side"]))
    return (lam + e / (1 + nu)) * strain, lam * strain


def constraint_measures(out: Path) -> dict:
    """The turned block's errors at the end of a constraint_case run (its interior's mean
    sigma_nn and sigma_tt, its worst interior point, the loaded and opposite faces' reactions,
    against constraint_exact) and its costs per step (the constraints, detection, the step),
    ms."""
    import json

    c = CONSTRAINT
    exact_nn, exact_tt = constraint_exact()
    a = np.radians(c["angle"])
    n, t = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
    particles = _particles(out)
    r = particles[["x", "y"]].to_numpy() - 1.5
    inner = (np.abs(r @ n) < c["interior"]) & (np.abs(r @ t) < c["interior"])
    sxx, syy, sxy = (particles[k].to_numpy()[inner] for k in ("sxx", "syy", "sxy"))
    snn = sxx * n[0] ** 2 + syy * n[1] ** 2 + 2 * sxy * n[0] * n[1]
    stt = sxx * t[0] ** 2 + syy * t[1] ** 2 + 2 * sxy * t[0] * t[1]
    last = read_timeseries(_out(out)).iloc[-1]
    face = abs(exact_nn) * c["side"]
    loaded = np.array([last["constraint_0_fx"], last["constraint_0_fy"]])
    opposite = np.array([last["constraint_1_fx"], last["constraint_1_fy"]])
    summary = json.loads((_out(out) / "run.json").read_text())["summary"]
    steps = max(1, summary["n_steps"])
    stages = summary["stage_seconds"]
    return {
        "sigma_nn_rel_error": float(snn.mean() / exact_nn - 1.0),
        "sigma_tt_rel_error": float(stt.mean() / exact_tt - 1.0),
        "worst_point_rel_error": float(np.max(np.abs(snn / exact_nn - 1.0))),
        "reaction_rel_error": float(loaded @ (-n) / face - 1.0),
        "opposite_rel_error": float(opposite @ n / face - 1.0),
        "rms_gap_m": float(last["constraint_0_gap"]),
        "constraint_ms_per_step": 1e3 * stages.get("constraints", 0.0) / steps,
        "detection_ms_per_step": 1e3 * stages.get("detect", 0.0) / steps,
        "step_ms": 1e3 * summary["wall_time_s"] / steps,
    }


def _constraint(outs, jobs, add, outcome, folder):
    """The turned block's interior stress and reaction against uniaxial strain, per penalty
    factor and cell size: constraint.csv/.md, constraint.png, and the default run's errors as
    metrics and benchmark rows."""
    import matplotlib.pyplot as plt

    c = CONSTRAINT
    exact_nn, _ = constraint_exact()
    rows = []
    for key in jobs:
        if not key.startswith("constraint/"):
            continue
        _, method, factor, cells = key.split("/")
        rows.append(
            {
                "method": method,
                "penalty_factor": float(factor),
                "cells_per_side": int(cells),
                **constraint_measures(_out(outs[key])),
            }
        )
    table = pd.DataFrame(rows).sort_values(
        ["method", "cells_per_side", "penalty_factor"]
    )
    outcome.tables.append(
        write_table(
            folder,
            table,
            "constraint",
            "Constraints on the detected boundary: a block turned 30 degrees in uniaxial "
            "strain",
        )
    )
    penalty = table[table.method == "penalty"]
    default = penalty[
        (penalty.penalty_factor == c["default_factor"])
        & (penalty.cells_per_side == c["default_cells"])
    ].iloc[0]
    add(
        "constraint",
        "interior mean sigma_nn (block turned 30 degrees, factor 100, h = L / 16)",
        exact_nn * (1.0 + default.sigma_nn_rel_error),
        exact_nn,
        "kPa",
        "interior_stress_rel_error",
    )
    add(
        "constraint",
        "reaction on the loaded face",
        abs(exact_nn) * c["side"] * (1.0 + default.reaction_rel_error),
        abs(exact_nn) * c["side"],
        "kN/m",
        "reaction_rel_error",
    )
    figure, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for column, label in (
        ("reaction_rel_error", "reaction"),
        ("sigma_nn_rel_error", "interior sigma_nn"),
    ):
        for method, style in (("penalty", "o-"), ("nitsche", "s--")):
            runs = table[table.method == method]
            sweep = runs[runs.cells_per_side == c["default_cells"]]
            refined = runs[runs.penalty_factor == c["default_factor"]]
            for axis, x, y in (
                (axes[0], sweep.penalty_factor, sweep[column]),
                (axes[1], c["side"] / refined.cells_per_side, refined[column]),
            ):
                if not y.empty:
                    axis.semilogx(x, 100 * y, style, label=f"{label}, {method}")
    axes[0].set_xlabel("penalty factor (beta = factor M / h)")
    axes[1].set_xlabel("h (m), penalty factor 100")
    for axis in axes:
        axis.axhline(0.0, color="grey", lw=0.8)
        axis.set_ylabel("error (%)")
        axis.legend()
    outcome.figures.append(
        save_figure(
            folder,
            figure,
            "constraint",
            "Constraint on the detected boundary: error against the penalty and h",
        )
    )
