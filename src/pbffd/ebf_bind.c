/* pbffd — parameterisation (PB-FFD §3.1): the rows of the sparse N x M matrix
 * W (w_ij = normalised weight, eq. 5) and of D (w_ij u_ij, eq. 7), computed in
 * parallel over points (a counting pass that also notes which grid candidates
 * enter, then each row written in place from those only), so
 * that the rows do not depend on the thread count. Absolute rows (the
 * hierarchy, eq. 10) also keep the master's constant term. */
#include "pbffd/pbffd.h"

#include <assert.h>
#include <string.h>

#define CHUNK 1024

void ffd_ebf_rows_free(ffd_ebf_rows *r)
{
    if (!r)
        return;
    ffd_free(r->start);
    ffd_free(r->col);
    ffd_free(r->w);
    ffd_free(r->d);
    ffd_free(r->c);
    memset(r, 0, sizeof *r);
}

static ffd_status rows_alloc(ffd_ebf_rows *r, size_t n, size_t cap, int absolute)
{
    memset(r, 0, sizeof *r);
    r->n = n;
    r->cap = cap;
    r->start = ffd_malloc_array(n + 1, sizeof *r->start);
    r->col = ffd_malloc_array(cap ? cap : 1, sizeof *r->col);
    r->w = ffd_malloc_array(cap ? cap : 1, sizeof *r->w);
    r->d = ffd_malloc_array(cap ? cap : 1, 3 * sizeof *r->d);
    if (absolute)
        r->c = ffd_malloc_array(n ? n : 1, 3 * sizeof *r->c);
    if (!r->start || !r->col || !r->w || !r->d || (absolute && !r->c)) {
        ffd_ebf_rows_free(r);
        return FFD_ERR_NOMEM;
    }
    r->start[0] = 0;
    return FFD_OK;
}

ffd_status ffd_ebf_rows_bind(const ffd_ebf_space *s, const double *points, size_t n, int absolute,
                             size_t min_cap, ffd_ebf_rows *rows)
{
    memset(rows, 0, sizeof *rows);
    size_t *start = ffd_malloc_array(n + 1, sizeof *start);
    uint64_t *accepted = ffd_malloc_array(n ? n : 1, sizeof *accepted);
    if (!start || !accepted) {
        ffd_free(start);
        ffd_free(accepted);
        return FFD_ERR_NOMEM;
    }
    /* pass 1: row lengths (no exp), pass 2: the rows in place; every point on its own */
    const long long nn = (long long)n;
#pragma omp parallel for schedule(static, CHUNK)
    for (long long i = 0; i < nn; i++)
        start[i + 1] = ffd_ebf_space_count(s, points + 3 * (size_t)i, &accepted[i]);
    start[0] = 0;
    size_t max_nnz = 0;
    for (size_t i = 0; i < n; i++) {
        if (start[i + 1] > max_nnz)
            max_nnz = start[i + 1];
        start[i + 1] += start[i];
    }
    const size_t total = start[n], cap = total > min_cap ? total : min_cap;
    ffd_status st = rows_alloc(rows, n, cap, absolute);
    if (st != FFD_OK) {
        ffd_free(start);
        ffd_free(accepted);
        return st;
    }
    ffd_free(rows->start);
    rows->start = start;
    rows->max_nnz = max_nnz;
    uint32_t *col = rows->col;
    double *w = rows->w, *dd = rows->d, *cst = rows->c;
#pragma omp parallel for schedule(static, CHUNK)
    for (long long ii = 0; ii < nn; ii++) {
        size_t i = (size_t)ii, at = start[i];
        double mw;
        size_t e = ffd_ebf_space_weights(s, points + 3 * i, accepted[i], col + at, w + at,
                                         dd + 3 * at, &mw);
        (void)e;
        assert(e == start[i + 1] - at);
        if (cst)
            for (int c = 0; c < 3; c++) /* the master's p_m + A_m u_m is the point itself */
                cst[3 * i + c] = mw * points[3 * i + c];
    }
    ffd_free(accepted);
    return FFD_OK;
}

