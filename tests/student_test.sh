#!/bin/sh
# student_test.sh: the student skeleton (make student). Generated into a temporary folder, it
# differs from the lab only inside the lesson regions; no file in it holds a lesson body of the
# solution (tools/find_answers), and make_student refuses to write a kit that would; it has its
# start-here README, builds every target on its own, and still builds after a lesson function's
# signature changes; `make check` in it shows every step not started, then only step 02
# passing once it is written; `make carry` takes a function the student wrote into the later
# steps that use it unchanged, never over the student's work; `make diff` shows the steps as
# handed out; two of its steps build, run, print their TODO line once per function and fail
# the checker, while the lab's own steps pass; regenerating refuses to overwrite a student's
# edit.
#
#   sh tests/student_test.sh BUILD      (from the repository root; make test runs it)
set -u
build=${1:-build}
passed=0
failed=0
ok() { passed=$((passed + 1)); }
bad() { echo "student test: FAILED: $*" >&2; failed=$((failed + 1)); }  # stderr: never lost in a redirect
expect() {  # expect DESCRIPTION COMMAND...: the command must succeed
    description=$1
    shift
    if "$@"; then ok; else bad "$description"; fi
}

if [ -f .ctlab-student ]; then
    echo "student test: 0 passed, 0 failed (skipped: this is a generated student tree)"
    exit 0
fi
for tool in make_student check handout_listings find_answers carry make_phantom; do
    [ -x "$build/$tool" ] || { echo "student test: $build/$tool is not built"; exit 1; }
done
work=$(mktemp -d) || exit 1
trap 'rm -rf "$work"' EXIT INT TERM
student=$work/student
here=$(pwd)

# Lines outside the lesson regions (marker lines kept): all a skeleton may not change, but for
# the [[maybe_unused]] make_student puts before a static helper whose callers are stubs now.
outside_regions() {
    awk '/^[ \t]*\/\/< lesson:/ { inside = 0 }
         !inside { sub(/^\[\[maybe_unused\]\] /, ""); print }
         /^[ \t]*\/\/> lesson:/ { inside = 1 }' "$1"
}

# The lines between `//> lesson: NAME` and `//< lesson: NAME` of FILE.
region() {
    awk -v name="$1" '$0 ~ "^[ \t]*//< lesson: *" name "[ \t]*$" { inside = 0 }
                      inside { print }
                      $0 ~ "^[ \t]*//> lesson: *" name "[ \t]*$" { inside = 1 }' "$2"
}
# replace_region NAME FILE CONTENT_FILE: the region's lines become CONTENT_FILE's.
replace_region() {
    awk -v name="$1" -v content="$3" '
        $0 ~ "^[ \t]*//< lesson: *" name "[ \t]*$" { inside = 0 }
        !inside { print }
        $0 ~ "^[ \t]*//> lesson: *" name "[ \t]*$" {
            inside = 1
            while ((getline line < content) > 0) print line
            close(content)
        }' "$2" > "$2.new" && mv "$2.new" "$2"
}

# --- Generation -----------------------------------------------------------------------------
expect "make_student writes $student" "$build/make_student" --to "$student" > "$work/generate.log"

# The tree as generated holds no lesson body of the solution: searched before it is built
# (every file under it is read, and its build/ would add the objects), with the search itself
# tested below.
"$build/find_answers" --solution . --in "$student" > "$work/answers.txt" 2>&1
expect "the student tree holds no lesson body of the solution (find_answers exit 0)" \
    [ $? -eq 0 ]
grep "^$student" "$work/answers.txt" | sed "s|^$student/|  student/|" | head -n 40

# The kit's README has the student run `make carry` before anything is built: in a kit with no
# build/ yet, make knows how to make all it needs (it once found no rule for build/flags.txt).
env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make -n -C "$student" carry STEP=03 \
    > "$work/carry_first.log" 2>&1
expect "make carry is the first command of a fresh kit (make -n: every prerequisite has a rule)" \
    [ $? -eq 0 ]
grep 'No rule' "$work/carry_first.log"

