/* Tests of the GFFD primitive fields: the variational interpolant (against an
 * independent dense solve, gradient, scale invariance, regularisation),
 * exact distances (against brute force, polyhedron sign against the
 * generalized winding number), the sampling rules, and how well the fitted
 * field approximates the true distance. */
#include "ffd.h"
#include "check.h"
#include "gffd/gffd.h"

#include <stdint.h>

/* ============================== helpers ============================== */

static double rnd(double lo, double hi)
{
    return lo + (hi - lo) * check_rand01();
}

static double maxabs(const double *v, size_t n)
{
    double m = 0;
    for (size_t i = 0; i < n; i++)
        m = fabs(v[i]) > m ? fabs(v[i]) : m;
    return m;
}

static void random_centres(double *c, size_t m, double lo, double hi)
{
    for (size_t i = 0; i < 3 * m; i++)
        c[i] = rnd(lo, hi);
}

static int fit(const double *c, size_t m, const double *v, int dim, ffd_rbf *r,
               ffd_rbf_factor *fac)
{
    ffd_error err = {{0}};
    ffd_rbf_factor f;
    if (ffd_rbf_factor_create(c, m, &f, &err) != FFD_OK) {
        fprintf(stderr, "factor: %s\n", err.message);
        return 0;
    }
    ffd_status st = ffd_rbf_fit(&f, v, dim, r, &err);
    if (st != FFD_OK)
        fprintf(stderr, "fit: %s\n", err.message);
    if (fac)
        *fac = f;
    else
        ffd_rbf_factor_free(&f);
    return st == FFD_OK;
}

/* max_j |f(c_j) - v_j| over every column */
static double interp_error(const ffd_rbf *r, const double *c, size_t m, const double *v, int dim)
{
    double worst = 0, val[3];
    for (size_t j = 0; j < m; j++) {
        ffd_rbf_eval(r, c + 3 * j, val, NULL);
        for (int d = 0; d < dim; d++) {
            double e = fabs(val[d] - v[j * (size_t)dim + (size_t)d]);
            worst = e > worst || e != e ? e : worst;
        }
    }
    return worst;
}

/* ============== an independent solve of the saddle system ============== */

/* Gaussian elimination with partial pivoting on [A P; P' 0] built directly
 * in model coordinates: sol = (w_1..w_m, a_0, a_x, a_y, a_z). */
static int ref_solve(const double *c, size_t m, const double *v, double *sol)
{
    size_t n = m + 4, w = n + 1;
    double *M = calloc(n * w, sizeof *M);
    if (!M)
        return 0;
    for (size_t i = 0; i < m; i++) {
        for (size_t j = 0; j < m; j++) {
            double dx = c[3 * i] - c[3 * j], dy = c[3 * i + 1] - c[3 * j + 1],
                   dz = c[3 * i + 2] - c[3 * j + 2];
            double d = sqrt(dx * dx + dy * dy + dz * dz);
            M[i * w + j] = d * d * d;
        }
        M[i * w + m] = 1;
        M[m * w + i] = 1;
        for (size_t k = 0; k < 3; k++) {
            M[i * w + m + 1 + k] = c[3 * i + k];
            M[(m + 1 + k) * w + i] = c[3 * i + k];
        }
        M[i * w + n] = v[i];
    }
    for (size_t k = 0; k < n; k++) {
        size_t p = k;
        for (size_t i = k + 1; i < n; i++)
            if (fabs(M[i * w + k]) > fabs(M[p * w + k]))
                p = i;
        if (M[p * w + k] == 0) {
            free(M);
            return 0;
        }
        if (p != k)
            for (size_t j = 0; j < w; j++) {
                double t = M[k * w + j];
                M[k * w + j] = M[p * w + j];
                M[p * w + j] = t;
            }
        for (size_t i = k + 1; i < n; i++) {
            double f = M[i * w + k] / M[k * w + k];
            if (f != 0)
                for (size_t j = k; j < w; j++)
                    M[i * w + j] -= f * M[k * w + j];
        }
    }
    for (size_t k = n; k-- > 0;) {
        double s = M[k * w + n];
        for (size_t j = k + 1; j < n; j++)
            s -= M[k * w + j] * sol[j];
        sol[k] = s / M[k * w + k];
    }
    free(M);
    return 1;
}

static double ref_eval(const double *c, size_t m, const double *sol, const double x[3])
{
    double f = sol[m] + sol[m + 1] * x[0] + sol[m + 2] * x[1] + sol[m + 3] * x[2];
    for (size_t j = 0; j < m; j++) {
        double dx = x[0] - c[3 * j], dy = x[1] - c[3 * j + 1], dz = x[2] - c[3 * j + 2];
        double d = sqrt(dx * dx + dy * dy + dz * dz);
        f += sol[j] * d * d * d;
    }
    return f;
}

/* ============================== RBF tests ============================== */

static void test_rbf_interpolates_random(void)
{
    const size_t sizes[] = {50, 300};
    for (size_t s = 0; s < 2; s++) {
        size_t m = sizes[s];
        double *c = malloc(3 * m * sizeof *c), *v = malloc(3 * m * sizeof *v);
        random_centres(c, m, -1, 1);
        for (size_t i = 0; i < 3 * m; i++)
            v[i] = rnd(-1, 1);
        for (int dim = 1; dim <= 3; dim += 2) {
            ffd_rbf r;
            ffd_rbf_factor f;
            if (!fit(c, m, v, dim, &r, &f)) {
                CHECK(0);
                continue;
            }
            CHECK(f.regularised == 0);
            CHECK(f.rcond >= FFD_RBF_RCOND);
            CHECK(r.count == m && r.dim == dim);
            CHECK_NEAR(interp_error(&r, c, m, v, dim), 0, 1e-9 * maxabs(v, m * (size_t)dim));
            /* the bounding box of the centres */
            for (int k = 0; k < 3; k++) {
                double lo = c[k], hi = c[k];
                for (size_t j = 1; j < m; j++) {
                    lo = c[3 * j + k] < lo ? c[3 * j + k] : lo;
                    hi = c[3 * j + k] > hi ? c[3 * j + k] : hi;
                }
                CHECK(r.lo[k] == lo && r.hi[k] == hi);
            }
            ffd_rbf_free(&r);
            ffd_rbf_factor_free(&f);
        }
        free(c);
        free(v);
    }
}

