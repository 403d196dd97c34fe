#!/bin/sh
# `raytraffic sim` front end: din input, output formats, --db idempotence,
# a bad trace leaves nothing in the database, usage errors exit 2.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt_sim_cli.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }

# 17 lines cycled 4 times, one write per line on the first pass
i=0
while [ $i -lt 4 ]; do
    l=0
    while [ $l -lt 17 ]; do
        if [ $i -eq 0 ]; then echo "1 $(printf %x $((4096 + l * 64)))"; else echo "0 $(printf %x $((4096 + l * 64)))"; fi
        l=$((l + 1))
    done
    i=$((i + 1))
done > "$tmp/cyc.din"

"$bin" sim --sizes 1K,2K "$tmp/cyc.din" > "$tmp/out.txt" || die "sim text exit $?"
# 1K = 16 lines: every one of the 68 references misses; 17 write-backs
grep -E '^ +1024 +64 +full fb +68 +51 +17 +17 +0 +5440$' "$tmp/out.txt" >/dev/null || { die "1K row"; cat "$tmp/out.txt"; }
grep -E '^ +2048 +64 +full other +68 +0 +17 +0 +0 +1088$' "$tmp/out.txt" >/dev/null || die "2K group row"
"$bin" sim --format csv --sizes 1K "$tmp/cyc.din" | head -1 | grep -q '^trace,size_bytes,line,assoc,class,accesses' || die "csv header"
"$bin" sim --format json --sizes 1K "$tmp/cyc.din" | grep -q '"traffic_bytes": 5440' || die "json"
"$bin" sim --input-format din --din-class tri --sizes 1K "$tmp/cyc.din" | grep -q ' geometry ' || die "--din-class"
"$bin" sim --assoc 1 --line 48 --sizes 48K "$tmp/cyc.din" >/dev/null || die "direct-mapped 48-byte lines"
# --flush: the 17 lines written on the first pass stay dirty in 2K (32
# lines); the flush writes them back (17 x 64 more bytes)
"$bin" sim --flush --sizes 2K "$tmp/cyc.din" > "$tmp/fl.txt" || die "sim --flush exit $?"
grep -q 'policy wb-wa+flush,' "$tmp/fl.txt" || { die "--flush label"; cat "$tmp/fl.txt"; }
grep -E '^ +2048 +64 +full fb +68 +0 +17 +17 +0 +2176$' "$tmp/fl.txt" >/dev/null || { die "--flush row"; cat "$tmp/fl.txt"; }
"$bin" sim --write-fullline --flush --sizes 2K "$tmp/cyc.din" | grep -q 'policy wb-wa+flush+fullline,' || die "--write-fullline label"
"$bin" sim --method shards --flush "$tmp/cyc.din" >/dev/null 2>&1; [ $? -eq 2 ] || die "--flush with a sampled method must be a usage error"

# --repl: A B A C A in a 2-line cache; LRU keeps A (3 misses), FIFO evicts
# it for C (4 misses)
printf '0 1000\n0 1040\n0 1000\n0 1080\n0 1000\n' > "$tmp/abaca.din"
"$bin" sim --sizes 128 "$tmp/abaca.din" | grep -E '^ +128 +64 +full fb +5 +3 +0 ' >/dev/null || die "lru ABACA"
"$bin" sim --repl fifo --sizes 128 "$tmp/abaca.din" > "$tmp/fifo.txt" || die "sim --repl fifo exit $?"
grep -E '^ +128 +64 +full fb +5 +4 +0 ' "$tmp/fifo.txt" >/dev/null || { die "fifo ABACA"; cat "$tmp/fifo.txt"; }
grep -q 'policy wb-wa, replacement fifo, engine exact-persize' "$tmp/fifo.txt" || die "fifo header: $(head -1 "$tmp/fifo.txt")"
"$bin" sim --repl fifo --format json --sizes 128 "$tmp/abaca.din" | grep -q '"repl": "fifo"' || die "fifo json"
"$bin" sim --repl belady "$tmp/abaca.din" >/dev/null 2>"$tmp/err"; [ $? -eq 2 ] || die "unknown --repl must be a usage error"
grep -q "unknown replacement policy 'belady'" "$tmp/err" || die "unknown --repl message: $(cat "$tmp/err")"
"$bin" sim --repl fifo --method shards "$tmp/abaca.din" >/dev/null 2>&1; [ $? -eq 2 ] || die "--repl fifo with a sampled method must be a usage error"
"$bin" sim --seed 3 "$tmp/abaca.din" >/dev/null 2>&1; [ $? -eq 2 ] || die "--seed with exact lru must be a usage error"
"$bin" sim --repl plru --sizes 192 "$tmp/abaca.din" >/dev/null 2>"$tmp/err"; [ $? -eq 2 ] || die "plru with 3 ways must be a usage error"
grep -q "power-of-two" "$tmp/err" || die "plru ways message: $(cat "$tmp/err")"
"$bin" sim --repl opt --sizes 128 "$tmp/abaca.din" > "$tmp/opt.txt" || die "--repl opt exit"
grep -q 'replacement opt, engine exact-opt' "$tmp/opt.txt" || die "opt header: $(head -1 "$tmp/opt.txt")"
grep -E '^ +128 +64 +full fb +5 +3 +0 ' "$tmp/opt.txt" >/dev/null || { die "opt ABACA"; cat "$tmp/opt.txt"; }
for p in random plru srrip brrip; do
    "$bin" sim --repl $p --sizes 128 "$tmp/abaca.din" | grep -q "replacement $p," || die "--repl $p"
