"""The footing benchmark's cases and measure (studies/benchmarks/footing.py): both cases are valid
for the C++ reader; the constraint is the first and holds the top under the footing, the support
the fourth condition; footing_curve gives the settlement the footing's velocity and smooth ramp
prescribe and the reaction pressure over (2 + pi) c."""

import numpy as np
import pandas as pd
import pytest

from studies import analytic, benchmarks
from studies.common.paths import core


def test_the_footing_cases_are_valid_and_drive_the_footing():
    pfm_mpm = core()
    f = benchmarks.FOOTING
    constraint = pfm_mpm.parse_case(
        benchmarks.footing_case("constraint", 16.0), "c.json"
    )
    (spec,) = constraint["constraints"]
    assert spec["x_range"] == [-f["half_width"], f["half_width"]]
    assert constraint["solver"]["pic_fraction"] == f["pic_fraction"]
    support = pfm_mpm.parse_case(benchmarks.footing_case("support"), "s.json")
    moving = support["boundary_conditions"][3]
    assert moving["where"] == "footing" and moving["velocity"] == [0.0, -f["speed"]]


def test_footing_curve_is_the_prescribed_settlement_and_the_pressure(tmp_path):
    """After the smooth ramp t_r the footing has moved v (t - t_r / 2); before it, v t_r u^4
    (5/2 - 3 u + u^2) with u = t / t_r (the ramp's integral), to 1e-15 m."""
    f = benchmarks.FOOTING
    ramp = f["ramp_fraction"] * f["duration"]
    t = np.array([0.0, 0.5 * ramp, ramp, 2.0, f["duration"]])
    q_u = analytic.prandtl_bearing_capacity(f["cohesion"])
    force = -q_u * f["half_width"] * np.array([0.0, 0.5, 0.9, 1.0, 1.1])
    pd.DataFrame({"time": t, "reaction_3_fy": force}).to_csv(
        tmp_path / "timeseries.csv", index=False
    )
    curve = benchmarks.footing_curve(tmp_path, "mpm", constraint=False)
    u = 0.5
    expected = f["speed"] * np.array(
        [
            0.0,
            ramp * u**4 * (2.5 - 3 * u + u * u),
            ramp / 2,
            2.0 - ramp / 2,
            4.0 - ramp / 2,
        ]
    )
    assert np.allclose(curve["s_over_b"] * f["half_width"], expected, atol=1e-15)
    assert curve["q_over_prandtl"].tolist() == pytest.approx([0.0, 0.5, 0.9, 1.0, 1.1])


def test_a_slower_footing_reaches_the_same_settlement(tmp_path):
    """The rate check: at a fraction k of the speed the case runs 1 / k as long, ramps 1 / k as
    long, and footing_curve at k maps the scaled times onto the same settlements (to 1e-15 m).
    """
    f = benchmarks.FOOTING
    k = 0.25
    case = benchmarks.footing_case("constraint", 16.0, speedup=k)
    (spec,) = case["constraints"]
    assert spec["normal_velocity"] == pytest.approx(-k * f["speed"], rel=1e-15)
    assert case["time"]["end_time"] == pytest.approx(f["duration"] / k, rel=1e-15)
    assert spec["time_function"]["ramp_time"] == pytest.approx(
        f["ramp_fraction"] * f["duration"] / k, rel=1e-15
    )
    t = np.array([0.0, 0.2, 0.4, 2.0, f["duration"]])
    q = np.zeros_like(t)
    pd.DataFrame({"time": t, "reaction_3_fy": q}).to_csv(
        tmp_path / "timeseries.csv", index=False
    )
    at_speed = benchmarks.footing_curve(tmp_path, "mpm", constraint=False)
    pd.DataFrame({"time": t / k, "reaction_3_fy": q}).to_csv(
        tmp_path / "timeseries.csv", index=False
    )
    slower = benchmarks.footing_curve(tmp_path, "mpm", constraint=False, speedup=k)
    assert np.allclose(slower["s_over_b"], at_speed["s_over_b"], rtol=0, atol=1e-15)


def test_the_speedup_is_read_back_from_the_case():
    """_footing takes each run's speed from its case: the constraint's and the support's."""
    for k in (1.0, 0.5, 0.125):
        for how in ("constraint", "support"):
            case = benchmarks.footing_case(
                how, 16.0 if how == "constraint" else None, speedup=k
            )
            assert benchmarks.footing_speedup(case) == pytest.approx(k, rel=1e-15)


def test_a_refined_footing_has_the_cells_it_asks_for():
    """footing_case(cells=n) puts n cells (the UL-FEM: elements) under b; the jobs hold the
    constraint and the UL-FEM at FOOTING's refined_cells."""
    f = benchmarks.FOOTING
    n = f["refined_cells"]
    for how in ("constraint", "support"):
        case = benchmarks.footing_case(
            how, 16.0 if how == "constraint" else None, cells=n
        )
        assert benchmarks.footing_cells(case) == n
        assert case["grid"]["cell_size"] == pytest.approx(
            f["half_width"] / n, rel=1e-15
        )
    assert benchmarks.footing_cells(benchmarks.footing_case("support")) == (
        f["cells_under_half_width"]
    )
    jobs = benchmarks.footing_jobs()
    assert benchmarks.footing_cells(jobs[f"footing/constraint/f16_h{n}"][0]) == n
    assert jobs[f"footing/support/ulfem_h{n}"][1] == "ulfem"


