#!/bin/sh
# grade_test.sh: the checker (build/grade) against hostile and careless submissions, a class
# graded in one command, and `make reference` for a raw volume of another size.
#
#   sh tests/grade_test.sh BUILD      (make test runs it with BUILD = build)
#
# - A submission holding symbolic links (named check_diffs, named like the report's files, a
#   picture linked to /etc/passwd), a decompression bomb (a 2 MB PNG inflating to 2 GiB), a
#   PNG declaring 16384 x 16384, a 1x1 PPM followed by 1 GiB (sparse), a FIFO, a flipped byte:
#   graded under `ulimit -v` within seconds, each an error (or damaged) row with one line, and
#   nothing outside the report folder changes (every file of the submission, the references
#   and /etc/passwd hashed, or past 64 MiB its change time compared, before and after).
# - --report, --diff: refused inside (or as) a submission, a reference or an input.
# - A class of five students (one passing, two with byte-identical wrong pictures, one with
#   its pictures in a subfolder named in capitals, one student tree rendered from another
#   volume) into one class.csv and one summary.md.
# - A class of two student trees graded by build/check beside the checker (their programs run:
#   one right, one with a wrong threshold): verdicts, worst pixel, counter, side-by-side.
# - make reference VOLUME=f.raw DIMS=64,80,40 REFERENCE=dir, then a render checked against it.
#
# Prints one line per failure and a last line "grade test: N passed, M failed".
set -u
build=${1:?usage: sh tests/grade_test.sh BUILD}
cd "$(dirname "$0")/.." || exit 2
[ -d steps ] || { echo "grade test: run from the repository (no steps/ here)" >&2; exit 2; }
command -v python3 > /dev/null || { echo "grade test: needs python3" >&2; exit 2; }

passed=0
failed=0
work=$(mktemp -d) || exit 2
reference_pid=
trap '[ -z "$reference_pid" ] || kill "$reference_pid" 2> /dev/null; rm -rf "$work"' EXIT INT TERM
# check CONDITION_STATUS DESCRIPTION: counts a pass when the status before it was 0.
check() {
    if [ "$1" -eq 0 ]; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAIL: $2"; fi
}

# The checker is copied alone into a folder of its own: no build/check beside it, so a student
# tree is graded from its out/ pictures whatever else is built.
mkdir "$work/bin"
cp "$build/grade" "$work/bin/grade" || exit 2
checker="$work/bin/grade"
memory_kib=400000  # ulimit -v for the hostile runs: a 2 GiB inflation cannot fit
# A sanitizer build reserves terabytes of address space and cannot start under ulimit -v; its
# ASAN_OPTIONS (max_allocation_size_mb, see the Makefile) bound each allocation instead.
limit_memory="ulimit -v $memory_kib"
if ! (ulimit -v $memory_kib; "$checker" --help) > /dev/null 2>&1; then
    limit_memory=:
    echo "grade test: note: $build/grade does not start under ulimit -v (a sanitizer build?):" \
        "the hostile submission runs without it"
fi

# A small reference folder: steps 02 and 03, three views each, from the committed phantom's.
ref="$work/ref"
mkdir "$ref"
for picture in 02_threshold 03_depth_shading; do
    for view in top front side; do cp "data/reference/${picture}_$view.png" "$ref/"; done
done
cp data/reference/manifest.txt "$ref/"

# snapshot DIR...: every path with its type, size, link target, and modification and change
# times (any write moves the change time, and no unprivileged process can set it back), and
# the hash of every file up to 64 MiB: hashing the sparse 1 GiB one cost ~6 s of CPU a time.
snapshot() {
    find "$@" -printf '%p %y %s %l %T@ %C@\n' | LC_ALL=C sort
    find "$@" -type f -size -65537k -exec sha256sum {} + | LC_ALL=C sort
}
# png_width FILE: the width in a PNG's IHDR.
png_width() { od -An -tu1 -j16 -N4 "$1" | awk '{ print $1 * 16777216 + $2 * 65536 + $3 * 256 + $4 }'; }

