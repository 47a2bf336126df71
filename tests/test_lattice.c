/* Tests of the lattice FFD (Bernstein and cubic B-spline) and direct manipulation. */
#include "ffd.h"
#include "check.h"
#include "lattice/lattice.h"

#include <omp.h>
#if defined(__x86_64__)
#include <cpuid.h>
#endif

static const ffd_box rotated_box = {
    {-1.0, 0.5, 2.0},
    {{2.0, 0.4, 0.1}, {-0.3, 1.5, 0.2}, {0.2, -0.1, 3.0}},
};

static void box_point(const ffd_box *b, double s, double t, double u, double x[3])
{
    for (int c = 0; c < 3; c++)
        x[c] = b->origin[c] + s * b->axes[0][c] + t * b->axes[1][c] + u * b->axes[2][c];
}

static double *random_inside(const ffd_box *b, size_t n)
{
    double *p = malloc(n * 3 * sizeof *p);
    for (size_t i = 0; i < n; i++)
        box_point(b, check_rand01(), check_rand01(), check_rand01(), p + 3 * i);
    return p;
}

static ffd_lattice *make(ffd_basis basis, const ffd_box *box, uint32_t l, uint32_t m, uint32_t n)
{
    uint32_t res[3] = {l, m, n};
    ffd_lattice *lat = NULL;
    CHECK_OK(ffd_lattice_create(basis, box, res, &lat, NULL));
    return lat;
}

static void perturb(ffd_lattice *lat, double amount)
{
    size_t n = ffd_lattice_control_count(lat);
    double *d = malloc(n * 3 * sizeof *d);
    for (size_t i = 0; i < 3 * n; i++)
        d[i] = amount * (check_rand01() - 0.5);
    CHECK_OK(ffd_lattice_add(lat, d, NULL));
    free(d);
}

/* ---- identity at rest ---- */
static void test_identity_at_rest(void)
{
    const uint32_t R[][3] = {{2, 2, 2}, {3, 4, 5}, {5, 5, 5}, {8, 3, 6}, {4, 7, 2}};
    for (int basis = 0; basis < 2; basis++)
        for (size_t r = 0; r < sizeof R / sizeof R[0]; r++) {
            ffd_lattice *lat = make((ffd_basis)basis, &rotated_box, R[r][0], R[r][1], R[r][2]);
            size_t n = 2000;
            double *p = random_inside(&rotated_box, n);
            /* corners and faces too */
            box_point(&rotated_box, 0, 0, 0, p);
            box_point(&rotated_box, 1, 1, 1, p + 3);
            box_point(&rotated_box, 1, 0.3, 0, p + 6);
            ffd_lattice_binding *b = NULL;
            CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL));
            CHECK(ffd_lattice_binding_inside_count(b) == n);
            double *q = malloc(n * 3 * sizeof *q);
            CHECK_OK(ffd_lattice_eval(lat, b, q, NULL));
            double worst = 0;
            for (size_t i = 0; i < 3 * n; i++)
                worst = fmax(worst, fabs(q[i] - p[i]));
            /* exact: evaluation adds the (zero) displacement sum to the point */
            CHECK(worst == 0.0);
            free(q);
            free(p);
            ffd_lattice_binding_destroy(b);
            ffd_lattice_destroy(lat);
        }
}

/* ---- B-spline against de Boor's algorithm on the tripled-border net ---- */
static void de_boor_1d(int nctrl, const double *ctrl, double S, double *out)
{
    /* uniform knots 0..nctrl+3; segment sigma of ours is knot span [sigma+3, sigma+4) */
    double x = S + 3.0;
    int span = (int)floor(x);
    if (span > nctrl - 1)
        span = nctrl - 1;
    double d[4];
    for (int j = 0; j < 4; j++)
        d[j] = ctrl[span - 3 + j];
    for (int r = 1; r <= 3; r++)
        for (int j = 3; j >= r; j--) {
            int i = span - 3 + j;
            double alpha = (x - i) / (double)(3 + 1 - r);
            d[j] = (1.0 - alpha) * d[j - 1] + alpha * d[j];
        }
    *out = d[3];
}

static void test_bspline_matches_de_boor(void)
{
    ffd_lattice *lat = make(FFD_BASIS_BSPLINE, &rotated_box, 5, 4, 6);
    perturb(lat, 1.0);
    uint32_t res[3];
    ffd_lattice_resolution(lat, res);
    const double *P = ffd_lattice_control_points(lat);
    uint32_t e[3] = {res[0] + 4, res[1] + 4, res[2] + 4};
    for (int trial = 0; trial < 200; trial++) {
        double S[3] = {check_rand01() * (res[0] + 1), check_rand01() * (res[1] + 1),
                       check_rand01() * (res[2] + 1)};
        if (trial == 0)
            S[0] = 0, S[1] = res[1] + 1, S[2] = 2;
        double q[3];
        ffd_lattice_eval_params(lat, S, q);
        for (int c = 0; c < 3; c++) {
            /* tensor de Boor: reduce u, then t, then s over the expanded net (tie = clamp) */
            double *su = malloc(sizeof(double) * e[0] * e[1]);
            for (uint32_t a = 0; a < e[0]; a++)
                for (uint32_t b = 0; b < e[1]; b++) {
                    double col[64];
                    for (uint32_t k = 0; k < e[2]; k++) {
                        uint32_t i = ffd_bspline_tie(a, res[0]), j = ffd_bspline_tie(b, res[1]),
                                 kk = ffd_bspline_tie(k, res[2]);
                        col[k] = P[3 * ((i * res[1] + j) * res[2] + kk) + c];
                    }
                    de_boor_1d((int)e[2], col, S[2], &su[a * e[1] + b]);
                }
            double *st = malloc(sizeof(double) * e[0]);
            for (uint32_t a = 0; a < e[0]; a++)
                de_boor_1d((int)e[1], su + a * e[1], S[1], &st[a]);
            double ref;
            de_boor_1d((int)e[0], st, S[0], &ref);
            CHECK_NEAR(q[c], ref, 1e-12);
            free(su);
            free(st);
        }
    }
    ffd_lattice_destroy(lat);
}

/* ---- Bernstein against explicit sums with binomial coefficients ---- */
static double binom(int n, int k)
{
    double r = 1;
    for (int i = 1; i <= k; i++)
        r = r * (n - k + i) / i;
    return r;
}