done
"$bin" sim --repl random --seed 5 --sizes 128 "$tmp/abaca.din" > "$tmp/r1.txt" || die "--repl random --seed"
"$bin" sim --repl random --seed 5 --sizes 128 "$tmp/abaca.din" | cmp -s - "$tmp/r1.txt" || die "--repl random: same seed, different output"

# --hierarchy: L1 = the 1K cache above (68 misses, 17 write-backs) sends
# 68 fetches + 17 write-backs down; a 2K last level holds all 17 lines:
# 17 read misses, the write-backs hit
"$bin" sim --hierarchy L1=1K/full/64/lru,LLC=1K+2K/full/64/lru "$tmp/cyc.din" > "$tmp/h.txt" || die "--hierarchy exit $?"
grep -E '^L1 +1024 +64 +full lru +fb +68 +51 +17 +17 +0 +5440$' "$tmp/h.txt" >/dev/null || { die "hierarchy L1 row"; cat "$tmp/h.txt"; }
grep -E '^LLC +2048 +64 +full lru +fb +85 +17 +0 +0 +0 +1088$' "$tmp/h.txt" >/dev/null || { die "hierarchy LLC row"; cat "$tmp/h.txt"; }
grep -q 'hierarchy L1=1K/full/64/lru,LLC=1K+2K/full/64/lru, policy wb-wa' "$tmp/h.txt" || die "hierarchy header: $(head -1 "$tmp/h.txt")"
"$bin" sim --hierarchy L1=1K/full/64/lru,LLC=2K/full/64/lru --format csv "$tmp/cyc.din" | grep -q ',LLC,2048,64,0,lru,other,85,17,0,0,0,1088$' || die "hierarchy csv"
"$bin" sim --hierarchy L1=1K/full/64/lru,LLC=2K/full/64/lru --format json "$tmp/cyc.din" | grep -q '"level": "LLC", "size_bytes": 2048' || die "hierarchy json"
"$bin" sim --hierarchy L1=1K/full/64/lru,LLC=2K/full/64/lru --flush "$tmp/cyc.din" | grep -E '^LLC +2048 .* fb +85 +17 +0 +17 ' >/dev/null || die "hierarchy --flush"
"$bin" sim --hierarchy L1=1K/full/64 "$tmp/cyc.din" >/dev/null 2>"$tmp/err"; [ $? -eq 2 ] || die "bad --hierarchy must be a usage error"
grep -q 'hierarchy level L1' "$tmp/err" || die "bad --hierarchy message: $(cat "$tmp/err")"
"$bin" sim --hierarchy LLC=2K/full/64/lru --sizes 1K "$tmp/cyc.din" >/dev/null 2>&1; [ $? -eq 2 ] || die "--sizes with --hierarchy must be a usage error"

