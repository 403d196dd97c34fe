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
check 0 "no arguments prints usage" "$bin"
check 0 "--version" "$bin" --version
check 2 "unknown command" "$bin" no-such-command
for c in scene render trace trace-info trace-dump sim sweep report db bench; do
    check 0 "$c --help" "$bin" "$c" --help
    check 0 "help $c" "$bin" help "$c"
done
"$bin" --version | grep -q '^git revision:' || { echo "FAIL: --version lacks git revision"; fail=1; }
exit $fail
