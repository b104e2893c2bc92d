#!/usr/bin/env bash
# `fpm install` must install the library's modules only: exactly the modules declared under
# src/, none of the application's (app/) or the examples' (example/). fpm copies the .mod of
# every source that holds no submodule; see the [install] table of fpm.toml.
set -euo pipefail
cd "$(dirname "$0")/.."
FPM=${FPM:-fpm}
prefix=$(mktemp -d)
trap 'rm -rf "$prefix"' EXIT
"$FPM" install --prefix "$prefix" > /dev/null
expected=$(grep -rhiE '^[[:space:]]*module[[:space:]]+[a-z0-9_]+[[:space:]]*$' src \
               | awk '{print tolower($2)}' | sort)
installed=$(find "$prefix" -name '*.mod' -exec basename {} .mod \; | sort)
if [ "$expected" != "$installed" ]; then
    echo "fpm install: the installed modules differ from the library's (< src, > installed):" >&2
    diff <(echo "$expected") <(echo "$installed") >&2 || true
    exit 1
fi
echo "fpm install: $(echo "$installed" | wc -l) module files, all of the library and only those"
