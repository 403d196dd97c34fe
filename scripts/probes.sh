#!/bin/bash
# probes.sh -- the reliability probes of docs/reliability.md, re-runnable.
#
# Usage: scripts/probes.sh BIN [--quick] [--san SANBIN]
#
# Feeds the built binary BIN hostile inputs and hostile conditions and prints
# one Markdown table row per probe: inputs tried, crashes (exit >= 128 or a
# sanitizer report), hangs (over the probe's time limit), silent acceptances
# (a wrong input accepted with exit 0, or a wrong result reported as
# success), rows lost and rows duplicated (database probes), and other
# failures (a valid input refused, a wrong exit status, a message without
# the byte offset, line or option it must name). Details of every failure
# follow the table. Exit status 0 when every count is 0, 1 otherwise.
#
# RT_PROBES_KNOWN=FILE names known defects, one fixed string a line matched
# against a failing input's description: they are counted and listed like
# the others but do not make the exit status 1 (tests/probes.sh uses
# tests/probes/known-defects).
# --quick samples each probe (a few hundred inputs in all, under a minute:
# the size `make check-long` runs); the full run is what docs/reliability.md
# quotes. --san SANBIN runs the reader probes (1-3) with a sanitizer build
# (`configure --enable-sanitizers`) instead of BIN.
#
# Needs only BIN, coreutils, sqlite3 and python3 (to write mutated files).
# File names never reach a shell: every command is run with its arguments
# as separate words.
set -u
usage() { echo "usage: $0 BIN [--quick] [--san SANBIN]" >&2; exit 2; }
[ $# -ge 1 ] || usage
bin=$(readlink -f "$1") || usage
shift
quick=0 san=
while [ $# -gt 0 ]; do
    case $1 in
    --quick) quick=1 ;;
    --san) [ $# -ge 2 ] || usage; san=$(readlink -f "$2"); shift ;;
    *) usage ;;
    esac
    shift
done
[ -x "$bin" ] || { echo "$0: $bin is not an executable" >&2; exit 2; }
rbin=${san:-$bin} # the binary for the reader probes
src=$(cd "$(dirname "$0")/.." && pwd)
meshes=$src/data/meshes
tmp=$(mktemp -d /tmp/rt-probes.XXXXXX) || exit 1
bgpids=""
cleanup() {
    for p in $bgpids; do kill -KILL "$p" 2>/dev/null; done
    rm -rf "$tmp"
}
trap cleanup EXIT
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
start=$(date +%s)
notes=$tmp/notes
: > "$notes"
# at most $RT_PROBES_NOTES (default 5) notes per probe, then a count
maxnotes=${RT_PROBES_NOTES:-5}
known=${RT_PROBES_KNOWN:+$(readlink -f "$RT_PROBES_KNOWN")}
note() {
    nn=$((nn + 1))
    if [ -n "$known" ] && grep -qF -f "$known" <<< "$what"; then nknown=$((nknown + 1)); set -- "(known defect) $*"; fi
    if [ $nn -le "$maxnotes" ]; then echo "- probe $probe: $*" >> "$notes"; fi
}
status=0
row() { # name inputs crashes hangs silent lost dup other
    printf '| %s | %s | %s | %s | %s | %s | %s | %s |\n' "$@"
    if [ "$nn" -gt "$maxnotes" ]; then echo "- probe $probe: ... $((nn - maxnotes)) more" >> "$notes"; fi
    local sum=0 v
    for v in "$3" "$4" "$5" "$6" "$7" "$8"; do [ "$v" = - ] || sum=$((sum + v)); done
    [ $sum -le $nknown ] || status=1
}
begin() { probe=$1 n=0 crash=0 hang=0 silent=0 lost=0 dup=0 other=0 nn=0 nknown=0; }
# alive PID: the process exists and is not a zombie (an orphan killed by
# its parent's death may wait a while for init to reap it)
alive() { local s; s=$(ps -o stat= -p "$1" 2>/dev/null); [ -n "$s" ] && [ "${s#Z}" = "$s" ]; }

# run LIMIT CMD...: runs CMD with stdout in $tmp/out and stderr in $tmp/err;
# sets rc and kind = ok | refused | crash | hang | other.
run() {
    local limit=$1
    shift
    timeout -k 2 "$limit" "$@" > "$tmp/out" 2> "$tmp/err"
    rc=$?
    if [ $rc = 124 ] || [ $rc = 137 ]; then kind=hang
    elif [ $rc -ge 128 ] || grep -q 'Sanitizer\|runtime error:' "$tmp/err"; then kind=crash
    elif [ $rc = 0 ]; then kind=ok
    elif [ $rc = 1 ]; then kind=refused
    else kind=other; fi
}
# count the outcome of one input that must be refused; $1 = regex the
# message must match
must_refuse() {
    n=$((n + 1))
    case $kind in
    crash) crash=$((crash + 1)); note "$what: crash (exit $rc) $(head -c 300 "$tmp/err")" ;;
    hang) hang=$((hang + 1)); note "$what: no answer within the limit" ;;
    ok) silent=$((silent + 1)); note "$what: accepted (exit 0)" ;;
    refused) grep -Eq -- "$1" "$tmp/err" || { other=$((other + 1)); note "$what: message '$(head -c 200 "$tmp/err")' does not match '$1'"; } ;;
    *) other=$((other + 1)); note "$what: exit $rc: $(head -c 200 "$tmp/err")" ;;
    esac
}
must_accept() {
    n=$((n + 1))
    case $kind in
    crash) crash=$((crash + 1)); note "$what: crash (exit $rc) $(head -c 300 "$tmp/err")" ;;
    hang) hang=$((hang + 1)); note "$what: no answer within the limit" ;;
    ok) ;;
    *) other=$((other + 1)); note "$what: valid input refused (exit $rc): $(head -c 200 "$tmp/err")" ;;
    esac
}

echo "| probe | inputs tried | crashes | hangs | silent acceptances | rows lost | rows duplicated | other failures |"
echo "|---|---|---|---|---|---|---|---|"

# ---- 1. trace reader: truncations and bit flips --------------------------------
begin 1
mkdir "$tmp/p1"
"$bin" trace cornell -W 4 -H 4 -o "$tmp/p1/a.rtt" 2>/dev/null &&
    "$bin" trace knot -W 6 -H 6 --lights all -o "$tmp/p1/b.rtt" 2>/dev/null &&
    "$bin" trace cornell -t dynamic --cache-size 4K -W 8 -H 8 --lights 0 -o "$tmp/p1/c.rtt" 2>/dev/null ||
    { echo "$0: cannot write the probe traces" >&2; exit 1; }
if [ $quick = 1 ]; then step=61 nflip=150; else step=1 nflip=5000; fi
for t in a b c; do
    f=$tmp/p1/$t.rtt
    size=$(stat -c %s "$f")
    len=0
    while [ $len -lt "$size" ]; do
        head -c $len "$f" > "$tmp/p1/cut.rtt"
        what="$t.rtt cut to $len bytes"
        run 10 "$rbin" trace-info "$tmp/p1/cut.rtt"
        must_refuse 'byte [0-9]+'
        len=$((len + step))
    done
