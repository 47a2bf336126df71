// A 2 x 1 x 1 box for make_vtk_samples.py.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 2, 1, 1};