static void test_rbf_matches_dense_solve(void)
{
    const size_t sizes[] = {50, 300};
    for (size_t s = 0; s < 2; s++) {
        size_t m = sizes[s];
        double *c = malloc(3 * m * sizeof *c), *v = malloc(m * sizeof *v),
               *sol = malloc((m + 4) * sizeof *sol);
        random_centres(c, m, -2, 3);
        for (size_t i = 0; i < m; i++)
            v[i] = rnd(-1, 1);
        ffd_rbf r;
        CHECK(fit(c, m, v, 1, &r, NULL));
        CHECK(ref_solve(c, m, v, sol));
        /* coefficients: the weights are per model unit as in the reference;
         * the polynomial is about r.origin */
        double wmax = maxabs(sol, m), werr = 0;
        for (size_t j = 0; j < m; j++)
            werr = fmax(werr, fabs(r.weights[j] - sol[j]));
        CHECK_NEAR(werr / wmax, 0, 1e-8);
        double a0 = r.poly[0][0] - r.poly[1][0] * r.origin[0] - r.poly[2][0] * r.origin[1] -
                    r.poly[3][0] * r.origin[2];
        CHECK_NEAR(a0, sol[m], 1e-8 * (fabs(sol[m]) + 1));
        for (int k = 1; k < 4; k++)
            CHECK_NEAR(r.poly[k][0], sol[m + (size_t)k], 1e-8 * (fabs(sol[m + (size_t)k]) + 1));
        /* evaluations at random points in and around the centres' box */
        double eerr = 0;
        for (int t = 0; t < 200; t++) {
            double x[3] = {rnd(-3, 4), rnd(-3, 4), rnd(-3, 4)}, f;
            ffd_rbf_eval(&r, x, &f, NULL);
            double g = ref_eval(c, m, sol, x);
            eerr = fmax(eerr, fabs(f - g) / (fabs(g) + 1));
        }
        CHECK_NEAR(eerr, 0, 1e-8);
        ffd_rbf_free(&r);
        free(c);
        free(v);
        free(sol);
    }
}

/* ffd_rbf_eval's documented sum order (gffd_rbf.c), restated in scalar code:
 * centre j in lane j % 4, lanes added as (l0 + l2) + (l1 + l3). Whichever
 * instruction set the CPU gets (SSE2, or AVX where cpuid reports it), the
 * value and gradient must match it bitwise, for every count modulo 4. */
static void test_rbf_eval_lane_order(void)
{
    for (size_t m = 1; m <= 13; m++) {
        double c[3 * 13], v[13];
        random_centres(c, m, -1, 1);
        for (size_t j = 0; j < m; j++)
            v[j] = rnd(-1, 1);
        ffd_rbf r;
        CHECK(fit(c, m, v, 1, &r, NULL));
        for (int t = 0; t < 20; t++) {
            double x[3] = {rnd(-2, 2), rnd(-2, 2), rnd(-2, 2)};
            double lv[4] = {0, 0, 0, 0}, lg[3][4] = {{0}};
            for (size_t j = 0; j < m; j++) {
                const double *q = r.centres + 3 * j;
                double d[3] = {x[0] - q[0], x[1] - q[1], x[2] - q[2]};
                double d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                double wd = r.weights[j] * sqrt(d2);
                lv[j % 4] += wd * d2;
                for (int k = 0; k < 3; k++)
                    lg[k][j % 4] += wd * d[k];
            }
            const double p[3] = {x[0] - r.origin[0], x[1] - r.origin[1], x[2] - r.origin[2]};
            double want = (lv[0] + lv[2]) + (lv[1] + lv[3]);
            want += r.poly[0][0] + r.poly[1][0] * p[0] + r.poly[2][0] * p[1] + r.poly[3][0] * p[2];
            double got, grad[3], plain;
            ffd_rbf_eval(&r, x, &got, grad);
            ffd_rbf_eval(&r, x, &plain, NULL);
            CHECK(memcmp(&got, &want, sizeof got) == 0);
            CHECK(memcmp(&plain, &want, sizeof got) == 0);
            for (int k = 0; k < 3; k++) {
                double g = 3 * ((lg[k][0] + lg[k][2]) + (lg[k][1] + lg[k][3])) + r.poly[1 + k][0];
                CHECK(memcmp(&grad[k], &g, sizeof g) == 0);
            }
        }
        ffd_rbf_free(&r);
    }
}

static void test_rbf_gradient(void)
{
    size_t m = 80;
    double c[3 * 80], v[3 * 80];
    random_centres(c, m, -1, 1);
    for (size_t i = 0; i < 3 * m; i++)
        v[i] = sin(3 * c[i]) + 0.3 * c[(i + 1) % (3 * m)];
    for (int dim = 1; dim <= 3; dim += 2) {
        ffd_rbf r;
        CHECK(fit(c, m, v, dim, &r, NULL));
        double worst = 0, scale = 0;
        for (int t = 0; t < 100; t++) {
            double x[3] = {rnd(-1.5, 1.5), rnd(-1.5, 1.5), rnd(-1.5, 1.5)};
            double val[3], g[9], h = 1e-5;
            ffd_rbf_eval(&r, x, val, g);
            for (int k = 0; k < 3; k++) {
                double xp[3] = {x[0], x[1], x[2]}, xm[3] = {x[0], x[1], x[2]}, fp[3], fm[3];
                xp[k] += h;
                xm[k] -= h;
                ffd_rbf_eval(&r, xp, fp, NULL);
                ffd_rbf_eval(&r, xm, fm, NULL);
                for (int d = 0; d < dim; d++) {
                    double fd = (fp[d] - fm[d]) / (2 * h);
                    worst = fmax(worst, fabs(fd - g[3 * d + k]));
                    scale = fmax(scale, fabs(fd));
                }
            }
        }
        CHECK_NEAR(worst, 0, 1e-6 * scale);
        ffd_rbf_free(&r);
    }
}

