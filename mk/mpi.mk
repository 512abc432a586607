# Open MPI for distributed training and rendering (docs/training.md "Distributed training").
# Only tools/train/mpi_communicator.cc includes mpi.h (C API only: OMPI_SKIP_MPICXX): it is compiled
# with `mpicxx --showme:compile`
# flags and the tools link `mpicxx --showme:link` when mpicxx is found (Debian: openmpi-bin
# libopenmpi-dev), and without MPI otherwise (then `depthpose train` launched by mpirun says how
# to get it). MPI=0 forces the build without MPI, MPI=1 insists on it. The runtime never links it.
MPI ?= $(if $(shell command -v mpicxx 2>/dev/null),1,0)
MPI_OBJ := $(BUILD)/obj/tools/train/mpi_communicator.o
ifeq ($(MPI),1)
  MPI_COMPILE_FLAGS := $(shell mpicxx --showme:compile)
  MPI_LINK_FLAGS    := $(filter-out -lmpi_cxx,$(shell mpicxx --showme:link))
  $(MPI_OBJ): TOOLS_CXXFLAGS += $(MPI_COMPILE_FLAGS) -DDP_HAVE_MPI=1 -DOMPI_SKIP_MPICXX=1
  LDLIBS_TOOLS += $(MPI_LINK_FLAGS)
endif
# The object is rebuilt when the MPI choice or flags change: the stamp is rewritten (and so made
# newer) only when its text changes; make looks at its time again after the recipe.
MPI_STAMP := $(BUILD)/mpi-flags.txt
MPI_STAMP_TEXT := MPI=$(MPI) $(MPI_COMPILE_FLAGS) | $(MPI_LINK_FLAGS)
.PHONY: mpi-stamp-check
$(MPI_STAMP): mpi-stamp-check
	@mkdir -p $(@D); [ "$$(cat $@ 2>/dev/null)" = "$(MPI_STAMP_TEXT)" ] || echo "$(MPI_STAMP_TEXT)" > $@
$(MPI_OBJ): $(MPI_STAMP)

# `make test` runs mk/mpi_tests.sh: forests from 1, 2 and 3 ranks byte-identical (BPC, OJR with
# both objectives), distributed synth equal to one process, and errors that name the rank. Without
# MPI it fails (CI installs Open MPI; a skipped distributed test would hide a broken trainer).
# mpirun refuses root unless told; CI and this machine run as root.
.PHONY: test-run-mpi
test-run-mpi: $(CLI) $(EXTRA_LINK_DEPS)
	@mkdir -p $(BUILD)/test-logs
	@MPI_BUILD=$(MPI) CLI=$(CLI) MPI_TEST_DIR=$(BUILD)/mpi-test ASSETS=$(DEPTHPOSE_SHARED)/assets \
	  OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
	  mk/mpi_tests.sh > $(BUILD)/test-logs/mpi.log 2>&1; rc=$$?; \
	  grep -E '^\[  FAILED  \]|^\[==========\]' $(BUILD)/test-logs/mpi.log | sed 's|^|mpi: |'; exit $$rc

# Measurements of distributed training on this machine (docs/training.md "Distributed training").
.PHONY: bench-mpi
bench-mpi: $(CLI) $(EXTRA_LINK_DEPS)
	@CLI=$(CLI) MPI_BENCH_DIR=$(BUILD)/mpi-bench ASSETS=$(DEPTHPOSE_SHARED)/assets mk/mpi_bench.sh
