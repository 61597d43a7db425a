#!/usr/bin/env python3
"""Sums an ncu CSV (`--metrics gpu__time_duration.sum --csv`) by kernel: launches, total and
mean device time, share of the total, as a Markdown table (bench/run_gpu.sh step 3).

    python3 kernel_times.py ncu.csv [--frames N]

--frames divides the totals, so that a run of N frames reads per frame."""
import argparse
import csv
import re
import sys
from collections import defaultdict


def short(name):
    """The functor a launch helper ran (forEachKernel<mpm::kernels::Gather<...>>), or the kernel."""
    name = re.sub(r"\(.*\)$", "", name.strip())  # parameter list
    m = re.search(r"(forEachKernel|particleToGridKernel|gridToParticleKernel)<(.*)>", name)
    if m:
        inner = re.sub(r"<.*", "", m.group(2)).split("::")[-1]
        return f"{m.group(1)}<{inner}>"
    name = re.sub(r"^void ", "", name)
    return name[:90]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv")
    ap.add_argument("--frames", type=float, default=1.0)
    args = ap.parse_args()
    rows = []
    with open(args.csv, newline="") as f:
        lines = [l for l in f if l.startswith('"')]  # skip the ncu banner lines
    for r in csv.DictReader(lines):
        if r.get("Metric Name") != "gpu__time_duration.sum":
            continue
        rows.append((short(r["Kernel Name"]), float(r["Metric Value"].replace(",", ""))))
    if not rows:
        print("no kernel rows in", args.csv)
        return 1
    total = defaultdict(float)
    count = defaultdict(int)
    for k, ns in rows:
        total[k] += ns
        count[k] += 1
    all_ns = sum(total.values())
    print(f"{len(rows)} launches, {all_ns / 1e6 / args.frames:.3f} ms device time per frame ({args.frames:g} frames)\n")
    print("| kernel | launches / frame | us / frame | us / launch | share |")
    print("|---|---:|---:|---:|---:|")
    for k in sorted(total, key=total.get, reverse=True):
        print(f"| {k} | {count[k] / args.frames:.1f} | {total[k] / 1e3 / args.frames:.1f} | "
              f"{total[k] / 1e3 / count[k]:.2f} | {100 * total[k] / all_ns:.1f} % |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
