#!/usr/bin/env bash
# Link the holosym tool's sources (app/*.f90 but its main program, and its C services
# app/*.c) into mpi/app/, where the holosym-mpi executable is built from them and its own
# main program. fpm follows links to files, not to directories, hence one link per file;
# the links are not versioned.
set -euo pipefail
cd "$(dirname "$0")/.."
find mpi/app -maxdepth 1 -type l \( -name '*.f90' -o -name '*.c' \) -delete
for source in app/*.f90 app/*.c; do
    name=$(basename "$source")
    [ "$name" = main.f90 ] && continue
    ln -s "../../app/$name" "mpi/app/$name"
done
