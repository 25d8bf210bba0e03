"""Build the report from the latest study results.

Inputs: ``<results root>/<study>/study.json`` (+ its tables and figures) for every study in
studies.STUDY_NAMES, ``reports/thresholds.json`` and the history, ``<results root>/history.jsonl``
(outside the tracked tree: a report never modifies a tracked file).
Outputs in ``<results root>/report/``: ``index.html``, ``report.md`` and ``report.json`` (the
evaluated headline cells and metric verdicts); one line appended to the history.

Verdicts of a thresholded metric:
``pass`` / ``FAIL`` (value past the limit, or no finite value from a study that ran, or the
study failed), ``not run`` (its study, or the part of it that makes the metric, has not run, or
the quick variant leaves it out: the reason is shown), ``missing`` (the full study ran without
trouble but did not produce the metric), ``info`` (the threshold has no limit). A metric of a
quick variant is judged too, on its coarser grids, and marked ``quick``. The command exits 1 when
a verdict of a full study is FAIL (a quick variant's FAIL is shown, not counted: its grids are
not the gate's); a FAIL whose previous report passed is marked as a regression. A study's
heading shows its FAILs beside its status.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Optional

import pandas as pd

from studies import STUDY_NAMES
from studies.common import gitinfo
from studies.common.outcome import StudyOutcome
from studies.common.paths import repo_root, results_root
from studies.common.provenance import utc_now
from studies.common.tables import format_value, markdown_table
from studies.report.headline import ANY_DETECTOR, DETECTORS, headline_rows

THRESHOLDS_SCHEMA = 1
DIRECTIONS = ("lower", "higher")


def default_thresholds_path() -> Path:
    return repo_root() / "reports" / "thresholds.json"


def default_history_path(root: Optional[Path] = None) -> Path:
    """The history of the reports built from the results root `root` (default results_root())."""
    return Path(root or results_root()) / "history.jsonl"


def templates_dir() -> Path:
    return repo_root() / "reports" / "templates"


# ---------------------------------------------------------------- thresholds and verdicts


@dataclass
class Threshold:
    name: str
    direction: str
    limit: Optional[float]
    unit: str = ""
    description: str = ""
    source: str = ""


def read_thresholds(path: Path) -> tuple[int, list[Threshold]]:
    """Returns (file version, thresholds). The file: {"schema": 1, "version": int,
    "metrics": [{"name", "direction": "lower"|"higher", "limit": number|null, "unit",
    "description", "source"}]}."""
    data = json.loads(Path(path).read_text())
    if data.get("schema") != THRESHOLDS_SCHEMA:
        raise ValueError(f"{path}: /schema must be {THRESHOLDS_SCHEMA}")
    thresholds, seen = [], set()
    for i, entry in enumerate(data.get("metrics", [])):
        where = f"{path}: /metrics/{i}"
        if entry.get("direction") not in DIRECTIONS:
            raise ValueError(f"{where}/direction: must be one of {DIRECTIONS}")
        limit = entry.get("limit")
        if limit is not None and not isinstance(limit, (int, float)):
            raise ValueError(f"{where}/limit: must be a number or null")
        if entry.get("name") in seen or not entry.get("name"):
            raise ValueError(f"{where}/name: missing or duplicated")
        seen.add(entry["name"])
        thresholds.append(
            Threshold(
                **{k: entry[k] for k in entry if k in Threshold.__dataclass_fields__}
            )
        )
    return int(data.get("version", 0)), thresholds


def passes(value: float, threshold: Threshold) -> bool:
    if threshold.direction == "lower":
        return value <= threshold.limit
    return value >= threshold.limit


@dataclass
class Verdict:
    name: str
    study: str
    value: Optional[float]
    unit: str
    limit: Optional[float]
    direction: str
    status: str  # pass, FAIL, not run, missing, info
    reason: str = ""
    previous: Optional[float] = None
    change: Optional[float] = None
    regression: bool = False  # FAIL now, passed in the previous report
    quick: bool = False  # the value comes from a quick variant (coarser grids)


def study_of_metric(name: str) -> str:
    return name.split(".", 1)[0]


def evaluate(
    thresholds: list[Threshold], outcomes: dict, previous: dict
) -> list[Verdict]:
    values = {m.name: m.value for o in outcomes.values() for m in o.metrics}
    verdicts = []
    for t in thresholds:
        study = study_of_metric(t.name)
        outcome = outcomes.get(study)
        v = Verdict(t.name, study, None, t.unit, t.limit, t.direction, "missing")
        if outcome is None or outcome.status == "not_run":
            v.status = "not run"
            v.reason = outcome.reason if outcome else f"needs the {study} study"
        elif outcome.status == "failed":
            v.status, v.reason = (
                "FAIL",
                f"study failed: {outcome.reason.splitlines()[0]}",
            )
        elif t.name not in values:
            if outcome.reason:  # a part of the study did not run
                v.status, v.reason = "not run", outcome.reason
            elif outcome.quick:
                v.status, v.reason = "not run", "not in the quick variant"
            else:
                v.status, v.reason = (
                    "missing",
                    "the study ran but did not produce this metric",
                )
        else:
            v.value = values[t.name]
            v.quick = outcome.quick
            finite = v.value is not None and math.isfinite(v.value)
            if t.limit is None:
                v.status = "info"
            elif not finite:
                v.status, v.reason = "FAIL", "no finite value"
            else:
                v.status = "pass" if passes(v.value, t) else "FAIL"
        old = previous.get(t.name)
        if old is not None:
            v.previous = old
            if v.value is not None:
                v.change = v.value - old
            if v.status == "FAIL" and t.limit is not None and passes(old, t):
                v.regression = True
        verdicts.append(v)
    return verdicts


# ---------------------------------------------------------------- results and history


def load_outcomes(root: Path) -> dict:
    outcomes = {}
    for name in STUDY_NAMES:
        path = Path(root) / name / "study.json"
        if path.is_file():
            outcomes[name] = StudyOutcome.read(path)
        else:
            outcomes[name] = StudyOutcome.not_run(
                name, f"`make study-{name}` (no results yet)"
            )
    return outcomes


def read_history(path: Path) -> list[dict]:
    if not Path(path).is_file():
        return []
    lines = [line for line in Path(path).read_text().splitlines() if line.strip()]
    return [json.loads(line) for line in lines]


def history_entry(
    outcomes: dict, verdicts: list[Verdict], thresholds_version: int
) -> dict:
    return {
        "timestamp": utc_now(),
        "git_revision": gitinfo.revision(),
        "git_dirty": gitinfo.is_dirty(),
        "thresholds_version": thresholds_version,
        "studies": {n: o.status for n, o in outcomes.items()},
        "metrics": {m.name: m.value for o in outcomes.values() for m in o.metrics},
        "failed": sorted(v.name for v in verdicts if v.status == "FAIL"),
    }


# ---------------------------------------------------------------- headline table


def headline_table(outcomes: dict) -> tuple[list[str], list[list[str]], list[str]]:
    """(column names, rows of cell text, footnotes)."""
    entries = {}
    for outcome in outcomes.values():
        for h in outcome.headline:
            entries[(h.quantity, h.detector)] = h
    footnotes, note_of = [], {}

    def footnote(key: str, status: str, text: str) -> str:
        if key not in note_of:
            footnotes.append(text)
            note_of[key] = (status, len(footnotes))
        status, number = note_of[key]
        return f"{status} [{number}]"

    def not_run(study: str) -> str:
        outcome = outcomes.get(study)
        reason = outcome.reason if outcome else "not run"
        status = "failed" if outcome and outcome.status == "failed" else "not run"
        return footnote(
            study,
            status,
            f"{study}: {status}: {reason.splitlines()[0] if reason else ''}",
        )

    def cell(row, detector) -> str:
        outcome = outcomes.get(row.study)
        if outcome is None or outcome.status != "ok":
            return not_run(row.study)
        found = [entries.get((k, detector)) for k in row.keys]
        if (
            found[0] is not None
            and found[0].value is None
            and found[0].note.startswith("not run")
        ):
            return footnote(
                f"{row.study}:{found[0].note}",
                "not run",
                f"{row.study}: {found[0].note}",
            )
        if found[0] is None or found[0].value is None:
            return "-"
        text = format_value(found[0].value)
        if len(found) > 1 and found[1] is not None and found[1].value is not None:
            text += f" ({format_value(found[1].value)})"
        return text

    columns = ["quantity", "unit", "thesis", "any detector"] + [
        label for _, label in DETECTORS
    ]
    rows = []
    for row in headline_rows():
        if row.any_detector:
            cells = [cell(row, ANY_DETECTOR)] + ["" for _ in DETECTORS]
        else:
            cells = [""] + [cell(row, key) for key, _ in DETECTORS]
        rows.append([row.label, row.unit, row.thesis] + cells)
    return columns, rows, footnotes


# ---------------------------------------------------------------- rendering


def _table_html(frame: pd.DataFrame) -> str:
    return frame.to_html(
        index=False,
        border=0,
        classes="data",
        na_rep="",
        float_format=lambda v: format_value(float(v)),
    )


def summary_html(text: str) -> str:
    """A study's summary (reStructuredText, from its docstring) as an HTML fragment."""
    from docutils.core import publish_parts

    return publish_parts(
        text,
        writer_name="html5",
        settings_overrides={
            "report_level": 5,
            "halt_level": 5,
            "doctitle_xform": False,
        },
    )["body"]


