"""The code revision a result came from: ``git rev-parse HEAD`` and a hash of ``git diff HEAD``
(uncommitted changes to tracked files). Untracked files are not in ``git diff``; the runners
therefore also key the cache on the hash of the binary they execute."""

from __future__ import annotations

import hashlib
import subprocess

from studies.common.paths import repo_root
from studies.common.memo import once


def _git(*args: str) -> str:
    try:
        done = subprocess.run(
            ["git", "-C", str(repo_root()), *args],
            capture_output=True,
            check=True,
            timeout=60,
        )
    except (OSError, subprocess.SubprocessError):
        return ""
    return done.stdout.decode("utf-8", "replace")


@once
def revision() -> str:
    return _git("rev-parse", "HEAD").strip() or "unknown"


@once
def diff_hash() -> str:
    """sha256 of ``git diff HEAD`` (empty diff -> hash of the empty string)."""
    return hashlib.sha256(_git("diff", "HEAD").encode()).hexdigest()


@once
def is_dirty() -> bool:
    return bool(_git("status", "--porcelain", "--untracked-files=no").strip())
