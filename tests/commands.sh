#!/bin/sh
# Every command the scripts and tests run is installed by the project's own
# scripts on a bare Debian 12. tests/commands.pl lists the commands in
# command position in scripts/*.sh, run.sh, test.sh, .ci/run, tests/*.sh
# and tests/fuzz/*.sh; scripts/commands.txt maps each to its package and
# says who installs it. Fails when
#  - a script runs a command missing from scripts/commands.txt, or the list
#    holds a command no script runs (unless marked indirect);
#  - a deps/engines/fresh package is not in that list of scripts/deps.sh;
#  - a base package is neither Essential nor Priority: required (dpkg);
#  - an installed command belongs, by dpkg, to another package than the
#    one listed, or to one the listed package does not depend on.
# First the scanner itself on a script whose commands are known.
set -u
src=${RT_SRCDIR:-.}
list=$src/scripts/commands.txt
tmp=$(mktemp -d /tmp/rt-commands-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }

# ---- the scanner on known input -------------------------------------------
cat > "$tmp/known.sh" <<'SCRIPT'
#!/usr/bin/env bash
# comment: notacmd
x=$(cmd1 -a "$y" | cmd2) z=1 cmd3 'q1 q2' "$(cmd4)" 2>&1 >/dev/null
arr=(notacmd -W 3)
f() { cmd5 "$@"; }
f arg
case $x in
  notacmd|*.c) cmd6 ;;
  (other) nice -n 10 cmd7 --opt ;;
esac
if ! command -v cmd8 >/dev/null; then "$bin" notacmd; fi
cat <<EOF | cmd9
notacmd $(cmd10)
EOF
y="text $(cmd11 'a b') notacmd" && echo "$((1 + 2))" ${v:-notacmd} ; [ -x /bin/notacmd ] || /usr/bin/cmd12
sh -c 'notacmd' && for i in notacmd a; do cmd13 < "$i"; done
$SUDO cmd14 `cmd15` ./notacmd tests/notacmd.sh
SCRIPT
perl "$src/tests/commands.pl" "$tmp/known.sh" | awk '{ print $2 }' | LC_ALL=C sort -u | tr '\n' ' ' > "$tmp/got"
want="bash cat cmd1 cmd10 cmd11 cmd12 cmd13 cmd14 cmd15 cmd2 cmd3 cmd4 cmd5 cmd6 cmd7 cmd8 cmd9 env nice sh "
[ "$(cat "$tmp/got")" = "$want" ] || die "scanner: got '$(cat "$tmp/got")', want '$want'"

