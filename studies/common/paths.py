"""Where things are: the repository, the build, the results and the run cache.

Environment overrides (all optional):

* ``PFM_RESULTS``   results root; a study writes to ``$PFM_RESULTS/<study>/``
                    (default ``<repo>/results/studies``);
* ``PFM_MPM``       the ``pfm-mpm`` executable (default ``<repo>/build/bin/pfm-mpm``, or
                    ``$PFM_BUILD_DIR/bin/pfm-mpm``, or where there is no build (a Dask worker
                    on another machine) the one on the PATH). The one setting that picks the
                    solver; the
                    other executables (``pfm-quadrature-map``, ``pfm-ulfem``) are taken from
                    ``PFM_BUILD_DIR`` when it is set, else from the directory of ``PFM_MPM``;
* ``PFM_BUILD_DIR`` directory holding the binaries, either the build root (``.../build``, the
                    binaries then in ``bin/``) or the ``bin`` directory itself;
* ``PFM_CACHE``     run cache root (default ``<repo>/studies/.cache``, git-ignored).
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

_REPO_ROOT = Path(__file__).resolve().parents[2]


class PrerequisiteMissing(RuntimeError):
    """A study cannot run because something it needs is not there yet (a binary, an output
    file, a case file). ``needs`` is the short phrase the report shows: "not run: needs X".
    """

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


def _bin_of(directory: str) -> Path:
    path = Path(directory).resolve()
    return path / "bin" if (path / "bin").is_dir() else path


def build_dir() -> Path:
    """The directory that holds the executables other than pfm-mpm (``.../build/bin``)."""
    env = os.environ.get("PFM_BUILD_DIR")
    if env:
        return _bin_of(env)
    mpm = os.environ.get("PFM_MPM")
    if mpm:
        return Path(mpm).resolve().parent
    built = _REPO_ROOT / "build" / "bin"
    installed = shutil.which("pfm-mpm")
    if not built.is_dir() and installed:
        return Path(installed).resolve().parent
    return built


def core():
    """The module pfm_mpm on the C++ core (python/README.md): importable as is, or from the
    build beside the binaries (``<build dir>/../python``) or the repository's ``build/python``;
    PrerequisiteMissing when it is not built."""
    try:
        import pfm_mpm
    except ImportError:
        for build in (build_dir().parent, _REPO_ROOT / "build"):
            if (build / "python" / "pfm_mpm").is_dir():
                sys.path.append(str(build / "python"))
                break
        try:
            import pfm_mpm
        except ImportError as err:
            raise PrerequisiteMissing(f"the module pfm_mpm (make build): {err}")
    return pfm_mpm


def mpm_executable() -> Path:
    """The ``pfm-mpm`` executable: ``PFM_MPM``, else ``<build dir>/pfm-mpm``; raises
    PrerequisiteMissing when it is not there."""
    env = os.environ.get("PFM_MPM")
    path = Path(env).resolve() if env else build_dir() / "pfm-mpm"
    if not (path.is_file() and os.access(path, os.X_OK)):
        raise PrerequisiteMissing(f"{_show(path)} (not built; set PFM_MPM)")
    return path


def _show(path: Path) -> str:
    return (
        str(path.relative_to(_REPO_ROOT))
        if path.is_relative_to(_REPO_ROOT)
        else str(path)
    )


def cmake_build_root() -> Path:
    """The CMake build root (holds CMakeCache.txt) of pfm-mpm, the parent of its ``bin``."""
    env = os.environ.get("PFM_MPM")
    return (Path(env).resolve().parent if env else build_dir()).parent


def cache_root() -> Path:
    env = os.environ.get("PFM_CACHE")
    return Path(env).resolve() if env else _REPO_ROOT / "studies" / ".cache"


def tool_path(name: str) -> Path:
    """Path of an executable in the build; raises PrerequisiteMissing when it is not built.
    ``pfm-mpm`` goes through mpm_executable() (the PFM_MPM setting)."""
    if name == "pfm-mpm":
        return mpm_executable()
    path = build_dir() / name
    if not (path.is_file() and os.access(path, os.X_OK)):
        raise PrerequisiteMissing(f"{_show(path)} (not built)")
    return path
