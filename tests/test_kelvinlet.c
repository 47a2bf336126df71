/* Tests of the Kelvinlet brushes (src/kelvinlet, de Goes and James 2017).
 * The independent formula is the Navier-Cauchy equation itself, checked by
 * finite differences of the evaluated field with the paper's regularised
 * body force; the loads are recomputed here from the paper's calibration
 * (not the library's). */
#include "check.h"

#include "ffd.h"

#include <omp.h>

#define PI 3.14159265358979323846
#define EX FFD_SOURCE_DIR "/examples/"

static ffd_kelvinlet_brush grab(double cx, double cy, double cz, double eps, double dx, double dy,
                                double dz)
{
    ffd_kelvinlet_brush b = {0};
    b.type = FFD_KELVINLET_GRAB;
    b.center[0] = cx, b.center[1] = cy, b.center[2] = cz;
    b.radius = eps;
    b.displacement[0] = dx, b.displacement[1] = dy, b.displacement[2] = dz;
    b.factor = 1;
    return b;
}

static ffd_kelvinlet_brush twist(const double c[3], double eps, const double axis[3], double angle)
{
    ffd_kelvinlet_brush b = {0};
    b.type = FFD_KELVINLET_TWIST;
    memcpy(b.center, c, sizeof b.center);
    memcpy(b.axis, axis, sizeof b.axis);
    b.radius = eps;
    b.angle = angle;
    b.factor = 1;
    return b;
}

static ffd_kelvinlet *make(const ffd_kelvinlet_brush *b, size_t n, double nu,
                           ffd_kelvinlet_combine combine, uint32_t steps,
                           ffd_kelvinlet_multiscale ms)
{
    ffd_kelvinlet_options o = {0};
    o.poisson_ratio = nu;
    o.combine = combine;
    o.steps = steps;
    o.multiscale = ms;
    ffd_kelvinlet *k = NULL;
    ffd_error err = {{0}};
    if (ffd_kelvinlet_create(b, n, &o, &k, &err))
        fprintf(stderr, "create: %s\n", err.message);
    return k;
}

/* u(x) = x'(x) - x of one point. */
static void displacement(const ffd_kelvinlet *k, const double x[3], double u[3])
{
    double y[3];
    ffd_error err = {{0}};
    CHECK_OK(ffd_kelvinlet_eval(k, x, 1, y, &err));
    for (int a = 0; a < 3; a++)
        u[a] = y[a] - x[a];
}

/* ---- identity ---- */

static void test_identity_bitwise(void)
{
    double pts[3 * 4] = {0.1, -0.0, 3, 1e-300, 2, -7, -0.0, -0.0, -0.0, 1e8, -1e-8, 0.5};
    double out[12], jac[36];
    ffd_error err = {{0}};
    ffd_kelvinlet *none = make(NULL, 0, 0.3, FFD_KELVINLET_SUPERPOSE, 1, FFD_KELVINLET_SINGLE);
    CHECK(none != NULL);
    CHECK_OK(ffd_kelvinlet_eval(none, pts, 4, out, &err));
    CHECK(memcmp(out, pts, sizeof pts) == 0);
    CHECK_OK(ffd_kelvinlet_jacobian(none, pts, 4, jac, &err));
    for (int i = 0; i < 4; i++)
        for (int e = 0; e < 9; e++)
            CHECK(jac[9 * i + e] == (e % 4 == 0 ? 1.0 : 0.0));
    ffd_kelvinlet_destroy(none);
    /* inert brushes of every type, superposed and in sequence: the same bits */
    double c[3] = {0, 0, 0}, ax[3] = {0, 0, 1};
    ffd_kelvinlet_brush b[4] = {grab(0, 0, 0, 1, 0, 0, 0), twist(c, 1, ax, 0)};
    b[2] = b[0], b[2].type = FFD_KELVINLET_SCALE;
    b[3] = b[0], b[3].type = FFD_KELVINLET_PINCH;
    for (int mode = 0; mode < 2; mode++) {
        ffd_kelvinlet *k = make(b, 4, 0.5, (ffd_kelvinlet_combine)mode, mode ? 5 : 1,
                                FFD_KELVINLET_TRISCALE);
        CHECK(k != NULL);
        CHECK_OK(ffd_kelvinlet_eval(k, pts, 4, out, &err));
        CHECK(memcmp(out, pts, sizeof pts) == 0);
        ffd_kelvinlet_destroy(k);
    }
}

/* ---- calibration ---- */

