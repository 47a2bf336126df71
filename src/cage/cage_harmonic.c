/* cage_harmonic — harmonic coordinates (Joshi, Meyer, DeRose, Green &
 * Sanocki 2007, "Harmonic coordinates for character articulation", §3-4;
 * what Blender's Mesh Deform binds with): h_j solves Laplace's equation
 * inside the cage with h_j equal to the cage's piecewise-linear hat
 * function of vertex j on the cage. Discretised as in §4: a regular grid
 * over the cage; its nodes inside the cage (ray parity, spatial.c) are the
 * unknowns of the 7-point Laplacian; the nodes outside next to them (the
 * corners of every cell a cage triangle reaches, and every outside
 * neighbour of an interior node) carry the hat functions at their nearest
 * cage point (cage_hat.c), as do interior nodes on the cage. The one
 * symmetric positive definite matrix is factored once by CHOLMOD (this file
 * and tsv_arap.c are the files that include it) and solved for every cage
 * vertex at once; points are then interpolated trilinearly. A constant is
 * discretely harmonic, so the coordinates sum to one exactly (up to
 * rounding); by the discrete maximum principle they lie in [0, 1]. */
#include "cage/cage.h"
#include "math/tolerance.h"

#include <cholmod.h>

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- CHOLMOD's allocations through ours (as tsv_arap.c routes them) ---- */

static void *cage_ss_malloc(size_t size)
{
    return ffd_malloc(size);
}

static void *cage_ss_calloc(size_t count, size_t size)
{
    return ffd_calloc(count, size);
}

static void *cage_ss_realloc(void *ptr, size_t size)
{
    return ffd_realloc(ptr, size);
}

static void cage_ss_free(void *ptr)
{
    ffd_free(ptr);
}

static void route_cholmod_allocation(void)
{
    /* the same critical section as tsv_arap.c: one writer of the table */
#pragma omp critical(tsv_arap_suitesparse_config)
    {
        if (SuiteSparse_config.malloc_func == malloc && SuiteSparse_config.calloc_func == calloc &&
            SuiteSparse_config.realloc_func == realloc && SuiteSparse_config.free_func == free) {
            SuiteSparse_config.malloc_func = cage_ss_malloc;
            SuiteSparse_config.calloc_func = cage_ss_calloc;
            SuiteSparse_config.realloc_func = cage_ss_realloc;
            SuiteSparse_config.free_func = cage_ss_free;
        }
    }
}

void ffd_cage_grid_free(cage_grid *g)
{
    if (!g)
        return;
    ffd_free(g->slot);
    ffd_free(g->inside);
    ffd_free(g->values);
    ffd_free(g);
}

/* ---- the grid ---- */

enum { NODE_INSIDE = 1, NODE_NEAR = 2, NODE_DIRICHLET = 4 };
#define GRID_PAD 2 /* cells of margin around the cage's bounding box */

static void node_position(const cage_grid *g, size_t id, double x[3])
{
    size_t k = id % g->dims[2], j = (id / g->dims[2]) % g->dims[1], i = id / g->dims[2] / g->dims[1];
    x[0] = g->origin[0] + g->h * (double)i;
    x[1] = g->origin[1] + g->h * (double)j;
    x[2] = g->origin[2] + g->h * (double)k;
}

/* Marks the corners of every cell a triangle's bounding box reaches: a
 * grid edge that crosses the cage joins two such corners. */
static void mark_near(const ffd_cage *cage, const cage_grid *g, uint8_t *flags)
{
    const size_t sj = g->dims[2], si = (size_t)g->dims[1] * g->dims[2];
    const double slack = 1e-9 * cage->diag;
    for (size_t t = 0; t < cage->nt; t++) {
        long lo[3], hi[3];
        for (int a = 0; a < 3; a++) {
            double mn = INFINITY, mx = -INFINITY;
            for (int c = 0; c < 3; c++) {
                double v = cage->rest[3 * (size_t)cage->tri[3 * t + c] + a];
                mn = fmin(mn, v);
                mx = fmax(mx, v);
            }
            lo[a] = (long)floor((mn - slack - g->origin[a]) / g->h);
            hi[a] = (long)floor((mx + slack - g->origin[a]) / g->h) + 1;
            if (lo[a] < 0)
                lo[a] = 0;
            if (hi[a] > (long)g->dims[a] - 1)
                hi[a] = (long)g->dims[a] - 1;
        }
        for (long i = lo[0]; i <= hi[0]; i++)
            for (long j = lo[1]; j <= hi[1]; j++)
                for (long k = lo[2]; k <= hi[2]; k++)
                    flags[(size_t)i * si + (size_t)j * sj + (size_t)k] |= NODE_NEAR;
    }
}

