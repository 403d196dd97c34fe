#!/bin/sh
# scripts/policy-table.sh on a small case (room, 32x32): its tables have a
# row per size and tracer, a value equals the one `raytraffic sim` prints
# for the same trace (summed here from the text output, not the script's
# CSV path), the OPT check passes, and a usage error exits 2.
set -u
bin=${RT_BIN:-./raytraffic}
src=${RT_SRCDIR:-.}
tmp=$(mktemp -d /tmp/rt_policy_table.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }

"$src/scripts/policy-table.sh" "$bin" --scenes room -W 32 -H 32 --sizes 4K,64K --hier-sizes 64K \
    > "$tmp/out" 2> "$tmp/err" || die "script exit $? ($(head -n 1 "$tmp/err"))"
grep -q '^Check: OPT misses <= LRU and SRRIP misses at every point: ok (0 violations' "$tmp/out" || die "no passing check line"
grep -q '^wall time: [0-9]* s$' "$tmp/err" || die "no wall time on stderr"
[ "$(grep -c '^| room | ' "$tmp/out")" -eq 12 ] || die "expected 8 + 4 table rows"

# mb BYTES: as the script prints them
mb() { awk -v b="$1" 'BEGIN { printf "%.2f", b / 1048576 }'; }
# total TRACE ARGS...: geometry + ray + other group traffic of `sim` text output
# (the group rows are the last three of the size's block)
total() {
    f=$1; shift
    "$bin" sim "$@" --threads 1 "$f" | awk '/^#/ || $1 == "size_bytes" { next } { t[NR] = $NF; n = NR }
        END { print t[n] + t[n - 1] + t[n - 2] }'
}
"$bin" trace room -t recursive -W 32 -H 32 --lights none -o "$tmp/r.rtt" > /dev/null 2>&1 || die "trace recursive"
"$bin" trace room -t dynamic --cache-size 4K -W 32 -H 32 --lights none -o "$tmp/d.rtt" > /dev/null 2>&1 || die "trace dynamic"
ropt=$(mb "$(total "$tmp/r.rtt" --repl opt --sizes 4K)")
rlru=$(mb "$(total "$tmp/r.rtt" --repl lru --sizes 4K)")
dsr=$(mb "$(total "$tmp/d.rtt" --repl srrip --sizes 4K)")
hopt=$(mb "$(total "$tmp/r.rtt" --hierarchy L1=32K/8/64/lru,LLC=64K/full/64/opt)")
# fields split at ' | ': 1 '| scene', 2 cache, 3 tracer, 4-6 geometry LRU SRRIP OPT,
# 7-9 total LRU SRRIP OPT
row=$(grep '^| room | 4K | recursive |' "$tmp/out" | head -n 1)
[ "$(echo "$row" | awk -F' [|] ' '{ print $9 }')" = "$ropt" ] || die "recursive 4K OPT: table '$row', sim $ropt"
[ "$(echo "$row" | awk -F' [|] ' '{ print $7 }')" = "$rlru" ] || die "recursive 4K LRU: table '$row', sim $rlru"
row=$(grep '^| room | 4K | dynamic |' "$tmp/out")
[ "$(echo "$row" | awk -F' [|] ' '{ print $8 }')" = "$dsr" ] || die "dynamic 4K SRRIP: table '$row', sim $dsr"
row=$(sed -n '/^Last level behind/,$p' "$tmp/out" | grep '^| room | 64K | recursive |')
[ "$(echo "$row" | awk -F' [|] ' '{ print $9 }')" = "$hopt" ] || die "behind L1, recursive 64K OPT: table '$row', sim $hopt"

"$src/scripts/policy-table.sh" "$bin" --bogus > /dev/null 2>&1
[ $? -eq 2 ] || die "usage error not exit 2"
exit $fail
