#!/usr/bin/env bash
# The diagnosis benchmark: 5 hidden effects x 2 strengths, 3 measurement errors and 4 clean cases
# (two from another discretisation than the fit's), each observed and diagnosed from a scene
# without the effect (tools/diagnosis/benchmark.py); with CALCULIX, also the independent set
# rendered from CalculiX (tools/calculix/drops.sh's output folder). Prints each set's confusion
# matrix. Usage: tools/diagnosis-benchmark.sh [BUILD_DIR] [DEVICE]
#   STARTS, ITERATIONS (default 8, 30: ssc diagnose's), ONLY (comma-separated parts of case names), OUT (default build/diagnosis),
#   CALCULIX=DIR: the independent set as well; TIMING=1: only the 360-step timing case (run it with STARTS=16 ITERATIONS=40)
#   JOBS: diagnoses at once (default 1), GPUS: comma-separated GPU ids they share out (e.g. JOBS=4 GPUS=0,1)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
device=${2:-cpu}
out=${OUT:-$build/diagnosis}
run() {  # $1: results file, then benchmark.py's own options
  local results=$1; shift
  python3 tools/diagnosis/benchmark.py --ssc "$build/bin/ssc" --work "$out" --device "$device" \
    --starts "${STARTS:-8}" --iterations "${ITERATIONS:-30}" --only "${ONLY:-}" --jobs "${JOBS:-1}" --gpus "${GPUS:-}" \
    --json "$results" "$@"
}
run "$out/results-$device.json" ${TIMING:+--timing}
sets=("$out/results-$device.json")
if [ -n "${CALCULIX:-}" ] && [ -z "${TIMING:-}" ]; then
  run "$out/results-calculix-$device.json" --calculix "$CALCULIX"
  sets+=("$out/results-calculix-$device.json")
fi
for results in "${sets[@]}"; do
  echo; echo "confusion matrix, $results:"
  python3 tools/diagnosis/benchmark.py --confusion "$results"
done
