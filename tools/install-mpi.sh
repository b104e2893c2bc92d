#!/usr/bin/env bash
# Install OpenMPI (compiler wrapper mpifort with the mpi_f08 module, and mpirun) when
# missing: apt-get as root. Only the MPI targets of the Makefile call this; the default
# build needs no MPI.
set -euo pipefail
if command -v mpifort >/dev/null 2>&1 && command -v mpirun >/dev/null 2>&1; then
    exit 0
fi
if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "install-mpi: installing libopenmpi-dev openmpi-bin with apt-get" >&2
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libopenmpi-dev openmpi-bin >/dev/null
else
    echo "install-mpi: mpifort/mpirun missing; install them (apt-get install libopenmpi-dev" \
         "openmpi-bin) or run as root" >&2
    exit 1
fi
