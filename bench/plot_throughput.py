#!/usr/bin/env python3
"""Time per frame against particle count, one line per solver (the layout of CRESSim-MPM's
Fig. 3), from bench_throughput's CSV. Plotting only: needs matplotlib, which
bench/run_throughput.sh installs from PyPI into bench/.venv; the library never does.

    bench/plot_throughput.py bench/results/throughput.csv bench/results/throughput.png
"""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LABELS = {"mls": "MLS-MPM", "standard": "standard MPM"}


def label(solver):
    if solver in LABELS:
        return LABELS[solver]
    return "PB-MPM, %s iterations" % solver[2:]


def main(csv_path, png_path):
    lines = defaultdict(list)  # (solver, threads) -> [(particles, ms per frame)]
    with open(csv_path, newline="") as f:
        for row in csv.DictReader(f):
            if row.get("variant", "plain") != "plain":
                continue  # the pay-for-use variants are compared in the report's pairs table
            key = (row["solver"], int(row["threads"]))
            lines[key].append((int(row["particles"]), float(row["ms_per_frame_median"])))
    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=120)
    solvers = sorted({s for s, _ in lines}, key=lambda s: (s not in LABELS, s))
    colours = dict(zip(solvers, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    for (solver, threads), points in sorted(lines.items()):
        points.sort()
        xs, ys = zip(*points)
        ax.plot(xs, ys, marker="o", color=colours[solver], linestyle="-" if threads > 1 else "--",
                label="%s, %d thread%s" % (label(solver), threads, "s" if threads > 1 else ""))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("particles")
    ax.set_ylabel("wall time per 0.02 s frame [ms]")
    ax.set_title("CRESSim bench scene, CPU backend (MLS / standard: 10 substeps;\nPB-MPM: one 0.02 s step)",
                 fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png_path)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: plot_throughput.py THROUGHPUT.csv OUT.png")
    main(sys.argv[1], sys.argv[2])