# ---- the project's scripts ------------------------------------------------
set --
for f in "$src"/scripts/*.sh "$src/run.sh" "$src/test.sh" "$src/.ci/run" "$src"/tests/*.sh "$src"/tests/fuzz/*.sh; do
    [ -f "$f" ] && set -- "$@" "$f"
done
perl "$src/tests/commands.pl" "$@" > "$tmp/uses" || die "scanner failed"
nuses=$(awk '{ print $2 }' "$tmp/uses" | sort -u | wc -l)
[ "$nuses" -ge 40 ] || die "scanner found only $nuses commands"

grep -v '^#' "$list" | awk 'NF' > "$tmp/table"
awk -v L="$list" '
    NF < 3 || NF > 4 || ($4 != "" && $4 != "indirect") { print "FAIL: " L ": bad line: " $0; next }
    $3 !~ /^(base|deps|engines|fresh|optional)$/ { print "FAIL: " L ": " $1 ": unknown list " $3 }
    seen[$1]++ { print "FAIL: " L ": " $1 " listed twice" }' "$tmp/table" > "$tmp/bad"
[ -s "$tmp/bad" ] && { cat "$tmp/bad"; fail=1; }

# used but not listed; listed but not used
awk -v S="$src/" 'NR == FNR { known[$1] = 1; next }
    !known[$2] { w = $1; if (index(w, S) == 1) w = substr(w, length(S) + 1)
                 print "FAIL: " w ": runs " $2 ", which is not in scripts/commands.txt" }' \
    "$tmp/table" "$tmp/uses" > "$tmp/bad"
awk 'NR == FNR { used[$2] = 1; next }
    !used[$1] && $4 != "indirect" { print "FAIL: scripts/commands.txt: no script runs " $1 }' \
    "$tmp/uses" "$tmp/table" >> "$tmp/bad"
[ -s "$tmp/bad" ] && { cat "$tmp/bad"; fail=1; }

# the packages are in deps.sh's lists
for l in deps engines fresh; do
    opt=; [ $l = deps ] || opt=--$l
    # shellcheck disable=SC2086
    bash "$src/scripts/deps.sh" $opt --list > "$tmp/pk.$l" || die "scripts/deps.sh $opt --list failed"
    awk -v l=$l 'NR == FNR { have[$1] = 1; next }
        $3 == l && !have[$2] { print "FAIL: " $1 ": package " $2 " is not in scripts/deps.sh" (l == "deps" ? "" : " --" l) "'"'"'s list" }' \
        "$tmp/pk.$l" "$tmp/table" > "$tmp/bad"
    [ -s "$tmp/bad" ] && { cat "$tmp/bad"; fail=1; }
done

# What dpkg knows, on a Debian machine: base packages are in every system,
# each installed command belongs to its package (or to a package its
# package depends on: make to build-essential, clang-14 to clang).
if command -v dpkg-query >/dev/null 2>&1; then
    base=$(awk '$3 == "base" { print $2 }' "$tmp/table" | sort -u)
    # shellcheck disable=SC2086
    dpkg-query -W -f '${Package} ${Essential} ${Priority}\n' $base > "$tmp/prio" 2>/dev/null
    for p in $base; do
        grep -q "^$p \(yes [a-z]*\|[a-z]* required\)$" "$tmp/prio" ||
            die "$p is listed as base but is not Essential or Priority: required ($(grep "^$p " "$tmp/prio"))"
    done
    # candidate paths per command found in the system's folders (not in
    # PATH: a user's own tools would be no proof): as found, /bin <->
    # /usr/bin (merged /usr), the target of its links (awk -> mawk)
    while read -r c p l x; do
        w=
        for d in /usr/bin /bin /usr/sbin /sbin; do
            [ -x "$d/$c" ] && { w=$d/$c; break; }
        done
        [ -n "$w" ] || continue
        r=$(readlink -f "$w")
        for q in "$w" "$r"; do
            echo "$c $q"
            case $q in /usr/*) echo "$c ${q#/usr}";; *) echo "$c /usr$q";; esac
        done
    done < "$tmp/table" > "$tmp/paths"
    ninst=$(awk '{ print $1 }' "$tmp/paths" | sort -u | wc -l)
    # shellcheck disable=SC2046
    dpkg-query -S $(awk '{ print $2 }' "$tmp/paths" | sort -u) 2>/dev/null |
        grep -v '^diversion' | sed 's/:[a-z0-9]*:/:/' > "$tmp/owners"
    awk 'NR == FNR { sub(/:$/, "", $1); owner[$2] = $1; next }
        !($1 in got) && ($2 in owner) { got[$1] = owner[$2] }
        END { for (c in got) print c, got[c] }' "$tmp/owners" "$tmp/paths" > "$tmp/own"
    while read -r c o; do
        p=$(awk -v c="$c" '$1 == c { print $2 }' "$tmp/table")
        [ "$o" = "$p" ] && continue
        dpkg-query -W -f '${Depends}, ${Pre-Depends}\n' "$p" 2>/dev/null | tr ',|' '\n\n' |
            awk '{ print $1 }' | sed 's/:any$//' | grep -qx "$o" ||
            die "$c: dpkg says package $o, scripts/commands.txt says $p (which does not depend on $o)"
    done < "$tmp/own"
    echo "dpkg: $(wc -l < "$tmp/own") of $ninst installed commands checked against their packages"
else
    echo "dpkg-query missing: packages not checked against this system"
fi
echo "$nuses commands in $# scripts, $(wc -l < "$tmp/table") in scripts/commands.txt"
exit $fail
