#!/bin/sh
# True instancing from the front end (accel/inst.c, docs/bvh.md "Instancing"):
# 1. `render --instances bvh` writes the same PNG as the default flattened
#    run and as `--instances flatten`, on an instanced .pbrt written here,
#    in the shadow and whitted modes, for the recursive and packet tracers;
#    trace-info names the structure and its four regions;
# 2. the dynamic tracer refuses `--instances bvh` naming the option and the
#    reason (exit 1), `--accel` with it is a usage error (exit 2), and an
#    unknown mode is a usage error; the treelet tracer traces it: on this
#    scene, data/pbrt/instances-grid.pbrt and with a 64-byte budget (many
#    treelets over the top level) its PNG equals the flattened run's, and
#    its trace reads tlas and inst, as many as the recursive tracer's;
# 3. a sweep with `--instances bvh` stores instances = 'bvh' in the runs
#    table for the recursive, packet and treelet tracers; a plain sweep
#    stores 'flatten';
#    the classes table holds tlas, inst and alpha, the bvh run has traffic
#    rows of tlas, inst, node and tri, a 10-class file gets the new rows;
# 4. report --figure instances prints the levels of the two-level run and
#    the flattened one; its csv values are the traffic table's class sums
#    (tlas, inst, blas = node + index + tri; nodes, tri); no such runs is
#    an error naming what to sweep;
# 1b. the instanced trace has classes tlas and inst (footer of 12 classes,
#    sim rows); traces of the earlier writer (tests/data/
#    oldtrace, versions 1-3) read, and the same commands write the same
#    chunks, side chunks and footers today.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt-inst-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }
q() { sqlite3 "$1" "$2" 2>/dev/null || echo "sqlite error"; }

sc="$tmp/inst.pbrt"
cat > "$sc" <<'PBRT'
LookAt 0 4 -12  0 0 0  0 1 0
Camera "perspective" "float fov" 45
WorldBegin
LightSource "point" "point3 from" [2 8 -6] "rgb I" [50 50 50]
Shape "trianglemesh" "point3 P" [-8 -1 -8  8 -1 -8  8 -1 8  -8 -1 8] "integer indices" [0 1 2 0 2 3]
ObjectBegin "box"
Shape "trianglemesh" "point3 P" [-1 -1 -1 1 -1 -1 1 1 -1 -1 1 -1 -1 -1 1 1 -1 1 1 1 1 -1 1 1]
  "integer indices" [0 1 2 0 2 3  4 6 5 4 7 6  0 4 5 0 5 1  3 2 6 3 6 7  0 3 7 0 7 4  1 5 6 1 6 2]
ObjectEnd
ObjectBegin "ball"
Shape "sphere" "float radius" 0.7
ObjectEnd
ObjectInstance "box"
AttributeBegin Translate -3 0 1 Rotate 30 0 1 0 Rotate 20 1 0 0 ObjectInstance "box" AttributeEnd
AttributeBegin Translate 3 1 2 Scale 0.5 2 1 ObjectInstance "box" AttributeEnd
AttributeBegin Translate -2 2 -2 Rotate 70 0 0 1 Scale 1.5 0.6 1 ObjectInstance "ball" AttributeEnd
AttributeBegin Translate 2 -0.2 -3 ObjectInstance "ball" AttributeEnd
PBRT

# ---- 1. images and trace-info -------------------------------------------------
for t in recursive packet; do
    for m in shadow whitted; do
        for i in default flatten bvh; do
            opt=""; [ $i = default ] || opt="--instances $i"
            "$bin" render "$sc" -t $t --mode $m --lights all -W 48 -H 40 $opt -o "$tmp/$i.exr" --png "$tmp/$i-$m.png" \
                >/dev/null 2>"$tmp/err" || { cat "$tmp/err"; die "render $t $m $i"; }
        done
        cmp -s "$tmp/default-$m.png" "$tmp/bvh-$m.png" || die "$t $m: --instances bvh image differs from the flattened one"
        cmp -s "$tmp/default-$m.png" "$tmp/flatten-$m.png" || die "$t $m: --instances flatten image differs from the default"
    done
done
"$bin" trace "$sc" --lights all -W 24 -H 20 --instances bvh -o "$tmp/t.rtt" >/dev/null 2>&1 || die "trace --instances bvh"
"$bin" trace-info "$tmp/t.rtt" > "$tmp/info" 2>&1 || die "trace-info"
grep -q '^structure: *inst$' "$tmp/info" || die "trace-info does not name the inst structure: $(grep structure "$tmp/info")"
for r in tlas.node inst blas.node blas.tri; do
    grep -q "^  $r " "$tmp/info" || die "trace-info lacks region $r"
