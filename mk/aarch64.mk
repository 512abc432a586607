# ARM64 (aarch64) cross-build of the runtime library and the runtime's tests, run under emulation.
#   make aarch64                builds $(A64)/libdepthpose_runtime.a and $(A64)/bin/runtime_tests
#   make test-aarch64           runs those tests under qemu-aarch64; gtest output in $(A64)/test-logs/unit.log
#   make check-runtime-aarch64  check-runtime (no heap, no exceptions, ISA linkage) on the arm64 library
# Needs Debian's g++-aarch64-linux-gnu, qemu-user (qemu-aarch64; no root or binfmt: the loader and
# libraries come from /usr/aarch64-linux-gnu by -L) and libgtest-dev, whose sources
# (/usr/src/googletest) are built here with the cross compiler — no arm64 multiarch packages.
# Built for arm64: the runtime and what its tests link (forest_blob's writer, the demo fixtures).
# Not built: the CLI and the other tools (they link x86 host libraries: libpng, libbz2, OpenNI2,
# libusb). The PCL-forest tests read the trees as the blob the x86 CLI converts (PCL_BLOB,
# mk/runtime_tests.mk), as the arm64 build has no libbz2.
A64          := $(BUILD)/aarch64
A64_CXX      ?= aarch64-linux-gnu-g++
A64_NM       ?= aarch64-linux-gnu-nm
A64_CCACHE   := $(if $(filter ccache%,$(CXX)),ccache ,)
QEMU_A64     ?= qemu-aarch64 -L /usr/aarch64-linux-gnu
GTEST_SRC    ?= /usr/src/googletest/googletest
A64_LIB      := $(A64)/libdepthpose_runtime.a
A64_TEST_BIN := $(A64)/bin/runtime_tests
A64_TEST_SRCS := tests/runtime_kernel_test.cc tests/runtime_pipeline_test.cc forest_blob/blob_writer.cc \
                 platform/arena_memory.cc tools/common/file_io.cc \
                 tools/demo/fixtures.cc
A64_TEST_OBJS := $(A64_TEST_SRCS:%.cc=$(A64)/testobj/%.o)
A64_GTEST_OBJS := $(A64)/gtest/gtest-all.o $(A64)/gtest/gtest_main.o
A64_CXXFLAGS := $(CXXSTD) $(OPT) $(DEBUGINFO) $(WARN) -I. $(DEBUGFLAGS) -ffp-contract=off -pthread -DDP_NO_BZIP2=1 $(EXTRA_CXXFLAGS)

.PHONY: aarch64 test-aarch64 check-runtime-aarch64 FORCE_A64
aarch64: $(A64_LIB) $(A64_TEST_BIN)

# The library through this Makefile's own rules, for the cross compiler (TARGET_ARCH aarch64: kernels/ref
# and kernels/neon, no x86 folder). Make decides in the sub-make whether anything is out of date.
$(A64_LIB): FORCE_A64
	@$(MAKE) --no-print-directory BUILD=$(A64) CXX="$(A64_CCACHE)$(A64_CXX)" NM=$(A64_NM) $(A64_LIB)
FORCE_A64:

$(A64)/testobj/%.o: %.cc
	@mkdir -p $(@D)
	$(A64_CCACHE)$(A64_CXX) $(A64_CXXFLAGS) -MMD -MP -c $< -o $@
# GoogleTest itself at -O1: 15.6 CPU-s for gtest-all.cc instead of 22.0 at -O2 (the time under qemu
# goes to the runtime's code, not to the framework's).
$(A64)/gtest/%.o: $(GTEST_SRC)/src/%.cc
	@mkdir -p $(@D)
	$(A64_CCACHE)$(A64_CXX) $(CXXSTD) -O1 -pthread -I$(GTEST_SRC) -I$(GTEST_SRC)/include -c $< -o $@

$(A64_TEST_BIN): $(A64_TEST_OBJS) $(A64_GTEST_OBJS) $(A64_LIB)
	@mkdir -p $(@D)
	$(A64_CXX) -pthread -o $@ $(A64_TEST_OBJS) $(A64_GTEST_OBJS) $(A64_LIB)

# The x86-64 reference's digests of the real frames, which the aarch64 run must reproduce bit for
# bit, from the same PCL blob the aarch64 run reads (PCL_BLOB, mk/runtime_tests.mk: converted once).
$(A64)/data/x86_digests.txt: $(BUILD)/bin/runtime_tests $(PCL_BLOB)
	@mkdir -p $(@D)
	@DP_PCL_BLOB=$(PCL_BLOB) DP_DIGESTS_OUT=$@ mk/step_time.sh "x86-64 digests for $(A64)" $(BUILD)/bin/runtime_tests \
	  --gtest_filter=PclRealFramesSharedData.ReferenceDigestsAgreeAcrossArchitectures \
	  > $(A64)/data/x86_digests.log 2>&1 || { cat $(A64)/data/x86_digests.log; rm -f $@; exit 1; }

# Built by a make of its own, so `make test` can time the cross build.
.PHONY: test-aarch64-build
test-aarch64-build:
	@mk/step_time.sh "build $(A64)" $(MAKE) --no-print-directory $(A64_TEST_BIN)
test-aarch64: test-aarch64-build $(PCL_BLOB) $(A64)/data/x86_digests.txt
	@cd $(CURDIR) && DP_PCL_BLOB=$(PCL_BLOB) DP_DIGESTS_EXPECTED=$(A64)/data/x86_digests.txt \
	  mk/run_gtest.sh $(A64)/test-logs/unit.log "$(A64) (qemu)" $(QEMU_A64) $(A64_TEST_BIN) $(GTEST_ARGS)

check-runtime-aarch64: $(A64_LIB)
	@$(MAKE) --no-print-directory BUILD=$(A64) CXX="$(A64_CCACHE)$(A64_CXX)" NM=$(A64_NM) check-runtime

-include $(A64_TEST_OBJS:.o=.d)
