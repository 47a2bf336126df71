/* Sensitivities of the methods' own design variables (docs/sensitivities.md):
 * PB-FFD frames (rotation vector and scalings, McDonnell & Qin eq. 7, 9-10)
 * against central differences of ffd_pbffd_set_frame and against complex
 * steps through an independent complex implementation of eq. 1-7; the
 * centres' cascade (eq. 9-10) through the level's linear map; the T-spline
 * ARAP drag (Zhang et al. §3.4) at fixed rotations against central
 * differences of its global step, and the transpose products against the
 * products; GFFD's refusal. */
#include "ffd.h"
#include "check.h"
#include "tspline/tsv.h"

#include <complex.h>

/* ---------------- small helpers ---------------- */

static double max_abs(const double *a, size_t n)
{
    double m = 0;
    for (size_t i = 0; i < n; i++)
        m = fmax(m, fabs(a[i]));
    return m;
}

/* Relative difference of two vectors, scaled by the larger of their norms. */
static double rel_diff(const double *a, const double *b, size_t n)
{
    double d = 0, s = 0;
    for (size_t i = 0; i < n; i++) {
        d = fmax(d, fabs(a[i] - b[i]));
        s = fmax(s, fmax(fabs(a[i]), fabs(b[i])));
    }
    return d / fmax(s, 1e-300);
}

static double dot(const double *a, const double *b, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += a[i] * b[i];
    return s;
}

/* Column c of a CSR matrix, dense (rows). */
static void csr_column(const ffd_sparse *m, size_t c, double *out)
{
    for (size_t r = 0; r < m->rows; r++) {
        out[r] = 0;
        for (size_t k = m->row_ptr[r]; k < m->row_ptr[r + 1]; k++)
            if (m->col[k] == c)
                out[r] += m->val[k];
    }
}

/* Rodrigues: R = exp([w]x), real. */
static void rotation(const double w[3], double R[3][3])
{
    double t = sqrt(dot(w, w, 3));
    double a = t > 0 ? sin(t) / t : 1, b = t > 0 ? (1 - cos(t)) / (t * t) : 0.5;
    double K[3][3] = {{0, -w[2], w[1]}, {w[2], 0, -w[0]}, {-w[1], w[0], 0}};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double k2 = 0;
            for (int l = 0; l < 3; l++)
                k2 += K[i][l] * K[l][j];
            R[i][j] = (i == j) + a * K[i][j] + b * k2;
        }
}

/* The frame of e turned by w and each axis m scaled by s[m]. */
static void moved_frame(const ffd_ebf *e, const double w[3], const double s[3], double f[3][3])
{
    double R[3][3];
    rotation(w, R);
    for (int m = 0; m < 3; m++)
        for (int i = 0; i < 3; i++)
            f[m][i] = s[m] * (R[i][0] * e->frame[m][0] + R[i][1] * e->frame[m][1] +
                              R[i][2] * e->frame[m][2]);
}

/* ---------------- a small PB-FFD case ---------------- */

#define PB_N 40
#define PB_M 5

static double pb_points[3 * PB_N];
static ffd_ebf pb_controls[PB_M];

/* Oblique frames of unequal lengths and radii: every term of eq. 3 counts. */
static void pb_case(void)
{
    check_rng_state = 0x5e2517ull;
    for (size_t i = 0; i < 3 * PB_N; i++)
        pb_points[i] = check_rand01();
    for (size_t j = 0; j < PB_M; j++) {
        ffd_ebf *e = &pb_controls[j];
        memset(e, 0, sizeof *e);
        for (int a = 0; a < 3; a++) {
            e->center[a] = 0.2 + 0.6 * check_rand01();
            e->radius[a] = 0.6 + 0.3 * check_rand01();
            for (int b = 0; b < 3; b++)
                e->frame[a][b] = (a == b ? 0.8 + 0.4 * check_rand01() : 0.0) +
                                 0.2 * (check_rand01() - 0.5);
        }
    }
}

static ffd_pbffd *pb_make(uint32_t levels)
{
    pb_case();
    ffd_pbffd_options o = {0};
    o.levels = levels;
    o.sigma = 0.7;
    ffd_pbffd *pb = NULL;
    CHECK_OK(ffd_pbffd_create(pb_controls, PB_M, pb_points, PB_N, &o, &pb, NULL));
    return pb;
}

