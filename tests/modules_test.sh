#!/bin/sh
# modules_test.sh: a step maps the big libraries only when a run needs them (common/module.h).
# The dynamic loader's own account (LD_DEBUG=files: every library it maps, at start and by
# dlopen) of: --help, a phantom run and a raw run (no GDCM, nifticlib, teem, SDL2 or zlib
# beyond what libc needs), and --help and a raw run of every other step too; an NRRD run (the
# format module and teem, mapped then; GDCM, DICOM's module alone, not); a step copied away
# from its modules (one line naming the missing module, exit status 2); and the window module
# missing (a note, the PNGs still written, exit status 0).
#
#   sh tests/modules_test.sh BUILD
set -u
build=${1:?usage: sh tests/modules_test.sh BUILD}
cd "$(dirname "$0")/.." || exit 2
passed=0
failed=0
pass() { passed=$((passed + 1)); }
fail() { failed=$((failed + 1)); echo "modules test: FAILED: $*"; }
work=$(mktemp -d) || exit 2
trap 'rm -rf "$work"' EXIT INT TERM
step=$build/02_threshold
[ -x "$step" ] || { echo "modules test: $step is not built"; exit 2; }

# A 2x2x2 NRRD (text header, raw little-endian int16), written here byte by byte.
nrrd=$work/tiny.nrrd
printf 'NRRD0004\ntype: short\ndimension: 3\nsizes: 2 2 2\nendian: little\nencoding: raw\n\n' \
    > "$nrrd"
printf '\000\000\144\000\310\000\054\001\220\001\364\001\130\002\274\002' >> "$nrrd"
# A 2x2x2 raw int16 file named so its dims and type come from the name.
raw=$work/tiny_2x2x2_int16.raw
printf '\000\000\144\000\310\000\054\001\220\001\364\001\130\002\274\002' > "$raw"

# mapped NAME ARGS...: runs the step with LD_DEBUG=files; the libraries it mapped, one a line.
mapped() {
    name=$1
    shift
    rm -f "$work/ld.$name".*
    LD_DEBUG=files LD_DEBUG_OUTPUT="$work/ld.$name" "$@" > "$work/$name.out" 2> "$work/$name.err"
    echo $? > "$work/$name.status"
    sed -n 's/.*file=\([^ ]*\) *\[0\];* *\(needed\|dynamically loaded\).*/\1/p' \
        "$work/ld.$name".* | sort -u > "$work/$name.libs"
}
big='libgdcm|libniftiio|libznz|libteem|libSDL2|libX11|ctlab_formats|ctlab_dicom|ctlab_window'

mapped help "$step" --help
mapped phantom "$step" --volume phantom --dims 16,16,8 --no-window --out "$work/out"
mapped raw "$step" --volume "$raw" --no-window --out "$work/out"
mapped nrrd "$step" --volume "$nrrd" --no-window --out "$work/out"
for run in help phantom raw nrrd; do
    if [ "$(cat "$work/$run.status")" = 0 ]; then pass; else
        fail "$run: exit status $(cat "$work/$run.status"): $(head -c 300 "$work/$run.err")"
    fi
done
# The loader's account must be there at all, or the checks below prove nothing.
if grep -q 'libstdc++' "$work/help.libs"; then pass; else
    fail "LD_DEBUG=files named no libstdc++ for --help: the loader's account is missing"
fi
for run in help phantom raw; do
    if grep -Eq "$big" "$work/$run.libs"; then
        fail "$run mapped $(grep -E "$big" "$work/$run.libs" | tr '\n' ' ')"
    else pass; fi
done
for library in ctlab_formats.so libteem; do
    if grep -q "$library" "$work/nrrd.libs"; then pass; else
        fail "the NRRD run did not map $library (mapped: $(tr '\n' ' ' < "$work/nrrd.libs"))"
    fi
done
# GDCM (its dictionaries built at load, most of a small run) is DICOM's module alone.
if grep -Eq 'libgdcm|ctlab_dicom' "$work/nrrd.libs"; then
    fail "the NRRD run mapped GDCM: $(grep -E 'libgdcm|ctlab_dicom' "$work/nrrd.libs" | tr '\n' ' ')"
else pass; fi
if grep -Eq 'libSDL2|ctlab_window' "$work/nrrd.libs"; then
    fail "a headless NRRD run mapped the window module"
else pass; fi
# Every step, not only 02: --help and a raw run map none of them either (part 2 and 3 at a
# small camera picture; the steps found in steps/, whatever their number).
for source in steps/[0-9][0-9]_*.cpp; do
    stem=$(basename "$source" .cpp)
    [ -x "$build/$stem" ] || { fail "$build/$stem is not built"; continue; }
    size=
    case $stem in 0[0-9]_*|1[0-2]_*) ;; *) size="--size 8x8" ;; esac
    mapped "help_$stem" "$build/$stem" --help
    # shellcheck disable=SC2086
    mapped "raw_$stem" "$build/$stem" --volume "$raw" --no-window --out "$work/out" $size
    for run in "help_$stem" "raw_$stem"; do
        if [ "$(cat "$work/$run.status")" != 0 ]; then
            fail "$run: exit status $(cat "$work/$run.status"): $(head -c 300 "$work/$run.err")"
        elif ! grep -q 'libstdc++' "$work/$run.libs"; then
            fail "$run: LD_DEBUG=files named no libstdc++: the loader's account is missing"
        elif grep -Eq "$big" "$work/$run.libs"; then
            fail "$run mapped $(grep -E "$big" "$work/$run.libs" | tr '\n' ' ')"
        else pass; fi
    done
done

# A step without its modules: the phantom runs; a file that needs one is one line, exit 2.
mkdir "$work/alone"
cp "$step" "$work/alone/"
"$work/alone/02_threshold" --volume phantom --dims 8,8,4 --no-window --out "$work/alone_out" \
    > /dev/null 2>&1
if [ $? = 0 ]; then pass; else fail "a step without its modules cannot render the phantom"; fi
"$work/alone/02_threshold" --volume "$nrrd" --no-window --out "$work/alone_out" \
    > "$work/alone.out" 2> "$work/alone.err"
status=$?
if [ $status = 2 ] && [ "$(wc -l < "$work/alone.err")" = 1 ] &&
   grep -q "02_threshold: error: .*ctlab_formats.so.*not there" "$work/alone.err"; then pass
else fail "no format module: exit $status, stderr '$(cat "$work/alone.err")'"; fi

# Without the window module (but with a display asked for): a note, the PNGs, exit 0.
DISPLAY=:9999 timeout 20 "$work/alone/02_threshold" --volume phantom --dims 8,8,4 --view top \
    --out "$work/nowin" > /dev/null 2> "$work/nowin.err" < /dev/null
status=$?
if [ $status = 0 ] && [ -f "$work/nowin/02_threshold_top.png" ] &&
   grep -q "note: no window (.*ctlab_window.so" "$work/nowin.err"; then pass
else fail "no window module: exit $status, stderr '$(cat "$work/nowin.err")'"; fi

echo "modules test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
