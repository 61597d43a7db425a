"""Scenes of the pybullet coupling tests, shared with bench/pybullet_overhead.py: the C++
tests' scenes (tests/test_bullet_coupling.cpp, tests/test_bullet_physics.cpp) turned z-up,
pybullet's convention, so the physics they verify is known to hold at these sizes."""

import pybullet as p

import mpm_bullet as mb
from mpm_bullet.pybullet import Coupler

G = 9.81
SOFT_TISSUE = {"model": "NeoHookeanDecoupled", "youngsModulus": 2e5, "poissonRatio": 0.3, "density": 1000}


def world(gravity, tick=1.0 / 240, sub_steps=0):
    """A headless pybullet world stepping `tick` per stepSimulation, in `sub_steps` ticks of
    its own (0: one)."""
    client = p.connect(p.DIRECT)
    p.setGravity(0, 0, -gravity, physicsClientId=client)
    p.setPhysicsEngineParameter(fixedTimeStep=tick, numSubSteps=sub_steps, physicsClientId=client)
    return client


def free_sphere(client, radius, mass, position, velocity=(0, 0, 0)):
    """A pybullet sphere without pybullet's default damping (0.04), which would take
    momentum the coupling did not."""
    col = p.createCollisionShape(p.GEOM_SPHERE, radius=radius, physicsClientId=client)
    body = p.createMultiBody(mass, col, basePosition=position, physicsClientId=client)
    p.changeDynamics(body, -1, linearDamping=0, angularDamping=0, physicsClientId=client)
    p.resetBaseVelocity(body, velocity, (0, 0, 0), physicsClientId=client)
    return body


def resting_sphere(mass=2.0, radius=0.06, tissue=True):
    """RestingBoxFeelsItsWeight's scene (test_bullet_coupling.cpp), z-up, with a sphere for
    the box: a soft slab 0.3 x 0.3 x 0.1 m (E 200 kPa) on a static ground plane z = 0, dx 2 cm,
    the sphere dropped from 5 mm above it. Returns (client, scene, coupler, sphere, slab);
    tissue=False leaves the slab out (slab None), for timing the coupling alone."""
    client = world(G)
    scene = mb.Scene({"domain": {"lower": [-0.25, -0.25, -0.1], "upper": [0.25, 0.25, 0.4]}, "dx": 0.02,
                      "gravity": [0, 0, -G], "backend": "Cpu", "cpuThreads": 1})
    slab = scene.add_object({"primitive": "Box", "center": [0, 0, 0.05 + 0.002], "halfExtents": [0.15, 0.15, 0.05],
                             "material": SOFT_TISSUE}) if tissue else None
    ground = p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=client), physicsClientId=client)
    sphere = free_sphere(client, radius, mass, (0, 0, 0.104 + radius + 0.005))
    coupler = Coupler(client, scene)
    coupler.add_body(ground)
    coupler.add_body(sphere, contact={"friction": 0.5})
    return client, scene, coupler, sphere, slab


def sphere_at_free_tissue(sub_steps=0):
    """SphereHittingFreeTissueConservesTotalMomentum's scene (test_bullet_physics.cpp): zero
    gravity, no walls, a 6 cm block of tissue (0.216 kg) at dx 1 cm and a 0.2 kg sphere of
    radius 2 cm thrown at it at 2 m/s, 1 cm off its axis. Returns (client, scene, coupler,
    sphere, block, sphere mass). `sub_steps`: pybullet's numSubSteps."""
    client = world(0.0, sub_steps=sub_steps)
    scene = mb.Scene({"domain": {"lower": [-0.3, -0.3, -0.3], "upper": [0.3, 0.3, 0.3], "walls": False},
                      "dx": 0.01, "gravity": [0, 0, 0], "backend": "Cpu", "cpuThreads": 1})
    block = scene.add_object({"primitive": "Box", "center": [0, 0, 0], "halfExtents": [0.03, 0.03, 0.03],
                              "material": SOFT_TISSUE})
    radius, mass, speed = 0.02, 0.2, 2.0
    sphere = free_sphere(client, radius, mass, (-0.03 - radius - 0.01, 0, 0.01), (speed, 0, 0))
    coupler = Coupler(client, scene)
    coupler.add_body(sphere, contact={"friction": 0.3})
    return client, scene, coupler, sphere, block, mass