/* A deformed state: the derivative is taken there, not at rest. */
static void pb_deform(ffd_pbffd *pb)
{
    const double d0[3] = {0.05, -0.03, 0.02}, d2[3] = {-0.04, 0.01, 0.06};
    CHECK_OK(ffd_pbffd_move(pb, 0, 0, d0, NULL));
    CHECK_OK(ffd_pbffd_move(pb, 0, 2, d2, NULL));
    ffd_ebf e;
    CHECK_OK(ffd_pbffd_control(pb, 0, 1, &e, NULL));
    double f[3][3];
    const double w[3] = {0.3, -0.2, 0.1}, s[3] = {1.2, 0.9, 1.1};
    moved_frame(&e, w, s, f);
    CHECK_OK(ffd_pbffd_set_frame(pb, 0, 1, (const double(*)[3])f, NULL));
}

/* Central difference of the bound points for variable col (6 per control)
 * of level, through ffd_pbffd_set_frame; the frame is put back. */
static void pb_fd_column(ffd_pbffd *pb, size_t level, size_t col, double h, double *out)
{
    size_t q = col / 6, k = col % 6, n = ffd_pbffd_point_count(pb);
    ffd_ebf e;
    CHECK_OK(ffd_pbffd_control(pb, level, q, &e, NULL));
    double *xp = malloc(3 * n * sizeof *xp), *xm = malloc(3 * n * sizeof *xm);
    for (int sgn = -1; sgn <= 1; sgn += 2) {
        double w[3] = {0, 0, 0}, s[3] = {1, 1, 1}, f[3][3];
        if (k < 3)
            w[k] = sgn * h;
        else
            s[k - 3] = 1 + sgn * h;
        moved_frame(&e, w, s, f);
        CHECK_OK(ffd_pbffd_set_frame(pb, level, q, (const double(*)[3])f, NULL));
        CHECK_OK(ffd_pbffd_eval(pb, sgn > 0 ? xp : xm, NULL));
    }
    CHECK_OK(ffd_pbffd_set_frame(pb, level, q, (const double(*)[3])e.frame, NULL));
    for (size_t i = 0; i < 3 * n; i++)
        out[i] = (xp[i] - xm[i]) / (2 * h);
    free(xp);
    free(xm);
}

/* Every column of the matrix against central differences, and the
 * products against the matrix. */
static void check_frames_fd(ffd_pbffd *pb, size_t level)
{
    ffd_sparse W = {0};
    CHECK_OK(ffd_pbffd_frame_sensitivities(pb, level, &W, NULL));
    size_t n = ffd_pbffd_point_count(pb), m = ffd_pbffd_control_count(pb, level);
    CHECK(W.rows == 3 * n && W.cols == 6 * m && W.nnz == W.row_ptr[W.rows]);
    for (size_t r = 0; r < W.rows; r++)
        for (size_t k = W.row_ptr[r] + 1; k < W.row_ptr[r + 1]; k++)
            CHECK(W.col[k - 1] < W.col[k]);
    double *col = malloc(3 * n * sizeof *col), *fd = malloc(3 * n * sizeof *fd);
    double *e = calloc(6 * m, sizeof *e), *prod = malloc(3 * n * sizeof *prod);
    double worst = 0;
    size_t nonzero_columns = 0;
    for (size_t c = 0; c < 6 * m; c++) {
        csr_column(&W, c, col);
        pb_fd_column(pb, level, c, 1e-5, fd);
        double scale = fmax(max_abs(col, 3 * n), max_abs(fd, 3 * n));
        nonzero_columns += scale > 0;
        for (size_t i = 0; i < 3 * n; i++)
            worst = fmax(worst, fabs(col[i] - fd[i]) / fmax(scale, 1e-300));
        e[c] = 1;
        CHECK_OK(ffd_pbffd_frame_sensitivity_product(pb, level, e, prod, NULL));
        e[c] = 0;
        CHECK(rel_diff(prod, col, 3 * n) <= 1e-14 || max_abs(col, 3 * n) == 0);
    }
    CHECK_NEAR(worst, 0, 1e-8);
    CHECK(nonzero_columns >= 6 * m - 6); /* the test sees the columns it checks */
    free(col);
    free(fd);
    free(e);
    free(prod);
    ffd_sparse_free(&W);
}

