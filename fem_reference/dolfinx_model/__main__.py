"""CLI: /usr/bin/python3 -m fem_reference.dolfinx_model CASE.json --out DIR [--mode static|explicit] ..."""
from __future__ import annotations

import argparse
import json
import logging
import os
import sys


def ignored_keys(case, mode, driven=False):
    """Case keys this run does not use, each as "/json/pointer: reason". A static run with
    moving supports (`driven`) follows the case's time (end_time, the time functions).
    """
    out = list(case.ignored)
    if mode == "static":
        raw = case.raw
        why = "explicit mode only (the static run is quasi-static load control)"
        if driven:
            why = "explicit mode only (the static run is quasi-static)"
        for key in raw.get("time", {}):
            if not (driven and key == "end_time"):
                out.append(f"/time/{key}: {why}")
        if "damping" in raw.get("solver", {}):
            out.append(f"/solver/damping: {why}")
        if "ramp_time" in raw.get("gravity", {}):
            out.append(f"/gravity/ramp_time: {why}")
        for k, load in enumerate(raw.get("loads", [])):
            if "time_function" in load and not driven:
                out.append(f"/loads/{k}/time_function: {why}")
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="/usr/bin/python3 -m fem_reference.dolfinx_model",
        description="dolfinx reference model of a pfm-mpm case",
    )
    parser.add_argument("case", help="case JSON file (schema: README.md)")
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--mode", choices=("static", "explicit"), default="static")
    parser.add_argument(
        "--steps",
        type=int,
        default=10,
        help="static: load increments to full load, or with moving supports (displacement "
        "control) time increments to the end time",
    )
    parser.add_argument(
        "--collapse",
        action="store_true",
        help="static: keep increasing the load until Newton fails (collapse load)",
    )
    parser.add_argument(
        "--max-factor",
        type=float,
        default=10.0,
        help="collapse search: largest load multiplier tried",
    )
    parser.add_argument(
        "--min-step",
        type=float,
        default=1e-3,
        help="smallest load-factor increment before giving up",
    )
    parser.add_argument("--gravity-steps", type=int, default=1)
    parser.add_argument(
        "--initial-stress",
        choices=("zero", "k0", "gravity"),
        help="override the case's initial_stress.method",
    )
    parser.add_argument(
        "--degree",
        type=int,
        choices=(1, 2),
        help="displacement degree " "(static default 2, explicit default 1)",
    )
    parser.add_argument(
        "--element-size", type=float, help="mesh size (default: grid cell size)"
    )
    parser.add_argument(
        "--refine-size", type=float, help="finer mesh size at the load ends"
    )
    parser.add_argument(
        "--refine-distance", type=float, help="extent of the refinement (m)"
    )
    parser.add_argument(
        "--quads",
        action="store_true",
        help="quadrilateral mesh (gmsh recombination; Q2 / Q1 elements)",
    )
    parser.add_argument(
        "--updated-lagrangian",
        action="store_true",
        help="move the mesh with every converged increment (UL)",
    )
    parser.add_argument(
        "--kappa-measure",
        choices=("plastic_shear", "von_mises"),
        default="plastic_shear",
        help="softening variable (see material.py)",
    )
    parser.add_argument(
        "--end-time",
        type=float,
        help="explicit, or static with moving supports: override time.end_time",
    )
    parser.add_argument(
        "--snapshot-times",
        type=float,
        nargs="*",
        default=None,
        help="explicit: times of boundary CSVs (default 0.625 1.25 and the end)",
    )
    parser.add_argument(
        "--probe",
        action="append",
        default=[],
        metavar="NAME:X,Y",
        help="extra displacement probe at the nearest node, e.g. crest:12,10",
    )
    parser.add_argument("--no-fields", action="store_true", help="skip the XDMF fields")
    args = parser.parse_args(argv)
    logging.getLogger().setLevel(logging.WARNING)

    from .case import CaseError, read_case

    try:
        case = read_case(args.case)
    except CaseError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    from .analysis import (
        FieldWriter,
        refuse_moving_supports,
        run_driven,
        run_explicit,
        run_static,
        run_strength_reduction,
        write_boundary_csv,
        write_curve_csv,
        write_series_csv,
        write_table_csv,
    )
    from .model import Model, NoConvergence

    options = dict(
        element_size=args.element_size,
        refine_size=args.refine_size,
        refine_distance=args.refine_distance,
        quads=args.quads,
        updated_lagrangian=args.updated_lagrangian,
        kappa_measure=args.kappa_measure,
    )
    driven = any(bc.velocity is not None for bc in case.boundary_conditions)
    # The case's strength reduction (implicit.strength_reduction): the static run does it too.
    reduction = (case.raw.get("implicit") or {}).get("strength_reduction")
    try:  # before anything is written
        if reduction and (args.mode == "explicit" or args.collapse or driven):
            raise ValueError(
                f"{case.file}: /implicit/strength_reduction: the strength reduction runs in "
                "the static mode, without --collapse and without moving supports"
            )
        if args.mode == "explicit" or args.collapse:
            refuse_moving_supports(
                case, "explicit" if args.mode == "explicit" else "load control"
            )
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    degree = args.degree or (2 if args.mode == "static" else 1)
    model = Model(case, degree=degree, **options)
    for spec in args.probe:
        name, xy = spec.split(":")
        x, y = (float(v) for v in xy.split(","))
        model.add_probe(name, (x, y))
    os.makedirs(args.out, exist_ok=True)
    summary = {
        "case": os.path.abspath(args.case),
        "mode": args.mode,
        "degree": degree,
        "cells": int(model.n_cells),
        "options": options,
        "ignored": ignored_keys(case, args.mode, driven),
    }
    fields = (
        None
        if args.no_fields
        else FieldWriter(model, os.path.join(args.out, "fields.xdmf"))
    )
    if args.mode == "static":
        common = dict(
            steps=args.steps,
            min_step=args.min_step,
            initial_stress_method=args.initial_stress,
            gravity_steps=args.gravity_steps,
            model=model,
            on_step=(lambda m, x: fields.write(float(x))) if fields else None,
        )
        try:
            if driven:
                result = run_driven(case, end_time=args.end_time, **common)
            elif reduction:
                result = run_strength_reduction(
                    case, reduction["final_factor"], load_steps=args.steps, **common
                )
            else:
                result = run_static(
                    case,
                    collapse=args.collapse,
                    max_factor=args.max_factor,
                    **common,
                )
        except NoConvergence as err:
            if fields:
                fields.close()
            write_boundary_csv(
                model.boundary_loops(), os.path.join(args.out, "boundary.csv")
            )
            print(f"error: {err}", file=sys.stderr)
            return 4
    if args.mode == "static" and driven:
        write_table_csv(
            result.columns, result.series, os.path.join(args.out, "timeseries.csv")
        )
        summary.update(
            displacement_control=True,
            end_time=float(model.time),
            converged_to_end=result.converged_to_end,
            newton_iterations=result.newton_iterations,
            runtime_s=result.runtime,
        )
    elif args.mode == "static" and reduction:
        write_table_csv(
            ["strength_factor"]
            + [f"{name}_{axis}" for name in model.probes for axis in ("ux", "uy")],
            result.curve,
            os.path.join(args.out, "strength_reduction.csv"),
        )
        summary.update(
            strength_reduction=dict(
                last_converged_factor=result.last_converged_factor,
                failed_factor=result.failed_factor,
            ),
            newton_iterations=result.newton_iterations,
            runtime_s=result.runtime,
        )
    elif args.mode == "static":
        write_curve_csv(result.curve, os.path.join(args.out, "load_settlement.csv"))
        summary.update(
            initial_stress=result.initial_stress,
            collapse_load=result.collapse_load,
            converged_to_full_load=result.converged_to_full_load,
            newton_iterations=result.newton_iterations,
            runtime_s=result.runtime,
            final_settlement=result.curve[-1][1] if result.curve else None,
        )
    else:
        times = (
            args.snapshot_times if args.snapshot_times is not None else [0.625, 1.25]
        )
        end = args.end_time or case.end_time
        times = sorted({t for t in times if t <= end + 1e-12} | {end})
        result = run_explicit(
            case,
            end_time=end,
            initial_stress_method=args.initial_stress,
            snapshot_times=times,
            model=model,
        )
        write_series_csv(result.series, os.path.join(args.out, "timeseries.csv"))
        for t, loops in result.snapshots.items():
            write_boundary_csv(loops, os.path.join(args.out, f"boundary_t{t:.4f}.csv"))
        if fields:
            fields.write(end)
        summary.update(dt=result.dt, n_steps=result.n_steps, runtime_s=result.runtime)
    if fields:
        fields.close()
    write_boundary_csv(model.boundary_loops(), os.path.join(args.out, "boundary.csv"))
    summary["probes"] = {
        name: [float(v) for v in model.probe_displacement(name)]
        for name in model.probes
    }
    with open(os.path.join(args.out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    print(json.dumps(summary, indent=2))
    short = not summary.get("converged_to_end", True) or not summary.get(
        "converged_to_full_load", True
    )
    if args.mode == "static" and short:
        print(
            f"warning: Newton failed before the {'end time' if driven else 'full load'}; "
            "outputs hold the last converged state (exit code 3)",
            file=sys.stderr,
        )
        return 3
    return 0


if __name__ == "__main__":
    sys.exit(main())
