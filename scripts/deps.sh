#!/usr/bin/env bash
# Installs the Debian packages raytraffic needs, only those missing.
# --engines: also the optional test dependencies of tests/engines.sh (the
# job list on GNU parallel and a private Slurm; long tier only), which the
# build never needs: parallel, slurm-wlm, munge.
set -euo pipefail
# procps: pgrep in the tests; clang and libclang-rt-14-dev: the fuzz harnesses (check-long)
pkgs="build-essential autoconf automake pkg-config libsqlite3-dev zlib1g-dev libopenexr-dev sqlite3 gnuplot-nox procps clang libclang-rt-14-dev"
if [ "${1:-}" = --engines ]; then pkgs="parallel slurm-wlm munge"; fi
missing=""
for p in $pkgs; do
    dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"
done
[ -z "$missing" ] && exit 0
if ! command -v apt-get >/dev/null 2>&1; then
    echo "raytraffic: please install:$missing" >&2
    exit 1
fi
SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "installing:$missing" >&2
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
