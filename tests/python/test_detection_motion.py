"""detection.max_motion: a due detection runs only when some point has moved more than
max_motion x h since the last one. On the default case (quasi-static, to 10 s) the default
1e-3 h keeps the boundary through most steps: fewer than 1 in 8 steps detect, and the points
end within max_motion x h of the every-step run's (max_motion 0). (A restart between
detections continues with the same bytes: test_restart.) A collapsing block moves more than
that in nearly every step and detects in nearly every step."""

import json
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[2]


def default_case(max_motion=None) -> dict:
    case = json.loads((ROOT / "cases" / "bearing_quasi_static.json").read_text())
    if max_motion is not None:
        case.setdefault("detection", {"method": "improved"})["max_motion"] = max_motion
    return case


def test_the_default_case_keeps_its_boundary_while_it_hardly_moves(run_case, tmp_path):
    runs = {}
    for name, motion in (("every", 0.0), ("default", None)):
        result = run_case(default_case(motion), tmp_path / name)
        assert result.returncode == 0, result.stderr
        out = tmp_path / name / "out"
        runs[name] = (
            json.loads((out / "run.json").read_text())["summary"],
            pd.read_csv(out / "final_particles.csv").sort_values("id"),
        )
    every, default = runs["every"][0], runs["default"][0]
    assert every["detection"]["kept_calls"] == 0
    assert every["detection"]["calls"] == every["n_steps"] + 1
    assert default["detection"]["max_motion"] == 1e-3
    assert default["detection"]["calls"] < every["n_steps"] / 8
    h = default_case()["grid"]["cell_size"]
    a, b = runs["every"][1], runs["default"][1]
    assert np.abs(a[["x", "y"]].to_numpy() - b[["x", "y"]].to_numpy()).max() <= 1e-3 * h


def test_a_collapsing_block_detects_every_step(run_case, tmp_path):
    case = json.loads(
        (ROOT / "cases" / "thesis62_bearing_dynamic_zero_start.json").read_text()
    )
    case["time"]["end_time"] = 0.5
    case["output"] = {"interval": 0.5}
    result = run_case(case, tmp_path)
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "out" / "run.json").read_text())["summary"]
    assert summary["detection"]["kept_calls"] <= 0.05 * summary["n_steps"]
