#!/usr/bin/env bash
# Make the Python virtual environment of the figures and the reference solutions, with the
# packages given (default: matplotlib mpmath), installing only what is missing.
#   tools/python_venv.sh [DIR] [PACKAGE ...]     (make venv: build/venv)
set -euo pipefail
dir="${1:-build/venv}"
shift || true
packages=("$@")
[ ${#packages[@]} -gt 0 ] || packages=(matplotlib mpmath)
if [ ! -x "$dir/bin/python" ]; then
    echo "python_venv: creating $dir" >&2
    if ! python3 -m venv "$dir" >&2; then
        if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
            echo "python_venv: installing python3-venv with apt-get" >&2
            apt-get update -qq && DEBIAN_FRONTEND=noninteractive \
                apt-get install -y -qq python3-venv >/dev/null
            rm -rf "$dir"
            python3 -m venv "$dir" >&2
        else
            echo "python_venv: python3 -m venv failed; install python3-venv" >&2
            exit 1
        fi
    fi
fi
missing=()
for package in "${packages[@]}"; do
    "$dir/bin/python" -c "import $package" >/dev/null 2>&1 || missing+=("$package")
done
if [ ${#missing[@]} -gt 0 ]; then
    echo "python_venv: installing ${missing[*]} into $dir" >&2
    "$dir/bin/python" -m pip install --quiet "${missing[@]}"
fi
