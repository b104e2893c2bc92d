# holosym: two-command quick start on a fresh Debian/Ubuntu machine.
#   make test     install what is missing, build, run the test suite
#   make tables   the paper's Tables 1-3 (convergence orders, minimum Gauss points)
#   make bench    work-precision benchmark (real128 and real64 builds) into build/bench
#   make test-mpi the MPI build (installs OpenMPI) and its tests: ensembles and tables cells
#                 on 1-3 ranks give the serial files byte for byte; kill and resume
#   make scaling  measured throughput of ensembles (threads, ranks) into docs/ensemble.md
# Other targets: make test64, make install-check, make pendulum, make linkage, make examples,
# make mpi, make deps.

FPM ?= fpm
FPM_FLAGS ?= --profile release
SIMULATE_ARGS ?= --M 2 --N 1 --G 3 --h 0.125 --T 10 --every 8
BENCH_DIR ?= build/bench
BENCH_ARGS ?=
# The real64 build of the whole library (see src/core/holosym_kinds.F90).
REAL64_FLAGS ?= --flag "-DHOLOSYM_REAL64"

.PHONY: all deps include-digest test test64 install-check tables bench pendulum linkage \
	examples mpi test-mpi scaling clean

all: test

# Install gfortran, LAPACK/BLAS (apt, when run as root) and fpm (pip) if missing.
deps:
	@./tools/install-deps.sh

# Record the digest of include/*.inc in the sources that include it, so that fpm (which
# tracks only the sources' own text) rebuilds them after an edit of the template.
include-digest:
	@./tools/include_digest.sh

test: deps include-digest
	$(FPM) test

# fpm install gives the library's modules and nothing else.
install-check: deps include-digest
	./tools/check_install.sh

tables: deps include-digest
	$(FPM) run $(FPM_FLAGS) -- tables

# The test suite in the real64 build.
test64: deps include-digest
	$(FPM) test $(REAL64_FLAGS)

# real128 sweep (writes the reference), real64 sweep against it, summary, plot.
bench: deps include-digest
	$(FPM) run $(FPM_FLAGS) -- bench --out $(BENCH_DIR) $(BENCH_ARGS)
	$(FPM) run $(FPM_FLAGS) $(REAL64_FLAGS) -- bench --out $(BENCH_DIR) \
		--reference $(BENCH_DIR)/reference.csv $(BENCH_ARGS)
	$(FPM) run $(FPM_FLAGS) -- bench --summarize $(BENCH_DIR) > /dev/null
	./tools/plot_bench.sh $(BENCH_DIR)
	@cat $(BENCH_DIR)/summary.md

pendulum: deps include-digest
	$(FPM) run $(FPM_FLAGS) -- simulate --system pendulum $(SIMULATE_ARGS)

linkage: deps include-digest
	$(FPM) run $(FPM_FLAGS) -- simulate --system linkage $(SIMULATE_ARGS)

examples: deps include-digest
	$(FPM) run $(FPM_FLAGS) --example spherical_pendulum
	$(FPM) run $(FPM_FLAGS) --example spring_linkage
	$(FPM) run $(FPM_FLAGS) --example planar_pendulum
	$(FPM) run $(FPM_FLAGS) --example pendulum_ensemble

# The MPI build: the holosym-mpi package in mpi/ (OpenMPI's mpifort; the default build
# needs no MPI). MPI_FPM_FLAGS is its profile (the tests compare it with the default build
# of holosym, so both use fpm's default profile).
MPI_FPM_FLAGS ?=
MPI_FPM = cd mpi && FPM_FC=mpifort $(FPM)

mpi: deps include-digest
	./tools/install-mpi.sh
	./tools/mpi_links.sh
	$(MPI_FPM) build $(MPI_FPM_FLAGS)

test-mpi: mpi
	$(FPM) build $(MPI_FPM_FLAGS)
	./tools/test_mpi.sh "$$($(FPM) run $(MPI_FPM_FLAGS) --runner echo 2>/dev/null | tail -1)" \
		"mpi/$$($(MPI_FPM) run $(MPI_FPM_FLAGS) --runner echo 2>/dev/null | tail -1)"

# Trajectories per second against OpenMP threads and MPI ranks (release builds), into the
# scaling section of docs/ensemble.md. Re-run on a quiet machine: the numbers are only as
# good as it is quiet.
SCALING_ARGS ?=
scaling:
	$(MAKE) mpi MPI_FPM_FLAGS="$(FPM_FLAGS)"
	$(FPM) build $(FPM_FLAGS)
	./tools/ensemble_scaling.sh "$$($(FPM) run $(FPM_FLAGS) --runner echo 2>/dev/null | tail -1)" \
		"mpi/$$($(MPI_FPM) run $(FPM_FLAGS) --runner echo 2>/dev/null | tail -1)" \
		docs/ensemble.md $(SCALING_ARGS)

clean:
	$(FPM) clean --all
