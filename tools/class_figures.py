#!/usr/bin/env python3
"""class_figures.py: checks a graded class (build/grade --class) against what
tools/make_class.sh says each tree must get (CLASS.expected.txt: NAME RESULT STEP WHAT), never
against the grader's own view: every student's result and the steps it fails, summary.md's
figures (students passing, per step), and its 'Identical programs' groups (trees that got the
same mistake or hostile program hold the same source; no other trees do; a mistake that leaves
a stub in, whose output tests/check_mistakes.txt says shows "not started", is left out as the
grader leaves out steps not started: the kit's stubs are alike in every tree).

  python3 tools/class_figures.py CLASS.expected.txt REPORT [--steps 01,02]
  --steps   the steps graded (grade --step): those alone must have figures

Prints one line per problem and "N students, P problems"; exit status 1 on a problem.
"""
import csv
import re
import sys


def main(argv):
    if len(argv) not in (3, 5) or (len(argv) == 5 and argv[3] != "--steps"):
        print("usage: class_figures.py CLASS.expected.txt REPORT [--steps NN,NN]",
              file=sys.stderr)
        return 2
    expected_path, report = argv[1], argv[2]
    only = argv[4].split(",") if len(argv) == 5 else None
    expected = {}
    for line in open(expected_path):
        name, result, step, what = line.split(None, 3)
        expected[name] = (result, step, what.strip())
    csv_path = report + "/class.csv"
    rows = {row["student"]: row for row in csv.DictReader(open(csv_path))}
    steps = [c for c in next(csv.reader(open(csv_path))) if re.match(r"^[0-9]{2}_", c)]
    summary = open(report + "/summary.md").read()
    problems = []

    for name, (result, step, what) in sorted(expected.items()):
        row = rows.get(name)
        if row is None:
            problems.append(f"{name} ({what}): no row in class.csv")
            continue
        if row["result"] != result:
            problems.append(f"{name} ({what}): class.csv says {row['result']}, expected "
                            f"{result}: {row['note']}")
        # Each step's share of pictures and counters that pass; "" where it was not graded.
        failing = {c[:2] for c in steps if row[c] not in ("", "1.00")}
        want = set() if step == "-" else {step}
        if failing != want:
            problems.append(f"{name} ({what}): fails steps {sorted(failing)}, expected "
                            f"{sorted(want)}")
    if len(rows) != len(expected):
        problems.append(f"class.csv has {len(rows)} students, expected {len(expected)}")

    passing = sum(1 for r, s, w in expected.values() if r == "pass")
    line = f"- students: {len(expected)}, all steps pass: {passing}"
    if line not in summary:
        problems.append(f"summary.md has no '{line}'")
    graded = [c for c in steps if any(row[c] for row in rows.values())]
    if only is not None and sorted(c[:2] for c in graded) != sorted(only):
        problems.append(f"the steps graded are {graded}, not {only} alone (--step)")
    for column in graded:
        want = sum(1 for r, s, w in expected.values() if s != column[:2])
        line = f"| {column} | {want} | {len(expected)} |"
        if line not in summary:
            problems.append(f"summary.md has no '{line}'")

    # Identical programs: the trees made with the same mistake (or hostile program), two or
    # more, and nothing else (the solution is the lab's own source: left out).
    not_started = set()
    for line in open("tests/check_mistakes.txt"):
        fields = [field.strip() for field in line.split("|")]
        if not line.startswith("#") and len(fields) >= 6 and fields[5].startswith("not started"):
            not_started.add("mistake:" + fields[0])
    groups = {}
    for name, (result, step, what) in expected.items():
        if what != "the solution" and what not in not_started:
            groups.setdefault(what, set()).add(name)
    want_groups = {frozenset(names): what for what, names in groups.items() if len(names) > 1}
    found = {}
    section = summary.split("## Identical programs", 1)[-1]
    for match in re.finditer(r"^- ([0-9]{2}_[a-z0-9_]+): (.+) hand in byte-identical ", section,
                             re.M):
        found[frozenset(match.group(2).split(", "))] = match.group(1)
    for names, what in sorted(want_groups.items(), key=lambda item: sorted(item[0])):
        if names not in found:
            problems.append(f"summary.md names no identical programs for {what}: "
                            f"{', '.join(sorted(names))}")
        else:
            step = expected[next(iter(names))][1]
            if step != "-" and found[names][:2] != step:
                problems.append(f"identical programs of {what} in {found[names]}, expected "
                                f"step {step}")
    for names, step in found.items():
        if names not in want_groups:
            problems.append(f"summary.md names {', '.join(sorted(names))} as identical in "
                            f"{step}: make_class gave them no shared change")

    for problem in problems:
        print("FAILED: " + problem)
    print(f"{len(expected)} students, {len(want_groups)} groups of identical programs, "
          f"{len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
