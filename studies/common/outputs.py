"""Readers of the solver's output folders. Every reader names the file it needs; a missing file
raises PrerequisiteMissing, so a study whose inputs are not produced yet is recorded as
"not run: needs <file> in <tool> output" rather than failing.

Layout of ``pfm-mpm run CASE --out DIR`` (as written by the solver on 2026-11-23, plus the
boundary files the studies assume until the detection is wired into the run):

* ``run.json``          ``{"status": "completed", "summary": {"n_steps", "dt_s",
                          "final_time_s", "n_particles", "wall_time_s", "particle_steps_per_s",
                          "stage_seconds": {"<stage>": s, ...}, "energy": {...}}, ...}``;
                          ASSUMED: the detection stage is named ``detect`` in stage_seconds;
* ``timeseries.csv``    ``time,kinetic_energy,external_work,...``; ASSUMED for loaded cases:
                          ``load_target_fy``, ``load_applied_fy``, ``load_lost_fy`` (kN/m:
                          q (x1 - x0), the sum of the nodal forces applied, the part on nodes
                          of empty cells);
* ``particles.xdmf`` + ``particles.h5``  one group ``/step_NNNNNNNN`` per output time with
                          ``position`` (n, 3), ``displacement`` (n, 3), ``velocity`` (n, 3),
                          ``sxx, syy, sxy, szz, eps_p, volume, id, material, body`` (n,); the
                          times are the XDMF ``<Time Value>`` of each grid;
* ``final_particles.csv`` ``id,x,y,vx,vy,sxx,syy,sxy,szz,eps_p,volume,ux,uy,material,body``;
* ASSUMED ``boundary/index.csv``  ``step,time,file``: the detected boundary at each output
                          time, ``file`` a loop CSV (``loop,x,y[,closed]``) relative to
                          ``boundary/``; the UL-FEM run writes its mesh's outer boundary there.

ASSUMED ``pfm-mpm detect PARTICLES.csv --config DETECT.json --out DIR`` writes
``DIR/boundary.csv`` (loop CSV). The dolfinx model (fem_reference/README.md) writes
``load_settlement.csv`` (``load,settlement,settlement_total``: kPa, m, m) in static mode and
``boundary_t<time:.4f>.csv`` at snapshot times in explicit mode.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Optional

import pandas as pd

from studies.common.paths import PrerequisiteMissing


def need(path: Path, tool: str = "pfm-mpm run") -> Path:
    path = Path(path)
    if not path.is_file():
        raise PrerequisiteMissing(f"{path.parent.name}/{path.name} in {tool} output")
    return path


def read_summary(out: Path) -> dict:
    data = json.loads(need(Path(out) / "run.json").read_text())
    if "summary" not in data:
        raise PrerequisiteMissing("/summary in run.json of pfm-mpm run")
    return data["summary"]


def read_timeseries(out: Path) -> pd.DataFrame:
    return pd.read_csv(need(Path(out) / "timeseries.csv"))


def particle_frames(out: Path) -> pd.DataFrame:
    """step, time, file ("<out>/particles.h5:/step_NNNNNNNN") of every particle output,
    read from particles.xdmf."""
    text = need(Path(out) / "particles.xdmf").read_text()
    rows = []
    for match in re.finditer(r'<Grid Name="(step_(\d+))" GridType="Uniform">\s*'
                             r'<Time Value="([^"]+)"', text):
        rows.append({"step": int(match.group(2)), "time": float(match.group(3)),
                     "file": f"{Path(out) / 'particles.h5'}:/{match.group(1)}"})
    if not rows:
        raise ValueError(f"{out}/particles.xdmf: no particle grids with times")
    return pd.DataFrame(rows)


def read_particles(location: str) -> pd.DataFrame:
    """A particle table (columns x, y, ux, uy, vx, vy, sxx, ...) from an HDF5 step
    ("<file>.h5:/step_N") or from a CSV file."""
    if ".h5:/" not in str(location):
        return pd.read_csv(need(Path(location)))
    import h5py

    path, group = str(location).split(":/", 1)
    with h5py.File(need(Path(path)), "r") as h5:
        data = h5[group]
        frame = {"x": data["position"][:, 0], "y": data["position"][:, 1],
                 "ux": data["displacement"][:, 0], "uy": data["displacement"][:, 1]}
        if "velocity" in data:
            frame.update(vx=data["velocity"][:, 0], vy=data["velocity"][:, 1])
        for name, values in data.items():
            if name not in ("position", "displacement", "velocity") and values.ndim == 1:
                frame[name] = values[:]
    return pd.DataFrame(frame)


def read_index(out: Path, kind: str) -> pd.DataFrame:
    """``kind`` = "boundary" (``boundary/index.csv``) or "particles" (from particles.xdmf):
    the frame step,time,file with absolute file locations."""
    if kind == "particles":
        return particle_frames(out)
    index = pd.read_csv(need(Path(out) / kind / "index.csv"))
    missing = {"step", "time", "file"} - set(index.columns)
    if missing:
        raise ValueError(f"{out}/{kind}/index.csv: missing columns {sorted(missing)}")
    index["file"] = [str(Path(out) / kind / f) for f in index["file"]]
    return index


def file_at_time(index: pd.DataFrame, time: float, tolerance: float) -> Optional[str]:
    """The file (location) whose time is closest to ``time`` if within ``tolerance`` (s)."""
    if index.empty:
        return None
    distance = (index["time"] - time).abs()
    best = distance.idxmin()
    return str(index.loc[best, "file"]) if distance[best] <= tolerance else None
