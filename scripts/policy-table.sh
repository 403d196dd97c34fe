#!/bin/bash
# policy-table.sh -- DRAM traffic under LRU, SRRIP and OPT (Belady's MIN) for
# the recursive, packet, dynamic and treelet tracers on the paper's three
# scenes, and the gap of each policy to OPT (docs/results.md, "Replacement
# policies and Belady's floor").
#
# Usage: scripts/policy-table.sh BIN [--sizes LIST] [--hier-sizes LIST]
#                                [--scenes LIST] [-W N] [-H N] [--no-hier]
#
# Traces each scene with each tracer at W x H (default 256 x 256), primary
# rays only (lights none); recursive and packet on their default structure
# (kd), treelet on its default (bvh4). The dynamic and treelet tracers are
# scheduled per cache size (--cache-size S) and each schedule is simulated at
# its own size only, as the paper's Figures 4-6 do; recursive and packet
# traces are simulated at every size. Caches: fully associative, 64-byte
# lines, write-back write-allocate, one pass of `raytraffic sim --repl P`
# per trace and policy.
#
# Table 1 (--sizes, default 4K,16K,64K,1M): one level. Table 2
# (--hier-sizes, default 64K,1M,4M; --no-hier skips it): the same policies
# at a last level behind a CPU-like L1, `sim --hierarchy
# L1=32K/8/64/lru,LLC=S/full/64/P`; dynamic and treelet are scheduled for
# the last level's size S. Traffic in MB = 2^20 bytes; "x OPT" = the
# policy's total DRAM traffic / OPT's.
#
# After the tables, a check: OPT's misses (read + write misses of the last
# level) must not exceed LRU's or SRRIP's at any point, as Belady's MIN
# minimises misses; its traffic is compared too (MIN does not minimise
# write-backs, so a traffic excess with fewer misses is listed as a note,
# not a violation). Exit status 0 when there is no violation, 1 otherwise,
# 2 on a usage error.
#
# Output is deterministic (traces and simulations are); the wall time goes
# to stderr. Every command is run with its arguments as separate words.
set -u
usage() { echo "usage: $0 BIN [--sizes LIST] [--hier-sizes LIST] [--scenes LIST] [-W N] [-H N] [--no-hier]" >&2; exit 2; }
[ $# -ge 1 ] || usage
bin=$(readlink -f "$1") || usage
shift
sizes=4K,16K,64K,1M hsizes=64K,1M,4M scenes=room,grove,sphereflake W=256 H=256 hier=1
while [ $# -gt 0 ]; do
    case $1 in
    --sizes) [ $# -ge 2 ] || usage; sizes=$2; shift ;;
    --hier-sizes) [ $# -ge 2 ] || usage; hsizes=$2; shift ;;
    --scenes) [ $# -ge 2 ] || usage; scenes=$2; shift ;;
    -W) [ $# -ge 2 ] || usage; W=$2; shift ;;
    -H) [ $# -ge 2 ] || usage; H=$2; shift ;;
    --no-hier) hier=0 ;;
    *) usage ;;
    esac
    shift
done
[ -x "$bin" ] || { echo "$0: $bin is not an executable" >&2; exit 2; }
l1=L1=32K/8/64/lru
policies="lru srrip opt"
tracers="recursive packet dynamic treelet"
tmp=$(mktemp -d /tmp/rt-policy.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
start=$(date +%s)
IFS=, read -r -a slist <<< "$sizes"
IFS=, read -r -a hlist <<< "$hsizes"
IFS=, read -r -a sclist <<< "$scenes"
# the sizes any schedule is needed for, each once
all=$(printf '%s\n' "${slist[@]}" $([ $hier = 1 ] && printf '%s\n' "${hlist[@]}") | sort -u)

die() { echo "$0: $*" >&2; exit 1; }

# trace SCENE TRACER [SIZE]: writes $tmp/SCENE-TRACER[-SIZE].rtt once
trace() {
    local f=$tmp/$1-$2${3:+-$3}.rtt
    [ -f "$f" ] && return 0
    local extra=()
    [ -n "${3:-}" ] && extra=(--cache-size "$3")
    "$bin" trace "$1" -t "$2" -W "$W" -H "$H" --lights none "${extra[@]}" -o "$f" \
        > /dev/null 2> "$tmp/err" || die "trace $1 -t $2 ${3:-} failed: $(head -n 1 "$tmp/err")"
}

# sim KIND SCENE TRACER TRACEFILE POLICY SIZES: appends one line per size to
# $tmp/rows: KIND scene tracer size policy geometry ray other misses
# (bytes of the last level; misses = read + write misses of every class)
sim() {
    local kind=$1 scene=$2 tr=$3 f=$4 p=$5 sz=$6 args
    if [ "$kind" = flat ]; then
        args=(--repl "$p" --sizes "$sz")
    else
        args=(--hierarchy "$l1,LLC=$sz/full/64/$p")
    fi
    "$bin" sim "${args[@]}" --format csv --threads 1 "$f" > "$tmp/csv" 2> "$tmp/err" ||
        die "sim ${args[*]} ($scene $tr) failed: $(head -n 1 "$tmp/err")"
    # flat columns: trace,size,line,assoc,class,accesses,rm,wm,wb,wt,traffic;
    # hierarchy: trace,level,size,line,assoc,repl,class,...; the last level
    # only. The group rows geometry, ray, other close each size's block.
    awk -F, -v kind="$kind" -v scene="$scene" -v tr="$tr" -v p="$p" '
        NR == 1 { next }
        {
            if (kind == "hier") { if ($2 != "LLC") next; os = 1; o = 2 } else os = o = 0
            size = $(2 + os); cls = $(5 + o)
            if (!(size in seen)) { seen[size] = 1; order[++n] = size }
            if (cls == "geometry") { ingroup[size] = 1; g[size] = $(11 + o); next }
            if (ingroup[size] && cls == "ray") { r[size] = $(11 + o); next }
            if (ingroup[size] && cls == "other") { ot[size] = $(11 + o); next }
            m[size] += $(7 + o) + $(8 + o)
        }
        END { for (i = 1; i <= n; i++) { s = order[i]
            printf "%s %s %s %s %s %s %s %s %s\n", kind, scene, tr, s, p, g[s], r[s], ot[s], m[s] } }
    ' "$tmp/csv" >> "$tmp/rows"
}

: > "$tmp/rows"
for scene in "${sclist[@]}"; do
    for tr in $tracers; do
        case $tr in
        recursive|packet)
            trace "$scene" "$tr"
            for p in $policies; do
                sim flat "$scene" "$tr" "$tmp/$scene-$tr.rtt" "$p" "$sizes"
                if [ $hier = 1 ]; then
                    for s in "${hlist[@]}"; do sim hier "$scene" "$tr" "$tmp/$scene-$tr.rtt" "$p" "$s"; done
                fi
            done ;;
        *)
            for s in $all; do trace "$scene" "$tr" "$s"; done
            for p in $policies; do
                for s in "${slist[@]}"; do sim flat "$scene" "$tr" "$tmp/$scene-$tr-$s.rtt" "$p" "$s"; done
                if [ $hier = 1 ]; then
                    for s in "${hlist[@]}"; do sim hier "$scene" "$tr" "$tmp/$scene-$tr-$s.rtt" "$p" "$s"; done
                fi
            done ;;
        esac
        rm -f "$tmp/$scene-$tr"*.rtt
    done
