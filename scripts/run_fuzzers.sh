#!/usr/bin/env bash
# Builds the libFuzzer targets of test/fuzz (clang, AddressSanitizer and
# UndefinedBehaviorSanitizer, core only) and runs each for a bounded time on
# seeds made from the shared data (test/fuzz/make_seeds.py). Fails on any
# finding (crash, sanitizer report, leak, time-out, out-of-memory); the
# reproducer is kept in $work/findings/<target>/.
#
# Usage: scripts/run_fuzzers.sh [SECONDS_EACH] (default 30; AMHMVS_FUZZ_SECONDS)
# Environment: AMHMVS_DATA_DIR (default ../shared/data), AMHMVS_FUZZ_BUILD_DIR
# (default build-clang-asan, shared with the sanitizer unit tests of
# scripts/run_tests.sh), AMHMVS_FUZZ_RESULTS (a JUnit XML file to write: one
# test case per target), AMHMVS_FUZZ_TARGETS (a subset, space-separated).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
seconds=${1:-${AMHMVS_FUZZ_SECONDS:-30}}
data=${AMHMVS_DATA_DIR:-$here/../shared/data}
build=${AMHMVS_FUZZ_BUILD_DIR:-$here/build-clang-asan}
work=$build/fuzz_runs
results=${AMHMVS_FUZZ_RESULTS:-$work/fuzz_results.xml}

CC=clang CXX=clang++ AMHMVS_MAKE_TARGETS=fuzzers AMHMVS_BUILD_TYPE=RelWithDebInfo \
  "$here/scripts/build_core.sh" "$build" -DAMHMVS_FUZZERS=ON -DAMHMVS_SANITIZERS=address,undefined
rm -rf "$work"
mkdir -p "$work/seeds" "$work/findings"
/usr/bin/python3 "$here/test/fuzz/make_seeds.py" "$data" "$work/seeds"

targets=${AMHMVS_FUZZ_TARGETS:-$(find "$build" -maxdepth 1 -type f -executable -name 'fuzz_*' -printf '%f\n' | sort)}
[ -n "$targets" ] || { echo "run_fuzzers: no fuzz targets built in $build"; exit 1; }
status=0
cases=""
failures=0
count=0
for target in $targets; do
  corpus=$work/corpus/$target
  mkdir -p "$corpus" "$work/findings/$target"
  [ -d "$work/seeds/$target" ] && cp "$work/seeds/$target"/* "$corpus"/
  log=$work/$target.log
  start=$(date +%s)
  set +e
  # 2 GiB of memory and 10 s per input at most; leaks are findings.
  (cd "$work/findings/$target" &&
    ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
      "$build/$target" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
      "$corpus" > "$log" 2>&1)
  rc=$?
  set -e
  runs=$(grep -oE 'stat::number_of_executed_units: *[0-9]+' "$log" | grep -oE '[0-9]+$' || echo 0)
  count=$((count + 1))
  if [ $rc -eq 0 ]; then
    echo "$target: ${runs} executions in $(( $(date +%s) - start )) s, no finding"
    cases+="<testcase name=\"$target\" classname=\"fuzz\" time=\"$seconds\"/>"
  else
    echo "$target: FINDING (exit $rc) after ${runs} executions; log $log, reproducer in $work/findings/$target"
    grep -E "ERROR|runtime error|threw|SUMMARY|Test unit written" "$log" | head -8 || true
    cases+="<testcase name=\"$target\" classname=\"fuzz\"><failure message=\"exit $rc\"/></testcase>"
    failures=$((failures + 1))
    status=1
  fi
done
mkdir -p "$(dirname "$results")"
echo "<testsuites tests=\"$count\" failures=\"$failures\" errors=\"0\"><testsuite name=\"fuzz\" tests=\"$count\" failures=\"$failures\">$cases</testsuite></testsuites>" > "$results"
exit $status
