#!/bin/sh
# Installs the Debian packages ctlab needs, if any are missing.
# As root it runs apt-get; otherwise it prints the one sudo command to run and stops.
#   sh tools/install-deps.sh        what building, running and testing the lab needs
#   sh tools/install-deps.sh fuzz   also clang and its libFuzzer runtime (make fuzz)
packages="g++ make pkg-config libsdl2-dev libstb-dev doctest-dev xvfb xauth xdotool python3"
[ "${1:-}" = fuzz ] && packages="$packages clang libclang-rt-dev"
missing=""
for package in $packages; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" \
        || missing="$missing $package"
done
[ -z "$missing" ] && exit 0
if [ "$(id -u)" = 0 ]; then
    echo "ctlab: installing$missing"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq && apt-get install -y -qq $missing >/dev/null || {
        echo "ctlab: apt-get could not install$missing" >&2; exit 1; }
else
    echo "ctlab: missing packages:$missing" >&2
    echo "Run:  sudo apt-get install -y$missing   then run make again." >&2
    exit 1
fi
