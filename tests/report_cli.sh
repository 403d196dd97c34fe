#!/bin/sh
# `raytraffic report` from the command line: a scene whose file name is a
# shell injection is plotted without running it; the database is opened
# read-only (read-only file and folder, no side files); a missing database
# is a one-line error and is not created; a newer schema is refused; a
# failing gnuplot and a mesh that has moved are errors, not silent; a
# report with nothing to show is one line and exit 1, nothing on stdout;
# the full report opens with its summary.
# SKIP (77) only when gnuplot is missing.
set -u
bin=${RT_BIN:-./raytraffic}
src=${RT_SRCDIR:-.}
tmp=$(mktemp -d /tmp/rt-report-XXXXXX)
trap 'chmod -R u+w "$tmp" 2>/dev/null; rm -rf "$tmp"' EXIT
fail=0
gp=${RT_GNUPLOT:-}
[ -n "$gp" ] || gp=$(command -v gnuplot 2>/dev/null) || { echo "SKIP: gnuplot not installed"; exit 77; }

cd "$tmp" || exit 1
mesh="x'\$(touch PWNED)'\"q.obj"
cp "$src/data/meshes/cube.obj" "$mesh" || { echo "FAIL: copy mesh"; exit 1; }
"$bin" sweep --scenes "$mesh" --lights primary -W 8 -H 8 --sizes 1K,4K --db i.db >log 2>&1 ||
    { echo "FAIL: sweep of the injection scene"; cat log; exit 1; }

# 1. the injection: plots drawn, nothing run
"$bin" report --db i.db --plot out >report.md 2>log || { echo "FAIL: report --plot"; cat log; fail=1; }
# the command would run in report's folder or gnuplot's: look there and
# in the build and source folders
if [ -n "$(find "$tmp" -name PWNED)" ] || [ -e "${RT_BUILDDIR:-.}/PWNED" ] || [ -e "$src/PWNED" ] ||
    [ -e "$tmp/out/PWNED" ]; then
    echo "FAIL: the scene name ran a command (PWNED created)"; fail=1
fi
[ -s "out/$mesh-traffic.png" ] || { echo "FAIL: no traffic plot"; ls out; fail=1; }
[ -s "out/$mesh-traffic.svg" ] || { echo "FAIL: no svg plot"; fail=1; }
[ -s out/scenes.png ] || { echo "FAIL: no scenes.png"; fail=1; }
grep -q "wrote out/scenes.png" log || { echo "FAIL: no 'wrote' line"; cat log; fail=1; }
grep -q "noenhanced" "out/$mesh-traffic.gp" || { echo "FAIL: titles not noenhanced"; fail=1; }
grep -q "$mesh" report.md || { echo "FAIL: report lacks the scene"; fail=1; }
# the traffic plot: geometry, ray, total and the reduction, keys outside
# the panels, cache sizes as powers of two; the scene strip names scenes
gpf="out/$mesh-traffic.gp"
grep -q 'total (geometry + ray) traffic' "$gpf" && grep -q 'recursive / dynamic' "$gpf" &&
    grep -q 'set key at screen' "$gpf" && ! grep -q 'set key .*inside\|set key top' "$gpf" &&
    grep -q 'set xtics ("1K" 1, "4K" 4)' "$gpf" || { echo "FAIL: traffic plot script: $(grep -c . "$gpf") lines"; fail=1; }
grep -q 'set title ".*q.obj" noenhanced' out/scenes.gp 2>/dev/null || grep -q 'set title' out/scenes.gp ||
    { echo "FAIL: scenes.png without scene names"; fail=1; }

# 2. a failing gnuplot is an error
RT_GNUPLOT=/bin/false "$bin" report --db i.db --plot out2 >/dev/null 2>log && { echo "FAIL: failing gnuplot exited 0"; fail=1; }
grep -q "gnuplot exited with status 1" log || { echo "FAIL: failing gnuplot message"; cat log; fail=1; }

# 3. the mesh has moved: an error naming it, no black picture
mv "$mesh" moved.obj
"$bin" report --db i.db --plot out3 >/dev/null 2>log && { echo "FAIL: missing mesh exited 0"; fail=1; }
grep -q "PWNED" log || { echo "FAIL: missing mesh message does not name it"; cat log; fail=1; }
[ -e out3/scenes.png ] && { echo "FAIL: scenes.png written without the mesh"; fail=1; }
mv moved.obj "$mesh"

