#!/usr/bin/env bash
# Check that the version is the same everywhere: fpm.toml, the output of
# `holosym --version` (passed as $1; it prints the library's holosym_version),
# the newest release heading of CHANGELOG.md and CITATION.cff.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
fpm_version="$(sed -n 's/^version *= *"\([0-9.]*\)".*/\1/p' "$root/fpm.toml")"
cli_version="$(printf '%s\n' "$1" | sed -n 's/^holosym \([0-9.]*\).*/\1/p')"
changelog_version="$(sed -n 's/^## \([0-9][0-9.]*\).*/\1/p' "$root/CHANGELOG.md" | head -1)"
citation_version="$(sed -n 's/^version: *\([0-9.]*\).*/\1/p' "$root/CITATION.cff")"
status=0
for pair in "holosym --version:$cli_version" "CHANGELOG.md:$changelog_version" \
            "CITATION.cff:$citation_version"; do
    if [ "${pair#*:}" != "$fpm_version" ]; then
        echo "check-version: ${pair%%:*} says '${pair#*:}', fpm.toml says '$fpm_version'" >&2
        status=1
    fi
done
[ "$status" -eq 0 ] && echo "check-version: $fpm_version everywhere"
exit "$status"
