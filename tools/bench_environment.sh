#!/usr/bin/env bash
# One line per fact of the machine and tools a benchmark ran with (for docs/performance.md):
# CPU, compiler, Python and heyoka versions, date. Usage: bench_environment.sh PYTHON
set -euo pipefail
python="${1:-python3}"
cpu=$(grep -m1 'model name' /proc/cpuinfo 2>/dev/null | sed 's/.*: //' || true)
echo "Machine: ${cpu:-unknown CPU}, $(nproc) cores; $(uname -sr)"
echo "Compiler: $(gfortran --version | head -n 1)"
echo "Competitor: $("$python" -c 'import heyoka, sys; print("heyoka", heyoka.__version__, "(Python", sys.version.split()[0] + ")")')"
echo "Date: $(date -u '+%Y-%m-%d %H:%M UTC')"
