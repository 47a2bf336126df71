/* Tests of RBF morphing (src/rbf, include/ffd_rbf.h) and inverse-distance
 * weighting (src/idw, include/ffd_idw.h): identity at rest (bitwise),
 * interpolation of the control points, affine and rigid motions reproduced
 * by the RBF's linear part, partition of unity, the map against PyGeM's
 * formulas written out independently (the absolute system solved by
 * Gaussian elimination here), Jacobians against finite differences, direct
 * manipulation reaching its targets, thread-count independence, and the
 * refusals (coincident control points, radius, kernel, counts). */
#include "check.h"

#include "ffd.h"
#include "rig/rig_json.h" /* ffd_rig_write_json: the rig as JSON text */

#include <omp.h>
#include <stdint.h>

#define EX FFD_SOURCE_DIR "/examples/"

/* 12 control points in general position in [0,1]^3 and 9 probe points */
static const double C[12][3] = {{0, 0, 0},         {1, 0, 0},         {0, 1, 0},
                                {0, 0, 1},         {1, 1, 1},         {0.5, 0.2, 0.8},
                                {0.3, 0.9, 0.1},   {0.8, 0.4, 0.3},   {0.15, 0.55, 0.65},
                                {0.95, 0.85, 0.05}, {0.4, 0.45, 0.5}, {0.7, 0.1, 0.9}};
static const double X[9][3] = {{0.1, 0.2, 0.3},  {0.5, 0.5, 0.5},   {0.9, 0.1, 0.4},
                               {1.3, -0.2, 0.6}, {0.25, 0.75, 0.9}, {0.6, 0.3, 0.31},
                               {0.3, 0.9, 0.1},  {-0.4, 0.4, 1.4},  {0.71, 0.12, 0.88}};
#define NC 12
#define NX 9

static void moved_points(double P[NC][3])
{
    for (int j = 0; j < NC; j++)
        for (int a = 0; a < 3; a++)
            P[j][a] = C[j][a] + 0.1 * sin(3.0 * j + a) * (j % 3 != 0);
}

/* ---- PyGeM's formulas, written out again (pygem/rbf_factory.py docstrings) ---- */

static double kernel_again(ffd_rbf_kernel k, double x, double r, unsigned p)
{
    double a = x / r;
    switch (k) {
    case FFD_RBF_GAUSSIAN: return exp(-a * a);
    case FFD_RBF_MULTIQUADRIC: return sqrt(x * x + r * r);
    case FFD_RBF_INV_MULTIQUADRIC: return 1 / sqrt(x * x + r * r);
    case FFD_RBF_THIN_PLATE: return a > 0 ? pow(a, p) * log(a) : 0;
    case FFD_RBF_WENDLAND_C2: return a < 1 ? pow(1 - a, 4) * (4 * a + 1) : 0;
    case FFD_RBF_POLYHARMONIC:
        return p % 2 ? pow(a, p) : a > 0 ? pow(a, p) * log(a) : 0; /* a^(k-1) ln(a^a) = a^k ln a */
    default: return NAN;
    }
}

/* Solves the n x n system A X = B (3 right-hand sides, row-major) by
 * Gaussian elimination with partial pivoting. */
static void gauss(int n, double *A, double *B)
{
    for (int c = 0; c < n; c++) {
        int piv = c;
        for (int r = c + 1; r < n; r++)
            if (fabs(A[r * n + c]) > fabs(A[piv * n + c]))
                piv = r;
        for (int k = 0; k < n; k++) {
            double t = A[c * n + k]; A[c * n + k] = A[piv * n + k]; A[piv * n + k] = t;
        }
        for (int k = 0; k < 3; k++) {
            double t = B[c * 3 + k]; B[c * 3 + k] = B[piv * 3 + k]; B[piv * 3 + k] = t;
        }
        for (int r = c + 1; r < n; r++) {
            double f = A[r * n + c] / A[c * n + c];
            for (int k = c; k < n; k++)
                A[r * n + k] -= f * A[c * n + k];
            for (int k = 0; k < 3; k++)
                B[r * 3 + k] -= f * B[c * 3 + k];
        }
    }
    for (int r = n - 1; r >= 0; r--)
        for (int k = 0; k < 3; k++) {
            double s = B[r * 3 + k];
            for (int c = r + 1; c < n; c++)
                s -= A[r * n + c] * B[c * 3 + k];
            B[r * 3 + k] = s / A[r * n + r];
        }
}

