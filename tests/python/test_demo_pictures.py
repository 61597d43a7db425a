"""demos/python/pictures.py draws every link of a pybullet body: a box, a sphere, a capsule, a
cylinder and a mesh (the box bounding its vertices, turned with the body) each give points
on or just inside their surface (within the spacing), where the link is."""
import os
import sys

import numpy as np
import pybullet as p
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "demos", "python"))
from pictures import link_points  # noqa: E402

ASSETS = os.path.join(os.path.dirname(__file__), "..", "..", "assets")
SPACING = 0.004


@pytest.fixture
def client():
    c = p.connect(p.DIRECT)
    yield c
    p.disconnect(c)


def body(client, shape, x):
    """A static body of one collision shape at (x, 0, 0.1), turned 90 degrees about y."""
    return p.createMultiBody(0, shape, basePosition=[x, 0, 0.1],
                             baseOrientation=p.getQuaternionFromEuler([0, np.pi / 2, 0]), physicsClientId=client)


def test_every_shape_gives_points_on_its_surface(client):
    r, length = 0.02, 0.08
    shapes = {
        # name: (shape, distance of a local point to the surface, negative inside)
        "box": (p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.03, 0.02, 0.01], physicsClientId=client),
                lambda q: np.max(np.abs(q) - [0.03, 0.02, 0.01], axis=1)),
        "sphere": (p.createCollisionShape(p.GEOM_SPHERE, radius=r, physicsClientId=client),
                   lambda q: np.linalg.norm(q, axis=1) - r),
        "capsule": (p.createCollisionShape(p.GEOM_CAPSULE, radius=r, height=length, physicsClientId=client),
                    lambda q: np.linalg.norm(q - np.c_[0 * q[:, :2], np.clip(q[:, 2], -length / 2, length / 2)],
                                             axis=1) - r),
        "cylinder": (p.createCollisionShape(p.GEOM_CYLINDER, radius=r, height=length, physicsClientId=client),
                     lambda q: np.maximum(np.linalg.norm(q[:, :2], axis=1) - r, np.abs(q[:, 2]) - length / 2)),
        "mesh": (p.createCollisionShape(p.GEOM_MESH, fileName=os.path.join(ASSETS, "sphere.obj"),
                                        physicsClientId=client),
                 lambda q: np.max(np.abs(q) - 0.05, axis=1)),  # sphere.obj: radius 0.05, drawn as its box
    }
    for i, (name, (shape, distance)) in enumerate(shapes.items()):
        x = 0.2 * i
        b = body(client, shape, x)
        pts = link_points(client, b, SPACING)
        assert len(pts) > 50, name
        # into the body's frame: the body is turned 90 degrees about y, at (x, 0, 0.1)
        R = np.array(p.getMatrixFromQuaternion(p.getQuaternionFromEuler([0, np.pi / 2, 0]))).reshape(3, 3)
        local = (pts - [x, 0, 0.1]) @ R
        d = distance(local)
        assert np.all(d <= 1e-6) and np.all(d >= -SPACING - 1e-6), (name, d.min(), d.max())
        # all round: the points reach the shape's extent on every local axis
        assert np.allclose(local.max(axis=0), -local.min(axis=0), atol=SPACING), name
