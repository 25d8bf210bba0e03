#!/usr/bin/python3
"""A stand-in for ``pfm-mpm`` (tests only) that writes the output layout the studies assume
(studies/common/outputs.py). Boundaries are the case outline moved up by a known amount: the
UL-FEM reference (``run --solver ulfem``) by 0, an MPM run by MPM_SHIFT, a ``detect``
call (on the reference's points, which are the outline's vertices in order) by DETECT_SHIFT,
so every distance the boundary study reports is known. Loaded runs report an applied force
2 % off the target and 3 % lost. Standard library + numpy + h5py only, to start fast."""

import argparse
import csv
import json
import pathlib
import sys

import h5py
import numpy as np

MPM_SHIFT = 0.1
DETECT_SHIFT = 0.05
APPLIED_ERROR = 0.02
LOST_FRACTION = 0.03


def outline_of(case):
    body = case["bodies"][0]
    if "rectangle" in body:
        (x0, y0), (x1, y1) = body["rectangle"]
        return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    return body["polygon"]


def write_loop(path, outline, shift):
    with open(path, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["loop", "x", "y"])
        writer.writerows([0, repr(x), repr(y + shift)] for x, y in outline)


def detect(args, out):
    config = json.loads(pathlib.Path(args.config).read_text())
    assert "method" in config and "grid" in config, config
    with open(args.input) as stream:
        points = [[float(row["x"]), float(row["y"])] for row in csv.DictReader(stream)]
    write_loop(out / "boundary.csv", points, DETECT_SHIFT)


def run(args, out):
    case = json.loads(pathlib.Path(args.input).read_text())
    reference = args.solver == "ulfem"
    assert (
        reference or "detection" in case
    ), "an MPM run of the studies detects its boundary"
    shift = 0.0 if reference else MPM_SHIFT
    outline = outline_of(case)
    end, interval = case["time"]["end_time"], case["output"]["interval"]
    outputs, grids = [], []
    with h5py.File(out / "particles.h5", "w") as h5:
        for i in range(int(round(end / interval)) + 1):
            time = i * interval * 1.0001  # outputs land just past the multiples
            step = 7 * i
            name = f"boundary_{step:08d}.csv"
            write_loop(out / name, outline, shift)
            outputs.append({"step": step, "time": time, "boundary": name})
            group = h5.create_group(f"step_{step:08d}")
            group.attrs["step"], group.attrs["time"] = float(step), time
            xy = np.array(outline, dtype=float)
            group["position"] = np.c_[xy, np.zeros(len(xy))]
            group["displacement"] = np.zeros((len(xy), 3))
            group["volume"] = np.full(len(xy), 0.0625)
            grids.append(
                f'<Grid Name="step_{step:08d}" GridType="Uniform">\n'
                f'<Time Value="{time!r}"/>\n</Grid>'
            )
    (out / "particles.xdmf").write_text(
        "<Xdmf><Domain>" + "\n".join(grids) + "</Domain></Xdmf>"
    )
    q = 0.0
    if case.get("loads"):
        load = case["loads"][0]
        q = load["pressure"] * (load["x_range"][1] - load["x_range"][0])
    with open(out / "timeseries.csv", "w") as stream:
        stream.write("time,load_target_fy,load_applied_fy,load_lost_fy\n")
        stream.write(f"0,{-q!r},{-q * (1 + APPLIED_ERROR)!r},0\n")
        stream.write(
            f"{end!r},{-q!r},{-q * (1 - APPLIED_ERROR / 2)!r},{-q * LOST_FRACTION!r}\n"
        )
    if "stop-early" in case.get("title", ""):  # a run that stops: exit code 3
        (out / "run.json").write_text(
            json.dumps(
                {
                    "status": "failed",
                    "error": "CFL violated",
                    "outputs": outputs[:1],
                    "summary": {"final_time_s": 0.01},
                }
            )
        )
        sys.stderr.write("pfm-mpm: simulation stopped: CFL violated\n")
        sys.exit(3)
    (out / "run.json").write_text(
        json.dumps(
            {
                "status": "completed",
                "outputs": outputs,
                "summary": {
                    "n_steps": 10,
                    "wall_time_s": 0.01,
                    "n_particles": len(outline),
                    "stage_seconds": {"stress": 0.01},
                    "detection": {"calls": 10, "seconds_per_call": 0.001},
                },
            }
        )
    )


def main(argv):
    parser = argparse.ArgumentParser()
    parser.add_argument("command", choices=["run", "detect"])
    parser.add_argument("input")
    parser.add_argument("--out", required=True)
    parser.add_argument("--threads", type=int)
    parser.add_argument("--config")
    parser.add_argument("--solver", choices=["mpm", "ulfem"], default="mpm")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True)
    (detect if args.command == "detect" else run)(args, out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
