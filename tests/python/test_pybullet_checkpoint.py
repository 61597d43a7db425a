"""Rewinding a coupled world, as a learning environment's reset does: the scene's checkpoint
bytes (Scene.save_bytes) with pybullet's own saveState. The run after restoring repeats the
run after saving bit for bit, tissue and body alike."""

import numpy as np
import pybullet as p

from pybullet_scenes import resting_sphere


def test_restored_world_repeats_its_run_bit_for_bit():
    client, scene, coupler, sphere, slab = resting_sphere()
    for _ in range(30):  # the sphere in contact, the slab moving
        coupler.step()
    tissue, world = scene.save_bytes(), p.saveState(physicsClientId=client)

    def run():
        for _ in range(20):
            coupler.step()
        pos, orn = p.getBasePositionAndOrientation(sphere, physicsClientId=client)
        v, w = p.getBaseVelocity(sphere, physicsClientId=client)
        return scene.positions(slab), scene.velocities(slab), np.array(pos + orn + v + w), scene.time

    first = run()
    scene.load_bytes(tissue)
    p.restoreState(world, physicsClientId=client)
    again = run()
    assert first[3] == again[3], "the scene's clock"
    for a, b, what in zip(first[:3], again[:3], ("positions", "velocities", "sphere")):
        assert np.array_equal(a, b), f"{what} differ after restoring: largest {np.abs(a - b).max():.3e}"
    p.disconnect(client)