/* PyGeM's RBF.__call__: H(x) W with H W = [Y; 0; 0], Y the moved points. */
static void pygem_rbf(ffd_rbf_kernel k, double r, unsigned p, const double P[NC][3],
                      const double x[3], double out[3])
{
    enum { M = NC + 4 };
    double H[M * M] = {0}, W[M * 3] = {0}, h[M];
    for (int i = 0; i < NC; i++) {
        for (int j = 0; j < NC; j++) {
            double d = sqrt(pow(C[i][0] - C[j][0], 2) + pow(C[i][1] - C[j][1], 2) +
                            pow(C[i][2] - C[j][2], 2));
            H[i * M + j] = kernel_again(k, d, r, p);
        }
        H[i * M + NC] = H[NC * M + i] = 1;
        for (int a = 0; a < 3; a++) {
            H[i * M + NC + 1 + a] = H[(NC + 1 + a) * M + i] = C[i][a];
            W[i * 3 + a] = P[i][a];
        }
    }
    gauss(M, H, W);
    for (int j = 0; j < NC; j++)
        h[j] = kernel_again(k, sqrt(pow(x[0] - C[j][0], 2) + pow(x[1] - C[j][1], 2) +
                                    pow(x[2] - C[j][2], 2)), r, p);
    h[NC] = 1;
    for (int a = 0; a < 3; a++)
        h[NC + 1 + a] = x[a];
    for (int a = 0; a < 3; a++) {
        out[a] = 0;
        for (int j = 0; j < M; j++)
            out[a] += h[j] * W[j * 3 + a];
    }
}

static ffd_rbf_morph *make_rbf(ffd_rbf_kernel k, double r, unsigned p)
{
    ffd_rbf_morph *rbf = NULL;
    ffd_rbf_options o = {k, r, p, FFD_RBF_SOLVER_AUTO};
    ffd_error err = {{0}};
    if (ffd_rbf_morph_create(&C[0][0], NC, &o, &rbf, &err))
        fprintf(stderr, "%s\n", err.message);
    return rbf;
}

static double rel(const double *a, const double *b, int n)
{
    double m = 0, s = 1;
    for (int i = 0; i < n; i++) {
        m = fmax(m, fabs(a[i] - b[i]));
        s = fmax(s, fabs(b[i]));
    }
    return m / s;
}

/* ---- RBF ---- */

/* Every kernel against PyGeM's absolute system solved independently. */
static void test_rbf_against_pygem(void)
{
    double P[NC][3], got[NX][3], want[3];
    moved_points(P);
    for (int k = 0; k < FFD_RBF_KERNEL_COUNT; k++)
        for (unsigned p = 1; p <= (k == FFD_RBF_POLYHARMONIC || k == FFD_RBF_THIN_PLATE ? 4 : 1); p++) {
            double r = k == FFD_RBF_WENDLAND_C2 ? 1.2 : 0.7;
            if (k == FFD_RBF_THIN_PLATE && p == 1)
                continue; /* a ln a: conditionally positive definite of order 1 only */
            ffd_rbf_morph *rbf = make_rbf((ffd_rbf_kernel)k, r, p);
            CHECK(rbf != NULL);
            if (!rbf)
                continue;
            CHECK_OK(ffd_rbf_morph_set_control_points(rbf, &P[0][0], NULL));
            CHECK_OK(ffd_rbf_morph_eval(rbf, &X[0][0], NX, &got[0][0], NULL));
            for (int i = 0; i < NX; i++) {
                pygem_rbf((ffd_rbf_kernel)k, r, p, (const double(*)[3])P, X[i], want);
                if (rel(got[i], want, 3) > 1e-10)
                    fprintf(stderr, "%s k=%u point %d\n", ffd_rbf_kernel_name((ffd_rbf_kernel)k), p, i);
                CHECK(rel(got[i], want, 3) <= 1e-10);
            }
            ffd_rbf_morph_destroy(rbf);
        }
}

/* At rest every point comes back bitwise with an identity Jacobian; moved
 * control points are interpolated. */
