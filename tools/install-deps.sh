#!/usr/bin/env bash
# Install what holosym needs and is missing: gfortran, LAPACK/BLAS (apt, as root), fpm (pip).
set -euo pipefail

missing_apt=()
command -v gfortran >/dev/null 2>&1 || missing_apt+=(gfortran)
ldconfig -p 2>/dev/null | grep -q 'liblapack\.so ' || missing_apt+=(liblapack-dev)
ldconfig -p 2>/dev/null | grep -q 'libblas\.so ' || missing_apt+=(libblas-dev)

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

if ! command -v fpm >/dev/null 2>&1; then
    echo "install-deps: installing fpm with pip" >&2
    python3 -m pip install --quiet fpm
fi
command -v fpm >/dev/null 2>&1 || { echo "install-deps: fpm not on PATH after pip install" >&2; exit 1; }
