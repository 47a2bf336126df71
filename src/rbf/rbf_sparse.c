/* rbf_sparse — RBF morphing with the compactly supported Wendland C2 kernel
 * (Wendland 1995; PyGeM's beckert_wendland_c2_basis) for many control
 * points: the control points bucketed in a grid of cells as wide as the
 * radius (the kernel is zero beyond it), Phi assembled sparse from
 * neighbouring cells and factored by CHOLMOD (this is the only RBF file
 * that includes it), and the saddle-point system
 *     [Phi P; P^T 0] [u; v] = [b; c],  P = [1 C]  (N by 4)
 * solved through the Schur complement of the polynomial block:
 *     y = Phi^-1 b,  S v = P^T y - c,  u = y - Z v,
 * with Z = Phi^-1 P and S = P^T Z (4 by 4) computed once.
 *
 * CHOLMOD allocation goes through the library allocator as in
 * src/tspline/tsv_arap.c (the process-wide SuiteSparse_config table, switched
 * once when it still holds the C library's functions); printing is off.
 * A handle's solves share its cholmod_common: one thread per handle. */
#include "ffd.h"
#include "math/dense.h"
#include "rbf/rbf.h"

#include <cholmod.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GRID_MAX_CELLS_PER_POINT 4 /* beyond this the cells grow (still >= the radius) */

/* ---- the grid ---- */

void ffd_rbf_grid_destroy(rbf_grid *g)
{
    if (!g)
        return;
    ffd_free(g->start);
    ffd_free(g->points);
    ffd_free(g);
}

static size_t cell_of(const rbf_grid *g, const double *p, int a)
{
    double t = floor((p[a] - g->origin[a]) / g->cell);
    return t <= 0 ? 0 : t >= (double)(g->dim[a] - 1) ? g->dim[a] - 1 : (size_t)t;
}

ffd_status ffd_rbf_grid_create(ffd_rbf_morph *rbf, ffd_error *err)
{
    const size_t N = rbf->count;
    rbf_grid *g = ffd_calloc(1, sizeof *g);
    if (!g)
        return ffd_fail(err, FFD_ERR_NOMEM, "rbf: out of memory");
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t j = 0; j < N; j++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], rbf->rest[3 * j + a]);
            hi[a] = fmax(hi[a], rbf->rest[3 * j + a]);
        }
    g->cell = rbf->radius;
    for (;;) {
        double cells = 1;
        for (int a = 0; a < 3; a++)
            cells *= floor((hi[a] - lo[a]) / g->cell) + 1;
        if (cells <= (double)(GRID_MAX_CELLS_PER_POINT * N + 64))
            break;
        g->cell *= 2;
    }
    size_t total = 1;
    for (int a = 0; a < 3; a++) {
        g->origin[a] = lo[a];
        g->dim[a] = (size_t)floor((hi[a] - lo[a]) / g->cell) + 1;
        total *= g->dim[a];
    }
    g->start = ffd_calloc(total + 1, sizeof *g->start);
    g->points = ffd_malloc_array(N, sizeof *g->points);
    size_t *cell = ffd_malloc_array(N, sizeof *cell);
    if (!g->start || !g->points || !cell) {
        ffd_free(cell);
        ffd_rbf_grid_destroy(g);
        return ffd_fail(err, FFD_ERR_NOMEM, "rbf: out of memory for the grid");
    }
    /* counting sort: ids ascending within a cell (deterministic) */
    for (size_t j = 0; j < N; j++) {
        const double *p = rbf->rest + 3 * j;
        cell[j] = (cell_of(g, p, 0) * g->dim[1] + cell_of(g, p, 1)) * g->dim[2] + cell_of(g, p, 2);
        g->start[cell[j] + 1]++;
    }
    for (size_t c = 0; c < total; c++)
        g->start[c + 1] += g->start[c];
    size_t *fill = ffd_malloc_array(total ? total : 1, sizeof *fill);
    if (!fill) {
        ffd_free(cell);
        ffd_rbf_grid_destroy(g);
        return ffd_fail(err, FFD_ERR_NOMEM, "rbf: out of memory for the grid");
    }
    memcpy(fill, g->start, total * sizeof *fill);
    for (size_t j = 0; j < N; j++)
        g->points[fill[cell[j]]++] = (uint32_t)j;
    ffd_free(fill);
    ffd_free(cell);
    rbf->grid = g;
    return FFD_OK;
}

int ffd_rbf_grid_range(const rbf_grid *g, const double x[3], size_t lo[3], size_t hi[3])
{
    for (int a = 0; a < 3; a++) {
        double t = floor((x[a] - g->origin[a]) / g->cell);
        if (!(t >= -1.0) || t > (double)g->dim[a]) /* farther than a cell outside (or NaN) */
            return 0;
        lo[a] = t <= 0 ? 0 : (size_t)t - 1;
        hi[a] = t + 1 >= (double)g->dim[a] ? g->dim[a] - 1 : (size_t)t + 1;
    }
    return 1;
}

