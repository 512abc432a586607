# `make model`: reproduces the shipped models (models/bpc.blob, models/ojr.blob, models/demo.oni)
# from ../shared/assets with our own tools. Sizes and seeds are recorded in docs/results.md.
# Splits use disjoint mocap clips and disjoint body-shape seeds.
ASSETS        ?= ../shared/assets
MODEL_DIR     ?= build/model
MODEL_W       ?= 320
MODEL_H       ?= 240
TRAIN_FRAMES  ?= 3000
VAL_FRAMES    ?= 300
TEST_FRAMES   ?= 500
DEMO_FRAMES   ?= 45
MODEL_DEPTH   ?= 16
MODEL_TREES   ?= 3
TRAIN_CLIPS   ?= 01_01,01_02,01_03,01_04,01_05,01_06,01_07,01_08,01_09,01_10,01_11,02_01,02_03,02_04,02_05,02_07,02_08,02_10,03_01,03_02
VAL_CLIPS     ?= 01_12,02_09,03_03
TEST_CLIPS    ?= 01_13,01_14,02_02,02_06,03_04
DEMO_CLIPS    ?= 02_06

model: all
	@mkdir -p $(MODEL_DIR) models
	MODEL_DIR=$(MODEL_DIR) MODEL_W=$(MODEL_W) MODEL_H=$(MODEL_H) TRAIN_FRAMES=$(TRAIN_FRAMES) VAL_FRAMES=$(VAL_FRAMES) \
	  TEST_FRAMES=$(TEST_FRAMES) DEMO_FRAMES=$(DEMO_FRAMES) MODEL_DEPTH=$(MODEL_DEPTH) MODEL_TREES=$(MODEL_TREES) \
	  TRAIN_CLIPS=$(TRAIN_CLIPS) VAL_CLIPS=$(VAL_CLIPS) TEST_CLIPS=$(TEST_CLIPS) DEMO_CLIPS=$(DEMO_CLIPS) ASSETS=$(ASSETS) \
	  CLI=$(CLI) mk/make_model.sh
