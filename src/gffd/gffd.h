/* gffd — generalized free-form deformation with scalar fields (Qin, Hua,
 * Fang, Bao, Peng, "GFFD: Generalized free-form deformation with scalar
 * fields", 2003).
 *
 * Files:
 *   gffd_rbf.c        variational interpolation (Turk & O'Brien 1999): the
 *                     r^3 + linear-polynomial interpolant, factor once, solve
 *                     many, value and analytic gradient (§2, and eq. 4-6's warp)
 *   gffd_distance.c   exact distances from a point to a primitive's geometry
 *                     (point, segment, triangle, polyline, polygon mesh)
 *   gffd_samples.c    the documented sampling rules: where each primitive's
 *                     distance field is sampled (§2, Fig. 1)
 *   gffd_skeleton.c   primitives checked and fitted; the merged field (eq. 1-2)
 *   gffd_track.c      repositioning (§3, Fig. 5): gradient (eq. 3) and warp
 *                     (eq. 4-6) tracking
 *   gffd_deformer.c   the ffd_gffd handle: bind, edit, replace, track
 *   gffd_resample.c   adaptive resampling (§4, Fig. 6)
 */
#ifndef FFD_GFFD_H
#define FFD_GFFD_H

#include "core/core.h"

#include <math.h>
#include <stddef.h>
#include <stdint.h>

/* ---- small vector helpers shared by the gffd files ---- */

static inline void sub3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

static inline double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static inline double norm3(const double a[3])
{
    return sqrt(dot3(a, a));
}

/* ---- variational interpolation (gffd_rbf.c) ------------------------------
 *
 * f(x) = sum_j w_j |x - c_j|^3 + a_0 + a_1 x + a_2 y + a_3 z, one column of
 * (w, a) per value dimension, solving
 *     [ A  P ] [w]   [v]
 *     [ P' 0 ] [a] = [0]      A_ij = |c_i - c_j|^3, P_i = (1, x_i, y_i, z_i).
 * The (m+4) x (m+4) symmetric indefinite matrix is factored once (LAPACK
 * dsytrf, Bunch-Kaufman) and then solved for any number of right-hand
 * sides (dsytrs). When the factorisation is singular or its reciprocal
 * condition number (dsycon, 1-norm) is below FFD_RBF_RCOND — coincident
 * centres, all centres coplanar so that P loses rank — the factor keeps a
 * copy of the matrix instead and every solve is the minimum-norm least
 * squares solution (ffd_dense_lstsq, SVD): the field then interpolates in
 * the least-squares sense, and `regularised` says so. */

#define FFD_RBF_RCOND 1e-14

typedef struct ffd_rbf_factor {
    size_t count;      /* m centres */
    double *centres;   /* m by 3 (copied) */
    double *lu;        /* (m+4)^2 column-major: dsytrf output, or the matrix itself when regularised */
    int *ipiv;         /* m+4 (NULL when regularised) */
    int regularised;   /* 1: solves are minimum-norm least squares */
    double rcond;      /* reciprocal condition estimate (0 when singular) */
} ffd_rbf_factor;

/* Factors the interpolation matrix of the m centres (m >= 1, finite).
 * FFD_ERR_NOMEM, FFD_ERR_NUMERIC (LAPACK failed), FFD_ERR_INVALID (m == 0),
 * FFD_ERR_NONFINITE (a centre). The matrix is built on the centres moved to
 * their centroid and scaled by their largest distance from it, so that rcond
 * and `regularised` do not depend on the skeleton's scale or position. */
ffd_status ffd_rbf_factor_create(const double *centres, size_t m, ffd_rbf_factor *out,
                                 ffd_error *err);
void ffd_rbf_factor_free(ffd_rbf_factor *f);

/* A fitted interpolant: dim value columns over the factor's centres. */
typedef struct ffd_rbf {
    size_t count;      /* m */
    int dim;           /* 1 (a distance field) or 3 (a warp displacement) */
    double *centres;   /* m by 3 (copied, so the rbf outlives its factor) */
    double *weights;   /* m by dim, row-major: w_j for centre j */
    double poly[4][3]; /* poly[k][d]: a_k of column d (k = 0 constant, 1..3 x, y, z), the
                          polynomial being in x - origin: a_0 + a_1 (x - o_x) + ... */
    double origin[3];  /* the centres' centroid (the polynomial's origin, for accuracy far
                          from the world origin); plain data, so that a copy of the struct
                          with deep copies of centres and weights is a working rbf */
    double lo[3], hi[3]; /* bounding box of the centres */
} ffd_rbf;

