#!/usr/bin/env bash
# Several GPUs and MPI ranks against one GPU (docs/benchmarks.md, "Several GPUs"), on the
# diagnosis timing case (a 360-step, one-camera sequence, tools/diagnosis/benchmark.py --timing):
#   1. ssc diagnose with --gpus 1, 2 and every visible GPU: wall times, and whether
#      diagnosis.json is the same apart from times, the device and the run's folder;
#   2. ssc reconstruct, 32 starts, on 1, 2, 4, ... GPUs up to every visible one: the same check;
#   3. mpirun -n 2 ssc reconstruct (one GPU per rank where there are two) against one process.
# Usage: tools/bench/multi-gpu.sh BUILD_DIR [WORK_DIR]   (STARTS, ITERATIONS: the diagnosis's budget)
set -uo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:?usage: multi-gpu.sh BUILD_DIR [WORK_DIR]}"
work="${2:-/tmp/ssc-multi-gpu}"
ssc="$build/bin/ssc"
gpus=$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | wc -l)
echo "== $gpus GPU(s): $(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | sort | uniq -c | xargs)"
mkdir -p "$work"
same() {  # same JSON apart from times, the device and the run's own folder in messages
  python3 - "$1" "$2" <<'PY'
import json, re, sys
def strip(x):
    if isinstance(x, dict):
        return {k: strip(v) for k, v in x.items() if k not in ("seconds", "wall_seconds", "device", "provenance")}
    if isinstance(x, list):
        return [strip(v) for v in x]
    return re.sub(r"/(diag|fit)-[\w-]+/", "/RUN/", x) if isinstance(x, str) else x
a, b = (strip(json.load(open(p))) for p in sys.argv[1:3])
print("same" if a == b else "DIFFERENT")
PY
}
clock() {  # runs the command, prints its wall time in seconds
  local t=$(date +%s%N); "$@" > "$work/last.log" 2>&1; local rc=$?
  awk -v ns=$(( $(date +%s%N) - t )) 'BEGIN { printf "%.1f", ns / 1e9 }'; return $rc
}

budget="--starts ${STARTS:-8} --iterations ${ITERATIONS:-30}"
for g in $(printf "%s\n" 1 2 "$gpus" | awk -v n="$gpus" '$1 <= n' | sort -nu); do
  python3 "$root/tools/diagnosis/benchmark.py" --ssc "$ssc" --work "$work/diag-g$g" --device cuda --timing \
    ${budget} --diagnose-args "--gpus $g" --json "$work/diag-g$g/results.json" | sed "s/^/gpus $g: /"
done
if [ -n "${FITS_PER_GPU:-}" ]; then  # diagnose's own fits, this many side by side on one GPU (default 2)
  SSC_FITS_PER_GPU=$FITS_PER_GPU python3 "$root/tools/diagnosis/benchmark.py" --ssc "$ssc" --work "$work/diag-g1-f$FITS_PER_GPU" \
    --device cuda --timing ${budget} --diagnose-args "--gpus 1" --json "$work/diag-g1-f$FITS_PER_GPU/results.json" |
    sed "s/^/gpus 1, $FITS_PER_GPU fits at once: /"
fi
case_dir=$(ls -d "$work"/diag-g1/timing* | head -1)
for g in 2 "$gpus"; do
  [ "$g" -gt "$gpus" ] || [ "$g" = 1 ] && continue
  caseN=$(ls -d "$work"/diag-g$g/timing* | head -1)
  echo "diagnosis.json, 1 vs $g GPUs: $(same "$case_dir/diag/diagnosis.json" "$caseN/diag/diagnosis.json")"
done
if [ -n "${FITS_PER_GPU:-}" ]; then
  caseF=$(ls -d "$work"/diag-g1-f$FITS_PER_GPU/timing* | head -1)
  echo "diagnosis.json, 1 GPU, $FITS_PER_GPU fits at once vs one: $(same "$case_dir/diag/diagnosis.json" "$caseF/diag/diagnosis.json")"
fi

fit="reconstruct $case_dir/fit.json --observations $case_dir/obs --fit youngs_modulus --starts 32 --iterations 10 --device cuda --quiet"
for g in 1 2 4 8; do
  [ "$g" -gt "$gpus" ] && break
  s=$(clock "$ssc" $fit --gpus $g --out "$work/fit-g$g") || { echo "reconstruct on $g GPUs failed:"; tail -5 "$work/last.log"; continue; }
  echo "reconstruct, 32 starts, $g GPU(s): $s s; result.json vs 1 GPU: $(same "$work/fit-g1/result.json" "$work/fit-g$g/result.json")"
done
if command -v mpirun > /dev/null; then
  s=$(OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 clock mpirun -n 2 --oversubscribe "$ssc" $fit --out "$work/fit-mpi2") ||
    { echo "mpirun -n 2 failed:"; tail -5 "$work/last.log"; }
  echo "mpirun -n 2 reconstruct: $s s; result.json vs one process on $gpus GPU(s): $(same "$work/fit-g$gpus/result.json" "$work/fit-mpi2/result.json")"
fi