static void test_bernstein_matches_explicit_sum(void)
{
    ffd_lattice *lat = make(FFD_BASIS_BERNSTEIN, &rotated_box, 4, 6, 3);
    perturb(lat, 1.0);
    const double *P = ffd_lattice_control_points(lat);
    for (int trial = 0; trial < 200; trial++) {
        double S[3] = {check_rand01(), check_rand01(), check_rand01()};
        if (trial < 5) /* outside [0,1]: the polynomials continue */
            S[trial % 3] = -0.3 + 1.6 * check_rand01();
        double q[3], ref[3] = {0, 0, 0};
        ffd_lattice_eval_params(lat, S, q);
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 6; j++)
                for (int k = 0; k < 3; k++) {
                    double w = binom(3, i) * pow(S[0], i) * pow(1 - S[0], 3 - i) * binom(5, j) *
                               pow(S[1], j) * pow(1 - S[1], 5 - j) * binom(2, k) * pow(S[2], k) *
                               pow(1 - S[2], 2 - k);
                    for (int c = 0; c < 3; c++)
                        ref[c] += w * P[3 * ((i * 6 + j) * 3 + k) + c];
                }
        for (int c = 0; c < 3; c++)
            CHECK_NEAR(q[c], ref[c], 1e-12);
    }
    ffd_lattice_destroy(lat);
}

/* ---- partition of unity of the rows (with S applied) ---- */
static void test_partition_of_unity(void)
{
    for (int basis = 0; basis < 2; basis++) {
        ffd_lattice *lat = make((ffd_basis)basis, &rotated_box, 5, 3, 4);
        size_t n = 500;
        double *p = random_inside(&rotated_box, n);
        ffd_lattice_binding *b = NULL;
        CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL));
        ffd_linear_map map;
        ffd_lattice_linear_map(lat, b, &map);
        uint32_t cols[256];
        double w[256];
        for (size_t i = 0; i < n; i++) {
            size_t k = map.row(map.self, i, cols, w);
            double sum = 0;
            for (size_t e = 0; e < k; e++) {
                sum += w[e];
                CHECK(w[e] >= -1e-15);
                CHECK(cols[e] < map.column_count);
            }
            CHECK_NEAR(sum, 1.0, 1e-14);
        }
        free(p);
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
    }
}

/* ---- inversion round trip, and the outer segments against Cardano's formula ---- */
static double cardano_root_in_unit(const double c[4], double x)
{
    /* c3 t^3 + c2 t^2 + c1 t + (c0 - x) = 0, real root in [0,1] */
    double a = c[3], b = c[2], cc = c[1], d = c[0] - x;
    if (fabs(a) < 1e-300) { /* quadratic or linear */
        if (fabs(b) < 1e-300)
            return -d / cc;
        double disc = sqrt(fmax(cc * cc - 4 * b * d, 0));
        double r1 = (-cc + disc) / (2 * b), r2 = (-cc - disc) / (2 * b);
        return (r1 >= -1e-9 && r1 <= 1 + 1e-9) ? r1 : r2;
    }
    double p = (3 * a * cc - b * b) / (3 * a * a);
    double q = (2 * b * b * b - 9 * a * b * cc + 27 * a * a * d) / (27 * a * a * a);
    double shift = -b / (3 * a), best = NAN;
    double disc = q * q / 4 + p * p * p / 27;
    double roots[3];
    int nr = 0;
    if (disc > 0) {
        double sq = sqrt(disc);
        roots[nr++] = cbrt(-q / 2 + sq) + cbrt(-q / 2 - sq) + shift;
    } else {
        double r = sqrt(-p / 3), phi = acos(fmax(-1, fmin(1, -q / (2 * r * r * r))));
        for (int k = 0; k < 3; k++)
            roots[nr++] = 2 * r * cos((phi - 2 * 3.14159265358979323846 * k) / 3) + shift;
    }
    for (int k = 0; k < nr; k++)
        if (roots[k] >= -1e-7 && roots[k] <= 1 + 1e-7)
            best = roots[k];
    return best;
}

static void test_inversion_round_trip(void)
{
    for (uint32_t res = 2; res <= 9; res++) {
        double kv_dummy = 0;
        (void)kv_dummy;
        double *kv = NULL;
        CHECK(ffd_bspline_rest_knots(res, &kv) == FFD_OK);
        for (int trial = 0; trial < 400; trial++) {
            double x = trial == 0 ? 0.0 : trial == 1 ? 1.0 : check_rand01();
            double S = ffd_bspline_invert(res, kv, x);
            CHECK(S >= 0 && S <= res + 1);
            CHECK_NEAR(ffd_bspline_rest_map(res, S, NULL), x, 1e-14);
            /* the independent closed-form cubic solve agrees */
            uint32_t sigma = S >= res + 1 ? res : (uint32_t)S;
            double c[4], f0 = ffd_bspline_rest_map(res, sigma, NULL);
            double f1 = ffd_bspline_rest_map(res, sigma + 1.0 - 1e-300, NULL);
            (void)f1;
            /* power basis from samples of the segment's cubic */
            double v[4];
            for (int k = 0; k < 4; k++)
                v[k] = ffd_bspline_rest_map(res, sigma + (k == 3 ? 1.0 - 1e-12 : k / 3.0), NULL);
            (void)f0;
            /* Newton-form interpolation through t = 0, 1/3, 2/3, 1 */
            double t[4] = {0, 1.0 / 3, 2.0 / 3, 1.0 - 1e-12};
            double dd[4] = {v[0], v[1], v[2], v[3]};
            for (int j = 1; j < 4; j++)
                for (int i = 3; i >= j; i--)
                    dd[i] = (dd[i] - dd[i - 1]) / (t[i] - t[i - j]);
            /* expand Newton form into power basis */
            c[0] = dd[0] - dd[1] * t[0] + dd[2] * t[0] * t[1] - dd[3] * t[0] * t[1] * t[2];
            c[1] = dd[1] - dd[2] * (t[0] + t[1]) + dd[3] * (t[0] * t[1] + t[0] * t[2] + t[1] * t[2]);
            c[2] = dd[2] - dd[3] * (t[0] + t[1] + t[2]);
            c[3] = dd[3];
            double tc = cardano_root_in_unit(c, x);
            if (isfinite(tc) && x > 0 && x < 1)
                CHECK_NEAR(S - sigma, tc, 1e-6);
        }
        free(kv);
    }
    /* whole lattice: bind, then the rest map of the parameters gives the point back */
    ffd_lattice *lat = make(FFD_BASIS_BSPLINE, &rotated_box, 5, 3, 7);
    size_t n = 3000;
    double *p = random_inside(&rotated_box, n);
    ffd_lattice_binding *b = NULL;
    CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL));
    for (size_t i = 0; i < n; i++) {
        double S[3], x[3];
        CHECK(ffd_lattice_binding_params(b, i, S) == 1);
        ffd_lattice_rest_at(lat, S, x);
        for (int c = 0; c < 3; c++)
            CHECK_NEAR(x[c], p[3 * i + c], 1e-12);
    }
    free(p);
    ffd_lattice_binding_destroy(b);
    ffd_lattice_destroy(lat);
}

