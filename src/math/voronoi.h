/* math — 3D Voronoi vertices through Qhull (voronoi.c is the only file that
 * includes Qhull). Used by PB-FFD automatic placement (McDonnell & Qin,
 * §3.2.1, Figure 2 step 1). */
#ifndef FFD_VORONOI_H
#define FFD_VORONOI_H

#include "core/core.h"

/* Vertices of the Voronoi diagram of n sites (#n by 3): the circumcentres of
 * the Delaunay cells (Qhull "v Qbb"; cospherical sites give one vertex per
 * Delaunay region, and cells too flat for a finite centre are skipped).
 * min_quality > 0 also skips every Delaunay tetrahedron whose shape quality
 * 6 |volume| / (longest edge)^3 (sqrt(2)/2 for a regular one) is below it:
 * the centre of such a sliver (four nearly cocircular sites) is fixed by
 * rounding or jitter, not by the shape; 0 keeps every finite centre.
 * *out receives *count by 3 doubles, allocated with ffd_malloc (freed with
 * ffd_free), in Qhull's facet order (deterministic for the same input).
 * Qhull never prints: its messages are captured. Errors: FFD_ERR_INVALID
 * (n < 5, or n too large for Qhull's int), FFD_ERR_NONFINITE (a site is
 * NaN/Inf), FFD_ERR_NUMERIC (Qhull failed, e.g. all sites coplanar: the
 * message carries Qhull's first error line), FFD_ERR_NOMEM. On failure *out
 * is NULL and *count 0. */
ffd_status ffd_voronoi_vertices(const double *points, size_t n, double min_quality, double **out,
                                size_t *count, ffd_error *err);

#endif
