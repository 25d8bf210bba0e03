"""Run the project's tools, through the cache.

* ``run_mpm(case, solver="mpm"|"ulfem")``  ``pfm-mpm run CASE.json --out DIR [--solver ulfem]
  [--threads N] --quiet`` (``pfm-ulfem CASE.json DIR`` while ``run`` has no ``--solver``)
* ``run_detect(csv, config[, library=True])``  ``pfm-mpm detect PARTICLES.csv --config DETECT.json
  --out DIR`` or the library baseline ``/usr/bin/python3 -m studies.detectors.skimage_detector`` (same
  arguments)
* ``run_dolfinx(case)``  ``/usr/bin/python3 -m fem_reference.dolfinx_model CASE.json --out DIR``
* ``run_tool(name, args)``  any other executable of the build (``{out}`` in args is replaced by
  the output folder), e.g. ``pfm-quadrature-map --out {out} --resolution 41``.

Each returns a ``RunResult`` whose ``out`` folder holds the tool's outputs; ``case.json``,
``stdout.log`` and ``stderr.log`` sit beside it in the cache entry. A missing executable raises
``PrerequisiteMissing``; a non-zero exit raises ``RunFailed`` carrying the end of stderr.
``use_cache=False`` (timing runs) runs in a fresh temporary folder every time.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

from studies.common.cache import Cache, cache_key, file_sha256
from studies.common.paths import PrerequisiteMissing, repo_root, tool_path
from studies.common.memo import once

MPM_EXECUTABLE = "pfm-mpm"
EXIT_STOPPED = (
    3  # pfm-mpm / pfm-ulfem: the simulation stopped (NaN, CFL, inverted element)
)
DOLFINX_MODULE = "fem_reference.dolfinx_model"


class RunFailed(RuntimeError):
    """A tool exited non-zero. ``returncode`` and ``stderr`` (its end) are kept so a study
    can tell a rejected input (exit code 2, see ``rejected_feature``) from a crash."""

    def __init__(
        self, message: str, returncode: Optional[int] = None, stderr: str = ""
    ):
        super().__init__(message)
        self.returncode = returncode
        self.stderr = stderr

    def rejected_feature(self) -> Optional[str]:
        """The case-file message when the tool rejected the input as not (yet) supported
        ("unknown key", "must be one of"): the study then records "not run: needs ...".
        None for any other failure."""
        if self.returncode != 2:
            return None
        match = re.search(
            r"(/[\w/]*): ((?:unknown key|must be one of|not supported|not implemented|not available)[^\n]*)",
            self.stderr,
        )
        return f"{match.group(1)}: {match.group(2)}" if match else None

    def __reduce__(self):  # keep the attributes across process pools
        return (RunFailed, (str(self), self.returncode, self.stderr))


@dataclass
class RunResult:
    folder: Path  # cache entry (or temporary folder)
    out: Path  # the tool's --out folder
    command: list
    seconds: float  # wall time of the tool when it ran (read back on a cache hit)
    cache_hit: bool
    returncode: int = 0  # 3: the simulation stopped early (outputs up to then are kept)

    @property
    def stopped(self) -> bool:
        return self.returncode == EXIT_STOPPED


def _execute(
    command: list,
    folder: Path,
    cwd: Optional[Path] = None,
    timeout: Optional[float] = None,
    accept: Sequence[int] = (0,),
) -> tuple:
    """Run ``command``; (wall seconds, exit code). An exit code outside ``accept`` raises
    RunFailed with the end of stderr."""
    started = time.perf_counter()
    with open(folder / "stdout.log", "wb") as out, open(
        folder / "stderr.log", "wb"
    ) as err:
        try:
            done = subprocess.run(
                command, stdout=out, stderr=err, cwd=cwd, timeout=timeout
            )
        except subprocess.TimeoutExpired as error:
            raise RunFailed(
                f"{' '.join(map(str, command))}: timed out after {timeout} s"
            ) from error
    seconds = time.perf_counter() - started
    if done.returncode not in accept:
        raise _failure(command, done.returncode, folder)
    (folder / "wall_time.json").write_text(
        json.dumps({"seconds": seconds, "returncode": done.returncode}) + "\n"
    )
    return seconds, done.returncode


def _failure(command, returncode: int, folder: Path) -> RunFailed:
    """The error of a run that exited with `returncode`: the program's name and the last line
    of its stderr (the last 2000 characters kept in the error)."""
    tail = (folder / "stderr.log").read_text(errors="replace")[-2000:]
    return RunFailed(
        f"{Path(str(command[0])).name} exited with code {returncode}: "
        f"{tail.strip().splitlines()[-1] if tail.strip() else ''}",
        returncode,
        tail,
    )


def _run(
    command_of,
    key_case,
    key_arguments,
    extra,
    use_cache,
    cache,
    timeout,
    cwd=None,
    accept: Sequence[int] = (0,),
    drop: Sequence[str] = (),
) -> RunResult:
    """``command_of(folder)`` -> (command list, out folder); it may write inputs into folder.
    ``drop``: output files removed after a cached run (what no study reads)."""
    record = {}

    def make(folder: Path) -> None:
        command, out = command_of(folder)
        record["command"] = [str(c) for c in command]
        record["out"] = out
        (folder / "command.json").write_text(json.dumps(record["command"]) + "\n")
        record["seconds"], record["returncode"] = _execute(
            record["command"], folder, cwd=cwd, timeout=timeout, accept=accept
        )
        if use_cache:
            for name in drop:
                (Path(out) / name).unlink(missing_ok=True)

    def fresh(folder: Path) -> RunResult:
        return RunResult(
            folder,
            record["out"],
            record["command"],
            record["seconds"],
            False,
            record["returncode"],
        )

    if not use_cache:  # the caller removes result.folder when done with it
        folder = Path(tempfile.mkdtemp(prefix="pfm-run-"))
        try:
            make(folder)
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)  # RunFailed carries the stderr
            raise
        return fresh(folder)
    cache = cache or Cache()
    key = cache_key(key_case, key_arguments, extra, **_NO_REVISION)
    folder, hit = cache.produce(
        key, make, info={"arguments": [str(a) for a in key_arguments]}
    )
    if hit:
        _, out = command_of(None)
        command = json.loads((folder / "command.json").read_text())
        wall = json.loads((folder / "wall_time.json").read_text())
        returncode = wall.get("returncode", 0)
        if (
            returncode not in accept
        ):  # a stopped run cached for a caller that accepts it
            raise _failure(command, returncode, folder)
        return RunResult(
            folder, folder / out, command, wall["seconds"], True, returncode
        )
    return fresh(folder)


# Outputs no study reads, removed from cached runs to keep the cache small: the UL-FEM's mesh
# series, and final_particles.csv (the last particles.h5 frame holds the same state; read it
# with studies.common.outputs.final_particles).
DROPPED_OUTPUTS = ("mesh.h5", "mesh.xdmf", "final_particles.csv")

# Solvers of ``run_mpm``: the MPM, and the updated-Lagrangian FEM (method map section 2).
SOLVERS = ("mpm", "ulfem")
ULFEM_EXECUTABLE = (
    "pfm-ulfem"  # stand-alone UL-FEM driver, used until `run --solver` exists
)
# The cache key leaves out the git revision and diff: the sha256 of the executable (or of the
# Python sources) is what decides a result, and a key that changed with every edit anywhere in
# the tree would make the cache useless while others work on the code.
_NO_REVISION = {"revision": "-", "diff": "-"}


@once
def _run_help(executable: str) -> str:
    try:
        done = subprocess.run(
            [executable, "run", "--help"], capture_output=True, timeout=60
        )
    except (OSError, subprocess.SubprocessError):
        return ""
    return done.stdout.decode(errors="replace") + done.stderr.decode(errors="replace")


def mpm_has_solver_option(executable: Optional[Path] = None) -> bool:
    """Whether ``pfm-mpm run`` takes ``--solver mpm|ulfem``."""
    return "--solver" in _run_help(str(executable or tool_path(MPM_EXECUTABLE)))


def run_mpm(
    case: dict,
    threads: Optional[int] = None,
    solver: str = "mpm",
    use_cache: bool = True,
    cache: Optional[Cache] = None,
    timeout: Optional[float] = None,
    allow_stopped: bool = False,
) -> RunResult:
    """``pfm-mpm run CASE --out DIR [--solver ulfem] [--threads N] --quiet``. Without the
    ``--solver`` option in pfm-mpm, ``solver="ulfem"`` runs ``pfm-ulfem CASE DIR [THREADS]``
    (same outputs). ``allow_stopped``: a simulation that stopped early (exit code 3, e.g. a
    collapsing slope violating the CFL condition or an inverted UL-FEM element) is a result
    (``RunResult.stopped``; no final_particles.csv, run.json "error" says why)."""
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
    executable = tool_path(MPM_EXECUTABLE)
    standalone = solver == "ulfem" and not mpm_has_solver_option(executable)
    if standalone:
        executable = tool_path(ULFEM_EXECUTABLE)
    arguments = ["run", "--solver", solver] + (
        ["--threads", str(threads)] if threads else []
    )

    def command_of(folder):
        if folder is None:
            return None, "out"
        (folder / "case.json").write_text(
            json.dumps(case, indent=2, sort_keys=True) + "\n"
        )
        if standalone:
            command = [executable, folder / "case.json", folder / "out"]
            return command + ([str(threads)] if threads else []), folder / "out"
        command = [
            executable,
            "run",
            folder / "case.json",
            "--out",
            folder / "out",
            "--quiet",
        ]
        if solver != "mpm":
            command += ["--solver", solver]
        if threads:
            command += ["--threads", str(threads)]
        return command, folder / "out"

    return _run(
        command_of,
        case,
        arguments,
        {"executable": file_sha256(executable)},
        use_cache,
        cache,
        timeout,
        accept=(0, EXIT_STOPPED) if allow_stopped else (0,),
        drop=DROPPED_OUTPUTS,
    )


# The library baseline detector (scikit-image), a Python module with the `detect` contract.
LIBRARY_DETECTOR_MODULE = "studies.detectors.skimage_detector"


def library_detector_folder() -> Path:
    folder = repo_root() / "studies" / "detectors"
    if not (folder / "skimage_detector.py").is_file():
        raise PrerequisiteMissing(
            "studies/detectors/skimage_detector.py (library baseline)"
        )
    return folder


def run_detect(
    particles_csv: Path,
    config: dict,
    library: bool = False,
    use_cache: bool = True,
    cache: Optional[Cache] = None,
    timeout: Optional[float] = None,
) -> RunResult:
    """``pfm-mpm detect PARTICLES.csv --config DETECT.json --out DIR`` (``library``: the same
    contract through ``/usr/bin/python3 -m studies.detectors.skimage_detector``); the result's
    ``out`` holds ``boundary.csv`` (loop,x,y) and ``summary.json``."""
    particles_csv = Path(particles_csv)
    if not particles_csv.is_file():
        raise PrerequisiteMissing(f"{particles_csv}")
    if library:
        code = {"module": _tree_hash(library_detector_folder())}
        program = [sys.executable, "-m", LIBRARY_DETECTOR_MODULE]
    else:
        executable = tool_path(MPM_EXECUTABLE)
        code = {"executable": file_sha256(executable)}
        program = [executable, "detect"]

    def command_of(folder):
        if folder is None:
            return None, "out"
        (folder / "detect.json").write_text(
            json.dumps(config, indent=2, sort_keys=True) + "\n"
        )
        return (
            [
                *program,
                particles_csv,
                "--config",
                folder / "detect.json",
                "--out",
                folder / "out",
            ],
            folder / "out",
        )

    extra = {**code, "particles": file_sha256(particles_csv)}
    return _run(
        command_of,
        config,
        ["detect", "library" if library else "pfm-mpm"],
        extra,
        use_cache,
        cache,
        timeout,
        cwd=repo_root(),
    )


def dolfinx_module_file() -> Path:
    """The file whose hash stands for the dolfinx model's code (package or single module)."""
    base = repo_root() / "fem_reference"
    for candidate in (
        base / "dolfinx_model" / "__main__.py",
        base / "dolfinx_model.py",
    ):
        if candidate.is_file():
            return candidate
    raise PrerequisiteMissing("fem_reference/dolfinx_model")


