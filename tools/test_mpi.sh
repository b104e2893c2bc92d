#!/usr/bin/env bash
# Tests of the MPI build: `holosym-mpi` on 1, 2 and 3 ranks writes the same results and
# sample files as the serial `holosym`, byte for byte; a job killed on a worker rank or on
# rank 0 keeps its completed rows and --resume completes it to the same file; `tables`
# cells and `poincare` orbits farmed over ranks give the serial tables and crossings.
# Usage: tools/test_mpi.sh HOLOSYM HOLOSYM_MPI   (mpirun runs as root in CI: allowed here)
set -uo pipefail
serial=$(realpath "$1")
parallel=$(realpath "$2")
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
mpirun="mpirun --oversubscribe"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
passed=0
failed=0
check() { # name, then a command that must succeed
    local name=$1
    shift
    if "$@" > check.log 2>&1; then
        passed=$((passed + 1))
        echo "  pass mpi/$name"
    else
        failed=$((failed + 1))
        echo "  FAIL mpi/$name"
        sed 's/^/    /' check.log | tail -20
    fi
}

run=(ensemble --system linkage --perturb 24 --scale 0.01 --M 3 --T 3 --quiet)
"$serial" "${run[@]}" --output serial.csv --samples serial.samples --every 8 2> serial.err
for ranks in 1 2 3; do
    $mpirun -np $ranks "$parallel" "${run[@]}" --output mpi$ranks.csv \
        --samples mpi$ranks.samples --every 8 2> mpi$ranks.err
    check "results_on_${ranks}_ranks_equal_serial" cmp serial.csv mpi$ranks.csv
    check "samples_on_${ranks}_ranks_equal_serial" diff -r serial.samples mpi$ranks.samples
done
check "timing_log_has_every_id" test "$(tail -n +2 mpi3.timing.csv | cut -d, -f1 | sort -n | \
    tr '\n' ' ')" = "$(seq 1 24 | tr '\n' ' ')"

# Kill a job after some rows: first a worker rank, then rank 0 (the writer).
long=(ensemble --system pendulum --perturb 40 --scale 0.05 --M 3 --T 60 --quiet)
"$serial" "${long[@]}" --output long.csv 2> long.err
rows() { tail -n +3 "$1" 2>/dev/null | wc -l; }
rank_pid() { # pid of the process of rank $2 under mpirun $1
    local pid
    for pid in $(pgrep -P "$1"); do
        if tr '\0' '\n' < /proc/$pid/environ 2>/dev/null | grep -qx "OMPI_COMM_WORLD_RANK=$2"
        then echo "$pid"; return; fi
    done
}
kill_and_resume() { # rank to kill, output file
    local rank=$1 out=$2 job pid i
    $mpirun -np 3 "$parallel" "${long[@]}" --output "$out" 2> "$out.err" &
    job=$!
    for i in $(seq 1 600); do
        [ "$(rows "$out")" -ge 5 ] && break
        sleep 0.05
    done
    pid=$(rank_pid "$job" "$rank")
    [ -n "$pid" ] && kill -9 "$pid"
    wait "$job"
    local kept
    kept=$(rows "$out")
    echo "killed rank $rank with $kept rows written" >&2
    [ "$kept" -ge 5 ] && [ "$kept" -lt 40 ] || { echo "rows after the kill: $kept"; return 1; }
    # Every kept row is a complete row of the uninterrupted run.
    tail -n +3 "$out" | while IFS= read -r line; do
        grep -qxF "$line" long.csv || { echo "row not in the full run: ${line:0:60}"; exit 1; }
    done || return 1
    $mpirun -np 3 "$parallel" "${long[@]}" --output "$out" --resume 2>> "$out.err" || return 1
    cmp long.csv "$out"
}
check "killed_worker_rank_then_resumed_equals_uninterrupted" kill_and_resume 1 killed1.csv
check "killed_rank_0_then_resumed_equals_uninterrupted" kill_and_resume 0 killed0.csv
check "resume_on_a_complete_file_changes_nothing" bash -c "cp long.csv done.csv && \
    $mpirun -np 2 '$parallel' ${long[*]} --output done.csv --resume && cmp long.csv done.csv"
check "existing_results_refused_without_resume" bash -c "cp long.csv kept.csv && \
    ! $mpirun -np 2 '$parallel' ${long[*]} --output kept.csv 2> refused.err && \
    cmp long.csv kept.csv && grep -q 'exists' refused.err"

# tables: the cells farmed over ranks give the serial tables (but the wall time).
tables=(tables --Mmax 2 --Nmax 2 --h 0.5,0.25,0.125 --T 2)
"$serial" "${tables[@]}" 2> /dev/null | grep -v '^Wall time' > tables.serial
$mpirun -np 3 "$parallel" "${tables[@]}" 2> /dev/null | grep -v '^Wall time' > tables.mpi
check "tables_on_3_ranks_equal_serial" cmp tables.serial tables.mpi
# poincare: the orbits farmed over ranks give the serial crossings file.
section=(poincare --system pendulum --section "q3 - 0.75" --perturb 6 --scale 0.01 --M 4 \
    --h 1/8 --T 10 --quiet)
"$serial" "${section[@]}" --output section.serial 2> /dev/null
$mpirun -np 3 "$parallel" "${section[@]}" --output section.mpi 2> /dev/null
check "poincare_on_3_ranks_equal_serial" cmp section.serial section.mpi
check "other_commands_refused" bash -c "! $mpirun -np 1 '$parallel' simulate 2> refused.err \
    && grep -q 'use holosym' refused.err"

echo "mpi: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
