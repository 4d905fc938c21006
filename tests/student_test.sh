#!/bin/sh
# student_test.sh: the student skeleton (make student). Generated into a temporary folder, it
# differs from the lab only inside the lesson regions; two of its steps build, run, print
# their TODO line once per function and fail the checker, while the lab's own steps pass;
# regenerating refuses to overwrite a student's edit.
#
#   sh tests/student_test.sh BUILD      (from the repository root; make test runs it)
set -u
build=${1:-build}
passed=0
failed=0
ok() { passed=$((passed + 1)); }
bad() { echo "student test: FAILED: $*"; failed=$((failed + 1)); }
expect() {  # expect DESCRIPTION COMMAND...: the command must succeed
    description=$1
    shift
    if "$@"; then ok; else bad "$description"; fi
}

if [ -f .ctlab-student ]; then
    echo "student test: 0 passed, 0 failed (skipped: this is a generated student tree)"
    exit 0
fi
for tool in make_student check handout_listings; do
    [ -x "$build/$tool" ] || { echo "student test: $build/$tool is not built"; exit 1; }
done
work=$(mktemp -d) || exit 1
trap 'rm -rf "$work"' EXIT INT TERM
student=$work/student
here=$(pwd)

# Lines outside the lesson regions (marker lines kept): all a skeleton may not change.
outside_regions() {
    awk '/^[ \t]*\/\/< lesson:/ { inside = 0 }
         !inside { print }
         /^[ \t]*\/\/> lesson:/ { inside = 1 }' "$1"
}

# --- Generation -----------------------------------------------------------------------------
expect "make_student writes $student" "$build/make_student" --to "$student" > "$work/generate.log"

for source in steps/[0-9][0-9]_*.cpp; do
    step=$(basename "$source" .cpp)
    generated=$student/$source
    outside_regions "$source" > "$work/lab.txt"
    outside_regions "$generated" > "$work/student.txt" 2>/dev/null
    expect "$generated differs from $source outside the lesson regions" \
        cmp -s "$work/lab.txt" "$work/student.txt"
    expect "$generated has no stub: not_done(\"$step\", ...)" \
        grep -q "not_done(\"$step\"," "$generated"
done
# Everything else is copied unchanged (the handouts quote the stubs instead of the solution).
copies=0
for file in $(sed -n 's/^[0-9a-f]*  //p' "$student/.ctlab-student"); do
    case "$file" in steps/* | handouts/*) continue ;; esac
    cmp -s "$file" "$student/$file" || bad "$student/$file is not a copy of $file"
    copies=$((copies + 1))
done
[ "$copies" -gt 0 ] && ok || bad "no copied files listed in $student/.ctlab-student"
if [ -f handouts/README.md ]; then
    expect "the student handouts' listings match the student steps" \
        sh -c "cd '$student' && '$here/$build/handout_listings' --check > /dev/null"
fi

# --- Two steps: build, run, check --------------------------------------------------------------
# The second step (02, the first surface) and the last one: the skeleton must work for
# every step, including ones added later.
first=$(ls steps/02_*.cpp 2>/dev/null || ls steps/[0-9][0-9]_*.cpp | head -n 1)
last=$(ls steps/[0-9][0-9]_*.cpp | tail -n 1)
chosen=$(basename "$first" .cpp)
[ "$last" != "$first" ] && chosen="$chosen $(basename "$last" .cpp)"

# common/ is copied unchanged: reuse the lab's compiled library instead of compiling it again.
same_common=yes
for file in common/*; do cmp -s "$file" "$student/$file" || same_common=no; done
if [ "$same_common" = yes ] && [ -f "$build/libctlab.a" ]; then
    mkdir -p "$student/$build"
    cp -R "$build/common" "$student/$build/" && cp "$build/libctlab.a" "$student/$build/"
    find "$student/$build/common" -type f -exec touch {} +  # newer than the fresh copies
    touch "$student/$build/libctlab.a"
fi
san=
[ "$build" = build-san ] && san=SAN=1
# shellcheck disable=SC2086
expect "the student tree builds: make -C $student $chosen" \
    env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make -s -C "$student" -j2 BUILD="$build" $san $chosen \
    > "$work/build.log" 2>&1
[ "$failed" -eq 0 ] || cat "$work/build.log"

for step in $chosen; do
    reference=data/reference/${step}_front.png
    "$student/$build/$step" --volume phantom --view front --no-window --out "$work/student_out" \
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
    "$build/check" "$work/student_out/${step}_front.png" "$reference" > /dev/null
    expect "the stubbed $step fails the checker (exit 1)" [ $? -eq 1 ]
    "$build/$step" --volume phantom --view front --no-window --out "$work/lab_out" > /dev/null
    expect "the lab's $step renders" [ $? -eq 0 ]
    "$build/check" "$work/lab_out/${step}_front.png" "$reference" > /dev/null
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
