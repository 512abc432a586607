# `make model`: regenerates the shipped models (models/bpc.blob, models/ojr.blob) from the CMU
# corpus in ../shared/assets with our own tools (mk/make_model.sh does the work; docs/results.md
# "Reproducing the models" has the usage, the pilot's timings and the estimate for the full run).
# Train / validation / test come from the held-out splits of tools/synth/splits.tsv (whole subjects
# and motion categories), each with its own body, clothing and pose-variation seeds. The training
# corpus is rendered in shards (one dataset per SHARD_FRAMES frames) and training checkpoints every
# level, so an interrupted `make model` continues where it stopped. Not run by `make test` or CI.
#
#   make model                      the full run (hours): 120 000 training images, BPC depth 20
#   make model MODEL_SCALE=pilot    the same chain at toy scale (~10 CPU-minutes) into build/model-pilot
#   make model TRAIN_FRAMES=60000 MODEL_DEPTH=18 ...   any knob below
MODEL_SCALE   ?= full
ifeq ($(MODEL_SCALE),pilot)
MODEL_DIR     ?= build/model-pilot
MODEL_OUT     ?= build/model-pilot/models
TRAIN_FRAMES  ?= 1500
SHARD_FRAMES  ?= 500
VAL_FRAMES    ?= 150
TEST_FRAMES   ?= 300
MODEL_DEPTH   ?= 12
BPC_SEEDS     ?= 1
OJR_STRUCTURE_DEPTH ?= 12
OJR_MIN_PIXELS ?= 0
OJR_MAX_LEAVES ?= 0
BPC_BLOB_TREES ?= 0
OJR_BLOB_TREES ?= 0
TRAIN_PIXELS  ?= 500
TRAIN_OFFSETS ?= 100
TRAIN_THRESHOLDS ?= 10
TRAIN_MIN_SAMPLES ?= 10
POSE_STRIDE   ?= 16
else ifneq ($(MODEL_SCALE),full)
$(error MODEL_SCALE must be full or pilot, got '$(MODEL_SCALE)')
endif
ASSETS        ?= ../shared/assets
MODEL_DIR     ?= build/model       # datasets, forests, checkpoints, evals, times.txt, report.txt
MODEL_OUT     ?= models            # where the tuned blobs (and a missing demo.oni) go
OLD_MODELS    ?= models            # the blobs being replaced: kept as MODEL_DIR/old_*.blob and scored beside the new
MODEL_W       ?= 320
MODEL_H       ?= 240
TRAIN_FRAMES  ?= 120000            # training images (all trees draw from them; paper: 300k-900k per tree)
SHARD_FRAMES  ?= 5000              # training images per rendered shard (the unit of resumed rendering)
VAL_FRAMES    ?= 1000              # tune's validation set
TEST_FRAMES   ?= 3000              # the held-out test set the report scores
MODEL_TREES   ?= 1                 # BPC trees grown per run (one tree: OJR test 0.776 vs 0.753 from three,
                                   # docs/results.md)
BPC_SEEDS     ?= 1 2               # one BPC run of MODEL_TREES trees per seed, merged (train --merge); OJR is
                                   # retro-fitted on the first run's trees (two one-tree runs: test BPC 0.755
                                   # vs 0.746 from one, docs/results.md)
MODEL_DEPTH   ?= 20                # BPC tree depth
OJR_STRUCTURE_DEPTH ?= 20          # OJR reuses the BPC trees cut to this depth (leaf votes are retro-fitted)
OJR_MAX_LEAVES ?= 200000           # ...and pruned to this many leaves over all trees by information gain
                                   # (9.2 MB once its votes are cut at the tuned lengths, format v4)
OJR_MIN_PIXELS ?= 0                # or (instead) to subtrees of >= this many training pixels (0 = none)
OJR_CUT_TUNED ?= 1                 # OJR votes cut at a first tune's vote lengths, then tuned again
MODEL_MAX_BYTES ?= 16000000        # blob budget: BPC is pruned to fit, OJR must fit
MODEL_PRUNE   ?= gain              # how BPC is pruned to the budget: gain (information) or pixels
BPC_BLOB_TREES ?= 0                # the BPC blob keeps the first N trees (0 = all)
OJR_BLOB_TREES ?= 0                # the OJR blob keeps the tuned blob's first N trees, tuned again (0 = all;
                                   # 2: validation 0.778 vs 0.780, 2/3 of the forest and vote work, docs/results.md)
