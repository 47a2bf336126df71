/* pbffd — point-based FFD with ellipsoidal basis functions (McDonnell & Qin,
 * "PB-FFD: A Point-based Technique for Free-Form Deformation"): the kernel
 * (eq. 1-3), the sparse W and D of eq. 7, evaluation, the control-point
 * hierarchy (§3.4, eq. 9-10), control-set edits, direct manipulation rows
 * (§3.3) and curves (§3.5). Automatic placement (§3.2.1) lives in
 * ebf_placement.c.
 *
 * Files: ebf_kernel.c (one EBF: frame, parameters, phi and its gradient),
 * ebf_space.c (a control set prepared for parameterisation: kernels, master,
 * a uniform grid over the ROIs, the normalised weights of eq. 5),
 * ebf_bind.c (rows: the CSR form of W and D), ebf_deformer.c (create,
 * destroy, accessors), ebf_eval.c (eq. 7 in displacement form), ebf_jacobian.c,
 * ebf_hierarchy.c (levels, cascade, move, set_frame, reset), ebf_edit.c
 * (add, remove, enable, redefine by rebasing), ebf_map.c (the linear map),
 * ebf_curve.c (Catmull-Rom curves over a deformer). */
#ifndef FFD_PBFFD_H
#define FFD_PBFFD_H

#include "core/core.h"

#include <math.h>

/* Centres, frame lengths and radii must lie within these magnitudes, so that
 * squared distances and frame determinants neither overflow nor underflow. */
#define FFD_PB_MAX_COORD 1e100
#define FFD_PB_MIN_LENGTH 1e-100

/* ---- one EBF prepared for evaluation (ebf_kernel.c) ---- */

typedef struct ffd_ebf_kernel {
    double center[3];
    double dual[3][3];   /* rows of [a b c]^-1: u = dual (x - center) solves x - center = F u */
    double q[3][3];      /* dual row k times |axis_k| / radius_k: rho^2 = |q (x - center)|^2 */
    double lo[3], hi[3]; /* bounding box of the ROI */
    double weight;       /* factor on phi: 1, master_weight for the master, 0 when disabled */
} ffd_ebf_kernel;

/* Validates one EBF: finite numbers (FFD_ERR_NONFINITE), radii > 0 and a
 * non-degenerate frame (FFD_ERR_INVALID). Messages start with
 * "<what>[index]: " ("controls[3]: radius 0: expected > 0"). */
ffd_status ffd_ebf_check(const ffd_ebf *e, const char *what, size_t index, ffd_error *err);

/* 1 when the frame's axes are (nearly) linearly dependent:
 * |det| <= FFD_TOL_VOLUME |a||b||c| (or not finite). */
int ffd_ebf_frame_degenerate(const double frame[3][3]);

/* Prepares e (valid, see ffd_ebf_check). weight multiplies phi. */
void ffd_ebf_kernel_init(const ffd_ebf *e, double weight, ffd_ebf_kernel *k);

/* The kernel of the ROI-normalised distance (rho^2 < 1): eq. 1 over tau,
 * exp(-rho^2 / (2 sigma^2)), times the window (1 - rho^2)^3 that brings phi and
 * its first two derivatives to zero on the ROI boundary. */
static inline double ffd_ebf_phi_of(double rho2, double inv2s2)
{
    double t = 1.0 - rho2;
    return exp(-rho2 * inv2s2) * (t * t * t);
}

/* The windowed kernel (ffd.h: eq. 1 / tau times (1 - rho^2)^3) at x, times
 * k->weight; 0 outside the ROI. u (may be NULL) receives the parameters
 * (alpha, beta, gamma) of eq. 3; grad (may be NULL) the gradient in x. */
double ffd_ebf_phi(const ffd_ebf_kernel *k, double inv2s2, const double x[3], double u[3],
                   double grad[3]);

/* Radius of the smallest sphere about the centre holding the ROI (the
 * largest singular value of [r_a a/|a|, r_b b/|b|, r_c c/|c|]). */
double ffd_ebf_bounding_radius(const ffd_ebf *e);

/* ---- a control set prepared for parameterisation (ebf_space.c) ---- */

