#!/usr/bin/env bash
# Regenerates the shipped models from ../shared/assets with our own tools (`make model`; the knobs,
# their defaults and the pilot preset are in mk/model.mk, the usage in docs/results.md).
# Resumable: every step whose output is complete is skipped on a rerun — a training shard with all
# its frames, a forest trained by the same command (knobs unchanged), a tuned blob of that forest —
# and BPC training continues from its per-level checkpoint (`train --resume`). Each step's wall time
# is appended to $MODEL_DIR/times.txt and its command to commands.txt; report.txt puts the new
# models beside the ones they replace.
set -euo pipefail
CLI=${CLI:-build/bin/depthpose}
D=${MODEL_DIR:-build/model}
OUT=${MODEL_OUT:-models}   # the tuned blobs (the chain smoke test writes elsewhere)
W=${MODEL_W:-320}; H=${MODEL_H:-240}
TRAIN_FRAMES=${TRAIN_FRAMES:-120000}; SHARD_FRAMES=${SHARD_FRAMES:-5000}
PIXELS=${TRAIN_PIXELS:-1000}; OFFSETS=${TRAIN_OFFSETS:-400}; THRESHOLDS=${TRAIN_THRESHOLDS:-20}
MIN_SAMPLES=${TRAIN_MIN_SAMPLES:-10}; IMAGES_PER_TREE=${TRAIN_IMAGES_PER_TREE:-0}
OJR_DEPTH=${OJR_STRUCTURE_DEPTH:-20}; OJR_MIN_PIXELS=${OJR_MIN_PIXELS:-0}; OJR_MAX_LEAVES=${OJR_MAX_LEAVES:-0}
OJR_CUT_TUNED=${OJR_CUT_TUNED:-1}
MAX_BYTES=${MODEL_MAX_BYTES:-16000000}; PRUNE=${MODEL_PRUNE:-gain}; BPC_BLOB_TREES=${BPC_BLOB_TREES:-0}
OJR_BLOB_TREES=${OJR_BLOB_TREES:-0}
[ "$OJR_MIN_PIXELS" -gt 0 ] && [ "$OJR_MAX_LEAVES" -gt 0 ] &&
  { echo "make_model: set OJR_MIN_PIXELS or OJR_MAX_LEAVES, not both" >&2; exit 2; }
case "$PRUNE" in gain|pixels) ;; *) echo "make_model: MODEL_PRUNE must be gain or pixels, got '$PRUNE'" >&2; exit 2;; esac
SEED0=${TRAIN_SEED:-1000}
# Datasets rendered at once, one thread each: a render spends most of its time pruning the varied
# pose pool, which is one thread (277 CPU-s of a shard's ~330 at POSE_STRIDE 4), so one render per
# core renders a corpus about twice as fast on 2 cores as one render with 2 threads (measured: 9
# shards + val + test of the full recipe in 47 min with 2 lanes; a shard alone took 310-740 s).
LANES=${SYNTH_LANES:-$(nproc)}
[ "$SHARD_FRAMES" -ge 1 ] && [ "$TRAIN_FRAMES" -ge 1 ] || { echo "make_model: TRAIN_FRAMES and SHARD_FRAMES must be >= 1" >&2; exit 2; }
[ "$LANES" -ge 1 ] 2>/dev/null || { echo "make_model: SYNTH_LANES must be a whole number >= 1, got '$LANES'" >&2; exit 2; }
SHARDS=$(( (TRAIN_FRAMES + SHARD_FRAMES - 1) / SHARD_FRAMES ))
mkdir -p "$D" "$OUT"
START=$(date +%s)
echo "# $(date -u +%FT%TZ) make_model: $TRAIN_FRAMES training frames in $SHARDS shard(s), depth ${MODEL_DEPTH:-20}" >> "$D/times.txt"

