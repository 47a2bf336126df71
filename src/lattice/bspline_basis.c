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

/* Samples of the inverse of each segment's cubic, to start Newton close to the root. */
#define INVERSE_SAMPLES 32

static double solve_segment_cubic_from(const double c[4], double x, double t);

ffd_status ffd_bspline_rest_knots(uint32_t res, double **values)
{
    /* layout: f(sigma) for sigma = 0..res+1; 4 power-basis coefficients per segment;
     * INVERSE_SAMPLES+1 samples of t(x) per segment at evenly spaced x */
    size_t nseg = (size_t)res + 1;
    double *v = ffd_malloc_array(res + 2 + nseg * (4 + INVERSE_SAMPLES + 1), sizeof *v);
    if (!v)
        return FFD_ERR_NOMEM;
    for (uint32_t sigma = 0; sigma <= res; sigma++) {
        double *c = v + res + 2 + 4 * (size_t)sigma;
        segment_cubic(res, sigma, c);
        v[sigma] = c[0];
    }
    v[res + 1] = 1.0;
    v[0] = 0.0;
    for (uint32_t sigma = 0; sigma <= res; sigma++) {
        const double *c = v + res + 2 + 4 * (size_t)sigma;
        double *tab = v + res + 2 + 4 * nseg + (INVERSE_SAMPLES + 1) * (size_t)sigma;
        double f0 = v[sigma], f1 = v[sigma + 1];
        for (int k = 0; k <= INVERSE_SAMPLES; k++) {
            double x = f0 + (f1 - f0) * k / INVERSE_SAMPLES;
            tab[k] = k == 0 ? 0.0 : k == INVERSE_SAMPLES ? 1.0 : solve_segment_cubic_from(c, x, 0.5);
        }
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
    uint32_t sigma = S >= nseg ? nseg - 1 : (uint32_t)S;
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
    uint32_t nseg = res + 1;
    if (x <= 0.0)
        return 0.0;
    if (x >= 1.0)
        return (double)nseg;
    /* inner segments 2..res-2 are linear: f(sigma + t) = (sigma - 1 + t) / (res - 1) */
    if (res >= 4 && x >= kv[2] && x <= kv[res - 1]) {
        double S = x * (double)(res - 1) + 1.0;
        if (S < 2.0)
            S = 2.0;
        if (S > (double)(res - 1))
            S = (double)(res - 1);
        return S;
    }
    /* outer segments: find the segment, then solve its cubic */
    uint32_t sigma = x < kv[2] ? 0 : (x < kv[res - 1] ? 1 : res - 1);
    while (sigma + 1 < nseg && x >= kv[sigma + 1])
        sigma++;
    const double *c = kv + res + 2 + 4 * (size_t)sigma;
    /* the border segments are f = c3 t^3 and f = 1 - k (1-t)^3: solved in closed form */
    if (sigma == 0)
        return cbrt(x / c[3]);
    if (sigma == res) {
        double k = c[3]; /* the t^3 coefficient of 1 - k (1-t)^3 is k */
        return (double)sigma + 1.0 - cbrt((1.0 - x) / k);
    }
    /* other outer segments: Newton from the sampled inverse */
    const double *tab = kv + res + 2 + 4 * (size_t)nseg + (INVERSE_SAMPLES + 1) * (size_t)sigma;
    double u = (x - kv[sigma]) / (kv[sigma + 1] - kv[sigma]) * INVERSE_SAMPLES;
    int k = (int)u;
    if (k >= INVERSE_SAMPLES)
        k = INVERSE_SAMPLES - 1;
    if (k < 0)
        k = 0;
    double t0 = tab[k] + (u - k) * (tab[k + 1] - tab[k]);
    return (double)sigma + solve_segment_cubic_from(c, x, t0);
}
