"""``make run``: a strip load on a clay layer, applied on the boundary the detector finds, with
the MPM, the updated-Lagrangian FEM and dolfinx's static answer.

Runs ``CASE`` (default ``cases/bearing_quasi_static.json``: K0 start, the load ramped on the
detected boundary, damped to rest) to its end time with

* the MPM (the run of ``pfm-mpm run``, stepped from Python by ``pfm_mpm.Simulation`` with its
  progress shown), whose load acts on the boundary it detects every step;
* the updated-Lagrangian FEM (``pfm-mpm run --solver ulfem``): the same points, stresses and
  explicit step on a mesh that moves with the body, so its boundary is exact;
* the dolfinx model in static mode (``python -m fem_reference.dolfinx_model``): P2 triangles of
  half the grid's cell size, small strain, the load in ``REFERENCE_STEPS`` increments, Newton.

It compares the settlement of the surface under the load centre at the end (the MPM within
``SETTLEMENT_LIMITS["mpm"]`` and the UL-FEM within ``SETTLEMENT_LIMITS["ulfem"]`` of dolfinx),
whether both explicit runs came to rest (kinetic energy / external work at the end below
``REST_LIMIT``), whether any MPM point jitters in place (studies.common.measures.jitter_counts
between consecutive outputs: none may), and at every output the detected boundary against the UL-FEM's mesh boundary
(mean, RMS and max distance over the free surface, studies.boundary's measure).

Writes into ``OUT``: ``mpm/``, ``ulfem/``, ``dolfinx/`` (the three runs), ``case.json``,
``verdict.json`` (the figures and the checks), ``history.csv`` (settlement and boundary distance
at every output), ``report.md`` and ``index.html``, the figures ``load_settlement.png``,
``plastic_zone.png``, ``boundary_distance.png``, ``energy.png``, and ``provenance.json``.
Exit 0 when the runs completed (the verdict is in the report), 2 on bad input or a missing tool,
1 when a run failed.

    /usr/bin/python3 -m studies demo [--case cases/bearing_quasi_static.json]
                                     [--out results/bearing_quasi_static] [--end-time T]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import jinja2
import numpy as np
import pandas as pd
from tqdm import tqdm

from studies.boundary import EDGE_BAND_CELLS, TIME_TOLERANCE, regions_of
from studies.common.cases import cell_size, derive
from studies.common.ledger import plot_energy_ledger
from studies.common.measures import (
    JITTER_SPEED,
    JITTER_TRAVEL,
    jitter_counts,
    surface_settlement_extrapolated,
)
from studies.common.outputs import (
    final_particles,
    read_boundary,
    read_index,
    read_particles,
    read_summary,
    read_timeseries,
    row_at_time,
    run_status,
)
from studies.common.paths import PrerequisiteMissing, core, mpm_executable, repo_root
from studies.common.provenance import utc_now, write_provenance
from studies.common.runner import DOLFINX_MODULE
from studies.common.tables import format_value, markdown_table
from studies.metrics import (
    boundary_distance,
    grid_edge_band,
    supported_sides_band,
)
from studies.report.build import templates_dir

# Relative settlement error against dolfinx, and kinetic energy / external work at the end.
SETTLEMENT_LIMITS = {"mpm": 0.01, "ulfem": 0.02}
REST_LIMIT = 1e-4
REFERENCE_STEPS = 20
SOLVER_NAMES = {"mpm": "MPM (detected boundary)", "ulfem": "UL-FEM"}


class RunFailed(Exception):
    pass


def run_stepped(case_file: Path, out: Path) -> int:
    """The MPM run of `case_file` into `out` stepped from Python (pfm_mpm.Simulation: the run,
    and the files, of `pfm-mpm run`), its steps shown on stderr (redrawn on a terminal, every
    5 s in a pipe or a log). 0, or 3 when the simulation stopped (its run.json says why).
    """
    pfm_mpm = core()
    print(f"demo: pfm_mpm.Simulation({case_file}, out={out})", flush=True)
    try:
        with pfm_mpm.Simulation(case_file, out) as sim, tqdm(
            total=sim.n_steps,
            desc="demo: mpm steps",
            file=sys.stderr,
            mininterval=0.1 if sys.stderr.isatty() else 5.0,
            ascii=not sys.stderr.isatty(),
        ) as bar:
            while sim.stepping:
                bar.update(sim.step(max(1, sim.n_steps // 100)))
    except pfm_mpm.SimulationError as stopped:
        print(f"demo: the MPM run stopped: {stopped}", file=sys.stderr)
        return 3
    except (pfm_mpm.InputError, pfm_mpm.OutputError) as failed:
        raise RunFailed(f"mpm run failed: {failed}") from failed
    return 0


def run_explicit(case_file: Path, out: Path, solver: str) -> int:
    """The run of `case_file` into `out` by `solver` ("mpm": stepped from Python; "ulfem":
    `pfm-mpm run --solver ulfem`); 0, or 3 when the simulation stopped."""
    if solver == "mpm":
        return run_stepped(case_file, out)
    command = [
        str(mpm_executable()),
        "run",
        str(case_file),
        "--out",
        str(out),
        "--quiet",
        "--solver",
        solver,
    ]
    print(f"demo: {' '.join(command)}", flush=True)
    code = subprocess.run(command).returncode
    if code not in (0, 3):
        raise RunFailed(f"{solver} run failed with exit code {code}")
    return code


def run_reference(case_file: Path, out: Path, h: float) -> int:
    """dolfinx static run; exit 0 (full load), 3 (Newton failed first) or 4 (no initial
    equilibrium), see fem_reference/README.md."""
    command = [
        sys.executable,
        "-m",
        DOLFINX_MODULE,
        str(case_file),
        "--out",
        str(out),
        "--steps",
        str(REFERENCE_STEPS),
        "--element-size",
        f"{h / 2:g}",
        "--no-fields",
    ]
    print(f"demo: {' '.join(command)}", flush=True)
    done = subprocess.run(command, cwd=repo_root(), stdout=subprocess.DEVNULL)
    if done.returncode not in (0, 3, 4):
        raise RunFailed(f"dolfinx run failed with exit code {done.returncode}")
    return done.returncode


def load_factor(load: dict, time: float) -> float:
    """The load's time function at `time` (constant 1, or a linear ramp to 1)."""
    function = load.get("time_function", {"type": "constant"})
    if function.get("type") == "ramp":
        return min(time / function["ramp_time"], 1.0)
    return 1.0


