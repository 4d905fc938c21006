#!/bin/sh
# class_test.sh: a generated class (tools/make_class.sh: the solution, trees with one mistake
# of tests/check_mistakes.txt each, hostile trees) graded in one command, build/grade --class,
# on steps 01 and 02 (--step: a small class for make test; the whole lab and 200 trees are the
# README's timing). Every student's result, the steps it fails, and summary.md's figures
# (students passing, and per step) must be what the mistakes give.
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

"$build/grade" --class "$work/class" --reference data/reference --report "$work/report" \
    --jobs 2 --timeout 5 --budget 120 --step 01 --step 02 > "$work/class.log" 2>&1
status=$?
if grep -q '^grade: no sandbox' "$work/class.log"; then
    echo "class test: no sandbox here: the class's programs are not run; skipped"
    echo "class test: $passed passed, $failed failed"
    [ "$failed" -eq 0 ]; exit
fi
[ "$status" -eq 1 ] && ok || bad "grade --class exited with $status, expected 1: $(cat "$work/class.log")"

# Each student as expected, and summary.md's figures (python3: a CSV with quoted notes).
python3 - "$work/class.expected.txt" "$work/report/class.csv" "$work/report/summary.md" \
    > "$work/figures.log" 2>&1 <<'EOF'
import csv, re, sys
expected = {}
for line in open(sys.argv[1]):
    name, result, step, what = line.split(None, 3)
    what = what.strip()
    expected[name] = (result, step, what)
rows = {row["student"]: row for row in csv.DictReader(open(sys.argv[2]))}
steps = [c for c in next(csv.reader(open(sys.argv[2]))) if re.match(r"^[0-9]{2}_", c)]
problems = 0
def problem(text):
    global problems
    problems += 1
    print("FAILED: " + text)
for name, (result, step, what) in sorted(expected.items()):
    row = rows.get(name)
    if row is None:
        problem(f"{name} ({what}): no row in class.csv")
        continue
    if row["result"] != result:
        problem(f"{name} ({what}): class.csv says {row['result']}, expected {result}: {row['note']}")
    failing = set()
    for column in steps:  # the share of its pictures and counters that pass; "" not graded
        if row[column] not in ("", "1.00"):
            failing.add(column[:2])
    want = set() if step == "-" else {step}
    if failing != want:
        problem(f"{name} ({what}): fails steps {sorted(failing)}, expected {sorted(want)}")
summary = open(sys.argv[3]).read()
passing = sum(1 for r, s, w in expected.values() if r == "pass")
line = f"- students: {len(expected)}, all steps pass: {passing}"
if line not in summary:
    problem(f"summary.md has no '{line}'")
graded = [c for c in steps if any(row[c] for row in rows.values())]
if sorted(c[:2] for c in graded) != ["01", "02"]:
    problem(f"the steps graded are {graded}, not 01 and 02 alone (--step)")
for column in graded:
    want = sum(1 for r, s, w in expected.values() if s != column[:2])
    line = f"| {column} | {want} | {len(expected)} |"
    if line not in summary:
        problem(f"summary.md has no '{line}'")
print(f"{len(expected)} students, {problems} problems")
sys.exit(1 if problems else 0)
EOF
if [ $? -eq 0 ]; then ok; else
    bad "the class's figures:"; sed 's/^/    /' "$work/figures.log"; sed 's/^/    /' "$work/class.log"
fi

echo "class test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
