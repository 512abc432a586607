# depthpose — GNU Make build. Everything lands under $(BUILD) (default build/).
#   make            build the CLI (build/bin/depthpose) and the runtime library
#   make run        install what is missing, build, run the shipped model on the shipped recording
#   make test       install what is missing, build, run every test (normal, ASan+UBSan, debug
#                   checks, the chain, the checks); prints each step's wall and CPU seconds, then
#                   ends with "N passed, N failed, N skipped"
#   make bench      benchmarks (tests/bench/*_bench.cc, one binary each)
#   make bench-mpi  distributed training measured under mpirun (mk/mpi.mk, docs/training.md)
#   make fuzz-smoke libFuzzer, one target per parser, FUZZ_RUNS fixed-seed inputs each (~2 min)
#   make fuzz       libFuzzer exploration, random seed, FUZZ_SECONDS (300) per parser
#   make check-runtime  proves the runtime references no heap / exception symbols
#   make deps       installs the Debian packages of mk/debian-packages.txt that are missing
# Components add rules in mk/*.mk; sources are found by directory, so adding a file needs no edit here.
# Builds use every core unless a -j is given (make -j1 for a serial build).

# GNU Make 4.3 shows no -j in $(MAKEFLAGS) while it reads the makefile, so the top-level make
# looks for one on its own command line (and in an exported MAKEFLAGS); sub-makes share its slots.
ifeq ($(MAKELEVEL),0)
  ifeq ($(filter -j% j% --jobs%,$(shell tr '\0' ' ' < /proc/$$PPID/cmdline 2>/dev/null; echo " $$MAKEFLAGS")),)
    MAKEFLAGS += -j$(shell nproc 2>/dev/null || echo 2)
  endif
endif

BUILD    ?= build
SAN      ?=
CXX      ?= g++
OPT      ?= -O2
# Debug information: line tables (-g1) by default: enough for the file:line of a backtrace or a
# sanitizer report, and the same code as -g (debug information never changes what GCC generates).
# Full -g (variables and types for gdb) costs about half as much again to compile at -O2
# (tools/common/dataset.cc: 25.8 CPU-s with -g, 17.2 with -g1, 14.8 with -g0): ask for it with
# `make DEBUGINFO=-g` (in its own BUILD folder: flags are not tracked, objects are not rebuilt).
DEBUGINFO ?= -g1
DEBUG    ?=
CXXSTD   := -std=c++20
# The target architecture, from the compiler (x86_64, aarch64, ...): it picks the kernel folders.
TARGET_ARCH := $(firstword $(subst -, ,$(shell $(CXX) -dumpmachine)))
# The x86 tools' baseline (tools/train uses SSE4.1 intrinsics). The runtime needs none: its generic
# code and kernels/ref are plain C++, and each kernels/<isa>/ folder gets its own flags below.
BASE_ISA := $(if $(filter x86_64,$(TARGET_ARCH)),-msse4.1,)
WARN     := -Wall -Wextra -Wno-missing-field-initializers
INCLUDES := -I. -I/usr/include/openni2
DEPFLAGS  = -MMD -MP

ifeq ($(SAN),1)
  SANFLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
else
  SANFLAGS :=
endif
# make DEBUG=1: the runtime's precondition checks (runtime/debug_check.h) compiled in, at -O1.
ifeq ($(DEBUG),1)
  OPT := -O1
  DEBUGFLAGS := -DDP_DEBUG_CHECKS=1
else
  DEBUGFLAGS :=
endif

CXXFLAGS_COMMON := $(CXXSTD) $(OPT) $(DEBUGINFO) $(BASE_ISA) $(WARN) $(INCLUDES) $(SANFLAGS) $(DEBUGFLAGS) $(EXTRA_CXXFLAGS)
# -ffp-contract=off: every float product and sum of the runtime is rounded on its own, as the
# reference kernels define it (no fused multiply-add on FMA-capable x86 kernels or on aarch64, where
# GCC would otherwise fuse), so every ISA gives the same bits.
RUNTIME_CXXFLAGS := $(filter-out $(BASE_ISA),$(CXXFLAGS_COMMON)) -ffp-contract=off -fno-exceptions -fno-rtti -fno-threadsafe-statics
TOOLS_CXXFLAGS   := $(CXXFLAGS_COMMON) -pthread
LDLIBS_TOOLS     := -lpng -lz -lbz2 -lusb-1.0 -lOpenNI2 -pthread

