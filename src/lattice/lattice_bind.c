/* lattice — binding: local coordinates of object points by inverting the rest
 * map (Hsu et al. 1992, §2 and footnote 5), sorted by cell for evaluation. */
#include "lattice/lattice.h"
#include "math/tolerance.h"

#include <math.h>
#include <string.h>

#define BLOCK_POINTS 256u

void ffd_lattice_binding_destroy(ffd_lattice_binding *b)
{
    if (!b)
        return;
    ffd_free(b->params);
    ffd_free(b->inside);
    ffd_free(b->order);
    ffd_free(b->local);
    ffd_free(b->blocks);
    ffd_free(b->out_index);
    ffd_free(b->out_params);
    ffd_free(b->out_offset);
    ffd_free(b);
}

size_t ffd_lattice_binding_count(const ffd_lattice_binding *b) { return b->n; }
size_t ffd_lattice_binding_inside_count(const ffd_lattice_binding *b) { return b->inside_count; }

int ffd_lattice_binding_params(const ffd_lattice_binding *b, size_t i, double stu[3])
{
    memcpy(stu, b->params + 3 * i, 3 * sizeof(double));
    return b->inside[i];
}

/* Segment of a global B-spline parameter (the last segment is closed). */
static inline uint32_t segment_of(double S, uint32_t res)
{
    uint32_t sigma = S <= 0 ? 0 : (uint32_t)S;
    return sigma > res ? res : sigma;
}

