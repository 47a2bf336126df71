/*
 * ffd_tspline.h — the T-spline method (proxy-driven FFD on a T-spline volume): its public API.
 *
 * Part of the public API of libffd: ffd.h includes this header (through
 * ffd_methods.h), so `#include <ffd.h>` gives it; ffd.h's conventions hold here.
 */
#ifndef FFD_TSPLINE_API_H
#define FFD_TSPLINE_API_H

#include "ffd.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ======================================================================
 * Proxy-driven FFD on a tailored cubic T-spline volume
 * (Zhang, Zheng & Cai 2020, "Proxy-driven free-form deformation by
 * topology-adjustable control lattice"; docs/tspline.md)
 * ====================================================================== */

/* The T-spline volume (§3.1, eq. 1): F(s,t,u) = sum_v W_v P_v B_v(s,t,u),
 * B_v = N[s_v](s) N[t_v](t) N[u_v](u), cubic B-splines on local knot
 * vectors found by casting rays in the T-lattice. The initial lattice is a
 * clamped uniform cubic B-spline volume of res[0] x res[1] x res[2] control
 * points over the bounding box of the object (knots 0,0,0,0,k,2k,...,1,1,1,1,
 * k = 1/(n-3)) with the control points at the Greville abscissae (eq. 2), so
 * every point x of the box has the parameters (x - min) / (max - min) (the
 * linear parameterisation of §3.2) and the rest map is the identity.
 * Refinement (§3.2-3.3) rewrites the map exactly: it never changes the
 * deformation and never re-parameterises the object.
 *
 * Elements have ids: control points 0 .. control_count-1 (never removed or
 * renumbered; refinement appends), edges, faces and cells 0 .. count-1
 * (a split keeps the element's id for its lower half along the split axis and
 * appends the other parts, so ids stay dense; initial cell (i,j,k) of the
 * (n_s-1)(n_t-1)(n_u-1) cells has id (i*(n_t-1) + j)*(n_u-1) + k). */

typedef struct ffd_tsv ffd_tsv;

/* Zero means default for every field. */
typedef struct ffd_tsv_options {
    double padding;  /* grows the bounding box by padding x its extent on each side
                        (an axis of zero extent gets padding x the diagonal, or
                        1e-9 x the diagonal when padding is 0); default 0 (the paper) */
} ffd_tsv_options;

/* Builds the initial lattice over the n points' bounding box and binds the
 * points (their parameters never change afterwards). The object's faces
 * (as in ffd_mesh_create; NULL, NULL, 0 for a point set) decide which cells
 * the object occupies, for the proxy: a cell is occupied when a face (or a
 * point) meets it. Errors: FFD_ERR_INVALID (res below 4 or above 256 on an
 * axis, n == 0, more than 2^31 control points, an extent of the points above
 * 1e100), FFD_ERR_RANGE (face index),
 * FFD_ERR_NONFINITE, FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_tsv_create(const double *points, size_t n, const uint32_t *face_offsets,
                                  const uint32_t *face_indices, size_t face_count, const uint32_t res[3],
                                  const ffd_tsv_options *options, ffd_tsv **out, ffd_error *err);
FFD_API void ffd_tsv_destroy(ffd_tsv *t);

FFD_API size_t ffd_tsv_point_count(const ffd_tsv *t);
/* The parameter box: min and max corners (the padded bounding box). */
FFD_API void ffd_tsv_box(const ffd_tsv *t, double min[3], double max[3]);
/* Parameters (s,t,u) in [0,1]^3 of bound point i. */
FFD_API void ffd_tsv_point_params(const ffd_tsv *t, size_t i, double stu[3]);

FFD_API size_t ffd_tsv_control_count(const ffd_tsv *t);
/* Current control points P_v, control_count by 3 (borrowed; valid until the
 * next edit). */
FFD_API const double *ffd_tsv_control_points(const ffd_tsv *t);
/* Rest position of control point v (where it sits in the identity map). */
FFD_API ffd_status ffd_tsv_rest_point(const ffd_tsv *t, uint32_t v, double out[3], ffd_error *err);
/* Weight W_v (1 on analysis-suitable lattices; kept exactly as refinement
 * leaves it) and the topological coordinates of control point v (its knot
 * line on each axis, in the lattice's index space sigma, where -1 and 2 are
 * the doubled end layers and (0,1) the parameter values). */
FFD_API ffd_status ffd_tsv_control_info(const ffd_tsv *t, uint32_t v, double *weight, double sigma[3],
                                        ffd_error *err);
/* Local knot vectors of control point v (eq. 1), parameter values, 3 by 5. */
FFD_API ffd_status ffd_tsv_knots(const ffd_tsv *t, uint32_t v, double knots[3][5], ffd_error *err);
/* max |W_v - 1| over the control points (a diagnostic). */
FFD_API double ffd_tsv_max_weight_deviation(const ffd_tsv *t);

/* Replaces all control points (count by 3, finite). */
FFD_API ffd_status ffd_tsv_set_control_points(ffd_tsv *t, const double *points, ffd_error *err);
/* Adds delta to control point v. FFD_ERR_RANGE, FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_tsv_move(ffd_tsv *t, uint32_t v, const double delta[3], ffd_error *err);
/* All control points back at rest. */
FFD_API void ffd_tsv_reset(ffd_tsv *t);

/* Frozen control points stay where they are in ARAP solves and are not
 * variables of direct manipulation. */
FFD_API ffd_status ffd_tsv_set_frozen(ffd_tsv *t, uint32_t v, int frozen, ffd_error *err);
FFD_API int ffd_tsv_frozen(const ffd_tsv *t, uint32_t v);

/* --- Lattice elements (current topology) --- */

typedef enum ffd_tsv_element {
    FFD_TSV_EDGE = 0,
    FFD_TSV_FACE,
    FFD_TSV_CELL
} ffd_tsv_element;

FFD_API size_t ffd_tsv_element_count(const ffd_tsv *t, ffd_tsv_element kind);
/* Edge e's two control points (lower end first) and its axis (0 s, 1 t, 2 u). */
FFD_API ffd_status ffd_tsv_edge(const ffd_tsv *t, uint32_t e, uint32_t ends[2], int *axis, ffd_error *err);
/* Element's box in parameter space: lo, hi in [0,1]^3 (zero thickness across
 * a face's normal, along all but an edge's axis; the end layers have zero
 * knot interval). */
FFD_API ffd_status ffd_tsv_element_box(const ffd_tsv *t, ffd_tsv_element kind, uint32_t id, double lo[3],
                                       double hi[3], ffd_error *err);
/* Control points on element id's closed boundary, in order: a face's ring
 * (corners and the hanging points on its sides, counter-clockwise about its
 * normal axis), a cell's corners and hanging points (ascending ids), an
 * edge's two ends. *ids freed with ffd_free. */
FFD_API ffd_status ffd_tsv_element_points(const ffd_tsv *t, ffd_tsv_element kind, uint32_t id,
                                          uint32_t **ids, size_t *count, ffd_error *err);
/* The element of kind nearest to a point given in rest world coordinates
 * (for a cell: the cell that contains its parameters, clamped into the box;
 * for a face or edge: the nearest one in parameter space scaled by the box,
 * lowest id on ties). FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_tsv_locate(const ffd_tsv *t, ffd_tsv_element kind, const double point[3],
                                  uint32_t *id, ffd_error *err);

/* --- Local refinement (§3.2-3.3) --- */

/* One insertion: FFD_TSV_EDGE inserts a point into edge id at ratio of its
 * knot interval (0: the midpoint; else in (0,1)); FFD_TSV_FACE splits face
 * id 1 -> 4 at its centre (1 -> 2 across an end layer); FFD_TSV_CELL splits
 * cell id 1 -> 8 (octree; 1 -> 4 or 1 -> 2 in the end layers). */
typedef struct ffd_tsv_insertion {
    ffd_tsv_element kind;
    uint32_t id;
    double ratio;
} ffd_tsv_insertion;

typedef struct ffd_tsv_refine_report {
    size_t added_points;    /* control points added (requested and extra) */
    size_t moved_points;    /* existing control points the closure moved */
    size_t topology_steps;  /* element splits, the requested ones included */
    double max_weight_deviation; /* max |W - 1| after the edit */
    double seconds;
} ffd_tsv_refine_report;

/* Applies the insertions as one edit (all topology first, ids as they are
 * before the edit, then one closure) with the T-spline local refinement
 * algorithm, so the map is unchanged (to rounding) for every point, and
 * updates the proxy. All or nothing. Allowed at any time, before or after
 * deformation; an ARAP drag in progress becomes stale. Errors:
 * FFD_ERR_RANGE (no such element: "cell 40: there are 36 cells"),
 * FFD_ERR_INVALID (an edge or face in an end layer whose knot interval is 0
 * in every direction the rule would split: "edge 3: zero knot interval";
 * ratio outside (0,1); the closure exceeded its guard), FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_tsv_refine(ffd_tsv *t, const ffd_tsv_insertion *insertions, size_t count,
                                  ffd_tsv_refine_report *report, ffd_error *err);

/* --- Evaluation --- */

/* Deformed positions of the bound points, n by 3 (eq. 1, evaluated as the
 * point plus the displacement Phi (P - P_rest): the rest lattice gives every
 * point back bitwise, and points no moved control point reaches keep their
 * bits). The first call after ffd_tsv_create or a refinement builds Phi
 * (about 64 entries per point), later ones reuse it; FFD_ERR_NOMEM when it
 * cannot be built (out unchanged). */
FFD_API ffd_status ffd_tsv_eval(const ffd_tsv *t, double *out, ffd_error *err);
/* Jacobians d(x')/d(x) at the bound points, n by 9 row-major (I plus the
 * displacement's derivative: exactly I where nothing moved). */
FFD_API ffd_status ffd_tsv_jacobian(const ffd_tsv *t, double *out, ffd_error *err);
/* The map at parameters (clamped into [0,1]^3), 3 doubles; jacobian (9,
 * d(x')/d(x), may be NULL). */
FFD_API void ffd_tsv_eval_params(const ffd_tsv *t, const double stu[3], double out[3], double *jacobian);
/* Sum over v of W_v B_v at stu (1 everywhere: partition of unity). */
FFD_API double ffd_tsv_weight_sum(const ffd_tsv *t, const double stu[3]);
/* The bound points as a linear map of the control points (x_i = sum_v
 * W_v B_v(s_i) P_v) for ffd_manip_solve: columns are control ids, frozen
 * ones tied FFD_TIE_FIXED. The map borrows t (and owns a tie vector in it):
 * refinement or a change of the frozen set invalidates it. */
FFD_API ffd_status ffd_tsv_linear_map(ffd_tsv *t, ffd_linear_map *map, ffd_error *err);

/* --- The proxy (§3.2-3.3) --- */

/* The boundary faces of the union of cells that the object meets (cells
 * enclosed by them count as inside), as a closed polygon mesh over control
 * point ids: quads, or n-gons where hanging points lie on a face's sides.
 * Faces are oriented outwards. Updated after every refinement. Borrowed;
 * valid until the next refinement.
 * Where inside cells touch only along an edge or at a vertex, four faces
 * meet at that edge (two fans at that vertex) over the same control ids;
 * face_points gives the same faces as a closed, outward 2-manifold: such a
 * control point is one point per sheet through it (faces of one inside cell
 * stay connected), and every point maps back to its control id, so all
 * copies of a control point always sit where it is and moving the control
 * point moves them all (docs/tspline.md, "The proxy"). */
typedef struct ffd_tsv_proxy {
    size_t face_count;
    const uint32_t *face_offsets;  /* face_count + 1 */
    const uint32_t *face_indices;  /* control point ids */
    const uint32_t *face_cells;    /* face_count: the inside cell behind each face */
    size_t vertex_count;
    const uint32_t *vertices;      /* distinct control ids on the proxy, ascending */
    size_t occupied_cells;         /* cells the object meets */
    size_t inside_cells;           /* cells inside the proxy (occupied or enclosed) */
    size_t point_count;            /* the manifold proxy's points (>= vertex_count) */
    const uint32_t *point_controls; /* point_count: each point's control id, ascending */
    const uint32_t *face_points;   /* face_offsets layout: the point at each corner */
} ffd_tsv_proxy;
FFD_API void ffd_tsv_get_proxy(const ffd_tsv *t, ffd_tsv_proxy *out);

/* --- Proxy-driven ARAP deformation (§3.4, eq. 3-8) --- */

/* Zero means default for every field. The energy is
 * w_one_form E_1F + w_proxy E_M + w_volume E_V (+ w_target E_C when soft). */
typedef struct ffd_tsv_arap_options {
    double w_one_form;   /* eq. 7; default 1   (the paper: w_1F = 1.5 w_M = 2 w_V = w_C) */
    double w_proxy;      /* eq. 5; default 2/3 */
    double w_volume;     /* eq. 6; default 1/2 */
    double w_target;     /* eq. 4 (soft mode); default 1 */
    uint32_t iterations; /* local/global iterations per solve; default 5 */
    int soft;            /* 1: handles are soft targets (E_C); default: hard */
    int only_target;     /* 1: w_1F = w_M = w_V = 0 apart from a 1e-9 regulariser (tests) */
} ffd_tsv_arap_options;

typedef struct ffd_tsv_arap ffd_tsv_arap;

/* Starts a drag: takes the current lattice as the reference, builds the
 * graphs (lattice edges; the 26-neighbour volumetric graph of each cell's
 * corners and hanging points; the proxy with cotangent weights), and
 * factorises the normal equations once (CHOLMOD) for this set of handles
 * (k control ids; with the frozen points they are the constrained set).
 * Errors: FFD_ERR_RANGE (id), FFD_ERR_INVALID (a handle is frozen: "handle
 * 12 is frozen"; nothing constrained: the system would be singular; a
 * repeated handle), FFD_ERR_NUMERIC (the factorisation failed), FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_tsv_arap_begin(ffd_tsv *t, const uint32_t *handles, size_t k,
                                      const ffd_tsv_arap_options *options, ffd_tsv_arap **out,
                                      ffd_error *err);
FFD_API void ffd_tsv_arap_destroy(ffd_tsv_arap *arap);

typedef struct ffd_tsv_arap_report {
    uint32_t iterations;
    double max_handle_error;  /* max |P_h - target_h| (0 in hard mode) */
    double seconds;
} ffd_tsv_arap_report;

