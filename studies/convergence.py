"""How the errors fall as the grid is refined.

What it measures, for h = 0.5, 0.25, 0.125, 0.0625 m (quick: 0.5, 0.25):

* manufactured solution (mpm/core/manufactured.hpp; Wallstedt and Guilkey 2008): a unit
  square of elastic soil, edges fixed, driven by the body force that makes
  u = A (1 - cos(2 pi t / T))^2 / 4 sin(pi x) sin(pi y) (1, 1) exact, on 8, 16, 32 and 64 cells
  across (quick: 8 to 32), for the MPM (linear and uGIMP, MUSL and USL; quadratic and cubic
  B-splines, MUSL, on a grid whose edges are the square's) and the UL-FEM, and quasi-statically
  by the implicit MPM (every shape function) and the implicit UL-FEM, held by the static body
  force -div sigma / rho: the relative L2 errors of displacement and stress at t = T / 2
  (``manufactured.png``);
* squeezed disk (the same file's uniform dilatation): a free disk (R = 1 m) squeezed by a
  follower pressure on its detected boundary, smooth ramp to p0 = 0.1 (2 (lambda + mu)), so its
  radius shrinks by 9.5 % and the loaded boundary crosses cells; 8, 16, 32 and 64 cells per
  radius (quick: 8 to 32), linear, uGIMP and the two B-splines: relative L2 errors at the end
  of the ramp against the exact finite-strain motion;

* column settlement: the benchmark column (studies.benchmarks: 1 m x 5 m, weight and 50 kPa
  surcharge on the grid-top nodes, from zero stress) with pfm-mpm's default shape function
  (quadratic B-splines; no margin: the grid's edges hold the column, their edge functions alone
  nonzero there) against the settlement of the solvers' own model, the stress rate M times the
  logarithmic strain rate (analytic.column_settlement_large_strain; 0.40 % below the
  small-strain q H / M + gamma H^2 / (2 M), which no refinement reaches), and the largest
  point-wise displacement error (against the small-strain profile). The surcharge stays on the
  initial top while the column settles (0.037 m, 0.6 h at the finest grid), so the load's
  distribution over the node rows near the top is wrong by O(1) in a layer of O(h): first
  order at best;
* the same column with the surcharge on the detected top (``column settlement (detected
  top)``), which moves with the column;
* the same column with linear and with GIMP shape functions (``column settlement (linear)``,
  ``(GIMP)``), the surcharge on the grid-top nodes: with linear shape functions the points
  that cross a cell edge as the column settles put stress jumps into it that grow as h falls
  below the settlement (cell-crossing error), and the settlement diverges; GIMP's smooth
  weights are the field's remedy, and the error that remains in the GIMP column (its top row)
  is that of a load left behind by a moving boundary;
* bearing settlement: an elastic bearing block (15 m x 5 m, E = 1e4 kPa, nu = 0.15, K0 start,
  q = 50 kPa on [5, 10] m on the grid top nodes, ramped over 0.5 s, damped to rest) under the
  load centre, against the dolfinx P2 model of the same case (static, small strain). The
  thesis's softening soil is left out on purpose: without regularisation its response depends
  on the mesh, so it has no limit to converge to;
* boundary error: the slope from K0 at t = 0.625 s against the UL-FEM on the same h, improved
  detector: ``total`` (the MPM run's own boundary) and ``detector_only`` (the detector on the
  UL-FEM's points), max and mean over the free surface (studies.boundary), in m.

The rates table gives the observed orders log(e_i / e_i+1) / log(h_i / h_i+1)
(studies.common.convergence.ConvergenceStudy).

Why: an error that does not fall with h points at a bug or at a floor (for the boundary: the
difference between the MPM and the FEM motion of softening soil, which does not vanish).

Reproduce: ``make study-convergence`` = ``/usr/bin/python3 -m studies convergence [--quick]``.
Needs ``pfm-mpm`` (``run``, ``run --solver ulfem``, ``detect``), ``cases/thesis55_slope_dynamic_zero_start.json`` and
``fem_reference/dolfinx_model``; writes ``rates.csv/.md``, ``manufactured.png`` and
``convergence.png``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from studies import analytic, benchmarks
from studies.boundary import EDGE_BAND_CELLS, OUTPUT_INTERVAL, TIME_TOLERANCE
from studies.common import detectors as det
from studies.common.cases import base_case, cell_size, derive, is_bspline
from studies.common.convergence import ConvergenceStudy
from studies.common.measures import initial_positions, surface_settlement_extrapolated
from studies.common.outcome import Metric, StudyOutcome
from studies.common.outputs import (
    final_particles,
    need,
    read_boundary,
    read_index,
    read_particles,
    row_at_time,
    run_status,
    write_detect_input,
)
from studies.common.parallel import parallel_map
from studies.common.paths import tool_path
from studies.common.runner import run_detect, run_dolfinx, run_mpm
from studies.common.tables import save_figure, write_table
from studies.metrics import boundary_distance, grid_edge_band

CELL_SIZES = (0.5, 0.25, 0.125, 0.0625)
QUICK_CELL_SIZES = (0.5, 0.25)
COMPARISON_TIME = 0.625
DETECTOR = "pfm_improved"
BEARING = {
    "youngs_modulus": 1.0e4,
    "poisson_ratio": 0.15,
    "pressure": 50.0,
    "x_range": [5.0, 10.0],
    "top": 5.0,
    "end_time": 2.0,
    "damping": 0.5,
}

# The manufactured solution (mpm/core/manufactured.hpp): a unit square of elastic soil, every
# edge fixed, driven by the body force that makes u = A (1 - cos(2 pi t / T))^2 / 4 Phi(X) (1, 1)
# exact; compared at t = T / 2, where u is largest. A is small enough that the small-strain
# solution and the updated-Lagrangian runs differ by far less than the discretisation error
# (strains of order pi A = 3e-5).
MANUFACTURED = {
    "size": 1.0,  # m
    "amplitude": 1.0e-5,  # m
    "period": 0.1,  # s (below the square's first natural period, 0.14 s)
    "youngs_modulus": 1.0e4,  # kPa
    "poisson_ratio": 0.3,
}
MANUFACTURED_CELLS = (8, 16, 32, 64)  # cells across the square
QUICK_MANUFACTURED_CELLS = (8, 16, 32)
# (label, solver, shape function, scheme)
MANUFACTURED_METHODS = (
    ("mpm linear musl", "mpm", "linear", "musl"),
    ("mpm linear usl", "mpm", "linear", "usl"),
    ("mpm gimp musl", "mpm", "gimp", "musl"),
    ("mpm gimp usl", "mpm", "gimp", "usl"),
    ("ulfem musl", "ulfem", "linear", "musl"),
    ("mpm quadratic_bspline musl", "mpm", "quadratic_bspline", "musl"),
    ("mpm cubic_bspline musl", "mpm", "cubic_bspline", "musl"),
    # Quasi-static (solver.type "implicit", one load step to T / 2): the same field held by its
    # static body force, b = -div sigma / rho.
    ("implicit mpm linear", "mpm", "linear", "implicit"),
    ("implicit mpm gimp", "mpm", "gimp", "implicit"),
    ("implicit ulfem", "ulfem", "linear", "implicit"),
    ("implicit mpm quadratic_bspline", "mpm", "quadratic_bspline", "implicit"),
    ("implicit mpm cubic_bspline", "mpm", "cubic_bspline", "implicit"),
)

EXPECTED_METRICS = [
    "convergence.manufactured.mpm_linear_musl.displacement_order",
    "convergence.manufactured.mpm_gimp_musl.displacement_order",
    "convergence.manufactured.ulfem_musl.displacement_order",
    "convergence.dilatation.mpm_gimp.displacement_order",
    "convergence.manufactured.mpm_quadratic_bspline_musl.displacement_order",
    "convergence.manufactured.mpm_cubic_bspline_musl.displacement_order",
    "convergence.manufactured.implicit_mpm_linear.displacement_order",
    "convergence.manufactured.implicit_mpm_gimp.displacement_order",
    "convergence.manufactured.implicit_ulfem.displacement_order",
    "convergence.manufactured.implicit_mpm_quadratic_bspline.displacement_order",
    "convergence.manufactured.implicit_mpm_cubic_bspline.displacement_order",
    "convergence.dilatation.mpm_quadratic_bspline.displacement_order",
    "convergence.dilatation.mpm_cubic_bspline.displacement_order",
    "convergence.column.settlement_order",
    "convergence.column.detected_top_settlement_order",
    "convergence.column.linear_settlement_order",
    "convergence.bearing.settlement_order",
    "convergence.boundary.slope_k0.max_order",
]


def refine(case: dict, h: float) -> dict:
    """The same case on a grid of cell size h covering the same region."""
    grid = case["grid"]
    scale = grid["cell_size"] / h
    n_cells = [max(1, int(round(n * scale))) for n in grid["n_cells"]]
    return derive(case, {"grid": {"cell_size": h, "n_cells": n_cells}})


def bearing_case() -> dict:
    b = BEARING
    return {
        "title": "convergence: elastic bearing block, K0 start, q = 50 kPa ramped",
        "grid": {"origin": [0.0, 0.0], "cell_size": 0.5, "n_cells": [30, 12]},
        "materials": [
            {
                "name": "soil",
                "model": "linear_elastic",
                "youngs_modulus": b["youngs_modulus"],
                "poisson_ratio": b["poisson_ratio"],
                "unit_weight": 20.0,
            }
        ],
        "bodies": [
            {
                "name": "block",
                "material": "soil",
                "rectangle": [[0.0, 0.0], [15.0, b["top"]]],
            }
        ],
        "initial_stress": {"method": "k0"},
        "boundary_conditions": [
            {"where": "bottom", "fix": "xy"},
            {"where": "left", "fix": "x"},
            {"where": "right", "fix": "x"},
        ],
        "loads": [
            {
                "type": "vertical_pressure",
                "pressure": b["pressure"],
                "x_range": b["x_range"],
                "apply_on": "grid_top_nodes",
                "time_function": {"type": "ramp", "ramp_time": 0.5},
            }
        ],
        "solver": {"damping": b["damping"], "shape_function": "linear"},
        "time": {"end_time": b["end_time"]},
        "output": {"interval": b["end_time"]},
    }


def manufactured_case(cells: int, shape_function: str, scheme: str) -> dict:
    """The manufactured solution on a grid of `cells` x `cells` cells over the unit square
    (with a 2-cell margin for linear functions and uGIMP, which needs it; none for the B-splines,
    whose edge functions hold the fixed edges: fixing the nodes beyond an edge would hold a
    B-spline's field at zero there instead, and its error would fall at first order), 2 x 2
    points per cell, every node on or beyond the square's edges fixed, run to T / 2. Scheme
    "implicit": the implicit solver in one load step, no inertia (the static body force).
    """
    m = MANUFACTURED
    size, h = m["size"], m["size"] / cells
    margin = 0 if is_bspline(shape_function) else 2
    far = 1e3
    walls = {
        "base": [[-far, -far], [far, 1e-9]],
        "lid": [[-far, size - 1e-9], [far, far]],
        "left_wall": [[-far, -far], [1e-9, far]],
        "right_wall": [[size - 1e-9, -far], [far, far]],
    }
    return {
        "title": f"convergence: manufactured solution, {cells} cells, {shape_function}, "
        f"{scheme}",
        "grid": {
            "origin": [-margin * h, -margin * h],
            "cell_size": h,
            "n_cells": [cells + 2 * margin, cells + 2 * margin],
        },
        "materials": [
            {
                "name": "soil",
                "model": "linear_elastic",
                "youngs_modulus": m["youngs_modulus"],
                "poisson_ratio": m["poisson_ratio"],
                "unit_weight": 20.0,
            }
        ],
        "bodies": [
            {"name": "square", "material": "soil", "rectangle": [[0, 0], [size, size]]}
        ],
        "gravity": {"g": 0.0},
        "node_sets": [{"name": k, "box": box} for k, box in walls.items()],
        "boundary_conditions": [{"where": k, "fix": "xy"} for k in walls],
        "manufactured_solution": {"amplitude": m["amplitude"], "period": m["period"]},
        "time": {"end_time": 0.5 * m["period"]},
        "output": {"interval": 0.5 * m["period"]},
    } | (
        {
            "solver": {"type": "implicit", "shape_function": shape_function},
            "implicit": {"load_steps": 1},
        }
        if scheme == "implicit"
        else {"solver": {"shape_function": shape_function, "scheme": scheme}}
    )


# The moving-boundary manufactured solution: a free disk squeezed by a follower pressure on its
# detected boundary (smooth ramp), the uniform dilatation of mpm/core/manufactured.hpp. p0 is
# 0.1 (2 (lambda + mu)): the radius shrinks by 9.5 %, about 6 cells on the finest grid.
DILATATION = {
    "radius": 1.0,  # m
    "vertices": 256,
    "pressure_over_modulus": 0.1,  # p0 / (2 (lambda + mu))
    "ramp_time": 0.1,  # s
}
DILATATION_CELLS = (8, 16, 32, 64)  # cells per radius
QUICK_DILATATION_CELLS = (8, 16, 32)
DILATATION_METHODS = (
    ("mpm linear", "linear"),
    ("mpm gimp", "gimp"),
    ("mpm quadratic_bspline", "quadratic_bspline"),
    ("mpm cubic_bspline", "cubic_bspline"),
)


def dilatation_case(cells_per_radius: int, shape_function: str) -> dict:
    """The squeezed disk on a grid of h = R / cells_per_radius over [0, 3 R]^2 (the disk at its
    centre), 2 x 2 points per cell placed to conform to its 256-gon, no damping, run to the end
    of the ramp."""
    d, m = DILATATION, MANUFACTURED
    r, h = d["radius"], d["radius"] / cells_per_radius
    nu, e = m["poisson_ratio"], m["youngs_modulus"]
    lam, mu = e * nu / ((1 + nu) * (1 - 2 * nu)), e / (2 * (1 + nu))
    angles = np.linspace(0.0, 2 * np.pi, d["vertices"], endpoint=False)
    polygon = [[1.5 * r + r * np.cos(a), 1.5 * r + r * np.sin(a)] for a in angles]
    return {
        "title": f"convergence: squeezed disk (uniform dilatation), {cells_per_radius} cells per "
        f"radius, {shape_function}",
        "grid": {
            "origin": [0.0, 0.0],
            "cell_size": h,
            "n_cells": [3 * cells_per_radius, 3 * cells_per_radius],
        },
        "materials": [
            {
                "name": "soil",
                "model": "linear_elastic",
                "youngs_modulus": e,
                "poisson_ratio": nu,
                "unit_weight": 20.0,
            }
        ],
        "bodies": [
            {
                "name": "disk",
                "material": "soil",
                "polygon": polygon,
                "placement": "conforming",
            }
        ],
        "gravity": {"g": 0.0},
        "loads": [
            {
                "type": "follower_pressure",
                "pressure": d["pressure_over_modulus"] * 2 * (lam + mu),
                "apply_on": "detected_boundary",
                "time_function": {"type": "smooth_ramp", "ramp_time": d["ramp_time"]},
            }
        ],
        "manufactured_solution": {"type": "uniform_dilatation"},
        "solver": {"shape_function": shape_function},
        "time": {"end_time": d["ramp_time"]},
        "output": {"interval": d["ramp_time"]},
    }


def relative_l2_errors(out: Path, exact) -> dict:
    """Relative L2 errors (volume-weighted over the points) of the displacement and of the
    in-plane stress at a run's final time against exact(X, t) -> (u (n x 2), stress (n x 4))
    at the points' initial positions X."""
    particles = final_particles(out)
    time = float(run_status(out)["final_time_s"])
    u_exact, s_exact = exact(initial_positions(particles), time)
    volume = particles["volume"].to_numpy()

    def l2(values):
        return float(np.sqrt(np.sum(volume[:, None] * values**2)))

    u = particles[["ux", "uy"]].to_numpy()
    s = particles[["sxx", "syy", "sxy"]].to_numpy()
    return {
        "displacement": l2(u - u_exact) / l2(u_exact),
        "stress": l2(s - s_exact[:, :3]) / l2(s_exact[:, :3]),
    }


def dilatation_errors(out: Path, case: dict) -> dict:
    """relative_l2_errors of a dilatation_case run against the exact motion (centre: the
    256-gon's centroid, the disk's centre)."""
    d, m = DILATATION, MANUFACTURED
    return relative_l2_errors(
        out,
        lambda start, time: analytic.manufactured_dilatation(
            start,
            time,
            case["loads"][0]["pressure"],
            d["ramp_time"],
            (1.5 * d["radius"], 1.5 * d["radius"]),
            m["youngs_modulus"],
            m["poisson_ratio"],
        ),
    )


def manufactured_errors(out: Path) -> dict:
    """relative_l2_errors of a manufactured_case run against the standing wave."""
    m = MANUFACTURED
    return relative_l2_errors(
        out,
        lambda start, time: analytic.manufactured_solution(
            start,
            time,
            m["amplitude"],
            m["period"],
            (0.0, 0.0),
            (m["size"], m["size"]),
            m["youngs_modulus"],
            m["poisson_ratio"],
        ),
    )


def slope_case() -> dict:
    slope, _ = base_case("thesis55_slope_dynamic_zero_start")
    # Detection only at the outputs: the slope carries no load, so the boundary does not act
    # on the motion, and detecting every step on 200k points would dominate the cost.
    return derive(
        slope,
        {
            "initial_stress": {"method": "k0"},
            "time": {"end_time": COMPARISON_TIME},
            "output": {"interval": OUTPUT_INTERVAL},
            "detection": det.detection_block(DETECTOR, every_steps=1_000_000),
        },
    )


def _mpm(task) -> str:
    case, solver = task
    return str(run_mpm(case, threads=1, solver=solver).out)


def _dolfinx(case: dict) -> str:
    return str(
        run_dolfinx(case, ["--mode", "static", "--steps", "1", "--no-fields"]).out
    )


def run(context) -> StudyOutcome:
    context.tools.append(tool_path("pfm-mpm"))
    quick = context.quick
    sizes = QUICK_CELL_SIZES if quick else CELL_SIZES
    dilatation_cells = QUICK_DILATATION_CELLS if quick else DILATATION_CELLS
    mms_cells = QUICK_MANUFACTURED_CELLS if quick else MANUFACTURED_CELLS
    _, slope_path = base_case("thesis55_slope_dynamic_zero_start")
    context.case_files.append(slope_path)
    bearing, slope = bearing_case(), slope_case()
    tasks, keys = _tasks(sizes, dilatation_cells, mms_cells, bearing, slope)
    outs = dict(
        zip(
            keys,
            map(
                Path,
                parallel_map(
                    _mpm,
                    tasks,
                    context.options.jobs,
                    context.options.scheduler,
                    "convergence runs",
                ),
            ),
        )
    )
    reference_out = Path(_dolfinx(bearing))
    curve = pd.read_csv(need(reference_out / "load_settlement.csv", "dolfinx_model"))
    bearing_reference = float(curve["settlement"].iloc[-1])
    rows = []
    for h in sizes:
        rows += _column_rows(outs, h)
        rows.append(_bearing_row(outs, h, bearing_reference))
        rows += slope_rows(
            outs[("slope", h)],
            outs[("slope_reference", h)],
            refine(slope, h),
            context.folder / "work",
        )
    rows += _field_error_rows(outs, dilatation_cells, mms_cells)
    study = ConvergenceStudy()
    for row in rows:
        study.add(
            row["quantity"], row["h_m"], row["error"], row["value"], row["reference"]
        )
    table = study.table()
    outcome = StudyOutcome(study="convergence")
    outcome.tables.append(
        write_table(
            context.folder,
            table,
            "rates",
            "Errors (m) and observed orders against h; bearing "
            "reference: dolfinx P2, static",
        )
    )
    _order_metrics(study, outcome)
    outcome.figures.append(
        save_figure(
            context.folder,
            manufactured_figure(table),
            "manufactured",
            "Manufactured solution: relative L2 errors against the cell size",
        )
    )
    outcome.figures.append(
        save_figure(
            context.folder,
            rates_figure(table),
            "convergence",
            "Errors against the cell size",
        )
    )
    return outcome


def _tasks(sizes, dilatation_cells, mms_cells, bearing: dict, slope: dict):
    """The runs (case, solver) and their keys (kind, h or cells): per cell size the slope (MPM
    and its UL-FEM reference), the bearing and the column in its variants; the squeezed disk
    and the manufactured solution per cell count and method."""
    tasks, keys = [], []
    # Finest first: the longest runs start early and the pool ends with the short ones.
    for h in sorted(sizes):
        reference_slope = refine(slope, h)
        reference_slope.pop("detection")
        for kind, case, solver in (
            ("slope", refine(slope, h), "mpm"),
            ("slope_reference", reference_slope, "ulfem"),
            ("bearing", refine(bearing, h), "mpm"),
            ("column", benchmarks.column_case(h, None), "mpm"),
            ("column_linear", benchmarks.column_case(h, "linear"), "mpm"),
            ("column_gimp", benchmarks.column_case(h, "gimp"), "mpm"),
            (
                "column_detected",
                benchmarks.column_case(h, "quadratic_bspline", "detected_boundary"),
                "mpm",
            ),
        ):
            tasks.append((case, solver))
            keys.append((kind, h))
    for cells in sorted(dilatation_cells, reverse=True):
        for label, shape in DILATATION_METHODS:
            tasks.append((dilatation_case(cells, shape), "mpm"))
            keys.append((label, cells))
    for cells in sorted(mms_cells, reverse=True):
        for label, solver, shape, scheme in MANUFACTURED_METHODS:
            tasks.append((manufactured_case(cells, shape, scheme), solver))
            keys.append((label, cells))
    return tasks, keys


def _column_rows(outs: dict, h: float) -> list[dict]:
    """The column at cell size h: its settlement against the solvers' model (updated
    Lagrangian, Jaumann rate: 0.40 % below the small-strain q H / M + gamma H^2 / (2 M), an
    error no refinement can remove) with each shape function and with the load on the
    detected top, and its largest point-wise displacement error against the small-strain
    profile."""
    c, m = benchmarks.COLUMN, benchmarks.ELASTIC
    parameters = (
        c["height"],
        c["surcharge"],
        m["unit_weight"],
        m["youngs_modulus"],
        m["poisson_ratio"],
    )
    column_exact = analytic.column_settlement_large_strain(*parameters)
    column_small_strain = analytic.column_settlement(*parameters)
    found = benchmarks.column_read_outs(final_particles(outs[("column", h)]), h)
    rows = [
        {
            "quantity": "column settlement",
            "h_m": h,
            "value": found["settlement"],
            "reference": column_exact,
            "error": abs(found["settlement"] - column_exact),
        },
        {
            "quantity": "column displacement max error",
            "h_m": h,
            "value": found["displacement_max_rel_error"] * column_small_strain,
            "reference": 0.0,
            "error": found["displacement_max_rel_error"] * column_small_strain,
        },
    ]
    for kind, quantity in (
        ("column_linear", "column settlement (linear)"),
        ("column_gimp", "column settlement (GIMP)"),
        ("column_detected", "column settlement (detected top)"),
    ):
        other = benchmarks.column_read_outs(final_particles(outs[(kind, h)]), h)
        rows.append(
            {
                "quantity": quantity,
                "h_m": h,
                "value": other["settlement"],
                "reference": column_exact,
                "error": abs(other["settlement"] - column_exact),
            }
        )
    return rows


def _bearing_row(outs: dict, h: float, reference: float) -> dict:
    """The bearing block's settlement under the load's centre at cell size h against dolfinx."""
    b = BEARING
    particles = final_particles(outs[("bearing", h)])
    value = surface_settlement_extrapolated(
        particles, 0.5 * sum(b["x_range"]), b["top"], h
    )
    return {
        "quantity": "bearing settlement",
        "h_m": h,
        "value": value,
        "reference": reference,
        "error": abs(value - reference),
    }


def _field_error_rows(outs: dict, dilatation_cells, mms_cells) -> list[dict]:
    """The L2 errors of displacement and stress of the manufactured solution and the squeezed
    disk, per method and cell count."""

    def error_rows(problem, label, h, errors):
        return [
            {
                "quantity": f"{problem} {field} L2 ({label})",
                "h_m": h,
                "value": errors[field],
                "reference": 0.0,
                "error": errors[field],
            }
            for field in ("displacement", "stress")
        ]

    rows = []
    for cells in mms_cells:
        for label, *_ in MANUFACTURED_METHODS:
            errors = manufactured_errors(outs[(label, cells)])
            rows += error_rows(
                "manufactured", label, MANUFACTURED["size"] / cells, errors
            )
    for cells in dilatation_cells:
        for label, shape in DILATATION_METHODS:
            case = dilatation_case(cells, shape)
            errors = dilatation_errors(outs[(label, cells)], case)
            rows += error_rows(
                "squeezed disk", label, DILATATION["radius"] / cells, errors
            )
    return rows


def _order_metrics(study: ConvergenceStudy, outcome):
    """The observed order between the two finest grids of each gated quantity."""
    manufactured_metrics = [
        (
            f"manufactured displacement L2 ({label})",
            f"convergence.manufactured.{label.replace(' ', '_')}.displacement_order",
        )
        for label, *_ in MANUFACTURED_METHODS
    ] + [
        (
            f"squeezed disk displacement L2 ({label})",
            f"convergence.dilatation.{label.replace(' ', '_')}.displacement_order",
        )
        for label, _ in DILATATION_METHODS
    ]
    for quantity, name in manufactured_metrics + [
        ("column settlement", "convergence.column.settlement_order"),
        (
            "column settlement (detected top)",
            "convergence.column.detected_top_settlement_order",
        ),
        ("column settlement (linear)", "convergence.column.linear_settlement_order"),
        ("bearing settlement", "convergence.bearing.settlement_order"),
        ("slope boundary max error (total)", "convergence.boundary.slope_k0.max_order"),
    ]:
        if quantity not in study.quantities():
            continue
        order = study.final_order(quantity)
        if order is not None:
            outcome.metrics.append(
                Metric(name, order, "1", "order between the two finest grids")
            )


def slope_rows(
    mpm_out: Path, reference_out: Path, case: dict, work: Path
) -> list[dict]:
    """Boundary errors of the slope at COMPARISON_TIME on one grid: total and detector only."""
    h = cell_size(case)
    tolerance = TIME_TOLERANCE
    ignore = grid_edge_band(case["grid"], EDGE_BAND_CELLS * h)
    reference_row = row_at_time(
        read_index(reference_out, "boundary"), COMPARISON_TIME, tolerance
    )
    detected_row = row_at_time(
        read_index(mpm_out, "boundary"), COMPARISON_TIME, tolerance
    )
    points_row = row_at_time(
        read_index(reference_out, "particles"), COMPARISON_TIME, tolerance
    )
    if reference_row is None or detected_row is None or points_row is None:
        raise ValueError(f"slope h = {h}: no output at t = {COMPARISON_TIME} s")
    work.mkdir(parents=True, exist_ok=True)
    points = write_detect_input(
        read_particles(points_row["file"]), work / f"slope_ulfem_points_h{h:g}.csv"
    )
    spacing = h / case["bodies"][0].get("points_per_cell", 2)
    only = run_detect(points, det.detect_config(DETECTOR, case["grid"], spacing)).out
    reference = read_boundary(reference_row["file"])
    rows = []
    for measure, boundary in (
        ("total", detected_row["file"]),
        ("detector only", only / "boundary.csv"),
    ):
        stats = boundary_distance(
            read_boundary(boundary), reference, h=h, ignore=ignore
        ).overall
        rows += [
            {
                "quantity": f"slope boundary max error ({measure})",
                "h_m": h,
                "value": stats.max,
                "reference": 0.0,
                "error": stats.max,
            },
            {
                "quantity": f"slope boundary mean error ({measure})",
                "h_m": h,
                "value": stats.mean,
                "reference": 0.0,
                "error": stats.mean,
            },
        ]
    return rows


def manufactured_figure(table: pd.DataFrame):
    """Relative L2 errors of the manufactured solution against h, one colour per method
    (displacement solid, stress dashed; the implicit solver's with triangles), with order-1 and order-2 slopes through the finest
    displacement error of the first method."""
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(10.0, 5.0))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (label, _, _, scheme) in enumerate(MANUFACTURED_METHODS):
        markers = ("^-", "v--") if scheme == "implicit" else ("o-", "s--")
        for field, style in zip(("displacement", "stress"), markers):
            group = table[table["quantity"] == f"manufactured {field} L2 ({label})"]
            axis.loglog(
                group["h_m"],
                group["error"],
                style,
                color=colours[k % len(colours)],
                markersize=4,
                label=f"{label}, {field}",
            )
    first = table[
        table["quantity"]
        == f"manufactured displacement L2 ({MANUFACTURED_METHODS[0][0]})"
    ]
    h = np.sort(first["h_m"].to_numpy())
    anchor = float(first.loc[first["h_m"] == h[0], "error"].iloc[0])
    axis.loglog(h, anchor * (h / h[0]) ** 2, "k:", label="order 2")
    axis.loglog(h, anchor * (h / h[0]), "k-.", label="order 1")
    axis.set_xlabel("h [m]")
    axis.set_ylabel("relative L2 error at t = T / 2")
    axis.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    axis.grid(True, which="both", alpha=0.3)
    return figure


