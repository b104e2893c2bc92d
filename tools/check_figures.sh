#!/usr/bin/env bash
# Check that every figure of docs/figures.md was drawn into DIR: each PNG exists, is not
# empty and starts with the PNG signature.
#   tools/check_figures.sh DIR
set -euo pipefail
dir="${1:?usage: $0 DIR}"
status=0
for name in fig1_pendulum fig2_energy fig4_linkage fig5_constraints long_run convergence \
    poincare; do
    file="$dir/$name.png"
    if [ ! -s "$file" ]; then
        echo "check_figures: $file missing or empty" >&2
        status=1
    elif [ "$(head -c 8 "$file" | od -An -tx1 | tr -d ' \n')" != "89504e470d0a1a0a" ]; then
        echo "check_figures: $file is not a PNG" >&2
        status=1
    else
        echo "check_figures: $file $(wc -c < "$file") bytes"
    fi
done
exit $status