typedef struct ffd_ebf_space {
    size_t count;
    ffd_ebf_kernel *kernel; /* count; disabled controls have weight 0 */
    int has_master;
    ffd_ebf_kernel master; /* weight = master_weight */
    double inv2s2;         /* 1 / (2 sigma^2) */
    /* uniform grid over the ROIs' bounding boxes; dim[0] == 0: no grid (scan all) */
    uint32_t dim[3];
    double lo[3], hi[3], inv_h; /* hi: lo + dim / inv_h, the far edge */
    uint32_t *cell_start; /* cells + 1 */
    uint32_t *cell_ctl;   /* controls whose ROI box meets the cell, ascending per cell */
} ffd_ebf_space;

/* Prepares count controls (and the master when not NULL). grid: build the
 * ROI grid (worth it for many points). FFD_ERR_NOMEM. */
ffd_status ffd_ebf_space_init(ffd_ebf_space *s, const ffd_ebf *controls, size_t count,
                              const ffd_ebf *master, double master_weight, double sigma, int grid);
void ffd_ebf_space_free(ffd_ebf_space *s);

/* The normalised weights of eq. 5 at x: for each control whose kernel is
 * positive there (ascending index) col, w (a row of W) and d = w (alpha,
 * beta, gamma) (3 each: a row of D, eq. 7). Returns the count (<= s->count). *master_w
 * receives the master's normalised weight, or 1 when no kernel (master
 * included) is positive at x: the point is then held where it is. */
size_t ffd_ebf_space_weights(const ffd_ebf_space *s, const double x[3], uint64_t accepted,
                             uint32_t *col, double *w, double *d, double *master_w);

/* The number of entries ffd_ebf_space_weights gives at x (no exp needed).
 * *accepted (may be NULL) receives which of x's grid candidates enter (bit
 * e: the e-th), for ffd_ebf_space_weights to visit only those (binding scans
 * the candidates once instead of twice), or FFD_EBF_TEST_ALL: test them all. */
size_t ffd_ebf_space_count(const ffd_ebf_space *s, const double x[3], uint64_t *accepted);
#define FFD_EBF_TEST_ALL UINT64_MAX

/* ---- rows: sparse W and D (ebf_bind.c) ---- */

typedef struct ffd_ebf_rows {
    size_t n;       /* rows */
    size_t cap;     /* entry capacity (>= start[n]) */
    size_t *start;  /* n + 1 */
    uint32_t *col;  /* control index per entry */
    double *w;      /* per entry: w_ij, the normalised weight (PB-FFD eq. 5), W of eq. 7 */
    double *d;      /* 3 per entry: w_ij u_ij, the D of eq. 7 */
    double *c;      /* absolute rows only (n by 3): the master's constant term w_m x (eq. 10) */
    size_t max_nnz; /* longest row */
} ffd_ebf_rows;

/* Parameterises n points (PB-FFD eq. 3-7) in parallel; results do not depend
 * on the thread count. absolute: also store c (rows evaluate as
 * c + sum w p_j + sum d . A_j). min_cap: entry capacity at least this. */
ffd_status ffd_ebf_rows_bind(const ffd_ebf_space *s, const double *points, size_t n, int absolute,
                             size_t min_cap, ffd_ebf_rows *rows);
void ffd_ebf_rows_free(ffd_ebf_rows *rows);
/* Deep copy with capacity at least min_cap. */
ffd_status ffd_ebf_rows_copy(const ffd_ebf_rows *src, size_t min_cap, ffd_ebf_rows *dst);
/* Copies src into dst without allocating (requires dst->cap >= entries of
 * src and dst->n == src->n). */
void ffd_ebf_rows_assign(ffd_ebf_rows *dst, const ffd_ebf_rows *src);

/* Row r of the result is old row pick[r] (columns through colmap when not
 * NULL) when pick[r] < old->n, else row pick[r] - old->n of sub. */
ffd_status ffd_ebf_rows_splice(const ffd_ebf_rows *old, const ffd_ebf_rows *sub, const size_t *pick,
                               size_t n, const uint32_t *colmap, size_t min_cap, ffd_ebf_rows *out);

