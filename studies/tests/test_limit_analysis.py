"""The upper bound by discontinuity layout optimisation (studies/common/limit_analysis.py)
against what plasticity's bound theorems say of a vertical cut in undrained clay, whose
stability number gamma H F / c lies between Pastor's lower bound 3.64 and the single planar
wedge's 4 (Chen 1975 gives 3.83 by a log spiral; Smith and Gilbert 2007 3.786 by DLO on fine
nodes), and of refining the nodes."""

import pytest

from studies.common.limit_analysis import upper_bound
from studies.common.limit_equilibrium import Profile, Soil

H = 4.0
# A vertical cut at x = 2 m over a metre of soil below its toe, 7 m of ground behind it (the
# wedge reaches H).
CUT = Profile((0.0, 2.0, 2.0 + 1e-9, 9.0), (0.0, 0.0, H, H))
CLAY = Soil(cohesion=20.0, friction_angle=0.0, unit_weight=20.0)
SLOPE = Profile((0.0, 10.125, 14.125, 26.0), (6.0, 6.0, 10.0, 10.0))


def stability_number(bound) -> float:
    return CLAY.unit_weight * H * bound.factor / CLAY.cohesion


def test_coarse_nodes_find_the_planar_wedge_of_a_vertical_cut():
    # Nodes H / 4 apart hold the 45-degree line from the toe to the crest's ground at H behind
    # it: the single wedge, gamma H F / c = 4 exactly (F = 4 c / (gamma H)).
    assert stability_number(
        upper_bound(CUT, CLAY, H / 4.0, base_y=-1.0)
    ) == pytest.approx(4.0, rel=1e-6)


def test_finer_nodes_find_better_mechanisms_above_the_lower_bound():
    # At H / 8 the blocks fan out from the toe: a mechanism better than the wedge, still above
    # the lower bound 3.64 (no admissible mechanism can go below the true value).
    number = stability_number(upper_bound(CUT, CLAY, H / 8.0, base_y=-1.0))
    assert 3.64 <= number < 4.0 * (1.0 - 1e-3)


def test_nested_nodes_only_lower_the_bound():
    # The nodes 1 m apart hold those 2 m apart, and every mechanism of theirs.
    coarse = upper_bound(SLOPE, CLAY, 2.0)
    fine = upper_bound(SLOPE, CLAY, 1.0)
    assert fine.factor <= coarse.factor * (1.0 + 1e-9)
    assert fine.n_nodes > coarse.n_nodes


def test_friction_is_refused():
    with pytest.raises(ValueError, match="phi = 0"):
        upper_bound(SLOPE, Soil(5.0, 30.0, 20.0), 2.0)
