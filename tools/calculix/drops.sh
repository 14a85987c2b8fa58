#!/usr/bin/env bash
# CalculiX drop scenes for ssc (tools/calculix/drops.py): runs ccx on each case, writes the
# surface PLY frames (60 Hz), the matching ssc scene and renders them with `ssc render`.
# Needs ccx 2.20 (Debian: apt-get install -y calculix-ccx), python3 and a built ssc.
# One ccx process per case, single-threaded.
#
#   tools/calculix/drops.sh [OUT, default out/calculix_drops] [drops.py options, e.g. --cases clean]
#   tools/calculix/drops.sh --test-data    # the small set kept in tests/data/calculix_drops
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
ssc="${SSC:-$root/build/bin/ssc}"

command -v ccx >/dev/null 2>&1 || { echo "drops.sh: ccx not found (Debian/Ubuntu: apt-get install -y calculix-ccx)" >&2; exit 1; }
command -v python3 >/dev/null 2>&1 || { echo "drops.sh: python3 not found" >&2; exit 1; }
[ -x "$ssc" ] || { echo "drops.sh: $ssc not found; build it (tools/setup-build) or set SSC=path/to/ssc" >&2; exit 1; }

export OMP_NUM_THREADS=1
export CCX_NPROC_STIFFNESS=1 CCX_NPROC_EQUATION_SOLVER=1 CCX_NPROC_RESULTS=1

if [ "${1:-}" = "--test-data" ]; then
    # 12 frames (0.2 s) of the clean case on the coarse mesh; only what the test reads is kept
    out="$root/tests/data/calculix_drops"
    tmp="$(mktemp -d)"
    python3 "$here/drops.py" "$tmp" --cases clean --elements 3 --duration 0.2 --ssc "$ssc"
    rm -rf "$out/clean"
    mkdir -p "$out/clean"
    cp -r "$tmp/clean/obs" "$tmp/clean/frames" "$tmp/clean/scene.json" "$tmp/clean/ccx_run.json" "$tmp/clean/drop_clean.inp" \
          "$tmp/clean/mesh_clean.inp" "$out/clean/"
    # the friction slides, whole (0.2 s): their scene and surface frames (tests/test_calculix_friction.cpp)
    python3 "$here/drops.py" "$tmp" --cases friction,friction_low --elements 3 --jobs 2
    for c in friction friction_low; do
        rm -rf "$out/$c"
        mkdir -p "$out/$c"
        cp -r "$tmp/$c/frames" "$tmp/$c/scene.json" "$out/$c/"
    done
    # the friction slide (mu 0.5) with 6 elements a 0.2 m edge: its scene and surface frames
    # (CalculixDropsFit.AOneStartFitThatStallsOnARoughCostGoesOnAndIsNotCalledConverged)
    python3 "$here/drops.py" "$tmp/six" --cases friction --elements 6
    rm -rf "$out/friction_6"
    mkdir -p "$out/friction_6"
    cp -r "$tmp/six/friction/frames" "$tmp/six/friction/scene.json" "$out/friction_6/"
    # the cylinder (a third shape, clean) with 6 elements, whole (0.35 s): its scene and surface frames
    # (CalculixDropsFit.ACylinderDroppedOnTheInclineFitsCalculixsModulus)
    python3 "$here/drops.py" "$tmp/six" --cases cylinder --elements 6
    rm -rf "$out/cylinder"
    mkdir -p "$out/cylinder"
    cp -r "$tmp/six/cylinder/frames" "$tmp/six/cylinder/scene.json" "$tmp/six/cylinder/ccx_run.json" "$out/cylinder/"
    # the two-material cube, whole (0.35 s): scene, surface frames and their render with 1 mm noise
    # (tests/test_calculix_two_materials.cpp)
    python3 "$here/drops.py" "$tmp" --cases two_materials --elements 3
    rm -rf "$out/two_materials"
    mkdir -p "$out/two_materials"
    cp -r "$tmp/two_materials/frames" "$tmp/two_materials/scene.json" "$tmp/two_materials/ccx_run.json" "$out/two_materials/"
    "$ssc" render "$out/two_materials/frames" --cameras "$out/two_materials/scene.json" --fps 60 --noise 0.001 --seed 7 \
        --out "$out/two_materials/obs"
    rm -rf "$tmp"
    echo "drops.sh: wrote $out/clean, $out/friction, $out/friction_low, $out/two_materials"
    exit 0
fi

out="${1:-$root/out/calculix_drops}"
[ $# -gt 0 ] && shift
python3 "$here/drops.py" "$out" --ssc "$ssc" "$@"