/* ---- the factor ---- */

typedef struct rbf_sparse {
    cholmod_common cc;
    cholmod_factor *L;
    double *Z;      /* N by 4 column-major: Phi^-1 P */
    double S[16];   /* P^T Z, then its factor */
    int ipiv[4];
} rbf_sparse;

static void *ss_malloc(size_t size) { return ffd_malloc(size); }
static void *ss_calloc(size_t count, size_t size) { return ffd_calloc(count, size); }
static void *ss_realloc(void *ptr, size_t size) { return ffd_realloc(ptr, size); }
static void ss_free(void *ptr) { ffd_free(ptr); }

static void route_allocation(void)
{
#pragma omp critical(rbf_sparse_suitesparse_config)
    {
        if (SuiteSparse_config.malloc_func == malloc && SuiteSparse_config.calloc_func == calloc &&
            SuiteSparse_config.realloc_func == realloc && SuiteSparse_config.free_func == free) {
            SuiteSparse_config.malloc_func = ss_malloc;
            SuiteSparse_config.calloc_func = ss_calloc;
            SuiteSparse_config.realloc_func = ss_realloc;
            SuiteSparse_config.free_func = ss_free;
        }
    }
}

void ffd_rbf_sparse_destroy(rbf_sparse *s)
{
    if (!s)
        return;
    cholmod_free_factor(&s->L, &s->cc);
    cholmod_finish(&s->cc);
    ffd_free(s->Z);
    ffd_free(s);
}

/* y = Phi^-1 b for nrhs columns of b (N by nrhs column-major), in place. */
static ffd_status phi_solve(rbf_sparse *s, size_t N, size_t nrhs, double *b, ffd_error *err)
{
    cholmod_dense B = {0};
    B.nrow = N;
    B.ncol = nrhs;
    B.nzmax = N * nrhs;
    B.d = N;
    B.x = b;
    B.xtype = CHOLMOD_REAL;
    B.dtype = CHOLMOD_DOUBLE;
    cholmod_dense *X = cholmod_solve(CHOLMOD_A, s->L, &B, &s->cc);
    if (!X)
        return ffd_fail(err, s->cc.status == CHOLMOD_OUT_OF_MEMORY ? FFD_ERR_NOMEM : FFD_ERR_NUMERIC,
                        "rbf: CHOLMOD solve failed (status %d)", s->cc.status);
    memcpy(b, X->x, N * nrhs * sizeof *b);
    cholmod_free_dense(&X, &s->cc);
    return FFD_OK;
}