def load_centre(case: dict) -> tuple[float, float]:
    """x of the first load's centre and the initial surface height (the body's top)."""
    load = case["loads"][0]
    body = case["bodies"][0]
    top = (
        body["rectangle"][1][1]
        if "rectangle" in body
        else max(y for _, y in body["polygon"])
    )
    return 0.5 * sum(load["x_range"]), top


def settlement(particles: pd.DataFrame, case: dict) -> float:
    x, top = load_centre(case)
    return surface_settlement_extrapolated(particles, x, top, cell_size(case))


def history(case: dict, mpm_out: Path, fem_out: Path) -> pd.DataFrame:
    """At every UL-FEM output: the load, the settlement of both solvers and the distance of
    the detected boundary to the UL-FEM boundary over the free surface."""
    h = cell_size(case)
    kind = "slope" if "polygon" in case["bodies"][0] else "block"
    regions = regions_of(case, kind, h)
    # Not the free surface: a block's walls and base (on the grid edges or inside a margin), a
    # slope's grid edges.
    if kind == "block":
        ignore = supported_sides_band(
            case["bodies"][0]["rectangle"], EDGE_BAND_CELLS * h
        )
    else:
        ignore = grid_edge_band(case["grid"], EDGE_BAND_CELLS * h)
    load = case["loads"][0]
    mpm_b, fem_b = read_index(mpm_out, "boundary"), read_index(fem_out, "boundary")
    particles = {
        s: read_index(o, "particles") for s, o in (("mpm", mpm_out), ("ulfem", fem_out))
    }
    rows = []
    for row in fem_b.itertuples(index=False):
        mine = row_at_time(mpm_b, row.time, TIME_TOLERANCE)
        if mine is None:
            continue
        distance = boundary_distance(
            read_boundary(mine["file"]),
            read_boundary(row.file),
            h=h,
            regions=regions,
            ignore=ignore,
        ).overall
        entry = {
            "time_s": row.time,
            "load_kPa": load["pressure"] * load_factor(load, row.time),
        }
        for solver, index in particles.items():
            frame = row_at_time(index, row.time, TIME_TOLERANCE)
            entry[f"settlement_{solver}_m"] = (
                settlement(read_particles(frame["file"]), case)
                if frame is not None
                else np.nan
            )
        entry.update(
            {
                "distance_mean_m": distance.mean,
                "distance_rms_m": distance.rms,
                "distance_max_m": distance.max,
            }
        )
        rows.append(entry)
    return pd.DataFrame(rows)


