"""Anti-locking (solver.anti_locking "bbar", mpm/core/kinematics.hpp): a smooth strip footing
on weightless, nearly incompressible Tresca soil (nu = 0.49) collapses at Prandtl's (2 + pi) c
with the mean dilatation, and locks without it (issue "A discretisation that converges", item 1).

The footing is studies.benchmarks.prandtl_case, made small enough for a test: b = 0.5 m with 4
cells under it (the benchmark study has 8, uGIMP and the load on the detected boundary, 6 min a
run), linear shape functions, the load on the grid-top nodes, ramped to 1.2 (2 + pi) c over
4 s, 130 outputs (a pressure step of 1 % of (2 + pi) c). Measured: MPM with B-bar -0.3 %,
UL-FEM with B-bar +1.5 % (a UL-FEM run may stop on an inverted element past the collapse);
without anti-locking neither collapses up to 1.2 (2 + pi) c.

Limits: the collapse within 3 % of (2 + pi) c for either solver (the issue's limit for the
MPM at 8 cells; this footing has 4); without anti-locking no collapse up to 1.2 (2 + pi) c
(the locking the issue reports: +16.7 % at nu = 0.45; the benchmark study's 8-cell footing
without it collapses at +11.5 %). The energy ledger closes on the B-bar runs (1e-6 of the
largest term, as test_energy_identity)."""

import json
import subprocess

import pytest

from studies import analytic
from studies.benchmarks import collapse_pressure, prandtl_case, prandtl_curve
from test_energy_identity import assert_ledger_closes

COHESION = 10.0  # kPa
RAMP = 4.0  # s


def run_footing(
    binary,
    folder,
    solver,
    anti_locking,
    shape_function="linear",
    apply_on="grid_top_nodes",
):
    case = prandtl_case(
        COHESION,
        0.5,
        anti_locking,
        cells_under_half_width=4,
        shape_function=shape_function,
        apply_on=apply_on,
        ramp_time=RAMP,
        outputs=130,
    )
    path = folder / "case.json"
    path.write_text(json.dumps(case))
    result = subprocess.run(
        [binary, "run", path, "--out", folder / "out", "--quiet", "--threads", "1"]
        + ["--solver", solver],
        capture_output=True,
        text=True,
    )
    # 3: stopped (an inverted UL-FEM element past the collapse); the outputs up to it are kept.
    assert result.returncode in (0, 3), result.stderr
    curve = prandtl_curve(folder / "out", case)
    return curve, collapse_pressure(curve, 0.05), result.returncode


@pytest.mark.parametrize("solver", ["mpm", "ulfem"])
def test_the_mean_dilatation_collapses_at_prandtl_and_without_it_the_footing_locks(
    pfm_binary, tmp_path, solver
):
    q_u = analytic.prandtl_bearing_capacity(COHESION)
    (tmp_path / "bbar").mkdir()
    curve, collapse, code = run_footing(pfm_binary, tmp_path / "bbar", solver, "bbar")
    assert (
        collapse is not None
    ), f"{solver}: no collapse up to {curve.pressure.max():.1f} kPa"
    assert (
        abs(collapse / q_u - 1) <= 0.03
    ), f"{solver}: {collapse:.2f} kPa against {q_u:.2f}"
    if code == 0:
        assert_ledger_closes(tmp_path / "bbar" / "out", RAMP)

    (tmp_path / "none").mkdir()
    curve, collapse, code = run_footing(pfm_binary, tmp_path / "none", solver, "none")
    assert code == 0
    assert collapse is None, f"{solver}: collapse at {collapse:.2f} kPa"


def test_quadratic_b_splines_with_the_mean_dilatation_collapse_at_prandtl(
    pfm_binary, tmp_path
):
    """The same footing with quadratic B-splines (the grid's edges as the supports) and the
    load on the detected top, as B-splines take it: the collapse within the same 3 %, and the
    energy ledger closes with the load's work on the detected boundary."""
    q_u = analytic.prandtl_bearing_capacity(COHESION)
    curve, collapse, code = run_footing(
        pfm_binary,
        tmp_path,
        "mpm",
        "bbar",
        shape_function="quadratic_bspline",
        apply_on="detected_boundary",
    )
    assert code == 0
    assert collapse is not None, f"no collapse up to {curve.pressure.max():.1f} kPa"
    assert abs(collapse / q_u - 1) <= 0.03, f"{collapse:.2f} kPa against {q_u:.2f}"
    assert_ledger_closes(tmp_path / "out", RAMP)
