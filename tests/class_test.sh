#!/bin/sh
# class_test.sh: a generated class (tools/make_class.sh: the solution, trees with one mistake
# of tests/check_mistakes.txt each, hostile trees, one tree handed in twice) graded in one
# command, build/grade --class, on steps 01 and 02 (--step: a small class for make test; the
# whole lab and 200 trees are make class-bench, timed in the README). Every student's result, the steps it fails, and
# summary.md's figures (students passing, per step, identical programs) must be what the
# mistakes give; the class cache reuses builds.
#
#   sh tests/class_test.sh BUILD      (from the repository root; make test runs it)
#   KEEP=1 sh tests/class_test.sh BUILD   keep the class and its report
set -u
build=${1:-build}
passed=0
failed=0
ok() { passed=$((passed + 1)); }
bad() { echo "class test: FAILED: $*"; failed=$((failed + 1)); }

if [ -f .ctlab-student ] || [ ! -f tests/check_mistakes.txt ]; then
    echo "class test: 0 passed, 0 failed (skipped: a student tree)"
    exit 0
fi
for tool in check grade; do
    [ -x "$build/$tool" ] || { echo "class test: $build/$tool is not built"; exit 1; }
done
work=$(mktemp -d) || exit 1
if [ -n "${KEEP:-}" ]; then echo "class test: kept in $work"; else
    trap 'rm -rf "$work"' EXIT INT TERM; fi

# Six trees: the solution, mistakes in steps 01 and 02, and every fourth tree hostile.
sh tools/make_class.sh "$work/class" 6 '0[12]' 4 > "$work/make_class.log" 2>&1 ||
    { bad "make_class: $(cat "$work/make_class.log")"; echo "class test: $passed passed, $failed failed"; exit 1; }
[ "$(wc -l < "$work/class.expected.txt")" -eq 6 ] && ok || bad "make_class made no 6 trees"
# A seventh tree, s004 handed in again (two students with one source): the same verdict, and
# summary.md names the pair.
cp -R "$work/class/s004" "$work/class/s007" &&
    sed -n 's/^s004 /s007 /p' "$work/class.expected.txt" >> "$work/class.expected.txt"

"$build/grade" --class "$work/class" --reference data/reference --report "$work/report" \
    --jobs 2 --timeout 5 --budget 120 --step 01 --step 02 > "$work/class.log" 2>&1
status=$?
if grep -q '^grade: no sandbox' "$work/class.log"; then
    echo "class test: no sandbox here: the class's programs are not run; skipped"
    echo "class test: $passed passed, $failed failed"
    [ "$failed" -eq 0 ]; exit
fi
[ "$status" -eq 1 ] && ok || bad "grade --class exited with $status, expected 1: $(cat "$work/class.log")"

# Each student as expected, summary.md's figures and its identical programs (s007 and s004),
# checked against make_class's record (tools/class_figures.py: a CSV with quoted notes).
if python3 tools/class_figures.py "$work/class.expected.txt" "$work/report" --steps 01,02 \
        > "$work/figures.log" 2>&1; then ok; else
    bad "the class's figures:"; sed 's/^/    /' "$work/figures.log"; sed 's/^/    /' "$work/class.log"
fi
# The copy took its steps' binaries from the class cache: some builds were not made again.
reused=$(sed -n 's/^- class cache: \([0-9]*\) of [0-9]* step builds.*/\1/p' "$work/report/summary.md")
[ "${reused:-0}" -gt 0 ] && ok ||
    bad "summary.md says no step build was reused: $(grep 'class cache' "$work/report/summary.md")"

echo "class test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