/* ---- B-spline locality: a moved control point changes only points in its support ---- */
static void test_bspline_locality(void)
{
    ffd_lattice *lat = make(FFD_BASIS_BSPLINE, &rotated_box, 8, 8, 8);
    size_t n = 5000;
    double *p = random_inside(&rotated_box, n);
    ffd_lattice_binding *b = NULL;
    CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL));
    double *q0 = malloc(3 * n * sizeof *q0), *q1 = malloc(3 * n * sizeof *q1);
    CHECK_OK(ffd_lattice_eval(lat, b, q0, NULL));
    uint32_t idx[3] = {4, 2, 5};
    double d[3] = {0.3, -0.2, 0.5};
    CHECK_OK(ffd_lattice_move(lat, idx, d, NULL));
    CHECK_OK(ffd_lattice_eval(lat, b, q1, NULL));
    ffd_linear_map map;
    ffd_lattice_linear_map(lat, b, &map);
    uint32_t target = (4 * 8 + 2) * 8 + 5, cols[64];
    double w[64];
    size_t moved = 0;
    for (size_t i = 0; i < n; i++) {
        size_t k = map.row(map.self, i, cols, w);
        double wt = 0;
        for (size_t e = 0; e < k; e++)
            if (map.tie[cols[e]] == target)
                wt += w[e];
        int changed = q0[3 * i] != q1[3 * i] || q0[3 * i + 1] != q1[3 * i + 1] ||
                      q0[3 * i + 2] != q1[3 * i + 2];
        if (wt == 0)
            CHECK(!changed);
        else {
            moved++;
            for (int c = 0; c < 3; c++)
                CHECK_NEAR(q1[3 * i + c] - q0[3 * i + c], wt * d[c], 1e-13);
        }
    }
    CHECK(moved > 0 && moved < n / 2);
    free(p);
    free(q0);
    free(q1);
    ffd_lattice_binding_destroy(b);
    ffd_lattice_destroy(lat);
}

/* ---- boundary: points on the boundary deform with the lattice, no seam ---- */
static void test_boundary_no_seam(void)
{
    for (int basis = 0; basis < 2; basis++) {
        ffd_lattice *lat = make((ffd_basis)basis, &rotated_box, 5, 5, 5);
        perturb(lat, 0.5);
        double p[12];
        box_point(&rotated_box, 1.0, 0.4, 0.7, p);
        box_point(&rotated_box, 1.0 - 1e-9, 0.4, 0.7, p + 3);
        box_point(&rotated_box, 0.0, 0.0, 0.2, p + 6);
        box_point(&rotated_box, 1e-9, 1e-9, 0.2, p + 9);
        ffd_lattice_binding *b = NULL;
        CHECK_OK(ffd_lattice_bind(lat, p, 4, FFD_OUTSIDE_FIXED, &b, NULL));
        CHECK(ffd_lattice_binding_inside_count(b) == 4);
        double q[12];
        CHECK_OK(ffd_lattice_eval(lat, b, q, NULL));
        for (int c = 0; c < 3; c++) {
            CHECK_NEAR(q[c], q[3 + c], 1e-6);
            CHECK_NEAR(q[6 + c], q[9 + c], 1e-6);
        }
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
    }
}

/* ---- outside policies ---- */
static void test_outside_policies(void)
{
    double p[6];
    box_point(&rotated_box, 1.2, 0.5, 0.5, p);
    box_point(&rotated_box, 1.0, 0.5, 0.5, p + 3);
    for (int basis = 0; basis < 2; basis++) {
        ffd_lattice *lat = make((ffd_basis)basis, &rotated_box, 4, 4, 4);
        /* at rest every policy is the identity */
        for (int pol = 0; pol < 3; pol++) {
            ffd_lattice_binding *b = NULL;
            CHECK_OK(ffd_lattice_bind(lat, p, 2, (ffd_outside)pol, &b, NULL));
            CHECK(ffd_lattice_binding_inside_count(b) == 1);
            double q[6];
            CHECK_OK(ffd_lattice_eval(lat, b, q, NULL));
            for (int c = 0; c < 3; c++)
                CHECK_NEAR(q[c], p[c], 1e-12);
            ffd_lattice_binding_destroy(b);
        }
        uint32_t idx[3] = {3, 2, 2};
        double d[3] = {0.5, 0.1, -0.2};
        CHECK_OK(ffd_lattice_move(lat, idx, d, NULL));
        ffd_lattice_binding *b = NULL;
        double q[6];
        CHECK_OK(ffd_lattice_bind(lat, p, 2, FFD_OUTSIDE_FIXED, &b, NULL));
        CHECK_OK(ffd_lattice_eval(lat, b, q, NULL));
        CHECK(memcmp(q, p, 3 * sizeof(double)) == 0); /* fixed: bitwise unchanged */
        ffd_lattice_binding_destroy(b);
        CHECK_OK(ffd_lattice_bind(lat, p, 2, FFD_OUTSIDE_CLAMP, &b, NULL));
        CHECK_OK(ffd_lattice_eval(lat, b, q, NULL));
        for (int c = 0; c < 3; c++) /* clamp: the boundary point's displacement */
            CHECK_NEAR(q[c] - p[c], q[3 + c] - p[3 + c], 1e-12);
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
    }
}

/* ---- Jacobian against central differences ---- */
static void test_jacobian(void)
{
    for (int basis = 0; basis < 2; basis++) {
        ffd_lattice *lat = make((ffd_basis)basis, &rotated_box, 5, 4, 6);
        perturb(lat, 0.6);
        size_t n = 50;
        double *p = random_inside(&rotated_box, n);
        for (size_t i = 0; i < n; i++) { /* keep away from the border for differences */
            double s = 0.05 + 0.9 * check_rand01(), t = 0.05 + 0.9 * check_rand01(),
                   u = 0.05 + 0.9 * check_rand01();
            box_point(&rotated_box, s, t, u, p + 3 * i);
        }
        ffd_lattice_binding *b = NULL;
        CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL));
        double *J = malloc(9 * n * sizeof *J);
        CHECK_OK(ffd_lattice_jacobian(lat, b, J, NULL));
        double h = 1e-6;
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++) {
                double pp[6];
                memcpy(pp, p + 3 * i, 3 * sizeof(double));
                memcpy(pp + 3, p + 3 * i, 3 * sizeof(double));
                pp[c] += h;
                pp[3 + c] -= h;
                ffd_lattice_binding *b2 = NULL;
                double q[6];
                CHECK_OK(ffd_lattice_bind(lat, pp, 2, FFD_OUTSIDE_FIXED, &b2, NULL));
                CHECK_OK(ffd_lattice_eval(lat, b2, q, NULL));
                for (int r = 0; r < 3; r++)
                    CHECK_NEAR(J[9 * i + 3 * r + c], (q[r] - q[3 + r]) / (2 * h), 1e-6);
                ffd_lattice_binding_destroy(b2);
            }
        free(J);
        free(p);
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
    }
}

