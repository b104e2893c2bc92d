# holosym: two-command quick start on a fresh Debian/Ubuntu machine.
#   make test     install what is missing, build, run the test suite
#   make tables   the paper's Tables 1-3 (convergence orders, minimum Gauss points)
#   make bench    work-precision benchmark (real128 and real64 builds) into build/bench
#   make figures  the figures of docs/figures.md: CSV from `holosym figures` into
#                 build/figures, PNG into docs/figures (matplotlib in build/venv)
# Other targets: make test64, make install-check, make pendulum, make linkage, make examples,
# make reference (the models' 50-digit reference solutions), make venv, make c-example
# (the C interface: example/c built with gcc against the real128 library and run;
# c-example64 the same with the real64 library), make deps.

FPM ?= fpm
FPM_FLAGS ?= --profile release
SIMULATE_ARGS ?= --M 2 --N 1 --G 3 --h 0.125 --T 10 --every 8
BENCH_DIR ?= build/bench
BENCH_ARGS ?=
# The real64 build of the whole library (see src/core/holosym_kinds.F90).
REAL64_FLAGS ?= --flag "-DHOLOSYM_REAL64"
VENV ?= build/venv
FIGURES_DATA ?= build/figures
FIGURES_PNG ?= docs/figures
FIGURES_ARGS ?=

.PHONY: all deps include-digest test test64 install-check tables bench pendulum linkage \
	examples clean venv figures reference c-example c-example64

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

# Python with matplotlib and mpmath, for the figures and the reference solutions.
venv:
	@./tools/python_venv.sh $(VENV) matplotlib mpmath

# Data of every figure from the library through the CLI, then the PNGs, then a check that
# each PNG was drawn.
figures: deps include-digest venv
	$(FPM) run $(FPM_FLAGS) -- figures --out $(FIGURES_DATA) $(FIGURES_ARGS)
	$(VENV)/bin/python tools/plot_figures.py $(FIGURES_DATA) $(FIGURES_PNG)
	./tools/check_figures.sh $(FIGURES_PNG)

# The models' independent reference states (50-digit index-1 solutions; ~10 minutes).
reference: venv
	$(VENV)/bin/python tools/reference/model_reference.py test/data/model_reference.csv

# The C example against the installed library, built with gcc and run (fails on a failed
# check).
c-example: deps include-digest
	./tools/c_example.sh real128

c-example64: deps include-digest
	./tools/c_example.sh real64

pendulum: deps include-digest
	$(FPM) run $(FPM_FLAGS) -- simulate --system pendulum $(SIMULATE_ARGS)

linkage: deps include-digest
	$(FPM) run $(FPM_FLAGS) -- simulate --system linkage $(SIMULATE_ARGS)

examples: deps include-digest
	$(FPM) run $(FPM_FLAGS) --example spherical_pendulum
	$(FPM) run $(FPM_FLAGS) --example spring_linkage
	$(FPM) run $(FPM_FLAGS) --example planar_pendulum
	$(FPM) run $(FPM_FLAGS) --example double_pendulum_start

clean:
	$(FPM) clean --all
