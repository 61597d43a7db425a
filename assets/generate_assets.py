#!/usr/bin/env python3
"""Writes the project's test and demo meshes into this folder (standard library only).

    python3 assets/generate_assets.py            # rewrites the files next to this script
    python3 assets/generate_assets.py --check    # fails if a committed file differs

Every mesh is in metres, in its own frame, with triangles wound counter-clockwise seen from
outside (outward normals). The counts and bounds the tests expect are printed at the end
and listed in README.md; change both together.
"""
import base64
import json
import math
import os
import struct
import sys

HERE = os.path.dirname(os.path.abspath(__file__))

SPHERE_RADIUS = 0.05          # [m]
SPHERE_SUBDIVISIONS = 3       # 20 * 4^3 = 1280 triangles, 642 vertices
SLAB_SIZE = (0.2, 0.04, 0.2)  # [m] full extents, centred on the origin
BOX_HALF = 0.05               # [m]
BOWL_RADIUS = 0.05            # [m]
BOWL_RINGS = 8                # latitude rings below the rim
BOWL_SEGMENTS = 24            # longitude segments


def fmt(x):
    # shortest round-trip text of a double, with -0 written as 0
    if x == 0:
        return "0"
    return repr(float(x))


# ---------------------------------------------------------------- geometry helpers
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def normalize(v):
    n = math.sqrt(dot(v, v))
    return (v[0] / n, v[1] / n, v[2] / n)


def signed_volume(vertices, triangles):
    """Positive for a closed mesh with outward (counter-clockwise) winding."""
    return sum(dot(vertices[a], cross(vertices[b], vertices[c])) for a, b, c in triangles) / 6.0


def edge_report(triangles):
    """(boundary, non-manifold, misoriented) edge counts."""
    uses = {}
    for t in triangles:
        for u, v in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            key = (min(u, v), max(u, v))
            forward, backward = uses.get(key, (0, 0))
            uses[key] = (forward + (u < v), backward + (u > v))
    boundary = sum(1 for f, b in uses.values() if f + b == 1)
    nonmanifold = sum(1 for f, b in uses.values() if f + b > 2)
    misoriented = sum(1 for f, b in uses.values() if f + b == 2 and (f == 2 or b == 2))
    return boundary, nonmanifold, misoriented


def bounds(vertices):
    lo = tuple(min(v[i] for v in vertices) for i in range(3))
    hi = tuple(max(v[i] for v in vertices) for i in range(3))
    return lo, hi