done

# The tables: one row per scene, size, tracer; sizes ascending as given.
report() { # KIND TITLE SIZES...
    local kind=$1 title=$2
    shift 2
    echo "$title"
    echo
    echo "| scene | cache | tracer | geometry LRU | geometry SRRIP | geometry OPT | total LRU | total SRRIP | total OPT | LRU x OPT | SRRIP x OPT |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|"
    awk -v kind="$kind" -v scenes="$scenes" -v sizes="$*" -v tracers="$tracers" '
        function mb(b) { return sprintf("%.2f", b / 1048576) }
        function bytes(s,   n, u) { n = s + 0; u = substr(s, length(s))
            if (u == "K") n *= 1024; else if (u == "M") n *= 1048576; return n }
        $1 == kind { k = $2 SUBSEP $3 SUBSEP $4 SUBSEP $5
            geo[k] = $6; tot[k] = $6 + $7 + $8 }
        END {
            ns = split(scenes, sc, ","); nz = split(sizes, sz, " "); nt = split(tracers, tt, " ")
            for (a = 1; a <= ns; a++) for (b = 1; b <= nz; b++) for (c = 1; c <= nt; c++) {
                s = bytes(sz[b]); base = sc[a] SUBSEP tt[c] SUBSEP s SUBSEP
                lo = tot[base "opt"]
                printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", sc[a], sz[b], tt[c],
                    mb(geo[base "lru"]), mb(geo[base "srrip"]), mb(geo[base "opt"]),
                    mb(tot[base "lru"]), mb(tot[base "srrip"]), mb(lo),
                    sprintf("%.2f", tot[base "lru"] / lo), sprintf("%.2f", tot[base "srrip"] / lo)
            }
        }' "$tmp/rows"
    echo
}
report flat "One level (fully associative, 64-byte lines), ${W}x${H}, primary rays; MB:" "${slist[@]}"
[ $hier = 1 ] && report hier "Last level behind $l1 (LLC fully associative, 64-byte lines), ${W}x${H}, primary rays; MB:" "${hlist[@]}"

# OPT against the others at every point
awk '
    { k = $1 SUBSEP $2 SUBSEP $3 SUBSEP $4; miss[k, $5] = $9; tot[k, $5] = $6 + $7 + $8; keys[k] = 1 }
    END {
        bad = 0; notes = 0
        for (k in keys) { split(k, f, SUBSEP)
            for (q = 1; q <= 2; q++) { p = (q == 1) ? "lru" : "srrip"
                if (miss[k, "opt"] > miss[k, p]) {
                    printf "VIOLATION: %s %s %s at %s: OPT misses %d > %s misses %d\n", f[1], f[2], f[3], f[4], miss[k, "opt"], p, miss[k, p]
                    bad++
                } else if (tot[k, "opt"] > tot[k, p]) {
                    printf "note: %s %s %s at %s: OPT traffic %d > %s traffic %d with fewer misses (write-backs)\n", f[1], f[2], f[3], f[4], tot[k, "opt"], p, tot[k, p]
                    notes++
                } } }
        printf "Check: OPT misses <= LRU and SRRIP misses at every point: %s (%d violations, %d traffic notes)\n", bad ? "FAILED" : "ok", bad, notes
        exit bad ? 1 : 0
    }' "$tmp/rows" | LC_ALL=C sort
status=${PIPESTATUS[0]}
echo "wall time: $(( $(date +%s) - start )) s" >&2
exit "$status"
