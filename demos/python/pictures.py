"""Pictures for the Python demos without a plotting library: particles and pybullet links
(boxes, spheres, capsules, cylinders; a mesh as the box bounding it) splatted as shaded discs in a side view (looking along +y, z up), written as PNG with the
standard library's zlib. Good enough to see what happened; mpm_run's renderer is nicer."""

import struct
import zlib

import numpy as np
import pybullet as p


def shell(distance, half, spacing):
    """Points of a lattice `spacing` apart over the box of half sizes `half` whose signed
    distance (negative inside) lies in [-spacing, 0]: a shape's surface, one layer thick."""
    axes = [np.linspace(-h, h, max(2, int(round(2 * h / spacing)) + 1)) for h in half]
    g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    d = distance(g)
    return g[(d <= 1e-9) & (d >= -spacing)]


def shape_points(geometry, dimensions, spacing):
    """Shape-local surface points of a pybullet collision shape, or None for a mesh (and any
    other shape): box (dimensions: full extents), sphere (radius first), capsule and
    cylinder (length, radius; along local z, as pybullet has them)."""
    if geometry == p.GEOM_BOX:
        half = 0.5 * np.asarray(dimensions[:3])
        return shell(lambda q: np.max(np.abs(q) - half, axis=1), half, spacing)
    if geometry == p.GEOM_SPHERE:
        r = dimensions[0]
        return shell(lambda q: np.linalg.norm(q, axis=1) - r, [r] * 3, spacing)
    if geometry in (p.GEOM_CAPSULE, p.GEOM_CYLINDER):
        half_length, r = 0.5 * dimensions[0], dimensions[1]
        if geometry == p.GEOM_CAPSULE:  # within r of the axis segment
            def distance(q):
                axis = np.clip(q[:, 2], -half_length, half_length)
                return np.linalg.norm(q - np.c_[0 * axis, 0 * axis, axis], axis=1) - r
            return shell(distance, [r, r, half_length + r], spacing)
        return shell(lambda q: np.maximum(np.linalg.norm(q[:, :2], axis=1) - r, np.abs(q[:, 2]) - half_length),
                     [r, r, half_length], spacing)
    return None


def link_points(client, body, spacing):
    """World points on every collision shape of a multibody's links (base included): boxes,
    spheres, capsules and cylinders as they are; a mesh as the box that bounds its vertices,
    turning with its link (any shape pybullet gives no vertices of: its world bounding box),
    so that it is seen."""
    pts = []
    for link in range(-1, p.getNumJoints(body, physicsClientId=client)):
        if link < 0:
            com, orn = p.getBasePositionAndOrientation(body, physicsClientId=client)
        else:
            com, orn = p.getLinkState(body, link, computeForwardKinematics=1, physicsClientId=client)[:2]
        for index, s in enumerate(p.getCollisionShapeData(body, link, physicsClientId=client)):
            local = shape_points(s[2], s[3], spacing)
            pos, q = p.multiplyTransforms(com, orn, s[5], s[6])
            if local is None:
                count, vertices = p.getMeshData(body, link, collisionShapeIndex=index, physicsClientId=client)
                if count > 0:
                    lo, hi = np.min(vertices, axis=0), np.max(vertices, axis=0)
                else:
                    lo, hi = (np.asarray(v) for v in p.getAABB(body, link, physicsClientId=client))
                    pos, q = (0, 0, 0), (0, 0, 0, 1)
                half = 0.5 * (hi - lo)
                local = shell(lambda x: np.max(np.abs(x) - half, axis=1), half, spacing) + 0.5 * (lo + hi)
            R = np.array(p.getMatrixFromQuaternion(q)).reshape(3, 3)
            pts.append(local @ R.T + np.asarray(pos))
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def render(batches, lower, upper, width=480):
    """(H, W, 3) uint8 side view of `batches` [(points (N, 3), radius [m], (r, g, b))] over
    the x-z window [lower, upper], the ground z < 0 shaded; nearer points (smaller y) drawn
    over farther ones."""
    scale = width / (upper[0] - lower[0])
    height = int(round((upper[1] - lower[1]) * scale))
    img = np.full((height, width, 3), 245, np.uint8)
    img[max(0, int(upper[1] * scale)):] = (205, 200, 190)  # the ground, z < 0
    depth = np.full((height, width), np.inf)
    for pts, radius, colour in batches:
        r = max(1, int(round(radius * scale)))
        dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
        disc = dx ** 2 + dy ** 2 <= r * r
        shade = np.sqrt(np.clip(1 - (dx ** 2 + dy ** 2) / (r * r + 1e-9), 0, 1))  # a lit sphere's cap
        colour = np.asarray(colour, float)
        for x, y, z in np.asarray(pts, float):
            cx, cy = int((x - lower[0]) * scale), int((upper[1] - z) * scale)
            ys, xs = cy + dy[disc], cx + dx[disc]
            ok = (ys >= 0) & (ys < height) & (xs >= 0) & (xs < width)
            ys, xs, s = ys[ok], xs[ok], shade[disc][ok]
            nearer = y < depth[ys, xs]
            depth[ys[nearer], xs[nearer]] = y
            img[ys[nearer], xs[nearer]] = (colour * (0.55 + 0.45 * s[nearer, None])).astype(np.uint8)
    return img


def write_png(path, img):
    """Writes an (H, W, 3) uint8 image as an RGB PNG."""
    h, w, _ = img.shape
    raw = b"".join(b"\x00" + img[row].tobytes() for row in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
