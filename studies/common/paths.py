"""Where things are: the repository, the build, the results and the run cache.

Environment overrides (all optional):

* ``PFM_RESULTS``   results root; a study writes to ``$PFM_RESULTS/<study>/``
                    (default ``<repo>/results/studies``);
* ``PFM_BUILD_DIR`` directory holding the binaries, either the build root (``.../build``, the
                    binaries then in ``bin/``) or the ``bin`` directory itself
                    (default ``<repo>/build/bin``);
* ``PFM_CACHE``     run cache root (default ``<repo>/studies/.cache``, git-ignored).
"""

from __future__ import annotations

import os
from pathlib import Path

_REPO_ROOT = Path(__file__).resolve().parents[2]


class PrerequisiteMissing(RuntimeError):
    """A study cannot run because something it needs is not there yet (a binary, an output
    file, a case file). ``needs`` is the short phrase the report shows: "not run: needs X"."""

    def __init__(self, needs: str):
        super().__init__(f"needs {needs}")
        self.needs = needs

    def __reduce__(self):  # survive process pools
        return (PrerequisiteMissing, (self.needs,))


def repo_root() -> Path:
    return _REPO_ROOT


def results_root() -> Path:
    env = os.environ.get("PFM_RESULTS")
    return Path(env).resolve() if env else _REPO_ROOT / "results" / "studies"


def study_dir(name: str, create: bool = True) -> Path:
    path = results_root() / name
    if create:
        path.mkdir(parents=True, exist_ok=True)
    return path


def build_dir() -> Path:
    """The directory that holds the executables (``.../build/bin``)."""
    env = os.environ.get("PFM_BUILD_DIR")
    if not env:
        return _REPO_ROOT / "build" / "bin"
    path = Path(env).resolve()
    return path / "bin" if (path / "bin").is_dir() else path


def cmake_build_root() -> Path:
    """The CMake build root (holds CMakeCache.txt), the parent of ``bin``."""
    return build_dir().parent


def cache_root() -> Path:
    env = os.environ.get("PFM_CACHE")
    return Path(env).resolve() if env else _REPO_ROOT / "studies" / ".cache"


def tool_path(name: str) -> Path:
    """Path of an executable in the build; raises PrerequisiteMissing when it is not built."""
    path = build_dir() / name
    if not (path.is_file() and os.access(path, os.X_OK)):
        raise PrerequisiteMissing(f"{path.relative_to(_REPO_ROOT) if path.is_relative_to(_REPO_ROOT) else path} (not built)")
    return path
