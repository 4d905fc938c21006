#!/bin/sh
# make_reference.sh: renders the reference images that data/reference/manifest.txt lists.
#
#   sh tools/make_reference.sh BUILD [VOLUME] [REFERENCE]      (what `make reference` runs)
#   DIMS=NX,NY,NZ ENDIAN=little|big SPACING=SX,SY,SZ ARGS='...'  (optional, in the environment)
#
# Without VOLUME: the phantom, into data/reference/ (or REFERENCE). With VOLUME (a CThead
# file, or a raw file of any size with DIMS=), REFERENCE is required, so the phantom's
# references are never overwritten by accident. DIMS, ENDIAN and SPACING become --dims,
# --endian and --spacing, and ARGS is added as it is, on every run (each step's default run
# and every manifest line). Every step in steps/ gets its default run whether the manifest
# lists it or not. Images the manifest no longer produces (NN_*.png) are removed from
# REFERENCE. A REFERENCE other than data/reference/ gets a copy of the manifest and
# volume.txt: the volume's path, dims, spacing, byte order, extra arguments, the commit and
# the date, so the folder says how it was made.
set -u
build=${1:?usage: make_reference.sh BUILD [VOLUME] [REFERENCE]}
volume=${2:-}
reference=${3:-}
dims=${DIMS:-}
endian=${ENDIAN:-}
spacing=${SPACING:-}
extra=${ARGS:-}
manifest=data/reference/manifest.txt

fail() { echo "make reference: $*" >&2; exit 2; }

# The volume's own flags, checked here so a typo stops the run before anything renders.
volume_flags=
if [ -n "$dims" ]; then
    echo "$dims" | grep -qx '[0-9][0-9]*,[0-9][0-9]*,[0-9][0-9]*' ||
        fail "DIMS=$dims: expected three whole numbers NX,NY,NZ, e.g. DIMS=64,80,40"
    volume_flags="--dims $dims"
fi
if [ -n "$endian" ]; then
    case "$endian" in little | big) ;; *) fail "ENDIAN=$endian: expected little or big" ;; esac
    volume_flags="$volume_flags --endian $endian"
fi
if [ -n "$spacing" ]; then
    echo "$spacing" | grep -qx '[0-9.eE+-]*,[0-9.eE+-]*,[0-9.eE+-]*' ||
        fail "SPACING=$spacing: expected three numbers SX,SY,SZ, e.g. SPACING=1,1,2"
    volume_flags="$volume_flags --spacing $spacing"
fi
case " $extra" in *" --volume"* | *" --out"* | *" --no-window"* | *" --debug-pixel"* | \
                 *" --view"*)
    fail "ARGS='$extra': --volume, --out, --no-window, --debug-pixel and --view are set by \
make reference or the manifest" ;;
esac
if [ -z "$volume" ] && [ -n "$volume_flags" ]; then
    fail "DIMS=, ENDIAN= and SPACING= describe a raw VOLUME=file: give VOLUME= too"
fi

[ -f "$manifest" ] || fail "no $manifest (run from the repository root)"
if [ -z "$volume" ]; then
    volume=phantom
    reference=${reference:-data/reference}
else
    # phantom:SEED: the phantom moved, mirrored and resized by the seed (common/phantom.h).
    case "$volume" in
        phantom:[0-9]*) ;;
        *) [ -f "$volume" ] || fail "VOLUME=$volume: no such file" ;;
    esac
    case "$volume" in -*) volume=./$volume ;; esac  # never read as a flag
    [ -n "$reference" ] || fail "VOLUME=$volume needs REFERENCE=folder (data/reference holds \
the phantom's images), e.g. make reference VOLUME=$volume REFERENCE=ref-cthead"
    [ "${reference%/}" != data/reference ] || fail "REFERENCE=data/reference is the phantom's: \
choose another folder for VOLUME=$volume"
fi
if [ "${reference%/}" = data/reference ] && [ -n "$extra" ]; then
    fail "ARGS= would change the committed phantom references: give REFERENCE=folder"
fi
mkdir -p "$reference" || fail "cannot create $reference"

work=$(mktemp -d) || fail "cannot create a temporary folder"
trap 'rm -rf "$work"' EXIT INT TERM

