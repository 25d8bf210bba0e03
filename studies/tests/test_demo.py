"""`make run` (studies.demo) end to end, with the built pfm-mpm and the dolfinx model, on the
default case cases/bearing_quasi_static.json (about 40 s): a strip load of 100 kPa ramped on
the detected boundary of a clay layer, K0 start, damped to rest."""

import json
import os
from pathlib import Path

import pandas as pd
import pytest

from studies import demo
from studies.common.paths import repo_root


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    build = Path(os.environ.get("PFM_BUILD_DIR", repo_root() / "build"))
    if not (build / "bin" / "pfm-mpm").is_file():
        pytest.fail(f"{build}/bin/pfm-mpm not built: run `make build` first")
    out = tmp_path_factory.mktemp("demo")
    assert demo.main(["--out", str(out)]) == 0
    return out, json.loads((out / "verdict.json").read_text())


def test_the_settlement_is_dolfinx_static_answer_within_1_percent_mpm_and_2_percent_ulfem(
    run,
):
    _, verdict = run
    reference = verdict["reference"]["settlement_m"]
    assert 0.03 < reference < 0.06  # E = 10 MPa, q = 100 kPa: a few centimetres
    assert abs(verdict["mpm"]["settlement_m"] / reference - 1.0) <= 0.01
    assert abs(verdict["ulfem"]["settlement_m"] / reference - 1.0) <= 0.02


def test_both_explicit_runs_end_at_rest_with_a_closed_energy_ledger(run):
    _, verdict = run
    for solver in ("mpm", "ulfem"):
        assert verdict[solver]["final_time_s"] == pytest.approx(10.0, abs=0.01)
        assert verdict[solver]["kinetic_over_external_work"] <= 1e-4
        assert verdict[solver]["energy_error_relative"] <= 1e-9


def test_no_mpm_point_jitters_in_place_over_any_output_interval(run):
    _, verdict = run
    assert verdict["mpm"]["jitter_largest_count"] == 0


def test_the_detected_boundary_stays_within_a_hundredth_of_a_cell_of_the_fem_boundary(
    run,
):
    out, verdict = run
    table = pd.read_csv(out / "history.csv")
    assert len(table) == 41  # t = 0, 0.25, ..., 10 s
    assert table["distance_max_m"].max() <= 0.01 * 0.5
    assert verdict["passed"]


def test_the_page_says_what_is_compared_gives_the_verdict_and_shows_the_figures(run):
    out, _ = run
    report = (out / "report.md").read_text()
    assert "## What is compared, and the verdict" in report
    assert "**Verdict: the detected-boundary load gives the static answer" in report
    for name in (
        "load_settlement.png",
        "plastic_zone.png",
        "boundary_distance.png",
        "energy.png",
        "index.html",
        "provenance.json",
    ):
        assert (out / name).is_file(), name
        assert name in report or name in ("index.html", "provenance.json")
