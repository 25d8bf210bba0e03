"""An upper bound on the factor of safety of an undrained (phi = 0) homogeneous slope by
discontinuity layout optimisation (DLO; Smith and Gilbert 2007, Proc. R. Soc. A 463: 2461-2484).

The soil lies between a firm rough base y = base_y and the ground surface y_s(x) of a Profile
(studies.common.limit_equilibrium), between smooth vertical walls at the profile's ends (the
rollers of the MPM's and the finite-element models' sides). Its nodes: columns h apart between
consecutive vertices of the profile, nodes h apart up each column from the base and one on the
ground surface. Every straight segment between two nodes that stays in the soil may be a slip
line; the soil between slip lines moves as rigid blocks, each translating. Across a slip line
of unit tangent t (oriented with t_x > 0, or upwards when vertical) the velocity jumps by s t
(phi = 0: tangential only, s of either sign), the velocity above it less the one below.

* Compatibility: at every node below the ground surface the jumps of the lines that meet there,
  +s t for those that start at it and -s t for those that end there, sum to zero (the velocity
  comes back to itself around the node). The firm base and the walls are blocks at rest: a line
  along the base (between neighbouring base nodes) is the soil's slip on it (horizontal), a
  line along a wall the soil's slip down or up it (vertical).
* Dissipation: c l |s| on each line, none on a smooth wall.
* Work of gravity: the velocity at a point is the sum of the jumps crossed by the vertical line
  below it (none below the base), so W = gamma sum_i (-s_i t_iy) A_i with A_i the area of soil
  above line i (a vertical line adds nothing).

With the strength c / F the mechanism dissipates the work of gravity at F = D(c) / W. Fixing
W = 1, the linear program min sum c l (p + q) over s = p - q, p, q >= 0, with the
compatibility equations, gives the least F over every mechanism the nodes allow. Each such
mechanism is kinematically admissible, so F bounds the true factor of safety from above (the
upper-bound theorem of plasticity; Chen 1975); finer nodes can only lower it. Solved by HiGHS
(scipy.optimize.linprog). Units: kPa, kN/m^3, m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sparse
from scipy.optimize import linprog

from studies.common.limit_equilibrium import Profile, Soil

_TOL = 1e-9
_GROUND = 1e-7  # m: a node this close to the ground surface is on it


@dataclass
class UpperBound:
    factor: float
    spacing: float  # m, between nodes
    n_nodes: int
    n_lines: int
    # The mechanism: the slip lines with a jump, from (x, y) to (x, y), and their jumps s (m/s
    # per unit work of gravity).
    starts: np.ndarray
    ends: np.ndarray
    jumps: np.ndarray


def _nodes(profile: Profile, spacing: float, base_y: float) -> np.ndarray:
    columns = [profile.x[0]]
    for a, b in zip(profile.x[:-1], profile.x[1:]):
        n = max(1, round((b - a) / spacing))
        columns += list(np.linspace(a, b, n + 1)[1:])
    nodes = []
    for x in columns:
        top = float(profile.height(x))
        n = math.floor((top - base_y) / spacing + _TOL)
        ys = base_y + spacing * np.arange(n + 1)
        if top - ys[-1] > _TOL:
            ys = np.append(ys, top)
        nodes += [(x, y) for y in ys]
    return np.array(nodes)


def _on_ground(profile: Profile, points: np.ndarray) -> np.ndarray:
    """Whether each point lies on the ground surface's polyline (a steep face's too)."""
    near = np.zeros(len(points), dtype=bool)
    for x0, y0, x1, y1 in zip(
        profile.x[:-1], profile.y[:-1], profile.x[1:], profile.y[1:]
    ):
        d = np.array([x1 - x0, y1 - y0])
        t = np.clip(((points - (x0, y0)) @ d) / (d @ d), 0.0, 1.0)
        near |= np.hypot(*(points - (np.array([x0, y0]) + t[:, None] * d)).T) < _GROUND
    return near


def _ground_integral(profile: Profile, x: np.ndarray) -> np.ndarray:
    """int_{x_0}^{x} y_s dx of the piecewise linear ground (exact: a trapezoid per piece)."""
    px, py = np.asarray(profile.x), np.asarray(profile.y)
    at_vertices = np.concatenate(
        [[0.0], np.cumsum(0.5 * (py[1:] + py[:-1]) * np.diff(px))]
    )
    k = np.clip(np.searchsorted(px, x, side="right") - 1, 0, len(px) - 2)
    return at_vertices[k] + 0.5 * (x - px[k]) * (py[k] + profile.height(x))


def _soil_above(profile: Profile, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per segment a-b (rows, a.x <= b.x): the area between it and the ground surface above
    it (zero for a vertical one)."""
    under_ground = _ground_integral(profile, b[:, 0]) - _ground_integral(
        profile, a[:, 0]
    )
    return under_ground - 0.5 * (a[:, 1] + b[:, 1]) * (b[:, 0] - a[:, 0])