elapsed() { local s=$(( $(date +%s) - START )); printf '%d:%02d:%02d' $((s / 3600)) $((s % 3600 / 60)) $((s % 60)); }
step() {  # step NAME command...: runs and times one step (its own lines on stderr: stdout may be a report file)
  local name=$1; shift
  local t0=$(date +%s.%N)
  echo "== [$(elapsed) elapsed] $name: $*" | tee -a "$D/commands.txt" >&2
  "$@"
  local t1=$(date +%s.%N)
  awk -v n="$name" -v a="$t0" -v b="$t1" 'BEGIN { printf "%s %.1f s\n", n, b - a }' | tee -a "$D/times.txt" >&2
}
skip() { echo "== [$(elapsed) elapsed] $1: done already ($2)" >&2; }
made() {  # made FILE command...: FILE exists and was made by this very command (knobs unchanged)
  local file=$1; shift
  [ -f "$file" ] && [ -f "$file.cmd" ] && [ "$(cat "$file.cmd")" = "$*" ]
}
unrecorded=()  # options a step runs with but does not record (they leave its output unchanged)
make_file() {  # make_file NAME FILE command...: runs the step, then records the command beside FILE
  local name=$1 file=$2; shift 2
  rm -f "$file.cmd"
  step "$name" "$@" "${unrecorded[@]}"
  echo "$*" > "$file.cmd"
}
synth() {  # synth NAME LABEL SEED FRAMES CLIPS [more synth options]: renders a dataset unless made already
  local name=$1 label=$2 seed=$3 frames=$4 clips=$5; shift 5
  local cmd=("$CLI" synth --assets "${ASSETS:-../shared/assets}" --out "$D/$name" --frames "$frames" --seed "$seed"
             --clips "$clips" --width "$W" --height "$H" "$@")
  # synth swaps a finished dataset in whole, so a directory with frames.jsonl is a complete one;
  # frames.jsonl.cmd beside it is the command that made it (other knobs: rendered again).
  if made "$D/$name/frames.jsonl" "${cmd[@]}"; then skip "$label" "$D/$name"; return 0; fi
  rm -rf "$D/$name"
  case $name in  # what was made from the old data is made again
    train_*) rm -f "$D/bpc.forest.cmd" "$D/bpc.forest.checkpoint" "$D/ojr.forest.cmd" ;;
    val) rm -f "$D/bpc.blob" "$D/ojr.blob" ;;
  esac
  # A pooled split (not the --sequence demo) renders with the pose cache (one per split: the
  # training shards read and retarget the clips once) and writes the pool report (poses before
  # and after pruning per category) to pool_NAME.txt. Neither changes a byte of the dataset, so
  # neither is part of the recorded command: shards recorded before the cache existed stay done.
  local unrecorded=()
  case " $* " in
    *" --sequence "*) make_file "$label" "$D/$name/frames.jsonl" "${cmd[@]}" ;;
    *) mkdir -p "$D/pose_cache"
       unrecorded=(--pose-cache "$D/pose_cache/${name%%_*}.bin" --pool-report)
       # With LANES > 1, once the split's pose cache exists (its first dataset renders alone and writes
       # it), the others render in the background, one thread each, at most LANES at once (lanes_done waits).
       if [ "$LANES" -gt 1 ] && [ -f "$D/pose_cache/${name%%_*}.bin" ]; then
         while [ "$(jobs -rp | wc -l)" -ge "$LANES" ]; do wait -n || true; done
         unrecorded+=(--threads 1)
         echo "== [$(elapsed) elapsed] $label: rendering beside others (its log: $D/log_$name.txt)" >&2
         make_file "$label" "$D/$name/frames.jsonl" "${cmd[@]}" > "$D/pool_$name.txt" 2> "$D/log_$name.txt" &
         lane_splits+=("$name")
       else
         lanes_done  # a render in the foreground starts once the lanes are empty (a failure there is named)
         make_file "$label" "$D/$name/frames.jsonl" "${cmd[@]}" > "$D/pool_$name.txt"
       fi ;;
  esac
}
lane_splits=()
lanes_done() {  # waits for every background render; a render that did not finish ends the run, naming its log
  while [ "$(jobs -rp | wc -l)" -gt 0 ]; do wait -n || true; done
  local name failed=0
  for name in "${lane_splits[@]}"; do
    if [ ! -f "$D/$name/frames.jsonl.cmd" ]; then
      echo "make_model: rendering $name failed; its log: $D/log_$name.txt" >&2
      tail -n 5 "$D/log_$name.txt" >&2 || true
      failed=1
    fi
  done
  [ "$failed" = 0 ] || exit 1
  lane_splits=()
}
# Every split: the varied pose pool, wide bodies, clothing and a hand-placed camera; each split has
# its own seeds, so no body, outfit or pose variant is shared with training.
corpus=(--pose-pool "${POSE_POOL:-varied}" --pose-stride "${POSE_STRIDE:-4}" --bodies "${BODIES:-wide}"
        --clothed "${CLOTHED:-0.8}" --camera-height "${CAMERA_HEIGHT:-0.5-1.9}" --camera-pitch "${CAMERA_PITCH:--5-25}"
        --camera-roll "${CAMERA_ROLL:-6}")