# --- The student tree builds every target on its own -------------------------------------
# common/, tools/ and tests/ are copied unchanged: reuse the lab's compiled objects for them
# (not for a file that includes a step: the student's steps are stubs), with the lab's
# compiler flags (BUILD/flags.txt: other flags would build everything again), so that only
# the steps are compiled: the kit is built once here, and after that only what a change
# touches.
reuse_objects() {
    for file in common/* tools/*.cpp tools/*.h; do
        cmp -s "$file" "$student/$file" && continue
        echo "student test: note: $file differs in the kit: it is built from scratch (slow)"
        return 0
    done
    if [ ! -f "$build/libctlab.a" ] || [ ! -f "$build/flags.txt" ]; then
        echo "student test: note: no $build/libctlab.a or flags.txt: the kit is built from scratch"
        return 0
    fi
    mkdir -p "$student/$build"
    cp -R "$build/common" "$student/$build/" && cp "$build/libctlab.a" "$student/$build/"
    # Without its debug information (20 MB of 21) each of the kit's ~35 links costs 0.10 s of
    # CPU, not 0.17 (the kit's steps are built without any); a sanitizer build keeps it.
    [ "$build" = build-san ] || strip -g "$student/$build/libctlab.a" 2>/dev/null || true
    cp "$build/flags.txt" "$student/$build/"
    for library in libctlab_tools.a ctlab_formats.so ctlab_dicom.so ctlab_window.so; do
        [ -f "$build/$library" ] && cp "$build/$library" "$student/$build/"
    done
    for folder in tools tests; do
        [ -d "$build/$folder" ] || continue
        for object in $(find "$build/$folder" -name '*.o'); do
            depends=${object%.o}.d
            [ -f "$depends" ] && ! grep -q 'steps/' "$depends" || continue
            mkdir -p "$student/$(dirname "$object")"
            cp "$object" "$depends" "$student/$(dirname "$object")/"
        done
    done
    # The programs linked from those objects alone (the tools and the test binary, which
    # include no step): the same objects linked again would prove nothing new (~8 s of CPU).
    for source in tools/*.cpp tools/*.c; do
        name=$(basename "${source%.*}")
        [ -x "$build/$name" ] && cp "$build/$name" "$student/$build/"
    done
    [ -x "$build/ctlab_tests" ] && cp "$build/ctlab_tests" "$student/$build/"
    # One time for all of them (no object older than the flags it was built with), a second
    # after the kit's sources were written: newer than they are, and not in the future.
    sleep 1
    now=$(date +%s)
    find "$student/$build" -type f -exec touch -d "@$now" {} +
}
reuse_objects
san=
[ "$build" = build-san ] && san=SAN=1
# The lab's own flags, as make test was given them (CI's WERROR=1): the kit's are the same.
grep -q -- ' -Werror' "$build/flags.txt" 2>/dev/null && san="$san WERROR=1"
# The kit's steps are stubs that render nothing (and step 02 once written): they compile with
# STEP_OPT (the Makefile's flags for the steps alone, outside the flags stamp) at -O0 without
# debug information, about 0.9 s of compiler CPU less per step than -O2 -g; a sanitizer build
# keeps its own flags.
step_opt="-O0 -g0"
[ "$build" = build-san ] && step_opt=
# And they link with gold (or lld) where the compiler can (STEP_LDFLAGS, outside the flags
# stamp as well): 0.05 s of CPU a link instead of ld.bfd's 0.14, for ~45 links.
step_ld=
if [ "$build" != build-san ]; then
    for linker in gold lld; do
        printf 'int main() { return 0; }\n' |
            ${CXX:-g++} -fuse-ld=$linker -x c++ - -o "$work/linker_probe" 2> /dev/null ||
            continue
        step_ld=-fuse-ld=$linker
        break
    done
fi
student_make() {  # student_make TARGET...: make in the student tree, quietly, log in build.log
    # shellcheck disable=SC2086
    env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make -s -C "$student" -j2 BUILD="$build" \
        STEP_OPT="$step_opt" STEP_LDFLAGS="$step_ld" $san "$@" > "$work/build.log" 2>&1
}
# The kit builds (make -j2) while the checks of its sources below run beside it: they read
# the generated files and write only into $work.
student_make all "$build/ctlab_tests" &
kit_build=$!


for source in steps/[0-9][0-9]_*.cpp; do
    step=$(basename "$source" .cpp)
    generated=$student/$source
    outside_regions "$source" > "$work/lab.txt"
    outside_regions "$generated" > "$work/student.txt" 2>/dev/null
    expect "$generated differs from $source outside the lesson regions" \
        cmp -s "$work/lab.txt" "$work/student.txt"
    expect "$generated has no stub: not_done(step_name, ...)" \
        grep -q "not_done(step_name, \"" "$generated"
    expect "$student/.ctlab/pristine/$source is the step as generated" \
        cmp -s "$generated" "$student/.ctlab/pristine/$source"
done
# Everything else is copied unchanged (the handouts quote the stubs instead of the solution).
copies=0
for file in $(sed -n 's/^[0-9a-f]*  //p' "$student/.ctlab-student"); do
    case "$file" in steps/* | handouts/* | README.md | LAB.md | .ctlab/*) continue ;; esac
    cmp -s "$file" "$student/$file" || bad "$student/$file is not a copy of $file"
    copies=$((copies + 1))
done
[ "$copies" -gt 0 ] && ok || bad "no copied files listed in $student/.ctlab-student"
if [ -f handouts/README.md ]; then
    expect "the student handouts' listings match the student steps" \
        sh -c "cd '$student' && '$here/$build/handout_listings' --check > /dev/null"
fi

# --- The start-here README, the lab's README, the carry record ------------------------------
expect "$student/README.md says how to check: make check STEP=NN" \
    grep -q "make check STEP=NN" "$student/README.md"
for topic in "make carry" "make diff STEP=NN" "--debug-pixel" "not started" "What you write"; do
    expect "$student/README.md explains '$topic'" grep -q -- "$topic" "$student/README.md"
done
for source in steps/[0-9][0-9]_*.cpp; do
    step=$(basename "$source" .cpp)
    expect "$student/README.md lists $step" grep -q "(handouts/$step.md)" "$student/README.md"
    # What the step teaches: its header's whole title, also when it goes on to a second comment
    # line (a title cut after its first line ended the row in the middle of a sentence).
    title=$(awk 'NR == 1 { sub(/^\/\/ [0-9][0-9]_[a-z0-9_]*\.cpp: /, ""); t = $0; next }
                 /^\/\/ *$/ || !/^\/\/ / { exit }
                 { sub(/^\/\/ +/, ""); t = t " " $0 } END { print t }' "$source")
    expect "$student/README.md gives $step's whole title" \
        grep -qF "(handouts/$step.md) | $title |" "$student/README.md"
done
expect "the lab's README.md is $student/LAB.md" cmp -s README.md "$student/LAB.md"
# Every `make run STEP=NN ARGS="..."` of the start-here README runs as printed (its step's own
# flags: `--view front` is refused from step 13 on), here headless on the phantom.
sed -n 's/.*make run STEP=\([0-9][0-9]\) ARGS="\([^"]*\)".*/\1 \2/p' "$student/README.md" |
    while read -r number arguments; do
        program=$(ls "$build/${number}_"* 2>/dev/null | head -n 1)
        # shellcheck disable=SC2086
        [ -n "$program" ] && "$program" --volume phantom --no-window --out "$work/run_out" \
            $arguments > "$work/run.log" 2>&1 ||
            echo "make run STEP=$number ARGS=\"$arguments\" fails: $(tail -n 1 "$work/run.log")"
    done > "$work/runs_printed.txt"
expect "every make run of $student/README.md runs as printed: $(cat "$work/runs_printed.txt")" \
    [ ! -s "$work/runs_printed.txt" ]
expect "$student/.ctlab/carry.txt carries first_hit from 02 into 03" \
    grep -q "^03_[a-z_]* first_hit 02_[a-z_]* [0-9a-f]*\$" "$student/.ctlab/carry.txt"
# A step carries from the step it builds on: step 12's corrected_opacity() from step 10 (not
# from 11, numbered before it).
if [ -f steps/12_physical_rays.cpp ]; then
    expect "$student/.ctlab/carry.txt carries corrected_opacity from 10 into 12" \
        grep -q "^12_[a-z_]* corrected_opacity 10_[a-z_]* [0-9a-f]*\$" "$student/.ctlab/carry.txt"
fi
# Part 2 branches: step 19 builds on 15, and takes step 15's compositing, not 17's jittered one.
if [ -f steps/19_isosurface.cpp ]; then
    expect "$student/.ctlab/carry.txt carries composite_front_to_back from 15 into 19" \
        grep -q "^19_[a-z_]* composite_front_to_back 15_[a-z_]* [0-9a-f]*\$" \
        "$student/.ctlab/carry.txt"
fi

# --- No answers in the student tree -------------------------------------------------------
# Every file (steps, tools, tests, handouts, data, README) is searched for every lesson body of
# the solution, whole or by its distinctive lines. The search itself is tested first: it must
# find the solution's own steps, and a body pasted re-indented into a handout.
"$build/find_answers" --solution . --in steps > "$work/self.txt" 2>&1
expect "find_answers finds the answers in the solution's own steps (exit 1)" [ $? -eq 1 ]
for source in steps/[0-9][0-9]_*.cpp; do
    expect "find_answers finds the lesson bodies of $source" grep -q "^$source:" "$work/self.txt"
done
mkdir -p "$work/planted/handouts"
planted=$(ls steps/05_*.cpp 2>/dev/null || ls steps/[0-9][0-9]_*.cpp | tail -n 1)
marker=$(sed -n 's|^[ \t]*//> lesson: *||p' "$planted" | head -n 1)
{
    echo "A paragraph, then a listing that quotes the solution re-indented:"
    echo '```cpp'
    region "$marker" "$planted" | sed 's/^ *//'
    echo '```'
} > "$work/planted/handouts/leak.md"
# One line of it alone in a sentence: the longest statement of the region.
line=$(region "$marker" "$planted" | grep -v '^ *//' | grep ';$' | sed 's/^ *//' |
       awk '{ print length, $0 }' |
       sort -rn | head -n 1 | cut -d' ' -f2-)
printf 'As the solution writes it, %s and so on.\n' "$line" > "$work/planted/handouts/line.md"
"$build/find_answers" --solution . --in "$work/planted" > "$work/planted.txt" 2>&1
expect "find_answers finds a lesson body pasted into a handout (exit 1)" [ $? -eq 1 ]
expect "find_answers names the handout holding the whole body" \
    grep -q "planted/handouts/leak.md:[0-9]*: .*the whole body" "$work/planted.txt"
expect "find_answers finds one solution line quoted in a sentence" \
    grep -q "planted/handouts/line.md:1: " "$work/planted.txt"

# make_student refuses to hand out answers: a lab whose handout quotes one solution line gets
# no kit (exit 1, the file named, nothing written), and an earlier kit stays as it was.
leaky=$work/leaky
mkdir -p "$leaky/tools" "$leaky/handouts" &&
    cp -R Makefile steps common "$leaky/" && cp tools/student_README.md "$leaky/tools/" &&
    cp "$work/planted/handouts/line.md" "$leaky/handouts/" || bad "cannot make $leaky"
"$build/make_student" --from "$leaky" --to "$work/leaky_kit" > /dev/null 2> "$work/leaky.txt"
expect "make_student refuses a kit holding a solution line (exit 1)" [ $? -eq 1 ]
expect "make_student names the handout that holds it" \
    grep -q "^  handouts/line.md:1: [0-9][0-9]_[a-z_0-9]* [a-z_0-9]*()\$" "$work/leaky.txt"
expect "make_student writes nothing when it refuses" [ ! -e "$work/leaky_kit" ]
record_before=$(cat "$student/.ctlab-student")
"$build/make_student" --from "$leaky" --to "$student" --force > /dev/null 2>&1
expect "make_student --force over an earlier kit refuses too (exit 1)" [ $? -eq 1 ]
expect "the earlier kit is left as it was" \
    [ "$record_before" = "$(cat "$student/.ctlab-student")" ]

wait "$kit_build"
if [ $? -eq 0 ]; then ok; else
    bad "the student tree builds every target: make -C $student all $build/ctlab_tests"
    tail -n 30 "$work/build.log"
fi

# progress_is PASSING_STEP WHAT: `make check` in the kit prints the progress table with
# PASSING_STEP (a stem, or none) passing and every other step not started. The first pass is
# `make check` itself. A later pass does what it does, for the steps whose binaries changed
# since: `make check-steps` (build what changed), then the kit's check on those steps, as
# make check runs it. A step's row depends on its binary, the references and the volume, and
# only binaries changed: the other rows are the first pass's (~20 s of CPU not spent again).
progress_is() {
    if [ ! -f "$work/progress_first.log" ]; then
        student_make check
        cp "$work/build.log" "$work/progress.log"
        cp "$work/build.log" "$work/progress_first.log"
        (cd "$student/$build" && cksum [0-9][0-9]_*) > "$work/binaries_first.txt"
    else
        student_make check-steps || bad "$2: make check-steps in the kit failed"
        changed=
        for source in steps/[0-9][0-9]_*.cpp; do
            step=$(basename "$source" .cpp)
            [ "$(cd "$student/$build" && cksum "$step")" = \
              "$(grep " $step\$" "$work/binaries_first.txt")" ] || changed="$changed $step"
        done
        # The step the student wrote, at least, is graded again.
        expect "$2: the kit's steps that changed are graded again:$changed" [ -n "$changed" ]
        # shellcheck disable=SC2086  # one --step per changed step
        (cd "$student" && "$build/check" --bin "$build" \
             $(for step in $changed; do printf ' --step %s' "$step"; done)) \
            > "$work/regraded.log" 2>&1
        : > "$work/progress.log"
        for source in steps/[0-9][0-9]_*.cpp; do
            step=$(basename "$source" .cpp)
            case " $changed " in
                *" $step "*) grep "^$step " "$work/regraded.log" >> "$work/progress.log" ;;
                *) grep "^$step " "$work/progress_first.log" >> "$work/progress.log" ;;
            esac
        done
    fi
    for source in steps/[0-9][0-9]_*.cpp; do
        step=$(basename "$source" .cpp)
        status="not started"
        [ "$step" = "$1" ] && status=passing
        expect "$2: make check in the kit says $step is $status" \
            grep -q "^$step  *$status " "$work/progress.log"
    done
}
# The kit's make check grades on the phantom written once to a raw file (the record
# `make reference VOLUME=...` writes, REFERENCE/volume.txt, names it): the same voxels, without
# painting the head again in each of the ~80 runs of a pass (0.1 s of CPU each). The built-in
# phantom itself is what the student's step 02 is graded on below.
"$build/make_phantom" "$work/phantom.raw" > /dev/null &&
    printf 'volume: %s\n' "$work/phantom.raw" > "$student/data/reference/volume.txt" ||
    bad "cannot write the phantom to $work/phantom.raw"
