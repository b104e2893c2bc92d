# holosym: two-command quick start on a fresh Debian/Ubuntu machine.
#   make test     install what is missing, build, run the test suite
#   make tables   the paper's Tables 1-3 (convergence orders, minimum Gauss points)
#   make bench    work-precision benchmark (real128 and real64 builds) into build/bench
# Other targets: make test64, make test-trap, make install-check, make pendulum, make linkage,
# make examples, make deps.

FPM ?= fpm
FPM_FLAGS ?= --profile release
SIMULATE_ARGS ?= --M 2 --N 1 --G 3 --h 0.125 --T 10 --every 8
BENCH_DIR ?= build/bench
BENCH_ARGS ?=
# The real64 build of the whole library (see src/core/holosym_kinds.F90).
REAL64_FLAGS ?= --flag "-DHOLOSYM_REAL64"
# Run-time checks, and floating-point exceptions that stop the program (SIGFPE).
TRAP_FLAGS ?= --flag "-g -fbacktrace -fcheck=all -ffpe-trap=invalid,zero,overflow"

.PHONY: all deps include-digest test test64 test-trap install-check tables bench pendulum \
	linkage examples clean

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

# The test suite (library and executable) built with run-time checks and trapping
# floating-point exceptions: the library's own checks never raise 'invalid', 'divide by
# zero' or 'overflow'. Tests that compute an overflow on purpose skip themselves in this
# build; docs/status-codes.md lists them.
test-trap: deps include-digest
	$(FPM) test $(TRAP_FLAGS)

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

clean:
	$(FPM) clean --all
