#!/bin/sh
# peers_test.sh: make bench's peers (tools/peer_volpack.c, tools/peer_vtk.py) render the same
# head from the same side as ctlab, so that their times are for the same picture.
# The phantom, and the phantom with a marker: a bone-bright block at the crown (small k), on
# the patient's right beside the head (large i), near the face (small j). Each renderer draws both; the
# pixels that differ are the marker, and their centre must fall in the same image quadrant as
# in ctlab's picture (a flipped, mirrored or back-side view puts it elsewhere or hides it),
# and near ctlab's (within a tenth of the image). Top view: ctlab's empty-space step (unlit)
# against VolPack's case a and VTK's a and d (maximum intensity); oblique: ctlab's free-camera
# step against both peers' case c. Also: VolPack refuses a volume its table makes fully
# transparent (it crashed rendering one) with one line and status 2.
# A peer that is not installed is skipped with one line (make bench PEERS=1 installs them).
#
#   sh tests/peers_test.sh BUILD      (from the repository root; make test runs it)
set -u
build=${1:?usage: sh tests/peers_test.sh BUILD}
cd "$(dirname "$0")/.." || exit 2
python=/usr/bin/python3  # Debian's, with numpy (and VTK when python3-vtk9 is installed)
work=$(mktemp -d) || exit 2
trap 'rm -rf "$work"' EXIT INT TERM
passed=0
failed=0
pass() { passed=$((passed + 1)); }
fail() { failed=$((failed + 1)); echo "FAIL: $*"; }
finish() { echo "peers test: $passed passed, $failed failed"; [ "$failed" -eq 0 ]; exit $?; }

# The steps, by name (part 2 may be renumbered): as tools/bench.cpp chooses them.
step_named() { for f in steps/[0-9][0-9]_"$1".cpp; do [ -f "$f" ] && basename "$f" .cpp; done | head -n 1; }
top_step=$(step_named empty_space)
camera_step=$(step_named free_camera)
for step in make_phantom "$top_step" "$camera_step"; do
    [ -n "$step" ] && [ -x "$build/$step" ] || { echo "peers test: no $build/${step:-step}"; exit 2; }
done
have_volpack=0
[ -x "$build/peer_volpack" ] && have_volpack=1
have_vtk=0
if $python -c 'import vtk' 2>/dev/null && command -v Xvfb > /dev/null; then have_vtk=1; fi
[ $have_volpack = 1 ] || echo "peers test: SKIPPED VolPack (libvolpack1-dev not installed)"
[ $have_vtk = 1 ] || echo "peers test: SKIPPED VTK (python3-vtk9 or xvfb not installed)"

