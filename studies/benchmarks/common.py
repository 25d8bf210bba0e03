"""The benchmarks' parameters (units: kN, m, s, t, kPa), the blocks their cases are cut from, and
the readers of a job's output that every section shares."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from studies.common.cases import is_bspline
from studies.common.outputs import final_particles
from studies.common.paths import PrerequisiteMissing

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
    # The dips (footing_dip): the reaction's means over windows this wide (s / b), from the
    # plateau's start on
    "dip_window": 0.01,
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