# --- make reference for a raw volume of another size (started here, checked last) ---------
# Every step's every run and probe on the volume, one process after another: it runs in the
# background, beside the sections below (its ~10 s of CPU were half this suite's, serial).
python3 - "$work/sphere.raw" <<'EOF'
import struct, sys
nx, ny, nz = 64, 80, 40
values = []
for k in range(nz):
    for j in range(ny):
        for i in range(nx):
            r = ((i - 32) ** 2 + (j - 40) ** 2 + (2 * (k - 20)) ** 2) ** 0.5
            values.append(-1000 if r > 30 else 0 if r > 24 else 1200)  # air, skin, bone
open(sys.argv[1], 'wb').write(struct.pack('<%dh' % len(values), *values))
EOF
make --no-print-directory reference STEP_BINARIES= BUILD="$build" VOLUME="$work/sphere.raw" \
    DIMS=64,80,40 \
    REFERENCE="$work/ref64" > "$work/reference.out" 2>&1 &
reference_pid=$!

# --- A hostile submission ---------------------------------------------------------------------
evil="$work/evil"
mkdir "$evil" "$work/elsewhere"
ln -s /etc/passwd "$evil/02_threshold_top.png"
ln -s "$ref" "$evil/check_diffs"
ln -s "$ref" "$evil/pictures"
ln -s "$ref/02_threshold_front.png" "$evil/report.md"
ln -s "$work/elsewhere/planted.csv" "$evil/report.csv"
python3 tests/make_bomb_png.py "$evil/02_threshold_front.png" 256 113 2147483648
python3 tests/make_bomb_png.py "$evil/03_depth_shading_top.png" 16384 16384 1048576
# A flipped byte inside the image data of a real PNG.
cp "$ref/02_threshold_side.png" "$evil/02_threshold_side.png"
python3 - "$evil/02_threshold_side.png" <<'EOF'
import sys
path = sys.argv[1]
data = bytearray(open(path, 'rb').read())
at = data.index(b'IDAT') + 4 + 40  # inside the compressed data
data[at] ^= 0x10
open(path, 'wb').write(bytes(data))
EOF
# 1x1 PPMs followed by 1 MiB, and by 1 GiB (sparse), of junk.
printf 'P6 1 1 255\n\001\002\003' > "$evil/03_depth_shading_front.png"
cp "$evil/03_depth_shading_front.png" "$evil/huge_junk.ppm"
truncate -s 1048587 "$evil/03_depth_shading_front.png"
truncate -s 1073741835 "$evil/huge_junk.ppm"
mkfifo "$evil/03_depth_shading_side.png"
printf 'not a picture' > "$evil/$(printf 'new\nline.png')"
before=$(snapshot "$evil" "$ref" "$work/elsewhere" /etc/passwd)

start=$(date +%s)
($limit_memory; timeout 60 "$checker" --submission "$evil" --reference "$ref" \
    --report "$work/evil_report" > "$work/evil.out" 2> "$work/evil.err")
status=$?
elapsed=$(($(date +%s) - start))
after=$(snapshot "$evil" "$ref" "$work/elsewhere" /etc/passwd)
[ "$before" = "$after" ]
check $? "the hostile submission changed a file outside the report folder"
[ $status -eq 1 ] && [ ! -s "$work/evil.err" ]
check $? "hostile submission: status $status (expected 1), stderr: $(cat "$work/evil.err")"
[ $elapsed -le 20 ]
check $? "hostile submission took $elapsed s"
csv="$work/evil_report/report.csv"
# expect FILE RESULT TEXT: the CSV row of FILE has RESULT and TEXT in its note, on one line.
expect() {
    line=$(grep "^$1," "$csv")
    [ "$(printf '%s\n' "$line" | wc -l)" -eq 1 ] && case "$line" in "$1,$2,"*"$3"*) true ;; *) false ;; esac
    check $? "$1: expected $2 with '$3', got: $line"
}
expect 02_threshold_top.png error "is a symbolic link: not followed"
expect 02_threshold_front.png error "refused (a decompression bomb?)"
expect 02_threshold_side.png damaged "does not match: a changed byte?"
expect 03_depth_shading_top.png error "is 16384x16384 pixels: larger than the limit"
expect 03_depth_shading_front.png error "more than its declared picture can need (14): refused unread"
expect 03_depth_shading_side.png error "not an ordinary file"
grep -q '^new\\nline.png,extra,' "$csv"
check $? "a file name with a newline is not reported escaped: $(grep extra "$csv")"
[ "$(ls -A "$work/evil_report" | tr '\n' ' ')" = "pictures report.csv report.md " ] &&
    [ -z "$(ls -A "$work/evil_report/pictures")" ] && [ -z "$(ls -A "$work/elsewhere")" ]