done

# the packet tracer, like the recursive one, loads the instances kept (no
# flattened copy): the file flattens to 254 triangles but holds 124 (2
# loose, the 12-triangle box and the 110-triangle sphere once), so under
# maxtri=200 the flattened load is refused and the kept one renders, its
# image the flattened run's
"$bin" render "$sc:maxtri=200" -t packet --instances bvh --lights all -W 48 -H 40 -o "$tmp/k.exr" --png "$tmp/k-packet.png" \
    >/dev/null 2>"$tmp/err" || die "packet kept under maxtri=200: $(cat "$tmp/err")"
"$bin" render "$sc:maxtri=200" -t packet --lights all -W 48 -H 40 -o "$tmp/k.exr" >/dev/null 2>"$tmp/err" &&
    die "the flattened scene loaded under maxtri=200"
grep -q "more than maxtri=200" "$tmp/err" || die "flattened under maxtri=200: $(cat "$tmp/err")"
"$bin" render "$sc" -t packet --lights all -W 48 -H 40 -o "$tmp/k.exr" --png "$tmp/f-packet.png" >/dev/null 2>&1 ||
    die "packet flattened"
cmp -s "$tmp/k-packet.png" "$tmp/f-packet.png" || die "packet over the kept instances: image differs from the flattened one"

# scene info: the records the two levels are built from
"$bin" scene info "$sc" > "$tmp/sinfo" 2>&1 || die "scene info"
grep -q '^two-level    5 instance records' "$tmp/sinfo" || die "scene info: $(grep -i inst "$tmp/sinfo")"
"$bin" scene info "$sc" --json 2>/dev/null | grep -q '"instance_records": 5,' || die "scene info --json lacks instance_records"

# ---- 1b. classes per level and traces of earlier writers ------------------------
# the instanced trace's footer and sample index hold classes tlas and inst
# (trace-info verified both above); sim gives them rows
for c in tlas inst node tri; do
    grep -q "^  $c  *geometry  *[1-9]" "$tmp/info" || die "trace-info: no references of class $c"
done
"$bin" sim "$tmp/t.rtt" --sizes 4K --format csv > "$tmp/sim.csv" 2>"$tmp/err" || { cat "$tmp/err"; die "sim exact"; }
for c in tlas inst; do
    grep -q ",$c," "$tmp/sim.csv" || die "sim exact: no $c row: $(cat "$tmp/sim.csv")"
done
# traces written before classes 10..12 existed (tests/data/oldtrace, made
# by the earlier writer: versions 1, 2 and 3) still read, and the same
# commands now write the very same chunks, side chunks and footer (only the
# header, which names the git revision, may differ)
od=${RT_SRCDIR:-.}/tests/data/oldtrace
body() { # the bytes after the header: 16 + payload length + 4
    P=$(od -An -t u4 -j 12 -N 4 "$1" | tr -d ' ')
    tail -c +$((16 + P + 4 + 1)) "$1"
}
for v in 1 2 3; do
    "$bin" trace-info "$od/v$v.rtt" > "$tmp/oi" 2>&1 || die "old v$v trace: $(tail -1 "$tmp/oi")"
    grep -q "verified: CRCs.* footer totals" "$tmp/oi" || die "old v$v trace not verified"
done
"$bin" trace cornell -W 16 -H 12 --lights all -o "$tmp/n3.rtt" >/dev/null 2>&1 || die "trace v3"
"$bin" trace cornell -W 16 -H 12 --lights all --no-sample -o "$tmp/n1.rtt" >/dev/null 2>&1 || die "trace v1"
"$bin" trace cornell -W 16 -H 12 -t dynamic --mode whitted --depth 3 --no-sample -o "$tmp/n2.rtt" >/dev/null 2>&1 ||
    die "trace v2"
for v in 1 2 3; do
    body "$od/v$v.rtt" > "$tmp/ob"; body "$tmp/n$v.rtt" > "$tmp/nb"
    cmp -s "$tmp/ob" "$tmp/nb" || die "v$v: chunks or footer differ from the earlier writer's"
done
# a 10-class footer is 268 bytes, the instanced trace's (tlas, inst: 12) 316
tail -c 268 "$od/v1.rtt" | head -c 4 | grep -q RTND || die "old footer not 268 bytes"
tail -c 316 "$tmp/t.rtt" | head -c 4 | grep -q RTND || die "12-class footer not 316 bytes"

