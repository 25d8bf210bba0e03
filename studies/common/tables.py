"""Tables as CSV (the data) plus Markdown (for reading), figures as PNG."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd


def format_value(value, digits: int = 4) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if value == 0.0:
            return "0"
        if abs(value) >= 1e5 or abs(value) < 1e-3:
            return f"{value:.{digits - 1}e}"
        return f"{value:.{digits}g}"
    return str(value)


def markdown_table(frame: pd.DataFrame, digits: int = 4) -> str:
    """GitHub-flavoured Markdown table (pandas + tabulate); numbers to ``digits`` significant
    figures (format_value)."""
    shown = frame.astype(object).apply(
        lambda column: column.map(lambda v: format_value(v, digits).replace("|", "\\|"))
    )
    return (
        shown.to_markdown(index=False, tablefmt="github", disable_numparse=True) + "\n"
    )


def write_table(folder: Path, frame: pd.DataFrame, name: str, title: str = ""):
    """Write ``<name>.csv`` (full precision) and ``<name>.md``; return a TableRef."""
    from studies.common.outcome import TableRef

    folder = Path(folder)
    frame.to_csv(folder / f"{name}.csv", index=False, float_format="%.17g")
    heading = f"### {title}\n\n" if title else ""
    (folder / f"{name}.md").write_text(heading + markdown_table(frame))
    return TableRef(name=name, title=title or name, csv=f"{name}.csv", md=f"{name}.md")


def save_figure(folder: Path, figure, name: str, title: str = "", tight: bool = True):
    """Save a matplotlib figure as ``<name>.png`` and close it; return a FigureRef.
    ``tight=False`` skips the tight bounding box (one draw less, for many-panel figures).
    """
    import matplotlib.pyplot as plt

    from studies.common.outcome import FigureRef

    figure.savefig(
        Path(folder) / f"{name}.png", dpi=110, bbox_inches="tight" if tight else None
    )
    plt.close(figure)
    return FigureRef(name=name, title=title or name, png=f"{name}.png")
