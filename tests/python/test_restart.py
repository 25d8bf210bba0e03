"""Checkpoint and restart (issue "Reliability", check 1).

A run of the bearing block with detection and traction on the detected boundary (load interval
carried by the material, so the coupling's state matters), and the quasi-static default case
(whose boundary is kept between detections while it hardly moves, detection.max_motion), are
killed with SIGKILL at a random step after their first checkpoint and continued with
``pfm-mpm run --restart``. The final state and every output must be bitwise identical to the
uninterrupted run's.
"""

import json
import random
import signal
import subprocess
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

# Not imported from conftest: with several test directories on one pytest command line, the
# module named "conftest" may be another directory's.
ROOT = Path(__file__).resolve().parents[2]


def short_bearing_block(tmp_path):
    case = json.loads(
        (ROOT / "cases" / "thesis62_bearing_dynamic_zero_start.json").read_text()
    )
    case["time"]["end_time"] = 1.5
    case["output"] = {
        "interval": 0.05,
        "timeseries_interval": 0.01,
        "nodal_loads": True,
        "vtk": True,
    }
    case["loads"][0]["interval"] = "material"
    case["loads"][0]["redistribute_lost_load"] = True
    case["detection"] = {"method": "improved", "every_steps": 3}
    path = tmp_path / "bearing_block_short.json"
    path.write_text(json.dumps(case))
    return path


def short_default_case(tmp_path):
    case = json.loads((ROOT / "cases" / "bearing_quasi_static.json").read_text())
    case["time"]["end_time"] = 1.5
    case["output"] = {"interval": 0.05, "timeseries_interval": 0.01, "vtk": True}
    path = tmp_path / "default_short.json"
    path.write_text(json.dumps(case))
    return path


def short_constraint_block(tmp_path):
    """The turned block under constraints on its detected faces, stopped during the ramp of the
    prescribed displacement (the constraints' prescribed displacement is in the checkpoint).
    """
    case = json.loads((ROOT / "cases" / "constraint_inclined_block.json").read_text())
    case["bodies"][0]["particles"] = str(
        ROOT / "cases" / case["bodies"][0]["particles"]
    )
    case["time"]["end_time"] = 0.08
    case["output"] = {"interval": 0.02, "timeseries_interval": 0.002}
    path = tmp_path / "constraint_block_short.json"
    path.write_text(json.dumps(case))
    return path


def h5_datasets(path):
    values = {}

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset):
            values[name] = np.asarray(obj[()])

    with h5py.File(path, "r") as f:
        f.visititems(visit)
    return values


def checkpoint_step(path):
    """The step of the checkpoint at `path`, or -1 while there is none (it is replaced by
    rename, so an opened file is always complete)."""
    try:
        with h5py.File(path, "r") as f:
            return int(f["n:solver|step"][0])
    except (FileNotFoundError, OSError):
        return -1


def assert_same_outputs(reference, restarted):
    text = (".csv", ".vtu", ".pvd")
    names = sorted(p.name for p in reference.iterdir() if p.suffix in text)
    assert names == sorted(p.name for p in restarted.iterdir() if p.suffix in text)
    for name in names:
        assert (reference / name).read_bytes() == (restarted / name).read_bytes(), name
    for h5 in ("particles.h5", "boundary.h5"):
        a, b = h5_datasets(reference / h5), h5_datasets(restarted / h5)
        assert sorted(a) == sorted(b), h5
        for name in a:
            assert a[name].tobytes() == b[name].tobytes(), f"{h5}:{name}"
    for xdmf in ("particles.xdmf", "boundary.xdmf"):
        assert (reference / xdmf).read_text() == (restarted / xdmf).read_text(), xdmf
    run_a = json.loads((reference / "run.json").read_text())
    run_b = json.loads((restarted / "run.json").read_text())
    assert run_a["outputs"] == run_b["outputs"]
    assert run_b["status"] == "completed" and len(run_b["restarts"]) == 1
    assert run_a["summary"]["n_steps"] == run_b["summary"]["n_steps"]


COMMON = ["--quiet", "--checkpoint-steps", "4"]


