/* tsv — the tailored cubic T-spline volume of proxy-driven FFD (Zhang, Zheng
 * & Cai 2020) and its refinable T-lattice. Internal to the library.
 *
 * Design: docs/design/tspline-volume.md (section numbers below refer
 * to it as "design §n"; "paper" is the Zhang-Zheng-Cai paper).
 *
 * Modules (one writer each):
 *   tsv_lattice.c  registries, elements, indexes, locate, ray casting, splits
 *   tsv_refine.c   pieces, the Sederberg closure, the three insertions
 *   tsv_eval.c     univariate basis, support bins, transfer matrix Phi, Jacobians
 *   tsv_proxy.c    occupancy, flood fill, proxy faces; ARAP graph from the lattice
 *   tsv_check.c    fold-over check
 *   tsv_arap.c     ARAP normal equations (CHOLMOD), rotations, solves
 *   tsv_deformer.c the public ffd_tsv_* API
 */
#ifndef FFD_TSV_H
#define FFD_TSV_H

#include "core/core.h"

#include <stdint.h>

/* ---------------------------------------------------------------------
 * Topological coordinates (design §1.1)
 * --------------------------------------------------------------------- */

/* Vertex planes sit at sigma = -1, 0, k, 2k, ..., 1, 2; frame planes (no
 * vertices, padding only) at -3, -2 and 3, 4. kappa(sigma) = clamp(sigma, 0, 1). */
#define TSV_SIGMA_MIN (-1.0)
#define TSV_SIGMA_MAX 2.0
/* Registry snap distance: a requested knot within this of an existing one is that one. */
#define TSV_REGISTRY_SNAP 1e-13
/* Weights below this are an error (design §3.4). */
#define TSV_MIN_WEIGHT 1e-8

static inline double tsv_kappa(double sigma)
{
    return sigma < 0.0 ? 0.0 : (sigma > 1.0 ? 1.0 : sigma);
}

/* Position channels carried through refinement (design §3.4). */
enum { TSV_CURRENT = 0, TSV_REST = 1, TSV_REFERENCE = 2, TSV_NCH = 3 };

typedef struct tsv_registry {
    double *v;   /* sorted ascending, distinct; includes the frame planes -3,-2,3,4 */
    size_t n, cap;
} tsv_registry;

typedef struct tsv_vertex {
    double sg[3];           /* sigma coordinates (copies of registry values) */
    double W;               /* weight w_i of eq. 1 */
    double P[TSV_NCH][3];   /* positions: current, rest, reference */
    uint8_t frozen;
} tsv_vertex;

typedef struct tsv_edge {
    int axis;               /* direction of the edge */
    double c[2];            /* sigma of the other two axes, in increasing axis order */
    double lo, hi;          /* sigma range along axis, lo < hi */
    uint32_t v0, v1;        /* vertices at lo and hi */
} tsv_edge;

typedef struct tsv_face {
    int normal;             /* axis the face is perpendicular to */
    double c;               /* sigma along the normal */
    double lo[2], hi[2];    /* sigma ranges along the two in-plane axes, increasing axis order */
    int32_t cell_neg;       /* cell on the -normal side, -1 = outside the domain */
    int32_t cell_pos;       /* cell on the +normal side, -1 = outside the domain */
} tsv_face;

typedef struct tsv_cell {
    double lo[3], hi[3];    /* sigma box */
    uint8_t occupied;       /* the object meets it (tsv_proxy.c) */
    uint8_t outside;        /* reached by the flood fill from the domain boundary */
} tsv_cell;

typedef struct tsv_lattice_index tsv_lattice_index; /* hashes and locators, tsv_lattice.c */

typedef struct tsv_lattice {
    tsv_registry reg[3];
    tsv_vertex *verts;  size_t nv, cap_v;
    tsv_edge *edges;    size_t ne, cap_e;
    tsv_face *faces;    size_t nf, cap_f;
    tsv_cell *cells;    size_t nc, cap_c;
    uint32_t res[3];        /* initial n_s, n_t, n_u */
    double box_min[3], box_max[3];
    uint64_t version;       /* bumped by every topology change */
    tsv_lattice_index *index;
} tsv_lattice;

/* ---------------------------------------------------------------------
 * tsv_lattice.c
 * --------------------------------------------------------------------- */

/* The initial clamped uniform lattice (design §1.4): res[a] >= 4 vertex
 * planes per axis, all channels at the Greville points, W = 1. Element ids
 * as documented in ffd.h (cells (i*(n_t-1)+j)*(n_u-1)+k). */
