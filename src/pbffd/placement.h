/* pbffd — internal declarations shared by the automatic placement files
 * (ebf_placement.c, ebf_decimate.c): PB-FFD, McDonnell & Qin §3.2.1. */
#ifndef FFD_PBFFD_PLACEMENT_H
#define FFD_PBFFD_PLACEMENT_H

#include "core/core.h"
#include "pbffd/pbffd.h"

/* Octree decimation (§3.2.1 step 3): reduces n points (#n by 3) to exactly
 * target points by replacing closest pairs with their midpoints. The
 * bounding cube is split recursively into octants until cells are small;
 * each cell brings its octants' results down to its share (proportional to
 * its point count) by closest-pair merging, and the root cell's merge is the
 * final global one, which makes the count exact. out receives target by 3
 * doubles (caller-allocated; may not alias points). Deterministic: the same
 * input gives the same output bitwise. FFD_ERR_INVALID (target == 0 or
 * target > n, NULL pointer), FFD_ERR_NONFINITE, FFD_ERR_NOMEM. */
ffd_status ffd_decimate_points(const double *points, size_t n, size_t target, double *out,
                               ffd_error *err);

#endif