static void test_rbf_scale_invariance(void)
{
    size_t m = 120;
    double c[3 * 120], v[120], cs[3 * 120], vs[120];
    random_centres(c, m, -1, 1);
    for (size_t i = 0; i < m; i++)
        v[i] = cos(2 * c[3 * i]) * c[3 * i + 1] + c[3 * i + 2];
    ffd_rbf r;
    CHECK(fit(c, m, v, 1, &r, NULL));
    const double scales[] = {1000, 1e-3};
    for (int s = 0; s < 2; s++) {
        double k = scales[s];
        for (size_t i = 0; i < 3 * m; i++)
            cs[i] = k * c[i];
        for (size_t i = 0; i < m; i++)
            vs[i] = k * v[i];
        ffd_rbf rs;
        ffd_rbf_factor f;
        CHECK(fit(cs, m, vs, 1, &rs, &f));
        CHECK(f.regularised == 0);
        double worst = 0, gworst = 0;
        for (int t = 0; t < 200; t++) {
            double x[3] = {rnd(-1.5, 1.5), rnd(-1.5, 1.5), rnd(-1.5, 1.5)};
            double xs[3] = {k * x[0], k * x[1], k * x[2]}, a, b, ga[3], gb[3];
            ffd_rbf_eval(&r, x, &a, ga);
            ffd_rbf_eval(&rs, xs, &b, gb);
            worst = fmax(worst, fabs(b / k - a));
            for (int j = 0; j < 3; j++)
                gworst = fmax(gworst, fabs(gb[j] - ga[j])); /* the gradient is scale-free */
        }
        CHECK_NEAR(worst, 0, 1e-9 * maxabs(v, m));
        CHECK_NEAR(gworst, 0, 1e-8);
        ffd_rbf_free(&rs);
        ffd_rbf_factor_free(&f);
    }
    /* far from the world origin: the same field, translated */
    for (size_t i = 0; i < m; i++)
        for (int j = 0; j < 3; j++)
            cs[3 * i + (size_t)j] = c[3 * i + (size_t)j] + 1e6 * (j + 1);
    ffd_rbf rt;
    CHECK(fit(cs, m, v, 1, &rt, NULL));
    double worst = 0;
    for (int t = 0; t < 200; t++) {
        double x[3] = {rnd(-1.5, 1.5), rnd(-1.5, 1.5), rnd(-1.5, 1.5)};
        double xt[3] = {x[0] + 1e6, x[1] + 2e6, x[2] + 3e6}, a, b;
        ffd_rbf_eval(&r, x, &a, NULL);
        ffd_rbf_eval(&rt, xt, &b, NULL);
        worst = fmax(worst, fabs(b - a));
    }
    /* the centres themselves are rounded to ~1e-10 there */
    CHECK_NEAR(worst, 0, 1e-7 * maxabs(v, m));
    ffd_rbf_free(&rt);
    ffd_rbf_free(&r);
}

static int all_finite_rbf(const ffd_rbf *r)
{
    for (size_t i = 0; i < r->count * (size_t)r->dim; i++)
        if (!isfinite(r->weights[i]))
            return 0;
    for (int k = 0; k < 4; k++)
        for (int d = 0; d < r->dim; d++)
            if (!isfinite(r->poly[k][d]))
                return 0;
    return 1;
}

static void test_rbf_regularised(void)
{
    /* coincident centres with the same value: still interpolates */
    {
        size_t m = 40;
        double c[3 * 42], v[42];
        random_centres(c, m, -1, 1);
        for (size_t i = 0; i < m; i++)
            v[i] = c[3 * i] * c[3 * i] + c[3 * i + 1] - 0.5 * c[3 * i + 2];
        memcpy(c + 3 * m, c + 3 * 5, 3 * sizeof *c);
        v[m] = v[5];
        memcpy(c + 3 * (m + 1), c + 3 * 17, 3 * sizeof *c);
        v[m + 1] = v[17];
        ffd_rbf r;
        ffd_rbf_factor f;
        CHECK(fit(c, m + 2, v, 1, &r, &f));
        CHECK(f.regularised == 1);
        CHECK(f.ipiv == NULL);
        CHECK(all_finite_rbf(&r));
        CHECK_NEAR(interp_error(&r, c, m + 2, v, 1), 0, 1e-8);
        /* inconsistent values at the duplicate: the least-squares compromise */
        double v2[42];
        memcpy(v2, v, sizeof v2);
        v2[m] = v[5] + 0.2;
        ffd_rbf r2;
        ffd_error err = {{0}};
        CHECK_OK(ffd_rbf_fit(&f, v2, 1, &r2, &err));
        CHECK(all_finite_rbf(&r2));
        double a;
        ffd_rbf_eval(&r2, c + 3 * 5, &a, NULL);
        CHECK_NEAR(a, v[5] + 0.1, 1e-6);
        ffd_rbf_free(&r2);
        ffd_rbf_free(&r);
        ffd_rbf_factor_free(&f);
    }
    /* all centres coplanar (z = 0.3): P loses rank */
    {
        size_t m = 60;
        double c[3 * 60], v[60], v3[180];
        for (size_t i = 0; i < m; i++) {
            c[3 * i] = rnd(-1, 1);
            c[3 * i + 1] = rnd(-1, 1);
            c[3 * i + 2] = 0.3;
            v[i] = sin(2 * c[3 * i]) + c[3 * i + 1] * c[3 * i + 1];
            for (int d = 0; d < 3; d++)
                v3[3 * i + (size_t)d] = (d + 1) * v[i];
        }
        ffd_rbf r, r3;
        ffd_rbf_factor f;
        CHECK(fit(c, m, v, 1, &r, &f));
        CHECK(f.regularised == 1);
        CHECK(all_finite_rbf(&r));
        CHECK_NEAR(interp_error(&r, c, m, v, 1), 0, 1e-8);
        ffd_error err = {{0}};
        CHECK_OK(ffd_rbf_fit(&f, v3, 3, &r3, &err));
        CHECK(all_finite_rbf(&r3));
        CHECK_NEAR(interp_error(&r3, c, m, v3, 3), 0, 3e-8);
        /* minimum norm: no slope across the plane, so symmetric about it */
        CHECK_NEAR(r.poly[3][0], 0, 1e-8);
        for (int t = 0; t < 20; t++) {
            double x[3] = {rnd(-1, 1), rnd(-1, 1), 0}, h = rnd(0.1, 1), a, b;
            x[2] = 0.3 + h;
            ffd_rbf_eval(&r, x, &a, NULL);
            x[2] = 0.3 - h;
            ffd_rbf_eval(&r, x, &b, NULL);
            CHECK_NEAR(a, b, 1e-8);
        }
        ffd_rbf_free(&r);
        ffd_rbf_free(&r3);
        ffd_rbf_factor_free(&f);
    }
    /* one, two and three centres: the constant, or least squares */
    for (size_t m = 1; m <= 3; m++) {
        double c[9] = {0.5, -2, 7, 1.5, -2, 7.5, 0.5, 0, 7}, v[3] = {3, 4, 5};
        ffd_rbf r;
        ffd_rbf_factor f;
        CHECK(fit(c, m, v, 1, &r, &f));
        CHECK(f.regularised == 1);
        CHECK(all_finite_rbf(&r));
        CHECK_NEAR(interp_error(&r, c, m, v, 1), 0, 1e-9);
        if (m == 1) {
            double x[3] = {4, 5, 6}, a, g[3];
            ffd_rbf_eval(&r, x, &a, g);
            CHECK_NEAR(a, 3, 1e-12);
            CHECK_NEAR(fabs(g[0]) + fabs(g[1]) + fabs(g[2]), 0, 1e-12);
        }
        ffd_rbf_free(&r);
        ffd_rbf_factor_free(&f);
    }
}