progress_is none "a fresh kit"
# A step's stubs of functions it takes unchanged from an earlier step come after its own, with
# the command that brings them (a part-3 step takes 20 or more: in a fresh kit its first TODO
# lines were all of them, with no word of make carry).
expect "a fresh kit's make check says which stubs make carry brings: $(grep -c 'TODO' "$work/progress_first.log") TODO lines" \
    grep -q "are your earlier steps' functions: \`make carry STEP=[0-9][0-9]\` copies them in" \
    "$work/progress_first.log"

# --- make carry: a function written once serves the later steps -------------------------
# Inside the test only: step 02's first_hit filled in from the solution.
step02=$(ls steps/02_*.cpp 2>/dev/null)
if [ -n "$step02" ] && grep -q '^0[3-9]_[a-z_]* first_hit 02_' "$student/.ctlab/carry.txt"; then
    region first_hit "$step02" > "$work/first_hit_02.txt"
    replace_region first_hit "$student/$step02" "$work/first_hit_02.txt"
    # The rest of step 02 filled in too (its shade()): the student has finished step 02.
    for lesson in $(sed -n 's|^[ \t]*//> lesson: *\([a-z_0-9]*\).*|\1|p' "$step02"); do
        [ "$lesson" = first_hit ] && continue
        region "$lesson" "$step02" > "$work/lesson_02.txt"
        replace_region "$lesson" "$student/$step02" "$work/lesson_02.txt"
    done
    expect "make carry runs in the student tree" student_make carry
    carried=$(sed -n 's/^\(0[3-9]_[a-z_]*\) first_hit .*/\1/p' "$student/.ctlab/carry.txt" |
              tr '\n' ' ')
    for step in $carried; do
        region first_hit "$student/steps/$step.cpp" > "$work/first_hit_carried.txt"
        expect "make carry: $step's first_hit is the student's from 02" \
            cmp -s "$work/first_hit_02.txt" "$work/first_hit_carried.txt"
    done
    for source in "$student"/steps/0[3-9]_*.cpp; do
        step=$(basename "$source" .cpp)
        case " $carried " in *" $step "*) continue ;; esac
        grep -q '//> lesson: first_hit' "$source" || continue
        expect "make carry leaves $step's first_hit, which differs in the solution, a stub" \
            sh -c "sed -n '/lesson: first_hit/,/lesson: first_hit/p' '$source' | grep -q not_done"
    done
    # The student's 02 builds and passes; 03 now lacks only its own shade().
    first_carried=$(echo $carried | cut -d' ' -f1)
    if student_make "$(basename "$step02" .cpp)" "$first_carried"; then
        ok
        "$student/$build/$(basename "$step02" .cpp)" --volume phantom --view front --no-window \
            --out "$work/carry_out" > /dev/null 2>&1
        expect "the student's step 02 passes the checker" "$build/grade" \
            "$work/carry_out/$(basename "$step02" .cpp)_front.png" \
            "data/reference/$(basename "$step02" .cpp)_front.png" > /dev/null
        "$student/$build/$first_carried" --volume "$work/phantom.raw" --view front --no-window \
            --out "$work/carry_out" > /dev/null 2> "$work/todo_carried.txt"
        expect "$first_carried no longer says first_hit() is not written" \
            sh -c "! grep -q 'first_hit() is not written' '$work/todo_carried.txt'"
    else
        bad "the student tree builds 02 and $first_carried after make carry"
        tail -n 30 "$work/build.log"
    fi
    # Never over the student's work: a changed 03 stays, and 04 takes 03's version.
    third=$(echo $carried | cut -d' ' -f1)
    fourth=$(echo $carried | cut -d' ' -f2 -s)
    { echo "// first_hit as I rewrote it in $third"; cat "$work/first_hit_02.txt"; } \
        > "$work/first_hit_mine.txt"
    replace_region first_hit "$student/steps/$third.cpp" "$work/first_hit_mine.txt"
    { echo "// changed again in 02"; cat "$work/first_hit_02.txt"; } > "$work/first_hit_again.txt"
    replace_region first_hit "$student/$step02" "$work/first_hit_again.txt"
    if [ -n "$fourth" ]; then
        region first_hit "$student/.ctlab/pristine/steps/$fourth.cpp" > "$work/stub.txt"
        replace_region first_hit "$student/steps/$fourth.cpp" "$work/stub.txt"
    fi
    "$student/$build/carry" --tree "$student" > "$work/carry.txt" 2>&1
    expect "carry runs again (exit 0)" [ $? -eq 0 ]
    region first_hit "$student/steps/$third.cpp" > "$work/after.txt"
    expect "carry keeps the first_hit the student rewrote in $third" \
        cmp -s "$work/first_hit_mine.txt" "$work/after.txt"
    expect "carry says it kept $third's first_hit" grep -q "^$third: first_hit(): kept" \
        "$work/carry.txt"
    if [ -n "$fourth" ]; then
        region first_hit "$student/steps/$fourth.cpp" > "$work/after.txt"
        expect "carry brings $third's version into $fourth's stub" \
            cmp -s "$work/first_hit_mine.txt" "$work/after.txt"
    fi
    "$student/$build/carry" --tree "$student" --step "${third%%_*}" > "$work/carry.txt" 2>&1
    expect "carry --step ${third%%_*} looks at that step only" \
        sh -c "! grep -v '^${third}: \\|^carry: ' '$work/carry.txt'"

    # --- make diff in the kit: the steps as handed out, not the student's code -------------
    env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make -s -C "$student" diff STEP="${third%%_*}" \
        > "$work/diff.txt" 2>&1
    expect "make diff STEP=${third%%_*} runs in the student tree" [ -s "$work/diff.txt" ]
    expect "make diff in the kit does not show the student's own code" \
        sh -c "! grep -q 'as I rewrote it\\|changed again' '$work/diff.txt'"
    expect "make diff in the kit shows what ${third%%_*} changes (its shade)" \
        grep -q '^[-+].*shade(' "$work/diff.txt"