/* One drag step: handle targets (k by 3, finite); runs the iterations
 * (assemble the rotated right-hand side, solve with the cached factor,
 * refit the rotations; warm-started from the previous step) and sets the
 * lattice's control points. FFD_ERR_INVALID when the lattice was refined
 * or the frozen set changed since begin; FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_tsv_arap_solve(ffd_tsv_arap *arap, const double *targets,
                                      ffd_tsv_arap_report *report, ffd_error *err);

/* --- Sensitivities of a drag (docs/sensitivities.md, "T-spline proxy handles") ---
 * The bound points X as a function of the k handle targets q: X = X_0 +
 * Phi (P(q) - P_rest), Phi the T-spline's linear map (ffd_tsv_linear_map's
 * rows) and P(q) the ARAP solution. These give the derivative of ONE GLOBAL
 * STEP AT FIXED ROTATIONS, dX/dq = Phi M^-1 B (M the factored ARAP matrix,
 * B the targets' columns of the right-hand side: eq. 4 in soft mode, the
 * fixed rows in hard mode), at the rotations the drag's last solve left
 * (the identity before the first). It is exact for that step (affine in
 * q) but is not the derivative of ffd_tsv_arap_solve, whose local steps
 * refit the rotations to the new positions: their derivative is left out.
 * With rotations converged it is the usual "frozen rotations" ARAP
 * linearisation. Frozen points are fixed (zero columns). One solve with the
 * drag's CHOLMOD factor per call; the transpose product is a solve with the
 * same symmetric factor. */
