/* cage_hat — the cage's piecewise-linear hat functions, evaluated at the
 * point of the cage nearest to x: the boundary values of harmonic
 * coordinates (Joshi et al. 2007, §3: the coordinates equal the cage's
 * linear interpolation on the cage) and the weights of a "clamp" point
 * outside the cage. */
#include "cage/cage.h"

#include <math.h>
#include <string.h>

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The point of triangle abc nearest to p as barycentric coordinates
 * (Voronoi regions of the vertices, edges and face, in that order). */
static void nearest_on_triangle(const double p[3], const double a[3], const double b[3],
                                const double c[3], double bary[3])
{
    double ab[3], ac[3], ap[3], bp[3], cp[3];
    for (int k = 0; k < 3; k++) {
        ab[k] = b[k] - a[k];
        ac[k] = c[k] - a[k];
        ap[k] = p[k] - a[k];
        bp[k] = p[k] - b[k];
        cp[k] = p[k] - c[k];
    }
    double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) {
        bary[0] = 1, bary[1] = 0, bary[2] = 0;
        return;
    }
    double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) {
        bary[0] = 0, bary[1] = 1, bary[2] = 0;
        return;
    }
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        double v = d1 / (d1 - d3);
        bary[0] = 1 - v, bary[1] = v, bary[2] = 0;
        return;
    }
    double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) {
        bary[0] = 0, bary[1] = 0, bary[2] = 1;
        return;
    }
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        double t = d2 / (d2 - d6);
        bary[0] = 1 - t, bary[1] = 0, bary[2] = t;
        return;
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
        double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        bary[0] = 0, bary[1] = 1 - t, bary[2] = t;
        return;
    }
    double den = 1.0 / (va + vb + vc);
    bary[1] = vb * den;
    bary[2] = vc * den;
    bary[0] = 1 - bary[1] - bary[2];
}

double ffd_cage_hat(const ffd_cage *cage, const double x[3], double *w)
{
    double best = INFINITY, best_bary[3] = {1, 0, 0};
    size_t best_t = 0;
    for (size_t t = 0; t < cage->nt; t++) {
        const uint32_t *ix = cage->tri + 3 * t;
        const double *a = cage->rest + 3 * (size_t)ix[0], *b = cage->rest + 3 * (size_t)ix[1],
                     *c = cage->rest + 3 * (size_t)ix[2];
        double bary[3], q[3], d2 = 0;
        nearest_on_triangle(x, a, b, c, bary);
        for (int k = 0; k < 3; k++) {
            q[k] = bary[0] * a[k] + bary[1] * b[k] + bary[2] * c[k] - x[k];
            d2 += q[k] * q[k];
        }
        if (d2 < best) {
            best = d2;
            best_t = t;
            memcpy(best_bary, bary, sizeof bary);
        }
    }
    memset(w, 0, cage->nv * sizeof *w);
    for (int k = 0; k < 3; k++)
        w[cage->tri[3 * best_t + k]] += best_bary[k];
    return best;
}
