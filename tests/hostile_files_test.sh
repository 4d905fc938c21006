#!/bin/sh
# hostile_files_test.sh: what an attacker would try against the loaders, the outputs and the
# instructor scripts (issue 28), each through the real binaries:
#   - data that is not an ordinary file: FIFOs (no hang), devices (/dev/zero), folders, in
#     place of a raw file, a .nii, a .img, an NRRD or MetaImage data file, a --tf file;
#   - short, long, cut, bomb and otherwise damaged files of every format, written by nibabel,
#     pydicom, numpy and by hand (tests/formats/write_hostile.py): exit status 2, one line
#     naming the problem, no picture;
#   - outputs under signals: SIGPIPE (| head -c 1), SIGXFSZ (ulimit -f), SIGTERM, SIGINT,
#     SIGHUP, SIGQUIT, SIGUSR1, SIGALRM: every picture or none, no temporary left;
#   - make reference and make carry with shell metacharacters in VOLUME, ARGS and STEP; carry
#     with a record line pointing outside the tree; the checker given one folder as
#     --submission and --reference.
#
#   sh tests/hostile_files_test.sh BUILD
#
# Prints one line per failure and a last line "hostile_files test: N passed, M failed"; exit
# status 1 when anything failed.
set -u
build=${1:?usage: sh tests/hostile_files_test.sh BUILD}
cd "$(dirname "$0")/.." || exit 2
root=$(pwd -P)
step="$build/02_threshold"
with_step=
passed=0
failed=0
work=$(mktemp -d -p "$(sh tests/scratch_parent.sh)") || exit 2
trap 'rm -rf "$work"' EXIT INT TERM
pass() { passed=$((passed + 1)); }
fail() {
    failed=$((failed + 1))
    echo "FAIL: $*"
}

# refused PATH SAYS [FLAGS...]: the step (02_threshold, or $with_step) exits 2 within 20 s
# with one line on stderr holding SAYS, and writes nothing into --out.
refused() {
    path=$1
    says=$2
    shift 2
    rm -rf "$work/out"
    timeout 20 "${with_step:-$step}" --volume "$path" --no-window --view top --out "$work/out" "$@" \
        > "$work/stdout" 2> "$work/stderr" < /dev/null
    status=$?
    lines=$(wc -l < "$work/stderr")
    said=$(head -c 300 "$work/stderr")
    if [ "$status" -ne 2 ]; then
        fail "$path $*: exit status $status, expected 2 ($said)"
    elif [ "$lines" -ne 1 ]; then
        fail "$path $*: $lines lines on stderr, expected one: $said"
    elif ! grep -qF -- "$says" "$work/stderr"; then
        fail "$path $*: the message does not say '$says': $said"
    elif [ -n "$(ls -A "$work/out" 2>/dev/null)" ]; then
        fail "$path $*: wrote into --out although refused"
    else
        pass
    fi
}

# loads PATH [FLAGS...]: the step renders it (exit 0, a picture).
loads() {
    rm -rf "$work/out"
    if timeout 30 "$step" --volume "$1" --no-window --view top --out "$work/out" \
            > "$work/stdout" 2> "$work/stderr" < /dev/null &&
            [ -f "$work/out/02_threshold_top.png" ]; then
        pass
    else
        fail "$1: did not load: $(head -c 300 "$work/stderr")"
    fi
}

# --- Class 1: not an ordinary file -------------------------------------------------------------
files="$work/files"
mkdir "$files"
printf 'NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: %s\n' \
    data.raw > "$files/fifo.nhdr"
printf 'NDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\nElementDataFile = data.raw\n' \
    > "$files/fifo.mhd"
for kind in fifo device folder; do
    mkdir "$files/$kind"
    cp "$files/fifo.nhdr" "$files/$kind/head.nhdr"
    cp "$files/fifo.mhd" "$files/$kind/head.mhd"
    for name in head_4x4x4_uint8.raw head.nii data.raw head.tf; do
        case $kind in
            fifo) mkfifo "$files/$kind/$name" ;;
            device) ln -s /dev/zero "$files/$kind/$name" ;;
            folder) mkdir "$files/$kind/$name" ;;
        esac
    done
    case $kind in
        fifo) says="FIFO" ;;
        device) says="a device" ;;
        folder) says="a folder" ;;
    esac
    refused "$files/$kind/head_4x4x4_uint8.raw" "$says"
    refused "$files/$kind/head.nii" "$says"
    refused "$files/$kind/head.nhdr" "$says"
    refused "$files/$kind/head.mhd" "$says"
    with_step="$build/07_back_to_front"
    refused phantom "$says" --tf "$files/$kind/head.tf"
    with_step=
