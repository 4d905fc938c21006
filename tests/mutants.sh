# mutants.sh: sourced by the suites that grade mistakes patched into copies of the solution's
# steps (tests/check_test.sh, tests/printed_commands_test.sh). Not a suite of its own.
#
#   . tests/mutants.sh             (needs $build, $work, $san and a function `bad MESSAGE`)
#   mutant_tree                    the tree the mutants are built in: $work/tree
#   mutant NAME SOURCE SCRIPT      SOURCE patched by the sed SCRIPT ('-': as it is), built
#                                  into $work/bin/NAME/STEM; status 1 (and `bad`) otherwise
#
# Only the step compiles: the tree has the lab's Makefile, common/ and its compiled library,
# and make is told (-o) never to remake the library or the modules. A mutant is graded once
# and thrown away: it compiles with STEP_OPT='-O1 -g0' (the Makefile's flags for the steps
# alone, outside the build's flags stamp), measured here at 22 mistakes: about 1 s of compiler
# CPU less each than the lab's -O2 -g, and -O0 would cost more in the phantom renders than it
# saves. A sanitizer build (SAN=1) keeps its own flags: its reports name the line.
# WERROR=0: a mistake may well warn (a parameter it no longer uses), and a student's build is
# not -Werror; CI's WERROR=1 reaches this make through MAKEFLAGS otherwise.
mutant_opt=${MUTANT_OPT:--O1 -g0}
[ -z "${san:-}" ] || mutant_opt=${MUTANT_OPT:-}

mutant_tree() {
    tree=$work/tree
    mkdir -p "$tree/steps" "$tree/$build" || return 1
    cp Makefile "$tree/" && cp -R common "$tree/" && cp -R "$build/common" "$tree/$build/" &&
        cp "$build/libctlab.a" "$tree/$build/" || { bad "cannot copy the lab into $tree"; return 1; }
    find "$tree/$build" -type f -exec touch {} +  # newer than the copied sources
}

mutant() {
    mutant_name=$1 mutant_source=$2 mutant_script=$3
    mutant_stem=$(basename "$mutant_source" .cpp)
    rm -f "$tree"/steps/*.cpp
    if [ "$mutant_script" = - ]; then
        cp "$mutant_source" "$tree/$mutant_source" ||
            { bad "$mutant_name: cannot copy $mutant_source"; return 1; }
    else
        sed -e "$mutant_script" "$mutant_source" > "$tree/$mutant_source" ||
            { bad "$mutant_name: bad sed script"; return 1; }
        if cmp -s "$mutant_source" "$tree/$mutant_source"; then
            bad "$mutant_name: '$mutant_script' changes nothing in $mutant_source (the step changed?)"
            return 1
        fi
    fi
    # shellcheck disable=SC2086
    if ! make --no-print-directory -C "$tree" BUILD="$build" WERROR=0 STEP_OPT="$mutant_opt" $san \
            -o "$build/libctlab.a" -o "$build/ctlab_formats.so" -o "$build/ctlab_window.so" \
            "$build/$mutant_stem" > "$work/make.log" 2>&1; then
        bad "$mutant_name: the patched $mutant_stem does not compile"; tail -n 20 "$work/make.log"
        return 1
    fi
    mkdir -p "$work/bin/$mutant_name" && mv "$tree/$build/$mutant_stem" "$work/bin/$mutant_name/"
}
