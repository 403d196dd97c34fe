#!/usr/bin/env bash
# The fresh-machine check: the README's two commands on a bare Debian 12.
#
#   scripts/fresh-debian.sh [DIR]     (as root; default /tmp/raytraffic-fresh)
#
# Builds a minimal Debian 12 (debootstrap --variant=minbase bookworm; the
# first run keeps it as DIR/minbase.tar so later runs start from the same
# bare system without downloading it again), copies the committed tree
# (git archive HEAD: no .git, so the build must do without git) to
# /root/raytraffic in it, and runs ./run.sh, then ./test.sh, in
# `chroot DIR/root` (niced) with /proc, /dev, /dev/pts and /sys bound. Every package they
# need is installed by scripts/deps.sh inside the chroot. Logs:
# DIR/run.log, DIR/test.log; exit status 0 when both commands passed.
#   RT_FRESH_MIRROR  Debian mirror (default http://deb.debian.org/debian)
# Not part of `make check`: it downloads Debian's packages (88 in the
# bare system, 258 after deps.sh) and took 827 s on the shared 2-core
# machine. Results: docs/reliability.md, "Fresh machine".
set -euo pipefail
# (One function, called on the last line: bash reads it whole before it
# runs, so editing the script during a run cannot change the run.)
main() {
top="$(cd "$(dirname "$0")/.." && pwd)"
dir="${1:-/tmp/raytraffic-fresh}"
mirror="${RT_FRESH_MIRROR:-http://deb.debian.org/debian}"
root="$dir/root"
[ "$(id -u)" -eq 0 ] || { echo "fresh-debian.sh: needs root (debootstrap, chroot, mount)" >&2; exit 1; }
case "$dir" in "$top"|"$top"/*) echo "fresh-debian.sh: $dir is inside the source tree" >&2; exit 1;; esac
mkdir -p "$dir"
dir="$(cd "$dir" && pwd)"
root="$dir/root"
start=$(date +%s)
say() { echo "== $* ($(( $(date +%s) - start )) s)"; }

# Anything still mounted below the chroot must never be deleted through.
mounted() { awk -v r="$root/" 'index($2 "/", r) == 1 { found = 1 } END { exit !found }' /proc/mounts; }
unbind() {
    local m
    for m in sys dev/pts dev proc; do
        if awk -v p="$root/$m" '$2 == p { f = 1 } END { exit !f }' /proc/mounts; then umount -l "$root/$m"; fi
    done
}
trap unbind EXIT

if [ ! -f "$dir/minbase.tar" ]; then
    "$top/scripts/deps.sh" --fresh
    ! mounted || { echo "fresh-debian.sh: something is mounted below $root" >&2; exit 1; }
    rm -rf "$root"
    say "debootstrap --variant=minbase bookworm $root"
    debootstrap --variant=minbase bookworm "$root" "$mirror" > "$dir/debootstrap.log" 2>&1 \
        || { tail -n 20 "$dir/debootstrap.log"; exit 1; }
    tar -C "$root" -cf "$dir/minbase.tar.tmp" . && mv "$dir/minbase.tar.tmp" "$dir/minbase.tar"
else
    ! mounted || { echo "fresh-debian.sh: something is mounted below $root" >&2; exit 1; }
    say "bare system from $dir/minbase.tar"
    rm -rf "$root"
    mkdir -p "$root"
    tar -C "$root" -xf "$dir/minbase.tar"
fi
cp /etc/resolv.conf "$root/etc/resolv.conf"

if [ -n "$(cd "$top" && git status --porcelain --untracked-files=no)" ]; then
    echo "fresh-debian.sh: note: uncommitted changes are not copied (git archive HEAD)" >&2
fi
rev="$(cd "$top" && git rev-parse --short=12 HEAD)"
say "copying $rev (git archive HEAD) to /root/raytraffic"
mkdir -p "$root/root/raytraffic"
(cd "$top" && git archive HEAD) | tar -C "$root/root/raytraffic" -xf -

mount --bind /proc "$root/proc"
mount --bind /dev "$root/dev"
mount --bind /dev/pts "$root/dev/pts"
mount --bind /sys "$root/sys"
inchroot() {
    nice -n 10 chroot "$root" /usr/bin/env -i HOME=/root PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
        TERM=dumb /bin/bash -c "cd /root/raytraffic && $1"
}
status=0
say "./run.sh"
if inchroot ./run.sh > "$dir/run.log" 2>&1; then say "./run.sh passed"; else
    status=1; say "./run.sh FAILED"; tail -n 30 "$dir/run.log"; fi
say "./test.sh"
if inchroot ./test.sh > "$dir/test.log" 2>&1; then say "./test.sh passed"; else
    status=1; say "./test.sh FAILED"; tail -n 60 "$dir/test.log"; fi
grep -E '^# (TOTAL|PASS|SKIP|XFAIL|FAIL|XPASS|ERROR):' "$dir/test.log" || true
grep -h '^SKIP' "$root"/root/raytraffic/build/tests/*.log 2>/dev/null | sort | uniq -c || true
echo "installed: $(chroot "$root" dpkg-query -W -f '${Package}\n' | wc -l) packages"
exit $status
}
main "$@"