def run_reference(pfm_binary, case, reference):
    """The uninterrupted run; returns its number of steps."""
    subprocess.run(
        [pfm_binary, "run", case, "--out", reference, "--threads", "2", *COMMON],
        check=True,
        capture_output=True,
    )
    return json.loads((reference / "run.json").read_text())["summary"]["n_steps"]


def run_and_kill(pfm_binary, case, killed, n_steps):
    """Runs `case` into `killed` and kills it with SIGKILL at a random step (seeded:
    reproducible), as soon as the checkpoint of that step or a later one is on disk, at most a
    few steps later; returns the checkpoint's step."""
    target = random.Random(7).randrange(8, n_steps // 3)
    process = subprocess.Popen(
        [pfm_binary, "run", case, "--out", killed, "--threads", "1", *COMMON],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 300
    step = -1
    while step < target:
        assert (
            process.poll() is None
        ), f"run ended before step {target} was checkpointed"
        assert time.monotonic() < deadline
        step = checkpoint_step(killed / "checkpoint.h5")
        time.sleep(0.002)
    process.send_signal(signal.SIGKILL)
    assert (
        process.wait() == -signal.SIGKILL
    ), "the run finished before it could be killed"
    step = checkpoint_step(killed / "checkpoint.h5")
    assert target <= step < n_steps
    return step


def restart(pfm_binary, killed):
    subprocess.run(
        [pfm_binary, "run", "--restart", killed, "--threads", "2", "--quiet"],
        check=True,
        capture_output=True,
    )


@pytest.mark.parametrize(
    "build", [short_bearing_block, short_default_case, short_constraint_block]
)
def test_killed_run_restarts_bitwise(pfm_binary, tmp_path, build):
    case = build(tmp_path)
    reference, killed = tmp_path / "reference", tmp_path / "killed"
    n_steps = run_reference(pfm_binary, case, reference)
    step = run_and_kill(pfm_binary, case, killed, n_steps)

    restart(pfm_binary, killed)
    assert_same_outputs(reference, killed)
    # The restart kept the original run's checkpoint settings (every 4 steps): it went on
    # writing checkpoints past the one it started from.
    run = json.loads((killed / "run.json").read_text())
    settings = run["checkpoint"]
    assert settings["steps"] == 4
    if build is short_default_case:  # the boundary was kept through most steps
        assert run["summary"]["detection"]["kept_calls"] > run["summary"]["n_steps"] / 2
    assert checkpoint_step(killed / "checkpoint.h5") > step


def test_a_series_the_kill_damaged_is_rebuilt_from_the_checkpoint_copy(
    pfm_binary, tmp_path
):
    """HDF5 appends an output step by rewriting the file's metadata in place: a kill during that
    write can leave particles.h5 or boundary.h5 unreadable ("bad symbol table node signature",
    seen once in about 45 runs of the test above). Each checkpoint first copies both series
    (<name>.checkpoint); here both are cut to half their size after the kill, and the restart
    still gives every output bitwise as the uninterrupted run does."""
    case = short_bearing_block(tmp_path)
    reference, killed = tmp_path / "reference", tmp_path / "killed"
    n_steps = run_reference(pfm_binary, case, reference)
    run_and_kill(pfm_binary, case, killed, n_steps)
    for name in ("particles.h5", "boundary.h5"):
        assert (killed / f"{name}.checkpoint").is_file(), name
        data = (killed / name).read_bytes()
        (killed / name).write_bytes(data[: len(data) // 2])
        with pytest.raises(OSError):
            h5py.File(killed / name, "r")
    restart(pfm_binary, killed)
    assert_same_outputs(reference, killed)


def test_restart_without_checkpoint_is_an_input_error(pfm_binary, tmp_path):
    case = short_bearing_block(tmp_path)
    out = tmp_path / "complete"
    subprocess.run(
        [pfm_binary, "run", case, "--out", out, "--quiet"],
        check=True,
        capture_output=True,
    )
    done = subprocess.run(
        [pfm_binary, "run", "--restart", out], capture_output=True, text=True
    )
    assert done.returncode == 2 and "nothing to restart" in done.stderr
    missing = subprocess.run(
        [pfm_binary, "run", "--restart", tmp_path / "nowhere"],
        capture_output=True,
        text=True,
    )
    assert missing.returncode == 2 and "run.json" in missing.stderr