# Per-ISA kernel folders: same file names as runtime/kernels/ref, compiled for their ISA (ref/ and
# neon/ need no flag: NEON is part of the AArch64 base architecture).
# -fno-tree-slp-vectorize: GCC 12's -O2 packs the forest kernels' scalar probe loads back into
# vectors with shift/or chains and stack spills (more ops per visit); without it the forest stage
# takes 5-12 % fewer cycles, the other kernels the same (docs/runtime_speed.md).
ISA_FLAGS_sse41  := -msse4.1
ISA_FLAGS_avx2   := -mavx2 -mfma -mbmi -mbmi2 -mpopcnt -fno-tree-slp-vectorize
ISA_FLAGS_avx512 := -mavx2 -mfma -mbmi -mbmi2 -mpopcnt -mavx512f -mavx512bw -mavx512vl -mavx512dq -fno-tree-slp-vectorize
ISA_FLAGS_neon   := -fno-tree-slp-vectorize
ISA_DIRS_x86_64  := sse41 avx2 avx512
ISA_DIRS_aarch64 := neon
ISA_DIRS         := $(ISA_DIRS_$(TARGET_ARCH))
OTHER_ISA_DIRS   := $(filter-out $(ISA_DIRS),sse41 avx2 avx512 neon)

RUNTIME_EXCLUDE ?=
RUNTIME_SRCS := $(sort $(filter-out $(foreach d,$(OTHER_ISA_DIRS),runtime/kernels/$(d)/%) $(RUNTIME_EXCLUDE), \
                         $(shell find runtime -name '*.cc' -not -name '*_test.cc')) \
                       $(wildcard forest_blob/blob_loader.cc forest_blob/crc32.cc))
# Files under platform/openni_driver/ build into an OpenNI2 driver (mk/openni.mk), not the CLI.
TOOLS_SRCS   := $(sort $(shell find tools platform forest_blob -name '*.cc' \
                   -not -path 'platform/openni_driver/*' -not -path 'tools/cli/main.cc') )
TOOLS_SRCS   := $(filter-out $(RUNTIME_SRCS),$(TOOLS_SRCS))
TEST_SRCS    := $(sort $(shell find tests -name '*.cc' -not -path 'tests/bench/*' -not -path 'tests/fuzz/*' \
                   -not -path 'tests/probes/*'))
