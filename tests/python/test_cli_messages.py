"""What the command line tells its user: the version, and a summary line at the end of a run
(issue "Fits the tools its users already use", item 4)."""

import json
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_version_names_the_release_and_the_revision(pfm_binary):
    done = subprocess.run([pfm_binary, "--version"], capture_output=True, text=True)
    assert done.returncode == 0
    assert done.stdout.startswith("pfm-mpm 0.") and "(git " in done.stdout, done.stdout


def test_a_run_ends_with_a_summary_line(pfm_binary, tmp_path):
    case = json.loads((ROOT / "cases" / "column.json").read_text())
    case["time"]["end_time"] = 0.2
    path = tmp_path / "column.json"
    path.write_text(json.dumps(case))
    for solver in ("mpm", "ulfem"):
        out = tmp_path / solver
        done = subprocess.run(
            [pfm_binary, "run", path, "--out", out, "--solver", solver],
            capture_output=True,
            text=True,
        )
        assert done.returncode == 0, done.stderr
        last = done.stderr.strip().splitlines()[-1]
        steps = json.loads((out / "run.json").read_text())["summary"]["n_steps"]
        assert last.startswith(f"pfm-mpm: completed: {steps} steps to t = 0.2"), last
        assert last.endswith(f"results in {out}"), last
        quiet = subprocess.run(
            [pfm_binary, "run", path, "--out", out, "--solver", solver, "--quiet"],
            capture_output=True,
            text=True,
        )
        assert quiet.returncode == 0 and quiet.stderr == "", quiet.stderr


def test_the_example_detector_configuration_runs_and_missing_f_is_a_warning(
    pfm_binary, tmp_path
):
    particles = tmp_path / "particles.csv"
    rows = [
        f"{0.125 + 0.25 * i},{0.125 + 0.25 * j},0.0625"
        for i in range(8)
        for j in range(4)
    ]
    particles.write_text("x,y,volume\n" + "\n".join(rows) + "\n")
    out = tmp_path / "out"
    done = subprocess.run(
        [
            pfm_binary,
            "detect",
            particles,
            "--config",
            ROOT / "cases/detect/improved.json",
        ]
        + ["--out", out],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert "no F11..F22 columns" in done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["loops"] == 1 and len(summary["warnings"]) == 1
