#!/usr/bin/env bash
# Draw DIR/work_precision.png and DIR/scaling.png with tools/plot_bench.py, in the
# benchmark's virtual environment (tools/bench_venv.sh installs matplotlib there).
set -euo pipefail
dir="${1:-build/bench}"
python=$("$(dirname "$0")/bench_venv.sh" "${BENCH_VENV:-build/venv}")
"$python" "$(dirname "$0")/plot_bench.py" "$dir"
