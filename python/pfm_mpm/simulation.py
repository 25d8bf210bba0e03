"""A run of the explicit MPM driven from Python: ``Simulation`` (python/README.md).

The run is the one ``pfm-mpm run`` makes (mpm/solver/run.hpp, MpmRun): the same solver, detected
boundary, outputs and run.json, in the output folder given. Stepped to the case's end time it
writes the same files as ``pfm-mpm run CASE --out OUT`` (byte for byte, run.json aside, which
records the command and times); ended earlier by ``finish()``, the files of a run whose end
time is now.

    sim = Simulation("cases/bearing_quasi_static.json", out="results/py_run", threads=1)
    sim.step(100)
    x = sim.position            # (n, 2) view of the run's particle positions, m
    loops = sim.detect()        # [(points (m, 2), closed), ...]
    sim.finish()                # final_particles.csv, run.json

Particle arrays are numpy views of the run's own memory, valid for the run's life: position,
velocity, stress ((xx, yy, xy, zz), kPa, tension positive) and deformation_gradient
(F[p, i, j]) are writable between steps; reference_position, mass and volume are read-only.
Units: kN, m, s, t, kPa; plane strain.
"""

from __future__ import annotations

import json
import os
from typing import Optional, Union

import numpy as np

from pfm_mpm import _core

PathLike = Union[str, "os.PathLike[str]"]


def _field(name: str, writable: bool, doc: str) -> property:
    """A property giving a numpy view of the run's particle field `name` (read-only unless
    `writable`)."""

    def get(self) -> np.ndarray:
        view = self._run.field(name)
        if not writable:
            view.flags.writeable = False
        return view

    return property(get, doc=doc)


class Simulation:
    """The case (a path to a case file, or a dict as a case file holds it) run into ``out``.

    ``threads`` 0 uses every core; ``overwrite`` writes into a folder holding files that are not
    pfm-mpm's (they are kept); ``progress`` shows the progress line on stderr;
    ``checkpoint_steps`` / ``checkpoint_seconds`` as ``pfm-mpm run``'s options (a checkpoint a
    later ``pfm-mpm run --restart OUT`` continues). ``file`` names a dict case in messages; its
    folder resolves the relative paths of body files.

    Built, the run has begun: run.json, the initial stress and the first output are written.
    Bad input raises InputError (nothing created); a simulation that stops raises
    SimulationError after ending the run "failed" with its outputs so far; a failed write raises
    OutputError."""

    def __init__(
        self,
        case: Union[PathLike, dict],
        out: PathLike,
        *,
        threads: int = 0,
        overwrite: bool = False,
        progress: bool = False,
        checkpoint_steps: int = 0,
        checkpoint_seconds: float = 600.0,
        file: Optional[str] = None,
    ):
        if isinstance(case, dict):
            path, text, name = "", json.dumps(case), str(file or "<dict>")
        else:
            path, text, name = os.fspath(case), "", os.fspath(case)
        self.out = os.fspath(out)
        self._run = _core.Simulation(
            path,
            text,
            name,
            self.out,
            int(threads),
            bool(overwrite),
            bool(progress),
            int(checkpoint_steps),
            float(checkpoint_seconds),
        )
        self._status: Optional[int] = None

    # The run.
    def step(self, n: int = 1) -> int:
        """Takes up to ``n`` steps, fewer at the case's end time (whose step is written as the
        last: final outputs then need only finish()). Returns the steps taken."""
        return self._run.step(int(n))

    def run(self) -> int:
        """Steps to the case's end time and finishes; the exit status (0)."""
        self._run.step(self.n_steps)  # stops at the end time
        return self.finish()

    def finish(self) -> int:
        """Ends the run at the current step: its time-series row and output (unless it has
        them), final_particles.csv and run.json "completed". Returns the exit status of
        ``pfm-mpm run`` (0); later calls return it again and step() takes no more steps.
        """
        if self._status is None:
            self._status = self._run.finish()
        return self._status

    def close(self) -> None:
        """Finishes and lets the run go: the output folder's lock is released once no particle
        view is left."""
        self.finish()
        self._run.close()

    def __enter__(self) -> "Simulation":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # Its state.
    @property
    def time(self) -> float:
        """Simulated time, s."""
        return self._run.time

    @property
    def step_count(self) -> int:
        return self._run.step_count

    @property
    def dt(self) -> float:
        """Time step, s."""
        return self._run.dt

    @property
    def n_steps(self) -> int:
        """Steps to the case's end time."""
        return self._run.n_steps

    @property
    def stepping(self) -> bool:
        """Whether step() would take a step (the run is on and short of its end time)."""
        return self._status is None and self._run.stepping

    def detect(self) -> list:
        """The detected boundary of the points now: [(points (m, 2), closed), ...], material on
        the left, by the case's detection block (the improved detector when it has none). The
        detector starts from a state of its own, so the run's detections are not touched.
        """
        return self._run.detect()

    position = _field("position", True, "(n, 2) m, writable.")
    velocity = _field("velocity", True, "(n, 2) m/s, writable.")
    stress = _field(
        "stress", True, "(n, 4) kPa, (xx, yy, xy, zz), tension positive, writable."
    )
    deformation_gradient = _field(
        "deformation_gradient", True, "(n, 2, 2), F[p, i, j], writable."
    )
    reference_position = _field(
        "reference_position",
        False,
        "(n, 2) m where displacements are measured from, read-only.",
    )
    mass = _field("mass", False, "(n,) t, read-only.")
    volume = _field("volume", False, "(n,) m^2 per unit thickness, now, read-only.")