def _lines(profile: Profile, nodes: np.ndarray, base_y: float):
    """The candidate slip lines (start, end indices), oriented, with their classes."""
    x, y = nodes[:, 0], nodes[:, 1]
    on_surface = _on_ground(profile, nodes)
    on_base = np.abs(y - base_y) < _TOL
    on_wall = (np.abs(x - profile.x[0]) < _TOL) | (np.abs(x - profile.x[-1]) < _TOL)
    i, j = np.triu_indices(len(nodes), 1)
    a, b = nodes[i], nodes[j]
    keep = np.ones(len(i), dtype=bool)
    # In the soil: the surface less the segment is piecewise linear, its kinks at the profile's
    # vertices, so it is non-negative along the segment when it is at them.
    for xv, yv in zip(profile.x[1:-1], profile.y[1:-1]):
        lo, hi = np.minimum(a[:, 0], b[:, 0]), np.maximum(a[:, 0], b[:, 0])
        crossing = (lo < xv - _TOL) & (hi > xv + _TOL)
        t = np.where(
            crossing, (xv - a[:, 0]) / np.where(crossing, b[:, 0] - a[:, 0], 1.0), 0.0
        )
        keep &= ~(crossing & (a[:, 1] + t * (b[:, 1] - a[:, 1]) > yv + _TOL))
    # Not along the ground surface (no soil above, nothing to slip against).
    middle = 0.5 * (a + b)
    keep &= ~(on_surface[i] & on_surface[j] & _on_ground(profile, middle))
    # Along the base or a wall only between neighbours (a longer one repeats them).
    base = on_base[i] & on_base[j]
    wall = on_wall[i] & on_wall[j] & (np.abs(a[:, 0] - b[:, 0]) < _TOL)
    for mask, coordinate, members in ((base, 0, on_base), (wall, 1, on_wall)):
        for k in np.flatnonzero(mask & keep):
            lo, hi = sorted((a[k, coordinate], b[k, coordinate]))
            same = members & (
                np.abs(nodes[:, 1 - coordinate] - a[k, 1 - coordinate]) < _TOL
            )
            between = (nodes[:, coordinate] > lo + _TOL) & (
                nodes[:, coordinate] < hi - _TOL
            )
            if np.any(same & between):
                keep[k] = False
    i, j, base, wall = i[keep], j[keep], base[keep], wall[keep]
    d = nodes[j] - nodes[i]
    flip = (d[:, 0] < -_TOL) | ((np.abs(d[:, 0]) <= _TOL) & (d[:, 1] < 0.0))
    start, end = np.where(flip, j, i), np.where(flip, i, j)
    return start, end, on_surface, wall


def upper_bound(
    profile: Profile, soil: Soil, spacing: float, base_y: float = 0.0
) -> UpperBound:
    """The least factor of safety over the mechanisms of nodes `spacing` apart (module docs);
    phi = 0 only."""
    if soil.friction_angle != 0.0:
        raise ValueError(
            "upper_bound: the slip lines are those of phi = 0 (Tresca) soil"
        )
    nodes = _nodes(profile, spacing, base_y)
    start, end, on_surface, wall = _lines(profile, nodes, base_y)
    a, b = nodes[start], nodes[end]
    length = np.hypot(*(b - a).T)
    tangent = (b - a) / length[:, None]
    cost = soil.cohesion * length
    cost[wall] = 0.0  # smooth walls
    above = _soil_above(profile, a, b)
    # Compatibility rows: two per node below the surface.
    row_of = -np.ones(len(nodes), dtype=int)
    inner = np.flatnonzero(~on_surface)
    row_of[inner] = np.arange(len(inner))
    rows, cols, values = [], [], []
    for sign, ends in ((1.0, start), (-1.0, end)):
        k = np.flatnonzero(row_of[ends] >= 0)
        for dim in (0, 1):
            rows.append(2 * row_of[ends[k]] + dim)
            cols.append(k)
            values.append(sign * tangent[k, dim])
    n_lines = len(start)
    compatibility = sparse.csr_matrix(
        (np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
        shape=(2 * len(inner), n_lines),
    )
    work = sparse.csr_matrix(-soil.unit_weight * tangent[:, 1] * above)
    equations = sparse.vstack([compatibility, work])
    matrix = sparse.hstack([equations, -equations]).tocsc()
    rhs = np.zeros(matrix.shape[0])
    rhs[-1] = 1.0
    result = linprog(
        np.concatenate([cost, cost]),
        A_eq=matrix,
        b_eq=rhs,
        bounds=(0, None),
        method="highs",
    )
    if result.status != 0:
        raise RuntimeError(f"upper_bound: the linear program failed: {result.message}")
    jump = result.x[:n_lines] - result.x[n_lines:]
    active = np.abs(jump) > 1e-9 * np.abs(jump).max()
    return UpperBound(
        factor=float(result.fun),
        spacing=spacing,
        n_nodes=len(nodes),
        n_lines=n_lines,
        starts=a[active],
        ends=b[active],
        jumps=jump[active],
    )
