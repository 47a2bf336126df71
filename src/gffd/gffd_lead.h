/* (temporary: merged into gffd.h once the field files land) */
#ifndef FFD_GFFD_LEAD_H
#define FFD_GFFD_LEAD_H

#include "gffd/gffd.h"

/* ---- skeletons (gffd_skeleton.c) ----------------------------------------- */

/* One primitive with its fitted distance field. */
typedef struct ffd_gffd_part {
    ffd_gffd_geometry geom;
    uint32_t *face_offsets; /* the primitive's own polygons (for ffd_gffd_get_primitive) */
    uint32_t *face_indices;
    size_t face_count;
    ffd_rbf field;          /* f_i: the variational distance field, fitted to fit_vertices */
    double *fit_vertices;   /* the geometry the field was fitted to (vertex_count by 3) */
    double rot[3][3];       /* current geometry = rot * fit + shift (a rigid edit moves */
    double shift[3];        /*  the fitted field instead of refitting it) */
    int rigid;              /* 1: rot/shift differ from the identity */
    int collinear;          /* 1: a point or a straight polyline: a rigid edit of it alone
                               leaves the turn about its line open */
    double lo[3], hi[3];    /* where f_i can be below r_i: the geometry's box grown by 4r/3 */
    double cutoff;          /* exp(-r_i/u), set by ffd_gffd_skeleton_set_unit */
    int regularised;
} ffd_gffd_part;

typedef struct ffd_gffd_skeleton {
    size_t count;
    ffd_gffd_part *parts;
    double inv_unit;        /* 1/u */
    double max_radius;
} ffd_gffd_skeleton;

/* Checks and fits count primitives ("skeleton[i]: ..." messages). */
ffd_status ffd_gffd_skeleton_create(const ffd_gffd_primitive *prims, size_t count,
                                    size_t max_samples, ffd_gffd_skeleton **out, ffd_error *err);
void ffd_gffd_skeleton_destroy(ffd_gffd_skeleton *s);
void ffd_gffd_skeleton_set_unit(ffd_gffd_skeleton *s, double unit);
/* A deep copy. */
ffd_status ffd_gffd_skeleton_copy(const ffd_gffd_skeleton *s, ffd_gffd_skeleton **out,
                                  ffd_error *err);
/* Refits part index with new vertex positions (same structure). */
ffd_status ffd_gffd_skeleton_set_vertices(ffd_gffd_skeleton *s, size_t index,
                                          const double *vertices, size_t max_samples,
                                          ffd_error *err);
/* Fills a public description of part index (borrowing its arrays). */
void ffd_gffd_skeleton_describe(const ffd_gffd_skeleton *s, size_t index, ffd_gffd_primitive *out);
/* Total vertex count and whether two skeletons have the same structure. */
size_t ffd_gffd_skeleton_vertex_count(const ffd_gffd_skeleton *s);
int ffd_gffd_skeleton_same_structure(const ffd_gffd_skeleton *a, const ffd_gffd_skeleton *b);
/* 1 when to = rot * from + shift for a rotation (n points, n by 3 each):
 * Kabsch; for collinear points the least rotation. */
int ffd_gffd_rigid_motion(const double *from, const double *to, size_t n, double rot[3][3],
                          double shift[3]);
/* When the whole skeleton moved rigidly from rest (its vertices, in part
 * order), gives that motion to every collinear part still fitted at rest,
 * so that points and straight polylines turn with the rest and a rigid
 * motion of the whole skeleton moves every field exactly. */
void ffd_gffd_skeleton_align(ffd_gffd_skeleton *cur, const ffd_gffd_skeleton *rest);

/* The warp's automatic correspondences (eq. 4) for an edit of rest into
 * cur (same structure): every skeleton vertex, and around it points at half
 * the radius that turn with the primitive there (a point: 6 along the axes;
 * a polyline vertex: 4 across its tangent; a patch vertex: 2 along its
 * normal), so that the warp is determined in 3D even for a straight or flat
 * skeleton and carries the cross-sections round a bend. count first, then
 * from (rest) and to (cur), count by 3 each. */
size_t ffd_gffd_correspondence_count(const ffd_gffd_skeleton *rest);
void ffd_gffd_correspondences(const ffd_gffd_skeleton *rest, const ffd_gffd_skeleton *cur,
                              double *from, double *to);

/* All vertices, in part order (ffd_gffd_skeleton_vertex_count by 3). */
void ffd_gffd_skeleton_gather_vertices(const ffd_gffd_skeleton *s, double *out);
/* The merged field E (eq. 1-2) at x, and its gradient (may be NULL). */
double ffd_gffd_skeleton_field(const ffd_gffd_skeleton *s, const double x[3], double grad[3]);
/* Bounding box of all skeleton vertices (count > 0). */
void ffd_gffd_skeleton_bounds(const ffd_gffd_skeleton *s, double lo[3], double hi[3]);

/* ---- the warp of eq. 4-6 (gffd_track.c) ---------------------------------- */

typedef struct ffd_gffd_warp {
    ffd_rbf_factor factor; /* over the sources P_j0 (cached: sources rarely change) */
    int has_factor;
    ffd_rbf displacement;  /* W(x, 1) - x, fitted to P_j1 - P_j0 */
    int fitted;
} ffd_gffd_warp;

/* ---- tracking (gffd_track.c) --------------------------------------------- */

typedef struct ffd_gffd_tracker {
    const ffd_gffd_skeleton *field;  /* the current skeleton */
    const ffd_gffd_warp *warp;       /* NULL: no correspondences */
    int mode;                        /* ffd_gffd_tracking */
    double tolerance;                /* epsilon (units of u: log-field) */
    uint32_t max_iterations;
    double max_step;                 /* model units */
} ffd_gffd_tracker;

/* Per-point outcome flags. */
enum { FFD_TRACK_UNCHANGED = 0, FFD_TRACK_CONVERGED = 1, FFD_TRACK_FAILED = 2 };

/* Tracks one point bound at p0 with recorded value e0 > 0 (Fig. 5) into out.
 * Returns FFD_TRACK_*; *iterations and *fallback receive counts, *error the
 * final |delta|. */
int ffd_gffd_track_point(const ffd_gffd_tracker *t, const double p0[3], double e0, double out[3],
                         uint32_t *iterations, int *fallback, double *error);

/* Tracks n points (values e0, may be 0: copied) in parallel, filling out and report. */
ffd_status ffd_gffd_track_points(const ffd_gffd_tracker *t, const double *points,
                                 const double *e0, size_t n, double *out,
                                 ffd_gffd_track_report *report, ffd_error *err);

#endif