def _tree_hash(folder: Path) -> str:
    digest = hashlib.sha256()
    for path in sorted(folder.rglob("*.py")):
        digest.update(str(path.relative_to(folder)).encode())
        digest.update(file_sha256(path).encode())
    return digest.hexdigest()


def run_dolfinx(
    case: dict,
    arguments: Sequence[str] = (),
    use_cache: bool = True,
    cache: Optional[Cache] = None,
    timeout: Optional[float] = None,
    accept: Sequence[int] = (0,),
) -> RunResult:
    """``arguments``: the model's options (``--mode explicit``, ``--updated-lagrangian``...).
    ``accept``: the exit codes that are results (3: a static run stopped before its end, its
    outputs up to then)."""
    module_file = dolfinx_module_file()
    arguments = [str(a) for a in arguments]

    def command_of(folder):
        if folder is None:
            return None, "out"
        (folder / "case.json").write_text(
            json.dumps(case, indent=2, sort_keys=True) + "\n"
        )
        return (
            [
                sys.executable,
                "-m",
                DOLFINX_MODULE,
                folder / "case.json",
                "--out",
                folder / "out",
                *arguments,
            ],
            folder / "out",
        )

    return _run(
        command_of,
        case,
        ["dolfinx", *arguments],
        {"module": _tree_hash(module_file.parent)},
        use_cache,
        cache,
        timeout,
        cwd=repo_root(),
        accept=accept,
    )


def run_tool(
    name: str,
    arguments: Sequence[str],
    use_cache: bool = True,
    cache: Optional[Cache] = None,
    timeout: Optional[float] = None,
) -> RunResult:
    """Run ``build/bin/<name>``; every ``{out}`` in ``arguments`` becomes the output folder."""
    executable = tool_path(name)
    arguments = [str(a) for a in arguments]

    def command_of(folder):
        if folder is None:
            return None, "out"
        out = folder / "out"
        out.mkdir(exist_ok=True)
        return [executable] + [a.replace("{out}", str(out)) for a in arguments], out

    return _run(
        command_of,
        None,
        [name, *arguments],
        {"executable": file_sha256(executable)},
        use_cache,
        cache,
        timeout,
    )


def env_threads() -> Optional[int]:
    value = os.environ.get("PFM_THREADS")
    return int(value) if value else None
