/* gffd — variational interpolation (Turk & O'Brien 1999): the r^3 radial
 * basis plus a linear polynomial; factor once (dsytrf), solve many (dsytrs),
 * value and analytic gradient.
 *
 * Conditioning: the matrix is built on normalised centres u = (c - o) / s
 * (o the centroid, s the largest distance from it), so that the same
 * skeleton at 1e-3 or 1e3 scale, or far from the world origin, gives the
 * same matrix. A fit maps the solution back: with d = |x - c_j| = s |u - u_j|,
 *   f = sum_j w'_j |u - u_j|^3 + a'_0 + a'.(u)
 *     = sum_j (w'_j / s^3) d^3 + a'_0 + (a' / s).(x - o),
 * so the interpolant keeps its weights per model unit and its polynomial
 * about o (ffd_rbf.origin). */
#include "gffd/gffd.h"
#include "math/dense.h"

#include <math.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__SSE2__) && (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__) &&      \
    !defined(FFD_NO_CLONES)
#include <immintrin.h>
#define RBF_AVX 1
#else
#define RBF_AVX 0
#endif

/* Relative singular-value threshold of the regularised (least squares) solves. */
#define RBF_LSTSQ_RCOND 1e-13

/* The normalising frame of the centres: origin o (centroid) and scale s. */
static void rbf_frame(const double *c, size_t m, double o[3], double *s)
{
    double sum[3] = {0, 0, 0};
    for (size_t j = 0; j < m; j++)
        for (int k = 0; k < 3; k++)
            sum[k] += c[3 * j + k];
    for (int k = 0; k < 3; k++)
        o[k] = sum[k] / (double)m;
    double r2 = 0;
    for (size_t j = 0; j < m; j++) {
        double dx = c[3 * j] - o[0], dy = c[3 * j + 1] - o[1], dz = c[3 * j + 2] - o[2];
        double d2 = dx * dx + dy * dy + dz * dz;
        if (d2 > r2)
            r2 = d2;
    }
    *s = r2 > 0 ? sqrt(r2) : 1.0;
}

/* The full symmetric saddle matrix [A P; P' 0] (n = m + 4, column-major) of
 * the normalised centres u (m by 3). */
static void rbf_matrix(const double *u, size_t m, double *M)
{
    size_t n = m + 4;
    for (size_t j = 0; j < m; j++) {
        double *col = M + j * n;
        const double *uj = u + 3 * j;
        col[j] = 0;
        for (size_t i = j + 1; i < m; i++) {
            double dx = u[3 * i] - uj[0], dy = u[3 * i + 1] - uj[1], dz = u[3 * i + 2] - uj[2];
            double d2 = dx * dx + dy * dy + dz * dz;
            double v = d2 * sqrt(d2);
            col[i] = v;
            M[j + i * n] = v;
        }
        col[m] = 1;
        M[j + m * n] = 1;
        for (int k = 0; k < 3; k++) {
            col[m + 1 + (size_t)k] = uj[k];
            M[j + (m + 1 + (size_t)k) * n] = uj[k];
        }
    }
    for (size_t j = m; j < n; j++)
        for (size_t i = m; i < n; i++)
            M[i + j * n] = 0;
}

static int all_finite(const double *v, size_t n, size_t *bad)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i])) {
            *bad = i;
            return 0;
        }
    return 1;
}

ffd_status ffd_rbf_factor_create(const double *centres, size_t m, ffd_rbf_factor *out,
                                 ffd_error *err)
{
    memset(out, 0, sizeof *out);
    if (m == 0)
        return ffd_fail(err, FFD_ERR_INVALID, "interpolation: no centres");
    size_t bad;
    if (!all_finite(centres, 3 * m, &bad))
        return ffd_fail(err, FFD_ERR_NONFINITE, "interpolation: centre %zu is not finite",
                        bad / 3);
    size_t n = m + 4;
    ffd_status st = FFD_OK;
    double o[3], s;
    double *u = ffd_malloc_array(3 * m, sizeof *u);
    out->centres = ffd_malloc_array(3 * m, sizeof *out->centres);
    out->ipiv = ffd_malloc_array(n, sizeof *out->ipiv);
    out->lu = n <= SIZE_MAX / n ? ffd_malloc_array(n * n, sizeof *out->lu) : NULL;
    if (!u || !out->centres || !out->ipiv || !out->lu) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "interpolation: out of memory for %zu centres", m);
        goto fail;
    }
    out->count = m;
    memcpy(out->centres, centres, 3 * m * sizeof *centres);
    rbf_frame(centres, m, o, &s);
    for (size_t j = 0; j < m; j++)
        for (int k = 0; k < 3; k++)
            u[3 * j + k] = (centres[3 * j + k] - o[k]) / s;
    rbf_matrix(u, m, out->lu);
    double anorm = ffd_dense_sym_norm1(n, out->lu);
    int singular = 0;
    st = ffd_dense_sym_factor(n, out->lu, out->ipiv, &singular, err);
    if (st != FFD_OK)
        goto fail;
    out->rcond = 0;
    if (!singular) {
        st = ffd_dense_sym_rcond(n, out->lu, out->ipiv, anorm, &out->rcond, err);
        if (st != FFD_OK)
            goto fail;
    }
    if (singular || !(out->rcond >= FFD_RBF_RCOND)) {
        /* keep the matrix itself: solves are minimum-norm least squares */
        if (singular || !(out->rcond >= 0))
            out->rcond = 0;
        out->regularised = 1;
        ffd_free(out->ipiv);
        out->ipiv = NULL;
        rbf_matrix(u, m, out->lu);
    }
    ffd_free(u);
    return FFD_OK;
