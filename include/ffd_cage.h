/*
 * ffd_cage.h — cage deformation: mean-value coordinates (Ju, Schaefer &
 * Warren 2005) and harmonic coordinates (Joshi, Meyer, DeRose, Green &
 * Sanocki 2007) of a closed triangle cage; its public API (docs/cage.md).
 *
 * Part of the public API of libffd: ffd.h includes this header (through
 * ffd_methods.h), so `#include <ffd.h>` gives it; ffd.h's conventions hold here.
 */
#ifndef FFD_CAGE_API_H
#define FFD_CAGE_API_H

#include "ffd.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ======================================================================
 * Cage deformation: x' = x + sum_j w_j(x) (v_j - v0_j)
 * ====================================================================== */

typedef struct ffd_cage ffd_cage;
typedef struct ffd_cage_binding ffd_cage_binding;

typedef enum ffd_cage_coordinates {
    FFD_CAGE_MEAN_VALUE = 0, /* Ju et al. 2005, closed form (Fig. 4); defined everywhere */
    FFD_CAGE_HARMONIC        /* Joshi et al. 2007: the discrete Laplace equation on a grid */
} ffd_cage_coordinates;

/* Points outside the cage. */
typedef enum ffd_cage_outside {
    FFD_CAGE_OUTSIDE_DEFAULT = 0, /* mean value: EXTEND; harmonic: FIXED */
    FFD_CAGE_OUTSIDE_EXTEND,      /* mean value coordinates continued outside (mean value only) */
    FFD_CAGE_OUTSIDE_FIXED,       /* keep their position (all weights 0) */
    FFD_CAGE_OUTSIDE_CLAMP        /* move with the nearest point of the cage (its hat weights):
                                     continuous across the cage */
} ffd_cage_outside;

#define FFD_CAGE_RESOLUTION_DEFAULT 32u
#define FFD_CAGE_RESOLUTION_MAX 256u

/* Zero means default. */
typedef struct ffd_cage_options {
    ffd_cage_coordinates coordinates;
    uint32_t resolution;      /* harmonic: grid cells along the cage's longest side
                                 (default 32, 4..FFD_CAGE_RESOLUTION_MAX) */
    ffd_cage_outside outside;
} ffd_cage_options;

/* A cage from its vertices (nv by 3, copied) and triangles (nt by 3 vertex
 * indices, copied). face_of (nt entries, may be NULL) gives each triangle
 * the index of the polygon it came from, for messages ("face 7"; NULL: the
 * triangle's own index). The cage must be a closed, edge- and
 * vertex-manifold, consistently oriented surface whose every vertex is on a
 * face and whose triangles have a non-zero area; an inward orientation
 * (negative enclosed volume) is turned outwards. Harmonic coordinates are
 * solved here, once for every cage vertex (CHOLMOD), on a grid of
 * resolution cells along the cage's longest side. Errors (messages name the
 * first bad face, edge or vertex): FFD_ERR_RANGE (an index >= nv),
 * FFD_ERR_NONFINITE, FFD_ERR_INVALID (open, non-manifold, inconsistently
 * oriented or degenerate cage; resolution out of range; EXTEND with
 * harmonic coordinates), FFD_ERR_NUMERIC (the factorisation failed),
 * FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_cage_create(const double *vertices, size_t nv, const uint32_t *triangles,
                                   size_t nt, const uint32_t *face_of,
                                   const ffd_cage_options *options, ffd_cage **out,
                                   ffd_error *err);
FFD_API void ffd_cage_destroy(ffd_cage *cage);

FFD_API size_t ffd_cage_vertex_count(const ffd_cage *cage);
FFD_API size_t ffd_cage_triangle_count(const ffd_cage *cage);
/* The triangles (nt by 3, outward), the rest and the current vertices (nv by 3). Borrowed. */
FFD_API const uint32_t *ffd_cage_triangles(const ffd_cage *cage);
FFD_API const double *ffd_cage_rest_vertices(const ffd_cage *cage);
FFD_API const double *ffd_cage_vertices(const ffd_cage *cage);
FFD_API ffd_cage_coordinates ffd_cage_coordinate_kind(const ffd_cage *cage);
/* The outside rule in force (never DEFAULT). */
FFD_API ffd_cage_outside ffd_cage_outside_rule(const ffd_cage *cage);

/* Sets the current vertices (nv by 3, finite, else FFD_ERR_NONFINITE and no change). */
FFD_API ffd_status ffd_cage_set_vertices(ffd_cage *cage, const double *vertices, ffd_error *err);
/* Moves vertex index by delta: FFD_ERR_RANGE, FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_cage_move(ffd_cage *cage, uint32_t index, const double delta[3],
                                 ffd_error *err);
/* Every vertex back at rest. */
FFD_API void ffd_cage_reset(ffd_cage *cage);

/* Binds n points (n by 3, given at rest): each point's coordinates w_j
 * over the nv cage vertices (a dense row; zero for a FIXED outside point),
 * computed in parallel, bitwise the same for any thread count. Mean value:
 * Ju et al. Fig. 4, a point on a cage vertex, edge or face gets the cage's
 * linear interpolation there. Harmonic: trilinear interpolation of the grid
 * solution. FFD_ERR_NONFINITE, FFD_ERR_NOMEM (n * nv doubles). */
FFD_API ffd_status ffd_cage_bind(const ffd_cage *cage, const double *points, size_t n,
                                 ffd_cage_binding **out, ffd_error *err);
FFD_API void ffd_cage_binding_destroy(ffd_cage_binding *binding);
FFD_API size_t ffd_cage_binding_count(const ffd_cage_binding *binding);
/* The bound points inside the cage (or on it). */
FFD_API size_t ffd_cage_binding_inside_count(const ffd_cage_binding *binding);
/* Point i's coordinates over the cage vertices (nv doubles, borrowed). */
FFD_API const double *ffd_cage_binding_weights(const ffd_cage_binding *binding, size_t i);

/* Deformed positions of the bound points, n by 3: the point plus
 * sum_j w_j (v_j - v0_j) over the moved vertices only, so a cage at rest
 * gives every point back bitwise. */
FFD_API ffd_status ffd_cage_eval(const ffd_cage *cage, const ffd_cage_binding *binding,
                                 double *out, ffd_error *err);
/* The binding as a linear map for ffd_manip_solve: dense rows over the nv
 * cage vertices (no ties). Borrows cage and binding. */
FFD_API void ffd_cage_linear_map(const ffd_cage *cage, const ffd_cage_binding *binding,
                                 ffd_linear_map *map);

/* --- Behind the generic interfaces (ffd.h) ---
 * ffd_deformer_handle(d, "cage") is the ffd_cage. The controls are the
 * cage's vertices; the deformation is linear in them, so the linear map,
 * direct manipulation and sensitivities come through it; there is no
 * Jacobian (ffd_deformer_jacobian is FFD_ERR_UNSUPPORTED) and ffd_rig_apply
 * recomputes normals from the deformed faces. ffd_limits count the n * nv
 * weights and, for harmonic coordinates, the grid's factorisation. In a rig
 * report: control_points are the deformed cage's vertices, control_edges its
 * edges, and the control mesh is the cage itself (ffd_rig_report_write_proxy
 * writes the deformed cage); outside_count counts the vertices outside the
 * cage; details hold coordinates, cage_vertices and cage_triangles
 * (docs/cage.md). */

#ifdef __cplusplus
}
#endif
#endif /* FFD_CAGE_API_H */
