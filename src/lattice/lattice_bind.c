/* lattice — binding: local coordinates of object points by inverting the rest
 * map (Hsu et al. 1992, §2 and footnote 5), sorted by cell for evaluation. */
#include "lattice/lattice.h"
#include "math/tolerance.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <string.h>
#include <unistd.h>

#define BLOCK_POINTS 256u

void ffd_lattice_binding_destroy(ffd_lattice_binding *b)
{
    if (!b)
        return;
    ffd_free(b->params);
    ffd_free(b->inside);
    ffd_free(b->order);
    ffd_free(b->local);
    ffd_free(b->rest);
    ffd_free(b->blocks);
    ffd_free(b->out_index);
    ffd_free(b->out_params);
    ffd_free(b->out_point);
    ffd_free(b->falloff);
    ffd_free(b->falloff_grad);
    ffd_free(b);
}

size_t ffd_lattice_binding_count(const ffd_lattice_binding *b) { return b->n; }
size_t ffd_lattice_binding_inside_count(const ffd_lattice_binding *b) { return b->inside_count; }

int ffd_lattice_binding_params(const ffd_lattice_binding *b, size_t i, double stu[3])
{
    memcpy(stu, b->params + 3 * i, 3 * sizeof(double));
    return b->inside[i];
}



/* Shared state of one bind. Points are split into `nchunk` contiguous chunks in
 * index order; each chunk has its own histogram row, and placement offsets are
 * prefix sums over (cell, chunk) in that order. So, within a cell (and among
 * the outside points), points keep ascending original index for any chunk
 * count: the binding is bitwise the same for any thread count. */
typedef struct bind_ctx {
    const ffd_lattice *lat;
    const double *points;
    ffd_lattice_binding *b;
    int bspline;
    uint32_t nseg[3];
    size_t ncell;
    size_t nchunk;
    uint32_t *hist; /* nchunk by ncell counts, then offsets (row k: chunk k) */
    size_t *out_at; /* per chunk: outside count, then first outside slot */
} bind_ctx;

static inline size_t chunk_begin(size_t n, size_t k, size_t nchunk)
{
    return (size_t)((unsigned long long)n * k / nchunk);
}

/* Cell of inside point i from its parameters (derived, so not stored). */
static inline uint32_t cell_of(const bind_ctx *x, const double *S)
{
    if (!x->bspline)
        return 0;
    const uint32_t *res = x->lat->res;
    return (ffd_bspline_segment(S[0], res[0]) * x->nseg[1] + ffd_bspline_segment(S[1], res[1])) * x->nseg[2] +
           ffd_bspline_segment(S[2], res[2]);
}

/* Phase 1 on points [lo, hi): parameters and inside flags, cell counts into
 * hist (when not NULL) and outside count. Returns the first non-finite point
 * index, or SIZE_MAX. */
static size_t bind_params(const bind_ctx *x, size_t lo, size_t hi, uint32_t *hist, size_t *nout)
{
    const ffd_lattice *lat = x->lat;
    ffd_lattice_binding *b = x->b;
    const int raw = b->outside == FFD_OUTSIDE_EXTRAPOLATE && !x->bspline;
    size_t first_bad = SIZE_MAX, out = 0;
    for (size_t i = lo; i < hi; i++) {
        const double *pt = x->points + 3 * i;
        double *S = b->params + 3 * i;
        if (!(isfinite(pt[0]) && isfinite(pt[1]) && isfinite(pt[2]))) {
            if (first_bad == SIZE_MAX)
                first_bad = i;
            S[0] = S[1] = S[2] = 0.0; /* the bind fails; keep the arrays defined */
            b->inside[i] = 0;
            continue;
        }
        double d[3], loc[3];
        for (int c = 0; c < 3; c++)
            d[c] = pt[c] - lat->box.origin[c];
        int in = 1;
        for (int c = 0; c < 3; c++) {
            loc[c] = lat->dual[c][0] * d[0] + lat->dual[c][1] * d[1] + lat->dual[c][2] * d[2];
            if (!(loc[c] >= -FFD_TOL_BOUNDARY && loc[c] <= 1.0 + FFD_TOL_BOUNDARY))
                in = 0;
        }
        b->inside[i] = (unsigned char)in;
        for (int c = 0; c < 3; c++) {
            double l = loc[c];
            if (in || !raw)
                l = l < 0 ? 0 : (l > 1 ? 1 : l);
            S[c] = x->bspline ? ffd_bspline_invert(lat->res[c], lat->knots_value[c], l) : l;
        }
        if (!in)
            out++;
        else if (hist)
            hist[cell_of(x, S)]++;
    }
    *nout = out;
    return first_bad;
}

