#!/bin/sh
# The render option table from the command line:
#  1. the front end built with one table entry more (tests/raytraffic_optx,
#     RT_OPTDEFS_EXAMPLE: --example-edge, read by the packet tracer) takes
#     it in render, trace and sweep and lists it in their --help, and the
#     tracers that do not read it refuse it; the plain binary knows nothing
#     of it;
#  2. every numeric option of render, trace, sweep, bench and trace-dump
#     refuses 0x10, ' 1', +2, 1e999 and nan (exit 2, the option named);
#  3. --lights refuses an index --light did not define;
#  4. --look-at: a view direction not finite in single precision, and the
#     scene's up along the view direction, are usage errors that say so.
set -u
bin=${RT_BIN:-./raytraffic}
optx=${RT_BUILDDIR:-.}/tests/raytraffic_optx
tmp=$(mktemp -d /tmp/rt-options-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }
# want STATUS DESCRIPTION command... : exit status and stderr in $tmp/err
want() {
    st=$1; shift; what=$1; shift
    "$@" >"$tmp/out" 2>"$tmp/err"; got=$?
    [ "$got" -eq "$st" ] || die "$what: exit $got, want $st ($(head -c 300 "$tmp/err"))"
}

# ---- 1. an entry added to the table ---------------------------------------
[ -x "$optx" ] || die "$optx not built"
for c in render trace sweep; do
    "$optx" $c --help 2>&1 | grep -q -- '--example-edge N' || die "$c --help lacks the added entry"
    "$bin" $c --help 2>&1 | grep -q -- '--example-edge' && die "plain $c --help lists the test entry"
done
"$optx" render --help | grep -q '^  --example-edge N   packet: the packet edge again (an entry the tests add)$' \
    || die "render --help: the entry's line is not formatted like the others"
want 0 "render takes the added option" "$optx" render cornell -t packet --example-edge 4 -W 16 -H 16 -o "$tmp/a.exr"
want 2 "the recursive tracer refuses it" "$optx" render cornell --example-edge 4 -W 16 -H 16 -o "$tmp/b.exr"
grep -q -- "--example-edge does not apply to the recursive tracer (only to packet)" "$tmp/err" \
    || die "refusal: $(cat "$tmp/err")"
want 0 "trace takes it" "$optx" trace cornell -t packet --example-edge 2 -W 16 -H 16 -o "$tmp/t.rtt"
"$optx" trace-info "$tmp/t.rtt" | grep -q 'packet=2' || die "trace: the run key lacks packet=2"
want 2 "its parser refuses 0x10" "$optx" trace cornell -t packet --example-edge 0x10 -o "$tmp/u.rtt"
want 0 "sweep takes it" "$optx" sweep --scenes cornell --tracers packet --example-edge 4 --list-jobs
grep -q "'--example-edge' '4'" "$tmp/out" || die "sweep --list-jobs lost the option: $(head -c 300 "$tmp/out")"
want 2 "sweep without a reader refuses it" "$optx" sweep --scenes cornell --tracers recursive --example-edge 4 --list-jobs
grep -q -- "--example-edge does not apply" "$tmp/err" || die "sweep refusal: $(cat "$tmp/err")"
want 2 "the plain binary does not know it" "$bin" render cornell -t packet --example-edge 4 -o "$tmp/c.exr"

# --help lists the tracers of the tracers' table, the ones an unknown -t names
"$bin" render cornell -t nosuch -o "$tmp/x.exr" 2>&1 | sed -n 's/.*unknown tracer .nosuch. (\(.*\))$/\1/p' | tr -d ',' > "$tmp/tr"
[ -s "$tmp/tr" ] || die "no tracer list in the unknown-tracer message"
"$bin" render --help | sed -n '/^  -t TRACER/,/(default/p' > "$tmp/th"
for t in $(cat "$tmp/tr"); do grep -q -- "$t" "$tmp/th" || die "render --help -t lacks $t: $(cat "$tmp/th")"; done