fail:
    ffd_free(u);
    ffd_rbf_factor_free(out);
    return st;
}

void ffd_rbf_factor_free(ffd_rbf_factor *f)
{
    if (!f)
        return;
    ffd_free(f->centres);
    ffd_free(f->lu);
    ffd_free(f->ipiv);
    memset(f, 0, sizeof *f);
}

ffd_status ffd_rbf_fit(const ffd_rbf_factor *f, const double *values, int dim, ffd_rbf *out,
                       ffd_error *err)
{
    memset(out, 0, sizeof *out);
    if (dim != 1 && dim != 3)
        return ffd_fail(err, FFD_ERR_INVALID, "interpolation: %d value columns (1 or 3)", dim);
    size_t m = f->count, n = m + 4, D = (size_t)dim, bad;
    if (!all_finite(values, m * D, &bad))
        return ffd_fail(err, FFD_ERR_NONFINITE, "interpolation: value %zu is not finite", bad / D);
    ffd_status st = FFD_OK;
    double *A = NULL, *B = ffd_calloc(n * D, sizeof *B);
    out->centres = ffd_malloc_array(3 * m, sizeof *out->centres);
    out->weights = ffd_malloc_array(m * D, sizeof *out->weights);
    if (!B || !out->centres || !out->weights) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "interpolation: out of memory for %zu centres", m);
        goto fail;
    }
    for (size_t d = 0; d < D; d++)
        for (size_t i = 0; i < m; i++)
            B[i + d * n] = values[i * D + d];
    if (!f->regularised) {
        st = ffd_dense_sym_solve(n, D, f->lu, f->ipiv, B, err);
    } else {
        A = ffd_malloc_array(n * n, sizeof *A);
        if (!A) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "interpolation: out of memory for %zu centres", m);
            goto fail;
        }
        memcpy(A, f->lu, n * n * sizeof *A);
        size_t rank;
        st = ffd_dense_lstsq(n, n, D, A, B, RBF_LSTSQ_RCOND, &rank, err);
    }
    if (st != FFD_OK)
        goto fail;
    if (!all_finite(B, n * D, &bad)) {
        st = ffd_fail(err, FFD_ERR_NONFINITE, "interpolation: the solve gave a non-finite result");
        goto fail;
    }
    double o[3], s;
    rbf_frame(f->centres, m, o, &s);
    out->count = m;
    out->dim = dim;
    memcpy(out->centres, f->centres, 3 * m * sizeof *out->centres);
    for (size_t j = 0; j < m; j++)
        for (size_t d = 0; d < D; d++)
            out->weights[j * D + d] = B[j + d * n] / s / s / s;
    for (size_t d = 0; d < D; d++) {
        out->poly[0][d] = B[m + d * n];
        for (size_t k = 1; k < 4; k++)
            out->poly[k][d] = B[m + k + d * n] / s;
    }
    for (int k = 0; k < 3; k++) {
        out->origin[k] = o[k];
        out->lo[k] = out->hi[k] = f->centres[k];
    }
    for (size_t j = 1; j < m; j++)
        for (int k = 0; k < 3; k++) {
            double c = f->centres[3 * j + k];
            if (c < out->lo[k])
                out->lo[k] = c;
            if (c > out->hi[k])
                out->hi[k] = c;
        }
    if (!all_finite(out->weights, m * D, &bad)) {
        st = ffd_fail(err, FFD_ERR_NONFINITE, "interpolation: the solve gave a non-finite result");
        goto fail;
    }
    ffd_free(A);
    ffd_free(B);
    return FFD_OK;
