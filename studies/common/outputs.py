"""Readers of the solver's output folders, on those of the module pfm_mpm (python/README.md)
where it has one. Every reader names the file it needs; a missing file raises
PrerequisiteMissing, so a study whose inputs are not produced yet is recorded as
"not run: needs <file> in <tool> output" rather than failing.

Layout of ``pfm-mpm run CASE --out DIR [--solver mpm|ulfem]`` (and of ``pfm-ulfem CASE DIR``):

* ``run.json``          ``{"status": "completed", "summary": {"n_steps", "dt_s",
                          "final_time_s", "n_particles", "wall_time_s", "particle_steps_per_s",
                          "stage_seconds": {"<stage>": s, ...}, "energy": {...},
                          "detection": {"calls", "seconds_per_call"}}, "outputs": [{"step",
                          "time", "boundary"}, ...]}``; MPM stages ``locate,
                          particles_to_grid, external_forces, update_grid, grid_to_particles,
                          remap, stress`` and, with a detection block, ``detect, bezier,
                          traction``; ``outputs`` may be missing (older runs): the output steps
                          are then read from the file names and ``particles.h5``;
* ``timeseries.csv``    ``time,kinetic_energy,external_work,...``; with loads on the detected
                          boundary also ``load_target_fx, load_target_fy, load_applied_fx,
                          load_applied_fy, load_lost_fx, load_lost_fy`` (kN/m);
* ``particles.xdmf`` + ``particles.h5``  one group ``/step_NNNNNNNN`` per output time with
                          ``position`` (n, 3), ``displacement`` (n, 3), ``velocity`` (n, 3),
                          ``sxx, syy, sxy, szz, eps_p, volume, id, material, body`` (n,); each
                          group's attributes ``step`` and ``time`` (s);
* ``final_particles.csv`` ``id,x,y,vx,vy,sxx,syy,sxy,szz,eps_p,volume,ux,uy,material,body``;
* ``boundary_<step:08d>.csv``  ``loop,x,y`` at each output step: the detected boundary (MPM
                          with a ``detection`` block) or the exact mesh boundary (UL-FEM).

``pfm-mpm detect PARTICLES.csv --config DETECT.json --out DIR`` writes ``DIR/boundary.csv``
(loop CSV) and ``DIR/summary.json`` (timings). The dolfinx model (fem_reference/README.md)
writes ``load_settlement.csv`` (``load,settlement,settlement_total``: kPa, m, m) in static mode.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Optional

import pandas as pd

from studies.common.paths import PrerequisiteMissing, core

BOUNDARY_FILE = re.compile(r"boundary_(\d{8})\.csv$")


def need(path: Path, tool: str = "pfm-mpm run") -> Path:
    path = Path(path)
    if not path.is_file():
        raise PrerequisiteMissing(f"{path.name} in {tool} output")
    return path


def read_run(out: Path) -> dict:
    return json.loads(need(Path(out) / "run.json").read_text())


def read_summary(out: Path) -> dict:
    data = read_run(out)
    if "summary" not in data:
        raise PrerequisiteMissing("/summary in run.json of pfm-mpm run")
    return data["summary"]


def read_timeseries(out: Path) -> pd.DataFrame:
    return pd.read_csv(need(Path(out) / "timeseries.csv"))


def particle_frames(out: Path) -> pd.DataFrame:
    """step, time, file ("<out>/particles.h5:/step_NNNNNNNN") of every particle output, from
    the step groups of particles.h5 (pfm_mpm.OutputFolder)."""
    need(Path(out) / "particles.h5")
    frames = core().OutputFolder(out).particle_steps()
    if frames.empty:
        raise ValueError(f"{out}/particles.h5: no particle outputs")
    h5 = Path(out) / "particles.h5"
    frames["file"] = [f"{h5}:/step_{step:08d}" for step in frames["step"]]
    return frames


def boundary_frames(out: Path) -> pd.DataFrame:
    """step, time, file of every ``boundary_<step>.csv`` of a run: from run.json ``outputs``
    when it lists them, else from the file names with the time of the particle output of the
    same step (particles.xdmf)."""
    out = Path(out)
    run = read_run(out)
    listed = [o for o in run.get("outputs", []) if o.get("boundary")]
    if listed:
        return pd.DataFrame(
            [
                {
                    "step": int(o["step"]),
                    "time": float(o["time"]),
                    "file": str(out / o["boundary"]),
                }
                for o in listed
            ]
        )
    files = sorted(
        p for p in out.glob("boundary_*.csv") if BOUNDARY_FILE.search(p.name)
    )
    if not files:
        raise PrerequisiteMissing(
            f"boundary_<step>.csv in the {out.name} run output "
            f"(a detection block in the case)"
        )
    times = dict(zip(*[particle_frames(out)[c] for c in ("step", "time")]))
    rows = []
    for path in files:
        step = int(BOUNDARY_FILE.search(path.name).group(1))
        if step not in times:
            raise ValueError(
                f"{path}: no particle output at step {step} to give its time"
            )
        rows.append({"step": step, "time": float(times[step]), "file": str(path)})
    return pd.DataFrame(rows)


def read_index(out: Path, kind: str) -> pd.DataFrame:
    """``kind`` = "boundary" or "particles": the frame step,time,file of a run's outputs."""
    if kind == "particles":
        return particle_frames(out)
    if kind == "boundary":
        return boundary_frames(out)
    raise ValueError(f"kind must be boundary or particles, got {kind!r}")


