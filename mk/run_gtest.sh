#!/usr/bin/env bash
# One GoogleTest run of `make test`:
#   mk/run_gtest.sh LOG LABEL command...
# runs the command (a test binary and its arguments) with its output in LOG and its exit status in
# LOG.rc, both read by mk/test_summary.sh; prints GoogleTest's closing lines prefixed with LABEL;
# times the run as the step "run LABEL" (mk/step_time.sh); exits with the command's status.
set -u
log=$1; label=$2; shift 2
mkdir -p "$(dirname "$log")"
"$(dirname "$0")/step_time.sh" "run $label" "$@" > "$log" 2>&1; rc=$?
echo $rc > "$log.rc"
grep -E '^\[  (FAILED  |SKIPPED )\]|^\[==========\]|^\[  PASSED  \]' "$log" | sed "s|^|$label: |"
exit $rc
