# holosym: two-command quick start on a fresh Debian/Ubuntu machine.
#   make test     install what is missing (gfortran, LAPACK/BLAS, fpm), build, run the tests
#   make tables   the paper's Tables 1-3 (convergence orders, minimum Gauss points)
#
# Library and packaging:
#   make install PREFIX=DIR   library, .mod files and holosym.pc into DIR (fpm, release)
#   make check-install        install into build/install-check, build the quick start
#                             against it with pkg-config, run it
#   make cmake-test           CMake build, ctest, install, a find_package(holosym) consumer
#   make test-flang           the real64 build and its tests with LLVM flang (flang-19)
#   make test64               the test suite in the real64 build (gfortran)
#   make test-trap            the test suite with -fcheck=all and trapping FP exceptions
#   make check-examples       every example prints what its header says
#   make check-version        fpm.toml, holosym --version, CHANGELOG and CITATION agree
#   make check-fpm-dependency a project with holosym as an fpm path dependency
#   make check-fpm-install    fpm install gives the library's modules and nothing else
#   make profile              callgrind on an example (PROFILE_EXAMPLE=quickstart)
#   make iteration-instructions  instructions per step of --iteration newton and
#                             automatic in both builds (callgrind, minutes), into
#                             build/iteration_instructions*.csv (docs/design.md)
# Documentation (each page regenerated from a command's output):
#   make docs                 API pages with FORD (into build/doc), fails on any warning
#   make docs-tables          docs/tables.md       (holosym tables, seconds)
#   make docs-stability       docs/stability.md    (holosym extremes, minutes)
#   make docs-performance     docs/performance.md and docs/figures (= make bench)
# Benchmark (heyoka in a venv, holosym's RATTLE compositions, chain scaling):
#   make bench                sweeps in both builds, scaling, plots into docs/figures and
#                             docs/performance.md (about an hour of CPU on one core)
#   make bench-long           the long runs against heyoka (about 80 minutes); that section
#                             of docs/performance.md
#   make bench-quick          the whole bench pipeline in a few minutes (build/bench-quick)
#   make bench-models         model files against the built-in models, chains from model
#                             files (minutes); that section of docs/performance.md
#   make bench-accuracy       what --accuracy delivers on five systems (a minute):
#                             the tables of docs/accuracy.md
# Figures, models, C interface:
#   make figures              every figure of docs/figures.md: CSV from `holosym figures`
#                             into build/figures, PNG into docs/figures (matplotlib in
#                             build/venv); FIGURES_PNG=DIR draws elsewhere (CI)
#   make reference            the models' 50-digit reference solutions (mpmath, ~10 min)
#                             into test/data/model_reference.csv
#   make reference-formula    the same for example/models/water.hsm and fourbar.hsm
#                             into test/data/formula_reference.csv
#   make c-example            example/c built with gcc against the real128 library and run
#   make c-example64          the same with the real64 library (double)
#   make python-test          the Python package (python/): a fresh venv, pip install
#                             ./python (CMake, shared library), pytest, the plot example
# Ensembles and MPI:
#   make test-mpi             the MPI build (installs OpenMPI) and its tests: ensembles and
#                             tables cells on 1-3 ranks give the serial files byte for byte
#   make scaling              ensemble throughput (threads, ranks) into docs/ensemble.md
# Other targets: make pendulum, make linkage, make examples, make mpi, make deps,
# make clean. Every target that needs an extra tool (cmake, flang, FORD, heyoka, MPI)
# installs it.

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
# The figures' and reference solutions' Python (matplotlib, mpmath), made by
# tools/python_venv.sh (the same environment as the benchmark's).
VENV ?= build/venv
FIGURES_DATA ?= build/figures
FIGURES_PNG ?= docs/figures
FIGURES_ARGS ?=
PREFIX ?= /usr/local
# Fortran modules are installed under $(PREFIX)/$(MODULE_DIR).
MODULE_DIR ?= include/holosym
FLANG ?= flang-new-19
# C compiler of the tool's POSIX services in the flang build (fpm would pick clang).
FLANG_CC ?= gcc
PYTHON ?= python3
DOCS_VENV ?= build/venv-docs
CMAKE_DIR ?= build/cmake