def study_sections(
    outcomes: dict, root: Path, out_dir: Path, failures: list[Verdict]
) -> list[dict]:
    sections = []
    for name in STUDY_NAMES:
        outcome = outcomes[name]
        folder = Path(root) / name
        tables = []
        for ref in outcome.tables:
            frame = pd.read_csv(folder / ref.csv)
            tables.append(
                {
                    "title": ref.title,
                    "html": _table_html(frame),
                    "md": markdown_table(frame),
                    "csv": os.path.relpath(folder / ref.csv, out_dir),
                }
            )
        figures = [
            {"title": ref.title, "src": os.path.relpath(folder / ref.png, out_dir)}
            for ref in outcome.figures
        ]
        provenance = {}
        if (folder / "provenance.json").is_file():
            provenance = json.loads((folder / "provenance.json").read_text())
        metrics = [
            {"name": m.name, "value": format_value(m.value), "unit": m.unit}
            for m in outcome.metrics
        ]
        sections.append(
            {
                "name": name,
                "title": outcome.title or name,
                "summary": outcome.summary,
                "summary_html": summary_html(outcome.summary),
                "status": outcome.status,
                "failures": [v.name for v in failures if v.study == name],
                "reason": outcome.reason,
                "command": outcome.command,
                "quick": outcome.quick,
                "tables": tables,
                "figures": figures,
                "metrics": metrics,
                "provenance": provenance,
            }
        )
    return sections


