#!/usr/bin/env python3
"""Partitioned test meshes for ffd-mpi (tests/mpi/test_mpi.sh, docs/mpi.md).

    make_partitions.py vtu MESH.msh OUTDIR K [--empty R]   -> OUTDIR/box.pvtu, OUTDIR/box_<r>.vtu
    make_partitions.py obj MESH.obj OUTDIR K                -> OUTDIR/piece_<r>.obj
    make_partitions.py xyz POINTS.xyz OUTDIR K              -> OUTDIR/points_<r>.xyz

vtu: the tetrahedra of a Gmsh MSH 2.2 ascii file, sorted by the x of their
centroid (ties by element number) and cut into K contiguous groups; each
piece keeps its group's nodes (a node on an interface is on both pieces) in
the order of their tags, with the point array GlobalNodeID = tag - 1 (Int64),
as ASCII VTU. --empty R puts a piece with no points and no cells at rank R
(K pieces in all, K-1 with data).
obj: the faces of an OBJ cut the same way (x of the first corner), each piece
an OBJ of its faces' vertices with "#GlobalNodeID id" lines (the vertex's
index in the whole file).
xyz: the points cut into K contiguous ranges, no ids (rank-major order).
Coordinates are copied as the source's text, so every piece reads back
the same doubles as the whole file. No dependencies beyond Python 3.
"""
import os
import sys


def cut(items, k):
    """k contiguous groups of the sorted items, sizes differing by at most one."""
    n = len(items)
    return [items[r * n // k:(r + 1) * n // k] for r in range(k)]


def read_msh22(path):
    text = open(path).read()
    if not text.startswith("$MeshFormat\n2.2"):
        sys.exit(f"{path}: expected MSH 2.2 ascii")
    nodes = {}
    lines = text.split("$Nodes\n")[1].split("$EndNodes")[0].split("\n")[1:]
    for line in lines:
        f = line.split()
        if f:
            nodes[int(f[0])] = f[1:4]
    tets = []
    lines = text.split("$Elements\n")[1].split("$EndElements")[0].split("\n")[1:]
    for line in lines:
        f = line.split()
        if f and f[1] == "4":  # 4-node tetrahedron: Gmsh's order is VTK's
            ntags = int(f[2])
            tets.append((int(f[0]), [int(t) for t in f[3 + ntags:7 + ntags]]))
    return nodes, tets


def write_vtu(path, coords, ids, cells):
    with open(path, "w") as out:
        out.write('<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" '
                  'byte_order="LittleEndian" header_type="UInt64">\n  <UnstructuredGrid>\n')
        out.write(f'    <Piece NumberOfPoints="{len(coords)}" NumberOfCells="{len(cells)}">\n')
        out.write('      <PointData>\n        <DataArray type="Int64" Name="GlobalNodeID" '
                  'format="ascii">\n')
        for i in ids:
            out.write(f"          {i}\n")
        out.write("        </DataArray>\n      </PointData>\n")
        out.write('      <Points>\n        <DataArray type="Float64" NumberOfComponents="3" '
                  'format="ascii">\n')
        for c in coords:
            out.write("          " + " ".join(c) + "\n")
        out.write("        </DataArray>\n      </Points>\n      <Cells>\n")
        out.write('        <DataArray type="Int64" Name="connectivity" format="ascii">\n')
        for cell in cells:
            out.write("          " + " ".join(str(v) for v in cell) + "\n")
        out.write('        </DataArray>\n        <DataArray type="Int64" Name="offsets" '
                  'format="ascii">\n')
        for c in range(len(cells)):
            out.write(f"          {4 * (c + 1)}\n")
        out.write('        </DataArray>\n        <DataArray type="UInt8" Name="types" '
                  'format="ascii">\n')
        for _ in cells:
            out.write("          10\n")
        out.write("        </DataArray>\n      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n"
                  "</VTKFile>\n")


def vtu(mesh, outdir, k, empty):
    nodes, tets = read_msh22(mesh)
    def key(t):
        return (sum(float(nodes[v][0]) for v in t[1]) / 4, t[0])
    groups = cut(sorted(tets, key=key), k - (empty is not None))
    if empty is not None:
        groups.insert(empty, [])
    stem = "box"
    with open(os.path.join(outdir, stem + ".pvtu"), "w") as out:
        out.write('<?xml version="1.0"?>\n<VTKFile type="PUnstructuredGrid" version="1.0" '
                  'byte_order="LittleEndian" header_type="UInt64">\n'
                  '  <PUnstructuredGrid GhostLevel="0">\n'
                  '    <PPointData>\n      <PDataArray type="Int64" Name="GlobalNodeID"/>\n'
                  '    </PPointData>\n    <PPoints>\n'
                  '      <PDataArray type="Float64" NumberOfComponents="3"/>\n    </PPoints>\n')
        for r in range(k):
            out.write(f'    <Piece Source="{stem}_{r}.vtu"/>\n')
        out.write("  </PUnstructuredGrid>\n</VTKFile>\n")
    for r, group in enumerate(groups):
        tags = sorted({v for _, t in group for v in t})
        local = {t: i for i, t in enumerate(tags)}
        write_vtu(os.path.join(outdir, f"{stem}_{r}.vtu"), [nodes[t] for t in tags],
                  [t - 1 for t in tags], [[local[v] for v in t] for _, t in group])


def obj(mesh, outdir, k):
    verts, faces = [], []
    for line in open(mesh):
        f = line.split()
        if f and f[0] == "v":
            verts.append(f[1:4])
        elif f and f[0] == "f":
            faces.append([int(c.split("/")[0]) - 1 for c in f[1:]])
    order = sorted(range(len(faces)), key=lambda i: (float(verts[faces[i][0]][0]), i))
    groups = cut(order, k)
    # the vertices no face uses go to the last piece, so that the union is the whole file
    used = {v for face in faces for v in face}
    for r, group in enumerate(groups):
        ids = sorted({v for i in group for v in faces[i]})
        if r == k - 1:
            ids = sorted(set(ids) | (set(range(len(verts))) - used))
        local = {v: i for i, v in enumerate(ids)}
        with open(os.path.join(outdir, f"piece_{r}.obj"), "w") as out:
            out.write(f"# piece {r} of {os.path.basename(mesh)}: {len(ids)} vertices, "
                      f"{len(group)} faces\n")
            for v in ids:
                out.write("v " + " ".join(verts[v]) + "\n")
            for i in group:
                out.write("f " + " ".join(str(local[v] + 1) for v in faces[i]) + "\n")
            for v in ids:
                out.write(f"#GlobalNodeID {v}\n")


def xyz(points, outdir, k):
    lines = [l for l in open(points) if l.strip() and not l.startswith("#")]
    for r, group in enumerate(cut(lines, k)):
        with open(os.path.join(outdir, f"points_{r}.xyz"), "w") as out:
            out.writelines(group)


def main():
    args = sys.argv[1:]
    empty = None
    if "--empty" in args:
        i = args.index("--empty")
        empty = int(args[i + 1])
        del args[i:i + 2]
    if len(args) != 4 or args[0] not in ("vtu", "obj", "xyz"):
        sys.exit(__doc__)
    kind, src, outdir, k = args[0], args[1], args[2], int(args[3])
    os.makedirs(outdir, exist_ok=True)
    {"vtu": lambda: vtu(src, outdir, k, empty), "obj": lambda: obj(src, outdir, k),
     "xyz": lambda: xyz(src, outdir, k)}[kind]()


if __name__ == "__main__":
    main()
