"""Problems with known answers: is the loaded MPM right where we can know it exactly?

What it measures:

* ``column``: an elastic column (1 m x 5 m, rollers on the sides, fixed base) loaded from zero
  stress by its weight and a 50 kPa surcharge (both ramped over 0.5 s, damped to rest): top
  settlement against q H / M + gamma H^2 / (2 M) (small strain; the large-strain value of the
  Jaumann-rate model is shown beside it) and syy against -(q + gamma (H - y0)) at every point
  (y0 its initial height: the weight above a material point does not change);
* ``strip``: a weightless elastic block (20 m x 10 m) under a 2 m strip of 10 kPa: sigma_z under
  the centre at depths b..4b against the elastic half-space strip solution
  q / pi (alpha + sin alpha) (the finite, fixed-base block differs most at depth);
* ``prandtl``: a smooth strip footing of half-width b on weightless, nearly incompressible
  Tresca soil (nu = 0.49, E = 1e4 kPa), half model, 8 cells under b, the pressure ramped on
  the detected top from 0 to 1.2 (2 + pi) c over 16 s per m of b: the collapse pressure (where
  the tangent stiffness dq/ds falls below 5 % of its initial value) against Prandtl's
  (2 + pi) c, for c = 10 and 20 kPa and b = 1 and 2 m, on the MPM (uGIMP, and quadratic
  B-splines on a grid whose edges are the symmetry plane, base and far side) and the UL-FEM,
  all with anti-locking (``solver.anti_locking: "bbar"``), and once on the MPM without it;
* ``softening``: a plane-strain compression test of a softening specimen (1 m x 2 m, Tresca,
  c 20 -> 10 kPa over a plastic strain of 0.2, a weaker square of c 18 kPa at a base corner to
  start the shear band; smooth platens, the top one moving down 0.08 m over 2 s: displacement
  control, moving supports) on grids of h = 1/16, 1/32, 1/64 m (quadratic B-splines, the
  platens on the grid's edges): with one law on every grid the band that localises thins with h
  and the specimen softens faster per metre of shortening (mesh dependence); with
  ``materials[].softening_length`` = 1/32 m the law's plastic strains are scaled by L / h (the
  fracture-energy regularisation). The force-shortening curves of both, the peak (2 c W), and
  each law's spread over the grids of the shortening at which the force has fallen halfway
  from the peak to the residual 2 c_r W. The same test on the dolfinx model (P2 triangles of
  h = 1/16, 1/32, 1/48 m, static, the top platen's displacement prescribed on its mesh nodes:
  ``run_driven``), the same two laws (its regularisation scales by L / element size);
* ``constraint``: a 1 m square block turned 30 degrees to the grid (a lattice of 2 x 2 points
  per cell area, turned with it), 0.01 m of normal displacement on one face and zero on the
  three others through constraints on the detected boundary (``constraints[]``, the penalty
  method and Nitsche's): uniaxial strain, sigma_nn = (lambda + 2 mu) ln(0.99) (the solver's
  rate form integrates the stretching; small strain's -0.01 is 0.5 % less). The interior's
  mean sigma_nn and the loaded face's reaction against it, for penalty factors 1 to 1000 at
  h = L / 16 with each method (the penalty method's error, about h / (factor L), falling as
  the penalty grows; Nitsche's, consistent, flat from factor 4) and for h = L / 8, L / 16,
  L / 32 with each method at the default factor 100, with the constraints' cost per step;
* ``footing``: a rigid smooth strip footing (b = 1 m, 8 cells under b) pushed at 0.0375 m/s
  into the Prandtl benchmark's weightless Tresca soil (c = 10 kPa) to s = 0.14 b: through a
  constraint on the detected top under it (normal velocity; the penalty method at factors 16
  and 100, Nitsche's at 16; the first again at 1/2, 1/4 and 1/8 of the speed and with 16
  cells under b), as a moving support on the grid's top nodes, on the UL-FEM (its mesh nodes;
  also with 16 elements under b) and on the dolfinx model (static): the reaction pressure
  against (2 + pi) c along the settlement, its plateau's mean over s / b in [0.03, 0.12]
  (issue 25 must-show 2) and its mean over windows of s / b, where the constraint is compared
  with the UL-FEM of the same h (the reaction rises along the settlement on both: the footing
  sinks into its heave);
* ``disk``: a plane-strain elastic disk (R = 2 m, centre node fixed) under a uniform pressure
  of 10 kPa applied as a follower pressure on its detected boundary (improved detector, every
  step): the uniform radial strain against the closed form -p (1 + nu)(1 - 2 nu) / E, the test
  of traction on a curved boundary; and the net force of the pressure (0 on a closed curve).

Why: they check the loading and the solver apart from the boundary detection's accuracy
(column, strip and footing loaded on the grid-aligned top), then with it (disk).

Reproduce: ``make study-benchmarks`` = ``/usr/bin/python3 -m studies benchmarks [--quick]``
(quick: column, disk and the constraint at the default penalty). Cases are built by this module from the README's case schema
(h = 0.25 m but for the footings). Writes ``benchmarks.csv/.md``, ``prandtl.csv/.md``, ``column_stress.png``,
``strip_sigma_z.png``, ``prandtl.png``, ``softening.csv/.md``, ``softening.png``,
``footing.csv/.md``, ``footing.png`` and
``energy_ledger.png`` (the energy ledger of each
run, with the metric ``benchmarks.<name>.energy_identity_rel``).
"""