# ---- 2. refusals ----------------------------------------------------------------
for t in dynamic; do
    "$bin" render "$sc" -t $t --instances bvh -W 16 -H 16 -o "$tmp/x.exr" >/dev/null 2>"$tmp/err"
    rc=$?
    [ $rc -ne 0 ] && grep -q -- "--instances bvh: the $t tracer" "$tmp/err" ||
        die "$t with --instances bvh: rc $rc, '$(cat "$tmp/err")'"
done
grid=${RT_SRCDIR:-.}/data/pbrt/instances-grid.pbrt
for f in "$sc" "$grid"; do
    for g in 64 0; do
        go=""; [ $g = 0 ] || go="--gmax $g"
        "$bin" render "$f" -t treelet --mode shadow --lights all -W 40 -H 30 -o "$tmp/x.exr" --png "$tmp/tf.png" \
            >/dev/null 2>"$tmp/err" || { cat "$tmp/err"; die "treelet flatten $f"; }
        "$bin" render "$f" -t treelet --instances bvh --mode shadow --lights all -W 40 -H 30 $go -o "$tmp/x.exr" \
            --png "$tmp/tb.png" >"$tmp/out" 2>&1 || { cat "$tmp/out"; die "treelet --instances bvh $f"; }
        cmp -s "$tmp/tf.png" "$tmp/tb.png" || die "treelet --instances bvh $g on $f: image differs from the flattened one"
        [ $g = 0 ] || grep -Eq "treelets=([2-9]|[1-9][0-9]+) .* suspends=[1-9]" "$tmp/out" ||
            die "treelet --gmax 64 on $f: too few treelets or no suspends: $(cat "$tmp/out")"
    done
done
# the trace's geometry classes: tlas and inst read, each class's references
# the recursive tracer's (the same nodes, records and triangles per ray)
"$bin" trace "$grid" -t treelet --instances bvh --gmax 64 --lights all -W 24 -H 16 -o "$tmp/tl.rtt" >/dev/null 2>"$tmp/err" ||
    { cat "$tmp/err"; die "trace -t treelet --instances bvh"; }
"$bin" trace "$grid" -t recursive --instances bvh --lights all -W 24 -H 16 -o "$tmp/rc.rtt" >/dev/null 2>"$tmp/err" ||
    { cat "$tmp/err"; die "trace -t recursive --instances bvh"; }
refs() { "$bin" trace-info "$1" 2>/dev/null | sed -n '/^references by class/,$p' | awk -v c="$2" '$1 == c {print $3}'; }
for c in tlas inst node tri shade; do
    a=$(refs "$tmp/tl.rtt" $c); b=$(refs "$tmp/rc.rtt" $c)
    [ -n "$a" ] && [ "$a" = "$b" ] || die "class $c: treelet --instances bvh reads $a, the recursive tracer $b"
done
[ "$(refs "$tmp/tl.rtt" tlas)" -gt 0 ] && [ "$(refs "$tmp/tl.rtt" inst)" -gt 0 ] || die "treelet trace: no tlas or inst reads"
"$bin" render "$sc" --instances bvh --accel bvh2 -W 16 -H 16 -o "$tmp/x.exr" >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] && grep -q -- "--instances bvh chooses" "$tmp/err" || die "--instances bvh --accel bvh2: '$(cat "$tmp/err")'"
"$bin" render "$sc" --instances deep -W 16 -H 16 -o "$tmp/x.exr" >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] && grep -q -- "--instances: unknown mode 'deep'" "$tmp/err" || die "--instances deep: '$(cat "$tmp/err")'"

# ---- 3. the runs table ----------------------------------------------------------
"$bin" sweep --scenes "$sc" --tracers recursive,packet,treelet --lights primary -W 16 -H 12 --sizes 4K --instances bvh \
    --db "$tmp/a.db" >/dev/null 2>"$tmp/err" || { cat "$tmp/err"; die "sweep --instances bvh"; }
"$bin" sweep --scenes "$sc" --tracers recursive --lights primary -W 16 -H 12 --sizes 4K \
    --db "$tmp/a.db" >/dev/null 2>"$tmp/err" || { cat "$tmp/err"; die "plain sweep"; }
got=$(q "$tmp/a.db" "SELECT group_concat(t, ',') FROM (SELECT tracer || ':' || instances AS t FROM runs ORDER BY t)")
[ "$got" = "packet:bvh,recursive:bvh,recursive:flatten,treelet:bvh" ] ||
    die "runs (tracer:instances): want packet:bvh,recursive:bvh,recursive:flatten,treelet:bvh, got '$got'"
