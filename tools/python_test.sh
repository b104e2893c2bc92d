#!/usr/bin/env bash
# The Python package's test: a fresh virtual environment (build/python-test-venv),
# pip install ./python (the library built by scikit-build-core with the project's CMake),
# pytest and numpy in it, the `holosym` command for the comparisons (fpm, release; also its
# real64 build for precision="double"), then
# pytest python/tests and the example python/examples/plot_errors.py (matplotlib, Agg).
#   tools/python_test.sh [VENV]
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${1:-build/python-test-venv}"
python="${PYTHON:-python3}"
fpm="${FPM:-fpm}"
if ! "$python" -c "import venv, ensurepip" >/dev/null 2>&1; then
    ./tools/apt-install.sh python3-venv
fi
rm -rf "$venv"
"$python" -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --upgrade pip
# The CMake build directory is kept between runs (build/python-cmake): a rerun compiles
# only what changed; the environment itself is new each time.
"$venv/bin/python" -m pip install --quiet \
    --config-settings=build-dir="$PWD/build/python-cmake" ./python
"$venv/bin/python" -m pip install --quiet pytest numpy matplotlib
exe=$("$fpm" run --profile release --runner echo holosym 2>/dev/null | tail -n 1)
[ -x "$exe" ] || { echo "python_test: no holosym command from fpm ($exe)" >&2; exit 1; }
echo "python_test: holosym command $exe" >&2
# The real64 build of the command, for precision="double".
exe64=$("$fpm" run --profile release --flag "-DHOLOSYM_REAL64" --runner echo holosym \
    2>/dev/null | tail -n 1)
[ -x "$exe64" ] || { echo "python_test: no real64 holosym command from fpm ($exe64)" >&2
                     exit 1; }
echo "python_test: real64 holosym command $exe64" >&2
# From outside the source tree: the tests import the installed package.
(cd python/tests && HOLOSYM_EXE="$PWD/../../$exe" HOLOSYM_EXE64="$PWD/../../$exe64" \
    MPLBACKEND=Agg "../../$venv/bin/python" -m pytest -q -p no:cacheprovider .)
out="build/python-test-plot.png"
rm -f "$out"
MPLBACKEND=Agg "$venv/bin/python" python/examples/plot_errors.py --output "$out"
[ -s "$out" ] || { echo "python_test: $out was not written" >&2; exit 1; }
echo "python_test: $out written" >&2
