#!/bin/bash
# A/B of the step benchmarks between a base revision and the working tree, on one machine:
# both built Release side by side, three interleaved runs, the minimum of each printed.
#   git archive REV | gzip > base.tar.gz; tools/bench/ab-steps.sh base.tar.gz [OUTDIR]
# (on the device machine: carry the archive, OUTDIR=$OUT).
set -u
BASE_TAR=${1:?usage: ab-steps.sh BASE.tar.gz [OUTDIR]}
OUTDIR=${2:-${OUT:-/tmp}}
BASE=$(mktemp -d)
tar xzf "$BASE_TAR" -C "$BASE"
( cmake -S "$BASE" -B "$BASE/build" -DCMAKE_BUILD_TYPE=Release > /dev/null 2>&1 &&
  cmake --build "$BASE/build" -j8 --target ssc_bench > /dev/null 2>&1; echo "base build rc $?" ) &
( cmake -S . -B build-gpu -DCMAKE_BUILD_TYPE=Release > /dev/null 2>&1 &&
  cmake --build build-gpu -j8 --target ssc_bench > /dev/null 2>&1; echo "new build rc $?" ) &
wait
F=${FILTER:-'CpuForwardStep|CpuGradientStep|GpuGradientStep|GpuForwardStep/.*/double|GpuAdjointStep/.*/double'}
: > "$OUTDIR/ab.txt"
for r in 1 2 3; do
  for v in base new; do
    b=$BASE/build/bin/ssc_bench; [ $v = new ] && b=build-gpu/bin/ssc_bench
    $b --benchmark_min_time=0.1s --benchmark_filter="$F" 2>/dev/null | grep -E "^(Cpu|Gpu)" |
      awk -v v=$v '{print v, $1, $2, $3}' >> "$OUTDIR/ab.txt"
  done
done
python3 - "$OUTDIR/ab.txt" <<'PY'
import sys, collections
m = collections.defaultdict(lambda: collections.defaultdict(list))
for l in open(sys.argv[1]):
    v, k, t, u = l.split()[:4]
    m[k][v].append(float(t) * {'us': 1e-3, 'ms': 1, 's': 1e3}.get(u, 1))
for k in sorted(m):
    if m[k]['base'] and m[k]['new']:
        b, n = min(m[k]['base']), min(m[k]['new'])
        print(f"{k:48s} base {b:9.3f} new {n:9.3f} ms {100*(n/b-1):+6.1f} %")
PY
