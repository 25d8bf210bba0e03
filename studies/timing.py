"""What each stage of a step costs, and what detection adds (thesis 5.2).

What it measures: the wall time per step of every stage of the explicit MPM step (run.json
``summary.stage_seconds``: locate, particles_to_grid, external_forces, update_grid,
grid_to_particles, remap, stress) and of the boundary stages (detect, bezier, traction), as
the median and spread (min, max, quartiles) of 5 repetitions, for N = 1k to 300k material
points on 1 and 2 threads; the detection cost per call (``summary.detection``) against one
MPM step beside the thesis's 0.047 s / 0.048 s (its slope, 3368 points), for every detector on
the slope; the throughput in particle-steps per second.

Cases: a block of soil (4 points per cell, linear elastic, gravity, K0 start, h = 0.5 m)
sized to N points, run for a fixed number of steps with a fixed dt (about 3e6 particle-steps
per run, at least 10 and at most 100 steps) with the improved detector every step, and the slope
(``cases/thesis55_slope_dynamic_zero_start.json``, the thesis-sized problem, K0 start, 0.5 s =
54 steps) with each detector, and from zero stress (``slope_zero``, the thesis's start) with the
thesis PFM plain and as run and the improved PFM. The slope
is also timed through its failure and run-out (``slope_runout``: 2.5 s = 270 steps, the boundary
study's last time, improved and thesis PFM): the body then lies spread and sheared, its points
no longer 2 x 2 per cell, and both the step (plastic points) and the detection (a wider band)
cost more than in the first 0.5 s. Every detector is also timed on each particle state of
tests/data/failure_states (the thesis bearing block collapsing at 100 and 150 kPa, the slope's
run-out, the quasi-static default case; issue 19): one ``pfm-mpm detect`` call per process, the
sum of its summary.json timings, against one MPM step of the state's case (0.5 s from its start,
without its loads on the detected boundary). Runs are
never cached (every repetition is a fresh process) and run one at a time (parallel runs would
time each other). The library baseline (scikit-image) does not run inside pfm-mpm: its cost is
the ``summary.json`` timing of ``studies.detectors.skimage_detector`` on the slope's points.
Release build expected (provenance records the build type).

Why: the thesis's claim is that PFM costs about one explicit step. Cost per step and its
scaling with N and threads decide whether detecting the boundary at every step is affordable.

Reproduce: ``make study-timing`` = ``/usr/bin/python3 -m studies timing [--quick]``
(quick: N = 1k and 4k, 1 thread, 10 steps; slope with the thesis and improved PFM). Writes
``stages.csv/.md`` (one row per case, N, threads, detector, stage), ``ratios.csv/.md``
(detection per call, MPM step, their ratio, particle-steps per second),
``failure_states.csv/.md`` (per state and detector: detection per call, the case's step, their
ratio; quick: two states, the improved detector), ``raw_timings.csv`` and ``scaling.png``.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd

from studies.common import detectors as det
from studies.common.cases import base_case, derive
from studies.common.outcome import Headline, Metric, StudyOutcome
from studies.common.outputs import final_particles, read_summary, write_detect_input
from studies.common.paths import PrerequisiteMissing, repo_root, tool_path
from studies.common.runner import RunFailed, run_detect, run_mpm
from studies.common.study import missing_reason
from studies.common.tables import save_figure, write_table
from studies.report.headline import DETECTORS

PARTICLE_COUNTS = (1_000, 3_000, 10_000, 30_000, 100_000, 300_000)
THREADS = (1, 2)
REPETITIONS = 5
PARTICLE_STEPS_PER_RUN = 3.0e6
MIN_STEPS, MAX_STEPS = 10, 100
QUICK_PARTICLE_COUNTS = (1_000, 4_000)
QUICK_THREADS = (1,)
QUICK_STEPS = 10
SWEEP_DETECTOR = "pfm_improved"
QUICK_SLOPE_DETECTORS = ("pfm_thesis", "pfm_improved")
SLOPE_END_TIME = 0.5  # s: 54 steps of the slope
QUICK_SLOPE_END_TIME = 0.1  # s: 11 steps
RUNOUT_END_TIME = 2.5  # s: 270 steps of the slope, through its failure
RUNOUT_DETECTORS = ("pfm_improved", "pfm_thesis")
# The slope from zero stress (the thesis's start), beside the K0 start of every detector.
ZERO_START_DETECTORS = ("pfm_thesis", "pfm_thesis_final", "pfm_improved")
QUICK_RUNOUT_DETECTORS = ("pfm_improved",)
# The particle states of failing bodies (tests/data/failure_states, issue 19): every detector
# times one call on each through ``pfm-mpm detect`` (a fresh process per call), against one MPM
# step of the state's case at its start (elastic; a plastic step of the state costs up to
# twice as much). Quick: two states, the improved detector, one call.
FAILURE_STATES_FOLDER = ("tests", "data", "failure_states")
QUICK_FAILURE_STATES = ("bearing_150kPa_k0_t2.5", "bearing_quasi_static_t5")
QUICK_FAILURE_DETECTORS = ("pfm_improved",)
FAILURE_STEP_TIME = 0.5  # s of each case run for its MPM step (about 120-170 steps)
BOUNDARY_STAGES = ("detect", "bezier", "traction")
THESIS_DETECT_S, THESIS_STEP_S, THESIS_POINTS = 0.047, 0.048, 3368
CELL_SIZE = 0.5  # m
POINTS_PER_CELL = 2  # 2 x 2 = 4 points per cell, as the thesis

EXPECTED_METRICS = [
    "timing.slope.pfm_improved.detect_to_step_ratio",
    "timing.slope.pfm_thesis.detect_to_step_ratio",
    "timing.slope_runout.pfm_improved.detect_to_step_ratio",
    "timing.block_200k.pfm_improved.detect_to_step_ratio",
    "timing.block_100k.mpm_particle_steps_per_s",
]


def steps_for(n_particles: int) -> int:
    return int(
        min(MAX_STEPS, max(MIN_STEPS, round(PARTICLE_STEPS_PER_RUN / n_particles)))
    )


def block_case(n_particles: int, detector, steps: int) -> dict:
    """A soil block of ~n_particles points (4 per cell, aspect 3:1) with a 1-cell margin."""
    n_cells = max(1, round(n_particles / POINTS_PER_CELL**2))
    ny = max(1, round(math.sqrt(n_cells / 3.0)))
    nx = max(1, round(n_cells / ny))
    youngs, nu, gamma = 1.0e4, 0.3, 20.0
    modulus = youngs * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    dt = 0.45 * CELL_SIZE / math.sqrt(modulus / (gamma / 9.81))  # 90 % of the CFL limit
    case = {
        "title": f"timing block {nx} x {ny} cells",
        "grid": {
            "origin": [-CELL_SIZE, 0.0],
            "cell_size": CELL_SIZE,
            "n_cells": [nx + 2, ny + 2],
        },
        "materials": [
            {
                "name": "soil",
                "model": "linear_elastic",
                "youngs_modulus": youngs,
                "poisson_ratio": nu,
                "unit_weight": gamma,
            }
        ],
        "bodies": [
            {
                "name": "block",
                "material": "soil",
                "points_per_cell": POINTS_PER_CELL,
                "rectangle": [[0.0, 0.0], [nx * CELL_SIZE, ny * CELL_SIZE]],
            }
        ],
        "initial_stress": {"method": "k0"},
        "boundary_conditions": [
            {"where": "bottom", "fix": "xy"},
            {"where": "left", "fix": "x"},
            {"where": "right", "fix": "x"},
        ],
        "time": {"end_time": steps * dt, "dt": dt},
        "output": {"interval": steps * dt, "timeseries_interval": steps * dt},
    }
    if detector is not None:
        case["detection"] = det.detection_block(detector)
    return case


def timed_run(case: dict, threads: int) -> dict:
    """One fresh, uncached run; its run.json summary. The temporary folder is removed."""
    result = run_mpm(case, threads=threads, use_cache=False)
    try:
        return read_summary(result.out)
    finally:
        shutil.rmtree(result.folder, ignore_errors=True)


def stage_rows(summary: dict, label: dict) -> list[dict]:
    """Seconds per step of every stage, plus ``mpm_step`` (the MPM stages without the boundary
    stages) and ``detect_per_call`` (summary.detection, when the run detected).

    The boundary stages of the steps (detect, bezier, traction) run inside the
    ``external_forces`` stage (its hook); the detections for the output at step 0 and for output
    steps between two detection steps run outside the step. So ``external_forces`` loses the
    in-step share of the boundary stages, estimated as their total times the fraction
    ceil(n_steps / every_steps) / calls of the detection calls made inside the steps; the
    result, ``external_forces_mpm``, is what the step costs without a detected boundary.
    """
    n_steps = int(summary["n_steps"])
    stage_seconds = dict(summary["stage_seconds"])
    detection = summary.get("detection") or {}
    boundary = sum(stage_seconds.get(k, 0.0) for k in BOUNDARY_STAGES)
    if boundary > 0.0 and detection.get("calls"):
        every = int(detection.get("every_steps", 1) or 1)
        in_step = min(1.0, math.ceil(n_steps / every) / float(detection["calls"]))
        external = stage_seconds.get("external_forces", 0.0)
        stage_seconds["external_forces_mpm"] = max(0.0, external - in_step * boundary)
    else:
        stage_seconds["external_forces_mpm"] = stage_seconds.get("external_forces", 0.0)
    stages = {k: v / n_steps for k, v in stage_seconds.items()}
    stages["mpm_step"] = sum(
        v for k, v in stages.items() if k not in BOUNDARY_STAGES + ("external_forces",)
    )
    if detection.get("seconds_per_call") is not None:
        stages["detect_per_call"] = float(detection["seconds_per_call"])
    return [
        {**label, "stage": stage, "seconds_per_step": seconds}
        for stage, seconds in stages.items()
    ]


def summarise(raw: pd.DataFrame) -> pd.DataFrame:
    keys = [c for c in raw.columns if c not in ("repetition", "seconds_per_step")]
    grouped = raw.groupby(keys)["seconds_per_step"]
    table = grouped.agg(
        median="median",
        min="min",
        max="max",
        q25=lambda s: s.quantile(0.25),
        q75=lambda s: s.quantile(0.75),
        repetitions="count",
    ).reset_index()
    return table


def library_timings(slope: dict, repetitions: int) -> list[dict]:
    """The library baseline on the slope's initial points: seconds per call from its
    summary.json (total of its timings), ``repetitions`` uncached calls."""
    run = run_mpm(derive(slope, {"time": {"end_time": 1e-3}}), threads=1)
    particles = run.folder / "slope_points.csv"
    frame = final_particles(run.out)
    write_detect_input(frame, particles)
    config = det.detect_config(
        det.LIBRARY, slope["grid"], slope["grid"]["cell_size"] / POINTS_PER_CELL
    )
    rows = []
    for repetition in range(repetitions):
        result = run_detect(particles, config, library=True, use_cache=False)
        try:
            summary = json.loads((result.out / "summary.json").read_text())
        finally:
            shutil.rmtree(result.folder, ignore_errors=True)
        # Its own stage timings (field, edge points, connection, filters), as pfm-mpm detect:
        # the Python start-up and file reading are left out.
        timings = summary.get("timings_s", {})
        seconds = sum(v for v in timings.values() if isinstance(v, (int, float)))
        rows.append(
            {
                "case": "slope",
                "n_particles": len(frame),
                "threads": 1,
                "detector": det.LIBRARY,
                "repetition": repetition,
                "stage": "detect_per_call",
                "seconds_per_step": float(seconds),
            }
        )
    return rows


def state_case(state: dict) -> tuple[dict, Path]:
    """The case a failure state came from, with its overrides (loads by index, the other
    blocks merged key by key: tests/data/failure_states/generate.py), run for
    FAILURE_STEP_TIME with no output but at its end."""
    case, path = base_case(state["case"])
    for key, value in state["overrides"].items():
        if key == "loads":
            for index, load in value.items():
                case["loads"][int(index)].update(load)
        else:
            case = derive(case, {key: value})
    case = derive(
        case,
        {
            "time": {"end_time": FAILURE_STEP_TIME},
            "output": {"interval": FAILURE_STEP_TIME},
        },
    )
    # Without detection, so without what acts on the detected boundary.
    case.pop("detection", None)
    for block in ("loads", "constraints"):
        kept = [
            entry
            for entry in case.get(block, [])
            if entry.get("apply_on") != "detected_boundary"
        ]
        if kept:
            case[block] = kept
        else:
            case.pop(block, None)
    return case, path


def failure_state_timings(
    detectors, names, repetitions: int
) -> tuple[list[dict], list[Path]]:
    """Seconds per detection call of each detector on each failure state (the sum of the
    timings in its summary.json: reading and writing left out) and the MPM step of each
    state's case; and the case files used."""
    folder = repo_root().joinpath(*FAILURE_STATES_FOLDER)
    states = json.loads((folder / "states.json").read_text())
    rows, steps, case_files = [], {}, []
    for state in states:
        if names is not None and state["name"] not in names:
            continue
        case, path = state_case(state)
        key = json.dumps(case, sort_keys=True)
        if key not in steps:
            stages = stage_rows(timed_run(case, 1), {})
            steps[key] = next(
                r["seconds_per_step"] for r in stages if r["stage"] == "mpm_step"
            )
            case_files.append(path)
        particles = folder / f"{state['name']}.csv"
        for detector in detectors:
            config = det.detect_config(
                detector, state["grid"], state["initial_spacing"]
            )
            for repetition in range(repetitions):
                result = run_detect(
                    particles,
                    config,
                    library=not det.in_run(detector),
                    use_cache=False,
                )
                try:
                    summary = json.loads((result.out / "summary.json").read_text())
                finally:
                    shutil.rmtree(result.folder, ignore_errors=True)
                timings = summary.get("timings_s", {})
                rows.append(
                    {
                        "state": state["name"],
                        "n_particles": int(state["points"]),
                        "detector": detector,
                        "repetition": repetition,
                        "detect_s": float(
                            sum(
                                v
                                for v in timings.values()
                                if isinstance(v, (int, float))
                            )
                        ),
                        "mpm_step_s": steps[key],
                    }
                )
    return rows, case_files


