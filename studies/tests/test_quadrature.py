"""The quadrature study's analysis on synthetic tool output with known maxima, and the whole
study against a stand-in for the C++ tool."""

import json
import os
import stat
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from studies import quadrature
from studies.common.study import StudyOptions, execute
from studies.tests import synthetic


def test_maxima_table_finds_the_known_maxima():
    table = quadrature.maxima_table(
        synthetic.error_map(5), synthetic.random_segments(7)
    )
    assert len(table) == len(quadrature.MODES) * len(quadrature.K_VALUES) * len(
        quadrature.SPLITS
    )
    for row in table.itertuples(index=False):
        expected = max(
            synthetic.map_error(row.mode, row.k, row.split, x, y)
            for x in np.linspace(-1, 1, 5)
            for y in np.linspace(-1, 1, 5)
        )
        assert row.map_max_total_force_rel_error == pytest.approx(expected, rel=1e-15)
        assert row.map_max_nodal_force_rel_error == pytest.approx(
            2 * expected, rel=1e-15
        )
        assert row.random_segments == 7
    thesis5 = table[
        (table["mode"] == "thesis") & (table["k"] == 5) & (table["split"] == 0)
    ].iloc[0]
    assert thesis5.map_max_total_force_rel_error == pytest.approx(0.14, rel=1e-15)
    # |cx + cy| is largest at (1, 1) and (-1, -1); idxmax returns the first in file order.
    assert (thesis5.map_worst_cx, thesis5.map_worst_cy) in {(1.0, 1.0), (-1.0, -1.0)}
    assert thesis5.random_max_nodal_force_rel_error == pytest.approx(0.7, rel=1e-15)


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    folder = tmp_path_factory.mktemp("quadrature")
    k_values = (2, 5, 8)  # fewer panels to draw; k = 5 carries the metrics
    return folder, quadrature.analyse(
        synthetic.error_map(5, k_values), synthetic.random_segments(7, k_values), folder
    )


def test_analyse_writes_tables_figures_metrics_and_headline(analysed):
    tmp_path, outcome = analysed
    assert [t.name for t in outcome.tables] == ["maxima"]
    assert (tmp_path / "maxima.csv").is_file() and (tmp_path / "maxima.md").is_file()
    names = {f.name for f in outcome.figures}
    assert names == {
        f"heatmap_{w}_split{s}" for w in ("total", "nodal") for s in (0, 1)
    }
    for figure in outcome.figures:
        assert (tmp_path / figure.png).stat().st_size > 10_000
    assert sorted(m.name for m in outcome.metrics) == sorted(
        quadrature.EXPECTED_METRICS
    )
    metric = {m.name: m.value for m in outcome.metrics}
    assert metric[
        "quadrature.thesis.k5.split0.max_total_force_rel_error"
    ] == pytest.approx(0.14, rel=1e-15)
    assert metric[
        "quadrature.exact.k5.split1.max_total_force_rel_error"
    ] == pytest.approx(2e-16, rel=1e-12)
    headline = {(h.quantity, h.detector): h.value for h in outcome.headline}
    assert headline[("traction.quadrature.thesis", "*")] == pytest.approx(
        0.14, rel=1e-15
    )


def test_missing_column_is_reported(tmp_path):
    frame = synthetic.error_map(3).drop(columns=["nodal_force_rel_error"])
    frame.to_csv(tmp_path / "error_map.csv", index=False)
    with pytest.raises(ValueError, match="nodal_force_rel_error"):
        quadrature.read_checked(tmp_path / "error_map.csv", quadrature.MAP_COLUMNS)


def test_study_is_not_run_without_the_tool(isolated):
    outcome = execute(quadrature, StudyOptions(quick=True))
    assert outcome.status == "not_run"
    assert "pfm-quadrature-map" in outcome.reason
    saved = json.loads((isolated["results"] / "quadrature" / "study.json").read_text())
    assert saved["status"] == "not_run"
    assert (isolated["results"] / "quadrature" / "provenance.json").is_file()


def _install_fake_tool(bin_dir: Path):
    tool = bin_dir / quadrature.TOOL
    tool.write_text(
        synthetic.FAKE_TOOL.format(
            python=sys.executable, root=str(Path(synthetic.__file__).parents[2])
        )
    )
    tool.chmod(tool.stat().st_mode | stat.S_IXUSR)
    return tool


def test_study_runs_the_tool_once_and_then_uses_the_cache(isolated):
    _install_fake_tool(isolated["bin"])
    first = execute(quadrature, StudyOptions(quick=True))
    assert first.status == "ok", first.reason
    folder = isolated["results"] / "quadrature"
    assert {
        "maxima.csv",
        "maxima.md",
        "heatmap_total_split1.png",
        "provenance.json",
        "README.md",
    } <= set(os.listdir(folder))
    provenance = json.loads((folder / "provenance.json").read_text())
    assert str(isolated["bin"] / quadrature.TOOL) in provenance["tools"]
    second = execute(quadrature, StudyOptions(quick=True))
    assert second.status == "ok"
    calls = list(isolated["cache"].rglob("calls.txt"))
    assert len(calls) == 1
    assert calls[0].read_text().splitlines() == [
        f"--out {calls[0].parent / 'out'} " + " ".join(quadrature.QUICK_ARGUMENTS)
    ]
    maxima = pd.read_csv(folder / "maxima.csv")
    assert maxima["map_max_total_force_rel_error"].max() == pytest.approx(
        0.14, rel=1e-15
    )
