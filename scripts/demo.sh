#!/bin/sh
# The demo: render a synthetic horse canter, analyse its silhouettes, pose the
# chosen key-images with the true poses, animate, and report how close the result is.
set -eu
bin=$1
out=$2
export PYOPENGL_PLATFORM="${PYOPENGL_PLATFORM:-egl}"
"$bin/gaitcore" synth --gait canter --frames 100 --out "$out/clip" --overwrite
"$bin/gaitcore" analyze "$out/clip/masks" --out "$out/analysis" --keys 4 --pcs 2
"$bin/python" scripts/demo_pose_keys.py "$out/analysis/analysis.json" "$out/clip/poses.csv" "$out/keys.csv"
"$bin/gaitcore" animate "$out/analysis/analysis.json" --key-poses "$out/keys.csv" \
    --out "$out/curves.csv" --bvh "$out/canter.bvh" --skeleton "$out/clip/skeleton.json"
"$bin/python" scripts/demo_pose_keys.py --compare "$out/curves.csv" "$out/clip/poses.csv" "$out/clip/skeleton.json"
echo "headless run written to $out (curves.csv, canter.bvh, analysis/analysis.json, clip/images)"
# Then the application on the same clip, keys posed, the animation ready: a window when
# there is a display, else a screenshot of the loaded main window.
"$bin/python" scripts/demo_pose_keys.py --project "$out/clip" "$out/keys.csv" "$out/canter.gaitproj"
if [ -n "${DISPLAY:-}" ] || [ -n "${WAYLAND_DISPLAY:-}" ]; then
    "$bin/gaitstudio" "$out/canter.gaitproj"
elif command -v xvfb-run >/dev/null 2>&1; then
    # A virtual display gives the 3D viewport an OpenGL context too.
    xvfb-run -a -s "-screen 0 1600x1000x24" "$bin/gaitstudio" "$out/canter.gaitproj" --screenshot "$out/gaitstudio.png"
    echo "no display: saved the Gait Studio window to $out/gaitstudio.png"
else
    QT_QPA_PLATFORM=offscreen "$bin/gaitstudio" "$out/canter.gaitproj" --screenshot "$out/gaitstudio.png"
    echo "no display: saved the Gait Studio window to $out/gaitstudio.png"
fi
