/* Tests of the lattice variants (lattice_axis.c, lattice_general.c): an
 * interpolation per axis (linear, Kochanek-Bartels cardinal, Catmull-Rom,
 * B-spline, Bernstein), and cylindrical and spherical lattices. */
#include "ffd.h"
#include "check.h"
#include "lattice/lattice.h"

#include <omp.h>

#define TWO_PI 6.283185307179586476925286766559
#define PI 3.1415926535897932384626433832795

static const ffd_box oblique_box = {
    {-1.0, 0.5, 2.0},
    {{2.0, 0.4, 0.1}, {-0.3, 1.5, 0.2}, {0.2, -0.1, 3.0}},
};

/* every interpolation, open and (where allowed) periodic */
typedef struct axis_case {
    ffd_interp interp;
    double tension, continuity;
    uint32_t res;
    int periodic;
} axis_case;

static const axis_case axis_cases[] = {
    {FFD_INTERP_LINEAR, 0, 0, 2, 0},       {FFD_INTERP_LINEAR, 0, 0, 5, 0},
    {FFD_INTERP_LINEAR, 0, 0, 5, 1},       {FFD_INTERP_CARDINAL, 0.3, 0.2, 2, 0},
    {FFD_INTERP_CARDINAL, 0.3, 0.2, 6, 0}, {FFD_INTERP_CARDINAL, -1, -1, 6, 0},
    {FFD_INTERP_CARDINAL, 0.9, 1, 4, 1},   {FFD_INTERP_CATMULL_ROM, 0, 0, 3, 1},
    {FFD_INTERP_CATMULL_ROM, 0, 0, 7, 0},  {FFD_INTERP_BSPLINE, 0, 0, 2, 0},
    {FFD_INTERP_BSPLINE, 0, 0, 6, 0},      {FFD_INTERP_BSPLINE, 0, 0, 3, 1},
    {FFD_INTERP_BSPLINE, 0, 0, 8, 1},      {FFD_INTERP_BERNSTEIN, 0, 0, 5, 0},
};
#define AXIS_CASES (sizeof axis_cases / sizeof *axis_cases)

static void axis_make(const axis_case *c, ffd_lattice_axis *ax)
{
    ffd_error err = {{0}};
    CHECK_OK(ffd_lattice_axis_init(ax, c->interp, c->tension, c->continuity, c->res, c->periodic,
                                   "axis", &err));
}

/* Sum of weights is 1 and of their derivatives 0; the weights reproduce
 * the rest map from the nodes (linear precision of the axis). */
static void test_partition_and_precision(void)
{
    for (size_t k = 0; k < AXIS_CASES; k++) {
        ffd_lattice_axis ax;
        axis_make(&axis_cases[k], &ax);
        double top = ffd_lattice_axis_top(&ax);
        for (int s = 0; s <= 200; s++) {
            double S = top * (s < 200 ? check_rand01() : 1.0);
            uint32_t idx[FFD_AXIS_MAX_SUPPORT];
            double w[FFD_AXIS_MAX_SUPPORT], dw[FFD_AXIS_MAX_SUPPORT], sum = 0, dsum = 0, f = 0;
            uint32_t n = ffd_lattice_axis_weights(&ax, S, idx, w, dw);
            double df;
            double rest = ffd_lattice_axis_rest(&ax, S, &df);
            double dfw = 0;
            for (uint32_t e = 0; e < n; e++) {
                CHECK(idx[e] < ax.res);
                for (uint32_t o = 0; o < e; o++)
                    CHECK(idx[o] != idx[e]);
                sum += w[e];
                dsum += dw[e];
                if (!ax.periodic) {
                    f += w[e] * ffd_lattice_axis_node(&ax, idx[e]);
                    dfw += dw[e] * ffd_lattice_axis_node(&ax, idx[e]);
                }
            }
            CHECK_NEAR(sum, 1.0, 1e-14);
            CHECK_NEAR(dsum, 0.0, 1e-12);
            if (!ax.periodic) {
                CHECK_NEAR(f, rest, 1e-14);
                CHECK_NEAR(dfw, df, 1e-12);
            }
        }
        ffd_lattice_axis_release(&ax);
    }
}

/* The real root in [0,1] of -2T t^3 + 3T t^2 + (1-T) t - y = 0 by
 * Cardano's formula (trigonometric form for three real roots), written from
 * the depressed cubic, independently of the library's Newton solve. */
