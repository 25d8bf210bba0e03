"""The library baseline on static bodies at h = 0.5 m with 2 x 2 points per cell (equal spacing
and Gauss points), its output contract and its input errors."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from studies.detectors import skimage_detector as sd

H = 0.5
SPACING = H / 2
GRID = sd.Grid((0.0, 0.0), H, (24, 20))
REPO = Path(__file__).resolve().parents[3]


def lattice(lo, hi, inside, gauss=False):
    """2 x 2 points per cell of the lattice covering [lo, hi], kept when inside(x)."""
    offset = H / (2 * math.sqrt(3)) if gauss else H / 4
    points = []
    for j in range(int(math.floor(lo[1] / H)), int(math.ceil(hi[1] / H))):
        for i in range(int(math.floor(lo[0] / H)), int(math.ceil(hi[0] / H))):
            centre = ((i + 0.5) * H, (j + 0.5) * H)
            for dy in (-offset, offset):
                for dx in (-offset, offset):
                    x = (centre[0] + dx, centre[1] + dy)
                    if inside(x):
                        points.append(x)
    points = np.array(points)
    return sd.Particles(points, np.full(len(points), H * H / 4))


def signed_area(points):
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def check_contract(contours):
    """Closed loops do not repeat their first point and start at their lowest-then-leftmost
    point; contours are sorted by that point."""
    keys = []
    for points, closed in contours:
        order = np.lexsort((points[:, 0], points[:, 1]))
        lowest = points[order[0]]
        if closed:
            assert not np.array_equal(points[0], points[-1])
            assert np.array_equal(points[0], lowest)
        keys.append((lowest[1], lowest[0]))
    assert keys == sorted(keys)


@pytest.mark.parametrize("gauss", [False, True])
def test_rectangle_faces_within_one_hundredth_of_a_cell(gauss):
    # Measured: 0.0004 h (equal spacing: the squares tile the body) and 0.003 h (Gauss
    # points: the overlap/gap stripes one cell apart, damped to 0.7 % by the Gaussian of
    # half a cell).
    particles = lattice((2, 2), (8, 6), lambda x: True, gauss)
    result = sd.detect(particles, GRID, SPACING, sd.Settings())
    contours = result["contours"]
    assert len(contours) == 1
    points, closed = contours[0]
    assert closed
    check_contract(contours)
    assert signed_area(points) > 0  # counter-clockwise: material on the left
    x, y = points[:, 0], points[:, 1]
    distance = np.minimum.reduce([abs(x - 2), abs(x - 8), abs(y - 2), abs(y - 6)])
    away_from_corners = (np.minimum(abs(x - 2), abs(x - 8)) > 0.75) | (
        np.minimum(abs(y - 2), abs(y - 6)) > 0.75
    )
    print(
        f"rectangle gauss={gauss}: faces max {distance[away_from_corners].max() / H:.4f} h"
    )
    assert distance[away_from_corners].max() <= 0.01 * H


@pytest.mark.parametrize("gauss", [False, True])
def test_disk_bias_is_the_smoothing_curvature_bias(gauss):
    # The 0.5 level of a disk blurred by a Gaussian of standard deviation sigma lies about
    # sigma^2 / (2 R) inside the disk (0.031 h here); bound: that + 0.02 h, largest error 0.1 h.
    # Measured: bias -0.031 h / -0.034 h, max 0.070 h / 0.067 h.
    centre = np.array([6.0, 5.0])
    particles = lattice(
        (3, 2), (9, 8), lambda x: math.hypot(x[0] - 6, x[1] - 5) < 2, gauss
    )
    radius = math.sqrt(particles.volume.sum() / math.pi)
    settings = sd.Settings()
    contours = sd.detect(particles, GRID, SPACING, settings)["contours"]
    assert len(contours) == 1 and contours[0][1]
    check_contract(contours)
    error = (np.hypot(*(contours[0][0] - centre).T) - radius) / H
    sigma = settings.sigma * SPACING
    print(
        f"disk gauss={gauss}: bias {error.mean():+.4f} h, max {abs(error).max():.4f} h"
    )
    assert abs(error.mean()) <= sigma**2 / (2 * radius) / H + 0.02
    assert abs(error).max() <= 0.1


def test_ring_hole_runs_clockwise():
    particles = lattice(
        (3, 2),
        (9, 8),
        lambda x: 1.0 < math.hypot(x[0] - 6, x[1] - 5) < 2.0,
        gauss=False,
    )
    contours = sd.detect(particles, GRID, SPACING, sd.Settings())["contours"]
    assert len(contours) == 2
    check_contract(contours)
    assert signed_area(contours[0][0]) > 0  # the outer loop starts lower
    assert signed_area(contours[1][0]) < 0


def test_body_on_the_grid_edge_gives_one_open_chain_ending_on_it():
    # The rectangle [0, 6] x [0, 4] rests on the grid's bottom-left corner: no boundary along
    # the two grid edges, one chain from the bottom edge (x = 6) over the top to the left edge.
    particles = lattice((0, 0), (6, 4), lambda x: True)
    contours = sd.detect(particles, GRID, SPACING, sd.Settings())["contours"]
    assert len(contours) == 1
    points, closed = contours[0]
    assert not closed
    assert points[0][1] == 0.0 and points[0][0] == pytest.approx(6.0, abs=1e-9)
    assert points[-1][0] == 0.0 and points[-1][1] == pytest.approx(4.0, abs=1e-9)
    inside = (points[:, 0] < 5.5) & (points[:, 1] < 3.5)
    assert not inside.any()


def write_block(folder: Path):
    rows = ["# a 3 m x 2 m block", "id,x,y,volume"]
    for j in range(8):
        for i in range(12):
            rows.append(f"{12 * j + i},{2.125 + 0.25 * i},{2.125 + 0.25 * j},0.0625")
    (folder / "p.csv").write_text("\n".join(rows) + "\n")


def test_command_line_writes_boundary_and_summary(tmp_path):
    write_block(tmp_path)
    config = {
        "method": "skimage",
        "initial_spacing": 0.25,
        "grid": {"origin": [0, 0], "cell_size": 0.5, "n_cells": [14, 12]},
    }
    (tmp_path / "c.json").write_text(json.dumps(config))
    completed = subprocess.run(
        [
            sys.executable,
            "-m",
            "studies.detectors.skimage_detector",
            str(tmp_path / "p.csv"),
            "--config",
            str(tmp_path / "c.json"),
            "--out",
            str(tmp_path / "out"),
        ],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=False,
    )
    assert completed.returncode == 0, completed.stderr
    lines = (tmp_path / "out" / "boundary.csv").read_text().splitlines()
    assert lines[0] == "loop,x,y"
    points = np.array([[float(v) for v in line.split(",")[1:]] for line in lines[1:]])
    assert {line.split(",")[0] for line in lines[1:]} == {"0"}
    x, y = points[:, 0], points[:, 1]
    distance = np.minimum.reduce([abs(x - 2), abs(x - 5), abs(y - 2), abs(y - 4)])
    away_from_corners = (np.minimum(abs(x - 2), abs(x - 5)) > 0.75) | (
        np.minimum(abs(y - 2), abs(y - 4)) > 0.75
    )
    assert distance[away_from_corners].max() <= 0.01 * H
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["method"] == "skimage"
    assert summary["loops"] == 1 and summary["closed"] == 1 and summary["open"] == 0
    assert summary["points_per_loop"] == [len(lines) - 1]
    assert not list((tmp_path / "out").glob(".*.tmp"))


@pytest.mark.parametrize(
    "csv, config, expected",
    [
        ("", {}, "p.csv: file is empty"),
        ("x,y\n1,2\n", {}, 'p.csv:1: missing column "volume"'),
        ("x,y,volume\n1,2,0.1\n1,nan,0.1\n", {}, "p.csv:3: column y: must be finite"),
        ("x,y,volume\n1,2,abc\n", {}, 'p.csv:2: column volume: "abc" is not a number'),
        ("x,y,volume\n1,2\n", {}, "p.csv:2: 2 fields, the header has 3"),
        ("x,y,volume\n1,2,-0.1\n", {}, "p.csv:2: column volume: must be > 0"),
        (
            "x,y,volume\n1,2,0.1\n",
            {"skimage": {"sgima": 1}},
            "c.json: /skimage/sgima: unknown key",
        ),
        ("x,y,volume\n1,2,0.1\n", {"method": "improved"}, "c.json: /method"),
        (
            "x,y,volume\n1,2,0.1\n",
            {"grid": {"origin": [0, 0], "cell_size": -1, "n_cells": [4, 4]}},
            "c.json: /grid/cell_size: must be > 0",
        ),
        ("x,y,volume\n1,2,0.1\n", {"typo": 1}, "c.json: /typo: unknown key"),
    ],
)
def test_bad_input_exits_2_names_the_place_and_writes_nothing(
    tmp_path, capsys, csv, config, expected
):
    (tmp_path / "p.csv").write_text(csv)
    (tmp_path / "c.json").write_text(json.dumps(config))
    code = sd.main(
        [
            str(tmp_path / "p.csv"),
            "--config",
            str(tmp_path / "c.json"),
            "--out",
            str(tmp_path / "out"),
        ]
    )
    assert code == 2
    assert expected in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
