#!/usr/bin/env python3
"""Collects what bench/run_peers.sh measured into bench/results/<machine>/peers.{md,csv}; also the
physics check (`compare`). Standard library only.

    tabulate.py table   RUN_DIR OUT_STEM   # RUN_DIR: ours_*.csv, taichi_*.json, bandwidth.csv, info.txt
    tabulate.py compare OURS.csv TAICHI.csv  # prints the largest centre-of-mass difference
"""
import csv
import glob
import json
import os
import statistics
import sys

BYTES_PER_PARTICLE_SUBSTEP = 204  # bench/throughput.cpp kBytesPerParticleSubstep


def read_trajectory(path):
    with open(path) as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


def compare(ours_path, peer_path):
    """Largest |com difference| over the frames, and at the last frame, in metres."""
    a, b = read_trajectory(ours_path), read_trajectory(peer_path)
    n = min(len(a), len(b))
    worst = (0.0, 0)
    for i in range(n):
        d = max(abs(a[i][k] - b[i][k]) for k in ("com_x", "com_y", "com_z"))
        if d > worst[0]:
            worst = (d, int(a[i]["frame"]))
    dmin = max(abs(a[i]["min_y"] - b[i]["min_y"]) for i in range(n))
    lowest_ours = min(r["com_y"] for r in a[:n])
    lowest_peer = min(r["com_y"] for r in b[:n])
    return {
        "frames": n - 1,
        "max_com_diff_m": worst[0],
        "at_frame": worst[1],
        "max_min_y_diff_m": dmin,
        "final_com_y_ours": a[n - 1]["com_y"],
        "final_com_y_peer": b[n - 1]["com_y"],
        "lowest_com_y_ours": lowest_ours,
        "lowest_com_y_peer": lowest_peer,
    }


def fmt(v, d):
    return "–" if v is None else f"{v:.{d}f}"