static void test_rbf_bad_input(void)
{
    ffd_error err = {{0}};
    ffd_rbf_factor f;
    double c[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    CHECK(ffd_rbf_factor_create(c, 0, &f, &err) == FFD_ERR_INVALID);
    c[4] = NAN;
    CHECK(ffd_rbf_factor_create(c, 4, &f, &err) == FFD_ERR_NONFINITE);
    c[4] = 0;
    CHECK_OK(ffd_rbf_factor_create(c, 4, &f, &err));
    double v[4] = {1, 2, INFINITY, 4};
    ffd_rbf r;
    CHECK(ffd_rbf_fit(&f, v, 1, &r, &err) == FFD_ERR_NONFINITE);
    CHECK(strstr(err.message, "2") != NULL);
    CHECK(r.weights == NULL && r.centres == NULL);
    v[2] = 3;
    CHECK(ffd_rbf_fit(&f, v, 2, &r, &err) == FFD_ERR_INVALID);
    ffd_rbf_factor_free(&f);
    ffd_rbf_factor_free(&f); /* twice is harmless */
}

static void test_rbf_failing_allocations(void)
{
    double c[3 * 20], v[20];
    random_centres(c, 20, -1, 1);
    for (size_t i = 0; i < 20; i++)
        v[i] = c[3 * i];
    int succeeded = 0;
    for (long k = 0; k < 40 && !succeeded; k++) {
        fail_alloc fa = {k, 0};
        ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_set_allocator(&a);
        ffd_error err = {{0}};
        ffd_rbf_factor f;
        ffd_rbf r;
        ffd_status st = ffd_rbf_factor_create(c, 20, &f, &err);
        if (st == FFD_OK) {
            st = ffd_rbf_fit(&f, v, 1, &r, &err);
            if (st == FFD_OK)
                ffd_rbf_free(&r);
            ffd_rbf_factor_free(&f);
        }
        ffd_set_allocator(NULL);
        CHECK(st == FFD_OK || st == FFD_ERR_NOMEM);
        succeeded = st == FFD_OK;
    }
    CHECK(succeeded);
}

/* ============================ distances ============================ */

static double brute_segment(const double p[3], const double a[3], const double b[3], int n)
{
    double best = INFINITY;
    for (int i = 0; i <= n; i++) {
        double t = (double)i / n, d2 = 0;
        for (int k = 0; k < 3; k++) {
            double q = a[k] + t * (b[k] - a[k]) - p[k];
            d2 += q * q;
        }
        best = fmin(best, d2);
    }
    return sqrt(best);
}

static double brute_triangle(const double p[3], const double a[3], const double b[3],
                             const double c[3], int n)
{
    double best = INFINITY;
    for (int i = 0; i <= n; i++)
        for (int j = 0; i + j <= n; j++) {
            double u = (double)i / n, v = (double)j / n, d2 = 0;
            for (int k = 0; k < 3; k++) {
                double q = a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]) - p[k];
                d2 += q * q;
            }
            best = fmin(best, d2);
        }
    return sqrt(best);
}

static double dist3(const double a[3], const double b[3])
{
    double d2 = 0;
    for (int k = 0; k < 3; k++)
        d2 += (a[k] - b[k]) * (a[k] - b[k]);
    return sqrt(d2);
}

static void test_distance_segment(void)
{
    for (int t = 0; t < 300; t++) {
        double a[3], b[3], p[3];
        for (int k = 0; k < 3; k++) {
            a[k] = rnd(-1, 1);
            b[k] = rnd(-1, 1);
            p[k] = rnd(-2, 2);
        }
        if (t % 10 == 0)
            for (int k = 0; k < 3; k++) /* p on the line, beyond or between the ends */
                p[k] = a[k] + (t % 20 ? 1.7 : 0.4) * (b[k] - a[k]);
        int n = 20000;
        double exact = sqrt(ffd_dist2_point_segment(p, a, b));
        double brute = brute_segment(p, a, b, n);
        CHECK(exact <= brute + 1e-12);
        CHECK(brute - exact <= dist3(a, b) / n + 1e-12);
    }
    /* a zero-length segment is a point */
    double a[3] = {1, 2, 3}, p[3] = {2, 2, 3};
    CHECK_NEAR(ffd_dist2_point_segment(p, a, a), 1, 0);
}

static void test_distance_triangle(void)
{
    for (int t = 0; t < 240; t++) {
        double a[3], b[3], c[3], p[3];
        for (int k = 0; k < 3; k++) {
            a[k] = rnd(-1, 1);
            b[k] = rnd(-1, 1);
            c[k] = rnd(-1, 1);
            p[k] = rnd(-1.5, 1.5);
        }
        switch (t % 8) {
        case 1: /* a needle: two vertices 1e-7 apart */
            for (int k = 0; k < 3; k++)
                c[k] = b[k] + 1e-7 * rnd(-1, 1);
            break;
        case 2: /* a cap: c a hair off the segment ab */
            for (int k = 0; k < 3; k++)
                c[k] = a[k] + 0.3 * (b[k] - a[k]) + 1e-9 * rnd(-1, 1);
            break;
        case 3: /* exactly collinear (c between a and b) */
            for (int k = 0; k < 3; k++)
                c[k] = a[k] + 0.5 * (b[k] - a[k]);
            break;
        case 4: /* two coincident vertices */
            memcpy(c, a, sizeof c);
            break;
        case 5: /* a sliver: c just beyond b */
            for (int k = 0; k < 3; k++)
                c[k] = a[k] + 1.2 * (b[k] - a[k]) + 1e-5 * rnd(-1, 1);
            break;
        case 6: /* p just above the interior */
            for (int k = 0; k < 3; k++)
                p[k] = 0.2 * a[k] + 0.3 * b[k] + 0.5 * c[k] + 1e-3 * rnd(-1, 1);
            break;
        default:
            break;
        }
        int n = 400;
        double exact = sqrt(ffd_dist2_point_triangle(p, a, b, c));
        double brute = brute_triangle(p, a, b, c, n);
        double lmax = fmax(dist3(a, b), fmax(dist3(b, c), dist3(c, a)));
        /* brute samples the triangle: never closer than the exact distance,
         * and within the grid's spacing of it */
        CHECK(exact <= brute + 1e-12);
        CHECK(brute - exact <= 2 * lmax / n + 1e-12);
        /* the same for every vertex order */
        double e2 = sqrt(ffd_dist2_point_triangle(p, c, a, b));
        double e3 = sqrt(ffd_dist2_point_triangle(p, b, a, c));
        CHECK_NEAR(e2, exact, 1e-12);
        CHECK_NEAR(e3, exact, 1e-12);
    }
    /* known values: above the interior, beyond an edge, beyond a vertex */
    double a[3] = {0, 0, 0}, b[3] = {2, 0, 0}, c[3] = {0, 2, 0};
    double p1[3] = {0.5, 0.5, 3}, p2[3] = {1, -1, 1}, p3[3] = {-1, -1, 0};
    CHECK_NEAR(ffd_dist2_point_triangle(p1, a, b, c), 9, 1e-14);
    CHECK_NEAR(ffd_dist2_point_triangle(p2, a, b, c), 2, 1e-14);
    CHECK_NEAR(ffd_dist2_point_triangle(p3, a, b, c), 2, 1e-14);
}

