"""Physics of mpm_bullet.pybullet.Coupler against closed forms, on the C++ tests' scenes
(pybullet_scenes.py): a sphere resting on tissue carries its weight, and a sphere thrown at
free tissue keeps the total momentum. Coarse and short: a few seconds each on one core."""

import numpy as np
import pybullet as p
import pytest

import mpm_bullet as mb

from pybullet_scenes import G, resting_sphere, sphere_at_free_tissue


# A 2 kg sphere dropped from 5 mm onto the slab rocks on it (an undamped elastic contact)
# and comes to rest. Averaged over 0.8-1.2 s the vertical impulse the grid gave it carries its
# weight: J_z / (m g T) = 1 within 2 %, the C++ RestingBoxFeelsItsWeight's bound. (Over
# 0.4-0.8 s, the C++ test's window, the sphere, on a softer Hertz contact than the box's
# flat face, still rocks at 0.1 m/s: its momentum change there is 3 % of m g T.) Over the
# whole run the sphere's own balance J_z - m g T = dp holds to rounding: pybullet received
# the grid's impulse exactly once.
def test_sphere_resting_on_tissue_carries_its_weight():
    client, scene, coupler, sphere, slab = resting_sphere(mass=2.0)
    shape = coupler.shape_of(sphere)
    mass = p.getDynamicsInfo(sphere, -1, physicsClientId=client)[0]
    impulse, window, total, elapsed = 0.0, 0.0, 0.0, 0.0
    for _ in range(288):  # 1.2 s at 1/240 s
        coupler.step()
        total += float(scene.shape_impulse(shape)[0][2])
        elapsed += coupler.last_dt
        if scene.time > 0.8:
            impulse += float(scene.shape_impulse(shape)[0][2])
            window += coupler.last_dt
    ratio = impulse / (mass * G * window)
    (x, y, z), _ = p.getBasePositionAndOrientation(sphere, physicsClientId=client)
    v, _ = p.getBaseVelocity(sphere, physicsClientId=client)
    balance = total - mass * G * elapsed - mass * v[2]  # it started at rest
    print(f"resting sphere: J_z / (m g T) = {ratio:.4f} over {window:.3f} s; J - m g t - dp = {balance:.2e} N s "
          f"over {elapsed:.2f} s; centre at z = {z:.4f} m, speed {np.linalg.norm(v):.4f} m/s")
    assert window > 0.3
    assert ratio == pytest.approx(1.0, abs=0.02), "time-averaged vertical impulse over m g T"
    assert abs(balance) < 1e-4 * mass * G * elapsed, "the sphere's momentum balance"
    assert np.linalg.norm(v) < 0.05, "the sphere has come to rest"
    # on the tissue, neither through it nor floating on a cushion of grid: its bottom within
    # half a cell of the slab's top (0.104 m); Hertz puts it 4 mm in (F = 4/3 E* R^1/2 d^3/2,
    # E* = E / (1 - nu^2) = 220 kPa, R 6 cm, F 19.6 N)
    assert abs((z - 0.06) - 0.104) < 0.5 * 0.02
    p.disconnect(client)


# Zero gravity, no walls: the 0.2 kg sphere at 2 m/s hits the free block. Nothing else acts,
# so m v (pybullet) + sum m_p v_p (particles) stays p0 through the collision; the grid's
# momentum reaches pybullet as a force over each step, so the drift is rounding only. 1 % of
# |p0| is the C++ test's bound. The sphere must have handed on most of its momentum. After
# every step pybullet's sphere moves and spins as the scene's dynamic shape ended the step
# (the force at its centre of mass and the torque, world frame, applied exactly), to float
# rounding (measured 3e-7). (The angular momentum about the origin is not kept exactly: the
# scene moves the shape through its substeps while pybullet applies the step's impulse at
# where the centre of mass was at its start, as the C++ coupler applies it to a Bullet body;
# measured here 2.5 % of L0 = m r x v, all of it while the sphere is in contact.) With
# pybullet's numSubSteps 4 the force must act over all four of its ticks. With the tissue
# advanced once every 4 steps (Coupler.tissue_interval) the same holds where the intervals
# end (the sphere has then received all of the advance's momentum).
@pytest.mark.parametrize("sub_steps,interval", [(0, 1), (4, 1), (0, 4)])
def test_sphere_thrown_at_free_tissue_conserves_momentum(sub_steps, interval):
    client, scene, coupler, sphere, block, mass = sphere_at_free_tissue(sub_steps)
    coupler.tissue_interval = interval
    shape = coupler.shape_of(sphere)

    def total():
        v, _ = p.getBaseVelocity(sphere, physicsClientId=client)
        return mass * np.array(v) + np.array(scene.summary(block)["momentum"])

    p0 = total()
    drift = off_v = off_w = 0.0
    for k in range(20):  # 83 ms, as the C++ test's 5 frames of 1/60 s
        coupler.step()
        if (k + 1) % interval:
            continue  # inside an interval: the scene is ahead of pybullet
        drift = max(drift, float(np.linalg.norm(total() - p0)))
        v, w = p.getBaseVelocity(sphere, physicsClientId=client)
        _, _, vs, ws = scene.shape_state(shape)
        off_v = max(off_v, float(np.abs(np.array(v) - vs).max()))
        off_w = max(off_w, float(np.abs(np.array(w) - ws).max()))
    tissue = np.array(scene.summary(block)["momentum"])
    v, w = p.getBaseVelocity(sphere, physicsClientId=client)
    print(f"thrown sphere (tissue every {interval} steps): p0 = {p0}, sphere p_x {mass * v[0]:.5f}, tissue p = {tissue}; largest |p - p0| = "
          f"{drift:.2e} ({100 * drift / np.linalg.norm(p0):.4f} % of |p0|); sphere spin {w[1]:.3f} rad/s; pybullet "
          f"against the scene's shape: velocity {off_v:.1e} m/s, spin {off_w:.1e} rad/s")
    assert drift < 0.01 * np.linalg.norm(p0), "total momentum drift"
    assert tissue[0] > 0.5 * p0[0], "the sphere hit and handed on most of its momentum"
    assert mass * v[0] < 0.5 * p0[0]
    assert abs(w[1]) > 1.0, "the off-centre hit with friction spins the sphere"
    assert off_v < 1e-5 and off_w < 1e-5, "pybullet's sphere leaves each step as the scene's shape did"
    p.disconnect(client)


# The interval is a count of steps >= 1, changed only between intervals (as the C++
# Coupler::setTissueInterval); a step that advances says so, and its impulses are the
# advance's over the interval.
def test_tissue_interval_is_checked_and_set_between_intervals():
    client, scene, coupler, sphere, block, mass = sphere_at_free_tissue()
    for bad in (0, -2, 1.5, True):
        with pytest.raises(mb.InvalidArgument, match=r"Coupler.tissue_interval = .*: must be an int >= 1"):
            coupler.tissue_interval = bad
    coupler.tissue_interval = 2
    coupler.step()
    assert coupler.tissue_advanced and scene.time == pytest.approx(2 * coupler.last_dt)
    with pytest.raises(mb.InvalidArgument, match="cannot change while an interval is open"):
        coupler.tissue_interval = 3
    coupler.step()
    assert not coupler.tissue_advanced
    coupler.tissue_interval = 3
    assert coupler.tissue_interval == 3
    p.disconnect(client)
