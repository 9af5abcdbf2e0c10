#!/bin/sh
# Installs the Debian packages that headless rendering and the GUI tests need, when they are
# missing and we are root. Otherwise says what is missing and carries on: the tests that need
# them skip with a reason.
set -eu
need=""
command -v xvfb-run >/dev/null 2>&1 || need="$need xvfb xauth"
for lib in libEGL.so.1 libGL.so.1 libxkbcommon-x11.so.0 libxcb-cursor.so.0 libxcb-icccm.so.4 \
           libfontconfig.so.1 libdbus-1.so.3; do
    ldconfig -p | grep -q "$lib" || need="$need $lib"
done
[ -z "$need" ] && exit 0
packages="xvfb xauth libegl1 libgl1 libgl1-mesa-dri libegl-mesa0 libxkbcommon-x11-0 \
libxcb-icccm4 libxcb-image0 libxcb-keysyms1 libxcb-render-util0 libxcb-cursor0 libxcb-xinerama0 \
libxcb-randr0 libxcb-shape0 libfontconfig1 libdbus-1-3"
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing system packages for headless OpenGL and Xvfb:$need"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null
    # shellcheck disable=SC2086
    apt-get install -y -qq --no-install-recommends $packages >/dev/null
else
    echo "missing system packages ($need); install: $packages" >&2
fi