/* A cube [-h, h]^3 as 6 quads, fan-triangulated (outward orientation). */
static const double cube_v[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                    {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
static const uint32_t cube_quads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                          {2, 3, 7, 6}, {1, 2, 6, 5}, {0, 4, 7, 3}};

static void make_cube(double h, double *v, uint32_t *tris)
{
    for (int i = 0; i < 8; i++)
        for (int k = 0; k < 3; k++)
            v[3 * i + k] = h * cube_v[i][k];
    for (int f = 0; f < 6; f++) {
        const uint32_t *q = cube_quads[f];
        uint32_t t[6] = {q[0], q[1], q[2], q[0], q[2], q[3]};
        memcpy(tris + 6 * f, t, sizeof t);
    }
}

static double box_sdf(const double x[3], double h)
{
    double q[3], out = 0, in = -INFINITY;
    for (int k = 0; k < 3; k++) {
        q[k] = fabs(x[k]) - h;
        out += q[k] > 0 ? q[k] * q[k] : 0;
        in = fmax(in, q[k]);
    }
    return out > 0 ? sqrt(out) : in;
}

/* Generalized winding number of a closed oriented triangle mesh
 * (Van Oosterom & Strackee solid angles): ~1 inside, ~0 outside. */
static double winding(const double *v, const uint32_t *tris, size_t nt, const double p[3])
{
    double w = 0;
    for (size_t t = 0; t < nt; t++) {
        double a[3], b[3], c[3];
        for (int k = 0; k < 3; k++) {
            a[k] = v[3 * tris[3 * t] + (size_t)k] - p[k];
            b[k] = v[3 * tris[3 * t + 1] + (size_t)k] - p[k];
            c[k] = v[3 * tris[3 * t + 2] + (size_t)k] - p[k];
        }
        double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        double lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
        double lc = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        double det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                     a[2] * (b[0] * c[1] - b[1] * c[0]);
        double ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        double bc = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
        double ca = c[0] * a[0] + c[1] * a[1] + c[2] * a[2];
        w += 2 * atan2(det, la * lb * lc + ab * lc + bc * la + ca * lb);
    }
    return w / (4 * 3.14159265358979323846);
}

static void test_distance_polyhedron_cube(void)
{
    double v[24];
    uint32_t tris[36];
    make_cube(1, v, tris);
    ffd_gffd_geometry g = {FFD_GFFD_POLYHEDRON, 8, v, 12, tris, 1};
    for (int t = 0; t < 400; t++) {
        double x[3];
        for (int k = 0; k < 3; k++)
            x[k] = t < 200 ? rnd(-0.999, 0.999) : rnd(-3, 3);
        if (t % 25 == 0) /* on symmetry planes and diagonals: rays may graze edges */
            x[1] = x[0];
        if (t % 50 == 0)
            x[2] = x[0];
        if (t == 0)
            x[0] = x[1] = x[2] = 0;
        CHECK_NEAR(ffd_gffd_geometry_distance(&g, x), box_sdf(x, 1), 1e-14);
    }
    /* on the surface and at vertices: zero */
    double on[3] = {1, 0.3, -0.2}, corner[3] = {1, 1, 1};
    CHECK(ffd_gffd_geometry_distance(&g, on) == 0);
    CHECK(ffd_gffd_geometry_distance(&g, corner) == 0);
    /* the patch (same triangles) is unsigned */
    g.kind = FFD_GFFD_PATCH;
    double in[3] = {0.2, 0.1, 0};
    CHECK_NEAR(ffd_gffd_geometry_distance(&g, in), 0.8, 1e-15);
}

static void test_distance_polyhedron_bunny(void)
{
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read(FFD_DATA_DIR "/bunny.obj", &mesh, &err));
    if (!mesh)
        return;
    size_t nv = ffd_mesh_vertex_count(mesh), nf = ffd_mesh_face_count(mesh);
    const uint32_t *off = ffd_mesh_face_offsets(mesh), *idx = ffd_mesh_face_indices(mesh);
    size_t nt = 0;
    for (size_t f = 0; f < nf; f++)
        nt += off[f + 1] - off[f] - 2;
    uint32_t *tris = malloc(3 * nt * sizeof *tris);
    size_t t = 0;
    for (size_t f = 0; f < nf; f++)
        for (uint32_t k = off[f] + 1; k + 1 < off[f + 1]; k++, t++) {
            tris[3 * t] = idx[off[f]];
            tris[3 * t + 1] = idx[k];
            tris[3 * t + 2] = idx[k + 1];
        }
    double *v = (double *)ffd_mesh_positions(mesh);
    ffd_gffd_geometry g = {FFD_GFFD_POLYHEDRON, nv, v, nt, tris, 1};
    double lo[3], hi[3], mean[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++)
        lo[k] = hi[k] = v[k];
    for (size_t i = 0; i < nv; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], v[3 * i + (size_t)k]);
            hi[k] = fmax(hi[k], v[3 * i + (size_t)k]);
            mean[k] += v[3 * i + (size_t)k] / (double)nv;
        }
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    /* the vertex centroid is inside; far points are outside */
    CHECK(ffd_gffd_geometry_distance(&g, mean) < 0);
    double far[3] = {hi[0] + diag, mean[1], mean[2]};
    CHECK(ffd_gffd_geometry_distance(&g, far) > 0);
    /* random points in the box: the sign agrees with the winding number */
    double wsign = winding(v, tris, nt, mean) > 0 ? 1 : -1; /* the mesh's orientation */
    int inside = 0, disagree = 0;
    for (int s = 0; s < 300; s++) {
        double x[3];
        for (int k = 0; k < 3; k++)
            x[k] = rnd(lo[k], hi[k]);
        double d = ffd_gffd_geometry_distance(&g, x);
        if (fabs(d) < 1e-6 * diag)
            continue;
        int in_w = wsign * winding(v, tris, nt, x) > 0.5;
        inside += in_w;
        disagree += in_w != (d < 0);
    }
    CHECK(inside > 20);
    CHECK(disagree == 0);
    free(tris);
    ffd_mesh_destroy(mesh);
}