/* ---- same result for 1 and 2 threads ---- */
static void test_thread_invariance(void)
{
    for (int basis = 0; basis < 2; basis++) {
        ffd_lattice *lat = make((ffd_basis)basis, &rotated_box, 5, 5, 5);
        perturb(lat, 0.8);
        size_t n = 20000;
        double *p = random_inside(&rotated_box, n);
        double *q1 = malloc(3 * n * sizeof *q1), *q2 = malloc(3 * n * sizeof *q2);
        ffd_lattice_binding *b1 = NULL, *b2 = NULL;
        omp_set_num_threads(1);
        CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b1, NULL));
        CHECK_OK(ffd_lattice_eval(lat, b1, q1, NULL));
        omp_set_num_threads(2);
        CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b2, NULL));
        CHECK_OK(ffd_lattice_eval(lat, b2, q2, NULL));
        CHECK(memcmp(q1, q2, 3 * n * sizeof *q1) == 0);
        free(p);
        free(q1);
        free(q2);
        ffd_lattice_binding_destroy(b1);
        ffd_lattice_binding_destroy(b2);
        ffd_lattice_destroy(lat);
    }
}

/* ---- the block kernels agree with the scalar evaluation, for any thread count ---- */
/* Resolutions that exercise every remainder of the Bernstein kernel's four
 * terms per pass (n mod 4 = 0..3) and the smallest and larger nets. */
static void test_block_eval_matches_scalar(void)
{
    static const uint32_t R[][3] = {{2, 3, 9}, {8, 5, 4}, {4, 7, 6}, {3, 8, 8}};
    for (int basis = 0; basis < 2; basis++)
        for (size_t r = 0; r < sizeof R / sizeof R[0]; r++) {
            ffd_lattice *lat = make((ffd_basis)basis, &rotated_box, R[r][0], R[r][1], R[r][2]);
            perturb(lat, 0.6);
            size_t n = 3000; /* several blocks of 256 per cell for the coarse lattices */
            double *p = random_inside(&rotated_box, n);
            double *q1 = malloc(3 * n * sizeof *q1), *q2 = malloc(3 * n * sizeof *q2);
            ffd_lattice_binding *b = NULL;
            CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL));
            omp_set_num_threads(1);
            CHECK_OK(ffd_lattice_eval(lat, b, q1, NULL));
            omp_set_num_threads(2);
            CHECK_OK(ffd_lattice_eval(lat, b, q2, NULL));
            CHECK(memcmp(q1, q2, 3 * n * sizeof *q1) == 0);
            for (size_t i = 0; i < n; i++) {
                double stu[3], ref[3];
                if (!ffd_lattice_binding_params(b, i, stu))
                    continue;
                ffd_lattice_eval_params(lat, stu, ref);
                for (int c = 0; c < 3; c++)
                    CHECK_NEAR(q1[3 * i + c], ref[c], 1e-12 * fmax(1.0, fabs(ref[c])));
            }
            free(p);
            free(q1);
            free(q2);
            ffd_lattice_binding_destroy(b);
            ffd_lattice_destroy(lat);
        }
}

/* ---- the evaluation runs the fastest kernel the CPU has ---- */

/* What cpuid and XCR0 say, read here independently of the library (which
 * goes through libgcc's __builtin_cpu_supports): the path a CPU should get. */
static ffd_simd_path expected_simd_path(void)
{
#if FFD_SIMD_DISPATCH
    unsigned a, b, c, d;
    if (!__get_cpuid(1, &a, &b, &c, &d))
        return FFD_SIMD_DEFAULT;
    int fma = (c >> 12) & 1, osxsave = (c >> 27) & 1, avx = (c >> 28) & 1;
    if (!osxsave || !avx || __get_cpuid_max(0, NULL) < 7)
        return FFD_SIMD_DEFAULT;
    unsigned xcr0_lo, xcr0_hi;
    __asm__ volatile("xgetbv" : "=a"(xcr0_lo), "=d"(xcr0_hi) : "c"(0));
    (void)xcr0_hi;
    __cpuid_count(7, 0, a, b, c, d);
    int avx2 = (b >> 5) & 1, avx512f = (b >> 16) & 1;
    int os_ymm = (xcr0_lo & 0x6) == 0x6, os_zmm = (xcr0_lo & 0xe6) == 0xe6;
    if (avx512f && avx2 && fma && os_zmm)
        return FFD_SIMD_AVX512;
    if (avx2 && fma && os_ymm)
        return FFD_SIMD_AVX2;
#endif
    return FFD_SIMD_DEFAULT;
}

static void test_simd_dispatch(void)
{
    ffd_simd_path want = expected_simd_path(), got = ffd_lattice_simd_path();
    if (got != want)
        fprintf(stderr, "simd_dispatch: cpuid asks for %s, the library dispatches %s\n",
                ffd_simd_path_name(want), ffd_simd_path_name(got));
    CHECK(got == want);
    CHECK(strcmp(ffd_simd_path_name(FFD_SIMD_AVX512), "avx512") == 0);
    CHECK(strcmp(ffd_simd_path_name(FFD_SIMD_AVX2), "avx2") == 0);
    CHECK(strcmp(ffd_simd_path_name(FFD_SIMD_DEFAULT), "default") == 0);
}

