#!/bin/sh
# class_bench.sh: a class of N generated student trees (tools/make_class.sh: the solution, one
# mistake of tests/check_mistakes.txt each, every tenth tree hostile) graded in one command,
# build/grade --class, on every step of the lab, and checked against make_class's own record
# of which mistake it put where (tools/class_figures.py). Prints the wall time and the CPU
# time (user+sys) of the whole grading, and each per tree: the README's class timing table.
#
#   sh tools/class_bench.sh BUILD N [JOBS]      (from the lab's root; make class-bench N=200)
#   JOBS      students graded at once (grade --jobs; default 2)
#   TIMEOUT=S seconds one run may take (grade --timeout; default 10: the hostile trees that
#             sleep or fork wait it out; a class's default is 120)
#   CACHE=0   grade --no-cache: every tree's steps built and run, for comparison
#   KEEP=1    keep the class and its report (printed)
#
# CPU time: the sandbox's programs are not counted by the shell's time or /usr/bin/time
# (bwrap's monitor exits without reaping them), so it is perf stat's task-clock (every process
# the grader starts, sandboxed or not), else a cgroup (v1 cpuacct) of its own where one can be
# made; otherwise it says so and gives the wall time alone.
set -u
build=${1:?usage: sh tools/class_bench.sh BUILD N [JOBS]}
count=${2:?usage: sh tools/class_bench.sh BUILD N [JOBS]}
jobs=${3:-2}
timeout=${TIMEOUT:-10}
fail() { echo "class_bench: error: $*" >&2; exit 2; }
[ -f tests/check_mistakes.txt ] && [ -d steps ] || fail "run it from the lab's root"
for tool in check grade; do
    [ -x "$build/$tool" ] || fail "$build/$tool is not built: make"
done
work=$(mktemp -d) || exit 2
if [ -n "${KEEP:-}" ]; then echo "class_bench: kept in $work"; else
    trap 'rm -rf "$work"' EXIT INT TERM; fi

sh tools/make_class.sh "$work/class" "$count" || fail "make_class failed"
cache_flag=
[ "${CACHE:-1}" = 0 ] && cache_flag=--no-cache

# perf's task-clock, else a cpuacct cgroup of our own: the grading and all it starts counted.
perf= group=
if perf stat -x, -o /dev/null -e task-clock true > /dev/null 2>&1; then
    perf="perf stat -x, -o $work/perf.txt -e task-clock"
else
    group=/sys/fs/cgroup/cpuacct/ctlab_class_bench_$$
    mkdir "$group" 2> /dev/null || group=
fi
start=$(date +%s.%N)
sh -c 'if [ -n "$1" ]; then echo $$ > "$1/tasks"; fi; shift; exec "$@"' sh "$group" \
    $perf "$build/grade" --class "$work/class" --reference data/reference \
    --report "$work/report" --jobs "$jobs" --timeout "$timeout" $cache_flag \
    > "$work/class.log" 2>&1
status=$?
end=$(date +%s.%N)
cpu=
if [ -n "$perf" ]; then  # "MSEC,msec,task-clock,..."
    cpu=$(awk -F, '$3 == "task-clock" { printf "%.1f", $1 / 1000 }' "$work/perf.txt")
elif [ -n "$group" ]; then
    cpu=$(awk '{ s += $1 } END { printf "%.1f", s / 1e9 }' "$group/cpuacct.usage_user" \
              "$group/cpuacct.usage_sys")
    rmdir "$group" 2> /dev/null
fi
tail -n 4 "$work/class.log"
[ "$status" -le 1 ] || fail "grade --class exited with $status: $(tail -n 5 "$work/class.log")"

python3 tools/class_figures.py "$work/class.expected.txt" "$work/report"
figures=$?
awk -v n="$count" -v s="$start" -v e="$end" -v cpu="$cpu" -v jobs="$jobs" 'BEGIN {
    wall = e - s
    printf "class_bench: %d trees, --jobs %d, %d cores: wall %.0f s (%.1f s per tree)", n,
           jobs, '"$(nproc)"', wall, wall / n
    if (cpu != "") printf ", CPU %.0f s user+sys (%.1f s per tree)\n", cpu, cpu / n
    else printf ", CPU not measured (no perf, no cgroup here)\n"
}'
grep '^- class cache:' "$work/report/summary.md" | sed 's/^- /class_bench: /'
exit "$figures"
