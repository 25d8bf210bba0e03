#!/bin/sh
# Runs the libFuzzer targets one after the other (used by `make fuzz`; tests/fuzz/README.md).
#
#   tests/fuzz/run_fuzz.sh BUILD_DIR SECONDS_PER_TARGET [TARGET...]
#
# Each target starts from the seeds of make_seeds.py plus the committed corpus
# tests/fuzz/corpus/<target>/, fuzzes in fork mode (so that it goes on after a finding) under
# `nice`, then merges the inputs that add edge coverage into tests/fuzz/corpus/<target>/. Findings
# (crash-*, timeout-*, oom-*) are written to BUILD_DIR/fuzz-work/artifacts/<target>/ and listed at
# the end; the summary line of each target gives executions per second and corpus sizes.
set -eu
build=$1
seconds=$2
shift 2
targets=${*:-case particle_csv config detect}
here=$(cd "$(dirname "$0")" && pwd)
work=$build/fuzz-work
python=${PYTHON:-/usr/bin/python3}
rm -rf "$work/seeds"
"$python" "$here/make_seeds.py" "$work/seeds" > /dev/null
status=0
for t in $targets; do
  corpus=$work/corpus/$t
  artifacts=$work/artifacts/$t
  mkdir -p "$corpus" "$artifacts" "$here/corpus/$t"
  cp "$work/seeds/$t"/* "$corpus"/
  find "$here/corpus/$t" -type f -exec cp {} "$corpus"/ \;
  dict=
  [ -f "$here/$t.dict" ] && dict=-dict=$here/$t.dict
  echo "== fuzz_$t: $seconds s"
  nice "$build/bin/fuzz_$t" -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
    -timeout=10 -rss_limit_mb=2048 -max_total_time="$seconds" $dict \
    -artifact_prefix="$artifacts/" "$corpus" > "$work/$t.log" 2>&1 || status=1
  grep -E '^#[0-9]+: cov' "$work/$t.log" | tail -1
  before=$(find "$here/corpus/$t" -type f | wc -l)
  # Set-cover merge on edge coverage alone: the smallest corpus that reaches every edge.
  # (A crashing input is left out of the merge and saved with the other findings.)
  nice "$build/bin/fuzz_$t" -set_cover_merge=1 -use_counters=0 -timeout=10 -rss_limit_mb=2048 \
    -artifact_prefix="$artifacts/" "$here/corpus/$t" "$corpus" \
    > "$work/$t.merge.log" 2>&1
  after=$(find "$here/corpus/$t" -type f | wc -l)
  echo "   working corpus $(find "$corpus" -type f | wc -l) files; tests/fuzz/corpus/$t: $before -> $after files, $(cat "$here/corpus/$t"/* | wc -c) bytes"
  findings=$(find "$artifacts" -type f | wc -l)
  echo "   findings: $findings in $artifacts"
done
exit $status
