Merge "../hinge.stl";
// the STL's facets as one discrete surface; the volume it closes, meshed with tetrahedra
ClassifySurfaces{Pi/4, 1, 0, Pi};
CreateGeometry;
Surface Loop(1) = Surface{:};
Volume(1) = {1};
Physical Surface("skin") = Surface{:};
Physical Volume("part") = {1};
Mesh.MeshSizeFromCurvature = 0;
