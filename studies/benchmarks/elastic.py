"""The elastic benchmarks with closed forms: the column under its weight and a surcharge, the strip
load on a block, and the disk under a follower pressure on its detected boundary."""

from __future__ import annotations


import numpy as np
import pandas as pd

from studies import analytic
from studies.common.cases import is_bspline
from studies.common.measures import initial_positions, surface_settlement_extrapolated
from studies.common.outcome import Metric
from studies.common.outputs import read_timeseries
from studies.common.paths import PrerequisiteMissing
from studies.common.tables import save_figure
from studies.benchmarks.common import (
    COLUMN,
    DISK,
    ELASTIC,
    H,
    STRIP,
    _block,
    _out,
    _particles,
)


def column_case(
    h: float = H,
    shape_function: str | None = "linear",
    apply_on: str = "grid_top_nodes",
) -> dict:
    """The column from zero stress: weight (gravity ramp 0.5 s) and surcharge (ramp 0.5 s), on
    the grid-top nodes or on the detected top. shape_function None: pfm-mpm's default. With
    B-splines the grid's edges are its base and sides, with two cell rows of headroom above it
    (a B-spline at the top reaches the row above)."""
    c = COLUMN
    case = _block(
        c["width"],
        c["height"],
        ELASTIC,
        [
            {
                "type": "vertical_pressure",
                "pressure": c["surcharge"],
                "x_range": [0.0, c["width"]],
                "time_function": {"type": "ramp", "ramp_time": 0.5},
            }
        ],
        initial="zero",
        end_time=c["end_time"],
        h=h,
        damping=c["damping"],
        headroom=2 if is_bspline(shape_function) else 0,
        shape_function=shape_function,
    )
    case["title"] = f"benchmark column, h = {h} m"
    names = {
        None: "the default shape function",
        "gimp": "GIMP",
        "quadratic_bspline": "quadratic B-splines",
    }
    if shape_function != "linear":
        case["title"] += ", " + names.get(shape_function, shape_function)
    if apply_on != "grid_top_nodes":
        case["loads"][0]["apply_on"] = apply_on
        case["title"] += ", load on the " + apply_on.replace("_", " ")
    return case


def strip_case(pressure=None, material=None) -> dict:
    s = STRIP
    centre = 0.5 * s["width"]
    # Weightless soil: gravity off (g = 0); the unit weight still gives the mass density.
    case = _block(
        s["width"],
        s["depth"],
        material or ELASTIC,
        [
            {
                "type": "vertical_pressure",
                "pressure": s["pressure"] if pressure is None else pressure,
                "x_range": [centre - s["half_width"], centre + s["half_width"]],
                "time_function": {"type": "ramp", "ramp_time": 0.5},
            }
        ],
        gravity=False,
    )
    case["title"] = "benchmark strip load"
    return case


def disk_case() -> dict:
    r = DISK["radius"]
    angles = np.linspace(0.0, 2 * np.pi, 128, endpoint=False)
    centre = r + 1.0
    polygon = [[centre + r * np.cos(a), centre + r * np.sin(a)] for a in angles]
    return {
        "title": "benchmark disk under external pressure on its detected boundary",
        "grid": {
            "origin": [0.0, 0.0],
            "cell_size": H,
            "n_cells": [int(round((2 * r + 2) / H))] * 2,
        },
        "materials": [ELASTIC],
        "bodies": [{"name": "disk", "material": "elastic", "polygon": polygon}],
        "gravity": {"g": 0.0},
        "node_sets": [
            {"name": "centre", "box": [[centre - 1e-9] * 2, [centre + 1e-9] * 2]}
        ],
        "boundary_conditions": [{"where": "centre", "fix": "xy"}],
        "loads": [
            {
                "type": "follower_pressure",
                "pressure": DISK["pressure"],
                "apply_on": "detected_boundary",
                "time_function": {"type": "ramp", "ramp_time": 0.5},
            }
        ],
        "detection": {"method": "improved", "every_steps": 1},
        "solver": {"damping": 0.5, "shape_function": "linear"},
        "time": {"end_time": 2.0},
        "output": {"interval": 1.0},
    }


def column_read_outs(particles: pd.DataFrame, h: float) -> dict:
    """Top settlement (extrapolated from the top cell row of points), the largest point-wise
    displacement error against the small-strain profile (relative to the exact settlement) and
    the largest stress error max |syy - exact(y0)| / (q + gamma H)."""
    c, m = COLUMN, ELASTIC
    start = initial_positions(particles)
    exact_profile = analytic.column_displacement(
        start[:, 1],
        c["height"],
        c["surcharge"],
        m["unit_weight"],
        m["youngs_modulus"],
        m["poisson_ratio"],
    )
    exact = analytic.column_settlement(
        c["height"],
        c["surcharge"],
        m["unit_weight"],
        m["youngs_modulus"],
        m["poisson_ratio"],
    )
    stress = analytic.column_vertical_stress(
        start[:, 1], c["height"], c["surcharge"], m["unit_weight"]
    )
    return {
        "settlement": surface_settlement_extrapolated(
            particles, 0.5 * c["width"], c["height"], h
        ),
        "displacement_max_rel_error": float(
            np.max(np.abs(particles["uy"] - exact_profile)) / exact
        ),
        "stress_max_rel_error": float(
            np.max(np.abs(particles["syy"] - stress))
            / (c["surcharge"] + m["unit_weight"] * c["height"])
        ),
    }


