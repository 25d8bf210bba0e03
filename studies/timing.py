"""What each stage of a step costs, and what detection adds (thesis 5.2).

What it measures: the wall time per step of every stage of the explicit MPM step and of the
boundary detection, as the median and spread (min, max, interquartile range) of >= 5
repetitions, for N = 1k to 300k material points on 1 and 2 threads, per detector; the
detection / step ratio beside the thesis's 0.047 s / 0.048 s (its slope, 3368 points); and the
throughput in particle-steps per second.

Why: the thesis's claim is that PFM costs about one explicit step. Cost per step and its
scaling with N and threads decide whether detecting the boundary at every step is affordable.

Cases: a block of soil (4 points per cell, linear elastic, gravity, K0 start) sized to N points,
run for a fixed number of steps with a fixed dt, and the slope case (``cases/slope.json``, the
thesis-sized problem) for the headline numbers. Runs are never cached (every repetition is a
fresh process); Release build expected (provenance records the build type).

Reproduce: ``make study-timing`` = ``/usr/bin/python3 -m studies timing [--quick]``; writes
``stages.csv/.md`` (one row per N, threads, detector, stage), ``scaling.png``.
Needs ``run.json`` ``summary.stage_seconds`` and ``summary.n_steps`` from ``pfm-mpm run``.
"""

from __future__ import annotations

import math
import shutil

import numpy as np
import pandas as pd

from studies.common.cases import base_case, derive
from studies.common.outcome import Headline, Metric, StudyOutcome
from studies.common.outputs import read_summary
from studies.common.paths import tool_path
from studies.common.runner import run_mpm
from studies.common.tables import save_figure, write_table
from studies.report.headline import DETECTORS

PARTICLE_COUNTS = (1_000, 3_000, 10_000, 30_000, 100_000, 300_000)
THREADS = (1, 2)
REPETITIONS = 5
STEPS = 50
QUICK_PARTICLE_COUNTS = (1_000, 4_000)
QUICK_THREADS = (1,)
QUICK_STEPS = 10
# The N x threads sweep runs these two detectors only (the 30 min budget of `make study`);
# every detector is timed on the slope.
SWEEP_DETECTORS = ("pfm_thesis", "pfm_improved")
DETECT_STAGE = "detect"
THESIS_DETECT_S, THESIS_STEP_S = 0.047, 0.048
CELL_SIZE = 0.5  # m
POINTS_PER_CELL = 2  # 2 x 2 = 4 points per cell, as the thesis

EXPECTED_METRICS = ["timing.slope.pfm_improved.detect_to_step_ratio",
                    "timing.slope.pfm_thesis.detect_to_step_ratio",
                    "timing.block_100k.mpm_particle_steps_per_s"]


def block_case(n_particles: int, detector: str, steps: int) -> dict:
    """A soil block of ~n_particles points (4 per cell, aspect 3:1) with a 1-cell margin."""
    n_cells = max(1, round(n_particles / POINTS_PER_CELL ** 2))
    ny = max(1, round(math.sqrt(n_cells / 3.0)))
    nx = max(1, round(n_cells / ny))
    youngs, nu, gamma = 1.0e4, 0.3, 20.0
    modulus = youngs * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    dt = 0.5 * CELL_SIZE / math.sqrt(modulus / (gamma / 9.81))
    return {
        "title": f"timing block {nx} x {ny} cells",
        "grid": {"origin": [-CELL_SIZE, 0.0], "cell_size": CELL_SIZE, "n_cells": [nx + 2, ny + 2]},
        "materials": [{"name": "soil", "model": "linear_elastic", "youngs_modulus": youngs,
                       "poisson_ratio": nu, "unit_weight": gamma}],
        "bodies": [{"name": "block", "material": "soil", "points_per_cell": POINTS_PER_CELL,
                    "rectangle": [[0.0, 0.0], [nx * CELL_SIZE, ny * CELL_SIZE]]}],
        "initial_stress": {"method": "k0"},
        "boundary_conditions": [{"where": "bottom", "fix": "xy"}, {"where": "left", "fix": "x"},
                                {"where": "right", "fix": "x"}],
        "time": {"end_time": steps * dt, "dt": dt},
        "output": {"interval": steps * dt},
        "detection": {"method": detector},
    }


def timed_run(case: dict, threads: int) -> dict:
    """One fresh, uncached run; its run.json summary. The temporary folder is removed."""
    result = run_mpm(case, threads=threads, use_cache=False)
    try:
        return read_summary(result.out)
    finally:
        shutil.rmtree(result.folder, ignore_errors=True)


def stage_rows(summary: dict, label: dict) -> list[dict]:
    n_steps = int(summary["n_steps"])
    stages = dict(summary["stage_seconds"])
    step_total = sum(v for k, v in stages.items() if k != DETECT_STAGE)
    stages["mpm_step"] = step_total
    return [{**label, "stage": stage, "seconds_per_step": seconds / n_steps}
            for stage, seconds in stages.items()]


def summarise(raw: pd.DataFrame) -> pd.DataFrame:
    keys = [c for c in raw.columns if c not in ("repetition", "seconds_per_step")]
    grouped = raw.groupby(keys)["seconds_per_step"]
    table = grouped.agg(median="median", min="min", max="max",
                        q25=lambda s: s.quantile(0.25), q75=lambda s: s.quantile(0.75),
                        repetitions="count").reset_index()
    return table