static void pbffd_frames_match_central_differences(void)
{
    ffd_pbffd *pb = pb_make(1);
    pb_deform(pb);
    check_frames_fd(pb, 0);
    ffd_pbffd_destroy(pb);
}

/* A coarser level's frame moves level 0's centres through eq. 10, then the
 * points through eq. 9 (ffd_pbffd_set_frame's cascade). */
static void pbffd_coarse_frames_match_central_differences(void)
{
    ffd_pbffd *pb = pb_make(2);
    CHECK(ffd_pbffd_level_count(pb) == 2);
    pb_deform(pb);
    check_frames_fd(pb, 1);
    check_frames_fd(pb, 0);
    ffd_pbffd_destroy(pb);
}

/* <W v, w> = <v, W^T w>, and W^T w against the matrix. */
static void pbffd_frame_transpose_product(void)
{
    ffd_pbffd *pb = pb_make(2);
    pb_deform(pb);
    for (size_t level = 0; level < 2; level++) {
        size_t n = PB_N, m = ffd_pbffd_control_count(pb, level);
        double *v = malloc(6 * m * sizeof *v), *w = malloc(3 * n * sizeof *w);
        double *Wv = malloc(3 * n * sizeof *Wv), *Wtw = malloc(6 * m * sizeof *Wtw);
        double *ref = calloc(6 * m, sizeof *ref);
        for (size_t i = 0; i < 6 * m; i++)
            v[i] = check_rand01() - 0.5;
        for (size_t i = 0; i < 3 * n; i++)
            w[i] = check_rand01() - 0.5;
        CHECK_OK(ffd_pbffd_frame_sensitivity_product(pb, level, v, Wv, NULL));
        CHECK_OK(ffd_pbffd_frame_sensitivity_transpose_product(pb, level, w, Wtw, NULL));
        double a = dot(Wv, w, 3 * n), b = dot(v, Wtw, 6 * m);
        CHECK_NEAR(a, b, 1e-12 * fmax(1, fabs(a)));
        ffd_sparse W = {0};
        CHECK_OK(ffd_pbffd_frame_sensitivities(pb, level, &W, NULL));
        for (size_t r = 0; r < W.rows; r++)
            for (size_t k = W.row_ptr[r]; k < W.row_ptr[r + 1]; k++)
                ref[W.col[k]] += W.val[k] * w[r];
        CHECK(rel_diff(ref, Wtw, 6 * m) <= 1e-13);
        ffd_sparse_free(&W);
        free(v);
        free(w);
        free(Wv);
        free(Wtw);
        free(ref);
    }
    ffd_pbffd_destroy(pb);
}

/* ---- an independent complex implementation of eq. 1-7 ---- */

typedef double complex cplx;

static double det3(const double a[3], const double b[3], const double c[3])
{
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - b[0] * (a[1] * c[2] - a[2] * c[1]) +
           c[0] * (a[1] * b[2] - a[2] * b[1]);
}

/* eq. 1 (windowed as the library documents it, ffd_pbffd.h "The kernel")
 * and eq. 3 (Cramer) of control e at x: phi, and the parameters u. */
static double ref_phi(const ffd_ebf *e, double sigma, const double x[3], double u[3])
{
    double v[3] = {x[0] - e->center[0], x[1] - e->center[1], x[2] - e->center[2]};
    double d = det3(e->frame[0], e->frame[1], e->frame[2]);
    u[0] = det3(v, e->frame[1], e->frame[2]) / d;
    u[1] = det3(e->frame[0], v, e->frame[2]) / d;
    u[2] = det3(e->frame[0], e->frame[1], v) / d;
    double r2 = 0;
    for (int k = 0; k < 3; k++) {
        double t = u[k] * sqrt(dot(e->frame[k], e->frame[k], 3)) / e->radius[k];
        r2 += t * t;
    }
    if (r2 >= 1)
        return 0;
    return exp(-r2 / (2 * sigma * sigma)) * pow(1 - r2, 3);
}

/* exp([w]x) for complex w near 0 by its series in theta^2 = w . w (no
 * conjugate: the analytic continuation the complex step needs). */
