SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Mesh.MeshSizeMax = 1.0;
Physical Volume("box") = {1};
Physical Surface("skin") = {1, 2, 3, 4, 5, 6};
