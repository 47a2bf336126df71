/* math — spatial indexes: a k-d tree over points for nearest-neighbour
 * queries (PB-FFD placement, McDonnell & Qin §3.2.1, uses one as the paper's
 * ANN kd-tree), and a grid over triangles for point-in-solid tests by ray
 * parity. Plain C, no globals; queries are read-only, so one index can be
 * queried from many threads at once. Results are deterministic: equal
 * distances go to the lower point index. */
#ifndef FFD_SPATIAL_H
#define FFD_SPATIAL_H

#include "core/core.h"

#include <stdint.h>

typedef struct ffd_kdtree ffd_kdtree;

/* Builds a tree over n points (#n by 3, copied; n may be 0). Point indices
 * in queries are positions in this array. FFD_ERR_INVALID (NULL points with
 * n > 0), FFD_ERR_NONFINITE, FFD_ERR_NOMEM. */
ffd_status ffd_kdtree_create(const double *points, size_t n, ffd_kdtree **out, ffd_error *err);
void ffd_kdtree_destroy(ffd_kdtree *tree);
size_t ffd_kdtree_count(const ffd_kdtree *tree);

/* Index of the point nearest to q, or SIZE_MAX when the tree is empty.
 * dist2 (may be NULL) receives the squared distance. */
size_t ffd_kdtree_nearest(const ffd_kdtree *tree, const double q[3], double *dist2);

/* Same among the points at a positive distance from q (copies of q are
 * skipped): for q = point i, the nearest other point of the set. SIZE_MAX
 * when every point coincides with q. */
size_t ffd_kdtree_nearest_distinct(const ffd_kdtree *tree, const double q[3], double *dist2);

/* The min(k, n) points nearest to q, closest first: writes their indices
 * (and squared distances when dist2 is not NULL) and returns how many. */
size_t ffd_kdtree_k_nearest(const ffd_kdtree *tree, const double q[3], size_t k, size_t *index,
                            double *dist2);

/* Point-in-solid index: the triangles (nt by 3 vertex indices into
 * positions, #nv by 3) binned by their xy bounding boxes into a uniform
 * grid. positions are borrowed and must outlive the index; triangles are
 * copied. FFD_ERR_RANGE (a vertex index >= nv), FFD_ERR_NOMEM. */
typedef struct ffd_inside_index ffd_inside_index;
ffd_status ffd_inside_index_create(const double *positions, size_t nv, const uint32_t *triangles,
                                   size_t nt, ffd_inside_index **out, ffd_error *err);
void ffd_inside_index_destroy(ffd_inside_index *index);

/* 1 when the ray from q along +z crosses the triangles an odd number of
 * times: q is inside the closed surface they form. A ray through a shared
 * edge or vertex is counted once: orientation tests run on each edge in one
 * canonical direction (lower vertex index first), and q on an edge's line is
 * decided as for q moved by (eps, eps^2) (simulation of simplicity), so a ray
 * through a vertex (a grid of query points often meets one) is counted once too. */
int ffd_inside_index_test(const ffd_inside_index *index, const double q[3]);

#endif