static void crotation(const cplx w[3], cplx R[3][3])
{
    cplx t2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    cplx a = 1 - t2 / 6 + t2 * t2 / 120 - t2 * t2 * t2 / 5040;
    cplx b = 0.5 - t2 / 24 + t2 * t2 / 720 - t2 * t2 * t2 / 40320;
    cplx K[3][3] = {{0, -w[2], w[1]}, {w[2], 0, -w[0]}, {-w[1], w[0], 0}};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            cplx k2 = 0;
            for (int l = 0; l < 3; l++)
                k2 += K[i][l] * K[l][j];
            R[i][j] = (i == j) + a * K[i][j] + b * k2;
        }
}

/* The bound points (one level, master as created) with control q's frame
 * turned by w and scaled by s (complex), the others as cur; weights and
 * parameters from the controls as created (rest): eq. 5 normalised with the
 * master's term, eq. 7 x' = x + sum_j w_j (dP_j + u_j . dA_j). */
static void ref_points(const ffd_ebf *rest, const ffd_ebf *cur, size_t m, const ffd_ebf *master,
                       double sigma, size_t q, const cplx w[3], const cplx s[3], cplx *out)
{
    cplx R[3][3], Aq[3][3];
    crotation(w, R);
    for (int a = 0; a < 3; a++)
        for (int i = 0; i < 3; i++)
            Aq[a][i] = s[a] * (R[i][0] * cur[q].frame[a][0] + R[i][1] * cur[q].frame[a][1] +
                               R[i][2] * cur[q].frame[a][2]);
    for (size_t i = 0; i < PB_N; i++) {
        const double *x = pb_points + 3 * i;
        double phi[PB_M], u[PB_M][3], um[3], S = 0;
        for (size_t j = 0; j < m; j++)
            S += phi[j] = ref_phi(&rest[j], sigma, x, u[j]);
        if (master)
            S += ref_phi(master, sigma, x, um);
        for (int c = 0; c < 3; c++) {
            cplx acc = x[c];
            for (size_t j = 0; j < m && S > 0; j++) {
                if (phi[j] == 0)
                    continue;
                cplx d = cur[j].center[c] - rest[j].center[c];
                for (int a = 0; a < 3; a++)
                    d += u[j][a] * ((j == q ? Aq[a][c] : cur[j].frame[a][c]) - rest[j].frame[a][c]);
                acc += phi[j] / S * d;
            }
            out[3 * i + c] = acc;
        }
    }
}

static void pbffd_frames_match_complex_step(void)
{
    ffd_pbffd *pb = pb_make(1);
    pb_deform(pb);
    ffd_ebf cur[PB_M], master;
    for (size_t j = 0; j < PB_M; j++)
        CHECK_OK(ffd_pbffd_control(pb, 0, j, &cur[j], NULL));
    CHECK(ffd_pbffd_master(pb, 0, &master) == 1);
    cplx *z = malloc(3 * PB_N * sizeof *z);
    double *x = malloc(3 * PB_N * sizeof *x), *col = malloc(3 * PB_N * sizeof *col);
    /* the reference reproduces the library's points where they are */
    const cplx w0[3] = {0, 0, 0}, s1[3] = {1, 1, 1};
    ref_points(pb_controls, cur, PB_M, &master, 0.7, 0, w0, s1, z);
    CHECK_OK(ffd_pbffd_eval(pb, x, NULL));
    double worst = 0;
    for (size_t i = 0; i < 3 * PB_N; i++)
        worst = fmax(worst, fabs(creal(z[i]) - x[i]));
    CHECK_NEAR(worst, 0, 1e-13);
    ffd_sparse W = {0};
    CHECK_OK(ffd_pbffd_frame_sensitivities(pb, 0, &W, NULL));
    const double h = 1e-30;
    worst = 0;
    for (size_t c = 0; c < 6 * PB_M; c++) {
        cplx w[3] = {0, 0, 0}, s[3] = {1, 1, 1};
        if (c % 6 < 3)
            w[c % 6] = I * h;
        else
            s[c % 6 - 3] += I * h;
        ref_points(pb_controls, cur, PB_M, &master, 0.7, c / 6, w, s, z);
        csr_column(&W, c, col);
        double scale = 0;
        for (size_t i = 0; i < 3 * PB_N; i++)
            scale = fmax(scale, fmax(fabs(cimag(z[i]) / h), fabs(col[i])));
        for (size_t i = 0; i < 3 * PB_N; i++)
            worst = fmax(worst, fabs(cimag(z[i]) / h - col[i]) / fmax(scale, 1e-300));
    }
    CHECK_NEAR(worst, 0, 1e-8);
    ffd_sparse_free(&W);
    free(z);
    free(x);
    free(col);
    ffd_pbffd_destroy(pb);
}