train_dirs=""
for ((k = 0; k < SHARDS; ++k)); do
  n=$(( TRAIN_FRAMES - k * SHARD_FRAMES < SHARD_FRAMES ? TRAIN_FRAMES - k * SHARD_FRAMES : SHARD_FRAMES ))
  name=$(printf 'train_%03d' "$k")
  synth "$name" "synth_train_shard $((k + 1))/$SHARDS" $((SEED0 + k)) "$n" "${TRAIN_CLIPS:-split:train}" \
        --pose-seed $((SEED0 + k)) "${corpus[@]}"
  train_dirs+="${train_dirs:+,}$D/$name"
done
synth val  synth_val  2001 "${VAL_FRAMES:-1000}"  "${VAL_CLIPS:-split:validation}" --pose-seed 2001 "${corpus[@]}" \
      --preview "$D/val_preview.png"
synth test synth_test 3001 "${TEST_FRAMES:-3000}" "${TEST_CLIPS:-split:test}" --pose-seed 3001 "${corpus[@]}" \
      --preview "$D/test_preview.png"
lanes_done

# The models being replaced (OLD_MODELS, e.g. models/; unset = none), copied once, before `make
# model` overwrites them, and scored on the same test split for the side-by-side report.
if [ -n "${OLD_MODELS:-}" ]; then
  for m in bpc ojr; do
    if [ -f "$OLD_MODELS/$m.blob" ] && [ ! -f "$D/old_$m.blob" ]; then cp "$OLD_MODELS/$m.blob" "$D/old_$m.blob"; fi
  done
fi

# BPC: one run of MODEL_TREES trees per seed of BPC_SEEDS (each checkpointed after every level: an
# interrupted run continues from it, train prints level ETAs); several runs are merged into one
# forest (`train --merge`: a tree is decided by its seed and index, so runs can be trained one at a time
# or on other machines).
read -r -a bpc_seeds <<< "${BPC_SEEDS:-1}"
[ "${#bpc_seeds[@]}" -ge 1 ] || { echo "make_model: BPC_SEEDS names no seed" >&2; exit 2; }
bpc_runs=()
for s in "${bpc_seeds[@]}"; do
  [[ "$s" =~ ^[0-9]+$ ]] || { echo "make_model: BPC_SEEDS must be whole numbers, got '$s'" >&2; exit 2; }
  run="$D/bpc_seed$s.forest"; [ "${#bpc_seeds[@]}" = 1 ] && run="$D/bpc.forest"
  bpc_train=("$CLI" train --data "$train_dirs" --method bpc --trees "${MODEL_TREES:-3}" --depth "${MODEL_DEPTH:-20}"
    --images-per-tree "$IMAGES_PER_TREE" --pixels-per-image "$PIXELS" --offsets "$OFFSETS" --thresholds "$THRESHOLDS"
    --min-samples "$MIN_SAMPLES" --seed "$s" --out "$run" --resume)
  if made "$run" "${bpc_train[@]}"; then skip "train_bpc (seed $s)" "$run"; else
    # everything made from the old forest (OJR: from the first run's)
    [ "$s" = "${bpc_seeds[0]}" ] && rm -f "$D/ojr.forest.cmd" "$D/ojr.blob"
    rm -f "$D/bpc.blob" "$D/bpc.forest.cmd"
    make_file "train_bpc (seed $s)" "$run" "${bpc_train[@]}"
  fi
  bpc_runs+=("$run")
