"""The softening benchmark's case and measure (studies/benchmarks/softening.py): the case is valid
for the C++ reader (through pfm_mpm), its top platen is the third condition (the reaction column
the study reads) and moves the shortening in the duration; the half-softening shortening is
exact on a piecewise-linear curve."""

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from studies import benchmarks
from studies.common.paths import core


@pytest.mark.parametrize("regularised", [False, True])
def test_the_compression_case_is_valid_and_its_platen_moves_the_shortening(regularised):
    pfm_mpm = core()
    raw = benchmarks.softening_case(32, regularised)
    case = pfm_mpm.parse_case(raw, "softening.json")
    platen = case["boundary_conditions"][2]
    assert platen["where"] == "top" and platen["fix"] == "y"
    s = benchmarks.SOFTENING
    ramp = platen["time_function"]["ramp_time"]
    # The smooth ramp's factor integrates to ramp / 2: the platen moves v (T - t_r / 2).
    moved = -platen["velocity"][1] * (case["time"]["end_time"] - ramp / 2)
    assert moved == pytest.approx(s["shortening"], rel=1e-14)
    lengths = {m["softening_length"] for m in case["materials"]}
    assert lengths == ({s["softening_length"]} if regularised else {None})
    assert case["grid"]["cell_size"] == pytest.approx(1.0 / 32, rel=1e-15)


def test_half_softening_is_where_the_force_crosses_the_middle():
    """Peak 40 at 0.01 m, then linear to 20 at 0.03 m: halfway to a residual of 20 (30 kN/m)
    at 0.02 m, to rounding; a curve that never gets there gives NaN."""
    d = np.linspace(0.0, 0.04, 81)
    force = np.interp(d, [0.0, 0.01, 0.03, 0.04], [0.0, 40.0, 20.0, 20.0])
    curve = pd.DataFrame({"shortening": d, "force": force})
    assert benchmarks.half_softening_shortening(curve, 20.0) == pytest.approx(
        0.02, abs=1e-15
    )
    assert np.isnan(benchmarks.half_softening_shortening(curve, -10.0))


def test_the_dolfinx_model_drives_the_same_case_elastically_exactly():
    """The dolfinx jobs run softening_case as it is: on its coarsest mesh the model holds one
    node in x (the base centre), the top platen moves v times the smooth ramp's integral, and
    while the specimen is elastic (the first 0.12 s: 0.0027 m, 12 kN/m, below the flaw's
    2 c W = 36 kN/m) the platen's force is the plane-strain uniaxial E / (1 - nu^2) W d / H
    (1e-9 relative; the flaw has the same stiffness). dolfinx_softening_curve reads it.
    """
    pytest.importorskip("dolfinx")
    from fem_reference.dolfinx_model import case_from_dict, run_driven, write_table_csv

    s = benchmarks.SOFTENING
    cells = s["dolfinx_cells_across"][0]
    jobs = benchmarks.softening_jobs()
    assert jobs[f"softening/dolfinx/regularised/cells{cells}"][1] == "dolfinx"
    case = case_from_dict(benchmarks.softening_case(cells, True))
    result = run_driven(case, steps=4, end_time=0.12, degree=2)
    assert result.converged_to_end
    assert [len(dofs) for _, dofs in result.model.support_dofs[1]] == [1]
    with tempfile.TemporaryDirectory() as tmp:
        write_table_csv(result.columns, result.series, Path(tmp) / "timeseries.csv")
        curve = benchmarks.dolfinx_softening_curve(Path(tmp))
    e_prime = s["youngs_modulus"] / (1 - s["poisson_ratio"] ** 2)
    exact = e_prime * s["width"] / s["height"] * curve["shortening"]
    assert curve["shortening"].iloc[-1] == pytest.approx(
        benchmarks.softening_speed()
        * (0.12 - 0.5 * s["ramp_fraction"] * s["duration"]),
        rel=1e-12,
    )
    error = np.abs(curve["force"] - exact)[1:] / exact[1:]
    print(f"\ndolfinx softening case, elastic: worst force error {error.max():.1e}")
    assert error.max() <= 1e-9
