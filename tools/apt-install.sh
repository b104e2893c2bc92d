#!/usr/bin/env bash
# Install Debian packages (the extra tools of some make targets: cmake, flang-19, ...).
# Needs root and apt-get; otherwise says what to install.
set -euo pipefail
if [ "$#" -eq 0 ]; then
    echo "usage: $0 PACKAGE..." >&2
    exit 2
fi
if [ "$(id -u)" -ne 0 ] || ! command -v apt-get >/dev/null 2>&1; then
    echo "apt-install: please install $* (apt-get install $*, as root)" >&2
    exit 1
fi
echo "apt-install: installing $* with apt-get" >&2
apt-get update -qq
DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