check $? "the report folder holds other files: $(ls -AR "$work/evil_report" "$work/elsewhere")"
# Run again into the same folder: old reports are replaced, no temporary is left.
"$checker" --submission "$evil" --reference "$ref" --report "$work/evil_report" > /dev/null 2>&1
[ $? -eq 1 ] && [ "$(ls -A "$work/evil_report" | tr '\n' ' ')" = "pictures report.csv report.md " ]
check $? "a second run left: $(ls -A "$work/evil_report")"

# --- Where the checker refuses to write ------------------------------------------------------
good="$work/good"
mkdir "$good"
cp "$ref"/0*.png "$good/"
# refuse EXPECTED_TEXT ARGUMENTS...: status 2, one stderr line holding the text, no new file.
refuse() {
    text=$1
    shift
    before=$(snapshot "$good" "$ref" "$work/elsewhere")
    "$checker" "$@" > "$work/refuse.out" 2> "$work/refuse.err"
    status=$?
    after=$(snapshot "$good" "$ref" "$work/elsewhere")
    [ $status -eq 2 ] && [ "$(wc -l < "$work/refuse.err")" -eq 1 ] &&
        grep -qF -- "$text" "$work/refuse.err" && [ "$before" = "$after" ]
    check $? "check $*: status $status, expected 2 and '$text': $(cat "$work/refuse.err")"
}
refuse "is inside the submission folder" --submission "$good" --reference "$ref" \
    --report "$good/reports"
refuse "is the submission folder" --submission "$good" --reference "$ref" --report "$good"
refuse "is the reference folder" --submission "$good" --reference "$ref" --report "$ref/"
refuse "holds the submission folder" --submission "$good" --reference "$ref" --report "$work"
refuse "cannot create folder" --submission "$good" --reference "$ref" \
    --report "$work/no/such/parent"
refuse "is one of the pictures being compared" "$good/02_threshold_top.png" "$ref/02_threshold_top.png" \
    --diff "$good/02_threshold_top.png"
refuse "is in a reference folder" "$good/02_threshold_top.png" "$ref/02_threshold_top.png" \
    --diff "$ref/heat.png"
refuse "does not exist (create it first)" "$good/02_threshold_top.png" \
    "$ref/02_threshold_top.png" --diff "$work/elsewhere/missing/heat.png"
ln -s "$ref/02_threshold_side.png" "$work/elsewhere/link.png"
refuse "is a symbolic link: not replaced" "$good/02_threshold_top.png" \
    "$ref/02_threshold_top.png" --diff "$work/elsewhere/link.png"
rm "$work/elsewhere/link.png"
refuse "is not an ordinary file" "$good/02_threshold_top.png" "$ref/02_threshold_top.png" \
    --diff /dev/null
refuse "is a symbolic link: not followed" "$evil/02_threshold_top.png" \
    "$ref/02_threshold_top.png"
refuse "is 1073741835 bytes: larger than any picture the checker reads" "$evil/huge_junk.ppm" \
    "$ref/02_threshold_top.png"
[ ! -e "$work/elsewhere/missing" ]
check $? "--diff created a missing folder"
"$checker" --submission "$good" --reference "$ref" > "$work/good.out" 2>&1
check $? "a correct submission does not pass: $(tail -n 3 "$work/good.out")"
"$checker" "$good/02_threshold_top.png" "$ref/02_threshold_top.png" --diff "$work/heat.png" \
    > /dev/null && [ -s "$work/heat.png" ]