/* Phase 2 on chunk k = points [lo, hi): scatters inside points into their cell
 * ranges (offsets in row k of hist) and fills the outside records. */
static void bind_place(const bind_ctx *x, size_t k, size_t lo, size_t hi)
{
    const ffd_lattice *lat = x->lat;
    ffd_lattice_binding *b = x->b;
    uint32_t *next = x->hist + k * x->ncell;
    const size_t nin = b->inside_count;
    double *ls = b->local, *lt = b->local + nin, *lu = b->local + 2 * nin;
    size_t o = x->out_at[k];
    for (size_t i = lo; i < hi; i++) {
        const double *S = b->params + 3 * i;
        if (!b->inside[i]) {
            const double *pt = x->points + 3 * i;
            b->out_index[o] = (uint32_t)i;
            memcpy(b->out_params + 3 * o, S, 3 * sizeof(double));
            /* the point itself: fixed keeps it, clamp and extrapolation add the
             * lattice's displacement at the (clamped or raw) parameters */
            memcpy(b->out_point + 3 * o, pt, 3 * sizeof(double));
            o++;
            continue;
        }
        uint32_t pos = next[cell_of(x, S)]++;
        b->order[pos] = (uint32_t)i;
        memcpy(b->rest + 3 * (size_t)pos, x->points + 3 * i, 3 * sizeof(double));
        if (x->bspline) {
            const uint32_t *res = lat->res;
            ls[pos] = S[0] - (double)ffd_bspline_segment(S[0], res[0]);
            lt[pos] = S[1] - (double)ffd_bspline_segment(S[1], res[1]);
            lu[pos] = S[2] - (double)ffd_bspline_segment(S[2], res[2]);
        } else {
            ls[pos] = S[0];
            lt[pos] = S[1];
            lu[pos] = S[2];
        }
    }
}

/* Between the phases (one thread): turns counts into offsets, sizes and
 * allocates the sorted arrays. Returns 0 when out of memory. */
static int bind_prefix(bind_ctx *x, size_t n)
{
    ffd_lattice_binding *b = x->b;
    size_t nout = 0;
    for (size_t k = 0; k < x->nchunk; k++) {
        size_t cnt = x->out_at[k];
        x->out_at[k] = nout;
        nout += cnt;
    }
    size_t nin = n - nout;
    /* cell-major, chunk-minor: the sequential order of a stable counting sort */
    uint32_t pos = 0;
    for (size_t c = 0; c < x->ncell; c++)
        for (size_t k = 0; k < x->nchunk; k++) {
            uint32_t cnt = x->hist[k * x->ncell + c];
            x->hist[k * x->ncell + c] = pos;
            pos += cnt;
        }
    b->inside_count = nin;
    b->order = ffd_malloc_array(nin, sizeof *b->order);
    b->local = ffd_malloc_array(nin, 3 * sizeof(double));
    b->rest = ffd_malloc_array(nin, 3 * sizeof(double));
    b->out_index = ffd_malloc_array(nout, sizeof *b->out_index);
    b->out_params = ffd_malloc_array(nout, 3 * sizeof(double));
    b->out_point = ffd_malloc_array(nout, 3 * sizeof(double));
    return b->order && b->local && b->rest && b->out_index && b->out_params && b->out_point;
}

/* Blocks of at most BLOCK_POINTS points per cell, from the cell ends (after
 * placement, the last chunk's row of hist holds the end of each cell). */
static int bind_blocks(const bind_ctx *x)
{
    ffd_lattice_binding *b = x->b;
    const uint32_t *end_of = x->hist + (x->nchunk - 1) * x->ncell;
    size_t nblock = 0, begin = 0;
    for (size_t c = 0; c < x->ncell; c++) {
        nblock += (end_of[c] - begin + BLOCK_POINTS - 1) / BLOCK_POINTS;
        begin = end_of[c];
    }
    b->blocks = ffd_malloc_array(nblock ? nblock : 1, sizeof *b->blocks);
    if (!b->blocks)
        return 0;
    const size_t ntu = (size_t)x->nseg[1] * x->nseg[2];
    size_t k = 0;
    begin = 0;
    for (size_t c = 0; c < x->ncell; c++) {
        size_t end = end_of[c];
        for (size_t p = begin; p < end; p += BLOCK_POINTS) {
            ffd_lattice_block *blk = &b->blocks[k++];
            blk->cell[0] = (uint32_t)(c / ntu);
            blk->cell[1] = (uint32_t)((c / x->nseg[2]) % x->nseg[1]);
            blk->cell[2] = (uint32_t)(c % x->nseg[2]);
            blk->begin = (uint32_t)p;
            blk->end = (uint32_t)(p + BLOCK_POINTS < end ? p + BLOCK_POINTS : end);
        }
        begin = end;
    }
    b->block_count = nblock;
    return 1;
}

