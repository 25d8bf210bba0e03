"""``make run``: the bearing block with boundary detection and traction, compared with the FEM.

Runs ``CASE`` (default ``cases/bearing_block.json``: q_v on the detected boundary, improved
detector every step) to ``--end-time`` (default 1.25 s, the thesis's last comparison time) with
the MPM and with the updated-Lagrangian FEM (``pfm-mpm run --solver ulfem``), then at every
output time compares the MPM's detected boundary with the FEM's exact mesh boundary (mean, RMS,
max over the free surface, studies.boundary's measure) and the settlement under the load
centre, and reads the traction diagnostics (applied against target force, force lost on nodes
of empty cells). Writes ``OUT/mpm/``, ``OUT/ulfem/`` (the solvers' outputs), and
``OUT/report.md``, ``OUT/index.html``, ``OUT/comparison.csv``, ``OUT/overlay.png``,
``OUT/comparison.png``; prints where the report is.

    /usr/bin/python3 -m studies demo [--case cases/bearing_block.json]
                                     [--out results/bearing_block] [--end-time 1.25]
"""

from __future__ import annotations

import argparse
import html
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from studies.boundary import (
    EDGE_BAND_CELLS,
    TIME_TOLERANCE,
    regions_of,
    traction_errors,
)
from studies.common.cases import cell_size, derive
from studies.common.measures import surface_settlement_extrapolated
from studies.common.outputs import (
    read_boundary,
    read_index,
    read_particles,
    read_summary,
    read_timeseries,
    row_at_time,
    run_status,
)
from studies.common.paths import PrerequisiteMissing, mpm_executable, repo_root
from studies.common.runner import mpm_has_solver_option, tool_path
from studies.common.tables import markdown_table
from studies.metrics import boundary_distance, grid_edge_band


def run_solver(case_file: Path, out: Path, solver: str) -> int:
    executable = mpm_executable()
    if solver == "ulfem" and not mpm_has_solver_option(executable):
        command = [str(tool_path("pfm-ulfem")), str(case_file), str(out)]
    else:
        command = [str(executable), "run", str(case_file), "--out", str(out), "--quiet"]
        if solver != "mpm":
            command += ["--solver", solver]
    print(f"demo: {' '.join(command)}", flush=True)
    done = subprocess.run(command)
    if done.returncode not in (0, 3):
        raise SystemExit(f"demo: {solver} run failed with exit code {done.returncode}")
    return done.returncode


def compare(case: dict, mpm_out: Path, fem_out: Path) -> pd.DataFrame:
    h = cell_size(case)
    kind = "slope" if "polygon" in case["bodies"][0] else "block"
    regions = regions_of(case, kind, h)
    ignore = grid_edge_band(case["grid"], EDGE_BAND_CELLS * h)
    load = case["loads"][0] if case.get("loads") else None
    mpm_b, fem_b = read_index(mpm_out, "boundary"), read_index(fem_out, "boundary")
    mpm_p, fem_p = read_index(mpm_out, "particles"), read_index(fem_out, "particles")
    rows = []
    for row in fem_b.itertuples(index=False):
        mine = row_at_time(mpm_b, row.time, TIME_TOLERANCE)
        if mine is None:
            continue
        result = boundary_distance(
            read_boundary(mine["file"]),
            read_boundary(row.file),
            h=h,
            regions=regions,
            ignore=ignore,
        )
        entry = {
            "time_s": row.time,
            "mean_m": result.overall.mean,
            "rms_m": result.overall.rms,
            "max_m": result.overall.max,
        }
        if "loaded_strip" in result.regions:
            entry["loaded_strip_max_m"] = result.regions["loaded_strip"].max
        if load is not None and kind == "block":
            x = 0.5 * sum(load["x_range"])
            top = case["bodies"][0]["rectangle"][1][1]
            for name, index in (("mpm", mpm_p), ("fem", fem_p)):
                frame = row_at_time(index, row.time, TIME_TOLERANCE)
                entry[f"settlement_{name}_m"] = settlement(frame, x, top, h)
        rows.append(entry)
    return pd.DataFrame(rows)


def settlement(frame, x: float, top: float, h: float) -> float:
    """Surface settlement at x from a particle output row (NaN without points there)."""
    if frame is None:
        return np.nan
    try:
        return surface_settlement_extrapolated(read_particles(frame["file"]), x, top, h)
    except ValueError:
        return np.nan