/* ---- bad input ---- */
static void test_bad_input(void)
{
    ffd_lattice *lat = NULL;
    ffd_error err = {{0}};
    uint32_t r1[3] = {1, 4, 4};
    CHECK(ffd_lattice_create(FFD_BASIS_BSPLINE, &rotated_box, r1, &lat, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "below the minimum") != NULL);
    CHECK(lat == NULL);
    uint32_t r2[3] = {4, 4, 4};
    ffd_box flat = rotated_box;
    memcpy(flat.axes[2], flat.axes[0], sizeof flat.axes[0]);
    CHECK(ffd_lattice_create(FFD_BASIS_BERNSTEIN, &flat, r2, &lat, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "zero volume") != NULL);
    ffd_box nanbox = rotated_box;
    nanbox.origin[1] = NAN;
    CHECK(ffd_lattice_create(FFD_BASIS_BERNSTEIN, &nanbox, r2, &lat, &err) == FFD_ERR_NONFINITE);
    lat = make(FFD_BASIS_BSPLINE, &rotated_box, 4, 4, 4);
    uint32_t bad[3] = {4, 0, 0};
    double d[3] = {1, 1, 1};
    CHECK(ffd_lattice_move(lat, bad, d, &err) == FFD_ERR_RANGE);
    uint32_t ok[3] = {3, 0, 0};
    d[1] = INFINITY;
    CHECK(ffd_lattice_move(lat, ok, d, &err) == FFD_ERR_NONFINITE);
    double p[3] = {0, NAN, 0};
    ffd_lattice_binding *b = NULL;
    CHECK(ffd_lattice_bind(lat, p, 1, FFD_OUTSIDE_FIXED, &b, &err) == FFD_ERR_NONFINITE);
    CHECK(b == NULL);
    ffd_box box;
    CHECK(ffd_box_fit(p, 0, 0.05, &box, &err) == FFD_ERR_INVALID);
    ffd_lattice_destroy(lat);
}

/* ================= direct manipulation ================= */

static void bind_points(ffd_lattice *lat, const double *p, size_t n, ffd_lattice_binding **b)
{
    CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, b, NULL));
}

/* targets reached to 1e-10 (feasible: few points, many control points) */
static void test_manip_targets_reached(void)
{
    for (int basis = 0; basis < 2; basis++) {
        ffd_lattice *lat = make((ffd_basis)basis, &rotated_box, 6, 6, 6);
        size_t n = 6;
        double *p = random_inside(&rotated_box, n);
        ffd_lattice_binding *b = NULL;
        bind_points(lat, p, n, &b);
        ffd_linear_map map;
        ffd_lattice_linear_map(lat, b, &map);
        size_t pts[6] = {0, 1, 2, 3, 4, 5};
        double cur[18], tgt[18], res[6];
        CHECK_OK(ffd_lattice_eval(lat, b, cur, NULL));
        for (int i = 0; i < 18; i++)
            tgt[i] = cur[i] + 0.3 * (check_rand01() - 0.5);
        double *delta = malloc(3 * map.variable_count * sizeof *delta);
        ffd_manip_result r;
        CHECK_OK(ffd_manip_solve(&map, pts, n, cur, tgt, NULL, delta, res, &r, NULL));
        CHECK(r.rank == n);
        CHECK_OK(ffd_lattice_add(lat, delta, NULL));
        double after[18];
        CHECK_OK(ffd_lattice_eval(lat, b, after, NULL));
        for (int i = 0; i < 18; i++)
            CHECK_NEAR(after[i], tgt[i], 1e-10);
        for (size_t i = 0; i < n; i++)
            CHECK(res[i] <= 1e-10);
        free(delta);
        free(p);
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
    }
}

/* single point: dP = B^+ dq with B^+ = B^T / |B|^2 (eq. 4), with S applied (eq. 7) */
static void test_manip_single_point_formula(void)
{
    ffd_lattice *lat = make(FFD_BASIS_BSPLINE, &rotated_box, 4, 5, 4);
    double p[3];
    box_point(&rotated_box, 0.05, 0.5, 0.93, p); /* near the border: tripled points involved */
    ffd_lattice_binding *b = NULL;
    bind_points(lat, p, 1, &b);
    ffd_linear_map map;
    ffd_lattice_linear_map(lat, b, &map);
    /* explicit B S over the distinct control points */
    size_t nv = map.variable_count;
    double *BS = calloc(nv, sizeof *BS);
    uint32_t cols[64];
    double w[64];
    size_t k = map.row(map.self, 0, cols, w);
    for (size_t e = 0; e < k; e++)
        BS[map.tie[cols[e]]] += w[e];
    double n2 = 0;
    for (size_t v = 0; v < nv; v++)
        n2 += BS[v] * BS[v];
    double cur[3], tgt[3], dq[3];
    CHECK_OK(ffd_lattice_eval(lat, b, cur, NULL));
    for (int c = 0; c < 3; c++) {
        tgt[c] = cur[c] + (c + 1) * 0.1;
        dq[c] = tgt[c] - cur[c];
    }
    double *delta = malloc(3 * nv * sizeof *delta);
    size_t pt = 0;
    CHECK_OK(ffd_manip_solve(&map, &pt, 1, cur, tgt, NULL, delta, NULL, NULL, NULL));
    for (size_t v = 0; v < nv; v++)
        for (int c = 0; c < 3; c++)
            CHECK_NEAR(delta[3 * v + c], BS[v] / n2 * dq[c], 1e-14);
    /* tied slots stay tied: the tripled-border net copies of one point are equal */
    CHECK_OK(ffd_lattice_add(lat, delta, NULL));
    for (size_t e = 0; e < map.column_count; e++)
        for (int c = 0; c < 3; c++)
            CHECK(lat->P_ext[3 * e + c] == lat->P[3 * (size_t)lat->tie[e] + c]);
    free(BS);
    free(delta);
    ffd_lattice_binding_destroy(b);
    ffd_lattice_destroy(lat);
}

/* several points sharing control points: the explicit pseudoinverse (eq. 3 with
 * full row rank: B+ = B^T (B B^T)^-1) gives the same change */
static void solve_small(int n, double *A, double *x) /* Gaussian elimination, A n x (n+1) */
{
    for (int i = 0; i < n; i++) {
        int piv = i;
        for (int r = i + 1; r < n; r++)
            if (fabs(A[r * (n + 1) + i]) > fabs(A[piv * (n + 1) + i]))
                piv = r;
        for (int c = 0; c <= n; c++) {
            double t = A[i * (n + 1) + c];
            A[i * (n + 1) + c] = A[piv * (n + 1) + c];
            A[piv * (n + 1) + c] = t;
        }
        for (int r = 0; r < n; r++)
            if (r != i) {
                double f = A[r * (n + 1) + i] / A[i * (n + 1) + i];
                for (int c = i; c <= n; c++)
                    A[r * (n + 1) + c] -= f * A[i * (n + 1) + c];
            }
    }
    for (int i = 0; i < n; i++)
        x[i] = A[i * (n + 1) + n] / A[i * (n + 1) + i];
}

