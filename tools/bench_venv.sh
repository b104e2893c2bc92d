#!/usr/bin/env bash
# The benchmark's Python: a virtual environment (default build/venv) with heyoka (the
# competitor), numpy and matplotlib (the plots), created or completed with pip. Prints the
# path of its python. Only the bench targets of the Makefile use it; `make test` does not.
set -euo pipefail
venv="${1:-build/venv}"
if [ ! -x "$venv/bin/python" ]; then
    echo "bench_venv: creating $venv" >&2
    if ! python3 -m venv "$venv" >&2; then
        if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
            echo "bench_venv: installing python3-venv with apt-get" >&2
            apt-get update -qq && DEBIAN_FRONTEND=noninteractive \
                apt-get install -y -qq python3-venv >/dev/null
            rm -rf "$venv"
            python3 -m venv "$venv" >&2
        else
            echo "bench_venv: python3 -m venv failed; install python3-venv" >&2
            exit 1
        fi
    fi
fi
if ! "$venv/bin/python" -c "import heyoka, numpy, matplotlib" >/dev/null 2>&1; then
    echo "bench_venv: installing heyoka, numpy and matplotlib with pip" >&2
    "$venv/bin/python" -m pip install --quiet heyoka numpy matplotlib >&2
fi
echo "$venv/bin/python"
