#!/bin/sh
# bad_input_test.sh: issue 6's list of bad input, one table row per case, run on the real
# binaries. Each must exit with status 2 and print exactly one line on stderr,
# "BINARY: error: ...", containing the row's text (which names the flag or file and what was
# expected); it must leave no file behind (no PNG, no temporary file) and end within a
# minute. tests/cli_test.sh runs the cases every step shares (missing file, a folder, an empty
# file, one byte short, dims over the limit, unknown flag and --view, --threads 0, --debug-pixel
# outside, --threshold abc, unwritable --out) on every step; this table adds the rest, and a
# check that huge dims are refused before anything is allocated.
#
#   sh tests/bad_input_test.sh BUILD      (make test runs it with BUILD = build)
#
# Prints one line per failure and a last line "bad input test: N passed, M failed".
set -u
build=${1:?usage: sh tests/bad_input_test.sh BUILD}
cd "$(dirname "$0")/.." || exit 2
[ -d steps ] || { echo "bad input test: run from the repository (no steps/ here)" >&2; exit 2; }

cthead_bytes=14811136  # 256 x 256 x 113 int16
passed=0
failed=0
work=$(mktemp -d) || exit 2
trap 'rm -rf "$work"' EXIT INT TERM
pass() { passed=$((passed + 1)); }
fail() {
    failed=$((failed + 1))
    echo "FAIL: $*"
}

# --- The files the table uses ------------------------------------------------------------
mkdir "$work/a_folder"
printf x > "$work/one_byte"
: > "$work/regular_file"
dd if=/dev/zero of="$work/one_long" bs=1 count=0 seek=$((cthead_bytes + 1)) 2> /dev/null
head -c 48 /dev/zero > "$work/raw48"  # 4x3x2 int16 voxels
tf() { printf '%b' "$2" > "$work/$1.tf"; }  # tf NAME TEXT: a transfer-function file
tf bad_kind '# line 1 is a comment\n\n-300 50 constnt 1 0.79 0.6 0.12 skin\n'
tf few_fields '-300 50 constant 1 0.79 0.6 0.12 skin\n300 32768\n'
tf field_count '-300 50 constant 1 0.79 0.6 0.12 skin extra\n'
tf not_number '-300 50 constant 1 zero 0.6 0.12\n'
tf whole_value '-300.5 50 constant 1 1 1 0.12\n'
tf above_int16 '300 40000 constant 1 1 1 0.8\n'
tf empty_range '50 50 constant 1 1 1 0.8\n'
tf overlapping '-300 50 constant 1 0.79 0.6 0.12 skin\n0 300 constant 1 1 1 0.5\n'
tf unsorted '300 32768 constant 1 1 1 0.8 bone\n-300 50 constant 1 0.79 0.6 0.12 skin\n'
tf opacity_high '-300 50 constant 1 0.79 0.6 1.5 skin\n'
tf opacity_negative '300 32768 ramp 1 1 1 0.2 1 1 1 -0.1\n'
tf opacity_nan '-300 50 constant 1 0.79 0.6 nan skin\n'
tf colour_inf '-300 50 constant inf 0.79 0.6 0.1 skin\n'
tf label_twice '-300 50 constant 1 1 1 0.1 skin\n300 400 constant 1 1 1 0.1 skin\n'
tf label_number '-300 50 constant 1 1 1 0.1 0.5\n'
tf binary '\001\002\003 \033[31m x y\r\n'
tf nul_byte '-300 5\00001 constant 1 1 1 0.1\n'  # 5, a NUL byte, 1
tf no_skin '300 32768 constant 1 1 1 0.8 bone\n'
# Pictures for the checker: 2x1 and 1x1 P3, a PNG cut short, text, an empty file.
printf 'P3 2 1 255 0 0 0 255 255 255\n' > "$work/two.ppm"
printf 'P3 1 1 255 9 9 9\n' > "$work/one.ppm"
printf 'P6 2 2 255\nabc' > "$work/short.ppm"
printf 'P6 4000 4000 65535\n' > "$work/header_only.ppm"
head -c 60 tests/fuzz/seeds/image/rgb8_4x3.png > "$work/cut.png"
echo "my notes, not a picture" > "$work/notes.png"
: > "$work/empty.png"

# --- The table ----------------------------------------------------------------------------
# Each case is two lines: BINARY ARGUMENTS (shell words), then "says: TEXT", the text that
# the one line on stderr must contain. A step (NN_name) gets --no-window --out OUT first.
w=$work
cat > "$work/table" << EOF
02_threshold --volume $w/one_byte
  says: '$w/one_byte' has 1 byte, expected exactly $cthead_bytes for CThead (256x256x113 int16)