static void test_manip_multi_point_formula(void)
{
    for (int basis = 0; basis < 2; basis++) {
        ffd_lattice *lat = make((ffd_basis)basis, &rotated_box, 5, 5, 5);
        enum { K = 4 };
        double p[3 * K];
        box_point(&rotated_box, 0.3, 0.3, 0.3, p);
        box_point(&rotated_box, 0.35, 0.32, 0.3, p + 3); /* shares control points with p0 */
        box_point(&rotated_box, 0.8, 0.1, 0.6, p + 6);
        box_point(&rotated_box, 0.02, 0.9, 0.99, p + 9);
        ffd_lattice_binding *b = NULL;
        bind_points(lat, p, K, &b);
        ffd_linear_map map;
        ffd_lattice_linear_map(lat, b, &map);
        size_t nv = map.variable_count;
        double *BS = calloc(K * nv, sizeof *BS);
        uint32_t *cols = malloc(map.max_row_nnz * sizeof *cols);
        double *w = malloc(map.max_row_nnz * sizeof *w);
        for (int i = 0; i < K; i++) {
            size_t k = map.row(map.self, (size_t)i, cols, w);
            for (size_t e = 0; e < k; e++)
                BS[i * nv + (map.tie ? map.tie[cols[e]] : cols[e])] += w[e];
        }
        double cur[3 * K], tgt[3 * K];
        CHECK_OK(ffd_lattice_eval(lat, b, cur, NULL));
        for (int i = 0; i < 3 * K; i++)
            tgt[i] = cur[i] + 0.2 * (check_rand01() - 0.5);
        double *delta = malloc(3 * nv * sizeof *delta);
        size_t pts[K] = {0, 1, 2, 3};
        CHECK_OK(ffd_manip_solve(&map, pts, K, cur, tgt, NULL, delta, NULL, NULL, NULL));
        for (int c = 0; c < 3; c++) {
            double G[K * (K + 1)], y[K];
            for (int i = 0; i < K; i++) {
                for (int j = 0; j < K; j++) {
                    double s = 0;
                    for (size_t v = 0; v < nv; v++)
                        s += BS[i * nv + v] * BS[j * nv + v];
                    G[i * (K + 1) + j] = s;
                }
                G[i * (K + 1) + K] = tgt[3 * i + c] - cur[3 * i + c];
            }
            solve_small(K, G, y);
            for (size_t v = 0; v < nv; v++) {
                double ref = 0;
                for (int i = 0; i < K; i++)
                    ref += BS[i * nv + v] * y[i];
                CHECK_NEAR(delta[3 * v + c], ref, 1e-11);
            }
        }
        free(BS);
        free(cols);
        free(w);
        free(delta);
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
    }
}

/* over-determined: more constraints than the lattice can satisfy; the
 * least-squares optimality (normal equations) holds and residuals are reported */
static void test_manip_overdetermined(void)
{
    ffd_lattice *lat = make(FFD_BASIS_BSPLINE, &rotated_box, 2, 2, 2);
    enum { K = 40 };
    double *p = random_inside(&rotated_box, K);
    ffd_lattice_binding *b = NULL;
    bind_points(lat, p, K, &b);
    ffd_linear_map map;
    ffd_lattice_linear_map(lat, b, &map);
    double cur[3 * K], tgt[3 * K], res[K];
    CHECK_OK(ffd_lattice_eval(lat, b, cur, NULL));
    for (int i = 0; i < 3 * K; i++) /* a wave the 2x2x2 lattice cannot make */
        tgt[i] = cur[i] + 0.3 * sin(7.0 * cur[i]);
    size_t pts[K];
    for (int i = 0; i < K; i++)
        pts[i] = (size_t)i;
    double delta[3 * 8];
    ffd_manip_result r;
    CHECK_OK(ffd_manip_solve(&map, pts, K, cur, tgt, NULL, delta, res, &r, NULL));
    CHECK(r.max_residual > 1e-3);
    CHECK(r.rank == 8);
    CHECK_OK(ffd_lattice_add(lat, delta, NULL));
    double after[3 * K];
    CHECK_OK(ffd_lattice_eval(lat, b, after, NULL));
    for (int i = 0; i < K; i++) {
        double d2 = 0;
        for (int c = 0; c < 3; c++)
            d2 += (after[3 * i + c] - tgt[3 * i + c]) * (after[3 * i + c] - tgt[3 * i + c]);
        CHECK_NEAR(res[i], sqrt(d2), 1e-12);
    }
    /* normal equations: (BS)^T (reached - target) = 0 */
    uint32_t cols[64];
    double w[64], g[8][3] = {{0}};
    for (int i = 0; i < K; i++) {
        size_t k = map.row(map.self, (size_t)i, cols, w);
        for (size_t e = 0; e < k; e++)
            for (int c = 0; c < 3; c++)
                g[map.tie[cols[e]]][c] += w[e] * (after[3 * i + c] - tgt[3 * i + c]);
    }
    for (int v = 0; v < 8; v++)
        for (int c = 0; c < 3; c++)
            CHECK_NEAR(g[v][c], 0, 1e-12);
    free(p);
    ffd_lattice_binding_destroy(b);
    ffd_lattice_destroy(lat);
}

/* rank deficient: the same point pinned twice to different targets -> the average */
static void test_manip_rank_deficient(void)
{
    ffd_lattice *lat = make(FFD_BASIS_BSPLINE, &rotated_box, 5, 5, 5);
    double p[6];
    box_point(&rotated_box, 0.4, 0.6, 0.5, p);
    memcpy(p + 3, p, sizeof(double) * 3);
    ffd_lattice_binding *b = NULL;
    bind_points(lat, p, 2, &b);
    ffd_linear_map map;
    ffd_lattice_linear_map(lat, b, &map);
    double cur[6], tgt[6], res[2];
    CHECK_OK(ffd_lattice_eval(lat, b, cur, NULL));
    for (int c = 0; c < 3; c++) {
        tgt[c] = cur[c] + 0.2;
        tgt[3 + c] = cur[c] - 0.2;
    }
    size_t pts[2] = {0, 1};
    double *delta = malloc(3 * map.variable_count * sizeof *delta);
    ffd_manip_result r;
    CHECK_OK(ffd_manip_solve(&map, pts, 2, cur, tgt, NULL, delta, res, &r, NULL));
    CHECK(r.rank == 1);
    for (size_t v = 0; v < 3 * map.variable_count; v++)
        CHECK_NEAR(delta[v], 0, 1e-14); /* the average of +0.2 and -0.2 is no move */
    CHECK_NEAR(res[0], 0.2 * sqrt(3.0), 1e-12);
    CHECK_NEAR(res[1], 0.2 * sqrt(3.0), 1e-12);
    /* non-finite target is refused */
    tgt[1] = NAN;
    ffd_error err = {{0}};
    CHECK(ffd_manip_solve(&map, pts, 2, cur, tgt, NULL, delta, res, &r, &err) == FFD_ERR_NONFINITE);
    free(delta);
    ffd_lattice_binding_destroy(b);
    ffd_lattice_destroy(lat);
}