static double cardano_root(double T, double y)
{
    if (T == 0)
        return y;
    double a = -2 * T, b = 3 * T, c = 1 - T, d = -y;
    double B = b / a, C = c / a, D = d / a;
    double p = C - B * B / 3, q = 2 * B * B * B / 27 - B * C / 3 + D;
    double disc = q * q / 4 + p * p * p / 27;
    double roots[3];
    int nr;
    if (disc > 0) {
        double sq = sqrt(disc);
        roots[0] = cbrt(-q / 2 + sq) + cbrt(-q / 2 - sq) - B / 3;
        nr = 1;
    } else {
        double r = sqrt(-p / 3), phi = acos(fmax(-1, fmin(1, -q / (2 * r * r * r))));
        for (int k = 0; k < 3; k++)
            roots[k] = 2 * r * cos((phi - 2 * PI * k) / 3) - B / 3;
        nr = 3;
    }
    double best = NAN;
    for (int k = 0; k < nr; k++)
        if (roots[k] >= -1e-9 && roots[k] <= 1 + 1e-9)
            best = roots[k];
    return best;
}

/* The cardinal rest map's inverse matches Cardano's root, and the rest map
 * of every axis type is inverted to full precision. */
static void test_inverse_rest_map(void)
{
    static const double tensions[] = {-1, -0.5, 0.25, 0.6, 0.95};
    for (size_t k = 0; k < sizeof tensions / sizeof *tensions; k++)
        for (int s = 1; s < 100; s++) {
            double y = s / 100.0 + 1e-3 * check_rand01();
            double t = ffd_cardinal_invert(tensions[k], y);
            CHECK_NEAR(t, cardano_root(tensions[k], y), 1e-12);
            CHECK_NEAR(ffd_cardinal_rest(tensions[k], t, NULL), y, 2.3e-16); /* 1 ulp */
        }
    for (size_t k = 0; k < AXIS_CASES; k++) {
        ffd_lattice_axis ax;
        axis_make(&axis_cases[k], &ax);
        for (int s = 0; s <= 300; s++) {
            double x = s / 300.0;
            double S = ffd_lattice_axis_invert(&ax, x);
            CHECK(S >= 0 && S <= ffd_lattice_axis_top(&ax));
            CHECK_NEAR(ffd_lattice_axis_rest(&ax, S, NULL), x, 4e-16);
        }
        ffd_lattice_axis_release(&ax);
    }
}

/* The Kochanek-Bartels weights against the spline written from the paper:
 * Hermite with the tangents, phantom ends extrapolated. */
static void test_cardinal_against_hermite(void)
{
    const double T = 0.35, C = -0.4;
    const uint32_t res = 5;
    double p[5];
    for (uint32_t j = 0; j < res; j++)
        p[j] = check_rand01();
    ffd_lattice_axis ax;
    ffd_error err = {{0}};
    CHECK_OK(ffd_lattice_axis_init(&ax, FFD_INTERP_CARDINAL, T, C, res, 0, "axis", &err));
    for (int s = 0; s < 100; s++) {
        double S = (res - 1) * check_rand01();
        uint32_t i = (uint32_t)S;
        double t = S - i;
        double q[4]; /* p_{i-1}, p_i, p_{i+1}, p_{i+2} with phantoms */
        for (int k = 0; k < 4; k++) {
            int j = (int)i - 1 + k;
            q[k] = j < 0 ? 2 * p[0] - p[1] : j >= (int)res ? 2 * p[res - 1] - p[res - 2] : p[j];
        }
        double d0 = (1 - T) * (1 + C) / 2 * (q[1] - q[0]) + (1 - T) * (1 - C) / 2 * (q[2] - q[1]);
        double d1 = (1 - T) * (1 - C) / 2 * (q[2] - q[1]) + (1 - T) * (1 + C) / 2 * (q[3] - q[2]);
        double want = (2 * t * t * t - 3 * t * t + 1) * q[1] + (t * t * t - 2 * t * t + t) * d0 +
                      (-2 * t * t * t + 3 * t * t) * q[2] + (t * t * t - t * t) * d1;
        uint32_t idx[4];
        double w[4], got = 0;
        uint32_t n = ffd_lattice_axis_weights(&ax, S, idx, w, NULL);
        for (uint32_t e = 0; e < n; e++)
            got += w[e] * p[idx[e]];
        CHECK_NEAR(got, want, 1e-14);
    }
    ffd_lattice_axis_release(&ax);
}

/* ---- whole lattices ---- */

static ffd_lattice_shape mixed_shape(void)
{
    ffd_lattice_shape sh;
    memset(&sh, 0, sizeof sh);
    sh.interp[0] = FFD_INTERP_LINEAR;
    sh.interp[1] = FFD_INTERP_CARDINAL;
    sh.interp[2] = FFD_INTERP_BSPLINE;
    sh.tension[1] = 0.4;
    sh.continuity[1] = 0.3;
    return sh;
}