def failure_state_table(rows: list[dict]) -> pd.DataFrame:
    """Median seconds per call of each detector on each state, against the step."""
    frame = pd.DataFrame(rows)
    table = (
        frame.groupby(["state", "n_particles", "detector"], sort=False)
        .agg(
            detect_s=("detect_s", "median"),
            mpm_step_s=("mpm_step_s", "first"),
            calls=("detect_s", "count"),
        )
        .reset_index()
    )
    table["detect_to_step_ratio"] = table["detect_s"] / table["mpm_step_s"]
    return table


class _Attempts:
    """Calls a timing; a missing prerequisite (a detector pfm-mpm does not know, a library
    not installed) gives None and a note instead of failing the study."""

    def __init__(self):
        self.notes = []

    def __call__(self, label: str, function):
        try:
            return function()
        except (PrerequisiteMissing, RunFailed) as error:
            reason = missing_reason(error)
            if reason is None:
                raise
            self.notes.append(f"{label}: needs {reason}")
            return None


def run(context) -> StudyOutcome:
    context.tools.append(tool_path("pfm-mpm"))
    quick = context.quick
    outcome = StudyOutcome(study="timing")
    attempt = _Attempts()
    # Timing runs are serial on purpose: parallel runs would measure each other.
    raw = _block_rows(quick, attempt)
    slope, slope_path = base_case("thesis55_slope_dynamic_zero_start")
    context.case_files.append(slope_path)
    end_time = QUICK_SLOPE_END_TIME if quick else SLOPE_END_TIME
    slope = derive(
        slope,
        {
            "initial_stress": {"method": "k0"},
            "time": {"end_time": end_time},
            "output": {"interval": end_time},
        },
    )
    raw += _slope_runs(slope, quick, attempt)
    failure = attempt(
        "failure states",
        lambda: failure_state_timings(
            QUICK_FAILURE_DETECTORS if quick else tuple(d for d, _ in DETECTORS),
            QUICK_FAILURE_STATES if quick else None,
            1 if quick else REPETITIONS,
        ),
    )
    if not any(r["case"] == "slope" and r["detector"] != det.LIBRARY for r in raw):
        # at least the MPM step of the slope
        raw += _slope_rows(slope, "slope", None, attempt)
    raw = pd.DataFrame(raw)
    raw.to_csv(context.folder / "raw_timings.csv", index=False)
    table = summarise(raw)
    outcome.tables.append(
        write_table(
            context.folder,
            table,
            "stages",
            "Seconds per step, per stage (median of repetitions; "
            "detect_per_call: seconds per detection call)",
        )
    )
    ratios, slope_step = _ratios_with_library(table)
    outcome.tables.append(
        write_table(
            context.folder,
            pd.concat([_thesis_row(), ratios]),
            "ratios",
            "Detection per call against one MPM step; throughput "
            "(median of the repetitions)",
        )
    )
    _slope_metrics(ratios, slope_step, outcome)
    if failure is not None and failure[0]:
        _failure_states(context, failure, outcome)
    _block_metrics(ratios, outcome)
    outcome.figures.append(
        save_figure(
            context.folder,
            scaling_figure(ratios),
            "scaling",
            "Seconds per step against N (block), per thread count",
        )
    )
    if attempt.notes:
        outcome.reason = "partly not run: " + "; ".join(dict.fromkeys(attempt.notes))
    return outcome


