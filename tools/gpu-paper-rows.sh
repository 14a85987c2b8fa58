#!/usr/bin/env bash
# On a GPU machine: builds with tools/device-check.sh (tests only) and runs the rows of
# tools/paper-experiments.sh named in ROWS on the GPU (20 starts x 30 iterations for the torus
# rows), packing each row's result.json and the run lists into $OUT/paper.tgz as it goes (for
# the device tool; merge them into out/paper/ here and rerun tools/paper_comparison.py).
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-out/gpu-rows}
mkdir -p "$OUT"
BENCH= tools/device-check.sh >"$OUT/device-check.txt" 2>&1 || { tail -30 "$OUT/device-check.txt"; exit 1; }
grep -E "passed/|FAILED" "$OUT/device-check.txt"
for row in ${ROWS:?name the rows}; do
  SSC=build-gpu/bin/ssc DEVICE=cuda STARTS=${STARTS:-20} ITERATIONS=${ITERATIONS:-30} ONLY="$row" \
    tools/paper-experiments.sh --full 2>&1 | grep -v "^ssc: running"
  tar czf "$OUT/paper.tgz" out/paper/*-fit/result.json out/paper/*.txt
done
