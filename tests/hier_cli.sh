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

# a trace with ray generations: per-level rows per generation too, summing
# to the level's rows over all generations
"$bin" sim "$tmp/t.rtt" --db "$tmp/gen.db" --hierarchy L1=4K/2/64/lru,LLC=64K/full/64/lru 2>/dev/null || die "sim --db generations"
[ "$(sqlite3 "$tmp/gen.db" "select count(distinct gen) from level_traffic where gen >= 0")" -ge 3 ] || die "level rows per generation"
[ "$(sqlite3 "$tmp/gen.db" "select count(*) from (select level, cache_size, class, sum(case when gen < 0 then accesses else -accesses end) d, sum(case when gen < 0 then misses else -misses end) m from level_traffic group by 1, 2, 3) where d <> 0 or m <> 0")" = 0 ] || die "generations do not sum to the level rows"

# the in-process sweep: runs keyed by their spec and policy, per-level rows;
# the LLC's rows are the run's traffic and equal the same hierarchy on the
# job's kept trace through `sim`
"$bin" sweep --scenes cornell --tracers recursive -W 24 -H 24 --lights primary --db "$tmp/s.db" --keep-traces "$tmp" \
    --hierarchy L1=2K/4/64/lru,LLC=1K-16K/full/64/lru >/dev/null 2>&1 || die "sweep --hierarchy"
[ "$(sqlite3 "$tmp/s.db" "select hierarchy from runs")" = "L1=2K/4/64/lru,LLC=1K-16K/full/64/lru" ] || die "sweep: stored spec"
[ "$(sqlite3 "$tmp/s.db" "select count(distinct cache_size) from level_traffic where level = 2")" = 5 ] || die "sweep: LLC level rows"
kept=$(ls "$tmp"/job*.rtt | head -1)
"$bin" sim "$kept" --hierarchy L1=2K/4/64/lru,LLC=1K-16K/full/64/lru --format csv > "$tmp/k.csv" || die "sim of the kept trace"
want=$(grep ',LLC,16384,' "$tmp/k.csv" | tail -3 | awk -F, '{s += $13} END {print s}') # the three group rows
got=$(sqlite3 "$tmp/s.db" "select sum(t.traffic_bytes) from traffic t join cache_configs c on c.id = t.config_id where c.size = 16384")
[ -n "$want" ] && [ "$want" = "$got" ] || die "sweep LLC traffic $got, sim of its trace $want"
"$bin" sweep --scenes cornell --tracers recursive -W 24 -H 24 --lights primary --db "$tmp/s.db" --repl fifo --sizes 1K-4K \
    >/dev/null 2>&1 || die "sweep --repl"
[ "$(sqlite3 "$tmp/s.db" "select count(*) from runs where repl = 'fifo' and hierarchy = ''")" = 1 ] || die "sweep: fifo run"
"$bin" sweep --scenes cornell --tracers recursive --hierarchy LLC=1K/full/64/lru --line 32 --db "$tmp/x.db" >/dev/null 2>&1
[ $? -eq 2 ] || die "sweep --line with --hierarchy must be a usage error"
"$bin" sweep --scenes cornell --tracers recursive --repl fifo --approx shards --db "$tmp/x.db" >/dev/null 2>&1
[ $? -eq 2 ] || die "sweep --repl with --approx must be a usage error"

# the presets name their hierarchies
"$bin" sweep --preset gpu --scenes cornell --tracers recursive --lights primary -W 16 -H 16 --db "$tmp/g.db" >/dev/null 2>&1 || die "--preset gpu"
[ "$(sqlite3 "$tmp/g.db" "select hierarchy from runs")" = "L1=128K/4/128/lru,L2=1M+2M+4M+6M/16/128/lru" ] || die "gpu preset spec"
"$bin" sweep --preset cpu --scenes cornell --tracers recursive --lights primary -W 16 -H 16 --db "$tmp/c.db" >/dev/null 2>&1 || die "--preset cpu"
[ "$(sqlite3 "$tmp/c.db" "select hierarchy from runs")" = "L1=32K/8/64/lru,L2=1M/16/64/lru,LLC=1K-4M/full/64/lru" ] || die "cpu preset spec"

# report --figure hierarchy: the levels of the hierarchy run, and the
# policies against OPT for the runs that differ only in their policy
for p in lru opt; do
    "$bin" sweep --scenes cornell --tracers recursive -W 24 -H 24 --lights primary --db "$tmp/s.db" --repl $p --sizes 1K-4K \
        >/dev/null 2>&1 || die "sweep --repl $p"
