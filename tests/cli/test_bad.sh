#!/usr/bin/env bash
# Runs the bad-input corpus, tests/bad/*/case (format: tests/bad/README.md).
# For every case: the command exits with the expected status (never 0 unless
# the case says so, never a signal, never a timeout), stderr starts with
# "ffd: " and holds the expected fragment, the command stays within its
# case's CPU time (user + system of all its threads, `ulimit -t`: the bound
# on its work, which other processes' load cannot trip; a wall-clock limit
# ten times longer catches a command that blocks), the case's input files are
# byte-identical afterwards, the pre-existing output files in $OUT are
# byte-identical and nothing else appeared there (no temporary files), and
# under a sanitizer build stderr holds no sanitizer report. Outside sanitizer
# builds each command runs with its virtual memory limited to 4 GB
# (FFD_BAD_ULIMIT_KB overrides, 0 disables).
# usage: bash test_bad.sh PATH_TO_ffd SOURCE_DIR [CASE_NAME_PATTERN]
set -u
source "$(dirname "$0")/lib.sh" "$1" "$2"
ONLY=${3:-*}
BAD=$SRC/tests/bad
DATA=$SRC/tests/data
EXAMPLES=$SRC/examples

# A sanitizer build reserves terabytes of virtual memory and runs slower.
ASAN=0
case $FFD in *asan* | *sanitize*) ASAN=1 ;; esac
if [ "$ASAN" = 1 ]; then
    ULIMIT_KB=${FFD_BAD_ULIMIT_KB:-0}
    SLOW=6
else
    ULIMIT_KB=${FFD_BAD_ULIMIT_KB:-4000000}
    SLOW=1
fi
OUTPUTS="out.obj out.ply out.off out.stl out.json lattice.obj proxy.obj points.obj"

key() { # key NAME CASEFILE: the value of "NAME: value" (first occurrence)
    sed -n "s/^$1:[[:space:]]*//p" "$2" | head -n 1
}
cpu_children() { # cpu_children VAR: VAR = user + system seconds of this shell's finished
    # children (bash's `times`, which must run in this shell, not in a $(...))
    times >"$T/times"
    printf -v "$1" '%s' "$(awk 'NR == 2 { for (i = 1; i <= NF; i++) { split($i, t, "m"); s += t[1] * 60 + t[2] } printf "%.2f", s }' "$T/times")"
}
snapshot() { # snapshot DIR: name, size and checksum of every file below DIR
    (cd "$1" && find . -type f -print0 | sort -z | xargs -0 -r cksum)
}

cases=0
skipped=0
start_all=$(date +%s)
for dir in "$BAD"/$ONLY/; do
    dir=${dir%/}
    [ -f "$dir/case" ] || continue
    name=$(basename "$dir")
    cf=$dir/case
    cmd=$(key cmd "$cf")
    status=$(key status "$cf")
    expect=$(key expect "$cf")
    gen=$(key gen "$cf")
    limit=$(key timeout "$cf")
    limit=${limit:-20}
    if ! grep -q '^cmd:' "$cf" || [ -z "$status" ] || [ -z "$expect" ]; then
        fail "$name: case file lacks cmd, status or expect"
        continue
    fi
    if [ "$ASAN" = 1 ] && [ "$(key asan "$cf")" = skip ]; then
        echo "skip  $name (too slow under the sanitizers)"
        skipped=$((skipped + 1))
        continue
    fi
    cases=$((cases + 1))

    IN=$T/$name/in
    OUT=$T/$name/out
    mkdir -p "$IN" "$OUT"
    (cd "$dir" && find . -mindepth 1 -maxdepth 1 ! -name case -exec cp -R {} "$IN/" \;)
    if [ -n "$gen" ]; then
        (cd "$IN" && eval "$gen") || { fail "$name: gen failed: $gen"; rm -rf "${T:?}/$name"; continue; }
    fi
    for o in $OUTPUTS; do
        printf 'sentinel %s: must survive every failed run\n' "$o" >"$OUT/$o"
    done
    in_before=$(snapshot "$IN")
    out_before=$(snapshot "$OUT")

    eval "set -- $cmd"
    # the bound is CPU time (SIGXCPU at the limit, no core file); the wall
    # clock is only a safety net for a command that blocks without working
    cpu_limit=$((limit * SLOW))
    wall_limit=$((cpu_limit * 10))
    t0=$EPOCHREALTIME
    cpu_children c0
    (
        [ "$ULIMIT_KB" != 0 ] && ulimit -v "$ULIMIT_KB"
        ulimit -c 0
        # the soft limit stops it with SIGXCPU; 5 s later the hard one kills (SIGKILL)
        ulimit -S -t "$cpu_limit" && ulimit -H -t $((cpu_limit + 5)) || exit 125
        exec timeout -k 5 "$wall_limit" "$FFD" "$@"
    ) >"$T/stdout" 2>"$T/stderr"
    rc=$?
    secs=$(awk -v a="$t0" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.2f", b - a }')
    cpu_children c1
    cpu=$(awk -v a="$c0" -v b="$c1" 'BEGIN { printf "%.2f", b - a }')
    err=$(head -c 2000 "$T/stderr")
    problems=""
    if [ "$rc" -eq 152 ] || { [ "$rc" -eq 137 ] && awk -v c="$cpu" -v l="$cpu_limit" 'BEGIN { exit !(c >= l) }'; }; then
        problems+=" used more than its $cpu_limit s of CPU time ($cpu s user + system);"
    elif [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; then
        problems+=" timed out after $wall_limit s of wall-clock time ($cpu s of CPU time: blocked?);"
    elif [ "$rc" -ne "$status" ]; then
        problems+=" exited $rc, expected $status;"
    fi
    if [ "$status" -eq 0 ]; then
        grep -qF -- "$expect" "$T/stdout" "$T/stderr" || problems+=" output lacks '$expect';"
    else
        grep -qF -- "$expect" "$T/stderr" || problems+=" stderr lacks '$expect';"
        head -n 1 "$T/stderr" | grep -q '^ffd: ' || problems+=" stderr does not start with 'ffd: ';"
    fi
    if grep -qE 'Sanitizer|runtime error:' "$T/stderr"; then
        problems+=" sanitizer report;"
    fi
    [ "$(snapshot "$IN")" = "$in_before" ] || problems+=" an input file was modified, created or removed;"
    [ "$(snapshot "$OUT")" = "$out_before" ] || problems+=" the output directory changed (damaged output or leftover file);"
    if [ -n "$problems" ]; then
        fail "$name:$problems stderr: $err"
    else
        printf 'ok    %-34s %5.2f s (cpu %5.2f s)  %s\n' "$name" "$secs" "$cpu" "$(head -n 1 "$T/stderr" | cut -c1-100)"
    fi
    rm -rf "${T:?}/$name"
done

echo "$cases cases, $skipped skipped, $failures failure(s), $(($(date +%s) - start_all)) s"
[ "$cases" -gt 0 ] || fail "no case found in $BAD"
[ "$failures" -eq 0 ] || exit 1
