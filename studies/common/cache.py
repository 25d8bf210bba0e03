"""A content-addressed cache of tool runs.

Key = sha256 of the canonical JSON text of
``{"case": <case, canonical JSON text>, "revision": git HEAD, "diff": sha256(git diff HEAD),
"arguments": [tool arguments], "extra": {...}}``, where the canonical text is
``json.dumps(case, sort_keys=True, separators=(",", ":"))`` so key order and whitespace in the
case file do not matter. ``extra`` holds what else decides the result (the sha256 of the
executable, for example). An entry is a folder ``<cache root>/<key[:2]>/<key>/`` holding the
run's outputs; it counts only once its ``.complete.json`` marker exists (written last), so an
interrupted run is never mistaken for a result.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import time
from pathlib import Path
from typing import Callable, Optional

from studies.common import gitinfo
from studies.common.paths import cache_root

MARKER = ".complete.json"
# PFM_CACHE_MAX_MB: least recently used entries go beyond this size.
DEFAULT_MAX_MB = 600


def canonical_json(value) -> str:
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=True)


def file_sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def cache_key(
    case,
    arguments=(),
    extra=None,
    revision: Optional[str] = None,
    diff: Optional[str] = None,
) -> str:
    """``case`` is a dict (the parsed case) or None; revision/diff default to the repository's."""
    payload = {
        "case": canonical_json(case) if case is not None else None,
        "revision": revision if revision is not None else gitinfo.revision(),
        "diff": diff if diff is not None else gitinfo.diff_hash(),
        "arguments": [str(a) for a in arguments],
        "extra": extra or {},
    }
    return hashlib.sha256(canonical_json(payload).encode()).hexdigest()


class Cache:
    def __init__(self, root: Optional[Path] = None):
        self.root = Path(root) if root is not None else cache_root()

    def folder(self, key: str) -> Path:
        return self.root / key[:2] / key

    def lookup(self, key: str) -> Optional[Path]:
        folder = self.folder(key)
        return folder if (folder / MARKER).is_file() else None

    def produce(
        self, key: str, make: Callable[[Path], None], info: Optional[dict] = None
    ) -> tuple[Path, bool]:
        """Return ``(folder, hit)``. On a miss, ``make(folder)`` fills a fresh folder; the entry
        is committed only if it returns without raising (a failed attempt is removed).
        """
        hit = self.lookup(key)
        if hit is not None:
            os.utime(hit / MARKER)  # recently used: pruned last
            return hit, True
        folder = self.folder(key)
        if folder.exists():
            shutil.rmtree(folder)
        folder.mkdir(parents=True)
        started = time.time()
        try:
            make(folder)
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)
            raise
        marker = {"key": key, "seconds": time.time() - started, **(info or {})}
        (folder / MARKER).write_text(
            json.dumps(marker, indent=2, sort_keys=True) + "\n"
        )
        return folder, False

    def entries(self) -> list[tuple[float, int, Path]]:
        """(last use time, bytes, folder) of every complete entry."""
        found = []
        if not self.root.is_dir():
            return found
        for marker in self.root.glob(f"*/*/{MARKER}"):
            folder = marker.parent
            size = sum(f.stat().st_size for f in folder.rglob("*") if f.is_file())
            found.append((marker.stat().st_mtime, size, folder))
        return found

    def prune(self, max_bytes: Optional[int] = None) -> int:
        """Remove the least recently used entries until the cache holds at most ``max_bytes``
        (default PFM_CACHE_MAX_MB, 600 MB); returns the bytes removed."""
        if max_bytes is None:
            max_bytes = int(
                float(os.environ.get("PFM_CACHE_MAX_MB", DEFAULT_MAX_MB)) * 1e6
            )
        entries = sorted(self.entries())
        total = sum(size for _, size, _ in entries)
        removed = 0
        for _, size, folder in entries:
            if total - removed <= max_bytes:
                break
            shutil.rmtree(folder, ignore_errors=True)
            removed += size
        return removed
