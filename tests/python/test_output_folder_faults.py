"""Output folders that never lose user data, and write faults that are errors, not crashes
(issue "Outputs that survive", check 1; mpm/core/output_folder.hpp).

Every case asserts: no user file lost, no signal, the documented exit code (0 done, 2 refused,
4 a write failed), and run.json never left "running" by a handled failure.
"""

import json
import os
import shutil
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SHORT_END, LONG_END = (
    0.05,
    5.0,
)  # s of the default case: a few steps / about two seconds


def case_file(tmp_path, end_time):
    case = json.loads((ROOT / "cases" / "bearing_quasi_static.json").read_text())
    case["time"]["end_time"] = end_time
    case["output"]["interval"] = min(case["output"]["interval"], end_time / 2)
    path = tmp_path / f"case_{end_time:g}.json"
    path.write_text(json.dumps(case))
    return path


def run(binary, *arguments, cwd=None, timeout=120):
    done = subprocess.run(
        [binary, *map(str, arguments), "--quiet"],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=timeout,
    )
    assert done.returncode >= 0, f"killed by signal {-done.returncode}: {done.stderr}"
    return done


def status(folder):
    return json.loads((folder / "run.json").read_text())["status"]


def no_temporaries(folder):
    return not [
        p.name for p in folder.iterdir() if p.name.endswith((".tmp", ".rebuild"))
    ]


def test_a_folder_with_a_user_file_is_refused_and_overwrite_keeps_the_file(
    pfm_binary, tmp_path
):
    case = case_file(tmp_path, SHORT_END)
    out = tmp_path / "out"
    out.mkdir()
    (out / "my_case.json").write_text("mine")
    (out / "run.json").write_text("my own run.json, not a pfm-mpm one")
    done = run(pfm_binary, "run", case, "--out", out)
    assert done.returncode == 2 and "--overwrite" in done.stderr
    assert sorted(p.name for p in out.iterdir()) == ["my_case.json", "run.json"]
    assert (out / "run.json").read_text().startswith("my own")
    done = run(pfm_binary, "run", case, "--out", out, "--overwrite")
    assert done.returncode == 0, done.stderr
    assert (out / "my_case.json").read_text() == "mine" and status(out) == "completed"


def test_a_rerun_removes_only_its_own_earlier_files(pfm_binary, tmp_path):
    out = tmp_path / "out"
    assert (
        run(pfm_binary, "run", case_file(tmp_path, 0.2), "--out", out).returncode == 0
    )
    earlier = {p.name for p in out.iterdir()}
    assert (
        run(pfm_binary, "run", case_file(tmp_path, SHORT_END), "--out", out).returncode
        == 0
    )
    now = {p.name for p in out.iterdir()}
    assert earlier - now, "the longer run's later boundary files are gone"
    listed = set((out / ".pfm-mpm-files").read_text().split())
    assert now == listed | {".pfm-mpm-files", ".pfm-mpm.lock"}
    # A user file added afterwards stops the next rerun; --overwrite keeps it.
    (out / "notes.txt").write_text("keep")
    assert (
        run(pfm_binary, "run", case_file(tmp_path, SHORT_END), "--out", out).returncode
        == 2
    )
    assert (out / "notes.txt").read_text() == "keep"


def test_a_damaged_manifest_never_names_a_file_outside_the_folder(pfm_binary, tmp_path):
    out = tmp_path / "out"
    case = case_file(tmp_path, SHORT_END)
    assert run(pfm_binary, "run", case, "--out", out).returncode == 0
    outside = tmp_path / "outside.txt"
    outside.write_text("keep")
    with open(out / ".pfm-mpm-files", "a") as manifest:
        manifest.write(f"../outside.txt\n{outside}\n.\n..\n")
    assert run(pfm_binary, "run", case, "--out", out).returncode == 0
    assert outside.read_text() == "keep"


def test_a_listed_name_that_became_a_folder_is_never_removed(pfm_binary, tmp_path):
    out = tmp_path / "out"
    case = case_file(tmp_path, SHORT_END)
    assert run(pfm_binary, "run", case, "--out", out).returncode == 0
    (out / "timeseries.csv").unlink()
    (out / "timeseries.csv").mkdir()  # empty: fs::remove would take it
    done = run(pfm_binary, "run", case, "--out", out)
    assert done.returncode == 2 and "is a folder" in done.stderr, done.stderr
    assert (out / "timeseries.csv").is_dir()


def test_out_dot(pfm_binary, tmp_path):
    case = case_file(tmp_path, SHORT_END)
    here = tmp_path / "here"
    here.mkdir()
    assert run(pfm_binary, "run", case, "--out", ".", cwd=here).returncode == 0
    assert run(pfm_binary, "run", case, "--out", ".", cwd=here).returncode == 0
    (here / "mine.txt").write_text("keep")
    done = run(pfm_binary, "run", case, "--out", ".", cwd=here)
    assert done.returncode == 2 and "mine.txt" in done.stderr
    assert (here / "mine.txt").read_text() == "keep" and here.is_dir()


@pytest.mark.parametrize(
    "where,reason",
    [
        (lambda t: t / "afile" / "sub", "is not a folder"),
        (lambda t: t / ("n" * 300), "longer than 255"),
        (lambda t: t / "afile", "is not a folder"),
    ],
    ids=["file_as_parent", "name_too_long", "a_file"],
)
def test_impossible_folders_are_refused(pfm_binary, tmp_path, where, reason):
    (tmp_path / "afile").write_text("keep")
    done = run(
        pfm_binary, "run", case_file(tmp_path, SHORT_END), "--out", where(tmp_path)
    )
    assert done.returncode == 2 and reason in done.stderr, done.stderr
    assert (tmp_path / "afile").read_text() == "keep"


