# mixed_22.msh: one hexahedron, pyramid, prism and tetrahedron sharing faces,
# a quadrangle, a line and a point; node tags sparse (10, 20, ...).
P = [(0,0,0),(1,0,0),(1,1,0),(0,1,0),(0,0,1),(1,0,1),(1,1,1),(0,1,1),
     (1.5,0.5,0.5),(0,0,2),(1,0,2),(0,1,2),(1,1,2)]
E = [  # gmsh type, physical, elementary, nodes (1-based, Gmsh order)
    (15, 20, 7, [1]),
    (1, 21, 6, [1, 2]),
    (3, 10, 5, [1, 4, 3, 2]),
    (5, 1, 1, [1, 2, 3, 4, 5, 6, 7, 8]),
    (7, 1, 2, [2, 3, 7, 6, 9]),
    (6, 2, 3, [5, 6, 8, 10, 11, 12]),
    (4, 2, 4, [6, 7, 8, 13]),
]
tag = lambda i: 10 * i
with open("mixed_22.msh", "w") as f:
    f.write("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n")
    f.write('$PhysicalNames\n3\n3 1 "solid"\n3 2 "cap"\n2 10 "bottom"\n$EndPhysicalNames\n')
    f.write("$Nodes\n%d\n" % len(P))
    for i, p in enumerate(P):
        f.write("%d %s\n" % (tag(i + 1), " ".join(repr(float(x)) if x != int(x) else str(int(x)) for x in p)))
    f.write("$EndNodes\n$Elements\n%d\n" % len(E))
    for k, (t, ph, el, n) in enumerate(E):
        f.write("%d %d 2 %d %d %s\n" % (k + 1, t, ph, el, " ".join(str(tag(i)) for i in n)))
    f.write("$EndElements\n")
    f.write('$NodeData\n1\n"temperature"\n1\n0.0\n3\n0\n1\n%d\n' % len(P))
    for i in range(len(P)):
        f.write("%d %g\n" % (tag(i + 1), 1.5 + i))
    f.write("$EndNodeData\n")