check $? "--diff into a folder of its own writes no heat map"

# --- A class of five ---------------------------------------------------------------------------
class="$work/class"
mkdir -p "$class/ann" "$class/ben" "$class/cat" "$class/dan/out" "$class/eve/out" "$class/eve/steps"
cp "$ref"/0*.png "$class/ann/"
cp "$ref"/0*.png "$class/ben/"
cp data/reference/02_threshold_front_dense.png "$class/ben/02_threshold_front.png"  # wrong
cp "$ref"/0*.png "$class/cat/"
cp "$class/ben/02_threshold_front.png" "$class/cat/"  # byte-identical to ben's wrong one
for picture in "$ref"/0*.png; do
    name=$(basename "$picture" | tr a-z A-Z)  # 02_THRESHOLD_TOP.PNG
    cp "$picture" "$class/dan/out/$name"
done
: > "$class/eve/.ctlab-student"  # a student tree, its out/ rendered from another volume
for picture in "$ref"/0*.png; do
    python3 tests/make_bomb_png.py "$class/eve/out/$(basename "$picture")" 64 40 \
        $((40 * (1 + 64 * 3)))
done
printf 'ann\nben\n' > "$class/roster.txt"  # a file, not a student
# grade_class CHECKER CLASS REFERENCE REPORT WHAT: the class graded into REPORT: status 1 (some
# student fails), nothing on stderr, the class and reference folders unchanged.
grade_class() {
    before=$(snapshot "$2" "$3")
    "$1" --class "$2" --reference "$3" --report "$4" > "$4.out" 2> "$4.err"
    status=$?
    after=$(snapshot "$2" "$3")
    [ $status -eq 1 ] && [ ! -s "$4.err" ] && [ "$before" = "$after" ]
    check $? "$5: status $status (expected 1), stderr: $(cat "$4.err")"
}
grade_class "$checker" "$class" "$ref" "$work/class_report" "class"
classcsv="$work/class_report/class.csv"
[ "$(head -n 1 "$classcsv")" = "student,result,score_pct,source,02_threshold,03_depth_shading,note" ] &&
    [ "$(wc -l < "$classcsv")" -eq 6 ]
check $? "class.csv: expected a header and 5 rows: $(cat "$classcsv")"
grep -qx 'ann,pass,100.0,pictures,1.00,1.00,' "$classcsv"
check $? "class.csv: ann: $(grep ^ann "$classcsv")"
grep -qx 'ben,fail,83.3,pictures,0.67,1.00,' "$classcsv" &&
    grep -qx 'cat,fail,83.3,pictures,0.67,1.00,' "$classcsv"
check $? "class.csv: ben and cat: $(grep -e ^ben -e ^cat "$classcsv")"
grep -q "^dan,pass,100.0,pictures in out/,1.00,1.00,.*the pictures sit in the subfolder 'out/'" \
    "$classcsv"
check $? "class.csv: dan: $(grep ^dan "$classcsv")"
grep -q "^eve,fail,0.0,tree's out/ pictures.*rendered from another volume or view?" "$classcsv"
check $? "class.csv: eve: $(grep ^eve "$classcsv")"
summary="$work/class_report/summary.md"
grep -q '02_threshold_front.png: ben, cat handed in byte-identical failing pictures' "$summary"
check $? "summary.md names no identical pictures: $(sed -n '/Identical/,$p' "$summary")"
grep -q '| 02_threshold_front.png | fail: pixels beyond the tolerance | 2 | ben, cat |' "$summary"
check $? "summary.md: commonest failures: $(sed -n '/Commonest/,/Identical/p' "$summary")"
side="$work/class_report/students/ben/pictures/02_threshold_front.png"
[ -f "$side" ] && [ "$(png_width "$side")" -eq $((3 * 256 + 2 * 4)) ] &&
    [ -f "$work/class_report/students/ben/report.md" ] &&
    [ ! -e "$work/class_report/students/ann/pictures/02_threshold_front.png" ]
