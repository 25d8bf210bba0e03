"""The report: one HTML page and one Markdown file with every table and figure of the latest
study results, the headline table (thesis beside ours), each metric against its threshold in
``reports/thresholds.json`` and the comparison with the previous report
(``<results root>/history.jsonl``, outside the tracked tree). ``python -m studies report`` exits
1 when a metric of a full study is past its threshold."""

from studies.report.build import build_report, main

__all__ = ["build_report", "main"]
