#!/usr/bin/env bash
# Installs the Debian packages raytraffic needs, only those missing.
#   scripts/deps.sh            build, run.sh, test.sh, make check-long, .ci/run
#   scripts/deps.sh --engines  the optional engines of tests/engines.sh (the
#                              job list on GNU parallel and a private Slurm;
#                              long tier), which the build never needs
#   scripts/deps.sh --fresh    what scripts/fresh-debian.sh needs (debootstrap)
#   ... --list                 print the list's packages, install nothing
# scripts/commands.txt maps every command the scripts and tests run to its
# package; tests/commands.sh checks that each is in one of these lists or
# in every Debian system (Priority: required).
set -euo pipefail
# build-essential autoconf automake pkg-config: the build; libsqlite3-dev
# zlib1g-dev libopenexr-dev libpng-dev: the libraries (libpng: alpha
# textures on PNG files); sqlite3: the tests read the
# databases; gnuplot-nox: run.sh's plots; procps: pgrep and ps in the tests;
# clang libclang-rt-14-dev: the fuzz harnesses (make fuzz, check-long);
# python3: the reliability probes (check-long) and tests/fuzz/make_corpus.sh;
# git: the revision recorded in every result (the build does without it)
# and .ci/run's check of the golden files; ca-certificates: clones over https.
main="build-essential autoconf automake pkg-config libsqlite3-dev zlib1g-dev libopenexr-dev libpng-dev sqlite3 gnuplot-nox
procps clang libclang-rt-14-dev python3 git ca-certificates"
engines="parallel slurm-wlm munge"
fresh="debootstrap"
pkgs=$main list=0
for a in "$@"; do
    case $a in
        --engines) pkgs=$engines ;;
        --fresh) pkgs=$fresh ;;
        --list) list=1 ;;
        *) echo "usage: scripts/deps.sh [--engines|--fresh] [--list]" >&2; exit 2 ;;
    esac
done
if [ $list = 1 ]; then printf '%s\n' $pkgs; exit 0; fi
missing=""
for p in $pkgs; do
    # installed, not merely known (a removed package keeps its status entry)
    [ "$(dpkg-query -W -f '${db:Status-Status}' "$p" 2>/dev/null)" = installed ] || missing="$missing $p"
done
[ -z "$missing" ] && exit 0
if ! command -v apt-get >/dev/null 2>&1; then
    echo "raytraffic: please install:$missing" >&2
    exit 1
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    if ! command -v sudo >/dev/null 2>&1; then
        echo "raytraffic: as root (or with sudo installed) run: apt-get install$missing" >&2
        exit 1
    fi
    SUDO=sudo
fi
echo "installing:$missing" >&2
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