done
"$bin" report --db "$tmp/s.db" --figure hierarchy > "$tmp/rep.md" || die "report --figure hierarchy exit"
grep -q '^### cornell, recursive, 24x24, lights none, run 1: L1=2K/4/64/lru,LLC=1K-16K/full/64/lru (non-inclusive)$' "$tmp/rep.md" || die "report: hierarchy heading"
[ "$(grep -c '^| LLC | ' "$tmp/rep.md")" = 5 ] || die "report: LLC rows"
grep -q '^| size | lru KB | fifo KB | opt KB | LRU gap to OPT |$' "$tmp/rep.md" || die "report: policy header"
# the gap is computed from the stored totals
lru=$(sqlite3 "$tmp/s.db" "select total(t.traffic_bytes) from traffic t join runs r on r.id = t.run_id join cache_configs c on c.id = t.config_id where r.repl = 'lru' and r.hierarchy = '' and c.size = 1024")
opt=$(sqlite3 "$tmp/s.db" "select total(t.traffic_bytes) from traffic t join runs r on r.id = t.run_id join cache_configs c on c.id = t.config_id where r.repl = 'opt' and c.size = 1024")
gap=$(awk -v l="$lru" -v o="$opt" 'BEGIN {printf "%.1f%%", 100 * (l / o - 1)}')
grep -q "^| 1024 | .* | $gap |\$" "$tmp/rep.md" || die "report: gap $gap at 1K: $(grep '^| 1024' "$tmp/rep.md")"
"$bin" report --db "$tmp/x.db" --figure hierarchy >/dev/null 2>&1; [ $? -eq 1 ] || die "report --figure hierarchy without runs must exit 1"

# trace --sim: the tables `sim` prints for the trace written, for one level,
# a --repl and a two-level hierarchy (byte for byte, the trace named the same)
n=0
for o in "--sizes 1K-8K" "--repl srrip --assoc 4 --sizes 2K,8K" "--hierarchy L1=1K/2/64/lru,LLC=1K-8K/full/64/fifo"; do
    n=$((n + 1))
    # shellcheck disable=SC2086
    "$bin" trace cornell -W 16 -H 16 --lights 0 -o "$tmp/ts$n.rtt" --sim $o > "$tmp/ts$n.out" 2>/dev/null || die "trace --sim $o"
    # shellcheck disable=SC2086
    "$bin" sim "$tmp/ts$n.rtt" $o > "$tmp/ts$n.want" || die "sim $o"
    [ -s "$tmp/ts$n.want" ] && cmp -s "$tmp/ts$n.out" "$tmp/ts$n.want" || die "trace --sim $o differs from sim of its trace"
done
grep -q '^L1 ' "$tmp/ts3.out" && grep -q '^LLC  *8192 .* fifo ' "$tmp/ts3.out" || die "trace --sim --hierarchy: level rows"
"$bin" trace cornell -W 16 -H 16 -o "$tmp/ts9.rtt" --repl fifo >/dev/null 2>&1
[ $? -eq 2 ] || die "trace --repl without --sim must be a usage error"
"$bin" trace cornell -W 16 -H 16 -o "$tmp/ts9.rtt" --sim --hierarchy L1=1K/2/64/bogus >/dev/null 2>&1
[ $? -eq 2 ] && [ ! -e "$tmp/ts9.rtt" ] || die "trace --sim with a bad hierarchy must be a usage error before tracing"

# inclusion: inclusive and exclusive hierarchies print back-invalidations;
# an inclusive one whose last level never evicts has the non-inclusive L1
"$bin" sim "$tmp/t.rtt" --hierarchy L1=4K/2/64/lru,LLC=8K-16K/full/64/lru,inclusive --format csv > "$tmp/inc.csv" || die "inclusive exit"
head -1 "$tmp/inc.csv" | grep -q ',last_level_size,.*,backinvals,bi_writebacks$' || die "inclusive csv header"
[ "$(awk -F, '$2 == "L1" && $3 == 8192 {s += $15} END {print s + 0}' "$tmp/inc.csv")" -gt 0 ] || die "inclusive: no back-invalidation at 8K"
"$bin" sim "$tmp/t.rtt" --hierarchy L1=4K/2/64/lru,LLC=64M/full/64/lru,inclusive --format csv > "$tmp/incbig.csv" || die "inclusive 64M exit"
"$bin" sim "$tmp/t.rtt" --hierarchy L1=4K/2/64/lru,LLC=64M/full/64/lru --format csv > "$tmp/ninebig.csv" || die "nine 64M exit"
# (class columns of both; the non-inclusive rows list the classes before the groups)
a=$(awk -F, '$2 == "L1" {print $8, $9, $10, $11, $12, $14, $15}' "$tmp/incbig.csv")
b=$(awk -F, '$2 == "L1" {print $7, $8, $9, $10, $11, $13, 0}' "$tmp/ninebig.csv" | head -n "$(echo "$a" | wc -l)")
[ -n "$a" ] && [ "$a" = "$b" ] || die "inclusive without evictions differs from non-inclusive: $a / $b"
"$bin" sim "$tmp/t.rtt" --hierarchy L1=4K/2/64/lru,LLC=8K/full/64/lru,exclusive > "$tmp/exc.txt" || die "exclusive exit"
grep -q '^# .*hierarchy L1=4K/2/64/lru,LLC=8K/full/64/lru,exclusive, .*, exclusive$' "$tmp/exc.txt" || die "exclusive heading"
# stored: sim --db keeps every chain's level rows (last_size, back-
# invalidations) as sim prints them, and the last level's as the traffic
for inc in inclusive exclusive; do
    spec="L1=4K/2/64/plru,LLC=8K+16K/full/64/srrip,$inc"
    "$bin" sim "$tmp/t.rtt" --hierarchy "$spec" --format csv > "$tmp/$inc.csv" || die "$inc csv"
    "$bin" sim "$tmp/t.rtt" --hierarchy "$spec" --db "$tmp/$inc.db" 2>/dev/null || die "$inc --db"
    [ "$(sqlite3 "$tmp/$inc.db" "select hierarchy from runs")" = "$spec" ] || die "$inc: stored spec"
    want=$(awk -F, 'NR > 1 {print $2, $3, $4, $8, $9, $10, $11, $12, $14, $15, $16}' "$tmp/$inc.csv" | sort)
    got=$(sqlite3 -separator ' ' "$tmp/$inc.db" "select level_name, last_size, cache_size, class, accesses, misses, 0, writebacks, traffic_bytes, backinvals, bi_writebacks from level_traffic" | sort)
    # sim's csv has read and write misses apart: compare their sum
    want=$(echo "$want" | awk '{print $1, $2, $3, $4, $5, $6 + $7, 0, $8, $9, $10, $11}' | sort)
    [ -n "$got" ] && [ "$got" = "$want" ] || die "$inc: level rows differ from sim's: $(echo "$got" | head -2) / $(echo "$want" | head -2)"
    a=$(awk -F, '$2 == "LLC" {s[$3] += $14} END {for (k in s) print k, s[k]}' "$tmp/$inc.csv" | sort)
    b=$(sqlite3 -separator ' ' "$tmp/$inc.db" "select c.size, sum(t.traffic_bytes) from traffic t join cache_configs c on c.id = t.config_id group by 1" | sort)
    [ -n "$a" ] && [ "$a" = "$b" ] || die "$inc: traffic rows $b, the LLC's $a"
