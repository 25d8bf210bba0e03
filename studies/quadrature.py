"""Quadrature error of the boundary traction on a cubic Bezier segment (thesis 6.1.1, fig. 6.4).

What it measures: the relative error of the nodal forces f = integral over Gamma_t of
N^T (q n) dGamma (thesis eq. 6.1, 6.4) and of their sum (the total force, which must equal
q (x_B - x_A), eq. 6.13) when the integral along one cubic Bezier segment inside one bilinear
cell is done with k-point Gauss quadrature, k = 2..8, in two ways:

* ``thesis``: the thesis's eq. 6.12, the quadrature of the arc length times a separate
  quadrature of N^T t (not the integral of their product);
* ``exact``:  the integrand N(B(t))^T (q n(t)) |B'(t)|, a polynomial of degree 8 in t inside a
  cell, so 5-point Gauss is exact once the segment is split where it crosses cell edges
  (``split`` = 1; ``split`` = 0 integrates over the whole segment at once).

Set-up of figure 6.4: A = (-1, 1), B = (1, -1), D = (0.75, -0.75), the control point C swept
over the square [-1, 1]^2 (``--resolution`` points per side), plus random segments crossing
several cells (``random_segments.csv``).

Why: the thesis reports up to ~14 % total-force error with its formula (k = 5) and therefore
used only linear boundaries; the method map (section 5) claims the error is the formula's, not
the curve's. The heat maps show both formulas side by side; the maxima table is the evidence.

Reproduce: ``make study-quadrature`` = ``/usr/bin/python3 -m studies quadrature [--quick]``,
which runs ``build/bin/pfm-quadrature-map --out DIR --resolution 101 --random-segments 1000
--seed 1`` (quick: ``--resolution 41 --random-segments 100``; 101 x 101 positions of C keep the
map's CSV near 14 MB) and writes ``maxima.csv/.md``, ``heatmap_<total|nodal>_split<0|1>.png``
and the tool's ``error_map.csv.gz``, ``random_segments.csv`` beside ``provenance.json``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from studies.common.outcome import Headline, Metric, StudyOutcome
from studies.common.paths import PrerequisiteMissing
from studies.common.runner import run_tool
from studies.common.tables import save_figure, write_table

TOOL = "pfm-quadrature-map"
FULL_ARGUMENTS = ["--resolution", "101", "--random-segments", "1000", "--seed", "1"]
QUICK_ARGUMENTS = ["--resolution", "41", "--random-segments", "100", "--seed", "1"]
MAP_COLUMNS = [
    "cx",
    "cy",
    "mode",
    "k",
    "split",
    "total_force_rel_error",
    "nodal_force_rel_error",
]
RANDOM_COLUMNS = [
    "segment",
    "n_cells_crossed",
    "mode",
    "k",
    "split",
    "nodal_force_rel_error",
    "total_force_rel_error",
]
MODES = ("thesis", "exact")
K_VALUES = tuple(range(2, 9))
SPLITS = (0, 1)
POINT_A, POINT_B, POINT_D = (-1.0, 1.0), (1.0, -1.0), (0.75, -0.75)
THESIS_K = 5  # thesis table 6.1
LOG_FLOOR = 1e-16  # errors below this are drawn at the floor of the log colour scale

EXPECTED_METRICS = [
    f"quadrature.{mode}.k{THESIS_K}.split{split}.{which}"
    for mode in MODES
    for split in SPLITS
    for which in (
        "max_total_force_rel_error",
        "max_nodal_force_rel_error",
        "random.max_total_force_rel_error",
        "random.max_nodal_force_rel_error",
    )
]


def read_checked(path: Path, columns: list) -> pd.DataFrame:
    if not Path(path).is_file():
        raise PrerequisiteMissing(f"{path.name} from {TOOL}")
    frame = pd.read_csv(path)
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise ValueError(f"{path}: missing columns {missing} (expected {columns})")
    frame["mode"] = frame["mode"].astype(str)
    return frame


def maxima_table(
    error_map: pd.DataFrame, random_segments: pd.DataFrame
) -> pd.DataFrame:
    """One row per (mode, k, split): the largest errors over the map (with the C that gives
    the largest total-force error) and over the random segments."""
    rows = []
    keys = ["mode", "k", "split"]
    random_groups = (
        dict(list(random_segments.groupby(keys))) if len(random_segments) else {}
    )
    for (mode, k, split), group in error_map.groupby(keys):
        worst = group.loc[group["total_force_rel_error"].idxmax()]
        rnd = random_groups.get((mode, k, split))
        rows.append(
            {
                "mode": mode,
                "k": int(k),
                "split": int(split),
                "map_max_total_force_rel_error": float(
                    group["total_force_rel_error"].max()
                ),
                "map_worst_cx": float(worst["cx"]),
                "map_worst_cy": float(worst["cy"]),
                "map_max_nodal_force_rel_error": float(
                    group["nodal_force_rel_error"].max()
                ),
                "random_max_total_force_rel_error": float(
                    rnd["total_force_rel_error"].max()
                )
                if rnd is not None
                else np.nan,
                "random_max_nodal_force_rel_error": float(
                    rnd["nodal_force_rel_error"].max()
                )
                if rnd is not None
                else np.nan,
                "random_mean_nodal_force_rel_error": float(
                    rnd["nodal_force_rel_error"].mean()
                )
                if rnd is not None
                else np.nan,
                "random_segments": int(len(rnd)) if rnd is not None else 0,
            }
        )
    order = {m: i for i, m in enumerate(MODES)}
    table = pd.DataFrame(rows)
    return table.sort_values(
        ["split", "mode", "k"], key=lambda s: s.map(order) if s.name == "mode" else s
    ).reset_index(drop=True)


def heatmap_figure(error_map: pd.DataFrame, column: str, split: int, title: str):
    """Rows: thesis / exact formula; columns: k = 2..8; colour: the relative error on a log
    scale (floor LOG_FLOOR). Images (imshow) and ticks on the outer axes only: a 14-panel
    figure of pcolormesh with ticks everywhere took seconds per figure to draw."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    subset = error_map[error_map["split"] == split]
    k_values = [k for k in K_VALUES if k in set(subset["k"])] or sorted(
        set(subset["k"])
    )
    positive = subset[column][subset[column] > 0]
    vmax = max(float(positive.max()) if len(positive) else 1.0, 10 * LOG_FLOOR)
    norm = LogNorm(vmin=LOG_FLOOR, vmax=vmax)
    figure, axes = plt.subplots(
        len(MODES),
        len(k_values),
        figsize=(2.0 * len(k_values) + 1, 4.6),
        squeeze=False,
        sharex=True,
        sharey=True,
    )
    figure.subplots_adjust(
        left=0.05, right=0.88, bottom=0.1, top=0.8, wspace=0.08, hspace=0.35
    )
    image = None
    for row, mode in enumerate(MODES):
        for col, k in enumerate(k_values):
            axis = axes[row][col]
            cell = subset[(subset["mode"] == mode) & (subset["k"] == k)]
            if len(cell):
                grid = cell.pivot_table(
                    index="cy", columns="cx", values=column, aggfunc="max"
                )
                x, y = grid.columns.to_numpy(), grid.index.to_numpy()
                dx = (x[1] - x[0]) / 2 if len(x) > 1 else 0.5
                dy = (y[1] - y[0]) / 2 if len(y) > 1 else 0.5
                image = axis.imshow(
                    np.clip(grid.to_numpy(), LOG_FLOOR, None),
                    origin="lower",
                    extent=(x[0] - dx, x[-1] + dx, y[0] - dy, y[-1] + dy),
                    norm=norm,
                    cmap="viridis",
                    interpolation="nearest",
                )
                axis.set_title(
                    f"{mode}, k={k}\nmax {float(cell[column].max()):.1e}", fontsize=7
                )
            else:
                axis.set_title(f"{mode}, k={k}\nno data", fontsize=7)
            points = np.array([POINT_A, POINT_B, POINT_D])
            axis.plot(points[:, 0], points[:, 1], "r.", markersize=4)
            for (px, py), label in zip(points, "ABD"):
                axis.text(px, py, label, fontsize=6, color="red")
            axis.tick_params(
                labelsize=6,
                left=col == 0,
                labelleft=col == 0,
                bottom=row == len(MODES) - 1,
                labelbottom=row == len(MODES) - 1,
            )
            if col == 0:
                axis.set_ylabel("C_y", fontsize=7)
            if row == len(MODES) - 1:
                axis.set_xlabel("C_x", fontsize=7)
    if image is not None:
        bar_axis = figure.add_axes([0.9, 0.1, 0.015, 0.7])
        figure.colorbar(image, cax=bar_axis, label=column.replace("_", " "))
    figure.suptitle(title, fontsize=9)
    return figure