def verdict(case: dict, outs: dict, reference_code: int) -> dict:
    """The figures the page reports and the checks made on them."""
    load = case["loads"][0]
    result = {"load_kPa": load["pressure"], "reference": {"exit_code": reference_code}}
    curve = None
    if reference_code == 0:
        curve = pd.read_csv(outs["dolfinx"] / "load_settlement.csv")
        result["reference"]["settlement_m"] = float(curve["settlement"].iloc[-1])
    checks = []
    for solver in ("mpm", "ulfem"):
        series = read_timeseries(outs[solver])
        last = series.iloc[-1]
        entry = {
            "final_time_s": float(last["time"]),
            "settlement_m": settlement(final_particles(outs[solver]), case),
            "kinetic_over_external_work": float(
                last["kinetic_energy"] / abs(last["external_work"])
            ),
            "energy_error_relative": float(
                read_summary(outs[solver])["energy"]["relative_error"]
            ),
        }
        checks.append(
            {
                "what": f"{SOLVER_NAMES[solver]} at rest: kinetic energy / external work",
                "value": entry["kinetic_over_external_work"],
                "limit": REST_LIMIT,
                "passed": bool(entry["kinetic_over_external_work"] <= REST_LIMIT),
            }
        )
        if curve is not None:
            reference = result["reference"]["settlement_m"]
            entry["settlement_error_relative"] = entry["settlement_m"] / reference - 1.0
            checks.append(
                {
                    "what": f"{SOLVER_NAMES[solver]} settlement against dolfinx (relative)",
                    "value": entry["settlement_error_relative"],
                    "limit": SETTLEMENT_LIMITS[solver],
                    "passed": bool(
                        abs(entry["settlement_error_relative"])
                        <= SETTLEMENT_LIMITS[solver]
                    ),
                }
            )
        result[solver] = entry
    frames = read_index(outs["mpm"], "particles")
    counts = jitter_counts(
        [read_particles(f) for f in frames["file"]], list(frames["time"])
    )
    result["mpm"]["jitter_largest_count"] = max(counts, default=0)
    checks.append(
        {
            "what": f"MPM points faster than {JITTER_SPEED:g} m/s that move less than "
            f"{JITTER_TRAVEL:g} x speed x the interval between outputs (largest count)",
            "value": result["mpm"]["jitter_largest_count"],
            "limit": 0,
            "passed": result["mpm"]["jitter_largest_count"] == 0,
        }
    )
    result["checks"] = checks
    result["passed"] = bool(curve is not None and all(c["passed"] for c in checks))
    return result


def figures(case: dict, outs: dict, table: pd.DataFrame, out: Path) -> list:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    made = []

    def save(figure, name: str, title: str):
        figure.tight_layout()
        figure.savefig(out / name, dpi=110)
        plt.close(figure)
        made.append((name, title))

    figure, axis = plt.subplots(figsize=(6.5, 4.2))
    for solver, style in (("mpm", "o"), ("ulfem", "s")):
        axis.plot(
            table[f"settlement_{solver}_m"],
            table["load_kPa"],
            style,
            markersize=3,
            label=f"{SOLVER_NAMES[solver]}, at the outputs",
        )
    curve_file = outs["dolfinx"] / "load_settlement.csv"
    if curve_file.is_file():
        curve = pd.read_csv(curve_file)
        axis.plot(curve["settlement"], curve["load"], "k-", label="dolfinx P2, static")
    axis.set_xlabel("settlement under the load centre [m]")
    axis.set_ylabel("pressure q [kPa]")
    axis.legend(fontsize=8)
    save(figure, "load_settlement.png", "Load against settlement under the load centre")

    particles = final_particles(outs["mpm"])
    figure, axis = plt.subplots(figsize=(10, 4.2))
    points = axis.scatter(
        particles["x"], particles["y"], c=particles["eps_p"], s=6, cmap="viridis"
    )
    figure.colorbar(points, ax=axis, label="MPM equivalent plastic strain [-]")
    styles = [
        (
            "UL-FEM boundary",
            read_boundary_at_end(outs["ulfem"]),
            {"color": "black", "linewidth": 2},
        ),
        (
            "detected boundary (MPM)",
            read_boundary_at_end(outs["mpm"]),
            {"color": "tab:red", "linewidth": 1},
        ),
    ]
    for label, loops, style in styles:
        for i, loop in enumerate(loops):
            p = loop.drawn()
            axis.plot(p[:, 0], p[:, 1], label=label if i == 0 else None, **style)
    axis.set_aspect("equal")
    axis.set_xlabel("x [m]")
    axis.set_ylabel("y [m]")
    axis.set_title(f"t = {table['time_s'].iloc[-1]:.3g} s (true scale)", fontsize=9)
    axis.legend(fontsize=7, loc="lower left")
    save(figure, "plastic_zone.png", "Plastic zone and boundaries at the end")

    figure, axis = plt.subplots(figsize=(6.5, 3.8))
    for column, label in (
        ("distance_mean_m", "mean"),
        ("distance_rms_m", "RMS"),
        ("distance_max_m", "max"),
    ):
        axis.plot(table["time_s"], table[column], "o-", markersize=3, label=label)
    axis.set_xlabel("time t [s]")
    axis.set_ylabel("detected to UL-FEM boundary [m]")
    axis.legend(fontsize=8)
    save(
        figure, "boundary_distance.png", "Detected boundary against the UL-FEM boundary"
    )

    figure, axes = plt.subplots(1, 2, figsize=(12, 4.2), sharey=True)
    for axis, solver in zip(axes, ("mpm", "ulfem")):
        plot_energy_ledger(axis, read_timeseries(outs[solver]), SOLVER_NAMES[solver])
    save(figure, "energy.png", "Energy ledger of both explicit runs")
    return made