def run(context) -> StudyOutcome:
    context.tools.append(tool_path("pfm-mpm"))
    quick = context.quick
    counts = QUICK_PARTICLE_COUNTS if quick else PARTICLE_COUNTS
    threads_list = QUICK_THREADS if quick else THREADS
    steps = QUICK_STEPS if quick else STEPS
    detectors = SWEEP_DETECTORS if quick else tuple(d for d, _ in DETECTORS)
    raw = []
    # Timing runs are serial on purpose: parallel runs would measure each other.
    for n in counts:
        for threads in threads_list:
            for detector in SWEEP_DETECTORS:
                for repetition in range(REPETITIONS):
                    summary = timed_run(block_case(n, detector, steps), threads)
                    raw += stage_rows(summary, {"case": "block", "n_particles": int(
                        summary.get("n_particles", n)), "threads": threads, "detector": detector,
                        "repetition": repetition})
    slope, slope_path = base_case("slope")
    context.case_files.append(slope_path)
    for detector in detectors:
        for repetition in range(REPETITIONS):
            case = derive(slope, {"detection": {"method": detector}})
            summary = timed_run(case, 1)
            raw += stage_rows(summary, {"case": "slope", "n_particles": int(
                summary.get("n_particles", 0)), "threads": 1, "detector": detector,
                "repetition": repetition})
    raw = pd.DataFrame(raw)
    raw.to_csv(context.folder / "raw_timings.csv", index=False)
    table = summarise(raw)
    outcome = StudyOutcome(study="timing")
    outcome.tables.append(write_table(context.folder, table, "stages",
                                      "Seconds per step, per stage (median of repetitions)"))
    ratios = []
    for (case, n, threads, detector), group in table.groupby(
            ["case", "n_particles", "threads", "detector"]):
        per_stage = dict(zip(group["stage"], group["median"]))
        detect, step = per_stage.get(DETECT_STAGE, np.nan), per_stage["mpm_step"]
        ratios.append({"case": case, "n_particles": n, "threads": threads, "detector": detector,
                       "detect_s": detect, "mpm_step_s": step, "detect_to_step_ratio":
                       detect / step, "mpm_particle_steps_per_s": n / step,
                       "total_particle_steps_per_s": n / (step + detect)})
    ratios = pd.DataFrame(ratios)
    detect_missing = ratios["detect_s"].isna().all()
    thesis = pd.DataFrame([{"case": "slope (thesis)", "n_particles": 3368, "threads": 1,
                            "detector": "pfm_thesis", "detect_s": THESIS_DETECT_S,
                            "mpm_step_s": THESIS_STEP_S, "detect_to_step_ratio":
                            THESIS_DETECT_S / THESIS_STEP_S, "mpm_particle_steps_per_s":
                            3368 / THESIS_STEP_S, "total_particle_steps_per_s":
                            3368 / (THESIS_STEP_S + THESIS_DETECT_S)}])
    outcome.tables.append(write_table(context.folder, pd.concat([thesis, ratios]), "ratios",
                                      "Detection against one MPM step; throughput"))
    for row in ratios[ratios["case"] == "slope"].itertuples(index=False):
        if detect_missing:
            note = f"not run: needs a '{DETECT_STAGE}' stage in run.json summary.stage_seconds"
            outcome.headline += [Headline("cost.detect_per_step", row.detector, None, "s", note),
                                 Headline("cost.detect_to_step_ratio", row.detector, None, "1",
                                          note)]
            continue
        outcome.metrics.append(Metric(f"timing.slope.{row.detector}.detect_to_step_ratio",
                                      row.detect_to_step_ratio, "1"))
        outcome.headline += [
            Headline("cost.detect_per_step", row.detector, row.detect_s, "s"),
            Headline("cost.detect_to_step_ratio", row.detector, row.detect_to_step_ratio, "1")]
    slope_steps = ratios[ratios["case"] == "slope"]["mpm_step_s"]
    if len(slope_steps):
        outcome.headline.append(Headline("cost.mpm_step", "*", float(slope_steps.median()), "s",
                                         "median over the detectors' runs"))
    big = ratios[(ratios["case"] == "block") & (ratios["threads"] == 1)]
    if len(big):
        row = big.loc[(big["n_particles"] - 100_000).abs().idxmin()]
        outcome.metrics.append(Metric("timing.block_100k.mpm_particle_steps_per_s",
                                      float(row["mpm_particle_steps_per_s"]), "1/s",
                                      f"N = {row['n_particles']}"))
    outcome.figures.append(save_figure(context.folder, scaling_figure(ratios), "scaling",
                                       "Seconds per step against N (block), per thread count"))
    if detect_missing:
        outcome.reason = (f"partly not run: detection cost needs a '{DETECT_STAGE}' stage in "
                          f"run.json summary.stage_seconds (MPM stages measured)")
    return outcome


def scaling_figure(ratios: pd.DataFrame):
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(7, 4.5))
    block = ratios[ratios["case"] == "block"]
    for threads, by_threads in block.groupby("threads"):
        first = by_threads[by_threads["detector"] == by_threads["detector"].iloc[0]]
        axis.loglog(first["n_particles"], first["mpm_step_s"], "k-o",
                    label=f"MPM step, {threads} thread(s)", alpha=0.5 + 0.25 * (threads - 1))
        for detector, group in by_threads.groupby("detector"):
            axis.loglog(group["n_particles"], group["detect_s"], "--.",
                        label=f"{detector}, {threads} thread(s)")
    axis.loglog([3368], [THESIS_STEP_S], "rs", label="thesis MPM step (0.048 s)")
    axis.loglog([3368], [THESIS_DETECT_S], "r^", label="thesis PFM (0.047 s)")
    axis.set_xlabel("material points N")
    axis.set_ylabel("seconds per step")
    axis.legend(fontsize=6)
    axis.grid(True, which="both", alpha=0.3)
    return figure
