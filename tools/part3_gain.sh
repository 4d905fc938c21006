#!/bin/sh
# part3_gain.sh: what each part-3 step's trick gains, in CPU time per render, on the bench's
# four cases (handouts/30_speed_baseline.md). What `make gain` runs.
#
#   sh tools/part3_gain.sh BUILD [OUT]       (OUT default out/part3_gain.md)
#
# Every part-3 step (steps/3N_*.cpp) renders each case on the phantom at spacing 1,1,1 on one
# thread, once with --repeat 1 and once with --repeat REPEAT (default 11), and a render costs
# the difference of the two processes' CPU time (user + sys, /usr/bin/time) over REPEAT - 1:
# loading the volume, the bricks and any table made once per process cancel out, and CPU
# time, unlike wall time, hardly depends on what else the shared machine runs. Each figure is
# the median of PAIRS (default 3) such pairs. OUT gets one section per step,
# <!-- section: gain:NN_name -->, for tools/measured.cpp to copy into the handout's block.
set -u
build=${1:?usage: part3_gain.sh BUILD [OUT]}
out=${2:-out/part3_gain.md}
repeat=${REPEAT:-11}
pairs=${PAIRS:-3}

fail() { echo "part3_gain: $*" >&2; exit 2; }
[ -x /usr/bin/time ] || fail "needs /usr/bin/time (Debian package time) for CPU times"
[ "$repeat" -ge 2 ] 2>/dev/null || fail "REPEAT=$repeat: expected a whole number >= 2"
[ "$pairs" -ge 1 ] 2>/dev/null || fail "PAIRS=$pairs: expected a whole number >= 1"

# The bench's cases (../shared/performance.md), as part 3's flags.
top="--azimuth 180 --elevation 90 --size 256x256"
case_flags() {
    case $1 in
        a) echo "--unlit $top" ;;
        b) echo "$top" ;;
        c) echo "--unlit --azimuth 30 --elevation 20 --size 512x512 --zoom 1.356" ;;
        d) echo "--mode mip $top" ;;
    esac
}
case_name() {
    case $1 in
        a) echo "a composite unlit, top, 256²" ;;
        b) echo "b composite lit, top, 256²" ;;
        c) echo "c composite unlit, oblique, 512²" ;;
        d) echo "d maximum intensity, top, 256²" ;;
    esac
}

work=$(mktemp -d) || fail "cannot create a temporary folder"
trap 'rm -rf "$work"' EXIT INT TERM

# CPU seconds (user + sys) of one run of STEP with FLAGS and --repeat N.
cpu_of() {
    step=$1 n=$2
    shift 2
    # shellcheck disable=SC2068
    /usr/bin/time -f '%U %S' -o "$work/time" "$build/$step" --volume phantom --spacing 1,1,1 \
        --no-window --threads 1 --out "$work/out" --repeat "$n" $@ > "$work/log" 2>&1 ||
        { cat "$work/log" >&2; fail "$step $* failed"; }
    awk '{ printf "%.4f\n", $1 + $2 }' "$work/time"
}

# Milliseconds of CPU per render: the median over the pairs.
per_render_ms() {
    step=$1 flags=$2
    : > "$work/pairs"
    p=0
    while [ "$p" -lt "$pairs" ]; do
        # shellcheck disable=SC2086
        one=$(cpu_of "$step" 1 $flags) || exit 2
        # shellcheck disable=SC2086
        many=$(cpu_of "$step" "$repeat" $flags) || exit 2
        echo "$one $many" | awk -v r="$repeat" '{ printf "%.1f\n", 1000 * ($2 - $1) / (r - 1) }' \
            >> "$work/pairs"
        p=$((p + 1))
    done
    sort -n "$work/pairs" | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'
}

steps=$(ls steps/3[0-9]_*.cpp 2>/dev/null | sed 's|steps/||; s|\.cpp$||')
[ -n "$steps" ] || fail "no part-3 steps in steps/ (run from the repository root)"
for step in $steps; do
    [ -x "$build/$step" ] || fail "$build/$step is not built (make all)"
done

# Every step, every case: work/ms_STEP_CASE.
for step in $steps; do
    for c in a b c d; do
        ms=$(per_render_ms "$step" "$(case_flags $c)") || exit 2
        echo "$ms" > "$work/ms_${step}_$c"
        echo "part3_gain: $step case $c: $ms ms CPU per render"
    done
done

when=$(date -u '+%Y-%m-%d %H:%M UTC')
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo 2>/dev/null | head -n 1)
load=$(cut -d ' ' -f 1-3 /proc/loadavg 2>/dev/null)
mkdir -p "$(dirname "$out")" || fail "cannot create $(dirname "$out")"
{
    echo "# Part 3: CPU time per render, 1 thread (tools/part3_gain.sh)"
    echo
    echo "Measured $when on ${cpu:-an unknown CPU} (load average $load): the phantom at"
    echo "spacing 1,1,1, --threads 1; each figure the median of $pairs pairs of runs (--repeat 1 and"
    echo "--repeat $repeat), CPU ms per render = the pair's difference / $((repeat - 1))."
    echo
    first=
    previous=
    for step in $steps; do
        number=${step%%_*}
        echo "<!-- section: gain:$step -->"
        if [ -z "$first" ]; then
            echo "| case | flags | step $number, CPU ms per render |"
            echo "|---|---|---|"
            for c in a b c d; do
                echo "| $(case_name $c) | \`$(case_flags $c)\` | $(cat "$work/ms_${step}_$c") |"
            done
        else
            p_number=${previous%%_*}
            f_number=${first%%_*}
            # The gain over the step before, and over the first (the same column for step 31).
            if [ "$previous" = "$first" ]; then
                echo "| case | step $p_number ms | step $number ms | gain over step $p_number |"
                echo "|---|---|---|---|"
            else
                echo "| case | step $f_number ms | step $p_number ms | step $number ms | gain over step $p_number | over step $f_number |"
                echo "|---|---|---|---|---|---|"
            fi
            short=
            [ "$previous" != "$first" ] || short=1
            for c in a b c d; do
                f=$(cat "$work/ms_${first}_$c")
                p=$(cat "$work/ms_${previous}_$c")
                t=$(cat "$work/ms_${step}_$c")
                echo "$c $f $p $t" | awk -v name="$(case_name $c)" -v short="$short" '{
                    gain_p = ($4 > 0) ? sprintf("%.2fx", $3 / $4) : "n/a";
                    gain_f = ($4 > 0) ? sprintf("%.2fx", $2 / $4) : "n/a";
                    if (short) printf "| %s | %s | %s | %s |\n", name, $3, $4, gain_p;
                    else printf "| %s | %s | %s | %s | %s | %s |\n", name, $2, $3, $4, gain_p, gain_f }'
            done
        fi
        echo
        echo "CPU ms per render on 1 thread (\`make gain\`, $when; load average $load; the median"
        echo "of $pairs pairs of runs, \`--repeat 1\` and \`--repeat $repeat\`: the CPU clock counts in 10 ms,"
        echo "so a figure is good to about $(awk -v r="$repeat" 'BEGIN { printf "%.0f", 10 / (r - 1) }') ms)."
        echo "<!-- end section -->"
        echo
        [ -n "$first" ] || first=$step
        previous=$step
    done
} > "$out.tmp" && mv "$out.tmp" "$out" || fail "cannot write $out"
echo "part3_gain: wrote $out"
