#!/bin/sh
# window_test.sh: the preview window for real, on a virtual X display (xvfb-run). A step opens
# its window and is driven by --window-script (keys and a click pushed as SDL events after the
# first frame): view switch, knob change with re-render, pixel trace, save, quit. Then, when
# xdotool is installed, real X input: a pointer click and key presses through the X server.
#
#   sh tests/window_test.sh BUILD      (from the repository root; make test runs it)
set -u

# --- Inner mode: run inside xvfb-run by the xdotool check below -----------------------------
# window_test.sh --xdotool STEP_BINARY OUT_FOLDER LOG VOLUME_FLAGS...: opens the window,
# clicks image pixel (100, 50) of the top view with the real pointer, presses 3 (side view),
# then q.
if [ "${1:-}" = "--xdotool" ]; then
    binary=$2 out=$3 log=$4
    shift 4
    name=$(basename "$binary")
    "$binary" "$@" --view top --out "$out" > "$log" 2>&1 &
    pid=$!
    # wait_for PATTERN: until the log has a line matching it (at most about 20 s)
    wait_for() {
        tries=0
        until grep -q "$1" "$log"; do
            tries=$((tries + 1))
            [ "$tries" -gt 100 ] && { echo "xdotool: timed out waiting for '$1'"; return 1; }
            sleep 0.2
        done
    }
    finish() { kill "$pid" 2>/dev/null; wait "$pid"; exit 1; }
    # The title is set once the first frame is drawn: "02_threshold | top | ...".
    window='' tries=0
    while [ -z "$window" ]; do
        window=$(xdotool search --name "^$name [|]" 2>/dev/null | head -n 1)
        tries=$((tries + 1))
        [ "$tries" -gt 100 ] && { echo "xdotool: no window named $name"; finish; }
        [ -z "$window" ] && sleep 0.2
    done
    eval "$(xdotool getwindowgeometry --shell "$window")"  # sets X, Y, WIDTH, HEIGHT
    # Right of the control panel, each image pixel a block of whole window pixels: the window
    # says where ("window: image LEFT,TOP scale SX,SY ...").
    wait_for '^window: image ' || finish
    set -- $(sed -n 's/^window: image \([0-9]*\),\([0-9]*\) scale \([0-9]*\),\([0-9]*\) .*/\1 \2 \3 \4/p' \
             "$log" | tail -n 1)
    left=$1 top=$2 scale_x=$3 scale_y=$4
    click_x=$((X + left + 100 * scale_x + scale_x / 2))
    click_y=$((Y + top + 50 * scale_y + scale_y / 2))
    xdotool mousemove "$click_x" "$click_y" click 1
    wait_for '^debug pixel x=100 y=50 view=top' || {
        echo "(window ${WIDTH}x$HEIGHT at $X,$Y on $DISPLAY, clicked $click_x,$click_y)"
        finish
    }
    # With no window manager the keyboard follows the pointer, which is over the window.
    xdotool key 3
    wait_for '^step=.* view=side ' || finish
    xdotool key q
    tries=0
    while kill -0 "$pid" 2>/dev/null; do
        tries=$((tries + 1))
        [ "$tries" -gt 50 ] && { echo "xdotool: the step did not quit on q"; finish; }
        sleep 0.2
    done
    wait "$pid"
    exit $?
fi

# --- The test --------------------------------------------------------------------------------
build=${1:-build}
passed=0
failed=0
ok() { passed=$((passed + 1)); }
bad() { echo "window test: FAILED: $*"; failed=$((failed + 1)); }
check() {  # check DESCRIPTION COMMAND...: the command must succeed
    description=$1
    shift
    if "$@"; then ok; else bad "$description"; fi
}

# xvfb and xauth are optional packages (tools/install-deps.sh): without them the test is
# skipped with one line naming the package, and does not fail.
for tool in xvfb-run:xvfb xauth:xauth; do
    if ! command -v "${tool%%:*}" > /dev/null 2>&1; then
        echo "window test: SKIPPED (package ${tool#*:} not installed: ${tool%%:*} missing)"
        exit 0
    fi
