"""Closing figures of the reference FEM (issue 5): the three cross-code comparisons of
fem_reference/tests/test_cross_codes.py, run once more with their tables and plots.

Sample run (from the repository root, after `make build`; about 40 s):

    /usr/bin/python3 -m fem_reference.closing_figures --out results/fem_closing

Writes into OUT:
  figures.json                 every figure (units in the keys) with provenance (git revision,
                               UL-FEM command, date, runtimes)
  figures.csv                  quantity,ulfem,reference,relative_error,tolerance
  prandtl_load_settlement.png  strip-centre settlement against pressure: UL-FEM slow ramp,
                               dolfinx load control (P2, refined), Prandtl's (2 + pi) c
  slope_boundaries.png         deformed boundaries of the elastic slope, UL-FEM and dolfinx UL,
                               whole body and around the crest
  ulfem_*/                     the UL-FEM output directories
"""
from __future__ import annotations

import argparse
import csv
import datetime
import json
import logging
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from fem_reference.crosscheck import (
    DATA,
    PRANDTL,
    PRANDTL_DOLFINX_RUN,
    ROOT,
    boundary_distance,
    collapse_from_curve,
    mesh_history,
    missing_binary_message,
    nearest_node,
    ramp_pressure,
    read_boundary_csv,
    run_json,
    run_ulfem,
    ulfem_command,
)


def bearing_elastic(command, out: Path) -> dict:
    from fem_reference.dolfinx_model import read_case, run_static

    case = DATA / "bearing_block_elastic.json"
    run = run_ulfem(command, case, out / "ulfem_bearing_elastic")
    _, reference, disp = mesh_history(run)
    node = nearest_node(reference, (7.5, 5.0), tolerance=0.05)
    ulfem = float(-disp[-1][node, 1])
    result = run_static(read_case(case), steps=1, element_size=0.5)
    dolfinx = float(result.curve[-1][1])
    return {
        "ulfem_settlement_m": ulfem,
        "dolfinx_settlement_m": dolfinx,
        "relative_error": ulfem / dolfinx - 1,
        "tolerance": 0.02,
        "ulfem_wall_s": run_json(run)["summary"]["wall_time_s"],
        "dolfinx_runtime_s": result.runtime,
    }


def prandtl(command, out: Path) -> tuple[dict, dict]:
    from fem_reference.dolfinx_model import read_case, run_static

    case_path = DATA / "bearing_block_tresca_ramp.json"
    ramp_case = json.loads(case_path.read_text())
    run = run_ulfem(command, case_path, out / "ulfem_prandtl")
    times, reference, disp = mesh_history(run)
    node = nearest_node(reference, (7.5, 5.0))
    load = np.array([ramp_pressure(ramp_case, t) for t in times])
    settlement = np.array([-u[node, 1] for u in disp])
    collapse, initial = collapse_from_curve(load, settlement)
    # dolfinx: the procedure of test_dolfinx_model.py::test_bearing_block_tresca_collapse_load
    result = run_static(
        read_case(DATA / "bearing_block_tresca.json"), **PRANDTL_DOLFINX_RUN
    )
    curve = np.array(result.curve)
    figures = {
        "ulfem_collapse_kPa": collapse,
        "ulfem_relative_error": None if collapse is None else collapse / PRANDTL - 1,
        "ulfem_initial_stiffness_kPa_per_m": initial,
        "dolfinx_collapse_kPa": result.collapse_load,
        "dolfinx_relative_error": result.collapse_load / PRANDTL - 1,
        "prandtl_kPa": PRANDTL,
        "ulfem_tolerance": 0.05,
        "dolfinx_tolerance": 0.03,
        "ulfem_wall_s": run_json(run)["summary"]["wall_time_s"],
        "dolfinx_runtime_s": result.runtime,
    }
    curves = {"ulfem": (load, settlement), "dolfinx": (curve[:, 0], curve[:, 1])}
    return figures, curves


def slope(command, out: Path) -> tuple[dict, dict]:
    from fem_reference.dolfinx_model import (
        Model,
        read_case,
        run_static,
        write_boundary_csv,
    )

    case_path = DATA / "slope_elastic.json"
    run = run_ulfem(command, case_path, out / "ulfem_slope")
    _, reference, disp = mesh_history(run)
    crest_fem = disp[-1][nearest_node(reference, (14.125, 10.0))]
    fem_boundary = read_boundary_csv(run / run_json(run)["outputs"][-1]["boundary"])
    initial_boundary = read_boundary_csv(run / run_json(run)["outputs"][0]["boundary"])
    case = read_case(case_path)
    model = Model(case, element_size=0.5, updated_lagrangian=True)
    model.add_probe("crest", (14.125, 10.0))
    result = run_static(case, model=model, gravity_steps=10)
    crest_dolfinx = model.probe_displacement("crest")
    write_boundary_csv(model.boundary_loops(), out / "dolfinx_slope_boundary.csv")
    dolfinx_boundary = read_boundary_csv(out / "dolfinx_slope_boundary.csv")
    largest = float(np.linalg.norm(model.u.x.array.reshape(-1, 2), axis=1).max())
    distance, where = boundary_distance(fem_boundary, dolfinx_boundary)
    crest_error = np.linalg.norm(crest_fem - crest_dolfinx) / np.linalg.norm(
        crest_dolfinx
    )
    figures = {
        "ulfem_crest_m": [float(v) for v in crest_fem],
        "dolfinx_crest_m": [float(v) for v in crest_dolfinx],
        "crest_relative_error": float(crest_error),
        "crest_tolerance": 0.02,
        "boundary_distance_m": distance,
        "boundary_distance_where_m": [float(v) for v in where],
        "largest_displacement_m": largest,
        "boundary_relative": distance / largest,
        "boundary_tolerance": 0.01,
        "ulfem_wall_s": run_json(run)["summary"]["wall_time_s"],
        "dolfinx_runtime_s": result.runtime,
    }
    shapes = {
        "initial": initial_boundary,
        "ulfem": fem_boundary,
        "dolfinx": dolfinx_boundary,
    }
    return figures, shapes