from __future__ import annotations

import copy
import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from studies import analytic
from studies.common.cases import is_bspline
from studies.common.ledger import plot_energy_ledger, relative_energy_error
from studies.common.measures import initial_positions, surface_settlement_extrapolated
from studies.common.outcome import Metric, StudyOutcome
from studies.common.outputs import (
    final_particles,
    read_index,
    read_particles,
    read_timeseries,
)
from studies.common.parallel import parallel_map
from studies.common.paths import PrerequisiteMissing, tool_path
from studies.common.runner import RunFailed, run_dolfinx, run_mpm
from studies.common.study import missing_reason
from studies.common.tables import save_figure, write_table

H = 0.25  # m, cell size of the benchmarks
ELASTIC = {
    "name": "elastic",
    "model": "linear_elastic",
    "youngs_modulus": 1.0e4,
    "poisson_ratio": 0.3,
    "unit_weight": 20.0,
}
COLUMN = {
    "width": 1.0,
    "height": 5.0,
    "surcharge": 50.0,
    "end_time": 3.0,
    "damping": 0.5,
}
STRIP = {"width": 20.0, "depth": 10.0, "half_width": 1.0, "pressure": 10.0}
PRANDTL = {
    "cohesions": (10.0, 20.0),  # kPa
    "half_widths": (1.0, 2.0),  # m
    "cells_under_half_width": 8,
    "youngs_modulus": 1.0e4,  # kPa
    "poisson_ratio": 0.49,  # undrained: nearly incompressible
    "max_factor": 1.2,
    "ramp_per_half_width": 16.0,  # s per m of b
    "damping": 0.2,
    "outputs": 260,
    "stiffness_fraction": 0.05,
}
# The plane-strain compression test of a softening specimen (width x height) under smooth
# platens, the top one driven down `shortening` over `duration` (after a smooth ramp of
# ramp_fraction x duration), on grids of `cells_across` cells over the width; the law as given
# at every h (plain) and scaled by softening_length / h (regularised; equal at h = L, the middle
# grid). A weaker square (`flaw` m, `flaw_cohesion`) at the base's left corner starts the band.
SOFTENING = {
    "width": 1.0,  # m
    "height": 2.0,  # m
    "youngs_modulus": 1.0e4,  # kPa
    "poisson_ratio": 0.3,
    "cohesion": 20.0,  # kPa, softening to residual_fraction x cohesion
    "flaw_cohesion": 18.0,  # kPa
    "residual_fraction": 0.5,
    "residual_plastic_strain": 0.2,
    "flaw": 0.125,  # m
    "softening_length": 1.0 / 32.0,  # m: the middle grid's h
    "cells_across": (16, 32, 64),
    # the dolfinx model's meshes (P2 triangles of size h = width / n; a shear band there is
    # about one element wide, in the MPM's quadratic B-splines two to three cells; at h = 1/8
    # the regularised law, scaled by L / h = 1/4, snaps back and the static run stops past the
    # peak) and its static increments over the duration (400 give the same half-softening
    # shortening within 0.15 %)
    "dolfinx_cells_across": (16, 32, 48),
    "dolfinx_steps": 200,
    "shortening": 0.08,  # m
    "duration": 2.0,  # s
    "ramp_fraction": 0.05,
    "samples": 400,  # time-series rows
}
# A rigid smooth strip footing of half-width b pushed at `speed` (after a smooth ramp of
# ramp_fraction x duration) into weightless Tresca soil, half model as PRANDTL's (8 cells under
# b, uGIMP, B-bar): through a constraint on the detected top under it (normal velocity, a face
# window of window_angle about the vertical) at each penalty factor, as a moving support on the
# grid's top nodes over it, on the UL-FEM (its mesh nodes) and on the dolfinx model (static,
# `dolfinx_steps` increments); the constraint at the first penalty factor again at each of the
# `rate_check` fractions of the speed, to the same settlement. The reaction pressure (the force
# on the body over b) against (2 + pi) c; its plateau the mean over the settlements s / b in
# `plateau`.
FOOTING = {
    "cohesion": 10.0,  # kPa
    "half_width": 1.0,  # m
    "cells_under_half_width": 8,
    "speed": 0.0375,  # m/s
    "duration": 4.0,  # s: a settlement of 0.1425 b
    # The constraint at the first penalty factor again at these fractions of the speed: its
    # plateau depends on the speed (boundary_constraint.hpp)
    "rate_check": (0.5, 0.25, 0.125),
    "ramp_fraction": 0.1,
    "damping": 0.05,
    # FLIP's particle velocities pick up the constraint's band of nodes and grow (the run
    # stops at s / b 0.05); 5 % PIC removes it and adds about 2 % to the node support's plateau
    "pic_fraction": 0.05,
    "window_angle": 45.0,  # degrees
    "penalty_factors": (16.0, 100.0),
    "nitsche_factors": (16.0,),
    "plateau": (0.03, 0.12),  # s / b
    # The reaction's mean over each of these windows of s / b too: it rises along the
    # settlement, on the UL-FEM as well (the footing sinks into its heave)
    "windows": ((0.01, 0.03), (0.03, 0.06), (0.06, 0.09), (0.09, 0.12)),
    # The constraint at the first penalty factor and the UL-FEM again with this many cells
    # under b: the h-dependence of both
    "refined_cells": 16,
    "dolfinx_steps": 80,
    "samples": 400,  # time-series rows
}
DISK = {"radius": 2.0, "pressure": 10.0}
CONSTRAINT = {
    "angle": 30.0,  # degrees, of the block to the grid
    "side": 1.0,  # m
    "displacement": -0.01,  # m, along the loaded face's outward normal
    "youngs_modulus": 1.0e4,  # kPa
    "poisson_ratio": 0.3,
    "factors": (1.0, 4.0, 16.0, 100.0, 1000.0),  # each method's
    "cells_per_side": (8, 16, 32),
    "default_factor": 100.0,
    "default_cells": 16,
    "interior": 0.3,  # m: |r . n|, |r . t| below this from the centre
}
QUICK_BENCHMARKS = ("column", "disk", "constraint")
ALL_BENCHMARKS = (
    "column",
    "strip",
    "prandtl",
    "softening",
    "disk",
    "constraint",
    "footing",
)