done
binary=$build/02_threshold
[ -x "$binary" ] || binary=$build/01_ray_loops
[ -x "$binary" ] || { echo "window test: no $build/02_threshold or 01_ray_loops built"; exit 1; }
work=$(mktemp -d) || exit 1
trap 'rm -rf "$work"' EXIT INT TERM
# The phantom painted once, to a raw file (build/make_phantom), its size and spacing as that
# reports them: every run below reads it instead of painting it again.
painted=$("$build/make_phantom" "$work/phantom.raw" 2>&1) ||
    { echo "window test: $build/make_phantom failed: $painted"; exit 1; }
phantom=$(echo "$painted" | sed -n "s|.*: \([0-9]*\) x \([0-9]*\) x \([0-9]*\) int16 \
little-endian, spacing \([0-9.]*\):\([0-9.]*\):\([0-9.]*\),.*|--volume $work/phantom.raw \
--dims \1,\2,\3 --spacing \4,\5,\6|p")
[ -n "$phantom" ] || { echo "window test: make_phantom printed '$painted'"; exit 1; }
# SAN=1 builds: LeakSanitizer is off for the windowed runs only. SDL_Init opens a D-Bus
# connection that libdbus never frees (SDL 2.26 does not call dbus_shutdown); the headless
# tests still check our own code for leaks. ASan and UBSan stay on.
ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"
export ASAN_OPTIONS
xvfb() { timeout 60 xvfb-run -a -s "-screen 0 1280x1024x24" "$@"; }

