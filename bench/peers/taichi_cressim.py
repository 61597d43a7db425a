#!/usr/bin/env python3
"""The CRESSim bench scene (BENCH_SCENES.md section 1) written with Taichi, as the peer of
bench_throughput's MLS-MPM on the CPU backend.

It is the same scene as `mpm::scenes::CressimBench` and the same MLS-MPM substep as
mpm/src/solvers/mls_mpm.h:
- grid [-5.5, 5.5]^3, cell dx = 0.2: 55 cells, nodes 0..55 per axis (56^3);
- a box of particles centred at the origin on a lattice of spacing 0.1 at the centres of
  the lattice cells (x = (i + 0.5 - n/2) * 0.1), mass 10 and rest volume 1e-3 each;
- fixed corotated, E = 5e5, nu = 0.4: tau = 2 mu (F - R) F^T + lambda (J - 1) J I, R from
  the polar decomposition;
- quadratic B-splines, stencil base floor((x - lower)/dx - 0.5); P2G of mass w m and
  momentum w (m v + A (x_i - x_p)) with A = m C - dt V0 (4/dx^2) tau; grid update
  v = mv/m + dt g on nodes with m > 1e-30 (others zeroed); domain walls on the two node
  layers at each face, "separate" mode (only the velocity into the wall is removed);
  G2P v = sum w v_i, C = 4/dx^2 sum w v_i (x_i - x_p)^T, x += dt v, F <- (I + dt C) F;
- gravity (0, -1, 0), dt = 0.002, 10 substeps per 0.02 s frame.

Grids (--grid): `dense` (the mpm88/mpm128 layout: a dense 56^3 field, cleared every substep,
atomic P2G), `pointer` (pointer blocks of 4^3 nodes activated by P2G and deactivated every
substep, so the grid update only visits blocks that hold material) and `bitmasked` (a
dense array of 4^3 blocks with a bitmask per node).

Timing: `--warmup` untimed frames (they include the JIT compilation of every kernel), then
`--frames` timed frames, each ending with ti.sync(). One JSON line goes to stdout:
particles, ms/frame, M particle-substeps/s, process CPU time and the CPU other processes
used meanwhile (from /proc/stat). With --trajectory FILE, the centre of mass and lowest
particle height after every frame go to FILE as CSV (no timing).

    python taichi_cressim.py --half-size 2.5 --threads 2 --frames 50
"""
import argparse
import json
import os
import sys
import time

import numpy as np
import taichi as ti

LOWER = -5.5
UPPER = 5.5
DX = 0.2
SPACING = 0.1
PARTICLE_MASS = 10.0
E, NU = 5e5, 0.4
GRAVITY = (0.0, -1.0, 0.0)
DT = 0.002
SUBSTEPS = 10
WALL = 2            # node layers at each face that the wall acts on
EMPTY_MASS = 1e-30  # nodes lighter than this hold no material


def lattice(half_size):
    """The box's particle positions, as the library samples them (mpm/src/scene/particle_seeding.cpp)."""
    n = int(round(2 * half_size / SPACING))
    r = (np.arange(n, dtype=np.float32) + np.float32(0.5) - np.float32(0.5 * n)) * np.float32(SPACING)
    g = np.stack(np.meshgrid(r, r, r, indexing="ij"), axis=-1).reshape(-1, 3)
    return np.ascontiguousarray(g.astype(np.float32))


def machine_busy_seconds():
    """CPU time all processes have used since boot [s], or None."""
    try:
        with open("/proc/stat") as f:
            fields = f.readline().split()
        user, nice, system, idle, iowait, irq, softirq, steal = (int(v) for v in fields[1:9])
        return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError):
        return None


