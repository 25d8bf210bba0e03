"""Do two builds give the same bytes? Runs every shipped case (cases/*.json, MPM, and the
column on the UL-FEM) with two pfm-mpm binaries on 1 and on 2 threads and compares every output
file but run.json (which records times, threads and the revision) byte for byte.

    /usr/bin/python3 tests/tools/compare_builds.py OLD/bin/pfm-mpm NEW/bin/pfm-mpm [CASE ...]

Prints one line per case and thread count, and the first differing file; exits 1 when any
differ, 0 when all are equal. For refactorings that must not change results."""

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def run(binary, case, out, threads, solver):
    subprocess.run(
        [binary, "run", case, "--out", out, "--threads", str(threads), "--quiet"]
        + ["--solver", solver],
        check=True,
        stdout=subprocess.DEVNULL,
    )


def differing_file(first: Path, second: Path):
    """The first file (by name) whose bytes differ or that only one folder has, or None."""
    names = {p.name for p in first.iterdir()} | {p.name for p in second.iterdir()}
    for name in sorted(names - {"run.json"}):
        a, b = first / name, second / name
        if not (a.is_file() and b.is_file()) or a.read_bytes() != b.read_bytes():
            return name
    return None


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("old", type=Path)
    parser.add_argument("new", type=Path)
    parser.add_argument("cases", nargs="*", help="case files (default: cases/*.json)")
    args = parser.parse_args(argv)
    jobs = [(Path(c), "mpm") for c in args.cases] or [
        (p, "mpm") for p in sorted((ROOT / "cases").glob("*.json"))
    ] + [(ROOT / "cases" / "column.json", "ulfem")]
    failed = 0
    with tempfile.TemporaryDirectory() as scratch:
        for k, (case, solver) in enumerate(jobs):
            for threads in (1, 2):
                old, new = (
                    Path(scratch) / f"{k}_{threads}_old",
                    Path(scratch) / f"{k}_{threads}_new",
                )
                run(args.old, case, old, threads, solver)
                run(args.new, case, new, threads, solver)
                name = differing_file(old, new)
                failed += name is not None
                verdict = "same bytes" if name is None else f"DIFFER first in {name}"
                print(
                    f"{case.name} {solver} {threads} thread(s): {verdict}", flush=True
                )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
