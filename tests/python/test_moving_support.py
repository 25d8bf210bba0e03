"""Moving supports (boundary_conditions[].velocity): the fixed components of a node set move at
a prescribed velocity, and the force holding them is the reaction in timeseries.csv.

An oedometer driven by a platen: a 1 m x 2 m elastic block (E = 1e4 kPa, nu = 0.3, weightless)
on a fixed base between rollers, its top (the grid's top edge) pushed down at 0.01 m/s after a
smooth ramp of 0.2 s. At rest the stress is uniform, s_yy = -M d / H with the constrained
modulus M and the platen's displacement d = v (t - t_r / 2), and the reaction is s_yy times the
width. The explicit run lags the quasi-static answer by the stress wave's transit: about 0.5 %."""

import json

import numpy as np
import pandas as pd
import pytest

E, NU, H, WIDTH, V, RAMP = 1.0e4, 0.3, 2.0, 1.0, 0.01, 0.2
M = E * (1 - NU) / ((1 + NU) * (1 - 2 * NU))


def oedometer(shape: str = "linear") -> dict:
    return {
        "title": "oedometer by a moving platen",
        "grid": {"origin": [0, 0], "cell_size": 0.25, "n_cells": [4, 8]},
        "materials": [
            {
                "name": "soil",
                "model": "linear_elastic",
                "youngs_modulus": E,
                "poisson_ratio": NU,
                "unit_weight": 20.0,
            }
        ],
        "bodies": [
            {"name": "block", "material": "soil", "rectangle": [[0, 0], [1, 2]]}
        ],
        "gravity": {"g": 0.0},
        "boundary_conditions": [
            {"where": "bottom", "fix": "xy"},
            {"where": "left", "fix": "x"},
            {"where": "right", "fix": "x"},
            {
                "where": "top",
                "fix": "y",
                "velocity": [0, -V],
                "time_function": {"type": "smooth_ramp", "ramp_time": RAMP},
            },
        ],
        "solver": {"shape_function": shape},
        "time": {"end_time": 1.0, "cfl": 0.5},
        "output": {"interval": 0.5},
    }


@pytest.mark.parametrize(
    "shape, solver",
    [("linear", "mpm"), ("quadratic_bspline", "mpm"), ("linear", "ulfem")],
)
def test_a_platen_compresses_an_oedometer_with_its_reaction(
    run_case, tmp_path, shape, solver
):
    """After the ramp (t >= 0.3 s) the reaction is within 1 % of -M d / H x width; the energy
    identity closes to 1e-12 of its largest term; the platen's work (constraint_work) is the
    elastic energy stored, within 1 %."""
    result = run_case(oedometer(shape), tmp_path, "--solver", solver)
    assert result.returncode == 0, result.stderr
    series = pd.read_csv(tmp_path / "out" / "timeseries.csv")
    after = series[series["time"] >= 0.3]
    settlement = V * (after["time"] - RAMP / 2)
    expected = -M * settlement / H * WIDTH
    error = (after["reaction_3_fy"] - expected) / expected.abs()
    assert error.abs().max() <= 0.01, error.abs().max()
    assert (after["reaction_3_fx"] == 0.0).all()  # x is not held by this condition
    scale = series[["elastic_energy", "constraint_work"]].abs().to_numpy().max()
    assert series["energy_error"].abs().max() <= 1e-12 * scale
    last = series.iloc[-1]
    assert abs(last["constraint_work"] / last["elastic_energy"] - 1.0) <= 0.01


def test_a_platen_at_rest_is_a_support(run_case, tmp_path):
    """velocity [0, 0] gives the run of a plain support, every output byte but the time
    series' reaction columns."""
    held = oedometer()
    held["boundary_conditions"][3] = {"where": "top", "fix": "y"}
    still = oedometer()
    still["boundary_conditions"][3]["velocity"] = [0, 0]
    for name, case in (("held", held), ("still", still)):
        result = run_case(case, tmp_path / name)
        assert result.returncode == 0, result.stderr
    for name in ("final_particles.csv", "particles.h5"):
        a = (tmp_path / "held" / "out" / name).read_bytes()
        assert a == (tmp_path / "still" / "out" / name).read_bytes(), name
    moving = pd.read_csv(tmp_path / "still" / "out" / "timeseries.csv")
    plain = pd.read_csv(tmp_path / "held" / "out" / "timeseries.csv")
    assert np.array_equal(moving[plain.columns].to_numpy(), plain.to_numpy())


@pytest.mark.parametrize(
    "change, pointer, words",
    [
        (
            {"velocity": [0.1, -0.01]},
            "/boundary_conditions/3/velocity",
            "x is not fixed",
        ),
        ({"velocity": "fast"}, "/boundary_conditions/3/velocity", ""),
        (
            {"velocity": None, "time_function": {"type": "ramp", "ramp_time": 1}},
            "/boundary_conditions/3/time_function",
            'used only with "velocity"',
        ),
    ],
)
def test_bad_moving_supports_exit_2_with_the_json_path(
    run_case, tmp_path, change, pointer, words
):
    case = oedometer()
    condition = case["boundary_conditions"][3]
    condition.update(change)
    if condition["velocity"] is None:
        del condition["velocity"]
    result = run_case(case, tmp_path)
    assert result.returncode == 2, result.stderr
    assert pointer in result.stderr and words in result.stderr, result.stderr