fail:
    ffd_free(A);
    ffd_free(B);
    ffd_rbf_free(out);
    return st;
}

void ffd_rbf_free(ffd_rbf *r)
{
    if (!r)
        return;
    ffd_free(r->centres);
    ffd_free(r->weights);
    memset(r, 0, sizeof *r);
}

/* ---- evaluation ------------------------------------------------------------
 *
 * The sums over the centres run in lanes: for one value column centre j goes
 * to lane j % 4 and the lanes are added as (l0 + l2) + (l1 + l3); for three
 * columns lane j % 2, then l0 + l1. The SSE2 code (two centres per register;
 * a last partial group is padded with weight-0 copies of the last centre,
 * which add exact zeros) and the portable code do the same operations in the
 * same order, so they agree bitwise. */

#if defined(__SSE2__)

static inline double hsum(__m128d a)
{
    return _mm_cvtsd_f64(_mm_add_sd(a, _mm_unpackhi_pd(a, a)));
}

/* p[0] and p[stride] */
static inline __m128d load2(const double *p, size_t stride)
{
    return _mm_loadh_pd(_mm_load_sd(p), p + stride);
}

typedef struct lanes1 {
    __m128d v[2], a[2], b[2], c[2]; /* [0]: lanes 0, 1; [1]: lanes 2, 3 */
} lanes1;

/* Four centres (c: 4 by 3, w: 4 weights) into the lanes. */
static inline void group1(lanes1 *L, __m128d px, __m128d py, __m128d pz, const double *c,
                          const double *w, int grad)
{
    for (int h = 0; h < 2; h++) {
        const double *q = c + 6 * h;
        __m128d dx = _mm_sub_pd(px, load2(q, 3));
        __m128d dy = _mm_sub_pd(py, load2(q + 1, 3));
        __m128d dz = _mm_sub_pd(pz, load2(q + 2, 3));
        __m128d d2 =
            _mm_add_pd(_mm_add_pd(_mm_mul_pd(dx, dx), _mm_mul_pd(dy, dy)), _mm_mul_pd(dz, dz));
        __m128d wd = _mm_mul_pd(_mm_loadu_pd(w + 2 * h), _mm_sqrt_pd(d2));
        L->v[h] = _mm_add_pd(L->v[h], _mm_mul_pd(wd, d2));
        if (grad) {
            L->a[h] = _mm_add_pd(L->a[h], _mm_mul_pd(wd, dx));
            L->b[h] = _mm_add_pd(L->b[h], _mm_mul_pd(wd, dy));
            L->c[h] = _mm_add_pd(L->c[h], _mm_mul_pd(wd, dz));
        }
    }
}

static void eval1(const ffd_rbf *r, const double x[3], double *value, double *grad)
{
    const size_t m = r->count, full = m & ~(size_t)3;
    const double *C = r->centres, *W = r->weights;
    const __m128d px = _mm_set1_pd(x[0]), py = _mm_set1_pd(x[1]), pz = _mm_set1_pd(x[2]);
    lanes1 L;
    L.v[0] = L.v[1] = L.a[0] = L.a[1] = L.b[0] = L.b[1] = L.c[0] = L.c[1] = _mm_setzero_pd();
    if (grad)
        for (size_t j = 0; j < full; j += 4)
            group1(&L, px, py, pz, C + 3 * j, W + j, 1);
    else
        for (size_t j = 0; j < full; j += 4)
            group1(&L, px, py, pz, C + 3 * j, W + j, 0);
    if (full < m) {
        double c[12], w[4];
        for (size_t l = 0; l < 4; l++) {
            size_t j = full + l < m ? full + l : m - 1;
            memcpy(c + 3 * l, C + 3 * j, 3 * sizeof *c);
            w[l] = full + l < m ? W[j] : 0;
        }
        group1(&L, px, py, pz, c, w, grad != NULL);
    }
    *value = hsum(_mm_add_pd(L.v[0], L.v[1]));
    if (grad) {
        grad[0] = hsum(_mm_add_pd(L.a[0], L.a[1]));
        grad[1] = hsum(_mm_add_pd(L.b[0], L.b[1]));
        grad[2] = hsum(_mm_add_pd(L.c[0], L.c[1]));
    }
}