done
if [ "${#bpc_runs[@]}" -gt 1 ]; then
  merge=("$CLI" train --merge "$(IFS=,; echo "${bpc_runs[*]}")" --out "$D/bpc.forest")
  if made "$D/bpc.forest" "${merge[@]}"; then skip merge_bpc "$D/bpc.forest"; else
    rm -f "$D/bpc.blob"
    make_file merge_bpc "$D/bpc.forest" "${merge[@]}"
  fi
fi
# OJR: the BPC structure cut back to OJR_STRUCTURE_DEPTH and pruned to OJR_MAX_LEAVES leaves by
# information gain (or to subtrees of at least OJR_MIN_PIXELS training pixels), vote leaves
# retro-fitted (paper 3.5.2); the retro-fit checkpoints blocks of leaves and continues from its
# checkpoint (`--resume`).
prune=()
[ "$OJR_MIN_PIXELS" -gt 0 ] && prune=(--structure-min-pixels "$OJR_MIN_PIXELS")
[ "$OJR_MAX_LEAVES" -gt 0 ] && prune=(--structure-max-leaves "$OJR_MAX_LEAVES")
# OJR's structure is the first BPC run's trees (BPC_SEEDS's first seed).
ojr_train=("$CLI" train --data "$train_dirs" --method ojr --structure "${bpc_runs[0]}" --structure-depth "$OJR_DEPTH"
  "${prune[@]}" --images-per-tree "$IMAGES_PER_TREE" --pixels-per-image "$PIXELS" --seed 1 --out "$D/ojr.forest" --resume)
if made "$D/ojr.forest" "${ojr_train[@]}"; then skip train_ojr "$D/ojr.forest"; else
  rm -f "$D/ojr.blob"
  make_file train_ojr "$D/ojr.forest" "${ojr_train[@]}"