static void test_rbf_identity_and_interpolation(void)
{
    double out[NX][3], J[NX][9], P[NC][3], at[NC][3];
    ffd_rbf_morph *rbf = make_rbf(FFD_RBF_MULTIQUADRIC, 0.5, 2);
    CHECK(rbf != NULL);
    if (!rbf)
        return;
    CHECK_OK(ffd_rbf_morph_eval(rbf, &X[0][0], NX, &out[0][0], NULL));
    CHECK(memcmp(out, X, sizeof out) == 0);
    CHECK_OK(ffd_rbf_morph_jacobian(rbf, &X[0][0], NX, &J[0][0], NULL));
    for (int i = 0; i < NX; i++)
        for (int e = 0; e < 9; e++)
            CHECK(J[i][e] == (e % 4 == 0));
    moved_points(P);
    CHECK_OK(ffd_rbf_morph_set_control_points(rbf, &P[0][0], NULL));
    CHECK_OK(ffd_rbf_morph_eval(rbf, &C[0][0], NC, &at[0][0], NULL));
    CHECK(rel(&at[0][0], &P[0][0], 3 * NC) <= 1e-12);
    CHECK_OK(ffd_rbf_morph_set_control_points(rbf, ffd_rbf_morph_rest_points(rbf), NULL));
    CHECK_OK(ffd_rbf_morph_eval(rbf, &X[0][0], NX, &out[0][0], NULL));
    CHECK(memcmp(out, X, sizeof out) == 0);
    ffd_rbf_morph_destroy(rbf);
}

/* The linear part reproduces affine motions of the control points exactly
 * (up to rounding) for every kernel: a rotation with translation, and a
 * shear with scaling; the cardinal functions sum to 1 and reproduce x. */
static void test_rbf_affine_and_rigid(void)
{
    const double c = cos(0.7), s = sin(0.7);
    const double maps[2][3][4] = {{{c, -s, 0, 0.3}, {s, c, 0, -1.2}, {0, 0, 1, 2.0}},
                                  {{1.5, 0.4, 0, 0.1}, {0, 0.8, 0.3, 0}, {0.2, 0, 1.1, -0.5}}};
    for (int k = 0; k < FFD_RBF_KERNEL_COUNT; k++)
        for (int m = 0; m < 2; m++) {
            ffd_rbf_morph *rbf = make_rbf((ffd_rbf_kernel)k, 0.9, 3);
            CHECK(rbf != NULL);
            if (!rbf)
                continue;
            double P[NC][3], out[NX][3], want[NX][3], a[NC + 4];
            for (int j = 0; j < NC; j++)
                for (int r = 0; r < 3; r++)
                    P[j][r] = maps[m][r][0] * C[j][0] + maps[m][r][1] * C[j][1] +
                              maps[m][r][2] * C[j][2] + maps[m][r][3];
            for (int i = 0; i < NX; i++)
                for (int r = 0; r < 3; r++)
                    want[i][r] = maps[m][r][0] * X[i][0] + maps[m][r][1] * X[i][1] +
                                 maps[m][r][2] * X[i][2] + maps[m][r][3];
            CHECK_OK(ffd_rbf_morph_set_control_points(rbf, &P[0][0], NULL));
            CHECK_OK(ffd_rbf_morph_eval(rbf, &X[0][0], NX, &out[0][0], NULL));
            CHECK(rel(&out[0][0], &want[0][0], 3 * NX) <= 1e-10);
            ffd_rbf_morph_cardinal(rbf, X[3], a);
            double sum = 0, lin[3] = {0, 0, 0};
            for (int j = 0; j < NC; j++) {
                sum += a[j];
                for (int r = 0; r < 3; r++)
                    lin[r] += a[j] * C[j][r];
            }
            CHECK_NEAR(sum, 1.0, 1e-10);
            CHECK(rel(lin, X[3], 3) <= 1e-10);
            ffd_rbf_morph_destroy(rbf);
        }
}