/* ============================== samples ============================== */

static double seg_dist(const double x[3], const double a[3], const double b[3])
{
    return sqrt(ffd_dist2_point_segment(x, a, b));
}

static void check_values(const ffd_gffd_geometry *g, const double *s, const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        CHECK(v[i] == ffd_gffd_geometry_distance(g, s + 3 * i));
}

/* no two samples closer than tol */
static int all_distinct(const double *s, size_t n, double tol)
{
    for (size_t i = 0; i < n; i++)
        for (size_t j = i + 1; j < n; j++)
            if (dist3(s + 3 * i, s + 3 * j) <= tol)
                return 0;
    return 1;
}

static void test_samples_point(void)
{
    double p[3] = {0.5, -1, 2};
    ffd_gffd_geometry g = {FFD_GFFD_POINT, 1, p, 0, NULL, 0.9};
    double *s, *v;
    size_t n;
    ffd_error err = {{0}};
    CHECK_OK(ffd_gffd_samples(&g, 4000, &s, &v, &n, &err));
    CHECK(n == 57);
    check_values(&g, s, v, n);
    CHECK(dist3(s, p) == 0);
    /* 14 per shell at r/3, 2r/3, r, 4r/3 */
    for (int k = 1; k <= 4; k++) {
        int c = 0;
        for (size_t i = 0; i < n; i++)
            c += fabs(v[i] - k * 0.3) < 1e-12;
        CHECK(c == 14);
    }
    CHECK(all_distinct(s, n, 1e-3));
    ffd_free(s);
    ffd_free(v);
    /* the limit */
    CHECK(ffd_gffd_samples(&g, 56, &s, &v, &n, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "57") && strstr(err.message, "56"));
    CHECK(s == NULL && v == NULL && n == 0);
    CHECK_OK(ffd_gffd_samples(&g, 57, &s, &v, &n, &err));
    ffd_free(s);
    ffd_free(v);
}

static void test_samples_polyline(void)
{
    /* a straight segment of length 3, r = 1: stations at most 0.5 apart -> 7 */
    double p[6] = {1, 1, 1, 1 + 3 / sqrt(3.0), 1 + 3 / sqrt(3.0), 1 + 3 / sqrt(3.0)};
    ffd_gffd_geometry g = {FFD_GFFD_POLYLINE, 2, p, 0, NULL, 1};
    double *s, *v;
    size_t n;
    ffd_error err = {{0}};
    CHECK_OK(ffd_gffd_samples(&g, 4000, &s, &v, &n, &err));
    CHECK(n == 7 * 25 + 2 * 20);
    check_values(&g, s, v, n);
    for (size_t i = 0; i < n; i++)
        CHECK_NEAR(v[i], seg_dist(s + 3 * i, p, p + 3), 1e-15);
    CHECK(all_distinct(s, n, 1e-3));
    /* stations (value 0): 7, evenly spaced */
    int st = 0;
    for (size_t i = 0; i < n; i++)
        st += v[i] < 1e-12;
    CHECK(st == 7);
    ffd_free(s);
    ffd_free(v);
    /* r = 0.7: 3 / 0.35 = 8.57 -> 9 pieces, 10 stations */
    g.radius = 0.7;
    CHECK_OK(ffd_gffd_samples(&g, 4000, &s, &v, &n, &err));
    CHECK(n == 10 * 25 + 40);
    ffd_free(s);
    ffd_free(v);
    /* a bent polyline: stations 3 + 2 interior + 1 interior */
    double q[9] = {0, 0, 0, 1, 0, 0, 1, 0.6, 0};
    ffd_gffd_geometry h = {FFD_GFFD_POLYLINE, 3, q, 0, NULL, 1};
    CHECK_OK(ffd_gffd_samples(&h, 4000, &s, &v, &n, &err));
    CHECK(n == (3 + 1 + 1) * 25 + 40);
    check_values(&h, s, v, n);
    ffd_free(s);
    ffd_free(v);
    /* a huge polyline is refused before its samples are made */
    double big[6] = {0, 0, 0, 1e9, 0, 0};
    ffd_gffd_geometry hb = {FFD_GFFD_POLYLINE, 2, big, 0, NULL, 1};
    CHECK(ffd_gffd_samples(&hb, 4000, &s, &v, &n, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "4000") != NULL);
    CHECK(ffd_gffd_samples(&hb, 0, &s, &v, &n, &err) == FFD_ERR_NOMEM); /* no limit */
    /* no limit: a few thousand samples are fine */
    g.radius = 0.1;
    CHECK_OK(ffd_gffd_samples(&g, 0, &s, &v, &n, &err));
    CHECK(n == 61 * 25 + 40);
    ffd_free(s);
    ffd_free(v);
}

static void test_samples_merge(void)
{
    /* there and back again: the second segment's samples coincide with the
     * first's (and the two ends' caps), up to rounding */
    double p[9] = {0.1, 0.2, 0.3, 2.1, 1.2, -0.7, 0.1, 0.2, 0.3};
    double len = sqrt(4 + 1 + 1);
    int pieces = (int)ceil(len / 0.5);
    ffd_gffd_geometry g = {FFD_GFFD_POLYLINE, 3, p, 0, NULL, 1};
    double *s, *v;
    size_t n;
    ffd_error err = {{0}};
    CHECK_OK(ffd_gffd_samples(&g, 4000, &s, &v, &n, &err));
    CHECK(n == (size_t)(pieces + 1) * 25 + 20);
    CHECK(all_distinct(s, n, 1e-9));
    check_values(&g, s, v, n);
    /* the first is kept: the samples are those of the first segment */
    ffd_gffd_geometry g1 = {FFD_GFFD_POLYLINE, 2, p, 0, NULL, 1};
    double *s1, *v1;
    size_t n1;
    CHECK_OK(ffd_gffd_samples(&g1, 4000, &s1, &v1, &n1, &err));
    CHECK(n1 == n + 20);
    /* every sample of the single segment but the far end cap is in the merged set, bitwise */
    size_t found = 0;
    for (size_t i = 0; i < n1; i++)
        for (size_t j = 0; j < n; j++)
            if (memcmp(s1 + 3 * i, s + 3 * j, 3 * sizeof *s) == 0) {
                found++;
                break;
            }
    CHECK(found == n);
    ffd_free(s1);
    ffd_free(v1);
    /* the limit counts merged samples */
    CHECK_OK(ffd_gffd_samples(&g, n, &s1, &v1, &n1, &err));
    ffd_free(s1);
    ffd_free(v1);
    CHECK(ffd_gffd_samples(&g, n - 1, &s1, &v1, &n1, &err) == FFD_ERR_INVALID);
    ffd_free(s);
    ffd_free(v);
}

