#!/usr/bin/env bash
# Reproduces the paper's torus experiments with ssc and writes docs/paper-comparison.md.
#   tools/paper-experiments.sh            the reduced set (one configuration per sweep, 4 starts; CPU-sized)
#   tools/paper-experiments.sh --full     every row, 20 starts x 40 iterations (hours on a CPU)
#   ONLY="res20 cams4" tools/paper-experiments.sh --full   just those rows (added to earlier runs)
#   STARTS=N ITERATIONS=K override the counts.
# Each configuration renders its observations (out/paper/<name>-obs), reconstructs Young's
# modulus from perturbed starts (out/paper/<name>-fit) and is summarised by
# tools/paper_comparison.py: how many starts converged (within 10 % of 5000 Pa) and the mean
# relative error of those.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
mode=reduced
[ "${1:-}" = "--full" ] && mode=full
# SSC=path: a built (or copied) binary, so that rebuilding does not change a long run
[ -n "${SSC:-}" ] || "$root/tools/setup-build" --target ssc >/dev/null
ssc=${SSC:-build/bin/ssc}
device=${DEVICE:-auto}  # DEVICE=cpu|cuda|auto: where the reconstructions run
out=out/paper
mkdir -p "$out"
if [ "$mode" = full ]; then starts=20; iterations=40; else starts=4; iterations=20; fi
starts=${STARTS:-$starts}
iterations=${ITERATIONS:-$iterations}
only=${ONLY:-}

# camera k of n on a ring around the torus, 30 degrees above the horizon, 50x50 unless given
cameras() {
  local n=$1 res=$2
  python3 - "$n" "$res" <<'PY'
import json, math, sys
n, res = int(sys.argv[1]), int(sys.argv[2])
cams = []
for k in range(n):
    a = 2 * math.pi * k / n + 0.66
    eye = [5.7 * math.cos(a) * math.cos(math.radians(20)), 1.0 + 5.7 * math.sin(math.radians(20)), 5.7 * math.sin(a) * math.cos(math.radians(20))]
    cams.append({"name": f"cam{k}", "width": res, "height": res, "fov_deg": 45, "eye": eye, "target": [0, 1.0, 0],
                 "min_depth": 0.5, "max_depth": 12})
print(json.dumps(cams))
PY
}

run() {  # name, cameras, resolution, noise, phi_max, [reconstruct options...]
  local name=$1 ncam=$2 res=$3 noise=$4 phi=$5
  shift 5
  local extra=("$@")
  if [ -n "$only" ] && [[ " $only " != *" $name "* ]]; then return; fi
  local sets=(--set "observation.cameras=$(cameras "$ncam" "$res")" --set "observation.noise=$noise"
              --set "observation.phi_max=$phi")
  echo "== $name: $ncam camera(s), ${res}x${res}, noise $noise m, phi_max $phi m, $starts starts x $iterations iterations"
  $ssc observe examples/torus.json --out "$out/$name-obs" "${sets[@]}" >/dev/null
  $ssc reconstruct examples/torus.json --observations "$out/$name-obs" --fit youngs_modulus \
    --starts "$starts" --iterations "$iterations" --seed 7 --device "$device" --out "$out/$name-fit" "${sets[@]}" "${extra[@]}" | tail -2
  grep -v "^$name " "$out/runs.txt" >"$out/runs.tmp" 2>/dev/null || true
  echo "$name $ncam $res $noise $phi $starts $iterations ${extra[*]}" >>"$out/runs.tmp"
  mv "$out/runs.tmp" "$out/runs.txt"
}

[ -n "$only" ] || rm -f "$out/runs.txt"
run base 1 50 0.01 0.4
if [ "$mode" = full ]; then
  for n in 2 4 8; do run "cams$n" "$n" 50 0.01 0.4; done
  for r in 20 100 200; do run "res$r" 1 "$r" 0.01 0.4; done
  for s in 0.001 0.1; do run "noise$s" 1 50 "$s" 0.4; done
  for p in 0.2 0.8; do run "phimax$p" 1 50 0.01 "$p"; done
  for opt in gd lbfgs rprop-paper; do run "opt-$opt" 1 50 0.01 0.4 --optimizer "$opt"; done
  run fd-rprop 1 50 0.01 0.4 --gradient fd
fi
python3 tools/paper_comparison.py "$out" "$mode" "$starts" "$iterations" >docs/paper-comparison.md
echo "wrote docs/paper-comparison.md"