# The volumes: the phantom (256x256x113) kept at every 4th voxel (64x64x29: the test is
# about where the head is, not how it is sampled, and a small volume keeps it cheap), the
# same with the marker, a fully transparent one.
"$build/make_phantom" "$work/full.raw" > /dev/null || { fail "make_phantom"; finish; }
dims="64 64 29"
$python - "$work" <<'END' || { fail "writing the marked volume"; finish; }
import sys, numpy
work = sys.argv[1]
volume = numpy.fromfile(work + "/full.raw", dtype="<i2").reshape(113, 256, 256)[::4, ::4, ::4]
volume = numpy.ascontiguousarray(volume)
volume.tofile(work + "/plain.raw")
nz, ny, nx = volume.shape
marked = volume.copy()
# The marker: bone (>= 300) at the crown, on the patient's right beside the head (in air seen
# from the top: maximum intensity shows it too), near the face.
marked[0:nz // 6, ny // 6:ny // 3, (nx * 25) // 32:(nx * 29) // 32] = 1500
marked.astype("<i2").tofile(work + "/marked.raw")
numpy.full(volume.shape, -1000, dtype="<i2").tofile(work + "/air.raw")
END

# ctlab: both volumes, top view (unlit composite) and the oblique camera (unlit composite).
for volume in plain marked; do
    "$build/$top_step" --volume "$work/$volume.raw" --dims 64,64,29 --spacing 1,1,1 \
        --view top --unlit --no-window --pfm --threads 2 --out "$work/ctlab_$volume" > /dev/null &&
    "$build/$camera_step" --volume "$work/$volume.raw" --dims 64,64,29 --spacing 1,1,1 \
        --unlit --zoom 1.356 --size 128x128 --no-window --pfm --threads 2 --out "$work/ctlab_$volume" \
        > /dev/null || fail "ctlab's $top_step or $camera_step on $volume.raw"
done

# peer NAME CASE SIZE: renders both volumes into $work/NAME_CASE_{plain,marked}.ppm.
peer() {
    for volume in plain marked; do
        out=$work/$1_$2_$volume.ppm
        if [ "$1" = volpack ]; then
            "$build/peer_volpack" "$work/$volume.raw" $dims "$2" "$3" "$3" 1 "$out"
        else
            DISPLAY=$display $python tools/peer_vtk.py "$work/$volume.raw" $dims "$2" "$3" "$3" 1 \
                "$out" 2
        fi > "$work/$1_$2_$volume.txt" 2>&1 || { fail "$1 case $2 on $volume.raw:" \
            "$(tail -n 1 "$work/$1_$2_$volume.txt")"; return 1; }
        grep -q "^peer=$1 case=$2 .*warm_ms=" "$work/$1_$2_$volume.txt" ||
            { fail "$1 case $2: no summary line"; return 1; }
    done
    pass
}

# same_place LABEL CTLAB_STEM PEER_STEM: the marker where ctlab has it (tests/ sizes alike).
same_place() {
    verdict=$($python - "$work" "$2" "$3" <<'END'
import sys, numpy
work, ctlab, peer = sys.argv[1:4]

def read_pfm(path):
    with open(path, "rb") as f:
        kind, size, scale = f.readline(), f.readline(), f.readline()
        w, h = map(int, size.split())
        order = "<" if float(scale) < 0 else ">"
        data = numpy.frombuffer(f.read(), dtype=order + "f4")
    channels = 3 if kind.strip() == b"PF" else 1
    rows = data.reshape(h, w, channels)[::-1]  # PFM rows run bottom up
    return numpy.clip(rows * 255, 0, 255)

def read_ppm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"P6"
        w, h = map(int, f.readline().split())
        f.readline()
        return numpy.frombuffer(f.read(), dtype=numpy.uint8).reshape(h, w, 3).astype(float)

def marker(plain, marked):
    """Centre (x, y) of the pixels the marker changed, as fractions of the image."""
    changed = numpy.abs(marked - plain).sum(axis=2) > 24
    if changed.sum() < 20:
        return None
    ys, xs = numpy.nonzero(changed)
    h, w = changed.shape
    return (xs.mean() + 0.5) / w, (ys.mean() + 0.5) / h

ours = marker(read_pfm(work + "/ctlab_plain/" + ctlab), read_pfm(work + "/ctlab_marked/" + ctlab))
theirs = marker(read_ppm(work + "/" + peer + "_plain.ppm"), read_ppm(work + "/" + peer + "_marked.ppm"))
if ours is None or theirs is None:
    print("no marker in %s's picture" % ("ctlab" if ours is None else peer))
elif [v > 0.5 for v in ours] != [v > 0.5 for v in theirs]:
    print("marker at (%.2f, %.2f) of the image, ctlab's at (%.2f, %.2f): another quadrant "
          "(flipped, mirrored or seen from another side)" % (theirs + ours))
elif max(abs(a - b) for a, b in zip(ours, theirs)) > 0.1:
    print("marker at (%.2f, %.2f) of the image, ctlab's at (%.2f, %.2f): too far" % (theirs + ours))
else:
    print("ok")
END
)
    if [ "$verdict" = ok ]; then pass; else fail "$1: $verdict"; fi
}

top_picture=${top_step}_top.pfm
camera_picture=${camera_step}_camera.pfm
if [ $have_volpack = 1 ]; then
    peer volpack a 64 && same_place "VolPack top view (case a)" "$top_picture" volpack_a
    peer volpack c 128 && same_place "VolPack oblique (case c)" "$camera_picture" volpack_c
    # Fully transparent under the classic table: refused, one line, status 2, no picture.
    "$build/peer_volpack" "$work/air.raw" $dims a 64 64 1 "$work/air.ppm" > "$work/air.txt" 2>&1
    status=$?
    if [ $status = 2 ] && [ "$(wc -l < "$work/air.txt")" = 1 ] && [ ! -e "$work/air.ppm" ]; then
        pass
    else
        fail "VolPack on a fully transparent volume: status $status, $(cat "$work/air.txt")"
    fi
    # Bad input: a case it has not (maximum intensity), a file of the wrong size.
    "$build/peer_volpack" "$work/plain.raw" $dims d 64 64 1 "$work/d.ppm" > /dev/null 2>&1
    [ $? = 2 ] && pass || fail "VolPack case d (it has no maximum intensity): not status 2"
    "$build/peer_volpack" "$work/plain.raw" 64 64 28 a 64 64 1 "$work/x.ppm" > /dev/null 2>&1
    [ $? = 2 ] && pass || fail "VolPack on a file of the wrong size: not status 2"
fi
if [ $have_vtk = 1 ]; then
    # One X server for every VTK run (-displayfd: a free display, no race with other suites'
    # servers; -noreset: no reset between two clients that would refuse the next one).
    Xvfb -displayfd 3 -nolisten tcp -noreset 3> "$work/xdisplay" > /dev/null 2>&1 &
    xvfb=$!
    trap 'kill $xvfb 2> /dev/null; rm -rf "$work"' EXIT INT TERM
    tries=0
    while [ ! -s "$work/xdisplay" ] && [ $tries -lt 400 ]; do sleep 0.05; tries=$((tries + 1)); done
    display=:$(cat "$work/xdisplay")
    peer vtk a 64 && same_place "VTK top view (case a)" "$top_picture" vtk_a
    peer vtk d 64 && same_place "VTK maximum intensity, top view (case d)" "$top_picture" vtk_d
    peer vtk c 128 && same_place "VTK oblique (case c)" "$camera_picture" vtk_c
fi
finish
