"""Sweeps on a real Dask cluster (issue 46, must-show 6): a `dask-scheduler` and two
`dask-worker` processes started as the Dask documentation says, in a folder outside the
checkout and without PYTHONPATH (they know nothing of the `studies` package), run a sweep of
the studies; its results equal the local run's, byte for byte."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

distributed = pytest.importorskip("distributed")

from studies import parametric  # noqa: E402
from studies.common.parallel import parallel_map  # noqa: E402
from studies.common.paths import mpm_executable  # noqa: E402


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def small_cases() -> list[dict]:
    """The elastic column (cases/column.json) shortened, at two moduli."""
    import json

    base = json.loads((ROOT / "cases" / "column.json").read_text())
    cases = []
    for modulus in (4000.0, 6000.0):
        case = json.loads(json.dumps(base))
        case["materials"][0]["youngs_modulus"] = modulus
        case["time"]["end_time"] = 0.2
        case["output"]["interval"] = 0.1
        cases.append(case)
    return cases


@pytest.fixture
def cluster(tmp_path):
    """A scheduler and two workers in tmp_path/outside, their environment without PYTHONPATH;
    the workers get PFM_MPM (the binary) and a run cache of their own."""
    for tool in ("dask-scheduler", "dask-worker"):
        if shutil.which(tool) is None:
            pytest.skip(f"{tool} not installed (Debian: python3-distributed)")
    outside = tmp_path / "outside"
    outside.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "PFM_"))}
    worker_env = dict(
        env, PFM_MPM=str(mpm_executable()), PFM_CACHE=str(tmp_path / "cache_dask")
    )
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    log = open(tmp_path / "cluster.log", "w")
    processes = [
        subprocess.Popen(
            [
                "dask-scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
                "--no-dashboard",
            ],
            cwd=outside,
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
    ]
    try:
        for _ in range(2):
            processes.append(
                subprocess.Popen(
                    ["dask-worker", address, "--nworkers", "1", "--nthreads", "1"]
                    + ["--no-dashboard"],
                    cwd=outside,
                    env=worker_env,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                )
            )
        with distributed.Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=60)
        yield address
    finally:
        for process in reversed(processes):
            process.terminate()
        for process in processes:
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
        log.close()


def test_sweep_on_workers_without_the_checkout_equals_the_local_run(
    cluster, tmp_path, monkeypatch
):
    cases = small_cases()
    # The workers cannot import the package (the state the issue found: "No module named
    # 'studies'" on the workers) ...
    probe = subprocess.run(
        ["/usr/bin/python3", "-c", "import studies"],
        cwd=tmp_path / "outside",
        env={k: v for k, v in os.environ.items() if not k.startswith("PYTHON")},
        capture_output=True,
    )
    assert probe.returncode != 0
    # ... yet the sweep runs on them: the studies' functions travel with the tasks.
    on_cluster = [
        Path(p) for p in parallel_map(parametric._mpm, cases, scheduler=cluster)
    ]
    monkeypatch.setenv("PFM_CACHE", str(tmp_path / "cache_local"))
    local = [Path(p) for p in parallel_map(parametric._mpm, cases, jobs=1)]
    for remote, here in zip(on_cluster, local):
        assert remote.is_relative_to(tmp_path / "cache_dask")  # the workers ran them
        assert here.is_relative_to(tmp_path / "cache_local")
        names = sorted(p.name for p in here.iterdir() if p.name != "run.json")
        assert {"particles.h5", "timeseries.csv"} <= set(names)
        for name in names:
            assert (remote / name).read_bytes() == (here / name).read_bytes(), name