ffd_status ffd_ebf_rows_copy(const ffd_ebf_rows *src, size_t min_cap, ffd_ebf_rows *dst)
{
    size_t nnz = src->start ? src->start[src->n] : 0;
    ffd_status st = rows_alloc(dst, src->n, nnz > min_cap ? nnz : min_cap, src->c != NULL);
    if (st != FFD_OK)
        return st;
    ffd_ebf_rows_assign(dst, src);
    return FFD_OK;
}

void ffd_ebf_rows_assign(ffd_ebf_rows *dst, const ffd_ebf_rows *src)
{
    size_t nnz = src->start ? src->start[src->n] : 0;
    dst->n = src->n;
    dst->max_nnz = src->max_nnz;
    if (src->start)
        memcpy(dst->start, src->start, (src->n + 1) * sizeof *dst->start);
    else
        dst->start[0] = 0;
    if (nnz) {
        memcpy(dst->col, src->col, nnz * sizeof *dst->col);
        memcpy(dst->w, src->w, nnz * sizeof *dst->w);
        memcpy(dst->d, src->d, 3 * nnz * sizeof *dst->d);
    }
    if (src->c && dst->c && src->n)
        memcpy(dst->c, src->c, 3 * src->n * sizeof *dst->c);
}

ffd_status ffd_ebf_rows_splice(const ffd_ebf_rows *old, const ffd_ebf_rows *sub, const size_t *pick,
                               size_t n, const uint32_t *colmap, size_t min_cap, ffd_ebf_rows *out)
{
    size_t nnz = 0;
    for (size_t r = 0; r < n; r++) {
        const ffd_ebf_rows *src = pick[r] < old->n ? old : sub;
        size_t i = pick[r] < old->n ? pick[r] : pick[r] - old->n;
        nnz += src->start[i + 1] - src->start[i];
    }
    ffd_status st = rows_alloc(out, n, nnz > min_cap ? nnz : min_cap, old->c != NULL);
    if (st != FFD_OK)
        return st;
    size_t at = 0;
    for (size_t r = 0; r < n; r++) {
        const int from_old = pick[r] < old->n;
        const ffd_ebf_rows *src = from_old ? old : sub;
        size_t i = from_old ? pick[r] : pick[r] - old->n;
        size_t b = src->start[i], e = src->start[i + 1];
        for (size_t k = b; k < e; k++) {
            out->col[at] = from_old && colmap ? colmap[src->col[k]] : src->col[k];
            out->w[at] = src->w[k];
            memcpy(out->d + 3 * at, src->d + 3 * k, 3 * sizeof *out->d);
            at++;
        }
        out->start[r + 1] = at;
        if (e - b > out->max_nnz)
            out->max_nnz = e - b;
        if (out->c)
            memcpy(out->c + 3 * r, src->c + 3 * i, 3 * sizeof *out->c);
    }
    return FFD_OK;
}

void ffd_ebf_rows_eval_abs(const ffd_ebf_rows *rows, size_t i, const ffd_ebf *ctl, double out[3])
{
    /* PB-FFD eq. 10: p = c + sum_j w_ij p_j + sum_j (w_ij u_ij) . (a_j, b_j, c_j) */
    double x[3];
    memcpy(x, rows->c + 3 * i, sizeof x);
    for (size_t k = rows->start[i]; k < rows->start[i + 1]; k++) {
        const ffd_ebf *e = &ctl[rows->col[k]];
        const double w = rows->w[k], *q = rows->d + 3 * k;
        for (int c = 0; c < 3; c++)
            x[c] += w * e->center[c] + q[0] * e->frame[0][c] + q[1] * e->frame[1][c] +
                    q[2] * e->frame[2][c];
    }
    memcpy(out, x, sizeof x);
}
