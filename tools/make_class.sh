#!/bin/sh
# make_class.sh: a class of generated student trees, for trying the class grader at scale
# (build/grade --class). Each tree holds the solution's steps with one mistake of
# tests/check_mistakes.txt (the rows taken in turn), or, every HOSTILE-th tree, step 02 with
# one of the hostile programs of tests/hostile/ appended; the first tree is the solution as
# it is. CLASS.expected.txt (beside the class folder) says what each tree must get:
#   NAME RESULT STEP WHAT      RESULT pass or fail; STEP the step that decides it (- : none)
#
#   sh tools/make_class.sh CLASS N [STEPS_REGEX [HOSTILE]]   (from the lab's root)
#   STEPS_REGEX   only mistakes in steps matching it (default: every step), e.g. '0[127]'
#   HOSTILE       every HOSTILE-th tree is hostile (default 10; 0: none)
# A mistake row whose step does not exist, or whose sed script changes nothing, is passed by.
set -u
class=${1:?usage: sh tools/make_class.sh CLASS N [STEPS_REGEX [HOSTILE]]}
count=${2:?usage: sh tools/make_class.sh CLASS N [STEPS_REGEX [HOSTILE]]}
only=${3:-.*}
every=${4:-10}
fail() { echo "make_class: error: $*" >&2; exit 2; }
[ -f tests/check_mistakes.txt ] && [ -d steps ] || fail "run it from the lab's root"
[ -e "$class" ] && fail "'$class' exists already"
mkdir -p "$class" || fail "cannot create '$class'"
expected=${class%/}.expected.txt
lab=$(pwd)
work=$(mktemp -d) || exit 2
trap 'rm -rf "$work"' EXIT INT TERM

# The mistakes that apply here: NAME|STEP|SCRIPT|EXPECT, one per line.
grep -v '^#' tests/check_mistakes.txt | grep -v '^[[:space:]]*$' |
while IFS='|' read -r name step view script expect shows; do
    step=$(echo $step)
    echo "$step" | grep -Eq "^($only)\$" || continue
    ls steps/"$step"_*.cpp > /dev/null 2>&1 || continue
    printf '%s|%s|%s|%s\n' "$(echo $name)" "$step" \
        "$(printf '%s\n' "$script" | sed 's/^ *//; s/ *$//')" "$(echo $expect)"
done > "$work/mistakes"
[ -s "$work/mistakes" ] || fail "no mistake of tests/check_mistakes.txt matches '$only'"
rows=$(wc -l < "$work/mistakes")
# Hostile programs whose verdict does not depend on the volume graded or on a server:
# NAME RESULT (the one that writes elsewhere is contained, and renders right: it passes).
hostile_list="sleeps fail
fork_bomb fail
floods_stdout fail
floods_file fail
allocates_50gb fail
searches_reference fail
copies_reference fail
writes_elsewhere pass"
hostiles=$(echo "$hostile_list" | wc -l)
mkdir -p "$work/home"

new_tree() {  # new_tree NAME: the solution's steps and the student marker
    mkdir -p "$class/$1/steps" && : > "$class/$1/.ctlab-student" &&
        cp steps/[0-9][0-9]_*.cpp "$class/$1/steps/"
}
n=0 made=0 row=0 hostile=0 skipped=0
: > "$expected"
while [ "$made" -lt "$count" ]; do
    n=$((n + 1))
    name=$(printf 's%03d' "$n")
    if [ "$made" -eq 0 ]; then
        new_tree "$name" && echo "$name pass - the solution" >> "$expected"
    elif [ "$every" -gt 0 ] && [ $((made % every)) -eq 0 ]; then
        line=$(echo "$hostile_list" | sed -n "$((hostile % hostiles + 1))p")
        hostile=$((hostile + 1))
        what=${line% *} result=${line#* }
        new_tree "$name" || exit 2
        sed 's/^int main(int argc, char\*\* argv) {/static int student_main(int argc, char** argv) {/' \
            steps/02_threshold.cpp > "$class/$name/steps/02_threshold.cpp"
        sed -e "s|@LAB@|$lab|g" -e "s|@OTHER@|$class/s001|g" -e "s|@HOME@|$work/home|g" \
            -e "s|@PORT@|9|g" "tests/hostile/$what.inc" >> "$class/$name/steps/02_threshold.cpp"
        step=02
        [ "$result" = pass ] && step=-
        echo "$name $result $step hostile:$what" >> "$expected"
    else
        IFS='|' read -r what step script expect <<EOF
$(sed -n "$((row % rows + 1))p" "$work/mistakes")
EOF
        row=$((row + 1))
        source=$(ls steps/"$step"_*.cpp | head -n 1)
        new_tree "$name" || exit 2
        sed -e "$script" "$source" > "$class/$name/$source" || exit 2
        if cmp -s "$source" "$class/$name/$source"; then
            rm -rf "${class:?}/$name"; n=$((n - 1)) skipped=$((skipped + 1))
            echo "make_class: $what changes nothing in $source: passed by" >&2
            [ "$skipped" -gt "$rows" ] && fail "no mistake changes its step"
            continue
        fi
        [ "$expect" = pass ] && step=-
        echo "$name $expect $step mistake:$what" >> "$expected"
    fi
    made=$((made + 1))
done
echo "make_class: $made trees in $class ($(grep -c ' pass ' "$expected") expected to pass); $expected says what each must get"