/* out (bound points n by 3) = dX/dq v, v k by 3 (handle order of begin).
 * FFD_ERR_INVALID (NULL argument; the lattice was refined or the frozen set
 * changed since begin), FFD_ERR_NUMERIC (CHOLMOD), FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_tsv_arap_sensitivity_product(ffd_tsv_arap *arap, const double *v, double *out,
                                                    ffd_error *err);
/* out (k by 3) = (dX/dq)^T w, w n by 3 (e.g. dJ/dX of an objective J).
 * Errors as ffd_tsv_arap_sensitivity_product. */
FFD_API ffd_status ffd_tsv_arap_sensitivity_transpose_product(ffd_tsv_arap *arap, const double *w,
                                                              double *out, ffd_error *err);
/* --- Fold-over check (beyond the paper: its stated limitation) --- */

typedef struct ffd_tsv_fold_report {
    size_t cells_checked;
    size_t folded_cell_count;   /* cells with det J <= 0 at some sample */
    uint32_t *folded_cells;     /* their ids, ascending (ffd_free; NULL when none) */
    double min_det;             /* min det J over all samples (1 at rest) */
    size_t inverted_face_count; /* object faces whose deformed normal opposes J^-T n, the
                                   normal an orientation-preserving map gives their rest
                                   normal n (at the face's centre): folded or flipped faces */
    uint32_t *inverted_faces;   /* their ids, ascending (ffd_free; NULL when none) */
} ffd_tsv_fold_report;

