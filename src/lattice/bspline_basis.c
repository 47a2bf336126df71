/* lattice — uniform cubic B-spline basis and the rest map of a lattice axis
 * whose border control points have multiplicity three (Hsu et al. 1992, §2). */
#include "lattice/lattice.h"
#include "math/tolerance.h"

#include <math.h>

void ffd_bspline_basis(double t, double b[4], double d[4])
{
    double t2 = t * t, t3 = t2 * t, s = 1.0 - t;
    b[0] = s * s * s / 6.0;
    b[1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
    b[2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
    b[3] = t3 / 6.0;
    if (d) {
        d[0] = -0.5 * s * s;
        d[1] = 1.5 * t2 - 2.0 * t;
        d[2] = -1.5 * t2 + t + 0.5;
        d[3] = 0.5 * t2;
    }
}

/* Normalised rest coordinate of slot e: the tripled-border control values c_e. */
static double rest_value(uint32_t e, uint32_t res)
{
    return (double)ffd_bspline_tie(e, res) / (double)(res - 1);
}

/* Power-basis coefficients of segment sigma of the rest map: f = c0 + c1 t + c2 t^2 + c3 t^3. */
static void segment_cubic(uint32_t res, uint32_t sigma, double c[4])
{
    double p0 = rest_value(sigma, res), p1 = rest_value(sigma + 1, res);
    double p2 = rest_value(sigma + 2, res), p3 = rest_value(sigma + 3, res);
    /* uniform cubic B-spline basis matrix (1/6) [1 4 1 0; -3 0 3 0; 3 -6 3 0; -1 3 -3 1] */
    c[0] = (p0 + 4.0 * p1 + p2) / 6.0;
    c[1] = (-3.0 * p0 + 3.0 * p2) / 6.0;
    c[2] = (3.0 * p0 - 6.0 * p1 + 3.0 * p2) / 6.0;
    c[3] = (-p0 + 3.0 * p1 - 3.0 * p2 + p3) / 6.0;
}

/* Inversion tables. Only two segments of an axis need an iterative solve: the
 * inner segments 2..res-2 are linear and the border segments 0 and res are
 * c3 t^3 and 1 - k (1-t)^3 (closed form). Segments 1 and res-1 get a table
 * of INVERSE_INTERVALS cubic Hermite pieces of their inverse t(x), built from
 * exact samples of t and dt/dx. f' is bounded away from zero on those
 * segments (f'(t) >= p2/2 > 0), so the inverse is smooth; its curvature
 * scale is only ~5 times the segment width, hence the 128 pieces (the
 * Hermite error falls as h^4: ~2e-6 with 32 pieces, ~1e-8 with 128). One
 * Newton step then squares that error below the rounding level (residual
 * |f(S) - x| <= 3.4e-16 over res 2..1024), replacing a 3-4 step loop with a
 * single division. The two tables take 8 KiB per axis. */
#define INVERSE_INTERVALS 128

/* Layout of the array returned by ffd_bspline_rest_knots: */
#define KV_COEF(res) ((size_t)(res) + 2) /* 4 power-basis coefficients per segment */
#define KV_TABLE(res) (KV_COEF(res) + 4 * ((size_t)(res) + 1)) /* 2 tables, 4 per piece */
#define KV_TABLE_SIZE (4 * INVERSE_INTERVALS + 1) /* pieces, then INVERSE_INTERVALS / (f1 - f0) */

static double solve_segment_cubic_from(const double c[4], double x, double t);

/* Hermite pieces of the inverse of the cubic c on [f0, f1], in the variable
 * theta = u - k of u = (x - f0) / (f1 - f0) * INVERSE_INTERVALS, piece k. */
static void build_inverse_table(const double c[4], double f0, double f1, double *tab)
{
    double tk[INVERSE_INTERVALS + 1], mk[INVERSE_INTERVALS + 1];
    double du = (f1 - f0) / INVERSE_INTERVALS; /* x per unit of u */
    for (int k = 0; k <= INVERSE_INTERVALS; k++) {
        double x = f0 + (f1 - f0) * k / INVERSE_INTERVALS;
        double t = k == 0 ? 0.0 : k == INVERSE_INTERVALS ? 1.0 : solve_segment_cubic_from(c, x, 0.5);
        tk[k] = t;
        mk[k] = du / (c[1] + t * (2.0 * c[2] + 3.0 * t * c[3])); /* dt/du = (dx/du) / f'(t) */
    }
    for (int k = 0; k < INVERSE_INTERVALS; k++) {
        double p0 = tk[k], p1 = tk[k + 1], m0 = mk[k], m1 = mk[k + 1];
        double *a = tab + 4 * k;
        a[0] = p0;
        a[1] = m0;
        a[2] = 3.0 * (p1 - p0) - 2.0 * m0 - m1;
        a[3] = 2.0 * (p0 - p1) + m0 + m1;
    }
    tab[4 * INVERSE_INTERVALS] = INVERSE_INTERVALS / (f1 - f0); /* saves a division per point */
}

ffd_status ffd_bspline_rest_knots(uint32_t res, double **values)
{
    /* layout: f(sigma) for sigma = 0..res+1; 4 power-basis coefficients per segment;
     * the inverse tables of segment 1 and segment res-1 (the same one when res == 2) */
    size_t nseg = (size_t)res + 1;
    double *v = ffd_malloc_array(KV_TABLE(res) + 2 * KV_TABLE_SIZE, sizeof *v);
    if (!v)
        return FFD_ERR_NOMEM;
    for (uint32_t sigma = 0; sigma < nseg; sigma++) {
        double *c = v + KV_COEF(res) + 4 * (size_t)sigma;
        segment_cubic(res, sigma, c);
        v[sigma] = c[0];
    }
    v[res + 1] = 1.0;
    v[0] = 0.0;
    for (int side = 0; side < 2; side++) {
        uint32_t sigma = side == 0 ? 1 : res - 1;
        build_inverse_table(v + KV_COEF(res) + 4 * (size_t)sigma, v[sigma], v[sigma + 1],
                            v + KV_TABLE(res) + (size_t)side * KV_TABLE_SIZE);
    }
    *values = v;
    return FFD_OK;
}

double ffd_bspline_rest_map(uint32_t res, double S, double *dfdS)
{
    uint32_t nseg = res + 1;
    if (S < 0)
        S = 0;
    if (S > nseg)
        S = nseg;
    uint32_t sigma = ffd_bspline_segment(S, res);
    double t = S - sigma, c[4];
    segment_cubic(res, sigma, c);
    if (dfdS)
        *dfdS = c[1] + t * (2.0 * c[2] + 3.0 * t * c[3]);
    return c[0] + t * (c[1] + t * (c[2] + t * c[3]));
}

/* Root of the monotone cubic f(t) = x on [0,1]: Newton steps kept inside a
 * shrinking bracket (bisection when a step leaves it). */
static double solve_segment_cubic_from(const double c[4], double x, double t)
{
    double lo = 0.0, hi = 1.0;
    if (t < 0)
        t = 0;
    if (t > 1)
        t = 1;
    for (int it = 0; it < 100; it++) {
        double f = c[0] + t * (c[1] + t * (c[2] + t * c[3])) - x;
        double df = c[1] + t * (2.0 * c[2] + 3.0 * t * c[3]);
        if (f == 0.0)
            return t;
        if (f < 0)
            lo = t;
        else
            hi = t;
        double tn = (df > 0) ? t - f / df : 0.5 * (lo + hi);
        if (!(tn > lo && tn < hi))
            tn = 0.5 * (lo + hi);
        if (fabs(tn - t) <= FFD_TOL_CUBIC) {
            t = tn;
            break;
        }
        t = tn;
        if (hi - lo <= FFD_TOL_CUBIC)
            break;
    }
    return t;
}

double ffd_bspline_invert(uint32_t res, const double *kv, double x)
{
    if (x <= 0.0)
        return 0.0;
    if (x >= 1.0)
        return (double)res + 1.0;
    /* the border segments are f = c3 t^3 and f = 1 - k (1-t)^3: solved in closed form */
    if (x < kv[1])
        return cbrt(x / kv[KV_COEF(res) + 3]);
    if (x >= kv[res]) {
        double k = kv[KV_COEF(res) + 4 * (size_t)res + 3]; /* t^3 coefficient of 1 - k (1-t)^3 */
        return (double)res + 1.0 - cbrt((1.0 - x) / k);
    }
    /* inner segments 2..res-2 are linear: f(sigma + t) = (sigma - 1 + t) / (res - 1) */
    int side;
    if (x < kv[2])
        side = 0;
    else if (x >= kv[res - 1])
        side = 1;
    else {
        double S = x * (double)(res - 1) + 1.0;
        if (S < 2.0)
            S = 2.0;
        if (S > (double)(res - 1))
            S = (double)(res - 1);
        return S;
    }
    /* segments 1 and res-1: Hermite start from the table, then one Newton step */
    uint32_t sigma = side == 0 ? 1 : res - 1;
    const double *c = kv + KV_COEF(res) + 4 * (size_t)sigma;
    const double *tab = kv + KV_TABLE(res) + (size_t)side * KV_TABLE_SIZE;
    double u = (x - kv[sigma]) * tab[4 * INVERSE_INTERVALS];
    int k = (int)u;
    if (k > INVERSE_INTERVALS - 1)
        k = INVERSE_INTERVALS - 1;
    if (k < 0)
        k = 0;
    const double *a = tab + 4 * k;
    double th = u - k;
    double t = a[0] + th * (a[1] + th * (a[2] + th * a[3]));
    double f = c[0] + t * (c[1] + t * (c[2] + t * c[3])) - x;
    double df = c[1] + t * (2.0 * c[2] + 3.0 * t * c[3]);
    t -= f / df;
    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
    return (double)sigma + t;
}
