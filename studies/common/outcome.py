"""The data model a study hands to the report: ``study.json`` in the study's results folder.

``study.json``::

    {
      "schema": 1,
      "study": "quadrature",
      "status": "ok" | "not_run" | "failed",
      "reason": "needs build/bin/pfm-quadrature-map (not built)",   # "" when ok
      "quick": false,
      "title": "...", "summary": "first paragraph of the module docstring",
      "command": "/usr/bin/python3 -m studies quadrature",
      "tables":  [{"name": "maxima", "title": "...", "csv": "maxima.csv", "md": "maxima.md"}],
      "figures": [{"name": "...", "title": "...", "png": "heatmap_total_split1.png"}],
      "metrics": [{"name": "quadrature.exact.k5.split1.max_total_force_rel_error",
                   "value": 1.2e-15, "unit": "1"}],
      "headline": [{"quantity": "traction.quadrature.exact", "detector": "*",
                    "value": 1.2e-15, "unit": "1", "note": ""}],
      "expected": ["quadrature.exact.k5.split1.max_total_force_rel_error", ...]
    }

* ``metrics`` are scalars the report checks against ``reports/thresholds.json`` (by name);
* ``headline`` entries fill the report's first table (quantity keys in studies.report.headline);
  ``detector`` is one of studies.boundary.DETECTORS or ``"*"`` (independent of the detector);
* ``expected`` lists the metric names the study produces when it runs, so that a study that
  did not run can still be shown metric by metric as "not run: <reason>".
Paths are relative to the study's folder.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Optional

SCHEMA_VERSION = 1
STATUSES = ("ok", "not_run", "failed")


@dataclass
class TableRef:
    name: str
    title: str
    csv: str
    md: str = ""


@dataclass
class FigureRef:
    name: str
    title: str
    png: str


@dataclass
class Metric:
    name: str
    value: Optional[float]
    unit: str = ""
    note: str = ""


@dataclass
class Headline:
    quantity: str
    detector: str
    value: Optional[float]
    unit: str = ""
    note: str = ""


@dataclass
class StudyOutcome:
    study: str
    status: str = "ok"
    reason: str = ""
    quick: bool = False
    title: str = ""
    summary: str = ""
    command: str = ""
    tables: list = field(default_factory=list)
    figures: list = field(default_factory=list)
    metrics: list = field(default_factory=list)
    headline: list = field(default_factory=list)
    expected: list = field(default_factory=list)

    def __post_init__(self):
        if self.status not in STATUSES:
            raise ValueError(f"status must be one of {STATUSES}, got {self.status!r}")

    @classmethod
    def not_run(cls, study: str, needs: str, **kwargs) -> "StudyOutcome":
        return cls(study=study, status="not_run", reason=f"needs {needs}", **kwargs)

    def to_json(self) -> dict:
        data = asdict(self)
        data["schema"] = SCHEMA_VERSION
        for entry in data["metrics"] + data["headline"]:
            value = entry["value"]
            if value is not None and not math.isfinite(value):
                entry["value"] = None
                entry["note"] = (entry["note"] + " non-finite").strip()
        return data

    def write(self, folder: Path) -> Path:
        path = Path(folder) / "study.json"
        path.write_text(json.dumps(self.to_json(), indent=2, sort_keys=True) + "\n")
        return path

    @classmethod
    def read(cls, path: Path) -> "StudyOutcome":
        data = json.loads(Path(path).read_text())
        schema = data.pop("schema", SCHEMA_VERSION)
        if schema != SCHEMA_VERSION:
            raise ValueError(
                f"{path}: study.json schema {schema}, expected {SCHEMA_VERSION}"
            )
        outcome = cls(
            **{
                k: v
                for k, v in data.items()
                if k not in ("tables", "figures", "metrics", "headline")
            }
        )
        outcome.tables = [TableRef(**t) for t in data.get("tables", [])]
        outcome.figures = [FigureRef(**f) for f in data.get("figures", [])]
        outcome.metrics = [Metric(**m) for m in data.get("metrics", [])]
        outcome.headline = [Headline(**h) for h in data.get("headline", [])]
        return outcome
