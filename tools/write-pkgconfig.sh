#!/usr/bin/env bash
# Write holosym.pc (pkg-config) for an installation by `make install` to standard output,
# from the template holosym.pc.in that CMake fills too. The file goes to
# PREFIX/LIBDIR/pkgconfig and finds PREFIX from its own place (${pcfiledir}).
#   tools/write-pkgconfig.sh LIBDIR MODULEDIR   (both relative to the prefix)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
libdir="$1"
moduledir="$2"
# From PREFIX/LIBDIR/pkgconfig back to PREFIX.
up="$(printf '%s/pkgconfig' "$libdir" | sed 's|[^/][^/]*|..|g')"
version="$(sed -n 's/^version *= *"\([0-9.]*\)".*/\1/p' "$root/fpm.toml")"
# The library is built with gfortran -fopenmp by fpm's openmp dependency.
sed -e "s|@HOLOSYM_PC_PREFIX@|\${pcfiledir}/$up|" \
    -e "s|@HOLOSYM_PC_LIBDIR@|\${prefix}/$libdir|" \
    -e "s|@HOLOSYM_PC_INCLUDEDIR@|\${prefix}/$moduledir|" \
    -e "s|@HOLOSYM_PC_VERSION@|$version|" \
    -e "s|@HOLOSYM_PC_LIBNAME@|holosym|" \
    -e "s|@HOLOSYM_PC_OPENMP@|-fopenmp|" \
    "$root/holosym.pc.in"
