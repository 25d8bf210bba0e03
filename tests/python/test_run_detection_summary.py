"""A run's detection summary (issue 19, item 2): each output step's boundary has its loops
counted by class in run.json, and the thesis bearing collapse (zero start, q = 50 kPa at once,
softening Tresca) keeps no spurious loop through its failure with the default detector.
"""

import json
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_collapse_has_no_spurious_loop_at_any_output(pfm_binary, tmp_path):
    case = json.loads(
        (ROOT / "cases" / "thesis62_bearing_dynamic_zero_start.json").read_text()
    )
    case["time"]["end_time"] = 2.5
    path = tmp_path / "collapse.json"
    path.write_text(json.dumps(case))
    out = tmp_path / "out"
    subprocess.run(
        [pfm_binary, "run", str(path), "--out", str(out), "--quiet"],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    run = json.loads((out / "run.json").read_text())
    outputs = [o for o in run["outputs"] if "loop_classes" in o]
    assert len(outputs) == len(run["outputs"]) == 21
    spurious = ("spurious_loop", "spurious_island", "spurious_hole")
    for o in outputs:
        assert all(o["loop_classes"][k] == 0 for k in spurious), o
        assert o["loop_classes"]["body"] >= 1, o
    detection = run["summary"]["detection"]
    totals = detection["loop_classes_at_outputs"]
    for kind in totals:
        assert totals[kind] == sum(o["loop_classes"][kind] for o in outputs)
    # The collapse needs the second pass: bridges, and no pass at the guards' refinement.
    assert detection["bridged_calls"] > 0 and detection["guard_refinement_passes"] == 0