def _block_rows(quick: bool, attempt: _Attempts) -> list[dict]:
    """The block at every particle count and thread count, REPETITIONS times, with the sweep's
    detector (the plain MPM if pfm-mpm does not accept it): stage_rows of each run."""
    counts = QUICK_PARTICLE_COUNTS if quick else PARTICLE_COUNTS
    threads_list = QUICK_THREADS if quick else THREADS
    raw = []
    detector = SWEEP_DETECTOR
    for n in counts:
        steps = QUICK_STEPS if quick else steps_for(n)
        for threads in threads_list:
            for repetition in range(REPETITIONS):
                summary = attempt(
                    f"block N = {n}",
                    lambda: timed_run(block_case(n, detector, steps), threads),
                )
                if summary is None:  # detection not accepted: time the plain MPM
                    detector = None
                    summary = timed_run(block_case(n, None, steps), threads)
                raw += stage_rows(
                    summary,
                    {
                        "case": "block",
                        "n_particles": int(summary.get("n_particles", n)),
                        "threads": threads,
                        "detector": detector or "none",
                        "repetition": repetition,
                    },
                )
    return raw


def _slope_rows(
    case: dict, label: str, detector: str | None, attempt: _Attempts
) -> list[dict]:
    """The repetitions of one slope run on 1 thread; none if the detector cannot run."""
    rows = []
    if detector is not None:
        case = derive(case, {"detection": det.detection_block(detector)})
    for repetition in range(REPETITIONS):
        summary = attempt(f"{label} {detector or 'MPM'}", lambda: timed_run(case, 1))
        if summary is None:
            break
        rows += stage_rows(
            summary,
            {
                "case": label,
                "n_particles": int(summary.get("n_particles", 0)),
                "threads": 1,
                "detector": detector or "none",
                "repetition": repetition,
            },
        )
    return rows


