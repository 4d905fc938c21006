#!/bin/sh
# Installs the Debian packages ctlab needs, if any are missing.
#   sh tools/install-deps.sh        what building, running and testing the lab needs
#   sh tools/install-deps.sh fuzz   also clang and its libFuzzer runtime (make fuzz)
#   sh tools/install-deps.sh peers  also make bench's peers, VolPack and VTK (make bench PEERS=1)
#   sh tools/install-deps.sh fuzz peers   both (CI)
# Required packages build and run the lab; optional ones only serve one test (the window test
# on a virtual display). As root it installs whatever is missing with apt-get. Otherwise a
# missing required package stops here (exit status 1) with the one sudo command to run, and
# missing optional packages get a one-line note: the tests that need them are skipped.
required="g++ make pkg-config libsdl2-dev libstb-dev doctest-dev libimgui-dev"
# The volume formats: nifticlib, teem (NRRD), GDCM (DICOM), zlib; the tests' independent
# writers of those files: nibabel, pydicom, numpy.
required="$required libnifti2-dev libteem-dev libgdcm-dev zlib1g-dev"
required="$required python3-nibabel python3-pydicom python3-numpy"
# The grading sandbox: students' programs are built and run inside bwrap (tools/sandbox.h).
required="$required bubblewrap"
optional="xvfb xauth xdotool python3"  # window tests: virtual X display, real X input,
                                        # a display that never answers (bad_input_test.sh)
for extra in "$@"; do
    case $extra in
        fuzz|peers) ;;
        *) echo "install-deps: unknown list '$extra' (fuzz or peers)" >&2; exit 2 ;;
    esac
done
case " $* " in *" fuzz "*) required="$required clang libclang-rt-dev" ;; esac
# make bench PEERS=1: the peers it times ctlab against (VolPack, VTK's CPU ray caster on a
# virtual X display); without them the bench leaves their rows out.
case " $* " in *" peers "*) required="$required libvolpack1-dev python3-vtk9 xvfb xauth" ;; esac

# missing PACKAGES...: the ones not installed, each with a leading space
missing() {
    for package in "$@"; do
        dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" \
            || printf ' %s' "$package"
    done
}
missing_required=$(missing $required)
missing_optional=$(missing $optional)
[ -z "$missing_required$missing_optional" ] && exit 0

if [ "$(id -u)" = 0 ]; then
    echo "ctlab: installing$missing_required$missing_optional"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq || { echo "ctlab: apt-get update failed" >&2; exit 1; }
    if [ -n "$missing_required" ]; then
        apt-get install -y -qq $missing_required >/dev/null || {
            echo "ctlab: apt-get could not install$missing_required" >&2; exit 1; }
    fi
    if [ -n "$missing_optional" ]; then
        apt-get install -y -qq $missing_optional >/dev/null ||
            echo "ctlab: apt-get could not install the optional$missing_optional;" \
                 "the tests that need them are skipped" >&2
    fi
    exit 0
fi
if [ -n "$missing_required" ]; then
    echo "ctlab: missing packages:$missing_required$missing_optional" >&2
    echo "Run:  sudo apt-get install -y$missing_required$missing_optional   then run make again." >&2
    exit 1
fi
echo "ctlab: optional packages not installed:$missing_optional (the window test skips what" \
     "needs them; sudo apt-get install -y$missing_optional adds them)" >&2
exit 0
