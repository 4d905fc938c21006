#!/bin/sh
# test_summary.sh: the last lines of `make test`: every suite's closing line added up into
# "test: N passed, M failed" (doctest files count their test cases, scripts their checks),
# and for a suite that failed, crashed or closed without its count, its name and the last
# lines of its log. Exit status 1 when anything failed.
#
#   sh tests/test_summary.sh BUILD SUITE...
set -u
build=${1:?usage: sh tests/test_summary.sh BUILD SUITE...}
shift
logs=$build/test-logs
passed=0
failed=0
broken=""
slowest=""
# shard NAME: for a shard of a doctest file's suite (FILE.KofN, tests/shard_cases.sh), "FILE K N".
shard() {
    case $1 in
        *.*of*) file=${1%.*} part=${1##*.}
                [ -f "tests/$file.cpp" ] && echo "$file ${part%of*} ${part#*of}" ;;
    esac
}
for name in "$@"; do
    log=$logs/$name.log
    { read -r status seconds < "$logs/$name.status"; } 2>/dev/null || { status=none; seconds=0; }
    if [ -f "tests/$name.cpp" ] || [ -n "$(shard "$name")" ]; then
        # [doctest] test cases:  8 |  8 passed | 0 failed | 161 skipped
        line=$(grep '^\[doctest\] test cases:' "$log" 2>/dev/null | tail -n 1)
        p=$(printf '%s\n' "$line" | sed -n 's/.*| *\([0-9]*\) passed.*/\1/p')
        f=$(printf '%s\n' "$line" | sed -n 's/.*| *\([0-9]*\) failed.*/\1/p')
        # A file whose test cases are not in the binary runs none: not compiled (the
        # Makefile's TEST_UNIT_N), not a pass.
        if [ -f "tests/$name.cpp" ] && [ -n "$line" ] && [ "$(printf '%s\n' "$line" |
                sed -n 's/^\[doctest\] test cases: *\([0-9]*\) .*/\1/p')" = 0 ]; then
            echo "test: FAILED suite $name: no test case of tests/$name.cpp in $build/ctlab_tests" \
                 "(not compiled in? make -B $build/ctlab_tests)"
            p=
        fi
    else
        # "cli test: 351 passed, 0 failed" (with anything after it: "(2 skipped)")
        line=$(grep -E '^[a-z0-9 _-]+: [0-9]+ passed, [0-9]+ failed' "$log" 2>/dev/null | tail -n 1)
        p=$(printf '%s\n' "$line" | sed -n 's/^[^:]*: \([0-9]*\) passed.*/\1/p')
        f=$(printf '%s\n' "$line" | sed -n 's/^[^:]*: [0-9]* passed, \([0-9]*\) failed.*/\1/p')
    fi
    passed=$((passed + ${p:-0}))
    failed=$((failed + ${f:-0}))
    slowest="$slowest$seconds $name
"
    if [ "$status" = none ] && [ ! -f "$log" ]; then
        # make test runs a suite once what it needs is built (make -k): a build that failed
        # leaves it not run.
        failed=$((failed + 1))
        broken="$broken $name"
        echo "test: FAILED suite $name: not run (what it needs did not build: make's errors above)"
    elif [ -z "$p" ] || [ "$status" != 0 ] || [ "${f:-0}" != 0 ]; then
        [ -n "$p" ] || failed=$((failed + 1))  # a suite that never counted is one failure
        broken="$broken $name"
        echo "test: FAILED suite $name (exit status $status; log $log), its last lines:"
        tail -n 15 "$log" 2>/dev/null | sed 's/^/    /'
    fi
done
echo "test: the slowest suites (s):$(printf '%s' "$slowest" | sort -rn | head -n 4 |
    awk '{printf " %s %s", $2, $1}')"
# Every doctest test case belongs to one file's suite, or to one shard of it: the counts must
# add up. (A doctest file or shard left out with SKIP_SUITES is left out of the count too.)
left_out=""
for file in tests/test_*.cpp; do
    name=$(basename "$file" .cpp)
    case " $* " in (*" $name "*) ;; (*) left_out="$left_out${left_out:+,}*tests/$name.cpp";; esac
done
if [ -x "$build/ctlab_tests" ]; then
    total=$("$build/ctlab_tests" --count --no-version=true \
                --source-file-exclude="${left_out:-none}" 2>/dev/null |
            sed -n 's/.*unskipped test cases passing the current filters: *\([0-9]*\).*/\1/p')
    # A sharded file's cases are counted shard by shard (only the shards that ran).
    for name in "$@"; do
        # shellcheck disable=SC2046
        [ -n "$(shard "$name")" ] && [ -n "$total" ] || continue
        in_shard=$(sh tests/shard_cases.sh "$build" $(shard "$name") | grep -c .)
        total=$((total + in_shard))
    done
    shards=0
    for name in "$@"; do
        [ -f "tests/$name.cpp" ] || [ -n "$(shard "$name")" ] || continue
        n=$(grep '^\[doctest\] test cases:' "$logs/$name.log" 2>/dev/null | tail -n 1 |
            sed -n 's/^\[doctest\] test cases: *\([0-9]*\) .*/\1/p')
        shards=$((shards + ${n:-0}))
    done
    if [ -n "$total" ] && [ "$total" != "$shards" ]; then
        echo "test: FAILED: the doctest files' suites ran $shards test cases of $total"
        failed=$((failed + 1))
        broken="$broken doctest-files"
    fi
fi
[ -z "$broken" ] || echo "test: failed suites:$broken"
echo "test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
