"""Blades fixed in pybullet bodies (Coupler.add_slicer): the C++ CouplerSlicer test's scalpel
(tests/test_bullet_coupling.cpp), z-up, through the Python coupler."""

import numpy as np
import pybullet as p
import pytest

import mpm_bullet as mb
from mpm_bullet.pybullet import Coupler
from pybullet_scenes import world


# A 20 kg pybullet body (its inertia made huge: held level, as by a hand, since the blade's
# force acts 5 cm below it) carrying a quad blade is thrown sideways at 0.1 m/s through a
# block bonded to a static box, the blade's edge 2 cm deep, the tissue's toughness
# G_c = 50 J/m^2. While its leading end crosses the middle of the block the body decelerates
# at G_c d / M = 0.05 m/s^2 (within 20 %, the C++ bound), and the momentum it lost is the
# impulse the scene reported on the blade (within 1 %).
def test_a_dynamic_scalpel_is_slowed_by_the_toughness():
    client = world(0.0)
    scene = mb.Scene({"domain": {"lower": [-0.1, -0.1, -0.04], "upper": [0.1, 0.1, 0.1]}, "dx": 0.01,
                      "gravity": [0, 0, 0], "backend": "Cpu", "cpuThreads": 1})
    scene.add_object({"primitive": "Box", "center": [0, 0, 0.02], "halfExtents": [0.04, 0.03, 0.02],
                      "material": {"youngsModulus": 1e5, "fractureToughness": 50}})
    ground = p.createMultiBody(0, p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.06, 0.05, 0.01],
                                                         physicsClientId=client),
                               basePosition=[0, 0, -0.01], physicsClientId=client)
    mass, depth, half, speed = 20.0, 0.02, 0.02, 0.1
    box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[half, 0.001, 0.01], physicsClientId=client)
    scalpel = p.createMultiBody(mass, box, basePosition=[0.04 + half + 0.005, 0.0032, 0.04 - depth + 0.05],
                                physicsClientId=client)
    p.setCollisionFilterGroupMask(scalpel, -1, 0, 0, physicsClientId=client)  # touches only the tissue
    p.changeDynamics(scalpel, -1, linearDamping=0, angularDamping=0, localInertiaDiagonal=[1e6] * 3,
                     physicsClientId=client)
    p.resetBaseVelocity(scalpel, [-speed, 0, 0], [0, 0, 0], physicsClientId=client)
    coupler = Coupler(client, scene)
    coupler.add_body(ground, contact={"mode": "bonded"})
    # the blade: edge along x, 5 cm below the body's centre, its faces (local z = 0) upright
    # and along the motion, its width (local y) upwards
    upright = p.getQuaternionFromEuler([np.pi / 2, 0, 0])
    blade = coupler.add_slicer(scalpel, pose=((0, 0, -0.05), upright), half_length=half, width=0.1)
    t, v, impulse, v_in = [], [], 0.0, None
    for f in range(180):
        before = p.getBaseVelocity(scalpel, physicsClientId=client)[0][0]
        coupler.step()
        lead = p.getBasePositionAndOrientation(scalpel, physicsClientId=client)[0][0] - half
        if abs(lead) < 0.02:  # the leading end crosses the block's middle
            if v_in is None:
                v_in = before
            impulse += float(scene.slicer_impulse(blade)[0][0])
            t.append((f + 1) / 240)
            v.append(p.getBaseVelocity(scalpel, physicsClientId=client)[0][0])
        elif v_in is not None:
            break
    assert len(t) > 20
    a = np.polyfit(t, v, 1)[0]
    expected = 50.0 * depth / mass
    lost = mass * (v[-1] - v_in)
    print(f"scalpel: deceleration {a:.4f} m/s^2 (G_c d / M = {expected:.4f}, {100 * (a / expected - 1):+.1f} %); "
          f"momentum change {lost:.5f} N s, blade impulses {impulse:.5f} N s")
    assert a == pytest.approx(expected, rel=0.2)
    assert lost == pytest.approx(impulse, rel=0.01, abs=1e-6)
    p.disconnect(client)


# A needle (a half circle of 12 mm) on a free 20 g pybullet body, coupled with add_needle,
# thrown tip first into a free soft block (E 30 kPa, dx 2.5 mm) at 0.2 m/s, gravity off: the
# C++ NeedleCoupling.BlockGainsWhatTheNeedleLoses (tests/test_suturing_bullet.cpp), in its
# own axes (nothing here has a down). Over 50 ms of 1/960 s steps the block gains the
# momentum the needle's body loses (1e-4 of the throw, the C++ bound), and the tissue has
# slowed the needle. Removing the body takes the needle out of the scene.
def test_a_needle_body_loses_what_the_block_gains():
    client = world(0.0, tick=1.0 / 960)
    scene = mb.Scene({"domain": {"lower": [-0.04, -0.02, -0.02], "upper": [0.04, 0.05, 0.02]}, "dx": 0.0025,
                      "gravity": [0, 0, 0], "backend": "Cpu", "cpuThreads": 1})
    block = scene.add_object({"primitive": "Box", "center": [0, 0.01, 0], "halfExtents": [0.02, 0.01, 0.00625],
                              "material": {"youngsModulus": 3e4, "poissonRatio": 0.3, "density": 1000,
                                           "fractureToughness": 25}})
    m, v0 = 0.02, np.array([0, -0.2, 0])
    ball = p.createCollisionShape(p.GEOM_SPHERE, radius=0.001, physicsClientId=client)
    body = p.createMultiBody(m, ball, basePosition=[0.012, 0.022, 0], physicsClientId=client)
    p.changeDynamics(body, -1, linearDamping=0, angularDamping=0, physicsClientId=client)
    p.resetBaseVelocity(body, v0.tolist(), [0, 0, 0], physicsClientId=client)
    coupler = Coupler(client, scene)
    # the arc's centre at the body's centre of mass: its tip (angle pi) 2 mm above the block
    needle = coupler.add_needle(body, radius=0.012, start_angle=0.0, end_angle=np.pi)
    pb0 = np.array(scene.summary(block)["momentum"])
    for _ in range(48):  # 50 ms
        coupler.step()
    lost = m * (v0 - np.array(p.getBaseVelocity(body, physicsClientId=client)[0]))
    gained = np.array(scene.summary(block)["momentum"]) - pb0
    throw = m * np.linalg.norm(v0)
    print(f"needle thrown with {throw:.4e} kg m/s, lost {lost}, block gained {gained}: |gained - lost| / throw "
          f"{np.linalg.norm(gained - lost) / throw:.2e}; tip inside {scene.tip_inside(needle)}")
    assert np.linalg.norm(lost) > 0.01 * throw, "the tissue slowed the needle"
    assert np.linalg.norm(gained - lost) < 1e-4 * throw
    coupler.remove(body)
    assert not scene.is_valid(needle)
    p.disconnect(client)
