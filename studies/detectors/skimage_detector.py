"""Library baseline detector: the particles rasterised and contoured by scikit-image.

What it does: every particle is drawn as an axis-aligned square of area ``volume`` centred on
it (the uGIMP particle domain; a deformation gradient in the file is not used) onto a raster
whose nodes lie on the detector grid with spacing ``pixel_size`` x initial spacing. A node's
value is the covered fraction of the pixel centred on it (counted inside the grid only, so a
body resting on the grid edge has no boundary along it), smoothed by a Gaussian of standard
deviation ``sigma`` x initial spacing (``scipy.ndimage.gaussian_filter``, mirrored at the grid
edges) and contoured at ``level`` by ``skimage.measure.find_contours``.

Why the smoothing: with equal spacing the squares tile the body and the raster is exact
(sigma = 0 finds a grid-aligned face exactly); with Gauss-point placement the squares overlap
and leave gaps in stripes one cell apart, which break the 0.5 level into dozens of loops. A
Gaussian of one spacing (half a cell at 2 x 2 points per cell) damps that pattern by
exp(-2 pi^2 sigma^2 / h^2) = 0.007 and costs a curvature bias of about sigma^2 / (2 R) inwards
(0.03 h on a disk of radius 2 m at h = 0.5 m).

Output contract: the same as ``pfm-mpm detect`` (mpm/detect/contour.hpp and
detect_command.hpp): ``boundary.csv`` with columns ``loop,x,y`` (material on the left: outer
loops counter-clockwise, holes clockwise; a closed loop does not repeat its first point and
starts at its lowest-then-leftmost point; open chains end on the grid edge; loops sorted by
their lowest-then-leftmost point) and ``summary.json``. Both are written to temporary names and
renamed; the output folder is created only after the input has been read.

Configuration (JSON, the ``--config`` of ``pfm-mpm detect`` with these keys allowed):

==================  ===========================  =============================================
key                 default                      meaning
==================  ===========================  =============================================
method              "skimage"                    must be "skimage" when given
initial_spacing     sqrt(median volume)          m
grid                box + 3 spacings + a cell    {"origin": [x, y], "cell_size": h,
                                                 "n_cells": [nx, ny]}; cell 2 x spacing
skimage.pixel_size  0.25                         raster spacing, initial spacings
skimage.sigma       1.0                          Gaussian smoothing, initial spacings (0: off)
skimage.level       0.5                          contour level (covered fraction)
==================  ===========================  =============================================

Bad input (file, line, column or JSON pointer named) exits with code 2 and writes nothing.

Sample run::

    /usr/bin/python3 -m studies.detectors.skimage_detector particles.csv --config c.json --out DIR
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional, Sequence, Tuple

import numpy as np

EXIT_INPUT_ERROR = 2
TOP_LEVEL_KEYS = ("method", "initial_spacing", "grid", "skimage")
SKIMAGE_KEYS = ("pixel_size", "sigma", "level")


class InputError(Exception):
    """Bad input: the message names the file and the place in it."""


@dataclass
class Particles:
    position: np.ndarray  # (n, 2), m
    volume: np.ndarray  # (n,), m^2


@dataclass
class Grid:
    origin: Tuple[float, float]
    cell_size: float
    n_cells: Tuple[int, int]

    @property
    def upper(self) -> Tuple[float, float]:
        return (
            self.origin[0] + self.n_cells[0] * self.cell_size,
            self.origin[1] + self.n_cells[1] * self.cell_size,
        )


@dataclass
class Settings:
    pixel_size: float = 0.25
    sigma: float = 1.0
    level: float = 0.5


# ---- input -----------------------------------------------------------------------------------


def read_particle_csv(path: Path) -> Particles:
    """Columns x, y, volume (others ignored; F11..F22 all four or none); '#' lines skipped."""
    try:
        text = Path(path).read_text()
    except OSError as error:
        raise InputError(f"{path}: cannot open file ({error.strerror})") from None
    header: Optional[List[str]] = None
    header_line = 0
    xs: List[float] = []
    ys: List[float] = []
    volumes: List[float] = []
    columns = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = [f.strip() for f in line.split(",")]
        if header is None:
            header, header_line = fields, number
            columns = {name: index for index, name in enumerate(header)}
            for name in ("x", "y", "volume"):
                if name not in columns:
                    raise InputError(
                        f'{path}:{number}: missing column "{name}" in the header '
                        "(need x, y, volume; optional F11, F12, F21, F22)"
                    )
            n_f = sum(name in columns for name in ("F11", "F12", "F21", "F22"))
            if n_f not in (0, 4):
                raise InputError(
                    f"{path}:{number}: deformation gradient columns must be all of "
                    "F11, F12, F21, F22 or none"
                )
            continue
        if len(fields) != len(header):
            raise InputError(
                f"{path}:{number}: {len(fields)} fields, the header has {len(header)}"
            )

        def value(name: str) -> float:
            text_value = fields[columns[name]]
            try:
                result = float(text_value)
            except ValueError:
                raise InputError(
                    f'{path}:{number}: column {name}: "{text_value}" is not a number'
                ) from None
            if not math.isfinite(result):
                raise InputError(
                    f"{path}:{number}: column {name}: must be finite, got {text_value}"
                )
            return result

        xs.append(value("x"))
        ys.append(value("y"))
        volume = value("volume")
        if not volume > 0.0:
            raise InputError(f"{path}:{number}: column volume: must be > 0")
        volumes.append(volume)
    if header is None:
        raise InputError(f"{path}: file is empty, expected a header line x,y,volume")
    if not xs:
        raise InputError(
            f"{path}: no particle rows after the header (line {header_line})"
        )
    return Particles(np.column_stack([xs, ys]), np.asarray(volumes, dtype=float))


def _number(value, pointer: str, file: str, positive: bool = False) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
    ):
        raise InputError(f"{file}: {pointer}: expected a finite number")
    if positive and not value > 0:
        raise InputError(f"{file}: {pointer}: must be > 0")
    return float(value)


def read_config(path: Path) -> dict:
    try:
        text = Path(path).read_text()
    except OSError as error:
        raise InputError(f"{path}: cannot open file ({error.strerror})") from None
    try:
        config = json.loads(text)
    except json.JSONDecodeError as error:
        raise InputError(
            f"{path}: invalid JSON at line {error.lineno}: {error.msg}"
        ) from None
    if not isinstance(config, dict):
        raise InputError(f"{path}: : expected an object")
    for key in config:
        if key not in TOP_LEVEL_KEYS:
            raise InputError(
                f"{path}: /{key}: unknown key (allowed: {', '.join(TOP_LEVEL_KEYS)})"
            )
    if "method" in config and config["method"] != "skimage":
        raise InputError(f'{path}: /method: the library baseline runs "skimage" only')
    return config


def parse_settings(config: dict, file: str) -> Settings:
    settings = Settings()
    block = config.get("skimage", {})
    if not isinstance(block, dict):
        raise InputError(f"{file}: /skimage: expected an object")
    for key in block:
        if key not in SKIMAGE_KEYS:
            raise InputError(
                f"{file}: /skimage/{key}: unknown key (allowed: {', '.join(SKIMAGE_KEYS)})"
            )
    if "pixel_size" in block:
        settings.pixel_size = _number(
            block["pixel_size"], "/skimage/pixel_size", file, True
        )
    if "sigma" in block:
        settings.sigma = _number(block["sigma"], "/skimage/sigma", file)
        if settings.sigma < 0:
            raise InputError(f"{file}: /skimage/sigma: must be >= 0 (0 = off)")
    if "level" in block:
        settings.level = _number(block["level"], "/skimage/level", file)
        if not 0.0 < settings.level < 1.0:
            raise InputError(f"{file}: /skimage/level: must be in (0, 1)")
    return settings


def parse_grid(config: dict, file: str, particles: Particles, spacing: float) -> Grid:
    if "grid" not in config:
        h = 2.0 * spacing
        lo = particles.position.min(axis=0)
        hi = particles.position.max(axis=0)
        margin = 3.0 * spacing + h
        origin = (
            math.floor((lo[0] - margin) / h) * h,
            math.floor((lo[1] - margin) / h) * h,
        )
        n_cells = (
            int(math.ceil((hi[0] + margin - origin[0]) / h)),
            int(math.ceil((hi[1] + margin - origin[1]) / h)),
        )
        return Grid(origin, h, n_cells)
    grid = config["grid"]
    if not isinstance(grid, dict):
        raise InputError(f"{file}: /grid: expected an object")
    for key in grid:
        if key not in ("origin", "cell_size", "n_cells"):
            raise InputError(f"{file}: /grid/{key}: unknown key")
    for key in ("origin", "cell_size", "n_cells"):
        if key not in grid:
            raise InputError(f"{file}: /grid: missing key {key}")
    origin = grid["origin"]
    if not isinstance(origin, list) or len(origin) != 2:
        raise InputError(f"{file}: /grid/origin: must be [x, y]")
    origin = tuple(_number(v, f"/grid/origin/{k}", file) for k, v in enumerate(origin))
    cell_size = _number(grid["cell_size"], "/grid/cell_size", file, True)
    n_cells = grid["n_cells"]
    if (
        not isinstance(n_cells, list)
        or len(n_cells) != 2
        or not all(
            isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in n_cells
        )
    ):
        raise InputError(f"{file}: /grid/n_cells: must be [nx, ny], whole numbers >= 1")
    return Grid(origin, cell_size, (n_cells[0], n_cells[1]))


# ---- detection -------------------------------------------------------------------------------


def rasterise(
    particles: Particles, grid: Grid, pixel: float
) -> Tuple[np.ndarray, Tuple[np.ndarray, np.ndarray]]:
    """Covered fraction of the pixel around every raster node (rows: y, columns: x), counted
    over the part of the pixel inside the grid; and the node coordinates (x row, y row).
    """
    lo = np.asarray(grid.origin, dtype=float)
    hi = np.asarray(grid.upper, dtype=float)
    n_x = int(round((hi[0] - lo[0]) / pixel)) + 1
    n_y = int(round((hi[1] - lo[1]) / pixel)) + 1
    node_x = lo[0] + pixel * np.arange(n_x)
    node_y = lo[1] + pixel * np.arange(n_y)
    node_x[-1], node_y[-1] = hi[0], hi[1]
    # Pixel extents clipped to the grid.
    px0 = np.maximum(node_x - 0.5 * pixel, lo[0])
    px1 = np.minimum(node_x + 0.5 * pixel, hi[0])
    py0 = np.maximum(node_y - 0.5 * pixel, lo[1])
    py1 = np.minimum(node_y + 0.5 * pixel, hi[1])
    half = 0.5 * np.sqrt(particles.volume)
    x, y = particles.position[:, 0], particles.position[:, 1]
    i0 = np.floor((x - half - lo[0]) / pixel + 0.5).astype(int)
    j0 = np.floor((y - half - lo[1]) / pixel + 0.5).astype(int)
    span = int(np.ceil(2.0 * half.max() / pixel)) + 2
    covered = np.zeros((n_y, n_x))
    for di in range(span):
        i = i0 + di
        ok_i = (i >= 0) & (i < n_x)
        ic = np.clip(i, 0, n_x - 1)
        ox = np.clip(
            np.minimum(x + half, px1[ic]) - np.maximum(x - half, px0[ic]), 0.0, None
        )
        ox = np.where(ok_i, ox, 0.0)
        for dj in range(span):
            j = j0 + dj
            ok = ok_i & (j >= 0) & (j < n_y)
            jc = np.clip(j, 0, n_y - 1)
            oy = np.clip(
                np.minimum(y + half, py1[jc]) - np.maximum(y - half, py0[jc]), 0.0, None
            )
            area = np.where(ok, ox * oy, 0.0)
            np.add.at(covered, (jc, ic), area)
    pixel_area = np.outer(py1 - py0, px1 - px0)
    return covered / pixel_area, (node_x, node_y)


def canonical(contours: List[Tuple[np.ndarray, bool]]) -> List[Tuple[np.ndarray, bool]]:
    """Merge repeated points, rotate closed loops to their lowest-then-leftmost point and sort
    the contours by that point (contour.hpp)."""

    def lowest(points: np.ndarray) -> int:
        return int(np.lexsort((points[:, 0], points[:, 1]))[0])

    kept = []
    for points, closed in contours:
        keep = np.ones(len(points), dtype=bool)
        keep[1:] = np.any(points[1:] != points[:-1], axis=1)
        points = points[keep]
        if closed:
            while len(points) > 1 and np.array_equal(points[-1], points[0]):
                points = points[:-1]
            if len(points) < 3:
                continue
            points = np.roll(points, -lowest(points), axis=0)
        elif len(points) < 2:
            continue
        kept.append((points, closed))
    kept.sort(key=lambda c: (c[0][lowest(c[0]), 1], c[0][lowest(c[0]), 0]))
    return kept


def detect(
    particles: Particles, grid: Grid, spacing: float, settings: Settings
) -> dict:
    """Contours (list of (points (n, 2), closed)) and timings of the library baseline."""
    from scipy.ndimage import gaussian_filter
    from skimage.measure import find_contours

    pixel = settings.pixel_size * spacing
    start = time.perf_counter()
    field, nodes = rasterise(particles, grid, pixel)
    raster_s = time.perf_counter() - start
    start = time.perf_counter()
    if settings.sigma > 0:
        field = gaussian_filter(field, settings.sigma * spacing / pixel, mode="mirror")
    filter_s = time.perf_counter() - start
    start = time.perf_counter()
    # Rows are y and columns x, a reflection of (x, y): "low on the left" in (row, column) is
    # material (high) on the left in (x, y).
    raw = find_contours(field, settings.level, positive_orientation="low")
    contours = []
    n_y, n_x = field.shape
    for rc in raw:
        closed = len(rc) > 2 and np.array_equal(rc[0], rc[-1])
        col, row = rc[:, 1], rc[:, 0]
        x = np.interp(col, np.arange(n_x), nodes[0])
        y = np.interp(row, np.arange(n_y), nodes[1])
        contours.append((np.column_stack([x, y]), closed))
    contours = canonical(contours)
    contour_s = time.perf_counter() - start
    return {
        "contours": contours,
        "timings_s": {
            "field": raster_s,
            "edge_points": contour_s,
            "connection": 0.0,
            "filters": filter_s,
        },
        "raster": list(field.shape[::-1]),
    }


# ---- output ----------------------------------------------------------------------------------


def _write_atomically(folder: Path, name: str, text: str) -> None:
    temporary = folder / f".{name}.tmp"
    temporary.write_text(text)
    os.replace(temporary, folder / name)


def run(particles_csv: Path, config_json: Path, out_dir: Path) -> int:
    config = read_config(config_json)
    settings = parse_settings(config, str(config_json))
    particles = read_particle_csv(particles_csv)
    if "initial_spacing" in config:
        spacing = _number(
            config["initial_spacing"], "/initial_spacing", str(config_json), True
        )
    else:
        spacing = float(math.sqrt(np.median(particles.volume)))
    grid = parse_grid(config, str(config_json), particles, spacing)
    result = detect(particles, grid, spacing, settings)
    lines = ["loop,x,y"]
    for loop, (points, _) in enumerate(result["contours"]):
        lines += [f"{loop},{x!r},{y!r}" for x, y in points.tolist()]
    summary = {
        "method": "skimage",
        "particles": int(len(particles.volume)),
        "initial_spacing": spacing,
        "grid": {
            "origin": list(grid.origin),
            "cell_size": grid.cell_size,
            "n_cells": list(grid.n_cells),
        },
        "pixel_size": settings.pixel_size * spacing,
        "sigma": settings.sigma * spacing,
        "level": settings.level,
        "raster": result["raster"],
        "loops": len(result["contours"]),
        "closed": sum(1 for _, closed in result["contours"] if closed),
        "open": sum(1 for _, closed in result["contours"] if not closed),
        "points_per_loop": [len(points) for points, _ in result["contours"]],
        "loop_closed": [bool(closed) for _, closed in result["contours"]],
        "timings_s": result["timings_s"],
    }
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    _write_atomically(out_dir, "boundary.csv", "\n".join(lines) + "\n")
    _write_atomically(out_dir, "summary.json", json.dumps(summary, indent=2) + "\n")
    return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog="/usr/bin/python3 -m studies.detectors.skimage_detector",
        description="Library baseline: particles rasterised and contoured by scikit-image.",
    )
    parser.add_argument("particles", type=Path, help="particle CSV with x,y,volume")
    parser.add_argument(
        "--config", type=Path, required=True, help="detector configuration (JSON)"
    )
    parser.add_argument("--out", type=Path, required=True, help="output directory")
    try:
        arguments = parser.parse_args(argv)
    except SystemExit as exit_request:
        return EXIT_INPUT_ERROR if exit_request.code else 0
    try:
        return run(arguments.particles, arguments.config, arguments.out)
    except InputError as error:
        print(f"skimage_detector: error: {error}", file=sys.stderr)
        return EXIT_INPUT_ERROR


if __name__ == "__main__":
    sys.exit(main())
