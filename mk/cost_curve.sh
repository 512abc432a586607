#!/usr/bin/env bash
# Accuracy against training cost (`make cost-curve`): BPC forests trained on the corpus `make model`
# rendered (MODEL_DIR) with fewer images per tree, shallower trees or other candidate counts, each
# converted with the default runtime parameters and scored on the validation split — never on the
# test split, whose scores report the shipped models. A row: the knobs, the training's CPU and wall
# seconds, the forest's leaves and blob bytes, validation mAP and per-class accuracy. The table
# lands in $MODEL_DIR/cost_curve.md (and on stdout); docs/results.md explains the choices it backs.
#
# CURVE_POINTS lists "images:depth:offsets:thresholds" points (images per tree; 0 = all). A point
# whose forest was trained by the same command (recorded beside it) is not trained again, so an
# interrupted run continues where it stopped. CURVE_SHIPPED=1 adds the forest `make model` trained
# ($MODEL_DIR/bpc.forest, unpruned), scored the same way.
set -euo pipefail
CLI=${CLI:-build/bin/depthpose}
D=${MODEL_DIR:-build/model}
C=$D/cost_curve
POINTS=${CURVE_POINTS:-"1000:20:400:20 3000:20:400:20 10000:20:400:20 3000:12:400:20 3000:16:400:20 3000:20:100:20 3000:20:1000:20"}
TREES=${MODEL_TREES:-3}; PIXELS=${TRAIN_PIXELS:-1000}; MIN_SAMPLES=${TRAIN_MIN_SAMPLES:-10}
mkdir -p "$C"
[ -f "$D/val/frames.jsonl" ] || { echo "cost_curve: no validation split in $D/val (run make model first)" >&2; exit 2; }
train_dirs=$(ls -d "$D"/train_[0-9]* 2>/dev/null | while read -r dir; do
  [ -f "$dir/frames.jsonl" ] && printf '%s,' "$dir"; done)
train_dirs=${train_dirs%,}
[ -n "$train_dirs" ] || { echo "cost_curve: no complete training shard (train_NNN/frames.jsonl) in $D" >&2; exit 2; }

# timed LOG command...: runs the command (its output appended to LOG) and prints "wall user+sys" seconds.
timed() {
  local log=$1; shift
  local TIMEFORMAT='%R %U %S' t
  t=$( { time "$@" >> "$log" 2>&1 ; } 2>&1 ) || { echo "cost_curve: failed: $*; see $log" >&2; tail -n 5 "$log" >&2; exit 1; }
  awk '{ printf "%.1f %.1f\n", $1, $2 + $3 }' <<< "$t"
}
json_number() { sed -n "s/^  \"$2\": \([-0-9.e]*\),\$/\1/p" "$1" | head -n 1; }
# score NAME FOREST: converts with the default runtime parameters and evaluates on validation.
score() {
  local name=$1 forest=$2
  "$CLI" convert "$forest" --out "$C/$name.blob" >> "$C/$name.log" 2>&1 ||
    { echo "cost_curve: convert $forest failed; see $C/$name.log" >&2; exit 1; }
  "$CLI" eval --blob "$C/$name.blob" --data "$D/val" --json "$C/$name.eval.json" > "$C/$name.eval.txt" 2>> "$C/$name.log" ||
    { echo "cost_curve: eval of $C/$name.blob failed; see $C/$name.log" >&2; exit 1; }
  printf '%s %s %s\n' "$(json_number "$C/$name.eval.json" mAP)" "$(json_number "$C/$name.eval.json" class_accuracy)" \
    "$(stat -c %s "$C/$name.blob")"
}
leaves() { "$CLI" info "$1" 2>/dev/null | sed -n 's/.*, \([0-9][0-9]*\) leaf records.*/\1/p' | head -n 1; }  # of a blob

{
  echo "| images/tree | depth | offsets × thresholds | train wall s | train CPU s | leaves | blob MB | val mAP | val class acc. |"
  echo "|---|---|---|---|---|---|---|---|---|"
} > "$C/table.md"
for p in $POINTS; do
  IFS=: read -r images depth offsets thresholds <<< "$p"
  for v in "$images" "$depth" "$offsets" "$thresholds"; do
    [[ "$v" =~ ^[0-9]+$ ]] || { echo "cost_curve: CURVE_POINTS entry '$p' is not images:depth:offsets:thresholds" >&2; exit 2; }
  done
  name="i${images}_d${depth}_o${offsets}_t${thresholds}"
  cmd=("$CLI" train --data "$train_dirs" --method bpc --trees "$TREES" --depth "$depth" --images-per-tree "$images"
       --pixels-per-image "$PIXELS" --offsets "$offsets" --thresholds "$thresholds" --min-samples "$MIN_SAMPLES" --seed 1
       --out "$C/$name.forest" --resume --quiet)
  if [ -f "$C/$name.forest" ] && [ -f "$C/$name.time" ] && [ "$(cat "$C/$name.forest.cmd" 2>/dev/null)" = "${cmd[*]}" ]; then
    echo "cost_curve: $name trained already" >&2
  else
    echo "cost_curve: training $name" >&2
    rm -f "$C/$name.forest.cmd" "$C/$name.time"
    timed "$C/$name.log" "${cmd[@]}" > "$C/$name.time.tmp"
    mv "$C/$name.time.tmp" "$C/$name.time"
    echo "${cmd[*]}" > "$C/$name.forest.cmd"
  fi
  read -r wall cpu < "$C/$name.time"
  read -r map acc bytes <<< "$(score "$name" "$C/$name.forest")"
  printf '| %s | %s | %s × %s | %s | %s | %s | %.2f | %.3f | %.3f |\n' "${images/#0/all}" "$depth" "$offsets" "$thresholds" \
    "$wall" "$cpu" "$(leaves "$C/$name.blob")" "$(awk -v b="$bytes" 'BEGIN { print b / 1e6 }')" "$map" "$acc" >> "$C/table.md"
done
if [ "${CURVE_SHIPPED:-0}" = 1 ] && [ -f "$D/bpc.forest" ]; then
  read -r map acc bytes <<< "$(score shipped "$D/bpc.forest")"
  printf '| all (make model) | %s | — | — | — | %s | %.2f | %.3f | %.3f |\n' "${MODEL_DEPTH:-20}" "$(leaves "$C/shipped.blob")" \
    "$(awk -v b="$bytes" 'BEGIN { print b / 1e6 }')" "$map" "$acc" >> "$C/table.md"
fi
cp "$C/table.md" "$D/cost_curve.md"
cat "$D/cost_curve.md"
