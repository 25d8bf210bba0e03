"""The slope section of the implicit study (studies/slope_safety.py): its cases are what the C++
reader accepts and what the section says, and Bishop's circle of its profile is tangent to the
rough base, in the range of Taylor's chart for a 45 degree slope in purely cohesive soil."""

import pytest

from fem_reference.dolfinx_model.case import _core
from studies.slope_safety import SLOPE_CELLS, bishop, slope_case, slope_profile


@pytest.mark.parametrize("h", SLOPE_CELLS)
def test_slope_cases_are_read_as_the_section_describes(h):
    resolved = _core().parse_case(slope_case(h), "slope.json")
    assert resolved["solver"]["type"] == "implicit"
    # B-bar by default with the strength reduction (isochoric plastic flow).
    assert resolved["solver"]["anti_locking"] == "bbar"
    assert resolved["implicit"]["strength_reduction"] == {
        "start_time": 1.0,
        "final_factor": 2.0,
    }
    assert resolved["grid"]["cell_size"] == h
    assert resolved["grid"]["n_cells"] == [round(26.0 / h), round(11.0 / h)]


def test_bishop_circle_of_the_thesis_slope():
    case = slope_case(0.5)
    profile = slope_profile(case)
    assert profile.x == (0.0, 10.125, 14.125, 26.0)
    assert profile.y == (6.0, 6.0, 10.0, 10.0)
    result = bishop(case)
    # Tangent to the rough base at y = 0 (the base limits the deep circle of phi = 0 soil).
    assert result.circle.yc - result.circle.radius == pytest.approx(0.0, abs=1e-3)
    # Taylor's chart (phi = 0, beta = 45 degrees): the stability number c / (F gamma H) of the
    # deepest circle is 0.181, so F >= 1.38; a base that cuts the circle off raises F, at this
    # depth factor (2.5) by a few per cent.
    assert 1.38 <= result.factor <= 1.45
