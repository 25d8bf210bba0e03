"""pfm-mpm studies: the numbers behind the claims (method map section 6).

Each study is a module with a literate docstring (what it measures, why, the command that
reproduces it) and a ``run(options) -> StudyOutcome`` function. Results go to
``results/studies/<name>/`` (override the root with the environment variable PFM_RESULTS):

* ``study.json``      the outcome: status (ok / not_run / failed), reason, tables, figures,
                      metrics, headline entries (see studies.common.outcome);
* ``provenance.json`` git revision, dirty flag, command, case hashes, timestamps, host, build type;
* ``README.md``       the study's literate header;
* ``*.csv`` + ``*.md`` tables, ``*.png`` figures.

Command line (the Makefile's ``make study-NAME`` / ``make study`` / ``make report``)::

    /usr/bin/python3 -m studies NAME [--quick] [--scheduler ADDR] [--jobs N]
    /usr/bin/python3 -m studies all [--quick]
    /usr/bin/python3 -m studies report
"""

STUDY_NAMES = (
    "boundary",
    "quadrature",
    "timing",
    "parametric",
    "convergence",
    "benchmarks",
    "stability",
    "near_boundary",
    "implicit",
)