# 4. read-only database in a read-only folder
mkdir ro && cp i.db ro/ && chmod a-w ro/i.db ro
"$bin" report --db ro/i.db >ro.md 2>log || { echo "FAIL: read-only report"; cat log; fail=1; }
sed 's#ro/i.db#i.db#' ro.md | cmp -s - report.md || { echo "FAIL: read-only report differs"; fail=1; }
ls ro | grep -q -- '-wal\|-shm' && { echo "FAIL: side files in the read-only folder: $(ls ro)"; fail=1; }
# as a user who cannot write there, the folder really is read-only
user=""
[ "$(id -u)" != 0 ] || { chmod o+rx "$tmp"; user="setpriv --reuid=65534 --regid=65534 --clear-groups"; }
# (the unprivileged user must reach the binary and the paper's tables: not
# so in a tree under a private home, as /root)
if [ -z "$user" ] || { $user "$bin" version >/dev/null 2>&1 && $user test -r "$src/data/paper_primary.csv"; }; then
    if $user "$bin" report --db ro/i.db >ro2.md 2>log && cmp -s ro.md ro2.md; then :; else
        echo "FAIL: report as a user who cannot write"; cat log; fail=1
    fi
else
    echo "note: an unprivileged user cannot reach the binary or its data; read-only folder checked as root only"
fi
chmod u+w ro

# 5. missing database: one line, exit 1, nothing created
"$bin" report --db none.db >out.txt 2>log
rc=$?
[ "$rc" = 1 ] || { echo "FAIL: missing database exit $rc"; fail=1; }
[ "$(wc -l <log)" = 1 ] && grep -q "none.db: No such file" log || { echo "FAIL: missing database message"; cat log; fail=1; }
[ -e none.db ] && { echo "FAIL: missing database was created"; fail=1; }

# 6. newer schema refused
cp i.db newer.db && sqlite3 newer.db "PRAGMA user_version = 9" 2>/dev/null
"$bin" report --db newer.db >/dev/null 2>log && { echo "FAIL: newer schema accepted"; fail=1; }
grep -q "schema version 9 is newer" log || { echo "FAIL: newer schema message"; cat log; fail=1; }

# 7. nothing to show: one line on stderr, exit 1, nothing on stdout (a
# figure of a scene the database lacks, in Markdown and CSV; a figure of
# runs it lacks; speed against error and the appendix without approximate
# runs)
for args in "--figure 4" "--figure 9 --format csv" "--figure accel" "--figure treelet" "--speed-error" \
    "--appendix"; do
    # shellcheck disable=SC2086
    "$bin" report --db i.db $args >out.txt 2>log
    rc=$?
    [ "$rc" = 1 ] && [ ! -s out.txt ] && [ "$(wc -l <log)" = 1 ] ||
        { echo "FAIL: report $args with nothing to show: exit $rc, stdout $(wc -c <out.txt) bytes, $(cat log)"; fail=1; }
done
grep -q "nothing to show for figure 4: no run of the paper's room" log 2>/dev/null ||
    "$bin" report --db i.db --figure 4 2>&1 | grep -q "nothing to show for figure 4" ||
    { echo "FAIL: figure 4 message"; fail=1; }
# the full report opens with its summary, headings descend one level at a time
"$bin" report --db i.db >full.md 2>log || { echo "FAIL: report"; cat log; fail=1; }
[ "$(grep -m1 -n '^## ' full.md)" = "3:## Summary" ] || { echo "FAIL: report does not open with its summary"; head -5 full.md; fail=1; }
grep -q "^- Command: \`.*sweep --scenes" full.md && grep -q "^- Revision: [0-9a-fu]" full.md &&
    grep -q "^- Preset: none" full.md || { echo "FAIL: summary lacks command, revision or preset"; fail=1; }
awk '/^#/ { n = index($0, " ") - 1; if (p && n > p + 1) { print "jump: " $0; bad = 1 } p = n } END { exit bad }' full.md ||
    { echo "FAIL: a heading level is skipped"; fail=1; }

[ "$fail" = 0 ] && echo "report_cli: ok"
exit $fail
