#!/usr/bin/env bash
# Ours against OpenCV 4.14 on the same 1024² pair, interleaved: each round runs opencv_akaze.py, then the
# feature and matching tables of `cargo bench -p plumbline-imaging -- features matching` with the OpenCV columns
# filled from it. The matching rows time OpenCV's BFMatcher on our own descriptors (exported once), of the
# "graf" pair when PLUMBLINE_GRAF_DIR names a folder with img1.ppm and img2.ppm, else of the synthetic pair.
# Usage: benches/compare_opencv.sh [rounds] (default 3), with PYTHON pointing at a python that has
# opencv-python-headless<5 (default /tmp/cv/bin/python). Reports the load (uptime) before each round.
set -euo pipefail
rounds=${1:-3}
python=${PYTHON:-/tmp/cv/bin/python}
here=$(cd "$(dirname "$0")" && pwd)
results=$(mktemp)
descriptors=$(mktemp -d)
trap 'rm -rf "$results" "$descriptors"' EXIT
cargo bench -p plumbline-imaging --no-run >/dev/null 2>&1
cargo bench -q -p plumbline-imaging --bench imaging -- export-descriptors "$descriptors" 2>/dev/null
for round in $(seq "$rounds"); do
    echo "## round $round — $(uptime)"
    "$python" "$here/opencv_akaze.py" --tsv "$results" --match "$descriptors"
    OPENCV_RESULTS="$results" cargo bench -q -p plumbline-imaging --bench imaging -- features matching 2>/dev/null
done