def test_the_constraint_is_compared_with_the_ulfem_of_the_same_cells():
    """footing_against_ulfem: the largest |constraint / UL-FEM - 1| over the windows both
    reached, per constraint run at the speed, against the UL-FEM of its own cells only.
    """
    f = benchmarks.FOOTING
    names = [f"mean_{a:g}_{z:g}" for a, z in f["windows"]]

    def row(run, solver, cells, values, speed=f["speed"]):
        return {"run": run, "solver": solver, "cells": cells, "speed": speed} | dict(
            zip(names, values)
        )

    nan = float("nan")
    rows = [
        row("constraint_f16", "mpm", 8, [1.1, 1.2, 1.0, 1.0]),
        row("constraint_f16_x0.5", "mpm", 8, [1.1, 1.2, 1.0, 1.0], 0.5 * f["speed"]),
        row("constraint_f16_h16", "mpm", 16, [1.0, 1.05, 1.0, nan]),
        row("support_mpm", "mpm", 8, [9.0, 9.0, 9.0, 9.0]),
        row("support_ulfem", "ulfem", 8, [1.0, 1.0, 1.0, 1.0]),
        row("support_ulfem_h16", "ulfem", 16, [1.0, 1.0, 1.25, 9.0]),
    ]
    result = benchmarks.footing_against_ulfem(rows)
    assert set(result) == {"constraint_f16", "constraint_f16_h16"}
    assert result["constraint_f16"] == pytest.approx(0.2, rel=1e-12)
    assert result["constraint_f16_h16"] == pytest.approx(0.2, rel=1e-12)


def test_the_plateau_line_is_the_least_squares_line_over_the_plateau():
    """footing_plateau_line recovers q = q0 + k s / b over the plateau window to rounding, and
    ignores the curve outside it."""
    lo, hi = benchmarks.FOOTING["plateau"]
    s = np.linspace(0.0, 0.14, 281)
    q = np.where((s >= lo) & (s <= hi), 1.02 + 1.06 * s, 5.0)
    at_0, slope = benchmarks.footing_plateau_line(
        pd.DataFrame({"s_over_b": s, "q_over_prandtl": q})
    )
    assert at_0 == pytest.approx(1.02, abs=1e-12)
    assert slope == pytest.approx(1.06, abs=1e-10)


def test_the_dip_is_the_deepest_fall_below_the_highest_window_before():
    """footing_dip: 0 for a rising reaction, whatever happens before the plateau's start; for a
    reaction that rises, falls by 5 % of its highest window mean over one window and rises
    again, 0.05 (windows of FOOTING's dip_window from the plateau's start)."""
    f = benchmarks.FOOTING
    lo, step = f["plateau"][0], f["dip_window"]
    s = np.linspace(0.0, 0.1425, 571)
    rising = 1.0 + s + np.where(s < lo, 0.5 - 10 * s, 0.0)
    curve = pd.DataFrame({"s_over_b": s, "q_over_prandtl": rising})
    assert benchmarks.footing_dip(curve) == 0.0
    q = np.full_like(s, 1.0)
    q[s >= lo + step] = 2.0
    fallen = (s >= lo + 5 * step) & (s < lo + 6 * step)
    q[fallen] = 1.9
    curve = pd.DataFrame({"s_over_b": s, "q_over_prandtl": q})
    assert benchmarks.footing_dip(curve) == pytest.approx(0.05, rel=1e-12)


def test_each_constraint_is_compared_with_its_refined_twin():
    """footing_against_refined: the largest |mean q / the twin's - 1| over the windows both
    reached, for a run at FOOTING's cells whose name with _h<refined_cells> is a run; runs
    without a twin and the twins themselves have none. The jobs hold the default shape
    functions' twins."""
    f = benchmarks.FOOTING
    n, cells = f["refined_cells"], f["cells_under_half_width"]
    names = [f"mean_{a:g}_{z:g}" for a, z in f["windows"]]

    def row(run, cells, values):
        return {"run": run, "cells": cells} | dict(zip(names, values))

    nan = float("nan")
    rows = [
        row("constraint_f16", cells, [1.1, 1.2, 1.0, 5.0]),
        row(f"constraint_f16_h{n}", n, [1.0, 1.0, 1.25, nan]),
        row("constraint_f100", cells, [1.0, 1.0, 1.0, 1.0]),
        row(f"constraint_f16_default_h{n}", n, [1.0, 1.0, 1.0, 1.0]),
    ]
    result = benchmarks.footing_against_refined(rows)
    assert set(result) == {"constraint_f16"}
    assert result["constraint_f16"] == pytest.approx(0.2, rel=1e-12)
    jobs = benchmarks.footing_jobs()
    for key in (
        "footing/constraint/f16_default",
        f"footing/constraint/f16_default_h{n}",
    ):
        assert "shape_function" not in jobs[key][0]["solver"]
    assert (
        benchmarks.footing_cells(jobs[f"footing/constraint/f16_default_h{n}"][0]) == n
    )
