#!/usr/bin/env bash
# Instructions per step (callgrind, exact) of each model file of `holosym bench --models`
# against its built-in twin, through the command line as a user runs it:
#   tools/model_instructions.sh HOLOSYM DIR
# runs `HOLOSYM simulate` under valgrind --tool=callgrind for S and 3S steps of each system
# and form (the difference is the cost of 2S steps, set-up, parsing and the first steps
# excluded) and writes
# DIR/model_instructions.csv (model_instructions64.csv for the real64 executable, which
# `HOLOSYM --version` names); then the same for the chains of K = 8 .. 256 links from
# DIR/models/chainK.hsm at (4, 3, 5), h = 0.01, into DIR/model_scaling_instructions.csv
# (model_scaling_instructions64.csv).
set -euo pipefail
cd "$(dirname "$0")/.."
holosym=$1
dir=$2
command -v valgrind >/dev/null 2>&1 || ./tools/apt-install.sh valgrind
precision=real128
suffix=""
if "$holosym" --version | grep -q "64-bit real"; then
    precision=real64
    suffix=64
fi
out="$dir/model_instructions$suffix.csv"
# shellcheck source=tools/callgrind_steps.sh
. tools/callgrind_steps.sh
echo "precision,model,M,N,G,h,steps,builtin_instructions_per_step,model_instructions_per_step,ratio" > "$out"
while read -r name builtin model m n g h steps; do
    builtin=${builtin//,/ }  # options of the built-in system, comma-separated below
    a=$(per_step "$builtin" "$steps" --M "$m" --N "$n" --G "$g" --h "$h")
    b=$(per_step "--model $model" "$steps" --M "$m" --N "$n" --G "$g" --h "$h")
    ratio=$(awk -v a="$a" -v b="$b" 'BEGIN { printf "%.4f", b / a }')
    echo "$precision,$name,$m,$n,$g,$h,$steps,$a,$b,$ratio" >> "$out"
    echo "model_instructions: $precision $name ($m,$n,$g): $a and $b per step, ratio $ratio" >&2
done <<LIST
pendulum --system=pendulum example/models/spherical_pendulum.hsm 4 3 5 0.125 200
pendulum --system=pendulum example/models/spherical_pendulum.hsm 8 7 9 0.125 100
linkage --system=linkage example/models/spring_linkage.hsm 4 3 5 0.125 100
linkage --system=linkage example/models/spring_linkage.hsm 8 7 9 0.125 50
chain64 --system=chain,--links=64 $dir/models/chain64.hsm 4 3 5 0.01 8
LIST
out="$dir/model_scaling_instructions$suffix.csv"
echo "precision,path,links,steps,instructions_per_step" > "$out"
for k in ${MODEL_CHAINS:-8 16 32 64 128 256}; do
    # 8 and 24 steps: the cost of a step varies from step to step (factors renewed or
    # kept), and 16 steps average it.
    b=$(per_step "--model $dir/models/chain$k.hsm" 8 --M 4 --N 3 --G 5 --h 0.01)
    echo "$precision,model,$k,16,$b" >> "$out"
    echo "model_instructions: $precision chain of $k links from its file: $b per step" >&2
done
