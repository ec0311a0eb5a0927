#!/usr/bin/env bash
# The fault campaign's kinds of input, rerun: signals at random points, concurrent runs,
# a full disk, damaged and restored inputs. Every case checks one invariant: no result is
# lost and none is stale (a file in OUT either belongs to the run that wrote it, complete,
# or is absent), and a rerun gives the clean run's numbers.
#
#   scripts/bench-faults.sh [BIN] [ROUNDS]
#
# BIN defaults to target/release/bendscope; ROUNDS (default 6) random kill times per
# signal. The disk-full cases mount small tmpfs folders and need root; they are skipped
# otherwise. Prints one line per case and a summary; exits 1 if any invariant failed.
set -uo pipefail
set -m # background jobs get SIGINT (a script without job control starts them ignoring it)
cd "$(dirname "$0")/.."
bin=$(realpath "${1:-target/release/bendscope}")
rounds=${2:-6}
work=$(mktemp -d /tmp/bendscope-faults.XXXXXX)
trap 'for m in "$work"/full-*; do mountpoint -q "$m" && umount "$m"; done; rm -rf "$work"' EXIT
session=fixtures/sessions/example
fails=0
cases=0

pass() { cases=$((cases + 1)); printf 'ok    %s\n' "$1"; }
fail() { cases=$((cases + 1)); fails=$((fails + 1)); printf 'FAIL  %s: %s\n' "$1" "$2"; }

# The measured columns of per_video.csv (file, pressure, radius, curvature, angle), the
# numbers a rerun must reproduce.
numbers() { cut -d, -f1-5 "$1/per_video.csv" 2> /dev/null; }

