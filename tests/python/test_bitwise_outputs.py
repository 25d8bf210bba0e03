"""Two runs of the same case give byte-identical files (issue "Outputs that survive", item 5).

HDF5 stamps each dataset with the second it was made unless told not to; the writers turn the
object times off (mpm/step/hdf5_untimed.hpp). Every shipped case (MPM, and the column with the
UL-FEM) runs to its end time twice, on 1 and on 2 threads, more
than a second apart: every output file but run.json (which records the times and the thread
counts of its run) must be the same bytes.
"""

import json
import subprocess
import time
from pathlib import Path

import pytest

from test_energy_identity import assert_ledger_closes

ROOT = Path(__file__).resolve().parents[2]


def run(pfm_binary, case, out, threads, *extra):
    subprocess.run(
        [
            pfm_binary,
            "run",
            str(case),
            "--out",
            str(out),
            "--threads",
            str(threads),
            *extra,
        ],
        check=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


CASES = sorted(p.name for p in (ROOT / "cases").glob("*.json"))


@pytest.mark.parametrize(
    "case, extra",
    [(case, []) for case in CASES] + [("column.json", ["--solver", "ulfem"])],
)
def test_two_runs_write_the_same_bytes(pfm_binary, tmp_path, case, extra):
    first, second = tmp_path / "first", tmp_path / "second"
    run(pfm_binary, ROOT / "cases" / case, first, 1, *extra)
    time.sleep(1.1)  # a later second for any time stamp
    run(pfm_binary, ROOT / "cases" / case, second, 2, *extra)
    names = sorted(p.name for p in first.iterdir() if p.name != "run.json")
    assert names == sorted(p.name for p in second.iterdir() if p.name != "run.json")
    assert any(name.endswith(".h5") for name in names)
    for name in names:
        assert (first / name).read_bytes() == (second / name).read_bytes(), name
    # The energy ledger closes at every row (test_energy_identity.py).
    assert_ledger_closes(
        first, json.loads((ROOT / "cases" / case).read_text())["time"]["end_time"]
    )
    a = json.loads((first / "run.json").read_text())
    b = json.loads((second / "run.json").read_text())
    assert a["outputs"] == b["outputs"]
    assert a["summary"]["energy"] == b["summary"]["energy"]
    # --threads fixes the count: the run records it, never changed.
    assert a["summary"]["threads"] == {"policy": "fixed", "fewest": 1, "most": 1}
    assert b["summary"]["threads"] == {"policy": "fixed", "fewest": 2, "most": 2}
