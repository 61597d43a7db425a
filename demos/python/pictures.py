"""Pictures for the Python demos without a plotting library: particles and box-shaped links
splatted as shaded discs in a side view (looking along +y, z up), written as PNG with the
standard library's zlib. Good enough to see what happened; mpm_run's renderer is nicer."""

import struct
import zlib

import numpy as np
import pybullet as p


def box_points(half, position, orientation, spacing):
    """Points on the surface of a box of half extents `half` at a pose, `spacing` apart."""
    axes = [np.linspace(-h, h, max(2, int(round(2 * h / spacing)) + 1)) for h in half]
    g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    g = g[np.any(np.isclose(np.abs(g), half), axis=1)]
    R = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
    return g @ R.T + np.asarray(position)


def link_boxes(client, body, spacing):
    """Surface points of every box collision shape of a multibody's links (base included)."""
    pts = []
    for link in range(-1, p.getNumJoints(body, physicsClientId=client)):
        if link < 0:
            com, orn = p.getBasePositionAndOrientation(body, physicsClientId=client)
        else:
            com, orn = p.getLinkState(body, link, computeForwardKinematics=1, physicsClientId=client)[:2]
        for s in p.getCollisionShapeData(body, link, physicsClientId=client):
            if s[2] == p.GEOM_BOX:
                pos, q = p.multiplyTransforms(com, orn, s[5], s[6])
                pts.append(box_points(0.5 * np.array(s[3]), pos, q, spacing))
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