EXPECTED_METRICS = [
    "benchmarks.column.settlement_rel_error",
    "benchmarks.column.stress_max_rel_error",
    "benchmarks.strip.sigma_z_max_rel_error",
    "benchmarks.prandtl.collapse_pressure_rel_error",
    "benchmarks.prandtl.bspline_collapse_pressure_rel_error",
    "benchmarks.prandtl.ulfem_collapse_pressure_rel_error",
    "benchmarks.softening.plain_half_softening_spread",
    "benchmarks.softening.regularised_half_softening_spread",
    "benchmarks.softening.peak_rel_error",
    "benchmarks.disk.radial_displacement_rel_error",
    "benchmarks.constraint.interior_stress_rel_error",
    "benchmarks.constraint.reaction_rel_error",
]


def _grid(width: float, height: float, h: float, margin_cells: int = 2) -> dict:
    return {
        "origin": [-margin_cells * h, -margin_cells * h],
        "cell_size": h,
        "n_cells": [
            int(round(width / h)) + 2 * margin_cells,
            int(round(height / h)) + 2 * margin_cells,
        ],
    }


def _block(
    width,
    height,
    material,
    loads,
    initial="zero",
    gravity=True,
    end_time=2.0,
    h=H,
    damping=0.5,
    output_interval=None,
    headroom=0,
    shape_function="linear",
):
    """A rectangle [0, width] x [0, height] inside a grid with a margin of two cells (and
    `headroom` more cell rows above), fixed base, rollers on both sides. The node sets hold
    the nodes on the walls and beyond them (the base set every node at y <= 0, the side sets
    every node outside the body's width up to its top, or up to the grid's top with headroom,
    where the soil may heave): the walls are rigid, and a GIMP particle next to one reaches the
    nodes behind it (with linear shape functions those nodes carry no mass and the extra
    fixities change nothing). B-splines have no margin: the walls are then the grid's edges,
    which their edge functions hold (mpm/core/shape_functions.hpp). shape_function None leaves
    the key out, for pfm-mpm's default (studies.common.cases.DEFAULT_SHAPE_FUNCTION).
    """
    margin_cells = 0 if is_bspline(shape_function) else 2
    far = 1e3  # m, beyond any grid of these cases
    wall_top = height if headroom == 0 else far
    case = {
        "grid": _grid(width, height, h, margin_cells),
        "materials": [material],
        "bodies": [
            {
                "name": "soil",
                "material": material["name"],
                "rectangle": [[0.0, 0.0], [width, height]],
            }
        ],
        "gravity": {"g": 9.81, "ramp_time": 0.5} if gravity else {"g": 0.0},
        "initial_stress": {"method": initial},
        "node_sets": [
            {"name": "base", "box": [[-far, -far], [width + far, 1e-9]]},
            {"name": "left_side", "box": [[-far, 0.0], [1e-9, wall_top]]},
            {
                "name": "right_side",
                "box": [[width - 1e-9, 0.0], [width + far, wall_top]],
            },
        ],
        "boundary_conditions": [
            {"where": "base", "fix": "xy"},
            {"where": "left_side", "fix": "x"},
            {"where": "right_side", "fix": "x"},
        ],
        "loads": loads,
        "solver": {"damping": damping},
        "time": {"end_time": end_time},
        "output": {"interval": output_interval or end_time},
    }
    if shape_function:
        case["solver"]["shape_function"] = shape_function
    case["grid"]["n_cells"][1] += headroom
    return case


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