static ffd_status cholmod_failed(cholmod_common *cc, const char *what, ffd_error *err)
{
    return ffd_fail(err, cc->status == CHOLMOD_OUT_OF_MEMORY ? FFD_ERR_NOMEM : FFD_ERR_NUMERIC,
                    "harmonic coordinates: CHOLMOD %s failed (status %d)", what, cc->status);
}

ffd_status ffd_cage_harmonic_solve(ffd_cage *cage, uint32_t resolution, ffd_error *err)
{
    const size_t nv = cage->nv;
    ffd_status st = FFD_OK;
    uint8_t *flags = NULL;
    size_t *dirichlet = NULL;
    cholmod_common cc;
    int started = 0;
    cholmod_sparse *A = NULL;
    cholmod_factor *L = NULL;
    cholmod_dense *B = NULL, *X = NULL;
    cage_grid *g = ffd_calloc(1, sizeof *g);
    if (!g)
        return ffd_fail(err, FFD_ERR_NOMEM, "harmonic coordinates: out of memory");

    double ext = 0;
    for (int a = 0; a < 3; a++)
        ext = fmax(ext, cage->hi[a] - cage->lo[a]);
    g->h = ext / resolution;
    size_t count = 1;
    for (int a = 0; a < 3; a++) {
        double cells = ceil((cage->hi[a] - cage->lo[a]) / g->h - 1e-9);
        g->dims[a] = (uint32_t)cells + 1 + 2 * GRID_PAD;
        g->origin[a] = 0.5 * (cage->lo[a] + cage->hi[a]) - 0.5 * (g->dims[a] - 1) * g->h;
        count *= g->dims[a];
    }
    const size_t sj = g->dims[2], si = (size_t)g->dims[1] * g->dims[2];
    flags = ffd_calloc(count, 1);
    g->slot = ffd_malloc_array(count, sizeof *g->slot);
    g->inside = ffd_calloc(count, 1);
    if (!flags || !g->slot || !g->inside) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "harmonic coordinates: out of memory for %zu grid nodes",
                      count);
        goto done;
    }
    /* inside the cage: ray parity from every node */
#pragma omp parallel for schedule(static)
    for (long long id = 0; id < (long long)count; id++) {
        double x[3];
        node_position(g, (size_t)id, x);
        if (ffd_inside_index_test(cage->inside, x))
            flags[id] |= NODE_INSIDE;
    }
    mark_near(cage, g, flags);
    /* Dirichlet nodes: outside and near the cage, or next to an interior node */
    size_t nd = 0;
    for (size_t id = 0; id < count; id++) {
        if (!(flags[id] & NODE_INSIDE))
            continue;
        const size_t nb[6] = {id - 1, id + 1, id - sj, id + sj, id - si, id + si};
        for (int q = 0; q < 6; q++)
            if (nb[q] < count && !(flags[nb[q]] & NODE_INSIDE))
                flags[nb[q]] |= NODE_DIRICHLET;
    }
    for (size_t id = 0; id < count; id++)
        if (!(flags[id] & NODE_INSIDE) && (flags[id] & NODE_NEAR))
            flags[id] |= NODE_DIRICHLET;
    for (size_t id = 0; id < count; id++)
        nd += (flags[id] & (NODE_DIRICHLET | NODE_NEAR)) != 0;
    dirichlet = ffd_malloc_array(nd ? nd : 1, sizeof *dirichlet);
    if (!dirichlet) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "harmonic coordinates: out of memory");
        goto done;
    }
    /* candidates: the Dirichlet nodes and the interior nodes near the cage
     * (those on the cage become Dirichlet nodes) */
    nd = 0;
    for (size_t id = 0; id < count; id++)
        if (flags[id] & (NODE_DIRICHLET | NODE_NEAR))
            dirichlet[nd++] = id;
    double *hat = ffd_malloc_array(nd ? nd : 1, nv * sizeof(double));
    if (!hat) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "harmonic coordinates: out of memory for %zu boundary "
                      "nodes", nd);
        goto done;
    }
    const double on_cage = FFD_TOL_CAGE_VERTEX * cage->diag;
