"""Readers of a run's output folder (``pfm-mpm run CASE --out DIR``, MPM or UL-FEM; the layout
is in README.md, "Outputs") into numpy arrays and pandas frames.

    run = OutputFolder("results/bearing_quasi_static/mpm")
    run.summary["n_steps"]; run.timeseries["kinetic_energy"]
    steps = run.particle_steps()          # step, time
    p = run.particles(steps.step.iloc[-1])  # x, y, ux, uy, vx, vy, sxx, ..., id, material
    loops = run.boundary(step)            # [(points (m, 2), closed), ...]

A missing file raises FileNotFoundError naming it. Units: kN, m, s, t, kPa.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

# Vectors stored as (n, 3) (x, y, 0 for the XDMF readers) and the columns they become.
_VECTORS = {
    "position": ("x", "y"),
    "displacement": ("ux", "uy"),
    "velocity": ("vx", "vy"),
}


def _need(path: Path) -> Path:
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such output file")
    return path


def _steps(path: Path) -> pd.DataFrame:
    """step, time of the step_<N> groups of an HDF5 series (their step and time attributes)."""
    import h5py

    rows = []
    with h5py.File(_need(path), "r") as h5:
        for name, group in h5.items():
            if name.startswith("step_") and isinstance(group, h5py.Group):
                rows.append(
                    {
                        "step": int(group.attrs["step"]),
                        "time": float(group.attrs["time"]),
                    }
                )
    return pd.DataFrame(rows, columns=["step", "time"]).sort_values(
        "step", ignore_index=True
    )


def particle_table(path, group: str) -> pd.DataFrame:
    """The particles of one step group of an HDF5 particle file: columns x, y, ux, uy, vx, vy
    and one per scalar field (sxx, syy, sxy, szz, eps_p, volume, id, material, body, F11 ...);
    a deformation gradient stored as ``F`` (n, 4) or (n, 2, 2) becomes F11, F12, F21, F22.
    """
    import h5py

    with h5py.File(_need(Path(path)), "r") as h5:
        data = h5[group]
        frame = {}
        for name, columns in _VECTORS.items():
            if name in data:
                values = data[name][:]
                for k, column in enumerate(columns):
                    frame[column] = values[:, k]
        for name, values in data.items():
            if name in _VECTORS:
                continue
            if values.ndim == 1:
                frame[name] = values[:]
            elif name in ("F", "deformation_gradient") and values.size == 4 * len(
                values
            ):
                f = np.asarray(values[:]).reshape(len(values), 4)
                frame.update(F11=f[:, 0], F12=f[:, 1], F21=f[:, 2], F22=f[:, 3])
    return pd.DataFrame(frame)


def boundary_loops(path, group: str) -> list:
    """The loops of one step group of boundary.h5: [(points (m, 2), closed), ...] in file
    order. A closed loop has as many segments as points, an open one one fewer."""
    import h5py

    with h5py.File(_need(Path(path)), "r") as h5:
        data = h5[group]
        loop = np.asarray(data["loop"][:]).astype(int)
        position = np.asarray(data["position"][:])[:, :2]
        segments = np.asarray(data["segments"][:]).reshape(-1, 2)
    if len(loop) == 0:
        return []
    counted = np.bincount(loop[segments[:, 0]], minlength=loop.max() + 1)
    loops = []
    for k in np.unique(loop):
        points = position[loop == k]
        loops.append((points, bool(counted[k] == len(points))))
    return loops


class OutputFolder:
    """One run's output folder."""

    def __init__(self, path):
        self.path = Path(path)
        if not self.path.is_dir():
            raise FileNotFoundError(f"{self.path}: no such output folder")

    @property
    def run(self) -> dict:
        """run.json: status, provenance, summary, outputs."""
        return json.loads(_need(self.path / "run.json").read_text())

    @property
    def summary(self) -> dict:
        return self.run.get("summary", {})

    @property
    def timeseries(self) -> pd.DataFrame:
        return pd.read_csv(_need(self.path / "timeseries.csv"))

    def particle_steps(self) -> pd.DataFrame:
        """step, time of every particle output (particles.h5)."""
        return _steps(self.path / "particles.h5")

    def particles(self, step: int) -> pd.DataFrame:
        """The particles at output step ``step`` (particle_table)."""
        return particle_table(self.path / "particles.h5", f"step_{int(step):08d}")

    def final_particles(self) -> pd.DataFrame:
        """final_particles.csv, or the last particle output of a run that stopped early."""
        path = self.path / "final_particles.csv"
        if path.is_file():
            return pd.read_csv(path)
        return self.particles(self.particle_steps()["step"].iloc[-1])

    def boundary_steps(self) -> pd.DataFrame:
        """step, time of every boundary output (boundary.h5)."""
        return _steps(self.path / "boundary.h5")

    def boundary(self, step: int) -> list:
        """The boundary at output step ``step``: [(points (m, 2), closed), ...]."""
        return boundary_loops(self.path / "boundary.h5", f"step_{int(step):08d}")