/* Solves for values (m by dim, row-major) and fills out. dim is 1 or 3.
 * FFD_ERR_NOMEM, FFD_ERR_NUMERIC, FFD_ERR_NONFINITE (a value or the solution). */
ffd_status ffd_rbf_fit(const ffd_rbf_factor *f, const double *values, int dim, ffd_rbf *out,
                       ffd_error *err);
void ffd_rbf_free(ffd_rbf *r);

/* f(x): value[dim]; gradient (may be NULL) receives dim rows of 3
 * (gradient[3*d + k] = d f_d / d x_k), analytic: grad |x-c|^3 = 3 |x-c| (x-c).
 * No allocation; thread-safe. The sums run in a fixed lane order (SSE2 where
 * the compiler targets it, the same order in portable C elsewhere), so the
 * result does not depend on the platform's vector width. */
void ffd_rbf_eval(const ffd_rbf *r, const double x[3], double *value, double *gradient);

/* ---- exact distances (gffd_distance.c) ---------------------------------- */

double ffd_dist2_point_segment(const double p[3], const double a[3], const double b[3]);
/* Squared distance from p to the closed triangle (a, b, c); a degenerate
 * triangle is measured as its longest edge. */
double ffd_dist2_point_triangle(const double p[3], const double a[3], const double b[3],
                                const double c[3]);

/* ---- primitives (gffd_skeleton.c checks; gffd_samples.c samples) -------- */

/* The primitive kinds of ffd.h (FFD_GFFD_POINT ...) with their geometry
 * copied; polygons are fan-triangulated into tris (for distances). */
typedef struct ffd_gffd_geometry {
    int kind;              /* ffd_gffd_kind */
    size_t vertex_count;
    double *vertices;      /* vertex_count by 3 */
    size_t tri_count;
    uint32_t *tris;        /* tri_count by 3 (patch, polyhedron) */
    double radius;         /* r_s, model units */
} ffd_gffd_geometry;

/* Exact (unsigned) distance from x to the geometry; for a polyhedron signed:
 * negative inside (inside by ray parity against tris: the majority of three
 * rays in fixed oblique directions, a ray that grazes an edge or a vertex
 * replaced by the next direction; 0 on the surface). O(tri_count). */
double ffd_gffd_geometry_distance(const ffd_gffd_geometry *g, const double x[3]);

/* Sample points of one primitive's distance field (ffd.h documents the
 * rules): *samples (count by 3) and *values (count: the exact signed
 * distance from each sample to the geometry); coincident samples (within
 * 1e-12 x the geometry's bounding-box diagonal, or exactly equal) are merged,
 * the first kept. Details the public rules leave open (gffd_samples.c):
 * "faces" are the triangles of tris; vertex normals are angle-weighted (the
 * same for any triangulation of a planar polygon); vertices of no triangle
 * get no samples. Freed with ffd_free. max_samples == 0: no limit.
 * FFD_ERR_NOMEM (also a polyline that would make over 1e9 samples),
 * FFD_ERR_INVALID (more than max_samples samples after merging, or a
 * polyline with more than 8 x max_samples before: the message names the
 * count and the limit). */
ffd_status ffd_gffd_samples(const ffd_gffd_geometry *g, size_t max_samples, double **samples,
                            double **values, size_t *count, ffd_error *err);

/* Limits (ffd_limits; gffd_estimate.c): an upper bound on the samples the
 * rules above give primitive p before merging, at most max_samples (more
 * is refused anyway), from its vertex count, its faces' corner count
 * (face_offsets) and its segments' lengths; reads no face index, so it may
 * run before p is checked. Exact for points and polylines without merged
 * samples. */
double ffd_gffd_estimate_samples(const ffd_gffd_primitive *p, size_t max_samples);
/* Peak bytes and operations of fitting one field of m samples: the dense
 * (m+4)^2 matrix (twice when a singular solve falls back to least squares
 * is not counted), dsytrf's m^3/3 flops at 1/10 (LAPACK), and the exact
 * distance of each sample (O(faces)). */
void ffd_gffd_estimate_fit(double m, size_t face_count, double *bytes, double *work);

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
    int turned;             /* 1: rot/shift were given (ffd_gffd_skeleton_transform), not
                               fitted to the vertices: the whole skeleton's fit keeps off */
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
 * motion of the whole skeleton moves every field exactly. scratch holds
 * 6 x ffd_gffd_skeleton_vertex_count(rest) doubles (allocated by the caller
 * before it changes anything, so that this step cannot fail). */
void ffd_gffd_skeleton_align(ffd_gffd_skeleton *cur, const ffd_gffd_skeleton *rest,
                             double *scratch);