ffd_status ffd_tsv_lattice_create(const double box_min[3], const double box_max[3],
                              const uint32_t res[3], tsv_lattice **out, ffd_error *err);
void ffd_tsv_lattice_destroy(tsv_lattice *L);
/* Deep copy (snapshot for roll-back). NULL on OOM. */
tsv_lattice *ffd_tsv_lattice_clone(const tsv_lattice *L);
/* Moves src's contents into dst (dst's old contents freed); src is left empty and freed. */
void ffd_tsv_lattice_swap_in(tsv_lattice *dst, tsv_lattice *src);

/* Registry: the canonical sigma for parameter value v in (0,1) on axis a
 * (an existing one within TSV_REGISTRY_SNAP, else inserted). */
ffd_status ffd_tsv_registry_get(tsv_lattice *L, int axis, double v, double *sigma, ffd_error *err);
/* Registry neighbours of an existing sigma (frame planes beyond the ends). */
double ffd_tsv_registry_prev(const tsv_lattice *L, int axis, double sigma);
double ffd_tsv_registry_next(const tsv_lattice *L, int axis, double sigma);
/* Global Greville coordinate gamma(sigma) = (kappa(prev) + kappa(sigma) + kappa(next))/3
 * of a registry value (design §5.1): monotone, gamma(-1) = 0, gamma(2) = 1. */
double ffd_tsv_gamma(const tsv_lattice *L, int axis, double sigma);

/* Lookups (exact sigma compare). -1 / UINT32_MAX when absent. */
uint32_t ffd_tsv_vertex_find(const tsv_lattice *L, const double sg[3]);

/* Lowest-dimensional element whose closed box contains q: *dim = 0 vertex,
 * 1 edge, 2 face, 3 cell; *id its index. q must lie in [-1,2]^3. */
void ffd_tsv_lattice_locate(const tsv_lattice *L, const double q[3], int *dim, uint32_t *id);

/* Local knot vectors of vertex v by ray casting (design §1.3, paper eq. 1):
 * knots[d][0..4] in sigma (frame-padded). */
void ffd_tsv_infer_knots(const tsv_lattice *L, uint32_t v, double knots[3][5]);

/* Topological splits (design §3.1) at registry value x. The element keeps
 * its id for the part below x; new parts are appended. New vertices get
 * W = 1 and zero positions (the closure fills them). */
ffd_status ffd_tsv_split_edge(tsv_lattice *L, uint32_t e, double x, uint32_t *new_vertex,
                          ffd_error *err);
ffd_status ffd_tsv_split_face(tsv_lattice *L, uint32_t f, int axis, double x, ffd_error *err);
ffd_status ffd_tsv_split_cell(tsv_lattice *L, uint32_t c, int axis, double x, ffd_error *err);

/* Vertex ids on face f's closed boundary, counter-clockwise seen from +normal
 * (in the in-plane axes (a,b) = the two other axes in increasing order),
 * starting at the (lo,lo) corner. *ids: ffd_malloc'd. */
ffd_status ffd_tsv_face_ring(const tsv_lattice *L, uint32_t f, uint32_t **ids, size_t *count,
                         ffd_error *err);
/* Vertex ids on cell c's closed boundary (corners and hanging), ascending. */
ffd_status ffd_tsv_cell_points(const tsv_lattice *L, uint32_t c, uint32_t **ids, size_t *count,
                           ffd_error *err);
/* max |W_v - 1| over the vertices (design §1.5's diagnostic). */
double ffd_tsv_lattice_max_weight_deviation(const tsv_lattice *L);
/* Checks invariants 1-4 of design §1.2 (tests). FFD_ERR_NUMERIC with the first violation. */
ffd_status ffd_tsv_lattice_validate(const tsv_lattice *L, ffd_error *err);

/* ---------------------------------------------------------------------
 * tsv_refine.c
 * --------------------------------------------------------------------- */

typedef struct tsv_refine_stats {
    size_t added_points, moved_points, topology_steps;
    double max_weight_deviation;
} tsv_refine_stats;

/* One edit = the public insertions (ids as before the edit): apply all the
 * topology, then the closure of design §3.3 carrying every channel; on any
 * error the lattice is restored from a snapshot. Updates L->version. */
ffd_status ffd_tsv_lattice_refine(tsv_lattice *L, const ffd_tsv_insertion *ins, size_t count,
                      tsv_refine_stats *stats, ffd_error *err);
