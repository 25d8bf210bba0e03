"""Shared machinery of the studies: paths, cache, runners, provenance, parallel sweeps,
progress bars, tables and the outcome data model."""

from studies.common.outcome import Headline, Metric, StudyOutcome, TableRef, FigureRef
from studies.common.paths import (
    PrerequisiteMissing,
    build_dir,
    cache_root,
    repo_root,
    results_root,
    study_dir,
    tool_path,
)

__all__ = [
    "Headline",
    "Metric",
    "StudyOutcome",
    "TableRef",
    "FigureRef",
    "PrerequisiteMissing",
    "build_dir",
    "cache_root",
    "repo_root",
    "results_root",
    "study_dir",
    "tool_path",
]