/* The warp's automatic correspondences (eq. 4) for an edit of rest into
 * cur (same structure): every skeleton vertex, and around it points at half
 * the radius that turn with the primitive there (a point: 6 along the axes;
 * a polyline vertex: 4 across its tangent; a patch vertex: 2 along its
 * normal), so that the warp is determined in 3D even for a straight or flat
 * skeleton and carries the cross-sections round a bend. count first, then
 * from (rest) and to (cur), count by 3 each; either may be NULL. */
size_t ffd_gffd_correspondence_count(const ffd_gffd_skeleton *rest);
void ffd_gffd_correspondences(const ffd_gffd_skeleton *rest, const ffd_gffd_skeleton *cur,
                              double *from, double *to);

/* Moves part index rigidly by x -> rot x + shift: its vertices, and its
 * fitted field with them (composed with the part's placement; no refit).
 * Unlike new vertex positions this carries the turn of a point or of a
 * straight polyline about itself. Cannot fail. */
void ffd_gffd_skeleton_transform(ffd_gffd_skeleton *s, size_t index, const double rot[3][3],
                                 const double shift[3]);
/* 1 when every field of cur is the rest one moved by one and the same rigid
 * motion (rot, shift), not the identity: then tracking is that motion. */
int ffd_gffd_skeleton_motion(const ffd_gffd_skeleton *cur, const ffd_gffd_skeleton *rest,
                             double rot[3][3], double shift[3]);

/* The primitive nearest to x relative to its radius, among those whose box
 * holds x: its field value *f, gradient and radius; 0 when none. */
int ffd_gffd_skeleton_nearest(const ffd_gffd_skeleton *s, const double x[3], double *f,
                              double grad[3], double *radius);
/* The motion of the primitive nearest to x in the rest skeleton (relative
 * to its radius, among those in range) when cur moved it rigidly from rest:
 * 1 and (rot, shift); 0 otherwise. Tracking's fallback start. */
int ffd_gffd_skeleton_own_motion(const ffd_gffd_skeleton *rest, const ffd_gffd_skeleton *cur,
                                 const double x[3], double rot[3][3], double shift[3]);

/* All vertices, in part order (ffd_gffd_skeleton_vertex_count by 3). */
void ffd_gffd_skeleton_gather_vertices(const ffd_gffd_skeleton *s, double *out);
/* The merged field E (eq. 1-2) at x, and its gradient (may be NULL). */
double ffd_gffd_skeleton_field(const ffd_gffd_skeleton *s, const double x[3], double grad[3]);

/* The influence band (a departure from the paper, docs/gffd.md): over the
 * outer GFFD_BAND of each radius the tracked displacement fades to zero, so
 * that the deformation is continuous where an influence region ends. */
#define GFFD_BAND (1.0 / 3.0)
/* E at x, and in *weight the blend weight b(x) in [0, 1]: the largest over
 * the primitives in range of S((r_i - f_i) / (GFFD_BAND r_i)), S the quintic
 * smoothstep (C^2). b = 0 exactly where E = 0, 1 deeper than the band. */
double ffd_gffd_skeleton_field_weight(const ffd_gffd_skeleton *s, const double x[3],
                                      double *weight);
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
    const ffd_gffd_skeleton *rest;   /* the rest one, when field is an edit of it (else NULL) */
    int rigid;                       /* 1: every field moved by (rot, shift): points do too */
    double rot[3][3], shift[3];
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

/* Tracks n points (values e0, may be 0: copied) in parallel, filling out
 * and report; then each point's displacement is scaled by its blend weight
 * (n, in [0, 1]; 1 leaves the tracked position bitwise, 0 the point). */
ffd_status ffd_gffd_track_points(const ffd_gffd_tracker *t, const double *points,
                                 const double *e0, const double *weight, size_t n, double *out,
                                 ffd_gffd_track_report *report, ffd_error *err);

/* ---- any point set (gffd_deformer.c; ffd_deformer_bind) ---------------- */

/* What binding records for each of n points (§3), as ffd_gffd_create does
 * for its own: e_0 = E(P) in g's rest field and the blend weight of the
 * influence band (both n). Depends on the rest skeleton only. */
void ffd_gffd_bind_values(const ffd_gffd *g, const double *points, size_t n, double *e0,
                          double *weight);
/* Tracks n points with values e0 and blend weights weight into out (n by 3)
 * against g's current skeleton, exactly as ffd_gffd_track tracks g's own
 * points (the same warp, rigid-motion shortcut and options); report may be
 * NULL. */
ffd_status ffd_gffd_track_with(const ffd_gffd *g, const double *points, const double *e0,
                               const double *weight, size_t n, double *out,
                               ffd_gffd_track_report *report, ffd_error *err);

#endif
