"""Which pybullet bodies and links the coupler takes, and in which frames: a static body of
two collision shapes (a compound) and a URDF robot (a fixed base and a link on a fixed joint,
their inertial frames offset and turned against their link frames) each hold up tissue on
every part; bad input is refused naming it."""

import os

import numpy as np
import pybullet as p
import pytest

import mpm_bullet as mb
from mpm_bullet.pybullet import Coupler
from pybullet_scenes import G, SOFT_TISSUE, free_sphere, resting_sphere, world

HERE = os.path.dirname(os.path.abspath(__file__))
PAD_TOP = 0.02  # every pad's top [m]
DX = 0.02


def pads_under_blocks():
    """Four pads 7 x 7 x 2 cm in a row along x, tops at z = 2 cm: two are the parts of one
    static body, one the base of two_pads.urdf (fixed), one its link (0.3 kg, fixed joint).
    A 6 cm block of tissue is dropped on each from 5 mm; a pad the coupler missed or put
    in the wrong place lets its block fall to the domain's floor or rest at another height."""
    client = world(G)
    scene = mb.Scene({"domain": {"lower": [-0.26, -0.08, -0.06], "upper": [0.26, 0.08, 0.14]}, "dx": DX,
                      "gravity": [0, 0, -G], "backend": "Cpu", "cpuThreads": 1})
    xs = [-0.165, -0.055, 0.055, 0.165]
    blocks = [scene.add_object({"primitive": "Box", "center": [x, 0, PAD_TOP + 0.03 + 0.005],
                                "halfExtents": [0.03, 0.03, 0.03], "material": SOFT_TISSUE}) for x in xs]
    two = p.createCollisionShapeArray([p.GEOM_BOX, p.GEOM_BOX], halfExtents=[[0.035, 0.035, 0.01]] * 2,
                                      collisionFramePositions=[[xs[0], 0, 0], [xs[1], 0, 0]], physicsClientId=client)
    compound = p.createMultiBody(0, two, basePosition=[0, 0, 0.01], physicsClientId=client)
    robot = p.loadURDF(os.path.join(HERE, "assets", "two_pads.urdf"), [xs[2], 0, 0.01], useFixedBase=True,
                       physicsClientId=client)
    coupler = Coupler(client, scene)
    compound_shapes = coupler.add_body(compound)
    robot_shapes = coupler.add_body(robot)
    return client, scene, coupler, blocks, compound_shapes, robot_shapes, robot


# Averaged over 0.25-0.5 s each shape carries the blocks on it: the impulse the grid gave it
# balances their weight and momentum change (J + m g T + dp = 0: the blocks touch nothing
# else), and once settled their weight alone, J / (m g T) = -1 within 2 % as the resting
# sphere. Each block's centre rests 3 cm above its pad's top within half a cell (its own
# compression, rho g h^2 / 2E, is 0.1 mm; the grid's contact gap is of a quarter cell), the
# C++ resting tests' bound; without its pad a block falls to the domain's floor.
def test_compound_parts_and_urdf_links_each_hold_their_tissue():
    client, scene, coupler, blocks, compound_shapes, robot_shapes, _ = pads_under_blocks()
    assert len(compound_shapes) == 1 and len(robot_shapes) == 2, "one shape per body part with geometry"
    shapes = [compound_shapes[0], robot_shapes[0], robot_shapes[1]]
    carried = [[blocks[0], blocks[1]], [blocks[2]], [blocks[3]]]
    J = np.zeros(3)
    window = 0.0
    start = None
    for _ in range(120):  # 0.5 s
        if scene.time > 0.25 and start is None:
            start = [sum(scene.summary(b)["momentum"][2] for b in group) for group in carried]
        coupler.step()
        if start is not None:
            J += [float(scene.shape_impulse(s)[0][2]) for s in shapes]
            window += coupler.last_dt
    end = [sum(scene.summary(b)["momentum"][2] for b in group) for group in carried]
    for k, group in enumerate(carried):
        m = sum(scene.summary(b)["mass"] for b in group)
        balance = J[k] + m * G * window + (end[k] - start[k])
        print(f"shape {k}: J_z {J[k]:.6f} N s over {window:.3f} s, -m g T {-m * G * window:.6f}, dp "
              f"{end[k] - start[k]:.2e}: balance {balance:.2e}, rest {-J[k] / (m * G * window):.4f}")
        assert abs(balance) < 1e-3 * m * G * window, f"shape {k}: J + m g T + dp"
        assert -J[k] / (m * G * window) == pytest.approx(1.0, abs=0.02), f"shape {k} carries its blocks' weight"
    for i, b in enumerate(blocks):
        z = scene.summary(b)["center_of_mass"][2]
        print(f"block {i}: centre of mass at z = {z:.4f} m, 3 cm above the pad's top: {PAD_TOP + 0.03:.4f}")
        assert abs(z - (PAD_TOP + 0.03)) < 0.5 * DX, f"block {i} rests on its pad"
    p.disconnect(client)


