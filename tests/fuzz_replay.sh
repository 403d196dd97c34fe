#!/bin/sh
# fuzz_replay.sh -- replays the fuzz seed corpora and the regression inputs
# (tests/fuzz/corpus/TARGET, tests/fuzz/regress/TARGET) through the
# harnesses' standalone mains (tests/fuzz/replay_TARGET, built by
# `make check`). Every input must run to the end without a crash or a
# broken contract (a sanitizer build, --enable-sanitizers, also catches
# memory errors); seeds named ok-* must be accepted and bad-* refused, so
# a harness that silently reads nothing fails here.
set -u
src=${RT_SRCDIR:-.}/tests/fuzz
bld=${RT_BUILDDIR:-.}/tests/fuzz
fail=0
for t in trace din obj ply cli pbrt gz; do
  for d in corpus regress; do
    dir=$src/$d/$t
    test -d "$dir" || continue
    nfiles=$(ls "$dir" | wc -l)
    test "$nfiles" -gt 0 || continue
    out=$("$bld/replay_$t" "$dir" 2>/tmp/fuzz_replay.$$)
    rc=$?
    if test $rc -ne 0; then
      echo "FAIL $t $d: exit $rc"; cat /tmp/fuzz_replay.$$; fail=1; continue
    fi
    n=$(printf '%s\n' "$out" | grep -c ': \(accepted\|refused\)$')
    if test "$n" -ne "$nfiles"; then echo "FAIL $t $d: $n verdicts for $nfiles files"; fail=1; fi
    wrong=$(printf '%s\n' "$out" | grep -E '/ok-[^/]*: refused$|/bad-[^/]*: accepted$')
    if test -n "$wrong"; then echo "FAIL $t $d: wrong verdicts:"; echo "$wrong"; fail=1; fi
    echo "ok $t $d: $nfiles inputs"
  done
done
rm -f /tmp/fuzz_replay.$$
exit $fail