ffd_status ffd_lattice_bind(const ffd_lattice *lat, const double *points, size_t n,
                            ffd_outside outside, ffd_lattice_binding **out, ffd_error *err)
{
    *out = NULL;
    if (outside != FFD_OUTSIDE_FIXED && outside != FFD_OUTSIDE_CLAMP &&
        outside != FFD_OUTSIDE_EXTRAPOLATE)
        return ffd_fail(err, FFD_ERR_INVALID, "unknown outside policy %d", (int)outside);
    if (n > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "cannot bind %zu points (at most 2^32-1)", n);
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(points[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "point %zu has a non-finite coordinate", i / 3);
    ffd_lattice_binding *b = ffd_calloc(1, sizeof *b);
    uint32_t *cell = NULL;
    size_t *start = NULL;
    if (!b)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory binding %zu points", n);
    b->n = n;
    b->outside = outside;
    b->basis = lat->basis;
    memcpy(b->res, lat->res, sizeof b->res);
    b->params = ffd_malloc_array(n, 3 * sizeof(double));
    b->inside = ffd_malloc_array(n, 1);
    cell = ffd_malloc_array(n, sizeof *cell);
    if (!b->params || !b->inside || !cell)
        goto oom;

    const int bspline = lat->basis == FFD_BASIS_BSPLINE;
    const uint32_t nseg[3] = {bspline ? lat->res[0] + 1 : 1, bspline ? lat->res[1] + 1 : 1,
                              bspline ? lat->res[2] + 1 : 1};
    const long long nn = (long long)n;
#pragma omp parallel for schedule(static)
    for (long long ii = 0; ii < nn; ii++) {
        size_t i = (size_t)ii;
        double d[3], loc[3];
        for (int c = 0; c < 3; c++)
            d[c] = points[3 * i + c] - lat->box.origin[c];
        int in = 1;
        for (int c = 0; c < 3; c++) {
            loc[c] = lat->dual[c][0] * d[0] + lat->dual[c][1] * d[1] + lat->dual[c][2] * d[2];
            if (!(loc[c] >= -FFD_TOL_BOUNDARY && loc[c] <= 1.0 + FFD_TOL_BOUNDARY))
                in = 0;
        }
        b->inside[i] = (unsigned char)in;
        double *S = b->params + 3 * i;
        uint32_t sg[3];
        for (int c = 0; c < 3; c++) {
            double l = loc[c];
            int raw = !in && outside == FFD_OUTSIDE_EXTRAPOLATE && !bspline;
            if (!raw)
                l = l < 0 ? 0 : (l > 1 ? 1 : l);
            S[c] = bspline ? ffd_bspline_invert(lat->res[c], lat->knots_value[c], l) : l;
            sg[c] = bspline ? segment_of(S[c], lat->res[c]) : 0;
        }
        cell[i] = in ? (sg[0] * nseg[1] + sg[1]) * nseg[2] + sg[2] : UINT32_MAX;
    }

    /* counting sort of the inside points by cell (deterministic) */
    size_t ncell = (size_t)nseg[0] * nseg[1] * nseg[2];
    start = ffd_calloc(ncell + 1, sizeof *start);
    if (!start)
        goto oom;
    size_t nin = 0;
    for (size_t i = 0; i < n; i++)
        if (cell[i] != UINT32_MAX) {
            start[cell[i] + 1]++;
            nin++;
        }
    for (size_t c = 0; c < ncell; c++)
        start[c + 1] += start[c];
    b->inside_count = nin;
    b->order = ffd_malloc_array(nin, sizeof *b->order);
    b->local = ffd_malloc_array(nin, 3 * sizeof(double));
    size_t nout = n - nin;
    b->out_index = ffd_malloc_array(nout, sizeof *b->out_index);
    b->out_params = ffd_malloc_array(nout, 3 * sizeof(double));
    b->out_offset = ffd_malloc_array(nout, 3 * sizeof(double));
    if (!b->order || !b->local || !b->out_index || !b->out_params || !b->out_offset)
        goto oom;
    {
        size_t o = 0;
        for (size_t i = 0; i < n; i++) {
            if (cell[i] == UINT32_MAX) {
                b->out_index[o] = (uint32_t)i;
                memcpy(b->out_params + 3 * o, b->params + 3 * i, 3 * sizeof(double));
                double rest[3];
                ffd_lattice_rest_at(lat, b->params + 3 * i, rest);
                /* fixed: the point itself; clamp: its offset from the clamped rest point;
                 * Bernstein extrapolation: nothing (the polynomials reproduce it) */
                int extrapolate = outside == FFD_OUTSIDE_EXTRAPOLATE && !bspline;
                for (int c = 0; c < 3; c++)
                    b->out_offset[3 * o + c] = outside == FFD_OUTSIDE_FIXED ? points[3 * i + c]
                                               : extrapolate ? 0.0
                                                             : points[3 * i + c] - rest[c];
                o++;
                continue;
            }
            size_t pos = start[cell[i]]++;
            b->order[pos] = (uint32_t)i;
            const double *S = b->params + 3 * i;
            for (int c = 0; c < 3; c++)
                b->local[(size_t)c * nin + pos] =
                    bspline ? S[c] - (double)segment_of(S[c], lat->res[c]) : S[c];
        }
    }
    /* start[c] now holds the end of cell c; fill local coordinates and blocks */
    size_t nblock = 0;
    {
        size_t begin = 0;
        for (size_t c = 0; c < ncell; c++) {
            size_t end = start[c];
            nblock += (end - begin + BLOCK_POINTS - 1) / BLOCK_POINTS;
            begin = end;
        }
    }
    b->blocks = ffd_malloc_array(nblock ? nblock : 1, sizeof *b->blocks);
    if (!b->blocks)
        goto oom;
    {
        size_t begin = 0, k = 0;
        for (size_t c = 0; c < ncell; c++) {
            size_t end = start[c];
            uint32_t cs = (uint32_t)(c / ((size_t)nseg[1] * nseg[2]));
            uint32_t ct = (uint32_t)((c / nseg[2]) % nseg[1]);
            uint32_t cu = (uint32_t)(c % nseg[2]);
            for (size_t p = begin; p < end; p += BLOCK_POINTS) {
                ffd_lattice_block *blk = &b->blocks[k++];
                blk->cell[0] = cs;
                blk->cell[1] = ct;
                blk->cell[2] = cu;
                blk->begin = (uint32_t)p;
                blk->end = (uint32_t)(p + BLOCK_POINTS < end ? p + BLOCK_POINTS : end);
            }
            begin = end;
        }
        b->block_count = k;
    }
    b->block_count = nblock;
    ffd_free(cell);
    ffd_free(start);
    *out = b;
    return FFD_OK;
oom:
    ffd_free(cell);
    ffd_free(start);
    ffd_lattice_binding_destroy(b);
    return ffd_fail(err, FFD_ERR_NOMEM, "out of memory binding %zu points", n);
}
