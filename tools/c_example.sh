#!/usr/bin/env bash
# Build the C examples example/c/planar_pendulum.c (a system by callbacks) and
# example/c/model.c (a system from a model file) against the installed library with gcc
# and run them (each exits non-zero when one of its checks fails).
#   tools/c_example.sh           the real128 library (__float128)
#   tools/c_example.sh real64    the real64 library (double), -DHOLOSYM_REAL64 on both sides
set -euo pipefail
cd "$(dirname "$0")/.."
FPM=${FPM:-fpm}
CC=${CC:-gcc}
variant="${1:-real128}"
case "$variant" in
    real128) fortran_flags=(); c_flags=(); libs=(-lquadmath) ;;
    real64) fortran_flags=(--flag "-DHOLOSYM_REAL64"); c_flags=(-DHOLOSYM_REAL64); libs=() ;;
    *) echo "usage: $0 [real128|real64]" >&2; exit 2 ;;
esac
prefix="build/capi-$variant"
"$FPM" install --profile release "${fortran_flags[@]}" --prefix "$prefix" > /dev/null
for example in planar_pendulum model; do
    "$CC" -std=gnu11 -Wall -Wextra -O2 "${c_flags[@]}" -Iinclude "example/c/$example.c" \
        -L"$prefix/lib" -lholosym -lgfortran "${libs[@]}" -llapack -lblas -fopenmp -lm \
        -o "$prefix/$example"
    echo "c_example: built $prefix/$example with $CC ($variant); running it" >&2
    "$prefix/$example"
done
