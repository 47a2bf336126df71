/*
 * ffd_idw.h — inverse-distance weighting (PyGeM's IDW): its public API.
 *
 * Part of the public API of libffd: ffd.h includes this header (through
 * ffd_methods.h), so `#include <ffd.h>` gives it; ffd.h's conventions hold here.
 */
#ifndef FFD_IDW_API_H
#define FFD_IDW_API_H

#include "ffd.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ======================================================================
 * Inverse-distance weighting (Shepard 1968; PyGeM's pygem/idw.py)
 * ====================================================================== */

/* x' = x + sum_j a_j(x) (p_j - c_j),  a_j = w_j(x) / sum_k w_k(x), with
 *   FFD_IDW_PYGEM    w_j = 1 / |x - c_j|_p   (the Minkowski p-norm: what
 *                    PyGeM's IDW computes, cdist with np.linalg.norm(ord=p))
 *   FFD_IDW_SHEPARD  w_j = 1 / |x - c_j|_2^p (Shepard's weights, as PyGeM's
 *                    docstring writes them)
 * A point at a control point (distance exactly 0) takes that control point's
 * displacement (the mean of those it sits on). Linear in the control points:
 * the rows a_j are the linear map (direct manipulation); a rest IDW gives
 * every point back bitwise, and a translation of every control point moves
 * every point by it. */
typedef enum ffd_idw_weighting { FFD_IDW_PYGEM = 0, FFD_IDW_SHEPARD } ffd_idw_weighting;

/* Zero means default. */
typedef struct ffd_idw_options {
    double power;                /* p > 0; 0: 2 (PyGeM's default) */
    ffd_idw_weighting weighting; /* default FFD_IDW_PYGEM */
} ffd_idw_options;

typedef struct ffd_idw ffd_idw;

/* An IDW at rest on control_points (count >= 1 by 3, copied).
 * FFD_ERR_INVALID: two control points coincide (named), a power <= 0 or not
 * finite; FFD_ERR_NONFINITE; FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_idw_create(const double *control_points, size_t count,
                                  const ffd_idw_options *options, ffd_idw **out, ffd_error *err);
FFD_API void ffd_idw_destroy(ffd_idw *idw);
FFD_API size_t ffd_idw_control_count(const ffd_idw *idw);
/* Current and rest control points, count by 3; borrowed. */
FFD_API const double *ffd_idw_control_points(const ffd_idw *idw);
FFD_API const double *ffd_idw_rest_points(const ffd_idw *idw);
/* Moves every control point (count by 3). FFD_ERR_NONFINITE; on error
 * nothing changed. */
FFD_API ffd_status ffd_idw_set_control_points(ffd_idw *idw, const double *points, ffd_error *err);
/* x' of n points (n by 3; out n by 3). */
FFD_API ffd_status ffd_idw_eval(const ffd_idw *idw, const double *points, size_t n, double *out,
                                ffd_error *err);
/* d(x')/d(x) at n points, n by 9 row-major; I at a control point, where
 * the map has a cone (not differentiable), and exactly I at rest. */
FFD_API ffd_status ffd_idw_jacobian(const ffd_idw *idw, const double *points, size_t n,
                                    double *out, ffd_error *err);
/* The normalised weights a_j(x) at one point: count values. */
FFD_API void ffd_idw_weights(const ffd_idw *idw, const double x[3], double *weights);

/* --- Behind the generic interfaces (ffd.h) ---
 * ffd_deformer_handle(d, "idw") is the ffd_idw. In a rig report: the
 * control points, moved, in the rig's order; no grid, edges or control
 * mesh; outside_count 0; details {"power", "weighting"}. */

#ifdef __cplusplus
}
#endif
#endif /* FFD_IDW_API_H */
