#!/bin/sh
# check_test.sh: build/check grades programs. The lab's own steps pass with every manifest
# variant and counter; each mistake of tests/check_mistakes.txt, patched into a copy of its
# step and built with the lab's Makefile, fails with the hint the table names; a step that is
# not built, a stub, a crash and a stale picture get their own verdicts.
#
#   sh tests/check_test.sh BUILD      (from the repository root; make test runs it)
#   ONLY=REGEX KEEP=1 sh tests/check_test.sh BUILD   only the mistakes named so; keep the logs
set -u
build=${1:-build}
passed=0
failed=0
skipped=0
ok() { passed=$((passed + 1)); }
bad() { echo "check test: FAILED: $*"; failed=$((failed + 1)); }

# The table quotes solution lines: make student leaves it out of a student tree.
if [ -f .ctlab-student ] || [ ! -f tests/check_mistakes.txt ]; then
    echo "check test: 0 passed, 0 failed (skipped: a student tree, no mistakes table)"
    exit 0
fi
for tool in grade make_phantom; do
    [ -x "$build/$tool" ] || { echo "check test: $build/$tool is not built"; exit 1; }
done
work=$(mktemp -d) || exit 1
if [ -n "${KEEP:-}" ]; then echo "check test: logs kept in $work"; else
    trap '[ -z "${lab_pid:-}" ] || kill "$lab_pid" 2> /dev/null; rm -rf "$work"' EXIT INT TERM; fi
case "$build" in *san*) san=SAN=1 ;; *) san= ;; esac
# The phantom, written once to a raw file that every graded run reads: the same voxels as
# --volume phantom (the lab's steps pass on it with every counter), without painting the head
# again in each of the ~200 runs (0.1 s of CPU each). make check's own default, the built-in
# phantom, is graded in tests/student_test.sh and tests/printed_commands_test.sh.
phantom=$work/phantom.raw
"$build/make_phantom" "$phantom" > /dev/null || { echo "check test: make_phantom failed"; exit 1; }

# grade_ok NAME EXPECTED_STATUS LOG PATTERNS: the exit status and every ';'-separated pattern.
grade_ok() {
    name=$1 expected=$2 status=$3 log=$4 patterns=$5
    if [ "$status" -ne "$expected" ]; then
        bad "$name: grade exited with $status, expected $expected"; sed 's/^/    /' "$log"
        return 1
    fi
    old_ifs=$IFS; IFS=';'
    for pattern in $patterns; do
        IFS=$old_ifs
        if ! grep -Eq -- "$pattern" "$log"; then
            bad "$name: grade's output does not match '$pattern'"; sed 's/^/    /' "$log"
            return 1
        fi
    done
    IFS=$old_ifs
    ok
}

# --- The lab's own steps: every run of the manifest, every view, pictures and counters --------
# Graded in the background while the mistakes are patched and built (its verdict is read at
# the end): check runs one step at a time, and the mutants' make and grading fill the other
# core.
lab_pid=
if [ -z "${ONLY:-}" ]; then
    "$build/check" --bin "$build" --volume "$phantom" --out "$work/lab" > "$work/lab.log" 2>&1 &
    lab_pid=$!
fi

# --- One run of the manifest alone (--run): one picture, one summary line graded ------------
"$build/check" --bin "$build" --run 02_threshold_skin --view top --volume "$phantom" \
    --out "$work/one_run" > "$work/one_run.log" 2>&1
grade_ok "check --run 02_threshold_skin" 0 $? "$work/one_run.log" \
    "^1 step: 1 passing;^02_threshold +passing +1/1 +1/1\$"
[ -f "$work/one_run/02_threshold_skin/02_threshold_top.png" ] &&
    [ ! -e "$work/one_run/02_threshold" ] && ok || bad "check --run ran other runs too"

# --- A step that is not built: graded "not built", with the command that shows why -----------
mkdir -p "$work/empty"
"$build/check" --bin "$work/empty" --step 02 --out "$work/none" > "$work/none.log" 2>&1
grade_ok "a step not built" 1 $? "$work/none.log" "not built;make 02_"

# --- Bad input: one line, exit status 2 -----------------------------------------------------------
"$build/check" --step 99 --out "$work/none" > "$work/bad.log" 2>&1
grade_ok "check --step 99" 2 $? "$work/bad.log" "^check: error: --step 99: no such step"
"$build/check" --reference "$work/empty" --out "$work/none" > "$work/bad.log" 2>&1
grade_ok "check --reference with no manifest" 2 $? "$work/bad.log" "^check: error: no .*manifest.txt"
"$build/check" --step 02 --run 03_depth_shading --out "$work/none" > "$work/bad.log" 2>&1
grade_ok "check --run of a step not graded" 2 $? "$work/bad.log" \
    "^check: error: --run 03_depth_shading: no such run of the steps graded"