static void test_samples_cube(void)
{
    double cv[24];
    uint32_t tris[36];
    make_cube(1, cv, tris);
    ffd_gffd_geometry g = {FFD_GFFD_POLYHEDRON, 8, cv, 12, tris, 1};
    double *s, *v;
    size_t n;
    ffd_error err = {{0}};
    g.radius = 0.9;
    CHECK_OK(ffd_gffd_samples(&g, 4000, &s, &v, &n, &err));
    /* 8 vertices and 12 triangle centroids (every face diagonal > r/2), each
     * with 2 normal directions x 4 shells */
    CHECK(n == 8 * 9 + 12 * 9);
    check_values(&g, s, v, n);
    int neg = 0, zero = 0;
    for (size_t i = 0; i < n; i++) {
        CHECK_NEAR(v[i], box_sdf(s + 3 * i, 1), 1e-14);
        neg += v[i] < 0;
        zero += v[i] == 0;
    }
    CHECK(neg == 20 * 4 && zero == 20);
    /* the angle-weighted vertex normal of a corner is its diagonal,
     * whatever the triangulation */
    for (size_t i = 0; i < n; i++) {
        double x = fabs(s[3 * i]), y = fabs(s[3 * i + 1]), z = fabs(s[3 * i + 2]);
        if (x > 1 + 1e-9 && y > 1 + 1e-9 && z > 1 + 1e-9) /* outside near a corner */
            CHECK(fabs(x - y) < 1e-12 && fabs(y - z) < 1e-12);
    }
    ffd_free(s);
    ffd_free(v);
    /* r = 1: inward samples of opposite (and of adjacent) faces' triangles
     * meet (e.g. depth 2/3 from z = 1 and 4/3 from z = -1): 20 merged */
    g.radius = 1;
    CHECK_OK(ffd_gffd_samples(&g, 4000, &s, &v, &n, &err));
    CHECK(n == 180 - 20);
    CHECK(all_distinct(s, n, 1e-9));
    check_values(&g, s, v, n);
    ffd_free(s);
    ffd_free(v);
    /* small faces (longest edge <= r/2): vertices only */
    g.radius = 2 * 2 * sqrt(2.0) + 0.1;
    CHECK_OK(ffd_gffd_samples(&g, 4000, &s, &v, &n, &err));
    CHECK(n == 8 * 9);
    check_values(&g, s, v, n);
    ffd_free(s);
    ffd_free(v);
}

/* A closed prism over a regular k-gon (radius 1, z in [-1, 1]): sides as
 * quads, caps as fans, all triangulated, outward. */
static size_t make_prism(int k, double *v, uint32_t *tris)
{
    for (int i = 0; i < k; i++) {
        double a = 2 * 3.14159265358979323846 * i / k;
        double p[6] = {cos(a), sin(a), -1, cos(a), sin(a), 1};
        memcpy(v + 3 * i, p, 3 * sizeof *v);
        memcpy(v + 3 * (k + i), p + 3, 3 * sizeof *v);
    }
    size_t t = 0;
    for (int i = 0; i < k; i++) {
        uint32_t a = (uint32_t)i, b = (uint32_t)((i + 1) % k), c = b + (uint32_t)k,
                 d = a + (uint32_t)k;
        uint32_t q[6] = {a, b, c, a, c, d};
        memcpy(tris + 3 * t, q, sizeof q);
        t += 2;
    }
    for (int i = 1; i + 1 < k; i++) {
        uint32_t bot[3] = {0, (uint32_t)(i + 1), (uint32_t)i};
        uint32_t top[3] = {(uint32_t)k, (uint32_t)(k + i), (uint32_t)(k + i + 1)};
        memcpy(tris + 3 * t++, bot, sizeof bot);
        memcpy(tris + 3 * t++, top, sizeof top);
    }
    return t;
}

static void test_samples_prism(void)
{
    enum { K = 48 };
    double v[3 * 2 * K];
    uint32_t tris[3 * (2 * K + 2 * (K - 2))];
    size_t nt = make_prism(K, v, tris);
    ffd_gffd_geometry g = {FFD_GFFD_POLYHEDRON, 2 * K, v, nt, tris, 0.5};
    double *s, *val;
    size_t n;
    ffd_error err = {{0}};
    CHECK_OK(ffd_gffd_samples(&g, 4000, &s, &val, &n, &err));
    /* 96 vertices and 188 triangles, all wider than r/2, x 9 (no two meet) */
    CHECK(n == (2 * K + nt) * 9);
    check_values(&g, s, val, n); /* (computed in parallel there, serially here) */
    size_t neg = 0;
    for (size_t i = 0; i < n; i++) {
        double rho = sqrt(s[3 * i] * s[3 * i] + s[3 * i + 1] * s[3 * i + 1]);
        /* inside the inscribed cylinder: negative; outside the circumscribed one: positive */
        if (rho < cos(3.14159265358979323846 / K) - 1e-9 && fabs(s[3 * i + 2]) < 1 - 1e-9)
            CHECK(val[i] < 0);
        if (rho > 1 + 1e-9 || fabs(s[3 * i + 2]) > 1 + 1e-9)
            CHECK(val[i] > 0);
        neg += val[i] < -1e-12; /* (a centroid station may be a rounding error off 0) */
        CHECK(i % 9 != 0 || fabs(val[i]) < 1e-15);
    }
    CHECK(neg == 4 * (2 * K + nt));
    ffd_free(s);
    ffd_free(val);
    /* too many for the limit */
    CHECK(ffd_gffd_samples(&g, 1000, &s, &val, &n, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "1000") != NULL);
}

static void test_samples_patch(void)
{
    /* a 2 x 2 square in z = 0 as two triangles: 4 boundary vertices */
    double p[12] = {0, 0, 0, 2, 0, 0, 2, 2, 0, 0, 2, 0};
    uint32_t tris[6] = {0, 1, 2, 0, 2, 3};
    ffd_gffd_geometry g = {FFD_GFFD_PATCH, 4, p, 2, tris, 1};
    double *s, *v;
    size_t n;
    ffd_error err = {{0}};
    CHECK_OK(ffd_gffd_samples(&g, 4000, &s, &v, &n, &err));
    CHECK(n == 4 * (1 + 8 + 4) + 2 * 9);
    check_values(&g, s, v, n);
    /* the boundary samples leave along the corner's outward diagonal */
    int out = 0;
    for (size_t i = 0; i < n; i++)
        if (s[3 * i + 2] == 0 && v[i] > 0) {
            out++;
            double dx = s[3 * i] - 1, dy = s[3 * i + 1] - 1;
            CHECK_NEAR(fabs(dx), fabs(dy), 1e-12);
        }
    CHECK(out == 16);
    ffd_free(s);
    ffd_free(v);
}