#if RBF_AVX
/* The same four lanes in one AVX register: centre j in lane j % 4, the
 * lanes added as (l0 + l2) + (l1 + l3) at the end. Sub, mul, add and sqrt
 * are correctly rounded and the target has no FMA to fuse them, so every
 * lane does what eval1's SSE2 lanes do and the sums agree bitwise; a field
 * evaluation is the whole cost of GFFD tracking (bench_gffd). */
__attribute__((target("avx"))) static void eval1_avx(const ffd_rbf *r, const double x[3],
                                                     double *value, double *grad)
{
    const size_t m = r->count, full = m & ~(size_t)3;
    const double *C = r->centres, *W = r->weights;
    const __m256d px = _mm256_set1_pd(x[0]), py = _mm256_set1_pd(x[1]), pz = _mm256_set1_pd(x[2]);
    __m256d v = _mm256_setzero_pd(), a = v, b = v, c = v;
    double tc[12], tw[4];
    for (size_t j = 0; j < m; j += 4) {
        const double *q = C + 3 * j, *w = W + j;
        if (j == full) { /* the last partial group, padded as eval1 pads it */
            for (size_t l = 0; l < 4; l++) {
                size_t k = full + l < m ? full + l : m - 1;
                memcpy(tc + 3 * l, C + 3 * k, 3 * sizeof *tc);
                tw[l] = full + l < m ? W[k] : 0;
            }
            q = tc;
            w = tw;
        }
        __m256d dx = _mm256_sub_pd(px, _mm256_set_pd(q[9], q[6], q[3], q[0]));
        __m256d dy = _mm256_sub_pd(py, _mm256_set_pd(q[10], q[7], q[4], q[1]));
        __m256d dz = _mm256_sub_pd(pz, _mm256_set_pd(q[11], q[8], q[5], q[2]));
        __m256d d2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)),
                                   _mm256_mul_pd(dz, dz));
        __m256d wd = _mm256_mul_pd(_mm256_loadu_pd(w), _mm256_sqrt_pd(d2));
        v = _mm256_add_pd(v, _mm256_mul_pd(wd, d2));
        if (grad) {
            a = _mm256_add_pd(a, _mm256_mul_pd(wd, dx));
            b = _mm256_add_pd(b, _mm256_mul_pd(wd, dy));
            c = _mm256_add_pd(c, _mm256_mul_pd(wd, dz));
        }
    }
#define RBF_LANES_SUM(r) /* (l0 + l2) + (l1 + l3) */                                              \
    hsum(_mm_add_pd(_mm256_castpd256_pd128(r), _mm256_extractf128_pd(r, 1)))
    *value = RBF_LANES_SUM(v);
    if (grad) {
        grad[0] = RBF_LANES_SUM(a);
        grad[1] = RBF_LANES_SUM(b);
        grad[2] = RBF_LANES_SUM(c);
    }
#undef RBF_LANES_SUM
}

/* Whether the CPU runs AVX (cpuid and the OS's ymm state; libgcc's check). */
static int has_avx(void)
{
    __builtin_cpu_init(); /* idempotent */
    return __builtin_cpu_supports("avx");
}
#endif

typedef struct lanes3 {
    __m128d v[3], g[3][3];
} lanes3;

/* Two centres (c: 2 by 3, w: 2 by 3) into the lanes. */
static inline void group3(lanes3 *L, __m128d px, __m128d py, __m128d pz, const double *c,
                          const double *w)
{
    __m128d dx = _mm_sub_pd(px, load2(c, 3));
    __m128d dy = _mm_sub_pd(py, load2(c + 1, 3));
    __m128d dz = _mm_sub_pd(pz, load2(c + 2, 3));
    __m128d d2 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(dx, dx), _mm_mul_pd(dy, dy)), _mm_mul_pd(dz, dz));
    __m128d d = _mm_sqrt_pd(d2);
    for (int k = 0; k < 3; k++) {
        __m128d wd = _mm_mul_pd(load2(w + k, 3), d);
        L->v[k] = _mm_add_pd(L->v[k], _mm_mul_pd(wd, d2));
        L->g[k][0] = _mm_add_pd(L->g[k][0], _mm_mul_pd(wd, dx));
        L->g[k][1] = _mm_add_pd(L->g[k][1], _mm_mul_pd(wd, dy));
        L->g[k][2] = _mm_add_pd(L->g[k][2], _mm_mul_pd(wd, dz));
    }
}