ffd_status ffd_lattice_bind(const ffd_lattice *lat, const double *points, size_t n,
                            ffd_outside outside, ffd_lattice_binding **out, ffd_error *err)
{
    *out = NULL;
    if (outside != FFD_OUTSIDE_FIXED && outside != FFD_OUTSIDE_CLAMP &&
        outside != FFD_OUTSIDE_EXTRAPOLATE)
        return ffd_fail(err, FFD_ERR_INVALID,
                        outside == FFD_OUTSIDE_FALLOFF
                            ? "outside policy %d (falloff) needs a distance: ffd_lattice_bind_falloff"
                            : "unknown outside policy %d",
                        (int)outside);
    if (n > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "cannot bind %zu points (at most 2^32-1)", n);
    if (lat->gen)
        return ffd_lattice_general_bind(lat, points, n, outside, out, err);
    bind_ctx x = {.lat = lat, .points = points, .bspline = lat->basis == FFD_BASIS_BSPLINE};
    for (int c = 0; c < 3; c++)
        x.nseg[c] = x.bspline ? lat->res[c] + 1 : 1;
    x.ncell = (size_t)x.nseg[0] * x.nseg[1] * x.nseg[2];
    /* One histogram row per thread while the rows are small next to the
     * points; otherwise (huge lattices, few points) one sequential row. */
    int nt = omp_get_max_threads();
    size_t maxchunk = (size_t)nt;
    if (maxchunk > 1 && x.ncell * maxchunk > n + 65536)
        maxchunk = 1;
    ffd_lattice_binding *b = ffd_calloc(1, sizeof *b);
    if (!b)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory binding %zu points", n);
    x.b = b;
    b->n = n;
    b->outside = outside;
    b->basis = lat->basis;
    memcpy(b->res, lat->res, sizeof b->res);
    b->params = ffd_malloc_array(n, 3 * sizeof(double));
    b->inside = ffd_malloc_array(n, 1);
    x.hist = ffd_calloc(maxchunk * x.ncell, sizeof *x.hist);
    x.out_at = ffd_calloc(maxchunk, sizeof *x.out_at);
    if (!b->params || !b->inside || !x.hist || !x.out_at)
        goto oom;

    size_t first_bad = SIZE_MAX;
    int ok = 1;
    ffd_progress progress;
    ffd_progress_begin(&progress, "binding");
#pragma omp parallel num_threads(nt) reduction(min : first_bad)
    {
        size_t T = (size_t)omp_get_num_threads(), t = (size_t)omp_get_thread_num();
        /* a team smaller than asked for still gets a row each (T <= maxchunk) */
        size_t nchunk = maxchunk == 1 ? 1 : T;
        size_t lo = chunk_begin(n, t, T), hi = chunk_begin(n, t + 1, T), nout_t;
        uint32_t *row = nchunk == T ? x.hist + t * x.ncell : NULL;
        first_bad = bind_params(&x, lo, hi, row, &nout_t);
        if (row)
            x.out_at[t] = nout_t;
#pragma omp barrier
#pragma omp single
        {
            x.nchunk = nchunk;
            if (nchunk == 1 && T > 1) { /* sequential counts for the single row */
                for (size_t i = 0; i < n; i++) {
                    if (b->inside[i])
                        x.hist[cell_of(&x, b->params + 3 * i)]++;
                    else
                        x.out_at[0]++;
                }
            }
        }
        /* a non-finite point anywhere makes the whole bind fail, so skip placement;
         * first_bad is private until the reduction, hence the shared flag */
#pragma omp atomic update
        ok &= first_bad == SIZE_MAX;
#pragma omp barrier
#pragma omp single
        {
            if (ok && !bind_prefix(&x, n))
                ok = -1;
        }
        if (ok == 1 && t < nchunk)
            bind_place(&x, t, chunk_begin(n, t, nchunk), chunk_begin(n, t + 1, nchunk));
    }
    if (first_bad != SIZE_MAX) {
        ffd_free(x.hist);
        ffd_free(x.out_at);
        ffd_lattice_binding_destroy(b);
        return ffd_fail(err, FFD_ERR_NONFINITE, "point %zu has a non-finite coordinate",
                        first_bad);
    }
    ffd_progress_update(&progress, 0.8);
    if (ok != 1 || !bind_blocks(&x))
        goto oom;
    ffd_progress_end(&progress);
    ffd_free(x.hist);
    ffd_free(x.out_at);
    *out = b;
    return FFD_OK;
oom:
    ffd_free(x.hist);
    ffd_free(x.out_at);
    ffd_lattice_binding_destroy(b);
    return ffd_fail(err, FFD_ERR_NOMEM, "out of memory binding %zu points", n);
}
