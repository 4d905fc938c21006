#!/bin/sh
# cli_test.sh: every step's real binary on the command line. --help; bad input (exit status 2,
# one line on stderr naming the problem, no PNG written); a good run (one PNG and one summary
# line per view); --debug-pixel (a trace ending with the pixel).
#
#   sh tests/cli_test.sh BUILD      (make test runs it with BUILD = build)
#
# Prints one line per failure and a last line "cli test: N passed, M failed"; exit status 1
# when anything failed, 2 when it could not run.
set -u
build=${1:?usage: sh tests/cli_test.sh BUILD}
cd "$(dirname "$0")/.." || exit 2
[ -d steps ] || { echo "cli test: run from the repository (no steps/ here)" >&2; exit 2; }

cthead_bytes=14811136  # 256 x 256 x 113 int16
passed=0
failed=0
work=$(mktemp -d -p "$(sh tests/scratch_parent.sh)") || exit 2
trap 'rm -rf "$work"' EXIT INT TERM

pass() { passed=$((passed + 1)); }
fail() {
    failed=$((failed + 1))
    echo "FAIL: $*"
}
# check CONDITION_STATUS DESCRIPTION: counts a pass when the status before it was 0.
check() {
    if [ "$1" -eq 0 ]; then pass; else fail "$2"; fi
}

# Bad input files: missing, a folder, empty, one byte short of CThead, a regular file
# standing where a folder should be.
missing="$work/missing_volume"
folder="$work/a_folder"
empty="$work/empty_volume"
short="$work/short_volume"
regular="$work/regular_file"
mkdir "$folder"
: > "$empty"
: > "$regular"
dd if=/dev/zero of="$short" bs=1 count=0 seek=$((cthead_bytes - 1)) 2> /dev/null
[ "$(wc -c < "$short")" -eq $((cthead_bytes - 1)) ] || { echo "cli test: dd failed" >&2; exit 2; }

# A 4x3x2 big-endian raw volume: value n*100 - 1000 for voxel n (min -1000, max 1300).
raw="$work/small_big_endian.raw"
: > "$raw"
n=0
while [ $n -lt 24 ]; do
    value=$(( (n * 100 - 1000) & 65535 ))
    printf "\\$(printf %o $((value >> 8)))\\$(printf %o $((value & 255)))" >> "$raw"
    n=$((n + 1))
done
[ "$(wc -c < "$raw")" -eq 48 ] || { echo "cli test: could not write $raw" >&2; exit 2; }

# The phantom as a raw file, painted once (build/make_phantom): the good runs after the first
# load it (the same voxels and spacing as --volume phantom) instead of painting the head
# again, 0.12 s of CPU per run. The first step's good run keeps --volume phantom itself.
phantom_raw="$work/phantom.raw"
"$build/make_phantom" "$phantom_raw" > /dev/null ||
    { echo "cli test: $build/make_phantom failed" >&2; exit 2; }
phantom_flags="--volume $phantom_raw --dims 256,256,113 --spacing 1,1,2"

# expect_bad STEP TEXT ARGS...: exit status 2, exactly one line on stderr, of the form
# "STEP: error: ..." and containing TEXT; no PNG anywhere under the --out folder.
expect_bad() {
    step=$1
    text=$2
    shift 2
    out="$work/bad_out"
    # The checks below are the shell's own (read, case, test): this runs ~500 times, and the
    # rm, wc, grep and find processes it started were a third of this test's CPU time.
    [ -e "$out" ] && rm -rf "$out"
    "$build/$step" --no-window --out "$out" "$@" > "$work/stdout" 2> "$work/stderr"
    status=$?
    what="$step $*"
    if [ $status -ne 2 ]; then
        fail "$what: exit status $status, expected 2"
        return
    fi
    # The lines of stderr, counted as wc -l counts them (a last line without its newline is
    # none), the last one kept.
    lines=0
    line=
    while IFS= read -r next; do
        lines=$((lines + 1))
        line=$next
    done < "$work/stderr"
    if [ $lines -ne 1 ]; then
        fail "$what: expected one line on stderr, got: $(cat "$work/stderr")"
        return
    fi
    case $line in "$step: error: "*) said_error=1 ;; *) said_error=0 ;; esac
    case $line in *"$text"*) said_text=1 ;; *) said_text=0 ;; esac
    if [ $said_error -eq 0 ] || [ $said_text -eq 0 ]; then
        fail "$what: stderr does not say '$step: error: ...$text...': $(cat "$work/stderr")"
        return
    fi
    if [ -e "$out" ] && [ -n "$(find "$out" -name '*.png*' 2> /dev/null)" ]; then
        fail "$what: wrote a PNG despite the error"
        return
    fi
    pass
}