def footing_case(
    how: str,
    penalty_factor: float | None = None,
    method: str = "penalty",
    speedup: float = 1.0,
    cells: int | None = None,
) -> dict:
    """The rigid footing of FOOTING: `how` "constraint" (on the detected top, x <= b, with
    `penalty_factor` and `method`) or "support" (the grid's or the mesh's top nodes over
    x <= b: MPM, UL-FEM and dolfinx), pushed at `speedup` times FOOTING's speed (smaller than
    1: slower) to the same settlement, with `cells` cells (or elements) under b (default
    FOOTING's). The support is the fourth boundary condition (reaction_3_*), the constraint
    the first (constraint_0_*)."""
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
        shape_function="gimp",
    )
    case["title"] = f"benchmark footing: {how}" + (
        f", {method}, penalty factor {penalty_factor:g}" if penalty_factor else ""
    )
    if speedup != 1.0:
        case["title"] += f", {speedup:g} times the speed"
    if cells != f["cells_under_half_width"]:
        case["title"] += f", {cells} cells under b"
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


def _run(job):
    """The output folder of a (case, solver) job, or {"missing": what} when pfm-mpm rejects a
    key it does not support yet, so the other benchmarks still run. A footing run gives
    {"curve": its prandtl_curve, "timeseries": ...} at once: its outputs (about 250 MB) are
    more than the run cache keeps (PFM_CACHE_MAX_MB), which may drop them before the study reads
    them. A footing run that stops (a UL-FEM element inverted past the collapse, a rigid
    footing's run past its stable settlement) is a result: its outputs up to the stop. A job
    (case, "dolfinx", steps) runs the dolfinx model in static mode."""
    case, solver = job[:2]
    footing = case["title"].startswith("benchmark Prandtl")
    stop_is_result = footing or case["title"].startswith("benchmark footing")
    try:
        if solver == "dolfinx":  # a stop (exit 3: Newton failed) is a result up to then
            arguments = ["--mode", "static", "--no-fields", "--min-step", "1e-5"]
            arguments += ["--steps", job[2]]
            return str(run_dolfinx(case, arguments, accept=(0, 3)).out)
        out = run_mpm(case, threads=1, solver=solver, allow_stopped=stop_is_result).out
        if footing:
            return {
                "curve": prandtl_curve(out, case),
                "timeseries": read_timeseries(out),
            }
        return str(out)
    except (RunFailed, PrerequisiteMissing) as failure:
        reason = missing_reason(failure)
        if reason is not None:
            return {"missing": reason}
        raise


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