static void test_grab_moves_center_exactly(void)
{
    const double nus[] = {0, 0.3, 0.45, 0.5};
    for (size_t q = 0; q < 4; q++)
        for (int ms = 0; ms < 3; ms++)
            for (int mode = 0; mode < 2; mode++) {
                ffd_kelvinlet_brush b = grab(1, 2, 3, 0.7, 0.3, -0.2, 0.9);
                ffd_kelvinlet *k = make(&b, 1, nus[q], (ffd_kelvinlet_combine)mode,
                                        mode ? 8 : 1, (ffd_kelvinlet_multiscale)ms);
                double u[3];
                displacement(k, b.center, u);
                for (int a = 0; a < 3; a++)
                    CHECK_NEAR(u[a], b.displacement[a], 1e-14);
                ffd_kelvinlet_destroy(k);
            }
}

/* d u/d x at the center: angle [axis]x (twist), (factor - 1) I (scale), the pinch matrix. */
static void test_affine_calibration(void)
{
    double c[3] = {0.5, -1, 2}, ax[3] = {1, 2, 2}, jac[9];
    ffd_error err = {{0}};
    for (int ms = 0; ms < 3; ms++) {
        ffd_kelvinlet_brush b[3];
        b[0] = twist(c, 0.8, ax, 0.25);
        b[1] = b[0], b[1].type = FFD_KELVINLET_SCALE, b[1].factor = 1.4;
        b[2] = b[0], b[2].type = FFD_KELVINLET_PINCH;
        double P[3][3] = {{0.2, 0.1, 0}, {0.1, -0.3, 0.05}, {0, 0.05, 0.1}};
        memcpy(b[2].pinch, P, sizeof P);
        double want[3][9] = {{0}};
        double k3[3] = {1.0 / 3, 2.0 / 3, 2.0 / 3}, th = 0.25;
        double W[9] = {0, -k3[2], k3[1], k3[2], 0, -k3[0], -k3[1], k3[0], 0};
        for (int e = 0; e < 9; e++) {
            want[0][e] = th * W[e];
            want[1][e] = e % 4 == 0 ? 0.4 : 0;
            want[2][e] = P[e / 3][e % 3];
        }
        for (int t = 0; t < 3; t++) {
            ffd_kelvinlet *k = make(&b[t], 1, 0.3, FFD_KELVINLET_SUPERPOSE, 1,
                                    (ffd_kelvinlet_multiscale)ms);
            CHECK_OK(ffd_kelvinlet_jacobian(k, c, 1, jac, &err));
            for (int e = 0; e < 9; e++)
                CHECK_NEAR(jac[e] - (e % 4 == 0), want[t][e], 1e-13);
            double u[3];
            displacement(k, c, u); /* the center stays */
            for (int a = 0; a < 3; a++)
                CHECK_NEAR(u[a], 0, 1e-15);
            ffd_kelvinlet_destroy(k);
        }
    }
}

/* A twist integrated in steps (RK4) rotates the neighbourhood of its center by the
 * angle (a rigid motion near the center), for a large angle too. */
static void test_twist_rotates_near_center(void)
{
    double c[3] = {0, 0, 0}, ax[3] = {0, 0, 2}, eps = 1;
    const double angle = 1.3;
    ffd_kelvinlet_brush b = twist(c, eps, ax, angle);
    ffd_kelvinlet *k = make(&b, 1, 0.4, FFD_KELVINLET_SEQUENCE, 32, FFD_KELVINLET_SINGLE);
    double rho = 1e-3 * eps, x[3] = {rho, 0, 0.5 * rho}, y[3];
    ffd_error err = {{0}};
    CHECK_OK(ffd_kelvinlet_eval(k, x, 1, y, &err));
    CHECK_NEAR(atan2(y[1], y[0]), angle, 1e-5);
    CHECK_NEAR(hypot(y[0], y[1]), rho, 1e-5 * rho);
    CHECK_NEAR(y[2], x[2], 1e-5 * rho);
    ffd_kelvinlet_destroy(k);
    /* superposed: a pure infinitesimal rotation at the center (skew J - I) */
    k = make(&b, 1, 0.4, FFD_KELVINLET_SUPERPOSE, 1, FFD_KELVINLET_SINGLE);
    double J[9];
    CHECK_OK(ffd_kelvinlet_jacobian(k, c, 1, J, &err));
    for (int p = 0; p < 3; p++)
        for (int q = 0; q < 3; q++)
            CHECK_NEAR(J[3 * p + q] - (p == q) + J[3 * q + p] - (p == q), 0, 1e-14);
    ffd_kelvinlet_destroy(k);
}

/* ---- the Navier-Cauchy equation (the independent formula) ---- */

/* mu Lap u + mu/(1 - 2 nu) grad div u + b = 0 at x, by central differences
 * (step h) of the evaluated field; mu = 1. Returns the residual's norm and
 * the size of mu Lap u (its scale) in *scale. */