static ffd_lattice_shape framed_shape(ffd_coordinates co, double r0, double t1, double p0, double p1)
{
    ffd_lattice_shape sh;
    memset(&sh, 0, sizeof sh);
    sh.coordinates = co;
    sh.interp[0] = FFD_INTERP_LINEAR;
    sh.interp[1] = co == FFD_COORDINATES_CYLINDRICAL ? FFD_INTERP_CATMULL_ROM : FFD_INTERP_BSPLINE;
    sh.interp[2] = co == FFD_COORDINATES_CYLINDRICAL ? FFD_INTERP_BSPLINE : FFD_INTERP_CARDINAL;
    sh.tension[2] = 0.2;
    double centre[3] = {0.3, -0.2, 0.5}, axis[3] = {0.2, 1.0, 0.1}, ref[3] = {1, 0, 0};
    memcpy(sh.frame.centre, centre, sizeof centre);
    memcpy(sh.frame.axis, axis, sizeof axis);
    memcpy(sh.frame.reference, ref, sizeof ref);
    sh.frame.range[0][0] = r0;
    sh.frame.range[0][1] = 2.0;
    sh.frame.range[1][0] = -0.5;
    sh.frame.range[1][1] = -0.5 + t1;
    sh.frame.range[2][0] = co == FFD_COORDINATES_CYLINDRICAL ? -1.0 : p0;
    sh.frame.range[2][1] = co == FFD_COORDINATES_CYLINDRICAL ? 1.5 : p1;
    return sh;
}

static ffd_lattice *make_shaped(const ffd_lattice_shape *sh, uint32_t l, uint32_t m, uint32_t n)
{
    ffd_lattice *lat = NULL;
    ffd_error err = {{0}};
    uint32_t res[3] = {l, m, n};
    CHECK_OK(ffd_lattice_create_shaped(FFD_BASIS_BSPLINE, &oblique_box, res, sh, &lat, &err));
    if (err.message[0])
        fprintf(stderr, "%s\n", err.message);
    return lat;
}

/* Points inside the lattice: the rest map of random normalised coordinates. */
static double *inside_points(const ffd_lattice *lat, size_t n)
{
    double *p = malloc(3 * n * sizeof *p);
    ffd_lattice_shape sh;
    ffd_lattice_get_shape(lat, &sh);
    for (size_t i = 0; i < n; i++) {
        double loc[3] = {check_rand01(), check_rand01(), check_rand01()};
        if (sh.coordinates == FFD_COORDINATES_CARTESIAN) {
            for (int c = 0; c < 3; c++)
                p[3 * i + c] = oblique_box.origin[c] + loc[0] * oblique_box.axes[0][c] +
                               loc[1] * oblique_box.axes[1][c] + loc[2] * oblique_box.axes[2][c];
            continue;
        }
        double S[3];
        for (int a = 0; a < 3; a++)
            S[a] = ffd_lattice_axis_invert(ffd_lattice_general_axis(lat, a), loc[a]);
        ffd_lattice_eval_params(lat, S, p + 3 * i); /* at rest: the coordinate map */
    }
    return p;
}

static ffd_lattice *variant(int v)
{
    ffd_lattice_shape sh;
    switch (v) {
    case 0:
        sh = mixed_shape();
        return make_shaped(&sh, 4, 5, 4);
    case 1:
        sh = framed_shape(FFD_COORDINATES_CYLINDRICAL, 0, TWO_PI, 0, 0);
        return make_shaped(&sh, 3, 6, 4);
    case 2:
        sh = framed_shape(FFD_COORDINATES_CYLINDRICAL, 0.5, 2.0, 0, 0);
        return make_shaped(&sh, 3, 4, 4);
    case 3:
        sh = framed_shape(FFD_COORDINATES_SPHERICAL, 0, TWO_PI, 0, PI);
        return make_shaped(&sh, 3, 6, 5);
    default:
        sh = framed_shape(FFD_COORDINATES_SPHERICAL, 0.3, 3.0, 0.4, 2.0);
        return make_shaped(&sh, 3, 4, 4);
    }
}
#define VARIANTS 5

static void displace_randomly(ffd_lattice *lat, double scale)
{
    size_t nc = ffd_lattice_control_count(lat);
    double *d = malloc(3 * nc * sizeof *d);
    for (size_t i = 0; i < 3 * nc; i++)
        d[i] = scale * (check_rand01() - 0.5);
    ffd_error err = {{0}};
    CHECK_OK(ffd_lattice_add(lat, d, &err));
    free(d);
}

/* A lattice at rest gives every point back bitwise, with identity Jacobians;
 * the Cartesian one's rest lattice reproduces every point (linear precision). */
