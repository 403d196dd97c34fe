#!/bin/sh
# Cache hierarchies and replacement policies against Dinero IV (d4-7).
# The numbers below were printed by Dinero IV version 7 (dineroIV built
# from d4-7.tar.gz, unified caches, -informat d, its defaults otherwise:
# write-back, write-allocate, demand fetch, the end-of-run flush) on the din
# trace this script makes; `raytraffic sim` must print the same misses and
# bytes with --flush --write-fullline (Dinero's accounting, docs/cachesim.md
# "Agreement with Dinero IV"). The din trace is 1-byte references, so
# --write-fullline matters only below the first level, where write-backs
# are whole-line writes.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt_hier_cli.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }

"$bin" trace cornell -t recursive --mode whitted --lights all -W 48 -H 48 -o "$tmp/t.rtt" >/dev/null 2>&1 || die "trace"
"$bin" trace-dump "$tmp/t.rtt" --din > "$tmp/t.din" || die "trace-dump --din"
[ "$(wc -l < "$tmp/t.din")" -eq 315931 ] || die "din trace has $(wc -l < "$tmp/t.din") records, Dinero saw 315931"

# row LEVEL SIZE LINE ASSOC REPL ACCESSES READ_MISSES WRITE_MISSES WRITEBACKS TRAFFIC: the 'other'
# group row (din records are class fb) of a hierarchy output
row() {
    f=$1; shift
    grep -E "^$1 +$2 +$3 +$4 +$5 +other +$6 +$7 +$8 +$9 +0 +${10}\$" "$f" >/dev/null || { die "row $*"; grep other "$f"; }
}

# FIFO, one level: dineroIV -l1-usize 16k -l1-ubsize 64 -l1-uassoc 4 -l1-urepl f
#   demand misses 6991 (read 6501, write 490), bytes from memory 447424, to memory 31360
"$bin" sim "$tmp/t.din" --sizes 16K --assoc 4 --repl fifo --flush --format csv > "$tmp/fifo.csv" || die "fifo exit"
grep -q '^[^,]*,16384,64,4,other,315931,6501,490,490,0,478784$' "$tmp/fifo.csv" || { die "fifo vs Dinero"; tail -1 "$tmp/fifo.csv"; }

# two levels: -l1-usize 4k -l1-ubsize 64 -l1-uassoc 2 -l2-usize 32k -l2-ubsize 64 -l2-uassoc 8
#   l1: misses 26633 (25697 + 936), from 1704512, to 59904
#   l2: fetches 27569, misses 2721 (read), from 174144, to 28032
"$bin" sim "$tmp/t.din" --hierarchy L1=4K/2/64/lru,L2=32K/8/64/lru --flush --write-fullline > "$tmp/h2.txt" || die "h2 exit"
row "$tmp/h2.txt" L1 4096 64 2 lru 315931 25697 936 936 1764416
row "$tmp/h2.txt" L2 32768 64 8 lru 27569 2721 0 438 202176

# three levels, three line sizes, FIFO in the middle:
#   -l1-usize 4k -l1-ubsize 32 -l1-uassoc 2 -l2-usize 16k -l2-ubsize 64 -l2-uassoc 4 -l2-urepl f
#   -l3-usize 128k -l3-ubsize 128 -l3-uassoc 8
#   l1: misses 22634 (21496 + 1138), from 724288, to 36416
#   l2: fetches 23772, misses 6505 (6480 + 25), from 416320, to 32000
#   l3: fetches 7005, misses 1151, from 147328, to 27776
"$bin" sim "$tmp/t.din" --hierarchy L1=4K/2/32/lru,L2=16K/4/64/fifo,L3=128K/8/128/lru --flush --write-fullline \
    > "$tmp/h3.txt" || die "h3 exit"
row "$tmp/h3.txt" L1 4096 32 2 lru 315931 21496 1138 1138 760704
row "$tmp/h3.txt" L2 16384 64 4 fifo 23772 6480 25 500 448320
row "$tmp/h3.txt" L3 131072 128 8 lru 7005 1151 0 217 175104

exit $fail