def table(run_dir, out_stem):
    rows = {}
    for path in sorted(glob.glob(os.path.join(run_dir, "ours_*.csv"))):
        with open(path) as f:
            for r in csv.DictReader(f):
                key = (int(r["particles"]), int(r["threads"]))
                e = rows.setdefault(key, {"half": float(r["half_size_m"]), "ours": [], "peer": [], "other": [],
                                          "ours_cpu": [], "peer_cpu": []})
                e["ours"].append(float(r["ms_per_frame_median"]))
                e["ours_cpu"].append(float(r["cpu_ms_per_frame"]))
                e["ours_mem"] = int(r["memory_bytes"])
                e["other"].append(float(r["other_load_cores"]))
                e["frames"] = int(r["frames"])
    for path in sorted(glob.glob(os.path.join(run_dir, "taichi_*.json"))):
        with open(path) as f:
            lines = [l for l in f if l.startswith("{")]
        if not lines:
            continue
        r = json.loads(lines[-1])
        key = (int(r["particles"]), int(r["threads"]))
        e = rows.setdefault(key, {"half": r["half_size"], "ours": [], "peer": [], "other": [],
                                  "ours_cpu": [], "peer_cpu": []})
        e["peer"].append(r["ms_per_frame"])
        e["peer_cpu"].append(r["cpu_ms_per_frame"])
        e["peer_grid"] = r["grid"]
        e["taichi"] = r["taichi"]
        if r.get("other_load_cores") is not None:
            e["other"].append(r["other_load_cores"])
    bw = {}
    bw_path = os.path.join(run_dir, "bandwidth.csv")
    if os.path.exists(bw_path):
        with open(bw_path) as f:
            for r in csv.DictReader(f):
                bw[int(r["threads"])] = (float(r["triad_gb_per_s"]), float(r["update_gb_per_s"]))
    info = open(os.path.join(run_dir, "info.txt")).read() if os.path.exists(os.path.join(run_dir, "info.txt")) else ""
    physics = ""
    if os.path.exists(os.path.join(run_dir, "physics.json")):
        with open(os.path.join(run_dir, "physics.json")) as f:
            physics = json.load(f)

    out_rows = []
    for (particles, threads), e in sorted(rows.items()):
        ours = statistics.median(e["ours"]) if e["ours"] else None
        peer = statistics.median(e["peer"]) if e["peer"] else None
        mps = lambda ms: None if ms is None else particles * 10 / (1e-3 * ms) / 1e6
        gbs = None if ours is None else mps(ours) * BYTES_PER_PARTICLE_SUBSTEP / 1e3
        out_rows.append({
            "half_size_m": e["half"], "particles": particles, "threads": threads, "frames": e.get("frames"),
            "runs_ours": len(e["ours"]), "runs_taichi": len(e["peer"]),
            "ours_ms_per_frame": ours, "ours_ms_min": min(e["ours"]) if e["ours"] else None,
            "ours_ms_max": max(e["ours"]) if e["ours"] else None,
            "taichi_ms_per_frame": peer, "taichi_ms_min": min(e["peer"]) if e["peer"] else None,
            "taichi_ms_max": max(e["peer"]) if e["peer"] else None,
            "ours_cpu_ms_per_frame": statistics.median(e["ours_cpu"]) if e["ours_cpu"] else None,
            "taichi_cpu_ms_per_frame": statistics.median(e["peer_cpu"]) if e["peer_cpu"] else None,
            "ours_m_per_s": mps(ours), "taichi_m_per_s": mps(peer),
            "ratio_ours_over_taichi": None if ours is None or peer is None else peer / ours,
            "ours_particle_gb_per_s": gbs,
            "bandwidth_update_gb_per_s": bw.get(threads, (None, None))[1],
            "pct_of_bandwidth": None if gbs is None or threads not in bw else 100 * gbs / bw[threads][1],
            "ours_bytes_per_particle": e.get("ours_mem", 0) / particles if e.get("ours_mem") else None,
            "max_other_load_cores": max(e["other"]) if e["other"] else None,
            "taichi_grid": e.get("peer_grid"), "taichi_version": e.get("taichi"),
        })

    with open(out_stem + ".csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(out_rows[0].keys()) if out_rows else ["empty"])
        w.writeheader()
        for r in out_rows:
            w.writerow({k: ("" if v is None else (round(v, 4) if isinstance(v, float) else v)) for k, v in r.items()})

    busy = any((r["max_other_load_cores"] or 0) > 0.1 for r in out_rows)
    md = ["# Peers: our MLS-MPM against Taichi on the CRESSim scene, CPU", ""]
    if busy:
        md += ["**Preliminary: busy machine. Other processes used more than 0.1 core during some runs (last"
               " column); those times are inflated and the ratios uncertain. Rerun `bench/run_peers.sh` on"
               " an idle machine for figures to quote.**", ""]
    md += [info.strip(), ""]
    md += ["Scene: BENCH_SCENES.md section 1 (`mpm::scenes::CressimBench`), MLS-MPM, dt = 0.002 s,"
           " 10 substeps per 0.02 s frame. Ours: `bench_throughput --solvers mls`. Peer:"
           " `bench/peers/taichi_cressim.py` (Taichi CPU backend, `cpu_max_num_threads` = threads,"
           " the same substep; grid layout in the table). Untimed warm-up frames first (ours 2,"
           " Taichi 1: its JIT compilation happens in the first substep), then the same timed frames; one process per run, ours and"
           " Taichi alternating, each row the median of its runs.", "",
           "- ratio = Taichi ms/frame / ours ms/frame: how many times ours outruns Taichi (> 1: ours faster).",
           f"- particle GB/s: ours M/s x {BYTES_PER_PARTICLE_SUBSTEP} B, the particle state a substep must"
           " read and write at the least (bench/throughput.cpp); % of the in-place-update bandwidth"
           " measured in this run with the same thread count.",
           "- CPU ms/frame: process CPU time, all threads (median); on a busy machine less disturbed than"
           " wall time, but it also counts time threads spend spinning at barriers.",
           "- other load: the most CPU other processes took during one of the row's runs (/proc/stat) [cores].",
           ""]
    if bw:
        md += ["Memory bandwidth (bench/bandwidth.h, measured in this run):", "",
               "| threads | triad [GB/s] | in-place update [GB/s] |", "|---:|---:|---:|"]
        md += [f"| {t} | {v[0]:.2f} | {v[1]:.2f} |" for t, v in sorted(bw.items())]
        md += [""]
    md += ["| particles | threads | frames | ours ms/frame | Taichi ms/frame | ratio ours/Taichi | ours M/s"
           " | Taichi M/s | ours CPU ms/frame | Taichi CPU ms/frame | ours particle GB/s | % of bandwidth | runs"
           " | other load [cores] |",
           "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in out_rows:
        md.append(f"| {r['particles']} | {r['threads']} | {r['frames']} | {fmt(r['ours_ms_per_frame'], 2)}"
                  f" | {fmt(r['taichi_ms_per_frame'], 2)} | {fmt(r['ratio_ours_over_taichi'], 2)}"
                  f" | {fmt(r['ours_m_per_s'], 2)} | {fmt(r['taichi_m_per_s'], 2)}"
                  f" | {fmt(r['ours_cpu_ms_per_frame'], 1)} | {fmt(r['taichi_cpu_ms_per_frame'], 1)}"
                  f" | {fmt(r['ours_particle_gb_per_s'], 2)} | {fmt(r['pct_of_bandwidth'], 0)}"
                  f" | {r['runs_ours']}+{r['runs_taichi']} | {fmt(r['max_other_load_cores'], 2)} |")
    md.append("")
    if physics:
        md += ["## Same scene: physics check", "",
               f"Half-size {physics.get('half_size', 1)} ({physics.get('particles', '')} particles),"
               f" {physics['frames']} frames ({physics['frames'] * 0.02:.1f} s: the box falls, hits the"
               " floor wall and bounces), 1 thread each; centre of mass after every frame:", "",
               f"- largest difference of a centre-of-mass coordinate: {physics['max_com_diff_m']:.2e} m"
               f" (frame {physics['at_frame']}); tolerance {physics.get('tolerance_m', 0.01)} m:"
               f" **{'pass' if physics['max_com_diff_m'] <= physics.get('tolerance_m', 0.01) else 'FAIL'}**",
               f"- largest difference of the lowest particle's height: {physics['max_min_y_diff_m']:.2e} m",
               f"- lowest centre height: ours {physics['lowest_com_y_ours']:.4f} m, Taichi {physics['lowest_com_y_peer']:.4f} m;"
               f" at the end: ours {physics['final_com_y_ours']:.4f} m, Taichi {physics['final_com_y_peer']:.4f} m", ""]
    with open(out_stem + ".md", "w") as f:
        f.write("\n".join(md))
    print("\n".join(md))


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "compare":
        print(json.dumps(compare(sys.argv[2], sys.argv[3])))
    elif len(sys.argv) == 4 and sys.argv[1] == "table":
        table(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