/* Jacobian against central differences of the evaluation. */
static void jacobian_fd(ffd_status (*eval)(const void *, const double *, size_t, double *, ffd_error *),
                        ffd_status (*jac)(const void *, const double *, size_t, double *, ffd_error *),
                        const void *h, const char *what)
{
    double J[NX][9];
    CHECK_OK(jac(h, &X[0][0], NX, &J[0][0], NULL));
    for (int i = 0; i < NX; i++) {
        if (i == 6)
            continue; /* X[6] is control point 6: IDW's cone */
        for (int b = 0; b < 3; b++) {
            const double step = 1e-6;
            double xp[3], xm[3], fp[3], fm[3];
            memcpy(xp, X[i], sizeof xp);
            memcpy(xm, X[i], sizeof xm);
            xp[b] += step;
            xm[b] -= step;
            CHECK_OK(eval(h, xp, 1, fp, NULL));
            CHECK_OK(eval(h, xm, 1, fm, NULL));
            for (int a = 0; a < 3; a++) {
                double fd = (fp[a] - fm[a]) / (2 * step);
                if (fabs(fd - J[i][3 * a + b]) > 1e-6 * fmax(1, fabs(fd)))
                    fprintf(stderr, "%s: point %d J[%d][%d] %.10g vs %.10g\n", what, i, a, b,
                            J[i][3 * a + b], fd);
                CHECK(fabs(fd - J[i][3 * a + b]) <= 1e-6 * fmax(1, fabs(fd)));
            }
        }
    }
}

static ffd_status rbf_eval_v(const void *h, const double *p, size_t n, double *o, ffd_error *e)
{
    return ffd_rbf_morph_eval(h, p, n, o, e);
}
static ffd_status rbf_jac_v(const void *h, const double *p, size_t n, double *o, ffd_error *e)
{
    return ffd_rbf_morph_jacobian(h, p, n, o, e);
}
static ffd_status idw_eval_v(const void *h, const double *p, size_t n, double *o, ffd_error *e)
{
    return ffd_idw_eval(h, p, n, o, e);
}
static ffd_status idw_jac_v(const void *h, const double *p, size_t n, double *o, ffd_error *e)
{
    return ffd_idw_jacobian(h, p, n, o, e);
}

static void test_jacobians(void)
{
    double P[NC][3];
    moved_points(P);
    for (int k = 0; k < FFD_RBF_KERNEL_COUNT; k++) {
        ffd_rbf_morph *rbf = make_rbf((ffd_rbf_kernel)k, 1.1, 3);
        CHECK(rbf != NULL);
        if (!rbf)
            continue;
        CHECK_OK(ffd_rbf_morph_set_control_points(rbf, &P[0][0], NULL));
        jacobian_fd(rbf_eval_v, rbf_jac_v, rbf, ffd_rbf_kernel_name((ffd_rbf_kernel)k));
        ffd_rbf_morph_destroy(rbf);
    }
    for (int w = 0; w < 2; w++)
        for (double p = 1.5; p <= 3; p += 0.5) { /* the 1-norm has kinks where x_b = c_jb */
            ffd_idw *idw = NULL;
            ffd_idw_options o = {p, (ffd_idw_weighting)w};
            CHECK_OK(ffd_idw_create(&C[0][0], NC, &o, &idw, NULL));
            if (!idw)
                continue;
            CHECK_OK(ffd_idw_set_control_points(idw, &P[0][0], NULL));
            jacobian_fd(idw_eval_v, idw_jac_v, idw, w ? "idw shepard" : "idw pygem");
            ffd_idw_destroy(idw);
        }
}

/* The sparse solver (CHOLMOD and the Schur complement of the polynomial
 * block) gives the dense solver's map, cardinal functions and sensitivity
 * products for the Wendland kernel; the grid-limited evaluation matches an
 * evaluation over every control point (the dense Gaussian path of
 * PyGeM's formula in test_rbf_against_pygem covers Wendland too). */