TRAIN_PIXELS  ?= 1000              # training pixels per image
TRAIN_OFFSETS ?= 400               # candidate offset pairs per node (paper: 2000)
TRAIN_THRESHOLDS ?= 20             # candidate thresholds per offset pair (paper: 50)
TRAIN_MIN_SAMPLES ?= 10            # nodes with fewer pixels become leaves
TRAIN_IMAGES_PER_TREE ?= 0         # 0 = every training image in every tree
POSE_STRIDE   ?= 4                 # every N-th mocap frame enters the pose pool
SYNTH_LANES   ?=                   # datasets rendered at once, one thread each (empty = one per core)
POSE_POOL     ?= varied            # real poses plus mirrored, noisy and recombined ones
BODIES        ?= wide              # every macro control, ages 6-80
CLOTHED       ?= 0.8               # share of clothed bodies (the rest bare)
CAMERA_HEIGHT ?= 0.5-1.9           # metres above the floor
CAMERA_PITCH  ?= -5-25             # degrees, positive looking down
CAMERA_ROLL   ?= 6                 # degrees, uniform in [-R, R]
TRAIN_CLIPS   ?= split:train
VAL_CLIPS     ?= split:validation
TEST_CLIPS    ?= split:test
TRAIN_SEED    ?= 1000              # shard k renders with seed TRAIN_SEED + k
DEMO_FRAMES   ?= 45
DEMO_CLIPS    ?= 02_06

MODEL_VARS := ASSETS MODEL_DIR MODEL_OUT OLD_MODELS MODEL_W MODEL_H TRAIN_FRAMES SHARD_FRAMES VAL_FRAMES TEST_FRAMES \
  MODEL_TREES BPC_SEEDS MODEL_DEPTH OJR_STRUCTURE_DEPTH OJR_MIN_PIXELS OJR_MAX_LEAVES OJR_CUT_TUNED MODEL_MAX_BYTES MODEL_PRUNE BPC_BLOB_TREES OJR_BLOB_TREES TRAIN_PIXELS TRAIN_OFFSETS TRAIN_THRESHOLDS TRAIN_MIN_SAMPLES \
  TRAIN_IMAGES_PER_TREE POSE_STRIDE SYNTH_LANES POSE_POOL BODIES CLOTHED CAMERA_HEIGHT CAMERA_PITCH CAMERA_ROLL \
  TRAIN_CLIPS VAL_CLIPS TEST_CLIPS TRAIN_SEED DEMO_FRAMES DEMO_CLIPS

model: all
	env $(foreach v,$(MODEL_VARS),$(v)='$(strip $($(v)))') CLI=$(CLI) mk/make_model.sh

# Accuracy against training cost on the corpus `make model` rendered (mk/cost_curve.sh): BPC
# forests with fewer images per tree, other depths and candidate counts, scored on validation.
CURVE_POINTS  ?= 1000:20:400:20 3000:20:400:20 10000:20:400:20 3000:12:400:20 3000:16:400:20 3000:20:100:20 3000:20:1000:20
CURVE_SHIPPED ?= 1                 # also score make model's own forest the same way
.PHONY: cost-curve
cost-curve: all
	env MODEL_DIR='$(strip $(MODEL_DIR))' MODEL_TREES='$(strip $(MODEL_TREES))' MODEL_DEPTH='$(strip $(MODEL_DEPTH))' \
	  TRAIN_PIXELS='$(strip $(TRAIN_PIXELS))' TRAIN_MIN_SAMPLES='$(strip $(TRAIN_MIN_SAMPLES))' \
	  CURVE_POINTS='$(strip $(CURVE_POINTS))' CURVE_SHIPPED='$(strip $(CURVE_SHIPPED))' CLI=$(CLI) mk/cost_curve.sh