def analyse(
    error_map: pd.DataFrame, random_segments: pd.DataFrame, folder: Path
) -> StudyOutcome:
    """Tables, figures, metrics and headline entries from the tool's two CSV files."""
    outcome = StudyOutcome(study="quadrature")
    table = maxima_table(error_map, random_segments)
    outcome.tables.append(
        write_table(
            folder,
            table,
            "maxima",
            "Largest relative errors per formula, k and splitting",
        )
    )
    for column, label in (
        ("total_force_rel_error", "total"),
        ("nodal_force_rel_error", "nodal"),
    ):
        for split in SPLITS:
            if not (error_map["split"] == split).any():
                continue
            title = (
                f"{label} force relative error, C over the square, A=(-1,1), B=(1,-1), "
                f"D=(0.75,-0.75), split at cell edges: {'yes' if split else 'no'}"
            )
            figure = heatmap_figure(error_map, column, split, title)
            outcome.figures.append(
                save_figure(
                    folder, figure, f"heatmap_{label}_split{split}", title, tight=False
                )
            )
    for row in table.itertuples(index=False):
        if row.k != THESIS_K:
            continue
        prefix = f"quadrature.{row.mode}.k{row.k}.split{row.split}"
        outcome.metrics += [
            Metric(
                f"{prefix}.max_total_force_rel_error",
                row.map_max_total_force_rel_error,
                "1",
            ),
            Metric(
                f"{prefix}.max_nodal_force_rel_error",
                row.map_max_nodal_force_rel_error,
                "1",
            ),
            Metric(
                f"{prefix}.random.max_total_force_rel_error",
                row.random_max_total_force_rel_error,
                "1",
            ),
            Metric(
                f"{prefix}.random.max_nodal_force_rel_error",
                row.random_max_nodal_force_rel_error,
                "1",
            ),
        ]
        if (row.mode, row.split) == ("thesis", 0):
            outcome.headline.append(
                Headline(
                    "traction.quadrature.thesis",
                    "*",
                    row.map_max_total_force_rel_error,
                    "1",
                    "eq. 6.12, k = 5, no split, fig. 6.4 map",
                )
            )
        if (row.mode, row.split) == ("exact", 1):
            outcome.headline.append(
                Headline(
                    "traction.quadrature.exact",
                    "*",
                    row.map_max_total_force_rel_error,
                    "1",
                    "product integrand, k = 5, split at cell edges",
                )
            )
    return outcome


def run(context) -> StudyOutcome:
    arguments = ["--out", "{out}"] + (
        QUICK_ARGUMENTS if context.quick else FULL_ARGUMENTS
    )
    result = run_tool(TOOL, arguments)
    context.tools.append(result.command[0])
    error_map = read_checked(result.out / "error_map.csv", MAP_COLUMNS)
    random_segments = read_checked(result.out / "random_segments.csv", RANDOM_COLUMNS)
    error_map.to_csv(context.folder / "error_map.csv.gz", index=False)
    random_segments.to_csv(context.folder / "random_segments.csv", index=False)
    return analyse(error_map, random_segments, context.folder)