/* ---------- pins hard, drag soft (options.hard_count) ---------- */

/* The rows of B S of points (Bernstein: every column its own variable), k by
 * nv row-major. */
static double *map_rows(const ffd_linear_map *map, const size_t *pts, size_t k)
{
    size_t nv = map->variable_count;
    double *A = calloc(k * nv, sizeof *A), w[64];
    uint32_t cols[64];
    CHECK(map->max_row_nnz <= 64);
    for (size_t c = 0; c < k; c++) {
        size_t nnz = map->row(map->self, pts[c], cols, w);
        for (size_t e = 0; e < nnz; e++)
            A[c * nv + (map->tie ? map->tie[cols[e]] : cols[e])] += w[e];
    }
    return A;
}

/* Solves the n by n row-major M x = b in place (Gaussian elimination, partial pivoting). */
static void gauss_solve(double *M, double *b, size_t n)
{
    for (size_t c = 0; c < n; c++) {
        size_t piv = c;
        for (size_t r = c + 1; r < n; r++)
            if (fabs(M[r * n + c]) > fabs(M[piv * n + c]))
                piv = r;
        for (size_t j = 0; j < n; j++) {
            double t = M[c * n + j];
            M[c * n + j] = M[piv * n + j];
            M[piv * n + j] = t;
        }
        double t = b[c];
        b[c] = b[piv];
        b[piv] = t;
        CHECK(fabs(M[c * n + c]) > 1e-300);
        for (size_t r = c + 1; r < n; r++) {
            double f = M[r * n + c] / M[c * n + c];
            for (size_t j = c; j < n; j++)
                M[r * n + j] -= f * M[c * n + j];
            b[r] -= f * b[c];
        }
    }
    for (size_t c = n; c-- > 0;) {
        for (size_t j = c + 1; j < n; j++)
            b[c] -= M[c * n + j] * b[j];
        b[c] /= M[c * n + c];
    }
}

/* 12 controls (Bernstein 3 x 2 x 2), 8 pins and 6 dragged points: the pins
 * leave 4 of the 12 variables per axis free, too few for the 6 soft points.
 * The pins are held to 1e-12 relative where the plain least-squares solve
 * (hard_count 0) slides them, and each soft point's residual equals the one
 * of an independent solve of the same equality-constrained least-squares
 * problem: the KKT system [A_s^T A_s, A_h^T; A_h, 0] [x; l] = [A_s^T dq_s; dq_h]. */
static void test_manip_pins_hard_drag_soft(void)
{
    ffd_lattice *lat = make(FFD_BASIS_BERNSTEIN, &rotated_box, 3, 2, 2);
    enum { H = 8, S = 6, K = H + S };
    double *p = random_inside(&rotated_box, K);
    ffd_lattice_binding *b = NULL;
    bind_points(lat, p, K, &b);
    ffd_linear_map map;
    ffd_lattice_linear_map(lat, b, &map);
    size_t nv = map.variable_count, pts[K];
    CHECK(nv == 12);
    for (size_t i = 0; i < K; i++)
        pts[i] = i;
    double cur[3 * K], tgt[3 * K], res[K], after[3 * K];
    CHECK_OK(ffd_lattice_eval(lat, b, cur, NULL));
    for (size_t i = 0; i < 3 * K; i++) /* pins where they are, the soft points pulled away */
        tgt[i] = cur[i] + (i >= 3 * H ? 0.8 * (check_rand01() - 0.5) : 0.0);
    double *delta = malloc(3 * nv * sizeof *delta);
    ffd_manip_result r;

    /* the old solve: every pin slides */
    CHECK_OK(ffd_manip_solve(&map, pts, K, cur, tgt, NULL, delta, res, &r, NULL));
    double slid = 0;
    for (size_t i = 0; i < H; i++)
        slid = res[i] > slid ? res[i] : slid;
    CHECK(slid > 1e-3);

    ffd_manip_options o = {.hard_count = H};
    CHECK_OK(ffd_manip_solve(&map, pts, K, cur, tgt, &o, delta, res, &r, NULL));
    CHECK(r.hard_met == 1);
    CHECK(r.soft_residual > 1e-3); /* the drag comes up short */
    CHECK_OK(ffd_lattice_add(lat, delta, NULL));
    CHECK_OK(ffd_lattice_eval(lat, b, after, NULL));
    for (size_t i = 0; i < 3 * H; i++)
        CHECK_NEAR(after[i], tgt[i], 1e-12 * fmax(1, fabs(tgt[i])));
    for (size_t i = 0; i < H; i++)
        CHECK(res[i] <= 1e-12 * 4);

    /* the independent solve, one axis at a time */
    double *A = map_rows(&map, pts, K);
    size_t n = nv + H;
    for (int d = 0; d < 3; d++) {
        double *M = calloc(n * n, sizeof *M), *rhs = calloc(n, sizeof *rhs);
        for (size_t i = 0; i < nv; i++) {
            for (size_t j = 0; j < nv; j++)
                for (size_t c = H; c < K; c++)
                    M[i * n + j] += A[c * nv + i] * A[c * nv + j];
            for (size_t c = H; c < K; c++)
                rhs[i] += A[c * nv + i] * (tgt[3 * c + d] - cur[3 * c + d]);
            for (size_t c = 0; c < H; c++)
                M[i * n + nv + c] = M[(nv + c) * n + i] = A[c * nv + i];
        }
        for (size_t c = 0; c < H; c++)
            rhs[nv + c] = tgt[3 * c + d] - cur[3 * c + d];
        gauss_solve(M, rhs, n);
        for (size_t c = H; c < K; c++) { /* the reached soft points agree */
            double x = cur[3 * c + d];
            for (size_t j = 0; j < nv; j++)
                x += A[c * nv + j] * rhs[j];
            CHECK_NEAR(after[3 * c + d], x, 1e-9);
        }
        free(M);
        free(rhs);
    }
    double worst = 0;
    for (size_t c = H; c < K; c++) {
        double r2 = 0;
        for (int d = 0; d < 3; d++)
            r2 += (after[3 * c + d] - tgt[3 * c + d]) * (after[3 * c + d] - tgt[3 * c + d]);
        CHECK_NEAR(res[c], sqrt(r2), 1e-9);
        worst = fmax(worst, sqrt(r2));
    }
    CHECK_NEAR(r.soft_residual, worst, 1e-12);
    free(A);
    free(delta);
    free(p);
    ffd_lattice_binding_destroy(b);
    ffd_lattice_destroy(lat);
}

