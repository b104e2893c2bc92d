#!/usr/bin/env bash
# Keep the include/*.inc digests recorded in the sources that include them current.
#
# fpm rebuilds a source when its own text changes, not when a file it includes changes, so
# an edit of include/holosym_scheme_kernels.inc alone would leave stale objects. Every
# library source that includes a file from include/ therefore holds that file's SHA-256
# as its only 64-hex-digit string literal (`template_sha256`). This script rewrites that
# literal when the included file changed, which changes the source and makes fpm rebuild
# it and everything that uses it. The test suite compares the digest compiled into the
# modules with the file on disk, so a build that skipped this step fails its tests.
#
#   tools/include_digest.sh          update the recorded digests (run by make)
#   tools/include_digest.sh --check  only report; exit 1 when a digest is out of date
set -euo pipefail
cd "$(dirname "$0")/.."

check=0
case "${1:-}" in
    "") ;;
    --check) check=1 ;;
    *) echo "usage: $0 [--check]" >&2; exit 2 ;;
esac

stale=0
while IFS= read -r source; do
    while IFS= read -r name; do
        inc="include/$name"
        [ -f "$inc" ] || continue
        digest=$(sha256sum "$inc" | cut -d ' ' -f 1)
        found=$(grep -oE '"[0-9a-f]{64}"' "$source" | wc -l)
        if [ "$found" -ne 1 ]; then
            echo "$source: includes $inc but records no single SHA-256 literal ($found found)" >&2
            exit 1
        fi
        recorded=$(grep -oE '"[0-9a-f]{64}"' "$source" | tr -d '"')
        [ "$recorded" = "$digest" ] && continue
        if [ "$check" -eq 1 ]; then
            echo "$source: records $inc digest $recorded, the file has $digest" >&2
            stale=1
        else
            sed -i -E "s/\"[0-9a-f]{64}\"/\"$digest\"/" "$source"
            echo "$source: recorded the new digest of $inc"
        fi
    done < <(sed -n -E \
        's/^[[:space:]]*#?[[:space:]]*include[[:space:]]+"([^"]+)".*/\1/ip' "$source")
done < <(grep -rlE '^[[:space:]]*#?[[:space:]]*include[[:space:]]+"' src --include='*.f90' \
             --include='*.F90')

if [ "$stale" -eq 1 ]; then
    echo "Run tools/include_digest.sh (or any make target) to record the current digests." >&2
    exit 1
fi