static void test_rbf_sparse_matches_dense(void)
{
    enum { N = 600, NP = 400 };
    uint64_t st = 12345;
    double *cp = malloc(3 * N * sizeof *cp), *moved = malloc(3 * N * sizeof *moved);
    double *pts = malloc(3 * NP * sizeof *pts), *a = malloc(3 * N * sizeof *a), *b = malloc(3 * NP * sizeof *b);
    for (int i = 0; i < 3 * N; i++) {
        st = st * 6364136223846793005ull + 1442695040888963407ull;
        cp[i] = (double)(st >> 11) / 9007199254740992.0;
        moved[i] = cp[i] + 0.01 * sin(i);
    }
    for (int i = 0; i < 3 * NP; i++)
        pts[i] = fmod(i * 0.7548776662466927, 1.2) - 0.1;
    ffd_rbf_morph *dense = NULL, *sparse = NULL;
    ffd_rbf_options od = {FFD_RBF_WENDLAND_C2, 0.25, 2, FFD_RBF_SOLVER_DENSE};
    ffd_rbf_options os = {FFD_RBF_WENDLAND_C2, 0.25, 2, FFD_RBF_SOLVER_SPARSE};
    ffd_error err = {{0}};
    CHECK_OK(ffd_rbf_morph_create(cp, N, &od, &dense, &err));
    CHECK_OK(ffd_rbf_morph_create(cp, N, &os, &sparse, &err));
    if (dense && sparse) {
        CHECK_OK(ffd_rbf_morph_set_control_points(dense, moved, NULL));
        CHECK_OK(ffd_rbf_morph_set_control_points(sparse, moved, NULL));
        CHECK_OK(ffd_rbf_morph_eval(dense, pts, NP, a, NULL));
        CHECK_OK(ffd_rbf_morph_eval(sparse, pts, NP, b, NULL));
        CHECK(rel(a, b, 3 * NP) <= 1e-10);
        CHECK_OK(ffd_rbf_morph_eval(sparse, cp, N, a, NULL)); /* interpolation */
        CHECK(rel(a, moved, 3 * N) <= 1e-10);
        double *wd = malloc((N + 4) * sizeof *wd), *ws = malloc((N + 4) * sizeof *ws);
        ffd_rbf_morph_cardinal(dense, pts + 30, wd);
        ffd_rbf_morph_cardinal(sparse, pts + 30, ws);
        CHECK(rel(wd, ws, N) <= 1e-10);
        free(wd);
        free(ws);
    }
    /* the sparse solver is for the Wendland kernel only */
    ffd_rbf_morph *bad = NULL;
    ffd_rbf_options og = {FFD_RBF_GAUSSIAN, 0.25, 2, FFD_RBF_SOLVER_SPARSE};
    CHECK(ffd_rbf_morph_create(cp, N, &og, &bad, &err) == FFD_ERR_INVALID && !bad);
    CHECK(strstr(err.message, "beckert_wendland_c2_basis") != NULL);
    ffd_rbf_morph_destroy(dense);
    ffd_rbf_morph_destroy(sparse);
    free(cp);
    free(moved);
    free(pts);
    free(a);
    free(b);
}

/* ---- IDW ---- */

/* PyGeM's IDW.__call__ written out: p-norm distances (numpy's norm(ord=p)),
 * weights 1/d, or 1 where d == 0 and 0 elsewhere. */
static void pygem_idw(double p, int shepard, const double P[NC][3], const double x[3],
                      double out[3])
{
    double w[NC], d[NC], sum = 0;
    int zero = 0;
    for (int j = 0; j < NC; j++) {
        double e0 = fabs(x[0] - C[j][0]), e1 = fabs(x[1] - C[j][1]), e2 = fabs(x[2] - C[j][2]);
        d[j] = shepard ? pow(e0 * e0 + e1 * e1 + e2 * e2, p / 2)
                       : pow(pow(e0, p) + pow(e1, p) + pow(e2, p), 1 / p);
        zero |= d[j] == 0;
    }
    for (int j = 0; j < NC; j++)
        sum += w[j] = zero ? d[j] == 0 : 1 / d[j];
    for (int a = 0; a < 3; a++) {
        out[a] = x[a];
        for (int j = 0; j < NC; j++)
            out[a] += (P[j][a] - C[j][a]) * w[j] / sum;
    }
}