def _column(run, add, outcome, folder):
    c, m = COLUMN, ELASTIC
    particles = _particles(run)
    found = column_read_outs(particles, H)
    args = (
        c["height"],
        c["surcharge"],
        m["unit_weight"],
        m["youngs_modulus"],
        m["poisson_ratio"],
    )
    add(
        "column",
        "top settlement, q H / M + gamma H^2 / (2 M) (small strain)",
        found["settlement"],
        analytic.column_settlement(*args),
        "m",
        "settlement_rel_error",
    )
    add(
        "column",
        "top settlement, large strain (log-strain, Jaumann rate)",
        found["settlement"],
        analytic.column_settlement_large_strain(*args),
        "m",
    )
    series = read_timeseries(_out(run))
    outcome.metrics += [
        Metric(
            "benchmarks.column.stress_max_rel_error",
            found["stress_max_rel_error"],
            "1",
            "max |syy - exact(y0)| / (q + gamma H)",
        ),
        Metric(
            "benchmarks.column.displacement_max_rel_error",
            found["displacement_max_rel_error"],
            "1",
            "max |uy - exact(y0)| / settlement, small strain",
        ),
        Metric(
            "benchmarks.column.final_to_peak_kinetic_energy",
            float(series["kinetic_energy"].iloc[-1] / series["kinetic_energy"].max()),
            "1",
        ),
    ]
    import matplotlib.pyplot as plt

    start = initial_positions(particles)
    figure, axis = plt.subplots(figsize=(4, 5))
    axis.plot(particles["syy"], start[:, 1], ".", label="MPM")
    ys = np.linspace(0, c["height"], 50)
    axis.plot(
        analytic.column_vertical_stress(
            ys, c["height"], c["surcharge"], m["unit_weight"]
        ),
        ys,
        "k-",
        label="exact",
    )
    axis.set_xlabel("syy [kPa]")
    axis.set_ylabel("initial height y0 [m]")
    axis.legend()
    outcome.figures.append(
        save_figure(
            folder,
            figure,
            "column_stress",
            "Column: vertical stress against initial height",
        )
    )


def _strip(run, add, outcome, folder):
    s = STRIP
    particles = _particles(run)
    centre = 0.5 * s["width"]
    near = np.abs(particles["x"] - centre) <= 0.5 * H
    depth = s["depth"] - particles["y"][near]
    ours = -particles["syy"][near]  # compression positive
    exact = analytic.strip_vertical_stress(s["pressure"], s["half_width"], 0.0, depth)
    window = (depth >= s["half_width"]) & (depth <= 4 * s["half_width"])
    if not window.any():
        raise PrerequisiteMissing("particles under the strip centre")
    error = float(np.max(np.abs(ours[window] - exact[window])) / s["pressure"])
    at = int(np.argmin(np.abs(depth.to_numpy() - 2 * s["half_width"])))
    add(
        "strip",
        f"sigma_z under the centre at z = {float(depth.iloc[at]):.3g} m (~2b)",
        float(ours.iloc[at]),
        float(exact[at]),
        "kPa",
    )
    outcome.metrics.append(
        Metric(
            "benchmarks.strip.sigma_z_max_rel_error",
            error,
            "1",
            "max over z in [b, 4b] of |sigma_z - exact| / q",
        )
    )
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(4, 5))
    axis.plot(ours, depth, ".", label="MPM")
    zs = np.linspace(0.01, s["depth"], 100)
    axis.plot(
        analytic.strip_vertical_stress(s["pressure"], s["half_width"], 0.0, zs),
        zs,
        "k-",
        label="half-space",
    )
    axis.invert_yaxis()
    axis.set_xlabel("sigma_z under the centre [kPa, compression +]")
    axis.set_ylabel("depth [m]")
    axis.legend()
    outcome.figures.append(
        save_figure(
            folder,
            figure,
            "strip_sigma_z",
            "Strip load: vertical stress under the centre",
        )
    )


def _disk(run, add, outcome, folder):
    d = DISK
    particles = _particles(run)
    start = initial_positions(particles)
    centre = d["radius"] + 1.0
    radius0 = np.hypot(start[:, 0] - centre, start[:, 1] - centre)
    away = radius0 >= 0.5 * d["radius"]  # away from the fixed centre node
    radial = (
        particles["ux"] * (start[:, 0] - centre)
        + particles["uy"] * (start[:, 1] - centre)
    ) / np.maximum(radius0, 1e-12)
    strain = float(np.mean(radial[away] / radius0[away]))
    exact = analytic.disk_external_pressure(
        d["radius"], d["pressure"], ELASTIC["youngs_modulus"], ELASTIC["poisson_ratio"]
    )
    add(
        "disk",
        "radial displacement at r = R (uniform radial strain x R)",
        strain * d["radius"],
        exact["radial_displacement"],
        "m",
        "radial_displacement_rel_error",
    )
    series = read_timeseries(_out(run))
    if "load_applied_fx" in series:
        last = series.iloc[-1]
        scale = d["pressure"] * 2 * np.pi * d["radius"]
        outcome.metrics += [
            Metric(
                "benchmarks.disk.net_force_rel",
                float(
                    np.hypot(last["load_applied_fx"], last["load_applied_fy"]) / scale
                ),
                "1",
                "|sum of the nodal forces| / (p 2 pi R)",
            ),
            Metric(
                "benchmarks.disk.lost_force_rel",
                float(np.hypot(last["load_lost_fx"], last["load_lost_fy"]) / scale),
                "1",
                "|force on nodes of empty cells| / (p 2 pi R)",
            ),
        ]