# the classes table holds all 13 classes; the instanced run has rows per level
got=$(q "$tmp/a.db" "SELECT group_concat(name || ':' || grp, ',') FROM (SELECT * FROM classes WHERE name IN ('tlas','inst','alpha') ORDER BY name)")
[ "$got" = "alpha:geometry,inst:geometry,tlas:geometry" ] || die "classes table: '$got'"
got=$(q "$tmp/a.db" "SELECT group_concat(class, ',') FROM (SELECT DISTINCT t.class FROM traffic t JOIN runs r ON r.id = t.run_id WHERE r.instances = 'bvh' AND t.class IN ('tlas','inst','node','tri') ORDER BY t.class)")
[ "$got" = "inst,node,tlas,tri" ] || die "bvh run's level classes: '$got'"
got=$(q "$tmp/a.db" "SELECT COUNT(*) FROM traffic t JOIN runs r ON r.id = t.run_id WHERE r.instances = 'flatten' AND t.class IN ('tlas','inst')")
[ "$got" = 0 ] || die "flattened runs have tlas/inst rows: $got"
# a file made when there were 10 classes gets the new ones on its next open
q "$tmp/a.db" "DELETE FROM traffic WHERE class IN ('tlas','inst'); DELETE FROM traffic_gen WHERE class IN ('tlas','inst'); DELETE FROM classes WHERE name IN ('tlas','inst','alpha')" >/dev/null
"$bin" sweep --scenes "$sc" --tracers recursive --lights primary -W 16 -H 12 --sizes 8K --instances bvh \
    --db "$tmp/a.db" >/dev/null 2>"$tmp/err" || { cat "$tmp/err"; die "sweep into a 10-class database"; }
got=$(q "$tmp/a.db" "SELECT COUNT(*) FROM classes")
[ "$got" = 13 ] || die "classes after reopening a 10-class database: $got"

# ---- 4. report --figure instances: traffic per level ----------------------------
# the a.db runs: recursive bvh and flatten at 4K (and bvh at 8K); the csv's
# levels are the traffic table's class sums
"$bin" report --db "$tmp/a.db" --figure instances > "$tmp/rep.md" 2>"$tmp/err" || { cat "$tmp/err"; die "report --figure instances"; }
grep -q "^| inst (two-level) | tlas |" "$tmp/rep.md" || die "report: no two-level tlas row: $(cat "$tmp/rep.md")"
for l in inst blas shade geometry; do grep -q "^|  | $l |" "$tmp/rep.md" || die "report: no $l row"; done
grep -q "^| kd (flatten) | nodes |" "$tmp/rep.md" || die "report: no flattened row"
grep -q "^Two-level geometry over flattened: at 4 KB" "$tmp/rep.md" || die "report: no finding line"
"$bin" report --db "$tmp/a.db" --figure instances --format csv > "$tmp/rep.csv" 2>"$tmp/err" || die "report csv: $(cat "$tmp/err")"
lev() { grep "\",$1,$2,$3,4096," "$tmp/rep.csv" | grep "recursive" | head -1 | sed 's/.*,//'; }
sum() { q "$tmp/a.db" "SELECT CAST(TOTAL(t.traffic_bytes) AS INTEGER) FROM traffic t JOIN runs r ON r.id = t.run_id JOIN cache_configs c ON c.id = t.config_id WHERE r.tracer = 'recursive' AND r.instances = '$1' AND r.lights = 0 AND c.size = 4096 AND c.line = 64 AND c.assoc = 0 AND t.class IN ($2)"; }
for x in "inst bvh tlas 'tlas'" "inst bvh inst 'inst'" "inst bvh blas 'node','index','tri'" "kd flatten nodes 'node','index'" "kd flatten tri 'tri'"; do
    set -- $x
    got=$(lev $1 $2 $3); want=$(sum $2 "$4")
    [ -n "$got" ] && [ "$got" = "$want" ] || die "report csv $1 $3 at 4 KB: '$got', the traffic table says '$want'"
done
"$bin" report --db "$tmp/a.db" --figure instances --scene nosuch > /dev/null 2>"$tmp/err"
[ $? -ne 0 ] && grep -q "no two-level run beside a flattened run" "$tmp/err" || die "report on no runs: $(cat "$tmp/err")"

[ $fail -eq 0 ] && echo "inst_cli: ok"
exit $fail
