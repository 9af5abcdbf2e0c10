#!/bin/sh
# Runs the test suite. Qt widgets use the offscreen platform; tests that need an OpenGL
# window (marked gl) get a virtual X display from Xvfb when there is no real one.
set -eu
bin=$1
if [ -z "${DISPLAY:-}" ] && command -v xvfb-run >/dev/null 2>&1; then
    exec xvfb-run -a -s "-screen 0 1600x1000x24" "$bin/python" -m pytest
fi
exec "$bin/python" -m pytest
