#!/usr/bin/env python3
"""Force error against CPU time on the cylinder of Horton et al. 2010, one line per solver through its
resolutions (the choice a user makes: the lowest line at the time they can spend), from
bench_accuracy's CSV. Left: bonded compression against the CalculiX extrapolated curve;
middle: slip compression against the closed form; right: bonded extension against MTLED's
0.5 cm curve (whose own point, compared with itself, is left out). Plotting only: needs matplotlib, which
bench/run_accuracy.sh installs from PyPI into bench/.venv; the library never does.

    bench/plot_accuracy.py bench/results/<machine>/accuracy.csv bench/results/<machine>/accuracy.png
"""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import FuncFormatter, NullFormatter  # noqa: E402

LABELS = {"Mtled": "MTLED", "MlsMpm": "MLS-MPM", "StandardMpm": "standard MPM", "PbMpm": "PB-MPM"}
PANELS = [("compression-bonded", "bonded compression 20 %\n(vs CalculiX, extrapolated)"),
          ("compression-slip", "slip compression 20 %\n(vs closed form)"),
          ("extension-bonded", "bonded extension 20 %\n(vs MTLED at 0.5 cm)")]


def main(csv_path, png_path):
    # CPU time of the run's one thread: on a shared machine the wall time also counts the
    # other processes' share; on an idle one the two agree
    points = defaultdict(list)  # (case, solver) -> [(CPU s, L2 error %, resolution cm)]
    with open(csv_path, newline="") as f:
        for row in csv.DictReader(f):
            if row["ok"] != "1" or not row["l2_error"] or float(row["l2_error"]) <= 0:
                continue
            points[(row["case"], row["solver"])].append(
                (float(row["cpu_s"]), 100 * float(row["l2_error"]), float(row["resolution_cm"])))
    fig, axes = plt.subplots(1, len(PANELS), figsize=(14, 4.4), dpi=120, sharey=True)
    colours = dict(zip(LABELS, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    for ax, (case, title) in zip(axes, PANELS):
        for solver in LABELS:
            pts = sorted(points.get((case, solver), []), key=lambda p: -p[2])  # coarse to fine
            if not pts:
                continue
            xs, ys, res = zip(*pts)
            ax.plot(xs, ys, marker="o", color=colours[solver], label=LABELS[solver])
            for x, y, r in pts:
                ax.annotate("%g cm" % r, (x, y), textcoords="offset points", xytext=(4, 4), fontsize=6,
                            color=colours[solver])
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU time of the 3 s ramp, one thread [s]")
        ax.set_title(title, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(FuncFormatter(lambda v, _: "%g" % v))
            axis.set_minor_formatter(NullFormatter())
    axes[0].set_ylabel("relative L2 error of the force-time curve [%]")
    axes[0].legend(fontsize=7)
    fig.suptitle("Cylinder between plates, CPU backend: error against cost (labels: MPM dx / MTLED node spacing)",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(png_path)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: plot_accuracy.py ACCURACY.csv OUT.png")
    main(sys.argv[1], sys.argv[2])