def read_boundary_at_end(out: Path):
    return read_boundary(read_index(out, "boundary").iloc[-1]["file"])


def describe(case: dict, result: dict, summary: dict) -> list:
    """The page's words: what is compared, then the verdict."""
    load = case["loads"][0]
    x0, x1 = load["x_range"]
    material = case["materials"][0]
    mpm, fem = result["mpm"], result["ulfem"]
    words = [
        f"A pressure q = {load['pressure']:g} kPa acts downwards on the surface between "
        f"x = {x0:g} and {x1:g} m of a {material['model']} soil "
        f"(E = {material['youngs_modulus']:g} kPa, nu = {material['poisson_ratio']:g}). "
        "The MPM applies it on the boundary it detects from its material points at every "
        "step; the UL-FEM, with the same points and explicit step on a mesh that moves with "
        "the body, applies it on its exact mesh boundary; dolfinx solves the static problem "
        f"with P2 triangles of {cell_size(case) / 2:g} m in {REFERENCE_STEPS} load steps "
        "(small strain).",
        "",
        f"Compared: the settlement of the surface under the load centre (x = "
        f"{0.5 * (x0 + x1):g} m) at the end, t = {mpm['final_time_s']:.3g} s; whether both "
        "explicit runs have come to rest; whether any MPM point oscillates in place (fast but "
        "not moving, between two outputs); and, at every output, the distance of the detected "
        "boundary to the UL-FEM boundary over the free surface.",
        "",
        f"MPM: {summary['n_particles']} points, {summary['n_steps']} steps, "
        f"{summary['wall_time_s']:.2f} s wall, detection "
        f"{summary.get('detection', {}).get('seconds_per_call', 0.0) * 1e3:.3g} ms per call. "
        f"Energy ledger closure (largest |error| / largest term): MPM "
        f"{mpm['energy_error_relative']:.2g}, UL-FEM {fem['energy_error_relative']:.2g}.",
        "",
    ]
    reference = result["reference"]
    if "settlement_m" in reference:
        words.append(
            f"**Settlement:** dolfinx {reference['settlement_m']:.5g} m, MPM "
            f"{mpm['settlement_m']:.5g} m ({100 * mpm['settlement_error_relative']:+.2f} %), "
            f"UL-FEM {fem['settlement_m']:.5g} m "
            f"({100 * fem['settlement_error_relative']:+.2f} %)."
        )
    else:
        words.append(
            f"**No static reference:** the dolfinx run stopped with exit code "
            f"{reference['exit_code']} (3: Newton failed before the full load, 4: no "
            f"equilibrium under gravity; fem_reference/README.md). Settlement: MPM "
            f"{mpm['settlement_m']:.5g} m, UL-FEM {fem['settlement_m']:.5g} m."
        )
    words.append("")
    for check in result["checks"]:
        mark = "PASS" if check["passed"] else "FAIL"
        words.append(
            f"- {mark}: {check['what']} = {format_value(check['value'])} "
            f"(limit {format_value(check['limit'])})"
        )
    words += [
        "",
        "**Verdict: "
        + (
            "the detected-boundary load gives the static answer within the limits.**"
            if result["passed"]
            else "not within the limits above.**"
        ),
    ]
    return words


