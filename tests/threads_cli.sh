#!/bin/sh
# Host threads from the command line: render --threads N writes the image of
# one thread (the EXR's pixels byte for byte; only the command attribute
# differs); the dynamic tracer's modeled threads are --cores N (the run key
# keeps its version-1 spelling threads=N), and --threads for it, for trace
# and for sweep is a usage error saying so; bench --what threads compares
# the images itself.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt_threads_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }

for t in recursive packet treelet; do
    for n in 1 3; do
        "$bin" render cornell -W 24 -H 20 --lights all -t $t --threads $n -o "$tmp/$t$n.exr" --ppm "$tmp/$t$n.ppm" \
            --json >"$tmp/$t$n.json" 2>/dev/null || err "render -t $t --threads $n"
        sed 's/"kd_build_seconds.*//; s/"bvh4_build_seconds.*//' "$tmp/$t$n.json" >"$tmp/$t$n.stats"
    done
    cmp -s "$tmp/${t}1.ppm" "$tmp/${t}3.ppm" || err "$t: the PPM of 3 threads differs from one thread's"
    cmp -s "$tmp/${t}1.stats" "$tmp/${t}3.stats" || err "$t: the statistics of 3 threads differ: $(cat "$tmp/${t}3.stats")"
    # the EXRs differ only where the command line is stored: "--threads 1" / "3"
    # and the two file names ($t1.exr, $t1.ppm / $t3...)
    nd=$(cmp -l "$tmp/${t}1.exr" "$tmp/${t}3.exr" | wc -l)
    [ "$nd" -eq 3 ] || err "$t: the EXRs differ in $nd bytes, want 3 (in the command attribute)"
done

usage() { # expected-text command...
    want=$1; shift
    "$@" >/dev/null 2>"$tmp/u.log"
    st=$?
    [ "$st" = 2 ] && grep -q -- "$want" "$tmp/u.log" || err "'$*' exited $st, want 2 with '$want': $(cat "$tmp/u.log")"
    [ "$(wc -l <"$tmp/u.log")" -eq 1 ] || err "'$*': more than one line: $(cat "$tmp/u.log")"
}
usage "now --cores N" "$bin" render cornell -W 8 -H 8 -t dynamic --threads 2 -o "$tmp/d.exr"
usage "now --cores N" "$bin" trace cornell -W 8 -H 8 -t recursive --threads 2 -o "$tmp/d.rtt"
usage "now --cores N" "$bin" sweep --tracers dynamic --threads 8 --db "$tmp/u.db"
usage "--cores does not apply" "$bin" render cornell -W 8 -H 8 -t recursive --cores 2 -o "$tmp/d.exr"
usage "--threads does not apply" "$bin" render cornell -W 8 -H 8 -t stream-branching --threads 2 -o "$tmp/d.exr"
usage "--threads: '0'" "$bin" render cornell -W 8 -H 8 --threads 0 -o "$tmp/d.exr"

# --cores is the former --threads of the dynamic tracer: the same run key
"$bin" trace cornell -W 8 -H 8 -t dynamic --cores 2 -o "$tmp/d.rtt" >/dev/null 2>&1 || err "trace -t dynamic --cores 2"
"$bin" trace-info "$tmp/d.rtt" | grep -q "qorder=fullest threads=2" || err "trace-info: $("$bin" trace-info "$tmp/d.rtt" | grep -i params)"

"$bin" bench --what threads --scene cornell -W 32 -H 32 --threads 3 --reps 1 >"$tmp/b.txt" 2>&1 || err "bench --what threads: $(cat "$tmp/b.txt")"
[ "$(grep -c '| identical |' "$tmp/b.txt")" -eq 9 ] || err "bench --what threads: $(cat "$tmp/b.txt")"
grep -q "^| recursive | 3 |" "$tmp/b.txt" || err "bench: no three-thread row"

[ $fail = 0 ] && echo "PASS: threads_cli"
exit $fail