#pragma omp parallel for schedule(dynamic, 64)
    for (long long q = 0; q < (long long)nd; q++) {
        double x[3];
        node_position(g, dirichlet[q], x);
        double d2 = ffd_cage_hat(cage, x, hat + (size_t)q * nv);
        if ((flags[dirichlet[q]] & NODE_INSIDE) && d2 <= on_cage * on_cage)
            flags[dirichlet[q]] |= NODE_DIRICHLET;
    }
    /* slots: unknowns first (in node order), then the Dirichlet rows */
    size_t nu = 0, rows = 0;
    for (size_t id = 0; id < count; id++) {
        g->slot[id] = -1;
        if ((flags[id] & NODE_INSIDE) && !(flags[id] & NODE_DIRICHLET)) {
            g->slot[id] = (int32_t)nu++;
            g->inside[id] = 1;
        }
    }
    rows = nu;
    for (size_t id = 0; id < count; id++)
        if (flags[id] & NODE_DIRICHLET)
            g->slot[id] = (int32_t)rows++;
    if (rows > (size_t)INT32_MAX || nu == 0) {
        ffd_free(hat);
        st = nu == 0 ? ffd_fail(err, FFD_ERR_INVALID,
                                "harmonic coordinates: no grid node inside the cage at "
                                "resolution %u (raise \"resolution\")", resolution)
                     : ffd_fail(err, FFD_ERR_NOMEM, "harmonic coordinates: grid too large");
        goto done;
    }
    g->unknowns = nu;
    g->rows = rows;
    g->values = ffd_malloc_array(rows, nv * sizeof(double));
    if (!g->values) {
        ffd_free(hat);
        st = ffd_fail(err, FFD_ERR_NOMEM, "harmonic coordinates: out of memory for %zu x %zu "
                      "coordinates", rows, nv);
        goto done;
    }
    for (size_t q = 0; q < nd; q++)
        if (flags[dirichlet[q]] & NODE_DIRICHLET)
            memcpy(g->values + (size_t)g->slot[dirichlet[q]] * nv, hat + q * nv,
                   nv * sizeof(double));
    ffd_free(hat);

    /* the 7-point Laplacian on the unknowns (lower triangle, columns in node
     * order), and the Dirichlet neighbours' values on the right */
    route_cholmod_allocation();
    cholmod_start(&cc);
    started = 1;
    cc.print = 0;
    cc.error_handler = NULL;
    size_t nnz = 0;
    for (size_t id = 0; id < count; id++) {
        if (!g->inside[id])
            continue;
        nnz++;
        const size_t up[3] = {id + 1, id + sj, id + si};
        for (int q = 0; q < 3; q++)
            nnz += up[q] < count && g->inside[up[q]];
    }
    if (nnz > (size_t)INT_MAX) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "harmonic coordinates: grid too large");
        goto done;
    }
    /* each call resets cc.status: a NULL is out of memory whatever it says */
    if (!(A = cholmod_allocate_sparse(nu, nu, nnz, 1, 1, -1, CHOLMOD_REAL, &cc)) ||
        !(B = cholmod_zeros(nu, nv, CHOLMOD_REAL, &cc))) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "harmonic coordinates: out of memory for the grid "
                      "Laplacian (%zu unknowns, %zu cage vertices)", nu, nv);
        goto done;
    }
    int *Ap = A->p, *Ai = A->i;
    double *Ax = A->x, *Bx = B->x;
    size_t e = 0;
    for (size_t id = 0; id < count; id++) {
        if (!g->inside[id])
            continue;
        size_t c = (size_t)g->slot[id];
        Ap[c] = (int)e;
        Ai[e] = (int)c;
        Ax[e++] = 6.0;
        const size_t up[3] = {id + 1, id + sj, id + si};
        for (int q = 0; q < 3; q++)
            if (up[q] < count && g->inside[up[q]]) {
                Ai[e] = g->slot[up[q]];
                Ax[e++] = -1.0;
            }
        const size_t nb[6] = {id - 1, id + 1, id - sj, id + sj, id - si, id + si};
        for (int q = 0; q < 6; q++) {
            if (nb[q] >= count || g->inside[nb[q]] || g->slot[nb[q]] < 0)
                continue;
            const double *v = g->values + (size_t)g->slot[nb[q]] * nv;
            for (size_t j = 0; j < nv; j++)
                Bx[c + nu * j] += v[j];
        }
    }
    Ap[nu] = (int)e;
    L = cholmod_analyze(A, &cc);
    if (!L || !cholmod_factorize(A, L, &cc) || cc.status < CHOLMOD_OK) {
        st = cholmod_failed(&cc, "factorisation", err);
        goto done;
    }
    if (cc.status == CHOLMOD_NOT_POSDEF || L->minor < L->n) {
        st = ffd_fail(err, FFD_ERR_NUMERIC, "harmonic coordinates: the grid Laplacian is not "
                      "positive definite (column %zu)", (size_t)L->minor);
        goto done;
    }
    X = cholmod_solve(CHOLMOD_A, L, B, &cc);
    if (!X) {
        st = cholmod_failed(&cc, "solve", err);
        goto done;
    }
    const double *Xx = X->x;
    for (size_t c = 0; c < nu; c++)
        for (size_t j = 0; j < nv; j++)
            g->values[c * nv + j] = Xx[c + nu * j];
