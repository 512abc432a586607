#!/usr/bin/env bash
# Proves that mk/test_summary.sh cannot be fooled: runs tests/probes/summary_probe (a suite whose
# set-up fails, a skip, a failure, a pass) and checks the closing line the summary prints for its
# log, for a log cut short (a crash), for a clean-looking log whose run exited non-zero, and for a
# missing log. Prints one GoogleTest-style line per check so the summary counts them too.
#   usage: mk/test_summary_selftest.sh PROBE_BINARY WORK_DIR
set -u
probe=$1; dir=$2
summary="$(dirname "$0")/test_summary.sh"
mkdir -p "$dir"
ran=0
check() {  # check NAME EXPECTED_CLOSING_LINE EXPECTED_EXIT(0|nonzero) LOG...
  local name=$1 want=$2 want_rc=$3; shift 3
  ran=$((ran+1))
  local out rc got
  out=$("$summary" "$@" 2>&1); rc=$?
  got=$(printf '%s\n' "$out" | tail -n 1)
  local rc_ok=0
  if [ "$want_rc" = 0 ]; then [ $rc -eq 0 ] && rc_ok=1; else [ $rc -ne 0 ] && rc_ok=1; fi
  if [ "$got" = "$want" ] && [ $rc_ok = 1 ]; then
    echo "[       OK ] TestSummary.$name"
  else
    echo "[  FAILED  ] TestSummary.$name: want '$want' (exit $want_rc), got '$got' (exit $rc)"
    printf '%s\n' "$out" | sed 's/^/    /'
  fi
}
"$probe" > "$dir/probe.log" 2>&1; echo $? > "$dir/probe.log.rc"
check SuiteSetUpFailureCountsAsFailedAndItsTestsAsSkipped "1 passed, 2 failed, 3 skipped" nonzero "$dir/probe.log"
# The log as a crash right after the set-up-failing suite would leave it.
sed '/ProbePasses.Passes/,$d' "$dir/probe.log" > "$dir/cut.log"
check LogCutShortCountsAsFailed "0 passed, 1 failed, 2 skipped" nonzero "$dir/cut.log"
grep -E '^\[(==========|       OK )\]' "$dir/probe.log" > "$dir/clean.log"; echo 1 > "$dir/clean.log.rc"
check NonZeroExitWithCleanLogCountsAsFailed "1 passed, 1 failed, 0 skipped" nonzero "$dir/clean.log"
echo 0 > "$dir/clean.log.rc"
check CleanLogPasses "1 passed, 0 failed, 0 skipped" 0 "$dir/clean.log"
check MissingLogCountsAsFailed "1 passed, 1 failed, 0 skipped" nonzero "$dir/clean.log" "$dir/no-such.log"
echo "[==========] $ran tests ran."