static void test_identity_and_linear_precision(void)
{
    for (int v = 0; v < VARIANTS; v++) {
        ffd_lattice *lat = variant(v);
        const size_t n = 300;
        double *p = inside_points(lat, n), *q = malloc(3 * n * sizeof *q), *J = malloc(9 * n * sizeof *J);
        ffd_lattice_binding *b = NULL;
        ffd_error err = {{0}};
        CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, &err));
        CHECK(ffd_lattice_binding_inside_count(b) == n);
        CHECK_OK(ffd_lattice_eval(lat, b, q, &err));
        CHECK(memcmp(p, q, 3 * n * sizeof *p) == 0);
        CHECK_OK(ffd_lattice_jacobian(lat, b, J, &err));
        for (size_t i = 0; i < n; i++)
            for (int e = 0; e < 9; e++)
                CHECK(J[9 * i + e] == (e % 4 == 0 ? 1.0 : 0.0));
        if (v == 0) { /* sum_j w_ij P0_j = x_i through the linear map */
            ffd_linear_map map;
            ffd_lattice_linear_map(lat, b, &map);
            uint32_t *cols = malloc(map.max_row_nnz * sizeof *cols);
            double *w = malloc(map.max_row_nnz * sizeof *w);
            for (size_t i = 0; i < n; i++) {
                size_t k = map.row(map.self, i, cols, w);
                double x[3] = {0, 0, 0};
                for (size_t e = 0; e < k; e++) {
                    double r[3];
                    uint32_t c = cols[e];
                    ffd_lattice_rest_point(lat, c / (5 * 4), c / 4 % 5, c % 4, r);
                    for (int a = 0; a < 3; a++)
                        x[a] += w[e] * r[a];
                }
                for (int a = 0; a < 3; a++)
                    CHECK_NEAR(x[a], p[3 * i + a], 1e-13);
            }
            free(cols);
            free(w);
        }
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
        free(p);
        free(q);
        free(J);
    }
}

/* Every control point translated: every point translates; rotated (the
 * Cartesian lattice, which reproduces linear functions): every point rotates. */
static void test_rigid_motions(void)
{
    const double t[3] = {0.3, -1.1, 0.7};
    const double ang = 0.7, ax[3] = {0.48, 0.6, 0.64}; /* unit */
    double R[3][3];
    double c = cos(ang), s = sin(ang);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            R[i][j] = (i == j ? c : 0) + (1 - c) * ax[i] * ax[j] +
                      s * (i == 0 ? (j == 1 ? -ax[2] : j == 2 ? ax[1] : 0)
                           : i == 1 ? (j == 0 ? ax[2] : j == 2 ? -ax[0] : 0)
                                    : (j == 0 ? -ax[1] : j == 1 ? ax[0] : 0));
    for (int v = 0; v < VARIANTS; v++)
        for (int motion = 0; motion < (v == 0 ? 2 : 1); motion++) {
            ffd_lattice *lat = variant(v);
            const size_t n = 200;
            double *p = inside_points(lat, n), *q = malloc(3 * n * sizeof *q);
            size_t nc = ffd_lattice_control_count(lat);
            double *P = malloc(3 * nc * sizeof *P);
            for (size_t j = 0; j < nc; j++)
                for (int a = 0; a < 3; a++) {
                    const double *x = ffd_lattice_control_points(lat) + 3 * j;
                    P[3 * j + a] = motion == 0 ? x[a] + t[a]
                                               : R[a][0] * x[0] + R[a][1] * x[1] + R[a][2] * x[2];
                }
            ffd_error err = {{0}};
            ffd_lattice_binding *b = NULL;
            CHECK_OK(ffd_lattice_set_control_points(lat, P, &err));
            CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, &err));
            CHECK_OK(ffd_lattice_eval(lat, b, q, &err));
            for (size_t i = 0; i < n; i++)
                for (int a = 0; a < 3; a++) {
                    const double *x = p + 3 * i;
                    double want = motion == 0 ? x[a] + t[a]
                                              : R[a][0] * x[0] + R[a][1] * x[1] + R[a][2] * x[2];
                    CHECK_NEAR(q[3 * i + a], want, 1e-12);
                }
            ffd_lattice_binding_destroy(b);
            ffd_lattice_destroy(lat);
            free(p);
            free(q);
            free(P);
        }
}

/* The analytic Jacobian against central differences of the map, the linear
 * map's rows against the evaluation (W D = x' - x), W^T against W. */
