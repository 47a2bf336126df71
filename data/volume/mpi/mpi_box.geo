// A 2 x 1 x 1 box in tetrahedra for the MPI tests (tests/mpi, data/SOURCES.md).
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 2, 1, 1};
Mesh.MeshSizeMin = 0.45;
Mesh.MeshSizeMax = 0.45;