02_threshold --volume $w/one_long
  says: '$w/one_long' has $((cthead_bytes + 1)) bytes, expected exactly $cthead_bytes for CThead
02_threshold --volume /dev/zero
  says: '/dev/zero' has 0 bytes
02_threshold --volume ""
  says: --volume: expected a path or 'phantom'
02_threshold --volume $w/raw48 --dims 0,3,2
  says: --dims: expected a whole number from 1 to 2147483647, got 0
02_threshold --volume $w/raw48 --dims -4,3,2
  says: --dims: expected a whole number from 1 to 2147483647, got -4
02_threshold --volume $w/raw48 --dims four,3,2
  says: --dims: expected a whole number, got 'four'
02_threshold --volume $w/raw48 --dims 4,3
  says: --dims: expected NX,NY,NZ, got '4,3'
02_threshold --volume $w/raw48 --dims 99999999999,1,1
  says: --dims: expected a whole number from 1 to 2147483647, got 99999999999
02_threshold --volume $w/raw48 --dims 2048,2048,513
  says: --dims 2048x2048x513 is over the limit of 1073741824 voxels (2 GiB of int16)
02_threshold --volume phantom --dims 2048,2048,512
  says: phantom: 2048x2048x512 is over the limit of 1073741824 voxels (2 GiB of int16)
02_threshold --volume $w/raw48 --dims 65536,65536,65536
  says: --dims 65536x65536x65536 is over the limit
02_threshold --volume $w/raw48 --dims 4,3,3
  says: '$w/raw48' has 48 bytes, expected exactly 72 for 4x3x3 int16 voxels
02_threshold --volume $w/raw48 --dims 4,3,2 --spacing 1,0,1
  says: --spacing: expected three positive numbers SX,SY,SZ
02_threshold --volume $w/raw48 --dims 4,3,2 --spacing 1,1,-1
  says: --spacing: expected a number from 0 to 1e+06, got -1
02_threshold --volume $w/raw48 --dims 4,3,2 --spacing nan,1,1
  says: --spacing: expected a number, got 'nan'
02_threshold --volume $w/raw48 --dims 4,3,2 --spacing 1,2
  says: --spacing: expected SX,SY,SZ, got '1,2'
02_threshold --volume $w/raw48 --dims 4,3,2 --endian middle
  says: --endian: expected little or big, got 'middle'
07_compositing_order --volume phantom --order sideways
  says: --order: expected one of f2b, b2f, both, got 'sideways'
07_compositing_order --volume phantom --view back
  says: --view: expected top, front, side or all, got 'back'
08_lit_compositing --volume phantom --stpe 2
  says: unknown option '--stpe' (see --help)
02_threshold --volume phantom --threshold
  says: --threshold: missing value
02_threshold --volume phantom --no-window=yes
  says: --no-window: takes no value
02_threshold --volume phantom --debug-pixel 256,0
  says: --debug-pixel 256,0 is outside the top image (256x256)
02_threshold --volume phantom --view front --debug-pixel 0,113
  says: --debug-pixel 0,113 is outside the front image (256x113)
02_threshold --volume phantom --debug-pixel -1,5
  says: --debug-pixel: expected a whole number from 0 to 2147483647, got -1
02_threshold --volume phantom --debug-pixel 5
  says: --debug-pixel: expected X,Y (image column, row), got '5'
02_threshold --volume phantom --threshold 1e31
  says: --threshold: expected a number from -1e+30 to 1e+30, got 1e31
02_threshold --volume phantom --threshold 40000
  says: --threshold: expected a number from -32768 to 32767, got 40000
05_interpolated_hits --volume phantom --threshold bone
  says: --threshold: expected a number, got 'bone'
08_lit_compositing --volume phantom --step 0
  says: --step: expected a number from 0.25 to 4, got 0
08_lit_compositing --volume phantom --step nan
  says: --step: expected a number, got 'nan'
08_lit_compositing --volume phantom --spacing 1e6,1e6,1e6
  says: --step 1 with --spacing 1e+06,1e+06,1e+06 asks for 1.13e+08 samples per ray in the top view, over the limit of 7232 (64 per voxel): raise --step or lower --spacing
09_empty_space --volume phantom --spacing 1e6,1e6,1e6 --step 4
  says: --step 4 with --spacing 1e+06,1e+06,1e+06 asks for 2.825e+07 samples per ray in the top view, over the limit of 7232 (64 per voxel): raise --step or lower --spacing
09_empty_space --volume phantom --view front --spacing 1,1,100 --step 0.25
  says: --step 0.25 with --spacing 1,1,100 asks for 4.52e+04 samples per ray in the top view, over the limit of 7232 (64 per voxel): raise --step or lower --spacing
