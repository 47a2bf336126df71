/* rbf — RBF morphing with PyGeM's kernels and linear polynomial part
 * (include/ffd_rbf_morph.h): the kernels (rbf_kernel.c) and the factored system,
 * evaluation, Jacobian, cardinal functions and sensitivity products
 * (rbf_map.c). */
#ifndef FFD_RBF_H
#define FFD_RBF_H

#include "core/core.h"
#include "rig/rig_points.h"

struct ffd_rbf_morph {
    size_t count;            /* N control points */
    ffd_rbf_kernel kernel;
    double radius;
    unsigned power;
    double *rest;            /* N by 3: the control points c_j */
    double *points;          /* N by 3: where they are now, p_j */
    double *factor;          /* (N+4)^2: dsytrf factor of the system (include/ffd_rbf_morph.h) */
    int *ipiv;
    double *coef;            /* (N+4) by 3 column-major: [w; w_c; W_Q] for D = P - C */
    int moved;               /* 0: P == C bitwise, coef is zero and x' = x exactly */
    double rcond;            /* dsycon's estimate (dense), CHOLMOD's of Phi (sparse) */
    struct rbf_grid *grid;   /* WENDLAND_C2: the control points by cell (rbf_sparse.c) */
    struct rbf_sparse *sparse; /* the sparse factor instead of factor/ipiv (rbf_sparse.c) */
};

/* The control points bucketed in cubic cells of side >= the radius: the
 * points within the radius of x lie in the 27 cells around x's cell. */
typedef struct rbf_grid {
    double origin[3], cell;
    size_t dim[3];
    size_t *start;    /* dim[0]*dim[1]*dim[2] + 1 */
    uint32_t *points; /* control ids, by cell, ascending within a cell */
} rbf_grid;

/* The cell range [lo, hi] (inclusive, per axis) around x; 0 when empty. */
int ffd_rbf_grid_range(const rbf_grid *g, const double x[3], size_t lo[3], size_t hi[3]);
ffd_status ffd_rbf_grid_create(ffd_rbf_morph *rbf, ffd_error *err);
void ffd_rbf_grid_destroy(rbf_grid *g);
/* The sparse factorisation (rbf->sparse, rbf->rcond); FFD_ERR_INVALID when
 * Phi is not positive definite or S is singular. */
ffd_status ffd_rbf_sparse_factor(ffd_rbf_morph *rbf, ffd_error *err);
void ffd_rbf_sparse_destroy(struct rbf_sparse *s);
/* Solves the system H X = B for nrhs columns (B (N+4) by nrhs
 * column-major, overwritten by X) with the sparse factor. */
ffd_status ffd_rbf_sparse_solve(const ffd_rbf_morph *rbf, size_t nrhs, double *B, ffd_error *err);

/* phi(x) and, when dphi != NULL, dphi/dx (0 at x = 0), PyGeM's formulas. */
double ffd_rbf_phi(ffd_rbf_kernel kernel, double radius, unsigned power, double x, double *dphi);

/* FFD_ERR_INVALID naming the first two of the n points that coincide
 * ("METHOD: control_points[i] and control_points[j] coincide"). */
ffd_status ffd_rbf_check_distinct(const double *p, size_t n, const char *method, ffd_error *err);

/* The sensitivity products at n points: out (n by 3) = W v for v (N by
 * 3), and out (N by 3) = W^T w for w (n by 3), W = dX/dP. */
ffd_status ffd_rbf_morph_product(const ffd_rbf_morph *rbf, const double *points, size_t n, const double *v,
                           double *out, ffd_error *err);
ffd_status ffd_rbf_morph_transpose_product(const ffd_rbf_morph *rbf, const double *points, size_t n,
                                     const double *w, double *out, ffd_error *err);

/* The linear map of rows->points (n by 3) under the RBF rows->morph: dense
 * rows, the cardinal functions a_j(x) over the N control points (no tie). */
void ffd_rbf_morph_linear_map(const ffd_point_rows *rows, size_t n, ffd_linear_map *map);

#endif