static void test_jacobian_and_map_fd(void)
{
    for (int v = 0; v < VARIANTS; v++) {
        ffd_lattice *lat = variant(v);
        const size_t n = 60;
        double *p = inside_points(lat, n); /* at rest */
        displace_randomly(lat, 0.2);
        double *q = malloc(3 * n * sizeof *q), *J = malloc(9 * n * sizeof *J);
        ffd_error err = {{0}};
        ffd_lattice_binding *b = NULL;
        CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, &err));
        CHECK_OK(ffd_lattice_eval(lat, b, q, &err));
        CHECK_OK(ffd_lattice_jacobian(lat, b, J, &err));
        const double h = 1e-6;
        for (size_t i = 0; i < n; i++) {
            double loc_ok = 1;
            for (int a = 0; a < 3; a++)
                loc_ok *= b->params[3 * i + a] > 1e-3; /* away from the axis and the nudges */
            if (!loc_ok)
                continue;
            for (int c = 0; c < 3; c++) {
                double xp[6];
                memcpy(xp, p + 3 * i, 3 * sizeof(double));
                memcpy(xp + 3, p + 3 * i, 3 * sizeof(double));
                xp[c] += h;
                xp[3 + c] -= h;
                ffd_lattice_binding *bb = NULL;
                double qq[6];
                CHECK_OK(ffd_lattice_bind(lat, xp, 2, FFD_OUTSIDE_CLAMP, &bb, &err));
                CHECK_OK(ffd_lattice_eval(lat, bb, qq, &err));
                for (int r = 0; r < 3; r++)
                    CHECK_NEAR(J[9 * i + 3 * r + c], (qq[r] - qq[3 + r]) / (2 * h), 1e-6);
                ffd_lattice_binding_destroy(bb);
            }
        }
        ffd_linear_map map;
        ffd_lattice_linear_map(lat, b, &map);
        size_t nc = ffd_lattice_control_count(lat);
        uint32_t *cols = malloc(map.max_row_nnz * sizeof *cols);
        double *w = malloc(map.max_row_nnz * sizeof *w);
        double *D = malloc(3 * nc * sizeof *D), *Wv = malloc(3 * n * sizeof *Wv);
        double *g = malloc(3 * n * sizeof *g), *Wtg = malloc(3 * nc * sizeof *Wtg);
        for (size_t j = 0; j < nc; j++) {
            double r[3];
            ffd_lattice_rest_point(lat, (uint32_t)(j / (lat->res[1] * lat->res[2])),
                                   (uint32_t)(j / lat->res[2] % lat->res[1]),
                                   (uint32_t)(j % lat->res[2]), r);
            for (int a = 0; a < 3; a++)
                D[3 * j + a] = ffd_lattice_control_points(lat)[3 * j + a] - r[a];
        }
        CHECK_OK(ffd_lattice_sensitivity_product(lat, b, D, Wv, &err));
        for (size_t i = 0; i < 3 * n; i++)
            g[i] = check_rand01() - 0.5;
        CHECK_OK(ffd_lattice_sensitivity_transpose(lat, b, g, Wtg, &err));
        double gWD = 0, WtgD = 0;
        for (size_t i = 0; i < n; i++) {
            size_t k = map.row(map.self, i, cols, w);
            double x[3] = {0, 0, 0};
            for (size_t e = 0; e < k; e++) {
                uint32_t col = map.tie ? map.tie[cols[e]] : cols[e];
                for (int a = 0; a < 3; a++)
                    x[a] += w[e] * D[3 * col + a];
            }
            for (int a = 0; a < 3; a++) {
                CHECK_NEAR(p[3 * i + a] + x[a], q[3 * i + a], 1e-13);
                CHECK_NEAR(Wv[3 * i + a], x[a], 1e-13);
                gWD += g[3 * i + a] * x[a];
            }
        }
        for (size_t j = 0; j < 3 * nc; j++)
            WtgD += Wtg[j] * D[j];
        CHECK_NEAR(gWD, WtgD, 1e-12);
        free(cols), free(w), free(D), free(Wv), free(g), free(Wtg);
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
        free(p), free(q), free(J);
    }
}

/* Direct manipulation through the linear map reaches its targets, also for
 * a point on the axis / at the centre (a tied control point). */