/* The same; on success *undo (may be NULL when count == 0) is the lattice as
 * it was before the edit, for a caller whose own follow-up work can fail
 * (ffd_tsv_lattice_swap_in it back, or ffd_tsv_lattice_destroy it). */
ffd_status ffd_tsv_lattice_refine_undoable(tsv_lattice *L, const ffd_tsv_insertion *ins, size_t count,
                               tsv_refine_stats *stats, tsv_lattice **undo, ffd_error *err);

/* What a step will cost, estimated before it runs (ffd_limits; docs/rig.md
 * "Limits"): the cells it leaves, its peak bytes, its operations. The
 * constants are calibrated on the examples (bunny, 1 -> 4 proxy refinements;
 * see tsv_estimate.c) and are meant to be within a factor of two. */
typedef struct tsv_estimate {
    double cells;   /* cells afterwards (refinement) */
    double bytes;   /* peak bytes of the step's largest allocations */
    double work;    /* operations (about one per nanosecond of one core) */
} tsv_estimate;
/* A refinement: the cells its requested topology makes (a cell split makes
 * 2^a cells for its a axes of nonzero knot interval; face and edge
 * insertions make none), which the closure rarely grows. */
void ffd_tsv_estimate_refine(const tsv_lattice *L, const ffd_tsv_insertion *ins, size_t count,
                         tsv_estimate *out);
/* An ARAP drag begun on a lattice of nv control points (factor: nested
 * dissection of a 3D graph, fill ~ nv^(4/3), flops ~ nv^1.7 as measured). */
void ffd_tsv_estimate_arap(size_t nv, uint32_t iterations, tsv_estimate *out);
/* The fold check: samples^3 Jacobians in each cell of nonzero volume. */
void ffd_tsv_estimate_folds(const tsv_lattice *L, uint32_t samples, tsv_estimate *out);

/* ---------------------------------------------------------------------
 * tsv_eval.c
 * --------------------------------------------------------------------- */

/* Cubic B-spline N[k0..k4](x) on five sigma knots evaluated at parameter x
 * (Cox-de Boor on their kappa values; right-closed at x = 1); *dx its
 * derivative (may be NULL). */
double ffd_tsv_basis(const double knots[5], double x, double *dx);

/* Per-vertex cached knot vectors and a uniform support grid over [0,1]^3. */
typedef struct tsv_support tsv_support;
ffd_status ffd_tsv_support_build(const tsv_lattice *L, tsv_support **out, ffd_error *err);
void ffd_tsv_support_destroy(tsv_support *S);
/* Entries (vertex, W_v B_v, and d(W_v B_v)/d(s,t,u) when grad != NULL) of the
 * blending functions nonzero at stu in [0,1]^3; returns the count; arrays
 * need ffd_tsv_support_max(S) entries (grad 3 per entry). */
size_t ffd_tsv_support_eval(const tsv_support *S, const double stu[3], uint32_t *ids, double *w,
                        double *grad);
size_t ffd_tsv_support_max(const tsv_support *S);

/* Transfer matrix Phi (design §2), CSR: Phi[p][v] = W_v B_v(params_p). */
typedef struct tsv_phi {
    size_t rows, cols;
    size_t *rowptr;
    uint32_t *col;
    double *val;
} tsv_phi;
ffd_status ffd_tsv_phi_build(const tsv_lattice *L, const tsv_support *S, const double *params,
                         size_t n, tsv_phi *phi, ffd_error *err);
void ffd_tsv_phi_free(tsv_phi *phi);
/* out (rows by 3) = Phi P[channel]; parallel over rows, bitwise independent of threads. */
void ffd_tsv_phi_apply(const tsv_phi *phi, const tsv_lattice *L, int channel, double *out);
/* F at stu (clamped) for a channel; jac (9, row-major dF/d(s,t,u), may be NULL). */
void ffd_tsv_eval_point(const tsv_lattice *L, const tsv_support *S, int channel, const double stu[3],
                    double out[3], double *jac);
/* The same for the displacement sum_v W_v B_v (P_current - P_rest)_v. */
void ffd_tsv_eval_displacement(const tsv_lattice *L, const tsv_support *S, const double stu[3],
                           double out[3], double *jac);
/* out (rows by 3) = points + Phi (P_current - P_rest): eq. 1 in displacement
 * form (points are the bound points, which the rest channel reproduces);
 * a zero displacement leaves a point bitwise. Parallel over rows. */
void ffd_tsv_phi_apply_displacement(const tsv_phi *phi, const tsv_lattice *L, const double *points,
                                double *out);

