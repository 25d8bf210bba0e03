"""Regenerates the cost tables of mpm/detect/README.md from pfm-bench-detect.

    /usr/bin/python3 mpm/detect/tools/cost_tables.py [--bench build/bin/pfm-bench-detect]
        [--refined] [--write]

Runs the benchmarks BM_Detect (every detector on the slope at three sizes) and
BM_DetectFailureState (the improved detector on the failure states; with --refined also the
states refined 5 times, about 30k points, which take minutes to build) on one thread, and
prints two Markdown tables: detection per call against one MPM step of the same points, and
the failure states' cost against a step and against the case's own detection at t = 0, with
the loops of each state's boundary. With --write the tables replace the text between the
markers <!-- cost-tables:begin --> and <!-- cost-tables:end --> of the README, with the machine
and the git revision they were measured on.
"""

from __future__ import annotations

import argparse
import json
import platform
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
README = ROOT / "mpm" / "detect" / "README.md"
BEGIN, END = "<!-- cost-tables:begin -->", "<!-- cost-tables:end -->"
METHODS = ("pfm", "improved", "smm", "vof", "density")  # DetectorMethod order


def run_benchmarks(bench: Path, pattern: str) -> list:
    """The benchmark rows (Google Benchmark's JSON) whose names match `pattern`."""
    out = subprocess.run(
        [str(bench), f"--benchmark_filter={pattern}", "--benchmark_format=json"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    return json.loads(out)["benchmarks"]


def number(value: float, digits: int = 3) -> str:
    return f"{value:.{digits}g}"


def slope_table(rows: list) -> str:
    """Points, step and every detector's ms per call (and its ratio to the step)."""
    by_scale = {}
    for row in rows:
        scale, method = (int(v) for v in row["name"].split("/")[1:3])
        by_scale.setdefault(scale, {})[METHODS[method]] = row
    header = ["points", "MPM step"] + [f"{m}" for m in METHODS]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for scale in sorted(by_scale):
        entries = by_scale[scale]
        first = next(iter(entries.values()))
        cells = [f"{first['particles']:,.0f}", number(first["step_ms"]) + " ms"]
        for method in METHODS:
            row = entries.get(method)
            cells.append(
                "-"
                if row is None
                else f"{number(row['detect_ms'])} ms ({number(row['ratio_to_step'], 2)} x)"
            )
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def failure_table(rows: list) -> str:
    header = [
        "state",
        "points",
        "detection",
        "/ step",
        "/ own t = 0",
        "field evaluations",
        "bridges",
        "loops removed",
        "loops (spurious)",
    ]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        lines.append(
            "| "
            + " | ".join(
                [
                    row["label"],
                    f"{row['particles']:,.0f}",
                    number(row["detect_ms"]) + " ms",
                    number(row["ratio_to_step"], 2),
                    number(row["ratio_to_t0"], 2),
                    f"{row['field_evaluations']:,.0f}",
                    f"{row['bridges']:.0f}",
                    f"{row['loops_removed']:.0f}",
                    f"{row['loops']:.0f} ({row['spurious_loops']:.0f})",
                ]
            )
            + " |"
        )
    return "\n".join(lines)


def cpu_name() -> str:
    """The CPU's model name (/proc/cpuinfo), or the architecture."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.machine()


def revision() -> str:
    try:
        return subprocess.run(
            ["git", "rev-parse", "--short=12", "HEAD"],
            cwd=ROOT,
            check=True,
            capture_output=True,
            text=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--bench", default=str(ROOT / "build" / "bin" / "pfm-bench-detect")
    )
    parser.add_argument("--refined", action="store_true", help="also the 5 x 5 states")
    parser.add_argument("--write", action="store_true", help="update the README")
    parser.add_argument("--readme", default=str(README), help="the README to update")
    args = parser.parse_args(argv)
    bench = Path(args.bench)
    if not bench.is_file():
        print(f"{bench}: not built (make build)", file=sys.stderr)
        return 2
    slope = run_benchmarks(bench, r"^BM_Detect/")
    states = "1|5" if args.refined else "1"
    failure = run_benchmarks(bench, rf"^BM_DetectFailureState/[0-9]+/({states})/")
    text = (
        f"Measured by `mpm/detect/tools/cost_tables.py` at revision {revision()} on "
        f"{cpu_name()}, one thread, CPU time of the calling thread.\n\n"
        "Every detector on the slope of `cases/thesis55_slope_dynamic_zero_start.json` after "
        "two steps, and refined about 10 x and 100 x (cells halved and quartered, 3 x 3 and "
        "5 x 5 points per cell), against one MPM step of the same points:\n\n"
        + slope_table(slope)
        + "\n\nThe improved detector on the failure states (tests/data/failure_states), "
        "against one step of their case and against the case's own detection at t = 0, with "
        "the loops of the boundary it finds (the spurious ones of `loop_classes.hpp` in "
        "brackets):\n\n" + failure_table(failure)
    )
    print(text)
    if args.write:
        path = Path(args.readme)
        readme = path.read_text()
        pattern = re.compile(re.escape(BEGIN) + ".*?" + re.escape(END), re.S)
        if not pattern.search(readme):
            print(f"{path}: no {BEGIN} ... {END} markers", file=sys.stderr)
            return 2
        path.write_text(pattern.sub(lambda _: f"{BEGIN}\n{text}\n{END}", readme))
    return 0


if __name__ == "__main__":
    sys.exit(main())