def render(context: dict, out_dir: Path) -> None:
    import jinja2

    environment = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(templates_dir())),
        autoescape=jinja2.select_autoescape(["html.j2"]),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    (out_dir / "index.html").write_text(
        environment.get_template("report.html.j2").render(**context)
    )
    (out_dir / "report.md").write_text(
        environment.get_template("report.md.j2").render(**context)
    )


def build_report(
    root: Optional[Path] = None,
    out_dir: Optional[Path] = None,
    thresholds_path: Optional[Path] = None,
    history_path: Optional[Path] = None,
    record_history: bool = True,
) -> int:
    """Build the report; return the exit code (1 if any thresholded metric FAILs)."""
    root = Path(root) if root else results_root()
    out_dir = Path(out_dir) if out_dir else root / "report"
    thresholds_path = (
        Path(thresholds_path) if thresholds_path else default_thresholds_path()
    )
    history_path = Path(history_path) if history_path else default_history_path(root)
    out_dir.mkdir(parents=True, exist_ok=True)

    outcomes = load_outcomes(root)
    version, thresholds = read_thresholds(thresholds_path)
    history = read_history(history_path)
    previous = history[-1] if history else {}
    verdicts = evaluate(thresholds, outcomes, previous.get("metrics", {}))
    columns, rows, footnotes = headline_table(outcomes)
    headline_md = markdown_table(pd.DataFrame(rows, columns=columns))
    failures = [v for v in verdicts if v.status == "FAIL"]
    counted = [v for v in failures if not v.quick]

    verdict_rows = [
        {
            **asdict(v),
            "value_text": format_value(v.value),
            "limit_text": format_value(v.limit),
            "previous_text": format_value(v.previous),
            "change_text": format_value(v.change),
        }
        for v in verdicts
    ]
    verdict_frame = pd.DataFrame(
        [
            {
                "metric": v["name"],
                "value": v["value_text"],
                "unit": v["unit"],
                "limit": ("<= " if v["direction"] == "lower" else ">= ")
                + v["limit_text"]
                if v["limit"] is not None
                else "",
                "verdict": v["status"]
                + (" (quick)" if v["quick"] else "")
                + (" (regression)" if v["regression"] else ""),
                "previous": v["previous_text"],
                "change": v["change_text"],
                "note": v["reason"],
            }
            for v in verdict_rows
        ],
        columns=[
            "metric",
            "value",
            "unit",
            "limit",
            "verdict",
            "previous",
            "change",
            "note",
        ],
    )
    context = {
        "generated": utc_now(),
        "revision": gitinfo.revision(),
        "dirty": gitinfo.is_dirty(),
        "thresholds_version": version,
        "thresholds_file": os.path.relpath(thresholds_path, repo_root())
        if thresholds_path.is_relative_to(repo_root())
        else str(thresholds_path),
        "previous": {k: previous.get(k) for k in ("timestamp", "git_revision")}
        if previous
        else None,
        "headline_columns": columns,
        "headline_rows": rows,
        "headline_notes": footnotes,
        "headline_md": headline_md,
        "verdicts": verdict_rows,
        "verdicts_md": markdown_table(verdict_frame),
        "n_fail": len(counted),
        "n_fail_quick": len(failures) - len(counted),
        "n_regressions": sum(v.regression for v in verdicts),
        "studies": study_sections(outcomes, root, out_dir, failures),
    }
    render(context, out_dir)
    (out_dir / "report.json").write_text(
        json.dumps(
            {
                "generated": context["generated"],
                "revision": context["revision"],
                "headline": {"columns": columns, "rows": rows, "notes": footnotes},
                "verdicts": [asdict(v) for v in verdicts],
                "studies": {
                    n: {"status": o.status, "reason": o.reason}
                    for n, o in outcomes.items()
                },
            },
            indent=2,
        )
        + "\n"
    )
    if record_history:
        history_path.parent.mkdir(parents=True, exist_ok=True)
        with open(history_path, "a") as stream:
            stream.write(
                json.dumps(history_entry(outcomes, verdicts, version), sort_keys=True)
                + "\n"
            )
    for v in failures:
        tag = (" (quick)" if v.quick else "") + (" REGRESSION" if v.regression else "")
        print(
            f"report: FAIL{tag} {v.name} = {format_value(v.value)} {v.unit} "
            f"(limit {v.direction} {format_value(v.limit)}) {v.reason}",
            file=sys.stderr,
        )
    print(
        f"report: {out_dir / 'index.html'} ({len(counted)} metric(s) past threshold"
        + (
            f", and {len(failures) - len(counted)} of quick variants"
            if len(failures) > len(counted)
            else ""
        )
        + ")"
    )
    return 1 if counted else 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m studies report",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--results",
        type=Path,
        help="results root (default: PFM_RESULTS or " "results/studies)",
    )
    parser.add_argument(
        "--out", type=Path, help="output folder (default: <results>/report)"
    )
    parser.add_argument(
        "--thresholds", type=Path, help="default: reports/thresholds.json"
    )
    parser.add_argument("--history", type=Path, help="default: <results>/history.jsonl")
    parser.add_argument(
        "--no-history",
        action="store_true",
        help="do not append this report to the history",
    )
    parser.add_argument(
        "--warn-only",
        action="store_true",
        help="print the metrics past their threshold but exit 0 (the quick "
        "variants of `make test`: they check that the studies run)",
    )
    args = parser.parse_args(argv)
    code = build_report(
        args.results,
        args.out,
        args.thresholds,
        args.history,
        record_history=not args.no_history,
    )
    return 0 if args.warn_only else code