def write_pages(case: dict, words: list, table: pd.DataFrame, made: list, out: Path):
    shown = table.iloc[:: max(1, len(table) // 10)]
    if shown.index[-1] != table.index[-1]:
        shown = pd.concat([shown, table.iloc[[-1]]])
    title = case.get("title", "pfm-mpm run")
    lines = [
        f"# {title}",
        "",
        "## What is compared, and the verdict",
        "",
        *words,
        "",
        "## Settlement and boundary distance at the outputs",
        "",
        "(every output in history.csv)",
        "",
        markdown_table(shown),
        "## Figures",
        "",
    ]
    lines += [f"![{t}]({f})" for f, t in made]
    (out / "report.md").write_text("\n".join(lines) + "\n")
    # index.html: the same words (paragraphs and lists), the table and the figures.
    blocks = []
    for line in words:
        text = line.replace("**", "")
        if line.startswith("- "):
            if not blocks or "entries" not in blocks[-1]:
                blocks.append({"entries": []})
            blocks[-1]["entries"].append(text[2:])
        elif line:
            blocks.append({"text": text})
    environment = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(templates_dir())),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    (out / "index.html").write_text(
        environment.get_template("demo.html.j2").render(
            title=title,
            blocks=blocks,
            table_html=shown.to_html(index=False, float_format=lambda v: f"{v:.4g}"),
            figures=[{"file": f, "title": t} for f, t in made],
        )
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m studies demo",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--case", type=Path, default=repo_root() / "cases" / "bearing_quasi_static.json"
    )
    parser.add_argument(
        "--out", type=Path, default=repo_root() / "results" / "bearing_quasi_static"
    )
    parser.add_argument(
        "--end-time", type=float, help="stop earlier than the case's end"
    )
    args = parser.parse_args(argv)
    started = utc_now()
    try:
        mpm_executable()
    except PrerequisiteMissing as missing:
        print(f"demo: needs {missing.needs}", file=sys.stderr)
        return 2
    try:
        case = json.loads(args.case.read_text())
    except (OSError, json.JSONDecodeError) as error:
        print(f"demo: {args.case}: {error}", file=sys.stderr)
        return 2
    if not case.get("loads"):
        print(
            f"demo: {args.case}: /loads: the demo needs a load (none given)",
            file=sys.stderr,
        )
        return 2
    if args.end_time is not None:
        case = derive(
            case, {"time": {"end_time": min(args.end_time, case["time"]["end_time"])}}
        )
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    case_file = out / "case.json"
    case_file.write_text(json.dumps(case, indent=2) + "\n")
    outs = {name: out / name for name in ("mpm", "ulfem", "dolfinx")}
    try:
        codes = {s: run_explicit(case_file, outs[s], s) for s in ("mpm", "ulfem")}
        reference_code = run_reference(case_file, outs["dolfinx"], cell_size(case))
    except RunFailed as failed:
        print(f"demo: {failed}", file=sys.stderr)
        return 1
    for solver, code in codes.items():
        if code != 0:
            status = run_status(outs[solver])
            print(
                f"demo: {solver} stopped at t = {status['final_time_s']:.4g} s: "
                f"{status['error']}",
                file=sys.stderr,
            )
            return 1
    table = history(case, outs["mpm"], outs["ulfem"])
    table.to_csv(out / "history.csv", index=False, float_format="%.10g")
    result = verdict(case, outs, reference_code)
    (out / "verdict.json").write_text(json.dumps(result, indent=2) + "\n")
    made = figures(case, outs, table, out)
    words = describe(case, result, read_summary(outs["mpm"]))
    write_pages(case, words, table, made, out)
    write_provenance(
        out,
        "demo",
        started,
        case_files=[args.case, case_file],
        tools=[mpm_executable()],
    )
    for line in words[-len(result["checks"]) - 2 :]:
        if line:
            print(f"demo: {line.replace('**', '')}")
    print(f"report: {out / 'report.md'} and {out / 'index.html'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