# --repl and --hierarchy runs are stored with their dimensions: the run key
# holds repl and the canonical spec, level_traffic one row per level, size
# and class; the traffic rows are the last level's
"$bin" sim --db "$tmp/hr.db" --repl fifo --sizes 128 "$tmp/abaca.din" 2>/dev/null || die "sim --db --repl fifo"
"$bin" sim --db "$tmp/hr.db" --sizes 128 "$tmp/abaca.din" 2>/dev/null || die "sim --db lru"
"$bin" sim --db "$tmp/hr.db" --hierarchy L1=1K/full/64/lru,LLC=1K+2K/full/64/lru "$tmp/cyc.din" 2>/dev/null || die "sim --db --hierarchy"
[ "$(sqlite3 "$tmp/hr.db" "select repl || '|' || hierarchy from runs order by id" | tr '\n' ' ')" = \
  "fifo| lru| lru|L1=1K/full/64/lru,LLC=1K+2K/full/64/lru " ] || die "stored repl/hierarchy: $(sqlite3 "$tmp/hr.db" 'select repl, hierarchy from runs')"
[ "$(sqlite3 "$tmp/hr.db" "select read_misses from traffic t join cache_configs c on c.id = t.config_id join runs r on r.id = t.run_id where r.repl = 'fifo'")" = 4 ] || die "fifo run's traffic row"
[ "$(sqlite3 "$tmp/hr.db" "select level || ':' || level_name || ':' || cache_size || ':' || accesses || ':' || misses || ':' || traffic_bytes from level_traffic order by level, cache_size" | tr '\n' ' ')" = \
  "1:L1:1024:68:68:5440 2:LLC:1024:85:68:5440 2:LLC:2048:85:17:1088 " ] || die "level rows: $(sqlite3 "$tmp/hr.db" 'select * from level_traffic')"

# database: storing twice keeps one run
"$bin" sim --db "$tmp/r.db" "$tmp/cyc.din" 2>"$tmp/err" || die "sim --db exit"
grep -q 'refs' "$tmp/err" || die "summary line on stderr"
"$bin" sim --db "$tmp/r.db" "$tmp/cyc.din" 2>/dev/null || die "sim --db again"
if command -v sqlite3 >/dev/null 2>&1; then
    n=$(sqlite3 "$tmp/r.db" 'SELECT count(*) FROM runs')
    [ "$n" = 1 ] || die "runs after two stores: $n"
    n=$(sqlite3 "$tmp/r.db" 'SELECT count(*) FROM traffic')
    [ "$n" = 13 ] || die "traffic rows: $n"
fi

# bad trace: exit 1, message with file:line, nothing stored
printf '0 100\n9 200\n' > "$tmp/bad.din"
"$bin" sim --db "$tmp/r.db" "$tmp/bad.din" 2>"$tmp/err"; st=$?
[ $st -eq 1 ] || die "bad din exit $st"
grep -q 'bad.din:2:' "$tmp/err" || die "bad din message: $(cat "$tmp/err")"
if command -v sqlite3 >/dev/null 2>&1; then
    n=$(sqlite3 "$tmp/r.db" 'SELECT count(*) FROM runs')
    [ "$n" = 1 ] || die "bad trace stored something"
fi
printf 'garbage\0\1\2' > "$tmp/junk.rtt"
"$bin" sim "$tmp/junk.rtt" >/dev/null 2>&1; st=$?
[ $st -eq 1 ] || die "corrupt rtt exit $st"
echo "not a database" > "$tmp/corrupt.db"
"$bin" sim --db "$tmp/corrupt.db" "$tmp/cyc.din" 2>"$tmp/err"; st=$?
[ $st -eq 1 ] && grep -q corrupt.db "$tmp/err" || die "corrupt db: exit $st $(cat "$tmp/err")"

# hybrid: estimates beside the reasons for the sizes it cannot give; the
# same seed twice gives the same numbers; rates as 1/N
i=0
while [ $i -lt 3000 ]; do
    echo "0 $(printf %x $((65536 + (i * 7919 % 2000) * 64)))"
    i=$((i + 1))
