"""``provenance.json`` beside every study's tables and figures: where the numbers came from.

Fields: study, git_revision, git_dirty (tracked files changed), git_diff_sha256, command
(argv), case_files ({path: sha256}), tools ({path: sha256} of the executables run),
started_utc, finished_utc, host, python, build_type (CMAKE_BUILD_TYPE from the build's
CMakeCache.txt, "unknown" without one), quick, cpu_count and load_average (1, 5, 15 min, at
the end: timings measured on a loaded machine are slower than its cores allow).
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import re
import sys
from pathlib import Path
from typing import Iterable, Optional

from studies.common import gitinfo
from studies.common.cache import file_sha256
from studies.common.paths import cmake_build_root


def utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def build_type() -> str:
    cache = cmake_build_root() / "CMakeCache.txt"
    if not cache.is_file():
        return "unknown"
    match = re.search(
        r"^CMAKE_BUILD_TYPE:\w+=(.*)$", cache.read_text(errors="replace"), re.M
    )
    return (match.group(1).strip() or "unset") if match else "unset"


def write_provenance(
    folder: Path,
    study: str,
    started_utc: str,
    case_files: Iterable[Path] = (),
    tools: Iterable[Path] = (),
    quick: bool = False,
    command: Optional[list] = None,
) -> Path:
    def hashes(paths):
        return {str(p): file_sha256(Path(p)) for p in paths if Path(p).is_file()}

    record = {
        "study": study,
        "git_revision": gitinfo.revision(),
        "git_dirty": gitinfo.is_dirty(),
        "git_diff_sha256": gitinfo.diff_hash(),
        "command": list(
            command if command is not None else [sys.executable, *sys.argv]
        ),
        "case_files": hashes(case_files),
        "tools": hashes(tools),
        "started_utc": started_utc,
        "finished_utc": utc_now(),
        "host": platform.node(),
        "python": platform.python_version(),
        "build_type": build_type(),
        "quick": quick,
        "cpu_count": os.cpu_count(),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
    }
    path = Path(folder) / "provenance.json"
    path.write_text(json.dumps(record, indent=2, sort_keys=True) + "\n")
    return path
