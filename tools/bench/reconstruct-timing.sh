#!/usr/bin/env bash
# End-to-end reconstruction time of the README's torus demo (Young's modulus from one 50x50
# depth camera, L-BFGS, 20 iterations) on the CPU and the GPU, and with 32 starts on the GPU.
# Usage: tools/bench/reconstruct-timing.sh [build dir, default build-gpu]
set -euo pipefail
cd "$(dirname "$0")/../.."
ssc=${1:-build-gpu}/bin/ssc
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$ssc" observe examples/torus.json --out "$tmp/obs" >/dev/null
for run in "cpu 4" "cuda 4" "cuda 32"; do
  set -- $run
  if ! "$ssc" reconstruct examples/torus.json --observations "$tmp/obs" --fit youngs_modulus \
       --set material.youngs_modulus=2000 --starts "$2" --iterations 20 --optimizer lbfgs --device "$1" \
       --out "$tmp/fit-$1-$2" >"$tmp/log" 2>&1; then
    tail -5 "$tmp/log"
    continue
  fi
  python3 -c "import json, sys; d = json.load(open(sys.argv[1])); \
print(f\"reconstruct --device {sys.argv[2]:4} --starts {sys.argv[3]:>2}: {d['wall_seconds']:6.2f} s, \
{d['evaluations']} evaluations, E = {d['parameters']['youngs_modulus']:.2f} Pa\")" \
    "$tmp/fit-$1-$2/result.json" "$1" "$2"
done
