/* rbf — RBF morphing with PyGeM's kernels and linear polynomial part
 * (include/ffd_rbf_morph.h): the kernels (rbf_kernel.c) and the factored system,
 * evaluation, Jacobian, cardinal functions and sensitivity products
 * (rbf_map.c). */
#ifndef FFD_RBF_H
#define FFD_RBF_H

#include "core/core.h"

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
    double rcond;            /* dsycon's estimate for the system */
};

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

/* The linear map of points (borrowed, n by 3) under rbf: dense rows, the
 * cardinal functions a_j(x) over the N control points (no tie); rows must
 * outlive map. */
typedef struct ffd_rbf_morph_rows {
    const ffd_rbf_morph *rbf;
    const double *points;
} ffd_rbf_morph_rows;
void ffd_rbf_morph_linear_map(const ffd_rbf_morph_rows *rows, size_t n, ffd_linear_map *map);

#endif