def _out(run) -> Path:
    if isinstance(run, dict):
        raise PrerequisiteMissing(run["missing"])
    return Path(run)


def _missing(run) -> bool:
    return isinstance(run, dict) and "missing" in run


def _particles(run) -> pd.DataFrame:
    frame = final_particles(_out(run))
    for column in ("x", "y", "ux", "uy", "syy"):
        if column not in frame:
            raise PrerequisiteMissing(f"column {column} in the particle output")
    return frame


def run(context) -> StudyOutcome:
    context.tools.append(tool_path("pfm-mpm"))
    names = QUICK_BENCHMARKS if context.quick else ALL_BENCHMARKS
    builders = {"column": column_case, "strip": strip_case, "disk": disk_case}
    jobs = {}
    for name in names:
        if name == "prandtl":
            jobs.update(prandtl_jobs())
        elif name == "softening":
            jobs.update(softening_jobs())
        elif name == "constraint":
            jobs.update(constraint_jobs(context.quick))
        elif name == "footing":
            jobs.update(footing_jobs())
        else:
            jobs[name] = (builders[name](), "mpm")
    outs = dict(
        zip(
            jobs,
            parallel_map(
                _run,
                list(jobs.values()),
                context.options.jobs,
                context.options.scheduler,
                "benchmark runs",
            ),
        )
    )
    outcome = StudyOutcome(study="benchmarks")
    rows, not_run = [], []

    def add(benchmark, quantity, ours, exact, unit, metric=None):
        error = abs(ours - exact) / abs(exact)
        rows.append(
            {
                "benchmark": benchmark,
                "quantity": quantity,
                "mpm": ours,
                "analytic": exact,
                "unit": unit,
                "rel_error": error,
            }
        )
        if metric:
            outcome.metrics.append(
                Metric(f"benchmarks.{benchmark}.{metric}", error, "1")
            )

    functions = {"column": _column, "strip": _strip, "disk": _disk}  # prandtl: below
    for name in names:
        try:
            if name == "prandtl":
                _prandtl(outs, jobs, outcome, context.folder)
            elif name == "softening":
                _softening(outs, outcome, context.folder)
            elif name == "constraint":
                _constraint(outs, jobs, add, outcome, context.folder)
            elif name == "footing":
                _footing(outs, jobs, outcome, context.folder)
            else:
                functions[name](outs[name], add, outcome, context.folder)
        except PrerequisiteMissing as missing:
            not_run.append(f"{name}: needs {missing.needs}")
    if not rows:
        raise PrerequisiteMissing("; ".join(not_run) or "benchmark outputs")
    # One energy ledger per benchmark (the Prandtl MPM run of the first c and b).
    first = {}
    for key, run in outs.items():
        first.setdefault(key.split("/")[0], run)
    _energy_ledgers(first, outcome, context.folder)
    outcome.tables.append(
        write_table(
            context.folder,
            pd.DataFrame(rows),
            "benchmarks",
            "Benchmarks against closed-form solutions",
        )
    )
    if not_run:
        outcome.reason = "partly not run: " + "; ".join(not_run)
    return outcome


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