static double navier_cauchy_residual(const ffd_kelvinlet *k, double nu, const double x[3],
                                     const double body[3], double h, double *scale)
{
    double lap[3] = {0}, gdiv[3] = {0}, u0[3];
    displacement(k, x, u0);
    for (int i = 0; i < 3; i++) {
        double xp[3], xm[3], up[3], um[3];
        memcpy(xp, x, sizeof xp), memcpy(xm, x, sizeof xm);
        xp[i] += h, xm[i] -= h;
        displacement(k, xp, up), displacement(k, xm, um);
        for (int a = 0; a < 3; a++)
            lap[a] += (up[a] - 2 * u0[a] + um[a]) / (h * h);
    }
    /* grad div: d/dx_a sum_j du_j/dx_j; the mixed terms by 4-point stencils */
    for (int a = 0; a < 3; a++)
        for (int j = 0; j < 3; j++) {
            double s = 0;
            if (a == j) {
                double xp[3], xm[3], up[3], um[3];
                memcpy(xp, x, sizeof xp), memcpy(xm, x, sizeof xm);
                xp[a] += h, xm[a] -= h;
                displacement(k, xp, up), displacement(k, xm, um);
                s = (up[j] - 2 * u0[j] + um[j]) / (h * h);
            } else {
                double sum = 0;
                for (int sa = -1; sa <= 1; sa += 2)
                    for (int sj = -1; sj <= 1; sj += 2) {
                        double xx[3], uu[3];
                        memcpy(xx, x, sizeof xx);
                        xx[a] += sa * h, xx[j] += sj * h;
                        displacement(k, xx, uu);
                        sum += sa * sj * uu[j];
                    }
                s = sum / (4 * h * h);
            }
            gdiv[a] += s;
        }
    double r2 = 0, l2 = 0;
    for (int a = 0; a < 3; a++) {
        double r = lap[a] + gdiv[a] / (1 - 2 * nu) + body[a];
        r2 += r * r;
        l2 += lap[a] * lap[a];
    }
    *scale = sqrt(l2);
    return sqrt(r2);
}

/* The regularised density of eq. 5: rho_eps(r) = 15 eps^4 / (8 pi r_eps^7). */
static double rho_eps(double r2, double eps)
{
    double re = sqrt(r2 + eps * eps);
    return 15 * pow(eps, 4) / (8 * PI * pow(re, 7));
}

static void test_navier_cauchy_grab(void)
{
    const double nu = 0.3, eps = 0.9, a = 1 / (4 * PI), b = a / (4 * (1 - nu));
    const double c[3] = {0.2, -0.1, 0.4}, d[3] = {0.3, -0.5, 0.2};
    ffd_kelvinlet_brush br = grab(c[0], c[1], c[2], eps, d[0], d[1], d[2]);
    ffd_kelvinlet *k = make(&br, 1, nu, FFD_KELVINLET_SUPERPOSE, 1, FFD_KELVINLET_SINGLE);
    /* the force of a grab that moves its center by d: u(0) = (3a - 2b)/(2 eps) f */
    double f[3];
    for (int i = 0; i < 3; i++)
        f[i] = 2 * eps * d[i] / (3 * a - 2 * b);
    const double offsets[4][3] = {{0.3, 0.1, -0.2}, {0.9, -0.4, 0.5}, {-0.1, 1.2, 0.3}, {0, 0, 0.05}};
    for (int p = 0; p < 4; p++) {
        double x[3], r2 = 0, body[3], scale;
        for (int i = 0; i < 3; i++) {
            x[i] = c[i] + offsets[p][i];
            r2 += offsets[p][i] * offsets[p][i];
        }
        for (int i = 0; i < 3; i++)
            body[i] = f[i] * rho_eps(r2, eps);
        double res = navier_cauchy_residual(k, nu, x, body, 2e-3, &scale);
        if (res > 1e-4 * scale)
            fprintf(stderr, "grab point %d: residual %.3g, scale %.3g\n", p, res, scale);
        CHECK(res <= 1e-4 * scale);
    }
    ffd_kelvinlet_destroy(k);
}

/* The affine loads answer the force couples: mu Lap u + ... + F grad rho_eps = 0
 * (eq. 12 is the derivative of eq. 6 along F's columns, so its body force is
 * the derivative of eq. 5's). */
