#!/bin/sh
# sandbox_test.sh: a class of hostile and careless student trees, graded in one command
# (build/grade --class: each tree's step 02 built from source and run in the sandbox, against
# the lab's common/). Each gets its verdict with one line of reason (tests/hostile/*.inc say
# what each program does), and nothing outside the students' output folders changes: the
# class, the lab's steps and references and a home folder are hashed before and after; a
# server on 127.0.0.1 sees no connection. The class is graded on phantom:SEED, a volume the
# students never saw: a program that renders the kit's phantom is named.
#
#   sh tests/sandbox_test.sh BUILD      (from the repository root; make test runs it)
#   KEEP=1 sh tests/sandbox_test.sh BUILD   keep the class and reports
set -u
build=${1:-build}
passed=0
failed=0
ok() { passed=$((passed + 1)); }
bad() { echo "sandbox test: FAILED: $*"; failed=$((failed + 1)); }
finish() {
    echo "sandbox test: $passed passed, $failed failed"
    [ "$failed" -eq 0 ]
    exit
}

if [ -f .ctlab-student ] || [ ! -d tests/hostile ]; then
    echo "sandbox test: 0 passed, 0 failed (skipped: a student tree)"
    exit 0
fi
for tool in check grade 02_threshold; do
    [ -x "$build/$tool" ] || { echo "sandbox test: $build/$tool is not built"; exit 1; }
done
lab=$(pwd)
work=$(mktemp -d) || exit 1
if [ -n "${KEEP:-}" ]; then echo "sandbox test: kept in $work"; else
    trap 'rm -rf "$work"' EXIT INT TERM; fi

# --- The reference: step 02's default run only (one build and one run per student), on a ----
# volume the students never saw: the phantom moved, mirrored and resized by the seed, as
# make reference VOLUME=phantom:SEED makes it (its volume.txt names the volume grade renders).
seed=2029
ref=$work/ref
mkdir -p "$ref"
"$build/02_threshold" --volume "phantom:$seed" --no-window --out "$ref" > "$work/ref.log" 2>&1 ||
    { bad "02_threshold --volume phantom:$seed: $(cat "$work/ref.log")"; finish; }
echo "02_threshold:" > "$ref/manifest.txt"
sed -n 's/^step=/02_threshold: step=/p' "$work/ref.log" > "$ref/counters.txt"
echo "volume: phantom:$seed" > "$ref/volume.txt"
# The variant's pictures are not the kit's.
"$build/grade" "$ref/02_threshold_top.png" data/reference/02_threshold_top.png > /dev/null
[ $? -eq 1 ] && ok || bad "phantom:$seed renders step 02's top view as the kit's phantom does"

# --- Without a sandbox, programs are not run unless the instructor says so -------------------
mkdir -p "$work/one/steps"
cp steps/02_threshold.cpp "$work/one/steps/"
if ! "$build/check" --build --tree "$work/one" --reference "$ref" --out "$work/one_out" \
        > "$work/one.log" 2>&1; then
    if grep -q '^check: error: no sandbox: ' "$work/one.log"; then
        ok
        echo "sandbox test: no sandbox here ($(cat "$work/one.log")): the rest is skipped"
        finish
    fi
    bad "the solution's step 02 does not pass in the sandbox: $(cat "$work/one.log")"
    finish
fi
ok

# --- The class -------------------------------------------------------------------------------
class=$work/class
home=$work/home
mkdir -p "$class" "$home"
echo "the instructor's" > "$home/notes.txt"
# student NAME [SOURCE]: a tree with step 02 (the solution's, or SOURCE's).
student() {
    mkdir -p "$class/$1/steps" && : > "$class/$1/.ctlab-student"
    cp "${2:-steps/02_threshold.cpp}" "$class/$1/steps/02_threshold.cpp"
}
student honest
# A wrong threshold (a constant: this file goes into student trees, no lesson line is quoted).
sed 's/bone_threshold = 400;/bone_threshold = 1000;/' steps/02_threshold.cpp > "$work/mistake.cpp"
cmp -s steps/02_threshold.cpp "$work/mistake.cpp" && bad "the mistake changes nothing in step 02"
student mistake "$work/mistake.cpp"
# Its own common/ breaks the PNG writer: ignored, the instructor's library is used.
student changes_common
mkdir -p "$class/changes_common/common"
echo 'this is not C++' > "$class/changes_common/common/image.cpp"
cp common/image.h "$class/changes_common/common/"
# Prebuilt programs that would pass, beside a source that does not: the source is graded.
student prebuilt "$work/mistake.cpp"
mkdir -p "$class/prebuilt/build" && cp "$build/02_threshold" "$class/prebuilt/build/"
# No code at all, its build/ a link to the lab's: nothing to build.
mkdir -p "$class/build_link/steps" && : > "$class/build_link/.ctlab-student"
ln -s "$lab/$build" "$class/build_link/build"
# A step source that is a link to the lab's own: not followed.
mkdir -p "$class/source_link/steps" && : > "$class/source_link/.ctlab-student"
ln -s "$lab/steps/02_threshold.cpp" "$class/source_link/steps/02_threshold.cpp"

