#!/usr/bin/env python3
"""Renders meshes side by side into a PNG for the docs (no dependencies beyond Python 3).

Usage: render_png.py OUT.png MESH.obj[:LATTICE.obj] [MESH2.obj[:LATTICE2.obj] ...]
Each mesh is drawn flat-shaded with a z-buffer, all with the same camera, in panels
left to right. Reads OBJ 'v', 'f' and 'l' lines only (convert other formats with
`ffd convert`). A lattice OBJ (as written by `ffd deform --lattice-out`) is drawn
over its panel: red in front of the mesh, pale behind it.
"""
import math
import struct
import sys
import zlib

W, H = 420, 420


def read_obj(path):
    vs, fs, ls = [], [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == 'v':
                vs.append(tuple(float(x) for x in p[1:4]))
            elif p[0] == 'f':
                idx = [int(t.split('/')[0]) for t in p[1:]]
                idx = [i - 1 if i > 0 else len(vs) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    fs.append((idx[0], idx[k], idx[k + 1]))
            elif p[0] == 'l':
                idx = [int(t) - 1 for t in p[1:]]
                for k in range(len(idx) - 1):
                    ls.append((idx[k], idx[k + 1]))
    return vs, fs, ls


def camera(points):
    lo = [min(p[c] for p in points) for c in range(3)]
    hi = [max(p[c] for p in points) for c in range(3)]
    centre = [(lo[c] + hi[c]) / 2 for c in range(3)]
    size = max(hi[c] - lo[c] for c in range(3)) or 1.0
    yaw, pitch = math.radians(-30), math.radians(-15)

    def project(p):
        x, y, z = (p[c] - centre[c] for c in range(3))
        x, z = x * math.cos(yaw) + z * math.sin(yaw), -x * math.sin(yaw) + z * math.cos(yaw)
        y, z = y * math.cos(pitch) - z * math.sin(pitch), y * math.sin(pitch) + z * math.cos(pitch)
        s = 0.62 * W / size
        return (W / 2 + s * x, H / 2 - s * y, z)
    return project


def render(mesh, project, lattice=None):
    vs, fs, _ = mesh
    img = [[(250, 250, 250)] * W for _ in range(H)]
    zb = [[-1e30] * W for _ in range(H)]
    pv = [project(v) for v in vs]
    light = (0.4, 0.6, 0.7)
    ln = math.sqrt(sum(c * c for c in light))
    for a, b, c in fs:
        pa, pb, pc = pv[a], pv[b], pv[c]
        # normal in view space for shading
        ux, uy, uz = (pb[i] - pa[i] for i in range(3))
        wx, wy, wz = (pc[i] - pa[i] for i in range(3))
        nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
        nn = math.sqrt(nx * nx + ny * ny + nz * nz) or 1.0
        shade = abs(nx * light[0] - ny * light[1] + nz * light[2]) / (nn * ln)
        col = (int(70 + 150 * shade), int(110 + 120 * shade), int(160 + 90 * shade))
        x0 = max(int(min(pa[0], pb[0], pc[0])), 0)
        x1 = min(int(max(pa[0], pb[0], pc[0])) + 1, W - 1)
        y0 = max(int(min(pa[1], pb[1], pc[1])), 0)
        y1 = min(int(max(pa[1], pb[1], pc[1])) + 1, H - 1)
        den = (pb[1] - pc[1]) * (pa[0] - pc[0]) + (pc[0] - pb[0]) * (pa[1] - pc[1])
        if abs(den) < 1e-12:
            continue
        for y in range(y0, y1 + 1):
            for x in range(x0, x1 + 1):
                l0 = ((pb[1] - pc[1]) * (x - pc[0]) + (pc[0] - pb[0]) * (y - pc[1])) / den
                l1 = ((pc[1] - pa[1]) * (x - pc[0]) + (pa[0] - pc[0]) * (y - pc[1])) / den
                l2 = 1 - l0 - l1
                if l0 < 0 or l1 < 0 or l2 < 0:
                    continue
                z = l0 * pa[2] + l1 * pb[2] + l2 * pc[2]
                if z > zb[y][x]:
                    zb[y][x] = z
                    img[y][x] = col
    if lattice:
        lv, _, ll = lattice
        lp = [project(v) for v in lv]

        def plot(x, y, z, front, behind):
            if 0 <= x < W and 0 <= y < H:
                if z >= zb[y][x]:
                    img[y][x] = front
                else:
                    r, g, b = img[y][x]
                    img[y][x] = ((r + behind[0]) // 2, (g + behind[1]) // 2, (b + behind[2]) // 2)
        for a, b in ll:
            n = int(max(abs(lp[a][0] - lp[b][0]), abs(lp[a][1] - lp[b][1]))) + 1
            for k in range(n + 1):
                f = k / n
                plot(int(lp[a][0] + (lp[b][0] - lp[a][0]) * f), int(lp[a][1] + (lp[b][1] - lp[a][1]) * f),
                     lp[a][2] + (lp[b][2] - lp[a][2]) * f, (200, 60, 40), (230, 150, 140))
        for p in lp:
            for dy in range(-2, 3):
                for dx in range(-2, 3):
                    plot(int(p[0]) + dx, int(p[1]) + dy, p[2], (170, 20, 10), (220, 120, 110))
    return img


def write_png(path, rows):
    h, w = len(rows), len(rows[0])
    raw = b''.join(b'\x00' + bytes(c for px in row for c in px) for row in rows)

    def chunk(tag, data):
        return struct.pack('>I', len(data)) + tag + data + struct.pack('>I', zlib.crc32(tag + data))
    png = b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 2, 0, 0, 0))
    png += chunk(b'IDAT', zlib.compress(raw, 9)) + chunk(b'IEND', b'')
    with open(path, 'wb') as f:
        f.write(png)


def main(argv):
    out, args = argv[1], argv[2:]
    meshes, lattices = [], []
    for a in args:
        mesh, _, lat = a.partition(':')
        meshes.append(read_obj(mesh))
        lattices.append(read_obj(lat) if lat else None)
    allp = [v for m in meshes for v in m[0]] + [v for l in lattices if l for v in l[0]]
    project = camera(allp)
    panels = [render(m, project, l) for m, l in zip(meshes, lattices)]
    rows = [sum((p[y] for p in panels), []) for y in range(H)]
    write_png(out, rows)


if __name__ == '__main__':
    main(sys.argv)
