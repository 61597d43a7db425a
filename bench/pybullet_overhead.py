"""Overhead of the Python coupler (mpm_bullet.pybullet.Coupler) per step against the same
scene through the C++ coupler (bench_pybullet_overhead): the resting-sphere scene of
tests/python/pybullet_scenes.py, one CPU thread. Prints, per run and as medians over runs,
a step's median and mean wall time, the solver's stages per step (Scene.timings) and the
rest (the coupling, pybullet or Bullet, scene bookkeeping), then the C++ bench's line.

    OMP_NUM_THREADS=1 python bench/pybullet_overhead.py --cpp build/bench/bench_pybullet_overhead

The machine should be otherwise idle (bench/idle_check.sh); both halves run alternately so
a neighbour's load falls on both alike.
"""

import argparse
import os
import re
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "python"))
import pybullet as p  # noqa: E402

from pybullet_scenes import resting_sphere  # noqa: E402


def python_run(ticks, tissue):
    client, scene, coupler, sphere, _ = resting_sphere(tissue=tissue)
    scene.reset_timings()
    times = []
    for _ in range(ticks):
        a = time.perf_counter()
        coupler.step()
        times.append(1e3 * (time.perf_counter() - a))
    t = scene.timings()
    stages = 1e3 * sum(t[k] for k in ("sort", "p2g", "grid_update", "contact", "g2p")) / ticks
    z = p.getBasePositionAndOrientation(sphere, physicsClientId=client)[0][2]
    p.disconnect(client)
    return statistics.median(times), statistics.fmean(times), stages, t["substeps"] / ticks, z


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ticks", type=int, default=192)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cpp", help="path of bench_pybullet_overhead, run alternately with the Python runs")
    ap.add_argument("--no-tissue", action="store_true",
                    help="leave the slab out: the step is then the coupling, the physics engine and the "
                         "scene's fixed cost per step")
    args = ap.parse_args()
    rows, cpp_rows = [], []
    for r in range(args.repeats):
        med, mean, stages, substeps, z = python_run(args.ticks, not args.no_tissue)
        rows.append((med, mean, stages, mean - stages))
        print(f"run {r}: step median {med:.3f} ms, mean {mean:.3f} ms; solver stages {stages:.3f} ms per step "
              f"({substeps:.1f} substeps); mean step less stages {mean - stages:.3f} ms (sphere at z = {z:.4f} m)")
        if args.cpp:
            extra = ["--no-tissue", "1"] if args.no_tissue else []
            out = subprocess.run([args.cpp, "--ticks", str(args.ticks), "--repeats", "1"] + extra, check=True,
                                 capture_output=True, text=True).stdout
            line = [l for l in out.splitlines() if l.startswith("run 0:")][0]
            n = [float(x) for x in re.findall(r"([0-9.]+) ms", line)]  # median, mean, stages, rest
            cpp_rows.append((n[0], n[1], n[2], n[3]))
            print("  C++", line)
    med = [statistics.median(c) for c in zip(*rows)]
    print(f"Python Coupler (pybullet), {args.ticks} steps x {args.repeats} runs (medians over runs): step median "
          f"{med[0]:.3f} ms, mean {med[1]:.3f} ms; solver stages {med[2]:.3f} ms; the rest (coupling, pybullet, "
          f"scene bookkeeping) {med[3]:.3f} ms")
    if cpp_rows:
        cm = [statistics.median(c) for c in zip(*cpp_rows)]
        print(f"C++ Coupler (btDiscreteDynamicsWorld), same runs: step median {cm[0]:.3f} ms, mean {cm[1]:.3f} ms; "
              f"solver stages {cm[2]:.3f} ms; the rest {cm[3]:.3f} ms")
        print(f"Python - C++: step median {med[0] - cm[0]:+.3f} ms, the rest {med[3] - cm[3]:+.3f} ms per step")


if __name__ == "__main__":
    main()