.PHONY: all deps include-digest test test64 test-trap tables bench bench-long bench-quick bench-report \
	bench-models bench-models-data bench-accuracy iteration-instructions \
	pendulum linkage examples clean install check-install check-fpm-install cmake-deps \
	cmake-test flang-deps test-flang check-examples check-version check-fpm-dependency \
	profile docs docs-deps docs-tables docs-stability docs-performance mpi test-mpi scaling \
	venv figures reference reference-formula c-example c-example64 python-test
# Run-time checks, and floating-point exceptions that stop the program (SIGFPE).
TRAP_FLAGS ?= --flag "-g -fbacktrace -fcheck=all -ffpe-trap=invalid,zero,overflow"

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
check-fpm-install: deps include-digest
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
	$(MAKE) bench-models-data
	$(MAKE) bench-report

# Model files against the built-in models (pendulum, linkage, chain of 64: CPU time in
# alternation, and instructions per step under callgrind through `holosym simulate`) and
# chains of K = 8 .. 256 links from model files written by tools/chain_model.py, in both
# builds (about ten minutes), into $(BENCH_DIR); bench-models then rewrites that section
# of docs/performance.md alone (make bench rewrites the whole page).
MODEL_CHAINS ?= 8 16 32 64 128 256
MODELS_ARGS ?=
bench-models-data: deps include-digest
	mkdir -p $(BENCH_DIR)/models
	for k in $(MODEL_CHAINS); do \
		$(PYTHON) tools/chain_model.py $$k $(BENCH_DIR)/models/chain$$k.hsm || exit 1; done
	$(FPM) run $(FPM_FLAGS) -- bench --models --out $(BENCH_DIR) $(MODELS_ARGS)
	$(FPM) run $(FPM_FLAGS) $(REAL64_FLAGS) -- bench --models --out $(BENCH_DIR) $(MODELS_ARGS)
	./tools/model_instructions.sh "$$($(FPM) run $(FPM_FLAGS) --runner echo | tail -n 1)" \
		$(BENCH_DIR)
	./tools/model_instructions.sh \
		"$$($(FPM) run $(FPM_FLAGS) $(REAL64_FLAGS) --runner echo | tail -n 1)" $(BENCH_DIR)

bench-models: bench-models-data
	$(FPM) run $(FPM_FLAGS) -- bench --models-section $(BENCH_DIR) > $(BENCH_DIR)/models.md
	$(PYTHON) tools/replace_section.py docs/performance.md $(BENCH_DIR)/models.md

# What --accuracy delivers (init_for_accuracy) on five systems, in both builds (a minute):
# the tables of docs/accuracy.md.
bench-accuracy: deps include-digest
	mkdir -p $(BENCH_DIR)
	$(FPM) run $(FPM_FLAGS) -- bench --accuracy --out $(BENCH_DIR)
	$(FPM) run $(FPM_FLAGS) $(REAL64_FLAGS) -- bench --accuracy --out $(BENCH_DIR)
	$(PYTHON) tools/replace_section.py docs/accuracy.md $(BENCH_DIR)/accuracy.md
	$(PYTHON) tools/replace_section.py docs/accuracy.md $(BENCH_DIR)/accuracy64.md

# The long runs (planar and spherical pendulum to T = 1e4, planar to 1e5) against heyoka,
# into $(BENCH_DIR)/long.csv; then its section of docs/performance.md (the other sections
# come from `make bench`).
bench-long: deps include-digest
	./tools/bench_venv.sh $(BENCH_VENV) > /dev/null
	mkdir -p $(BENCH_DIR)
	$(FPM) run $(FPM_FLAGS) -- bench --long --out $(BENCH_DIR) --heyoka $(BENCH_PYTHON) \
		$(LONG_ARGS)
	$(FPM) run $(FPM_FLAGS) -- bench --long-section $(BENCH_DIR) > $(BENCH_DIR)/long.md
	$(PYTHON) tools/replace_section.py docs/performance.md $(BENCH_DIR)/long.md

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
	mkdir -p build/bench-quick/models
	for k in 8 16 64; do \
		$(PYTHON) tools/chain_model.py $$k build/bench-quick/models/chain$$k.hsm || exit 1; done
	$(FPM) run $(FPM_FLAGS) -- bench --models --quick --out build/bench-quick
	$(FPM) run $(FPM_FLAGS) -- bench --summarize build/bench-quick > /dev/null
	BENCH_VENV=$(BENCH_VENV) ./tools/plot_bench.sh build/bench-quick

