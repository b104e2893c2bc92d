# holosym: two-command quick start on a fresh Debian/Ubuntu machine.
#   make test     install what is missing, build, run the test suite
#   make tables   the paper's Tables 1-3 (convergence orders, minimum Gauss points)
# Other targets: make pendulum, make linkage, make examples, make deps.

FPM ?= fpm
FPM_FLAGS ?= --profile release
SIMULATE_ARGS ?= --M 2 --N 1 --G 3 --h 0.125 --T 10 --every 8

.PHONY: all deps test tables pendulum linkage examples clean

all: test

# Install gfortran, LAPACK/BLAS (apt, when run as root) and fpm (pip) if missing.
deps:
	@./tools/install-deps.sh

test: deps
	$(FPM) test

tables: deps
	$(FPM) run $(FPM_FLAGS) -- tables

pendulum: deps
	$(FPM) run $(FPM_FLAGS) -- simulate --system pendulum $(SIMULATE_ARGS)

linkage: deps
	$(FPM) run $(FPM_FLAGS) -- simulate --system linkage $(SIMULATE_ARGS)

examples: deps
	$(FPM) run $(FPM_FLAGS) --example spherical_pendulum
	$(FPM) run $(FPM_FLAGS) --example spring_linkage
	$(FPM) run $(FPM_FLAGS) --example planar_pendulum

clean:
	$(FPM) clean --all