# ---------------------------------------------------------------- meshes
def icosphere(radius, subdivisions):
    t = (1.0 + math.sqrt(5.0)) / 2.0
    unit = [normalize(p) for p in [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
                                   (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
                                   (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
             (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
             (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
             (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        midpoint = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in midpoint:
                pa, pb = unit[a], unit[b]
                unit.append(normalize(((pa[0] + pb[0]) / 2, (pa[1] + pb[1]) / 2, (pa[2] + pb[2]) / 2)))
                midpoint[key] = len(unit) - 1
            return midpoint[key]

        refined = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            refined += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = refined
    vertices = [(radius * p[0], radius * p[1], radius * p[2]) for p in unit]
    return vertices, faces


def box(half):
    """Axis-aligned box centred on the origin, 8 vertices, 12 triangles."""
    hx, hy, hz = half
    vertices = [(x, y, z) for x in (-hx, hx) for y in (-hy, hy) for z in (-hz, hz)]
    # vertex index = 4*ix + 2*iy + iz; each quad listed counter-clockwise seen from outside
    quads = [(0, 1, 3, 2),   # -x
             (4, 6, 7, 5),   # +x
             (0, 4, 5, 1),   # -y
             (2, 3, 7, 6),   # +y
             (0, 2, 6, 4),   # -z
             (1, 5, 7, 3)]   # +z
    faces = []
    for a, b, c, d in quads:
        faces += [(a, b, c), (a, c, d)]
    return vertices, faces


def bowl(radius, rings, segments):
    """Lower hemisphere shell (y <= 0), open along the rim at y = 0: not watertight."""
    vertices = [(0.0, -radius, 0.0)]  # south pole
    for r in range(1, rings + 1):
        polar = math.pi / 2 * r / rings  # from the pole (0) to the rim (pi/2)
        for s in range(segments):
            azimuth = 2 * math.pi * s / segments
            vertices.append((radius * math.sin(polar) * math.cos(azimuth),
                             0.0 if r == rings else -radius * math.cos(polar),
                             radius * math.sin(polar) * math.sin(azimuth)))

    def ring(r, s):
        return 1 + (r - 1) * segments + s % segments

    faces = []
    # outward = away from the centre, i.e. the convex underside faces out
    for s in range(segments):
        faces.append((0, ring(1, s), ring(1, s + 1)))
    for r in range(1, rings):
        for s in range(segments):
            a, b = ring(r, s), ring(r, s + 1)
            c, d = ring(r + 1, s + 1), ring(r + 1, s)
            faces += [(a, c, b), (a, d, c)]
    return vertices, faces


def scalpel():
    """A blade-like prism: a convex 2D outline in the xy plane extruded along z.

    Origin at the middle of the blade root; +x towards the tip, the curved cutting edge
    faces -y, the straight spine faces +y, thickness along z. 40 mm long, 8 mm high,
    0.5 mm thick.
    """
    length, spine_y, belly_y, tip_y, thickness = 0.040, 0.003, -0.005, 0.0025, 0.0005
    outline = [(0.0, belly_y)]
    # cutting edge: a quarter ellipse from the root's lower corner up to the tip
    arc_points = 8
    for i in range(1, arc_points + 1):
        angle = math.pi / 2 * i / arc_points
        outline.append((length * math.sin(angle), belly_y + (tip_y - belly_y) * (1 - math.cos(angle))))
    outline += [(0.030, spine_y), (0.0, spine_y)]
    # counter-clockwise seen from +z and convex (every turn is to the left)
    n = len(outline)
    for i in range(n):
        a, b, c = outline[i], outline[(i + 1) % n], outline[(i + 2) % n]
        turn = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
        assert turn > 0, "scalpel outline must be convex and counter-clockwise"
    cx = sum(p[0] for p in outline) / n
    cy = sum(p[1] for p in outline) / n
    hz = thickness / 2
    vertices = [(x, y, hz) for x, y in outline] + [(x, y, -hz) for x, y in outline]
    vertices += [(cx, cy, hz), (cx, cy, -hz)]
    top_centre, bottom_centre = 2 * n, 2 * n + 1
    faces = []
    for i in range(n):
        j = (i + 1) % n
        faces.append((top_centre, i, j))                  # +z face
        faces.append((bottom_centre, n + j, n + i))       # -z face
        faces += [(i, n + i, n + j), (i, n + j, j)]       # side quad
    return vertices, faces


# ---------------------------------------------------------------- writers
def write_obj(name, vertices, faces, comment):
    lines = ["# " + comment, "# units: metres; generated by generate_assets.py"]
    lines += ["v %s %s %s" % tuple(fmt(c) for c in v) for v in vertices]
    lines += ["f %d %d %d" % (a + 1, b + 1, c + 1) for a, b, c in faces]
    return name, "\n".join(lines) + "\n"


def write_ascii_stl(name, vertices, faces, solid):
    lines = ["solid " + solid]
    for a, b, c in faces:
        n = normalize(cross(sub(vertices[b], vertices[a]), sub(vertices[c], vertices[a])))
        lines.append("  facet normal %s %s %s" % tuple(fmt(x) for x in n))
        lines.append("    outer loop")
        for i in (a, b, c):
            lines.append("      vertex %s %s %s" % tuple(fmt(x) for x in vertices[i]))
        lines.append("    endloop")
        lines.append("  endfacet")
    lines.append("endsolid " + solid)
    return name, "\n".join(lines) + "\n"


def write_ascii_ply(name, vertices, faces, comment):
    lines = ["ply", "format ascii 1.0", "comment " + comment,
             "comment units: metres; generated by generate_assets.py",
             "element vertex %d" % len(vertices),
             "property float x", "property float y", "property float z",
             "element face %d" % len(faces),
             "property list uchar int vertex_indices", "end_header"]
    lines += ["%s %s %s" % tuple(fmt(c) for c in v) for v in vertices]
    lines += ["3 %d %d %d" % f for f in faces]
    return name, "\n".join(lines) + "\n"


def write_gltf(name, vertices, faces):
    positions = b"".join(struct.pack("<3f", *v) for v in vertices)
    indices = b"".join(struct.pack("<3H", *f) for f in faces)
    blob = positions + indices  # positions are 12-byte multiples, so indices stay aligned
    lo, hi = bounds([struct.unpack("<3f", struct.pack("<3f", *v)) for v in vertices])
    doc = {
        "asset": {"version": "2.0", "generator": "mpm_bullet assets/generate_assets.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "box", "mesh": 0}],
        "meshes": [{"name": "box", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode("ascii")}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(positions), "target": 34962},
            {"buffer": 0, "byteOffset": len(positions), "byteLength": len(indices), "target": 34963}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(vertices), "type": "VEC3",
             "min": list(lo), "max": list(hi)},
            {"bufferView": 1, "componentType": 5123, "count": 3 * len(faces), "type": "SCALAR"}],
    }
    return name, json.dumps(doc, indent=2) + "\n"


# ---------------------------------------------------------------- main
def build():
    files, summary = [], []

    def add(entry, vertices, faces, watertight):
        files.append(entry)
        b, nm, mo = edge_report(faces)
        assert (b == 0 and nm == 0 and mo == 0) == watertight, (entry[0], b, nm, mo)
        assert signed_volume(vertices, faces) > 0, entry[0] + " is wound inside out"
        lo, hi = bounds(vertices)
        summary.append("%-16s %5d vertices %5d triangles  boundary edges %3d  bounds [%s] .. [%s]" % (
            entry[0], len(vertices), len(faces), b,
            ", ".join("%.6g" % x for x in lo), ", ".join("%.6g" % x for x in hi)))

    v, f = icosphere(SPHERE_RADIUS, SPHERE_SUBDIVISIONS)
    add(write_obj("sphere.obj", v, f, "icosphere, radius %g m, %d subdivisions of an icosahedron"
                  % (SPHERE_RADIUS, SPHERE_SUBDIVISIONS)), v, f, True)
    v, f = box(tuple(s / 2 for s in SLAB_SIZE))
    add(write_ascii_stl("tissue_slab.stl", v, f, "tissue_slab"), v, f, True)
    v, f = box((BOX_HALF, BOX_HALF, BOX_HALF))
    add(write_gltf("box.gltf", v, f), v, f, True)
    v, f = bowl(BOWL_RADIUS, BOWL_RINGS, BOWL_SEGMENTS)
    add(write_ascii_ply("bowl_open.ply", v, f, "open hemisphere shell, radius %g m, rim at y = 0 (not watertight)"
                        % BOWL_RADIUS), v, f, False)
    v, f = scalpel()
    add(write_obj("scalpel.obj", v, f, "scalpel blade prism: x to the tip, cutting edge towards -y, thickness along z"),
        v, f, True)
    return files, summary


def main():
    check = "--check" in sys.argv[1:]
    files, summary = build()
    stale = []
    for name, text in files:
        path = os.path.join(HERE, name)
        if check:
            try:
                with open(path, "r", encoding="ascii", newline="") as fh:
                    if fh.read() != text:
                        stale.append(name)
            except FileNotFoundError:
                stale.append(name)
        else:
            with open(path, "w", encoding="ascii", newline="\n") as fh:
                fh.write(text)
    print("\n".join(summary))
    if stale:
        print("out of date: " + ", ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