# --- Mistakes, patched into copies of the solution's steps ---------------------------------------
# Each built against the lab's compiled library, all of them in one parallel make, then graded
# one by one (tests/mutants.sh).
. tests/mutants.sh
mutant_tree || exit 1

grep -v '^#' tests/check_mistakes.txt | grep -v '^[[:space:]]*$' |
    grep -E "^(${ONLY:-.*}) " > "$work/mistakes"
: > "$work/patched"
while IFS='|' read -r name step view script expect shows; do
    name=$(echo $name) step=$(echo $step)
    # printf, not echo: the scripts hold backslashes.
    script=$(printf '%s\n' "$script" | sed 's/^ *//; s/ *$//')
    source=$(ls steps/"$step"_*.cpp 2>/dev/null | head -n 1)
    if [ -z "$source" ]; then
        echo "check test: skipped: $name: there is no step $step"; skipped=$((skipped + 1))
        continue
    fi
    mutant_patch "$name" "$source" "$script" || continue
    printf '%s|%s|%s|%s|%s|%s\n' "$name" "$step" "$view" "$source" "$expect" "$shows" \
        >> "$work/patched"
done < "$work/mistakes"
mutants_build

# Each mutant's grading is a command of its own ($work/grading/NAME), run two at a time
# (MUTANT_JOBS), the part 2 and 3 steps' (the longest) first; their verdicts are read after,
# in the table's order.
mkdir -p "$work/grading"
while IFS='|' read -r name step view source expect shows; do
    # VIEW [RUN...]: the view, then the manifest runs graded (all when none is named).
    # shellcheck disable=SC2086
    set -- $view
    view=$1
    shift
    run_flags=
    for run in "$@"; do run_flags="$run_flags --run $run"; done
    stem=$(basename "$source" .cpp)
    [ -x "$work/bin/$name/$stem" ] || continue  # mutants_build said why
    # The reference's own picture planted where the (first graded) run writes: it must be gone
    # before the run.
    planted=${1:-$stem}
    mkdir -p "$work/out/$name/$planted" &&
        cp "data/reference/${stem}_$view${planted#"$stem"}.png" \
            "$work/out/$name/$planted/${stem}_$view.png" || bad "$name: no plant"
    # A part-2 step has one view, the camera's, and no --view to choose it.
    view_flags="--view $view"
    [ "$view" = camera ] && view_flags=
    # $work is mktemp's and the names and runs are words: no quoting needed inside.
    printf '"%s/check" --bin "%s/bin/%s" --step %s %s%s --volume "%s" --out "%s/out/%s" > "%s/%s.log" 2>&1\necho $? > "%s/%s.status"\n' \
        "$build" "$work" "$name" "$step" "$view_flags" "$run_flags" "$phantom" "$work" "$name" \
        "$work" "$name" "$work" "$name" > "$work/grading/$name"
    echo "$step $name" >> "$work/grading.order"
done < "$work/patched"
if [ -f "$work/grading.order" ]; then
    sort -r "$work/grading.order" | while read -r step name; do echo "$work/grading/$name"; done |
        xargs -n 1 -P "${MUTANT_JOBS:-2}" sh
fi

while IFS='|' read -r name step view source expect shows; do
    expect=$(echo $expect)
    shows=$(printf '%s\n' "$shows" | sed 's/^ *//; s/ *$//')
    [ -f "$work/grading/$name" ] || continue  # not built: mutants_build said why
    status=$(cat "$work/$name.status" 2> /dev/null || echo 127)
    case "$expect" in
        pass) grade_ok "$name (must pass)" 0 $status "$work/$name.log" "$shows" ;;
        fail) grade_ok "$name (must fail)" 1 $status "$work/$name.log" "$shows" ;;
        *) bad "$name: EXPECT is pass or fail, got '$expect'" ;;
    esac
done < "$work/patched"

if [ -n "$lab_pid" ]; then
    wait "$lab_pid"
    status=$?
    lab_pid=
    steps=$(ls steps/[0-9][0-9]_*.cpp | wc -l)
    grade_ok "the lab's steps" 0 $status "$work/lab.log" "^$steps steps?: $steps passing; result=pass"
fi

echo "check test: $passed passed, $failed failed, $skipped skipped"
[ "$failed" -eq 0 ]