/* As many generic pins as variables: the pins alone fix the controls, the
 * drag cannot move anything (delta as for the pins alone, residual the
 * dragged point's distance to its target). */
static void test_manip_pins_leave_no_freedom(void)
{
    ffd_lattice *lat = make(FFD_BASIS_BERNSTEIN, &rotated_box, 2, 2, 2);
    enum { K = 9 };
    double *p = random_inside(&rotated_box, K);
    ffd_lattice_binding *b = NULL;
    bind_points(lat, p, K, &b);
    ffd_linear_map map;
    ffd_lattice_linear_map(lat, b, &map);
    size_t pts[K] = {0, 1, 2, 3, 4, 5, 6, 7, 8};
    double cur[3 * K], tgt[3 * K], res[K];
    CHECK_OK(ffd_lattice_eval(lat, b, cur, NULL));
    memcpy(tgt, cur, sizeof cur);
    tgt[3 * 8] += 0.5;
    double delta[3 * 8];
    ffd_manip_options o = {.hard_count = 8};
    ffd_manip_result r;
    CHECK_OK(ffd_manip_solve(&map, pts, K, cur, tgt, &o, delta, res, &r, NULL));
    CHECK(r.hard_met == 1);
    for (int i = 0; i < 24; i++)
        CHECK_NEAR(delta[i], 0.0, 1e-12);
    CHECK_NEAR(res[8], 0.5, 1e-12);
    CHECK_NEAR(r.soft_residual, 0.5, 1e-12);
    free(p);
    ffd_lattice_binding_destroy(b);
    ffd_lattice_destroy(lat);
}

/* Everything reachable: the same delta as without hard constraints (the
 * minimum-norm solution of the whole system); pins that contradict each
 * other (one point, two targets) fall back to least squares and say so. */
static void test_manip_hard_soft_under_constrained(void)
{
    ffd_lattice *lat = make(FFD_BASIS_BSPLINE, &rotated_box, 6, 6, 6);
    size_t n = 6;
    double *p = random_inside(&rotated_box, n);
    ffd_lattice_binding *b = NULL;
    bind_points(lat, p, n, &b);
    ffd_linear_map map;
    ffd_lattice_linear_map(lat, b, &map);
    size_t pts[7] = {0, 1, 2, 3, 4, 5, 0};
    double cur[21], tgt[21], res[7];
    CHECK_OK(ffd_lattice_eval(lat, b, cur, NULL));
    for (int i = 0; i < 18; i++)
        tgt[i] = cur[i] + 0.3 * (check_rand01() - 0.5);
    size_t nv = map.variable_count;
    double *d0 = malloc(3 * nv * sizeof *d0), *d1 = malloc(3 * nv * sizeof *d1);
    ffd_manip_result r0, r1;
    ffd_manip_options o = {.hard_count = 4};
    CHECK_OK(ffd_manip_solve(&map, pts, n, cur, tgt, NULL, d0, NULL, &r0, NULL));
    CHECK_OK(ffd_manip_solve(&map, pts, n, cur, tgt, &o, d1, res, &r1, NULL));
    CHECK(r1.hard_met == 1);
    CHECK(r1.soft_residual <= 1e-10);
    for (size_t i = 0; i < 3 * nv; i++)
        CHECK_NEAR(d1[i], d0[i], 1e-12);
    /* point 0 pinned twice, 0.2 apart: least squares over the pins */
    memcpy(cur + 18, cur, 3 * sizeof *cur);
    memcpy(tgt + 18, tgt, 3 * sizeof *tgt);
    tgt[18] += 0.2;
    size_t order[7] = {0, 1, 2, 3, 4, 0, 5};
    double c2[21], t2[21];
    for (int i = 0; i < 7; i++) {
        size_t src = i == 5 ? 6 : i == 6 ? 5 : (size_t)i;
        memcpy(c2 + 3 * i, cur + 3 * src, 3 * sizeof *c2);
        memcpy(t2 + 3 * i, tgt + 3 * src, 3 * sizeof *t2);
    }
    o.hard_count = 6;
    CHECK_OK(ffd_manip_solve(&map, order, 7, c2, t2, &o, d1, res, &r1, NULL));
    CHECK(r1.hard_met == 0);
    CHECK_NEAR(res[0], 0.1, 1e-9);
    CHECK_NEAR(res[5], 0.1, 1e-9);
    CHECK(r1.soft_residual <= 1e-10);
    o.hard_count = 8;
    ffd_error err = {{0}};
    CHECK(ffd_manip_solve(&map, order, 7, c2, t2, &o, d1, res, &r1, &err) == FFD_ERR_RANGE);
    CHECK(strstr(err.message, "hard_count 8") != NULL);
    free(d0);
    free(d1);
    free(p);
    ffd_lattice_binding_destroy(b);
    ffd_lattice_destroy(lat);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"identity_at_rest", test_identity_at_rest},
        {"bspline_matches_de_boor", test_bspline_matches_de_boor},
        {"bernstein_matches_explicit_sum", test_bernstein_matches_explicit_sum},
        {"partition_of_unity", test_partition_of_unity},
        {"inversion_round_trip", test_inversion_round_trip},
        {"bspline_locality", test_bspline_locality},
        {"boundary_no_seam", test_boundary_no_seam},
        {"outside_policies", test_outside_policies},
        {"jacobian", test_jacobian},
        {"thread_invariance", test_thread_invariance},
        {"simd_dispatch", test_simd_dispatch},
        {"block_eval_matches_scalar", test_block_eval_matches_scalar},
        {"bad_input", test_bad_input},
        {"manip_targets_reached", test_manip_targets_reached},
        {"manip_single_point_formula", test_manip_single_point_formula},
        {"manip_multi_point_formula", test_manip_multi_point_formula},
        {"manip_overdetermined", test_manip_overdetermined},
        {"manip_rank_deficient", test_manip_rank_deficient},
        {"manip_pins_hard_drag_soft", test_manip_pins_hard_drag_soft},
        {"manip_pins_leave_no_freedom", test_manip_pins_leave_no_freedom},
        {"manip_hard_soft_under_constrained", test_manip_hard_soft_under_constrained},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
