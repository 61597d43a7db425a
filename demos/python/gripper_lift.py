"""A two-finger gripper (gripper.urdf) in a headless pybullet world pinches a 4 cm cube of
soft tissue (E 30 kPa) lying on the ground and lifts it 5 cm, through
mpm_bullet.pybullet.Coupler; writes side-view PNGs and prints the cube's height.

    python demos/python/gripper_lift.py --out /tmp/gripper

The gripper is a pybullet robot driven by position-controlled joint motors; the tissue
pushes back on its fingers (they are dynamic links), so the squeeze is what the finger
motors' force limit (10 N) and the tissue's stiffness make of it, and the cube is held up by
friction (mu 1) alone.
"""

import argparse
import os
import sys

import numpy as np
import pybullet as p

import mpm_bullet as mb
from mpm_bullet.pybullet import Coupler

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pictures import link_points, render, write_png  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
TICK = 1.0 / 240
PALM_START = 0.18  # palm centre [m]; the fingers reach 9 cm below it


def targets(t):
    """(lift, finger) joint targets at time t: down around the cube, close, lift, hold."""
    down, close, lift = 0.4, 0.8, 1.4
    grip_lift = -(PALM_START - 0.095)  # finger tips 5 mm above the ground
    if t < down:
        return grip_lift * t / down, 0.0
    if t < close:
        return grip_lift, 0.025 * (t - down) / (close - down)  # inner faces from 3.5 to 1 cm off the axis
    if t < lift:
        return grip_lift + 0.05 * (t - close) / (lift - close), 0.025
    return grip_lift + 0.05, 0.025


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="gripper_frames", help="folder for the PNGs")
    ap.add_argument("--seconds", type=float, default=1.8)
    ap.add_argument("--png-every", type=int, default=24, help="ticks between pictures (24 = 10 per second)")
    ap.add_argument("--dx", type=float, default=0.005, help="grid cell [m]")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)

    client = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81)
    p.setPhysicsEngineParameter(fixedTimeStep=TICK, numSubSteps=0)
    ground = p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE))
    gripper = p.loadURDF(os.path.join(HERE, "gripper.urdf"), [0, 0, PALM_START], useFixedBase=True)
    joints = {p.getJointInfo(gripper, j)[1].decode(): j for j in range(p.getNumJoints(gripper))}

    scene = mb.Scene({"domain": {"lower": [-0.1, -0.1, -0.02], "upper": [0.1, 0.1, 0.2]}, "dx": args.dx,
                      "gravity": [0, 0, -9.81]})
    cube = scene.add_object({"primitive": "Box", "center": [0, 0, 0.0205], "halfExtents": [0.02, 0.02, 0.02],
                             "material": {"model": "NeoHookeanDecoupled", "youngsModulus": 3e4,
                                          "poissonRatio": 0.4, "density": 1000}})
    coupler = Coupler(client, scene)
    coupler.add_body(ground)
    coupler.add_body(gripper, contact={"friction": 1.0})

    start = scene.summary(cube)["center_of_mass"][2]
    strip = {}  # open, closed, lifted: side by side in strip.png
    ticks = int(round(args.seconds / TICK))
    for i in range(ticks + 1):
        if i % args.png_every == 0:
            img = render([(scene.positions(cube), 0.6 * args.dx, (220, 120, 110)),
                          (link_points(client, gripper, 0.004), 0.003, (120, 120, 140))],
                         lower=(-0.1, -0.01), upper=(0.1, 0.21))
            write_png(os.path.join(args.out, f"gripper_{i // args.png_every:03d}.png"), img)
            for name, t in (("open", 0.0), ("closed", 0.8), ("lifted", args.seconds)):
                if name not in strip and scene.time >= t - 1e-9:
                    strip[name] = img
            z = scene.summary(cube)["center_of_mass"][2]
            palm = p.getLinkState(gripper, joints["lift"])[0][2]
            print(f"t = {scene.time:.3f} s: palm at z = {palm:.4f} m, cube's centre {1e3 * (z - start):+.1f} mm")
        if i == ticks:
            break
        lift, finger = targets(scene.time)
        p.setJointMotorControl2(gripper, joints["lift"], p.POSITION_CONTROL, targetPosition=lift, force=40)
        for name in ("left", "right"):
            p.setJointMotorControl2(gripper, joints[name], p.POSITION_CONTROL, targetPosition=finger, force=10,
                                    maxVelocity=0.1)
        coupler.step()
    write_png(os.path.join(args.out, "strip.png"), np.concatenate(list(strip.values()), axis=1))
    rise = scene.summary(cube)["center_of_mass"][2] - start
    print(f"the cube rose {1e3 * rise:.1f} mm while the palm rose 50 mm; pictures in {args.out}")
    p.disconnect(client)


if __name__ == "__main__":
    main()
