#!/usr/bin/env python3
"""Writes the small mesh fixtures used by tests/test_mesh.c (run from this directory)."""
import struct

open("all_forms.obj", "w", newline="").write(
"""# fixture: every OBJ index form
mtllib cube.mtl
o cube
v 0 0 0 1 0 0
v 1.0 0 0 0 1 0
v 1 1 0
v 0 1.000 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 -1
vn 0 0 1
vn 0 -1 0
vn 1 0 0
vn 0 1 0
vn -1 0 0
vn 0.5 0.5 0.5
g bottom
usemtl red
s off
f 1 4 3 2
g top
s 1
f 5/1 6/2 7/3 8/4
f -8//-5 -7//-5 -3//-5 -4//-5
f 2/2/4 3/3/4 7/3/4 6/2/4
f 3//5 4//5 8//5 7//5
f -5/-4/-2 -1/-3/-2 -4/-2/-2 1/-1/-2
l 1 2
p 3
# end\r
""")

verts = [(0,0,0),(1,0,0),(1,1,0),(0,1,0),(0,0,1),(1,0,1),(1,1,1),(0,1,1)]
faces = [(0,3,2,1),(4,5,6,7),(0,1,5,4),(1,2,6,5),(2,3,7,6),(3,0,4,7)]
def ply_header(fmt):
    return ("ply\nformat %s 1.0\ncomment fixture with extra properties and an extra element\n"
            "element vertex 8\nproperty float x\nproperty double y\nproperty float32 z\n"
            "property float nx\nproperty float ny\nproperty float nz\n"
            "property uchar red\nproperty uint8 green\nproperty short quality\n"
            "element face 6\nproperty list uchar int vertex_indices\nproperty int flags\n"
            "element edge 2\nproperty int vertex1\nproperty uint32 vertex2\nproperty list ushort float32 weights\n"
            "end_header\n" % fmt)
def norm(v):
    return tuple((c - 0.5) for c in v)
out = ply_header("ascii")
for i, v in enumerate(verts):
    n = norm(v)
    out += "%g %g %g %g %g %g %d %d %d\n" % (v + n + (i * 30, 255 - i, -i))
for f in faces:
    out += "4 %d %d %d %d 7\n" % f
out += "0 1 2 0.25 0.75\n2 3 0\n"
open("cube_ascii.ply", "w", newline="").write(out)
for fmt, e in (("binary_little_endian", "<"), ("binary_big_endian", ">")):
    b = ply_header(fmt).encode()
    for i, v in enumerate(verts):
        n = norm(v)
        b += struct.pack(e + "fdffffBBh", v[0], v[1], v[2], n[0], n[1], n[2], i * 30, 255 - i, -i)
    for f in faces:
        b += struct.pack(e + "Biiiii", 4, *f, 7)
    b += struct.pack(e + "iIHff", 0, 1, 2, 0.25, 0.75) + struct.pack(e + "iIH", 2, 3, 0)
    open("cube_%s.ply" % ("ble" if e == "<" else "bbe"), "wb").write(b)

open("comments.off", "w", newline="").write(
"""OFF # a cube with comments and per-face colours
# counts: vertices faces edges
8 6 12

# vertices
0 0 0
1 0 0
1 1 0 # a comment after a vertex
0 1 0
0 0 1
1 0 1
1 1 1
0 1 1
# faces with colours
4 0 3 2 1 1.0 0.0 0.0
4 4 5 6 7 0 1 0
4 0 1 5 4
4 1 2 6 5
4 2 3 7 6
5 3 0 4 7 7 255 255 255 255
""")

open("normals.off", "w", newline="").write(
"NOFF\n4 2 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n3 0 2 3\n")

tris = [((0,0,-1),(0,0,0),(1,1,0),(1,0,0)), ((0,0,-1),(0,0,0),(0,1,0),(1,1,0)),
        ((0,0,1),(0,0,1),(1,0,1),(1,1,1)), ((0.1,0.2,0.3),(0,0,0),(0.5,0,0),(0,0.5,0))]
s = "solid fixture\n"
for t in tris:
    s += "  facet normal %e %e %e\n    outer loop\n" % t[0]
    for v in t[1:]:
        s += "      vertex %e %e %e\n" % v
    s += "    endloop\n  endfacet\nendsolid fixture\n" if t is tris[-1] else "    endloop\n  endfacet\n"
open("tri_ascii.stl", "w", newline="").write(s)
b = b"solid-looking header of a binary STL".ljust(80, b" ") + struct.pack("<I", len(tris))
for k, t in enumerate(tris):
    b += struct.pack("<12fH", *(t[0] + t[1] + t[2] + t[3]), k)
open("tri_binary.stl", "wb").write(b)

# Bad inputs (more are built inline in the test).
open("bad_index.obj", "w").write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
open("bad_nan.obj", "w").write("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n")
open("bad_counts.off", "w").write("OFF\n5 1 0\n0 0 0\n1 0 0\n0 1 0\n")
open("bad_format.ply", "w").write("ply\nformat binary_middle_endian 1.0\nelement vertex 0\nend_header\n")
open("bad_huge.ply", "w").write("ply\nformat binary_little_endian 1.0\nelement vertex 1099511627776\n"
                                "property float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0")
bb = b"\0" * 80 + struct.pack("<I", 3) + b"\0" * 50 * 2
open("bad_size.stl", "wb").write(bb)
open("empty.obj", "w").write("")