# ---- 2. strict numbers ----------------------------------------------------
# OPTION PREFIX SUFFIX: the bad word goes between prefix and suffix
numeric="-W|| -H|| --packet|| --cache-size|| --gmax|| --subsample||:8 --threads|| --depth|| --spp|| --bounces||
 --vb-size|| --grid-min|| --grid-density|| --oracle-fraction|| --unroll||,1 --ray-window|| --fov||
 --look-at||,0,2,0,0,0 --light|0.5,|,0.9 --light|0.5,0.5,0.9,|"
for ent in $numeric; do
    opt=${ent%%|*}; rest=${ent#*|}; pre=${rest%%|*}; suf=${rest#*|}
    for b in 0x10 ' 1' +2 1e999 nan; do
        want 2 "render $opt '$pre$b$suf'" "$bin" render cornell "$opt" "$pre$b$suf" -o "$tmp/n.exr"
        grep -q -- "$opt" "$tmp/err" || die "render $opt '$pre$b$suf': message does not name it: $(cat "$tmp/err")"
    done
done
for b in 0x10 ' 1' +2 1e999 nan; do
    want 2 "trace --level '$b'" "$bin" trace cornell --level "$b" -o "$tmp/n.rtt"
    want 2 "trace-dump --limit '$b'" "$bin" trace-dump --limit "$b" "$tmp/none.rtt"
    for o in --reps --sim-refs --ref-spp; do
        want 2 "bench $o '$b'" "$bin" bench "$o" "$b" --what sim --sim-refs 10
        grep -q -- "$o" "$tmp/err" || die "bench $o '$b': message does not name it: $(cat "$tmp/err")"
    done
    for o in --jobs --job --line -W --grid-density --threads; do
        want 2 "sweep $o '$b'" "$bin" sweep --scenes cornell --tracers dynamic,feedback "$o" "$b" --list-jobs
        grep -q -- "$o" "$tmp/err" || die "sweep $o '$b': message does not name it: $(cat "$tmp/err")"
    done
done
want 0 "a plain value is taken" "$bin" render cornell --grid-density 4 -t feedback -W 8 -H 8 -o "$tmp/g.exr"

# ---- 3. --lights names only lights that exist ------------------------------
want 2 "--lights 1,2 with one --light" "$bin" trace cornell --light 0.5,0.5,0.9 --lights 1,2 -W 8 -H 8 -o "$tmp/l.rtt"
grep -q -- "--lights: light 1 is not defined" "$tmp/err" || die "lights message: $(cat "$tmp/err")"
[ -e "$tmp/l.rtt" ] && die "a refused trace left its file"
want 0 "--lights all with one --light" "$bin" trace cornell --light 0.5,0.5,0.9 --lights all -W 8 -H 8 -o "$tmp/l.rtt"
want 0 "--lights 0,1 with two" "$bin" render cornell --light 0.5,0.5,0.9 --light 0.2,0.5,0.9 --lights 0,1 -W 8 -H 8 \
    -o "$tmp/l.exr"
want 2 "sweep lighting 1 with one --light" "$bin" sweep --scenes cornell --tracers recursive --light 0.5,0.5,0.9 \
    --lights primary,1 --list-jobs
grep -q "light 1 is not defined" "$tmp/err" || die "sweep lights message: $(cat "$tmp/err")"

# ---- 4. --look-at's frame ---------------------------------------------------
want 2 "--look-at at 1e20" "$bin" render cornell --look-at 1e20,1e20,1e20,-1e20,-1e20,-1e20 -W 8 -H 8 -o "$tmp/v.exr"
grep -q "not finite" "$tmp/err" || die "large look-at message: $(cat "$tmp/err")"
want 2 "--look-at along knot's up" "$bin" render knot --look-at 0,0,12,0,0,0 -W 8 -H 8 -o "$tmp/v.exr"
grep -q "the scene's up vector (0,0,1) is along the view direction.*UX,UY,UZ" "$tmp/err" \
    || die "scene-up message: $(cat "$tmp/err")"
want 0 "--look-at with its own up" "$bin" render knot --look-at 0,0,12,0,0,0,0,1,0 -W 8 -H 8 -o "$tmp/v.exr"
exit $fail