/* Samples det J on a samples^3 grid in each cell (0: 3) that has nonzero
 * volume in parameter space, and checks the object's faces. */
FFD_API ffd_status ffd_tsv_check_folds(const ffd_tsv *t, uint32_t samples, ffd_tsv_fold_report *report,
                                       ffd_error *err);
FFD_API void ffd_tsv_fold_report_free(ffd_tsv_fold_report *report);

/* --- Behind the generic interfaces (ffd.h) ---
 * ffd_deformer_handle(d, "tspline") is the ffd_tsv; ffd_deformer_create
 * reads the mesh for the proxy; a refinement ends the borrow of a map from
 * ffd_deformer_linear_map. The ARAP factor is CHOLMOD's, which allocates
 * through ffd_set_allocator's allocator once an ARAP solve has started.
 * ffd_limits count the lattice after a refinement and the ARAP factor. In a
 * rig report (ffd_rig_report): control_points are the T-lattice's control
 * points, by id, and control_edges its edges (ffd_rig_report_write_lattice:
 * every control point and one 'l' per T-lattice edge); the control mesh is
 * the manifold proxy (ffd_rig_report_write_proxy writes it); notes report
 * fold-overs; details hold cells, proxy counts, refinements, ARAP solves,
 * folds (docs/rig.md, "The report"). */

#ifdef __cplusplus
}
#endif
#endif /* FFD_TSPLINE_API_H */
