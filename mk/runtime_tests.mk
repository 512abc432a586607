# The runtime's own test binary: the kernel and pipeline suites with only what they link (the blob
# writer, the demo fixtures, the PCL importer), so a build variant of the runtime can be tested
# without building every tool in that variant.
#   make test-debug     the runtime with its debug checks (DEBUG=1: -O1 -DDP_DEBUG_CHECKS=1) in
#                       $(BUILD)/debug; gtest output in $(BUILD)/debug/test-logs/unit.log
#   make $(BUILD)/bin/runtime_tests   that binary for the current flags (e.g. OPT=-O0 BUILD=build-o0)
RUNTIME_TEST_SRCS := tests/runtime_kernel_test.cc tests/runtime_pipeline_test.cc forest_blob/blob_writer.cc \
                     tools/demo/fixtures.cc tools/convert/pcl_import.cc tools/convert/pcl_tree_reader.cc \
                     tools/common/file_io.cc platform/arena_memory.cc
RUNTIME_TEST_OBJS := $(RUNTIME_TEST_SRCS:%.cc=$(BUILD)/obj/%.o)
RUNTIME_TEST_BIN  := $(BUILD)/bin/runtime_tests

.PHONY: test-debug test-runtime
$(RUNTIME_TEST_BIN): $(RUNTIME_TEST_OBJS) $(RUNTIME_LIB)
	@mkdir -p $(@D)
	$(CXX) $(TOOLS_CXXFLAGS) -o $@ $(RUNTIME_TEST_OBJS) $(RUNTIME_LIB) -lbz2 -lgtest -lgtest_main -pthread

# Runs the runtime's tests of this build variant; gtest output in $(BUILD)/test-logs/runtime.log.
test-runtime: $(RUNTIME_TEST_BIN)
	@mkdir -p $(BUILD)/test-logs
	@cd $(CURDIR) && $(RUNTIME_TEST_BIN) $(GTEST_ARGS) 2>&1 | tee $(BUILD)/test-logs/runtime.log; exit $${PIPESTATUS[0]}

# PCL_BLOB (Makefile): PCL's trees converted once by the CLI.
$(PCL_BLOB): $(CLI)
	@mkdir -p $(@D)
	mk/step_time.sh "convert the PCL trees" $(CLI) convert --from-pcl $(PCL_TREES) --out $@

# The debug binary builds while the CLI (which converts PCL_BLOB) does; the run waits for both.
.PHONY: test-debug-build
test-debug-build:
	@mk/step_time.sh "build $(BUILD)/debug" $(MAKE) --no-print-directory BUILD=$(BUILD)/debug DEBUG=1 $(BUILD)/debug/bin/runtime_tests
test-debug: test-debug-build $(PCL_BLOB)
	@cd $(CURDIR) && DP_PCL_BLOB=$(PCL_BLOB) mk/run_gtest.sh $(BUILD)/debug/test-logs/unit.log $(BUILD)/debug \
	  $(BUILD)/debug/bin/runtime_tests $(GTEST_ARGS)

-include $(RUNTIME_TEST_OBJS:.o=.d)
