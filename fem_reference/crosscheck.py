"""Helpers to compare the C++ UL-FEM (run as a binary) with the dolfinx model and with analytic
values: finding and running the binary, reading its outputs (run.json, mesh.h5, boundary CSVs),
distances between boundaries, the collapse criterion of a load-settlement curve. Used by
fem_reference/tests/test_cross_codes.py and fem_reference/closing_figures.py.
"""
from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "fem_reference" / "tests" / "data"
PRANDTL = (2.0 + math.pi) * 20.0  # kPa, (2 + pi) c for c = 20 kPa

# dolfinx's collapse run of data/bearing_block_tresca.json (run_static keywords): load factor
# raised in increments of 1/4, halved on failure, until an increment below 1e-3 fails or the
# factor reaches 1.5; 0.75 m elements, 0.125 m within 1.5 m of the refinement points.
PRANDTL_DOLFINX_RUN = dict(
    steps=4,
    collapse=True,
    max_factor=1.5,
    min_step=1e-3,
    element_size=0.75,
    refine_size=0.125,
    refine_distance=1.5,
)


def build_dir() -> Path:
    """$PFM_BUILD_DIR, default build/ (as tests/python/conftest.py)."""
    return Path(os.environ.get("PFM_BUILD_DIR", ROOT / "build"))


def ulfem_command():
    """A function (case, out) -> argv running a case with the UL-FEM, or None if not built:
    `pfm-mpm run CASE --out DIR --solver ulfem` when `pfm-mpm run --help` offers --solver,
    else the stand-alone `pfm-ulfem CASE DIR`."""
    build = build_dir()
    mpm = build / "bin" / "pfm-mpm"
    if mpm.exists():
        done = subprocess.run(
            [str(mpm), "run", "--help"], capture_output=True, text=True
        )
        if "--solver" in done.stdout + done.stderr:
            return lambda case, out: [
                str(mpm),
                "run",
                str(case),
                "--out",
                str(out),
                "--solver",
                "ulfem",
                "--threads",
                "1",
                "--quiet",
            ]
    standalone = build / "bin" / "pfm-ulfem"
    if standalone.exists():
        return lambda case, out: [str(standalone), str(case), str(out), "1"]
    return None


def missing_binary_message() -> str:
    build = build_dir()
    return (
        f"UL-FEM binary not built: neither {build}/bin/pfm-mpm with `run --solver` "
        f"nor {build}/bin/pfm-ulfem exists (run `make build`)"
    )


def run_ulfem(command, case, out) -> Path:
    """Run `case` into `out` (replaced); RuntimeError with the binary's stderr on failure."""
    out = Path(out)
    if out.exists():
        shutil.rmtree(out)
    done = subprocess.run(command(case, out), capture_output=True, text=True, cwd=ROOT)
    if done.returncode != 0:
        raise RuntimeError(
            f"UL-FEM run of {case} failed ({done.returncode}): {done.stderr}"
        )
    return out


def run_json(out) -> dict:
    return json.loads((Path(out) / "run.json").read_text())


def mesh_history(out):
    """Node displacements per output step: (times, reference positions of the first output,
    [displacement arrays (n, 2)]) from mesh.h5 and run.json "outputs"."""
    import h5py

    times = [entry["time"] for entry in run_json(out)["outputs"]]
    with h5py.File(Path(out) / "mesh.h5", "r") as f:
        groups = sorted(k for k in f if k.startswith("step_"))
        first = f[groups[0]]
        reference = first["geometry"][:, :2] - first["displacement"][:, :2]
        disp = [f[g]["displacement"][:, :2] for g in groups]
    if len(times) != len(disp):
        raise RuntimeError(
            f"{out}: {len(times)} outputs in run.json, {len(disp)} in mesh.h5"
        )
    return np.array(times), reference, disp


def nearest_node(reference, point, tolerance=1e-9) -> int:
    """The mesh node at `point` (within `tolerance`, m)."""
    distance = np.linalg.norm(reference - np.asarray(point), axis=1)
    node = int(np.argmin(distance))
    if distance[node] > tolerance:
        raise ValueError(f"no mesh node within {tolerance} m of {point}")
    return node


def read_boundary_csv(path):
    """Loop 0 of a `loop,x,y` CSV (the outer boundary), as an (n, 2) array."""
    with open(path) as f:
        if f.readline().strip() != "loop,x,y":
            raise ValueError(f"{path}: header is not loop,x,y")
    rows = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return rows[rows[:, 0] == 0][:, 1:]


def point_to_polygon(points, polygon):
    """Distance of each point to the closed polygon (segments between consecutive vertices)."""
    a = polygon
    b = np.roll(polygon, -1, axis=0)
    d = b - a
    length2 = np.maximum((d**2).sum(axis=1), 1e-300)
    t = np.clip(
        ((points[:, None, :] - a[None]) * d[None]).sum(axis=2) / length2, 0.0, 1.0
    )
    closest = a[None] + t[..., None] * d[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=2).min(axis=1)


def boundary_distance(first, second):
    """Largest distance of a point of either closed boundary to the other one (m), and where."""
    to_second = point_to_polygon(first, second)
    to_first = point_to_polygon(second, first)
    if to_second.max() >= to_first.max():
        return float(to_second.max()), first[to_second.argmax()]
    return float(to_first.max()), second[to_first.argmax()]


def collapse_from_curve(load, settlement, window=2.0, fraction=0.05, elastic_load=20.0):
    """Collapse load of a load-settlement curve from a slow ramp: the smallest recorded load q
    at which the secant stiffness over the next `window` kPa of load, dq / ds, is below
    `fraction` of the initial elastic stiffness (the secant from 0 to `elastic_load`), i.e. the
    settlement rate has blown up: the plateau criterion of the dolfinx Prandtl test (last
    increment's stiffness < 5 % of the initial) applied along the explicit curve. None if the
    curve never gets there."""
    i0 = int(np.searchsorted(load, elastic_load))
    initial = load[i0] / settlement[i0]
    for i in range(len(load)):
        j = int(np.searchsorted(load, load[i] + window))
        if j >= len(load):
            return None, initial
        if (load[j] - load[i]) < fraction * initial * (settlement[j] - settlement[i]):
            return float(load[i]), initial
    return None, initial


def ramp_pressure(case, t):
    """Sum of the case's pressures at time t (all loads act on the same interval)."""
    total = 0.0
    for load in case["loads"]:
        tf = load.get("time_function", {"type": "constant"})
        factor = min(1.0, t / tf["ramp_time"]) if tf["type"] == "ramp" else 1.0
        total += load["pressure"] * factor
    return total