static void test_navier_cauchy_affine(void)
{
    const double nu = 0.25, eps = 1.1, a = 1 / (4 * PI), b = a / (4 * (1 - nu));
    const double c[3] = {0, 0.3, -0.2}, ax[3] = {0, 0.6, 0.8}, theta = 0.3;
    ffd_kelvinlet_brush br[3];
    br[0] = twist(c, eps, ax, theta);
    br[1] = br[0], br[1].type = FFD_KELVINLET_SCALE, br[1].factor = 1.2;
    br[2] = br[0], br[2].type = FFD_KELVINLET_PINCH;
    double P[3][3] = {{0.1, 0.2, 0}, {0.2, 0, 0}, {0, 0, -0.1}};
    memcpy(br[2].pinch, P, sizeof P);
    /* the couples from the calibration grad u(0) = (b (F + F^T + tr F I) - 5/2 a F) / eps^3 */
    double F[3][3][3] = {{{0}}};
    double e3 = eps * eps * eps, q = -2 * e3 * theta / (5 * a);
    F[0][0][1] = -q * ax[2], F[0][0][2] = q * ax[1], F[0][1][2] = -q * ax[0];
    F[0][1][0] = q * ax[2], F[0][2][0] = -q * ax[1], F[0][2][1] = q * ax[0];
    for (int i = 0; i < 3; i++)
        F[1][i][i] = 0.2 * e3 / (5 * b - 2.5 * a);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            F[2][i][j] = P[i][j] * e3 / (2 * b - 2.5 * a);
    const double offsets[3][3] = {{0.4, 0.2, -0.3}, {-0.7, 0.5, 0.6}, {0.1, -1.3, 0.2}};
    for (int t = 0; t < 3; t++) {
        ffd_kelvinlet *k = make(&br[t], 1, nu, FFD_KELVINLET_SUPERPOSE, 1, FFD_KELVINLET_SINGLE);
        for (int p = 0; p < 3; p++) {
            double x[3], r[3], r2 = 0, body[3], scale;
            for (int i = 0; i < 3; i++) {
                r[i] = offsets[p][i];
                x[i] = c[i] + r[i];
                r2 += r[i] * r[i];
            }
            /* grad rho_eps = -7 rho_eps r / r_eps^2 */
            double g = -7 * rho_eps(r2, eps) / (r2 + eps * eps);
            for (int i = 0; i < 3; i++)
                body[i] = g * (F[t][i][0] * r[0] + F[t][i][1] * r[1] + F[t][i][2] * r[2]);
            double res = navier_cauchy_residual(k, nu, x, body, 2e-3, &scale);
            if (res > 1e-4 * scale)
                fprintf(stderr, "affine %d point %d: residual %.3g, scale %.3g\n", t, p, res,
                        scale);
            CHECK(res <= 1e-4 * scale);
        }
        ffd_kelvinlet_destroy(k);
    }
}

/* ---- volume awareness: div u -> 0 as nu -> 0.5 ---- */

static void test_volume_awareness(void)
{
    ffd_kelvinlet_brush br[2] = {grab(0, 0, 0, 1, 0.4, 0.1, -0.2)};
    br[1] = br[0], br[1].type = FFD_KELVINLET_PINCH;
    br[1].pinch[0][0] = 0.3, br[1].pinch[1][1] = -0.3;
    ffd_error err = {{0}};
    const double x[4][3] = {{0.3, 0.2, 0.1}, {1, -0.5, 0.2}, {-0.4, 0.8, -1.5}, {2, 1, 0}};
    for (int t = 0; t < 2; t++) {
        double prev = INFINITY;
        const double nus[] = {0.0, 0.3, 0.45, 0.49, 0.5};
        for (int q = 0; q < 5; q++) {
            ffd_kelvinlet *k = make(&br[t], 1, nus[q], FFD_KELVINLET_SUPERPOSE, 1,
                                    FFD_KELVINLET_SINGLE);
            double J[36], worst = 0;
            CHECK_OK(ffd_kelvinlet_jacobian(k, &x[0][0], 4, J, &err));
            for (int p = 0; p < 4; p++)
                worst = fmax(worst, fabs(J[9 * p] + J[9 * p + 4] + J[9 * p + 8] - 3));
            if (q == 4)
                CHECK(worst <= 1e-14);
            else
                CHECK(worst < prev && worst > 1e-4 * (0.5 - nus[q]));
            prev = worst;
            ffd_kelvinlet_destroy(k);
        }
    }
    /* a scale brush needs a compressible material */
    ffd_kelvinlet_brush s = br[0];
    s.type = FFD_KELVINLET_SCALE, s.factor = 1.5;
    ffd_kelvinlet_options o = {0.5, FFD_KELVINLET_SUPERPOSE, 1, FFD_KELVINLET_SINGLE, 0};
    ffd_kelvinlet *k = NULL;
    CHECK(ffd_kelvinlet_create(&s, 1, &o, &k, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "poisson_ratio") != NULL && k == NULL);
}

/* ---- rigid motions and decay ---- */

static void rotate(double R[3][3], const double v[3], double out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = R[i][0] * v[0] + R[i][1] * v[1] + R[i][2] * v[2];
}

