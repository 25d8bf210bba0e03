"""Boundary distances on polylines whose distances are known exactly."""

import math

import numpy as np
import pytest

from studies.metrics import (
    grid_edge_band,
    OTHER,
    Polyline,
    assign_regions,
    block_regions,
    boundary_distance,
    read_loops,
    slope_regions,
    write_loops,
)


@pytest.mark.parametrize("offset", [0.37, 1e-3, 2.5])
def test_parallel_offset_lines_are_exactly_offset_apart(offset):
    # Uneven vertices on one line so that the resampling pieces differ between the two.
    a = [Polyline([[0.0, 0.0], [0.3, 0.0], [3.3, 0.0], [10.0, 0.0]], closed=False)]
    b = [Polyline([[0.0, offset], [7.1, offset], [10.0, offset]], closed=False)]
    result = boundary_distance(a, b, h=0.5)
    for value in (result.overall.mean, result.overall.rms, result.overall.max):
        assert abs(value - offset) <= 1e-12
    scaled = result.overall.scaled(0.5)
    assert abs(scaled.max - offset / 0.5) <= 1e-12
    assert result.overall.length_detected == pytest.approx(10.0, abs=1e-12)


@pytest.mark.parametrize("n_sides", [4, 6, 12, 40])
def test_circle_against_inscribed_polygon_max_is_the_sagitta(n_sides):
    radius = 2.0
    n_circle = 2 * n_sides * 25  # a vertex at the middle of every polygon edge's arc
    theta = np.arange(n_circle) * 2 * np.pi / n_circle
    circle = [Polyline(np.c_[radius * np.cos(theta), radius * np.sin(theta)])]
    phi = np.arange(n_sides) * 2 * np.pi / n_sides
    polygon = [Polyline(np.c_[radius * np.cos(phi), radius * np.sin(phi)])]
    result = boundary_distance(polygon, circle)
    assert abs(result.overall.max - radius * (1 - math.cos(math.pi / n_sides))) <= 1e-9


def test_mean_is_exact_when_distance_is_linear_along_the_curves():
    # A = [0, 1] x {0}; B = the diagonal from (0, 0) to (1, 1).
    # d(a, B) = x / sqrt 2 along A (length 1); d(b, A) = t along B (length sqrt 2).
    a = [Polyline([[0.0, 0.0], [1.0, 0.0]], closed=False)]
    b = [Polyline([[0.0, 0.0], [1.0, 1.0]], closed=False)]
    result = boundary_distance(a, b, spacing=1e-3)
    root2 = math.sqrt(2.0)
    integral = 1 / (2 * root2) + root2 / 2
    assert abs(result.overall.mean - integral / (1 + root2)) <= 1e-12
    assert abs(result.overall.max - 1.0) <= 1e-12  # from (1, 1) to A
    squares = 1 / 6 + root2 / 3  # int x^2/2 dx + int t^2 sqrt2 dt
    assert (
        abs(result.overall.rms - math.sqrt(squares / (1 + root2))) <= 1e-6
    )  # trapezoid O(ds^2)


def test_identical_boundaries_are_zero_apart():
    square = [Polyline([[0, 0], [4, 0], [4, 3], [0, 3]])]
    result = boundary_distance(square, square, h=0.5)
    assert result.overall.max <= 1e-12 and result.overall.mean <= 1e-12


SLOPE = [
    [0.0, 0.0],
    [26.0, 0.0],
    [26.0, 10.0],
    [14.125, 10.0],
    [10.125, 6.0],
    [0.0, 6.0],
]