static void test_direct_manipulation(void)
{
    for (int v = 0; v < VARIANTS; v++) {
        ffd_lattice *lat = variant(v);
        const size_t n = 4;
        double *p = inside_points(lat, n);
        double centre_point[3];
        ffd_lattice_shape sh;
        ffd_lattice_get_shape(lat, &sh);
        if (sh.coordinates != FFD_COORDINATES_CARTESIAN && sh.frame.range[0][0] == 0) {
            double S[3] = {0, 0.5, 0.5};
            ffd_lattice_eval_params(lat, S, centre_point); /* on the axis / the centre */
            memcpy(p, centre_point, sizeof centre_point);
        }
        ffd_error err = {{0}};
        ffd_lattice_binding *b = NULL;
        CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, &err));
        ffd_linear_map map;
        ffd_lattice_linear_map(lat, b, &map);
        size_t rows[4] = {0, 1, 2, 3};
        double tgt[12], res[4], *delta = malloc(3 * map.variable_count * sizeof *delta);
        for (int i = 0; i < 12; i++)
            tgt[i] = p[i] + 0.1 * (check_rand01() - 0.5);
        ffd_manip_result r;
        CHECK_OK(ffd_manip_solve(&map, rows, n, p, tgt, NULL, delta, res, &r, &err));
        CHECK_OK(ffd_lattice_add(lat, delta, &err));
        double q[12];
        CHECK_OK(ffd_lattice_eval(lat, b, q, &err));
        for (int i = 0; i < 12; i++)
            CHECK_NEAR(q[i], tgt[i], 1e-12);
        free(delta);
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
        free(p);
    }
}

/* Linear interpolation: a lattice refined by midpoints (control points set
 * from the coarse map at the new nodes) is the same map. */
static void test_linear_refinement(void)
{
    ffd_lattice_shape sh;
    memset(&sh, 0, sizeof sh);
    sh.interp[0] = sh.interp[1] = sh.interp[2] = FFD_INTERP_LINEAR;
    ffd_lattice *coarse = make_shaped(&sh, 3, 2, 4), *fine = make_shaped(&sh, 5, 3, 7);
    displace_randomly(coarse, 0.3);
    size_t nf = ffd_lattice_control_count(fine);
    double *P = malloc(3 * nf * sizeof *P);
    for (uint32_t i = 0; i < 5; i++)
        for (uint32_t j = 0; j < 3; j++)
            for (uint32_t k = 0; k < 7; k++) {
                double S[3] = {i / 2.0, j / 2.0, k / 2.0}; /* coarse parameters of fine nodes */
                ffd_lattice_eval_params(coarse, S, P + 3 * (((size_t)i * 3 + j) * 7 + k));
            }
    ffd_error err = {{0}};
    CHECK_OK(ffd_lattice_set_control_points(fine, P, &err));
    const size_t n = 200;
    double *p = inside_points(coarse, n), *a = malloc(3 * n * sizeof *a), *c = malloc(3 * n * sizeof *c);
    ffd_lattice_binding *ba = NULL, *bc = NULL;
    CHECK_OK(ffd_lattice_bind(coarse, p, n, FFD_OUTSIDE_FIXED, &ba, &err));
    CHECK_OK(ffd_lattice_bind(fine, p, n, FFD_OUTSIDE_FIXED, &bc, &err));
    CHECK_OK(ffd_lattice_eval(coarse, ba, a, &err));
    CHECK_OK(ffd_lattice_eval(fine, bc, c, &err));
    for (size_t i = 0; i < 3 * n; i++)
        CHECK_NEAR(a[i], c[i], 1e-13);
    ffd_lattice_binding_destroy(ba);
    ffd_lattice_binding_destroy(bc);
    ffd_lattice_destroy(coarse);
    ffd_lattice_destroy(fine);
    free(P), free(p), free(a), free(c);
}

/* Deformed position at normalised coordinates of a framed lattice. */
static void deform_at(ffd_lattice *lat, const double loc[3], double out[3])
{
    double S[3], x[3];
    for (int a = 0; a < 3; a++)
        S[a] = ffd_lattice_axis_invert(ffd_lattice_general_axis(lat, a), loc[a]);
    /* the point at rest (the coordinate map: the map with no displacement),
     * then bound like any point */
    double *D = malloc(3 * ffd_lattice_control_count(lat) * sizeof *D);
    memcpy(D, lat->D_ext, 3 * ffd_lattice_control_count(lat) * sizeof *D);
    memset(lat->D_ext, 0, 3 * ffd_lattice_control_count(lat) * sizeof *D);
    ffd_lattice_eval_params(lat, S, x);
    memcpy(lat->D_ext, D, 3 * ffd_lattice_control_count(lat) * sizeof *D);
    free(D);
    ffd_error err = {{0}};
    ffd_lattice_binding *b = NULL;
    CHECK_OK(ffd_lattice_bind(lat, x, 1, FFD_OUTSIDE_FIXED, &b, &err));
    CHECK_OK(ffd_lattice_eval(lat, b, out, &err));
    ffd_lattice_binding_destroy(b);
}

/* Continuity across the theta seam and towards the axis and the poles: the
 * map's value differs by O(eps) at eps from them, whatever the direction. */
