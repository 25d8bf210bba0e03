"""Long-run stability: does a body under a load on its top come to rest and stay there, with
every shape function and both schemes?

The runs: the elastic column under a surcharge on its detected top (tests/python/
test_boundary_holds.py's: 1 x 4 m, h = 0.25 m, 30 kPa, damping 0.1) to 60 s, 60 times its load
ramp; the shipped rest cases, ``cases/bearing_quasi_static.json`` (the strip load on the clay
layer, at rest by 10 s) and ``cases/column.json`` (self-weight, at rest by 4 s) to 60 s too,
each with its shape function replaced by each of linear, uGIMP, quadratic and cubic B-splines
(the shipped bearing case's walls are node sets at the body's faces with a margin of 2 cells,
as uGIMP needs; the columns' supports are the grid's edges, which uGIMP cannot take, so uGIMP
gets a margin and node-set walls there; cases/column.json is 2 cells wide, too narrow for cubic
B-splines), with MUSL and with USL; every other setting as the
case has it (defaults included: the ties of nearly empty nodes with B-splines,
mpm/core/basis_extension.hpp).

Per run: the kinetic energy at the end against the external work (the share of the work still
moving), the kinetic energy at the end against its value halfway (above 1: growing), and the
drift of the external work over the last half, (max - min) / |final| (a load pumping energy in
shows as the work falling: the soil pushing the load back up). The figure plots the kinetic
energy over the external work against time for every run. Metrics
``stability.<case>.<shape>.<scheme>.kinetic_to_work``, ``.work_drift`` and ``.kinetic_growth``
are gated (reports/thresholds.json: at rest means below 1e-5 of the work, a drift below 0.1 %
and no more than 1 % of growth over the last half).
The quick variant (make test) runs the column under a surcharge alone, with MUSL and with USL
for the quadratic B-splines.

Reproduce: ``make study-stability`` (``QUICK=1`` for the quick variant).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from studies.common.outcome import Metric, StudyOutcome
from studies.common.parallel import parallel_map
from studies.common.paths import repo_root
from studies.common.runner import run_mpm
from studies.common.tables import save_figure, write_table

SHAPES = ("linear", "gimp", "quadratic_bspline", "cubic_bspline")
SCHEMES = ("musl", "usl")
# Case name -> end time (s) of the long run.
END_TIMES = {"column_surcharge": 60.0, "bearing_quasi_static": 60.0, "column": 60.0}
# Cubic B-splines need 3 cells along each axis; cases/column.json has 2 across.
SKIPPED = {("column", "cubic_bspline")}
QUICK_RUNS = [("column_surcharge", s, "musl") for s in SHAPES] + [
    ("column_surcharge", "quadratic_bspline", "usl")
]


def column_surcharge_case() -> dict:
    """The column of tests/python/test_boundary_holds.py, load on its detected top."""
    return {
        "title": "column under a 30 kPa surcharge on its detected top",
        "grid": {"origin": [0.0, 0.0], "cell_size": 0.25, "n_cells": [4, 20]},
        "materials": [
            {
                "name": "soil",
                "model": "linear_elastic",
                "youngs_modulus": 5000.0,
                "poisson_ratio": 0.25,
                "unit_weight": 18.0,
            }
        ],
        "bodies": [
            {
                "name": "column",
                "material": "soil",
                "rectangle": [[0.0, 0.0], [1.0, 4.0]],
                "points_per_cell": 2,
            }
        ],
        "gravity": {"g": 9.81, "ramp_time": 1.0},
        "boundary_conditions": [
            {"where": "bottom", "fix": "xy"},
            {"where": "left", "fix": "x"},
            {"where": "right", "fix": "x"},
        ],
        "loads": [
            {
                "type": "vertical_pressure",
                "pressure": 30.0,
                "x_range": [0.0, 1.0],
                "apply_on": "detected_boundary",
                "time_function": {"type": "ramp", "ramp_time": 1.0},
            }
        ],
        "solver": {"damping": 0.1},
        "time": {"end_time": 4.0},
    }


def with_margin(case: dict) -> dict:
    """A case whose supports are the grid's edges (bottom, left, right) moved inside the grid, as
    uGIMP needs: a margin of 2 cells, and walls as node sets at the old edges holding the nodes
    behind them."""
    grid = case["grid"]
    h = grid["cell_size"]
    x0, y0 = grid["origin"]
    x1 = x0 + grid["n_cells"][0] * h
    grid["origin"] = [x0 - 2 * h, y0 - 2 * h]
    grid["n_cells"] = [grid["n_cells"][0] + 4, grid["n_cells"][1] + 2]
    far = 1000.0
    eps = 1e-9 * h
    case["node_sets"] = case.get("node_sets", []) + [
        {"name": "grid_base", "box": [[-far, -far], [far, y0 + eps]]},
        {"name": "grid_left", "box": [[-far, y0], [x0 + eps, far]]},
        {"name": "grid_right", "box": [[x1 - eps, y0], [far, far]]},
    ]
    renamed = {"bottom": "grid_base", "left": "grid_left", "right": "grid_right"}
    for bc in case["boundary_conditions"]:
        bc["where"] = renamed.get(bc["where"], bc["where"])
    return case


def run_case(name: str, shape: str, scheme: str) -> dict:
    if name == "column_surcharge":
        case = column_surcharge_case()
    else:
        case = json.loads((repo_root() / "cases" / f"{name}.json").read_text())
    case["title"] = f"{case.get('title', name)} [stability: {shape}, {scheme}]"
    end = END_TIMES[name]
    case["time"]["end_time"] = end
    case["output"] = {"interval": end / 4, "timeseries_interval": end / 400}
    case.setdefault("solver", {})
    case["solver"]["shape_function"] = shape
    case["solver"]["scheme"] = scheme
    sides = {bc["where"] for bc in case.get("boundary_conditions", [])}
    if shape == "gimp" and sides & {"bottom", "left", "right"}:
        case = with_margin(case)
    return case


def _run(task) -> str:
    return str(run_mpm(run_case(*task), threads=1).out)


def measure(out: Path) -> dict:
    series = pd.read_csv(Path(out) / "timeseries.csv")
    time = series["time"].to_numpy()
    kinetic = series["kinetic_energy"].to_numpy()
    work = series["external_work"].to_numpy()
    half = time >= time[-1] / 2 - 1e-9
    final = abs(work[-1])
    return {
        "kinetic_to_work": kinetic[-1] / final,
        "kinetic_growth": kinetic[-1] / kinetic[half][0]
        if kinetic[half][0] > 0
        else 0.0,
        "work_drift": (work[half].max() - work[half].min()) / final,
        "series": pd.DataFrame({"time": time, "ratio": kinetic / max(final, 1e-300)}),
    }


def envelope_figure(curves: dict):
    import matplotlib.pyplot as plt

    cases = sorted({key[0] for key in curves})
    figure, axes = plt.subplots(
        1, len(cases), figsize=(5 * len(cases), 4), squeeze=False
    )
    for axis, name in zip(axes[0], cases):
        for (case, shape, scheme), frame in sorted(curves.items()):
            if case != name:
                continue
            axis.semilogy(
                frame["time"],
                np.clip(frame["ratio"], 1e-16, None),
                "-" if scheme == "musl" else "--",
                label=f"{shape}, {scheme}",
                linewidth=1,
            )
        axis.axhline(1e-5, color="grey", linewidth=0.8, linestyle=":")
        axis.set_title(name, fontsize=9)
        axis.set_xlabel("time (s)")
        axis.set_ylabel("kinetic energy / external work at the end")
        axis.legend(fontsize=6)
    return figure


def run(context) -> StudyOutcome:
    outcome = StudyOutcome(study="stability")
    tasks = (
        QUICK_RUNS
        if context.quick
        else [
            (name, shape, scheme)
            for name in END_TIMES
            for shape in SHAPES
            for scheme in SCHEMES
            if (name, shape) not in SKIPPED
        ]
    )
    outs = parallel_map(
        _run,
        tasks,
        jobs=context.options.jobs,
        scheduler=context.options.scheduler,
        description="stability",
    )
    rows, curves = [], {}
    for task, out in zip(tasks, outs):
        m = measure(Path(out))
        curves[task] = m.pop("series")
        rows.append(dict(zip(("case", "shape_function", "scheme"), task), **m))
        prefix = "stability." + ".".join(task)
        outcome.metrics += [
            Metric(f"{prefix}.kinetic_to_work", m["kinetic_to_work"], "1"),
            Metric(f"{prefix}.work_drift", m["work_drift"], "1"),
            Metric(f"{prefix}.kinetic_growth", m["kinetic_growth"], "1"),
        ]
    table = pd.DataFrame(rows)
    outcome.tables.append(
        write_table(
            context.folder,
            table,
            "stability",
            "Kinetic energy / external work at the end, its growth over the last half "
            "(end / halfway) and the drift of the external work over the last half",
        )
    )
    outcome.figures.append(
        save_figure(
            context.folder,
            envelope_figure(curves),
            "kinetic_envelope",
            "Kinetic energy over the final external work against time (solid MUSL, dashed "
            "USL; dotted: 1e-5)",
        )
    )
    outcome.expected = [
        f"stability.{n}.{s}.{k}.{what}"
        for n in END_TIMES
        for s in SHAPES
        for k in SCHEMES
        for what in ("kinetic_to_work", "work_drift", "kinetic_growth")
        if (n, s) not in SKIPPED
    ]
    return outcome
