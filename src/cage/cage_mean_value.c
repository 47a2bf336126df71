/* cage_mean_value — mean value coordinates for closed triangular meshes
 * (Ju, Schaefer & Warren 2005, "Mean value coordinates for closed
 * triangular meshes", the robust pseudo-code of Fig. 4): each triangle's
 * projection on the unit sphere around x gives its vertices' share of the
 * mean value integral, in closed form from the triangle's spherical edge
 * lengths theta_i; the sum normalised is w(x). Points on a vertex, an edge
 * or a face get the cage's linear interpolation there (the coordinates are
 * continuous across the cage and interpolate it). Defined everywhere, so
 * points outside the cage are deformed by the same formula. */
#include "cage/cage.h"
#include "math/tolerance.h"

#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

int ffd_cage_mean_value(const ffd_cage *cage, const double x[3], double *w, double *scratch)
{
    const size_t nv = cage->nv;
    const double *p = cage->rest;
    double *d = scratch, *u = scratch + nv; /* d_j = |p_j - x|, u_j = (p_j - x) / d_j */
    memset(w, 0, nv * sizeof *w);
    for (size_t j = 0; j < nv; j++) {
        double v[3] = {p[3 * j] - x[0], p[3 * j + 1] - x[1], p[3 * j + 2] - x[2]};
        d[j] = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if (d[j] < FFD_TOL_CAGE_VERTEX * cage->diag) { /* x on vertex j */
            w[j] = 1.0;
            return 1;
        }
        for (int a = 0; a < 3; a++)
            u[3 * j + a] = v[a] / d[j];
    }
    for (size_t t = 0; t < cage->nt; t++) {
        const uint32_t *ix = cage->tri + 3 * t;
        double theta[3], c[3], s[3], sin_theta[3];
        for (int i = 0; i < 3; i++) {
            const double *a = u + 3 * (size_t)ix[(i + 1) % 3], *b = u + 3 * (size_t)ix[(i + 2) % 3];
            double l = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                            (a[2] - b[2]) * (a[2] - b[2]));
            theta[i] = 2.0 * asin(fmin(1.0, 0.5 * l)); /* the arc opposite vertex i */
            sin_theta[i] = sin(theta[i]);
        }
        double h = 0.5 * (theta[0] + theta[1] + theta[2]);
        if (M_PI - h < FFD_TOL_CAGE_FACE) {
            /* x lies on t (its face or an edge): 2D barycentric coordinates */
            memset(w, 0, nv * sizeof *w);
            double sum = 0;
            for (int i = 0; i < 3; i++) {
                double wi = sin_theta[i] * d[ix[(i + 2) % 3]] * d[ix[(i + 1) % 3]];
                w[ix[i]] += wi;
                sum += wi;
            }
            for (int i = 0; i < 3; i++)
                w[ix[i]] /= sum;
            return 1;
        }
        /* x on the line through an edge: the spherical triangle is a zero-area
         * arc (x is in t's plane, outside t), and t adds nothing */
        if (sin_theta[0] <= 0 || sin_theta[1] <= 0 || sin_theta[2] <= 0)
            continue;
        const double *u0 = u + 3 * (size_t)ix[0], *u1 = u + 3 * (size_t)ix[1],
                     *u2 = u + 3 * (size_t)ix[2];
        double det = u0[0] * (u1[1] * u2[2] - u1[2] * u2[1]) -
                     u0[1] * (u1[0] * u2[2] - u1[2] * u2[0]) +
                     u0[2] * (u1[0] * u2[1] - u1[1] * u2[0]);
        int in_plane = 0;
        for (int i = 0; i < 3; i++) {
            double adjacent = sin_theta[(i + 1) % 3] * sin_theta[(i + 2) % 3];
            c[i] = 2.0 * sin(h) * sin(h - theta[i]) / adjacent - 1.0;
            /* Fig. 4's s_i = sign(det) sqrt(1 - c_i^2) is the sine of the
             * spherical angle at u_i; det[u0 u1 u2] = sin(theta_{i+1})
             * sin(theta_{i-1}) sin(phi_i) gives it with its sign and without
             * the cancellation of 1 - c_i^2 when x nears t's plane */
            s[i] = det / adjacent;
            in_plane |= fabs(s[i]) <= FFD_TOL_CAGE_PLANE;
        }
        if (in_plane) /* x in t's plane, outside t */
            continue;
        for (int i = 0; i < 3; i++) {
            int next = (i + 1) % 3, prev = (i + 2) % 3;
            w[ix[i]] += (theta[i] - c[next] * theta[prev] - c[prev] * theta[next]) /
                        (d[ix[i]] * sin_theta[next] * s[prev]);
        }
    }
    double sum = 0;
    for (size_t j = 0; j < nv; j++)
        sum += w[j];
    for (size_t j = 0; j < nv; j++)
        w[j] /= sum;
    return 0;
}