def _slope_runs(slope: dict, quick: bool, attempt: _Attempts) -> list[dict]:
    """The slope from K0 with every detector (the library on its own timings), from zero
    stress (full study) and its run-out."""
    raw = []
    for name in QUICK_SLOPE_DETECTORS if quick else tuple(d for d, _ in DETECTORS):
        if det.in_run(name):
            raw += _slope_rows(slope, "slope", name, attempt)
        else:
            rows = attempt(f"slope {name}", lambda: library_timings(slope, REPETITIONS))
            raw += rows or []
    if not quick:
        # The thesis's start: no initial stress, the slope settling under gravity from t = 0.
        zero = derive(slope, {"initial_stress": {"method": "zero"}})
        for name in ZERO_START_DETECTORS:
            raw += _slope_rows(zero, "slope_zero", name, attempt)
    runout = derive(
        slope,
        {
            "time": {"end_time": RUNOUT_END_TIME},
            "output": {"interval": RUNOUT_END_TIME},
        },
    )
    for name in QUICK_RUNOUT_DETECTORS if quick else RUNOUT_DETECTORS:
        raw += _slope_rows(runout, "slope_runout", name, attempt)
    return raw


def _ratios_with_library(table: pd.DataFrame) -> tuple[pd.DataFrame, pd.Series]:
    """ratio_table of the stages, the library's row against the median MPM step of the slope
    runs (which it returns too)."""
    ratios = ratio_table(table)
    slope_step = ratios[(ratios["case"] == "slope") & ratios["mpm_step_s"].notna()][
        "mpm_step_s"
    ]
    if len(slope_step):  # the library's row: its call against the slope's MPM step
        library = ratios["detector"] == det.LIBRARY
        ratios.loc[library, "mpm_step_s"] = float(slope_step.median())
        ratios.loc[library, "detect_to_step_ratio"] = ratios.loc[
            library, "detect_s"
        ] / float(slope_step.median())
    return ratios, slope_step