# after LINE PATTERN: some line after the first line equal to LINE matches PATTERN
after() { awk -v mark="$1" -v pattern="$2" '$0 == mark { seen = 1; next }
                                           seen && $0 ~ pattern { found = 1 }
                                           END { exit !found }' "$work/stdout"; }

# --- Scripted SDL events -----------------------------------------------------------------------
xvfb "$binary" $phantom --view top --out "$work/out" \
    --window-script "key:2,key:Up,click:100:50,save,quit" > "$work/stdout" 2> "$work/stderr"
status=$?
check "the step exits with status 0 (got $status; 124 = timed out)" [ "$status" -eq 0 ]
check "the window opened (stderr: $(head -c 300 "$work/stderr"))" \
    test -z "$(grep 'no window' "$work/stderr")"
check "the window renders its first frame (a second top summary)" \
    [ "$(grep -c '^step=.* view=top ' "$work/stdout")" -ge 2 ]
check "key 2 re-renders the front view" after "window: key=2" '^step=.* view=front '

# 02_threshold's knob is its threshold (step 01 has none). Up prints "window: NAME=VALUE".
knob=''
[ "$(basename "$binary")" = 02_threshold ] && knob=threshold
if [ -n "$knob" ]; then
    check "key Up prints the new $knob" after "window: key=Up" "^window: $knob="
    # NAME=VALUE of the front summary lines before and after the key.
    before=$(awk '/^window: key=Up$/ { exit } /^step=.* view=front /' "$work/stdout" |
             tail -n 1 | tr ' ' '\n' | grep "^$knob=")
    after_up=$(awk 'seen && /^step=.* view=front / { print; exit }
                    /^window: key=Up$/ { seen = 1 }' "$work/stdout" | tr ' ' '\n' |
               grep "^$knob=")
    changed=no
    [ -n "$before" ] && [ -n "$after_up" ] && [ "$before" != "$after_up" ] && changed=yes
    check "key Up re-renders with a new $knob (before '$before', after '$after_up')" \
        [ "$changed" = yes ]
else
    check "key Up is handled (this step has no knob)" grep -qx "window: key=Up" "$work/stdout"
fi

check "the click names image pixel 100,50" grep -qx "window: click x=100 y=50" "$work/stdout"
check "the click prints the trace of pixel 100,50 in the front view" \
    after "window: click x=100 y=50" '^debug pixel x=100 y=50 view=front '
saved=$(sed -n 's/^saved //p' "$work/stdout" | head -n 1)
check "S prints 'saved PATH'" [ -n "$saved" ]
check "the saved file '$saved' exists" test -f "$saved"
magic=$(od -An -tx1 -N8 "$saved" 2>/dev/null | tr -d ' \n')
check "the saved file is a PNG (magic bytes: '$magic')" [ "$magic" = "89504e470d0a1a0a" ]
check "q quits the window" grep -qx "window: key=q" "$work/stdout"

# --- P: the next preset (data/presets in name order), the whole step run again ------------------
# 07 on the phantom: ct, cthead and eight_bit run (the command line's volume wins); float's
# table (0.12 ..) does not fit CT values: one line, then phantom; the script goes on (Up).
tf_binary=$build/07_back_to_front
if [ -x "$tf_binary" ]; then
    xvfb "$tf_binary" $phantom --view top --out "$work/preset_out" \
        --window-script "key:p,key:p,key:p,key:p,key:Up,quit" > "$work/stdout" 2> "$work/stderr"
    status=$?
    check "presets: the step exits with status 0 (got $status; $(head -c 300 "$work/stderr"))" \
        [ "$status" -eq 0 ]
    check "presets: P switches to the first preset, ct" after "window: key=p" "^window: preset=ct$"
    check "presets: ct renders with its table" after "window: preset=ct" \
        '^step=07_back_to_front view=top .* tf=data/tf/classic.tf'
    check "presets: eight_bit renders with its table" after "window: preset=eight_bit" \
        '^step=07_back_to_front view=top .* skin_opacity=0.05 tf=data/tf/eight_bit.tf'
    check "presets: float's table does not fit CT values: one line naming it" \
        grep -q "^window: preset float does not fit: data/tf/float.tf:[0-9]*: FROM must be" \
        "$work/stdout"
    check "presets: then the next, phantom, renders" after "window: preset=phantom" \
        '^step=07_back_to_front view=top .* tf=data/tf/classic.tf'
    check "presets: the script goes on in the new window (Up after the switches)" \
        after "window: preset=phantom" '^window: skin_opacity=0.14$'
    check "presets: q quits" grep -qx "window: key=q" "$work/stdout"
    check "presets: nothing on stderr ($(head -c 300 "$work/stderr"))" test ! -s "$work/stderr"
else
    echo "window test: presets SKIPPED ($tf_binary not built)"
fi

# --- The ray panel: a click opens the ray picture beside the image, the knob moves its hit ---
panel_step=$build/05_interpolated_hits
if [ -x "$panel_step" ]; then
    xvfb "$panel_step" $phantom --view front --out "$work/panel" \
        --window-script "click:128:30,shot,key:Up,key:Up,shot,quit" > "$work/panel.log" 2>&1
    status=$?
    # The same ray traced headless at the threshold the window started with and at the one
    # its two Ups reach (400 + 2 * 50): its rays alone (--trace-only), its picture and numbers.
    for threshold in 400 500; do
        "$panel_step" $phantom --view front --no-window --trace-only \
            --out "$work/panel_$threshold" --threshold "$threshold" \
            --debug-pixel 128,30 > /dev/null 2>&1
    done
    check "the ray panel run exits with status 0 (got $status)" [ "$status" -eq 0 ]
    # "window: ray panel x=128 y=30 view=front WxH hit t=T": once for the click, once per Up.
    panel='^window: ray panel x=128 y=30 view=front [0-9]*x[0-9]* hit t=\([0-9.]*\).*'
    hits=$(sed -n "s/$panel/\\1/p" "$work/panel.log" | tr '\n' ' ')
    set -- $hits
    check "the click and each Up draw the ray panel with its hit (got '$hits')" [ $# -eq 3 ]
    if [ $# -eq 3 ]; then
        check "turning the threshold up moves the hit deeper ($1 < $2 < $3)" \
            awk -v a="$1" -v b="$2" -v c="$3" 'BEGIN { exit !(a < b && b < c) }'
        # The panel's hit is the ray picture's at the threshold the two Ups reach.
        expected=$(sed -n 's/^mark hit \([^ ]*\) .*/\1/p' \
                   "$work/panel_500/05_interpolated_hits_front_ray_128_30.txt")
        check "the panel's hit after two Ups ($3) is --threshold 500's ray's ($expected)" \
            awk -v a="$3" -v b="$expected" \
                'BEGIN { d = a - b; exit !(b != "" && d < 1e-3 && d > -1e-3) }'
    fi
    # The panel's pixels on screen (shots before and after the Ups: "window: shot PATH WxH
    # panel=X,Y,W,H") are the ray pictures' plots at the same threshold, and those two differ
    # (the band's edge and label, the hit): the window draws what --debug-pixel draws, and
    # follows the knob.
    if command -v python3 > /dev/null 2>&1; then
        shots=$(sed -n 's/^window: shot \([^ ]*\) [0-9]*x[0-9]* panel=\([0-9,]*\)$/\1 \2/p' \
                "$work/panel.log")
        set -- $shots
        check "two shots of the window with the panel open (got '$shots')" [ $# -eq 4 ]
        if [ $# -eq 4 ]; then
            picture=05_interpolated_hits_front_ray_128_30.png
            compare="python3 $(dirname "$0")/panel_pixels.py"
            before=$($compare "$1" "$2" "$work/panel_400/$picture" 2>&1)
            check "the panel on screen before Up is the threshold 400 ray picture's plot: $before" \
                [ "$before" = same ]
            after_ups=$($compare "$3" "$4" "$work/panel_500/$picture" 2>&1)
            check "the panel on screen after two Ups is the threshold 500 picture's plot: \
$after_ups" [ "$after_ups" = same ]
            moved=$($compare "$3" "$4" "$work/panel_400/$picture" 2>&1)
            check "the panel after two Ups differs from the threshold 400 picture's ($moved)" \
                sh -c "echo '$moved' | grep -q '^[1-9][0-9]* of [0-9]* pixels differ'"
        fi
    else
        echo "window test: the panel's pixels SKIPPED (python3 not installed)"
    fi
fi

# --- Real X input (optional: needs xdotool) ----------------------------------------------------
if command -v xdotool > /dev/null 2>&1; then
    xvfb sh "$0" --xdotool "$binary" "$work/real_out" "$work/real.log" $phantom \
        > "$work/real.stdout" 2>&1
    status=$?
    # A run that fails is run once more, its first failure printed (as tests/panel_test.sh
    # does): under a loaded make test a virtual display is now and then lost or never found,
    # and the step's window then ends with status 1. A fault of the window fails both runs.
    if [ "$status" -ne 0 ]; then
        echo "window test: the real X input run failed once (status $status:" \
             "$(cat "$work/real.stdout"); its log ends:" \
             "$(tail -n 3 "$work/real.log" | tr '\n' ' ')); once more"
        xvfb sh "$0" --xdotool "$binary" "$work/real_out" "$work/real.log" $phantom \
            > "$work/real.stdout" 2>&1
        status=$?
    fi
    check "real X input: the run completes (status $status; $(cat "$work/real.stdout"))" \
        [ "$status" -eq 0 ]
    check "real X input: a pointer click traces pixel 100,50 of the top view" \
        grep -q '^debug pixel x=100 y=50 view=top ' "$work/real.log"
    check "real X input: key 3 shows the side view" grep -q '^step=.* view=side ' "$work/real.log"
    check "real X input: key q quits" grep -qx "window: key=q" "$work/real.log"
else
    echo "window test: real X input SKIPPED (package xdotool not installed)"
fi

# --- The orbit (part 2): drag to turn, wheel to zoom, coarse previews, full size after -------
# Each "window: orbit azimuth=A elevation=E zoom=Z (N previews at WxH)" line is followed by the
# full-size render's summary line, which must show the same camera.
camera_step=$build/25_free_leaping
if [ -x "$camera_step" ]; then
    xvfb "$camera_step" $phantom --size 128x128 --zoom 0.5 --out "$work/orbit_out" \
        --window-script "press:64:64,move:70:64,move:80:64,release:80:64,wheel:2,wait:500,\
press:64:64,move:64:70,move:64:90,wait:500,move:64:100,release:64:100,click:64:64,quit" \
        > "$work/orbit.stdout" 2> "$work/orbit.stderr"
    status=$?
    check "orbit: the step exits with status 0 (got $status; stderr: \
$(head -c 300 "$work/orbit.stderr"))" [ "$status" -eq 0 ]
    # field NAME LINE: the value of NAME= in LINE
    field() { echo "$2" | tr ' ' '\n' | sed -n "s/^$1=//p" | head -n 1; }
    orbit_lines=$(grep -c '^window: orbit ' "$work/orbit.stdout")
    # Release after the drag, wheel then still, still while held, release: four full renders.
    check "orbit: four full-size renders after previews (got $orbit_lines)" \
        [ "$orbit_lines" -eq 4 ]
    first=$(grep -m 1 '^window: orbit ' "$work/orbit.stdout")
    second=$(grep '^window: orbit ' "$work/orbit.stdout" | sed -n 2p)
    last=$(grep '^window: orbit ' "$work/orbit.stdout" | tail -n 1)
    # A drag to the right turns the camera to its left: azimuth down from 30, elevation kept.
    check "orbit: dragging right lowers the azimuth ($first)" \
        awk -v a="$(field azimuth "$first")" 'BEGIN { exit !(a < 30) }'
    check "orbit: dragging right keeps the elevation ($first)" \
        [ "$(field elevation "$first")" = 20 ]
    check "orbit: the drag was previewed ($first)" \
        sh -c "echo '$first' | grep -q ' ([1-9][0-9]* previews at [0-9]*x[0-9]*)\$'"
    preview_size=$(echo "$first" | sed -n 's/.* previews at \([0-9]*\)x[0-9]*)$/\1/p')
    check "orbit: the preview has fewer columns than the picture ($preview_size < 128)" \
        [ "${preview_size:-999}" -lt 128 ]
    check "orbit: the wheel up zooms in ($second)" \
        awk -v z="$(field zoom "$second")" 'BEGIN { exit !(z > 0.5) }'
    check "orbit: dragging down raises the elevation ($last)" \
        awk -v e="$(field elevation "$last")" 'BEGIN { exit !(e > 20) }'
    # The summary line after each orbit line renders that camera, at full size.
    mismatched=$(awk '/^window: orbit / { want = $3 " " $4 " " $5; next }
                      want != "" && /^step=/ { line = $0; got = ""
                          n = split(line, f, " ")
                          for (i = 1; i <= n; i++)
                              if (f[i] ~ /^(azimuth|elevation|zoom)=/) got = got (got ? " " : "") f[i]
                          if (got != want || line !~ / size=128x128 /) print want " / " got
                          want = "" }' "$work/orbit.stdout")
    check "orbit: each full render shows the camera the orbit line names ($mismatched)" \
        [ -z "$mismatched" ]
    check "orbit: a click without a drag still traces its pixel" \
        grep -q '^debug pixel x=64 y=64 view=camera ' "$work/orbit.stdout"
    if [ "$failed" -ne 0 ]; then
        echo "window test: stdout of the orbit run:"
        cut -c 1-160 "$work/orbit.stdout" | grep -v '^  t=' | sed 's/^/    /'
    fi
else
    echo "window test: orbit SKIPPED ($camera_step not built)"
fi

if [ "$failed" -ne 0 ]; then
    echo "window test: stdout of the scripted run:"
    cut -c 1-160 "$work/stdout" | grep -v '^  t=' | sed 's/^/    /'
fi
echo "window test: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