BENCH_SRCS   := $(sort $(wildcard tests/bench/*_bench.cc))

RUNTIME_OBJS := $(RUNTIME_SRCS:%.cc=$(BUILD)/obj/%.o)
TOOLS_OBJS   := $(TOOLS_SRCS:%.cc=$(BUILD)/obj/%.o)
# Every test driver has its own object rule (the runtime_tests binaries link two of them); the test
# binary links the objects of TEST_OBJS, built as TEST_UNITY says (below).
TEST_FILE_OBJS := $(TEST_SRCS:%.cc=$(BUILD)/obj/%.o)
TEST_OBJS    := $(TEST_FILE_OBJS)

# UNITY=1 (the ASan+UBSan build of `make test`): the tools compile as one translation unit per
# folder ($(BUILD)/unity/<folder>.cc includes the folder's sources), so the headers and the templates
# most of them instantiate (nlohmann::json's parser and serializer, above all) are compiled and
# instrumented once per folder instead of once per file (ASan+UBSan, CPU seconds: tools/app 77.1 as
# 10 files, 35.8 as one unit; tools/common 51.4 → 33.6; tools/eval with its side-check and tune
# commands 56.7 as three units, 36.4 as one, side by side). The code and flags are those of the
# per-file build. Files listed in UNITY_SOLO compile on their own: they define a file-local name
# that another file of their folder defines too (kUsage of the *_command.cc files, lower, put) or
# take their own flags (mpi_communicator.cc). A new file whose local name clashes in its folder's
# unit fails that build with a redefinition or ambiguity error: give the name a file-specific
# spelling (kSideCheckUsage) or add the file here.
UNITY ?=
UNITY_SOLO := tools/app/skeleton_eval_command.cc tools/synth/skeleton_naming.cc tools/train/distributed_leaves.cc \
              tools/train/mpi_communicator.cc
ifeq ($(UNITY),1)
  UNITY_SRCS := $(filter-out $(UNITY_SOLO),$(TOOLS_SRCS))
  UNITY_DIRS := $(sort $(patsubst %/,%,$(dir $(UNITY_SRCS))))
  unity_name  = $(subst /,_,$(1))
  TOOLS_OBJS := $(filter-out $(UNITY_SRCS:%.cc=$(BUILD)/obj/%.o),$(TOOLS_OBJS)) \
                $(foreach d,$(UNITY_DIRS),$(BUILD)/obj/unity/$(call unity_name,$(d)).o)
endif
# TEST_UNITY=1 (the default, in every build folder): the test drivers compile as one translation unit
# per name prefix (the word before the first '_': tests/train_*.cc → $(BUILD)/unity/tests_train.cc),
# and the drivers alone in their prefix as one more unit (tests_misc), so the project headers and the
# templates the drivers share (GoogleTest's assertion helpers, the standard containers,
# nlohmann::json) are compiled once per unit. CPU seconds at -O1 -g1 with the precompiled header:
# the 8 train_* drivers 29.5 as 8 files, 13.6 as one unit. The drivers of TEST_UNITY_SOLO compile
# alone: they define a file-local name another driver of their prefix defines too (kAssets, room(),
# ...), or the runtime_tests binaries link them on their own (mk/runtime_tests.mk). A new driver
# whose local name clashes in its unit fails the build with a redefinition or ambiguity error: add
# it here. TEST_UNITY=0 compiles every driver alone (quicker to rebuild after editing one driver).
TEST_UNITY ?= 1
TEST_UNITY_SOLO := tests/reliability_outputs_test.cc tests/segmentation_users_test.cc tests/synth_pool_test.cc \
                   tests/synth_render_test.cc tests/runtime_kernel_test.cc tests/runtime_pipeline_test.cc
ifeq ($(TEST_UNITY),1)
  test_prefix      = $(firstword $(subst _, ,$(notdir $(1))))
  TEST_UNITY_CANDS := $(filter-out $(TEST_UNITY_SOLO),$(TEST_SRCS))
  test_prefix_srcs = $(strip $(foreach s,$(TEST_UNITY_CANDS),$(if $(filter $(1),$(call test_prefix,$(s))),$(s))))
  TEST_PREFIXES    := $(sort $(foreach s,$(TEST_UNITY_CANDS),$(call test_prefix,$(s))))
  TEST_UNITS       := $(strip $(foreach p,$(TEST_PREFIXES),$(if $(word 2,$(call test_prefix_srcs,$(p))),$(p))))
  $(foreach p,$(TEST_UNITS),$(eval TEST_UNIT_SRCS_$(p) := $(call test_prefix_srcs,$(p))))
  TEST_UNIT_SRCS_misc := $(foreach p,$(filter-out $(TEST_UNITS),$(TEST_PREFIXES)),$(call test_prefix_srcs,$(p)))
  TEST_UNITS       += $(if $(word 2,$(TEST_UNIT_SRCS_misc)),misc)
  TEST_UNITY_SRCS  := $(foreach u,$(TEST_UNITS),$(TEST_UNIT_SRCS_$(u)))
  TEST_OBJS        := $(filter-out $(TEST_UNITY_SRCS:%.cc=$(BUILD)/obj/%.o),$(TEST_FILE_OBJS)) \
                      $(TEST_UNITS:%=$(BUILD)/obj/unity/tests_%.o)
endif
BENCH_BINS   := $(patsubst tests/bench/%_bench.cc,$(BUILD)/bin/bench_%,$(BENCH_SRCS))

RUNTIME_LIB  := $(BUILD)/libdepthpose_runtime.a
TOOLS_LIB    := $(BUILD)/libdepthpose_tools.a
CLI          := $(BUILD)/bin/depthpose
TEST_BIN     := $(BUILD)/bin/depthpose_tests
# Tools register subcommands through static objects: link the whole archive.
LINK_TOOLS   := -Wl,--whole-archive $(TOOLS_LIB) -Wl,--no-whole-archive $(RUNTIME_LIB)
EXTRA_LINK_DEPS :=

.PHONY: all run test test-unit test-debug test-asan chain-smoke bench fuzz-smoke fuzz check-runtime deps clean model
.DEFAULT_GOAL := all
all: $(CLI) $(RUNTIME_LIB) $(EXTRA_LINK_DEPS)

define ISA_RULE
$$(BUILD)/obj/runtime/kernels/$(1)/%.o: runtime/kernels/$(1)/%.cc
	@mkdir -p $$(@D)
	$$(CXX) $$(RUNTIME_CXXFLAGS) $$(ISA_FLAGS_$(1)) $$(DEPFLAGS) -c $$< -o $$@
endef
$(foreach d,$(ISA_DIRS),$(eval $(call ISA_RULE,$(d))))
$(BUILD)/obj/runtime/%.o: runtime/%.cc
	@mkdir -p $(@D)
	$(CXX) $(RUNTIME_CXXFLAGS) $(DEPFLAGS) -c $< -o $@
$(BUILD)/obj/forest_blob/blob_loader.o $(BUILD)/obj/forest_blob/crc32.o: $(BUILD)/obj/forest_blob/%.o: forest_blob/%.cc
	@mkdir -p $(@D)
	$(CXX) $(RUNTIME_CXXFLAGS) $(DEPFLAGS) -c $< -o $@
$(BUILD)/obj/%.o: %.cc
	@mkdir -p $(@D)
	$(CXX) $(TOOLS_CXXFLAGS) $(DEPFLAGS) -c $< -o $@
# Each unit (UNITY, TEST_UNITY) is rewritten only when its list of files changes (a new or removed
# file), so make rebuilds it then or when one of the files it includes changes (its .d file).
.PHONY: unity-check
ifeq ($(UNITY),1)
define UNITY_RULE
$$(BUILD)/unity/$(call unity_name,$(1)).cc: unity-check
	@mkdir -p $$(@D)
	@printf '#include "%s"\n' $(strip $(foreach s,$(UNITY_SRCS),$(if $(filter $(1)/,$(dir $(s))),$(s)))) > $$@.tmp; cmp -s $$@.tmp $$@ && rm $$@.tmp || mv $$@.tmp $$@
$$(BUILD)/obj/unity/$(call unity_name,$(1)).o: $$(BUILD)/unity/$(call unity_name,$(1)).cc
	@mkdir -p $$(@D)
	$$(CXX) $$(TOOLS_CXXFLAGS) $$(DEPFLAGS) -c $$< -o $$@
endef
$(foreach d,$(UNITY_DIRS),$(eval $(call UNITY_RULE,$(d))))
endif
# Test drivers (tests/*.cc, not the benches) compile at TEST_OPT with line tables only; the code they
# test keeps its own flags. Measured on three heavy test files (CPU seconds, -O2 -g → -O1 -g1):
# runtime_kernel_test 19.2 → 8.8, segmentation_cut_test 18.2 → 9.5, train_dataset_test 8.8 → 4.1.
# They share a precompiled header (tests/test_pch.h, built per build folder with their flags):
# -1.0 to -3.2 s CPU per driver (train_dataset_test 5.4 → 3.9, segmentation_cut_test 9.0 → 5.8).
# Under the sanitizers (SAN=1) the drivers compile at -O0: at -O1 GCC optimizes the sanitizer checks
# of every inlined GoogleTest and container template, which more than doubles a unit's compile time
# (ASan+UBSan, CPU seconds: the tests_segmentation unit 46.0 at -O1, 19.9 at -O0; every driver of
# the ASan+UBSan build: README.md "What `make test` costs"). -O0 drops no check (every access stays
# instrumented); the code under test keeps its -O1, also where a driver compiles the same inline
# function or template (TEST_BIN's link order, below). The normal build compiles the same drivers
# at -O1, so the warnings that need the optimizer (-Wmaybe-uninitialized, ...) still show there.
TEST_OPT ?= $(if $(filter -O0,$(OPT))$(filter 1,$(SAN)),-O0,-O1)
TEST_CXXFLAGS := $(filter-out $(OPT) $(DEBUGINFO),$(TOOLS_CXXFLAGS)) $(TEST_OPT) -g1
TEST_PCH := $(BUILD)/pch/test_pch.h
$(TEST_PCH): tests/test_pch.h
	@mkdir -p $(@D)
	cp $< $@
$(TEST_PCH).gch: $(TEST_PCH)
	$(CXX) $(TEST_CXXFLAGS) -x c++-header $< -o $@
$(TEST_FILE_OBJS): $(BUILD)/obj/tests/%.o: tests/%.cc $(TEST_PCH).gch
	@mkdir -p $(@D)
	$(CXX) $(TEST_CXXFLAGS) -Winvalid-pch -include $(TEST_PCH) $(DEPFLAGS) -c $< -o $@
ifeq ($(TEST_UNITY),1)
define TEST_UNITY_RULE
$$(BUILD)/unity/tests_$(1).cc: unity-check
	@mkdir -p $$(@D)
	@printf '#include "%s"\n' $(TEST_UNIT_SRCS_$(1)) > $$@.tmp; cmp -s $$@.tmp $$@ && rm $$@.tmp || mv $$@.tmp $$@
$$(BUILD)/obj/unity/tests_$(1).o: $$(BUILD)/unity/tests_$(1).cc $$(TEST_PCH).gch
	@mkdir -p $$(@D)
	$$(CXX) $$(TEST_CXXFLAGS) -Winvalid-pch -include $$(TEST_PCH) $$(DEPFLAGS) -c $$< -o $$@
endef
$(foreach p,$(TEST_UNITS),$(eval $(call TEST_UNITY_RULE,$(p))))
endif

$(RUNTIME_LIB): $(RUNTIME_OBJS)
	@mkdir -p $(@D)
	rm -f $@ && ar rcs $@ $^
$(TOOLS_LIB): $(TOOLS_OBJS)
	@mkdir -p $(@D)
	rm -f $@ && ar rcs $@ $^

$(CLI): $(BUILD)/obj/tools/cli/main.o $(TOOLS_LIB) $(RUNTIME_LIB)
	@mkdir -p $(@D)
	$(CXX) $(TOOLS_CXXFLAGS) -o $@ $< $(LINK_TOOLS) $(LDLIBS_TOOLS) -Wl,-rpath,'$$ORIGIN/../openni'

# The libraries come before the drivers on the link line, both whole: for an inline function or
# template that a library and a driver both compile (a header's helpers, std::vector<float>, ...)
# the linker keeps the first copy, so the tests run the libraries' copy, built with their flags,
# not the driver's (-O0 in the sanitizer build: with the drivers first, the ASan+UBSan run took
# a third more CPU time).
$(TEST_BIN): $(TEST_OBJS) $(TOOLS_LIB) $(RUNTIME_LIB)
	@mkdir -p $(@D)
	$(CXX) $(TOOLS_CXXFLAGS) -o $@ -Wl,--whole-archive $(TOOLS_LIB) $(RUNTIME_LIB) -Wl,--no-whole-archive $(TEST_OBJS) \
	  $(LDLIBS_TOOLS) -lgtest -lgtest_main -Wl,-rpath,'$$ORIGIN/../openni'

$(BUILD)/bin/bench_%: $(BUILD)/obj/tests/bench/%_bench.o $(TOOLS_LIB) $(RUNTIME_LIB)
	@mkdir -p $(@D)
	$(CXX) $(TOOLS_CXXFLAGS) -o $@ $< $(LINK_TOOLS) $(LDLIBS_TOOLS) -lbenchmark -Wl,-rpath,'$$ORIGIN/../openni'

# ---- checks -------------------------------------------------------------------------------
FORBIDDEN_RUNTIME_SYMS := malloc calloc realloc free aligned_alloc posix_memalign _Znwm _Znam _ZdlPv _ZdaPv \
  _ZdlPvm _ZdaPvm _ZnwmSt11align_val_t _ZnamSt11align_val_t _ZdlPvSt11align_val_t __cxa_throw \
  __cxa_allocate_exception __cxa_begin_catch __gxx_personality_v0
NM ?= nm
check-runtime: $(RUNTIME_LIB)
	@NM=$(NM) mk/check_isa_linkage.sh $(BUILD)/obj/runtime/kernels
	@bad=$$($(NM) -u $(RUNTIME_LIB) | awk '{print $$2}' | sort -u | grep -x -F $(addprefix -e ,$(FORBIDDEN_RUNTIME_SYMS)) || true); \
	if [ -n "$$bad" ]; then echo "check-runtime: FAILED: runtime references: $$bad"; exit 1; fi; \
	echo "check-runtime: OK ($(RUNTIME_LIB) references no heap or exception symbols)"

# Where the tests find the shared data (../shared: assets, PCL trees, Skeltrack frames). Tests that
# need it carry "SharedData" in their suite name: GTEST_ARGS=--gtest_filter=-*SharedData* runs the rest.
SHARED ?= ../shared
export DEPTHPOSE_SHARED := $(abspath $(SHARED))
# PCL's three depth-20 trees as a blob, converted once by the CLI (~14 s CPU; rule in
# mk/runtime_tests.mk) for the runs that need not convert them again: the debug run, the x86-64
# digests and the aarch64 run (which has no libbz2). The normal and ASan+UBSan runs of
# depthpose_tests still convert the trees in-process (PclRealFramesSharedData).
PCL_TREES := $(foreach i,1 2 3,$(DEPTHPOSE_SHARED)/data/pcl-people-trees/forest$(i)_tree_20.txt.bz2)
PCL_BLOB  := $(BUILD)/data/pcl.blob

# One GoogleTest run: its log and exit status land in $(BUILD)/test-logs/unit.log(.rc) for
# mk/test_summary.sh, which also counts suite set-up failures, skips and crashes.
test-unit: $(TEST_BIN) $(EXTRA_LINK_DEPS)
	@cd $(CURDIR) && mk/run_gtest.sh $(BUILD)/test-logs/unit.log $(BUILD) $(TEST_BIN) $(GTEST_ARGS)
.PHONY: test-bin
test-bin: $(TEST_BIN) $(EXTRA_LINK_DEPS)

SHELL := /bin/bash
# The runs of `make test`, as independent targets so that they build and run side by side.
# The ASan+UBSan build lives in its own folder; each run writes a log that the summary reads.
# test-debug: the runtime's tests against the runtime built with its debug checks (DEBUG=1);
# test-aarch64: the runtime's tests cross-built for ARM64 and run under qemu-aarch64 (mk/*.mk);
# test-run-mpi: distributed training and rendering under mpirun (mk/mpi.mk).
# The ASan+UBSan binary is the longest run: it runs as ASAN_SHARDS GoogleTest shards side by side
# (GTEST_TOTAL_SHARDS/GTEST_SHARD_INDEX: each test runs in exactly one shard), each with its own log.
ASAN_BUILD  := $(BUILD)/asan
ASAN_SHARDS := 2
ASAN_RUNS   := $(foreach i,$(shell seq 0 $$(($(ASAN_SHARDS) - 1))),test-run-asan-$(i))
TEST_LOGS := $(BUILD)/test-logs/unit.log $(ASAN_RUNS:test-run-asan-%=$(ASAN_BUILD)/test-logs/unit-%.log) \
             $(BUILD)/debug/test-logs/unit.log \
             $(BUILD)/aarch64/test-logs/unit.log $(BUILD)/chain/chain.log \
             $(BUILD)/test-logs/check-runtime.log $(BUILD)/test-logs/summary-selftest.log \
             $(BUILD)/test-logs/mpi.log
# Each step of `make test` appends its wall and CPU seconds here (mk/step_time.sh); `make test`
# prints them before its closing line. Exported, so the sub-makes of other build folders add theirs.
export STEP_TIMES ?= $(abspath $(BUILD))/test-logs/step-times.txt
.PHONY: ensure-deps test-runs test-run-unit test-run-asan test-build-asan $(ASAN_RUNS) test-run-check-runtime test-summary-selftest
ensure-deps:
	@mk/ensure_deps.sh
test: ensure-deps
	@rm -f $(STEP_TIMES); rc=0; mk/step_time.sh total $(MAKE) --no-print-directory -k test-runs || rc=1; \
	mk/step_time.sh --report $(STEP_TIMES); \
	mk/test_summary.sh $(TEST_LOGS); s=$$?; \
	[ $$rc -eq 0 ] && [ $$s -eq 0 ]
test-runs: test-run-asan test-run-unit test-debug test-aarch64 chain-smoke test-run-check-runtime test-summary-selftest \
           test-run-mpi
test-run-unit: test-unit
test-build-asan:
	@mk/step_time.sh "build $(ASAN_BUILD)" $(MAKE) --no-print-directory test-bin BUILD=$(ASAN_BUILD) SAN=1 OPT=-O1 DEBUGINFO=-g1 UNITY=1
test-run-asan: $(ASAN_RUNS)
$(ASAN_RUNS): test-run-asan-%: test-build-asan
	@cd $(CURDIR) && GTEST_TOTAL_SHARDS=$(ASAN_SHARDS) GTEST_SHARD_INDEX=$* \
	  mk/run_gtest.sh $(ASAN_BUILD)/test-logs/unit-$*.log "$(ASAN_BUILD) shard $*/$(ASAN_SHARDS)" $(ASAN_BUILD)/bin/depthpose_tests $(GTEST_ARGS)
# After the libraries are built (by this make and by test-aarch64), so no second make builds them at once.
test-run-check-runtime: $(RUNTIME_LIB) test-aarch64
	@mkdir -p $(BUILD)/test-logs
	@log=$(BUILD)/test-logs/check-runtime; rc=0; : > $$log.out; : > $$log.log; \
	for arch in x86_64 aarch64; do \
	  target=check-runtime; [ $$arch = aarch64 ] && target=check-runtime-aarch64; \
	  $(MAKE) --no-print-directory $$target >> $$log.out 2>&1; r=$$?; \
	  if [ $$r -eq 0 ]; then echo "[       OK ] CheckRuntime.NoHeapOrExceptionSymbols_$$arch"; \
	  else echo "[  FAILED  ] CheckRuntime.NoHeapOrExceptionSymbols_$$arch"; rc=1; fi >> $$log.log; \
	done; \
	cat $$log.out; echo "[==========] 2 tests ran." >> $$log.log; exit $$rc
$(BUILD)/bin/summary_probe: tests/probes/summary_probe.cc
	@mkdir -p $(@D)
	$(CXX) $(TOOLS_CXXFLAGS) -o $@ $< -lgtest -lgtest_main
test-summary-selftest: $(BUILD)/bin/summary_probe
	@mkdir -p $(BUILD)/test-logs
	@mk/test_summary_selftest.sh $(BUILD)/bin/summary_probe $(BUILD)/summary-selftest | tee $(BUILD)/test-logs/summary-selftest.log | grep -v '^\[       OK'; true

# The whole chain (synth → train → convert → tune → eval → record → run) on a tiny corpus.
chain-smoke: $(CLI) $(EXTRA_LINK_DEPS)
	@CLI=$(CLI) CHAIN_DIR=$(BUILD)/chain ASSETS=$(DEPTHPOSE_SHARED)/assets mk/step_time.sh "chain smoke" mk/chain_smoke.sh

bench: $(BENCH_BINS) $(CLI) $(EXTRA_LINK_DEPS)
	@mkdir -p $(BUILD)/bench
	@for b in $(BENCH_BINS); do echo "== $$b"; $$b || exit 1; done

# ---- fuzz (clang + libFuzzer) --------------------------------------------------------------
# One target per parser (tests/fuzz/*_fuzz.cc), each built with its own sources under ASan+UBSan
# and started from the seeds in tests/fuzz/seeds/<target> (the blob target from the demo blobs).
# Any crash, leak, sanitizer report or timeout fails the target; crash inputs land in
# $(BUILD)/fuzz/artifacts (add them to tests/fuzz/seeds/<target> once fixed).
#   make fuzz-smoke  deterministic: FUZZ_RUNS inputs per target from seed FUZZ_SEED, so every CI
#                    run explores exactly what the last one did (~1-2 min after the build);
#                    FUZZ_SECONDS per target (default 60) is only a ceiling for a slow machine.
#   make fuzz        exploration: a fresh random seed, FUZZ_SECONDS per target (default 300);
#                    run it before a parser change lands, and keep what it finds as seeds.
FUZZ_CXX := clang++-14
FUZZ_SEED ?= 1
FUZZ_RUNS ?= 20000
FUZZ_DIR := $(BUILD)/fuzz
FUZZ_FLAGS := $(CXXSTD) -O1 -g -I. -I/usr/include/openni2 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined
FUZZ_RUN_FLAGS := -max_len=65536 -timeout=10 -rss_limit_mb=2048 -print_final_stats=0
# target: sources and libraries besides tests/fuzz/<target>_fuzz.cc
FUZZ_SRCS_blob_loader   := forest_blob/blob_loader.cc forest_blob/crc32.cc
FUZZ_SRCS_forest_file   := tools/train/forest_file.cc tools/common/file_io.cc
FUZZ_LIBS_forest_file   := -lz
FUZZ_SRCS_oni_container := platform/oni_container.cc platform/oni_codec.cc forest_blob/crc32.cc
FUZZ_SRCS_png_dataset   := tools/common/png_io.cc tools/common/dataset.cc tools/common/file_io.cc
FUZZ_LIBS_png_dataset   := -lpng -lz
FUZZ_SRCS_bvh           := tools/synth/motion.cc tools/synth/skeleton_naming.cc
FUZZ_LIBS_bvh           := -lz
FUZZ_SRCS_asf_amc       := tools/synth/motion.cc tools/synth/skeleton_naming.cc
FUZZ_LIBS_asf_amc       := -lz
FUZZ_SRCS_pcl_tree      := tools/convert/pcl_tree_reader.cc
FUZZ_LIBS_pcl_tree      := -lbz2
FUZZ_SRCS_mhclo         := tools/synth/garment.cc
FUZZ_TARGETS := blob_loader forest_file oni_container png_dataset bvh asf_amc pcl_tree mhclo

$(FUZZ_DIR)/blob_loader_fuzz: tests/fuzz/blob_loader_fuzz.cc $(FUZZ_SRCS_blob_loader)
	@mkdir -p $(@D)
	$(FUZZ_CXX) $(FUZZ_FLAGS) -DDP_BLOB_FUZZING -fno-exceptions -fno-rtti $^ -o $@
define FUZZ_RULE
$(FUZZ_DIR)/$(1)_fuzz: tests/fuzz/$(1)_fuzz.cc $(FUZZ_SRCS_$(1)) $(wildcard tests/fuzz/*.h)
	@mkdir -p $$(@D)
	$(FUZZ_CXX) $(FUZZ_FLAGS) $$(filter %.cc,$$^) $(FUZZ_LIBS_$(1)) -o $$@
endef
$(foreach t,$(filter-out blob_loader,$(FUZZ_TARGETS)),$(eval $(call FUZZ_RULE,$(t))))

# $(1) = make target, $(2) = libFuzzer's bounds for each parser. Each parser is a target of its own
# ($(1)-<parser>), so the parsers are fuzzed side by side on every core (-j1: one at a time).
define FUZZ_CAMPAIGN
.PHONY: $(1) $(1)-corpus $(FUZZ_TARGETS:%=$(1)-%)
$(1)-corpus: $(CLI)
	@mkdir -p $(FUZZ_DIR)/artifacts
	@rm -rf $(FUZZ_DIR)/corpus && mkdir -p $(FUZZ_DIR)/corpus/blob_loader
	@$(CLI) demo --write-blobs $(FUZZ_DIR)/corpus/blob_loader > /dev/null
$(FUZZ_TARGETS:%=$(1)-%): $(1)-%: $(FUZZ_DIR)/%_fuzz $(1)-corpus
	@t=$$*; mkdir -p $(FUZZ_DIR)/corpus/$$$$t; \
	if [ -d tests/fuzz/seeds/$$$$t ]; then cp tests/fuzz/seeds/$$$$t/* $(FUZZ_DIR)/corpus/$$$$t/; fi; \
	$(FUZZ_DIR)/$$$${t}_fuzz $(FUZZ_RUN_FLAGS) $(2) \
	  -artifact_prefix=$(FUZZ_DIR)/artifacts/$$$$t- $(FUZZ_DIR)/corpus/$$$$t > $(FUZZ_DIR)/$$$$t.log 2>&1 \
	  || { tail -40 $(FUZZ_DIR)/$$$$t.log; echo "$(1): $$$$t FAILED (log $(FUZZ_DIR)/$$$$t.log)"; exit 1; }; \
	echo "== fuzz $$$$t ($(2)): $$$$(grep -E "^#[0-9]+.*DONE" $(FUZZ_DIR)/$$$$t.log | tail -1)"
$(1): $(FUZZ_TARGETS:%=$(1)-%)
	@echo "$(1): OK ($(words $(FUZZ_TARGETS)) targets, nothing found)"
endef
$(eval $(call FUZZ_CAMPAIGN,fuzz-smoke,-seed=$(FUZZ_SEED) -runs=$(FUZZ_RUNS) -max_total_time=$(or $(FUZZ_SECONDS),60)))
$(eval $(call FUZZ_CAMPAIGN,fuzz,-seed=0 -max_total_time=$(or $(FUZZ_SECONDS),300)))

deps:
	@mk/ensure_deps.sh

clean:
	rm -rf build

-include $(sort $(wildcard mk/*.mk))
-include $(RUNTIME_OBJS:.o=.d) $(TOOLS_OBJS:.o=.d) $(TEST_OBJS:.o=.d) $(BUILD)/obj/tools/cli/main.d

# ---- the main job ----------------------------------------------------------------------------
# Installs what is missing, builds, then replays the shipped recording with the shipped OJR blob
# (MODEL=bpc for BPC), writing the overlays under $(RUN_OUT). A missing model, recording or
# subcommand is an error that names it.
MODEL   ?= ojr
RUN_OUT ?= $(BUILD)/run
run: ensure-deps
	@$(MAKE) --no-print-directory all
	@for f in models/$(MODEL).blob models/demo.oni; do \
	  [ -f $$f ] || { echo "make run: $$f is missing (make model regenerates the shipped models)"; exit 1; }; done
	@$(CLI) --help | grep -q '^  run ' || { echo "make run: $(CLI) has no 'run' subcommand (its registration is broken)"; exit 1; }
	@mkdir -p $(RUN_OUT)
	$(CLI) run --blob models/$(MODEL).blob --source oni:models/demo.oni --overlay $(RUN_OUT)
	@echo "make run: overlays written to $(RUN_OUT)/"
