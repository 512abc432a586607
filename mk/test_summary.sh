#!/usr/bin/env bash
# Sums GoogleTest-style results over the given logs and prints the plain closing line CI reads:
#   N passed, N failed, N skipped
# Counted per log:
#   passed  - "[       OK ] Suite.Test" lines;
#   failed  - distinct "[  FAILED  ] Suite.Test" names, plus each suite whose SetUpTestSuite or
#             TearDownTestSuite failed ("[  FAILED  ] Suite: SetUpTestSuite or TearDownTestSuite");
#             a log that lacks GoogleTest's closing "... ran." line (the binary crashed or was
#             killed), and a run whose exit status file (LOG.rc, when present) is non-zero while no
#             failure was counted, each add one failure;
#   skipped - distinct "[  SKIPPED ] Suite.Test" names (GTEST_SKIP, or the tests of a suite whose
#             set-up failed).
# Exits 0 only when nothing failed and something passed. Skips are named and counted, never hidden.
set -u
passed=0; failed=0; skipped=0
for log in "$@"; do
  if [ ! -f "$log" ]; then
    echo "test_summary: FAILED: missing log $log (that test run did not happen)"
    failed=$((failed+1)); continue
  fi
  p=$(grep -c '^\[       OK \] ' "$log" || true)
  f_tests=$(grep -oE '^\[  FAILED  \] [A-Za-z0-9_/]+\.[A-Za-z0-9_/]+' "$log" | sort -u)
  f_suites=$(grep -oE '^\[  FAILED  \] [A-Za-z0-9_/]+: SetUpTestSuite or TearDownTestSuite' "$log" | sort -u)
  s_tests=$(grep -oE '^\[  SKIPPED \] [A-Za-z0-9_/]+\.[A-Za-z0-9_/]+' "$log" | sort -u)
  f=$( (printf '%s\n' "$f_tests"; printf '%s\n' "$f_suites") | grep -c . || true)
  s=$(printf '%s\n' "$s_tests" | grep -c . || true)
  if ! grep -qE '^\[==========\] .* ran\.' "$log"; then
    echo "test_summary: FAILED: $log did not finish (no closing '... ran.' line)"
    f=$((f+1))
  fi
  if [ -f "$log.rc" ] && [ "$(cat "$log.rc")" != 0 ] && [ "$f" -eq 0 ]; then
    echo "test_summary: FAILED: $log: the run exited with status $(cat "$log.rc") and reported no failing test"
    f=$((f+1))
  fi
  [ -n "$f_tests" ] && printf '%s\n' "$f_tests" | sed "s|^\[  FAILED  \] |test_summary: failed: |; s|\$| ($log)|"
  [ -n "$f_suites" ] && printf '%s\n' "$f_suites" | sed "s|^\[  FAILED  \] |test_summary: failed suite set-up/tear-down: |; s|\$| ($log)|"
  [ -n "$s_tests" ] && printf '%s\n' "$s_tests" | sed "s|^\[  SKIPPED \] |test_summary: skipped: |; s|\$| ($log)|"
  passed=$((passed+p)); failed=$((failed+f)); skipped=$((skipped+s))
done
echo "$passed passed, $failed failed, $skipped skipped"
[ "$failed" -eq 0 ] && [ "$passed" -gt 0 ]