static void test_idw_against_pygem(void)
{
    double P[NC][3], got[NX][3], want[3], rest[NX][3];
    moved_points(P);
    for (int shepard = 0; shepard < 2; shepard++)
        for (double p = 0.5; p <= 4; p += 0.5) {
            ffd_idw *idw = NULL;
            ffd_idw_options o = {p, shepard ? FFD_IDW_SHEPARD : FFD_IDW_PYGEM};
            CHECK_OK(ffd_idw_create(&C[0][0], NC, &o, &idw, NULL));
            if (!idw)
                continue;
            CHECK_OK(ffd_idw_eval(idw, &X[0][0], NX, &rest[0][0], NULL));
            CHECK(memcmp(rest, X, sizeof rest) == 0);
            CHECK_OK(ffd_idw_set_control_points(idw, &P[0][0], NULL));
            CHECK_OK(ffd_idw_eval(idw, &X[0][0], NX, &got[0][0], NULL));
            for (int i = 0; i < NX; i++) {
                pygem_idw(p, shepard, (const double(*)[3])P, X[i], want);
                CHECK(rel(got[i], want, 3) <= 1e-12);
            }
            /* X[6] is control point 6: it takes its displacement exactly */
            for (int a = 0; a < 3; a++)
                CHECK(got[6][a] == X[6][a] + (P[6][a] - C[6][a]));
            ffd_idw_destroy(idw);
        }
}

/* A translation of every control point moves every point by it (partition of unity). */
static void test_idw_translation(void)
{
    double P[NC][3], out[NX][3];
    ffd_idw *idw = NULL;
    CHECK_OK(ffd_idw_create(&C[0][0], NC, NULL, &idw, NULL));
    if (!idw)
        return;
    for (int j = 0; j < NC; j++)
        for (int a = 0; a < 3; a++)
            P[j][a] = C[j][a] + (a + 1) * 0.25;
    CHECK_OK(ffd_idw_set_control_points(idw, &P[0][0], NULL));
    CHECK_OK(ffd_idw_eval(idw, &X[0][0], NX, &out[0][0], NULL));
    for (int i = 0; i < NX; i++)
        for (int a = 0; a < 3; a++)
            CHECK_NEAR(out[i][a], X[i][a] + (a + 1) * 0.25, 1e-14);
    ffd_idw_destroy(idw);
}

/* ---- rigs: direct manipulation, threads, refusals ---- */

/* The example rigs with constraints reach their targets. */
static void test_direct_manipulation(void)
{
    const char *rigs[] = {EX "rbf/bunny-pins.json", EX "idw/bunny-pins.json"};
    for (int r = 0; r < 2; r++) {
        ffd_mesh *mesh = NULL;
        ffd_rig *rig = NULL;
        ffd_rig_report report = {0};
        ffd_error err = {{0}};
        CHECK_OK(ffd_mesh_read(EX "lattice/bunny.obj", &mesh, &err));
        CHECK_OK(ffd_rig_read(rigs[r], &rig, &err));
        if (mesh && rig) {
            CHECK_OK(ffd_rig_apply(rig, mesh, &report, &err));
            CHECK(report.constraint_count == 3);
            CHECK(report.max_residual <= 1e-9);
            /* the constrained vertex is where the target says */
            CHECK(rel(ffd_mesh_positions(mesh) + 3 * 553, (const double[]){1.5, 8.8, -1.0}, 3) <= 1e-9);
        }
        ffd_rig_report_free(&report);
        ffd_rig_destroy(rig);
        ffd_mesh_destroy(mesh);
    }
}

/* The same bits for 1 and 4 threads. */
static void test_threads(void)
{
    enum { N = 2000 };
    double *pts = malloc(3 * N * sizeof *pts), *a = malloc(3 * N * sizeof *a), *b = malloc(3 * N * sizeof *b);
    double P[NC][3];
    moved_points(P);
    for (int i = 0; i < 3 * N; i++)
        pts[i] = fmod(i * 0.618033988749895, 1.3) - 0.15;
    ffd_rbf_morph *rbf = make_rbf(FFD_RBF_GAUSSIAN, 0.6, 2);
    ffd_idw *idw = NULL;
    CHECK_OK(ffd_idw_create(&C[0][0], NC, NULL, &idw, NULL));
    if (rbf && idw) {
        CHECK_OK(ffd_rbf_morph_set_control_points(rbf, &P[0][0], NULL));
        CHECK_OK(ffd_idw_set_control_points(idw, &P[0][0], NULL));
        int saved = omp_get_max_threads();
        omp_set_num_threads(1);
        CHECK_OK(ffd_rbf_morph_eval(rbf, pts, N, a, NULL));
        omp_set_num_threads(4);
        CHECK_OK(ffd_rbf_morph_eval(rbf, pts, N, b, NULL));
        CHECK(memcmp(a, b, 3 * N * sizeof *a) == 0);
        omp_set_num_threads(1);
        CHECK_OK(ffd_idw_eval(idw, pts, N, a, NULL));
        omp_set_num_threads(4);
        CHECK_OK(ffd_idw_eval(idw, pts, N, b, NULL));
        CHECK(memcmp(a, b, 3 * N * sizeof *a) == 0);
        omp_set_num_threads(saved);
    }
    ffd_rbf_morph_destroy(rbf);
    ffd_idw_destroy(idw);
    free(pts);
    free(a);
    free(b);
}

