#!/bin/sh
# shard_cases.sh: the test cases of one shard of a doctest file's suite, one name a line. A
# long file (tests/test_extremes.cpp) runs in `make test` as N suites side by side, named
# FILE.KofN (test_extremes.1of4): shard K holds the file's test cases number K, K+N, K+2N...
# in doctest's order (by file and line), so the shards together run each case once.
#
#   sh tests/shard_cases.sh BUILD FILE K N         names, one a line
#   sh tests/shard_cases.sh BUILD FILE K N --filter    the same as one doctest -tc value
set -u
build=${1:?usage: sh tests/shard_cases.sh BUILD FILE K N [--filter]}
file=${2:?usage: sh tests/shard_cases.sh BUILD FILE K N [--filter]}
k=${3:?usage: sh tests/shard_cases.sh BUILD FILE K N [--filter]}
n=${4:?usage: sh tests/shard_cases.sh BUILD FILE K N [--filter]}
names=$("$build/ctlab_tests" --source-file="*tests/$file.cpp" --list-test-cases \
            --no-version=true | grep -v -e '^\[doctest\]' -e '^=====*$' |
        awk -v k="$k" -v n="$n" '(NR - 1) % n == k - 1') || exit 2
if [ "${5:-}" = --filter ]; then
    # doctest's filters are comma-separated: a comma inside a name is written "\,".
    printf '%s\n' "$names" | sed 's/,/\\,/g' | paste -s -d, -
else
    printf '%s\n' "$names"
fi
