#!/usr/bin/env bash
# Reproduces the paper's experiments with ssc and writes docs/paper-comparison.md.
#   tools/paper-experiments.sh            the reduced set (the base torus row, 4 starts; CPU-sized)
#   tools/paper-experiments.sh --full     every row: the torus rows (20 starts x 40 iterations unless
#                                         STARTS/ITERATIONS say otherwise), the six ball settings, the
#                                         ball optimiser rows, the multi-parameter ball, the dragon
#                                         (minutes on a GPU, hours on a CPU)
#   ONLY="res20 cams4" tools/paper-experiments.sh --full   just those rows (added to earlier runs)
#   STARTS=N ITERATIONS=K override the counts.
# Each configuration renders its observations (out/paper/<name>-obs), reconstructs from
# perturbed starts (out/paper/<name>-fit) and is summarised by tools/paper_comparison.py: how
# many starts converged and the mean relative error of those.
set -euo pipefail
# SSC_ROOT=dir: the checkout to run in (for a copy of this script run from elsewhere, so that
# editing the script does not disturb a long run: bash reads scripts as it goes)
root="${SSC_ROOT:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}"
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

# Rows on other scenes: name, scene, fitted parameters, starts, iterations, a description
# (no spaces), then --set arguments; recorded in scenes.txt.
run_scene() {
  local name=$1 scene=$2 fit=$3 n=$4 k=$5 desc=$6
  shift 6
  if [ -n "$only" ] && [[ " $only " != *" $name "* ]]; then return; fi
  echo "== $name: $scene, fitting $fit, $n starts x $k iterations ($desc)"
  local sets=() args=("$@") i
  for ((i = 0; i < ${#args[@]}; i++)); do  # the scene overrides also shape the observations
    if [ "${args[i]}" = --set ]; then sets+=(--set "${args[i + 1]}"); i=$((i + 1)); fi
  done
  $ssc observe "$scene" --out "$out/$name-obs" "${sets[@]}" >/dev/null
  $ssc reconstruct "$scene" --observations "$out/$name-obs" --fit "$fit" --starts "$n" --iterations "$k" --seed 7 \
    --device "$device" --out "$out/$name-fit" "$@" | tail -2
  grep -v "^$name " "$out/scenes.txt" >"$out/scenes.tmp" 2>/dev/null || true
  echo "$name $scene $fit $n $k $desc" >>"$out/scenes.tmp"
  mv "$out/scenes.tmp" "$out/scenes.txt"
}

# The paper's six ball settings: ground tilt (polar 0-25 degrees, any azimuth), ground height
# and initial velocity drawn once with a fixed seed.
ball_settings() {
  python3 - <<'PY'
import random
rng = random.Random(2020)
for k in range(6):
    polar, azimuth = rng.uniform(0, 25), rng.uniform(0, 360)
    height = rng.uniform(-0.03, 0.01)
    v = [rng.uniform(-1, 1), rng.uniform(-2, -0.5), rng.uniform(-1, 1)]
    print(f"{polar:.1f} {azimuth:.0f} {height:.3f} {v[0]:.2f} {v[1]:.2f} {v[2]:.2f}")
PY
}

[ -n "$only" ] || rm -f "$out/runs.txt" "$out/scenes.txt"
run base 1 50 0.01 0.4
if [ "$mode" = full ]; then
  for n in 2 4 8; do run "cams$n" "$n" 50 0.01 0.4; done
  for r in 20 100 200; do run "res$r" 1 "$r" 0.01 0.4; done
  for s in 0.001 0.1; do run "noise$s" 1 50 "$s" 0.4; done
  for p in 0.2 0.8; do run "phimax$p" 1 50 0.01 "$p"; done
  for opt in gd lbfgs rprop-paper; do run "opt-$opt" 1 50 0.01 0.4 --optimizer "$opt"; done
  run fd-rprop 1 50 0.01 0.4 --gradient fd
  # The ball on a stiff penalty ground (stiffness 1e6 N/m^2 per unit area, soft-min 200 /m) and,
  # rows "-soft", on the torus example's ground (1e5, 50 /m).
  for ground_kind in stiff soft; do
    if [ $ground_kind = stiff ]; then contact='"stiffness":1e6,"softmin_alpha":200'; suffix=""; else
      contact='"stiffness":1e5,"softmin_alpha":50'; suffix="-soft"; fi
    k=0
    while read -r polar azimuth height vx vy vz; do
      ground="{\"angles_deg\":[$polar,$azimuth],\"height\":$height,$contact}"
      sets=(--set "ground=$ground" --set "initial.linear_velocity=[$vx,$vy,$vz]")
      [ $k -eq 0 ] && [ $ground_kind = stiff ] && ball0_sets=("${sets[@]}")
      run_scene "ball$k$suffix" examples/paper-ball.json youngs_modulus 20 30 \
        "${ground_kind}_ground;polar=${polar},azimuth=${azimuth},height=${height};v0=($vx,$vy,$vz)" "${sets[@]}"
      k=$((k + 1))
    done < <(ball_settings)
  done
  for opt in gd lbfgs; do
    run_scene "ball0-$opt" examples/paper-ball.json youngs_modulus 20 30 "setting_of_ball0;optimizer_$opt" \
      "${ball0_sets[@]}" --optimizer "$opt"
  done
  run_scene ball-multi examples/paper-ball.json gravity.y,youngs_modulus,stiffness_damping 60 20 "stiff_flat_ground;v0=(0.5,-1.5,0)"
  run_scene ball-multi-soft examples/paper-ball.json gravity.y,youngs_modulus,stiffness_damping 60 20 \
    "soft_flat_ground;v0=(0.5,-1.5,0)" --set 'ground={"height":0,"normal":[0,1,0],"stiffness":1e5,"softmin_alpha":50}'

  dragon_obs='{"every":1,"noise":0.002,"seed":42,"depth_scale":0.0001,"phi_max":0.03,"cameras":[{"name":"side","width":50,"height":50,"fov_deg":50,"eye":[0.9,0.45,0.2],"target":[0,0.2,0],"min_depth":0.1,"max_depth":3}]}'
  run_scene dragon examples/dragon.json youngs_modulus 20 30 "fixed_base;10_steps;1_camera_50x50" \
    --set "observation=$dragon_obs" --set time.steps=10
fi
python3 tools/paper_comparison.py "$out" "$mode" "$starts" "$iterations" >docs/paper-comparison.md
echo "wrote docs/paper-comparison.md"