def figures(case, mpm_out: Path, fem_out: Path, table: pd.DataFrame, out: Path) -> list:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    made = []
    times = list(table["time_s"])
    chosen = [times[0], times[len(times) // 2], times[-1]] if len(times) >= 3 else times
    figure, axes = plt.subplots(
        len(chosen), 1, figsize=(9, 2.6 * len(chosen)), squeeze=False
    )
    for axis, time in zip(axes[:, 0], chosen):
        for label, run, style in (
            ("UL-FEM", fem_out, {"color": "black", "linewidth": 2}),
            ("MPM (detected)", mpm_out, {"color": "tab:red", "linewidth": 1}),
        ):
            row = row_at_time(read_index(run, "boundary"), time, TIME_TOLERANCE)
            for i, loop in enumerate(read_boundary(row["file"])):
                p = (
                    np.vstack([loop.points, loop.points[:1]])
                    if loop.closed
                    else loop.points
                )
                axis.plot(p[:, 0], p[:, 1], label=label if i == 0 else None, **style)
        axis.set_aspect("equal")
        axis.set_title(f"t = {time:.3g} s", fontsize=9)
        axis.legend(fontsize=7, loc="lower left")
    figure.tight_layout()
    figure.savefig(out / "overlay.png", dpi=100)
    plt.close(figure)
    made.append(("overlay.png", "Detected (MPM) and exact (UL-FEM) boundaries"))
    figure, axis = plt.subplots(figsize=(6, 3.5))
    for column in ("mean_m", "rms_m", "max_m"):
        axis.plot(table["time_s"], table[column], "o-", label=column)
    axis.set_xlabel("t [s]")
    axis.set_ylabel("distance to the UL-FEM boundary [m]")
    axis.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(out / "comparison.png", dpi=100)
    plt.close(figure)
    made.append(("comparison.png", "Boundary distance against time"))
    return made


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m studies demo",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--case", type=Path, default=repo_root() / "cases" / "bearing_block.json"
    )
    parser.add_argument(
        "--out", type=Path, default=repo_root() / "results" / "bearing_block"
    )
    parser.add_argument("--end-time", type=float, default=1.25)
    args = parser.parse_args(argv)
    try:
        mpm_executable()
    except PrerequisiteMissing as missing:
        print(f"demo: needs {missing.needs}", file=sys.stderr)
        return 2
    case = json.loads(args.case.read_text())
    case = derive(
        case, {"time": {"end_time": min(args.end_time, case["time"]["end_time"])}}
    )
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    case_file = out / "case.json"
    case_file.write_text(json.dumps(case, indent=2) + "\n")
    codes = {s: run_solver(case_file, out / s, s) for s in ("mpm", "ulfem")}
    table = compare(case, out / "mpm", out / "ulfem")
    table.to_csv(out / "comparison.csv", index=False, float_format="%.10g")
    made = figures(case, out / "mpm", out / "ulfem", table, out)
    summary = read_summary(out / "mpm")
    detection = summary.get("detection", {})
    lines = [
        f"# {case.get('title', args.case.name)}",
        "",
        f"Case `{args.case}` to t = {case['time']['end_time']:g} s. MPM: "
        f"{summary['n_particles']} points, {summary['n_steps']} steps, "
        f"{summary['wall_time_s']:.2f} s wall; detection {detection.get('calls', 0)} calls, "
        f"{detection.get('seconds_per_call', 0.0):.4f} s per call.",
        "",
    ]
    for solver, code in codes.items():
        if code != 0:
            status = run_status(out / solver)
            lines.append(
                f"**{solver} stopped at t = {status['final_time_s']:.4g} s:** "
                f"{status['error']}"
            )
    lines += [
        "",
        "## Detected boundary (MPM) against the exact UL-FEM boundary",
        "",
        "Free surface only (the boundary within 1.5 h of the grid edges is left out).",
        "",
        markdown_table(table),
    ]
    if case.get("loads"):
        series = read_timeseries(out / "mpm")
        errors = traction_errors(series, case["loads"][0])
        lines += [
            "## Traction on the detected boundary",
            "",
            markdown_table(pd.DataFrame([errors])),
        ]
    lines += ["## Figures", ""] + [f"![{t}]({f})" for f, t in made]
    (out / "report.md").write_text("\n".join(lines) + "\n")
    body = [
        "<h1>" + html.escape(lines[0][2:]) + "</h1>",
        "<p>" + html.escape(lines[2]) + "</p>",
        "<h2>Detected boundary (MPM) against the exact UL-FEM boundary</h2>",
        table.to_html(index=False, float_format=lambda v: f"{v:.4g}"),
    ]
    if case.get("loads"):
        body += [
            "<h2>Traction on the detected boundary</h2>",
            pd.DataFrame([errors]).to_html(
                index=False, float_format=lambda v: f"{v:.4g}"
            ),
        ]
    body += [f'<h3>{html.escape(t)}</h3><img src="{f}">' for f, t in made]
    (out / "index.html").write_text(
        "<!doctype html><html><head><meta charset='utf-8'>"
        "<title>pfm-mpm run</title></head><body>" + "\n".join(body) + "</body></html>\n"
    )
    last = table.iloc[-1]
    print(
        f"demo: at t = {last['time_s']:.3g} s the detected boundary is {last['mean_m']:.3g} m "
        f"(mean) / {last['max_m']:.3g} m (max) from the UL-FEM boundary"
    )
    print(f"report: {out / 'report.md'} and {out / 'index.html'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
