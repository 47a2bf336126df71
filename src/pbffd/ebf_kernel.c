/* pbffd — one ellipsoidal basis function (PB-FFD eq. 1-3): its frame, the
 * parameters u = (alpha, beta, gamma) of a point, the ROI-normalised distance
 * rho and the windowed kernel phi with its gradient. */
#include "pbffd/pbffd.h"
#include "math/tolerance.h"

#include <math.h>
#include <string.h>

#define PI 3.14159265358979323846

static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

int ffd_ebf_frame_degenerate(const double frame[3][3])
{
    double bc[3];
    cross(frame[1], frame[2], bc);
    double det = dot(frame[0], bc);
    double la = sqrt(dot(frame[0], frame[0])), lb = sqrt(dot(frame[1], frame[1])),
           lc = sqrt(dot(frame[2], frame[2]));
    double scale = la * lb * lc;
    return !(scale > 0) || !(fabs(det) > FFD_TOL_VOLUME * scale) || !isfinite(det);
}

ffd_status ffd_ebf_check(const ffd_ebf *e, const char *what, size_t index, ffd_error *err)
{
    for (int c = 0; c < 3; c++)
        if (!isfinite(e->center[c]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "%s[%zu]: center is not finite", what, index);
    for (int a = 0; a < 3; a++)
        for (int c = 0; c < 3; c++)
            if (!isfinite(e->frame[a][c]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "%s[%zu]: frame is not finite", what,
                                index);
    for (int a = 0; a < 3; a++) {
        if (!isfinite(e->radius[a]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "%s[%zu]: radius is not finite", what, index);
        if (!(e->radius[a] > 0))
            return ffd_fail(err, FFD_ERR_INVALID, "%s[%zu]: radius %g: expected > 0", what, index,
                            e->radius[a]);
    }
    /* Products of three lengths (the frame's determinant) must stay in range. */
    for (int c = 0; c < 3; c++)
        if (fabs(e->center[c]) > FFD_PB_MAX_COORD)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "%s[%zu]: center %g is beyond the supported range (|x| <= 1e100)",
                            what, index, e->center[c]);
    for (int a = 0; a < 3; a++) {
        double len = sqrt(e->frame[a][0] * e->frame[a][0] + e->frame[a][1] * e->frame[a][1] +
                          e->frame[a][2] * e->frame[a][2]);
        if (len > FFD_PB_MAX_COORD || (len > 0 && len < FFD_PB_MIN_LENGTH) ||
            e->radius[a] > FFD_PB_MAX_COORD || e->radius[a] < FFD_PB_MIN_LENGTH)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "%s[%zu]: frame axis %d (length %g) or radius %g is beyond the "
                            "supported range [1e-100, 1e100]",
                            what, index, a, len, e->radius[a]);
    }
    if (ffd_ebf_frame_degenerate(e->frame))
        return ffd_fail(err, FFD_ERR_INVALID, "%s[%zu]: degenerate frame (parallel axes)", what,
                        index);
    return FFD_OK;
}

void ffd_ebf_kernel_init(const ffd_ebf *e, double weight, ffd_ebf_kernel *k)
{
    memcpy(k->center, e->center, sizeof k->center);
    k->weight = weight;
    /* the rows of F^-1, F = [a b c] as columns: cofactors over the determinant */
    const double(*f)[3] = e->frame;
    double bc[3], ca[3], ab[3];
    cross(f[1], f[2], bc);
    cross(f[2], f[0], ca);
    cross(f[0], f[1], ab);
    double inv_det = 1.0 / dot(f[0], bc);
    for (int c = 0; c < 3; c++) {
        k->dual[0][c] = bc[c] * inv_det;
        k->dual[1][c] = ca[c] * inv_det;
        k->dual[2][c] = ab[c] * inv_det;
    }
    /* rho^2 = sum_k (u_k |axis_k| / radius_k)^2 (eq. 1: R S^-2 R^T in the frame's
     * own, possibly oblique, coordinates); the ROI is c + sum t_k r_k axis_k/|axis_k|,
     * |t| <= 1, whose box has half-extent sqrt(sum_k (r_k axis_k[d]/|axis_k|)^2) */
    double half[3] = {0, 0, 0};
    for (int a = 0; a < 3; a++) {
        double len = sqrt(dot(f[a], f[a]));
        double s = len / e->radius[a];
        for (int c = 0; c < 3; c++) {
            k->q[a][c] = k->dual[a][c] * s;
            double g = f[a][c] / len * e->radius[a];
            half[c] += g * g;
        }
    }
    for (int c = 0; c < 3; c++) {
        double h = sqrt(half[c]);
        k->lo[c] = e->center[c] - h;
        k->hi[c] = e->center[c] + h;
    }
}

double ffd_ebf_phi(const ffd_ebf_kernel *k, double inv2s2, const double x[3], double u[3],
                   double grad[3])
{
    double v[3] = {x[0] - k->center[0], x[1] - k->center[1], x[2] - k->center[2]};
    double r[3];
    for (int a = 0; a < 3; a++)
        r[a] = k->q[a][0] * v[0] + k->q[a][1] * v[1] + k->q[a][2] * v[2];
    double rho2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    if (u)
        for (int a = 0; a < 3; a++)
            u[a] = k->dual[a][0] * v[0] + k->dual[a][1] * v[1] + k->dual[a][2] * v[2];
    if (!(rho2 < 1.0) || k->weight == 0.0) {
        if (grad)
            grad[0] = grad[1] = grad[2] = 0.0;
        return 0.0;
    }
    double phi = ffd_ebf_phi_of(rho2, inv2s2) * k->weight;
    if (grad) {
        double g = exp(-rho2 * inv2s2), t = 1.0 - rho2, t2 = t * t;
        /* d phi / d rho^2 = -phi / (2 sigma^2) - 3 g t^2; d rho^2 / dx = 2 q^T r */
        double dr = (-g * t2 * t * inv2s2 - 3.0 * g * t2) * k->weight;
        for (int c = 0; c < 3; c++)
            grad[c] = 2.0 * dr * (k->q[0][c] * r[0] + k->q[1][c] * r[1] + k->q[2][c] * r[2]);
    }
    return phi;
}

/* Largest eigenvalue of a symmetric 3x3 matrix (trigonometric closed form). */
static double sym3_max_eigenvalue(double m[3][3])
{
    double p1 = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
    double tr = m[0][0] + m[1][1] + m[2][2];
    if (p1 == 0.0)
        return fmax(m[0][0], fmax(m[1][1], m[2][2]));
    double qm = tr / 3.0;
    double a = m[0][0] - qm, b = m[1][1] - qm, c = m[2][2] - qm;
    double p2 = a * a + b * b + c * c + 2.0 * p1;
    double p = sqrt(p2 / 6.0);
    double B[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            B[i][j] = (m[i][j] - (i == j ? qm : 0.0)) / p;
    double detB = B[0][0] * (B[1][1] * B[2][2] - B[1][2] * B[2][1]) -
                  B[0][1] * (B[1][0] * B[2][2] - B[1][2] * B[2][0]) +
                  B[0][2] * (B[1][0] * B[2][1] - B[1][1] * B[2][0]);
    double r = detB / 2.0;
    double phi = r <= -1 ? PI / 3.0 : (r >= 1 ? 0.0 : acos(r) / 3.0);
    return qm + 2.0 * p * cos(phi);
}

double ffd_ebf_bounding_radius(const ffd_ebf *e)
{
    double g[3][3]; /* columns r_k axis_k / |axis_k| */
    for (int a = 0; a < 3; a++) {
        double len = sqrt(dot(e->frame[a], e->frame[a]));
        for (int c = 0; c < 3; c++)
            g[a][c] = e->frame[a][c] / len * e->radius[a];
    }
    double m[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            m[i][j] = dot(g[i], g[j]);
    double lmax = sym3_max_eigenvalue(m);
    /* never below the largest semi-axis (rounding in the closed form) */
    double rmax = fmax(e->radius[0], fmax(e->radius[1], e->radius[2]));
    return fmax(sqrt(fmax(lmax, 0.0)), rmax);
}