def rates_figure(table: pd.DataFrame):
    """The errors against h in three panels, each with order-1 and order-2 slopes through the
    finest error of its first series: the column's settlement (m) per shape function and load
    target, the squeezed disk's relative L2 errors, the bearing's settlement and the slope's
    boundary (m)."""
    import matplotlib.pyplot as plt

    table = table[~table["quantity"].str.startswith("manufactured")]
    panels = (
        (("column settlement",), "column settlement: error [m]"),
        (("squeezed disk",), "squeezed disk: relative L2 error"),
        (("bearing", "slope"), "bearing settlement, slope boundary: error [m]"),
    )
    figure, axes = plt.subplots(1, 3, figsize=(15, 5))
    for axis, (prefixes, ylabel) in zip(axes, panels):
        chosen = table[table["quantity"].map(lambda q: q.startswith(prefixes))]
        groups = list(chosen.groupby("quantity", sort=True))
        for quantity, group in groups:
            group = group.sort_values("h_m")
            axis.loglog(
                group["h_m"], group["error"], "o-", markersize=4, label=quantity
            )
        if groups:
            first = groups[0][1].sort_values("h_m")
            h = first["h_m"].to_numpy()
            anchor = float(first["error"].iloc[0])
            axis.loglog(h, anchor * (h / h[0]) ** 2, "k:", label="order 2")
            axis.loglog(h, anchor * (h / h[0]), "k--", label="order 1")
        axis.set_xlabel("h [m]")
        axis.set_ylabel(ylabel)
        axis.legend(fontsize=6, loc="best")
        axis.grid(True, which="both", alpha=0.3)
    figure.tight_layout()
    return figure