done

# A preset (data/presets/NAME.preset, read from the current folder) that is a FIFO, a device,
# a folder: refused at once, in a folder of our own.
case $build in /*) step_path=$step ;; *) step_path=$root/$step ;; esac
for kind in fifo device folder; do
    mkdir -p "$files/presets_$kind/data/presets"
    case $kind in
        fifo) mkfifo "$files/presets_$kind/data/presets/evil.preset"; says=FIFO ;;
        device) ln -s /dev/zero "$files/presets_$kind/data/presets/evil.preset"; says="a device" ;;
        folder) mkdir "$files/presets_$kind/data/presets/evil.preset"; says="a folder" ;;
    esac
    (cd "$files/presets_$kind" && timeout 20 "$step_path" --preset evil --volume phantom \
        --no-window --view top --out out > /dev/null 2> "$work/preset.err" < /dev/null)
    status=$?
    if [ "$status" -eq 2 ] && grep -q "$says" "$work/preset.err" &&
            [ ! -e "$files/presets_$kind/out" ]; then
        pass
    else
        fail "a preset that is a $kind: exit status $status: $(head -c 300 "$work/preset.err")"
    fi
done

# --- Classes 1-5: damaged files of every format, from independent writers -------------------------
if /usr/bin/python3 tests/formats/write_hostile.py "$work/hostile" > "$work/python.log" 2>&1; then
    # A .hdr whose .img is a FIFO, a device, a folder (each beside a good header).
    for kind in fifo device folder; do
        cp "$work/hostile/good_pair.hdr" "$files/$kind/pair.hdr"
        case $kind in
            fifo) mkfifo "$files/$kind/pair.img"; says=FIFO ;;
            device) ln -s /dev/zero "$files/$kind/pair.img"; says="a device" ;;
            folder) mkdir "$files/$kind/pair.img"; says="a folder" ;;
        esac
        refused "$files/$kind/pair.hdr" "$says"
    done
    while read -r name; do
        loads "$work/hostile/$name"
    done < "$work/hostile/good.txt"
    while IFS='|' read -r name says; do
        refused "$work/hostile/$name" "$says"
    done < "$work/hostile/cases.txt"
    rm -f "$work/hostile/huge.raw" "$work/hostile/no_newline.mha"  # 3 GiB each, sparse
else
    echo "hostile_files: skipped the written files: $(tail -n 1 "$work/python.log")" \
         "(sh tools/install-deps.sh installs them)"
fi

# --- Class 6: outputs under signals: all or none, no temporary -----------------------------------
# all_or_none DIR WHAT: DIR holds no temporary, and either every view's picture or none.
all_or_none() {
    pictures=$(ls "$1" 2>/dev/null | grep -c '^02_threshold_.*\.png$')
    temporaries=$(ls -A "$1" 2>/dev/null | grep -c 'tmp')
    if [ "$temporaries" -ne 0 ]; then
        fail "$2: temporaries left: $(ls -A "$1" | tr '\n' ' ')"
    elif [ "$pictures" -ne 0 ] && [ "$pictures" -ne 3 ]; then
        fail "$2: $pictures of 3 pictures written"
    else
        pass
    fi
}
# SIGPIPE: the summary lines go into a pipe closed after one byte.
rm -rf "$work/pipe"
"$step" --volume phantom --no-window --view all --out "$work/pipe" 2>/dev/null | head -c 1 \
    > /dev/null
all_or_none "$work/pipe" "SIGPIPE (| head -c 1)"
# SIGXFSZ: a file size limit below one picture: a one-line error, exit 2, nothing written.
rm -rf "$work/fsize"
(ulimit -f 2; "$step" --volume phantom --no-window --view all --out "$work/fsize") \
    > /dev/null 2> "$work/fsize.err"
status=$?
all_or_none "$work/fsize" "SIGXFSZ (ulimit -f 2)"
if [ "$status" -eq 2 ] && grep -q "cannot write" "$work/fsize.err" &&
        [ "$(wc -l < "$work/fsize.err")" -eq 1 ]; then
    pass
else
    fail "ulimit -f 2: exit status $status, expected 2 and one line:" \
         "$(head -c 300 "$work/fsize.err")"
fi
# Signals from outside, at several moments of a run that writes many pictures.
# A command started with & in a script starts with SIGINT and SIGQUIT ignored (POSIX: no job
# control), and a step keeps an ignored signal ignored (as under nohup): without
# `env --default-signal` those two runs would never see their signal and render to the end
# (2.5 s of CPU each).
default_signals="env --default-signal=INT,QUIT"
$default_signals true 2> /dev/null || default_signals=
# Each signal with its number on Linux (the exit status of a process it ended is 128 + it).
for pair in TERM:15 INT:2 HUP:1 QUIT:3 USR1:10 ALRM:14; do
    signal=${pair%:*}
    number=${pair#*:}
    if [ -z "$default_signals" ] && { [ "$signal" = INT ] || [ "$signal" = QUIT ]; }; then
        echo "hostile_files: SIG$signal not sent (no env --default-signal, coreutils 8.31)"
        continue
    fi
    for delay in 0.05 0.2 0.4; do
        rm -rf "$work/sig"
        $default_signals "$build/24_ambient_occlusion" --volume phantom --no-window --view all \
            --out "$work/sig" > /dev/null 2>&1 &
        pid=$!
        sleep "$delay"
        kill -s "$signal" "$pid" 2> /dev/null
        wait "$pid" 2> /dev/null
        status=$?
        temporaries=$(ls -A "$work/sig" 2>/dev/null | grep -c 'tmp')
        if [ "$temporaries" -ne 0 ]; then
            fail "SIG$signal after ${delay}s: temporaries left: $(ls -A "$work/sig" | tr '\n' ' ')"
        elif [ "$status" -ne 0 ] && [ "$status" -ne $((128 + number)) ]; then
            fail "SIG$signal after ${delay}s: exit status $status, expected $((128 + number))" \
                 "(ended by the signal) or 0 (done before it)"
        else
            pass
        fi
    done
done

# --- Class 7: instructor scripts run nothing they are given ---------------------------------------
# make is run with STEP_BINARIES= and -o: it runs the recipes only, never rebuilds a binary
# (under BUILD=build-san without SAN=1 it would rebuild them without the sanitizers).
touch_mark="$work/injected"
raw="$work/volume_4x4x4_uint8.raw"
head -c 64 /dev/zero > "$raw"
# A name with a command substitution: refused as a missing file, the command never run.
make -s --no-print-directory reference STEP_BINARIES= BUILD="$build" \
    VOLUME="a\`touch $touch_mark\`.raw" REFERENCE="$work/ref" > "$work/ref.log" 2>&1
if [ -e "$touch_mark" ]; then fail "make reference VOLUME='a\`touch ...\`': the command ran"
else pass; fi
# A '"' in ARGS: no stray file in the tree, one refusal, nothing run.
make -s --no-print-directory reference STEP_BINARIES= BUILD="$build" VOLUME="$raw" \
    REFERENCE="$work/ref" ARGS="--threads 1\" > stray_file_from_args \"" > "$work/ref.log" 2>&1
if [ -e stray_file_from_args ] || [ -e '"' ]; then
    fail "make reference ARGS with '\"': a stray file in the tree"
    rm -f stray_file_from_args
else
    pass
fi
# carry: a record line pointing outside the tree is refused, the file there untouched.
tree="$work/tree"
mkdir -p "$tree/.ctlab" "$tree/steps" "$work/victim_dir"
printf 'int main() { return 0; }\n' > "$work/victim_dir/victim.cpp"
cp "$work/victim_dir/victim.cpp" "$work/victim_before"
printf '../../victim_dir/victim shade 01_ray_loops 0123\n' > "$tree/.ctlab/carry.txt"
cp steps/01_ray_loops.cpp "$tree/steps/"
"$build/carry" --tree "$tree" > "$work/carry.log" 2>&1
status=$?
if [ "$status" -eq 2 ] && cmp -s "$work/victim_before" "$work/victim_dir/victim.cpp" &&
        grep -q "is not 'NN_step" "$work/carry.log"; then
    pass
else
    fail "carry with '../../victim': exit status $status: $(head -c 300 "$work/carry.log")"
fi
# make carry STEP='1; touch x': the value is never run.
make -s --no-print-directory -o "$build/carry" carry BUILD="$build" \
    STEP="1; touch $touch_mark" > /dev/null 2>&1
if [ -e "$touch_mark" ]; then fail "make carry STEP='1; touch ...': the command ran"; else pass; fi

# --- Class 8: the checker refuses to compare a folder with itself -------------------------------
mkdir -p "$work/same"
cp data/reference/02_threshold_top.png "$work/same/"
ln -s "$work/same" "$work/same_link"
for other in "$work/same" "$work/same_link" "$work/same/"; do
    "$build/grade" --submission "$work/same" --reference "$other" > "$work/check.log" 2>&1
    status=$?
    if [ "$status" -eq 2 ] && grep -q "is the reference folder" "$work/check.log"; then
        pass
    else
        fail "grade --submission DIR --reference $other: exit status $status:" \
             "$(head -c 200 "$work/check.log")"
    fi
done

echo "hostile_files test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