static void test_seam_axis_poles(void)
{
    for (int v = 1; v <= 3; v += 2) {
        ffd_lattice *lat = variant(v);
        displace_randomly(lat, 0.4);
        for (int s = 0; s < 20; s++) {
            double r = 0.2 + 0.6 * check_rand01(), z = 0.2 + 0.6 * check_rand01();
            double a[3], b[3], lo[3] = {r, 1e-9, z}, hi[3] = {r, 1 - 1e-9, z};
            deform_at(lat, lo, a);
            deform_at(lat, hi, b);
            for (int c = 0; c < 3; c++)
                CHECK_NEAR(a[c], b[c], 1e-7);
            /* towards the axis / centre: every direction meets one point */
            double ref[3], eps = 1e-9;
            double l0[3] = {eps, check_rand01(), z};
            deform_at(lat, l0, ref);
            for (int k = 0; k < 4; k++) {
                double l1[3] = {eps, check_rand01(), v == 3 ? check_rand01() : z}, q[3];
                deform_at(lat, l1, q);
                for (int c = 0; c < 3; c++)
                    CHECK_NEAR(q[c], ref[c], 1e-7);
            }
            if (v == 3) /* the poles, at any radius and azimuth */
                for (int pole = 0; pole < 2; pole++) {
                    double p0[3] = {r, check_rand01(), pole ? 1 - eps : eps}, p1[3], q0[3], q1[3];
                    p1[0] = r, p1[1] = check_rand01(), p1[2] = p0[2];
                    deform_at(lat, p0, q0);
                    deform_at(lat, p1, q1);
                    for (int c = 0; c < 3; c++)
                        CHECK_NEAR(q0[c], q1[c], 1e-7);
                }
        }
        ffd_lattice_destroy(lat);
    }
}

/* Tied control points: a move of any member moves the group. */
static void test_tied_controls(void)
{
    ffd_lattice *lat = variant(1); /* cylindrical, r0 = 0: (0, j, k) tied to (0, 0, k) */
    uint32_t idx[3] = {0, 3, 2};
    double d[3] = {0.1, 0.2, -0.3};
    ffd_error err = {{0}};
    CHECK_OK(ffd_lattice_move(lat, idx, d, &err));
    const double *P = ffd_lattice_control_points(lat);
    for (uint32_t j = 0; j < 6; j++) {
        double r[3];
        ffd_lattice_rest_point(lat, 0, j, 2, r);
        for (int c = 0; c < 3; c++)
            CHECK(P[3 * ((size_t)j * 4 + 2) + c] == r[c] + d[c]);
    }
    /* setting a follower alone changes nothing: it shows its representative */
    size_t nc = ffd_lattice_control_count(lat);
    double *Q = malloc(3 * nc * sizeof *Q);
    memcpy(Q, P, 3 * nc * sizeof *Q);
    double rep_x = P[3 * 2];
    Q[3 * ((size_t)3 * 4 + 2)] += 1.0;
    CHECK_OK(ffd_lattice_set_control_points(lat, Q, &err));
    CHECK(P[3 * 2] == rep_x); /* the group did not move */
    CHECK(P[3 * ((size_t)3 * 4 + 2)] == rep_x);
    free(Q);
    ffd_lattice_destroy(lat);
}

/* Bitwise the same for 1 and N threads. */
static void test_thread_invariance(void)
{
    for (int v = 0; v < VARIANTS; v++) {
        ffd_lattice *lat = variant(v);
        const size_t n = 2000;
        double *p = inside_points(lat, n);
        displace_randomly(lat, 0.3);
        double *a = malloc(3 * n * sizeof *a), *c = malloc(3 * n * sizeof *c);
        ffd_error err = {{0}};
        int nt = omp_get_max_threads();
        ffd_lattice_binding *b = NULL;
        omp_set_num_threads(1);
        CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_CLAMP, &b, &err));
        CHECK_OK(ffd_lattice_eval(lat, b, a, &err));
        ffd_lattice_binding_destroy(b);
        omp_set_num_threads(nt > 1 ? nt : 4);
        CHECK_OK(ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_CLAMP, &b, &err));
        CHECK_OK(ffd_lattice_eval(lat, b, c, &err));
        omp_set_num_threads(nt);
        CHECK(memcmp(a, c, 3 * n * sizeof *a) == 0);
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
        free(p), free(a), free(c);
    }
}

/* The fast path stays the fast path: a cartesian shape with one of its
 * bases on every axis makes the plain lattice. */
