"""The command line, the outcome file and the solver-output readers."""

import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from studies.common.outcome import Headline, Metric, StudyOutcome
from studies.common.outputs import file_at_time, read_index, read_particles
from studies.common.paths import PrerequisiteMissing
from studies.common.runner import RunFailed
from studies.common.study import missing_reason

REPO = Path(__file__).resolve().parents[2]


def run_cli(*args, env):
    return subprocess.run(
        [sys.executable, "-m", "studies", *args],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_cli_records_not_run_when_the_binary_is_missing(isolated):
    env = dict(os.environ)
    done = run_cli("quadrature", "--quick", env=env)
    assert done.returncode == 0, done.stderr
    study = json.loads((isolated["results"] / "quadrature" / "study.json").read_text())
    assert study["status"] == "not_run" and study["quick"] is True
    assert (
        study["reason"].startswith("needs ") and "pfm-quadrature-map" in study["reason"]
    )
    assert run_cli("nonsense", env=env).returncode == 2


def test_cli_report_builds_from_not_run_studies(isolated, tmp_path):
    env = dict(os.environ)
    run_cli("quadrature", "--quick", env=env)
    done = run_cli("report", "--history", str(tmp_path / "h.jsonl"), env=env)
    assert done.returncode == 0, done.stderr  # nothing ran, so nothing is past a limit
    html = (isolated["results"] / "report" / "index.html").read_text()
    assert "not run" in html and (tmp_path / "h.jsonl").is_file()


def test_outcome_round_trip_replaces_non_finite_values(tmp_path):
    outcome = StudyOutcome(
        study="x",
        metrics=[Metric("x.a", float("nan"), "m")],
        headline=[Headline("q", "*", 1.5, "s")],
    )
    outcome.write(tmp_path)
    back = StudyOutcome.read(tmp_path / "study.json")
    assert back.metrics[0].value is None and "non-finite" in back.metrics[0].note
    assert back.headline[0].value == 1.5
    with pytest.raises(ValueError):
        StudyOutcome(study="x", status="maybe")


def test_rejected_case_keys_count_as_missing_prerequisites():
    stderr = (
        "pfm-mpm: error: /tmp/c/case.json: /solver/formulation: unknown key "
        "(allowed here: scheme, shape_function, damping)\n"
    )
    assert (
        missing_reason(RunFailed("x", 2, stderr))
        == "pfm-mpm to accept: /solver/formulation: unknown key (allowed here: scheme, "
        "shape_function, damping)"
    )
    stderr = "pfm-mpm: error: c.json: /detection/method: must be one of pfm, improved\n"
    assert (
        missing_reason(RunFailed("x", 2, stderr))
        == "pfm-mpm to accept: /detection/method: must be one of pfm, improved"
    )
    assert missing_reason(RunFailed("x", 1, stderr)) is None  # a crash, not an input
    assert missing_reason(RunFailed("x", 2, "/time/dt: above the CFL limit")) is None
    assert (
        missing_reason(
            PrerequisiteMissing("cases/thesis55_slope_dynamic_zero_start.json")
        )
        == "cases/thesis55_slope_dynamic_zero_start.json"
    )


def test_particle_outputs_are_read_from_hdf5(tmp_path):
    """The step groups of particles.h5 give the steps and times (their attributes) and the
    particle tables."""
    n = 4
    with h5py.File(tmp_path / "particles.h5", "w") as h5:
        for step, shift, time in ((0, 0.0, 0.0), (14, 0.5, 0.12983)):
            group = h5.create_group(f"step_{step:08d}")
            group.attrs["step"], group.attrs["time"] = float(step), time
            position = np.c_[np.arange(n), np.ones(n) + shift, np.zeros(n)]
            group["position"] = position
            group["displacement"] = np.c_[np.zeros(n), np.full(n, shift), np.zeros(n)]
            group["syy"] = -np.arange(n, dtype=float)
    index = read_index(tmp_path, "particles")
    assert list(index["step"]) == [0, 14] and list(index["time"]) == [0.0, 0.12983]
    location = file_at_time(index, 0.125, tolerance=0.01)
    frame = read_particles(location)
    assert list(frame["y"]) == [1.5] * n and list(frame["uy"]) == [0.5] * n
    assert list(frame["syy"]) == [0.0, -1.0, -2.0, -3.0]
    assert file_at_time(index, 0.5, tolerance=0.01) is None
    (tmp_path / "run.json").write_text(json.dumps({"status": "completed"}))
    with pytest.raises(PrerequisiteMissing, match="boundary_<step>.csv"):
        read_index(tmp_path, "boundary")
    # Boundary files without run.json "outputs": the time is the particle output's.
    for step in (0, 14):
        (tmp_path / f"boundary_{step:08d}.csv").write_text(
            "loop,x,y\n0,0,0\n0,1,0\n0,0,1\n"
        )
    boundaries = read_index(tmp_path, "boundary")
    assert list(boundaries["step"]) == [0, 14] and list(boundaries["time"]) == [
        0.0,
        0.12983,
    ]
    assert boundaries["file"].iloc[1] == str(tmp_path / "boundary_00000014.csv")
    # With run.json "outputs" (the solver's own list), that list is used.
    (tmp_path / "run.json").write_text(
        json.dumps(
            {
                "status": "completed",
                "outputs": [
                    {"step": 14, "time": 0.13, "boundary": "boundary_00000014.csv"}
                ],
            }
        )
    )
    boundaries = read_index(tmp_path, "boundary")
    assert list(boundaries["step"]) == [14] and list(boundaries["time"]) == [0.13]