def plot_prandtl(curves: dict, figures: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    load, settlement = curves["ulfem"]
    ax.plot(
        settlement, load, "-", lw=1.2, label="UL-FEM, Q4 0.5 m, slow ramp (explicit)"
    )
    load, settlement = curves["dolfinx"]
    ax.plot(
        settlement, load, "o-", ms=3, lw=1, label="dolfinx, P2 refined, load control"
    )
    ax.axhline(
        PRANDTL, color="k", ls="--", lw=0.8, label=f"(2 + pi) c = {PRANDTL:.1f} kPa"
    )
    if figures["ulfem_collapse_kPa"] is not None:
        ax.axhline(
            figures["ulfem_collapse_kPa"],
            color="C0",
            ls=":",
            lw=0.8,
            label=f"UL-FEM collapse {figures['ulfem_collapse_kPa']:.1f} kPa "
            f"({100 * figures['ulfem_relative_error']:+.1f} %)",
        )
    ax.set_xlabel("strip-centre settlement (m)")
    ax.set_ylabel("footing pressure (kPa)")
    ax.set_xlim(0, 0.3)
    ax.set_ylim(0, 120)
    ax.set_title("Weightless Tresca block, c = 20 kPa")
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)


def plot_slope(shapes: dict, figures: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [2, 1]}
    )
    for ax in axes:
        closed = {k: np.vstack([v, v[:1]]) for k, v in shapes.items()}
        ax.plot(*closed["initial"].T, color="0.7", lw=1, label="undeformed")
        ax.plot(*closed["ulfem"].T, "-", lw=1.2, label="UL-FEM (Q4 0.5 m, explicit)")
        ax.plot(
            *closed["dolfinx"].T, "--", lw=1.2, label="dolfinx UL (P2 0.5 m, static)"
        )
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    axes[0].legend(loc="lower right", fontsize=8)
    axes[0].set_title(
        f"Elastic slope under gravity: boundaries {1e3 * figures['boundary_distance_m']:.1f} mm "
        f"apart ({100 * figures['boundary_relative']:.2f} % of max |u|)",
        fontsize=9,
    )
    axes[1].set_xlim(12.5, 16.0)
    axes[1].set_ylim(8.5, 10.3)
    axes[1].set_title(
        f"crest: {100 * figures['crest_relative_error']:.2f} % apart", fontsize=9
    )
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)


def git_revision() -> str:
    done = subprocess.run(
        ["git", "rev-parse", "--short=12", "HEAD"],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    return done.stdout.strip() or "unknown"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="/usr/bin/python3 -m fem_reference.closing_figures"
    )
    parser.add_argument("--out", required=True, help="output directory (created)")
    args = parser.parse_args(argv)
    logging.getLogger().setLevel(logging.WARNING)
    command = ulfem_command()
    if command is None:
        print(f"closing_figures: {missing_binary_message()}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    bearing = bearing_elastic(command, out)
    collapse, curves = prandtl(command, out)
    slope_figures, shapes = slope(command, out)
    plot_prandtl(curves, collapse, out / "prandtl_load_settlement.png")
    plot_slope(shapes, slope_figures, out / "slope_boundaries.png")
    figures = {
        "provenance": {
            "git_revision": git_revision(),
            "ulfem_command": " ".join(command("CASE", "OUT")),
            "utc": datetime.datetime.now(datetime.timezone.utc).isoformat(
                timespec="seconds"
            ),
            "wall_s": time.perf_counter() - start,
        },
        "bearing_block_elastic": bearing,
        "prandtl": collapse,
        "slope_elastic": slope_figures,
    }
    (out / "figures.json").write_text(json.dumps(figures, indent=2) + "\n")
    rows = [
        ("bearing settlement (m)", bearing["ulfem_settlement_m"],
         bearing["dolfinx_settlement_m"], bearing["relative_error"], bearing["tolerance"]),
        ("Prandtl collapse, UL-FEM (kPa)", collapse["ulfem_collapse_kPa"], PRANDTL,
         collapse["ulfem_relative_error"], collapse["ulfem_tolerance"]),
        ("Prandtl collapse, dolfinx (kPa)", collapse["dolfinx_collapse_kPa"], PRANDTL,
         collapse["dolfinx_relative_error"], collapse["dolfinx_tolerance"]),
        ("slope crest |u| (m); error |du|/|u|", float(np.linalg.norm(slope_figures["ulfem_crest_m"])),
         float(np.linalg.norm(slope_figures["dolfinx_crest_m"])),
         slope_figures["crest_relative_error"], slope_figures["crest_tolerance"]),
        ("slope boundary distance (m)", slope_figures["boundary_distance_m"],
         slope_figures["largest_displacement_m"], slope_figures["boundary_relative"],
         slope_figures["boundary_tolerance"]),
    ]  # fmt: skip
    with open(out / "figures.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(
            ["quantity", "ulfem", "reference", "relative_error", "tolerance"]
        )
        for row in rows:
            writer.writerow(
                [row[0]] + [("" if v is None else f"{v:.6g}") for v in row[1:]]
            )
    for row in rows:
        error = "n/a" if row[3] is None else f"{100 * row[3]:+.2f} %"
        value = "none" if row[1] is None else f"{row[1]:.6g}"
        print(
            f"{row[0]:34s} {value:>12} vs {row[2]:.6g}: {error} (tolerance {row[4]:.0%})"
        )
    print(f"closing figures in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
