"""The Python module pfm_mpm on the C++ core (python/README.md): each function gives what the
core gives through the command-line tool, to the bit where both write the same numbers, and
the facts the core guarantees (exact resultants, interpolation, the detector's accuracy on
faces) hold through the bindings."""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("PFM_BUILD_DIR", ROOT / "build"))
sys.path.insert(0, str(BUILD / "python"))

pfm_mpm = pytest.importorskip("pfm_mpm", reason="build the module first: make build")

GRID = {"origin": [-2.0, -2.0], "cell_size": 1.0, "n_cells": [8, 8]}


def square_cloud(n=8, spacing=0.5):
    """n x n points of a regular square lattice filling [0, n spacing]^2, their volumes."""
    centres = (np.arange(n) + 0.5) * spacing
    x, y = np.meshgrid(centres, centres, indexing="ij")
    return np.c_[x.ravel(), y.ravel()], np.full(n * n, spacing**2)


def test_version_is_the_command_line_tools(pfm_binary):
    cli = subprocess.run(
        [pfm_binary, "--version"], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert pfm_mpm.version() == cli


@pytest.mark.parametrize("path", sorted((ROOT / "cases").glob("*.json")), ids=str)
def test_every_shipped_case_reads_resolved(path):
    """The resolved case holds the file's values and the documented defaults."""
    case = pfm_mpm.read_case(path)
    raw = json.loads(path.read_text())
    assert case["grid"]["cell_size"] == raw["grid"]["cell_size"]
    assert case["grid"]["n_cells"] == raw["grid"]["n_cells"]
    assert [m["name"] for m in case["materials"]] == [
        m["name"] for m in raw["materials"]
    ]
    assert case["time"]["end_time"] == raw["time"]["end_time"]
    assert case["time"]["cfl"] == raw["time"].get("cfl", 0.5)
    assert case["solver"]["shape_function"] == raw.get("solver", {}).get(
        "shape_function", "quadratic_bspline"
    )
    for body in case["bodies"]:
        if body["source"] == "particles":  # points from a file: no polygon
            continue
        polygon = np.array(body["polygon"])
        x, y = polygon[:, 0], polygon[:, 1]
        area = 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)
        assert area > 0.0  # counter-clockwise


