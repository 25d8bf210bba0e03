"""The report on a tiny synthetic set of study results."""

import json
import re

import pandas as pd
import pytest

from studies.common.outcome import FigureRef, Headline, Metric, StudyOutcome
from studies.common.tables import write_table
from studies.report.build import build_report, read_thresholds

THRESHOLDS = {
    "schema": 1,
    "version": 7,
    "metrics": [
        {
            "name": "quadrature.exact.k5.split1.max_total_force_rel_error",
            "direction": "lower",
            "limit": 1e-10,
            "unit": "1",
        },
        {
            "name": "timing.slope.pfm_improved.detect_to_step_ratio",
            "direction": "lower",
            "limit": 1.0,
            "unit": "1",
        },
        {
            "name": "benchmarks.column.settlement_rel_error",
            "direction": "lower",
            "limit": 0.01,
            "unit": "1",
        },
        {
            "name": "timing.block_100k.mpm_particle_steps_per_s",
            "direction": "higher",
            "limit": None,
            "unit": "1/s",
        },
    ],
}
PNG = bytes.fromhex(
    "89504e470d0a1a0a0000000d4948445200000001000000010806000000"
    "1f15c4890000000d49444154789c6360000002000154a24f5d0000000049454e44ae426082"
)


def write_study(root, name, quadrature_error=1e-15, status="ok", quick=False):
    folder = root / name
    folder.mkdir(parents=True, exist_ok=True)
    outcome = StudyOutcome(
        study=name,
        status=status,
        title=f"{name} title",
        summary=f"{name} summary:\n\n* the ``{name}`` part\n  over two lines;\n* another",
        command=f"python -m studies {name}",
        reason="" if status == "ok" else "boom",
        quick=quick,
    )
    if name == "quadrature" and status == "ok":
        frame = pd.DataFrame(
            {
                "mode": ["thesis", "exact"],
                "k": [5, 5],
                "max_error": [0.1357, quadrature_error],
            }
        )
        outcome.tables.append(
            write_table(folder, frame, "maxima", "Quadrature maxima table")
        )
        (folder / "heatmap.png").write_bytes(PNG)
        outcome.figures.append(FigureRef("heatmap", "Heat map figure", "heatmap.png"))
        outcome.metrics.append(
            Metric(
                "quadrature.exact.k5.split1.max_total_force_rel_error",
                quadrature_error,
                "1",
            )
        )
        outcome.headline.append(
            Headline("traction.quadrature.thesis", "*", 0.1357, "1")
        )
    if name == "timing" and status == "ok":
        frame = pd.DataFrame(
            {"stage": ["stress", "detect"], "median": [0.0123, 0.0456]}
        )
        outcome.tables.append(
            write_table(folder, frame, "stages", "Timing stages table")
        )
        outcome.metrics += [
            Metric("timing.slope.pfm_improved.detect_to_step_ratio", 0.8765, "1"),
            Metric("timing.block_100k.mpm_particle_steps_per_s", 2.5e6, "1/s"),
        ]
        outcome.headline.append(
            Headline("cost.detect_per_step", "pfm_improved", 0.04321, "s")
        )
    outcome.write(folder)


@pytest.fixture
def setup(tmp_path):
    root = tmp_path / "results"
    write_study(root, "quadrature")
    write_study(root, "timing")
    thresholds = tmp_path / "thresholds.json"
    thresholds.write_text(json.dumps(THRESHOLDS))
    return {
        "root": root,
        "out": tmp_path / "report",
        "thresholds": thresholds,
        "history": tmp_path / "history.jsonl",
    }


def build(setup):
    return build_report(
        setup["root"], setup["out"], setup["thresholds"], setup["history"]
    )


def verdicts(setup) -> dict:
    """The report's verdicts by metric name."""
    report = json.loads((setup["out"] / "report.json").read_text())
    return {v["name"]: v for v in report["verdicts"]}


