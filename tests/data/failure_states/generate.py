"""Particle states of failing bodies for the detector's benchmark and tests (mpm/detect/README.md,
"Failure states"). Runs the built pfm-mpm on the thesis cases and keeps the particles at the
chosen times as ``<name>.csv`` with the columns of ``pfm-mpm detect`` (x, y, volume, F11, F12,
F21, F22) plus eps_p, 9 significant digits:

* ``bearing_<q>kPa_<start>_t<T>``: cases/thesis62_bearing_dynamic_zero_start.json with
  q = 100 and 150 kPa, zero and K0 initial stress, at T = 0.625, 1.25 and 2.5 s. These collapses
  fling points faster than the case's time step allows (CFL 0.5 stops them between 0.9 and
  1.9 s), so they run at time.cfl = 0.2;
* ``slope_runout_t2.5``: cases/thesis55_slope_dynamic_zero_start.json at 2.5 s;
* ``bearing_quasi_static_t5``: cases/bearing_quasi_static.json at 5 s with uGIMP and its load
  ramped over 3 s (the case as it was when the states were made).

    /usr/bin/python3 tests/data/failure_states/generate.py [--build build]

One run per case, one thread, outputs every 0.625 s: the states are deterministic (same build
type, same bits). Writes the CSV files beside this script, each atomically (a temporary file
renamed), and states.json: name, case, overrides, time, points, the case's grid and initial
spacing (what ``pfm-mpm detect`` needs to detect as the run did) and the git revision of the
pfm-mpm that made them. Takes about 10 minutes (the collapses detect every step).
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
COLUMNS = ("x", "y", "volume", "F11", "F12", "F21", "F22", "eps_p")
BEARING = "thesis62_bearing_dynamic_zero_start"
INTERVAL = 0.625


def runs() -> list[dict]:
    """name prefix, case, overrides, end time and the times kept."""
    out = []
    for q in (100, 150):
        for start in ("zero", "k0"):
            out.append(
                {
                    "prefix": f"bearing_{q}kPa_{start}",
                    "case": BEARING,
                    "overrides": {
                        "loads": {"0": {"pressure": float(q)}},
                        "initial_stress": {"method": start},
                        "time": {"cfl": 0.2},
                    },
                    "times": (0.625, 1.25, 2.5),
                }
            )
    out.append(
        {
            "prefix": "slope_runout",
            "case": "thesis55_slope_dynamic_zero_start",
            "overrides": {},
            "times": (2.5,),
        }
    )
    out.append(
        {
            "prefix": "bearing_quasi_static",
            "case": "bearing_quasi_static",
            "overrides": {
                "solver": {"shape_function": "gimp"},
                "loads": {"0": {"time_function": {"type": "ramp", "ramp_time": 3.0}}},
            },
            "times": (5.0,),
        }
    )
    return out


def derived(case: dict, overrides: dict, end: float) -> dict:
    case = copy.deepcopy(case)
    for key, value in overrides.items():
        if key == "loads":
            for index, load in value.items():
                case["loads"][int(index)].update(load)
        else:
            case.setdefault(key, {}).update(value)
    case["time"]["end_time"] = end
    case["output"] = {"interval": INTERVAL}
    return case


def write_atomically(path: Path, text: str):
    with tempfile.NamedTemporaryFile("w", dir=path.parent, delete=False) as stream:
        stream.write(text)
    os.replace(stream.name, path)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", type=Path, default=ROOT / "build")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from studies.common.outputs import read_index, read_particles

    executable = args.build / "bin" / "pfm-mpm"
    if not executable.is_file():
        print(f"generate: {executable} not built (make build)", file=sys.stderr)
        return 2
    revision = subprocess.run(
        ["git", "rev-parse", "--short=12", "HEAD"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    ).stdout.strip()
    index = []
    with tempfile.TemporaryDirectory() as scratch:
        for run in runs():
            case = json.loads((ROOT / "cases" / f"{run['case']}.json").read_text())
            case = derived(case, run["overrides"], max(run["times"]))
            case_file = Path(scratch) / f"{run['prefix']}.json"
            case_file.write_text(json.dumps(case, indent=1))
            out = Path(scratch) / run["prefix"]
            print(f"generate: {run['prefix']} to {max(run['times']):g} s", flush=True)
            command = [str(executable), "run", str(case_file), "--out", str(out)]
            done = subprocess.run(command + ["--quiet", "--threads", "1"])
            if done.returncode != 0:
                print(
                    f"generate: {run['prefix']}: pfm-mpm exit {done.returncode}",
                    file=sys.stderr,
                )
                return 1
            frames = read_index(out, "particles")
            body = case["bodies"][0]
            for time in run["times"]:
                row = frames.iloc[(frames["time"] - time).abs().argmin()]
                particles = read_particles(row["file"]).sort_values("id")
                name = f"{run['prefix']}_t{time:g}"
                write_atomically(
                    HERE / f"{name}.csv",
                    particles[list(COLUMNS)].to_csv(index=False, float_format="%.9g"),
                )
                index.append(
                    {
                        "name": name,
                        "case": run["case"],
                        "overrides": run["overrides"],
                        "time": float(row["time"]),
                        "points": len(particles),
                        "grid": case["grid"],
                        "initial_spacing": case["grid"]["cell_size"]
                        / body.get("points_per_cell", 2),
                        "pfm_mpm_revision": revision,
                    }
                )
    write_atomically(HERE / "states.json", json.dumps(index, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
