/*
 * ffd_kelvinlet.h — the Kelvinlet brushes method: its public API.
 *
 * Part of the public API of libffd: ffd.h includes this header (through
 * ffd_methods.h), so `#include <ffd.h>` gives it; ffd.h's conventions hold here.
 */
#ifndef FFD_KELVINLET_API_H
#define FFD_KELVINLET_API_H

#include "ffd.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ======================================================================
 * Kelvinlets: sculpting brushes from the regularised fundamental solutions
 * of linear elasticity (de Goes and James, "Regularized Kelvinlets:
 * Sculpting Brushes based on Fundamental Solutions of Elasticity",
 * SIGGRAPH 2017; docs/kelvinlet.md)
 * ====================================================================== */

/* A brush's load. Each is calibrated (§4, §5) so that what it asks for
 * happens at its center: */
typedef enum ffd_kelvinlet_type {
    FFD_KELVINLET_GRAB = 0, /* the center moves by displacement exactly (eq. 6) */
    FFD_KELVINLET_TWIST,    /* d u/d x at the center is angle [axis]x: a rotation by angle
                               about axis through the center, to first order (eq. 12, F skew) */
    FFD_KELVINLET_SCALE,    /* d u/d x at the center is (factor - 1) I (eq. 12, F = s I) */
    FFD_KELVINLET_PINCH     /* d u/d x at the center is the symmetric traceless pinch matrix
                               (eq. 12, F symmetric traceless) */
} ffd_kelvinlet_type;

typedef struct ffd_kelvinlet_brush {
    ffd_kelvinlet_type type;
    double center[3];
    double radius;          /* the regularisation radius epsilon, > 0 */
    double displacement[3]; /* grab */
    double axis[3];         /* twist: any non-zero length (normalised) */
    double angle;           /* twist, radians */
    double factor;          /* scale: > 0; 1 is no change */
    double pinch[3][3];     /* pinch: symmetric, trace 0 (row-major) */
} ffd_kelvinlet_brush;

/* How brushes combine (docs/kelvinlet.md "Combining brushes"). */
typedef enum ffd_kelvinlet_combine {
    FFD_KELVINLET_SUPERPOSE = 0, /* x' = x + sum_j u_j(x): every brush at the rest positions;
                                    linear in the grabs' displacements */
    FFD_KELVINLET_SEQUENCE       /* brush after brush in order, each from the positions the
                                    previous left, its field a velocity integrated over `steps`
                                    time steps (RK4; a grab's center moves along): near its
                                    center a twist rotates by angle, a scale by factor, a
                                    pinch P applies exp(P) (a stroke, §7) */
} ffd_kelvinlet_combine;

/* The multi-scale extrapolation (§6): faster falloff by combining radii
 * epsilon, ratio epsilon, ratio^2 epsilon. */
typedef enum ffd_kelvinlet_multiscale {
    FFD_KELVINLET_SINGLE = 0, /* one radius: u falls off as 1/r */
    FFD_KELVINLET_BISCALE,    /* u_eps - u_(ratio eps): 1/r^3 */
    FFD_KELVINLET_TRISCALE    /* three radii, weights cancelling the 1/r and 1/r^3 terms: 1/r^5 */
} ffd_kelvinlet_multiscale;

typedef struct ffd_kelvinlet_options {
    double poisson_ratio;             /* nu in [0, 0.5] used as given (0 is nu = 0); 0.5 is the
                                         incompressible limit, which a scale brush cannot have */
    ffd_kelvinlet_combine combine;
    uint32_t steps;                   /* sub-steps of each brush in a sequence (0: 1); 1 when
                                         superposed */
    ffd_kelvinlet_multiscale multiscale;
    double ratio;                     /* between successive radii of the multi-scale (0: 2);
                                         > 1 */
} ffd_kelvinlet_options;

typedef struct ffd_kelvinlet ffd_kelvinlet;