def test_report_holds_every_table_figure_and_the_headline(setup):
    assert build(setup) == 0
    html = (setup["out"] / "index.html").read_text()
    markdown = (setup["out"] / "report.md").read_text()
    for text in ("Quadrature maxima table", "0.1357", "Timing stages table", "0.0456"):
        assert text in html and text in markdown
    assert 'src="../results/quadrature/heatmap.png"' in html
    # Headline: our numbers in their detector's column, the thesis beside them.
    row = re.search(r"<tr><td>cost: detection per call.*?</tr>", html, re.S).group(0)
    cells = re.findall(r"<td[^>]*>(.*?)</td>", row)
    # quantity, unit, thesis, any detector, thesis PFM plain, as run, median, improved PFM, ...
    assert cells[2] == "0.047 s (5.2)" and cells[7] == "0.04321"
    # Studies without results are marked as such, with the reason as a footnote.
    assert "not run [" in html and "`make study-boundary` (no results yet)" in html
    found = verdicts(setup)
    assert (
        found["quadrature.exact.k5.split1.max_total_force_rel_error"]["status"]
        == "pass"
    )
    assert found["benchmarks.column.settlement_rel_error"]["status"] == "not run"
    assert found["timing.block_100k.mpm_particle_steps_per_s"]["status"] == "info"
    history = setup["history"].read_text().splitlines()
    assert len(history) == 1 and json.loads(history[0])["failed"] == []


def test_report_exits_non_zero_on_a_regression_past_the_threshold(setup, capsys):
    assert build(setup) == 0
    write_study(setup["root"], "quadrature", quadrature_error=3e-3)  # past 1e-10
    assert build(setup) == 1
    verdict = verdicts(setup)["quadrature.exact.k5.split1.max_total_force_rel_error"]
    assert verdict["status"] == "FAIL" and verdict["regression"]
    assert verdict["previous"] == 1e-15
    assert "FAIL REGRESSION quadrature.exact.k5.split1" in capsys.readouterr().err
    html = (setup["out"] / "index.html").read_text()
    assert 'class="verdict-FAIL"' in html and "(regression)" in html
    assert json.loads(setup["history"].read_text().splitlines()[-1])["failed"] == [
        "quadrature.exact.k5.split1.max_total_force_rel_error"
    ]


def test_a_failed_study_fails_its_thresholded_metrics(setup):
    write_study(setup["root"], "timing", status="failed")
    assert build(setup) == 1
    html = (setup["out"] / "index.html").read_text()
    assert "study failed: boom" in html


def test_thresholds_file_is_validated(tmp_path):
    bad = dict(THRESHOLDS, metrics=[{"name": "x", "direction": "smaller", "limit": 1}])
    path = tmp_path / "t.json"
    path.write_text(json.dumps(bad))
    with pytest.raises(ValueError, match="/metrics/0/direction"):
        read_thresholds(path)


def test_the_repository_thresholds_file_is_valid():
    from studies.report.build import default_thresholds_path

    version, thresholds = read_thresholds(default_thresholds_path())
    assert version >= 1 and len(thresholds) >= 10


def test_a_quick_variants_fail_is_shown_and_not_counted(setup, capsys):
    write_study(setup["root"], "quadrature", quadrature_error=3e-3, quick=True)
    assert build(setup) == 0
    verdict = verdicts(setup)["quadrature.exact.k5.split1.max_total_force_rel_error"]
    assert verdict["status"] == "FAIL" and verdict["quick"]
    assert "FAIL (quick) quadrature.exact" in capsys.readouterr().err
    html = (setup["out"] / "index.html").read_text()
    assert "0 metric(s) past threshold (and 1 of quick variants" in html


def test_a_study_with_a_failing_metric_is_never_green(setup):
    write_study(setup["root"], "quadrature", quadrature_error=3e-3)
    assert build(setup) == 1
    html = (setup["out"] / "index.html").read_text()
    heading = re.search(r'<h3 id="study-quadrature">.*?</h3>', html, re.S).group(0)
    assert 'class="status-failed"' in heading and "1 metric(s) FAIL" in heading
    assert 'class="status-ok"' not in heading
    markdown = (setup["out"] / "report.md").read_text()
    assert "### quadrature: quadrature title [ok, 1 metric(s) FAIL]" in markdown


def test_study_texts_are_rendered_from_restructuredtext(setup):
    build(setup)
    html = (setup["out"] / "index.html").read_text()
    section = html.split('id="study-timing"', 1)[1].split("<h3", 1)[0]
    assert '<span class="docutils literal">timing</span>' in section
    assert section.count("<li>") == 2 and "``" not in section


def test_the_history_lives_beside_the_results_not_in_the_tracked_tree(setup):
    code = build_report(setup["root"], setup["out"], setup["thresholds"])
    assert code == 0
    assert len((setup["root"] / "history.jsonl").read_text().splitlines()) == 1
