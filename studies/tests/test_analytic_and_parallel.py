"""Closed-form references and the sweep machinery."""

import math
import sys

import numpy as np
import pytest

from studies import analytic
from studies.common.convergence import ConvergenceStudy
from studies.common.parallel import SchedulerUnavailable, parallel_map


def test_strip_load_under_the_centre_at_depth_b():
    # alpha = 2 atan(b / z) = pi / 2 at z = b: sigma_z = q (pi / 2 + 1) / pi.
    q, b = 100.0, 1.5
    value = analytic.strip_vertical_stress(q, b, 0.0, b)
    assert abs(value - q * (math.pi / 2 + 1) / math.pi) <= 1e-12


def test_strip_load_limits_and_symmetry():
    q, b = 10.0, 1.0
    assert (
        abs(analytic.strip_vertical_stress(q, b, 0.0, 1e-9) - q) <= 1e-6
    )  # surface, inside
    assert (
        abs(analytic.strip_vertical_stress(q, b, 3.0, 1e-9)) <= 1e-6
    )  # surface, outside
    assert analytic.strip_vertical_stress(q, b, 0.0, 1e4) <= 1e-3 * q  # deep
    x = np.linspace(-5, 5, 11)
    values = analytic.strip_vertical_stress(q, b, x, 2.0)
    assert np.allclose(values, values[::-1], rtol=0, atol=1e-12)


def test_column_and_prandtl_and_disk():
    m = analytic.constrained_modulus(1.0e4, 0.3)
    assert abs(m - 1.0e4 * 0.7 / (1.3 * 0.4)) <= 1e-9
    assert (
        abs(analytic.column_surcharge_settlement(5.0, 50.0, 1.0e4, 0.3) - 250.0 / m)
        <= 1e-15
    )
    assert analytic.column_vertical_stress(5.0, 5.0, 50.0, 20.0) == -50.0
    assert abs(analytic.prandtl_bearing_capacity(10.0) - 51.41592653589793) <= 1e-12
    disk = analytic.disk_external_pressure(2.0, 10.0, 1.0e4, 0.3)
    assert disk["szz"] == -6.0 and disk["radial_displacement"] < 0


def test_observed_orders_of_a_second_order_error():
    h = [0.5, 0.25, 0.125]
    orders = analytic.observed_orders(h, [3 * x**2 for x in h])
    assert orders[0] is None and all(abs(o - 2.0) <= 1e-12 for o in orders[1:])


def test_convergence_study_orders_from_coarse_to_fine_whatever_the_order_added():
    # e = 3 h^2 and e = h added finest first: orders 2 and 1 exactly, None at the coarsest.
    study = ConvergenceStudy()
    for h in (0.125, 0.5, 0.25):
        study.add("second", h, 3 * h**2, value=1.0 + 3 * h**2, reference=1.0)
        study.add("first", h, h)
    assert study.quantities() == ["second", "first"]
    assert [h for h, _ in study.orders("second")] == [0.5, 0.25, 0.125]
    assert study.orders("second")[0][1] is None
    assert abs(study.final_order("second") - 2.0) <= 1e-12
    assert abs(study.final_order("first") - 1.0) <= 1e-12
    table = study.table()
    assert list(table["quantity"]) == ["first"] * 3 + ["second"] * 3
    assert list(table["h_m"])[:3] == [0.5, 0.25, 0.125]
    second = table[table["quantity"] == "second"]
    assert np.allclose(second["value"] - second["reference"], second["error"])
    assert np.allclose(second["observed_order"].iloc[1:].astype(float), 2.0)
    # A zero error has no order; a single size has no final order.
    study.add("exact", 0.5, 0.0)
    study.add("exact", 0.25, 0.0)
    assert study.final_order("exact") is None
    study.add("once", 0.5, 1.0)
    assert study.final_order("once") is None


@pytest.mark.parametrize(
    "h, error", [(0.0, 1.0), (-0.5, 1.0), (float("nan"), 1.0), (0.5, -1.0), (0.5, None)]
)
def test_convergence_study_refuses_what_has_no_order(h, error):
    with pytest.raises((ValueError, TypeError)):
        ConvergenceStudy().add("q", h, error)


def test_convergence_study_refuses_a_size_twice():
    study = ConvergenceStudy()
    study.add("q", 0.5, 1.0)
    with pytest.raises(ValueError, match="twice"):
        study.add("q", 0.5, 2.0)


def square(x):
    return x * x


def test_parallel_map_keeps_the_order_of_the_items():
    items = list(range(20))
    assert parallel_map(square, items, jobs=2) == [x * x for x in items]
    assert parallel_map(square, items, jobs=1) == [x * x for x in items]


def test_scheduler_without_dask_fails_with_a_clear_message(monkeypatch):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # import now raises
    with pytest.raises(SchedulerUnavailable, match="dask.distributed"):
        parallel_map(square, [1, 2], scheduler="tcp://127.0.0.1:8786")