done
[ "$(sqlite3 "$tmp/inclusive.db" "select sum(backinvals) > 0 and count(distinct last_size) = 2 from level_traffic where level = 1")" = 1 ] || die "inclusive: L1 rows per chain"
[ "$(sqlite3 "$tmp/inclusive.db" "select distinct inclusion from v_level")" = inclusive ] || die "v_level: inclusion"
"$bin" sim "$tmp/t.rtt" --hierarchy L1=4K/2/64/lru,LLC=8K/full/64/opt,inclusive >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] && grep -q 'level LLC: inclusive needs a per-size policy' "$tmp/err" || die "inclusive opt must be refused"
"$bin" sim "$tmp/t.rtt" --hierarchy L1=4K/2/64/lru,LLC=8K/full/64/lru,inclusiv >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] && grep -q "'inclusiv'" "$tmp/err" || die "a misspelt inclusion must be a usage error naming it"
# the sweep stores an inclusive hierarchy as sim does on the job's trace,
# and the report names the inclusion, per last-level size
spec=L1=1K/full/64/fifo,LLC=2K+4K/full/64/lru,inclusive
mkdir -p "$tmp/si"; "$bin" sweep --scenes cornell --tracers recursive -W 16 -H 16 --lights primary --db "$tmp/si.db" --keep-traces "$tmp/si" \
    --hierarchy "$spec" >/dev/null 2>&1 || die "sweep --hierarchy inclusive"
[ "$(sqlite3 "$tmp/si.db" "select hierarchy from runs")" = "$spec" ] || die "sweep inclusive: stored spec"
"$bin" sim "$(ls "$tmp"/si/job*.rtt | head -1)" --hierarchy "$spec" --db "$tmp/si2.db" 2>/dev/null || die "sim of the kept trace"
q="select level, last_size, class, accesses, misses, writebacks, traffic_bytes, backinvals, bi_writebacks from level_traffic order by 1, 2, 3"
[ "$(sqlite3 "$tmp/si.db" "$q")" = "$(sqlite3 "$tmp/si2.db" "$q")" ] && [ -n "$(sqlite3 "$tmp/si.db" "$q")" ] || die "sweep inclusive rows differ from sim's"
"$bin" report --db "$tmp/si.db" --figure hierarchy > "$tmp/repi.md" || die "report inclusive"
grep -q "^### cornell, recursive, 16x16, lights none, run 1: $spec (inclusive)\$" "$tmp/repi.md" || die "report: inclusive heading"
grep -q '^| last-level size | level | .* | back-invalidations | their write-backs |$' "$tmp/repi.md" || die "report: inclusive header"
bi=$(sqlite3 "$tmp/si.db" "select sum(backinvals) from level_traffic where level = 1 and last_size = 2048")
grep -q "^| 2048 | L1 | 1024 | .* | $bi | [0-9]* |\$" "$tmp/repi.md" || die "report: L1 row of the 2K chain ($bi back-invalidations)"

exit $fail
