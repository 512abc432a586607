#!/usr/bin/env bash
# Distributed training measurements on this machine (`make bench-mpi`; docs/training.md
# "Distributed training"): the same BPC training as 1 rank × T threads, 1 rank × 1 thread and
# N ranks × 1 thread (N = 2, 3; oversubscribed beyond the cores), reporting wall time, the payload
# each rank hands to the sums per level (from rank 0's progress lines), each rank's images and
# peak resident memory, and the CPU seconds of all processes (on a loaded machine the CPU time
# shows the work a configuration costs better than the wall time). All runs must write the same forest (checked).
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
measure() {  # measure NAME RANKS THREADS: wall and CPU seconds (user + system, all processes)
  local name=$1 ranks=$2 threads=$3 log=$ROOT/$1.log t
  local TIMEFORMAT='%R %U %S'
  if [ "$ranks" = 0 ]; then
    t=$( { time "$CLI" "${TRAIN[@]}" --threads "$threads" --out "$ROOT/$name.forest" 2>"$log" ; } 2>&1 ) || { cat "$log"; exit 1; }
  else
    t=$( { time "${MPIRUN[@]}" -np "$ranks" "$CLI" "${TRAIN[@]}" --threads "$threads" --out "$ROOT/$name.forest" 2>"$log" ; } 2>&1 ) ||
      { cat "$log"; exit 1; }
  fi
  echo "$t" | awk -v n="$name" '{ printf "%-22s wall %6.2f s, CPU %6.2f s\n", n, $1, $2 + $3 }'
  grep -E "rank [0-9]+ of" "$log" | sed 's/^train: /    /'
  [ "$ranks" = 0 ] && grep -oE "images [0-9.]+ MB.*peak resident [0-9.]+ MB" "$log" | sed 's/^/    /'
  true
}
echo "== $FRAMES frames 320x240, ${BENCH_PIXELS:-1000} px/image, depth ${BENCH_DEPTH:-12}, ${BENCH_OFFSETS:-200} x ${BENCH_THRESHOLDS:-20} candidates, $(nproc) cores"
echo "== 1 rank x 2 threads vs 2 ranks x 1 thread (and references)"
measure one-process-2-threads 0 2
measure one-process-1-thread 0 1
measure 2-ranks-1-thread 2 1
measure 3-ranks-1-thread 3 1
echo "== payload each rank hands to the sums, per level (rank 0's progress lines; N = 2 then 3)"
for n in 2 3; do
  grep -oE "level +[0-9]+/[0-9]+: [0-9]+ nodes, [0-9]+ split, [0-9.]+M px, [0-9.]+ G evals, [0-9.]+ MB reduced per rank" \
    "$ROOT/$n-ranks-1-thread.log" | sed "s/^/    N=$n /"
done
for f in one-process-1-thread 2-ranks-1-thread 3-ranks-1-thread; do
  cmp "$ROOT/one-process-2-threads.forest" "$ROOT/$f.forest" || { echo "bench-mpi: $f wrote another forest"; exit 1; }
done
echo "== every run wrote the same forest"
