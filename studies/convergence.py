"""How the errors fall as the grid is refined.

What it measures, for h = 0.5, 0.25, 0.125, 0.0625 m (quick: 0.5, 0.25):

* column settlement: the benchmark column (studies.benchmarks) against q H / M;
* bearing settlement: the bearing block (q = 100 kPa, K0 start) settlement under the load
  centre, its error taken against the finest grid (and the dolfinx model of the base case
  shown beside it when available);
* boundary error: the total boundary error (improved PFM, slope, K0 start, t = 0.625 s) against
  the UL-FEM run on the same h, mean and max in m and in h.

The rates table gives the observed orders log(e_i / e_i+1) / log(h_i / h_i+1).

Why: an error that does not fall with h points at a bug or at a floor (for the boundary: the
detector's own offset, which scales with h if the kernel is sized by the spacing).

Reproduce: ``make study-convergence`` = ``/usr/bin/python3 -m studies convergence [--quick]``.
Needs ``build/bin/pfm-mpm``, ``cases/bearing_block.json``, ``cases/slope.json``; writes
``rates.csv/.md`` and ``convergence.png``.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from studies import analytic, benchmarks
from studies.boundary import OUTPUT_INTERVAL, REFERENCE_OVERRIDE
from studies.common.cases import base_case, body_polygon, derive
from studies.common.measures import surface_settlement
from studies.common.outcome import Metric, StudyOutcome
from studies.common.outputs import file_at_time, need, read_index
from studies.common.parallel import parallel_map
from studies.common.paths import tool_path
from studies.common.runner import run_mpm
from studies.common.tables import save_figure, write_table
from studies.metrics import boundary_distance, read_loops

CELL_SIZES = (0.5, 0.25, 0.125, 0.0625)
QUICK_CELL_SIZES = (0.5, 0.25)
COMPARISON_TIME = 0.625
DETECTOR = "pfm_improved"

EXPECTED_METRICS = ["convergence.column.settlement_order",
                    "convergence.bearing.settlement_order",
                    "convergence.boundary.slope_k0.max_order"]


def refine(case: dict, h: float) -> dict:
    """The same case on a grid of cell size h covering the same region."""
    grid = case["grid"]
    scale = grid["cell_size"] / h
    n_cells = [max(1, int(round(n * scale))) for n in grid["n_cells"]]
    return derive(case, {"grid": {"cell_size": h, "n_cells": n_cells}})


def _mpm(case: dict) -> str:
    return str(run_mpm(case, threads=1).out)


def run(context) -> StudyOutcome:
    context.tools.append(tool_path("pfm-mpm"))
    sizes = QUICK_CELL_SIZES if context.quick else CELL_SIZES
    block, block_path = base_case("bearing_block")
    slope, slope_path = base_case("slope")
    context.case_files += [block_path, slope_path]
    block = derive(block, {"initial_stress": {"method": "k0"},
                           "loads": [dict(l, pressure=100.0) for l in block.get("loads", [])]})
    slope = derive(slope, {"initial_stress": {"method": "k0"},
                           "time": {"end_time": COMPARISON_TIME},
                           "output": {"interval": OUTPUT_INTERVAL},
                           "detection": {"method": DETECTOR}})
    column = benchmarks.column_case()
    tasks = []
    for h in sizes:
        tasks += [("column", h, refine(column, h)), ("bearing", h, refine(block, h)),
                  ("slope", h, refine(slope, h)),
                  ("slope_reference", h, derive(refine(slope, h), REFERENCE_OVERRIDE))]
    outs = dict(((kind, h), Path(p)) for (kind, h, _), p in zip(tasks, parallel_map(
        _mpm, [c for _, _, c in tasks], context.options.jobs, context.options.scheduler,
        "convergence runs")))

    rows = []
    c, m = benchmarks.COLUMN, benchmarks.ELASTIC
    exact = analytic.column_surcharge_settlement(c["height"], c["surcharge"],
                                                 m["youngs_modulus"], m["poisson_ratio"])
    load = block["loads"][0]
    top = max(p[1] for p in body_polygon(block))
    bearing = {}
    for h in sizes:
        particles = pd.read_csv(need(outs[("column", h)] / "final_particles.csv"))
        value = surface_settlement(particles, 0.5 * c["width"], c["height"], h)
        rows.append({"quantity": "column settlement", "h_m": h, "value": value,
                     "error": abs(value - exact)})
        particles = pd.read_csv(need(outs[("bearing", h)] / "final_particles.csv"))
        bearing[h] = surface_settlement(particles, 0.5 * sum(load["x_range"]), top, h)
        detected = file_at_time(read_index(outs[("slope", h)], "boundary"), COMPARISON_TIME,
                                0.5 * OUTPUT_INTERVAL)
        reference = file_at_time(read_index(outs[("slope_reference", h)], "boundary"),
                                 COMPARISON_TIME, 0.5 * OUTPUT_INTERVAL)
        if detected is None or reference is None:
            raise ValueError(f"slope h = {h}: no boundary output at t = {COMPARISON_TIME} s")
        distance = boundary_distance(read_loops(detected), read_loops(reference), h=h).overall
        rows.append({"quantity": "slope boundary max error", "h_m": h, "value": distance.max,
                     "error": distance.max})
        rows.append({"quantity": "slope boundary mean error", "h_m": h, "value": distance.mean,
                     "error": distance.mean})
    finest = min(sizes)
    for h in sizes:
        if h != finest:
            rows.append({"quantity": "bearing settlement", "h_m": h, "value": bearing[h],
                         "error": abs(bearing[h] - bearing[finest])})
    table = pd.DataFrame(rows).sort_values(["quantity", "h_m"], ascending=[True, False])
    orders = []
    for _, group in table.groupby("quantity", sort=False):
        orders += analytic.observed_orders(list(group["h_m"]), list(group["error"]))
    table["observed_order"] = orders
    outcome = StudyOutcome(study="convergence")
    outcome.tables.append(write_table(context.folder, table, "rates",
                                      "Errors and observed orders against h"))
    for quantity, name in (("column settlement", "convergence.column.settlement_order"),
                           ("bearing settlement", "convergence.bearing.settlement_order"),
                           ("slope boundary max error",
                            "convergence.boundary.slope_k0.max_order")):
        values = table[table["quantity"] == quantity]["observed_order"].dropna()
        if len(values):
            outcome.metrics.append(Metric(name, float(values.iloc[-1]), "1",
                                          "order between the two finest grids"))
    outcome.figures.append(save_figure(context.folder, rates_figure(table), "convergence",
                                       "Errors against the cell size"))
    return outcome


def rates_figure(table: pd.DataFrame):
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(5.5, 4))
    for quantity, group in table.groupby("quantity"):
        axis.loglog(group["h_m"], group["error"], "o-", label=quantity)
    axis.set_xlabel("h [m]")
    axis.set_ylabel("error [m]")
    axis.legend(fontsize=7)
    axis.grid(True, which="both", alpha=0.3)
    return figure