/* Objectivity: moving the brushes and the points by a rigid motion moves the
 * result by it (the kernels depend on r only through rotation-covariant terms). */
static void test_rigid_motion_covariance(void)
{
    const double cs = cos(0.7), sn = sin(0.7), t[3] = {1.5, -2, 0.25};
    double R[3][3] = {{cs, -sn, 0}, {sn * 0.6, cs * 0.6, -0.8}, {sn * 0.8, cs * 0.8, 0.6}};
    double c[3] = {0.1, 0.2, 0.3}, ax[3] = {0.3, -1, 0.2};
    ffd_kelvinlet_brush b[4] = {grab(0, 0, 0, 0.8, 0.2, 0.5, -0.1), twist(c, 0.6, ax, 0.4)};
    b[2] = grab(-0.5, 0.4, 0.1, 0.5, 0, 0, 0), b[2].type = FFD_KELVINLET_SCALE, b[2].factor = 0.8;
    b[3] = grab(0.4, -0.4, 0.2, 0.7, 0, 0, 0), b[3].type = FFD_KELVINLET_PINCH;
    double P[3][3] = {{0.1, 0.05, 0}, {0.05, 0.1, 0.02}, {0, 0.02, -0.2}};
    memcpy(b[3].pinch, P, sizeof P);
    ffd_kelvinlet_brush m[4];
    for (int j = 0; j < 4; j++) {
        m[j] = b[j];
        rotate(R, b[j].center, m[j].center);
        for (int a = 0; a < 3; a++)
            m[j].center[a] += t[a];
        rotate(R, b[j].displacement, m[j].displacement);
        rotate(R, b[j].axis, m[j].axis);
        for (int p = 0; p < 3; p++) /* R P R^T */
            for (int q = 0; q < 3; q++) {
                double s = 0;
                for (int i = 0; i < 3; i++)
                    for (int k = 0; k < 3; k++)
                        s += R[p][i] * b[j].pinch[i][k] * R[q][k];
                m[j].pinch[p][q] = s;
            }
    }
    ffd_error err = {{0}};
    for (int mode = 0; mode < 2; mode++) {
        ffd_kelvinlet *k0 = make(b, 4, 0.35, (ffd_kelvinlet_combine)mode, mode ? 3 : 1,
                                 FFD_KELVINLET_BISCALE);
        ffd_kelvinlet *k1 = make(m, 4, 0.35, (ffd_kelvinlet_combine)mode, mode ? 3 : 1,
                                 FFD_KELVINLET_BISCALE);
        double x[3 * 5], xm[3 * 5], y[3 * 5], ym[3 * 5];
        for (int i = 0; i < 15; i++)
            x[i] = check_rand01() * 2 - 1;
        for (int i = 0; i < 5; i++) {
            rotate(R, x + 3 * i, xm + 3 * i);
            for (int a = 0; a < 3; a++)
                xm[3 * i + a] += t[a];
        }
        CHECK_OK(ffd_kelvinlet_eval(k0, x, 5, y, &err));
        CHECK_OK(ffd_kelvinlet_eval(k1, xm, 5, ym, &err));
        for (int i = 0; i < 5; i++) {
            double want[3];
            rotate(R, y + 3 * i, want);
            for (int a = 0; a < 3; a++)
                CHECK_NEAR(ym[3 * i + a], want[a] + t[a], 1e-12);
        }
        ffd_kelvinlet_destroy(k0);
        ffd_kelvinlet_destroy(k1);
    }
}

/* Far from the brush the displacement falls off as 1/r (single), 1/r^3
 * (bi-scale) and 1/r^5 (tri-scale), §6. */
static void test_decay(void)
{
    const double powers[3] = {1, 3, 5};
    for (int ms = 0; ms < 3; ms++) {
        ffd_kelvinlet_brush b = grab(0, 0, 0, 0.5, 0, 0, 1);
        ffd_kelvinlet *k = make(&b, 1, 0.4, FFD_KELVINLET_SUPERPOSE, 1,
                                (ffd_kelvinlet_multiscale)ms);
        double x1[3] = {50, 30, 0}, x2[3] = {500, 300, 0}, u1[3], u2[3];
        displacement(k, x1, u1);
        displacement(k, x2, u2);
        double ratio = sqrt(u2[0] * u2[0] + u2[1] * u2[1] + u2[2] * u2[2]) /
                       sqrt(u1[0] * u1[0] + u1[1] * u1[1] + u1[2] * u1[2]);
        CHECK_NEAR(log10(ratio), -powers[ms], 0.01);
        ffd_kelvinlet_destroy(k);
    }
}

/* ---- derivatives ---- */

