# mutants.sh: sourced by the suites that grade mistakes patched into copies of the solution's
# steps (tests/check_test.sh, tests/printed_commands_test.sh). Not a suite of its own.
#
#   . tests/mutants.sh             (needs $build, $work, $san and a function `bad MESSAGE`)
#   mutant_tree                    the tree the mutants are built in: $work/tree
#   mutant NAME SOURCE SCRIPT      SOURCE patched by the sed SCRIPT ('-': as it is), built
#                                  into $work/bin/NAME/STEM; status 1 (and `bad`) otherwise
#   mutant_patch NAME SOURCE SCRIPT  only patched, into a tree of its own ($work/trees/NAME);
#   mutants_build                  then every patched one built at once (make -j2), each into
#                                  $work/bin/NAME/STEM: check there, `bad` for one that is not
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

# fast_linker: -fuse-ld=gold (or lld) when the compiler links with it here, else nothing: the
# steps' links (STEP_LDFLAGS, outside the build's flags stamp) at 0.05 s of CPU each instead
# of ld.bfd's 0.14. Not for a sanitizer build, which keeps the usual link.
fast_linker() {
    [ -z "${san:-}" ] || return 0
    for linker in gold lld; do
        if printf 'int main() { return 0; }\n' |
                ${CXX:-g++} -fuse-ld=$linker -x c++ - -o "$work/linker_probe" 2> /dev/null; then
            rm -f "$work/linker_probe"
            echo "-fuse-ld=$linker"
            return 0
        fi
    done
}

# The library alone, not the objects it was made from: make is told never to remake it, and
# their ~200 dependency files (BUILD/common/*.d) cost each make ~0.3 s of CPU to read. Without
# its debug information (20 MB of the library's 21), each link takes 0.10 s of CPU, not 0.17;
# a sanitizer build keeps it, for its reports' lines.
mutant_tree() {
    tree=$work/tree
    mutant_ld=$(fast_linker)
    mkdir -p "$tree/steps" "$tree/$build" || return 1
    cp Makefile "$tree/" && cp -R common "$tree/" &&
        cp "$build/libctlab.a" "$tree/$build/" || { bad "cannot copy the lab into $tree"; return 1; }
    [ -n "${san:-}" ] || strip -g "$tree/$build/libctlab.a" 2>/dev/null || true
    find "$tree/$build" -type f -exec touch {} +  # newer than the copied sources
}

# mutant_make DIR TARGET...: make in DIR with the mutants' flags, never remaking the library.
mutant_make() {
    mutant_folder=$1
    shift
    # shellcheck disable=SC2086
    make --no-print-directory -C "$mutant_folder" BUILD="$build" WERROR=0 \
        STEP_OPT="$mutant_opt" STEP_LDFLAGS="$mutant_ld" $san \
        -o "$build/libctlab.a" -o "$build/ctlab_formats.so" -o "$build/ctlab_dicom.so" \
        -o "$build/ctlab_window.so" "$@"
}

# mutant_write TREE: the mutant's source, $mutant_source patched by $mutant_script (- for the
# step as it is), written into TREE; a script that changes nothing is a failure of its own.
mutant_write() {
    if [ "$mutant_script" = - ]; then
        cp "$mutant_source" "$1/$mutant_source" ||
            { bad "$mutant_name: cannot copy $mutant_source"; return 1; }
    else
        sed -e "$mutant_script" "$mutant_source" > "$1/$mutant_source" ||
            { bad "$mutant_name: bad sed script"; return 1; }
        if cmp -s "$mutant_source" "$1/$mutant_source"; then
            bad "$mutant_name: '$mutant_script' changes nothing in $mutant_source (the step changed?)"
            return 1
        fi
    fi
}

mutant() {
    mutant_name=$1 mutant_source=$2 mutant_script=$3
    mutant_stem=$(basename "$mutant_source" .cpp)
    rm -f "$tree"/steps/*.cpp
    mutant_write "$tree" || return 1
    # STEP_PCH=: no precompiled header for these few, built one by one (printed_commands:
    # three). Made at -O1 -g0, it took 2.9 s of compiler CPU and saved each mutant ~0.4 s.
    if ! mutant_make "$tree" STEP_PCH= "$build/$mutant_stem" > "$work/make.log" 2>&1; then
        bad "$mutant_name: the patched $mutant_stem does not compile"; tail -n 20 "$work/make.log"
        return 1
    fi
    mkdir -p "$work/bin/$mutant_name" && mv "$tree/$build/$mutant_stem" "$work/bin/$mutant_name/"
}

# A tree of its own for each mutant, sharing the lab's library, common/ and the precompiled
# header (made once, in $tree) through links, so that all of them build in one parallel make.
mutant_patch() {
    mutant_name=$1 mutant_source=$2 mutant_script=$3
    mutant_stem=$(basename "$mutant_source" .cpp)
    own=$work/trees/$mutant_name
    if [ ! -f "$work/trees/Makefile" ]; then  # the first: the shared header made in $tree
        mkdir -p "$work/trees" || return 1
        # Also writes BUILD/flags.txt. GCC only (make fuzz's clang has no precompiled header):
        # without one, each mutant reads common/ctlab.h itself.
        mutant_make "$tree" "$build/pch/common/ctlab.h.gch" > "$work/trees/pch.log" 2>&1
        printf 'all:\n' > "$work/trees/Makefile"
    fi
    mkdir -p "$own/steps" "$own/$build" &&
        ln -s "$tree/Makefile" "$tree/common" "$own/" &&
        ln -s "$tree/$build/libctlab.a" "$tree/$build/flags.txt" "$own/$build/" ||
        { bad "$mutant_name: cannot make $own"; return 1; }
    [ -d "$tree/$build/pch" ] && ln -s "$tree/$build/pch" "$own/$build/"
    mutant_write "$own" || return 1
    # One target of the make that builds them all (the same make as mutant_make's), its log in
    # the mutant's tree (the target is named like that folder: phony). $work is mktemp's: no
    # spaces, no quotes.
    {
        printf 'all: %s\n.PHONY: %s\n%s:\n' "$mutant_name" "$mutant_name" "$mutant_name"
        printf '\t@$(MAKE) --no-print-directory -C %s BUILD=%s WERROR=0 STEP_OPT="%s" STEP_LDFLAGS="%s" %s' \
            "$own" "$build" "$mutant_opt" "$mutant_ld" "$san"
        printf ' -o %s/%s' "$build" libctlab.a "$build" ctlab_formats.so "$build" ctlab_dicom.so \
            "$build" ctlab_window.so
        printf ' %s/%s > %s/make.log 2>&1\n' "$build" "$mutant_stem" "$own"
    } >> "$work/trees/Makefile"
}

mutants_build() {
    [ -f "$work/trees/Makefile" ] || return 0
    # Its own job count (2), whatever make runs this suite: each mutant's make is its own.
    # shellcheck disable=SC2086
    env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL \
        make --no-print-directory -k -j"${MUTANT_JOBS:-2}" -C "$work/trees" > /dev/null 2>&1
    for own in "$work"/trees/*/; do
        own=${own%/}
        mutant_name=$(basename "$own")
        mutant_stem=$(basename "$(ls "$own"/steps/*.cpp)" .cpp)
        if [ ! -x "$own/$build/$mutant_stem" ]; then
            bad "$mutant_name: the patched $mutant_stem does not compile"
            tail -n 20 "$own/make.log"
            continue
        fi
        mkdir -p "$work/bin/$mutant_name" &&
            mv "$own/$build/$mutant_stem" "$work/bin/$mutant_name/"
    done
}
