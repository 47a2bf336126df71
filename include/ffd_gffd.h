/*
 * ffd_gffd.h — the GFFD method (skeleton scalar fields): its public API.
 *
 * Part of the public API of libffd: ffd.h includes this header (through
 * ffd_methods.h), so `#include <ffd.h>` gives it; ffd.h's conventions hold here.
 */
#ifndef FFD_GFFD_API_H
#define FFD_GFFD_API_H

#include "ffd.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ======================================================================
 * GFFD: generalized FFD with skeleton scalar fields
 * (Qin, Hua, Fang, Bao, Peng, "GFFD: Generalized free-form deformation with
 * scalar fields", 2003)
 * ====================================================================== */

/* A skeleton primitive (§2): geometry and an influence radius r_s. */
typedef enum ffd_gffd_kind {
    FFD_GFFD_POINT = 0,  /* one vertex */
    FFD_GFFD_POLYLINE,   /* >= 2 vertices joined in order; no zero-length segment */
    FFD_GFFD_PATCH,      /* an open polygon mesh (faces of >= 3 vertices) */
    FFD_GFFD_POLYHEDRON  /* a closed polygon mesh: every edge in exactly two faces */
} ffd_gffd_kind;

/* Geometry is borrowed for the call and copied. faces as in ffd_mesh_create
 * (face_offsets has face_count+1 entries); NULL for points and polylines. */
typedef struct ffd_gffd_primitive {
    ffd_gffd_kind kind;
    const double *vertices;        /* vertex_count by 3 */
    size_t vertex_count;
    const uint32_t *face_offsets;  /* PATCH, POLYHEDRON */
    const uint32_t *face_indices;
    size_t face_count;
    double radius;                 /* r_s > 0, model units */
} ffd_gffd_primitive;

/* Each primitive's distance field f_i is a variational interpolant (Turk &
 * O'Brien 1999: phi(r) = r^3 plus a linear polynomial) of the exact distance
 * to the primitive, signed for a polyhedron (negative inside), at samples
 * placed by these rules (r = r_s, shells at r/3, 2r/3, r and 4r/3):
 *   POINT       the point, and 14 directions (6 axes, 8 cube diagonals) per shell;
 *   POLYLINE    stations at every vertex and evenly along each segment, at
 *               most r/2 apart: the station, and 6 directions per shell in
 *               the plane normal to the curve there; at each end 5 directions
 *               per shell (the outward tangent and 4 at 45 degrees to it);
 *   PATCH       stations at every vertex and at the centroid of each face
 *               wider than r/2: the station, and both normal directions per
 *               shell; at boundary vertices also the outward direction in the
 *               tangent plane per shell;
 *   POLYHEDRON  as PATCH (no boundary): the vertices and the points along
 *               their normals, inside and outside, as the paper says.
 * Coincident samples are merged. The fields are merged by eq. 1-2:
 *   E(P) = sum_i E_i(P),  E_i = exp(-f_i/u) - exp(-r_i/u) where f_i < r_i, else 0,
 * with u the deformer's distance unit, so that a rig gives the same shape at
 * any scale (see ffd_gffd_options). E has an analytic gradient. */

typedef enum ffd_gffd_tracking {
    FFD_GFFD_TRACK_GRADIENT = 0, /* along the normalised field gradient (eq. 3) */
    FFD_GFFD_TRACK_WARP          /* along the warp direction (eq. 4-6) */
} ffd_gffd_tracking;

/* Zero means default for every field. */
typedef struct ffd_gffd_options {
    double unit;            /* u: distances are measured in units of u in eq. 2 and in the
                               tolerance; default 1/10 of the bounding-box diagonal of the
                               bound points and the rest skeleton together */
    double tolerance;       /* epsilon of Fig. 5, in units of u: |ln E(P) - ln e_0| < eps;
                               default 1e-6 */
    uint32_t max_iterations;/* tracking steps per point; default 100 */
    ffd_gffd_tracking tracking;
    size_t max_samples;     /* per primitive; default 4000 */
} ffd_gffd_options;

typedef struct ffd_gffd ffd_gffd;

/* Builds the rest skeleton's fields and binds the n points: records each
 * point's field value e_0 = E(P) (§3). Points with e_0 = 0 are outside every
 * influence region and never move. Errors name the primitive
 * ("skeleton[2]: ..."): FFD_ERR_INVALID (count == 0; radius <= 0; a point
 * with other than one vertex; a polyline with fewer than 2 vertices or a
 * zero-length segment; a face with fewer than 3 vertices or a repeated
 * vertex or zero area; a polyhedron that is not closed; too many samples;
 * options out of range), FFD_ERR_RANGE (face index), FFD_ERR_NONFINITE,
 * FFD_ERR_NOMEM. n may be 0 (points NULL). */
FFD_API ffd_status ffd_gffd_create(const ffd_gffd_primitive *skeleton, size_t count, const double *points,
                                   size_t n, const ffd_gffd_options *options, ffd_gffd **out,
                                   ffd_error *err);
FFD_API void ffd_gffd_destroy(ffd_gffd *g);

FFD_API size_t ffd_gffd_point_count(const ffd_gffd *g);
/* Bound points with e_0 > 0 (the ones tracking may move). */
FFD_API size_t ffd_gffd_influenced_count(const ffd_gffd *g);
FFD_API double ffd_gffd_unit(const ffd_gffd *g);
/* Primitives of the current skeleton, and their current geometry (borrowed,
 * valid until the skeleton changes). */
FFD_API size_t ffd_gffd_primitive_count(const ffd_gffd *g);
FFD_API ffd_status ffd_gffd_get_primitive(const ffd_gffd *g, size_t index, ffd_gffd_primitive *out,
                                          ffd_error *err);
/* 1 when some primitive's field solve was singular and fell back to least
 * squares (coincident or coplanar samples). */
FFD_API int ffd_gffd_regularised(const ffd_gffd *g);

/* Skeleton edit (§5, first way): gives primitive index of the current
 * skeleton new vertex positions (same count, same faces); only that
 * primitive's field is refitted. The rest skeleton's vertices and the new
 * ones give the warp's correspondences P_j0 -> P_j1 (eq. 4) unless
 * ffd_gffd_set_correspondences gave others. FFD_ERR_RANGE,
 * FFD_ERR_NONFINITE, FFD_ERR_INVALID (the edit makes the primitive
 * degenerate); on error nothing changes. */
FFD_API ffd_status ffd_gffd_set_vertices(ffd_gffd *g, size_t index, const double *vertices,
                                         ffd_error *err);
/* Rigid skeleton edit: moves primitive index of the current skeleton by
 * x -> rotation x + translation (rotation: 3 by 3, row-major, a proper
 * rotation to 1e-12), and its field with it, exactly (no refit). Unlike new
 * vertex positions it carries a turn that the vertices cannot show: a point
 * or a straight polyline turned about itself. When every primitive has moved
 * by one and the same rigid motion (and neither a replacement nor user
 * correspondences intervened), tracking moves every influenced point by it
 * in either mode (then blended in the influence band, see ffd_gffd_track).
 * FFD_ERR_RANGE, FFD_ERR_NONFINITE, FFD_ERR_INVALID (not a rotation; a
 * moved coordinate beyond 1e100 or too far for the unit), FFD_ERR_NOMEM; on
 * error nothing changes. */
FFD_API ffd_status ffd_gffd_transform(ffd_gffd *g, size_t index, const double rotation[9],
                                      const double translation[3], ffd_error *err);
/* Skeleton replacement (§5, second way): the current skeleton becomes
 * another one (any primitives, any count). There are no automatic
 * correspondences then: warp tracking needs ffd_gffd_set_correspondences
 * (ffd_gffd_track fails with FFD_ERR_INVALID without them). Errors as
 * ffd_gffd_create; on error nothing changes. */
FFD_API ffd_status ffd_gffd_replace(ffd_gffd *g, const ffd_gffd_primitive *skeleton, size_t count,
                                    ffd_error *err);
/* Back to the rest skeleton (and the automatic correspondences). */
FFD_API ffd_status ffd_gffd_reset(ffd_gffd *g, ffd_error *err);
/* User correspondences for the warp (eq. 4): from[j] on the rest skeleton
 * goes to to[j] (k by 3 each); k == 0 returns to the automatic ones.
 * FFD_ERR_NONFINITE, FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_gffd_set_correspondences(ffd_gffd *g, const double *from, const double *to,
                                                size_t k, ffd_error *err);

/* What a tracking pass did. */
typedef struct ffd_gffd_track_report {
    size_t tracked;            /* influenced points whose field value changed */
    size_t converged;          /* of those, within the tolerance */
    size_t failed_count;       /* not converged (left at their best position) */
    uint32_t *failed;          /* their ids, ascending (free with ffd_free; NULL when none) */
    size_t fallback_count;     /* points that needed a fallback start: gradient tracking that met a
                                  zero gradient and used the warp, or any tracking that started
                                  from the motion of the nearest, rigidly moved primitive */
    size_t iterations;         /* total steps over all points */
    double max_error;          /* max |ln E(P) - ln e_0| over tracked points, units of u */
} ffd_gffd_track_report;

/* Repositions the bound points in the current field (§3, Fig. 5): each
 * influenced point starts where it was bound and moves until it regains
 * e_0: dV = delta V / (grad(-ln E) . V) (the paper's delta V with
 * delta = ln E(P) - ln e_0 in units of u; the same step when the field is a
 * true distance); a step that would cross the iso-surface is tried at the
 * secant point of the bracket, then halved; one that does not improve is
 * reversed, then halved; until |delta| < tolerance or max_iterations.
 * Gradient tracking takes V along grad(-ln E) (eq. 3); a point whose field
 * value did not change is copied unchanged (bitwise); where the gradient
 * vanishes it uses the warp (counted in fallback_count) or gives up. Warp
 * tracking moves every influenced point along V = (W(P) - P)/|W(P) - P|
 * (eq. 6) to W(P) (eq. 5) and restores its value there along the gradient
 * (then, failing that, along the line through P in direction V, then along
 * the gradient from P), so a rigid motion of the skeleton moves the points
 * rigidly; points the warp moves are moved even where the field did not
 * change. When every primitive moved by one and the same rigid motion
 * (ffd_gffd_transform) every influenced point moves by it, in both modes.
 * Points outside every influence region at bind time are copied
 * unchanged (bitwise) in both modes. The influence band (a departure from
 * the paper): each point's displacement is then scaled by its blend weight
 * b = max_i S((r_i - f_i) / (r_i / 3)) over the primitives whose rest
 * field f_i is below r_i, S the quintic smoothstep clamped to [0, 1], so
 * that the deformation is continuous (C^2 in the field) where an influence
 * region ends; points deeper than the outer third of a radius (b = 1) keep
 * their tracked positions bitwise, and points that did not converge are
 * blended the same way (and reported). out: n by 3. report may be NULL; free
 * it with ffd_gffd_track_report_free. Parallel over points, bitwise
 * identical for any thread count. FFD_ERR_INVALID (warp tracking without
 * correspondences), FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_gffd_track(const ffd_gffd *g, double *out, ffd_gffd_track_report *report,
                                  ffd_error *err);
FFD_API void ffd_gffd_track_report_free(ffd_gffd_track_report *report);

/* The merged field E (eq. 1-2) of the rest (current == 0) or current
 * (current == 1) skeleton at n points: values (n) and gradients (n by 3,
 * may be NULL). */
FFD_API ffd_status ffd_gffd_field(const ffd_gffd *g, int current, const double *points, size_t n,
                                  double *values, double *gradients, ffd_error *err);
/* The recorded field values e_0 of the bound points (n). */
FFD_API const double *ffd_gffd_bound_values(const ffd_gffd *g);
/* The blend weights b of the bound points (n, in [0, 1]; see ffd_gffd_track). */
FFD_API const double *ffd_gffd_bound_weights(const ffd_gffd *g);

/* Zero means default for every field. */
typedef struct ffd_gffd_resample_options {
    double ratio;        /* split an edge when its length grows by >= ratio; default 1.8 */
    uint32_t max_rounds; /* rounds of splitting; default 8 */
    size_t max_vertices; /* stop adding vertices beyond this total; default 16 x the input's */
} ffd_gffd_resample_options;

typedef struct ffd_gffd_resample_report {
    size_t rounds;
    size_t added_vertices;
    size_t split_edges;
    size_t long_edges;         /* edges still >= ratio x their reference when it stopped */
    int capped;                /* 1: stopped by max_rounds or max_vertices */
    ffd_gffd_track_report track; /* over the original and added points together */
} ffd_gffd_resample_report;

/* Adaptive resampling (§4, Fig. 6). mesh must be the mesh whose vertices
 * were bound (same count, positions as bound). Tracks the bound points,
 * then, round by round, splits every edge whose deformed length is >= ratio
 * x its reference length (an original edge's rest length; a half inherits
 * its parent's; an edge drawn inside a cell inherits the mean edge length
 * of the original face): the midpoint of the rest edge gets the average of
 * its ends' recorded field values and is tracked too; each edge is split
 * once for all the faces that share it, so closed stays closed and no
 * T-junction appears. Cells are re-polygonised: a triangle with 1, 2 or 3
 * split edges becomes 2, 3 or 4 triangles; a quad with two opposite split
 * edges 2 quads, with four 4 quads about its centre; other polygons take
 * the midpoints into their boundary. *out is a new mesh in the input's
 * format whose new vertices interpolate every vertex attribute (texture
 * coordinates, colours, normals) and whose new faces keep their parent's
 * attributes; its positions are the deformed ones. report may be NULL;
 * free it with ffd_gffd_resample_report_free. FFD_ERR_INVALID (vertex count
 * differs from the bound points), FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_gffd_resample(const ffd_gffd *g, const ffd_mesh *mesh,
                                     const ffd_gffd_resample_options *options, ffd_mesh **out,
                                     ffd_gffd_resample_report *report, ffd_error *err);
FFD_API void ffd_gffd_resample_report_free(ffd_gffd_resample_report *report);

/* --- Behind the generic interfaces (ffd.h) ---
 * ffd_deformer_handle(d, "gffd") is the ffd_gffd. Tracking is not linear in
 * the controls: ffd_deformer_linear_map is FFD_ERR_UNSUPPORTED. The
 * controls are the skeleton's vertices; setting one (ffd_deformer_set_controls)
 * moves its primitive and re-tracks. ffd_deformer_create reads the mesh for
 * tracking. A rig's skeleton "file"s are resolved against the rig's
 * directory (ffd_rig_input_path lists them; ffd_session_load_rig wants them
 * under its root). ffd_rig_apply edits or replaces the skeleton and tracks
 * the vertices (normals recomputed from the deformed faces); with "resample"
 * the mesh gains vertices and faces (it is replaced by the refined mesh).
 * ffd_limits count a field's dense (m+4)^2 matrix. In a rig report:
 * control_points are the current skeleton's vertices (ffd_rig_report_write_lattice
 * writes them only; control_label "GFFD skeleton vertices"); no control
 * mesh; notes name the vertices that tracking lost; details hold influenced,
 * unit, tracking and resampling (docs/rig.md, "The report"). */

#ifdef __cplusplus
}
#endif
#endif /* FFD_GFFD_API_H */
