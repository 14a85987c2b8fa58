#!/usr/bin/env python3
"""Where a kernel's warps wait, from Nsight Compute's per-instruction samples.

Reads the CSV of `ncu -i REPORT --page source --csv --print-source sass` (a report taken with
`--set full`, whose SourceCounters section samples warp stalls per instruction) and prints, for
the first kernel in it:
  - the samples by stall reason;
  - the samples of each stretch of code between two synchronising instructions (a block
    barrier, a memory barrier, an atomic) or the starts of runs of global loads or shuffles, in
    address order, so that a persistent solver's iteration reads as its phases;
  - the instructions with the most samples.
A sample is one warp at one instant, so a stretch that only one warp of a block runs (warp 0's
part of a grid sum) shows few samples while the block's other warps pile up on the barrier
after it.

Usage: sass_stalls.py SASS.csv [--top N] [--min-share PERCENT]
Taking the profile (docs/benchmarks.md, session 33):
  ncu --clock-control none --set full -k regex:one_phase --launch-skip 20 -c 1 -o prof \\
      build-gpu/bin/ssc_bench --benchmark_filter=GpuUnobservedRollout/peer-dragon/double/1/
  ncu -i prof.ncu-rep --page source --csv --print-source sass > sass.csv
"""
import argparse
import csv
import sys

SAMPLES = "Warp Stall Sampling (All Samples)"
SYNC_OPS = ("BAR.", "MEMBAR", "ATOM", "RED.", "ERRBAR", "CCTL", "NANOSLEEP")


def first_kernel(path):
    header, rows, name = None, [], None
    try:
        f = open(path, newline="")
    except OSError as e:
        sys.exit(f"{path}: {e.strerror}")
    with f:
        for r in csv.reader(f):
            if r and r[0] == "Kernel Name":
                if name is not None:
                    break
                name = r[1]
            elif r and r[0] == "Address":
                header = r
            elif header and len(r) == len(header):
                rows.append(r)
    if header is None or not rows:
        sys.exit(f"{path}: no per-instruction rows (was it written with --page source --print-source sass?)")
    return name, header, rows


def opcode(source):
    words = source.split()
    if words and words[0].startswith("@"):
        words = words[1:]
    return words[0] if words else ""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv")
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--min-share", type=float, default=1.0, help="print stretches above this share (%%)")
    a = ap.parse_args()
    name, header, rows = first_kernel(a.csv)
    col = {h: i for i, h in enumerate(header)}
    if SAMPLES not in col:
        sys.exit(f"{a.csv}: no '{SAMPLES}' column (take the report with --set full)")
    reasons = [h for h in header if h.startswith("stall_") and "Not Issued" not in h]

    def num(r, key):
        v = r[col[key]].replace(",", "")
        return float(v) if v else 0.0

    total = sum(num(r, SAMPLES) for r in rows)
    if total == 0:
        sys.exit(f"{a.csv}: no samples")
    print(f"{name}: {total:.0f} warp samples over {len(rows)} instructions")
    print("\nby stall reason:")
    by_reason = sorted(((sum(num(r, k) for r in rows), k) for k in reasons), reverse=True)
    for v, k in by_reason:
        if v / total >= 0.005:
            print(f"  {k[6:]:22s} {v:9.0f}  {100 * v / total:5.1f} %")

    print("\nby stretch, in address order (cut at barriers, memory barriers, atomics and the start of")
    print("each run of global loads or shuffles; 'at a barrier': warps waiting at a block barrier,")
    print("sampled at the instruction that follows it):")
    ops = [opcode(r[col["Source"]]) for r in rows]
    cuts = {0, len(rows)}
    for i, op in enumerate(ops):
        prev = ops[i - 1] if i else ""
        if op.startswith(SYNC_OPS):
            cuts.add(i)
        for run in ("LDG", "SHFL"):
            if op.startswith(run) and not prev.startswith(run):
                cuts.add(i)
    bounds = sorted(cuts)
    for lo, hi in zip(bounds, bounds[1:]):
        acc = sum(num(r, SAMPLES) for r in rows[lo:hi])
        if 100 * acc / total < a.min_share:
            continue
        runs = max(num(r, "Instructions Executed") for r in rows[lo:hi])
        barrier = sum(num(r, "stall_barrier") for r in rows[lo:hi])
        print(f"  {rows[lo][col['Address']][-6:]}..{rows[hi - 1][col['Address']][-6:]}  {acc:9.0f}  "
              f"{100 * acc / total:5.1f} %  at a barrier {100 * barrier / total:5.1f} %  "
              f"from {ops[lo]} to {ops[hi - 1]} (warp runs {runs:.0f})")

    print(f"\nthe {a.top} instructions with the most samples:")
    top = sorted(rows, key=lambda r: -num(r, SAMPLES))[: a.top]
    for r in top:
        main_reason = max(reasons, key=lambda k: num(r, k))
        print(f"  {r[col['Address']][-6:]}  {num(r, SAMPLES):8.0f}  {100 * num(r, SAMPLES) / total:5.1f} %  "
              f"{main_reason[6:]:14s} {r[col['Source']].strip()[:60]}")


if __name__ == "__main__":
    main()
