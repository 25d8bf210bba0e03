"""Command line of the studies (the Makefile's targets call exactly this)::

    python -m studies NAME [--quick] [--scheduler ADDR] [--jobs N]   # one study
    python -m studies all [--quick] [--scheduler ADDR] [--jobs N]    # every study, in order
    python -m studies report [--no-history] [...]                    # build the report
    python -m studies demo [--case C] [--out D] [--end-time T]       # `make run`

NAME is one of boundary, quadrature, timing, parametric, convergence, benchmarks, stability,
near_boundary, implicit.
Exit code: 0 when every study ran or was recorded as "not run" (a prerequisite is missing),
1 when a study failed; ``report`` exits 1 when a metric is past its threshold.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys

from studies import STUDY_NAMES

# The studies need the Debian Python packages; another interpreter first on PATH cannot see them.
_MISSING = [
    name
    for name in ("numpy", "pandas", "matplotlib", "scipy", "h5py", "tqdm", "tabulate")
    if importlib.util.find_spec(name) is None
]
if _MISSING:
    sys.exit(
        f"studies: {sys.executable} cannot import {', '.join(_MISSING)}: run the studies with "
        "the Debian interpreter, /usr/bin/python3 (make PYTHON=... to choose another), after "
        "`make deps` (Debian packages python3-numpy, python3-pandas, ...)"
    )


def run_studies(names, quick: bool, jobs, scheduler) -> int:
    from studies.common.study import StudyOptions, execute

    options = StudyOptions(quick=quick, jobs=jobs, scheduler=scheduler)
    if scheduler:
        # Fail early and clearly rather than in the middle of a sweep.
        try:
            import dask.distributed  # noqa: F401
        except ImportError as error:
            print(
                f"studies: --scheduler {scheduler} given but dask.distributed is not installed "
                f"({error}); install python3-distributed or drop --scheduler",
                file=sys.stderr,
            )
            return 2
    failed = []
    for name in names:
        outcome = execute(importlib.import_module(f"studies.{name}"), options)
        if outcome.status == "failed":
            failed.append(name)
    if failed:
        print(f"studies: failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "report":
        from studies.report.build import main as report_main

        return report_main(argv[1:])
    if argv and argv[0] == "demo":
        from studies.demo import main as demo_main

        return demo_main(argv[1:])
    parser = argparse.ArgumentParser(
        prog="python -m studies",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("name", choices=[*STUDY_NAMES, "all", "report", "demo"])
    parser.add_argument(
        "--quick",
        action="store_true",
        help="the small variant used by `make test` (minutes, not tens of them)",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="Dask distributed scheduler address (e.g. tcp://host:8786)",
    )
    parser.add_argument(
        "--jobs",
        type=int,
        default=None,
        help="local worker processes for sweeps (default: all cores)",
    )
    args = parser.parse_args(argv)
    names = STUDY_NAMES if args.name == "all" else (args.name,)
    return run_studies(names, args.quick, args.jobs, args.scheduler)


if __name__ == "__main__":
    sys.exit(main())