@pytest.mark.parametrize("mirror", [False, True])
def test_slope_regions_assign_each_point_to_its_region(mirror):
    crest, toe = (14.125, 10.0), (10.125, 6.0)
    points = {
        "crest": (14.3, 9.9),
        "toe": (10.0, 6.1),
        "face": (12.125, 8.0),
        "top": (20.0, 10.0),
        "bottom": (3.0, 6.0),
        "loaded_strip": (17.0, 10.05),
        OTHER: (5.0, 0.0),
    }
    load = (16.0, 18.0)
    if mirror:  # the same slope descending towards +x
        crest, toe = (30 - crest[0], crest[1]), (30 - toe[0], toe[1])
        points = {k: (30 - x, y) for k, (x, y) in points.items()}
        load = (30 - load[1], 30 - load[0])
    regions = slope_regions(crest, toe, radius=1.0, load_range=load)
    labels = assign_regions(np.array(list(points.values())), regions)
    assert list(labels) == list(points)


def test_block_regions():
    regions = block_regions(top_y=5.0, load_range=(5.0, 10.0), band=0.5)
    labels = assign_regions(
        np.array([[7.0, 5.0], [2.0, 4.8], [7.0, 0.0], [15.0, 2.0]]), regions
    )
    assert list(labels) == ["loaded_strip", "top", OTHER, OTHER]


def test_per_region_distances_see_only_their_own_error():
    # The detected slope equals the reference except that its top, far behind the crest,
    # lies 0.1 m higher: only "top" sees 0.1 m; face, toe, bottom see nothing.
    reference = [Polyline(SLOPE)]
    shifted = [list(p) for p in SLOPE]
    shifted[2] = [26.0, 10.1]
    shifted.insert(3, [20.0, 10.1])
    shifted.insert(4, [19.9, 10.0])
    detected = [Polyline(shifted)]
    regions = slope_regions((14.125, 10.0), (10.125, 6.0), radius=1.0)
    result = boundary_distance(detected, reference, h=0.5, regions=regions)
    assert abs(result.regions["top"].max - 0.1) <= 1e-12
    for name in ("face", "crest", "toe", "bottom"):
        assert result.regions[name].max <= 1e-12
    assert abs(result.overall.max - 0.1) <= 1e-12
    rows = {row["region"]: row for row in result.rows()}
    assert abs(rows["top"]["max_h"] - 0.2) <= 1e-12


def test_loop_csv_round_trip(tmp_path):
    loops = [
        Polyline([[0, 0], [1, 0], [1, 1]]),
        Polyline([[2, 2], [3, 3]], closed=False),
    ]
    write_loops(tmp_path / "b.csv", loops)
    back = read_loops(tmp_path / "b.csv")
    assert [l.closed for l in back] == [True, False]
    assert np.array_equal(back[0].points, loops[0].points)
    (tmp_path / "plain.csv").write_text("loop,x,y\n0,0,0\n0,1,0\n0,1,1\n")
    assert read_loops(tmp_path / "plain.csv")[0].closed  # closed by default
    (tmp_path / "bad.csv").write_text("x,y\n0,0\n")
    with pytest.raises(ValueError, match="loop"):
        read_loops(tmp_path / "bad.csv")


def test_grid_edge_band_leaves_out_the_supported_boundary():
    # Reference: a 4 x 2 block resting on the grid's base and sides (grid 4 x 3 m). Detected:
    # only its top, 0.1 m high, plus a spurious scallop on the base. With the grid-edge band
    # left out, only the free top counts: 0.1 m everywhere.
    grid = {"origin": [0.0, 0.0], "cell_size": 0.5, "n_cells": [8, 6]}
    reference = [Polyline([[0, 0], [4, 0], [4, 2], [0, 2]])]
    detected = [
        Polyline([[4, 2.1], [0, 2.1]], closed=False),
        Polyline([[1, 0], [1.2, 0.2], [1.4, 0]], closed=False),
    ]
    band = grid_edge_band(grid, 0.75)
    result = boundary_distance(detected, reference, h=0.5, ignore=band)
    assert (
        abs(result.overall.max - 0.1) <= 1e-12
        and abs(result.overall.mean - 0.1) <= 1e-12
    )
    # x in [0.75, 3.25] of the top, to one sample spacing (h / 20): samples are dropped whole
    assert abs(result.overall.length_reference - 2.5) <= result.spacing + 1e-12
    without = boundary_distance(detected, reference, h=0.5)
    assert without.overall.max >= 1.9  # the base and sides
