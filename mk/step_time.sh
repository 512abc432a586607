#!/usr/bin/env bash
# Times one step of `make test` and appends it to the file named by $STEP_TIMES (when set):
#   mk/step_time.sh NAME command...   runs the command; appends "NAME<TAB>wall<TAB>cpu<TAB>status",
#                                     seconds, cpu = user + sys of the command and every process
#                                     it waited for (compilers, test binaries, sub-makes); exits
#                                     with the command's status
#   mk/step_time.sh --report FILE     prints the steps of FILE, slowest CPU first, then the line
#                                     "total" the file holds, and what the steps leave over in it
#                                     (the build that no step times, mostly the normal build)
# The steps run side by side, so their wall times overlap; on N cores the whole takes at least
# max(longest chain of steps, total CPU / N).
set -u
if [ "${1:-}" = --report ]; then
  file=$2
  [ -f "$file" ] || { echo "step_time: no step times in $file"; exit 0; }
  awk -F'\t' '
    $1 == "total" { tw = $2; tc = $3; next }
    { n++; name[n] = $1; wall[n] = $2; cpu[n] = $3; st[n] = $4; sum += $3 }
    END {
      printf "make test steps (seconds; CPU = user + sys; steps run side by side):\n"
      printf "  %-34s %8s %8s\n", "step", "wall", "CPU"
      for (i = 1; i <= n; i++) order[i] = i
      for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (cpu[order[j]] > cpu[order[i]]) { t = order[i]; order[i] = order[j]; order[j] = t }
      for (k = 1; k <= n; k++) { i = order[k]; printf "  %-34s %8.1f %8.1f%s\n", name[i], wall[i], cpu[i], st[i] == 0 ? "" : "  (failed: status " st[i] ")" }
      if (tc != "") {
        printf "  %-34s %8s %8.1f\n", "normal build and the rest (untimed)", "", tc - sum
        printf "  %-34s %8.1f %8.1f\n", "total", tw, tc
      }
    }' "$file"
  exit 0
fi
name=$1; shift
start=$EPOCHREALTIME
"$@"; rc=$?
end=$EPOCHREALTIME
if [ -n "${STEP_TIMES:-}" ]; then
  # `times` (a builtin: run in this shell, not in a pipe's subshell) prints the shell's own user and
  # sys time, then its reaped children's: "XmY.YYYs XmY.YYYs".
  mkdir -p "$(dirname "$STEP_TIMES")"
  t=$STEP_TIMES.$$; times > "$t"
  awk -v name="$name" -v start="$start" -v end="$end" -v rc="$rc" '
    NR == 2 { cpu = 0; for (i = 1; i <= 2; i++) { split($i, a, /[ms]/); cpu += a[1] * 60 + a[2] }
              printf "%s\t%.1f\t%.1f\t%d\n", name, end - start, cpu, rc }' "$t" >> "$STEP_TIMES"
  rm -f "$t"
fi
exit $rc
