#!/usr/bin/env bash
# Sums GoogleTest results over the given logs and prints the plain closing line CI reads.
passed=0; failed=0
for log in "$@"; do
  if [ ! -f "$log" ]; then echo "test_summary: missing log $log (that test run did not happen)"; failed=$((failed+1)); continue; fi
  p=$(grep -c '^\[       OK \]' "$log" || true)
  f=$(grep -oE '^\[  FAILED  \] [A-Za-z0-9_/]+\.[A-Za-z0-9_/]+' "$log" | sort -u | wc -l)
  passed=$((passed+p)); failed=$((failed+f))
  if ! grep -q '^\[==========\] .* ran\.' "$log"; then echo "test_summary: $log did not finish"; failed=$((failed+1)); fi
done
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ] && [ "$passed" -gt 0 ]