static void eval3(const ffd_rbf *r, const double x[3], double value[3], double grad[9])
{
    const size_t m = r->count, full = m & ~(size_t)1;
    const double *C = r->centres, *W = r->weights;
    const __m128d px = _mm_set1_pd(x[0]), py = _mm_set1_pd(x[1]), pz = _mm_set1_pd(x[2]);
    lanes3 L;
    for (int k = 0; k < 3; k++) {
        L.v[k] = _mm_setzero_pd();
        L.g[k][0] = L.g[k][1] = L.g[k][2] = L.v[k];
    }
    for (size_t j = 0; j < full; j += 2)
        group3(&L, px, py, pz, C + 3 * j, W + 3 * j);
    if (full < m) {
        double c[6], w[6] = {0, 0, 0, 0, 0, 0};
        memcpy(c, C + 3 * full, 3 * sizeof *c);
        memcpy(c + 3, C + 3 * full, 3 * sizeof *c);
        memcpy(w, W + 3 * full, 3 * sizeof *w);
        group3(&L, px, py, pz, c, w);
    }
    for (int k = 0; k < 3; k++) {
        value[k] = hsum(L.v[k]);
        for (int i = 0; i < 3; i++)
            grad[3 * k + i] = hsum(L.g[k][i]);
    }
}

#else /* portable: the same lanes and order */

static void eval1(const ffd_rbf *r, const double x[3], double *value, double *grad)
{
    const size_t m = r->count;
    const double *C = r->centres, *W = r->weights;
    double v[4] = {0, 0, 0, 0}, a[4] = {0, 0, 0, 0}, b[4] = {0, 0, 0, 0}, c[4] = {0, 0, 0, 0};
    for (size_t j = 0; j < m; j++) {
        size_t l = j & 3;
        double dx = x[0] - C[3 * j], dy = x[1] - C[3 * j + 1], dz = x[2] - C[3 * j + 2];
        double d2 = dx * dx + dy * dy + dz * dz;
        double wd = W[j] * sqrt(d2);
        v[l] += wd * d2;
        a[l] += wd * dx;
        b[l] += wd * dy;
        c[l] += wd * dz;
    }
    *value = (v[0] + v[2]) + (v[1] + v[3]);
    if (grad) {
        grad[0] = (a[0] + a[2]) + (a[1] + a[3]);
        grad[1] = (b[0] + b[2]) + (b[1] + b[3]);
        grad[2] = (c[0] + c[2]) + (c[1] + c[3]);
    }
}

static void eval3(const ffd_rbf *r, const double x[3], double value[3], double grad[9])
{
    const size_t m = r->count;
    const double *C = r->centres, *W = r->weights;
    double v[3][2] = {{0}}, g[3][3][2] = {{{0}}};
    for (size_t j = 0; j < m; j++) {
        size_t l = j & 1;
        double dx = x[0] - C[3 * j], dy = x[1] - C[3 * j + 1], dz = x[2] - C[3 * j + 2];
        double d2 = dx * dx + dy * dy + dz * dz;
        double d = sqrt(d2);
        for (int k = 0; k < 3; k++) {
            double wd = W[3 * j + (size_t)k] * d;
            v[k][l] += wd * d2;
            g[k][0][l] += wd * dx;
            g[k][1][l] += wd * dy;
            g[k][2][l] += wd * dz;
        }
    }
    for (int k = 0; k < 3; k++) {
        value[k] = v[k][0] + v[k][1];
        for (int i = 0; i < 3; i++)
            grad[3 * k + i] = g[k][i][0] + g[k][i][1];
    }
}

#endif

void ffd_rbf_eval(const ffd_rbf *r, const double x[3], double *value, double *gradient)
{
    const double p0 = x[0] - r->origin[0], p1 = x[1] - r->origin[1], p2 = x[2] - r->origin[2];
    if (r->dim == 1) {
        double g[3];
#if RBF_AVX
        if (has_avx())
            eval1_avx(r, x, value, gradient ? g : NULL);
        else
#endif
            eval1(r, x, value, gradient ? g : NULL);
        value[0] += r->poly[0][0] + r->poly[1][0] * p0 + r->poly[2][0] * p1 + r->poly[3][0] * p2;
        if (gradient) {
            gradient[0] = 3 * g[0] + r->poly[1][0];
            gradient[1] = 3 * g[1] + r->poly[2][0];
            gradient[2] = 3 * g[2] + r->poly[3][0];
        }
        return;
    }
    double g[9];
    eval3(r, x, value, g);
    for (int k = 0; k < 3; k++) {
        value[k] += r->poly[0][k] + r->poly[1][k] * p0 + r->poly[2][k] * p1 + r->poly[3][k] * p2;
        if (gradient)
            for (int i = 0; i < 3; i++)
                gradient[3 * k + i] = 3 * g[3 * k + i] + r->poly[1 + i][k];
    }
}