ffd_status ffd_rbf_sparse_factor(ffd_rbf_morph *rbf, ffd_error *err)
{
    const size_t N = rbf->count;
    ffd_status st = rbf->grid ? FFD_OK : ffd_rbf_grid_create(rbf, err);
    if (st)
        return st;
    const rbf_grid *g = rbf->grid;
    rbf_sparse *s = ffd_calloc(1, sizeof *s);
    if (!s)
        return ffd_fail(err, FFD_ERR_NOMEM, "rbf: out of memory");
    route_allocation();
    cholmod_start(&s->cc);
    s->cc.print = 0;
    s->cc.error_handler = NULL;
    /* the lower triangle of Phi, column by column (stype -1) */
    size_t cap = 16 * N + 16, nnz = 0;
    cholmod_triplet *T = cholmod_allocate_triplet(N, N, cap, -1, CHOLMOD_REAL, &s->cc);
    for (size_t j = 0; T && j < N; j++) {
        const double *cj = rbf->rest + 3 * j;
        size_t lo[3], hi[3];
        if (!ffd_rbf_grid_range(g, cj, lo, hi))
            continue;
        for (size_t a = lo[0]; a <= hi[0]; a++)
            for (size_t b = lo[1]; b <= hi[1]; b++)
                for (size_t c = lo[2]; c <= hi[2]; c++) {
                    size_t cell = (a * g->dim[1] + b) * g->dim[2] + c;
                    for (size_t q = g->start[cell]; q < g->start[cell + 1]; q++) {
                        size_t i = g->points[q];
                        if (i < j)
                            continue;
                        const double *ci = rbf->rest + 3 * i;
                        double e0 = ci[0] - cj[0], e1 = ci[1] - cj[1], e2 = ci[2] - cj[2];
                        double phi = ffd_rbf_phi(rbf->kernel, rbf->radius, rbf->power,
                                                 sqrt(e0 * e0 + e1 * e1 + e2 * e2), NULL);
                        if (phi == 0)
                            continue;
                        if (nnz == T->nzmax && !cholmod_reallocate_triplet(2 * nnz, T, &s->cc)) {
                            cholmod_free_triplet(&T, &s->cc);
                            break;
                        }
                        ((int *)T->i)[nnz] = (int)i;
                        ((int *)T->j)[nnz] = (int)j;
                        ((double *)T->x)[nnz] = phi;
                        T->nnz = ++nnz;
                    }
                }
    }
    cholmod_sparse *A = T ? cholmod_triplet_to_sparse(T, nnz, &s->cc) : NULL;
    cholmod_free_triplet(&T, &s->cc);
    if (A && (s->L = cholmod_analyze(A, &s->cc)) != NULL)
        cholmod_factorize(A, s->L, &s->cc);
    cholmod_free_sparse(&A, &s->cc);
    if (!s->L || s->cc.status == CHOLMOD_OUT_OF_MEMORY) {
        st = ffd_fail(err, s->cc.status == CHOLMOD_OUT_OF_MEMORY ? FFD_ERR_NOMEM : FFD_ERR_NUMERIC,
                      "rbf: CHOLMOD analysis failed (status %d)", s->cc.status);
        goto fail;
    }
    if (s->cc.status == CHOLMOD_NOT_POSDEF || s->L->minor < s->L->n) {
        st = ffd_fail(err, FFD_ERR_INVALID,
                      "rbf: the Wendland matrix of the %zu control points is not positive "
                      "definite (column %zu): the system is singular",
                      N, (size_t)s->L->minor);
        goto fail;
    }
    rbf->rcond = cholmod_rcond(s->L, &s->cc);
    /* Z = Phi^-1 P, S = P^T Z */
    s->Z = ffd_malloc_array(N, 4 * sizeof *s->Z);
    if (!s->Z) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "rbf: out of memory");
        goto fail;
    }
    for (size_t j = 0; j < N; j++) {
        s->Z[j] = 1.0;
        for (int a = 0; a < 3; a++)
            s->Z[(1 + a) * N + j] = rbf->rest[3 * j + a];
    }
    if ((st = phi_solve(s, N, 4, s->Z, err)))
        goto fail;
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++) {
            double sum = 0;
            for (size_t j = 0; j < N; j++)
                sum += (r == 0 ? 1.0 : rbf->rest[3 * j + r - 1]) * s->Z[c * N + j];
            s->S[c * 4 + r] = sum;
        }
    double anorm = ffd_dense_sym_norm1(4, s->S), rcond = 0;
    int singular = 0;
    if ((st = ffd_dense_sym_factor(4, s->S, s->ipiv, &singular, err)) ||
        (!singular && (st = ffd_dense_sym_rcond(4, s->S, s->ipiv, anorm, &rcond, err))))
        goto fail;
    if (singular || !(rcond >= 1e-15)) {
        st = ffd_fail(err, FFD_ERR_INVALID,
                      "rbf: the system of %zu control points is singular (the linear part needs "
                      "four control points not in one plane)",
                      N);
        goto fail;
    }
    rbf->sparse = s;
    return FFD_OK;
fail:
    ffd_rbf_sparse_destroy(s);
    return st;
}

ffd_status ffd_rbf_sparse_solve(const ffd_rbf_morph *rbf, size_t nrhs, double *B, ffd_error *err)
{
    rbf_sparse *s = rbf->sparse;
    const size_t N = rbf->count, M = N + 4;
    double *y = ffd_malloc_array(N, nrhs * sizeof *y);
    if (!y)
        return ffd_fail(err, FFD_ERR_NOMEM, "rbf: out of memory");
    for (size_t k = 0; k < nrhs; k++)
        memcpy(y + k * N, B + k * M, N * sizeof *y);
    ffd_status st = phi_solve(s, N, nrhs, y, err);
    for (size_t k = 0; !st && k < nrhs; k++) {
        const double *yk = y + k * N;
        double *bk = B + k * M, v[4];
        for (int r = 0; r < 4; r++) { /* P^T y - c */
            double sum = 0;
            for (size_t j = 0; j < N; j++)
                sum += (r == 0 ? 1.0 : rbf->rest[3 * j + r - 1]) * yk[j];
            v[r] = sum - bk[N + r];
        }
        if ((st = ffd_dense_sym_solve(4, 1, s->S, s->ipiv, v, err)))
            break;
        for (size_t j = 0; j < N; j++)
            bk[j] = yk[j] - (s->Z[j] * v[0] + s->Z[N + j] * v[1] + s->Z[2 * N + j] * v[2] +
                             s->Z[3 * N + j] * v[3]);
        memcpy(bk + N, v, sizeof v);
    }
    ffd_free(y);
    return st;
}
