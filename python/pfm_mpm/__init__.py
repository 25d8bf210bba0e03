"""pfm_mpm: the pfm-mpm C++ core from Python (python/README.md).

* ``read_case(path)`` / ``parse_case(document, file)``: a case file validated by the C++ reader
  (the one schema), returned resolved (defaults applied, bodies as counter-clockwise polygons).
* ``detect(position, volume, initial_spacing, grid, config)``: the detectors on arrays.
* ``composite_bezier(points, closed, kind)``: composite Bezier curves through boundary points.
* ``nodal_forces(grid, curves, load)``: a surface load integrated into nodal forces.
* ``Simulation(case, out)`` (pfm_mpm.simulation): a run stepped from Python, its particle arrays
  as numpy views, the same output folder as ``pfm-mpm run``.
* ``OutputFolder(path)`` (pfm_mpm.outputs): a run's output folder as numpy arrays and pandas
  frames.

Bad input raises ``InputError`` (a ValueError) with the C++ message: the file and the JSON
pointer; a simulation that stops raises ``SimulationError`` (a RuntimeError), a failed write
``OutputError`` (an OSError). Units: kN, m, s, t (tonne), kPa; plane strain; tension positive.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from pfm_mpm import _core
from pfm_mpm._core import InputError, OutputError, SimulationError
from pfm_mpm.outputs import OutputFolder
from pfm_mpm.simulation import Simulation

__all__ = [
    "InputError",
    "SimulationError",
    "OutputError",
    "Simulation",
    "OutputFolder",
    "Curve",
    "version",
    "read_case",
    "parse_case",
    "detect",
    "composite_bezier",
    "nodal_forces",
]


def version() -> str:
    """'pfm-mpm <version> (git <revision>, <build type> build)', as ``pfm-mpm --version``."""
    return _core.version()


def read_case(path) -> dict:
    """The case file at ``path`` validated by the C++ reader and resolved (mpm/step/case.hpp,
    resolved_case: every key with its value or default). Raises InputError."""
    return json.loads(_core.read_case_json(str(path)))


def parse_case(document: dict, file: str = "<dict>") -> dict:
    """As read_case, for a case already parsed into a dict; ``file`` names it in messages and
    its folder resolves the relative paths of body files."""
    return json.loads(_core.parse_case_json(json.dumps(document), str(file)))


def _grid_json(grid: dict) -> str:
    return json.dumps(
        {k: grid[k] for k in ("origin", "cell_size", "n_cells") if k in grid}
    )


def detect(
    position,
    volume,
    initial_spacing: float,
    grid: dict,
    config: Optional[dict] = None,
    deformation_gradient=None,
) -> list:
    """Detected boundary loops of the points: [(points (m, 2), closed), ...], material on the
    left. ``grid`` as the case's grid block ({"origin", "cell_size", "n_cells"}), ``config`` as
    a case's detection block without every_steps (default: the improved detector),
    ``deformation_gradient`` (n, 2, 2) or None (F = I)."""
    f = None
    if deformation_gradient is not None:
        f = np.ascontiguousarray(deformation_gradient, dtype=float)
    return _core.detect(
        np.ascontiguousarray(position, dtype=float),
        np.ascontiguousarray(volume, dtype=float),
        float(initial_spacing),
        _grid_json(grid),
        json.dumps(config or {}),
        f,
    )


@dataclass
class Curve:
    """A composite Bezier curve: segment s has control points control[s, :degree[s] + 1]."""

    control: np.ndarray  # (n, 4, 2), m
    degree: np.ndarray  # (n,)
    closed: bool


def composite_bezier(points, closed: bool, kind: str = "cubic") -> Curve:
    """The composite curve of ``kind`` (linear, quadratic, cubic, catmull_rom) through the
    points (mpm/boundary/bezier.hpp)."""
    control, degree, closed = _core.composite_bezier(
        np.ascontiguousarray(points, dtype=float), bool(closed), kind
    )
    return Curve(control, degree, closed)


def nodal_forces(
    grid: dict,
    curves: Sequence[Curve],
    load: dict,
    load_factor: float = 1.0,
    shape_degree: int = 1,
    node_mass=None,
):
    """(forces (n_nodes, 2) kN/m, totals) of a load given as a case's loads[] entry on the
    detected boundary (``"apply_on": "detected_boundary"``) acting on ``curves``; nodes are
    numbered row by row (node (i, j) is j (nx + 1) + i). shape_degree 1 for the bilinear grid
    functions, 2 or 3 for the B-splines. node_mass (n_nodes,) decides which nodes are too light
    to carry a load (None: every node has mass)."""
    mass = None
    if node_mass is not None:
        mass = np.ascontiguousarray(node_mass, dtype=float)
    return _core.nodal_forces(
        _grid_json(grid),
        [(c.control, np.asarray(c.degree, dtype=np.int32), c.closed) for c in curves],
        json.dumps(load),
        float(load_factor),
        int(shape_degree),
        mass,
    )
