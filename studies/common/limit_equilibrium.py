"""Bishop's simplified method of slices (Bishop 1955) for a homogeneous dry slope: the factor of
safety of a circular slip surface, and the critical circle by a search.

The ground surface is a piecewise linear profile y_s(x) (m). A circle of centre (xc, yc) and
radius R cuts it where its lower arc y_c(x) = yc - sqrt(R^2 - (x - xc)^2) lies below the
surface; the soil between them slides by a rotation about the centre. The sliding mass is cut
into n vertical slices of width b; slice i has weight W_i = gamma b (y_s - y_c) at its middle,
base length l_i (the arc it spans, exactly) and base inclination alpha_i at its middle,
sin(alpha_i) = s (x_i - xc) / R, where s = +1 when the ground
rises with x (the mass moves towards -x) and -1 otherwise. Moment equilibrium about the centre
with the interslice shear forces neglected (Bishop's simplification) gives

    F = sum_i [c l_i cos(alpha_i) + W_i tan(phi)] / m_i  /  sum_i W_i sin(alpha_i),
    m_i = cos(alpha_i) + sin(alpha_i) tan(phi) / F,

solved by fixed-point iteration in F. For phi = 0 it is the exact moment balance of the
circle, F = c R L / sum W (x - xc) s (L the arc's length). Units: kPa, degrees, kN/m^3, m.

A firm base at y = base_y (a rough stratum the slip surface cannot enter): where a circle
cuts it, the surface follows the base (a composite surface, as slope-stability programs treat a
strong layer). Such a slice has a horizontal base (alpha = 0), so its base normal force equals
its weight and their moments cancel; its base shear (c l + W tan(phi)) / F acts at the arm
yc - base_y instead of R, so its term in the numerator is (yc - base_y) / R (c l + W tan(phi)).

A circle is admissible when its sliding mass is one interval [x_a, x_b] inside the profile's
extent and its driving moment is positive; bishop_factor returns None for any other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq, minimize


@dataclass(frozen=True)
class Profile:
    """The ground surface y(x) through the points (x[k], y[k]), x strictly increasing."""

    x: tuple
    y: tuple

    def height(self, x):
        return np.interp(x, self.x, self.y)

    @property
    def rises(self) -> bool:
        """True when the ground is higher at the right end (the slide moves towards -x)."""
        return self.y[-1] > self.y[0]


@dataclass(frozen=True)
class Soil:
    cohesion: float  # kPa
    friction_angle: float  # degrees
    unit_weight: float  # kN/m^3


@dataclass(frozen=True)
class Circle:
    xc: float
    yc: float
    radius: float


def _sliding_interval(profile: Profile, circle: Circle):
    """(x_a, x_b) where the arc is below the ground, or None when that is not one interval
    inside the profile."""
    xc, yc, r = circle.xc, circle.yc, circle.radius
    lo, hi = max(xc - r, profile.x[0]), min(xc + r, profile.x[-1])
    if hi <= lo:
        return None

    def depth(x):
        return profile.height(x) - (yc - math.sqrt(max(r * r - (x - xc) ** 2, 0.0)))

    xs = np.linspace(lo, hi, 801)
    d = profile.height(xs) - (yc - np.sqrt(np.maximum(r * r - (xs - xc) ** 2, 0.0)))
    inside = d > 0.0
    if not inside.any():
        return None
    first, last = int(np.argmax(inside)), len(xs) - 1 - int(np.argmax(inside[::-1]))
    if not inside[first : last + 1].all():
        return None  # two separate masses
    # The arc must leave the ground inside the profile: a mass that reaches its ends is cut off.
    if first == 0 or last == len(xs) - 1:
        return None
    x_a = brentq(depth, xs[first - 1], xs[first], xtol=1e-12)
    x_b = brentq(depth, xs[last], xs[last + 1], xtol=1e-12)
    return x_a, x_b


def bishop_factor(
    profile: Profile,
    soil: Soil,
    circle: Circle,
    n_slices: int = 1000,
    base_y: float | None = None,
    tolerance: float = 1e-12,
):
    """Bishop's simplified factor of safety of `circle` (composite where it cuts the firm base
    at base_y), or None when it is not admissible."""
    if circle.radius <= 0.0:
        return None
    interval = _sliding_interval(profile, circle)
    if interval is None:
        return None
    x_a, x_b = interval
    r = circle.radius
    edges = x_a + (x_b - x_a) / n_slices * np.arange(n_slices + 1)
    base = -math.inf if base_y is None else base_y
    flat_half = 0.0
    if circle.yc - r < base:
        # The arc leaves the base at xc -+ flat_half: slice edges there too.
        flat_half = math.sqrt(r * r - (circle.yc - base) ** 2)
        cuts = [circle.xc - flat_half, circle.xc + flat_half]
        edges = np.unique(np.concatenate([edges, [v for v in cuts if x_a < v < x_b]]))
    b = np.diff(edges)
    x = 0.5 * (edges[1:] + edges[:-1])
    dx = x - circle.xc
    flat = np.abs(dx) < flat_half
    root = np.sqrt(np.maximum(r * r - dx * dx, 0.0))
    slip = np.maximum(circle.yc - root, base)
    weight = soil.unit_weight * b * np.maximum(profile.height(x) - slip, 0.0)
    # Each arc slice's base length exactly, R times the angle it spans (the arc may be vertical
    # at its ends, where b / cos(alpha) at the middle would not converge).
    unit = np.clip((edges - circle.xc) / r, -1.0, 1.0)
    length = np.where(flat, b, r * np.diff(np.arcsin(unit)))
    sign = 1.0 if profile.rises else -1.0
    sin_a = np.where(flat, 0.0, sign * dx / r)
    cos_a = np.where(flat, 1.0, root / r)
    # Moments about the centre. A flat slice's weight and base normal force (equal: its base
    # is horizontal and the interslice shear is neglected) cancel; its base shear acts at the
    # arm yc - base_y, an arc slice's at R.
    driving = r * float(np.sum(weight * sin_a))
    if driving <= 0.0:
        return None
    arm = np.where(flat, circle.yc - base, r)
    tan_phi = math.tan(math.radians(soil.friction_angle))
    # c b = c l cos(alpha): for phi = 0, c l per slice.
    resisting = arm * (soil.cohesion * length * cos_a + weight * tan_phi)
    factor = 1.0
    for _ in range(200):
        m = cos_a + sin_a * tan_phi / factor
        if np.any(m <= 0.0):
            return None  # a base too steep for Bishop's assumption
        new = float(np.sum(resisting / m)) / driving
        if abs(new - factor) <= tolerance * new:
            return new
        factor = new
    return None


@dataclass
class CriticalCircle:
    factor: float
    circle: Circle
    evaluated: int  # circles tried


def critical_circle(
    profile: Profile,
    soil: Soil,
    centre_box: tuple,
    radius_range: tuple,
    base_y: float | None = None,
    grid: tuple = (24, 24, 24),
    n_slices: int = 400,
) -> CriticalCircle:
    """The circle of least Bishop factor: a grid of centres in centre_box ((x0, x1), (y0, y1))
    and radii in radius_range (r0, r1), then Nelder-Mead from the best three grid circles, each
    circle's factor at n_slices and the best one's again at 4 n_slices."""
    (x0, x1), (y0, y1) = centre_box
    r0, r1 = radius_range
    evaluated = 0
    found = []
    for xc in np.linspace(x0, x1, grid[0]):
        for yc in np.linspace(y0, y1, grid[1]):
            for r in np.linspace(r0, r1, grid[2]):
                f = bishop_factor(profile, soil, Circle(xc, yc, r), n_slices, base_y)
                evaluated += 1
                if f is not None:
                    found.append((f, (xc, yc, r)))
    if not found:
        raise ValueError("no admissible circle in the search box")
    found.sort()
    scale = max(x1 - x0, y1 - y0, r1 - r0)

    def objective(v):
        f = bishop_factor(profile, soil, Circle(*v), n_slices, base_y)
        return 1e9 if f is None else f

    best_f, best_v = found[0]
    for _, start in found[:3]:
        simplex = np.array(start) + np.vstack([np.zeros(3), 0.05 * scale * np.eye(3)])
        result = minimize(
            objective,
            start,
            method="Nelder-Mead",
            options={"initial_simplex": simplex, "xatol": 1e-4, "fatol": 1e-7},
        )
        evaluated += result.nfev
        if result.fun < best_f:
            best_f, best_v = result.fun, tuple(result.x)
    circle = Circle(*best_v)
    factor = bishop_factor(profile, soil, circle, 4 * n_slices, base_y)
    return CriticalCircle(factor, circle, evaluated)