/* A rig's text is refused with a message holding want. */
static void refused(const char *text, const char *want)
{
    ffd_mesh *mesh = NULL;
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read(EX "lattice/bunny.obj", &mesh, &err));
    ffd_status s = ffd_rig_parse_json(text, strlen(text), "bad.json", &rig, &err);
    if (!s)
        s = ffd_rig_apply(rig, mesh, NULL, &err);
    CHECK(s != FFD_OK);
    if (!strstr(err.message, want))
        fprintf(stderr, "message '%s' lacks '%s'\n", err.message, want);
    CHECK(strstr(err.message, want) != NULL);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

static void test_refusals(void)
{
    refused("{\"deformer\": \"rbf\", \"control_points\": [[0,0,0],[1,0,0],[0,1,0],[0,0,1],[1,0,0]]}",
            "control_points[1] and control_points[4] coincide");
    refused("{\"deformer\": \"idw\", \"control_points\": [[0,0,0],[0,0,0]]}",
            "control_points[0] and control_points[1] coincide");
    refused("{\"deformer\": \"rbf\", \"radius\": 0, \"control_points\": [[0,0,0]]}",
            "radius: 0: expected a number > 0");
    refused("{\"deformer\": \"rbf\", \"radius\": -1, \"control_points\": [[0,0,0]]}",
            "radius: -1: expected a number > 0");
    refused("{\"deformer\": \"rbf\", \"kernel\": \"cubic\", \"control_points\": [[0,0,0]]}",
            "kernel: expected \"gaussian_spline\"");
    refused("{\"deformer\": \"rbf\", \"control_points\": [[0,0,0],[1,0,0]], "
            "\"deformed_control_points\": [[0,0,0]]}",
            "deformed_control_points: 1 points for 2 control_points");
    refused("{\"deformer\": \"idw\", \"control_points\": [[0,0,0],[1,0,0]], "
            "\"moves\": [{\"index\": 2, \"delta\": [0,0,1]}]}",
            "moves[0].index: 2 out of range");
    refused("{\"deformer\": \"idw\", \"power\": 0, \"control_points\": [[0,0,0]]}",
            "power: 0: expected a number > 0");
    refused("{\"deformer\": \"rbf\", \"control_points\": [[0,0,0],[1,0,0],[0,1,0],[1,1,0]]}",
            "is singular");
    refused("{\"deformer\": \"idw\", \"kernel\": \"gaussian_spline\", \"control_points\": [[0,0,0]]}",
            "kernel: only for \"deformer\": \"rbf\" rigs");
}

/* ---- PyGeM parameter files ---- */

/* PyGeM's cube examples (the layout of its write_parameters) read, written
 * back, read again: the same rig text; and they deform as the same rig in
 * JSON does. */