# The runs: each step's default run unless the manifest lists it, then the manifest's lines,
# each as "NAME ARGUMENTS".
: > "$work/runs"
for source in steps/[0-9][0-9]_*.cpp; do
    step=$(basename "$source" .cpp)
    grep -q "^$step:" "$manifest" || echo "$step" >> "$work/runs"
done
line_number=0
while IFS= read -r line || [ -n "$line" ]; do
    line_number=$((line_number + 1))
    case "$line" in '' | '#'*) continue ;; esac
    case "$line" in *:*) ;; *) fail "$manifest:$line_number: expected 'NAME: ARGUMENTS'" ;; esac
    name=${line%%:*}
    arguments=$(echo "${line#*:}" | sed -E 's/(^| )(tol|counters)=[^ ]*//g')  # grading fields
    case "$arguments" in *--volume* | *--out* | *--no-window* | *--debug-pixel*)
        fail "$manifest:$line_number: --volume, --out, --no-window and --debug-pixel are \
set by make reference" ;;
    esac
    echo "$name $arguments" >> "$work/runs"
done < "$manifest"

# Everything is rendered into $work/images first: a run that fails leaves REFERENCE as it was.
: > "$work/made"
echo "# Each run's summary lines without timings: the work counters build/check compares" \
    > "$work/counters"