/* Creates the brushes (count, copied; 0 is the identity). The stiffness mu
 * is 1: it cancels under the calibration. FFD_ERR_INVALID naming the brush
 * and its key (a radius <= 0, a zero twist axis, a factor <= 0, a pinch
 * that is not symmetric and traceless, a scale brush at nu = 0.5, nu
 * outside [0, 0.5], ratio <= 1, steps > 1 when superposed),
 * FFD_ERR_NONFINITE, FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_kelvinlet_create(const ffd_kelvinlet_brush *brushes, size_t count,
                                        const ffd_kelvinlet_options *options,
                                        ffd_kelvinlet **out, ffd_error *err);
FFD_API void ffd_kelvinlet_destroy(ffd_kelvinlet *k);
FFD_API size_t ffd_kelvinlet_brush_count(const ffd_kelvinlet *k);
/* Brush i (borrowed until the next change), NULL past the end. */
FFD_API const ffd_kelvinlet_brush *ffd_kelvinlet_brush_at(const ffd_kelvinlet *k, size_t i);
FFD_API void ffd_kelvinlet_get_options(const ffd_kelvinlet *k, ffd_kelvinlet_options *out);
/* Replaces brush i (checked as by create); on error nothing changes.
 * FFD_ERR_RANGE, and create's errors. */
FFD_API ffd_status ffd_kelvinlet_set_brush(ffd_kelvinlet *k, size_t i,
                                           const ffd_kelvinlet_brush *brush, ffd_error *err);

/* Deformed positions of n points given at rest (n by 3 each; out may be
 * points). A point no brush moves keeps its bits. FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_kelvinlet_eval(const ffd_kelvinlet *k, const double *points, size_t n,
                                      double *out, ffd_error *err);
/* d(x')/d(x) at the points, n by 9 row-major (supplemental eq. 1-2; a
 * sequence multiplies its steps' Jacobians). */
FFD_API ffd_status ffd_kelvinlet_jacobian(const ffd_kelvinlet *k, const double *points, size_t n,
                                          double *out, ffd_error *err);

/* The grab brushes' sensitivities (superposed brushes only): the deformed
 * points are x' = x + sum_g K_g(x) d_g + (the affine brushes), with d_g the
 * displacement of the g-th grab (in brush order) and K_g(x) a symmetric 3
 * by 3 matrix (eq. 6 divided by the calibration), so dX/dD is made of 3 by
 * 3 blocks, not the W (x) I3 of ffd_deformer_sensitivities.
 * blocks: n by grabs by 9, row-major blocks K_g(x_i). FFD_ERR_UNSUPPORTED
 * for a sequence (not linear in the displacements). */
FFD_API size_t ffd_kelvinlet_grab_count(const ffd_kelvinlet *k);
FFD_API ffd_status ffd_kelvinlet_grab_blocks(const ffd_kelvinlet *k, const double *points,
                                             size_t n, double *blocks, ffd_error *err);

/* --- Behind the generic interfaces (ffd.h) ---
 * ffd_deformer_handle(d, "kelvinlet") is the ffd_kelvinlet. The controls
 * are the grab brushes' handles, center + displacement, in brush order;
 * setting one sets that grab's displacement. Reset makes every brush inert
 * (grab displacement 0, twist angle 0, scale factor 1, pinch 0), centers
 * and radii kept. There is no ffd_linear_map, and ffd_deformer_sensitivities
 * and its products are FFD_ERR_UNSUPPORTED: a grab's response is a full 3 by
 * 3 matrix (ffd_kelvinlet_grab_blocks gives it). A rig's "constraints" are
 * solved over the grabs' displacements (minimum-norm least squares with
 * those blocks, superposed brushes only). In a rig report: control_points
 * are the grab handles (control_label "Kelvinlet grab handles"), no grid,
 * no control mesh; details hold "brushes", "grabs" and "combine"; every
 * vertex is moved by some brush (outside_count 0). */

#ifdef __cplusplus
}
#endif
#endif /* FFD_KELVINLET_API_H */
