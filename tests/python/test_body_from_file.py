"""Bodies from a particle file (issue "Fits the tools its users already use", item 3):
``bodies[].particles`` names a CSV file with columns x, y, volume, or an HDF5 file or group with
those datasets, and optionally the stresses (sxx, syy, sxy, szz) and the material index. The
points of a rectangle body written to such a file give the same run, every output file byte for
byte (run.json aside); a run's settled state read back with its stresses stays at rest, the same
from final_particles.csv and from particles.h5; bad files and the starts or solvers that cannot
take such a body are exit-2 errors that name the JSON path."""

import json
from pathlib import Path

import h5py
import numpy as np
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
    assert len(points) == 1200
    same_outputs(tmp_path / "rectangle" / "out", tmp_path / "points" / "out")


def same_outputs(a: Path, b: Path):
    """Every output file but run.json the same, byte for byte."""
    names = sorted(p.name for p in a.iterdir() if p.name != "run.json")
    assert names == sorted(p.name for p in b.iterdir() if p.name != "run.json")
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


def column_restart(folder: Path, particles: str, end_time: float = 1.0) -> dict:
    """cases/column.json's soil as a body from a particle file, zero start, gravity at once."""
    case = json.loads((ROOT / "cases" / "column.json").read_text())
    case["bodies"] = [{"name": "column", "material": "soil", "particles": particles}]
    case["gravity"] = {"g": 9.81}
    case["time"] = {"end_time": end_time, "cfl": 0.5}
    return case


def test_a_settled_state_read_back_with_its_stresses_stays_at_rest(run_case, tmp_path):
    """The column settled under its weight (settlement s = 0.0236 m), its final state read
    back as a body with the stresses: over 1 s of gravity every point moves less than 1 % of s
    and the stress changes by less than 1 % of the base stress; the same state without its
    stresses settles again by more than half of s. final_particles.csv and the last step group
    of particles.h5 (x, y from "position") give the same run, every file byte for byte.
    """
    settle = run_case(
        json.loads((ROOT / "cases" / "column.json").read_text()), tmp_path
    )
    assert settle.returncode == 0, settle.stderr
    settled = pd.read_csv(tmp_path / "out" / "final_particles.csv")
    settlement = -settled["uy"].min()
    assert settlement > 0.02
    last = json.loads((tmp_path / "out" / "run.json").read_text())["outputs"][-1]
    sources = {
        "csv": "../out/final_particles.csv",
        "h5": f"../out/particles.h5:/step_{last['step']:08d}",
    }
    for name, source in sources.items():
        result = run_case(column_restart(tmp_path, source), tmp_path / name)
        assert result.returncode == 0, result.stderr
    same_outputs(tmp_path / "csv" / "out", tmp_path / "h5" / "out")
    again = pd.read_csv(tmp_path / "csv" / "out" / "final_particles.csv")
    assert np.abs(again[["ux", "uy"]]).max().max() <= 0.01 * settlement
    base = np.abs(settled["syy"]).max()
    assert np.abs(again["syy"] - settled["syy"]).max() <= 0.01 * base
    assert list(again["material"]) == list(settled["material"])
    settled[["x", "y", "volume"]].to_csv(tmp_path / "bare.csv", index=False)
    bare = run_case(column_restart(tmp_path, "../bare.csv"), tmp_path / "bare")
    assert bare.returncode == 0, bare.stderr
    unstressed = pd.read_csv(tmp_path / "bare" / "out" / "final_particles.csv")
    assert -unstressed["uy"].min() >= 0.5 * settlement


def test_the_material_column_picks_each_points_material(run_case, tmp_path):
    """Two materials, two points given material 1 in the file and two material 0: the run's
    points carry those materials (the body's own material is 0)."""
    case = short_case()
    soft = dict(case["materials"][0], name="soft", unit_weight=18.0)
    case["materials"].append(soft)
    points = pd.DataFrame(
        {
            "x": [1.25, 1.75, 13.25, 13.75],
            "y": [1.25, 1.25, 1.25, 1.25],
            "volume": [0.25] * 4,
            "material": [1, 1, 0, 0],
        }
    )
    points.to_csv(tmp_path / "points.csv", index=False)
    result = run_case(file_body(case, "points.csv"), tmp_path)
    assert result.returncode == 0, result.stderr
    final = pd.read_csv(tmp_path / "out" / "final_particles.csv").sort_values("id")
    assert list(final["material"]) == [1, 1, 0, 0]


@pytest.mark.parametrize(
    "rows, key, words",
    [
        (None, "/bodies/0/particles", "cannot open"),
        ("x,y\n1,1\n", "/bodies/0/particles", 'missing column "volume"'),
        ("x,y,volume\n1,1,0\n", "/bodies/0/particles", "volume: must be > 0"),
        ("x,y,volume\n1,1,0.25\n99,1,0.25\n", "/bodies/0/particles", "point 2"),
        ("x,y,volume\n", "/bodies/0/particles", "no particle rows"),
        ("x,y,volume,material\n1,1,0.25,3\n", "/bodies/0/particles", "material 3"),
        ("x,y,volume,material\n1,1,0.25,0.5\n", "/bodies/0/particles", "whole number"),
        ("x,y,volume,sxx,syy\n1,1,0.25,0,0\n", "/bodies/0/particles", "sxx, syy, sxy"),
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
    (tmp_path / "stressed.csv").write_text(
        "x,y,volume,sxx,syy,sxy,szz\n1,1,0.25,0,-1,0,0\n"
    )
    stressed = file_body(
        dict(case, initial_stress={"method": "gravity"}), "stressed.csv"
    )
    result = run_case(stressed, tmp_path)
    assert result.returncode == 2 and "/bodies/0/particles" in result.stderr
    assert "initial_stress.method" in result.stderr


@pytest.mark.parametrize(
    "datasets, words",
    [
        ({"x": [1.0], "y": [1.0]}, 'no dataset "volume"'),
        ({"position": [[1.0, 1.0]], "volume": [0.25, 0.25]}, "expected 2 rows"),
        ({"x": [1.0], "y": [1.0], "volume": [0.25], "sxx": [0.0]}, "all of sxx"),
        ({"x": [1.0], "y": [np.nan], "volume": [0.25]}, "is not finite"),
    ],
)
def test_bad_hdf5_particle_files_are_input_errors(run_case, tmp_path, datasets, words):
    with h5py.File(tmp_path / "bad.h5", "w") as f:
        for name, values in datasets.items():
            f[name] = np.asarray(values)
    result = run_case(file_body(short_case(), "../bad.h5"), tmp_path / "case")
    assert result.returncode == 2
    assert (
        "/bodies/0/particles" in result.stderr and words in result.stderr
    ), result.stderr