mkdir -p "$work/images" || fail "cannot create a temporary folder"
runs=0
while read -r name arguments; do
    # NAME is a step (its default run) or STEP_VARIANT; the step is steps/NN_*.cpp.
    number=$(echo "$name" | sed -n 's/^\([0-9][0-9]\)_.*/\1/p')
    [ -n "$number" ] || fail "'$name': expected NN_name or NN_name_VARIANT"
    source=$(ls steps/"$number"_*.cpp 2>/dev/null | head -n 1)
    [ -n "$source" ] || fail "'$name': there is no step $number in steps/"
    step=$(basename "$source" .cpp)
    variant=
    if [ "$name" != "$step" ]; then
        variant=${name#"$step"_}
        [ "$variant" != "$name" ] || fail "'$name' does not start with the step name $step"
        echo "$variant" | grep -qx '[a-z0-9]*' ||
            fail "'$name': a variant is lower-case letters and digits, got '$variant'"
    fi
    [ -x "$build/$step" ] || fail "$build/$step is not built (make all)"

    rm -rf "$work/out"
    # The arguments are split at spaces on purpose: they are flags and plain values, never
    # file name patterns (set -f: ARGS='*' stays '*').
    set -f
    # shellcheck disable=SC2086
    "$build/$step" --volume "$volume" $volume_flags --no-window --out "$work/out" \
        $arguments $extra > "$work/log" 2>&1
    status=$?
    set +f
    if [ "$status" != 0 ]; then
        cat "$work/log" >&2
        fail "$name failed: $build/$step --volume $volume $volume_flags $arguments $extra"
    fi
    sed -n "s/^step=/$name: step=/p" "$work/log" |
        sed -E 's/ (time_ms|warm_ms|warmup_ms|precompute_ms|threads)=[^ ]*//g' >> "$work/counters"
    # The volume as the step read it: "volume=... dims=NXxNYxNZ spacing=... min=... max=...".
    [ -s "$work/volume_line" ] || grep -m 1 '^volume=' "$work/log" > "$work/volume_line"
    images=
    for image in "$work/out/$step"_*.png; do
        [ -f "$image" ] || fail "$name wrote no ${step}_*.png"
        rest=$(basename "$image" .png)
        rest=${rest#"$step"_}                 # the view, e.g. front (or front_diff)
        target=${step}_$rest${variant:+_$variant}.png
        mv "$image" "$work/images/$target" || fail "cannot move $image"
        echo "$target" >> "$work/made"
        images="$images $target"
    done
    echo "$name:$images"
    runs=$((runs + 1))
done < "$work/runs"

# The probe pixels' traces (data/reference/probes.txt): what make check compares a failing
# run's rays with. Each probe is its run again with --view VIEW --debug-pixel X,Y.
probes=data/reference/probes.txt
mkdir -p "$work/traces" "$work/rays" || fail "cannot create a temporary folder"
probe_count=0
if [ -f "$probes" ]; then
    while read -r name view pixel keep rest; do
        case "$name" in '' | '#'*) continue ;; esac
        run=$(grep -E "^$name( |$)" "$work/runs" | head -n 1)
        [ -n "$run" ] || fail "$probes: '$name' is not a run of $manifest"
        arguments=${run#"$name"}
        number=$(echo "$name" | sed -n 's/^\([0-9][0-9]\)_.*/\1/p')
        step=$(basename "$(ls steps/"$number"_*.cpp | head -n 1)" .cpp)
        view_flag="--view $view"
        [ "$view" != camera ] || view_flag=
        # Only the probe's ray is cast (and, kept as a picture, the pixels its ray picture
        # shows): the run's whole picture is in the reference already.
        only=--trace-only
        [ "$keep" = picture ] || only="$only --no-ray-picture"
        rm -rf "$work/out"
        set -f
        # shellcheck disable=SC2086
        "$build/$step" --volume "$volume" $volume_flags --no-window --out "$work/out" \
            $arguments $extra $view_flag --debug-pixel "$pixel" $only > "$work/log" 2>&1 < /dev/null
        status=$?
        set +f
        if [ "$status" != 0 ]; then
            # The probes are chosen on the phantom: a smaller volume may not have the pixel.
            if grep -q -- "--debug-pixel $pixel is outside" "$work/log"; then
                echo "make reference: probe $name $view $pixel skipped: outside this volume's image"
                continue
            fi
            cat "$work/log" >&2
            fail "probe $name $view $pixel failed"
        fi
        stem=${step}_${view}_ray_$(echo "$pixel" | tr , _)
        target=${name}_${view}_ray_$(echo "$pixel" | tr , _)
        mv "$work/out/$stem.txt" "$work/traces/$target.txt" || fail "probe $name: no $stem.txt"
        if [ "$keep" = picture ]; then
            mv "$work/out/$stem.png" "$work/rays/$target.png" || fail "probe $name: no $stem.png"
        fi
        probe_count=$((probe_count + 1))
    done < "$probes"
fi
rm -rf "$reference/traces" "$reference/rays"
mkdir -p "$reference/traces" "$reference/rays" || fail "cannot create $reference/traces"
for file in "$work/traces"/*.txt; do
    [ -f "$file" ] && { mv "$file" "$reference/traces/" || fail "cannot write $reference/traces"; }
done
# The steps write ray pictures uncompressed (a run's cost); stored ones are packed first.
for file in "$work/rays"/*.png; do
    [ -f "$file" ] || continue
    "$build/pack_png" "$file" || fail "cannot pack $file"
    mv "$file" "$reference/rays/" || fail "cannot write $reference/rays"
done
echo "make reference: $probe_count probe traces into $reference/traces/"

for image in "$work/images"/*.png; do
    mv "$image" "$reference/" || fail "cannot write $reference/$(basename "$image")"
done
mv "$work/counters" "$reference/counters.txt" || fail "cannot write $reference/counters.txt"
# Images the manifest no longer makes would mislead the checker and the handouts.
for image in "$reference"/[0-9][0-9]_*.png; do
    [ -f "$image" ] || continue
    if ! grep -qx "$(basename "$image")" "$work/made"; then
        rm -f "$image" && echo "removed $image: no longer in $manifest"
    fi
done
if [ "${reference%/}" != data/reference ]; then
    # The folder says how it was made.
    field() { tr ' ' '\n' < "$work/volume_line" | sed -n "s/^$1=//p" | head -n 1; }
    commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
    git diff --quiet HEAD -- steps common 2>/dev/null || commit="$commit (with uncommitted changes)"
    {
        echo "# How this reference folder was made (tools/make_reference.sh)."
        echo "volume: $volume"
        echo "dims: $(field dims)"
        echo "spacing: $(field spacing)"
        echo "endian: ${endian:-little}"
        echo "arguments: $volume_flags${extra:+ $extra}"
        echo "commit: $commit"
        echo "date: $(date -u '+%Y-%m-%d %H:%M:%S UTC')"
    } > "$work/volume.txt"
    cp "$manifest" "$work/manifest.txt"
    mv "$work/manifest.txt" "$reference/manifest.txt" || fail "cannot write $reference/manifest.txt"
    mv "$work/volume.txt" "$reference/volume.txt" || fail "cannot write $reference/volume.txt"
fi
echo "make reference: $(wc -l < "$work/made") images from $runs runs into $reference/ \
(volume $volume${volume_flags:+ $volume_flags}${extra:+ $extra})"