# Identity fixtures (tests/cli/test_identity.sh): a closed blob of quads and
# triangles whose text a deformation that moves nothing must not change:
# coordinates written "-0.000000", seven-digit values, texture coordinates,
# normals with "-0.0000" components. The flat one has one vn per face (not
# tied to a vertex), the smooth one one vn per vertex (carried to PLY and OFF).
import math
def blob(nu, nv):
    def p(t, ph):
        r = 1 + 0.3 * math.sin(3 * t) * math.sin(2 * ph) + 0.1 * math.cos(5 * t)
        return (r * math.sin(ph) * math.cos(t), 1.3 * r * math.cos(ph), 0.8 * r * math.sin(ph) * math.sin(t))
    vs, fs = [], []
    for j in range(1, nv):
        for i in range(nu):
            vs.append(p(2 * math.pi * i / nu, math.pi * j / nv))
    top, bot = len(vs), len(vs) + 1
    vs += [p(0, 0), p(0, math.pi)]
    at = lambda j, i: (j - 1) * nu + i % nu
    for j in range(1, nv - 1):
        for i in range(nu):
            fs.append((at(j, i), at(j + 1, i), at(j + 1, i + 1), at(j, i + 1)))
    for i in range(nu):
        fs.append((top, at(1, i), at(1, i + 1)))
        fs.append((bot, at(nv - 1, i + 1), at(nv - 1, i)))
    return vs, fs
def unit(n):
    l = math.sqrt(sum(c * c for c in n)) or 1.0
    return tuple(c / l for c in n)
def vn_line(n):
    # small components are written "-0.0000" on every other line (signed zeros in the text)
    vn_line.k += 1
    return "vn " + " ".join("-0.0000" if abs(c) < 3e-3 and vn_line.k % 2 else "%.4f" % c for c in n) + "\n"
vn_line.k = 0
def newell(vs, f):
    n = [0.0, 0.0, 0.0]
    for k in range(len(f)):
        a, b = vs[f[k]], vs[f[(k + 1) % len(f)]]
        n[0] += (a[1] - b[1]) * (a[2] + b[2])
        n[1] += (a[2] - b[2]) * (a[0] + b[0])
        n[2] += (a[0] - b[0]) * (a[1] + b[1])
    return unit(n)
for name, nu, nv, smooth in (("identity_flat.obj", 24, 12, False), ("identity_smooth.obj", 16, 9, True)):
    vs, fs = blob(nu, nv)
    s = "# fixture: a blob of quads and triangles (make_fixtures.py)\n"
    s += "".join("v %.6f %.7g %.7f\n" % v for v in vs)
    s += "".join("vt %.6f %.6f\n" % (0.5 + v[0] / 3, 0.5 + v[1] / 3) for v in vs)
    if smooth:
        acc = [[0.0, 0.0, 0.0] for _ in vs]
        for f in fs:
            n = newell(vs, f)
            for i in f:
                for c in range(3):
                    acc[i][c] += n[c]
        s += "".join(vn_line(unit(n)) for n in acc)
        s += "s 1\n" + "".join("f " + " ".join("%d/%d/%d" % (i + 1, i + 1, i + 1) for i in f) + "\n" for f in fs)
    else:
        s += "".join(vn_line(newell(vs, f)) for f in fs)
        s += "s off\n" + "".join("f " + " ".join("%d/%d/%d" % (i + 1, i + 1, k + 1) for i in f) + "\n"
                                 for k, f in enumerate(fs))
    open(name, "w", newline="").write(s)

# grid_tangents.glb: a 3 x 3 grid (8 triangles) with NORMAL and TANGENT
# (w alternating +1/-1) under a node with TRS below a turned parent: the
# glTF fixture whose tangents follow a deformation (alloc sweep, tests/bad).
import json, math
pos, nrm, tan = b"", b"", b""
for k in range(9):
    a = 0.3 + 0.7 * k
    pos += struct.pack("<3f", k % 3 - 1, k // 3 - 1, 0)
    nrm += struct.pack("<3f", 0, 0, 1)
    tan += struct.pack("<4f", math.cos(a), math.sin(a), 0, -1 if k % 2 else 1)
idx = b""
for r in range(2):
    for c in range(2):
        a = 3 * r + c
        idx += struct.pack("<6H", a, a + 1, a + 4, a, a + 4, a + 3)
bin_ = pos + nrm + tan + idx
gltf = {
    "asset": {"version": "2.0", "generator": "ffdkit tests (make_fixtures.py)"},
    "scene": 0, "scenes": [{"nodes": [0]}],
    "nodes": [{"name": "turn", "rotation": [0, 0, 0.7071067811865476, 0.7071067811865476], "children": [1]},
              {"name": "grid", "mesh": 0, "translation": [1, 2, 3],
               "rotation": [0.25881904510252074, 0, 0, 0.9659258262890683], "scale": [2, 1, 0.5]}],
    "materials": [{"name": "normal-mapped", "normalTexture": {"index": 0}}],
    "textures": [{"source": 0}], "images": [{"uri": "normal.png"}],
    "meshes": [{"name": "grid", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TANGENT": 2},
                                                "indices": 3, "material": 0}]}],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 9, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
        {"bufferView": 1, "componentType": 5126, "count": 9, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": 9, "type": "VEC4"},
        {"bufferView": 3, "componentType": 5123, "count": 24, "type": "SCALAR"}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 108},
                    {"buffer": 0, "byteOffset": 108, "byteLength": 108},
                    {"buffer": 0, "byteOffset": 216, "byteLength": 144},
                    {"buffer": 0, "byteOffset": 360, "byteLength": 48}],
    "buffers": [{"byteLength": len(bin_)}],
}
def glb(doc, data):
    j = json.dumps(doc, indent=1).encode()
    j += b" " * (-len(j) % 4)
    data += b"\0" * (-len(data) % 4)
    body = struct.pack("<II", len(j), 0x4E4F534A) + j + struct.pack("<II", len(data), 0x004E4942) + data
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body
open("grid_tangents.glb", "wb").write(glb(gltf, bin_))
