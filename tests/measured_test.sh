#!/bin/sh
# measured_test.sh: the measured figures the handouts quote (tools/measured.cpp).
# 1. build/measured rewrites a handout's <!-- measured: NAME --> block from a source's
#    <!-- section: NAME --> and leaves other blocks alone; --check says when they differ;
#    a block without its end line is bad input (status 2).
# 2. Every block in handouts/*.md is closed and names a section a measuring tool writes:
#    bench:NN_name for a step in steps/ (tools/bench.cpp), or a study section named in
#    tools/study.cpp. So `make bench` and `make study` refresh every measured table.
#
#   sh tests/measured_test.sh BUILD      (from the repository root; make test runs it)
set -u
build=${1:?usage: sh tests/measured_test.sh BUILD}
cd "$(dirname "$0")/.." || exit 2
tool=$build/measured
[ -x "$tool" ] || { echo "measured test: no $tool"; exit 2; }
work=$(mktemp -d) || exit 2
trap 'rm -rf "$work"' EXIT INT TERM
passed=0
failed=0
check() {  # check DESCRIPTION COMMAND...
    description=$1
    shift
    if "$@"; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAIL: $description"; fi
}

cat > "$work/source.md" <<'END'
# figures
<!-- section: demo:speed -->
| view | ms |
|---|---:|
| top | 1.25 ms |
<!-- end section -->
END
cat > "$work/handout.md" <<'END'
Before.
<!-- measured: demo:speed -->
| view | ms |
|---|---:|
| top | 9.99 ms |
<!-- end measured -->
Between.
<!-- measured: other:figures -->
kept as it is
<!-- end measured -->
After.
END
cat > "$work/expected.md" <<'END'
Before.
<!-- measured: demo:speed -->
| view | ms |
|---|---:|
| top | 1.25 ms |
<!-- end measured -->
Between.
<!-- measured: other:figures -->
kept as it is
<!-- end measured -->
After.
END
"$tool" --check "$work/source.md" "$work/handout.md" > /dev/null
check "--check exits 1 when a block differs from the source (got $?)" [ $? -eq 1 ]
check "--check writes nothing" grep -q "9.99 ms" "$work/handout.md"
"$tool" "$work/source.md" "$work/handout.md" > "$work/stdout"
check "rewriting exits 0 (got $?)" [ $? -eq 0 ]
check "the block is the source's section, the other block is kept" \
    cmp -s "$work/handout.md" "$work/expected.md"
check "it says how many blocks it rewrote" grep -q "^measured: 1 blocks from" "$work/stdout"
"$tool" --check "$work/source.md" "$work/handout.md" > /dev/null
check "--check exits 0 once they agree (got $?)" [ $? -eq 0 ]
printf 'x\n<!-- measured: demo:speed -->\nno end\n' > "$work/open.md"
"$tool" "$work/source.md" "$work/open.md" > /dev/null 2> "$work/stderr"
check "a block without its end line is bad input (status $?)" [ $? -eq 2 ]
check "and the error names it" grep -q "open.md:2: block 'demo:speed' has no" "$work/stderr"

# Every block in the handouts: closed, and a section some tool writes.
for handout in handouts/*.md; do
    awk -v file="$handout" '
        /^<!-- measured: .* -->$/ { if (open) { print file ":" NR ": block inside a block"; bad = 1 }
                                    open = NR; next }
        /^<!-- end measured -->$/ { if (!open) { print file ":" NR ": end without a block"; bad = 1 }
                                    open = 0 }
        END { if (open) { print file ":" open ": block not closed"; bad = 1 } exit bad }' \
        "$handout" > "$work/structure"
    check "blocks in $handout are well formed: $(cat "$work/structure")" [ ! -s "$work/structure" ]
    sed -n 's/^<!-- measured: \(.*\) -->$/\1/p' "$handout" | while read -r name; do
        case $name in
            bench:*) [ -f "steps/${name#bench:}.cpp" ] ;;
            study:*) grep -q "section(\"$name\"" tools/study.cpp ;;
            # make gain (build/bench --gain) writes one section per part-3 step.
            gain:*) [ -f "steps/${name#gain:}.cpp" ] && grep -q 'section: gain:' tools/bench.cpp ;;
            *) false ;;
        esac || echo "$handout: block '$name' is no section bench, study or gain writes"
    done > "$work/names"
    check "every block in $handout names a section a tool writes: $(cat "$work/names")" \
        [ ! -s "$work/names" ]
done
echo "measured test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