static void test_jacobian_fd(void)
{
    double c[3] = {0, 0, 0}, ax[3] = {1, 1, 0};
    ffd_kelvinlet_brush b[3] = {grab(0.2, 0, 0, 0.6, 0.5, 0.2, 0.1), twist(c, 0.9, ax, 0.8)};
    b[2] = grab(-0.3, 0.1, 0, 0.5, 0, 0, 0), b[2].type = FFD_KELVINLET_PINCH;
    b[2].pinch[0][1] = b[2].pinch[1][0] = 0.4;
    ffd_error err = {{0}};
    for (int mode = 0; mode < 2; mode++)
        for (int ms = 0; ms < 3; ms++) {
            ffd_kelvinlet *k = make(b, 3, 0.42, (ffd_kelvinlet_combine)mode, mode ? 4 : 1,
                                    (ffd_kelvinlet_multiscale)ms);
            double x[3 * 6], J[9 * 6];
            for (int i = 0; i < 18; i++)
                x[i] = 1.5 * (check_rand01() * 2 - 1);
            CHECK_OK(ffd_kelvinlet_jacobian(k, x, 6, J, &err));
            const double h = 1e-6;
            double worst = 0;
            for (int i = 0; i < 6; i++)
                for (int q = 0; q < 3; q++) {
                    double xp[3], xm[3], yp[3], ym[3];
                    memcpy(xp, x + 3 * i, sizeof xp), memcpy(xm, x + 3 * i, sizeof xm);
                    xp[q] += h, xm[q] -= h;
                    CHECK_OK(ffd_kelvinlet_eval(k, xp, 1, yp, &err));
                    CHECK_OK(ffd_kelvinlet_eval(k, xm, 1, ym, &err));
                    for (int p = 0; p < 3; p++)
                        worst = fmax(worst, fabs((yp[p] - ym[p]) / (2 * h) - J[9 * i + 3 * p + q]));
                }
            CHECK(worst <= 1e-7);
            ffd_kelvinlet_destroy(k);
        }
}

/* The grabs' sensitivity blocks against differences in the displacements
 * (exact: the superposed field is linear in them). */
static void test_grab_blocks(void)
{
    double c[3] = {0, 0, 0}, ax[3] = {0, 0, 1};
    ffd_kelvinlet_brush b[3] = {grab(0.3, 0, 0, 0.7, 0.2, 0.1, 0), twist(c, 1, ax, 0.5),
                                grab(-0.5, 0.2, 0.1, 0.4, 0, -0.3, 0.2)};
    ffd_error err = {{0}};
    ffd_kelvinlet *k = make(b, 3, 0.3, FFD_KELVINLET_SUPERPOSE, 1, FFD_KELVINLET_TRISCALE);
    CHECK(ffd_kelvinlet_grab_count(k) == 2);
    double x[3 * 4], K[4 * 2 * 9], y0[12], y1[12];
    for (int i = 0; i < 12; i++)
        x[i] = check_rand01() * 2 - 1;
    CHECK_OK(ffd_kelvinlet_grab_blocks(k, x, 4, K, &err));
    CHECK_OK(ffd_kelvinlet_eval(k, x, 4, y0, &err));
    const int brush_of[2] = {0, 2};
    for (int g = 0; g < 2; g++)
        for (int q = 0; q < 3; q++) {
            ffd_kelvinlet_brush m = b[brush_of[g]];
            m.displacement[q] += 0.25;
            CHECK_OK(ffd_kelvinlet_set_brush(k, (size_t)brush_of[g], &m, &err));
            CHECK_OK(ffd_kelvinlet_eval(k, x, 4, y1, &err));
            CHECK_OK(ffd_kelvinlet_set_brush(k, (size_t)brush_of[g], &b[brush_of[g]], &err));
            for (int i = 0; i < 4; i++)
                for (int p = 0; p < 3; p++)
                    CHECK_NEAR((y1[3 * i + p] - y0[3 * i + p]) / 0.25, K[9 * (2 * i + g) + 3 * p + q],
                               1e-12);
        }
    /* symmetric blocks (eq. 6), the identity at the grab's own center */
    double at[3] = {0.3, 0, 0}, Kc[18];
    CHECK_OK(ffd_kelvinlet_grab_blocks(k, at, 1, Kc, &err));
    for (int e = 0; e < 9; e++)
        CHECK_NEAR(Kc[e], e % 4 == 0, 1e-14);
    for (int p = 0; p < 3; p++)
        for (int q = 0; q < 3; q++)
            CHECK_NEAR(K[3 * p + q], K[3 * q + p], 1e-15);
    ffd_kelvinlet_destroy(k);
    k = make(b, 3, 0.3, FFD_KELVINLET_SEQUENCE, 2, FFD_KELVINLET_SINGLE);
    CHECK(ffd_kelvinlet_grab_blocks(k, x, 4, K, &err) == FFD_ERR_UNSUPPORTED);
    ffd_kelvinlet_destroy(k);
}