def _thesis_row() -> pd.DataFrame:
    """The thesis's own slope timing (THESIS_*), the ratios table's first row."""
    return pd.DataFrame(
        [
            {
                "case": "slope (thesis)",
                "n_particles": THESIS_POINTS,
                "threads": 1,
                "detector": "pfm_thesis",
                "detect_s": THESIS_DETECT_S,
                "mpm_step_s": THESIS_STEP_S,
                "detect_to_step_ratio": THESIS_DETECT_S / THESIS_STEP_S,
                "mpm_particle_steps_per_s": THESIS_POINTS / THESIS_STEP_S,
                "total_particle_steps_per_s": THESIS_POINTS
                / (THESIS_STEP_S + THESIS_DETECT_S),
            }
        ]
    )


def _slope_metrics(ratios: pd.DataFrame, slope_step: pd.Series, outcome):
    """Per detector on the slope and its run-out: the detection-to-step ratio (metric); on the
    slope the cost per call and the ratio (headline); the median MPM step (headline)."""
    for row in ratios[ratios["case"].isin(["slope", "slope_runout"])].itertuples(
        index=False
    ):
        if row.detector == "none":
            continue
        if row.detect_s is None or not np.isfinite(row.detect_s):
            continue
        outcome.metrics.append(
            Metric(
                f"timing.{row.case}.{row.detector}.detect_to_step_ratio",
                row.detect_to_step_ratio,
                "1",
            )
        )
        if row.case != "slope":
            continue
        outcome.headline += [
            Headline("cost.detect_per_step", row.detector, row.detect_s, "s"),
            Headline(
                "cost.detect_to_step_ratio", row.detector, row.detect_to_step_ratio, "1"
            ),
        ]
    if len(slope_step):
        outcome.headline.append(
            Headline(
                "cost.mpm_step",
                "*",
                float(slope_step.median()),
                "s",
                "median over the slope runs",
            )
        )