static void test_prm_round_trip(void)
{
    const char *files[] = {EX "rbf/cube.prm", EX "idw/cube.prm"};
    const char *methods[] = {"rbf", "idw"};
    for (int f = 0; f < 2; f++) {
        ffd_rig *rig = NULL, *again = NULL;
        ffd_error err = {{0}};
        char *prm = NULL, *json = NULL, *json2 = NULL;
        CHECK_OK(ffd_rig_read(files[f], &rig, &err));
        if (!rig) {
            fprintf(stderr, "%s\n", err.message);
            continue;
        }
        CHECK_OK(ffd_rig_write_prm(rig, &prm, &err));
        CHECK(prm && strstr(prm, f ? "[Inverse Distance Weighting]" : "[Radial Basis Functions]"));
        CHECK_OK(ffd_rig_parse_prm(prm, prm ? strlen(prm) : 0, "again.prm", &again, &err));
        CHECK_OK(ffd_rig_write_json(rig, &json, &err));
        if (again)
            CHECK_OK(ffd_rig_write_json(again, &json2, &err));
        CHECK(json && json2 && strcmp(json, json2) == 0);
        CHECK(json && strstr(json, methods[f]) != NULL);
        /* the cube's corner (1,1,1) moved to (1.5,1.6,1.7): points at the corners follow */
        double pts[2][3] = {{1, 1, 1}, {0, 0, 0}};
        ffd_mesh *mesh = NULL;
        CHECK_OK(ffd_mesh_create(&pts[0][0], 2, NULL, NULL, 0, &mesh, &err));
        if (mesh) {
            CHECK_OK(ffd_rig_apply(rig, mesh, NULL, &err));
            const double *x = ffd_mesh_positions(mesh);
            CHECK_NEAR(x[0], 1.5, 1e-12);
            CHECK_NEAR(x[1], 1.6, 1e-12);
            CHECK_NEAR(x[2], 1.7, 1e-12);
            /* the unmoved corner stays, to rounding (the solve's last bits depend on the BLAS) */
            CHECK(fabs(x[3]) <= 1e-12 && fabs(x[4]) <= 1e-12 && fabs(x[5]) <= 1e-12);
        }
        ffd_mesh_destroy(mesh);
        ffd_free(prm);
        ffd_free(json);
        ffd_free(json2);
        ffd_rig_destroy(rig);
        ffd_rig_destroy(again);
    }
}

/* .prm text refused with a message holding want. */
static void prm_refused(const char *text, const char *want)
{
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_rig_parse_prm(text, strlen(text), "bad.prm", &rig, &err) != FFD_OK);
    CHECK(rig == NULL);
    if (!strstr(err.message, want))
        fprintf(stderr, "message '%s' lacks '%s'\n", err.message, want);
    CHECK(strstr(err.message, want) != NULL);
}

static void test_prm_refusals(void)
{
    /* a lattice rig has no PyGeM writer of ours */
    ffd_rig *lattice = NULL;
    char *text = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_rig_read(EX "lattice/ears.json", &lattice, &err));
    CHECK(ffd_rig_write_prm(lattice, &text, &err) == FFD_ERR_UNSUPPORTED && !text);
    CHECK(strstr(err.message, "written for \"rbf\", \"idw\" rigs only") != NULL);
    ffd_rig_destroy(lattice);
    prm_refused("[Radial Basis Functions]\nbasis function: cubic\nradius: 1\n",
                "bad.prm:2: basis function: unknown kernel 'cubic'");
    prm_refused("[Radial Basis Functions]\nbasis function: gaussian_spline\nradius: 0\n",
                "bad.prm:3: radius: 0: expected a number > 0");
    prm_refused("[Radial Basis Functions]\nbasis function: gaussian_spline\nradius: 1\n"
                "[Control points]\noriginal control points: 0 0 0\n  1 0 0\n"
                "deformed control points: 0 0 0\n",
                "bad.prm:7: deformed control points: 1 points for 2 original control points");
    prm_refused("[Inverse Distance Weighting]\npower = 2\n[Control points]\n"
                "original control points: 0 0 0\n  1 0\ndeformed control points: 0 0 0\n  1 0 0\n",
                "bad.prm:5: original control points: expected 3 numbers a line, got 2");
    prm_refused("[Inverse Distance Weighting]\npower = 1.5\n",
                "bad.prm:2: power: 1.5: expected an integer >= 1");
    prm_refused("[Radial Basis Functions]\nbasis function: gaussian_spline\nradius: 1\nepsilon: 2\n",
                "bad.prm:4: 'epsilon': not a kernel parameter");
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"rbf_against_pygem", test_rbf_against_pygem},
        {"rbf_identity_and_interpolation", test_rbf_identity_and_interpolation},
        {"rbf_affine_and_rigid", test_rbf_affine_and_rigid},
        {"rbf_sparse_matches_dense", test_rbf_sparse_matches_dense},
        {"jacobians", test_jacobians},
        {"idw_against_pygem", test_idw_against_pygem},
        {"idw_translation", test_idw_translation},
        {"direct_manipulation", test_direct_manipulation},
        {"threads", test_threads},
        {"refusals", test_refusals},
        {"prm_round_trip", test_prm_round_trip},
        {"prm_refusals", test_prm_refusals},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
