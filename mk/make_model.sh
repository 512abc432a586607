#!/usr/bin/env bash
# Reproduces the shipped models from ../shared/assets with our own tools (`make model`).
# Every size, seed and clip list comes from mk/model.mk (overridable on the make command line);
# the timings of each step are appended to $MODEL_DIR/times.txt for docs/results.md.
set -euo pipefail
CLI=${CLI:-build/bin/depthpose}
D=${MODEL_DIR:-build/model}
W=${MODEL_W:-320}; H=${MODEL_H:-240}
PIXELS=${TRAIN_PIXELS:-1000}; OFFSETS=${TRAIN_OFFSETS:-400}; THRESHOLDS=${TRAIN_THRESHOLDS:-20}
MIN_SAMPLES=${TRAIN_MIN_SAMPLES:-30}; IMAGES_PER_TREE=${TRAIN_IMAGES_PER_TREE:-1000}
OJR_DEPTH=${OJR_STRUCTURE_DEPTH:-13}
OUT=${MODEL_OUT:-models}   # where the blobs and demo.oni go (the chain smoke test writes elsewhere)
mkdir -p "$D" "$OUT"
: > "$D/times.txt"
step() {  # step NAME command...
  local name=$1; shift
  local t0=$(date +%s.%N)
  echo "== $name: $*" | tee -a "$D/commands.txt"
  "$@"
  local t1=$(date +%s.%N)
  awk -v n="$name" -v a="$t0" -v b="$t1" 'BEGIN { printf "%s %.1f s\n", n, b - a }' | tee -a "$D/times.txt"
}
synth() {  # synth NAME SEED FRAMES CLIPS [more synth options]
  local name=$1 seed=$2 frames=$3 clips=$4; shift 4
  [ -f "$D/$name/frames.jsonl" ] && [ "$(wc -l < "$D/$name/frames.jsonl")" -eq "$frames" ] && return 0
  rm -rf "$D/$name"
  step "synth_$name" "$CLI" synth --assets "${ASSETS:-../shared/assets}" --out "$D/$name" --frames "$frames" \
       --seed "$seed" --clips "$clips" --width "$W" --height "$H" --preview "$D/${name}_preview.png" "$@"
}
synth train 101 "${TRAIN_FRAMES:-3000}" "$TRAIN_CLIPS"
synth val   202 "${VAL_FRAMES:-300}"    "$VAL_CLIPS"
synth test  303 "${TEST_FRAMES:-500}"   "$TEST_CLIPS"
# The demo is a recording-like scene: one camera, a floor, furniture and two people moving through
# a test clip (`make run` segments it and prints joints per user).
synth demo  "${DEMO_SEED:-415}" "${DEMO_FRAMES:-45}" "$DEMO_CLIPS" --sequence --floor --clutter 3 --people 2

step train_bpc "$CLI" train --data "$D/train" --method bpc --trees "${MODEL_TREES:-3}" --depth "${MODEL_DEPTH:-16}" \
     --images-per-tree "$IMAGES_PER_TREE" --pixels-per-image "$PIXELS" --offsets "$OFFSETS" --thresholds "$THRESHOLDS" \
     --min-samples "$MIN_SAMPLES" --seed 1 --out "$D/bpc.forest" --resume  # an interrupted run continues
# OJR: the classification structure cut back to depth 13 (so 16 joints x K=2 vote leaves fit ~6 MB),
# vote leaves retro-fitted (paper 3.5.2).
step train_ojr "$CLI" train --data "$D/train" --method ojr --structure "$D/bpc.forest" --structure-depth "$OJR_DEPTH" \
     --images-per-tree "$IMAGES_PER_TREE" --pixels-per-image "$PIXELS" --seed 1 --out "$D/ojr.forest"
for m in bpc ojr; do
  step "convert_$m" "$CLI" convert "$D/$m.forest" --out "$D/${m}_untuned.blob"
  step "tune_$m" "$CLI" tune --blob "$D/${m}_untuned.blob" --data "$D/val" --out "$D/$m.blob" --json "$D/tune_$m.json"
  cp "$D/$m.blob" "$OUT/$m.blob"
  step "eval_$m" "$CLI" eval --blob "$OUT/$m.blob" --data "$D/test" --json "$D/eval_$m.json" --plots "$D/plots_$m"
done
step record_demo "$CLI" record --source "dataset:$D/demo" --out "$OUT/demo.oni" --zero-border
ls -l "$OUT"