# Every CSV in OUT is complete: it ends with a newline and each row has the header's
# number of fields (an atomic write never leaves half a table).
complete_tables() {
    local f n
    for f in "$1"/*.csv; do
        [ -e "$f" ] || continue
        [ -z "$(tail -c1 "$f")" ] || { echo "$f does not end with a newline"; return 1; }
        n=$(head -1 "$f" | awk -F, '{print NF}')
        awk -F, -v n="$n" 'NF != n { bad = 1 } END { exit bad }' "$f" ||
            { echo "$f has rows of another width"; return 1; }
    done
    if ls "$1"/.*.tmp* "$1"/*.tmp* > /dev/null 2>&1; then echo "temporary files left"; return 1; fi
}

echo "bendscope fault campaign: $bin, $rounds rounds per signal"
start=$(date +%s.%N)
"$bin" process "$session" -o "$work/ref" --force > /dev/null 2>&1 || { echo "reference run failed"; exit 1; }
clean_s=$(echo "$(date +%s.%N) - $start" | bc)
numbers "$work/ref" > "$work/ref.numbers"
echo "clean run: $(printf '%.1f' "$clean_s") s, $(($(wc -l < "$work/ref.numbers") - 1)) videos"

# 1. process killed at a random point (fresh OUT and an OUT holding the earlier run),
#    then rerun: the tables are complete at every moment and the rerun equals the clean run.
for sig in INT TERM KILL; do
    for r in $(seq 1 "$rounds"); do
        name="process SIG$sig round $r"
        out="$work/p-$sig-$r"
        [ $((r % 2)) -eq 0 ] && cp -r "$work/ref" "$out"
        delay=$(echo "scale=2; $clean_s * $RANDOM / 32768" | bc)
        "$bin" process "$session" -o "$out" --force > /dev/null 2>&1 &
        pid=$!
        sleep "$delay"
        kill -s "$sig" "$pid" 2> /dev/null
        wait "$pid"
        why=$(complete_tables "$out") || { fail "$name (killed at $delay s)" "$why"; continue; }
        if [ -e "$out/per_video.csv" ] && ! cmp -s <(numbers "$out") "$work/ref.numbers"; then
            # A table left after a kill is a whole run's: the earlier one or the new one
            # (both measure the same videos, so both equal the clean run).
            fail "$name (killed at $delay s)" "per_video.csv holds numbers of neither run"
            continue
        fi
        "$bin" process "$session" -o "$out" > /dev/null 2>&1
        code=$?
        [ "$code" -eq 0 ] || { fail "$name" "rerun exit $code"; continue; }
        cmp -s <(numbers "$out") "$work/ref.numbers" || { fail "$name" "rerun differs from the clean run"; continue; }
        pass "$name (killed at $delay s)"
    done
done

# 2. Two runs into one OUT at once: one is refused (exit 2, OUT in use) unless the first
#    had finished; the outputs equal the clean run's.
for r in 1 2 3; do
    out="$work/c-$r"
    "$bin" process "$session" -o "$out" --force > /dev/null 2> "$work/c1.err" &
    a=$!
    sleep "0.$((RANDOM % 9 + 1))"
    "$bin" process "$session" -o "$out" --force > /dev/null 2> "$work/c2.err"
    b=$?
    wait "$a"
    a=$?
    if [ "$b" -eq 2 ] && grep -q "in use by another bendscope run" "$work/c2.err" && [ "$a" -eq 0 ]; then
        cmp -s <(numbers "$out") "$work/ref.numbers" && pass "concurrent runs $r (second refused)" ||
            fail "concurrent runs $r" "outputs differ from the clean run"
    elif [ "$a" -eq 0 ] && [ "$b" -eq 0 ]; then
        cmp -s <(numbers "$out") "$work/ref.numbers" && pass "concurrent runs $r (one after the other)" ||
            fail "concurrent runs $r" "outputs differ from the clean run"
    else
        fail "concurrent runs $r" "exit codes $a and $b: $(head -1 "$work/c2.err")"
    fi
done

# 3. A video damaged in its middle (same size, same mtime), measured, then restored with
#    cp -p: the rerun measures the restored video again (no stale cached result).
dmg="$work/damaged"
cp -rp "$session" "$dmg"
v="$dmg/GX010103.MP4"
cp -p "$v" "$work/good.mp4"
size=$(stat -c %s "$v")
dd if=/dev/urandom of="$v" bs=1 count=4096 seek=$((size / 2)) conv=notrunc status=none
touch -r "$work/good.mp4" "$v"
"$bin" process "$dmg" -o "$work/d-out" --force > /dev/null 2>&1
cp -p "$work/good.mp4" "$v"
"$bin" process "$dmg" -o "$work/d-out" > /dev/null 2>&1
cmp -s <(numbers "$work/d-out") "$work/ref.numbers" && pass "damaged then restored with cp -p" ||
    fail "damaged then restored with cp -p" "the rerun kept the damaged video's result"

# 3b. Bad files in place of one video (truncated, empty, random bytes, a text file): exit 1,
#     the bad video named with a status other than ok, the other four measured as in the
#     clean run.
for kind in truncated empty random text; do
    bad="$work/bad-$kind"
    cp -rp "$session" "$bad"
    v="$bad/GX010102.MP4"
    case $kind in
        truncated) truncate -s $(($(stat -c %s "$v") / 2)) "$v" ;;
        empty) : > "$v" ;;
        random) head -c 200000 /dev/urandom > "$v" ;;
        text) printf 'file,pressure_kpa\n' > "$v" ;;
    esac
    "$bin" process "$bad" -o "$work/bad-out-$kind" --force > /dev/null 2> "$work/bad.err"
    code=$?
    others=$(numbers "$work/bad-out-$kind" | grep -v '^GX010102')
    status=$(grep '^GX010102' "$work/bad-out-$kind/per_video.csv" 2> /dev/null | tr ',' '\n' | grep -cx ok)
    if [ "$code" -eq 1 ] && [ "$others" = "$(grep -v '^GX010102' "$work/ref.numbers")" ] && [ "$status" -eq 0 ] &&
        grep -q GX010102 "$work/bad.err"; then
        pass "$kind video (exit 1, the others kept: $(grep -m1 GX010102 "$work/bad.err" | cut -c1-100))"
    else
        fail "$kind video" "exit $code, status ok count $status"
    fi
done

# 4. A full disk at several sizes: exit 4 with the message, or 0 with every output; never
#    an old report beside new tables, never half a table.
if [ "$(id -u)" -eq 0 ]; then
    for kb in 64 256 1024 4096 16384; do
        m="$work/full-$kb"
        mkdir -p "$m"
        mount -t tmpfs -o size=${kb}k tmpfs "$m" 2> /dev/null || { echo "skip  disk full (mount failed)"; break; }
        "$bin" process "$session" -o "$m/out" --force > /dev/null 2> "$work/full.err"
        code=$?
        why=$(complete_tables "$m/out" 2>&1) || { fail "disk full ${kb} KiB" "$why"; umount "$m"; continue; }
        if [ "$code" -eq 4 ] && grep -q "no space left on" "$work/full.err"; then
            pass "disk full ${kb} KiB (exit 4)"
        elif [ "$code" -eq 0 ] && [ -e "$m/out/report.html" ]; then
            pass "disk full ${kb} KiB (fits, exit 0)"
        else
            fail "disk full ${kb} KiB" "exit $code: $(tail -1 "$work/full.err")"
        fi
        umount "$m"
    done
else
    echo "skip  disk full (needs root for tmpfs)"
fi

# 5. simulate killed at a random point into a folder holding another actuator's run:
#    config.toml and the results always belong together.
sim="$work/sim"
start=$(date +%s.%N)
"$bin" simulate --mesh-size 4 --pressures 30,40,50 -o "$sim" > /dev/null 2>&1
sim_s=$(echo "$(date +%s.%N) - $start" | bc)
"$bin" simulate --mesh-size 4 --pressures 10,20 -o "$sim" > /dev/null 2>&1
for r in $(seq 1 "$rounds"); do
    delay=$(echo "scale=2; $sim_s * $RANDOM / 32768" | bc)
    "$bin" simulate --mesh-size 4 --pressures 30,40,50 -o "$sim" > /dev/null 2>&1 &
    pid=$!
    sleep "$delay"
    kill -s INT "$pid" 2> /dev/null
    wait "$pid"
    steps=$(awk -F, 'NR > 1 { printf "%g ", $1 }' "$sim/steps.csv" 2> /dev/null)
    config=$(sed -n 's/^pressures_kpa = "\(.*\)"/\1/p' "$sim/config.toml" 2> /dev/null | tr ',' ' ')
    name="simulate SIGINT round $r (killed at $delay s, config ${config:-none}, steps ${steps:-none})"
    # Steps are written as they converge: steps.csv holds the config's ramp or a prefix of it.
    case "$config " in
        "$steps"*) owned=yes ;;
        *) owned=no ;;
    esac
    if [ -n "$steps" ] && [ "$owned" = no ]; then
        fail "$name" "steps.csv of another run beside config.toml"
    elif [ -e "$sim/summary.json" ] && [ "$steps" != "$config " ]; then
        fail "$name" "summary.json beside an unfinished ramp"
    else
        pass "$name"
    fi
    "$bin" simulate --mesh-size 4 --pressures 10,20 -o "$sim" > /dev/null 2>&1
done

echo "$((cases - fails)) of $cases cases kept every result whole"
[ "$fails" -eq 0 ]
