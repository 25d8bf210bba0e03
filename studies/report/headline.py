"""The report's first table: per detector, the numbers the project exists to produce, with the
thesis's figures beside ours.

Data model. A study contributes ``Headline`` entries (studies.common.outcome) to its
``study.json``: ``{"quantity": key, "detector": name or "*", "value": float, "unit", "note"}``.
A row of the table is a ``HeadlineRow``: a label, a unit, the thesis's figure (text, with its
source), the study that produces it and the quantity keys it shows. A cell is looked up by
(key, detector); "*" entries (independent of the detector: the quadrature map, the MPM step
cost) go to the column "any detector". A cell whose study has not run shows "not run [n]" with
the reason as footnote n (a failed study: "failed [n]"); an entry with ``value`` null and a
``note`` starting with "not run" (a part of a study that could not run) shows "not run [n]"
with that note; a cell whose study ran but gave no entry shows "-".

Boundary rows show ``max (RMS)`` in metres: keys ``boundary.<case>.<measure>.t<time>.max``
and ``.rms``, where case is one of BOUNDARY_CASES, measure ``detector_only`` or ``total`` and
time in COMPARISON_TIMES formatted with ``time_key``.
"""

from __future__ import annotations

from dataclasses import dataclass

DETECTORS = (
    ("pfm_thesis", "thesis PFM, plain"),
    ("pfm_thesis_final", "thesis PFM as the thesis ran it"),
    ("pfm_thesis_median", "thesis PFM, median filter"),
    ("pfm_improved", "improved PFM"),
    ("smm", "SMM"),
    ("vof", "VOF"),
    ("density", "density"),
    ("library", "library baseline"),
)
ANY_DETECTOR = "*"
COMPARISON_TIMES = (0.0, 0.625, 1.25)  # s; thesis 5.5.2 and 6.2.5
BOUNDARY_CASES = (
    ("slope_zero", "slope, zero-stress start (the thesis's)"),
    ("slope_k0", "slope, K0 start"),
    ("slope_gravity", "slope, gravity start"),
    ("slope_loaded_zero", "slope, 50 kPa 1 m behind the crest, zero-stress start"),
    ("block_zero", "bearing block, zero-stress start (the thesis's)"),
    ("block_k0", "bearing block, K0 start"),
    ("block_gravity", "bearing block, gravity start"),
)
MEASURES = (("detector_only", "detector only"), ("total", "total (MPM + detector)"))

THESIS_SLOPE = {
    0.0: "~0.3 m on the face, ~0.05 m top and bottom (5.5.2, fig. 5.33; zero-stress start)",
    0.625: "~0.15 m behind the crest, ~0.2 m at the bottom (fig. 5.34a)",
    1.25: "larger than at 0.625 s, not quantified (fig. 5.34b)",
}
THESIS_BLOCK = "compared graphically only (6.2.5, fig. 6.23)"
THESIS_OTHER_START = "the thesis started from zero stress only"
THESIS_LOADED_SLOPE = {
    0.0: "~0.3 m on the face, as unloaded (6.3.1, fig. 6.31a)",
    0.625: "face at the same place; the load's flanks missed (fig. 6.31b)",
    1.25: "not shown",
}


def time_key(time: float) -> str:
    """0.625 -> 't0.625', 0 -> 't0'."""
    return "t" + f"{time:g}"


def boundary_key(case: str, measure: str, time: float, statistic: str) -> str:
    return f"boundary.{case}.{measure}.{time_key(time)}.{statistic}"


@dataclass(frozen=True)
class HeadlineRow:
    label: str
    unit: str
    thesis: str
    study: str
    keys: tuple  # one key, or (max, rms) for boundary rows
    any_detector: bool = False  # the value sits in the "any detector" column


def headline_rows() -> list[HeadlineRow]:
    rows = []
    for case, case_label in BOUNDARY_CASES:
        for measure, measure_label in MEASURES:
            for time in COMPARISON_TIMES:
                if not case.endswith("_zero"):
                    thesis = THESIS_OTHER_START
                elif case == "slope_loaded_zero":
                    thesis = (
                        THESIS_LOADED_SLOPE[time]
                        if measure == "total"
                        else "not measured"
                    )
                elif case.startswith("slope"):
                    thesis = (
                        THESIS_SLOPE[time]
                        if measure == "total"
                        else (
                            "same as total at t = 0 (no deformation yet)"
                            if time == 0.0
                            else "not measured"
                        )
                    )
                else:
                    thesis = THESIS_BLOCK if measure == "total" else "not measured"
                rows.append(
                    HeadlineRow(
                        f"boundary error, {case_label}, {measure_label}, t = {time:g} s",
                        "m, max (RMS)",
                        thesis,
                        "boundary",
                        (
                            boundary_key(case, measure, time, "max"),
                            boundary_key(case, measure, time, "rms"),
                        ),
                    )
                )
    for case, what in (
        ("block_zero", "bearing block q = 100 kPa, zero-stress start"),
        ("block_k0", "bearing block q = 100 kPa, K0 start"),
        ("block_gravity", "bearing block q = 100 kPa, gravity start"),
        ("slope_loaded_zero", "slope, 50 kPa behind the crest, zero-stress start"),
    ):
        rows += [
            HeadlineRow(
                f"traction: applied vertical force against the exact resultant on the "
                f"detected curve, {what}",
                "1 (relative, max over time)",
                "up to ~14 % for cubic segments with eq. 6.12 (6.1.1); linear used",
                "boundary",
                (f"traction.{case}.total_force_rel_error",),
            ),
            HeadlineRow(
                f"traction: force lost on nodes of empty cells, {what}",
                "1 (relative, max over time)",
                "observed, not quantified (6.2)",
                "boundary",
                (f"traction.{case}.lost_force_rel",),
            ),
        ]
    rows += [
        HeadlineRow(
            "traction quadrature, thesis formula (eq. 6.12), k = 5: max total-force "
            "error over fig. 6.4",
            "1",
            "~14 % (6.1.1, fig. 6.4)",
            "quadrature",
            ("traction.quadrature.thesis",),
            any_detector=True,
        ),
        HeadlineRow(
            "traction quadrature, exact integrand split at cell edges, k = 5: max "
            "total-force error over fig. 6.4",
            "1",
            "not done in the thesis",
            "quadrature",
            ("traction.quadrature.exact",),
            any_detector=True,
        ),
        HeadlineRow(
            "cost: detection per call, slope 3384 points, 1 thread",
            "s",
            "0.047 s (5.2)",
            "timing",
            ("cost.detect_per_step",),
        ),
        HeadlineRow(
            "cost: one explicit MPM step without the boundary stages, same slope",
            "s",
            "0.048 s (5.2)",
            "timing",
            ("cost.mpm_step",),
            any_detector=True,
        ),
        HeadlineRow(
            "cost: detection per call / MPM step",
            "1",
            "0.98 (0.047 / 0.048, 5.2)",
            "timing",
            ("cost.detect_to_step_ratio",),
        ),
    ]
    return rows