/* Absolute row i evaluated against the controls (PB-FFD eq. 10). */
void ffd_ebf_rows_eval_abs(const ffd_ebf_rows *rows, size_t i, const ffd_ebf *ctl, double out[3]);

/* ---- the deformer ---- */

/* One level of the hierarchy (§3.4). Level 0 is the finest. */
typedef struct ffd_pb_level {
    size_t count;
    ffd_ebf *cur;      /* current P and A */
    ffd_ebf *base;     /* where reset puts them */
    ffd_ebf_rows rows; /* this level's points over level + 1, absolute (eq. 10); none on the top */
    ffd_ebf_rows rows_base; /* rows at the base state */
    unsigned char *changed; /* count flags, scratch of the cascade */
} ffd_pb_level;

/* A snapshot of level 0 against which some bound points were parameterised
 * (the Jacobian needs their kernels; evaluation uses only the latest). */
typedef struct ffd_pb_version {
    ffd_ebf *ctl; /* NULL: free slot */
    size_t count;
    size_t refs; /* bound points parameterised against it */
} ffd_pb_version;

typedef struct ffd_pb_map_state ffd_pb_map_state;

struct ffd_pbffd {
    double sigma;
    double master_weight;
    int has_master;
    ffd_ebf master; /* one master for every level (immovable) */
    size_t level_count;
    ffd_pb_level *levels;
    /* bound points: displacement rows over level 0:
     * x' = x_base + W (P - P_base) + D (A - A_base)    (PB-FFD eq. 7) */
    size_t n;
    double *x_base; /* n by 3: positions at level 0's base state */
    double *x_ref;  /* n by 3: where each row was parameterised */
    ffd_ebf_rows mesh;
    uint32_t *version; /* n: snapshot of each row; NULL: all 0 */
    double *J_ref;     /* n by 9: d x_ref / d x; NULL: identity */
    ffd_pb_version *versions;
    size_t version_count;
    uint32_t version_latest;
    ffd_pb_map_state **maps; /* level_count, lazily allocated (linear maps) */
    uint64_t edit_count;   /* control-set edits made (add, remove, set_enabled, redefine) */
    uint64_t rebase_count; /* of those, the ones that rebased (ebf_edit.c: base = current state) */
};

/* ebf_deformer.c */
/* Kernel space of level's current state, for parameterising points of level - 1
 * (level 0: the bound points). */
ffd_status ffd_pb_space(const ffd_pbffd *pb, size_t level, int grid, ffd_ebf_space *s);

/* ebf_hierarchy.c */
/* Builds levels 1.. from level 0 and parameterises every level in the next (eq. 10). */
ffd_status ffd_pb_build_hierarchy(ffd_pbffd *pb, uint32_t levels, ffd_error *err);
/* Sets control index of level to center (and frame when not NULL), re-parameterises
 * it in level + 1 when the centre changed, and cascades to the finer levels. */
ffd_status ffd_pb_place(ffd_pbffd *pb, size_t level, size_t index, const double center[3],
                        const double frame[3][3], ffd_error *err);
/* FFD_ERR_RANGE naming the level or the control when either is out of range. */
ffd_status ffd_pb_check_index(const ffd_pbffd *pb, size_t level, size_t index, ffd_error *err);

/* ebf_jacobian.c */
/* Kernels of every live version (NULL entries for free slots). */
ffd_status ffd_pb_version_kernels(const ffd_pbffd *pb, ffd_ebf_kernel ***out);
void ffd_pb_version_kernels_free(const ffd_pbffd *pb, ffd_ebf_kernel **k);
/* d x' / d x at bound point i, 9 row-major; master: the master's kernel or NULL. */
void ffd_pb_jacobian_point(const ffd_pbffd *pb, ffd_ebf_kernel *const *vk,
                           const ffd_ebf_kernel *master, size_t i, double J[9]);

/* ebf_map.c */
void ffd_pb_map_state_free(ffd_pb_map_state *m);

/* ebf_eval.c: the change of level 0 since its base, 12 per control (dP, da,
 * db, dc); flags[j] |= 1 when control j changed, 2 when its frame did.
 * Returns the OR of all flags. */
