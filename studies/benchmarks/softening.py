"""The softening benchmark: a plane-strain compression test of a softening specimen on three grids,
plain and regularised, MPM and dolfinx."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from studies.common.outcome import Metric, StudyOutcome
from studies.common.outputs import read_timeseries
from studies.common.tables import save_figure, write_table
from studies.benchmarks.common import (
    SOFTENING,
    _missing,
    _out,
)


def softening_case(cells: int, regularised: bool) -> dict:
    """The compression test of SOFTENING on `cells` cells across the width (quadratic
    B-splines; the platens are the grid's top and bottom edges, two cells of free grid on
    either side), plain or regularised. The top platen's condition is the third
    (reaction_2_fy)."""
    s = SOFTENING
    width, height = s["width"], s["height"]
    h = width / cells
    margin = max(2, int(round(0.25 / h)))

    def material(name, cohesion):
        law = [
            [0.0, cohesion],
            [s["residual_plastic_strain"], cohesion * s["residual_fraction"]],
        ]
        m = {
            "name": name,
            "model": "tresca",
            "youngs_modulus": s["youngs_modulus"],
            "poisson_ratio": s["poisson_ratio"],
            "unit_weight": 20.0,
            "cohesion": {"table": law},
        }
        if regularised:
            m["softening_length"] = s["softening_length"]
        return m

    duration, ramp = s["duration"], s["ramp_fraction"] * s["duration"]
    return {
        "title": f"benchmark softening: compression test, h = 1/{cells} m, "
        + ("regularised" if regularised else "plain"),
        "grid": {
            "origin": [-margin * h, 0.0],
            "cell_size": h,
            "n_cells": [cells + 2 * margin, int(round(height / h))],
        },
        "materials": [
            material("soil", s["cohesion"]),
            material("weak", s["flaw_cohesion"]),
        ],
        "bodies": [
            {
                "name": "flaw",
                "material": "weak",
                "rectangle": [[0, 0], [s["flaw"]] * 2],
            },
            {
                "name": "specimen",
                "material": "soil",
                "rectangle": [[0, 0], [width, height]],
            },
        ],
        "gravity": {"g": 0.0},
        "node_sets": [
            {"name": "centre", "box": [[width / 2, 0.0], [width / 2, 0.0]]},
        ],
        "boundary_conditions": [
            {"where": "bottom", "fix": "y"},
            {"where": "centre", "fix": "x"},
            {
                "where": "top",
                "fix": "y",
                "velocity": [0.0, -softening_speed()],
                "time_function": {"type": "smooth_ramp", "ramp_time": ramp},
            },
        ],
        "solver": {"shape_function": "quadratic_bspline", "damping": 0.0},
        "time": {"end_time": duration, "cfl": 0.5},
        "output": {
            "interval": duration / 4,
            "timeseries_interval": duration / s["samples"],
        },
    }


def softening_speed() -> float:
    """m/s: the top platen's speed after its smooth ramp, for the shortening of SOFTENING."""
    s = SOFTENING
    return s["shortening"] / (s["duration"] * (1.0 - s["ramp_fraction"] / 2.0))


def softening_curve(out: Path) -> pd.DataFrame:
    """shortening (m, the platen's displacement: v (t - t_r / 2) after the ramp t_r) and force
    (kN/m, the top platen's reaction) of a softening_case run, from the end of the ramp.
    """
    s = SOFTENING
    series = read_timeseries(out)
    ramp = s["ramp_fraction"] * s["duration"]
    series = series[series["time"] >= ramp]
    return pd.DataFrame(
        {
            "shortening": softening_speed() * (series["time"] - ramp / 2.0),
            "force": -series["reaction_2_fy"],
        }
    ).reset_index(drop=True)


def dolfinx_softening_curve(out: Path) -> pd.DataFrame:
    """shortening (m) and force (kN/m) of a softening_case run of the dolfinx model (static,
    every converged increment): the top platen's prescribed displacement and reaction.
    """
    series = read_timeseries(out)
    return pd.DataFrame(
        {"shortening": -series["displacement_2_y"], "force": -series["reaction_2_fy"]}
    )


def half_softening_shortening(curve: pd.DataFrame, residual: float) -> float:
    """The shortening past the peak at which the force first falls halfway from the peak to
    `residual` (linear between the samples); NaN if it never does."""
    peak = int(curve["force"].idxmax())
    level = 0.5 * (curve["force"].iloc[peak] + residual)
    after = curve.iloc[peak:]
    below = np.flatnonzero(after["force"].to_numpy() <= level)
    if len(below) == 0:
        return float("nan")
    k = peak + int(below[0])
    (d0, f0), (d1, f1) = curve.iloc[k - 1], curve.iloc[k]
    return float(d0 + (level - f0) * (d1 - d0) / (f1 - f0))


