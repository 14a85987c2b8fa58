#!/usr/bin/env bash
# Builds ssc on a GPU machine (Ubuntu 24.04, CUDA 13, CMake >= 3.20, no network needed)
# into build-gpu/, runs the code-generator and GPU tests, the benchmark binary and the
# end-to-end reconstruction timing (tools/bench/reconstruct-timing.sh), and prints a short
# summary table last. Usage: tools/device-check.sh [extra gtest filter]
#   BENCH=regex   only the benchmarks matching it (default: all); BENCH= skips them and the
#                 reconstruction timing
set -uo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BUILD=$ROOT/build-gpu
JOBS=$(nproc 2>/dev/null || echo 4)
LOG=$BUILD/device-check
mkdir -p "$LOG"
export SSC_KERNEL_CACHE=${SSC_KERNEL_CACHE:-$BUILD/kernel-cache}
export SSC_DUMP_KERNELS=${SSC_DUMP_KERNELS:-$LOG/kernels}

echo "== GPU"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null || echo "(nvidia-smi unavailable)"
echo "== configure + build ($JOBS jobs)"
t0=$(date +%s)
if ! cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DCUDAToolkit_ROOT=${CUDA_HOME:-/usr/local/cuda} \
     >"$LOG/cmake.log" 2>&1; then
  tail -30 "$LOG/cmake.log"; echo "configure failed"; exit 1
fi
if ! cmake --build "$BUILD" -j"$JOBS" >"$LOG/build.log" 2>&1; then
  grep -E "error|Error" "$LOG/build.log" | head -30; echo "build failed"; exit 1
fi
t1=$(date +%s)

FILTER='Codegen*:Nvrtc*:Gpu*:BatchEvaluation*'${1:+:$1}
echo "== tests: $FILTER"
"$BUILD/bin/ssc_tests" --gtest_filter="$FILTER" --gtest_output=json:"$LOG/tests.json" 2>&1 | tee "$LOG/tests.txt"
test_rc=${PIPESTATUS[0]}

bench_rc=-
BENCH=${BENCH-.}
if [ -x "$BUILD/bin/ssc_bench" ] && [ -n "$BENCH" ]; then
  echo "== benchmarks ($BENCH)"
  "$BUILD/bin/ssc_bench" --benchmark_min_time=0.05s --benchmark_filter="$BENCH" 2>&1 | tee "$LOG/bench.txt"
  bench_rc=${PIPESTATUS[0]}
fi

if [ -n "$BENCH" ]; then
  echo "== end-to-end reconstruction (torus demo)"
  tools/bench/reconstruct-timing.sh "$BUILD" 2>&1 | tee "$LOG/reconstruct.txt"
fi

echo "== kernel table (ssc kernels)"
"$BUILD/bin/ssc" kernels "$ROOT/examples/torus.json" --out "$LOG/kernels-torus" 2>&1 | tail -60 | tee "$LOG/kernels.txt"

passed=$(grep -c '^\[       OK \]' "$LOG/tests.txt")
# gtest lists failed and skipped tests twice; the timed line is counted once.
failed=$(grep -c '^\[  FAILED  \] [A-Za-z].*ms)$' "$LOG/tests.txt")
skipped=$(grep -c '^\[  SKIPPED \] [A-Za-z].*ms)$' "$LOG/tests.txt")
echo
echo "================ device check summary ================"
printf "%-28s %s\n" "build time" "$((t1 - t0)) s"
printf "%-28s %s\n" "tests passed/failed/skipped" "$passed/$failed/$skipped (rc $test_rc)"
printf "%-28s %s\n" "benchmarks" "$bench_rc"
grep -E "^\[ (double|float) \]" "$LOG/tests.txt" | sed 's/^/  /'
if [ -f "$LOG/bench.txt" ] && [ "$bench_rc" != "-" ]; then
  # Steps at batch 1 and 32 with their ratio, and the GPU's measured ceilings.
  awk '/^Gpu(Forward|Adjoint)Step\// { split($1, p, "/"); k = p[1] "/" p[2] "/" p[3]; t[k, p[4]] = $2; keys[k] = 1 }
       /^GpuRate\// { print "  " $0 }
       END { for (k in keys) if (t[k, 1] != "" && t[k, 32] != "")
               printf "  %-34s batch 1 %7s ms  batch 32 %7s ms  (%.1fx)\n", k, t[k, 1], t[k, 32], t[k, 32] / t[k, 1] }' \
      "$LOG/bench.txt" | sort
fi
[ -n "$BENCH" ] && grep -E "^reconstruct" "$LOG/reconstruct.txt" | sed 's/^/  /'
grep -E "ms/launch" "$LOG/kernels.txt" | head -40 | sed 's/^/  /'
exit "$test_rc"
