# Shared by the instruction-count scripts (source it; $holosym names the executable):
#   instructions ARGS...        instructions of `$holosym simulate ARGS` under callgrind
#   per_step OPTIONS STEPS ARGS instructions per step: runs of STEPS and 3 STEPS steps,
#                               differenced (set-up, parsing and the first steps excluded)
instructions() {
    valgrind --tool=callgrind --callgrind-out-file=/dev/null "$holosym" simulate "$@" \
        --every 1000000000 2>&1 >/dev/null | sed -n 's/.*Collected : *\([0-9]*\).*/\1/p'
}
per_step() {  # system-options steps scheme...
    local options=$1 steps=$2
    shift 2
    local a b
    # shellcheck disable=SC2086
    a=$(instructions $options "$@" --steps "$steps")
    # shellcheck disable=SC2086
    b=$(instructions $options "$@" --steps $((3 * steps)))
    echo $(( (b - a) / (2 * steps) ))
}