done > "$tmp/mix.din"
"$bin" sim --method hybrid --rate 1/4 --period 64 --window 16 --sizes 1K,2K,64K "$tmp/mix.din" > "$tmp/h1.txt" || die "hybrid exit $?"
grep -q 'engine hybrid rate=0.25 seed=1 window_below=32768 period=64 window=16' "$tmp/h1.txt" || die "hybrid engine line: $(head -1 "$tmp/h1.txt")"
grep -Eq '^ +65536 +64 +full fb +3000 ' "$tmp/h1.txt" || die "hybrid 64K row: $(cat "$tmp/h1.txt")"
grep -Eq '^ +1024 +64 +full fb +3000 ' "$tmp/h1.txt" || die "hybrid windowed 1K row"
"$bin" sim --method hybrid --rate 0.25 --period 64 --window 16 --sizes 1K,2K,64K "$tmp/mix.din" > "$tmp/h2.txt"
cmp -s "$tmp/h1.txt" "$tmp/h2.txt" || die "hybrid: same seed, different output"
"$bin" sim --method hybrid --sizes 1K,64K "$tmp/mix.din" | grep -q '^# 1024: trace too short for windows every 65536 references: 0 windows (need 32)' \
    || die "hybrid too-short reason"

# --threads: 1 and 2 print the same; a truncated or corrupted trace fails
# alike on both (exit 1, same message, nothing stored), no hang
"$bin" trace sphereflake -W 32 -H 32 -o "$tmp/t.rtt" >/dev/null 2>&1 || die "trace for --threads"
for f in "$tmp/t.rtt" "$tmp/cyc.din"; do
    "$bin" sim --threads 1 "$f" > "$tmp/t1.txt" || die "--threads 1 exit $?"
    "$bin" sim --threads 2 "$f" > "$tmp/t2.txt" || die "--threads 2 exit $?"
    cmp -s "$tmp/t1.txt" "$tmp/t2.txt" || die "--threads 1 and 2 differ on $f"
    "$bin" sim "$f" | cmp -s - "$tmp/t1.txt" || die "default --threads differs on $f"
done
size=$(wc -c < "$tmp/t.rtt")
head -c $((size / 2)) "$tmp/t.rtt" > "$tmp/cut.rtt"
cp "$tmp/t.rtt" "$tmp/flip.rtt"
printf 'Z' | dd of="$tmp/flip.rtt" bs=1 seek=$((size / 3)) conv=notrunc 2>/dev/null
cmp -s "$tmp/t.rtt" "$tmp/flip.rtt" && die "flip.rtt unchanged"
for f in cut flip; do
    for t in 1 2; do
        "$bin" sim --threads $t --db "$tmp/thr.db" "$tmp/$f.rtt" 2>"$tmp/err$t"; st=$?
        [ $st -eq 1 ] || die "$f.rtt --threads $t exit $st"
        grep -q "$f.rtt: byte [0-9]*: " "$tmp/err$t" || die "$f.rtt --threads $t message: $(cat "$tmp/err$t")"
    done
    cmp -s "$tmp/err1" "$tmp/err2" || die "$f.rtt: messages differ: $(cat "$tmp/err1" "$tmp/err2")"
    if command -v sqlite3 >/dev/null 2>&1; then
        n=$(sqlite3 "$tmp/thr.db" 'SELECT count(*) FROM runs')
        [ "$n" = 0 ] || die "$f.rtt stored $n runs"
    fi
done
for t in 1 2; do
    "$bin" sim --threads $t --db "$tmp/thr.db" "$tmp/bad.din" 2>"$tmp/err$t"; st=$?
    [ $st -eq 1 ] && grep -q 'bad.din:2: unsupported din label 9' "$tmp/err$t" || die "bad din --threads $t: $st"
done
for a in 0 3 x; do
    "$bin" sim --threads $a "$tmp/cyc.din" >/dev/null 2>"$tmp/err"; st=$?
    [ $st -eq 2 ] && grep -q -- '--threads' "$tmp/err" || die "--threads $a: exit $st $(cat "$tmp/err")"
done

# the sample index: `trace` writes version 3; sim --method hybrid reads only
# its side chunks, silently, with the output and database row (trace hash
# included) of the full decode of the same records in a version-1 file,
# which falls back with a one-line note
"$bin" trace cornell -W 96 -H 96 -o "$tmp/s3.rtt" 2>/dev/null || die "trace v3"
"$bin" trace cornell -W 96 -H 96 --no-sample -o "$tmp/s1.rtt" 2>/dev/null || die "trace --no-sample"
"$bin" trace-info "$tmp/s3.rtt" | grep -q '^format: *rtt version 3' || die "trace-info: version 3"
"$bin" trace-info "$tmp/s3.rtt" | grep -q '^sample index: 64-byte lines at rate 1/64' || die "trace-info: sample index"
"$bin" trace-info "$tmp/s1.rtt" | grep -q '^format: *rtt version 1' || die "trace --no-sample: version 1"
"$bin" trace-info --json "$tmp/s3.rtt" | grep -q '"format_version": 3,.*"sample_index": {"line": 64, "rate": 0.015625' ||
    die "trace-info --json: sample index"