else
    bad "no step 02 with a first_hit carried to later steps: the carry test did not run"
fi

# The student has written step 02 (and make carry brought its first_hit into 03 and 04):
# only 02 passes; 03 and 04 still have stubs of their own, and are not started.
[ -n "$step02" ] && progress_is "$(basename "$step02" .cpp)" "step 02 written"

# --- A lesson function's signature changes: every target still builds ---------------------
# Step 01's mip_top (nothing outside step 01 names it), then step 02's first_hit (tests,
# bench and study must not compile a step's lesson functions: they run the step binaries).
change_signature() {  # FILE FUNCTION: adds a first parameter `int unused_first` to FUNCTION
    # [[maybe_unused]]: the kit may be built with -Werror (CI's WERROR=1), and the point is
    # the new signature, not a warning about the parameter.
    sed -i "s/\\(static [A-Za-z]* $2(\\)/\\1[[maybe_unused]] int unused_first, /; s/\\([^a-z_]$2(\\)\\(volume\\)/\\1 0, \\2/" "$1"
    sed -i "s/static \\([A-Za-z]*\\) $2( 0, /static \\1 $2(/" "$1"
    grep -qF "$2([[maybe_unused]] int unused_first, " "$1" && grep -q "$2( 0, volume" "$1"
}
for change in "01 mip_top" "02 first_hit"; do
    set -- $change
    source=$(ls "$student"/steps/$1_*.cpp 2>/dev/null)
    [ -n "$source" ] || continue
    if ! change_signature "$source" "$2"; then
        bad "could not change $2's signature in $source (the test's sed)"
        continue
    fi
    if student_make all "$build/ctlab_tests"; then ok; else
        bad "after $2() in $source takes a new parameter, the student tree builds every target"
        grep -m 5 'error' "$work/build.log"
    fi
