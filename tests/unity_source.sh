#!/bin/sh
# unity_source.sh: the source of one of the doctest binary's translation units, made of
# several test files (the Makefile's TEST_UNIT_N). It includes every header the files include,
# then each file inside a namespace of its own (ctlab_unit_test_NAME), so that two files'
# helpers of one name (an anonymous namespace's `contains`, a `using namespace`) never meet.
# The headers, doctest and the standard library are parsed, and their templates compiled,
# once per unit instead of once per file. A test case keeps its file's name and line
# (__FILE__: the Makefile maps "./tests/..." to "tests/..."), so that
# `--source-file=*tests/NAME.cpp` still chooses a file's test cases.
#
#   sh tests/unity_source.sh tests/test_a.cpp tests/test_b.cpp ...     the source, on stdout
set -u
cd "$(dirname "$0")/.." || exit 2
for file in "$@"; do
    [ -f "$file" ] || { echo "unity_source: no test file $file" >&2; exit 2; }
done
echo "// A unit of the doctest binary's test files (tests/unity_source.sh): generated."
# Every header first, at file scope: a file's own #include of it, inside its namespace, is then
# skipped by the header's include guard. A quoted include found beside its file ("harness.h"
# in tests/) is named by its path from the repository's root.
for file in "$@"; do
    folder=$(dirname "$file")
    grep '^#include' "$file" | while IFS= read -r line; do
        case $line in
            *'"'*) header=${line#*\"}; header=${header%%\"*}
                   [ -f "$folder/$header" ] && line="#include \"$folder/$header\"" ;;
        esac
        printf '%s\n' "$line"
    done
done | awk '!seen[$0]++'
for file in "$@"; do
    stem=$(basename "$file" .cpp)
    printf 'namespace ctlab_unit_%s {\n#include "%s"\n}  // namespace ctlab_unit_%s\n' \
        "$stem" "$file" "$stem"
done
