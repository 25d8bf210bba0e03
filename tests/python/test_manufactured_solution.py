"""The manufactured solution (case key manufactured_solution, mpm/core/manufactured.hpp): a unit
square of elastic soil with its edges fixed, driven by the body force that makes
u = A (1 - cos(2 pi t / T))^2 / 4 sin(pi x) sin(pi y) (1, 1) exact, run to t = T / 2
(studies.convergence.manufactured_case; issue "A discretisation that converges", item 3).

On 16 and 32 cells across, the relative L2 displacement error must fall at order >= 1.8 and the
stress error at order >= 0.9 for the MPM (linear and uGIMP, MUSL) and the UL-FEM: second order
for the displacement of linear elements and first for their gradients, as for a smooth field
without cell crossing (A = 1e-5 m moves no point across a cell). Measured: 2.00 and 1.00 for
every method on 8 to 64 cells (make study-convergence). The B-splines are held on a grid whose
edges are the square's, by their edge-modified functions (mpm/core/shape_functions.hpp), which
reproduce linear fields only: in the first cells from a fixed edge the gradient error is O(h),
in a layer O(h) wide, so the stress error's L2 order tends to 1.5 however smooth the field
inside; it must fall at order >= 1.4. And the energy ledger closes with the
body force's work booked as gravity_work (1e-6 of the largest term, as test_energy_identity)."""

import json
import subprocess

import pytest

from studies.convergence import (
    dilatation_case,
    dilatation_errors,
    manufactured_case,
    manufactured_errors,
)
from studies.common.convergence import ConvergenceStudy
from test_energy_identity import assert_ledger_closes

CELLS = (16, 32)


ORDERS = [  # (solver, shape function, least order of the stress error)
    ("mpm", "linear", 0.9),
    ("mpm", "gimp", 0.9),
    ("ulfem", "linear", 0.9),
    ("mpm", "quadratic_bspline", 1.4),
    ("mpm", "cubic_bspline", 1.4),
]


def assert_orders(pfm_binary, folder, solver, shape, scheme, stress_order) -> list:
    """Runs the manufactured case by `scheme` on CELLS and asserts the orders: displacement
    >= 1.8, stress >= stress_order. Returns the output folders."""
    errors, outs, study = [], [], ConvergenceStudy()
    for cells in CELLS:
        path = folder / f"case_{cells}.json"
        path.write_text(json.dumps(manufactured_case(cells, shape, scheme)))
        outs.append(folder / f"out_{cells}")
        subprocess.run(
            [pfm_binary, "run", path, "--out", outs[-1], "--quiet", "--threads", "1"]
            + ["--solver", solver],
            check=True,
            capture_output=True,
        )
        errors.append(manufactured_errors(outs[-1]))
        study.add("displacement", 1.0 / cells, errors[-1]["displacement"])
        study.add("stress", 1.0 / cells, errors[-1]["stress"])
    u_order = study.final_order("displacement")
    s_order = study.final_order("stress")
    label = f"{scheme} {solver} {shape}"
    assert u_order >= 1.8, f"{label}: displacement order {u_order:.2f}, {errors}"
    assert s_order >= stress_order, f"{label}: stress order {s_order:.2f}, {errors}"
    return outs


@pytest.mark.parametrize("solver, shape, stress_order", ORDERS)
def test_errors_fall_at_the_orders_of_the_shape_functions(
    pfm_binary, tmp_path, solver, shape, stress_order
):
    outs = assert_orders(pfm_binary, tmp_path, solver, shape, "musl", stress_order)
    end_time = manufactured_case(CELLS[0], shape, "musl")["time"]["end_time"]
    for out in outs:
        assert_ledger_closes(out, end_time)


@pytest.mark.parametrize("shape", ["quadratic_bspline", "cubic_bspline"])
def test_squeezed_disk_converges_with_b_splines(pfm_binary, tmp_path, shape):
    """The moving-boundary manufactured case (studies.convergence.dilatation_case: a free disk
    squeezed by a follower pressure on its detected boundary, which crosses cells as the radius
    shrinks by 9.5 %), the traction integrated with the B-splines of the step: on 8 and 16 cells
    per radius the displacement error must fall at first order at least (>= 0.9; measured 1.09
    quadratic, 1.20 cubic, and 1.04 / 1.18 between 32 and 64 in make study-convergence), and
    the energy ledger must close with the pressure's work booked."""
    errors, study = [], ConvergenceStudy()
    for cells in (8, 16):
        case = dilatation_case(cells, shape)
        path = tmp_path / f"disk_{cells}.json"
        path.write_text(json.dumps(case))
        out = tmp_path / f"disk_{cells}"
        subprocess.run(
            [pfm_binary, "run", path, "--out", out, "--quiet", "--threads", "1"],
            check=True,
            capture_output=True,
        )
        errors.append(dilatation_errors(out, case))
        study.add("displacement", 1.0 / cells, errors[-1]["displacement"])
        assert_ledger_closes(out, case["time"]["end_time"])
    order = study.final_order("displacement")
    assert order >= 0.9, f"{shape}: displacement order {order:.2f}, {errors}"


@pytest.mark.parametrize("solver, shape, stress_order", ORDERS)
def test_the_implicit_solver_converges_at_the_same_orders(
    pfm_binary, tmp_path, solver, shape, stress_order
):
    """The same square quasi-statically (solver.type "implicit", one load step to T / 2), held
    by the static body force b = -div sigma / rho, so u is the same field: the orders are the
    shape functions' as in the explicit run above, on 16 and 32 cells (no time integration
    error on top of the spatial one)."""
    assert_orders(pfm_binary, tmp_path, solver, shape, "implicit", stress_order)


def test_the_implicit_solver_refuses_the_free_squeezed_disk(pfm_binary, tmp_path):
    """A free body has no supports: a quasi-static step's stiffness would be singular, so the
    uniform dilatation is refused (exit 2) with its JSON path."""
    case = dilatation_case(4, "quadratic_bspline")
    case["solver"]["type"] = "implicit"
    path = tmp_path / "case.json"
    path.write_text(json.dumps(case))
    done = subprocess.run(
        [pfm_binary, "run", path, "--out", tmp_path / "out", "--quiet"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2, done.stderr
    assert "/manufactured_solution/type" in done.stderr, done.stderr
    assert not (tmp_path / "out").exists()
