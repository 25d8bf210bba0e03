"""Running one study: a fresh results folder, the literate README, the outcome and its
provenance, and the translation of "something is missing" into a "not run" outcome."""

from __future__ import annotations

import inspect
import os
import shutil
import sys
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import matplotlib

matplotlib.use("Agg")

from studies.common.outcome import StudyOutcome  # noqa: E402
from studies.common.paths import PrerequisiteMissing, study_dir  # noqa: E402
from studies.common.provenance import utc_now, write_provenance  # noqa: E402
from studies.common.runner import RunFailed  # noqa: E402


@dataclass
class StudyOptions:
    quick: bool = False
    jobs: Optional[int] = None
    scheduler: Optional[str] = None


@dataclass
class StudyContext:
    """What a study's ``run`` gets: its name, its (empty) results folder and the options.
    Studies add the case files and executables they used so provenance can hash them."""

    name: str
    folder: Path
    options: StudyOptions
    case_files: list = field(default_factory=list)
    tools: list = field(default_factory=list)

    @property
    def quick(self) -> bool:
        return self.options.quick


def command_line(name: str, options: StudyOptions) -> str:
    parts = ["/usr/bin/python3 -m studies", name]
    if options.quick:
        parts.append("--quick")
    return " ".join(parts)


def docstring_parts(module) -> tuple[str, str]:
    """(title, summary): the docstring's first paragraph, flattened to one line, and the
    paragraphs after it up to "Why:" or "Reproduce:" (what the study measures), as written
    (reStructuredText: the report renders it)."""
    paragraphs = [p.strip() for p in (inspect.getdoc(module) or "").split("\n\n")]
    paragraphs = [p for p in paragraphs if p]
    title = " ".join(paragraphs[0].split()) if paragraphs else module.__name__
    summary = []
    for paragraph in paragraphs[1:]:
        if paragraph.startswith(("Why", "Reproduce")):
            break
        summary.append(paragraph)
    return title, "\n\n".join(summary)


def execute(module, options: StudyOptions) -> StudyOutcome:
    """Run ``module.run(context)`` and record what happened in the study's folder."""
    name = module.__name__.rsplit(".", 1)[-1]
    folder = study_dir(name, create=False)
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    started = utc_now()
    context = StudyContext(name, folder, options)
    title, summary = docstring_parts(module)
    (folder / "README.md").write_text(f"# Study: {name}\n\n{inspect.getdoc(module)}\n")
    try:
        outcome = module.run(context)
    except PrerequisiteMissing as missing:
        outcome = StudyOutcome.not_run(name, missing.needs)
    except RunFailed as failure:
        (folder / "error.log").write_text(f"{failure}\n{failure.stderr}")
        feature = failure.rejected_feature()
        if feature:
            outcome = StudyOutcome.not_run(name, f"pfm-mpm to accept: {feature}")
        else:
            outcome = StudyOutcome(
                study=name,
                status="failed",
                reason=f"{str(failure)[:300]} (see error.log)",
            )
    except Exception as error:  # a study's own bug or an unexpected output format
        (folder / "error.log").write_text(traceback.format_exc())
        outcome = StudyOutcome(
            study=name,
            status="failed",
            reason=f"{type(error).__name__}: {error} (see error.log)",
        )
    outcome.study = name
    outcome.quick = options.quick
    outcome.title = outcome.title or title
    outcome.summary = outcome.summary or summary
    outcome.command = command_line(name, options)
    outcome.expected = list(getattr(module, "EXPECTED_METRICS", ()))
    outcome.write(folder)
    write_provenance(
        folder, name, started, context.case_files, context.tools, options.quick
    )
    try:  # keep the run cache under PFM_CACHE_MAX_MB (least recently used entries go)
        from studies.common.cache import Cache

        Cache().prune()
    except OSError:
        pass
    status = outcome.status + (f" ({outcome.reason})" if outcome.reason else "")
    print(
        f"study {name}: {status} -> {folder}",
        file=sys.stderr if os.environ.get("PFM_QUIET") else sys.stdout,
    )
    return outcome


def missing_reason(error: BaseException):
    """The "needs ..." text when ``error`` means a prerequisite is missing (PrerequisiteMissing,
    or a tool rejecting a case key it does not support yet), else None."""
    if isinstance(error, PrerequisiteMissing):
        return error.needs
    if isinstance(error, RunFailed):
        feature = error.rejected_feature()
        return f"pfm-mpm to accept: {feature}" if feature else None
    return None


def run_parts(outcome: StudyOutcome, parts, folder: Optional[Path] = None) -> None:
    """Run independent parts of a study, ``parts`` = [(name, function()), ...], so that one
    part's trouble does not discard the others' tables. A part whose prerequisite is missing is
    noted in ``outcome.reason`` ("partly not run: ..."); a part that fails sets the outcome to
    "failed" (traceback appended to ``folder/error.log``); when every part is missing the whole
    study is not run."""
    missing, failed = [], []
    for name, function in parts:
        try:
            function()
        except Exception as error:  # noqa: BLE001 - recorded, not swallowed
            reason = missing_reason(error)
            if reason is not None:
                missing.append(f"{name}: needs {reason}")
                continue
            failed.append(
                f"{name}: {type(error).__name__}: {str(error).splitlines()[0][:300]}"
            )
            if folder is not None:
                with open(Path(folder) / "error.log", "a") as log:
                    log.write(f"--- {name}\n{traceback.format_exc()}\n")
                    if isinstance(error, RunFailed):
                        log.write(error.stderr + "\n")
    if missing and len(missing) == len(parts):
        raise PrerequisiteMissing("; ".join(missing))
    notes = []
    if failed:
        outcome.status = "failed"
        notes.append(
            "failed: " + "; ".join(failed) + (" (see error.log)" if folder else "")
        )
    if missing:
        notes.append("partly not run: " + "; ".join(missing))
    outcome.reason = " | ".join(notes)
