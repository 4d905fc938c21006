#!/bin/sh
# printed_commands_test.sh: every command build/check prints in its failure reports runs as
# printed. Mistakes are patched into copies of the solution's steps (a part-1 step, the first
# step holding the slab method, found by its lesson marker, and a crash), each graded as
# make check grades a tree; then every command line of the reports ("trace it:", "run it
# yourself:", "could not be traced:", "the whole report:", "to see the line ...:") is run
# from the lab's root exactly as printed: a step's command must exit 0 (its pictures go to
# out/, as the student's would), a make command must be one make knows how to run (make -n).
#
#   sh tests/printed_commands_test.sh BUILD      (from the repository root; make test runs it)
set -u
build=${1:-build}
passed=0
failed=0
ok() { passed=$((passed + 1)); }
bad() { echo "printed_commands test: FAILED: $*"; failed=$((failed + 1)); }

if [ -f .ctlab-student ]; then  # the mistakes patch solution lines
    echo "printed_commands test: 0 passed, 0 failed (skipped: a student tree)"
    exit 0
fi
[ -x "$build/check" ] || { echo "printed_commands test: $build/check is not built"; exit 1; }
work=$(mktemp -d) || exit 1
if [ -n "${KEEP:-}" ]; then echo "kept $work"; else trap 'rm -rf "$work"' EXIT INT TERM; fi
case "$build" in *san*) san=SAN=1 ;; *) san= ;; esac

# The mistakes, each built alone against the lab's compiled library: tests/mutants.sh's
# mutant NAME SOURCE SED puts the patched step into $work/bin/NAME.
. tests/mutants.sh
mutant_tree || exit 1

# run_printed NAME LOG [crash]: every printed command of the report, run as printed. With
# `crash`, a command that runs the crashing step itself passes when it crashes as reported:
# killed by a signal (status >= 128), or stopped by a sanitizer's report (a SAN build).
run_printed() {
    name=$1 log=$2 crashes=${3:-}
    sed -n -E 's/.*(trace it|run it yourself|could not be traced|the whole report|to see the line[^:]*): +//p' \
        "$log" > "$work/commands"
    count=$(wc -l < "$work/commands")
    if [ "$count" -eq 0 ]; then bad "$name: the report prints no command"; sed 's/^/    /' "$log"; return; fi
    while IFS= read -r command; do
        case $command in
            make\ *) check=$(echo "$command" | sed 's/^make /make -n /') ;;
            *) check=$command ;;
        esac
        # No window: the command as a student runs it, on a machine without a display here.
        env -u DISPLAY -u WAYLAND_DISPLAY sh -c "$check" > "$work/command.log" 2>&1 < /dev/null
        status=$?
        if [ $status -eq 0 ]; then
            ok
        elif [ -n "$crashes" ] && case $command in make\ *) false ;; *) true ;; esac &&
                { [ $status -ge 128 ] && [ $status -lt 160 ] ||
                  grep -Eq 'ERROR: (Address|Undefined)Sanitizer|runtime error:' "$work/command.log"; }; then
            ok  # the crash, reproduced by the command as printed
        else
            bad "$name: the printed command fails: $command"; tail -n 5 "$work/command.log"
        fi
    done < "$work/commands"
    echo "printed_commands test: $name: $count printed commands run"
}

# A part-1 picture that differs (the threshold moved): "trace it" and the probe ray.
mutant threshold_401 steps/02_threshold.cpp \
    's/bone_threshold = 400;/bone_threshold = 401;/' &&
    { "$build/check" --bin "$work/bin/threshold_401" --step 02 --out "$work/out/t" \
          > "$work/t.log" 2>&1
      [ $? -eq 1 ] || bad "threshold_401: grade did not fail"
      run_printed threshold_401 "$work/t.log"; }

# A crash: "to see the line: make san ...".
mutant crash steps/03_depth_shading.cpp \
    '/for (int [nt] = 0; [nt] < view.ray_length; ++[nt]) {/i\    if (x == 9) *static_cast<volatile int*>(nullptr) = 0;' &&
    { "$build/check" --bin "$work/bin/crash" --step 03 --view top --out "$work/out/c" \
          > "$work/c.log" 2>&1
      [ $? -eq 1 ] || bad "crash: grade did not fail"
      run_printed crash "$work/c.log" crash; }

# Part 2: the slab method without its parallel case (d == 0), in the first step that holds it.
slab=$(grep -l '^//> lesson: slab$' steps/[0-9][0-9]_*.cpp 2>/dev/null | head -n 1)
if [ -z "$slab" ]; then
    echo "printed_commands test: skipped: no step holds the slab method"
else
    number=$(basename "$slab" | cut -c1-2)
    mutant slab_parallel "$slab" '/if (d == 0) {  \/\/ true for -0 too/,/^        }$/d' &&
        { "$build/check" --bin "$work/bin/slab_parallel" --step "$number" --out "$work/out/s" \
              > "$work/s.log" 2>&1
          [ $? -eq 1 ] || { bad "slab_parallel: grade did not fail"; sed 's/^/    /' "$work/s.log"; }
          run_printed slab_parallel "$work/s.log"; }
fi

# Part 3, object order (a view made of slices and a warp, no ray of its own): step 35's
# maximum along i read as if slice rows were contiguous (a failing --mode mip run), and step
# 37's shift rounded down (the default run's picture and counters).
if [ -f steps/35_object_order_mip.cpp ] && [ -f steps/37_shear.cpp ]; then
    mutant mip_row_stride steps/35_object_order_mip.cpp \
        's/float(slice_row\[u \* shear.stride_a\])/float(slice_row[u])/' &&
        { "$build/check" --bin "$work/bin/mip_row_stride" --step 35 --out "$work/out/m" \
              > "$work/m.log" 2>&1
          [ $? -eq 1 ] || { bad "mip_row_stride: grade did not fail"; sed 's/^/    /' "$work/m.log"; }
          grep -q -- "--mode mip" "$work/m.log" ||
              bad "mip_row_stride: no printed command traces the --mode mip run"
          run_printed mip_row_stride "$work/m.log"; }
    mutant shift_truncated steps/37_shear.cpp '/if (position - \*low >= 0.5) ++\*low;/d' &&
        { "$build/check" --bin "$work/bin/shift_truncated" --step 37 --out "$work/out/h" \
              > "$work/h.log" 2>&1
          [ $? -eq 1 ] || { bad "shift_truncated: grade did not fail"; sed 's/^/    /' "$work/h.log"; }
          run_printed shift_truncated "$work/h.log"; }
else
    echo "printed_commands test: skipped: no steps 35 and 37"
fi

echo "printed_commands test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