# Python with matplotlib and mpmath, for the figures and the reference solutions.
venv:
	@./tools/python_venv.sh $(VENV) matplotlib mpmath

# Data of every figure from the library through the CLI, then the PNGs, then a check that
# each PNG was drawn.
# The Poincare sections (docs/events.md): the double pendulum near a regular and near a
# chaotic start (crossings of x1 = 0 rising), the spherical pendulum (q2 = 0 rising).
POINCARE = $(FPM) run $(FPM_FLAGS) -- poincare --quiet --M 4 --h 1/16
DOUBLE_MODEL = --model example/models/double_pendulum.hsm --section x1 --direction rising

figures: deps include-digest venv
	$(FPM) run $(FPM_FLAGS) -- figures --out $(FIGURES_DATA) $(FIGURES_ARGS)
	$(POINCARE) $(DOUBLE_MODEL) --set theta1=0.5 --set theta2=0.3 --T 300 --perturb 6 \
		--scale 0.05 --output $(FIGURES_DATA)/poincare_double_regular.csv
	$(POINCARE) $(DOUBLE_MODEL) --set theta1=2 --set theta2=2.5 --T 600 --perturb 2 \
		--scale 0.05 --output $(FIGURES_DATA)/poincare_double_chaotic.csv
	$(POINCARE) --system pendulum --section q2 --direction rising --T 200 --perturb 6 \
		--scale 0.2 --output $(FIGURES_DATA)/poincare_spherical.csv
	$(VENV)/bin/python tools/plot_figures.py $(FIGURES_DATA) $(FIGURES_PNG)
	./tools/check_figures.sh $(FIGURES_PNG)

# The models' independent reference states (50-digit index-1 solutions; ~10 minutes).
reference: venv
	$(VENV)/bin/python tools/reference/model_reference.py test/data/model_reference.csv

# The same for the formula models example/models/water.hsm and fourbar.hsm, from the
# files' exact starts (50 digits, not rounded to binary128).
reference-formula: venv
	$(VENV)/bin/python tools/reference/formula_reference.py test/data/formula_reference.csv

# The C example against the installed library, built with gcc and run (fails on a failed
# check).
c-example: deps include-digest
	./tools/c_example.sh real128

c-example64: deps include-digest
	./tools/c_example.sh real64

# The Python package: a fresh virtual environment under build/, pip install ./python,
# pytest python/tests (against the holosym command), python/examples/plot_errors.py.
python-test: deps include-digest
	./tools/python_test.sh

pendulum: deps include-digest
	$(FPM) run $(FPM_FLAGS) -- simulate --system pendulum $(SIMULATE_ARGS)

linkage: deps include-digest
	$(FPM) run $(FPM_FLAGS) -- simulate --system linkage $(SIMULATE_ARGS)

examples: deps include-digest
	$(FPM) run $(FPM_FLAGS) --example quickstart
	$(FPM) run $(FPM_FLAGS) --example spherical_pendulum
	$(FPM) run $(FPM_FLAGS) --example spring_linkage
	$(FPM) run $(FPM_FLAGS) --example planar_pendulum
	$(FPM) run $(FPM_FLAGS) --example double_pendulum_start
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

# ---------------------------------------------------------------- checks

# Each example's output against the expected output in its header comment, and the
# README's copy of the quick start.
check-examples: deps include-digest
	$(FPM) build $(FPM_FLAGS)
	$(PYTHON) tools/check_examples.py

# One version everywhere: fpm.toml, the library (holosym --version), CHANGELOG.md,
# CITATION.cff.
check-version: deps include-digest
	$(FPM) build $(FPM_FLAGS)
	@./tools/check-version.sh "$$($(FPM) run $(FPM_FLAGS) -- --version)"