# The four bytes a PNG starts with, as hex.
png_magic() { od -An -tx1 -N4 "$1" | tr -d ' \n'; }

steps=0
for source in steps/[0-9][0-9]_*.cpp; do
    step=$(basename "$source" .cpp)
    steps=$((steps + 1))
    if [ ! -x "$build/$step" ]; then
        fail "$build/$step is not built"
        continue
    fi

    # --help: the usage on stdout, status 0, nothing on stderr.
    "$build/$step" --help > "$work/stdout" 2> "$work/stderr"
    status=$?
    [ $status -eq 0 ] && grep -q "^usage: build/$step " "$work/stdout" && [ ! -s "$work/stderr" ]
    check $? "$step --help: status $status, or no 'usage: build/$step' line, or stderr output"

    # Bad input: each names what is wrong.
    expect_bad "$step" "$missing" --volume "$missing"
    expect_bad "$step" "'$folder' is a folder" --volume "$folder"
    expect_bad "$step" "has 0 bytes" --volume "$empty"
    expect_bad "$step" "has $((cthead_bytes - 1)) bytes" --volume "$short"
    expect_bad "$step" "over the limit" --volume "$raw" --dims 4194304,4194304,4194304
    expect_bad "$step" "over the limit" --volume phantom --dims 4194304,4194304,4194304
    expect_bad "$step" "'--bogus'" --volume phantom --bogus
    expect_bad "$step" "--view" --volume phantom --view bogus
    expect_bad "$step" "--threads" --volume phantom --threads 0
    # Found once the volume is loaded: on the small raw volume, not the phantom painted anew
    # each time (0.1 s of CPU per run).
    small="--volume $raw --dims 4,3,2 --endian big"
    # shellcheck disable=SC2086
    expect_bad "$step" "--debug-pixel 9999,9999 is outside" $small --debug-pixel 9999,9999
    expect_bad "$step" "--debug-pixel" --volume phantom --debug-pixel a,b
    expect_bad "$step" "--threshold" --volume phantom --threshold abc
    # shellcheck disable=SC2086
    expect_bad "$step" "/proc/ctlab" $small --out /proc/ctlab
    # shellcheck disable=SC2086
    expect_bad "$step" "is a file, not a folder" $small --out "$regular/out"

    # A good run: one PNG and one summary line per view, nothing on stderr. It traces a pixel
    # too (checked below): one render of the phantom serves both.
    # Part 1 and step 12 (00..12) render the three axis views; 13 on one camera picture, of its
    # default size (512x512) in the first camera step and in a step with a --size flag of its
    # own (none today); the other camera steps (35 and 36 default to 256x256) take that flag
    # from common/camera_flags.h, as the first does, and render 64x48 here, traced at its centre (a 512x512 render of the phantom is up
    # to 2.5 s of CPU: 13 of this test's 25 s went there).
    views="top:256x256 front:256x113 side:256x113" trace_view=front size_flags=
    px=128 py=60
    case "$step" in
        0[0-9]_*|1[0-2]_*) ;;
        *) views="camera:512x512" trace_view=camera
           # A step with a --size of its own says its default (default_size) in its source.
           own_size=$(sed -n 's/^constexpr const char\* default_size = "\([0-9]*x[0-9]*\)".*/\1/p' \
               "$source")
           [ -n "$own_size" ] && views="camera:$own_size"
           if [ -n "${camera_seen:-}" ] && ! grep -q 'add_string("--size"' "$source"; then
               views="camera:64x48" size_flags="--size 64x48" px=32 py=24
           fi
           camera_seen=1 ;;
    esac
    out="$work/good_$step"
    volume_flags=$phantom_flags
    [ $steps -eq 1 ] && volume_flags="--volume phantom"
    # shellcheck disable=SC2086
    "$build/$step" $volume_flags --no-window --out "$out" --debug-pixel $px,$py $size_flags \
        > "$work/stdout" 2> "$work/stderr"
    status=$?
    [ $status -eq 0 ] && [ ! -s "$work/stderr" ]
    check $? "$step $volume_flags $size_flags: status $status, stderr: $(cat "$work/stderr")"
    for view_size in $views; do
        view=${view_size%%:*}
        size=${view_size#*:}
        png="$out/${step}_$view.png"
        [ -f "$png" ] && [ "$(png_magic "$png")" = 89504e47 ]
        check $? "$step: $png missing or not a PNG"
        count=$(grep -c "^step=$step view=$view size=$size time_ms=[0-9.]* .*samples=[0-9]" \
            "$work/stdout")
        [ "$count" -eq 1 ]
        check $? "$step: expected one summary line 'step=$step view=$view size=$size time_ms=..\
 samples=..', got $count"
    done
    [ -z "$(find "$out" -name '*.tmp*' 2> /dev/null)" ]
    check $? "$step: temporary files left in $out"

    # --debug-pixel (the good run's): the trace of one ray in the front (or camera) view, its
    # last line the pixel (image column 128, row 60; 32, 24 in a 64x48 picture); the trace
    # ends where the next view's summary line or trace begins.
    sed -n "/^debug pixel x=$px y=$py view=$trace_view/,\$p" "$work/stdout" |
        awk 'NR > 1 && (/^step=/ || /^debug pixel /) { exit } { print }' > "$work/trace"
    last=$(tail -n 1 "$work/trace")
    trace_lines=$(wc -l < "$work/trace")
    [ $status -eq 0 ] && [ "$trace_lines" -ge 3 ] &&
        echo "$last" | grep -q "^pixel x=$px y=$py rgb=([0-9.]*, [0-9.]*, [0-9.]*) png=("
    check $? "$step --debug-pixel $px,$py: status $status, $trace_lines trace lines, last: $last"
done
[ $steps -ge 6 ]
check $? "found only $steps steps in steps/"

# A generic raw file: --dims, --endian big; the loader's line and the side view's size.
step=$(basename "$(ls steps/0[0-9]_*.cpp steps/1[0-2]_*.cpp | tail -n 1)" .cpp)  # part 1's last: it has a side view
"$build/$step" --volume "$raw" --dims 4,3,2 --endian big --view side --no-window \
    --out "$work/raw_out" > "$work/stdout" 2> "$work/stderr"
status=$?
[ $status -eq 0 ] && grep -q "dims=4x3x2 spacing=1,1,1 min=-1000 max=1300" "$work/stdout" &&
    grep -q "^step=$step view=side size=3x2 " "$work/stdout" &&
    [ -f "$work/raw_out/${step}_side.png" ]
check $? "$step --volume raw --dims 4,3,2 --endian big: status $status: $(cat "$work/stdout")"
expect_bad "$step" "has 48 bytes" --volume "$raw" --dims 4,3,3 --endian big
expect_bad "$step" "--dims" --volume "$raw" --dims 0,1,1
expect_bad "$step" "--spacing" --volume "$raw" --dims 4,3,2 --spacing 1,0,1

# A ray longer than a float counts whole voxels (2^24 = 16777216): 1x1x16777220 voxels of air
# (-1000), bone (1000) in the last one only. The hit is at sample 16777219, which a float
# would carry as 16777220, one past the end (undefined behaviour: the SAN=1 build stops there).
long="$work/long_ray"
yes "$(printf '\030\374')" | tr -d '\n' | head -c $((2 * 16777219)) > "$long"
printf '\350\003' >> "$long"
for step in 02_threshold 03_depth_shading 04_gradient_lighting 05_interpolated_hits \
            10_opacity_correction 11_empty_space; do
    case $step in
        0[2-5]_*) flags="--threshold 500"; expect="samples=16777220 .*hits=1" ;;
        08_*) flags=""; expect="samples=16777220 skipped=16777219 leapt=0 gradients=1 " ;;
        *) flags=""; expect="gradients=1 " ;;
    esac
    # shellcheck disable=SC2086
    "$build/$step" --volume "$long" --dims 1,1,16777220 --view top $flags --no-window \
        --out "$work/long_out" > "$work/stdout" 2> "$work/stderr"
    status=$?
    [ $status -eq 0 ] && grep -q "^step=$step view=top size=1x1 .*$expect" "$work/stdout"
    check $? "$step on a ray of 16777220 voxels: status $status: $(cat "$work/stdout" "$work/stderr")"
done

# The instructor's and the Makefile's tools: --help prints a usage line on stdout, status 0,
# nothing on stderr; an unknown flag is a one-line error, status 2.
for tool in bench study measured pack_png grade check carry make_student find_answers \
    make_phantom handout_listings; do
    [ -x "$build/$tool" ] || continue  # built by a target this run does not need
    "$build/$tool" --help > "$work/stdout" 2> "$work/stderr"
    status=$?
    [ $status -eq 0 ] && grep -q "^usage: " "$work/stdout" && [ ! -s "$work/stderr" ]
    check $? "$tool --help: status $status, or no 'usage:' line on stdout, or stderr output"
done
for tool in bench study; do
    [ -x "$build/$tool" ] || continue
    "$build/$tool" --no-such-flag > "$work/stdout" 2> "$work/stderr"
    status=$?
    [ $status -eq 2 ] && [ "$(wc -l < "$work/stderr")" -eq 1 ] &&
        grep -q "no-such-flag" "$work/stderr"
    check $? "$tool --no-such-flag: status $status (2 expected), stderr: $(cat "$work/stderr")"
done

echo "cli test: $passed passed, $failed failed"
[ $failed -eq 0 ]