/* The centres (S1's generic W is the level's linear map): level 1's map
 * composes eq. 10 into eq. 9, against central differences of
 * ffd_pbffd_move at level 1 (the cascade). */
static void pbffd_coarse_centres_cascade(void)
{
    ffd_pbffd *pb = pb_make(2);
    pb_deform(pb);
    ffd_linear_map map;
    CHECK_OK(ffd_pbffd_linear_map(pb, 1, &map, NULL));
    size_t m = ffd_pbffd_control_count(pb, 1), n = PB_N;
    CHECK(map.column_count == m && map.point_count == n);
    double *Wd = calloc(n * m, sizeof *Wd);
    uint32_t *cols = malloc(map.max_row_nnz * sizeof *cols);
    double *w = malloc(map.max_row_nnz * sizeof *w);
    for (size_t i = 0; i < n; i++) {
        size_t k = map.row(map.self, i, cols, w);
        for (size_t e = 0; e < k; e++)
            Wd[i * m + cols[e]] += w[e];
    }
    double *xp = malloc(3 * n * sizeof *xp), *xm = malloc(3 * n * sizeof *xm);
    double worst = 0, h = 1e-6;
    int seen = 0;
    for (size_t q = 0; q < m; q++)
        for (int a = 0; a < 3; a++) {
            double d[3] = {0, 0, 0};
            d[a] = h;
            CHECK_OK(ffd_pbffd_move(pb, 1, q, d, NULL));
            CHECK_OK(ffd_pbffd_eval(pb, xp, NULL));
            d[a] = -2 * h;
            CHECK_OK(ffd_pbffd_move(pb, 1, q, d, NULL));
            CHECK_OK(ffd_pbffd_eval(pb, xm, NULL));
            d[a] = h;
            CHECK_OK(ffd_pbffd_move(pb, 1, q, d, NULL));
            for (size_t i = 0; i < n; i++)
                for (int c = 0; c < 3; c++) {
                    double fd = (xp[3 * i + c] - xm[3 * i + c]) / (2 * h);
                    double ex = c == a ? Wd[i * m + q] : 0;
                    seen |= ex != 0;
                    worst = fmax(worst, fabs(fd - ex));
                }
        }
    CHECK(seen);
    CHECK_NEAR(worst, 0, 1e-8);
    free(Wd);
    free(cols);
    free(w);
    free(xp);
    free(xm);
    ffd_pbffd_destroy(pb);
}

static void pbffd_frame_sensitivities_bad_input(void)
{
    ffd_pbffd *pb = pb_make(1);
    ffd_sparse W = {0};
    ffd_error err = {{0}};
    CHECK(ffd_pbffd_frame_sensitivities(pb, 1, &W, &err) == FFD_ERR_RANGE);
    CHECK(strstr(err.message, "level 1") != NULL);
    CHECK(W.row_ptr == NULL && W.rows == 0);
    CHECK(ffd_pbffd_frame_sensitivities(pb, 0, NULL, &err) == FFD_ERR_INVALID);
    double out[3 * PB_N];
    CHECK(ffd_pbffd_frame_sensitivity_product(pb, 0, NULL, out, &err) == FFD_ERR_INVALID);
    CHECK(ffd_pbffd_frame_sensitivity_transpose_product(pb, 3, out, out, &err) == FFD_ERR_RANGE);
    ffd_pbffd_destroy(pb);
}

/* ---------------- T-spline: the ARAP drag at fixed rotations ---------------- */

#define TS_N 60

static ffd_tsv *ts_make(double *pts)
{
    check_rng_state = 0x75b1ull;
    for (size_t i = 0; i < 3 * TS_N; i++)
        pts[i] = (i % 3 == 0 ? 2.0 : 1.0) * check_rand01();
    /* the corners, so that the box and every proxy cell are met */
    for (int c = 0; c < 8; c++)
        for (int a = 0; a < 3; a++)
            pts[3 * c + a] = (c >> a & 1) ? (a == 0 ? 2.0 : 1.0) : 0.0;
    const uint32_t res[3] = {5, 4, 4};
    ffd_tsv *t = NULL;
    CHECK_OK(ffd_tsv_create(pts, TS_N, NULL, NULL, 0, res, NULL, &t, NULL));
    return t;
}