unsigned ffd_pb_delta_table(const ffd_pbffd *pb, double *table, unsigned char *flags);
/* ffd_pbffd_eval of any rows over level 0 made against its base state, for
 * points whose base positions are x_base (count by 3): x_base + W dP + D dA. */
ffd_status ffd_pb_eval_rows(const ffd_pbffd *pb, const ffd_ebf_rows *rows, const double *x_base,
                            size_t count, double *out, ffd_error *err);

/* ebf_jacobian.c: ffd_pb_jacobian_point for row i of any rows (columns of
 * level 0) made at x against the control state snap (kernels K); J_ref (9,
 * may be NULL: identity) composes on the right. */
void ffd_pb_jacobian_row(const ffd_pbffd *pb, const ffd_ebf_kernel *K, const ffd_ebf *snap,
                         const ffd_ebf_kernel *master, const ffd_ebf_rows *rows, size_t i,
                         const double x[3], const double *J_ref, double J[9]);

/* ebf_map.c: ffd_pbffd_linear_map of any rows over level 0 (points rows->n),
 * with an identity tie (a disabled control is in no row: its column is
 * empty). The state (*state, freed with ffd_pb_map_state_free) belongs to
 * the caller, not to pb; the map borrows pb, rows and the state. */
ffd_status ffd_pb_rows_linear_map(const ffd_pbffd *pb, size_t level, const ffd_ebf_rows *rows,
                                  ffd_linear_map *map, ffd_pb_map_state **state, ffd_error *err);

/* ebf_sensitivity.c: the bound points' derivatives with respect to the
 * frames of level's controls (6 columns per control: rotation vector, then
 * the three axis scalings), as CSR (3n rows + 1 in ptr; ffd_free each), and
 * its product (v: 6 per control -> out: 3n) or transpose product
 * (transpose: v 3n -> out 6 per control). FFD_ERR_RANGE, FFD_ERR_NOMEM. */
ffd_status ffd_pb_frame_sensitivities_csr(const ffd_pbffd *pb, size_t level, size_t **ptr,
                                          uint32_t **col, double **val, ffd_error *err);
ffd_status ffd_pb_frame_sensitivity_product(const ffd_pbffd *pb, size_t level, const double *v,
                                            double *out, int transpose, ffd_error *err);

/* ---- other point sets (ebf_points.c) ----
 * Points bound after creation as they would have been bound as the
 * deformer's points at creation: rows over level 0's base state, which is
 * the creation state while no control-set edit has rebased it
 * (rebase_count == 0). Edits that did not rebase (of disabled controls)
 * only renumber columns: the rows are made again (edit_count). */
typedef struct ffd_pb_points {
    size_t n;
    double *x;           /* n by 3: the points as bound */
    ffd_ebf_rows rows;   /* W and D of eq. 7 over level 0's base state */
    uint64_t edit_count; /* pb->edit_count when the rows were made */
} ffd_pb_points;

/* FFD_ERR_UNSUPPORTED when pb's control set was rebased (the message says
 * why), FFD_ERR_NOMEM. On error *out is zeroed. */
ffd_status ffd_pb_points_bind(const ffd_pbffd *pb, const double *points, size_t n,
                              ffd_pb_points *out, ffd_error *err);
void ffd_pb_points_free(ffd_pb_points *p);
/* p's rows, or (when pb's control set was edited since) rows made again
 * into *fresh (then p == fresh's owner must free it); *use receives which. */
ffd_status ffd_pb_points_current(const ffd_pbffd *pb, const ffd_pb_points *p,
                                 ffd_pb_points *fresh, const ffd_pb_points **use, ffd_error *err);
/* Positions (n by 3, eq. 7 in displacement form) and Jacobians (n by 9). */
ffd_status ffd_pb_points_eval(const ffd_pbffd *pb, const ffd_pb_points *p, double *out,
                              ffd_error *err);
ffd_status ffd_pb_points_jacobian(const ffd_pbffd *pb, const ffd_pb_points *p, double *out,
                                  ffd_error *err);

/* ebf_curve.c: the deformer a curve carries (its samples, one level). */
ffd_pbffd *ffd_pb_curve_deformer(const ffd_pbffd_curve *curve);

#endif
