#!/bin/sh
# threshold_mistakes_test.sh: on the phantom, a bone threshold off by one changes the pictures
# of steps 02-05 by more than the checker's tolerance, so such a submission fails.
# The phantom's edges are blurred (handouts/phantom.md), so every value near 400 occurs.
# Each step renders its default run, then with --threshold 399 (in steps 02-04 exactly what
# `value >= 400` renders on integer data), 401, 409, 300 and 211; build/grade compares each
# view with the default one at the checker's default tolerance (2 levels). Every threshold
# must fail at least one view of every step: the student's whole step fails.
#
#   sh tests/threshold_mistakes_test.sh BUILD      (from the repository root; make test runs it)
set -u
build=${1:?usage: sh tests/threshold_mistakes_test.sh BUILD}
cd "$(dirname "$0")/.." || exit 2
steps="02_threshold 03_depth_shading 04_gradient_lighting 05_interpolated_hits"
thresholds="399 401 409 300 211"
work=$(mktemp -d) || exit 2
trap 'rm -rf "$work"' EXIT INT TERM
passed=0
failed=0
# The phantom, written once to a raw file that every run reads: the same voxels as --volume
# phantom, without painting the head again in each of the 24 runs (0.1 s of CPU each).
[ -x "$build/make_phantom" ] || { echo "threshold test: no $build/make_phantom"; exit 2; }
phantom=$work/phantom.raw
"$build/make_phantom" "$phantom" > /dev/null || { echo "threshold test: make_phantom failed"; exit 2; }
for step in $steps; do
    [ -x "$build/$step" ] || { echo "threshold test: no $build/$step"; exit 2; }
    "$build/$step" --volume "$phantom" --view all --no-window --out "$work/default" > /dev/null ||
        { echo "threshold test: $step's default run failed"; exit 1; }
    for threshold in $thresholds; do
        out="$work/t$threshold"
        "$build/$step" --volume "$phantom" --view all --no-window --threshold "$threshold" \
            --out "$out" > /dev/null || { echo "threshold test: $step --threshold $threshold failed"; exit 1; }
        failing=""
        for view in top front side; do
            if ! "$build/grade" "$out/${step}_$view.png" "$work/default/${step}_$view.png" \
                    > "$work/line" 2>&1; then
                grep -q "result=fail" "$work/line" ||
                    { echo "threshold test: check could not compare: $(cat "$work/line")"; exit 2; }
                failing="$failing $view($(sed -n 's/.*\(over_tol_pct=[0-9.]*\).*/\1/p' "$work/line"))"
            fi
        done
        if [ -n "$failing" ]; then
            passed=$((passed + 1))
        else
            failed=$((failed + 1))
            echo "FAIL: $step with --threshold $threshold passes the checker against 400"
        fi
        [ -n "${VERBOSE:-}" ] && echo "$step --threshold $threshold: fails in$failing"
    done
done
echo "threshold test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
