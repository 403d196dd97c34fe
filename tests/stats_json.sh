#!/bin/sh
# Statistics as data: every tracer's `render --json` loads with Python's
# json, has no key twice (anywhere in the document), and holds its
# tracer statistics as an object ("stats") whose numbers are JSON numbers
# and whose keys and values are those of the old "extra" string; a sweep's
# every run has a valid stats_json (sqlite json_valid) with the keys of its
# stats text, once each, and json_extract reads the same numbers the text
# holds.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt_stats_json.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }

# the JSON checks: unique keys at every level; stats equal to the extra
# string's pairs, numbers as numbers; the tracer's own expectation ($2)
check_render() {
    python3 - "$1" "$2" <<'PY'
import json, sys
def pairs(kv):
    seen = {}
    for k, v in kv:
        if k in seen:
            sys.exit("key %r twice" % k)
        seen[k] = v
    return seen
d = json.load(open(sys.argv[1]), object_pairs_hook=pairs)
st = d["stats"]
if not isinstance(st, dict):
    sys.exit("stats is not an object: %r" % (st,))
extra = d.get("extra", "")
toks = [t.split("=", 1) for t in extra.split(" ")] if extra else []
if [k for k, _ in toks] != list(st):
    sys.exit("stats keys %r differ from extra %r" % (list(st), extra))
for k, v in toks:
    j = st[k]
    if isinstance(j, str):
        if j != v:
            sys.exit("%s: %r vs %r" % (k, j, v))
        try:
            float(v)
            sys.exit("%s: number %r kept as a string" % (k, v))
        except ValueError:
            pass
    elif float(v) != j:
        sys.exit("%s: %r vs %r" % (k, j, v))
exp = sys.argv[2]
if exp == "packet" and st != {"packet": 8}:
    sys.exit("packet stats %r" % st)
if exp == "dynamic" and (st["queue_points"] < 1 or not isinstance(st["queue_points"], int)
                         or st["rays"] != d["rays_primary"] or st["gmax_rule"] != "resident-top"):
    sys.exit("dynamic stats %r" % st)
if exp == "treelet" and not (isinstance(st["treelets"], int) and st["treelets"] >= 1):
    sys.exit("treelet stats %r" % st)
PY
}

for t in recursive packet dynamic stream-branching stream-multipass feedback treelet; do
    if "$bin" render cornell:glass=0 -W 16 -H 16 -t "$t" --json -o "$tmp/$t.exr" > "$tmp/$t.json" 2> "$tmp/$t.err"; then
        msg=$(check_render "$tmp/$t.json" "$t" 2>&1) || err "render -t $t --json: $msg: $(cat "$tmp/$t.json")"
    else
        err "render -t $t exited $?: $(cat "$tmp/$t.err")"
    fi
done
# the secondary-ray counters and host threads' merged statistics append
# keys of their own: still once each
i=0
for v in "-t packet --mode whitted" "-t dynamic --mode whitted" "-t treelet --mode whitted --threads 2" \
    "-t recursive --mode whitted --threads 2" "-t stream-multipass --mode whitted"; do
    i=$((i + 1))
    # shellcheck disable=SC2086 # $v is a list of options
    if "$bin" render cornell -W 16 -H 16 $v --json -o "$tmp/v$i.exr" > "$tmp/v$i.json" 2> "$tmp/v$i.err"; then
        msg=$(check_render "$tmp/v$i.json" "" 2>&1) || err "render $v --json: $msg: $(cat "$tmp/v$i.json")"
        python3 -c 'import json, sys; s = json.load(open(sys.argv[1]))["stats"]
if not isinstance(s.get("rays_secondary"), int) or s["rays_secondary"] <= 0: sys.exit("no rays_secondary: %r" % s)' \
            "$tmp/v$i.json" || err "render $v: no secondary-ray count in stats"
    else
        err "render $v exited $?: $(cat "$tmp/v$i.err")"
    fi
done

# the database: a small sweep over every tracer family and two structures
"$bin" sweep --scenes cornell:glass=0 --tracers recursive,packet,dynamic,treelet,feedback,stream-branching \
    --accels kd,bvh4 --lights primary,0 -W 16 -H 16 --sizes 1K --db "$tmp/s.db" > /dev/null 2> "$tmp/sweep.err" ||
    { err "sweep: $(cat "$tmp/sweep.err")"; }
n=$(sqlite3 "$tmp/s.db" "SELECT count(*) FROM runs")
bad=$(sqlite3 "$tmp/s.db" "SELECT count(*) FROM runs WHERE stats_json IS NULL OR NOT json_valid(stats_json)
    OR json_type(stats_json) <> 'object'")
[ "${n:-0}" -ge 6 ] && [ "$bad" = 0 ] || err "$bad of $n runs without a valid stats_json"
q=$(sqlite3 "$tmp/s.db" "SELECT count(*) FROM runs WHERE json_extract(stats_json, '\$.rays_primary') = 256
    AND stats LIKE 'rays_primary=256 %'")
[ "$q" = "$n" ] || err "json_extract(stats_json, '\$.rays_primary') = 256 in $q of $n runs"
msg=$(python3 - "$tmp/s.db" <<'PY'
import json, sqlite3, sys
def pairs(kv):
    d = {}
    for k, v in kv:
        if k in d:
            raise SystemExit("key %r twice" % k)
        d[k] = v
    return d
con = sqlite3.connect(sys.argv[1])
for rid, tracer, text, js in con.execute("SELECT id, tracer, stats, stats_json FROM runs ORDER BY id"):
    obj = json.loads(js, object_pairs_hook=pairs)
    keys = [t.split("=", 1)[0] for t in text.split(" ")]
    if keys != list(obj):
        raise SystemExit("run %d (%s): keys %r vs stats %r" % (rid, tracer, list(obj), text))
    if not isinstance(obj["nodes"], int) or obj["nodes"] <= 0:
        raise SystemExit("run %d: nodes %r" % (rid, obj["nodes"]))
PY
) || err "stats_json: $msg"

[ $fail = 0 ] && echo "PASS: statistics as JSON"
exit $fail