static void check_arap(int soft)
{
    double pts[3 * TS_N];
    ffd_tsv *t = ts_make(pts);
    if (!t)
        return;
    ffd_tsv_proxy proxy;
    ffd_tsv_get_proxy(t, &proxy);
    CHECK(proxy.vertex_count >= 8);
    /* three handles on the proxy, one frozen point */
    uint32_t h[3] = {proxy.vertices[0], proxy.vertices[proxy.vertex_count / 2],
                     proxy.vertices[proxy.vertex_count - 1]};
    CHECK_OK(ffd_tsv_set_frozen(t, proxy.vertices[1], 1, NULL));
    ffd_tsv_arap_options o = {0};
    o.soft = soft;
    o.iterations = 3;
    ffd_tsv_arap *a = NULL;
    CHECK_OK(ffd_tsv_arap_begin(t, h, 3, &o, &a, NULL));
    if (!a) {
        ffd_tsv_destroy(t);
        return;
    }
    const double *P = ffd_tsv_control_points(t);
    double q[9];
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 3; c++)
            q[3 * k + c] = P[3 * (size_t)h[k] + c] + 0.2 * (check_rand01() - 0.5);
    /* a solve: the rotations are no longer the identity */
    CHECK_OK(ffd_tsv_arap_solve(a, q, NULL, NULL));
    double Wv[3 * TS_N], xp[3 * TS_N], xm[3 * TS_N], fd[3 * TS_N], qq[9];
    double worst = 0, hstep = 1e-4;
    for (size_t col = 0; col < 9; col++) {
        double v[9] = {0};
        v[col] = 1;
        CHECK_OK(ffd_tsv_arap_sensitivity_product(a, v, Wv, NULL));
        memcpy(qq, q, sizeof qq);
        qq[col] += hstep;
        CHECK_OK(ffd_tsv_arap_global_step(a, qq, xp, NULL));
        qq[col] -= 2 * hstep;
        CHECK_OK(ffd_tsv_arap_global_step(a, qq, xm, NULL));
        for (size_t i = 0; i < 3 * TS_N; i++)
            fd[i] = (xp[i] - xm[i]) / (2 * hstep);
        CHECK(max_abs(Wv, 3 * TS_N) > 1e-3);
        worst = fmax(worst, rel_diff(Wv, fd, 3 * TS_N));
    }
    CHECK_NEAR(worst, 0, 1e-8);
    /* the transpose product is the adjoint of the product */
    double v[9], w[3 * TS_N], Wtw[9];
    for (int i = 0; i < 9; i++)
        v[i] = check_rand01() - 0.5;
    for (int i = 0; i < 3 * TS_N; i++)
        w[i] = check_rand01() - 0.5;
    CHECK_OK(ffd_tsv_arap_sensitivity_product(a, v, Wv, NULL));
    CHECK_OK(ffd_tsv_arap_sensitivity_transpose_product(a, w, Wtw, NULL));
    double l = dot(Wv, w, 3 * TS_N), r = dot(v, Wtw, 9);
    CHECK_NEAR(l, r, 1e-10 * fmax(1, fabs(l)));
    ffd_tsv_arap_destroy(a);
    ffd_tsv_destroy(t);
}

static void tspline_arap_hard_matches_central_differences(void)
{
    check_arap(0);
}

static void tspline_arap_soft_matches_central_differences(void)
{
    check_arap(1);
}

/* A translation of every handle moves every bound point by the same
 * amount in hard mode with nothing frozen (ARAP reproduces translations). */
static void tspline_arap_translation(void)
{
    double pts[3 * TS_N];
    ffd_tsv *t = ts_make(pts);
    if (!t)
        return;
    ffd_tsv_proxy proxy;
    ffd_tsv_get_proxy(t, &proxy);
    size_t k = proxy.vertex_count;
    ffd_tsv_arap *a = NULL;
    CHECK_OK(ffd_tsv_arap_begin(t, proxy.vertices, k, NULL, &a, NULL));
    double *v = malloc(3 * k * sizeof *v), Wv[3 * TS_N];
    for (size_t i = 0; i < k; i++) {
        v[3 * i] = 1;
        v[3 * i + 1] = -2;
        v[3 * i + 2] = 0.5;
    }
    CHECK_OK(ffd_tsv_arap_sensitivity_product(a, v, Wv, NULL));
    double worst = 0;
    for (size_t i = 0; i < TS_N; i++)
        worst = fmax(worst, fabs(Wv[3 * i] - 1) + fabs(Wv[3 * i + 1] + 2) + fabs(Wv[3 * i + 2] - 0.5));
    CHECK_NEAR(worst, 0, 1e-9);
    free(v);
    ffd_tsv_arap_destroy(a);
    ffd_tsv_destroy(t);
}