# the former key, kept for one release
"$bin" trace-info --json "$tmp/s3.rtt" | grep -q '"sample_stream": {"line": 64, "rate": 0.015625' ||
    die "trace-info --json: the former key sample_stream"
"$bin" trace-info --json "$tmp/s1.rtt" | grep -q 'sample_index\|sample_stream' && die "trace-info --json: sample index in version 1"
cmp -s "$tmp/s3.rtt" "$tmp/s1.rtt" && die "the two formats are the same bytes"
for t in 1 2; do
    "$bin" sim --method hybrid --threads $t "$tmp/s3.rtt" > "$tmp/h3.txt" 2> "$tmp/h3.err" || die "hybrid v3 --threads $t"
    "$bin" sim --method hybrid --threads $t "$tmp/s1.rtt" > "$tmp/h1.txt" 2> "$tmp/h1.err" || die "hybrid v1 --threads $t"
    [ -s "$tmp/h3.err" ] && die "hybrid on the sample index wrote to stderr: $(cat "$tmp/h3.err")"
    [ "$(wc -l < "$tmp/h1.err")" -eq 1 ] && grep -q 'note: .*s1.rtt: format version 1 has no sample index; decoding every record' \
        "$tmp/h1.err" || die "fallback note: $(cat "$tmp/h1.err")"
    sed 1d "$tmp/h3.txt" > "$tmp/h3b.txt"
    sed 1d "$tmp/h1.txt" | cmp -s - "$tmp/h3b.txt" || die "hybrid from the sample index differs from the full decode"
done
# the hybrid's standard errors: a column on group rows, a line per size with
# the whole traffic; CSV and JSON carry them; the exact method has none
grep -Eq '^ +size_bytes .* traffic_bytes +traffic_se$' "$tmp/h3.txt" || die "hybrid header: no traffic_se column"
grep -Eq '^ +65536 +64 +full node +[0-9]+( +[0-9]+){5} +-$' "$tmp/h3.txt" || die "hybrid class row: $(grep ' 65536 ' "$tmp/h3.txt" | head -2)"
grep -Eq '^ +65536 +64 +full geometry +[0-9]+( +[0-9]+){5} +[0-9]+$' "$tmp/h3.txt" || die "hybrid group row without an error"
grep -Eq '^# 65536: traffic [0-9]+ bytes, standard error [0-9]+ bytes \([0-9.]+%\)$' "$tmp/h3.txt" || die "hybrid error line"
[ "$(grep -c 'standard error' "$tmp/h3.txt")" -eq 8 ] || die "hybrid: not one error line per estimated size (32K-4M)"
"$bin" sim --method hybrid --format csv "$tmp/s3.rtt" > "$tmp/h.csv" || die "hybrid csv"
head -1 "$tmp/h.csv" | grep -q ',traffic_bytes,traffic_se_bytes$' || die "hybrid csv header: $(head -1 "$tmp/h.csv")"
grep -Eq ',geometry,([0-9]+,){6}[0-9]+$' "$tmp/h.csv" && grep -Eq ',node,([0-9]+,){6}$' "$tmp/h.csv" || die "hybrid csv rows"
"$bin" sim --method hybrid --format json "$tmp/s3.rtt" > "$tmp/h.json" || die "hybrid json"
grep -q '"class": "geometry".*"traffic_se_bytes": [0-9]' "$tmp/h.json" && grep -q '"class": "node".*"traffic_se_bytes": null' "$tmp/h.json" ||
    die "hybrid json errors"
