"""Readers of the real output layout (closed flags of boundary loops, stopped runs) and the
read-outs and closed forms the studies rely on, on synthetic data with known answers."""

import json
import math

import h5py
import numpy as np
import pandas as pd
import pytest

from studies import analytic
from studies.benchmarks import collapse_pressure
from studies.common.measures import surface_settlement_extrapolated
from studies.common.outputs import final_particles, loop_closed_flags, read_boundary
from studies.metrics import boundary_distance, Polyline


def test_closed_flags_come_from_the_detect_summary(tmp_path):
    # Two loops: an open chain ending on the grid edge and a closed square.
    (tmp_path / "boundary.csv").write_text(
        "loop,x,y\n0,0,1\n0,1,1.2\n0,2,1\n1,5,5\n1,6,5\n1,6,6\n1,5,6\n"
    )
    (tmp_path / "summary.json").write_text(json.dumps({"loop_closed": [False, True]}))
    loops = read_boundary(tmp_path / "boundary.csv")
    assert [l.closed for l in loops] == [False, True]
    # Without the closing segment the open chain is 2 * hypot(1, 0.2) long, not + 2 m.
    assert abs(loops[0].length() - 2 * math.hypot(1, 0.2)) <= 1e-12


def test_closed_flags_come_from_the_run_boundary_series(tmp_path):
    (tmp_path / "boundary_00000040.csv").write_text(
        "loop,x,y\n0,0,1\n0,1,1.2\n0,2,1\n1,5,5\n1,6,5\n1,6,6\n1,5,6\n"
    )
    with h5py.File(tmp_path / "boundary.h5", "w") as h5:
        group = h5.create_group("step_00000040")
        group["loop"] = np.array([0, 0, 0, 1, 1, 1, 1], dtype=float)
        group["segments"] = np.array([[0, 1], [1, 2], [3, 4], [4, 5], [5, 6], [6, 3]])
        group["position"] = np.zeros((7, 3))
    assert loop_closed_flags(tmp_path / "boundary_00000040.csv") == [False, True]
    assert (
        loop_closed_flags(tmp_path / "boundary_00000041.csv") is None
    )  # no group: closed


def test_final_particles_of_a_stopped_run_is_its_last_output(tmp_path):
    with h5py.File(tmp_path / "particles.h5", "w") as h5:
        for step, y in ((0, 1.0), (9, 0.5)):
            group = h5.create_group(f"step_{step:08d}")
            group.attrs["step"], group.attrs["time"] = float(step), step / 100
            group["position"] = np.array([[0.0, y, 0.0]])
            group["displacement"] = np.array([[0.0, y - 1.0, 0.0]])
    assert final_particles(tmp_path)["uy"].iloc[0] == -0.5


def test_surface_settlement_is_exact_for_a_linear_field():
    # uy = -(0.01 + 0.002 (5 - y0)): the top (y0 = 5) settles 0.01 m.
    y0 = np.array([4.875, 4.625, 4.875, 4.625, 4.375])
    x = np.array([7.4, 7.4, 7.6, 7.6, 7.5])
    uy = -(0.01 + 0.002 * (5.0 - y0))
    particles = pd.DataFrame({"x": x, "y": y0 + uy, "ux": 0.0, "uy": uy})
    assert (
        abs(surface_settlement_extrapolated(particles, 7.5, 5.0, 0.5) - 0.01) <= 1e-15
    )


def test_column_closed_forms():
    e, nu, gamma, q, height = 1.0e4, 0.3, 20.0, 50.0, 5.0
    m = analytic.constrained_modulus(e, nu)
    assert analytic.column_settlement(height, q, gamma, e, nu) == pytest.approx(
        q * height / m + gamma * height**2 / (2 * m), rel=1e-15
    )
    assert analytic.column_displacement(
        height, height, q, gamma, e, nu
    ) == pytest.approx(-analytic.column_settlement(height, q, gamma, e, nu), rel=1e-15)
    # Large strain: weightless limit H (1 - exp(-q / M)), and it tends to small strain as the
    # strains vanish (stiff soil).
    assert analytic.column_settlement_large_strain(
        height, q, 0.0, e, nu
    ) == pytest.approx(height * (1 - math.exp(-q / m)), rel=1e-15)
    stiff = 1e9
    assert analytic.column_settlement_large_strain(
        height, q, gamma, stiff, nu
    ) == pytest.approx(
        analytic.column_settlement(height, q, gamma, stiff, nu), rel=1e-5
    )
    assert analytic.column_settlement_large_strain(
        height, q, gamma, e, nu
    ) < analytic.column_settlement(height, q, gamma, e, nu)


def test_collapse_pressure_of_a_bilinear_curve():
    # Stiffness 1000 kPa/m up to 50 kPa, then 10 kPa/m (1 % of it): collapse at 50 kPa.
    q = np.linspace(0.0, 70.0, 71)
    s = np.where(q <= 50.0, q / 1000.0, 0.05 + (q - 50.0) / 10.0)
    assert (
        collapse_pressure(pd.DataFrame({"pressure": q, "settlement": s}), 0.05) == 50.0
    )
    elastic = pd.DataFrame({"pressure": q, "settlement": q / 1000.0})
    assert collapse_pressure(elastic, 0.05) is None


def test_distance_of_an_open_chain_counts_no_closing_segment():
    reference = [Polyline([[0.0, 1.0], [4.0, 1.0]], closed=False)]
    detected = [Polyline([[0.0, 1.1], [4.0, 1.1]], closed=False)]
    assert abs(boundary_distance(detected, reference, h=0.5).overall.max - 0.1) <= 1e-12


def test_ledger_lines_show_each_load_and_the_closure_is_relative_to_the_largest_term():
    from studies.common.ledger import ledger_lines, relative_energy_error

    t = np.linspace(0.0, 1.0, 5)
    series = pd.DataFrame(
        {
            "time": t,
            "gravity_work": 2.0 * t,
            "load_work": 3.0 * t,
            "load_work_0": 1.0 * t,
            "load_work_1": 2.0 * t,
            "elastic_energy": 1.0 + 4.0 * t,
            "kinetic_energy": 0.5 * t,
            "plastic_dissipation": 0.0 * t,
            "damping_work": -0.5 * t,
            "transfer_to_grid": 0.0 * t,
            "transfer_to_particles": 0.0 * t,
            "internal_force_work": -10.0 * t,
            "internal_work": 10.0 * t,
            "constraint_work": 0.0 * t,
            "rotation_work": 0.0 * t,
            "volume_work": 0.0 * t,
            "energy_error": [0.0, 1e-14, -5e-14, 0.0, 2e-14],
        }
    )
    labels = [label for label, _, _ in ledger_lines(series)]
    assert "work of load 0" in labels and "work of load 1" in labels
    assert "load work" not in labels
    # The largest term of the run: elastic energy 5 kJ/m and the internal force work -10.
    assert relative_energy_error(series) == pytest.approx(5e-14 / 10.0, rel=1e-12)
    one_load = series.drop(columns=["load_work_1"])
    assert "load work" in [label for label, _, _ in ledger_lines(one_load)]