def _failure_states(context, failure, outcome):
    """The failure states' table and each detector's worst detection-to-step ratio."""
    failure_rows, failure_cases = failure
    context.case_files += [p for p in failure_cases if p not in context.case_files]
    states = failure_state_table(failure_rows)
    outcome.tables.append(
        write_table(
            context.folder,
            states,
            "failure_states",
            "Detection per call on the failure states (tests/data/failure_states; "
            "pfm-mpm detect, a fresh process per call, median) against one MPM step of "
            "the state's case at its start",
        )
    )
    for detector, group in states.groupby("detector", sort=False):
        outcome.metrics.append(
            Metric(
                f"timing.failure_states.{detector}.worst_detect_to_step_ratio",
                float(group["detect_to_step_ratio"].max()),
                "1",
                f"over {len(group)} states, at "
                f"{group.loc[group['detect_to_step_ratio'].idxmax(), 'state']}",
            )
        )


def _block_metrics(ratios: pd.DataFrame, outcome):
    """The block's metrics: the improved detector's ratio on the largest block of 200k points
    or more (detection must not dominate a large run) and the MPM's particle-steps per second
    near 100k points, one thread each."""
    large = ratios[
        (ratios["case"] == "block")
        & (ratios["threads"] == 1)
        & (ratios["detector"] == "pfm_improved")
        & (ratios["n_particles"] >= 200_000)
    ]
    if len(large):
        row = large.loc[large["n_particles"].idxmax()]
        outcome.metrics.append(
            Metric(
                "timing.block_200k.pfm_improved.detect_to_step_ratio",
                float(row["detect_to_step_ratio"]),
                "1",
                f"N = {row['n_particles']}",
            )
        )
    single = ratios[(ratios["case"] == "block") & (ratios["threads"] == 1)]
    if len(single):
        row = single.loc[(single["n_particles"] - 100_000).abs().idxmin()]
        outcome.metrics.append(
            Metric(
                "timing.block_100k.mpm_particle_steps_per_s",
                float(row["mpm_particle_steps_per_s"]),
                "1/s",
                f"N = {row['n_particles']}",
            )
        )


