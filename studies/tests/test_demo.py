"""`make run` (studies.demo) end to end against the stand-in pfm-mpm: the MPM boundary is the
outline 0.1 m above the UL-FEM's, so the free-surface distance is 0.1 m at every output."""

import shutil
import stat
from pathlib import Path

import pandas as pd

from studies import demo
from studies.common import runner
from studies.tests import fake_mpm

CASE = """{"title": "block", "grid": {"origin": [0, 0], "cell_size": 0.5, "n_cells": [30, 15]},
 "bodies": [{"rectangle": [[0, 0], [15, 5]]}], "time": {"end_time": 0.5},
 "output": {"interval": 0.25}, "detection": {"method": "improved"},
 "loads": [{"type": "vertical_pressure", "pressure": 50, "x_range": [5, 10],
            "apply_on": "detected_boundary"}]}"""


def test_demo_compares_the_detected_and_the_fem_boundary(isolated, tmp_path, capsys):
    tool = isolated["bin"] / "pfm-mpm"
    shutil.copy(Path(fake_mpm.__file__), tool)
    tool.chmod(tool.stat().st_mode | stat.S_IXUSR)
    runner._run_help.cache_clear()
    (tmp_path / "case.json").write_text(CASE)
    out = tmp_path / "out"
    assert demo.main(["--case", str(tmp_path / "case.json"), "--out", str(out)]) == 0
    table = pd.read_csv(out / "comparison.csv")
    assert len(table) == 3
    assert (table["max_m"] - fake_mpm.MPM_SHIFT).abs().max() <= 1e-12
    assert (table["mean_m"] - fake_mpm.MPM_SHIFT).abs().max() <= 1e-12
    for name in ("report.md", "index.html", "overlay.png", "comparison.png"):
        assert (out / name).is_file()
    assert "report: " in capsys.readouterr().out
