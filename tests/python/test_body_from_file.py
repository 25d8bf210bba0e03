"""Bodies from a particle file (issue "Fits the tools its users already use", item 3):
``bodies[].particles`` names a CSV file with columns x, y, volume. The points of a rectangle
body written to such a file give the same run, every output file byte for byte (run.json
aside); bad files and the starts or solvers that cannot take such a body are exit-2 errors
that name the JSON path."""

import json
from pathlib import Path

import h5py
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
CASE = ROOT / "cases" / "thesis62_bearing_dynamic_zero_start.json"


def short_case() -> dict:
    case = json.loads(CASE.read_text())
    case["time"]["end_time"] = 0.25
    case["output"] = {"interval": 0.125}
    return case


def file_body(case: dict, name: str) -> dict:
    body = {
        "name": "block",
        "material": case["bodies"][0]["material"],
        "particles": name,
    }
    return dict(case, bodies=[body])


def test_the_points_of_a_rectangle_from_a_file_give_the_same_run(run_case, tmp_path):
    case = short_case()
    first = run_case(case, tmp_path / "rectangle")
    assert first.returncode == 0, first.stderr
    with h5py.File(tmp_path / "rectangle" / "out" / "particles.h5", "r") as f:
        start = f["step_00000000"]
        points = pd.DataFrame(
            {
                "x": start["position"][:, 0],
                "y": start["position"][:, 1],
                "volume": start["volume"][:],
            }
        )
    (tmp_path / "points").mkdir()
    points.to_csv(tmp_path / "points" / "block.csv", index=False, float_format="%.17g")
    second = run_case(file_body(case, "block.csv"), tmp_path / "points")
    assert second.returncode == 0, second.stderr
    a, b = tmp_path / "rectangle" / "out", tmp_path / "points" / "out"
    names = sorted(p.name for p in a.iterdir() if p.name != "run.json")
    assert names == sorted(p.name for p in b.iterdir() if p.name != "run.json")
    assert len(points) == 1200
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.mark.parametrize(
    "rows, key, words",
    [
        (None, "/bodies/0/particles", "cannot open"),
        ("x,y\n1,1\n", "/bodies/0/particles", 'missing column "volume"'),
        ("x,y,volume\n1,1,0\n", "/bodies/0/particles", "volume: must be > 0"),
        ("x,y,volume\n1,1,0.25\n99,1,0.25\n", "/bodies/0/particles", "point 2"),
        ("x,y,volume\n", "/bodies/0/particles", "no particle rows"),
    ],
)
def test_bad_particle_files_are_input_errors(run_case, tmp_path, rows, key, words):
    if rows is not None:
        (tmp_path / "bad.csv").write_text(rows)
    result = run_case(file_body(short_case(), "bad.csv"), tmp_path)
    assert result.returncode == 2
    assert key in result.stderr and words in result.stderr, result.stderr
    assert not (tmp_path / "out").exists()


def test_a_particle_file_that_is_no_regular_file_is_refused(run_case, tmp_path):
    for name in ("/dev/zero", str(tmp_path)):
        result = run_case(file_body(short_case(), name), tmp_path / "case")
        assert result.returncode == 2, name
        assert "is not a regular file" in result.stderr, result.stderr


def test_what_a_body_from_a_file_cannot_take_is_an_input_error(run_case, tmp_path):
    (tmp_path / "block.csv").write_text("x,y,volume\n1,1,0.25\n1.5,1,0.25\n")
    case = file_body(short_case(), "block.csv")
    both = json.loads(json.dumps(case))
    both["bodies"][0]["rectangle"] = [[0, 0], [1, 1]]
    result = run_case(both, tmp_path)
    assert result.returncode == 2 and "/bodies/0/rectangle" in result.stderr
    k0 = dict(case, initial_stress={"method": "k0"})
    result = run_case(k0, tmp_path)
    assert result.returncode == 2 and "/initial_stress/method" in result.stderr
    result = run_case(case, tmp_path, "--solver", "ulfem")
    assert result.returncode == 2 and "/bodies/0/particles" in result.stderr