static void tspline_arap_stale_drag(void)
{
    double pts[3 * TS_N];
    ffd_tsv *t = ts_make(pts);
    if (!t)
        return;
    ffd_tsv_proxy proxy;
    ffd_tsv_get_proxy(t, &proxy);
    uint32_t hd = proxy.vertices[0];
    ffd_tsv_arap *a = NULL;
    CHECK_OK(ffd_tsv_arap_begin(t, &hd, 1, NULL, &a, NULL));
    CHECK_OK(ffd_tsv_set_frozen(t, proxy.vertices[1], 1, NULL));
    double v[3] = {1, 0, 0}, out[3 * TS_N];
    ffd_error err = {{0}};
    CHECK(ffd_tsv_arap_sensitivity_product(a, v, out, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "frozen set changed") != NULL);
    CHECK(ffd_tsv_arap_sensitivity_transpose_product(a, out, v, &err) == FFD_ERR_INVALID);
    ffd_tsv_arap_destroy(a);
    ffd_tsv_destroy(t);
}

/* ---------------- GFFD: no sensitivities, and why ---------------- */

static void gffd_sensitivities_unsupported(void)
{
    const double pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const uint32_t off[] = {0, 3, 6, 9, 12}, idx[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    ffd_mesh *mesh = NULL;
    CHECK_OK(ffd_mesh_create(pos, 4, off, idx, 4, &mesh, NULL));
    const char *rig = "{\"deformer\": \"gffd\", \"skeleton\": [{\"type\": \"point\", "
                      "\"position\": [0.2,0.2,0.2], \"radius\": 1.5}]}";
    ffd_deformer *d = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_deformer_create_json(rig, strlen(rig), "rig.json", mesh, NULL, &d, &err));
    if (!d) {
        fprintf(stderr, "%s\n", err.message);
        ffd_mesh_destroy(mesh);
        return;
    }
    size_t nc = ffd_deformer_control_count(d);
    double *v = calloc(3 * (nc ? nc : 1), sizeof *v), out[12];
    ffd_sparse W = {0};
    CHECK(ffd_deformer_sensitivities(d, &W, &err) == FFD_ERR_UNSUPPORTED);
    CHECK(strstr(err.message, "gffd method") && strstr(err.message, "not a linear map") &&
          strstr(err.message, "tracking"));
    CHECK(W.row_ptr == NULL);
    CHECK(ffd_deformer_sensitivity_product(d, v, out, &err) == FFD_ERR_UNSUPPORTED);
    CHECK(strstr(err.message, "field's gradient") != NULL);
    CHECK(ffd_deformer_sensitivity_transpose_product(d, out, v, &err) == FFD_ERR_UNSUPPORTED);
    free(v);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"pbffd_frames_match_central_differences", pbffd_frames_match_central_differences},
        {"pbffd_coarse_frames_match_central_differences",
         pbffd_coarse_frames_match_central_differences},
        {"pbffd_frame_transpose_product", pbffd_frame_transpose_product},
        {"pbffd_frames_match_complex_step", pbffd_frames_match_complex_step},
        {"pbffd_coarse_centres_cascade", pbffd_coarse_centres_cascade},
        {"pbffd_frame_sensitivities_bad_input", pbffd_frame_sensitivities_bad_input},
        {"tspline_arap_hard_matches_central_differences",
         tspline_arap_hard_matches_central_differences},
        {"tspline_arap_soft_matches_central_differences",
         tspline_arap_soft_matches_central_differences},
        {"tspline_arap_translation", tspline_arap_translation},
        {"tspline_arap_stale_drag", tspline_arap_stale_drag},
        {"gffd_sensitivities_unsupported", gffd_sensitivities_unsupported},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
