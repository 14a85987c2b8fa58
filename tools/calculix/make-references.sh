#!/usr/bin/env bash
# Regenerates the CalculiX reference results in tests/data/calculix/ from scratch:
# input decks + meshes (20-node hexahedra), one JSON result file per case and
# the README with the numbers.  Needs ccx (Debian: apt-get install calculix-ccx)
# and python3 (standard library only).  Runs single-threaded, about a minute.
#
#   tools/calculix/make-references.sh [output folder, default tests/data/calculix]
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="${1:-$root/tests/data/calculix}"

if ! command -v ccx >/dev/null 2>&1; then
    echo "make-references.sh: ccx not found (Debian/Ubuntu: apt-get install -y calculix-ccx)" >&2
    exit 1
fi
command -v python3 >/dev/null 2>&1 || { echo "make-references.sh: python3 not found" >&2; exit 1; }

export OMP_NUM_THREADS=1
export CCX_NPROC_STIFFNESS=1 CCX_NPROC_EQUATION_SOLVER=1 CCX_NPROC_RESULTS=1

mkdir -p "$out"
python3 "$here/references.py" "$out"
echo "make-references.sh: wrote $(ls "$out" | wc -l) files to $out ($(ccx -v 2>&1 | grep -o 'Version.*'))"
