#!/usr/bin/env bash
# End-to-end smoke test of the whole offline + online chain on a tiny corpus (~15 s):
# synth → train (BPC, OJR) → convert → tune → eval → record → run, with the same script that
# makes the shipped models (mk/make_model.sh), writing under build/chain (never models/).
# Each check prints a GoogleTest-style line so mk/test_summary.sh counts it.
set -uo pipefail
CLI=${CLI:-build/bin/depthpose}
ROOT=${CHAIN_DIR:-build/chain}
LOG=$ROOT/chain.log
rm -rf "$ROOT"; mkdir -p "$ROOT"
ran=0
check() {  # check NAME command...
  local name=$1; shift
  ran=$((ran+1))
  if "$@" >>"$LOG.steps" 2>&1; then echo "[       OK ] ChainSmoke.$name"; else echo "[  FAILED  ] ChainSmoke.$name"; fi
}
{
  check MakeModel env CLI="$CLI" MODEL_DIR="$ROOT/model" MODEL_OUT="$ROOT/models" \
    MODEL_W=160 MODEL_H=120 TRAIN_FRAMES=60 SHARD_FRAMES=30 VAL_FRAMES=20 TEST_FRAMES=20 DEMO_FRAMES=5 \
    MODEL_DEPTH=8 MODEL_TREES=2 TRAIN_IMAGES_PER_TREE=60 TRAIN_PIXELS=200 TRAIN_OFFSETS=50 TRAIN_THRESHOLDS=10 \
    OJR_STRUCTURE_DEPTH=6 OJR_BLOB_TREES=1 ASSETS="${ASSETS:-../shared/assets}" SYNTH_LANES=2 \
    TRAIN_CLIPS=01_01,01_02,02_01 VAL_CLIPS=01_12 TEST_CLIPS=01_13 DEMO_CLIPS=02_06 \
    mk/make_model.sh
  # The second training shard read the pose cache the first one wrote and rendered in a background
  # lane with one thread; rendered again from its recorded command (no cache, every core), it must
  # be the same dataset byte for byte.
  check PoseCacheChangesNoByte bash -c "grep -q 'pose_cache/train.bin: real poses read' '$ROOT/model/log_train_001.txt' &&
    cmd=\$(sed 's| --out [^ ]*| --out $ROOT/train_001_uncached|' '$ROOT/model/train_001/frames.jsonl.cmd') &&
    \$cmd && diff -r -x frames.jsonl.cmd '$ROOT/model/train_001' '$ROOT/train_001_uncached'"
  # A render that fails in a background lane ends the run with its name and log (here every
  # render fails: the pose cache exists, so both shards go to lanes, and the CLI is `false`).
  check LaneFailureNamed bash -c "mkdir -p '$ROOT/failing/pose_cache' && touch '$ROOT/failing/pose_cache/train.bin' &&
    ! env CLI=false MODEL_DIR='$ROOT/failing' MODEL_OUT='$ROOT/failing/models' TRAIN_FRAMES=2 SHARD_FRAMES=1 SYNTH_LANES=2 \
      mk/make_model.sh 2> '$ROOT/failing.err' && grep -q 'rendering train_001 failed; its log: $ROOT/failing/log_train_001.txt' '$ROOT/failing.err'"
  # The accuracy-vs-cost table on the tiny corpus: two trained points and the recipe's forest, each
  # scored on validation; a rerun trains nothing again.
  check CostCurve bash -c "env CLI='$CLI' MODEL_DIR='$ROOT/model' CURVE_POINTS='20:6:50:10 0:8:50:10' CURVE_SHIPPED=1 \
      mk/cost_curve.sh > '$ROOT/curve.md' && [ \$(grep -cE '\| 0\.[0-9]{3} \| 0\.[0-9]{3} \|\$' '$ROOT/curve.md') -eq 3 ] &&
    env CLI='$CLI' MODEL_DIR='$ROOT/model' CURVE_POINTS='20:6:50:10' mk/cost_curve.sh 2>&1 >/dev/null | grep -q 'i20_d6_o50_t10 trained already'"
  # The Markdown tables of docs/results.md, from the evals the run made.
  check ReportTables bash -c "grep -q '^| \*\*mAP\*\* | \*\*0\.[0-9]\{3\}\*\* | \*\*0\.[0-9]\{3\}\*\* |' '$ROOT/model/report.md' &&
    [ \$(grep -c '^| [a-z_]* | [*0-9.]* | [*0-9.]* |\$' '$ROOT/model/report.md') -ge 16 ]"
  check BlobsDescribed bash -c "'$CLI' info '$ROOT/models/bpc.blob' && '$CLI' info '$ROOT/models/ojr.blob'"
  # A chain that lost the labels or joints on the way scores ~0; even this tiny forest scores > 0.1.
  check EvalScores bash -c "grep -qE '^  \"mAP\": *0\.[1-9]' '$ROOT/model/eval_bpc.json' && grep -qE '^  \"mAP\": *0\.[1-9]' '$ROOT/model/eval_ojr.json'"
  check PlotsWritten bash -c "ls '$ROOT/model/plots_bpc/'*.png '$ROOT/model/plots_ojr/'*.png"
  check RunOnRecording bash -c "'$CLI' run --blob '$ROOT/models/ojr.blob' --source 'oni:$ROOT/models/demo.oni' --json > '$ROOT/run.jsonl' && [ \$(grep -c '^{' '$ROOT/run.jsonl') -eq 5 ]"
  echo "[==========] $ran tests ran."
} | tee "$LOG"