done:
    if (started) {
        cholmod_free_sparse(&A, &cc);
        cholmod_free_factor(&L, &cc);
        cholmod_free_dense(&B, &cc);
        cholmod_free_dense(&X, &cc);
        cholmod_finish(&cc);
    }
    ffd_free(flags);
    ffd_free(dirichlet);
    if (st) {
        ffd_cage_grid_free(g);
        return st;
    }
    cage->grid = g;
    return FFD_OK;
}

int ffd_cage_harmonic_weights(const ffd_cage *cage, const double x[3], double *w,
                              int *all_inside)
{
    const cage_grid *g = cage->grid;
    const size_t nv = cage->nv;
    size_t cell[3];
    double t[3];
    *all_inside = 0;
    for (int a = 0; a < 3; a++) {
        double s = (x[a] - g->origin[a]) / g->h;
        if (!(s >= 0 && s <= (double)(g->dims[a] - 1)))
            return 0;
        double f = floor(s);
        if (f > (double)(g->dims[a] - 2))
            f = (double)(g->dims[a] - 2);
        cell[a] = (size_t)f;
        t[a] = s - f;
    }
    const size_t sj = g->dims[2], si = (size_t)g->dims[1] * g->dims[2];
    const size_t base = cell[0] * si + cell[1] * sj + cell[2];
    size_t corner[8];
    int inside = 1;
    for (int c = 0; c < 8; c++) {
        corner[c] = base + (c & 4 ? si : 0) + (c & 2 ? sj : 0) + (c & 1 ? 1 : 0);
        if (g->slot[corner[c]] < 0)
            return 0;
        inside &= g->inside[corner[c]];
    }
    memset(w, 0, nv * sizeof *w);
    for (int c = 0; c < 8; c++) {
        double tw = (c & 4 ? t[0] : 1 - t[0]) * (c & 2 ? t[1] : 1 - t[1]) *
                    (c & 1 ? t[2] : 1 - t[2]);
        if (tw == 0)
            continue;
        const double *v = g->values + (size_t)g->slot[corner[c]] * nv;
        for (size_t j = 0; j < nv; j++)
            w[j] += tw * v[j];
    }
    *all_inside = inside;
    return 1;
}
