#!/usr/bin/env bash
# Draw DIR/work_precision.png with tools/plot_bench.py, installing matplotlib with pip
# when it is missing.
set -euo pipefail
dir="${1:-build/bench}"
if ! python3 -c "import matplotlib" >/dev/null 2>&1; then
    echo "plot_bench: installing matplotlib with pip" >&2
    python3 -m pip install --quiet matplotlib || python3 -m pip install --quiet --user matplotlib
fi
python3 "$(dirname "$0")/plot_bench.py" "$dir"
