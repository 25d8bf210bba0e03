"""Physical read-outs shared by the studies, from particle tables (columns x, y, ux, uy; the
initial position is (x - ux, y - uy)) and detected boundaries (loop CSV)."""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd

from studies.metrics import Polyline


def initial_positions(particles: pd.DataFrame) -> np.ndarray:
    for column in ("x", "y", "ux", "uy"):
        if column not in particles:
            raise ValueError(
                f"particle table has no column {column} (need x, y, ux, uy)"
            )
    return np.c_[particles["x"] - particles["ux"], particles["y"] - particles["uy"]]


def displacement_near(
    particles: pd.DataFrame, point: Sequence[float]
) -> tuple[float, float]:
    """(ux, uy) of the particle that started closest to ``point`` (m)."""
    start = initial_positions(particles)
    i = int(np.argmin(np.hypot(start[:, 0] - point[0], start[:, 1] - point[1])))
    return float(particles["ux"].iloc[i]), float(particles["uy"].iloc[i])


def surface_settlement(
    particles: pd.DataFrame, x: float, top_y: float, h: float
) -> float:
    """Settlement (m, positive down) at abscissa x: minus the mean uy of the particles that
    started in the top cell row (within h of ``top_y``) and within h / 2 of x."""
    start = initial_positions(particles)
    chosen = (np.abs(start[:, 0] - x) <= 0.5 * h) & (start[:, 1] >= top_y - h)
    if not chosen.any():
        raise ValueError(f"no particle started near the surface at x = {x}")
    return float(-particles["uy"][chosen].mean())


def surface_settlement_extrapolated(
    particles: pd.DataFrame, x: float, top_y: float, h: float
) -> float:
    """Settlement (m, positive down) of the surface point (x, top_y): the least-squares line
    uy(y0) through the particles that started in the top cell row (y0 >= top_y - h) within
    h / 2 of x, evaluated at y0 = top_y. Particles sit h / 4 and 3 h / 4 below the surface
    (2 x 2 per cell), so their plain mean reads the displacement h / 2 down."""
    start = initial_positions(particles)
    chosen = (np.abs(start[:, 0] - x) <= 0.5 * h) & (start[:, 1] >= top_y - h)
    if chosen.sum() < 2 or np.ptp(start[chosen, 1]) <= 0.0:
        raise ValueError(f"fewer than two particle rows near the surface at x = {x}")
    slope, intercept = np.polyfit(
        start[chosen, 1], particles["uy"].to_numpy()[chosen], 1
    )
    return float(-(slope * top_y + intercept))


def hole_depth(
    loops: Sequence[Polyline], x_range: Sequence[float], top_y: float
) -> float:
    """Depth (m) of the lowest boundary point over x_range below the initial surface top_y,
    taking only the boundary above mid-height of the hole's search window (the top surface).
    """
    x0, x1 = x_range
    lowest = None
    for loop in loops:
        p = loop.points
        inside = (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] > top_y - 0.5 * (x1 - x0))
        if inside.any():
            value = float(p[inside, 1].min())
            lowest = value if lowest is None else min(lowest, value)
    if lowest is None:
        raise ValueError(f"no boundary point over x in [{x0}, {x1}] near the surface")
    return top_y - lowest


def scale_cohesion(cohesion, factor: float):
    """Cohesion in any of the case-file forms (number, initial/peak/residual, table) times
    factor; plastic-strain breakpoints unchanged."""
    if isinstance(cohesion, (int, float)):
        return cohesion * factor
    if "table" in cohesion:
        return {"table": [[eps, c * factor] for eps, c in cohesion["table"]]}
    scaled = dict(cohesion)
    for key in ("initial", "peak", "residual"):
        if key in scaled:
            scaled[key] = scaled[key] * factor
    return scaled


# Jitter: a point faster than JITTER_SPEED (m/s) that moves less than JITTER_TRAVEL x its speed x
# the interval between two outputs is oscillating in place (FLIP velocity the grid cannot see,
# or a load on a node that the body barely reaches), not travelling.
JITTER_SPEED = 0.5
JITTER_TRAVEL = 0.1


def jitter_counts(frames: Sequence[pd.DataFrame], times: Sequence[float]) -> list[int]:
    """Jittering points of each output interval: frames are particle tables (x, y, vx, vy and
    id) at the output times; the speed is the one at the end of the interval."""
    counts = []
    for (a, ta), (b, tb) in zip(zip(frames, times), zip(frames[1:], times[1:])):
        a, b = a.sort_values("id"), b.sort_values("id")
        if not np.array_equal(a["id"].to_numpy(), b["id"].to_numpy()):
            raise ValueError(f"the particles at t = {ta:g} s and t = {tb:g} s differ")
        speed = np.hypot(b["vx"].to_numpy(), b["vy"].to_numpy())
        moved = np.hypot(
            b["x"].to_numpy() - a["x"].to_numpy(), b["y"].to_numpy() - a["y"].to_numpy()
        )
        counts.append(
            int(
                np.sum(
                    (speed > JITTER_SPEED) & (moved < JITTER_TRAVEL * speed * (tb - ta))
                )
            )
        )
    return counts