static void test_fast_path_kept(void)
{
    ffd_lattice_shape sh;
    memset(&sh, 0, sizeof sh);
    ffd_lattice *lat = make_shaped(&sh, 4, 4, 4);
    CHECK(lat && lat->gen == NULL);
    ffd_lattice_destroy(lat);
    for (int a = 0; a < 3; a++)
        sh.interp[a] = FFD_INTERP_BERNSTEIN;
    lat = make_shaped(&sh, 4, 4, 4);
    CHECK(lat && lat->gen == NULL && ffd_lattice_basis(lat) == FFD_BASIS_BERNSTEIN);
    ffd_lattice_destroy(lat);
}

/* Shapes refused, with the range named. */
static void test_bad_shapes(void)
{
    struct {
        ffd_lattice_shape sh;
        uint32_t res[3];
        const char *needle;
    } bad[6];
    memset(bad, 0, sizeof bad);
    bad[0].sh = mixed_shape();
    bad[0].sh.tension[1] = 1.0;
    bad[0].needle = "[-1, 1)";
    bad[1].sh = mixed_shape();
    bad[1].sh.continuity[1] = 1.5;
    bad[1].needle = "continuity 1.5 outside [-1, 1]";
    bad[2].sh = framed_shape(FFD_COORDINATES_CYLINDRICAL, 0, TWO_PI, 0, 0);
    bad[2].sh.interp[1] = FFD_INTERP_BERNSTEIN;
    bad[2].needle = "cannot be periodic";
    bad[3].sh = framed_shape(FFD_COORDINATES_CYLINDRICAL, 0, TWO_PI, 0, 0);
    bad[3].needle = "resolution 2 outside [3,";
    bad[4].sh = framed_shape(FFD_COORDINATES_SPHERICAL, 0, TWO_PI, 0, 4.0);
    bad[4].needle = "phi range";
    bad[5].sh = framed_shape(FFD_COORDINATES_CYLINDRICAL, 0, TWO_PI, 0, 0);
    bad[5].sh.frame.reference[0] = 0.2, bad[5].sh.frame.reference[1] = 1.0;
    bad[5].sh.frame.reference[2] = 0.1;
    bad[5].needle = "parallel to the axis";
    for (int k = 0; k < 6; k++) {
        uint32_t res[3] = {3, k == 3 ? 2 : 4, 4};
        ffd_lattice *lat = NULL;
        ffd_error err = {{0}};
        CHECK(ffd_lattice_create_shaped(FFD_BASIS_BSPLINE, &oblique_box, res, &bad[k].sh, &lat,
                                        &err) == FFD_ERR_INVALID);
        CHECK(lat == NULL);
        if (!strstr(err.message, bad[k].needle))
            fprintf(stderr, "case %d: message \"%s\" lacks \"%s\"\n", k, err.message, bad[k].needle);
        CHECK(strstr(err.message, bad[k].needle) != NULL);
    }
}

/* The fold check sees a fold made by pushing one control point through its
 * neighbour, and none at rest. */
static void test_fold_check(void)
{
    for (int v = 0; v < VARIANTS; v++) {
        ffd_lattice *lat = variant(v);
        ffd_fold_report f;
        ffd_error err = {{0}};
        CHECK_OK(ffd_lattice_fold_check(lat, &f, &err));
        CHECK(f.folded == 0 && fabs(f.min_det - 1.0) < 1e-12);
        ffd_fold_report_free(&f);
        uint32_t idx[3] = {1, 1, 1};
        double r0[3], r1[3], d[3];
        ffd_lattice_rest_point(lat, 1, 1, 1, r0);
        ffd_lattice_rest_point(lat, 2, 1, 1, r1);
        for (int c = 0; c < 3; c++)
            d[c] = 2.5 * (r1[c] - r0[c]);
        CHECK_OK(ffd_lattice_move(lat, idx, d, &err));
        CHECK_OK(ffd_lattice_fold_check(lat, &f, &err));
        CHECK(f.folded > 0 && f.min_det < 0);
        ffd_fold_report_free(&f);
        ffd_lattice_destroy(lat);
    }
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"partition_and_precision", test_partition_and_precision},
        {"inverse_rest_map", test_inverse_rest_map},
        {"cardinal_against_hermite", test_cardinal_against_hermite},
        {"identity_and_linear_precision", test_identity_and_linear_precision},
        {"rigid_motions", test_rigid_motions},
        {"jacobian_and_map_fd", test_jacobian_and_map_fd},
        {"direct_manipulation", test_direct_manipulation},
        {"linear_refinement", test_linear_refinement},
        {"seam_axis_poles", test_seam_axis_poles},
        {"tied_controls", test_tied_controls},
        {"thread_invariance", test_thread_invariance},
        {"fast_path_kept", test_fast_path_kept},
        {"bad_shapes", test_bad_shapes},
        {"fold_check", test_fold_check},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
