#!/usr/bin/env bash
# ssc against the plain JAX implementation it must beat (issue 27), in one call on one GPU: the
# peer's table phase on its dragon (forward and jax.grad, f64 and f32, batch 1 and 32) and ssc's
# step benchmarks on the identical scene (the peer's ssc-scene-dragon.json; the CPU steps too),
# then the ratio table of docs/benchmarks.md. The peer has no band extension: its step is
# ssc's unobserved step, which the ratios compare. Both forward figures are averages over a
# 40-step trajectory from rest (the peer's rollout, ssc's GpuUnobservedRollout). Both gradient
# figures are J = sum |u_T|^2 after the 40 steps with its gradient, forward and backward, per
# step (the peer's jax.grad, ssc's GpuTrajectoryGradient: the adjoint solves warm-start from
# the later step's solution, the peer's transposed solves from zero). Beside them: the rollout
# plus one adjoint step from a cold start (GpuUnobservedAdjointStep, the table's measure before
# 2026-11-28) and the observed step (GpuForwardStep, GpuAdjointStep: with the extension, once
# per observed frame in a fit; one step, the 6th, repeated).
# Usage: tools/bench/peer-compare.sh BUILD_DIR PEER_DIR [OUT_DIR]
#   PEER_DIR: a copy of the peer (bench.py, its grid files and ssc-scene-dragon.json with its .sdf)
set -uo pipefail
build="${1:?usage: peer-compare.sh BUILD_DIR PEER_DIR [OUT_DIR]}"
peer="$(cd "${2:?usage: peer-compare.sh BUILD_DIR PEER_DIR [OUT_DIR]}" && pwd)"
out="${3:-/tmp/ssc-peer-compare}"
mkdir -p "$out/jax"
echo "== $(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1), ssc $(git -C "$(dirname "$0")" rev-parse --short HEAD 2>/dev/null)"
rm -f "$out/jax/results.jsonl"
(cd "$peer" && OUT="$out/jax" python3 bench.py --phases table --scenes dragon --dtypes f64,f32 --batches 1,32) \
  > "$out/jax.log" 2>&1 || { echo "the peer failed:"; tail -20 "$out/jax.log"; exit 1; }
SSC_PEER_SCENE="$peer/ssc-scene-dragon.json" "$build/bin/ssc_bench" --benchmark_filter='peer-dragon' \
  --benchmark_min_time=0.2s --benchmark_format=json --benchmark_out="$out/ssc.json" > "$out/ssc.log" 2>&1 ||
  { echo "ssc_bench failed:"; tail -20 "$out/ssc.log"; exit 1; }
python3 - "$out/jax/results.jsonl" "$out/ssc.json" <<'PY'
import json, sys
jax = [json.loads(l) for l in open(sys.argv[1]) if '"table"' in l]
ssc = {b["name"]: b for b in json.load(open(sys.argv[2]))["benchmarks"] if b.get("run_type", "iteration") == "iteration"}
def ms(name):  # ssc_bench reports milliseconds (Unit kMillisecond, real time)
    b = ssc.get(name)
    return b["real_time"] if b and not b.get("error_occurred") else float("nan")
print("| dragon | JAX forward | ssc forward | ratio | JAX gradient | ssc gradient | ratio | target (10x) fwd / grad "
      "| ssc rollout + cold adjoint step | ssc observed step: fwd / fwd+adj |")
print("|---|---|---|---|---|---|---|---|---|---|")
for dtype, real in (("f64", "double"), ("f32", "float")):
    for batch in (1, 32):
        r = next((x for x in jax if x["dtype"] == dtype and x["batch"] == batch and x["scene"] == "dragon"), None)
        if not r:
            continue
        f = ms(f"GpuUnobservedRollout/peer-dragon/{real}/{batch}/manual_time")
        a = ms(f"GpuUnobservedAdjointStep/peer-dragon/{real}/{batch}/real_time")
        of = ms(f"GpuForwardStep/peer-dragon/{real}/{batch}/real_time")
        oa = ms(f"GpuAdjointStep/peer-dragon/{real}/{batch}/real_time")
        g = ms(f"GpuTrajectoryGradient/peer-dragon/{real}/{batch}/manual_time")
        jf, jg = r["fwd_ms_per_step"], r["grad_ms_per_step"]
        print(f"| {dtype}, batch {batch} | {jf:.3f} ms | {f:.3f} ms | {jf / f:.2f}x | {jg:.3f} ms | {g:.3f} ms | "
              f"{jg / g:.2f}x | {jf / 10:.3f} / {jg / 10:.3f} ms | {f + a:.3f} ms ({jg / (f + a):.2f}x) | "
              f"{of:.3f} / {of + oa:.3f} ms |")
for name in ("CpuForwardStep/peer-dragon/1", "CpuGradientStep/peer-dragon", "CpuTrajectoryGradient/peer-dragon/1/manual_time"):
    print(f"{name}: {ms(name):.2f} ms" if name in ssc else f"{name}: not run")
PY
