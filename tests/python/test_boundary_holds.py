"""The boundary holds (issue 45, must-show 1 and 2): with the default quadratic B-splines, and
cubic ones, a load on the top of a body comes to rest and stays there, exact up to the boundary.

The column: 1 m wide, 4 m high, h = 0.25 m, 2 x 2 points per cell, E = 5000 kPa, nu = 0.25,
unit weight 18, rollers on the grid's sides, fixed base, 30 kPa on its top (the detected boundary,
or grid_top_nodes), gravity and load ramped over 1 s, local damping 0.1, run to 60 s (settled by
about 10 s). Without the ties of nearly empty nodes (mpm/core/basis_extension.hpp) the quadratic
B-splines' kinetic energy grows about x 1.35 every 3 s from 1e-4 kJ/m at 3 s, the external work
falls and the top rows' stresses swing by hundreds of kPa.

Limits: kinetic energy at 60 s below 1e-6 of the external work and not above its value at 30 s
(no growth over the last half: within 1 %, the study's limit); the top points' settlement within 0.5 % of the closed form of
the solver's model (studies.analytic.column_displacement_large_strain: the rate form integrates
the logarithmic strain, 0.6 % less settlement than q H / M + gamma H^2 / (2 M) here); the mean
syy of the top row of points within 3 % of -(q + gamma (H - Y)), Y its reference height; the
energy ledger closed (test_energy_identity's tolerance). Linear functions and uGIMP (the
thesis's and the shipped default case's) come to rest too; their top rows are not within 3 %
under a detected load (issue 45, open).
"""


import pandas as pd
import pytest

from studies import analytic
from studies.stability import column_surcharge_case, with_margin
from test_energy_identity import assert_ledger_closes

H, Q, GAMMA, E, NU = 4.0, 30.0, 18.0, 5000.0, 0.25  # the column_surcharge_case
END = 60.0


def column_case(shape_function: str, apply_on: str) -> dict:
    """The study's column (studies.stability.column_surcharge_case) with the shape function
    and the load's target, to END."""
    case = column_surcharge_case()
    case["title"] += f", {shape_function}, load on {apply_on}"
    case["loads"][0]["apply_on"] = apply_on
    case["solver"]["shape_function"] = shape_function
    case["time"]["end_time"] = END
    case["output"] = {"interval": END / 2, "timeseries_interval": 1.0}
    return case


def rested_top_row(run_case, case: dict, folder):
    """Runs the column case; asserts it is at rest at END and not growing over the last half and
    that its ledger closes; returns the top row of points and its reference height."""
    result = run_case(case, folder, "--threads", "1")
    assert result.returncode == 0, result.stderr
    out = folder / "out"
    series = pd.read_csv(out / "timeseries.csv")
    work = series["external_work"].iloc[-1]
    kinetic = series["kinetic_energy"]
    half = kinetic[series["time"] >= END / 2 - 1e-9].iloc[0]
    assert kinetic.iloc[-1] < 1e-6 * work, (kinetic.iloc[-1], work)
    assert kinetic.iloc[-1] <= 1.01 * half, (half, kinetic.iloc[-1])
    assert_ledger_closes(out, END)
    points = pd.read_csv(out / "final_particles.csv")
    reference_y = (points["y"] - points["uy"]).round(9)
    y0 = float(reference_y.max())
    return points[reference_y == y0], y0


@pytest.mark.parametrize("apply_on", ["detected_boundary", "grid_top_nodes"])
@pytest.mark.parametrize("shape_function", ["quadratic_bspline", "cubic_bspline"])
def test_column_under_a_surcharge_rests_exact_up_to_its_top(
    run_case, tmp_path, shape_function, apply_on
):
    top, y0 = rested_top_row(run_case, column_case(shape_function, apply_on), tmp_path)
    exact_u = analytic.column_displacement_large_strain(y0, H, Q, GAMMA, E, NU)
    assert top["uy"].mean() == pytest.approx(exact_u, rel=0.005)
    exact_syy = analytic.column_vertical_stress(y0, H, Q, GAMMA)
    assert top["syy"].mean() == pytest.approx(exact_syy, rel=0.03)


@pytest.mark.parametrize("shape_function", ["linear", "gimp"])
def test_column_under_a_detected_surcharge_rests_with_linear_functions_and_ugimp(
    run_case, tmp_path, shape_function
):
    """The twin for the other functions: at rest and not growing (uGIMP on a grid with a margin
    and node-set walls, studies.stability.with_margin; without the ties its kinetic energy
    triples over the last 30 s), the top points' settlement within 1 %."""
    case = column_case(shape_function, "detected_boundary")
    if shape_function == "gimp":
        case = with_margin(case)
    top, y0 = rested_top_row(run_case, case, tmp_path)
    exact_u = analytic.column_displacement_large_strain(y0, H, Q, GAMMA, E, NU)
    assert top["uy"].mean() == pytest.approx(exact_u, rel=0.01)


@pytest.mark.parametrize(
    "shape_function, apply_on",
    [
        ("quadratic_bspline", "detected_boundary"),
        ("quadratic_bspline", "grid_top_nodes"),
        ("cubic_bspline", "grid_top_nodes"),
    ],
)
def test_bspline_column_on_walls_inside_the_grid_settles_as_on_the_grid_edges(
    run_case, tmp_path, shape_function, apply_on
):
    """The column on a grid with a margin of 2 cells, its base and walls node sets that hold the
    nodes behind them (studies.stability.with_margin, as uGIMP needs): the B-splines' node behind
    each wall is its front neighbour's mirror image (mpm/core/wall_mirror.hpp), so the walls hold
    as the grid's edges do: settlement within 0.5 %. With the nodes behind merely fixed, the base
    gives way by 1/8 (quadratic) or 1/6 (cubic) of the first free node row's motion. The top
    row's syy within 3 % under the grid-top load; under the detected load the detector rounds the
    top corners by the walls (a third of a cell), and the points beside them carry less.
    """
    case = with_margin(column_case(shape_function, apply_on))
    top, y0 = rested_top_row(run_case, case, tmp_path)
    exact_u = analytic.column_displacement_large_strain(y0, H, Q, GAMMA, E, NU)
    assert top["uy"].mean() == pytest.approx(exact_u, rel=0.005)
    if apply_on == "grid_top_nodes":
        exact_syy = analytic.column_vertical_stress(y0, H, Q, GAMMA)
        assert top["syy"].mean() == pytest.approx(exact_syy, rel=0.03)