/* ---- rigs: direct manipulation reaches its targets ---- */

static void test_rig_constraints_reach_targets(void)
{
    ffd_mesh *mesh = NULL;
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read(EX "lattice/bunny.obj", &mesh, &err));
    CHECK_OK(ffd_rig_read(EX "kelvinlet/bunny-pins.json", &rig, &err));
    if (!mesh || !rig)
        return;
    ffd_deformer *d = NULL;
    CHECK_OK(ffd_deformer_create(rig, mesh, NULL, &d, &err));
    ffd_rig_report report = {0};
    CHECK_OK(ffd_rig_apply(rig, mesh, &report, &err));
    CHECK(report.constraint_count == 3 && report.rank == 9);
    CHECK(report.max_residual <= 1e-9);
    const double *x = ffd_mesh_positions(mesh);
    const uint32_t ids[3] = {553, 746, 896};
    const double targets[3][3] = {{0.5, 10.6, -1.8}, {-5.8, 6.2, 1.6}, {4.94885, 1.860936, 0.894463}};
    for (int c = 0; c < 3; c++)
        for (int a = 0; a < 3; a++)
            CHECK_NEAR(x[3 * ids[c] + a], targets[c][a], 1e-9);
    /* the deformer replays the solve: its evaluation is the applied mesh */
    size_t n = ffd_mesh_vertex_count(mesh);
    double *y = malloc(3 * n * sizeof *y);
    CHECK_OK(ffd_deformer_eval(d, y, &err));
    double worst = 0;
    for (size_t i = 0; i < 3 * n; i++)
        worst = fmax(worst, fabs(y[i] - x[i]));
    CHECK(worst == 0);
    CHECK(ffd_deformer_control_count(d) == 3);
    ffd_linear_map map;
    CHECK(ffd_deformer_linear_map(d, &map, &err) == FFD_ERR_UNSUPPORTED);
    free(y);
    ffd_rig_report_free(&report);
    ffd_deformer_destroy(d);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