def build(n_particles, grid_kind, serial_p2g=False):
    cells = int(round((UPPER - LOWER) / DX))  # 55
    nodes = cells + 1                         # 56
    inv_dx = 1.0 / DX
    p_vol = SPACING ** 3
    p_mass = PARTICLE_MASS
    mu = E / (2 * (1 + NU))
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    affine_scale = DT * p_vol * 4 * inv_dx * inv_dx

    x = ti.Vector.field(3, ti.f32, n_particles)
    v = ti.Vector.field(3, ti.f32, n_particles)
    C = ti.Matrix.field(3, 3, ti.f32, n_particles)
    F = ti.Matrix.field(3, 3, ti.f32, n_particles)
    grid_v = ti.Vector.field(3, ti.f32)
    grid_m = ti.field(ti.f32)
    block = None
    if grid_kind == "dense":
        ti.root.dense(ti.ijk, nodes).place(grid_v, grid_m)
    elif grid_kind == "pointer":
        block = ti.root.pointer(ti.ijk, nodes // 4)
        block.dense(ti.ijk, 4).place(grid_v, grid_m)
    elif grid_kind == "bitmasked":
        block = ti.root.pointer(ti.ijk, nodes // 4)
        block.bitmasked(ti.ijk, 4).place(grid_v, grid_m)
    else:
        raise ValueError(grid_kind)
    gravity = ti.Vector(GRAVITY)

    @ti.kernel
    def init(pos: ti.types.ndarray()):
        for p in x:
            x[p] = ti.Vector([pos[p, 0], pos[p, 1], pos[p, 2]])
            v[p] = ti.Vector.zero(ti.f32, 3)
            C[p] = ti.Matrix.zero(ti.f32, 3, 3)
            F[p] = ti.Matrix.identity(ti.f32, 3)

    @ti.kernel
    def clear_dense():
        for I in ti.grouped(grid_m):
            grid_v[I] = ti.Vector.zero(ti.f32, 3)
            grid_m[I] = 0.0

    @ti.kernel
    def p2g_update_g2p():
        # one thread: a serial loop lets Taichi demote the atomic adds to plain ones
        ti.loop_config(serialize=serial_p2g)
        for p in x:
            Xp = (x[p] - LOWER) * inv_dx
            base = ti.floor(Xp - 0.5).cast(int)
            fx = Xp - base.cast(ti.f32)
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
            Fp = F[p]
            R, _ = ti.polar_decompose(Fp)
            J = Fp.determinant()
            tau = 2.0 * mu * (Fp - R) @ Fp.transpose() + ti.Matrix.identity(ti.f32, 3) * (lam * (J - 1.0) * J)
            affine = p_mass * C[p] - affine_scale * tau
            mv = p_mass * v[p]
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                offset = ti.Vector([i, j, k])
                dpos = (offset.cast(ti.f32) - fx) * DX
                weight = w[i][0] * w[j][1] * w[k][2]
                grid_v[base + offset] += weight * (mv + affine @ dpos)
                grid_m[base + offset] += weight * p_mass
        for I in ti.grouped(grid_m):
            m = grid_m[I]
            if m > EMPTY_MASS:
                vel = grid_v[I] / m + DT * gravity
                for a in ti.static(range(3)):
                    if I[a] < WALL and vel[a] < 0.0:
                        vel[a] = 0.0
                    if I[a] > cells - WALL and vel[a] > 0.0:
                        vel[a] = 0.0
                grid_v[I] = vel
            else:
                grid_v[I] = ti.Vector.zero(ti.f32, 3)
        for p in x:
            Xp = (x[p] - LOWER) * inv_dx
            base = ti.floor(Xp - 0.5).cast(int)
            fx = Xp - base.cast(ti.f32)
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
            new_v = ti.Vector.zero(ti.f32, 3)
            new_C = ti.Matrix.zero(ti.f32, 3, 3)
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                offset = ti.Vector([i, j, k])
                dpos = (offset.cast(ti.f32) - fx) * DX
                weight = w[i][0] * w[j][1] * w[k][2]
                gv = grid_v[base + offset]
                new_v += weight * gv
                new_C += (4.0 * inv_dx * inv_dx * weight) * gv.outer_product(dpos)
            v[p] = new_v
            C[p] = new_C
            x[p] += DT * new_v
            F[p] = (ti.Matrix.identity(ti.f32, 3) + DT * new_C) @ F[p]

    def substep():
        if block is None:
            clear_dense()
        else:
            block.deactivate_all()
        p2g_update_g2p()

    def frame():
        for _ in range(SUBSTEPS):
            substep()
        ti.sync()

    return init, frame, x


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--half-size", type=float, default=1.0, help="box half-size [m]: 1, 2.5, 5 give 8k, 125k, 1M")
    ap.add_argument("--arch", choices=["cpu", "cuda"], default="cpu",
                    help="Taichi backend: cpu (the CPU peer), or cuda (the GPU peer of --backend cuda)")
    ap.add_argument("--threads", type=int, default=1, help="cpu_max_num_threads (cpu only)")
    ap.add_argument("--frames", type=int, default=50, help="timed frames")
    ap.add_argument("--warmup", type=int, default=2, help="untimed frames first (JIT compilation)")
    ap.add_argument("--grid", choices=["dense", "pointer", "bitmasked"], default="dense")
    ap.add_argument("--serialize", action="store_true",
                    help="run the particle loops serially (ti.loop_config(serialize=True)), so that"
                         " Taichi may demote P2G's atomic adds; only for --threads 1")
    ap.add_argument("--trajectory", metavar="FILE", help="write frame,t,com_x,com_y,com_z,min_y per frame; no timing")
    args = ap.parse_args()

    if args.arch == "cuda":
        ti.init(arch=ti.cuda, default_fp=ti.f32, random_seed=0, log_level=ti.WARN)
    else:
        ti.init(arch=ti.cpu, cpu_max_num_threads=args.threads, default_fp=ti.f32, random_seed=0,
                log_level=ti.WARN)
    pos = lattice(args.half_size)
    n = pos.shape[0]
    init, frame, x = build(n, args.grid, args.serialize)
    init(pos)

    if args.trajectory:
        with open(args.trajectory, "w") as out:
            out.write("frame,t,com_x,com_y,com_z,min_y\n")
            for f in range(args.frames + 1):
                if f:
                    frame()
                xs = x.to_numpy().astype(np.float64)
                c = xs.mean(axis=0)
                out.write(f"{f},{f * SUBSTEPS * DT:.4f},{c[0]:.7f},{c[1]:.7f},{c[2]:.7f},{xs[:, 1].min():.7f}\n")
        return

    t_compile = time.perf_counter()
    for _ in range(args.warmup):
        frame()
    t_compile = time.perf_counter() - t_compile
    busy0 = machine_busy_seconds()
    cpu0 = time.process_time()
    t0 = time.perf_counter()
    for _ in range(args.frames):
        frame()
    wall = time.perf_counter() - t0
    cpu = time.process_time() - cpu0
    busy1 = machine_busy_seconds()
    other = None if busy0 is None or busy1 is None else max(0.0, (busy1 - busy0 - cpu) / wall)
    ms = 1e3 * wall / args.frames
    print(json.dumps({
        "peer": "taichi", "taichi": ".".join(str(v) for v in ti.__version__), "arch": args.arch, "grid": args.grid,
        "serialize": args.serialize, "half_size": args.half_size, "particles": n, "threads": args.threads, "frames": args.frames,
        "warmup_s": round(t_compile, 3), "ms_per_frame": round(ms, 4),
        "cpu_ms_per_frame": round(1e3 * cpu / args.frames, 4),
        "m_particle_substeps_per_s": round(n * SUBSTEPS / (1e-3 * ms) / 1e6, 5),
        "other_load_cores": None if other is None else round(other, 3),
    }))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
