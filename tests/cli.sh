#!/bin/sh
# Front-end conventions: --help on every subcommand, exit codes, --version.
set -u
bin=${RT_BIN:-./raytraffic}
fail=0
check() { # expected-status description command...
    want=$1; shift; what=$1; shift
    "$@" >/dev/null 2>&1; got=$?
    if [ "$got" -ne "$want" ]; then echo "FAIL: $what: exit $got, want $want"; fail=1; fi
}
check 2 "no arguments: usage error" "$bin"
[ -z "$("$bin" 2>/dev/null)" ] || { echo "FAIL: no arguments: usage on stdout"; fail=1; }
"$bin" 2>&1 >/dev/null | grep -q '^Usage: raytraffic COMMAND' || { echo "FAIL: no arguments: no usage on stderr"; fail=1; }
check 0 "--version" "$bin" --version
check 2 "unknown command" "$bin" no-such-command
for c in scene render trace trace-info trace-dump sim sweep report db bench; do
    check 0 "$c --help" "$bin" "$c" --help
    check 0 "help $c" "$bin" help "$c"
done
"$bin" --version | grep -q '^git revision:' || { echo "FAIL: --version lacks git revision"; fail=1; }
# sweep names the tracers it knows; bench --help lists every --what item
msg=$("$bin" sweep --tracers foo --list-jobs 2>&1 >/dev/null); st=$?
[ "$st" -eq 2 ] || { echo "FAIL: sweep --tracers foo: exit $st"; fail=1; }
case "$msg" in *"(recursive, packet, dynamic, "*treelet*) ;; *) echo "FAIL: sweep --tracers foo: $msg"; fail=1;; esac
"$bin" bench --help | sed -n '/--what LIST/,/(default tracers/p' | grep -q 'stream,' \
    || { echo "FAIL: bench --help: --what lacks stream"; fail=1; }
exit $fail