def test_links_are_coupled_in_their_centre_of_mass_frames():
    # the link's shape sits where pybullet's collision shape is: its pose is the link's
    # centre-of-mass frame, its box part placed relative to it as getCollisionShapeData says
    client, scene, coupler, blocks, compound_shapes, robot_shapes, robot = pads_under_blocks()
    com, orn = p.getLinkState(robot, 0, computeForwardKinematics=1, physicsClientId=client)[:2]
    pos, q, _, _ = scene.shape_state(robot_shapes[1])
    assert np.allclose(pos, com, atol=1e-6) and abs(abs(np.dot(q, orn)) - 1) < 1e-6
    # the pad's box centre in the world from the shape's frame: (0.165, 0, 0.01)
    local = p.getCollisionShapeData(robot, 0, physicsClientId=client)[0][5:7]
    centre, _ = p.multiplyTransforms(com, orn, *local)
    assert np.allclose(centre, (0.165, 0, 0.01), atol=1e-6)
    p.disconnect(client)


# A capsule and a cylinder lying along y (their local z turned onto y) and a mesh block
# (6 x 8 x 3 cm, its collision frame 3 cm above its centre of mass), 0.2 kg each, dropped on
# the resting-sphere slab, come to rest with their lowest points on the tissue's top
# (0.102 m) within half a cell, the C++ resting tests' bound, and dent the tissue by less
# than a quarter of a cell (measured 0.7 mm). A part along the wrong axis pokes 3 cm into
# the tissue (the capsule's and cylinder's half-lengths are 5 cm, their radii 2 cm) and
# pushes it 13 mm aside (measured with the capsules' axis on local y); a mesh without its
# frame offset would sit 3 cm lower in the tissue.
def test_capsule_cylinder_and_mesh_rest_at_their_heights():
    client, scene, coupler, _, slab = resting_sphere(mass=0.2, radius=0.02)
    along_y = p.getQuaternionFromEuler([np.pi / 2, 0, 0])
    bodies = {}
    for name, kind, x in (("capsule", p.GEOM_CAPSULE, -0.09), ("cylinder", p.GEOM_CYLINDER, 0.0)):
        col = p.createCollisionShape(kind, radius=0.02, height=0.1, physicsClientId=client)
        bodies[name] = (p.createMultiBody(0.2, col, basePosition=[x, 0.1, 0.13], baseOrientation=along_y,
                                          physicsClientId=client), 0.02)
    col = p.createCollisionShape(p.GEOM_MESH, fileName=os.path.join(HERE, "assets", "block_6x8x3cm.obj"),
                                 collisionFramePosition=[0, 0, 0.03], physicsClientId=client)
    bodies["mesh"] = (p.createMultiBody(0.2, col, basePosition=[0.09, 0.1, 0.13 - 0.015], physicsClientId=client),
                      -0.03 + 0.015)  # centre of mass above the lowest point
    for body, _ in bodies.values():
        p.changeDynamics(body, -1, linearDamping=0, angularDamping=0, physicsClientId=client)
        coupler.add_body(body, contact={"friction": 0.5})
    x0 = scene.positions(slab).copy()
    for _ in range(144):  # 0.6 s
        coupler.step()
    moved = np.linalg.norm(scene.positions(slab) - x0, axis=1).max()
    print(f"largest particle displacement {1e3 * moved:.2f} mm")
    assert moved < 0.25 * DX, "the bodies dent the tissue, not poke into it"
    for name, (body, above) in bodies.items():
        (x, y, z), _ = p.getBasePositionAndOrientation(body, physicsClientId=client)
        v = np.linalg.norm(p.getBaseVelocity(body, physicsClientId=client)[0])
        print(f"{name}: lowest point at z = {z - above:.4f} m (tissue top 0.102), speed {v:.4f} m/s")
        assert abs(z - above - 0.102) < 0.5 * DX, f"the {name} rests on the tissue"
        assert v < 0.05, f"the {name} has come to rest"
    p.disconnect(client)


def test_bad_input_is_refused_naming_it():
    client = world(G)
    scene = mb.Scene({"domain": {"lower": [-0.1] * 3, "upper": [0.1] * 3}, "dx": 0.02, "backend": "Cpu"})
    coupler = Coupler(client, scene)
    sphere = p.createCollisionShape(p.GEOM_SPHERE, radius=0.02, physicsClientId=client)
    maximal = p.createMultiBody(1.0, sphere, useMaximalCoordinates=True, physicsClientId=client)
    with pytest.raises(mb.InvalidArgument, match="useMaximalCoordinates"):
        coupler.add_body(maximal)
    body = p.createMultiBody(1.0, sphere, physicsClientId=client)
    with pytest.raises(mb.InvalidArgument, match=r"Coupler.add_body link_index = 3: body \d+ has links -1"):
        coupler.add_body(body, link_index=3)
    coupler.add_body(body)
    with pytest.raises(mb.InvalidArgument, match="already coupled"):
        coupler.add_body(body)
    with pytest.raises(mb.InvalidArgument, match="not coupled"):
        coupler.shape_of(body, 0)
    coupler.remove(body)
    with pytest.raises(mb.InvalidArgument, match="not coupled"):
        coupler.shape_of(body)
    with pytest.raises(mb.InvalidArgument, match="Coupler client_id = 99"):
        Coupler(99, scene)
    with pytest.raises(mb.InvalidArgument, match="Coupler.add_body mode = 'floating'"):
        coupler.add_body(body, mode="floating")
    # the scene kept its default gravity (0, -9.81, 0) in pybullet's z-up world
    with pytest.warns(UserWarning, match=r"gravity \(0.0, -9.81.*\) is not pybullet's \(0.0, 0.0, -9.81\)"):
        coupler.step()
    p.disconnect(client)
