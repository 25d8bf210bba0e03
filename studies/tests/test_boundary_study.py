"""The boundary study end to end against a stand-in pfm-mpm that writes the assumed output
layout with boundaries at known distances from the reference (tests/fake_mpm.py)."""

import shutil
import stat
from pathlib import Path

import pandas as pd
import pytest

from studies import boundary
from studies.common.study import StudyOptions, execute
from studies.tests import fake_mpm as synthetic


@pytest.fixture
def fake_mpm(isolated):
    tool = isolated["bin"] / "pfm-mpm"
    shutil.copy(Path(synthetic.__file__), tool)
    tool.chmod(tool.stat().st_mode | stat.S_IXUSR)
    return isolated


def test_boundary_study_measures_the_known_offsets(fake_mpm):
    outcome = execute(boundary, StudyOptions(quick=True, jobs=1))
    assert outcome.status == "ok", outcome.reason
    folder = fake_mpm["results"] / "boundary"
    errors = pd.read_csv(folder / "boundary_errors.csv")
    overall = errors[errors["region"] == "all"]
    # quick: 2 cases x 3 detectors x 2 measures x 2 times
    assert len(overall) == 24
    for measure, shift in (
        ("total", synthetic.MPM_SHIFT),
        ("detector_only", synthetic.DETECT_SHIFT),
    ):
        rows = overall[overall["measure"] == measure]
        # A vertical translation: the horizontal edges are exactly `shift` apart.
        assert (rows["max_m"] - shift).abs().max() <= 1e-12
        assert (rows["max_h"] - shift / 0.5).abs().max() <= 1e-12
    headline = {(h.quantity, h.detector): h.value for h in outcome.headline}
    assert (
        abs(
            headline[("boundary.slope_k0.total.t0.625.max", "pfm_improved")]
            - synthetic.MPM_SHIFT
        )
        <= 1e-12
    )
    assert headline[
        ("traction.block_k0.total_force_rel_error", "pfm_thesis")
    ] == pytest.approx(0.02, rel=1e-12)
    assert headline[
        ("traction.block_k0.lost_force_rel", "pfm_thesis")
    ] == pytest.approx(0.03, rel=1e-12)
    # Per-region rows exist for the slope's regions, and the overlay figures were drawn.
    slope_regions = set(errors[errors["case"] == "slope_k0"]["region"])
    assert {"top", "face", "crest", "toe", "bottom"} <= slope_regions
    assert (folder / "overlay_slope_k0_t0.625.png").is_file()
    metrics = {m.name for m in outcome.metrics}
    assert metrics <= set(boundary.EXPECTED_METRICS)
    assert "boundary.slope_k0.total.t0.pfm_improved.max_h" in metrics
