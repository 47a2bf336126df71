/*
 * ffd_rbf_morph.h — RBF morphing (PyGeM's RBF): its public API.
 *
 * Part of the public API of libffd: ffd.h includes this header (through
 * ffd_methods.h), so `#include <ffd.h>` gives it; ffd.h's conventions hold here.
 */
#ifndef FFD_RBF_API_H
#define FFD_RBF_API_H

#include "ffd.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ======================================================================
 * RBF morphing (Buhmann 2003; Forti & Rozza 2014, as PyGeM's pygem/rbf.py)
 * ====================================================================== */

/* The kernels phi(x) of PyGeM's RBFFactory, with a = x / r (r the radius,
 * k the power):
 *   GAUSSIAN        gaussian_spline                        exp(-x^2 / r^2)
 *   MULTIQUADRIC    multi_quadratic_biharmonic_spline      sqrt(x^2 + r^2)
 *   INV_MULTIQUADRIC inv_multi_quadratic_biharmonic_spline 1 / sqrt(x^2 + r^2)
 *   THIN_PLATE      thin_plate_spline                      a^k ln a  (0 at a = 0)
 *   WENDLAND_C2     beckert_wendland_c2_basis              (1 - a)_+^4 (4 a + 1)
 *   POLYHARMONIC    polyharmonic_spline                    a^k for odd k; for even
 *                   k: a^(k-1) ln(a^a) when a < 1, a^k ln a when a >= 1 */
typedef enum ffd_rbf_kernel {
    FFD_RBF_GAUSSIAN = 0,
    FFD_RBF_MULTIQUADRIC,
    FFD_RBF_INV_MULTIQUADRIC,
    FFD_RBF_THIN_PLATE,
    FFD_RBF_WENDLAND_C2,
    FFD_RBF_POLYHARMONIC,
    FFD_RBF_KERNEL_COUNT
} ffd_rbf_kernel;

/* PyGeM's name of a kernel ("gaussian_spline", ...); NULL out of range. */
FFD_API const char *ffd_rbf_kernel_name(ffd_rbf_kernel kernel);

/* The map (PyGeM's RBF.__call__, written in displacement form):
 *   x' = x + sum_j phi(|x - c_j|) w_j + w_c + W_Q x
 * where [w; w_c; W_Q] solves the (N+4) x (N+4) system
 *   [ Phi  1  C ] [ w   ]   [ D ]
 *   [ 1^T  0  0 ] [ w_c ] = [ 0 ]     Phi_ij = phi(|c_i - c_j|),
 *   [ C^T  0  0 ] [ W_Q ]   [ 0 ]     D = moved - rest control points,
 * which is PyGeM's system with the deformed control points as right-hand side
 * minus the same system for the rest control points (the polynomial part
 * reproduces the identity). The system is factored once (LAPACK dsytrf) when
 * the RBF is created; every change of the control points is one solve. So
 * x' = x + sum_j a_j(x) (p_j - c_j): a_j are the cardinal functions, the RBF
 * is linear in its control points (ffd_linear_map, direct manipulation), a
 * rest RBF gives every point back bitwise, and an affine motion of the
 * control points moves every point by the same affine map. */
typedef struct ffd_rbf_morph ffd_rbf_morph;

/* How the system is solved. DENSE: LAPACK's dsytrf on the (N+4)^2 matrix.
 * SPARSE (WENDLAND_C2 only, whose Phi is sparse and positive definite):
 * CHOLMOD's Cholesky factor of Phi and the 4 x 4 Schur complement of the
 * polynomial block, S = P^T Phi^-1 P (P = [1 C]); the same map to rounding.
 * AUTO: SPARSE for WENDLAND_C2 with more than 2000 control points. */
typedef enum ffd_rbf_solver { FFD_RBF_SOLVER_AUTO = 0, FFD_RBF_SOLVER_DENSE, FFD_RBF_SOLVER_SPARSE } ffd_rbf_solver;

/* Zero means default for every field. */
typedef struct ffd_rbf_options {
    ffd_rbf_kernel kernel; /* default FFD_RBF_GAUSSIAN (PyGeM's default) */
    double radius;         /* r > 0; 0: PyGeM's default 0.5 */
    unsigned power;        /* k of THIN_PLATE and POLYHARMONIC; 0: 2 */
    ffd_rbf_solver solver; /* default AUTO */
} ffd_rbf_options;

/* An RBF at rest on control_points (count by 3, copied; count >= 1).
 * FFD_ERR_INVALID: two control points coincide (named), a radius <= 0 or not
 * finite, the sparse solver for a kernel other than WENDLAND_C2, or the
 * system is singular (its reciprocal condition number below 1e-15, e.g.
 * every control point in one plane: the linear part needs four affinely
 * independent points); FFD_ERR_NONFINITE; FFD_ERR_NOMEM. With WENDLAND_C2
 * the evaluation visits only the control points within the radius (a grid
 * of cells of the radius's size). */
FFD_API ffd_status ffd_rbf_morph_create(const double *control_points, size_t count,
                                  const ffd_rbf_options *options, ffd_rbf_morph **out, ffd_error *err);
FFD_API void ffd_rbf_morph_destroy(ffd_rbf_morph *rbf);
FFD_API size_t ffd_rbf_morph_control_count(const ffd_rbf_morph *rbf);
/* The current (moved) control points, count by 3; borrowed. */
FFD_API const double *ffd_rbf_morph_control_points(const ffd_rbf_morph *rbf);
/* The rest control points, count by 3; borrowed. */
FFD_API const double *ffd_rbf_morph_rest_points(const ffd_rbf_morph *rbf);
/* Moves every control point to points (count by 3): one solve with the
 * factor. FFD_ERR_NONFINITE; on error nothing changed. */
FFD_API ffd_status ffd_rbf_morph_set_control_points(ffd_rbf_morph *rbf, const double *points, ffd_error *err);
/* x' of n points (n by 3; out n by 3, may not alias points). */
FFD_API ffd_status ffd_rbf_morph_eval(const ffd_rbf_morph *rbf, const double *points, size_t n, double *out,
                                ffd_error *err);
/* d(x')/d(x) at n points, n by 9 row-major (exactly I at rest). */
FFD_API ffd_status ffd_rbf_morph_jacobian(const ffd_rbf_morph *rbf, const double *points, size_t n,
                                    double *out, ffd_error *err);
/* The cardinal functions a_j(x) at one point: weights receives count
 * values and needs count + 4 doubles of room (the solve's scratch). */
FFD_API void ffd_rbf_morph_cardinal(const ffd_rbf_morph *rbf, const double x[3], double *weights);

/* --- Behind the generic interfaces (ffd.h) ---
 * ffd_deformer_handle(d, "rbf") is the ffd_rbf_morph. In a rig report: the
 * control points, moved, in the rig's order; no grid, edges or control
 * mesh; outside_count 0 (every point moves); details {"kernel", "radius",
 * "power", "rcond"} (rcond: LAPACK's estimate of the system's reciprocal
 * condition number). */

#ifdef __cplusplus
}
#endif
#endif /* FFD_RBF_API_H */
