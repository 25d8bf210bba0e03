"""A run driven from Python (pfm_mpm.Simulation, python/pfm_mpm/simulation.py): stepped a step
at a time, its particle arrays read and written between steps, it ends with the same output
files as `pfm-mpm run` of the same case for the same steps, byte for byte (run.json aside,
which records the command and times)."""

import json
import os
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("PFM_BUILD_DIR", ROOT / "build"))
sys.path.insert(0, str(BUILD / "python"))

pfm_mpm = pytest.importorskip("pfm_mpm", reason="build the module first: make build")

DEFAULT_CASE = ROOT / "cases" / "bearing_quasi_static.json"


def differing_files(first: Path, second: Path) -> list:
    """The files (by name) whose bytes differ or that only one folder has, run.json aside."""
    names = {p.name for p in first.iterdir()} | {p.name for p in second.iterdir()}
    return [
        name
        for name in sorted(names - {"run.json"})
        if not ((first / name).is_file() and (second / name).is_file())
        or (first / name).read_bytes() != (second / name).read_bytes()
    ]


def cli_run_of(case: dict, end_time: float, folder: Path, run_case) -> Path:
    """`pfm-mpm run` (one thread) of the case ending at end_time; its output folder."""
    case = json.loads(json.dumps(case))
    case["time"]["end_time"] = end_time
    done = run_case(case, folder, "--threads", "1")
    assert done.returncode == 0, done.stderr
    return folder / "out"


def test_a_hundred_steps_from_python_write_what_the_command_line_writes(
    tmp_path, run_case
):
    """The default case stepped 100 times from Python and finished there equals `pfm-mpm run`
    of the case ending after 100 steps: every output file, byte for byte; the positions read
    after the last step are final_particles.csv's, and the views are the run's memory.
    """
    case = json.loads(DEFAULT_CASE.read_text())
    out = tmp_path / "python"
    sim = pfm_mpm.Simulation(case, out, threads=1, file=str(DEFAULT_CASE))
    assert sim.step_count == 0 and sim.n_steps > 100
    position = sim.position
    start = position.copy()
    assert sim.step(60) == 60
    assert sim.step(40) == 40
    assert sim.step_count == 100
    assert sim.time == pytest.approx(100 * sim.dt, rel=1e-12)
    assert np.shares_memory(position, sim.position)  # a view: it moved with the run
    assert np.abs(position - start).max() > 0
    read = position.copy()
    assert sim.finish() == 0
    assert sim.finish() == 0 and sim.step(5) == 0  # ended: no more steps

    cli = cli_run_of(case, 100 * sim.dt, tmp_path / "cli", run_case)
    assert differing_files(out, cli) == []
    final = pd.read_csv(cli / "final_particles.csv", float_precision="round_trip")
    np.testing.assert_array_equal(read, final[["x", "y"]].to_numpy())
    run = json.loads((out / "run.json").read_text())
    assert run["status"] == "completed" and run["summary"]["n_steps"] == 100
    sim.close()


def test_run_to_the_end_time_writes_what_the_command_line_writes(tmp_path, run_case):
    """Simulation.run() to the case's end time (its last step written as the last) equals
    `pfm-mpm run` of the same case."""
    case = json.loads(DEFAULT_CASE.read_text())
    probe = pfm_mpm.Simulation(case, tmp_path / "probe", threads=1)
    end_time = 37 * probe.dt
    probe.close()
    case["time"]["end_time"] = end_time
    with pfm_mpm.Simulation(case, tmp_path / "python", threads=1) as sim:
        assert sim.run() == 0
        assert sim.step_count == 37 and not sim.stepping
    cli = cli_run_of(case, end_time, tmp_path / "cli", run_case)
    assert differing_files(tmp_path / "python", cli) == []


def test_written_arrays_drive_the_run_and_a_stop_ends_it_failed(tmp_path):
    """What Python writes into a view is the run's state: one point sent at 1e4 m/s makes
    the next steps invert it, which stops the run with SimulationError and run.json
    "failed" with the outputs so far, as `pfm-mpm run` ends such a run."""
    out = tmp_path / "out"
    sim = pfm_mpm.Simulation(DEFAULT_CASE, out, threads=1)
    sim.step(3)
    stress = sim.stress
    stress[0, 1] = -123.0
    assert sim.stress[0, 1] == -123.0  # a new view sees the write
    sim.velocity[0] = (1e4, -1e4)
    with pytest.raises(pfm_mpm.SimulationError):
        sim.step(50)
    run = json.loads((out / "run.json").read_text())
    assert run["status"] == "failed" and run["error"]
    assert sim.finish() == 3 and not sim.stepping
    assert (out / "particles.h5").is_file()


def test_read_only_fields_and_detection_leave_the_run_alone(tmp_path):
    """mass, volume and reference_position refuse writes; detect() finds the body's one loop
    around its points without changing the run: the next step's positions equal those of a
    run that never called it."""
    sims = [
        pfm_mpm.Simulation(DEFAULT_CASE, tmp_path / name, threads=1)
        for name in ("a", "b")
    ]
    for sim in sims:
        sim.step(20)
    with pytest.raises(ValueError):
        sims[0].mass[0] = 1.0
    loops = sims[0].detect()
    assert len(loops) == 1 and loops[0][1]
    points = loops[0][0]
    x = sims[0].position
    assert points[:, 0].min() <= x[:, 0].min() and points[:, 0].max() >= x[:, 0].max()
    assert points[:, 1].max() >= x[:, 1].max()
    for sim in sims:
        sim.step(20)
    np.testing.assert_array_equal(sims[0].position, sims[1].position)
    for sim in sims:
        sim.close()


def test_bad_cases_raise_input_error_and_create_nothing(tmp_path):
    case = json.loads(DEFAULT_CASE.read_text())
    case["grid"]["cell_size"] = -1.0
    with pytest.raises(pfm_mpm.InputError, match="cell_size"):
        pfm_mpm.Simulation(case, tmp_path / "out")
    assert not (tmp_path / "out").exists()
    with pytest.raises(pfm_mpm.InputError, match="step"):
        with pfm_mpm.Simulation(DEFAULT_CASE, tmp_path / "ok", threads=1) as sim:
            sim.step(-1)
