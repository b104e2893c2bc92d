#!/usr/bin/env bash
# Build the C example example/c/planar_pendulum.c against the installed library with gcc and
# run it (it exits non-zero when one of its checks fails).
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
"$CC" -std=gnu11 -Wall -Wextra -O2 "${c_flags[@]}" -Iinclude example/c/planar_pendulum.c \
    -L"$prefix/lib" -lholosym -lgfortran "${libs[@]}" -llapack -lblas -fopenmp -lm \
    -o "$prefix/planar_pendulum"
echo "c_example: built $prefix/planar_pendulum with $CC ($variant); running it" >&2
"$prefix/planar_pendulum"
