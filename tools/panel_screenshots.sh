#!/bin/sh
# panel_screenshots.sh: the README's pictures of the window's control panel, taken on a virtual
# X display (xvfb-run) by --window-script's shot: step 07 with the transfer-function editor,
# step 25 with the camera's widgets. `make screenshots` runs it.
#
#   sh tools/panel_screenshots.sh BUILD FOLDER    (writes FOLDER/panel_NN_name.png)
set -u
build=${1:-build}
folder=${2:-handouts}
command -v xvfb-run > /dev/null 2>&1 || {
    echo "panel_screenshots: xvfb-run is missing (sudo apt-get install -y xvfb xauth)" >&2
    exit 1
}
work=$(mktemp -d) || exit 1
trap 'rm -rf "$work"' EXIT INT TERM

# shoot STEP FLAGS...: one shot of STEP's window, copied to FOLDER/panel_STEP.png
shoot() {
    step=$1
    shift
    # Into out/, the default (no --out on the panel's command line); the shot is copied.
    timeout 60 xvfb-run -a -s "-screen 0 1280x1024x24" "$build/$step" --volume phantom \
        "$@" > "$work/$step.log" 2>&1 || {
        echo "panel_screenshots: $step failed:" >&2
        tail -n 5 "$work/$step.log" >&2
        exit 1
    }
    shot=$(sed -n 's/^window: shot \([^ ]*\) .*/\1/p' "$work/$step.log" | tail -n 1)
    [ -f "$shot" ] || { echo "panel_screenshots: $step took no shot" >&2; exit 1; }
    cp "$shot" "$folder/panel_$step.png"
    echo "panel_screenshots: $folder/panel_$step.png"
}

# Step 07, front view: the table edited (a bluish range added between skin and bone, the skin
# more opaque) and a ray traced, so the editor, the image and the ray panel all show.
shoot 07_back_to_front --view front --window-script \
    "tf:1:from=1200,tf:add,tf:1:colour=4080ff,tf:1:opacity=0.04,tf:0:opacity=0.2,click:128:40,shot,quit"
# Step 25: the camera turned by its widgets (set: goes through the panel's own code).
shoot 25_free_leaping --size 384x384 --window-script \
    "set:azimuth=-35,set:elevation=25,set:projection=perspective,shot,quit"
