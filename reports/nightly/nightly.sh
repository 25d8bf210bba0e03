#!/usr/bin/env bash
# The nightly accuracy report: build, every study in full, the report, published.
#
#   reports/nightly/nightly.sh [NIGHTLY_DIR]
#
# NIGHTLY_DIR (default $PFM_NIGHTLY_DIR, else ~/.local/share/pfm-mpm-nightly) holds everything the
# run writes; nothing in the checkout changes (the build folder aside):
#   results/<UTC stamp>/    the studies' results and report/ (index.html, report.md, report.json)
#   latest                  a link to the newest results/<stamp> (publish this folder)
#   history.jsonl           one line per report: the metrics of every night, compared in the next
#   cache/                  the studies' run cache (PFM_CACHE; a new executable misses it anyway)
#   logs/<UTC stamp>.log    the whole output, with the wall time of each part
# PFM_NIGHTLY_PUBLISH, when set, is an rsync target the report folder is copied to afterwards.
# Exit: 0 when every gated metric passes, 1 when one fails or a study fails, 2 on bad usage,
# anything else from the build.
set -uo pipefail
if [ $# -gt 1 ]; then
  echo "usage: $0 [NIGHTLY_DIR]" >&2
  exit 2
fi
repo="$(cd "$(dirname "$0")/../.." && pwd)"
dir="${1:-${PFM_NIGHTLY_DIR:-$HOME/.local/share/pfm-mpm-nightly}}"
stamp="$(date -u +%Y%m%dT%H%M%SZ)"
results="$dir/results/$stamp"
mkdir -p "$results" "$dir/logs" "$dir/cache" || exit 2
log="$dir/logs/$stamp.log"
python="${PYTHON:-/usr/bin/python3}"

timed() {  # timed LABEL COMMAND...: runs it, logs its wall time, returns its exit code
  local label="$1" start code
  shift
  start=$(date +%s)
  echo "nightly: $label: $*"
  "$@"
  code=$?
  echo "nightly: $label: exit $code after $(($(date +%s) - start)) s"
  return $code
}

{
  echo "nightly: $stamp, revision $(git -C "$repo" rev-parse HEAD), into $results"
  timed build make -C "$repo" build || exit $?
  export PFM_BUILD_DIR="$repo/build" PFM_RESULTS="$results" PFM_CACHE="$dir/cache"
  cd "$repo" || exit 2
  timed studies "$python" -m studies all
  studies=$?
  timed report "$python" -m studies report --results "$results" --history "$dir/history.jsonl"
  report=$?
  ln -sfn "results/$stamp" "$dir/latest"
  if [ -n "${PFM_NIGHTLY_PUBLISH:-}" ]; then
    timed publish rsync -a "$results/" "$PFM_NIGHTLY_PUBLISH/"
  fi
  echo "nightly: report $dir/latest/report/index.html"
  [ $studies -eq 0 ] && [ $report -eq 0 ]
} 2>&1 | tee "$log"
exit "${PIPESTATUS[0]}"
