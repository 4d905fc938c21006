#!/bin/sh
# run_suite.sh: one suite of `make test`, its output kept together. A suite is a script
# tests/NAME_test.sh (run as `sh tests/NAME_test.sh BUILD`) or a doctest file tests/NAME.cpp
# (its test cases in BUILD/ctlab_tests, chosen by source file). The output goes to
# BUILD/test-logs/NAME.log, and the log is printed whole when the suite ends, so that suites
# running side by side (make -j) do not interleave; tests/test_summary.sh adds them up.
# A long doctest file runs as shards, suites named FILE.KofN (tests/shard_cases.sh): shard K
# of N of its test cases.
#
#   sh tests/run_suite.sh BUILD NAME
set -u
build=${1:?usage: sh tests/run_suite.sh BUILD NAME}
name=${2:?usage: sh tests/run_suite.sh BUILD NAME}
cd "$(dirname "$0")/.." || exit 2
logs=$build/test-logs
mkdir -p "$logs" || exit 2
log=$logs/$name.log
started=$(date +%s)
start_stamp=$(date +%s.%N)
# CPU time (user, system seconds) of the suite and every process it waited for: on a shared
# machine the figure that says what a suite costs (wall time says how busy the machine was).
cpu="/usr/bin/time -f %U_%S -o $logs/$name.cpu"
[ -x /usr/bin/time ] || cpu=
if [ -f "tests/${name}_test.sh" ]; then
    case $name in
        window|panel)  # real windows on virtual X displays: one such suite at a time
            $cpu flock "$logs/x_display.lock" sh "tests/${name}_test.sh" "$build" > "$log" 2>&1 ;;
        *) $cpu sh "tests/${name}_test.sh" "$build" > "$log" 2>&1 ;;
    esac
elif [ -f "tests/$name.cpp" ]; then
    # -sf: the test cases written in that file; a crash still ends the log with its message.
    $cpu "$build/ctlab_tests" --source-file="*tests/$name.cpp" --no-version=true > "$log" 2>&1
elif file=${name%.*} shard=${name##*.} && [ "$file" != "$name" ] &&
        [ -f "tests/$file.cpp" ] && k=${shard%of*} n=${shard#*of} &&
        [ "$k" -ge 1 ] 2> /dev/null && [ "$k" -le "$n" ] 2> /dev/null; then
    # FILE.KofN: the shard's test cases only (a shard without any is a failure: too many).
    cases=$(sh tests/shard_cases.sh "$build" "$file" "$k" "$n" --filter)
    if [ -n "$cases" ]; then
        $cpu "$build/ctlab_tests" --source-file="*tests/$file.cpp" --test-case="$cases" \
            --no-version=true > "$log" 2>&1
    else
        echo "run_suite: shard $name holds no test case of tests/$file.cpp" > "$log"
        false
    fi
else
    echo "run_suite: no suite '$name' (tests/${name}_test.sh, tests/$name.cpp or a shard" \
         "FILE.KofN of tests/FILE.cpp)" > "$log"
    false
fi
status=$?
seconds=$(( $(date +%s) - started ))
echo "$status $seconds" > "$logs/$name.status"
# When it started and ended (seconds since the epoch): where make test's cores idled.
echo "$start_stamp $(date +%s.%N)" > "$logs/$name.time"
echo "=== $name (exit $status, ${seconds} s) ==="
cat "$log"
exit 0  # the summary judges every suite; one failing does not stop the others