def read_particles(location: str) -> pd.DataFrame:
    """A particle table (columns x, y, ux, uy, vx, vy, sxx, ...) from an HDF5 step
    ("<file>.h5:/step_N", pfm_mpm.outputs.particle_table) or from a CSV file."""
    if ".h5:/" not in str(location):
        return pd.read_csv(need(Path(location)))
    path, group = str(location).split(":/", 1)
    return core().outputs.particle_table(need(Path(path)), group)


DETECT_COLUMNS = ("x", "y", "volume", "F11", "F12", "F21", "F22")


def write_detect_input(particles: pd.DataFrame, path: Path) -> Path:
    """The particle CSV of ``pfm-mpm detect``: x, y, volume and F11..F22 when known."""
    for column in ("x", "y", "volume"):
        if column not in particles:
            raise ValueError(
                f"particle table has no column {column} (detect needs x, y, volume)"
            )
    columns = [c for c in DETECT_COLUMNS if c in particles]
    particles[columns].to_csv(path, index=False, float_format="%.17g")
    return Path(path)


def file_at_time(index: pd.DataFrame, time: float, tolerance: float) -> Optional[str]:
    """The file (location) whose time is closest to ``time`` if within ``tolerance`` (s)."""
    if index.empty:
        return None
    distance = (index["time"] - time).abs()
    best = distance.idxmin()
    return str(index.loc[best, "file"]) if distance[best] <= tolerance else None


def row_at_time(index: pd.DataFrame, time: float, tolerance: float) -> Optional[dict]:
    """The index row (step, time, file) closest to ``time`` if within ``tolerance`` (s)."""
    if index.empty:
        return None
    distance = (index["time"] - time).abs()
    best = distance.idxmin()
    return dict(index.loc[best]) if distance[best] <= tolerance else None


def loop_closed_flags(boundary_csv: Path) -> Optional[list]:
    """Whether each loop of a boundary CSV is closed (the CSV itself does not say):

    * a ``detect`` output: ``loop_closed`` of the ``summary.json`` beside it;
    * a run's ``boundary_<step>.csv``: from ``boundary.h5`` beside it (group ``step_<step>``:
      a closed loop has as many ``segments`` as points, an open one one fewer);
    * otherwise None (every loop closed: the UL-FEM's mesh boundaries)."""
    boundary_csv = Path(boundary_csv)
    summary = boundary_csv.parent / "summary.json"
    if boundary_csv.name == "boundary.csv" and summary.is_file():
        flags = json.loads(summary.read_text()).get("loop_closed")
        if flags is not None:
            return [bool(f) for f in flags]
    match = BOUNDARY_FILE.search(boundary_csv.name)
    series = boundary_csv.parent / "boundary.h5"
    if match and series.is_file():
        try:
            loops = core().outputs.boundary_loops(series, f"step_{match.group(1)}")
        except KeyError:  # no such step group, or one without segments
            return None
        return [closed for _, closed in loops]
    return None


def read_boundary(boundary_csv: Path):
    """The loops (studies.metrics.Polyline) of a boundary CSV with their closed flags."""
    from studies.metrics import read_loops

    loops = read_loops(boundary_csv)
    flags = loop_closed_flags(boundary_csv)
    if flags is not None:
        if len(flags) != len(loops):
            raise ValueError(
                f"{boundary_csv}: {len(loops)} loops but {len(flags)} closed flags"
            )
        for loop, closed in zip(loops, flags):
            loop.closed = closed
    return loops


def final_particles(out: Path) -> pd.DataFrame:
    """The last particle state of a run: ``final_particles.csv``, or the last particle output
    of a run that stopped early (which writes no final_particles.csv)."""
    path = Path(out) / "final_particles.csv"
    if path.is_file():
        return pd.read_csv(path)
    return read_particles(particle_frames(out).iloc[-1]["file"])


def run_status(out: Path) -> dict:
    """{"status", "error", "final_time_s"} of a run (run.json)."""
    data = read_run(out)
    return {
        "status": data.get("status", ""),
        "error": data.get("error", ""),
        "final_time_s": data.get("summary", {}).get("final_time_s"),
    }
