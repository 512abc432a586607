# depthpose — GNU Make build. Everything lands under $(BUILD) (default build/).
#   make            build the CLI (build/bin/depthpose) and the runtime library
#   make run        run the main job (see README)
#   make test       unit tests, normal build and ASan+UBSan build; ends with "N passed, N failed"
#   make bench      benchmarks (tests/bench/*_bench.cc, one binary each)
#   make fuzz-smoke libFuzzer on the blob loader (~60 s)
#   make check-runtime  proves the runtime references no heap / exception symbols
#   make deps       installs the Debian packages the project needs
# Components add rules in mk/*.mk; sources are found by directory, so adding a file needs no edit here.

BUILD    ?= build
SAN      ?=
CXX      ?= g++
OPT      ?= -O2
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

CXXFLAGS_COMMON := $(CXXSTD) $(OPT) -g $(BASE_ISA) $(WARN) $(INCLUDES) $(SANFLAGS) $(DEBUGFLAGS) $(EXTRA_CXXFLAGS)
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
TEST_SRCS    := $(sort $(shell find tests -name '*.cc' -not -path 'tests/bench/*' -not -path 'tests/fuzz/*'))
BENCH_SRCS   := $(sort $(wildcard tests/bench/*_bench.cc))

RUNTIME_OBJS := $(RUNTIME_SRCS:%.cc=$(BUILD)/obj/%.o)
TOOLS_OBJS   := $(TOOLS_SRCS:%.cc=$(BUILD)/obj/%.o)
TEST_OBJS    := $(TEST_SRCS:%.cc=$(BUILD)/obj/%.o)
BENCH_BINS   := $(patsubst tests/bench/%_bench.cc,$(BUILD)/bin/bench_%,$(BENCH_SRCS))

RUNTIME_LIB  := $(BUILD)/libdepthpose_runtime.a
TOOLS_LIB    := $(BUILD)/libdepthpose_tools.a
CLI          := $(BUILD)/bin/depthpose
TEST_BIN     := $(BUILD)/bin/depthpose_tests
# Tools register subcommands through static objects: link the whole archive.
LINK_TOOLS   := -Wl,--whole-archive $(TOOLS_LIB) -Wl,--no-whole-archive $(RUNTIME_LIB)
EXTRA_LINK_DEPS :=

.PHONY: all run test test-unit test-asan chain-smoke bench fuzz-smoke check-runtime deps clean model
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

$(RUNTIME_LIB): $(RUNTIME_OBJS)
	@mkdir -p $(@D)
	rm -f $@ && ar rcs $@ $^
$(TOOLS_LIB): $(TOOLS_OBJS)
	@mkdir -p $(@D)
	rm -f $@ && ar rcs $@ $^

$(CLI): $(BUILD)/obj/tools/cli/main.o $(TOOLS_LIB) $(RUNTIME_LIB)
	@mkdir -p $(@D)
	$(CXX) $(TOOLS_CXXFLAGS) -o $@ $< $(LINK_TOOLS) $(LDLIBS_TOOLS) -Wl,-rpath,'$$ORIGIN/../openni'

$(TEST_BIN): $(TEST_OBJS) $(TOOLS_LIB) $(RUNTIME_LIB)
	@mkdir -p $(@D)
	$(CXX) $(TOOLS_CXXFLAGS) -o $@ $(TEST_OBJS) $(LINK_TOOLS) $(LDLIBS_TOOLS) -lgtest -lgtest_main -Wl,-rpath,'$$ORIGIN/../openni'

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

test-unit: $(TEST_BIN) $(EXTRA_LINK_DEPS)
	@mkdir -p $(BUILD)/test-logs
	@cd $(CURDIR) && $(TEST_BIN) $(GTEST_ARGS) 2>&1 | tee $(BUILD)/test-logs/unit.log; exit $${PIPESTATUS[0]}

SHELL := /bin/bash
test:
	@rc=0; \
	$(MAKE) --no-print-directory test-unit BUILD=build || rc=1; \
	$(MAKE) --no-print-directory test-unit BUILD=build/asan SAN=1 OPT=-O1 || rc=1; \
	$(MAKE) --no-print-directory check-runtime BUILD=build || rc=1; \
	$(MAKE) --no-print-directory chain-smoke BUILD=build || rc=1; \
	mk/test_summary.sh build/test-logs/unit.log build/asan/test-logs/unit.log build/chain/chain.log; s=$$?; \
	[ $$rc -eq 0 ] && [ $$s -eq 0 ]

# The whole chain (synth → train → convert → tune → eval → record → run) on a tiny corpus.
chain-smoke: $(CLI) $(EXTRA_LINK_DEPS)
	@CLI=$(CLI) mk/chain_smoke.sh

bench: $(BENCH_BINS) $(CLI) $(EXTRA_LINK_DEPS)
	@mkdir -p $(BUILD)/bench
	@for b in $(BENCH_BINS); do echo "== $$b"; $$b || exit 1; done

# ---- fuzz (clang + libFuzzer) --------------------------------------------------------------
FUZZ_CXX := clang++-14
fuzz-smoke: $(CLI)
	@mkdir -p $(BUILD)/fuzz/corpus
	$(CLI) demo --write-blobs $(BUILD)/fuzz/corpus
	$(FUZZ_CXX) $(CXXSTD) -O1 -g -I. -DDP_BLOB_FUZZING -fsanitize=fuzzer,address,undefined -fno-exceptions -fno-rtti \
	  tests/fuzz/blob_loader_fuzz.cc $(wildcard forest_blob/blob_loader.cc forest_blob/crc32.cc) -o $(BUILD)/fuzz/blob_loader_fuzz
	$(BUILD)/fuzz/blob_loader_fuzz -max_total_time=$${FUZZ_SECONDS:-60} -max_len=65536 $(BUILD)/fuzz/corpus

deps:
	apt-get update -qq
	DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
	  g++ make clang-14 libclang-rt-14-dev libfuzzer-14-dev libgtest-dev libbenchmark-dev \
	  libpng-dev zlib1g-dev libbz2-dev nlohmann-json3-dev libeigen3-dev \
	  libopenni2-dev libusb-1.0-0-dev assimp-testmodels

clean:
	rm -rf build

-include $(sort $(wildcard mk/*.mk))
-include $(RUNTIME_OBJS:.o=.d) $(TOOLS_OBJS:.o=.d) $(TEST_OBJS:.o=.d) $(BUILD)/obj/tools/cli/main.d

# ---- the main job ----------------------------------------------------------------------------
# Replays the shipped recording with the shipped OJR blob when both exist (MODEL=bpc for BPC);
# until then runs the handcrafted smoke demo.
MODEL ?= ojr
run: all
	@if [ -f models/$(MODEL).blob ] && [ -f models/demo.oni ] && $(CLI) --help | grep -q '^  run '; then \
	  mkdir -p out && $(CLI) run --blob models/$(MODEL).blob --source oni:models/demo.oni --overlay out; \
	else \
	  $(CLI) demo; \
	fi
