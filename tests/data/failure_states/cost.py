"""Detection of every failure state (states.json) with the improved detector at several kernel
stretch caps (``improved.max_stretch``), one thread: seconds of detection (field, edge points,
connection and filters of ``pfm-mpm detect``'s summary), loops and field evaluations, as a
Markdown table on standard output.

    /usr/bin/python3 tests/data/failure_states/cost.py [--build build] [--caps 0 2 3]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]


def detect(executable: Path, state: dict, cap: float, scratch: Path) -> dict:
    config = {
        "method": "improved",
        "initial_spacing": state["initial_spacing"],
        "grid": state["grid"],
        "improved": {"max_stretch": cap},
    }
    config_file = scratch / f"{state['name']}_{cap:g}.json"
    config_file.write_text(json.dumps(config))
    out = scratch / f"{state['name']}_{cap:g}"
    subprocess.run(
        [
            str(executable),
            "detect",
            str(HERE / f"{state['name']}.csv"),
            "--config",
            str(config_file),
            "--out",
            str(out),
            "--threads",
            "1",
        ],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    summary = json.loads((out / "summary.json").read_text())
    seconds = sum(
        v for v in summary["timings_s"].values() if isinstance(v, (int, float))
    )
    return {
        "s": seconds,
        "loops": summary["loops"],
        "evals": summary["field_evaluations"],
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", type=Path, default=ROOT / "build")
    parser.add_argument("--caps", type=float, nargs="+", default=[0.0, 2.0, 3.0])
    args = parser.parse_args(argv)
    executable = args.build / "bin" / "pfm-mpm"
    states = json.loads((HERE / "states.json").read_text())
    header = ["state", "points"] + [
        f"{what} (cap {cap:g})" for cap in args.caps for what in ("ms", "loops")
    ]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    with tempfile.TemporaryDirectory() as scratch:
        for state in states:
            cells = [state["name"], str(state["points"])]
            for cap in args.caps:
                r = detect(executable, state, cap, Path(scratch))
                cells += [f"{1e3 * r['s']:.1f}", str(r["loops"])]
            print("| " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