06_transfer_function --volume phantom --skin-opacity 2
  says: --skin-opacity: expected a number from 0 to 1, got 2
07_compositing_order --volume phantom --skin-opacity -0.1
  says: --skin-opacity: expected a number from 0 to 1, got -0.1
08_lit_compositing --volume phantom --skin-opacity 2
  says: --skin-opacity: expected a number from 0 to 1, got 2
08_lit_compositing --volume phantom --threads 0
  says: --threads: expected a whole number from 1 to 256, got 0
02_threshold --volume phantom --threads 1000
  says: --threads: expected a whole number from 1 to 256, got 1000
07_compositing_order --volume phantom --ert 2
  says: --ert: expected a number from 0 to 1, got 2
04_gradient_lighting --volume phantom --light-angle 500
  says: --light-angle: expected a number from -180 to 180, got 500
00_slices --volume phantom --view top --slice 200
  says: --slice: the top view has slices 0 to 112, got 200
06_transfer_function --volume phantom --tf $w/bad_kind.tf
  says: bad_kind.tf:3: the kind must be constant or ramp, got 'constnt'
06_transfer_function --volume phantom --tf $w/few_fields.tf
  says: few_fields.tf:2: expected FROM TO constant
06_transfer_function --volume phantom --tf $w/field_count.tf
  says: field_count.tf:1: a constant range has FROM TO constant, 4 numbers (R G B A) and an
06_transfer_function --volume phantom --tf $w/not_number.tf
  says: not_number.tf:1: green must be a number from 0 to 1, got 'zero'
06_transfer_function --volume phantom --tf $w/whole_value.tf
  says: whole_value.tf:1: FROM must be a whole CT value, got '-300.5'
06_transfer_function --volume phantom --tf $w/above_int16.tf
  says: above_int16.tf:1: TO must be from -32768 to 32768, got 40000
06_transfer_function --volume phantom --tf $w/empty_range.tf
  says: empty_range.tf:1: FROM must be below TO, got 50 50
06_transfer_function --volume phantom --tf $w/overlapping.tf
  says: overlapping.tf:2: the range [0, 300) overlaps [-300, 50) on line 1
06_transfer_function --volume phantom --tf $w/unsorted.tf
  says: unsorted.tf:2: ranges must be sorted by FROM: [-300, 50) comes after [300, 32768) on line 1
07_compositing_order --volume phantom --tf $w/opacity_high.tf
  says: opacity_high.tf:1: opacity must be from 0 to 1, got 1.5
08_lit_compositing --volume phantom --tf $w/opacity_negative.tf
  says: opacity_negative.tf:1: end opacity must be from 0 to 1, got -0.1
06_transfer_function --volume phantom --tf $w/opacity_nan.tf
  says: opacity_nan.tf:1: opacity is not a number (nan), expected 0 to 1
06_transfer_function --volume phantom --tf $w/colour_inf.tf
  says: colour_inf.tf:1: red must be from 0 to 1, got inf
06_transfer_function --volume phantom --tf $w/label_twice.tf
  says: label_twice.tf:2: the label 'skin' is already used on line 1
06_transfer_function --volume phantom --tf $w/label_number.tf
  says: label_number.tf:1: the label must be a name, got the number 0.5
06_transfer_function --volume phantom --tf $w/binary.tf
  says: binary.tf:1: FROM must be a whole CT value, got '???'
06_transfer_function --volume phantom --tf $w/nul_byte.tf
  says: nul_byte.tf:1: TO must be a whole CT value, got '5?1'
06_transfer_function --volume phantom --tf $w/no_skin.tf --skin-opacity 0.5
  says: --skin-opacity: $w/no_skin.tf has no range labelled 'skin'
06_transfer_function --volume phantom --tf $w/missing.tf
  says: --tf: cannot open '$w/missing.tf': No such file or directory
06_transfer_function --volume phantom --tf $w/a_folder
  says: --tf: '$w/a_folder' is a folder, not a file
06_transfer_function --volume phantom --tf /dev/zero
  says: --tf: '/dev/zero' is not an ordinary file
02_threshold --volume phantom --out ""
  says: --out: expected a folder
02_threshold --volume phantom --out $w/regular_file/out
  says: --out: cannot write to '$w/regular_file/out': '$w/regular_file' is a file, not a folder
02_threshold --volume phantom --out /proc/ctlab_out/pictures
  says: --out: cannot create folder '/proc/ctlab_out'
02_threshold --volume phantom --out /proc/self
  says: --out: cannot write to folder '/proc/self'
check $w/two.ppm $w/one.ppm --diff $w/out/diff.png
  says: $w/two.ppm is 2x1 but $w/one.ppm is 1x1
