#!/usr/bin/env bash
# Instructions per step (callgrind, exact) of the step's two iterations, through the
# command line as a user runs it:
#   tools/iteration_instructions.sh HOLOSYM [OUT.csv]
# runs `HOLOSYM simulate` with `--iteration automatic` (the default: without the Newton
# matrix where that contracts) and `--iteration newton` on each case below and prints
# (and writes to OUT.csv, when given) instructions per step and their ratio.
set -euo pipefail
cd "$(dirname "$0")/.."
holosym=$1
out=${2:-/dev/null}
command -v valgrind >/dev/null 2>&1 || ./tools/apt-install.sh valgrind
# shellcheck source=tools/callgrind_steps.sh
. tools/callgrind_steps.sh
precision=real128
if "$holosym" --version | grep -q "64-bit real"; then precision=real64; fi
echo "precision,system,M,h,steps,newton_instructions_per_step,automatic_instructions_per_step,ratio" > "$out"
while read -r name options m h steps; do
    options=${options//,/ }
    a=$(per_step "$options" "$steps" --M "$m" --h "$h" --iteration newton)
    b=$(per_step "$options" "$steps" --M "$m" --h "$h" --iteration automatic)
    ratio=$(awk -v a="$a" -v b="$b" 'BEGIN { printf "%.3f", a / b }')
    echo "$precision,$name,$m,$h,$steps,$a,$b,$ratio" >> "$out"
    echo "iteration_instructions: $precision $name M = $m h = $h: newton $a, automatic $b per step, newton/automatic $ratio"
done <<LIST
pendulum --system=pendulum 4 1/16 200
pendulum --system=pendulum 8 1/8 100
pendulum --system=pendulum 5 5/7 40
planar --system=planar 8 1/8 100
linkage --system=linkage 6 1/16 100
linkage --system=linkage 8 1/8 50
chain100 --system=chain,--links=100 4 1/100 8
LIST