done
cp "$student/.ctlab/pristine/steps/"01_*.cpp "$student/.ctlab/pristine/steps/"02_*.cpp \
    "$student/steps/"

# --- Two steps: build, run, check --------------------------------------------------------------
# The second step (02, the first surface) and the last one: the skeleton must work for
# every step, including ones added later. On the phantom's raw file (the same voxels).
first=$(ls steps/02_*.cpp 2>/dev/null || ls steps/[0-9][0-9]_*.cpp | head -n 1)
last=$(ls steps/[0-9][0-9]_*.cpp | tail -n 1)
chosen=$(basename "$first" .cpp)
[ "$last" != "$first" ] && chosen="$chosen $(basename "$last" .cpp)"

if student_make $chosen; then ok; else
    bad "the student tree builds: make -C $student $chosen"
    cat "$work/build.log"
fi

for step in $chosen; do
    # A part 1 step: its front view. A camera step (part 2) renders one picture, "camera".
    view=front
    view_flags="--view front"
    if [ ! -f "data/reference/${step}_front.png" ] && [ -f "data/reference/${step}_camera.png" ]
    then
        view=camera
        view_flags=
    fi
    reference=data/reference/${step}_$view.png
    # shellcheck disable=SC2086
    "$student/$build/$step" --volume "$work/phantom.raw" $view_flags --no-window \
        --out "$work/student_out" \
        > /dev/null 2> "$work/todo.txt"
    expect "the stubbed $step runs (exit 0)" [ $? -eq 0 ]
    expect "the stubbed $step prints 'TODO: $step: ...() is not written yet'" \
        grep -q "^TODO: $step: [a-z_0-9]*() is not written yet — see handouts/$step.md\$" \
        "$work/todo.txt"
    expect "the stubbed $step prints each TODO line once" \
        [ -z "$(sort "$work/todo.txt" | uniq -d)" ]
    if [ ! -f "$reference" ]; then
        bad "no $reference: run make reference"
        continue
    fi
    "$build/grade" "$work/student_out/${step}_$view.png" "$reference" > /dev/null
    expect "the stubbed $step fails the checker (exit 1)" [ $? -eq 1 ]
    # shellcheck disable=SC2086
    "$build/$step" --volume "$work/phantom.raw" $view_flags --no-window --out "$work/lab_out" \
        > /dev/null
    expect "the lab's $step renders" [ $? -eq 0 ]
    "$build/grade" "$work/lab_out/${step}_$view.png" "$reference" > /dev/null
    expect "the lab's $step passes the checker (exit 0)" [ $? -eq 0 ]
done

# --- A student's edit survives regeneration ------------------------------------------------
edited=$student/$(ls steps/[0-9][0-9]_*.cpp | head -n 1)
echo "// my work" >> "$edited"
"$build/make_student" --to "$student" > /dev/null 2> "$work/refuse.txt"
expect "make_student refuses to overwrite an edited step (exit 2)" [ $? -eq 2 ]
expect "make_student names the edited file" grep -q "$edited" "$work/refuse.txt"
expect "the edit is still there" grep -q "// my work" "$edited"
expect "make_student --force regenerates" \
    "$build/make_student" --to "$student" --force > /dev/null
expect "--force replaced the edited step" sh -c "! grep -q '// my work' '$edited'"

echo "student test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
