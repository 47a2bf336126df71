/* mesh_quality — internal entry points of the cell checks (mesh_quality.c)
 * for the methods' step limiting; the public ones are in include/ffd.h,
 * "Cell quality and inversions". */
#ifndef FFD_MESH_QUALITY_H
#define FFD_MESH_QUALITY_H

#include "mesh/mesh.h"

/* The number of m's 3D cells inverted at positions x (vertex_count by 3)
 * against positions rest, as ffd_mesh_check_inversions counts them. */
size_t ffd_mesh_inverted_cells(const ffd_mesh *m, const double *x, const double *rest);

#endif