def footing_plateau_line(curve: pd.DataFrame) -> tuple[float, float]:
    """The least-squares line q / (2 + pi) c = q0 + k s / b through a footing_curve over
    FOOTING's plateau window: (q0, k). In a large-deformation run the reaction rises along the
    settlement (the footing sinks into its heave); q0, the line at s = 0, is the level without
    that rise, and k the rise."""
    lo, hi = FOOTING["plateau"]
    window = curve[(curve["s_over_b"] >= lo) & (curve["s_over_b"] <= hi)]
    slope, at_0 = np.polyfit(window["s_over_b"], window["q_over_prandtl"], 1)
    return float(at_0), float(slope)


def footing_against_ulfem(rows: list[dict]) -> dict:
    """Per constraint run at FOOTING's speed with a UL-FEM run of the same cells under b: the
    largest |mean q of the constraint / mean q of the UL-FEM - 1| over the windows both
    reached (rows as in footing.md)."""
    windows = [f"mean_{a:g}_{z:g}" for a, z in FOOTING["windows"]]
    ulfem = {r["cells"]: r for r in rows if r["solver"] == "ulfem"}
    out = {}
    for r in rows:
        reference = ulfem.get(r["cells"])
        if not r["run"].startswith("constraint_") or reference is None:
            continue
        if not math.isclose(r["speed"], FOOTING["speed"], rel_tol=1e-12):
            continue
        ratios = [
            abs(r[w] / reference[w] - 1.0)
            for w in windows
            if math.isfinite(r[w]) and math.isfinite(reference[w])
        ]
        if ratios:
            out[r["run"]] = max(ratios)
    return out


def _footing(outs: dict, jobs: dict, outcome: StudyOutcome, folder: Path):
    """The rigid footing on every code: the table footing.md (per run the plateau's mean,
    least and largest q / (2 + pi) c over FOOTING's plateau window, the mean over each of its
    windows, the plateau's line, the last settlement reached), the curves footing.png, and
    the metrics benchmarks.footing.<run>_plateau_rel_error (the plateau's mean
    |q / (2 + pi) c - 1|) and <run>_line_at_0_rel_error (|q0 - 1|, footing_plateau_line) for
    each run that reached the plateau's end, <run>_vs_ulfem_rel_error (footing_against_ulfem)
    for the constraint runs at the speed; <run> as in the table (constraint_f<factor>,
    constraint_nitsche_f<factor>, constraint_f<factor>_x<k>, constraint_f<factor>_h<n>,
    support_mpm, support_ulfem, support_ulfem_h<n>, support_dolfinx). A run that stopped is
    read up to its stop."""
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
        row["last_s_over_b"] = reached
        rows.append(row)
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


def _energy_ledgers(outs: dict, outcome: StudyOutcome, folder: Path):
    """energy_ledger.png, a panel per benchmark run, and the identity's closure of each run
    (largest |energy_error| over the largest term, every time-series row)."""
    import matplotlib.pyplot as plt

    series = {
        name: run["timeseries"] if isinstance(run, dict) else read_timeseries(run)
        for name, run in outs.items()
        if not _missing(run)
    }
    if not series:
        return
    figure, axes = plt.subplots(
        len(series), 1, figsize=(7, 3.2 * len(series)), squeeze=False
    )
    for axis, (name, table) in zip(axes[:, 0], series.items()):
        plot_energy_ledger(axis, table, name)
        outcome.metrics.append(
            Metric(
                f"benchmarks.{name}.energy_identity_rel",
                relative_energy_error(table),
                "1",
                "largest |energy_error| / largest ledger term",
            )
        )
    figure.tight_layout()
    outcome.figures.append(
        save_figure(
            folder, figure, "energy_ledger", "Energy ledger of each benchmark run"
        )
    )


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
