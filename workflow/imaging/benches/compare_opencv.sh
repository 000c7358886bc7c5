#!/usr/bin/env bash
# Ours against OpenCV 4.14 on the same 1024² pair, interleaved: each round runs opencv_akaze.py, then the
# feature table of `cargo bench -p plumbline-imaging -- features` with the OpenCV columns filled from it.
# Usage: benches/compare_opencv.sh [rounds] (default 3), with PYTHON pointing at a python that has
# opencv-python-headless<5 (default /tmp/cv/bin/python). Reports the load (uptime) before each round.
set -euo pipefail
rounds=${1:-3}
python=${PYTHON:-/tmp/cv/bin/python}
here=$(cd "$(dirname "$0")" && pwd)
results=$(mktemp)
trap 'rm -f "$results"' EXIT
cargo bench -p plumbline-imaging --no-run >/dev/null 2>&1
for round in $(seq "$rounds"); do
    echo "## round $round — $(uptime)"
    "$python" "$here/opencv_akaze.py" --tsv "$results"
    OPENCV_RESULTS="$results" cargo bench -q -p plumbline-imaging --bench imaging -- features 2>/dev/null
done
