"""mpm/detect/tools/cost_tables.py regenerates the README's cost tables from pfm-bench-detect's
JSON: against a stand-in benchmark that prints known rows, the tables hold those figures (ms
per call, ratio to the step, the failure states' counters) and --write replaces only the text
between the markers."""

import json
import re
import stat
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "mpm" / "detect" / "tools"))

import cost_tables  # noqa: E402
import pytest  # noqa: E402

ROWS = [
    {"name": "BM_Detect/0/1/min_time:0.500/manual_time", "particles": 3384.0,
     "step_ms": 0.2, "detect_ms": 0.25, "ratio_to_step": 1.25},
    {"name": "BM_Detect/0/0/min_time:0.500/manual_time", "particles": 3384.0,
     "step_ms": 0.2, "detect_ms": 0.5, "ratio_to_step": 2.5},
    {"name": "BM_DetectFailureState/3/1/min_time:0.300/manual_time", "label": "slope_t2.5",
     "particles": 1200.0, "step_ms": 0.1, "detect_ms": 0.4, "ratio_to_step": 4.0,
     "ratio_to_t0": 2.0, "field_evaluations": 1234.0, "bridges": 7.0, "loops_removed": 1.0,
     "loops": 3.0, "spurious_loops": 0.0},
]  # fmt: skip

FAKE = """#!{python}
import json, re, sys
pattern = re.compile(sys.argv[1].split("=", 1)[1])
rows = {rows}
print(json.dumps({{"benchmarks": [r for r in rows if pattern.search(r["name"])]}}))
"""


def test_tables_from_a_benchmark_and_the_readme_between_markers(tmp_path, capsys):
    bench = tmp_path / "pfm-bench-detect"
    bench.write_text(FAKE.format(python=sys.executable, rows=json.dumps(ROWS)))
    bench.chmod(bench.stat().st_mode | stat.S_IXUSR)
    readme = tmp_path / "README.md"
    readme.write_text(f"before\n{cost_tables.BEGIN}\nold\n{cost_tables.END}\nafter\n")
    assert (
        cost_tables.main(["--bench", str(bench), "--write", "--readme", str(readme)])
        == 0
    )
    text = readme.read_text()
    assert (
        text.startswith("before\n") and text.endswith("after\n") and "old" not in text
    )
    assert "| 3,384 | 0.2 ms | 0.5 ms (2.5 x) | 0.25 ms (1.2 x) | - | - | - |" in text
    assert "| slope_t2.5 | 1,200 | 0.4 ms | 4 | 2 | 1,234 | 7 | 1 | 3 (0) |" in text
    assert capsys.readouterr().out.strip() in text


def test_a_readme_without_markers_is_refused(tmp_path):
    bench = tmp_path / "pfm-bench-detect"
    bench.write_text(FAKE.format(python=sys.executable, rows=json.dumps(ROWS)))
    bench.chmod(bench.stat().st_mode | stat.S_IXUSR)
    readme = tmp_path / "README.md"
    readme.write_text("no markers\n")
    assert (
        cost_tables.main(["--bench", str(bench), "--write", "--readme", str(readme)])
        == 2
    )
    assert readme.read_text() == "no markers\n"


# What the README's tables measure: the detectors and their benchmark. A change to these since
# the revision the tables name means they are to be measured again (cost_tables.py --write).
MEASURED_CODE = [
    "mpm/detect",
    "mpm/bench/bench_detect.cpp",
    ":(exclude)mpm/detect/README.md",
]


def test_the_readme_tables_were_measured_on_the_detectors_of_this_tree():
    """The revision stamped on mpm/detect/README.md's tables has the detectors and the
    benchmark of this tree: no committed or uncommitted change to them since."""
    readme = (ROOT / "mpm" / "detect" / "README.md").read_text()
    match = re.search(r"at revision ([0-9a-f]{7,40})", readme)
    assert match, "mpm/detect/README.md: no 'at revision' stamp on the cost tables"
    if not (ROOT / ".git").exists():
        pytest.skip("no git history to compare the stamp with")
    known = subprocess.run(
        ["git", "-C", ROOT, "cat-file", "-e", f"{match.group(1)}^{{commit}}"],
        capture_output=True,
    )
    if known.returncode != 0:
        pytest.skip(f"revision {match.group(1)} is not in this clone's history")
    changed = subprocess.run(
        ["git", "-C", ROOT, "diff", "--stat", match.group(1), "--", *MEASURED_CODE],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert changed == "", (
        f"the detectors changed since the tables were measured at {match.group(1)}: "
        f"run /usr/bin/python3 mpm/detect/tools/cost_tables.py --write\n{changed}"
    )
