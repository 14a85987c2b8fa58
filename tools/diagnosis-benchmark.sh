#!/usr/bin/env bash
# The diagnosis benchmark: 5 hidden effects x 2 strengths and 4 clean cases (two from another
# discretisation than the fit's), each observed and diagnosed from a scene without the effect
# (tools/diagnosis/benchmark.py). Usage: tools/diagnosis-benchmark.sh [BUILD_DIR] [DEVICE]
#   STARTS, ITERATIONS (default 8, 30: ssc diagnose's), ONLY (comma-separated parts of case names), OUT (default build/diagnosis),
#   TIMING=1: only the 360-step timing case (run it with STARTS=16 ITERATIONS=40)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
device=${2:-cpu}
out=${OUT:-$build/diagnosis}
python3 tools/diagnosis/benchmark.py --ssc "$build/bin/ssc" --work "$out" --device "$device" \
  --starts "${STARTS:-8}" --iterations "${ITERATIONS:-30}" --only "${ONLY:-}" --json "$out/results-$device.json" \
  ${TIMING:+--timing}
echo "results: $out/results-$device.json"