check $w/notes.png $w/one.ppm
  says: '$w/notes.png': is not a PNG or PPM (P6/P3) image
check $w/one.ppm $w/empty.png
  says: '$w/empty.png': is empty (0 bytes), not an image
check $w/cut.png $w/one.ppm
  says: '$w/cut.png': is a damaged or truncated PNG
check $w/short.ppm $w/one.ppm
  says: '$w/short.ppm': is truncated: 3 bytes of pixel data, expected at least 12
check $w/header_only.ppm $w/one.ppm
  says: '$w/header_only.ppm': is truncated
check $w/one.ppm $w/missing.png
  says: '$w/missing.png': no such file
check $w/a_folder $w/one.ppm
  says: '$w/a_folder': is a folder, not an image file
check /dev/zero $w/one.ppm
  says: '/dev/zero': is not an ordinary file
check $w/one.ppm
  says: expected STUDENT.png REFERENCE.png or --submission DIR, got 1 file names
check $w/one.ppm $w/one.ppm --tol two
  says: --tol: expected a number, got 'two'
check $w/one.ppm $w/one.ppm --tol 300
  says: --tol: expected a number from 0 to 255, got 300
check $w/one.ppm $w/one.ppm --tolerance 3
  says: unknown flag '--tolerance' (see check --help)
check --submission $w/missing
  says: submission folder '$w/missing' does not exist
check --submission $w/notes.png
  says: submission folder '$w/notes.png' is not a folder
check --submission $w/a_folder --reference $w/a_folder
  says: reference folder '$w/a_folder' has no pictures named NN_name_top
EOF

# --- Running it ---------------------------------------------------------------------------
out="$work/out"
while read -r binary arguments; do
    [ -z "$binary" ] && continue
    read -r says text
    [ "$says" = says: ] || { echo "bad input test: no 'says:' line after $binary"; exit 2; }
    eval "set -- $arguments"
    rm -rf "$out"
    mkdir "$out"
    case "$binary" in [0-9][0-9]_*) set -- --no-window --out "$out" "$@" ;; esac
    what="$binary $arguments"
    if [ ! -x "$build/$binary" ]; then
        fail "$build/$binary is not built"
        continue
    fi
    timeout 60 "$build/$binary" "$@" > "$work/stdout" 2> "$work/stderr" < /dev/null
    status=$?
    if [ $status -ne 2 ]; then
        fail "$what: exit status $status, expected 2 (124: it hung): $(head -c 300 "$work/stderr")"
    elif [ "$(wc -l < "$work/stderr")" -ne 1 ] || [ -n "$(tail -c 1 "$work/stderr")" ]; then
        fail "$what: expected one line on stderr, got: $(cat "$work/stderr")"
    elif ! grep -q "^$binary: error: " "$work/stderr" || ! grep -qF -- "$text" "$work/stderr"; then
        fail "$what: stderr does not say '$binary: error: ...$text...': $(cat "$work/stderr")"
    elif [ -n "$(find "$out" -type f)" ] || [ -n "$(find "$work" -name '*.tmp*')" ]; then
        fail "$what: left files behind: $(find "$out" "$work" -type f -name '*.*' | head -n 3)"
    else
        pass
    fi
done < "$work/table"

# --- Huge dims, tiny file: refused before allocating ----------------------------------------
# 1024x1024x1024 is at the voxel limit (2 GiB of int16) but the file has 48 bytes. With
# the address space limited to 1 GiB, allocating first would end in "out of memory"; the
# loader must look at the file's size first. A sanitizer build maps terabytes of shadow
# memory and cannot run under ulimit -v: there ASan itself refuses allocations over 1 GiB.
huge="--volume $work/raw48 --dims 1024,1024,1024"
# (The probe keeps its own status, so that a sanitizer build's abort is not reported here.)
if (ulimit -v 1048576 && "$build/02_threshold" --help; status=$?; exit $status) > /dev/null 2>&1
then
    (ulimit -v 1048576 && exec "$build/02_threshold" $huge --no-window --out "$out") \
        > /dev/null 2> "$work/stderr"
else
    ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}max_allocation_size_mb=1024" \
        "$build/02_threshold" $huge --no-window --out "$out" > /dev/null 2> "$work/stderr"
fi
status=$?
if [ $status -eq 2 ] && grep -qF "has 48 bytes, expected exactly 2147483648 for 1024x1024x1024 int16 voxels" "$work/stderr"; then
    pass
else
    fail "huge dims on a 48-byte file: status $status: $(head -c 300 "$work/stderr")"
fi

echo "bad input test: $passed passed, $failed failed"
[ $failed -eq 0 ]