/* ---------------------------------------------------------------------
 * tsv_proxy.c
 * --------------------------------------------------------------------- */

typedef struct tsv_object {
    const double *params;        /* n by 3, in [0,1]^3 */
    size_t n;
    const uint32_t *face_offsets; /* face_count + 1, or NULL */
    const uint32_t *face_indices;
    size_t face_count;
} tsv_object;

typedef struct tsv_proxy {
    size_t face_count;
    uint32_t *face_offsets, *face_indices, *face_cells;   /* face_cells: the inside cell */
    uint32_t *lattice_face;       /* face_count: the lattice face id */
    size_t vertex_count;
    uint32_t *vertices;           /* ascending */
    /* the proxy as a closed 2-manifold (tsv_proxy.c, "Sheets"): a control
     * point where inside cells touch only along an edge or at a vertex is one
     * point per sheet through it */
    size_t point_count;
    uint32_t *point_controls;     /* point_count: each point's control id, ascending */
    uint32_t *face_points;        /* face_offsets layout: the point at each corner */
    size_t occupied_cells, inside_cells;
} tsv_proxy;

/* Sets cells[].occupied (triangle-box SAT in gamma coordinates, design §5.1;
 * points in boxes when there are no faces) and cells[].outside (flood fill),
 * then extracts the proxy faces (design §5.3). Replaces *proxy's contents. */
ffd_status ffd_tsv_proxy_build(tsv_lattice *L, const tsv_object *obj, tsv_proxy *proxy,
                           ffd_error *err);
void ffd_tsv_proxy_free(tsv_proxy *proxy);

/* ---------------------------------------------------------------------
 * tsv_arap.c — works on plain arrays (design §6)
 * --------------------------------------------------------------------- */

typedef struct tsv_arap_graph {
    size_t n;                      /* lattice points */
    const double *ref;             /* n by 3 reference positions p */
    const uint32_t *edges;         /* 2 per lattice edge (undirected, each once): N_L, E_1F */
    size_t edge_count;
    const uint32_t *vol;           /* 2 per volumetric-graph pair (undirected, each once,
                                      includes the lattice edges): N_V, E_V */
    size_t vol_count;
    const uint32_t *proxy_offsets; /* proxy polygons over lattice ids: E_M */
    const uint32_t *proxy_indices;
    size_t proxy_face_count;
    const uint32_t *proxy_points;  /* NULL, or per corner its point of the manifold proxy
                                      (tsv_proxy.point_controls): one E_M row per point */
    const uint32_t *proxy_point_controls; /* proxy_point_count: each point's lattice id */
    size_t proxy_point_count;
    const double *proxy_uv;        /* 2 per proxy corner: in-plane gamma coordinates,
                                      for the ear-clipping triangulation */
} tsv_arap_graph;

/* Builds the graph arrays from the lattice (reference channel) and its
 * proxy (tsv_proxy.c). Arrays are owned by the graph; free with
 * ffd_tsv_arap_graph_free. */
ffd_status ffd_tsv_arap_graph_build(const tsv_lattice *L, const tsv_proxy *proxy,
                                tsv_arap_graph *g, ffd_error *err);
void ffd_tsv_arap_graph_free(tsv_arap_graph *g);

enum { TSV_FREE = 0, TSV_HARD = 1, TSV_SOFT = 2 };

typedef struct tsv_arap_weights {
    double one_form, proxy, volume, target;
} tsv_arap_weights;

typedef struct tsv_arap tsv_arap;
/* Factorises A (design §6) for roles (n: TSV_FREE, TSV_HARD fixed at its
 * target, TSV_SOFT penalty w.target). FFD_ERR_INVALID when nothing is
 * constrained; FFD_ERR_NUMERIC when CHOLMOD fails. The graph is copied. */
ffd_status ffd_tsv_arap_solver_create(const tsv_arap_graph *g, const uint8_t *roles,
                           const tsv_arap_weights *w, tsv_arap **out, ffd_error *err);
void ffd_tsv_arap_solver_destroy(tsv_arap *a);
/* iterations x (assemble rotated B, solve, refit rotations). targets: n by 3,
 * read at constrained rows. x: n by 3, in: warm start, out: solution.
 * Rotations persist between calls (warm start). */
ffd_status ffd_tsv_arap_solver_solve(tsv_arap *a, const double *targets, double *x, uint32_t iterations,
                          ffd_error *err);
