"""Run the project's tools, through the cache.

* ``run_mpm(case)``      ``build/bin/pfm-mpm run CASE.json --out DIR [--threads N]``
* ``run_detect(csv, config)``  ``build/bin/pfm-mpm detect PARTICLES.csv --config DETECT.json --out DIR``
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

MPM_EXECUTABLE = "pfm-mpm"
DOLFINX_MODULE = "fem_reference.dolfinx_model"


class RunFailed(RuntimeError):
    """A tool exited non-zero. ``returncode`` and ``stderr`` (its end) are kept so a study
    can tell a rejected input (exit code 2, see ``rejected_feature``) from a crash."""

    def __init__(self, message: str, returncode: Optional[int] = None, stderr: str = ""):
        super().__init__(message)
        self.returncode = returncode
        self.stderr = stderr

    def rejected_feature(self) -> Optional[str]:
        """The case-file message when the tool rejected the input as not (yet) supported
        ("unknown key", "must be one of"): the study then records "not run: needs ...".
        None for any other failure."""
        if self.returncode != 2:
            return None
        match = re.search(r"(/[\w/]*): ((?:unknown key|must be one of|not supported)[^\n]*)",
                          self.stderr)
        return f"{match.group(1)}: {match.group(2)}" if match else None

    def __reduce__(self):  # keep the attributes across process pools
        return (RunFailed, (str(self), self.returncode, self.stderr))


@dataclass
class RunResult:
    folder: Path          # cache entry (or temporary folder)
    out: Path             # the tool's --out folder
    command: list
    seconds: float        # wall time of the tool when it ran (read back on a cache hit)
    cache_hit: bool


def _execute(command: list, folder: Path, cwd: Optional[Path] = None,
             timeout: Optional[float] = None) -> float:
    started = time.perf_counter()
    with open(folder / "stdout.log", "wb") as out, open(folder / "stderr.log", "wb") as err:
        try:
            done = subprocess.run(command, stdout=out, stderr=err, cwd=cwd, timeout=timeout)
        except subprocess.TimeoutExpired as error:
            raise RunFailed(f"{' '.join(map(str, command))}: timed out after {timeout} s") \
                from error
    seconds = time.perf_counter() - started
    if done.returncode != 0:
        tail = (folder / "stderr.log").read_text(errors="replace")[-2000:]
        raise RunFailed(f"{Path(str(command[0])).name} exited with code {done.returncode}: "
                        f"{tail.strip().splitlines()[-1] if tail.strip() else ''}",
                        done.returncode, tail)
    (folder / "wall_time.json").write_text(json.dumps({"seconds": seconds}) + "\n")
    return seconds


def _run(command_of, key_case, key_arguments, extra, use_cache, cache, timeout, cwd=None
         ) -> RunResult:
    """``command_of(folder)`` -> (command list, out folder); it may write inputs into folder."""
    record = {}

    def make(folder: Path) -> None:
        command, out = command_of(folder)
        record["command"] = [str(c) for c in command]
        record["out"] = out
        (folder / "command.json").write_text(json.dumps(record["command"]) + "\n")
        record["seconds"] = _execute(record["command"], folder, cwd=cwd, timeout=timeout)

    if not use_cache:   # the caller removes result.folder when done with it
        folder = Path(tempfile.mkdtemp(prefix="pfm-run-"))
        try:
            make(folder)
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)   # RunFailed carries the stderr
            raise
        return RunResult(folder, record["out"], record["command"], record["seconds"], False)
    cache = cache or Cache()
    key = cache_key(key_case, key_arguments, extra)
    folder, hit = cache.produce(key, make, info={"arguments": [str(a) for a in key_arguments]})
    if hit:
        _, out = command_of(None)
        command = json.loads((folder / "command.json").read_text())
        seconds = json.loads((folder / "wall_time.json").read_text())["seconds"]
        return RunResult(folder, folder / out, command, seconds, True)
    return RunResult(folder, record["out"], record["command"], record["seconds"], False)


def run_mpm(case: dict, threads: Optional[int] = None, use_cache: bool = True,
            cache: Optional[Cache] = None, timeout: Optional[float] = None) -> RunResult:
    executable = tool_path(MPM_EXECUTABLE)
    arguments = ["run"] + (["--threads", str(threads)] if threads else [])

    def command_of(folder):
        if folder is None:
            return None, "out"
        (folder / "case.json").write_text(json.dumps(case, indent=2, sort_keys=True) + "\n")
        command = [executable, "run", folder / "case.json", "--out", folder / "out"]
        if threads:
            command += ["--threads", str(threads)]
        return command, folder / "out"

    return _run(command_of, case, arguments, {"executable": file_sha256(executable)},
                use_cache, cache, timeout)


def run_detect(particles_csv: Path, config: dict, use_cache: bool = True,
               cache: Optional[Cache] = None, timeout: Optional[float] = None) -> RunResult:
    executable = tool_path(MPM_EXECUTABLE)
    particles_csv = Path(particles_csv)
    if not particles_csv.is_file():
        raise PrerequisiteMissing(f"{particles_csv}")

    def command_of(folder):
        if folder is None:
            return None, "out"
        (folder / "detect.json").write_text(json.dumps(config, indent=2, sort_keys=True) + "\n")
        return ([executable, "detect", particles_csv, "--config", folder / "detect.json",
                 "--out", folder / "out"], folder / "out")

    extra = {"executable": file_sha256(executable), "particles": file_sha256(particles_csv)}
    return _run(command_of, config, ["detect"], extra, use_cache, cache, timeout)


def dolfinx_module_file() -> Path:
    """The file whose hash stands for the dolfinx model's code (package or single module)."""
    base = repo_root() / "fem_reference"
    for candidate in (base / "dolfinx_model" / "__main__.py", base / "dolfinx_model.py"):
        if candidate.is_file():
            return candidate
    raise PrerequisiteMissing("fem_reference/dolfinx_model")