/* ================= the fitted fields interpolate their samples ================= */

static void fit_samples(const ffd_gffd_geometry *g, ffd_rbf *r, int *regularised)
{
    double *s, *v;
    size_t n;
    ffd_error err = {{0}};
    memset(r, 0, sizeof *r);
    CHECK_OK(ffd_gffd_samples(g, 4000, &s, &v, &n, &err));
    ffd_rbf_factor f;
    CHECK_OK(ffd_rbf_factor_create(s, n, &f, &err));
    CHECK_OK(ffd_rbf_fit(&f, v, 1, r, &err));
    *regularised = f.regularised;
    CHECK_NEAR(interp_error(r, s, n, v, 1), 0, 1e-9 * fmax(maxabs(v, n), g->radius));
    ffd_rbf_factor_free(&f);
    ffd_free(s);
    ffd_free(v);
}

static void test_fields_interpolate_samples(void)
{
    double pt[3] = {3, -2, 1};
    double line[12] = {0, 0, 0, 1, 0.5, 0, 1.5, 1.5, 0.5, 1, 2.5, 1};
    double sq[12] = {0, 0, 0, 2, 0, 0, 2, 2, 0.3, 0, 2, 0};
    uint32_t sqt[6] = {0, 1, 2, 0, 2, 3};
    double cv[24];
    uint32_t ct[36];
    make_cube(0.5, cv, ct);
    ffd_gffd_geometry gs[4] = {
        {FFD_GFFD_POINT, 1, pt, 0, NULL, 0.8},
        {FFD_GFFD_POLYLINE, 4, line, 0, NULL, 0.6},
        {FFD_GFFD_PATCH, 4, sq, 2, sqt, 0.7},
        {FFD_GFFD_POLYHEDRON, 8, cv, 12, ct, 0.4},
    };
    for (int k = 0; k < 4; k++) {
        ffd_rbf r;
        int reg;
        fit_samples(&gs[k], &r, &reg);
        CHECK(reg == 0);
        ffd_rbf_free(&r);
    }
}

/* =================== how well the field approximates distance =================== */

/* max |f(x) - d(x)| / r over random x with d(x) <= r (and, second, with
 * d(x) in [r/3, r]: away from the skeleton, where the distance has a kink
 * that no smooth interpolant follows) */
static void field_quality(const ffd_gffd_geometry *g, double *all, double *away)
{
    ffd_rbf r;
    int reg;
    fit_samples(g, &r, &reg);
    double lo[3], hi[3], rad = g->radius;
    for (int k = 0; k < 3; k++) {
        lo[k] = hi[k] = g->vertices[k];
        for (size_t i = 1; i < g->vertex_count; i++) {
            lo[k] = fmin(lo[k], g->vertices[3 * i + (size_t)k]);
            hi[k] = fmax(hi[k], g->vertices[3 * i + (size_t)k]);
        }
    }
    *all = *away = 0;
    int got = 0;
    while (got < 20000) {
        double x[3], f;
        for (int k = 0; k < 3; k++)
            x[k] = rnd(lo[k] - rad, hi[k] + rad);
        double d = ffd_gffd_geometry_distance(g, x);
        if (d > rad)
            continue;
        got++;
        ffd_rbf_eval(&r, x, &f, NULL);
        double e = fabs(f - d) / rad;
        *all = fmax(*all, e);
        if (d >= rad / 3)
            *away = fmax(*away, e);
    }
    ffd_rbf_free(&r);
}

static void test_field_quality(void)
{
    /* Measured (20000 random points within distance r, this seed):
     *   point:             max |f - d| / r = 0.048 overall, 0.011 for d in [r/3, r]
     *   segment (len 4r):  max |f - d| / r = 0.075 overall, 0.026 for d in [r/3, r]
     * The worst errors sit next to the skeleton (d < r/3), where the distance
     * has its kink, and near a segment's ends. Elsewhere, measured the same
     * way: segments of 1r to 16r give 0.072-0.075 overall; a segment of r/2,
     * 0.091; an L-shaped polyline (2r + 2r), 0.075 within r/3 but 0.066 in
     * [2r/3, r] inside the bend. Patches and polyhedra are good only when
     * their triangles are small against r (a 3r square as 2 triangles: 0.43;
     * as 8 x 8 quads: 0.07), since the rules place stations at vertices and
     * triangle centroids only. */
    check_rng_state = 0x9e3779b97f4a7c15ull;
    double p[3] = {0.3, 0.2, -0.1};
    ffd_gffd_geometry gp = {FFD_GFFD_POINT, 1, p, 0, NULL, 1.5};
    double all, away;
    field_quality(&gp, &all, &away);
    printf("     point field:   max |f - d| / r = %.4f (%.4f for d >= r/3)\n", all, away);
    CHECK(all < 0.1);
    CHECK(away < 0.04);
    double s[6] = {0, 0, 0, 2, 1, 2}; /* length 3 */
    ffd_gffd_geometry gs = {FFD_GFFD_POLYLINE, 2, s, 0, NULL, 0.75};
    field_quality(&gs, &all, &away);
    printf("     segment field: max |f - d| / r = %.4f (%.4f for d >= r/3)\n", all, away);
    CHECK(all < 0.1);
    CHECK(away < 0.04);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"rbf_interpolates_random", test_rbf_interpolates_random},
        {"rbf_matches_dense_solve", test_rbf_matches_dense_solve},
        {"rbf_gradient", test_rbf_gradient},
        {"rbf_eval_lane_order", test_rbf_eval_lane_order},
        {"rbf_scale_invariance", test_rbf_scale_invariance},
        {"rbf_regularised", test_rbf_regularised},
        {"rbf_bad_input", test_rbf_bad_input},
        {"rbf_failing_allocations", test_rbf_failing_allocations},
        {"distance_segment", test_distance_segment},
        {"distance_triangle", test_distance_triangle},
        {"distance_polyhedron_cube", test_distance_polyhedron_cube},
        {"distance_polyhedron_bunny", test_distance_polyhedron_bunny},
        {"samples_point", test_samples_point},
        {"samples_polyline", test_samples_polyline},
        {"samples_merge", test_samples_merge},
        {"samples_cube", test_samples_cube},
        {"samples_prism", test_samples_prism},
        {"samples_patch", test_samples_patch},
        {"fields_interpolate_samples", test_fields_interpolate_samples},
        {"field_quality", test_field_quality},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