/* The global step at the current rotations, linearised in the targets
 * (exact: the step is affine in them): transpose 0: out = M^-1 B in (in: n
 * by 3 target changes, read at constrained rows; out: n by 3 point
 * changes); transpose 1: out = B^T M^-1 in (in: n by 3; out: n by 3, zero
 * at free rows). One solve with the cached factor. FFD_ERR_NUMERIC,
 * FFD_ERR_NOMEM (CHOLMOD). */
ffd_status ffd_tsv_arap_solver_linear(tsv_arap *a, const double *in, double *out, int transpose,
                                      ffd_error *err);
/* One global step at the current rotations, without the refit (x: n by 3 out). */
ffd_status ffd_tsv_arap_solver_global_step(tsv_arap *a, const double *targets, double *x,
                                           ffd_error *err);

/* ---------------------------------------------------------------------
 * tsv_deformer.c — the public object
 * --------------------------------------------------------------------- */

struct ffd_tsv {
    tsv_lattice *L;
    tsv_support *S;
    tsv_phi phi;                  /* built on first use (need_phi in tsv_deformer.c): set-up,
                                     refinements and the proxy do not pay for it */
    int has_phi;
    double *params;               /* n by 3 */
    double *points;               /* n by 3: the bound points (evaluation adds displacements) */
    size_t n;
    uint32_t *face_offsets, *face_indices; /* the object's faces (copied), or NULL */
    size_t face_count;
    tsv_proxy proxy;
    double *current;              /* nv by 3 cache of P[TSV_CURRENT] for the public getter */
    uint32_t *tie;                /* linear map tie vector */
    uint64_t frozen_version;      /* bumped when the frozen set changes */
};

/* ffd_tsv_eval and ffd_tsv_jacobian of the bound points together (x n by
 * 3, jac n by 9), the same bits, from one evaluation of the blending
 * functions and their derivatives per point and without Phi: the rig's one
 * final evaluation does not build Phi. Cannot fail today (FFD_OK). */
ffd_status ffd_tsv_eval_jacobian(const ffd_tsv *t, double *x, double *jac, ffd_error *err);

/* The bound points after one ARAP global step for the handle targets
 * (k by 3) at the drag's current rotations, without the refit and without
 * changing the drag or the lattice (out: n by 3): the map whose derivative
 * ffd_tsv_arap_sensitivity_product gives; for tests. */
ffd_status ffd_tsv_arap_global_step(ffd_tsv_arap *a, const double *targets, double *out,
                                    ffd_error *err);

/* ---------------------------------------------------------------------
 * tsv_deformer.c — any point set (ffd_deformer_bind)
 * --------------------------------------------------------------------- */

/* Points bound to a T-spline volume besides its own: their parameters in
 * the lattice's box (the linear parameterisation of §3.2, clamped to
 * [0,1]^3 as the object's are) and their rows of Phi for the lattice
 * topology at `version`: a refinement (which bumps L->version) makes Phi
 * stale and ffd_tsv_points_update rebuilds it. The box never changes, so
 * the parameters stay. */
typedef struct tsv_points {
    size_t n;
    double *points;   /* n by 3, as bound */
    double *params;   /* n by 3 */
    tsv_phi phi;      /* n rows over the lattice at version */
    uint64_t version;
    int has_phi;
    uint32_t *tie;    /* the identity over the columns, for the linear map */
    size_t tie_count;
} tsv_points;

/* Binds n points (finite) to t's lattice; out is filled (free it with
 * ffd_tsv_points_free, also after an error). FFD_ERR_NOMEM. */
ffd_status ffd_tsv_points_bind(const ffd_tsv *t, const double *points, size_t n, tsv_points *out,
                               ffd_error *err);
void ffd_tsv_points_free(tsv_points *p);
/* Rebuilds p's Phi when t's lattice changed since it was built. FFD_ERR_NOMEM
 * (p unchanged). */
ffd_status ffd_tsv_points_update(const ffd_tsv *t, tsv_points *p, ffd_error *err);
/* After ffd_tsv_points_update: the deformed points (n by 3), as ffd_tsv_eval
 * gives the object's; their Jacobians d(x')/d(x) (n by 9, row-major), as
 * ffd_tsv_jacobian's; and the linear map of the points over every control
 * point (the tie is the identity: no control is fixed), which borrows p
 * until its next update or free. */
void ffd_tsv_points_eval(const ffd_tsv *t, const tsv_points *p, double *out);
void ffd_tsv_points_jacobian(const ffd_tsv *t, const tsv_points *p, double *out);
ffd_status ffd_tsv_points_map(const ffd_tsv *t, tsv_points *p, ffd_linear_map *map,
                              ffd_error *err);

#endif