def ratio_table(table: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (case, n, threads, detector), group in table.groupby(
        ["case", "n_particles", "threads", "detector"]
    ):
        per_stage = dict(zip(group["stage"], group["median"]))
        detect = per_stage.get("detect_per_call", np.nan)
        step = per_stage.get("mpm_step", np.nan)
        rows.append(
            {
                "case": case,
                "n_particles": n,
                "threads": threads,
                "detector": detector,
                "detect_s": detect,
                "mpm_step_s": step,
                "detect_to_step_ratio": detect / step,
                "mpm_particle_steps_per_s": n / step,
                "total_particle_steps_per_s": n
                / (
                    step
                    + per_stage.get("detect", 0.0)
                    + per_stage.get("bezier", 0.0)
                    + per_stage.get("traction", 0.0)
                ),
            }
        )
    return pd.DataFrame(rows)


def scaling_figure(ratios: pd.DataFrame):
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(7, 4.5))
    block = ratios[ratios["case"] == "block"]
    for threads, group in block.groupby("threads"):
        group = group.sort_values("n_particles")
        axis.loglog(
            group["n_particles"],
            group["mpm_step_s"],
            "-o",
            label=f"MPM step, {threads} thread(s)",
        )
        if group["detect_s"].notna().any():
            axis.loglog(
                group["n_particles"],
                group["detect_s"],
                "--s",
                label=f"detection ({group['detector'].iloc[0]}), {threads} thread(s)",
            )
    slope = ratios[(ratios["case"] == "slope") & ratios["detect_s"].notna()]
    for row in slope.itertuples(index=False):
        axis.loglog(
            [row.n_particles], [row.detect_s], "^", label=f"slope: {row.detector}"
        )
    axis.loglog(
        [THESIS_POINTS], [THESIS_STEP_S], "rs", label="thesis MPM step (0.048 s)"
    )
    axis.loglog([THESIS_POINTS], [THESIS_DETECT_S], "r^", label="thesis PFM (0.047 s)")
    axis.set_xlabel("material points N")
    axis.set_ylabel("seconds per step / per detection call")
    axis.legend(fontsize=6)
    axis.grid(True, which="both", alpha=0.3)
    return figure