# A project that depends on holosym through fpm (path dependency), built and run: the
# README's dependency snippet, with the quick start as its program.
check-fpm-dependency: deps include-digest
	rm -rf build/fpm-consumer && mkdir -p build/fpm-consumer/app
	cp example/quickstart.f90 build/fpm-consumer/app/main.f90
	printf '%s\n' 'name = "holosym_consumer"' '[dependencies]' \
		'holosym = { path = "../.." }' > build/fpm-consumer/fpm.toml
	cd build/fpm-consumer && $(FPM) build $(FPM_FLAGS) > build.log 2>&1 || \
		{ cat build.log; exit 1; }
	@# fpm 0.12 compiles a path dependency with an include directory once more on the
	@# second build; settle it here so that `fpm run` below prints only the program.
	cd build/fpm-consumer && $(FPM) build $(FPM_FLAGS) >> build.log 2>&1
	$(PYTHON) tools/check_examples.py --runner \
		"sh -c 'cd build/fpm-consumer && $(FPM) run $(FPM_FLAGS)'" quickstart

# ---------------------------------------------------------------- profiling

PROFILE_EXAMPLE ?= quickstart
# callgrind on an example built with -g; the top of callgrind_annotate.
iteration-instructions: deps include-digest
	$(FPM) build $(FPM_FLAGS)
	$(FPM) build $(FPM_FLAGS) $(REAL64_FLAGS)
	./tools/iteration_instructions.sh \
		"$$($(FPM) run $(FPM_FLAGS) --runner echo | tail -n 1)" build/iteration_instructions.csv
	./tools/iteration_instructions.sh \
		"$$($(FPM) run $(FPM_FLAGS) $(REAL64_FLAGS) --runner echo | tail -n 1)" \
		build/iteration_instructions64.csv

profile: deps include-digest
	@command -v valgrind >/dev/null 2>&1 || ./tools/apt-install.sh valgrind
	$(FPM) build $(FPM_FLAGS) --flag "-g"
	$(FPM) run $(FPM_FLAGS) --flag "-g" --example $(PROFILE_EXAMPLE) --runner \
		"valgrind --tool=callgrind --callgrind-out-file=build/callgrind.out"
	callgrind_annotate build/callgrind.out | head -40

# ---------------------------------------------------------------- install

# The library (static), its .mod files and holosym.pc (pkg-config) under PREFIX.
install: deps include-digest
	$(FPM) install $(FPM_FLAGS) --prefix "$(PREFIX)" --includedir "$(MODULE_DIR)"
	mkdir -p "$(PREFIX)/lib/pkgconfig"
	./tools/write-pkgconfig.sh lib "$(MODULE_DIR)" > "$(PREFIX)/lib/pkgconfig/holosym.pc"