def softening_jobs() -> dict:
    """The MPM's runs (softening/<law>/cells<n>), then the dolfinx model's
    (softening/dolfinx/<law>/cells<n>)."""
    s = SOFTENING
    laws = {"plain": False, "regularised": True}
    jobs = {
        f"softening/{law}/cells{n}": (softening_case(n, r), "mpm")
        for n in s["cells_across"]
        for law, r in laws.items()
    }
    for n in s["dolfinx_cells_across"]:
        for law, r in laws.items():
            jobs[f"softening/dolfinx/{law}/cells{n}"] = (
                softening_case(n, r),
                "dolfinx",
                s["dolfinx_steps"],
            )
    return jobs


def _softening(outs: dict, outcome: StudyOutcome, folder: Path):
    """The softening compression test on every grid, plain and regularised, on the MPM and
    the dolfinx model: the table softening.md (peak force, shortening at half softening), the
    curves softening.png, and per code and law the spread over the grids of the shortening at
    half softening, (largest - smallest) / smallest
    (benchmarks.softening.[dolfinx_]<law>_half_softening_spread). A dolfinx run that stopped
    (Newton failed: a snap-back) is read up to its stop; missing, its rows are left out.
    """
    import matplotlib.pyplot as plt

    s = SOFTENING
    peak_force = 2.0 * s["cohesion"] * s["width"]  # Tresca, unconfined: s1 - s3 = 2 c
    residual = peak_force * s["residual_fraction"]
    codes = {
        "mpm": ("", s["cells_across"], lambda run: softening_curve(_out(run))),
        "dolfinx": (
            "dolfinx/",
            s["dolfinx_cells_across"],
            lambda run: dolfinx_softening_curve(_out(run)),
        ),
    }
    rows, curves = [], {}
    for code, (prefix, grids, read) in codes.items():
        for law in ("plain", "regularised"):
            for cells in grids:
                run = outs[f"softening/{prefix}{law}/cells{cells}"]
                if code == "dolfinx" and _missing(run):
                    continue
                curve = read(run)
                curves[(code, law, cells)] = curve
                rows.append(
                    {
                        "code": code,
                        "law": law,
                        "cells_across": cells,
                        "h_m": s["width"] / cells,
                        "peak_force_kN_per_m": float(curve["force"].max()),
                        "peak_rel_error": float(curve["force"].max()) / peak_force
                        - 1.0,
                        "half_softening_shortening_m": half_softening_shortening(
                            curve, residual
                        ),
                        "last_shortening_m": float(curve["shortening"].iloc[-1]),
                    }
                )
    table = pd.DataFrame(rows)
    outcome.tables.append(
        write_table(
            folder,
            table,
            "softening",
            f"Softening compression test ({s['width']:g} m x {s['height']:g} m, c "
            f"{s['cohesion']:g} -> {s['cohesion'] * s['residual_fraction']:g} kPa over a "
            f"plastic strain of {s['residual_plastic_strain']:g}, softening_length "
            f"{s['softening_length']:g} m): peak force (2 c W = {peak_force:g} kN/m) and the "
            f"shortening at which the force has fallen halfway to {residual:g} kN/m, on three "
            f"grids, the law as given (plain) and regularised; the MPM (quadratic B-splines) "
            f"and the dolfinx model (P2 triangles, static; last_shortening_m short of "
            f"{s['shortening']:g} m: its Newton failed there)",
        )
    )
    for (code, law), group in table.groupby(["code", "law"]):
        d = group["half_softening_shortening_m"]
        if d.notna().all() and len(d) == len(codes[code][1]):
            name = law if code == "mpm" else f"{code}_{law}"
            outcome.metrics.append(
                Metric(
                    f"benchmarks.softening.{name}_half_softening_spread",
                    float(d.max() / d.min() - 1.0),
                    "1",
                )
            )
    outcome.metrics.append(
        Metric(
            "benchmarks.softening.peak_rel_error",
            float(table[table["code"] == "mpm"]["peak_rel_error"].abs().max()),
            "1",
        )
    )
    figure, axes = plt.subplots(2, 2, figsize=(11, 7.5), sharey=True, sharex=True)
    for row, code in zip(axes, codes):
        for axis, law in zip(row, ("plain", "regularised")):
            for cells in codes[code][1]:
                if (code, law, cells) not in curves:
                    continue
                curve = curves[(code, law, cells)]
                axis.plot(curve["shortening"], curve["force"], label=f"h = 1/{cells} m")
            for level, text in ((peak_force, "2 c W"), (residual, "2 c_r W")):
                axis.axhline(level, color="0.6", lw=0.8, ls="--")
                axis.annotate(
                    text, (s["shortening"], level), ha="right", va="bottom", fontsize=8
                )
            axis.set_title(
                f"{'MPM' if code == 'mpm' else 'dolfinx (P2, static)'}, {law}"
            )
            axis.legend(fontsize=8)
        row[0].set_ylabel("force on the top platen [kN/m]")
    for axis in axes[1]:
        axis.set_xlabel("shortening (top platen's displacement) [m]")
    figure.tight_layout()
    outcome.figures.append(
        save_figure(
            folder,
            figure,
            "softening",
            "Softening compression test: force-shortening on three grids, plain and "
            "regularised, MPM (top) and dolfinx (bottom)",
        )
    )