def _tree_hash(folder: Path) -> str:
    digest = hashlib.sha256()
    for path in sorted(folder.rglob("*.py")):
        digest.update(str(path.relative_to(folder)).encode())
        digest.update(file_sha256(path).encode())
    return digest.hexdigest()


def run_dolfinx(case: dict, arguments: Sequence[str] = (), use_cache: bool = True,
                cache: Optional[Cache] = None, timeout: Optional[float] = None) -> RunResult:
    """``arguments``: the model's options (``--mode explicit``, ``--updated-lagrangian``...)."""
    module_file = dolfinx_module_file()
    arguments = [str(a) for a in arguments]

    def command_of(folder):
        if folder is None:
            return None, "out"
        (folder / "case.json").write_text(json.dumps(case, indent=2, sort_keys=True) + "\n")
        return ([sys.executable, "-m", DOLFINX_MODULE, folder / "case.json", "--out",
                 folder / "out", *arguments], folder / "out")

    return _run(command_of, case, ["dolfinx", *arguments],
                {"module": _tree_hash(module_file.parent)}, use_cache, cache, timeout,
                cwd=repo_root())


def run_tool(name: str, arguments: Sequence[str], use_cache: bool = True,
             cache: Optional[Cache] = None, timeout: Optional[float] = None) -> RunResult:
    """Run ``build/bin/<name>``; every ``{out}`` in ``arguments`` becomes the output folder."""
    executable = tool_path(name)
    arguments = [str(a) for a in arguments]

    def command_of(folder):
        if folder is None:
            return None, "out"
        out = folder / "out"
        out.mkdir(exist_ok=True)
        return [executable] + [a.replace("{out}", str(out)) for a in arguments], out

    return _run(command_of, None, [name, *arguments], {"executable": file_sha256(executable)},
                use_cache, cache, timeout)


def env_threads() -> Optional[int]:
    value = os.environ.get("PFM_THREADS")
    return int(value) if value else None
