#!/bin/sh
# Host threads from the command line: render --threads N writes the image of
# one thread (the EXR's pixels byte for byte; only the command attribute
# differs; the dynamic tracer: its N-core rounds on N threads, the same
# image); the dynamic tracer's modeled threads are --cores N (the run key
# keeps its version-1 spelling threads=N), and --threads for trace and for
# sweep is a usage error saying so; bench --what threads compares the
# images itself.
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
# the dynamic tracer: its N-core rounds on N host threads, one thread's image
for n in 1 3; do
    "$bin" render cornell -W 24 -H 20 --lights all -t dynamic --threads $n -o "$tmp/dyn$n.exr" --ppm "$tmp/dyn$n.ppm" \
        --json >"$tmp/dyn$n.json" 2>/dev/null || err "render -t dynamic --threads $n"
done
cmp -s "$tmp/dyn1.ppm" "$tmp/dyn3.ppm" || err "dynamic: the PPM of 3 threads differs from one thread's"
[ "$(cmp -l "$tmp/dyn1.exr" "$tmp/dyn3.exr" | wc -l)" -eq 3 ] || err "dynamic: the EXRs differ beyond the command"
grep -q "cores=3 rounds=" "$tmp/dyn3.json" || err "dynamic --threads 3: not the 3-core rounds: $(cat "$tmp/dyn3.json")"
usage "whitted and path modes on one thread" "$bin" render cornell -W 8 -H 8 -t dynamic --mode whitted --threads 2 -o "$tmp/d.exr"
usage "now --cores N" "$bin" trace cornell -W 8 -H 8 -t recursive --threads 2 -o "$tmp/d.rtt"
usage "now --cores N" "$bin" sweep --tracers dynamic --threads 8 --db "$tmp/u.db"
# every tracer splits its work over simulated cores (stream-branching: its pixels in chunks, one phase)
"$bin" render cornell -W 8 -H 8 -t stream-branching --cores 2 -o "$tmp/d.exr" 2>"$tmp/c.log" \
    && grep -q " cores=2 barriers=1$" "$tmp/c.log" || err "render -t stream-branching --cores 2: $(cat "$tmp/c.log")"
usage "--threads does not apply" "$bin" render cornell -W 8 -H 8 -t stream-branching --threads 2 -o "$tmp/d.exr"
usage "--threads: '0'" "$bin" render cornell -W 8 -H 8 --threads 0 -o "$tmp/d.exr"

# --cores is the former --threads of the dynamic tracer: the same run key
"$bin" trace cornell -W 8 -H 8 -t dynamic --cores 2 -o "$tmp/d.rtt" >/dev/null 2>&1 || err "trace -t dynamic --cores 2"
"$bin" trace-info "$tmp/d.rtt" | grep -q "qorder=fullest threads=2" || err "trace-info: $("$bin" trace-info "$tmp/d.rtt" | grep -i params)"

"$bin" bench --what threads --scene cornell -W 32 -H 32 --threads 3 --reps 1 >"$tmp/b.txt" 2>&1 || err "bench --what threads: $(cat "$tmp/b.txt")"
[ "$(grep -c '| identical |' "$tmp/b.txt")" -eq 9 ] || err "bench --what threads: $(cat "$tmp/b.txt")"
grep -q "^| recursive | 3 |" "$tmp/b.txt" || err "bench: no three-thread row"

# simulated cores: trace --cores 1 is the one-core trace; --cores 4 a
# version-4 trace whose cores' references add up to it; trace-dump --core
"$bin" trace cornell -W 16 -H 16 --lights all -o "$tmp/c.rtt" 2>/dev/null || err "trace"
"$bin" trace cornell -W 16 -H 16 --lights all --cores 1 -o "$tmp/c1.rtt" 2>/dev/null || err "trace --cores 1"
"$bin" trace cornell -W 16 -H 16 --lights all --cores 4 -o "$tmp/c4.rtt" 2>/dev/null || err "trace --cores 4"
"$bin" trace-dump "$tmp/c.rtt" >"$tmp/c.txt" && "$bin" trace-dump "$tmp/c1.rtt" >"$tmp/c1.txt" || err "trace-dump"
cmp -s "$tmp/c.txt" "$tmp/c1.txt" || err "--cores 1 changed the references"
"$bin" trace-info "$tmp/c1.rtt" | grep -q "^format: *rtt version 3" || err "--cores 1 is not a version-3 trace"
"$bin" trace-info "$tmp/c4.rtt" >"$tmp/i4.txt" || err "trace-info of a version-4 trace"
grep -q "^format: *rtt version 4" "$tmp/i4.txt" && grep -q "^cores: *4 simulated cores" "$tmp/i4.txt" \
    || err "trace-info: $(cat "$tmp/i4.txt")"
"$bin" trace-info "$tmp/c.rtt" | grep -q "^cores:" && err "trace-info shows cores for a one-core trace"
"$bin" trace-info --json "$tmp/c4.rtt" | grep -q '"cores": 4' || err "trace-info --json: no cores"
total=0
for k in 0 1 2 3; do
    "$bin" trace-dump "$tmp/c4.rtt" --core $k --din >"$tmp/d$k.din" || err "trace-dump --core $k"
    lines=$("$bin" trace-dump "$tmp/c4.rtt" --core $k | wc -l)
    [ "$lines" -gt 0 ] || err "core $k made no references"
    total=$((total + lines))
done
[ "$total" -eq "$(wc -l <"$tmp/c.txt")" ] || err "the cores' references add up to $total, one core made $(wc -l <"$tmp/c.txt")"
# the interleave: every line tagged; a core's run is whole ticks of 16
# references, except its last, after which it never comes back
"$bin" trace-dump "$tmp/c4.rtt" | awk '
    function endrun() { if (run % 16) { if (ended[prev]) bad++; ended[prev] = 1 } else if (ended[prev]) bad++ }
    { if ($5 != "core") bad++; if (NR > 1 && $6 != prev) { endrun(); run = 0 } run++; prev = $6 }
    END { endrun(); exit bad ? 1 : 0 }' || err "interleave not in ticks of 16 references"
"$bin" trace-dump "$tmp/c.rtt" --core 1 >/dev/null 2>"$tmp/u.log"; [ $? = 2 ] || err "--core 1 of a one-core trace"
grep -q "holds 1 core" "$tmp/u.log" || err "--core 1 message: $(cat "$tmp/u.log")"

[ $fail = 0 ] && echo "PASS: threads_cli"
exit $fail