fi
for m in bpc ojr; do
  # The tuned blob stands while its forest does (a retrained forest removes it, above).
  if [ -f "$D/$m.blob" ]; then skip "tune_$m" "$D/$m.blob"; else
    # BPC: the grown trees pruned to the byte budget (convert --max-bytes keeps the most leaves that
    # fit, by information gain or pixel count: MODEL_PRUNE). OJR: its size is set by its pruned
    # structure and its votes: the first tune's vote lengths cut every joint's votes
    # (convert --ojr-lengths-from: only votes that blob never casts go; smaller and faster), then
    # the cut blob is tuned again and must fit the budget.
    if [ "$m" = bpc ]; then
      # BPC_BLOB_TREES: the blob keeps the forest's first N trees (0 = all), so the budget buys
      # deeper leaves in fewer trees.
      trees=(); [ "$BPC_BLOB_TREES" -gt 0 ] && trees=(--trees "$BPC_BLOB_TREES")
      step convert_bpc "$CLI" convert "$D/bpc.forest" --out "$D/bpc_untuned.blob" --max-bytes "$MAX_BYTES" \
        --prune-by "$PRUNE" "${trees[@]}"
    elif [ "$OJR_CUT_TUNED" = 1 ]; then
      step convert_ojr "$CLI" convert "$D/ojr.forest" --out "$D/ojr_uncut.blob"
      step tune_ojr_uncut "$CLI" tune --blob "$D/ojr_uncut.blob" --data "$D/val" --out "$D/ojr_uncut_tuned.blob" \
        --json "$D/tune_ojr_uncut.json"
      step convert_ojr_cut "$CLI" convert "$D/ojr.forest" --out "$D/ojr_untuned.blob" \
        --ojr-lengths-from "$D/ojr_uncut_tuned.blob" --max-bytes "$MAX_BYTES"
    else
      step convert_ojr "$CLI" convert "$D/ojr.forest" --out "$D/ojr_untuned.blob" --max-bytes "$MAX_BYTES"
    fi
    step "tune_$m" "$CLI" tune --blob "$D/${m}_untuned.blob" --data "$D/val" --out "$D/$m.blob.tmp" --json "$D/tune_$m.json"
    if [ "$m" = ojr ] && [ "$OJR_BLOB_TREES" -gt 0 ]; then
      # OJR_BLOB_TREES: the tuned blob's first N trees (convert --from-blob), tuned again.
      mv "$D/ojr.blob.tmp" "$D/ojr_all_trees.blob"
      step ojr_trees "$CLI" convert --from-blob "$D/ojr_all_trees.blob" --trees "$OJR_BLOB_TREES" \
        --out "$D/ojr_trees_untuned.blob"
      step tune_ojr_trees "$CLI" tune --blob "$D/ojr_trees_untuned.blob" --data "$D/val" --out "$D/ojr.blob.tmp" \
        --json "$D/tune_ojr_trees.json"
    fi
    mv "$D/$m.blob.tmp" "$D/$m.blob"
  fi
  cp "$D/$m.blob" "$OUT/$m.blob"
  step "eval_$m" "$CLI" eval --blob "$D/$m.blob" --data "$D/test" --json "$D/eval_$m.json" --plots "$D/plots_$m" > "$D/eval_$m.txt"
  if [ -f "$D/old_$m.blob" ]; then
    step "eval_old_$m" "$CLI" eval --blob "$D/old_$m.blob" --data "$D/test" --json "$D/eval_old_$m.json" > "$D/eval_old_$m.txt"
  fi
done
# The demo is a recording-like scene (one camera, a floor, furniture, two people moving through a
# test clip; `make run` plays it). It stays as shipped: recorded only when missing.
if [ -f "$OUT/demo.oni" ]; then skip record_demo "$OUT/demo.oni"; else
  synth demo synth_demo "${DEMO_SEED:-415}" "${DEMO_FRAMES:-45}" "${DEMO_CLIPS:-02_06}" --sequence --floor --clutter 3 --people 2
  step record_demo "$CLI" record --source "dataset:$D/demo" --out "$OUT/demo.oni" --zero-border
fi

# report.txt: mAP overall and per held-out category, new beside old, from the eval JSONs.
{
  echo "held-out test split ($D/test, $(wc -l < "$D/test/frames.jsonl") frames), mAP at D_tp = 0.1 m"
  for m in bpc ojr; do
    files=("$D/eval_$m.json"); labels=("new")
    [ -f "$D/eval_old_$m.json" ] && { files+=("$D/eval_old_$m.json"); labels+=("old"); }
    echo "${m^^}:"
    for i in "${!files[@]}"; do
      sed -n 's/^  "mAP": \(.*\),$/\1/p' "${files[$i]}" | awk -v l="${labels[$i]}" '{ printf "  %-3s all categories  mAP %.3f\n", l, $1 }'
    done
    for i in "${!files[@]}"; do  # the per-category rows of the text report, without the joint columns
      sed -n '/^mAP per motion category/,/^mAP per mocap subject/p' "${files[$i]%.json}.txt" | sed '1d;$d' |
        cut -d'|' -f1 | sed "s/^/  ${labels[$i]} /"
    done
  done
} > "$D/report.txt"
cat "$D/report.txt"
# report.md: the Markdown tables of docs/results.md (overall, per category, per joint, AP vs D_tp).
python3 "$(dirname "$0")/model_report.py" "$D" > "$D/report.md"
echo "== [$(elapsed) elapsed] make_model: done; blobs in $OUT"
ls -l "$OUT"