check $? "side-by-side pictures: $(ls -R "$work/class_report/students" | tr '\n' ' ')"
# The counts read as English: "5 students: 2 pass, 3 do not"; a class of one is "1 student"
# (never "1 students"), one student "passes" and one failing "does not".
grep -qx '5 students: 2 pass, 3 do not' "$work/class_report.out"
check $? "the class's count line: $(grep ' pass, ' "$work/class_report.out")"
mkdir -p "$work/one/ann" "$work/two/ann" "$work/two/ben"
cp "$ref"/0*.png "$work/one/ann/"
cp "$class"/ann/*.png "$work/two/ann/"
cp "$class"/ben/*.png "$work/two/ben/"
"$checker" --class "$work/one" --reference "$ref" --report "$work/one_report" \
    > "$work/one.out" 2>&1
status=$?
[ $status -eq 0 ] && grep -qx '1 student: 1 passes, 0 do not' "$work/one.out"
check $? "a class of one (status $status): $(cat "$work/one.out")"
"$checker" --class "$work/two" --reference "$ref" --report "$work/two_report" \
    > "$work/two.out" 2>&1
grep -qx '2 students: 1 passes, 1 does not' "$work/two.out"
check $? "a class of two, one failing: $(grep ' pass, ' "$work/two.out")"
"$checker" --class "$class" --reference "$ref" --report "$class/reports" > /dev/null 2>&1
[ $? -eq 2 ] && [ ! -e "$class/reports" ]
check $? "--report inside the class folder was not refused"

# build/check --build refuses a library older than any file of common/ ("make, so students
# are built against the library as it is"): make must then archive it again, also for a
# header no object of the library includes (a pulled common/object_order.h left the refusal
# standing). make -q -W: what make would do were that header new, touching nothing.
if [ "$build" = build ] && [ -f common/object_order.h ]; then
    env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make -q -W common/object_order.h "$build/libctlab.a" \
        > /dev/null 2>&1
    [ $? -eq 1 ]
    check $? "make does not rebuild $build/libctlab.a when common/object_order.h is newer"
fi

# --- A class of student trees, graded by building and running their programs --------------
# build/check --build (beside the checker) builds each tree's steps/ from source against the
# lab's common/ in the sandbox and runs them on the phantom (never its out/ pictures, never its
# build/). Two trees with step 02: ann's source is the lab's own, ben's has the threshold 1000
# instead of the step's; each build/ holds a prebuilt program that says the opposite (ann's
# runs with --threshold 1000, ben's is the lab's binary): both are ignored.
gref=$work/gref
gclass=$work/gclass
mkdir -p "$gref"
cp data/reference/02_threshold_top.png data/reference/02_threshold_front.png \
    data/reference/02_threshold_side.png "$gref/"
echo "02_threshold:" > "$gref/manifest.txt"  # the default run alone: one run per student
grep '^02_threshold: ' data/reference/counters.txt > "$gref/counters.txt"
for student in ann ben; do
    mkdir -p "$gclass/$student/steps" "$gclass/$student/build"
    : > "$gclass/$student/.ctlab-student"
done
cp steps/02_threshold.cpp "$gclass/ann/steps/"
sed 's/bone_threshold = 400;/bone_threshold = 1000;/' steps/02_threshold.cpp \
    > "$gclass/ben/steps/02_threshold.cpp"
cp "$build/02_threshold" "$gclass/ben/build/"
case "$build" in
    /*) lab_program=$build/02_threshold ;;
    *) lab_program=$(pwd)/$build/02_threshold ;;
esac
printf '#!/bin/sh\nexec "%s" "$@" --threshold 1000\n' "$lab_program" \
    > "$gclass/ann/build/02_threshold"
chmod +x "$gclass/ann/build/02_threshold"
grade_class "$build/grade" "$gclass" "$gref" "$work/gclass_report" "class of trees"
gcsv="$work/gclass_report/class.csv"
grep -qx 'ann,pass,100.0,program (build/check),1.00,' "$gcsv" &&
    grep -q '^ben,fail,0.0,program (build/check),0.00,"*02_threshold: ' "$gcsv"
check $? "class of trees: class.csv: $(cat "$gcsv")"
ben=$work/gclass_report/students/ben
grep -q '^02_threshold: failing, pictures 0/3, counters 0/3$' "$ben/report.txt" &&
    grep -q -- '--view top --debug-pixel [0-9]*,[0-9]*$' "$ben/report.txt" &&
    grep -q '^  counter samples=5583119 where the reference run has samples=' \
        "$ben/report.txt" &&
    [ "$(png_width "$ben/side_by_side/02_threshold_top.png")" -eq $((3 * 256 + 2 * 4)) ] &&
    grep -q '^02_threshold: passing, pictures 3/3, counters 3/3$' \
        "$work/gclass_report/students/ann/report.txt"
check $? "class of trees: the students' grade reports: $(cat \
    "$work/gclass_report"/students/*/report.txt)"