done
# flips: python writes them all, named T.OFFSET.BIT.rtt
python3 - "$tmp/p1" "$nflip" <<'EOF' || exit 1
import os, random, sys
d, n = sys.argv[1], int(sys.argv[2])
rng = random.Random(20240601)
src = {t: open(os.path.join(d, t + ".rtt"), "rb").read() for t in "abc"}
os.mkdir(os.path.join(d, "flip"))
for i in range(n):
    t = "abc"[i % 3]
    b = bytearray(src[t])
    off, bit = rng.randrange(len(b)), rng.randrange(8)
    b[off] ^= 1 << bit
    open(os.path.join(d, "flip", "%s.%d.%d.rtt" % (t, off, bit)), "wb").write(b)
EOF
for f in "$tmp/p1/flip"/*.rtt; do
    what="flip $(basename "$f")"
    run 10 "$rbin" trace-info "$f"
    must_refuse 'byte [0-9]+'
done
rm -rf "$tmp/p1"
row "1. trace reader: truncated and bit-flipped traces (trace-info)" $n $crash $hang $silent - - $other

# ---- 2. din reader: truncations, NUL bytes, garbage lines ----------------------
begin 2
mkdir "$tmp/p2"
"$bin" trace cornell -W 4 -H 4 --lights all -o "$tmp/p2/t.rtt" 2>/dev/null &&
    "$bin" trace-dump "$tmp/p2/t.rtt" --din > "$tmp/p2/t.din" || { echo "$0: cannot write the din trace" >&2; exit 1; }
if [ $quick = 1 ]; then nmut=40; else nmut=1500; fi
# Each mutant comes with its expected outcome in a manifest line:
# NAME ok REFS (accepted with REFS records) or NAME bad LINE (refused at LINE).
python3 - "$tmp/p2" "$nmut" <<'EOF' || exit 1
import os, random, sys
d, n = sys.argv[1], int(sys.argv[2])
rng = random.Random(7)
base = open(os.path.join(d, "t.din"), "rb").read()
out = open(os.path.join(d, "manifest"), "w")
def valid(line):
    t = line.split()
    if not t: return None          # blank: skipped
    if len(t) < 2 or t[0] not in (b"0", b"1", b"2"): return False
    a = t[1][2:] if t[1][:2] in (b"0x", b"0X") else t[1]
    try: return len(a) > 0 and int(a, 16) < 2**64 and all(c in b"0123456789abcdefABCDEF" for c in a)
    except ValueError: return False
def expect(data):
    refs = 0
    for no, line in enumerate(data.split(b"\n"), 1):
        if b"\0" in line: return "bad %d" % no
        v = valid(line)
        if v is False: return "bad %d" % no
        if v: refs += 1
    return "ok %d" % refs
def put(name, data):
    open(os.path.join(d, name), "wb").write(data)
    out.write("%s %s\n" % (name, expect(data)))
# truncations: every line end and a mid-line cut around it, sampled
cuts = sorted(set(rng.randrange(len(base) + 1) for _ in range(n)))
for c in cuts: put("cut%d.din" % c, base[:c])
lines = base.split(b"\n")
garbage = [b"x", b"3 1000", b"0", b"0 zz", b"0 0x", b"-1 10", b"0 1g00",
           b"0 10000000000000000000", b"\xff\xfe", b"0 1000\x00", b"1 +5"]
for i in range(n // 2):
    k = rng.randrange(len(lines))
    l = list(lines)
    s = l[k] if l[k] else b"0 1000"
    p = rng.randrange(len(s) + 1)
    l[k] = s[:p] + b"\0" + s[p:]
    put("nul%d.din" % i, b"\n".join(l))
    l = list(lines)
    l.insert(rng.randrange(len(lines)), rng.choice(garbage))
    put("junk%d.din" % i, b"\n".join(l))
EOF
while read -r name exp arg; do
    what="$name (want $exp $arg)"
    run 10 "$rbin" sim --input-format din --sizes 1K --format csv "$tmp/p2/$name"
    if [ "$exp" = ok ] && [ "$arg" = 0 ]; then
        must_refuse "no references" # sim refuses a trace without references
    elif [ "$exp" = ok ]; then
        must_accept
        if [ $kind = ok ]; then
            got=$(awk -F, '$5 == "other" { print $6 }' "$tmp/out")
            [ "$got" = "$arg" ] || { silent=$((silent + 1)); note "$what: $got references reported"; }
        fi
    else
        must_refuse "$name:$arg: "
    fi
done < "$tmp/p2/manifest"
rm -rf "$tmp/p2"
row "2. din reader: truncations, NUL bytes, garbage lines (sim --input-format din)" $n $crash $hang $silent - - $other

# ---- 3. PLY and OBJ loaders: lying headers, broken bodies, extreme coordinates --
begin 3
mkdir "$tmp/p3"
python3 - "$tmp/p3" "$meshes" <<'EOF' || exit 1
import os, struct, sys
d, m = sys.argv[1], sys.argv[2]
man = open(os.path.join(d, "manifest"), "w")
def put(name, data, ok):
    open(os.path.join(d, name), "wb").write(data)
    man.write("%s %s\n" % (name, "ok" if ok else "bad"))
# --- PLY: the ascii tetrahedron and a binary copy of it
ply = open(os.path.join(m, "tetra_ascii.ply"), "rb").read()
head, body = ply.split(b"end_header\n")
head += b"end_header\n"
hl = head.split(b"\n")
rows = [r.split() for r in body.strip().split(b"\n")]
def binary(hl, rows, endian="<"):
    h = b"\n".join(hl).replace(b"format ascii", b"format binary_little_endian" if endian == "<" else b"format binary_big_endian")
    out = b""
    for r in rows[:4]: out += struct.pack(endian + "fffB", float(r[0]), float(r[1]), float(r[2]), int(r[3]))
    for r in rows[4:8]: out += struct.pack(endian + "B3ii", 3, *[int(x) for x in r[1:4]], int(r[4]))
    out += struct.pack(endian + "ii", *[int(x) for x in rows[8]])
    return h + out
variants = {"a": lambda hl, rows: b"\n".join(hl) + b"\n".join(b" ".join(r) for r in rows) + b"\n",
            "b": lambda hl, rows: binary(hl, rows, "<"), "be": lambda hl, rows: binary(hl, rows, ">")}
def num(x): return repr(x).encode()
for v, mk in variants.items():
    put("t_%s_orig.ply" % v, mk(hl, rows), True)
    # counts replaced
    for i, l in enumerate(hl):
        if l.startswith(b"element "):
            name, cnt = l.split()[1], int(l.split()[2])
            for c in [b"0", b"1", b"2", b"4294967295", b"-1", b"-4294967296", b"99999999999999999999", num(cnt + 1)]:
                if c == str(cnt).encode(): continue
                h2 = list(hl); h2[i] = b"element " + name + b" " + c
                put("t_%s_count_%s_%s.ply" % (v, name.decode(), c.decode()), mk(h2, rows), False)
    # properties removed (the data no longer matches the header)
    for i, l in enumerate(hl):
        if l.startswith(b"property"):
            h2 = hl[:i] + hl[i + 1:]
            put("t_%s_noprop%d.ply" % (v, i), mk(h2, rows), False)
    # format line removed
    put("t_%s_noformat.ply" % v, mk([l for l in hl if not l.startswith(b"format")], rows), False)
    # non-finite and extreme coordinates; in-range transforms stay valid
    def tr(f, ok, tag):
        r2 = [list(r) for r in rows]
        for r in r2[:4]: r[0:3] = [num(f(float(x))) for x in r[0:3]]
        put("t_%s_%s.ply" % (v, tag), mk(hl, r2), ok)
    for tag, val in [("nan", "nan"), ("inf", "inf"), ("minf", "-inf")]:
        r2 = [list(r) for r in rows]; r2[1][0] = val.encode()
        put("t_%s_%s.ply" % (v, tag), mk(hl, r2), False)
    for s in [1e10, 1e15, 3.4e38]: tr(lambda x, s=s: x * s, False, "scale%g" % s)
    tr(lambda x: x + 1e20, False, "offset1e20")
    tr(lambda x: x * 2 + 100, True, "scale2")
    tr(lambda x: x * 1e6, True, "scale1e6")
    # face indices out of range, a list count that lies
    for bad in [b"4", b"-1", b"2147483647"]:
        r2 = [list(r) for r in rows]; r2[5][2] = bad
        put("t_%s_index%s.ply" % (v, bad.decode()), mk(hl, r2), False)
    if v == "a":
        for bad in [b"255", b"0", b"2"]:
            r2 = [list(r) for r in rows]; r2[6][0] = bad
            put("t_a_list%s.ply" % bad.decode(), mk(hl, r2), False)
        put("t_a_trailing.ply", mk(hl, rows) + b"1 2 3\n", False)
# --- OBJ: the cube and the face-forms file
for o in ["cube", "forms"]:
    src = open(os.path.join(m, o + ".obj"), "rb").read()
    put("o_%s_orig.obj" % o, src, True)
    ls = src.split(b"\n")
    vs = [i for i, l in enumerate(ls) if l.startswith(b"v ")]
    fs = [i for i, l in enumerate(ls) if l.startswith(b"f ")]
    def tr(f, ok, tag):
        l2 = list(ls)
        for i in vs:
            t = l2[i].rstrip(b"\r").split()
            l2[i] = b"v " + b" ".join(num(f(float(x))) for x in t[1:4]) + (b"\r" if l2[i].endswith(b"\r") else b"")
        put("o_%s_%s.obj" % (o, tag), b"\n".join(l2), ok)
    for s in [1e10, 1e15, 3.4e38]: tr(lambda x, s=s: x * s, False, "scale%g" % s)
    tr(lambda x: x + 1e20, False, "offset1e20")
    tr(lambda x: x * 2 + 100, True, "scale2")
    for tag, val in [("nan", b"nan"), ("inf", b"inf"), ("minf", b"-inf"), ("1e39", b"1e39")]:
        l2 = list(ls); t = l2[vs[1]].split(); t[2] = val; l2[vs[1]] = b" ".join(t)
        put("o_%s_%s.obj" % (o, tag), b"\n".join(l2), False)
    for bad in [b"0", b"99", b"-99", b"4294967295", b"4294967296", b"99999999999999999999", b"x"]:
        l2 = list(ls); t = l2[fs[0]].split(); t[1] = bad; l2[fs[0]] = b" ".join(t)
        put("o_%s_face%s.obj" % (o, bad.decode()), b"\n".join(l2), False)
    l2 = list(ls); l2[vs[0]] = b"v 1 2"
    put("o_%s_shortv.obj" % o, b"\n".join(l2), False)
    l2 = list(ls); l2[fs[0]] = b"f 1 2"
    put("o_%s_shortf.obj" % o, b"\n".join(l2), False)
    put("o_%s_nofaces.obj" % o, b"\n".join(l for l in ls if not l.startswith(b"f ")), False)
EOF
while read -r name exp; do
    what=$name
    t0=$(date +%s%N)
    run 10 "$rbin" scene info "$tmp/p3/$name" --no-tree
    ms=$((($(date +%s%N) - t0) / 1000000))
    if [ $kind != hang ] && [ $ms -ge 1000 ]; then kind=hang; fi
    if [ "$exp" = ok ]; then must_accept; else must_refuse "$(sed 's/[.+]/\\&/g' <<< "$name")"; fi
done < "$tmp/p3/manifest"
rm -rf "$tmp/p3"
row "3. PLY and OBJ loaders: mutated headers, bodies, coordinates (scene info, 1 s limit)" $n $crash $hang $silent - - $other

# ---- 4. kill -9 during sweep, resume; SIGTERM to sweep --jobs 2 ---------------
begin 4
mkdir "$tmp/p4"
sweep=(sweep --scenes cornell,knot --lights primary,all --tracers recursive,dynamic -W 128 -H 128 --sizes 1K-256K)
# every stored value but timings, dates and provenance, one line per traffic row
dump() {
    sqlite3 "$1" "SELECT s.name, r.tracer, r.W, r.H, r.lights, r.sched_size, r.gmax, r.params, r.sim_method,
        r.sim_params, r.refs, c.size, c.line, c.assoc, c.policy, t.class, t.accesses, t.read_misses,
        t.write_misses, t.writebacks, t.wt_bytes, t.traffic_bytes
        FROM traffic t JOIN runs r ON r.id = t.run_id JOIN scenes s ON s.id = r.scene_id
        JOIN cache_configs c ON c.id = t.config_id ORDER BY 1,2,3,4,5,6,7,8,9,10,12,13,14,15,16" 2>&1
}
"$bin" "${sweep[@]}" --db "$tmp/p4/ref.db" 2>/dev/null || { echo "$0: reference sweep failed" >&2; exit 1; }
dump "$tmp/p4/ref.db" > "$tmp/p4/ref.txt"
nref=$(sqlite3 "$tmp/p4/ref.db" "SELECT COUNT(*) FROM runs")
if [ $quick = 1 ]; then trials=2; else trials=10; fi
RANDOM=4242
for jobs in 1 2; do
    i=0
    while [ $i -lt $trials ]; do
        db=$tmp/p4/k$jobs.$i.db
        what="kill -9 of sweep --jobs $jobs, trial $i"
        "$bin" "${sweep[@]}" --jobs $jobs --db "$db" 2>/dev/null &
        p=$!
        bgpids="$bgpids $p"
        sleep "0.$((RANDOM % 9 + 1))$((RANDOM % 10))"
        kids=$(pgrep -P $p | tr '\n' ' ')
        kill -KILL $p 2>/dev/null
        wait $p 2>/dev/null
        sleep 0.3
        left=""
        for k in $kids; do alive "$k" && left="$left $k"; done
        [ -z "$left" ] || { other=$((other + 1)); note "$what: workers left running:$left"; }
        for k in $left; do kill -KILL "$k" 2>/dev/null; done
        run 120 "$bin" "${sweep[@]}" --jobs $jobs --db "$db"
        n=$((n + 1))
        if [ $kind != ok ]; then
            case $kind in crash) crash=$((crash + 1)) ;; hang) hang=$((hang + 1)) ;; *) other=$((other + 1)) ;; esac
            note "$what: resume $kind (exit $rc): $(head -c 200 "$tmp/err")"
        fi
        dump "$db" > "$tmp/p4/got.txt"
        # rows in the reference missing from the resumed database, and extras
        l=$(comm -23 "$tmp/p4/ref.txt" "$tmp/p4/got.txt" | wc -l)
        x=$(comm -13 "$tmp/p4/ref.txt" "$tmp/p4/got.txt" | wc -l)
        runs=$(sqlite3 "$db" "SELECT COUNT(*) FROM runs")
        [ "$l" = 0 ] || { lost=$((lost + l)); note "$what: $l rows lost"; }
        [ "$x" = 0 ] && [ "$runs" = "$nref" ] || { dup=$((dup + x)); note "$what: $x extra rows, $runs runs of $nref"; }
        i=$((i + 1))
    done
done
# SIGTERM to a parallel sweep: no worker left, nothing stored afterwards
db=$tmp/p4/term.db
what="SIGTERM to sweep --jobs 2"
"$bin" "${sweep[@]}" --jobs 2 --db "$db" 2>/dev/null &
p=$!
bgpids="$bgpids $p"
i=0
while [ "$(sqlite3 "$db" "SELECT COUNT(*) FROM runs" 2>/dev/null || echo 0)" -lt 1 ] && [ $i -lt 100 ]; do
    sleep 0.05; i=$((i + 1))
done
kids=$(pgrep -P $p | tr '\n' ' ')
kill -TERM $p
wait $p
st=$?
n=$((n + 1))
[ $st != 0 ] || { silent=$((silent + 1)); note "$what: exit 0"; }
sleep 0.5
left=""
for k in $kids; do alive "$k" && left="$left $k"; done
n1=$(sqlite3 "$db" "SELECT COUNT(*) FROM runs"); sleep 1; n2=$(sqlite3 "$db" "SELECT COUNT(*) FROM runs")
[ -z "$left" ] && [ "$n1" = "$n2" ] || { other=$((other + 1)); note "$what: workers left:$left; runs $n1 -> $n2"; }
for k in $left; do kill -KILL "$k" 2>/dev/null; done
rm -rf "$tmp/p4"
row "4. kill -9 during sweep (--jobs 1, 2), resume, compare; SIGTERM to --jobs 2" $n $crash $hang $silent $lost $dup $other

# ---- 5. concurrent sim --db writers on a fresh database ------------------------
begin 5
mkdir "$tmp/p5"
if [ $quick = 1 ]; then W=4 R=3; else W=8 R=50; fi
"$bin" trace cornell -W 8 -H 8 -o "$tmp/p5/t.rtt" 2>/dev/null &&
    "$bin" trace-dump "$tmp/p5/t.rtt" --din > "$tmp/p5/t.din" || { echo "$0: cannot write the din trace" >&2; exit 1; }
i=1
while [ $i -le $W ]; do cp "$tmp/p5/t.din" "$tmp/p5/w$i.din"; i=$((i + 1)); done
r=1
while [ $r -le $R ]; do
    db=$tmp/p5/r$r.db pids="" i=1
    while [ $i -le $W ]; do
        timeout -k 2 120 "$bin" sim --db "$db" --sizes 1K,4K "$tmp/p5/w$i.din" 2> "$tmp/p5/err$i" &
        pids="$pids $!"
        i=$((i + 1))
    done
    i=1
    for p in $pids; do
        wait "$p"
        st=$?
        n=$((n + 1))
        if [ $st = 124 ]; then hang=$((hang + 1)); note "round $r writer $i: hang"
        elif [ $st -ge 128 ]; then crash=$((crash + 1)); note "round $r writer $i: exit $st"
        elif [ $st != 0 ]; then other=$((other + 1)); note "round $r writer $i: exit $st: $(head -c 200 "$tmp/p5/err$i")"
        fi
        i=$((i + 1))
    done
    # one run per writer (its own file name is its scene), 2 sizes x fb each
    got=$(sqlite3 "$db" "SELECT COUNT(DISTINCT scene_id) FROM runs")
    all=$(sqlite3 "$db" "SELECT COUNT(*) FROM runs")
    rows=$(sqlite3 "$db" "SELECT COUNT(*) FROM traffic")
    lost=$((lost + W - got)) dup=$((dup + all - got))
    [ "$got" = $W ] && [ "$all" = $W ] && [ "$rows" = $((2 * W)) ] || note "round $r: $all runs of $got scenes, $rows traffic rows; want $W, $((2 * W))"
    rm -f "$db" "$db-wal" "$db-shm"
    r=$((r + 1))
done
rm -rf "$tmp/p5"
row "5. $W concurrent sim --db writers x $R rounds on a fresh database" $n $crash $hang $silent $lost $dup $other

# ---- 6. output files: devices, links, directories, racing writers, full disks --
begin 6
mkdir -p "$tmp/p6/dir"
cube=$meshes/cube.obj
small=(-W 16 -H 16)
cd "$tmp/p6" || exit 1
if [ "$(id -u)" = 0 ]; then
    for c in render trace; do
        what="$c -o /dev/null as root"
        run 60 "$bin" $c "$cube" "${small[@]}" -o /dev/null
        must_accept
        [ -c /dev/null ] || { silent=$((silent + 1)); note "$what: /dev/null is no longer a device"; }
    done
fi
ln -s target.rtt link.rtt
what="trace -o SYMLINK"
run 60 "$bin" trace "$cube" "${small[@]}" -o link.rtt
must_accept
[ -L link.rtt ] && [ -s target.rtt ] || { silent=$((silent + 1)); note "$what: the link was replaced or its target not written"; }
for c in render trace "scene export"; do
    what="$c -o DIR"
    if [ "$c" = "scene export" ]; then run 60 "$bin" scene export "$cube" -o dir
    else run 60 "$bin" $c "$cube" "${small[@]}" -o dir; fi
    must_refuse "is a directory"
    [ -z "$(ls -A dir)" ] || { silent=$((silent + 1)); note "$what: left $(ls -A dir)"; rm -rf dir/* dir/.[!.]*; }
done
if [ $quick = 1 ]; then rounds=3; else rounds=18; fi
i=0
while [ $i -lt $rounds ]; do
    what="two writers to one trace, round $i"
    "$bin" trace "$cube" -W 24 -H 24 -o same.rtt 2>/dev/null & p1=$!
    "$bin" trace knot:segs=16,sides=4 -W 20 -H 20 -o same.rtt 2>/dev/null & p2=$!
    wait $p1; s1=$?
    wait $p2; s2=$?
    run 30 "$bin" trace-info same.rtt
    n=$((n + 1))
    [ $s1 = 0 ] && [ $s2 = 0 ] || { other=$((other + 1)); note "$what: writers exited $s1, $s2"; }
    [ $kind = ok ] || { silent=$((silent + 1)); note "$what: same.rtt is corrupt: $(head -c 200 "$tmp/err")"; }
    i=$((i + 1))
done
ls -A | grep -q '^\.same\.rtt\.' && { other=$((other + 1)); note "racing writers left temporaries"; }
if [ -c /dev/full ]; then
    ln -s /dev/full full.rtt
    ln -s /dev/full full.png
    what="trace -o /dev/full"
    run 60 "$bin" trace "$cube" "${small[@]}" -o full.rtt
    must_refuse "No space left"
    what="render --png /dev/full"
    run 60 "$bin" render "$cube" "${small[@]}" -o ok.exr --png full.png
    must_refuse "No space left"
    for c in "version" "--help" "scene list" "scene info $cube --no-tree" "sweep --scenes cornell --list-jobs" \
             "report --db $tmp/p6/rep.db" "render $cube -W 16 -H 16 -o $tmp/p6/j.exr --json"; do
        [ "${c#report}" != "$c" ] && [ ! -e rep.db ] &&
            "$bin" sweep --scenes cornell --lights primary --tracers recursive -W 16 -H 16 --sizes 1K,4K --db rep.db 2>/dev/null
        what="'$c' > /dev/full"
        read -r -a words <<< "$c" # split on blanks only: the paths here have none
        timeout -k 2 60 "$bin" "${words[@]}" > /dev/full 2> "$tmp/err"
        rc=$?
        if [ $rc = 124 ]; then kind=hang; elif [ $rc -ge 128 ]; then kind=crash
        elif [ $rc = 0 ]; then kind=ok; elif [ $rc = 1 ]; then kind=refused; else kind=other; fi
        must_refuse "write error: No space left on device"
    done
fi
cd "$src" || exit 1
rm -rf "$tmp/p6"
row "6. output files: /dev/null, symlink, directory, two writers, /dev/full" $n $crash $hang $silent - - $other

# ---- 7. shell injection through mesh file names --------------------------------
begin 7
mkdir -p "$tmp/p7/m" "$tmp/p7/run"
cd "$tmp/p7/run" || exit 1
for name in "x'\$(touch PWNED)'.obj" "x\`touch PWNED\`.obj" "x\"\$(touch PWNED)\".obj" "x;touch PWNED;.obj"; do
    what="mesh named $name"
    "$bin" scene export cornell:glass=0 -o "$tmp/p7/m/$name" 2>/dev/null || { other=$((other + 1)); note "$what: export failed"; continue; }
    run 120 "$bin" sweep --scenes "$tmp/p7/m/$name" --lights primary --tracers recursive -W 16 -H 16 --sizes 1K,64K --db inj.db
    must_accept
    run 120 "$bin" report --db inj.db --plot plots
    # without gnuplot --plot may fail; it must not run the name
    [ $kind = ok ] || [ $kind = refused ] || note "$what: report --plot $kind (exit $rc)"
    run 120 "$bin" sweep --scenes "$tmp/p7/m/$name" --lights primary --tracers recursive -W 16 -H 16 --sizes 1K --list-jobs
    must_accept
    if [ $kind = ok ]; then
        read -r -a job < "$tmp/out" # inspection only: the line is never run by a shell here
        [ "${#job[@]}" -gt 0 ] || note "$what: no job line"
    fi
    if [ -e PWNED ] || [ -e "$tmp/p7/m/PWNED" ] || [ -e "$tmp/p7/PWNED" ]; then
        silent=$((silent + 1)); note "$what: PWNED created"; rm -f PWNED "$tmp/p7/m/PWNED" "$tmp/p7/PWNED"
    fi
    rm -rf inj.db plots
done
cd "$src" || exit 1
rm -rf "$tmp/p7"
row "7. shell injection: mesh names with \$(...), backquotes, quotes (sweep, report --plot)" $n $crash $hang $silent - - $other

# ---- 8. bad option values: exit 2 naming the option -----------------------------
begin 8
mkdir "$tmp/p8"
"$bin" trace cornell -W 8 -H 8 -o "$tmp/p8/t.rtt" 2>/dev/null || exit 1
t=$tmp/p8/t.rtt o=$tmp/p8/o
cd "$tmp/p8" || exit 1
bad() { # OPTION COMMAND WORDS...
    local opt=$1
    shift
    what="$*"
    run 60 "$bin" "$@"
    n=$((n + 1))
    case $kind in
    crash) crash=$((crash + 1)); note "$what: crash (exit $rc)" ;;
    hang) hang=$((hang + 1)); note "$what: hang" ;;
    ok) silent=$((silent + 1)); note "$what: accepted (exit 0)" ;;
    *) [ $rc = 2 ] && grep -q -- "$opt" "$tmp/err" ||
        { other=$((other + 1)); note "$what: exit $rc, want 2 naming $opt: $(head -c 200 "$tmp/err")"; } ;;
    esac
}
bad --cache-size trace cornell -W 8 -H 8 -t dynamic --cache-size " -64" -o $o.rtt
bad --cache-size trace cornell -W 8 -H 8 -t dynamic --cache-size 0 -o $o.rtt
bad --cache-size trace cornell -W 8 -H 8 -t dynamic --cache-size 64Q -o $o.rtt
bad --depth trace cornell -W 8 -H 8 --mode whitted --depth 0 -o $o.rtt
bad --depth trace cornell -W 8 -H 8 --mode whitted --depth 65 -o $o.rtt
bad --spp trace cornell -W 8 -H 8 --mode path --spp 0 -o $o.rtt
bad --spp trace cornell -W 8 -H 8 --mode path --spp -1 -o $o.rtt
bad --bounces trace cornell -W 8 -H 8 --mode path --bounces 1001 -o $o.rtt
bad --mode trace cornell -W 8 -H 8 --mode bogus -o $o.rtt
bad --subsample trace cornell -W 8 -H 8 --subsample 4:16 -o $o.rtt
bad --subsample trace cornell -W 8 -H 8 --subsample 0 -o $o.rtt
bad --level trace cornell -W 8 -H 8 --level 10 -o $o.rtt
bad --packet trace cornell -W 8 -H 8 -t packet --packet 0 -o $o.rtt
bad --threads trace cornell -W 8 -H 8 -t dynamic --threads 0 -o $o.rtt
bad --qorder trace cornell -W 8 -H 8 -t dynamic --qorder sideways -o $o.rtt
bad --lights trace cornell -W 8 -H 8 --lights 7 -o $o.rtt
bad -W trace cornell -W 0 -H 8 -o $o.rtt
bad -H trace cornell -W 8 -H -3 -o $o.rtt
bad 'unknown tracer' trace cornell -W 8 -H 8 -t bogus -o $o.rtt
bad --rate sim --method exact --rate 1/64 "$t"
bad --rate sim --method shards --rate 0 "$t"
bad --rate sim --method shards --rate 2 "$t"
bad --method sim --method bogus "$t"
bad --sizes sim --sizes 1Q "$t"
bad --sizes sim --sizes 4M-1K "$t"
bad --sizes sim --sizes "" "$t"
bad --line sim --line 0 "$t"
bad --assoc sim --assoc 0 "$t"
bad --input-format sim --input-format xml "$t"
bad --din-class sim --input-format din --din-class bogus "$t"
bad --format sim --format xml "$t"
bad --preset sweep --preset huge --db $o.db
bad --tracers sweep --tracers bogus --db $o.db
bad --lights sweep --lights 9 --db $o.db
bad --jobs sweep --jobs 0 --db $o.db
bad --approx sweep --approx shards:7 --db $o.db
bad --proxy sweep --proxy res:0 --db $o.db
bad --figure report --figure 42 --db $o.db
bad --format report --format xml --db $o.db
# strict numbers in every render option (docs/options.md): hex, space, plus, overflow, nan
for v in 0x10 " 1" +2 1e999 nan; do
    bad --grid-density trace cornell -W 8 -H 8 -t feedback --grid-density "$v" -o $o.rtt
    bad --oracle-fraction trace cornell -W 8 -H 8 -t stream-multipass --oracle-fraction "$v" -o $o.rtt
    bad --fov trace cornell -W 8 -H 8 --fov "$v" -o $o.rtt
    bad --look-at trace cornell -W 8 -H 8 --look-at "$v,0,1,0,0,0" -o $o.rtt
    bad --light trace cornell -W 8 -H 8 --light "0.5,$v,0.9" -o $o.rtt
    bad --grid-density sweep --tracers feedback --grid-density "$v" --list-jobs
done
# a light index --light did not define; --look-at beyond single precision, along the scene's up
bad --lights trace cornell -W 8 -H 8 --light 0.5,0.5,0.9 --lights 1,2 -o $o.rtt
bad --lights sweep --scenes cornell --tracers recursive --light 0.5,0.5,0.9 --lights primary,1 --list-jobs
bad --look-at trace cornell -W 8 -H 8 --look-at 1e20,1e20,1e20,-1e20,-1e20,-1e20 -o $o.rtt
bad "scene's up vector" trace knot -W 8 -H 8 --look-at 0,0,12,0,0,0 -o $o.rtt
[ -e $o.db ] && { other=$((other + 1)); note "a usage error created the database"; }
cd "$src" || exit 1
rm -rf "$tmp/p8"
row "8. bad option values (exit 2 naming the option)" $n $crash $hang $silent - - $other

# ---- 9. hostile use: job lines, scene files, reruns, names, reports, databases ----
# docs/reliability.md §15-§26, one input (or condition) per defect found
begin 9
p9=$tmp/p9
mkdir -p "$p9/m/sub" && cd "$p9" || exit 1
cube=$meshes/cube.obj
NL='
'
usage_err() { # OPTION: the last run must be a usage error naming OPTION
    n=$((n + 1))
    case $kind in
    crash) crash=$((crash + 1)); note "$what: crash (exit $rc)" ;;
    hang) hang=$((hang + 1)); note "$what: hang" ;;
    ok) silent=$((silent + 1)); note "$what: accepted (exit 0)" ;;
    *) [ $rc = 2 ] && grep -q -- "$1" "$tmp/err" || { other=$((other + 1)); note "$what: exit $rc, want 2 naming $1: $(head -c 200 "$tmp/err")"; } ;;
    esac
}
check() { # CONDITION-EXIT-STATUS DESCRIPTION: count a yes/no check (0 = as it must be)
    n=$((n + 1))
    [ "$1" = 0 ] || { silent=$((silent + 1)); note "$2"; }
}
# §15 a newline in a scene name, --db, --keep-traces
cp "$cube" "x${NL}touch PWNED;#.obj"
what="--scenes with a newline"; run 30 "$bin" sweep --scenes "x${NL}touch PWNED;#.obj" --list-jobs; usage_err --scenes
what="--db with a newline"; run 30 "$bin" sweep --db "a${NL}touch PWNED;#" --list-jobs; usage_err --db
what="--keep-traces with a newline"; run 30 "$bin" sweep --keep-traces "a${NL}b" --list-jobs; usage_err --keep-traces
[ -e PWNED ]; check $((1 - $?)) "PWNED created"
rm -f "x${NL}touch PWNED;#.obj"
# §16 devices, FIFOs, files outside the folder
ln -s /dev/zero m/zero.obj
mkfifo m/fifo.obj m/sub/fifo.mtl
for f in m/zero.obj m/fifo.obj; do what="mesh $f"; run 10 "$bin" scene info "$f"; must_refuse "not a regular file"; done
for lib in /dev/zero ../../../../etc/passwd fifo.mtl; do
    { echo "mtllib $lib"; cat "$cube"; } > m/sub/t.obj
    what="mtllib $lib"; run 10 "$bin" scene info m/sub/t.obj; must_refuse "t.obj:1: material library"
done
# §17 a rerun with more sizes simulates them
a="--scenes cornell --tracers recursive --lights primary -W 16 -H 16 --db r17.db"
run 60 "$bin" sweep $a --sizes 1K-4K
run 60 "$bin" sweep $a --sizes 1K-16K
[ "$(sqlite3 r17.db "SELECT COUNT(DISTINCT c.size) FROM traffic t JOIN cache_configs c ON c.id = t.config_id")" = 5 ]
check $? "a rerun with --sizes 1K-16K left sizes unsimulated"
# §18, §19 long names, many scenes
L=$(printf 'm%.0s' $(seq 1 146))
cp "$cube" "${L}a.obj" && "$bin" scene export knot -o "${L}b.obj" 2>/dev/null
list=
for i in $(seq -w 1 17); do cp "$cube" "c$i.obj"; list=$list,c$i.obj; done
run 120 "$bin" sweep --scenes "${L}a.obj,${L}b.obj$list" --tracers recursive --lights primary -W 8 -H 8 --sizes 1K --db r18.db
run 60 "$bin" report --db r18.db --format csv --figure scenes
[ "$(grep -c "^${L}[ab].obj," "$tmp/out")" = 2 ]; check $? "two 151-byte names not reported whole and apart"
[ "$(grep -c '^c[0-9]*\.obj,' "$tmp/out")" = 17 ]; check $? "report dropped scenes after the 16th"
# §20 a gnuplot that draws nothing is an error
what="report --plot -p with a gnuplot that draws nothing"
RT_GNUPLOT=true run 60 "$bin" report --db r18.db --scene c01.obj --plot -p; must_refuse "gnuplot wrote no picture"
# §21 concurrent exports leave a consistent pair
for round in 1 2 3 4 5 6; do
    for sp in cornell cornell:material=mirror cornell:material=glass knot:material=mirror; do
        "$bin" scene export "$sp" -o same.obj 2>/dev/null &
    done
    wait
    what="concurrent export round $round"; run 30 "$bin" scene info same.obj; must_accept
done
# §22 lenient numbers
for v in abc 0x10 nan -1 1e999 " 5"; do what="report -W '$v'"; run 30 "$bin" report -W "$v"; usage_err -W; done
"$bin" trace cornell -W 8 -H 8 -o t.rtt 2>/dev/null
for v in " 0.5" 0x0.1 nan; do what="sim --rate '$v'"; run 30 "$bin" sim --method shards --rate "$v" t.rtt; usage_err --rate; done
# §23 a huge cache of a small trace needs little memory; a huge image is refused before allocating
vlim=1000000 # an ASan build cannot start in 1 GB of address space
bash -c "ulimit -v $vlim; exec \"\$0\" version" "$bin" > /dev/null 2>&1 || vlim=unlimited
what="sim --sizes 32G in 1 GB"; run 60 bash -c "ulimit -v $vlim; exec \"\$0\" sim --sizes 32G t.rtt" "$bin"; must_accept
mem=$(awk '/^MemTotal:/ { print int($2 / 1024) }' /proc/meminfo 2>/dev/null || echo 0)
if [ "${mem:-0}" -gt 0 ] && [ "$mem" -lt 98000 ]; then
    what="render -W 65536 -H 65536"; run 30 "$bin" render cornell -W 65536 -H 65536 -o big.exr; usage_err "-W 65536"
fi
# §24 a foreign file is refused untouched
sqlite3 f.db "CREATE TABLE foo(x); PRAGMA user_version = 4;"
sum=$(cksum < f.db)
what="foreign database"; run 30 "$bin" sim --db f.db t.rtt; must_refuse "not a raytraffic database"
[ "$(cksum < f.db)" = "$sum" ] && [ ! -e f.db-wal ]; check $? "the refused foreign database was modified"
# §25 --db is a path
run 30 "$bin" sim --db 'file:u.db?mode=memory' t.rtt
[ -f 'file:u.db?mode=memory' ]; check $? "--db 'file:u.db?mode=memory' read as a URI"
run 30 "$bin" sim --db file:other.db t.rtt
[ ! -e other.db ] && [ -f file:other.db ]; check $? "--db file:other.db wrote other.db"
# §26 lesser ones
what="render -o ''"; run 30 "$bin" render cornell -W 8 -H 8 -o ''; usage_err "-o"
if [ -w /dev/full ]; then
    what="render -o /dev/full"; run 30 "$bin" render cornell -W 64 -H 64 -o /dev/full; must_refuse "No space left"
fi
printf 'v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r' > cr.obj
what="CR-only OBJ"; run 10 "$bin" scene info cr.obj; must_accept
printf 'v 0 0 0\nv 0x1p0 0 0\nv 0 1 0\nf 1 2 3\n' > hex.obj
what="hex float in OBJ"; run 10 "$bin" scene info hex.obj; must_refuse "hex.obj:2"
L2=$(printf 'n%.0s' $(seq 1 240))
cp "$cube" "${L2}.obj"
what="240-byte name with --keep-traces"
run 60 "$bin" sweep --scenes "${L2}.obj" --tracers recursive --lights primary -W 8 -H 8 --sizes 1K --db k.db --keep-traces kept
must_accept
# sweep's scene list (docs/options.md): a comma in a mesh name, scenes loaded before --list-jobs,
# no empty database after a failure
cp "$cube" "a,b.obj" && printf 'a,b.obj\n' > list.txt
what="--scenes-file with a comma mesh"
run 60 "$bin" sweep --scenes-file list.txt --tracers recursive --lights primary -W 8 -H 8 --sizes 1K --db c.db; must_accept
printf 'Shape "nosuchshape"\n' > bad.pbrt
for sp in nosuch missing.obj bad.pbrt; do
    what="--list-jobs with scene $sp"; run 30 "$bin" sweep --scenes "$sp" --list-jobs
    [ $rc = 1 ] && [ ! -s "$tmp/out" ]; check $? "$what: exit $rc, $(wc -l < "$tmp/out") job lines"
done
run 30 "$bin" sweep --scenes nosuch --tracers recursive -W 8 -H 8 --db e.db
[ ! -e e.db ]; check $? "a failed sweep left an empty database"
# pbrt scene files (docs/scenes.md, "Limits and strictness"): amplification, overflow, strictness, gzip, links (issues [5/6], [6/6])
printf 'WorldBegin\nShape "loopsubdiv" "integer levels" 12\n"point3 P" [0 0 0 1 0 0 0 1 0 0 0 1]\n"integer indices" [0 2 1 0 1 3 0 3 2 1 2 3]\n' > tet.pbrt
what="tetrahedron at levels 12"; run 5 "$rbin" scene info tet.pbrt --no-tree; must_refuse "tet.pbrt:2:20: .*maxsubdiv=N"
python3 -c "print('WorldBegin\nObjectBegin \"s\"\nShape \"sphere\"\nObjectEnd\n' + 'ObjectInstance \"s\"\n' * 70000)" > inst.pbrt
what="70,000 instances"; run 5 "$rbin" scene info inst.pbrt:tess=9 --no-tree; must_refuse "inst.pbrt:69047:16: .*maxtri=N"
tri='Shape "trianglemesh" "point3 P" [ 0 0 0 1 0 0 0 1 0 ]'
printf 'WorldBegin\nRotate 1e22 0 0 1\nLightSource "point" "point3 from" [ 1 0 0 ]\n%s\n' "$tri" > rot.pbrt
what="Rotate 1e22"; run 10 "$rbin" scene info rot.pbrt --no-tree; must_accept
grep -q 'nan\|inf' "$tmp/out"; check $((1 - $?)) "Rotate 1e22: a light or vertex not finite"
printf 'WorldBegin\nScale 1e30 1e30 1e30\nScale 1e30 1 1\nLightSource "point" "point3 from" [ 1 0 0 ]\n%s\n' "$tri" > big.pbrt
what="light at infinity"; run 10 "$rbin" scene info big.pbrt --no-tree; must_refuse "big.pbrt:4:13: LightSource: .* not finite"
printf 'WorldBegin\nScale 1e30 1e30 1e30\nScale 1e30 1 1\n%s\n' "$tri" > vinf.pbrt
what="vertex at infinity"; run 10 "$rbin" scene info vinf.pbrt --no-tree; must_refuse "^raytraffic scene: vinf.pbrt:4:7: Shape"
printf 'WorldBegin\nShape "trianglemesh" "point3 P" [ 0x1p0 0 0 1 0 0 0 1 0 ]\n' > hex.pbrt
what="hex float in pbrt"; run 10 "$rbin" scene info hex.pbrt --no-tree; must_refuse "hex.pbrt:2:35: bad number"
printf 'WorldBegin\nMaterial "dielectric" "rgb eta" [ 1.5 1.5 ]\n%s\n' "$tri" > eta.pbrt
what="rgb eta of 2 values"; run 10 "$rbin" scene info eta.pbrt --no-tree; must_refuse "eta.pbrt:2:23: .*2 values, expected 3"
python3 -c "import gzip,sys; sys.stdout.buffer.write(gzip.compress(b'#' * 200000000 + b'\nWorldBegin\n'))" > bomb.pbrt.gz
what="gzip bomb"; RT_SCENE_MAX_BYTES=100M run 20 "$rbin" scene info bomb.pbrt.gz --no-tree; must_refuse "more than 104857600 bytes \(decompressed\)"
ln -s m/fifo.obj tofifo.pbrt
printf 'WorldBegin\nInclude "tofifo.pbrt"\n' > lf.pbrt
what="Include of a link to a FIFO"; run 5 "$rbin" scene info lf.pbrt --no-tree; must_refuse "lf.pbrt:2:9: .*not a regular file"
cd "$src" || exit 1
rm -rf "$p9"
row "9. hostile use: job lines, scene files, reruns, names, reports, exports, numbers, memory, databases" $n $crash $hang $silent - - $other

# ---- 10. databases stored nowhere or blocking, merge messages, stale temporaries, tiny scenes --
# docs/reliability.md §27-§31
begin 10
p10=$tmp/p10
mkdir -p "$p10" && cd "$p10" || exit 1
"$bin" trace cornell -W 8 -H 8 -o t.rtt 2>/dev/null
"$bin" sim --db good.db t.rtt > /dev/null 2>&1
sw="sweep --scenes cornell --tracers recursive --lights primary -W 8 -H 8 --sizes 1K"
# §27 names SQLite stores nowhere: usage errors
for name in ':memory:' '' ':x'; do
    what="sim --db '$name'"; run 30 "$bin" sim --db "$name" t.rtt; usage_err "not a file name\|empty database name"
    # shellcheck disable=SC2086
    what="sweep --db '$name'"; run 30 "$bin" $sw --db "$name"; usage_err "not a file name\|empty database name"
    what="report --db '$name'"; run 30 "$bin" report --db "$name"; usage_err "not a file name\|empty database name"
    what="db merge '$name' good.db"; run 30 "$bin" db merge "$name" good.db; usage_err "not a file name\|empty database name"
done
# §28 FIFOs, folders, devices: refused at once, nothing beside them
mkfifo f.db && mkdir d.db
for c in "report --db f.db" "sim --db f.db t.rtt" "db merge o.db f.db" "db merge f.db good.db" "$sw --db f.db" \
    "sim --db d.db t.rtt" "report --db d.db"; do
    # shellcheck disable=SC2086
    what="$c"; run 10 "$bin" $c; must_refuse "is a FIFO|is a directory"
done
[ ! -e o.db ]; check $? "db merge o.db f.db created o.db"
for dev in /dev/null /dev/full; do
    had=0; [ -e "$dev-journal" ] && had=1
    # shellcheck disable=SC2086
    for c in "sim --db $dev t.rtt" "$sw --db $dev" "db merge $dev good.db"; do
        what="$c"; run 10 "$bin" $c; must_refuse "character device"
    done
    [ $had = 1 ] || [ ! -e "$dev-journal" ]; check $? "$dev-journal created"
done
# §29 merge messages; nothing left beside the shards
cp good.db a.db
run 30 "$bin" db merge m.db a.db
[ ! -e a.db-wal ] && [ ! -e a.db-shm ]; check $? "db merge left -wal/-shm beside its shard"
head -c 3000 good.db > trunc.db
sqlite3 foreign.db "CREATE TABLE foo(x)"
cp good.db newer.db && sqlite3 newer.db "PRAGMA user_version = 99"
head -c 5000 "$meshes/cube.obj" > notsql.db
for x in "trunc.db:malformed database: truncated" "foreign.db:an SQLite file without raytraffic's tables" \
    "newer.db:schema version 99 is newer" "notsql.db:not an SQLite file" "missing.db:unreadable: No such file" \
    "d.db:unreadable: is a directory"; do
    f=${x%%:*}
    what="db merge of $f"; run 30 "$bin" db merge m2.db "$f"; must_refuse "$f: .*${x#*:}"
done
# §30 kept-trace temporaries after kill -9: the rerun removes them
ka="--scenes cornell,knot --tracers recursive,dynamic --lights primary,all -W 48 -H 48 --sizes 1K-16K --db k.db --keep-traces kept"
trials=$([ $quick = 1 ] && echo 2 || echo 5)
for trial in $(seq 1 "$trials"); do
    rm -rf kept k.db*
    # shellcheck disable=SC2086
    "$bin" sweep $ka > /dev/null 2>&1 &
    pid=$!
    bgpids="$bgpids $pid"
    i=0
    while ! ls -a kept 2>/dev/null | grep -q '^\.job.*\.rtt\.......$' && [ $i -lt 1000 ]; do sleep 0.01; i=$((i + 1)); done
    kill -KILL $pid 2>/dev/null
    wait $pid 2>/dev/null
    : > kept/.job0009-stale.rtt.Stale1
    : > kept/.unrelated.rtt.Keep12
    # shellcheck disable=SC2086
    what="sweep rerun after kill -9 (trial $trial)"; run 300 "$bin" sweep $ka; must_accept
    [ -z "$(ls -a kept | grep '^\.job.*\.rtt\.......$')" ]; check $? "trial $trial: stale temporaries left: $(ls -a kept | grep '^\.job' | head -3)"
    [ -e kept/.unrelated.rtt.Keep12 ]; check $? "trial $trial: the rerun removed a file not of its pattern"
done
# §31 tiny scenes refused; small ones keep their shadow rays
for f in 1e-19 1e-12 0; do
    awk -v f="$f" '$1 == "v" { printf "v %.9g %.9g %.9g\n", $2 * f, $3 * f, $4 * f; next } { print }' "$meshes/cube.obj" > "c$f.obj"
    what="cube scaled by $f"; run 10 "$bin" trace "c$f.obj" -W 16 -H 16 --lights all -o t2.rtt; must_refuse "scene extent .* is below 1e-09"
done
awk '$1 == "v" { printf "v %.9g %.9g %.9g\n", $2 * 1e-6, $3 * 1e-6, $4 * 1e-6; next } { print }' "$meshes/cube.obj" > c6.obj
a=$("$bin" trace "$meshes/cube.obj" -W 16 -H 16 --lights all -o t2.rtt 2>&1 | sed -n 's/.* + \([0-9]*\) shadow rays.*/\1/p')
b=$("$bin" trace c6.obj -W 16 -H 16 --lights all -o t2.rtt 2>&1 | sed -n 's/.* + \([0-9]*\) shadow rays.*/\1/p')
[ -n "$a" ] && [ "$a" = "$b" ]; check $? "cube at 1e-6: $b shadow rays, at 1: $a"
cd "$src" || exit 1
rm -rf "$p10"
row "10. databases stored nowhere, FIFOs/devices/folders as databases, merge messages, kill -9 temporaries, tiny scenes" $n $crash $hang $silent - - $other

end=$(date +%s)
echo
if [ -s "$notes" ]; then echo "Failures:"; cat "$notes"; echo; fi
echo "probes.sh: $([ $quick = 1 ] && echo quick || echo full) run in $((end - start)) s with $bin${san:+ (readers: $san)}"
exit $status
