# holosym: two-command quick start on a fresh Debian/Ubuntu machine.
#   make test     install what is missing, build, run the test suite
#   make tables   the paper's Tables 1-3 (convergence orders, minimum Gauss points)
#   make bench    benchmark against heyoka and RATTLE (real128 and real64 builds), chain
#                 scaling, plots and docs/performance.md (about an hour of CPU on one core)
# Other targets: make bench-long (the long runs, about an hour), make bench-quick (a short
# check of the whole bench pipeline), make test64, make install-check, make pendulum,
# make linkage, make examples, make deps.

FPM ?= fpm
FPM_FLAGS ?= --profile release
SIMULATE_ARGS ?= --M 2 --N 1 --G 3 --h 0.125 --T 10 --every 8
BENCH_DIR ?= build/bench
BENCH_ARGS ?=
SCALING_ARGS ?=
LONG_ARGS ?=
# The benchmark's Python (heyoka, numpy, matplotlib), made by tools/bench_venv.sh.
BENCH_VENV ?= build/venv
BENCH_PYTHON = $(BENCH_VENV)/bin/python
# The real64 build of the whole library (see src/core/holosym_kinds.F90).
REAL64_FLAGS ?= --flag "-DHOLOSYM_REAL64"

.PHONY: all deps include-digest test test64 install-check tables bench bench-long \
	bench-quick bench-report pendulum linkage examples clean

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

# The benchmark: heyoka (pip, in $(BENCH_VENV)) measured in the same runs as holosym and
# its RATTLE compositions, real128 sweep (writes the reference), real64 sweep against it,
# the chain scaling study in both builds; then the summary, the plots and
# docs/performance.md (which this target owns, with docs/figures/work_precision.png and
# docs/figures/scaling.png).
bench: deps include-digest
	./tools/bench_venv.sh $(BENCH_VENV) > /dev/null
	mkdir -p $(BENCH_DIR)
	./tools/bench_environment.sh $(BENCH_PYTHON) > $(BENCH_DIR)/environment.txt
	$(FPM) run $(FPM_FLAGS) -- bench --out $(BENCH_DIR) --heyoka $(BENCH_PYTHON) $(BENCH_ARGS)
	$(FPM) run $(FPM_FLAGS) $(REAL64_FLAGS) -- bench --out $(BENCH_DIR) \
		--reference $(BENCH_DIR)/reference.csv --heyoka $(BENCH_PYTHON) $(BENCH_ARGS)
	$(FPM) run $(FPM_FLAGS) -- bench --scaling --out $(BENCH_DIR) $(SCALING_ARGS)
	$(FPM) run $(FPM_FLAGS) $(REAL64_FLAGS) -- bench --scaling --out $(BENCH_DIR) $(SCALING_ARGS)
	$(MAKE) bench-report

# The long runs (planar pendulum to T = 1e4 and 1e5, spherical pendulum to 1e4) against
# heyoka, into $(BENCH_DIR)/long.csv; about an hour of CPU. Then docs/performance.md again.
bench-long: deps include-digest
	./tools/bench_venv.sh $(BENCH_VENV) > /dev/null
	mkdir -p $(BENCH_DIR)
	$(FPM) run $(FPM_FLAGS) -- bench --long --out $(BENCH_DIR) --heyoka $(BENCH_PYTHON) \
		$(LONG_ARGS)
	$(MAKE) bench-report

# Summary, plots and docs/performance.md from the CSV files in $(BENCH_DIR).
bench-report: deps include-digest
	$(FPM) run $(FPM_FLAGS) -- bench --summarize $(BENCH_DIR) > /dev/null
	BENCH_VENV=$(BENCH_VENV) ./tools/plot_bench.sh $(BENCH_DIR)
	mkdir -p docs/figures
	cp $(BENCH_DIR)/performance.md docs/performance.md
	cp $(BENCH_DIR)/work_precision.png docs/figures/work_precision.png
	if [ -f $(BENCH_DIR)/scaling.png ]; then cp $(BENCH_DIR)/scaling.png docs/figures/; fi
	@cat $(BENCH_DIR)/summary.md

# The whole pipeline in a few minutes (short sweeps, K <= 8, short long runs), into
# build/bench-quick; docs/ is not touched. BENCH_QUICK_ARGS narrows it further (CI:
# --systems planar --no-per-step).
BENCH_QUICK_ARGS ?=
bench-quick: deps include-digest
	./tools/bench_venv.sh $(BENCH_VENV) > /dev/null
	$(FPM) run $(FPM_FLAGS) -- bench --quick --out build/bench-quick --heyoka $(BENCH_PYTHON) \
		$(BENCH_QUICK_ARGS)
	$(FPM) run $(FPM_FLAGS) -- bench --scaling --quick --out build/bench-quick
	$(FPM) run $(FPM_FLAGS) -- bench --long --quick --out build/bench-quick \
		--heyoka $(BENCH_PYTHON)
	$(FPM) run $(FPM_FLAGS) -- bench --summarize build/bench-quick > /dev/null
	BENCH_VENV=$(BENCH_VENV) ./tools/plot_bench.sh build/bench-quick

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
