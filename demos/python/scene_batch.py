"""Many scenes at once with mpm_bullet.SceneBatch: a sweep over one parameter, here the speed
at which a 4 cm block of soft tissue is thrown downwards, one scene per value, stepped
together on the batch's threads. Prints each block's fall next to the closed form.

    python demos/python/scene_batch.py --scenes 4 --threads 2

Each block falls freely (no ground, walls far away), so its mean height comes down by
v0 t + g t^2 / 2. The solver's explicit substeps of length h give symplectic Euler's sum
instead (v += g h, then y -= v h each substep), which reaches the closed form as h goes to
0; the script prints both, from the substeps the batch reports.
"""

import argparse

import mpm_bullet as mb

SETTINGS = {"domain": {"lower": [-0.1, -0.7, -0.1], "upper": [0.1, 0.1, 0.1]}, "dx": 0.01,
            "gravity": [0.0, -9.81, 0.0]}
FRAME = 1 / 60  # [s]


def thrown_block(speed):
    """A scene holding one block (E 30 kPa) thrown down at `speed` [m/s]; returns (scene, block)."""
    scene = mb.Scene(SETTINGS)
    block = scene.add_object({"primitive": "Box", "center": [0.0, 0.0, 0.0], "halfExtents": [0.02, 0.02, 0.02],
                              "velocity": [0.0, -speed, 0.0],
                              "material": {"youngsModulus": 3e4, "poissonRatio": 0.4, "density": 1000}})
    return scene, block


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", type=int, default=4, help="how many speeds, 0 to 1 m/s")
    parser.add_argument("--threads", type=int, default=0, help="the batch's threads (0: all)")
    parser.add_argument("--frames", type=int, default=12, help="frames of 1/60 s")
    args = parser.parse_args()

    speeds = [i / max(1, args.scenes - 1) for i in range(args.scenes)]
    scenes = [thrown_block(v) for v in speeds]
    start = [float(s.positions(b)[:, 1].mean()) for s, b in scenes]
    batch = mb.SceneBatch([s for s, _ in scenes], threads=args.threads)

    # the discrete fall of each scene, summed over the substeps its reports give
    g = 9.81
    velocity = list(speeds)
    discrete = [0.0] * len(scenes)
    for _ in range(args.frames):
        reports = batch.step(FRAME)  # one StepReport per scene
        for i, r in enumerate(reports):
            for _ in range(r.substeps):
                velocity[i] += g * r.substep_dt
                discrete[i] += velocity[i] * r.substep_dt

    t = args.frames * FRAME
    print(f"{len(batch)} scenes on {batch.threads} threads, {t:.3f} s of free fall")
    for i, (scene, block) in enumerate(scenes):
        fell = start[i] - float(scene.positions(block)[:, 1].mean())
        closed = speeds[i] * t + 0.5 * g * t * t
        print(f"scene {i}: v0 {speeds[i]:.3f} m/s fell {fell:.6f} m; substeps' sum {discrete[i]:.6f} m, "
              f"closed form {closed:.6f} m")


if __name__ == "__main__":
    main()