"$bin" sim --format csv "$tmp/s3.rtt" | grep -q 'traffic_se' && die "exact csv has an error column"
"$bin" sim --method hybrid --no-error "$tmp/s3.rtt" > "$tmp/hn.txt" || die "hybrid --no-error"
grep -q 'traffic_se\|standard error' "$tmp/hn.txt" && die "--no-error printed errors"
# the estimates are the same with and without errors
sed -E 's/ +([0-9]+|-|traffic_se)$//' "$tmp/h3.txt" | grep -v 'standard error' | sed 1d > "$tmp/h3s.txt"
sed 1d "$tmp/hn.txt" | cmp -s - "$tmp/h3s.txt" || die "--no-error changed the estimates"
"$bin" sim --method shards --no-error "$tmp/s3.rtt" > /dev/null 2>&1; [ $? -eq 2 ] || die "--no-error with shards: not a usage error"
"$bin" sim "$tmp/s3.rtt" | grep -q 'traffic_se\|standard error' && die "exact text has an error column"
"$bin" sim --method hybrid --rate 1/32 "$tmp/s3.rtt" > /dev/null 2> "$tmp/h.err" || die "hybrid 1/32"
grep -q "rate 0.03125 is above the sample index's 1/64; decoding every record" "$tmp/h.err" || die "rate note: $(cat "$tmp/h.err")"
"$bin" sim --method hybrid --db "$tmp/h.db" "$tmp/s3.rtt" 2>"$tmp/h.err" || die "hybrid --db v3"
grep -Eq 'run 1, largest standard error [0-9.]+% of traffic \([0-9]+ bytes\)$' "$tmp/h.err" || die "hybrid --db summary: $(cat "$tmp/h.err")"
h3=$("$bin" trace-info "$tmp/s3.rtt" | sed -n 's/^file hash: *//p')
if command -v sqlite3 >/dev/null 2>&1; then
    got=$(sqlite3 "$tmp/h.db" "select trace_hash from runs order by id limit 1")
    [ "$got" = "$h3" ] || die "trace_hash $got, trace-info says $h3"
    [ "$(sqlite3 "$tmp/h.db" "select sim_method, sim_params from runs")" = \
      "hybrid|rate=0.015625 seed=1 window_below=32768 period=65536 window=1024 exact_below=0 errors=1" ] || die "hybrid run identity"
    # the stored errors are those printed: one row per estimated size
    sqlite3 "$tmp/h.db" "select '# ' || c.size || ': standard error ' || printf('%.0f', e.total_se) from traffic_se e
        join cache_configs c on c.id = e.config_id order by c.size" > "$tmp/hse.db.txt"
    sed -n 's/^\(# [0-9]*: \)traffic [0-9]* bytes, \(standard error [0-9]*\) bytes .*/\1\2/p' "$tmp/h3.txt" > "$tmp/hse.txt"
    [ -s "$tmp/hse.txt" ] && cmp -s "$tmp/hse.txt" "$tmp/hse.db.txt" || die "stored errors differ from printed: $(diff "$tmp/hse.txt" "$tmp/hse.db.txt")"
    # --no-error: another run (the key without errors=1), no error rows
    "$bin" sim --method hybrid --no-error --db "$tmp/h.db" "$tmp/s3.rtt" 2>/dev/null || die "hybrid --no-error --db"
    [ "$(sqlite3 "$tmp/h.db" "select count(*) from runs where sim_params not like '%errors=1'; select count(*) from traffic_se")" = \
      "$(printf '1\n8')" ] || die "--no-error --db: $(sqlite3 "$tmp/h.db" "select id, sim_params from runs")"
fi
# a damaged side chunk: the sampled read names the file and the offset
cp "$tmp/s3.rtt" "$tmp/bad3.rtt"
size=$(wc -c < "$tmp/bad3.rtt")
printf 'X' | dd of="$tmp/bad3.rtt" bs=1 seek=$((size - 300)) conv=notrunc 2>/dev/null
"$bin" sim --method hybrid "$tmp/bad3.rtt" > /dev/null 2> "$tmp/h.err"; st=$?
[ $st -eq 1 ] && grep -q 'bad3.rtt: byte [0-9]*: .*CRC mismatch' "$tmp/h.err" || die "damaged v3: exit $st $(cat "$tmp/h.err")"

# usage errors
for args in "" "--sizes x f" "--assoc zero f" "--format xml f" "--input-format foo f" "--nope f" "--line 0 f" \
    "--method hybrid --rate 2 f" "--method hybrid --rate 1/0 f" "--method hybrid --window 0 f" "--method hybrid --period x f"; do
    # shellcheck disable=SC2086
    "$bin" sim $args >/dev/null 2>&1; st=$?
    [ $st -eq 2 ] || die "usage error '$args' exit $st"
done
"$bin" sim --help | grep -q '^Usage: raytraffic sim' || die "--help"
exit $fail