# A server on 127.0.0.1 that records any connection (the sandbox has its own loopback).
port_file=$work/port
connected=$work/connected
python3 - "$port_file" "$connected" <<'EOF' &
import socket, sys
server = socket.socket()
server.bind(("127.0.0.1", 0))
server.listen(5)
server.settimeout(120)
open(sys.argv[1], "w").write(str(server.getsockname()[1]))
try:
    connection, _ = server.accept()
    open(sys.argv[2], "w").write("connected\n")
except OSError:
    pass
EOF
server=$!
# Up to 20 s for the port (python3's start-up alone took more than 2 s at load ~25).
tries=0
while [ ! -s "$port_file" ] && [ $tries -lt 100 ]; do sleep 0.2; tries=$((tries + 1)); done
port=$(cat "$port_file" 2>/dev/null)
[ -n "$port" ] || { bad "the 127.0.0.1 server did not start"; port=9; }

for hostile in tests/hostile/*.inc; do
    name=$(basename "$hostile" .inc)
    sed 's/^int main(int argc, char\*\* argv) {/static int student_main(int argc, char** argv) {/' \
        steps/02_threshold.cpp > "$work/$name.cpp"
    sed -e "s|@LAB@|$lab|g" -e "s|@OTHER@|$class/honest|g" -e "s|@HOME@|$home|g" \
        -e "s|@PORT@|$port|g" "$hostile" >> "$work/$name.cpp"
    student "$name" "$work/$name.cpp"
done

# Everything the class run must leave as it was.
fingerprint() {
    find "$class" "$home" "$lab/data/reference" "$lab/steps" "$lab/common" /tmp/pwned.txt \
        ! -type d 2>/dev/null | LC_ALL=C sort | while IFS= read -r file; do
        printf '%s ' "$file"; cksum < "$file"
    done
}
fingerprint > "$work/before.txt"

HOME=$home "$build/grade" --class "$class" --reference "$ref" --report "$work/report" \
    --jobs 2 --timeout 3 --budget 60 > "$work/class.log" 2>&1
status=$?
[ "$status" -eq 1 ] || bad "grade --class exited with $status, expected 1: $(cat "$work/class.log")"

fingerprint > "$work/after.txt"
if cmp -s "$work/before.txt" "$work/after.txt"; then ok; else
    bad "files outside the output folders changed: $(diff "$work/before.txt" "$work/after.txt")"
fi
[ ! -e "$connected" ] && ok || bad "a program connected to 127.0.0.1:$port"
kill "$server" 2>/dev/null
wait "$server" 2>/dev/null

# verdict NAME RESULT PATTERN: class.csv's result, and the reason in its report.
verdict() {
    row=$(grep "^$1," "$work/report/class.csv")
    report=$work/report/students/$1/report.txt
    case "$row" in
        "$1,$2,"*) ;;
        *) bad "$1: expected $2, class.csv says: $row"; sed 's/^/    /' "$report"; return ;;
    esac
    if [ "$3" = - ] || grep -Eq -- "$3" "$report"; then ok; else
        bad "$1: its report does not say '$3':"; sed 's/^/    /' "$report"
    fi
}
verdict honest pass '02_threshold: passing'
verdict mistake fail 'counter samples='
verdict changes_common pass '02_threshold: passing'
verdict prebuilt fail 'counter samples='
verdict build_link fail 'steps/02_threshold.cpp cannot be read'
verdict source_link fail 'steps/02_threshold.cpp is a symbolic link: not followed'
verdict copies_reference fail 'the run wrote no 02_threshold_top.png'
verdict searches_reference fail 'the run wrote no 02_threshold_top.png'
verdict writes_elsewhere pass '02_threshold: passing'
verdict fork_bomb fail 'stopped after [0-9]+ s'
# The address-space limit stops it (std::bad_alloc: SIGABRT); a sanitizer build runs without
# one (ASan's shadow needs terabytes of address space), and ASan's own allocator stops it.
verdict allocates_50gb fail 'crashed with SIGABRT|AddressSanitizer: out-of-memory'
verdict floods_stdout fail 'stopped: it printed more than 1 MiB'
verdict floods_file fail 'crashed with SIGXFSZ'
verdict sleeps fail 'stopped after [0-9]+ s'
verdict renders_kit_phantom fail "matches the kit's phantom reference, not the volume it was given \\(phantom:$seed\\)"
verdict connects fail "exited with status 3: connect 127.0.0.1:$port: Connection refused"

# --- A rerun keeps every finished student (as after an interrupted run) --------------------
students=$(ls -d "$class"/*/ | wc -l)
HOME=$home "$build/grade" --class "$class" --reference "$ref" --report "$work/report" \
    --jobs 2 --timeout 3 --budget 60 > "$work/rerun.log" 2>&1
status=$?
kept=$(grep -c '(graded before: kept)$' "$work/rerun.log")
if [ "$status" -eq 1 ] && [ "$kept" -eq "$students" ] &&
        grep -q "^grade: $students students graded by an earlier run were kept" "$work/rerun.log"
then ok; else bad "the rerun kept $kept of $students students (status $status):" \
    "$(cat "$work/rerun.log")"; fi
finish