static void test_rig_errors(void)
{
    static const struct {
        const char *text, *expect;
    } bad[] = {
        {"{\"deformer\":\"kelvinlet\",\"poisson_ratio\":0.6,\"brushes\":[]}", "outside [0, 0.5]"},
        {"{\"deformer\":\"kelvinlet\",\"brushes\":[{\"type\":\"grab\",\"center\":[0,0,0],"
         "\"radius\":0}]}", "brushes[0].radius"},
        {"{\"deformer\":\"kelvinlet\",\"brushes\":[{\"type\":\"twist\",\"center\":[0,0,0],"
         "\"radius\":1,\"axis\":[0,0,0]}]}", "brushes[0].axis"},
        {"{\"deformer\":\"kelvinlet\",\"brushes\":[{\"type\":\"pinch\",\"center\":[0,0,0],"
         "\"radius\":1,\"pinch\":[[1,0,0],[0,1,0],[0,0,0]]}]}", "trace"},
        {"{\"deformer\":\"kelvinlet\",\"brushes\":[{\"type\":\"grab\",\"center\":[0,0,0],"
         "\"radius\":1,\"angle\":1}]}", "brushes[0]"},
        {"{\"deformer\":\"kelvinlet\",\"steps\":4,\"brushes\":[]}", "sequence"},
        {"{\"deformer\":\"kelvinlet\",\"brushes\":[{\"type\":\"poke\",\"center\":[0,0,0],"
         "\"radius\":1}]}", "brushes[0].type"},
        {"{\"deformer\":\"kelvinlet\"}", "brushes"},
        {"{\"deformer\":\"kelvinlet\",\"brushes\":[],\"resolution\":[3,3,3]}", "lattice"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        ffd_rig *rig = NULL;
        ffd_error err = {{0}};
        ffd_status st = ffd_rig_parse_json(bad[i].text, strlen(bad[i].text), "r.json", &rig, &err);
        CHECK(st != FFD_OK && rig == NULL);
        if (!strstr(err.message, bad[i].expect))
            fprintf(stderr, "case %zu: %s\n", i, err.message);
        CHECK(strstr(err.message, bad[i].expect) != NULL);
        ffd_rig_destroy(rig);
    }
}

/* The editor's "brush" operation through ffd_deformer_command: a brush added
 * and removed, the controls following; bad bodies change nothing. */
static void test_brush_command(void)
{
    double tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0}, x[9];
    uint32_t off[2] = {0, 3}, idx[3] = {0, 1, 2};
    ffd_mesh *mesh = NULL;
    ffd_deformer *d = NULL;
    ffd_error err = {{0}};
    const char *rig = "{\"deformer\": \"kelvinlet\", \"brushes\": []}";
    CHECK_OK(ffd_mesh_create(tri, 3, off, idx, 1, &mesh, &err));
    CHECK_OK(ffd_deformer_create_json(rig, strlen(rig), "r.json", mesh, NULL, &d, &err));
    if (!d)
        return;
    CHECK(ffd_deformer_control_count(d) == 0);
    const char *add = "{\"add\": {\"type\": \"grab\", \"center\": [1, 0, 0], \"radius\": 0.5, "
                      "\"displacement\": [0, 0, 0.25]}}";
    CHECK_OK(ffd_deformer_command(d, "brush", add, strlen(add), &err));
    CHECK(ffd_deformer_control_count(d) == 1);
    CHECK_OK(ffd_deformer_eval(d, x, &err));
    CHECK_NEAR(x[5], 0.25, 1e-15); /* vertex 1 is the grab's center */
    const char *bad[] = {"{\"add\": {\"type\": \"twist\", \"center\": [0, 0, 0], \"radius\": 1}}",
                         "{\"remove\": 3}", "{\"add\": {}, \"remove\": 0}", "{\"move\": 1}"};
    const ffd_status want[] = {FFD_ERR_PARSE, FFD_ERR_RANGE, FFD_ERR_PARSE, FFD_ERR_PARSE};
    for (int i = 0; i < 4; i++) {
        CHECK(ffd_deformer_command(d, "brush", bad[i], strlen(bad[i]), &err) == want[i]);
        CHECK(ffd_deformer_control_count(d) == 1);
    }
    CHECK(ffd_deformer_command(d, "refine", "{}", 2, &err) == FFD_ERR_UNSUPPORTED);
    char *json = NULL;
    size_t size = 0;
    CHECK_OK(ffd_deformer_rig(d, &json, &size, &err));
    CHECK(json && strstr(json, "\"grab\"") != NULL);
    ffd_free(json);
    CHECK_OK(ffd_deformer_command(d, "brush", "{\"remove\": 0}", 13, &err));
    CHECK(ffd_deformer_control_count(d) == 0);
    CHECK_OK(ffd_deformer_eval(d, x, &err));
    CHECK(memcmp(x, tri, sizeof x) == 0);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

/* ---- threads ---- */

static void test_threads_bitwise(void)
{
    double c[3] = {0, 0, 0}, ax[3] = {0, 1, 0};
    ffd_kelvinlet_brush b[2] = {grab(0.2, 0, 0, 0.6, 0.5, 0.2, 0.1), twist(c, 0.9, ax, 0.8)};
    ffd_kelvinlet *k = make(b, 2, 0.4, FFD_KELVINLET_SEQUENCE, 3, FFD_KELVINLET_BISCALE);
    enum { N = 5000 };
    double *x = malloc(3 * N * sizeof *x), *y1 = malloc(12 * N * sizeof *y1),
           *y2 = malloc(12 * N * sizeof *y2);
    for (int i = 0; i < 3 * N; i++)
        x[i] = check_rand01() * 4 - 2;
    ffd_error err = {{0}};
    int before = omp_get_max_threads();
    omp_set_num_threads(1);
    CHECK_OK(ffd_kelvinlet_jacobian(k, x, N, y1, &err));
    CHECK_OK(ffd_kelvinlet_eval(k, x, N, y1 + 9 * N, &err));
    omp_set_num_threads(3);
    CHECK_OK(ffd_kelvinlet_jacobian(k, x, N, y2, &err));
    CHECK_OK(ffd_kelvinlet_eval(k, x, N, y2 + 9 * N, &err));
    omp_set_num_threads(before);
    CHECK(memcmp(y1, y2, 12 * N * sizeof *y1) == 0);
    free(x);
    free(y1);
    free(y2);
    ffd_kelvinlet_destroy(k);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"identity_bitwise", test_identity_bitwise},
        {"grab_moves_center_exactly", test_grab_moves_center_exactly},
        {"affine_calibration", test_affine_calibration},
        {"twist_rotates_near_center", test_twist_rotates_near_center},
        {"navier_cauchy_grab", test_navier_cauchy_grab},
        {"navier_cauchy_affine", test_navier_cauchy_affine},
        {"volume_awareness", test_volume_awareness},
        {"rigid_motion_covariance", test_rigid_motion_covariance},
        {"decay", test_decay},
        {"jacobian_fd", test_jacobian_fd},
        {"grab_blocks", test_grab_blocks},
        {"rig_constraints_reach_targets", test_rig_constraints_reach_targets},
        {"rig_errors", test_rig_errors},
        {"brush_command", test_brush_command},
        {"threads_bitwise", test_threads_bitwise},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
