#!/usr/bin/env bash
# Install what holosym needs and is missing: gfortran, LAPACK/BLAS (apt, as root), fpm (pip).
set -euo pipefail

missing_apt=()
command -v gfortran >/dev/null 2>&1 || missing_apt+=(gfortran)
ldconfig -p 2>/dev/null | grep -q 'liblapack\.so ' || missing_apt+=(liblapack-dev)
ldconfig -p 2>/dev/null | grep -q 'libblas\.so ' || missing_apt+=(libblas-dev)
# Optional: OpenBLAS provides the same BLAS/LAPACK (Debian's alternatives then point
# libblas.so.3/liblapack.so.3 at it); its dgetrf is 4-5x faster than the reference one for
# the ~100 x 100 Newton matrices of the linkage. Skipped where no package manager has it.
optional_apt=()
ldconfig -p 2>/dev/null | grep -q 'libopenblas' || optional_apt+=(libopenblas0-serial)

if [ ${#missing_apt[@]} -gt 0 ]; then
    if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "install-deps: installing ${missing_apt[*]} with apt-get" >&2
        apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing_apt[@]}" >/dev/null
    else
        echo "install-deps: missing ${missing_apt[*]}; install them (apt-get install" \
             "${missing_apt[*]}) or run as root" >&2
        exit 1
    fi
fi

if [ ${#optional_apt[@]} -gt 0 ] && [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "install-deps: installing ${optional_apt[*]} with apt-get (optional)" >&2
    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive \
        apt-get install -y -qq "${optional_apt[@]}" >/dev/null; } ||
        echo "install-deps: ${optional_apt[*]} not installed; the reference BLAS works too" >&2
fi

if ! command -v fpm >/dev/null 2>&1; then
    echo "install-deps: installing fpm with pip" >&2
    python3 -m pip install --quiet fpm
fi
command -v fpm >/dev/null 2>&1 || { echo "install-deps: fpm not on PATH after pip install" >&2; exit 1; }
