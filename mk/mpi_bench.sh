#!/usr/bin/env bash
# Distributed training measurements on this machine (`make bench-mpi`; docs/training.md
# "Distributed training"): the same BPC training as 1 rank × T threads, 1 rank × 1 thread and
# N ranks × 1 thread (N = 2, 3; oversubscribed beyond the cores), reporting wall time, the payload
# each rank hands to the sums per level (from rank 0's progress lines), each rank's images and
# peak resident memory, and the CPU seconds of all processes (on a loaded machine the CPU time
# shows the work a configuration costs better than the wall time). All runs must write the same forest (checked).
# The 2-rank run is repeated for each switch of BENCH_NODE_PARALLEL (--node-parallel-below: 0 =
# histogram sums at every level, larger = more levels node-parallel), side by side, with the
# payload per level of the histogram-sum run and of the default switch; 3 ranks run both ends.
# Sizes: BENCH_FRAMES (default 120) frames of 320×240, BENCH_PIXELS per image (1000), depth
# BENCH_DEPTH (12), BENCH_OFFSETS × BENCH_THRESHOLDS candidates (200 × 20).
set -uo pipefail
CLI=${CLI:-build/bin/depthpose}
ROOT=${MPI_BENCH_DIR:-build/mpi-bench}
ASSETS=${ASSETS:-../shared/assets}
FRAMES=${BENCH_FRAMES:-120}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
MPIRUN=(mpirun --oversubscribe --bind-to none)
mkdir -p "$ROOT"
if [ ! -f "$ROOT/data-$FRAMES/frames.jsonl" ]; then
  "$CLI" synth --assets "$ASSETS" --out "$ROOT/data-$FRAMES" --frames "$FRAMES" --seed 11 --clips 01_01,01_02,02_01 \
    2>"$ROOT/synth.log" || { cat "$ROOT/synth.log"; exit 1; }
fi
TRAIN=(train --data "$ROOT/data-$FRAMES" --method bpc --trees 1 --depth "${BENCH_DEPTH:-12}" --pixels-per-image "${BENCH_PIXELS:-1000}"
       --offsets "${BENCH_OFFSETS:-200}" --thresholds "${BENCH_THRESHOLDS:-20}" --no-timings)
SWEEP=(${BENCH_NODE_PARALLEL:-0 300 1000 3000 10000 30000})
DEFAULT=$("$CLI" train --help 2>&1 | sed -nE 's/.*\(default ([0-9]+), 0 = never\).*/\1/p')
[ -n "$DEFAULT" ] || { echo "bench-mpi: no default of --node-parallel-below in 'depthpose train --help'"; exit 1; }
measure() {  # measure NAME RANKS THREADS [train options]: wall and CPU seconds (user + system, all processes)
  local name=$1 ranks=$2 threads=$3 log=$ROOT/$1.log t
  shift 3
  local TIMEFORMAT='%R %U %S'
  if [ "$ranks" = 0 ]; then
    t=$( { time "$CLI" "${TRAIN[@]}" "$@" --threads "$threads" --out "$ROOT/$name.forest" 2>"$log" ; } 2>&1 ) || { cat "$log"; exit 1; }
  else
    t=$( { time "${MPIRUN[@]}" -np "$ranks" "$CLI" "${TRAIN[@]}" "$@" --threads "$threads" --out "$ROOT/$name.forest" 2>"$log" ; } 2>&1 ) ||
      { cat "$log"; exit 1; }
  fi
  echo "$t" | awk -v n="$name" '{ printf "%-30s wall %6.2f s, CPU %6.2f s\n", n, $1, $2 + $3 }'
  grep -E "rank [0-9]+ of" "$log" | sed 's/^train: /    /'
  [ "$ranks" = 0 ] && grep -oE "images [0-9.]+ MB.*peak resident [0-9.]+ MB" "$log" | sed 's/^/    /'
  true
}
echo "== $FRAMES frames 320x240, ${BENCH_PIXELS:-1000} px/image, depth ${BENCH_DEPTH:-12}, ${BENCH_OFFSETS:-200} x ${BENCH_THRESHOLDS:-20} candidates, $(nproc) cores"
echo "== 1 rank x 2 threads vs 2 ranks x 1 thread (and references)"
RUNS=(one-process-1-thread)
measure one-process-2-threads 0 2
measure one-process-1-thread 0 1
echo "== 2 ranks x 1 thread, --node-parallel-below S (0: histogram sums at every level; default $DEFAULT)"
for s in "${SWEEP[@]}"; do measure "2-ranks-below-$s" 2 1 --node-parallel-below "$s"; RUNS+=("2-ranks-below-$s"); done
echo "== 3 ranks x 1 thread: histogram sums, default switch"
measure 3-ranks-below-0 3 1 --node-parallel-below 0
measure "3-ranks-below-$DEFAULT" 3 1 --node-parallel-below "$DEFAULT"
RUNS+=(3-ranks-below-0 "3-ranks-below-$DEFAULT")
for s in 0 "$DEFAULT"; do
  for n in 2 3; do
    log=$ROOT/$n-ranks-below-$s.log
    [ -f "$log" ] || continue
    echo "== payload per rank and level, N=$n, --node-parallel-below $s (rank 0's progress lines)"
    grep -oE "level +[0-9]+/[0-9]+: [0-9]+ nodes, [0-9]+ split, .* node-parallel" "$log" |
      sed -E 's/, [0-9.]+M px, [0-9.]+ G evals//; s/^/    /'
  done
done
for f in "${RUNS[@]}"; do
  cmp "$ROOT/one-process-2-threads.forest" "$ROOT/$f.forest" || { echo "bench-mpi: $f wrote another forest"; exit 1; }
done
echo "== every run wrote the same forest"