def wait_for_lock(folder, process, seconds=60):
    """Returns once the run in `process` holds the folder's lock (its pid is in the file)."""
    deadline = time.monotonic() + seconds
    lock = folder / ".pfm-mpm.lock"
    while time.monotonic() < deadline:
        assert process.poll() is None, "the first run ended before it could be joined"
        if lock.exists() and lock.read_text().strip() == str(process.pid):
            return
        time.sleep(0.005)
    raise AssertionError("the first run never took the lock")


def test_two_runs_on_one_folder(pfm_binary, tmp_path):
    case = case_file(tmp_path, LONG_END)
    out = tmp_path / "out"
    first = subprocess.Popen(
        [pfm_binary, "run", case, "--out", out, "--quiet"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    wait_for_lock(out, first)
    second = run(pfm_binary, "run", case, "--out", out)
    restart = run(pfm_binary, "run", "--restart", out)
    assert first.wait(timeout=300) == 0, first.stderr.read()
    for done in (second, restart):
        assert (
            done.returncode == 2 and f"process {first.pid}" in done.stderr
        ), done.stderr
    assert status(out) == "completed"
    outputs = json.loads((out / "run.json").read_text())["outputs"]
    for name in ["particles.h5", "final_particles.csv"] + [
        o["boundary"] for o in outputs
    ]:
        assert (out / name).is_file(), name


def start_twice(binary, *arguments):
    """Exit codes of two processes of the same command started together (sorted)."""
    processes = [
        subprocess.Popen(
            [binary, *map(str, arguments), "--quiet"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        for _ in range(2)
    ]
    codes = sorted(p.wait(timeout=300) for p in processes)
    assert codes == [0, 2], [p.stderr.read() for p in processes]


def mark_running(out):
    """run.json as a killed run leaves it."""
    text = json.loads((out / "run.json").read_text())
    text["status"] = "running"
    (out / "run.json").write_text(json.dumps(text))


def test_two_runs_started_together(pfm_binary, tmp_path):
    out = tmp_path / "out"
    # Long enough (about 2 s) that the second process reaches the lock while the first holds it.
    start_twice(pfm_binary, "run", case_file(tmp_path, LONG_END), "--out", out)
    assert status(out) == "completed" and no_temporaries(out)


def test_two_restarts_together(pfm_binary, tmp_path):
    """One restarts; the other finds the folder locked or, if it came late, the run completed:
    exit 2 either way."""
    out = tmp_path / "out"
    case = case_file(tmp_path, 1.0)
    done = run(pfm_binary, "run", case, "--out", out, "--checkpoint-steps", "50")
    assert done.returncode == 0
    reference = (out / "final_particles.csv").read_bytes()
    mark_running(out)
    start_twice(pfm_binary, "run", "--restart", out)
    assert (out / "final_particles.csv").read_bytes() == reference
    mark_running(out)  # the checkpoint still restarts
    assert run(pfm_binary, "run", "--restart", out).returncode == 0


def mount_tmpfs(folder, options):
    folder.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a small file system needs root")
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(folder)],
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount tmpfs here: {done.stderr.strip()}")


@pytest.fixture
def small_disks(tmp_path):
    mounted = []

    def make(name, options):
        folder = tmp_path / name
        mount_tmpfs(folder, options)
        mounted.append(folder)
        return folder

    yield make
    for folder in mounted:
        subprocess.run(["umount", str(folder)], check=False)


def test_a_read_only_file_system_is_a_write_fault(pfm_binary, tmp_path, small_disks):
    disk = small_disks("ro", "ro,size=1m")
    done = run(pfm_binary, "run", case_file(tmp_path, SHORT_END), "--out", disk / "out")
    assert done.returncode == 4, done.stderr
    assert "Read-only file system" in done.stderr and str(disk / "out") in done.stderr


@pytest.mark.parametrize("kilobytes", [64, 100, 200, 300, 500, 1000, 2000])
def test_a_full_disk_is_a_write_fault(pfm_binary, tmp_path, small_disks, kilobytes):
    disk = small_disks("disk", f"size={kilobytes}k")
    out = disk / "out"
    done = run(
        pfm_binary,
        "run",
        case_file(tmp_path, 1.0),
        "--out",
        out,
        "--checkpoint-steps",
        "20",
    )
    assert done.returncode == 4, done.stderr
    assert "No space left on device" in done.stderr and str(out) in done.stderr
    record = json.loads((out / "run.json").read_text())
    assert record["status"] == "failed" and "No space left" in record["error"]
    assert no_temporaries(out)


def test_a_run_stopped_by_a_full_disk_restarts_where_it_stopped(
    pfm_binary, tmp_path, small_disks
):
    case = case_file(tmp_path, 1.0)
    reference = tmp_path / "reference"
    assert run(pfm_binary, "run", case, "--out", reference).returncode == 0
    disk = small_disks("disk", "size=2000k")
    out = disk / "out"
    done = run(pfm_binary, "run", case, "--out", out, "--checkpoint-steps", "20")
    assert done.returncode == 4 and (out / "checkpoint.h5").is_file(), done.stderr
    subprocess.run(["mount", "-o", "remount,size=100m", str(disk)], check=True)
    done = run(pfm_binary, "run", "--restart", out)
    assert done.returncode == 0, done.stderr
    for name in ("final_particles.csv", "timeseries.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    shutil.rmtree(out)