# Install into a scratch prefix, then compile the quick start against the installed copy
# with nothing but `pkg-config --cflags --libs holosym`, run it and check its output.
check-install:
	rm -rf build/install-check
	$(MAKE) --no-print-directory install PREFIX="$(CURDIR)/build/install-check"
	mkdir -p build/install-check/demo
	cd build/install-check/demo && \
		PKG_CONFIG_PATH="$(CURDIR)/build/install-check/lib/pkgconfig" && export PKG_CONFIG_PATH && \
		echo "gfortran \$$(pkg-config --cflags holosym) quickstart.f90 \$$(pkg-config --libs holosym)" \
			"  # = gfortran $$(pkg-config --cflags holosym) ... $$(pkg-config --libs holosym)" && \
		gfortran $$(pkg-config --cflags holosym) -o quickstart \
			"$(CURDIR)/example/quickstart.f90" $$(pkg-config --libs holosym)
	$(PYTHON) tools/check_examples.py --runner "build/install-check/demo/{name}" quickstart
	@extra=""; for mod in build/install-check/$(MODULE_DIR)/*.mod; do \
		name=$$(basename "$$mod" .mod); \
		grep -rqiE "^ *module +$$name *($$|!)" src || extra="$$extra $$name"; done; \
		if [ -n "$$extra" ]; then echo "check-install: modules from outside src/" \
			"installed:$$extra"; exit 1; else echo "check-install: library modules only"; fi

# ---------------------------------------------------------------- CMake

cmake-deps:
	@command -v cmake >/dev/null 2>&1 || ./tools/apt-install.sh cmake

# Configure, build (serially), run ctest, install into a scratch prefix, then build and
# run a separate project that finds the installed copy with find_package(holosym).
cmake-test: deps cmake-deps
	cmake -S . -B $(CMAKE_DIR) -DCMAKE_BUILD_TYPE=Release
	cmake --build $(CMAKE_DIR)
	ctest --test-dir $(CMAKE_DIR) --output-on-failure
	rm -rf $(CMAKE_DIR)-install $(CMAKE_DIR)-consumer
	cmake --install $(CMAKE_DIR) --prefix $(CURDIR)/$(CMAKE_DIR)-install
	cmake -S tools/consumer -B $(CMAKE_DIR)-consumer -DCMAKE_BUILD_TYPE=Release \
		-DCMAKE_PREFIX_PATH=$(CURDIR)/$(CMAKE_DIR)-install
	cmake --build $(CMAKE_DIR)-consumer
	$(PYTHON) tools/check_examples.py --runner "$(CMAKE_DIR)-consumer/{name}" quickstart

# ---------------------------------------------------------------- LLVM flang

flang-deps:
	@command -v $(FLANG) >/dev/null 2>&1 && ldconfig -p | grep -q 'libomp\.so ' || \
		./tools/apt-install.sh flang-19 libomp-19-dev

# flang-19 builds and tests the real64 library (its runtime has no REAL(16) math, so the
# real128 build cannot link); the real128 library is compiled too, to keep it building.
test-flang: deps include-digest flang-deps
	$(FPM) test --compiler $(FLANG) --c-compiler $(FLANG_CC) $(REAL64_FLAGS)
	cmake -S . -B build/flang-real128 -DCMAKE_Fortran_COMPILER=$(FLANG) \
		-DCMAKE_BUILD_TYPE=Release -DHOLOSYM_BUILD_TESTS=OFF -DHOLOSYM_BUILD_APP=OFF \
		-DHOLOSYM_BUILD_EXAMPLES=OFF
	cmake --build build/flang-real128

# ---------------------------------------------------------------- documentation

docs-deps:
	@test -x $(DOCS_VENV)/bin/ford || { \
		$(PYTHON) -m venv $(DOCS_VENV) 2>/dev/null || { ./tools/apt-install.sh python3-venv && \
			$(PYTHON) -m venv $(DOCS_VENV); } && \
		$(DOCS_VENV)/bin/pip install --quiet ford pcpp; }

# FORD pages into build/doc (landing page: the README, whose links to docs/ are served
# from a copy); the façade must list every name it exports; any FORD warning fails.
docs: docs-deps
	$(PYTHON) tools/check_api_docs.py
	mkdir -p build
	PATH="$(CURDIR)/$(DOCS_VENV)/bin:$$PATH" ford ford.md > build/ford.log 2>&1 || \
		{ cat build/ford.log; exit 1; }
	@if grep -q -i 'warning' build/ford.log; then grep -i -A2 'warning' build/ford.log; \
		echo "make docs: FORD printed warnings (build/ford.log)"; exit 1; fi
	rm -rf build/doc/docs && cp -r docs build/doc/docs && rm -rf build/doc/docs/templates
	@echo "make docs: build/doc/index.html, no FORD warnings"

docs-tables: deps include-digest
	$(FPM) build $(FPM_FLAGS)
	$(PYTHON) tools/docs_page.py docs/templates/tables.md docs/tables.md "make docs-tables" \
		-- sh -c '$(FPM) run $(FPM_FLAGS) -- tables && \
		$(FPM) run $(FPM_FLAGS) -- tables --system linkage'

docs-stability: deps include-digest
	$(FPM) build $(FPM_FLAGS)
	$(PYTHON) tools/docs_page.py docs/templates/stability.md docs/stability.md \
		"make docs-stability" -- $(FPM) run $(FPM_FLAGS) -- extremes

# docs/performance.md and its figures are written by the benchmark itself.
docs-performance: bench

clean:
	$(FPM) clean --all
