#!/bin/sh
# The feedback tracer end to end: usage errors (exit 2) for an unknown
# --accel, the path mode and a vertex buffer too small (the message gives
# the size needed); a run prints its passes, S_VB and stage shares in the
# --json statistics; --heatmap writes a PNG.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt_feedback_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }

"$bin" render cornell -t feedback --accel bvh -W 8 -H 8 -o "$tmp/a.exr" 2>"$tmp/e1"
[ $? -eq 2 ] || err "--accel bvh: want exit 2"
grep -q "accel" "$tmp/e1" || err "--accel bvh: message '$(cat "$tmp/e1")'"

"$bin" render cornell -t feedback --mode path -W 8 -H 8 -o "$tmp/a.exr" 2>"$tmp/e2"
[ $? -eq 2 ] || err "--mode path: want exit 2"
grep -q "path" "$tmp/e2" || err "--mode path: message '$(cat "$tmp/e2")'"

# 16 x 16, shadows and one bounce: 16 * 16 * (2 + 1) * 64 = 49152 bytes
"$bin" render cornell:material=mirror -t feedback --mode whitted --depth 2 --lights 0 -W 16 -H 16 \
    --vb-size 49151 -o "$tmp/a.exr" 2>"$tmp/e3"
[ $? -eq 2 ] || err "--vb-size too small: want exit 2"
grep -q "49152 bytes" "$tmp/e3" || err "--vb-size: message '$(cat "$tmp/e3")'"

"$bin" render cornell:material=mirror -t feedback --mode whitted --depth 2 --lights 0 -W 16 -H 16 \
    --vb-size 49152 --json --heatmap "$tmp/h.png" -o "$tmp/a.exr" >"$tmp/j" 2>/dev/null
[ $? -eq 0 ] || err "--vb-size 49152: want exit 0"
grep -q '"tracer": "feedback"' "$tmp/j" || err "json: $(cat "$tmp/j")"
grep -q 'passes=3 composite=eq1 svb=49152 G=2 G2=1' "$tmp/j" || err "json extra: $(cat "$tmp/j")"
grep -q 'share_vs=' "$tmp/j" || err "no stage shares"
[ "$(head -c 8 "$tmp/h.png" | od -An -c | tr -d ' ')" = "211PNG\r\n032\n" ] || err "heat map is not a PNG"
exit $fail