grep -q "^| 02_threshold (the program) | fail: see the student's report.txt | 1 | ben |\$" \
    "$work/gclass_report/summary.md"
check $? "class of trees: summary.md: $(sed -n '/Commonest/,/Identical/p' \
    "$work/gclass_report/summary.md")"

# --- Folder mode and program mode agree ------------------------------------------------------
# The same submission graded both ways: the lab's steps 08 and 10 run with --ert 0 (the exact
# answer: within 3 levels, the manifest's tol=3, of the early-terminated reference) pass both
# in program mode (build/check, pictures P/P) and folder mode (build/grade --submission on the
# pictures those runs wrote), and --ert 0.3 fails both; part 2's camera picture is expected,
# not "extra".
bref=$work/bref
mkdir -p "$bref"
for stem in 08_compositing_order 10_opacity_correction; do
    cp "data/reference/${stem}_top.png" "data/reference/${stem}_front.png" \
        "data/reference/${stem}_side.png" "$bref/"
    grep "^$stem: " data/reference/manifest.txt >> "$bref/manifest.txt"
done
cp data/reference/25_free_leaping_camera.png "$bref/"
echo "25_free_leaping: tol=3" >> "$bref/manifest.txt"
# The phantom written once to a raw file that every run reads (the same voxels as --volume
# phantom, without painting the head again in each of the ~20 runs, 0.1 s of CPU each), and
# step 25's picture, the same in both submissions, rendered once.
phantom=$work/phantom.raw
"$build/make_phantom" "$phantom" > /dev/null
"$build/25_free_leaping" --volume "$phantom" --no-window --out "$work/both_24" > /dev/null 2>&1
for ert in 0 0.3; do
    "$build/check" --bin "$build" --reference "$bref" --out "$work/both_$ert" --step 08 \
        --step 10 --step 25 --args "--ert $ert" --volume "$phantom" > "$work/both_$ert.log" 2>&1
    mkdir -p "$work/both_sub_$ert"
    cp "$work/both_$ert"/08_compositing_order/*.png "$work/both_$ert"/10_opacity_correction/*.png \
        "$work/both_24"/*.png "$work/both_sub_$ert/"
    "$checker" --submission "$work/both_sub_$ert" --reference "$bref" > "$work/both_check_$ert.log" 2>&1
done
grep -q '^08_compositing_order: [a-z]*, pictures 3/3,' "$work/both_0/report.txt" &&
    grep -q '^10_opacity_correction: [a-z]*, pictures 3/3,' "$work/both_0/report.txt" &&
    grep -q '^25_free_leaping: [a-z]*, pictures 1/1,' "$work/both_0/report.txt" &&
    grep -q '^7 expected: 7 pass, 0 fail, 0 damaged, 0 error, 0 missing; 0 extra; result=pass$' \
        "$work/both_check_0.log"
check $? "--ert 0 passes both modes: $(cat "$work/both_0/report.txt" "$work/both_check_0.log")"
grep -q '^08_compositing_order: failing, pictures 0/3,' "$work/both_0.3/report.txt" &&
    grep -q '^10_opacity_correction: failing, pictures 0/3,' "$work/both_0.3/report.txt" &&
    grep -q '^7 expected: 1 pass, 6 fail, .*result=fail$' "$work/both_check_0.3.log"
check $? "--ert 0.3 fails both modes: $(cat "$work/both_0.3/report.txt" "$work/both_check_0.3.log")"
"$checker" --submission "$work/both_sub_0" --reference "$bref" --tol 2 > "$work/both_tol2.log" 2>&1
grep -q '^7 expected: 1 pass, 6 fail' "$work/both_tol2.log"
check $? "--tol 2 holds for every picture: $(cat "$work/both_tol2.log")"

# --- make reference for a raw volume of another size ----------------------------------------
wait "$reference_pid"
status=$?
[ $status -eq 0 ] && [ "$(png_width "$work/ref64/02_threshold_front.png")" -eq 64 ] &&
    grep -qx 'dims: 64x80x40' "$work/ref64/volume.txt" &&
    grep -qx "volume: $work/sphere.raw" "$work/ref64/volume.txt" &&
    grep -qx 'endian: little' "$work/ref64/volume.txt" &&
    grep -q '^spacing: ' "$work/ref64/volume.txt" && grep -q '^commit: ' "$work/ref64/volume.txt" &&
    grep -q '^date: 20' "$work/ref64/volume.txt"
check $? "make reference DIMS=64,80,40: status $status: $(tail -n 2 "$work/reference.out"; cat "$work/ref64/volume.txt")"
# Every manifest variant saw the dims too (a variant without them would have failed to load).
[ "$(ls "$work/ref64"/0*.png | wc -l)" -eq "$(ls data/reference/0*.png | wc -l)" ]
check $? "make reference DIMS=: $(ls "$work/ref64" | wc -l) files"
"$build/02_threshold" --volume "$work/sphere.raw" --dims 64,80,40 --no-window \
    --out "$work/sphere_out" > /dev/null 2>&1 &&
    "$checker" "$work/sphere_out/02_threshold_top.png" "$work/ref64/02_threshold_top.png" > /dev/null
check $? "a render of the raw volume does not pass against its own reference"
DIMS=64,80 sh tools/make_reference.sh "$build" "$work/sphere.raw" "$work/ref_bad" \
    > /dev/null 2> "$work/bad_dims.err"
[ $? -eq 2 ] && grep -q 'DIMS=64,80: expected three whole numbers' "$work/bad_dims.err" &&
    [ ! -e "$work/ref_bad" ]
check $? "make reference DIMS=64,80: $(cat "$work/bad_dims.err")"

# A folder of pictures is graded on each step's default run: a variant's picture handed in
# too is an extra row that says it is a variant of the reference folder (it is there), not
# "not in the reference folder"; a picture the folder lacks still says that.
variant=$(sed -n 's/^\([0-9][0-9]_[a-z0-9_]*\)_\([a-z0-9]*\): .*/\1 \2/p' data/reference/manifest.txt |
    while read -r step name; do
        for view in top camera; do
            [ -f "data/reference/${step}_${view}.png" ] &&
                [ -f "data/reference/${step}_${view}_$name.png" ] &&
                { echo "${step}_$view ${step}_${view}_$name"; break; }
        done
    done | head -n 1)
if [ -n "$variant" ]; then
    set -- $variant
    mkdir "$work/ref_variant" "$work/variant"
    cp "data/reference/$1.png" "data/reference/$2.png" data/reference/manifest.txt "$work/ref_variant/"
    cp "data/reference/$1.png" "data/reference/$2.png" "$work/variant/"
    cp "data/reference/$1.png" "$work/variant/$1_mine.png"
    "$checker" --submission "$work/variant" --reference "$work/ref_variant" \
        --report "$work/variant_report" > /dev/null 2>&1
    csv="$work/variant_report/report.csv"
    expect "$1.png" pass ""
    expect "$2.png" extra "a variant of the reference folder, not graded"
    expect "$1_mine.png" extra "not in the reference folder"
else
    check 1 "no manifest variant with a default picture beside it in data/reference"
fi

echo "grade test: $passed passed, $failed failed"
[ $failed -eq 0 ]