def test_a_bad_case_raises_the_command_line_tools_message(pfm_binary, tmp_path):
    """One schema: the module's InputError is the message `pfm-mpm run` exits 2 with."""
    raw = json.loads((ROOT / "cases" / "column.json").read_text())
    raw["materials"][0]["poisson_ratio"] = 0.5
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(raw))
    with pytest.raises(pfm_mpm.InputError) as error:
        pfm_mpm.read_case(path)
    assert isinstance(error.value, ValueError)
    assert (
        str(error.value) == f"{path}: /materials/0/poisson_ratio: must be in [0, 0.5)"
    )
    run = subprocess.run(
        [pfm_binary, "run", path, "--out", tmp_path / "out"],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 2 and str(error.value) in run.stderr
    raw["materials"][0]["poisson_ratio"] = 0.15
    del raw["time"]
    with pytest.raises(pfm_mpm.InputError, match=r'^doc\.json: /: missing key "time"'):
        pfm_mpm.parse_case(raw, "doc.json")


def test_detection_on_arrays_is_the_detect_commands(pfm_binary, tmp_path):
    """The improved detector on an 8 x 8 lattice: one closed loop, within 0.005 cell of the
    square's faces away from the corners (its accuracy on faces; corners are rounded), and the same points to the bit as `pfm-mpm
    detect` writes (17 significant digits)."""
    position, volume = square_cloud()
    loops = pfm_mpm.detect(position, volume, 0.5, GRID)
    assert len(loops) == 1 and loops[0][1] is True
    points = loops[0][0]
    distance = np.minimum.reduce(
        [
            np.abs(points[:, 0]),
            np.abs(points[:, 0] - 4),
            np.abs(points[:, 1]),
            np.abs(points[:, 1] - 4),
        ]
    )
    face = (np.abs(points[:, 0] - 2) <= 1) | (np.abs(points[:, 1] - 2) <= 1)
    assert face.sum() >= 16
    assert distance[face].max() <= 0.005 * GRID["cell_size"]

    particles = tmp_path / "particles.csv"
    pd.DataFrame({"x": position[:, 0], "y": position[:, 1], "volume": volume}).to_csv(
        particles, index=False, float_format="%.17g"
    )
    config = tmp_path / "config.json"
    config.write_text(json.dumps({"initial_spacing": 0.5, "grid": GRID}))
    subprocess.run(
        [pfm_binary, "detect", particles, "--config", config, "--out", tmp_path / "d"],
        check=True,
        capture_output=True,
    )
    cli = pd.read_csv(tmp_path / "d" / "boundary.csv", float_precision="round_trip")
    assert np.array_equal(cli[["x", "y"]].to_numpy(), points)
    # The grid is read as pfm-mpm detect reads its "grid" block, with its limit of 5e7 nodes.
    huge = dict(GRID, n_cells=[10000, 10000])
    with pytest.raises(pfm_mpm.InputError, match="more than 5e7 grid nodes"):
        pfm_mpm.detect(position, volume, 0.5, huge)


def test_composite_bezier_interpolates_its_points():
    """Every kind passes through the points (segment ends); linear is the polygon itself; the
    cubic through collinear points is straight."""
    angles = np.linspace(0.0, 2 * np.pi, 12, endpoint=False)
    circle = np.c_[np.cos(angles), np.sin(angles)]
    for kind in ("linear", "quadratic", "cubic", "catmull_rom"):
        curve = pfm_mpm.composite_bezier(circle, True, kind)
        assert len(curve.degree) == len(circle)
        ends = curve.control[np.arange(len(circle)), curve.degree]
        assert np.array_equal(
            curve.control[:, 0], circle
        )  # each segment starts at a point
        assert np.array_equal(ends, np.roll(circle, -1, axis=0))  # and ends at the next
    linear = pfm_mpm.composite_bezier(circle, True, "linear")
    assert np.array_equal(linear.control[:, 1], np.roll(circle, -1, axis=0))
    line = np.c_[np.linspace(0, 3, 4), 2 * np.linspace(0, 3, 4)]
    cubic = pfm_mpm.composite_bezier(line, False, "cubic")
    assert len(cubic.degree) == 3
    controls = cubic.control[:, :4].reshape(-1, 2)
    assert np.abs(controls[:, 1] - 2 * controls[:, 0]).max() <= 1e-14
    with pytest.raises(pfm_mpm.InputError, match="kind"):
        pfm_mpm.composite_bezier(line, False, "spline")


@pytest.mark.parametrize("degree", [1, 2, 3])
def test_nodal_forces_of_a_vertical_pressure_sum_to_its_resultant(degree):
    """q = 25 kPa on the top of the detected square between x = 1 and 3.5 m: the nodal forces
    sum to (0, -q 2.5) kN/m to rounding with every grid function degree."""
    position, volume = square_cloud()
    points, closed = pfm_mpm.detect(position, volume, 0.5, GRID)[0]
    curve = pfm_mpm.composite_bezier(points, closed, "cubic")
    load = {
        "apply_on": "detected_boundary",
        "type": "vertical_pressure",
        "pressure": 25.0,
        "x_range": [1.0, 3.5],
    }
    forces, totals = pfm_mpm.nodal_forces(GRID, [curve], load, shape_degree=degree)
    assert forces.shape == (81, 2)
    assert forces.sum(axis=0) == pytest.approx((0.0, -62.5), abs=1e-12)
    assert totals["exact_force"] == pytest.approx((0.0, -62.5), abs=1e-12)
    half, _ = pfm_mpm.nodal_forces(GRID, [curve], load, 0.5, shape_degree=degree)
    assert np.abs(half - 0.5 * forces).max() <= 1e-14
    with pytest.raises(pfm_mpm.InputError, match="<load>: /pressure: must be >= 0"):
        pfm_mpm.nodal_forces(GRID, [curve], dict(load, pressure=-1.0))


def test_output_folder_reads_what_the_run_wrote(run_case, tmp_path):
    """The column case: every particle output step read through the module; the last equals
    final_particles.csv to rounding (17 digits), the steps and times equal run.json's.
    """
    raw = json.loads((ROOT / "cases" / "column.json").read_text())
    raw["time"]["end_time"] = 1.0
    assert run_case(raw, tmp_path).returncode == 0
    out = pfm_mpm.OutputFolder(tmp_path / "out")
    assert out.run["status"] == "completed"
    steps = out.particle_steps()
    listed = out.run["outputs"]
    assert list(steps["step"]) == [o["step"] for o in listed]
    assert np.array_equal(steps["time"], [o["time"] for o in listed])
    last = out.particles(steps["step"].iloc[-1]).sort_values("id", ignore_index=True)
    final = pd.read_csv(tmp_path / "out" / "final_particles.csv")
    final = final.sort_values("id", ignore_index=True)
    for column in ("x", "y", "ux", "uy", "sxx", "syy", "volume"):
        scale = max(1.0, float(np.abs(final[column]).max()))
        assert np.abs(last[column] - final[column]).max() <= 1e-15 * scale, column
    assert last["id"].dtype.kind == "i"
    with pytest.raises(FileNotFoundError, match="boundary.h5"):
        out.boundary_steps()


def test_output_folder_reads_the_detected_boundary(run_case, tmp_path):
    """The default case for 0.3 s: each boundary output's loops equal boundary_<step>.csv to
    rounding, one closed loop each."""
    raw = json.loads((ROOT / "cases" / "bearing_quasi_static.json").read_text())
    raw["time"]["end_time"] = 0.3
    raw["output"] = {"interval": 0.1}
    assert run_case(raw, tmp_path).returncode == 0
    out = pfm_mpm.OutputFolder(tmp_path / "out")
    steps = out.boundary_steps()
    assert len(steps) >= 3
    for step in steps["step"]:
        loops = out.boundary(step)
        csv = pd.read_csv(tmp_path / "out" / f"boundary_{step:08d}.csv")
        assert [closed for _, closed in loops] == [True]
        assert np.abs(loops[0][0] - csv[["x", "y"]].to_numpy()).max() <= 1e-12
