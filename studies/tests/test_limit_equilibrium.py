"""Bishop's simplified method (studies/common/limit_equilibrium.py) against closed forms: the
moment balance of a circle in purely cohesive soil, the area integrals of a circle's sliding
mass, and the infinite slope of a cohesionless soil that the critical circle approaches."""

import math

import numpy as np
import pytest

from studies.common.limit_equilibrium import (
    Circle,
    Profile,
    Soil,
    bishop_factor,
    critical_circle,
)

H = 4.0
# A vertical cut at x = 0: low ground y = 0 on the left, high ground y = H on the right.
CUT = Profile((-40.0, 0.0, 1e-9, 40.0), (0.0, 0.0, H, H))
CLAY = Soil(cohesion=20.0, friction_angle=0.0, unit_weight=20.0)


def test_quarter_circle_behind_a_vertical_cut_is_the_closed_form():
    # Centre at the crest (0, H), R = H: the sliding mass is a quarter disc, driving moment
    # gamma H^3 / 3, resisting c R (pi H / 2): F = 3 pi c / (2 gamma H); the slice sums
    # converge to it as n^-1.5 (the slices' heights behave as a square root at the entry).
    exact = 3.0 * math.pi * CLAY.cohesion / (2.0 * CLAY.unit_weight * H)
    errors = [
        abs(bishop_factor(CUT, CLAY, Circle(0.0, H, H), n) / exact - 1.0)
        for n in (250, 1000, 4000)
    ]
    assert errors[-1] < 2e-6
    for coarse, fine in zip(errors, errors[1:]):
        assert fine < coarse / 6.0  # 4^1.5 = 8


def _area_integral_factor(circle: Circle, n: int = 2400) -> float:
    """phi = 0: c R L / (gamma sum (x - xc) dA) by a fine cell sum over the mass and a fine
    angular sum of the arc below the ground (independent of the slices)."""
    r = circle.radius
    xs = np.linspace(circle.xc - r, circle.xc + r, n)
    ys = np.linspace(circle.yc - r, circle.yc, n)
    x, y = np.meshgrid(xs, ys)
    cell = (xs[1] - xs[0]) * (ys[1] - ys[0])
    inside = ((x - circle.xc) ** 2 + (y - circle.yc) ** 2 < r * r) & (y < CUT.height(x))
    moment = CLAY.unit_weight * np.sum((x - circle.xc)[inside]) * cell
    theta = np.linspace(math.pi, 2.0 * math.pi, 400001)
    ax, ay = circle.xc + r * np.cos(theta), circle.yc + r * np.sin(theta)
    length = r * np.count_nonzero(ay < CUT.height(ax)) * (theta[1] - theta[0])
    return CLAY.cohesion * r * length / moment


@pytest.mark.parametrize(
    "circle",
    [Circle(-0.5, 4.0, math.hypot(0.5, 4.0)), Circle(1.0, 5.0, math.hypot(1.0, 5.0))],
)
def test_slices_agree_with_the_area_integrals_of_the_sliding_mass(circle):
    # Circles through the toe, one passing under the low ground left of it: the cell sums are
    # good to about 1e-3 at this resolution.
    assert bishop_factor(CUT, CLAY, circle, 2000) == pytest.approx(
        _area_integral_factor(circle), rel=1e-3
    )


def test_inadmissible_circles_have_no_factor():
    assert bishop_factor(CUT, CLAY, Circle(10.0, 20.0, 1.0)) is None  # in the air
    # Reaching the profile's end: cut off.
    short = Profile((-40.0, 0.0, 1e-9, 3.0), (0.0, 0.0, H, H))
    assert bishop_factor(short, CLAY, Circle(0.0, H, H)) is None


def test_a_circle_cut_by_the_firm_base_follows_it():
    # phi = 0, the quarter circle behind the cut with a firm base at y = 1: the slip surface is
    # the base from x = 0 to x1 = sqrt(R^2 - (H - 1)^2) (arm H - 1 about the centre) and the arc
    # from x1 to R (arm R); the driving moment is the arc's columns' only (a flat slice's weight
    # and base reaction cancel): gamma int_x1^R x sqrt(R^2 - x^2) dx = gamma (R^2 - x1^2)^1.5 / 3.
    base, r = 1.0, H
    x1 = math.sqrt(r * r - (H - base) ** 2)
    arc = r * (math.pi / 2.0 - math.asin(x1 / r))
    driving = CLAY.unit_weight * (r * r - x1 * x1) ** 1.5 / 3.0
    exact = CLAY.cohesion * (r * arc + (H - base) * x1) / driving
    assert bishop_factor(
        CUT, CLAY, Circle(0.0, H, r), 4000, base_y=base
    ) == pytest.approx(exact, rel=1e-5)
    # A circle that only touches the base is the circular one.
    assert bishop_factor(
        CUT, CLAY, Circle(0.0, H, r), 1000, base_y=0.0
    ) == pytest.approx(bishop_factor(CUT, CLAY, Circle(0.0, H, r), 1000), rel=1e-12)


def test_critical_circle_of_a_cohesionless_slope_is_the_infinite_slope():
    # c = 0: the shallowest circles approach the infinite slope, F = tan(phi) / tan(beta), from
    # above; the search comes within 0.1 % (beta: 1 on 2, phi 35 degrees).
    slope = Profile((-10.0, 0.0, 80.0, 90.0), (0.0, 0.0, 40.0, 40.0))
    sand = Soil(cohesion=1e-9, friction_angle=35.0, unit_weight=20.0)
    result = critical_circle(slope, sand, ((0.0, 80.0), (40.0, 140.0)), (5.0, 140.0))
    infinite = math.tan(math.radians(35.0)) / 0.5
    assert result.factor >= infinite * (1.0 - 1e-9)
    assert result.factor == pytest.approx(infinite, rel=1e-3)
