#!/usr/bin/env python3
"""Writes fuzz_mesh_import's seeds into tests/fuzz/corpus/mesh/: the small meshes of assets/
with the format byte the target reads in front (0 OBJ, 1 STL, 2 PLY, 3 glTF, 4 GLB), plus
the slab as binary STL, the bowl as binary PLY and the box as GLB, made here from the ASCII and .gltf files."""
import base64, json, os, struct

root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
assets = os.path.join(root, "assets")
out = os.path.join(root, "tests", "fuzz", "corpus", "mesh")
OBJ, STL, PLY, GLTF, GLB = range(5)


def write(name, fmt, data):
    with open(os.path.join(out, name), "wb") as f:
        f.write(bytes([fmt]) + data)


def read(name):
    with open(os.path.join(assets, name), "rb") as f:
        return f.read()


write("seed-sphere.obj", OBJ, read("sphere.obj"))
write("seed-scalpel.obj", OBJ, read("scalpel.obj"))
write("seed-slab.stl", STL, read("tissue_slab.stl"))
write("seed-bowl.ply", PLY, read("bowl_open.ply"))
write("seed-box.gltf", GLTF, read("box.gltf"))

# binary STL of the slab: 80-byte header, count, then per facet normal, 3 vertices, 2 bytes
facets, corners = [], []
for line in read("tissue_slab.stl").decode().splitlines():
    words = line.split()
    if words[:2] == ["facet", "normal"]:
        normal = [float(w) for w in words[2:5]]
        corners = []
    elif words[:1] == ["vertex"]:
        corners.append([float(w) for w in words[1:4]])
    elif words[:1] == ["endfacet"]:
        facets.append((normal, corners))
stl = b"binary slab".ljust(80, b" ") + struct.pack("<I", len(facets))
for normal, corners in facets:
    stl += struct.pack("<12fH", *normal, *corners[0], *corners[1], *corners[2], 0)
write("seed-slab-binary.stl", STL, stl)

# GLB of the box: the JSON chunk with its buffer moved into the binary chunk
gltf = json.loads(read("box.gltf"))
buffer = base64.b64decode(gltf["buffers"][0]["uri"].split(",", 1)[1])
del gltf["buffers"][0]["uri"]
text = json.dumps(gltf, separators=(",", ":")).encode()
text += b" " * (-len(text) % 4)
buffer += b"\0" * (-len(buffer) % 4)
body = struct.pack("<I", len(text)) + b"JSON" + text + struct.pack("<I", len(buffer)) + b"BIN\0" + buffer
glb = b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body
write("seed-box.glb", GLB, glb)

# binary PLY of the bowl (little endian), same elements
lines = read("bowl_open.ply").decode().splitlines()
end = lines.index("end_header")
header, body = lines[: end + 1], lines[end + 1 :]
nv = int(next(l.split()[2] for l in header if l.startswith("element vertex")))
binary = b""
for l in body[:nv]:
    binary += struct.pack("<3f", *[float(w) for w in l.split()[:3]])
for l in body[nv:]:
    if l.strip():
        w = [int(x) for x in l.split()]
        binary += struct.pack("<B%di" % w[0], w[0], *w[1:])
header = [h.replace("format ascii 1.0", "format binary_little_endian 1.0") for h in header]
write("seed-bowl-binary.ply", PLY, ("\n".join(header) + "\n").encode() + binary)
