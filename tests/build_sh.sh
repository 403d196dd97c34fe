#!/bin/sh
# scripts/build.sh, on a stub source tree (a copy of the script, a deps.sh
# and a configure that only record their calls, an autoreconf first in
# PATH): the build folder defaults to `build` (the README's default);
# a named folder is used as given, relative to the source tree, from any
# working folder; autoreconf runs when configure or Makefile.in is missing
# (an interrupted autoreconf leaves one without the other), not otherwise;
# configure runs once per folder.
set -u
src=${RT_SRCDIR:-.}
tmp=$(mktemp -d /tmp/rt-build-sh-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }
top=$tmp/tree
mkdir -p "$top/scripts" "$tmp/bin" "$tmp/elsewhere"
cp "$src/scripts/build.sh" "$top/scripts/"
cat > "$top/scripts/deps.sh" <<STUB
#!/bin/sh
echo deps >> "$tmp/calls"
STUB
cat > "$tmp/configure.stub" <<STUB
#!/bin/sh
echo "configure \$(basename "\$PWD")" >> "$tmp/calls"
printf 'all:\\n\\ttouch built\\n' > Makefile
touch config.status
STUB
cat > "$tmp/bin/autoreconf" <<STUB
#!/bin/sh
echo "autoreconf \$*" >> "$tmp/calls"
touch Makefile.in
cp "$tmp/configure.stub" configure
chmod +x configure
STUB
chmod +x "$top/scripts/deps.sh" "$tmp/bin/autoreconf"
run() { (cd "$tmp/elsewhere" && PATH="$tmp/bin:$PATH" bash "$top/scripts/build.sh" "$@") > "$tmp/out" 2>&1; }

run || die "no folder argument: exit $?: $(cat "$tmp/out")"
[ -f "$top/build/built" ] || die "no folder argument: nothing built in build/"
[ "$(tr '\n' ' ' < "$tmp/calls")" = "deps autoreconf -fi configure build " ] ||
    die "no folder argument: calls $(tr '\n' ' ' < "$tmp/calls")"
: > "$tmp/calls"
run other || die "folder argument: exit $?: $(cat "$tmp/out")"
[ -f "$top/other/built" ] || die "folder argument: nothing built in other/"
[ ! -e "$tmp/elsewhere/other" ] || die "folder argument taken relative to the working folder"
[ "$(tr '\n' ' ' < "$tmp/calls")" = "deps configure other " ] ||
    die "second folder: calls $(tr '\n' ' ' < "$tmp/calls")"
: > "$tmp/calls"
rm -f "$top/build/built"
run build || die "again: exit $?"
[ -f "$top/build/built" ] || die "again: nothing built"
[ "$(tr '\n' ' ' < "$tmp/calls")" = "deps " ] || die "again: calls $(tr '\n' ' ' < "$tmp/calls")"
: > "$tmp/calls"
rm "$top/Makefile.in"
run || die "Makefile.in missing: exit $?"
grep -q '^autoreconf' "$tmp/calls" || die "Makefile.in missing: autoreconf did not run"
exit $fail
