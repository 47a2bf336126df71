/* pbffd — parameterisation (PB-FFD §3.1): the rows of the sparse N x M matrix
 * W (w_ij = normalised weight, eq. 5) and of D (w_ij u_ij, eq. 7), computed in
 * parallel over points in fixed chunks, so that the rows do not depend on the
 * thread count. Absolute rows (the hierarchy, eq. 10) also keep the master's
 * constant term. */
#include "pbffd/pbffd.h"

#include <string.h>

#define CHUNK 2048u

void ffd_ebf_rows_free(ffd_ebf_rows *r)
{
    if (!r)
        return;
    ffd_free(r->start);
    ffd_free(r->col);
    ffd_free(r->wd);
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
    r->wd = ffd_malloc_array(cap ? cap : 1, 4 * sizeof *r->wd);
    if (absolute)
        r->c = ffd_malloc_array(n ? n : 1, 3 * sizeof *r->c);
    if (!r->start || !r->col || !r->wd || (absolute && !r->c)) {
        ffd_ebf_rows_free(r);
        return FFD_ERR_NOMEM;
    }
    r->start[0] = 0;
    return FFD_OK;
}

typedef struct chunk_out {
    size_t nnz, cap;
    uint32_t *col;
    double *wd;
} chunk_out;

ffd_status ffd_ebf_rows_bind(const ffd_ebf_space *s, const double *points, size_t n, int absolute,
                             size_t min_cap, ffd_ebf_rows *rows)
{
    memset(rows, 0, sizeof *rows);
    size_t nchunk = (n + CHUNK - 1) / CHUNK;
    chunk_out *ch = ffd_calloc(nchunk ? nchunk : 1, sizeof *ch);
    size_t *start = ffd_malloc_array(n + 1, sizeof *start);
    double *cst = absolute ? ffd_malloc_array(n ? n : 1, 3 * sizeof *cst) : NULL;
    if (!ch || !start || (absolute && !cst)) {
        ffd_free(ch);
        ffd_free(start);
        ffd_free(cst);
        return FFD_ERR_NOMEM;
    }
    int failed = 0;
    const long long nc = (long long)nchunk;
#pragma omp parallel reduction(| : failed)
    {
        size_t m = s->count ? s->count : 1;
        uint32_t *col = ffd_malloc_array(m, sizeof *col);
        double *wd = ffd_malloc_array(m, 4 * sizeof *wd);
        if (!col || !wd)
            failed = 1;
#pragma omp for schedule(dynamic, 1)
        for (long long k = 0; k < nc; k++) {
            if (!col || !wd)
                continue;
            chunk_out *o = &ch[k];
            size_t lo = (size_t)k * CHUNK, hi = lo + CHUNK < n ? lo + CHUNK : n;
            for (size_t i = lo; i < hi; i++) {
                double mw;
                size_t e = ffd_ebf_space_weights(s, points + 3 * i, col, wd, &mw);
                start[i + 1] = e;
                if (cst)
                    for (int c = 0; c < 3; c++) /* the master's p_m + A_m u_m is the point itself */
                        cst[3 * i + c] = mw * points[3 * i + c];
                if (o->nnz + e > o->cap) {
                    size_t cap = o->cap ? o->cap : 4 * (hi - lo);
                    while (cap < o->nnz + e)
                        cap *= 2;
                    uint32_t *nc2 = ffd_realloc_array(o->col, cap, sizeof *nc2);
                    if (nc2)
                        o->col = nc2;
                    double *nw = ffd_realloc_array(o->wd, cap, 4 * sizeof *nw);
                    if (nw)
                        o->wd = nw;
                    if (!nc2 || !nw) {
                        failed = 1;
                        break;
                    }
                    o->cap = cap;
                }
                if (e == 0)
                    continue;
                memcpy(o->col + o->nnz, col, e * sizeof *col);
                memcpy(o->wd + 4 * o->nnz, wd, 4 * e * sizeof *wd);
                o->nnz += e;
            }
        }
        ffd_free(col);
        ffd_free(wd);
    }
    ffd_status st = failed ? FFD_ERR_NOMEM : FFD_OK;
    size_t total = 0, max_nnz = 0;
    if (st == FFD_OK) {
        start[0] = 0;
        for (size_t i = 0; i < n; i++) {
            size_t e = start[i + 1];
            if (e > max_nnz)
                max_nnz = e;
            start[i + 1] = start[i] + e;
        }
        total = start[n];
        size_t cap = total > min_cap ? total : min_cap;
        rows->col = ffd_malloc_array(cap ? cap : 1, sizeof *rows->col);
        rows->wd = ffd_malloc_array(cap ? cap : 1, 4 * sizeof *rows->wd);
        if (!rows->col || !rows->wd)
            st = FFD_ERR_NOMEM;
        rows->cap = cap;
    }
    if (st == FFD_OK) {
        size_t at = 0;
        for (size_t k = 0; k < nchunk; k++) {
            if (ch[k].nnz) {
                memcpy(rows->col + at, ch[k].col, ch[k].nnz * sizeof *rows->col);
                memcpy(rows->wd + 4 * at, ch[k].wd, 4 * ch[k].nnz * sizeof *rows->wd);
            }
            at += ch[k].nnz;
        }
        rows->n = n;
        rows->start = start;
        rows->c = cst;
        rows->max_nnz = max_nnz;
        start = NULL;
        cst = NULL;
    } else {
        ffd_free(rows->col);
        ffd_free(rows->wd);
        memset(rows, 0, sizeof *rows);
    }
    for (size_t k = 0; k < nchunk; k++) {
        ffd_free(ch[k].col);
        ffd_free(ch[k].wd);
    }
    ffd_free(ch);
    ffd_free(start);
    ffd_free(cst);
    return st;
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
        memcpy(dst->wd, src->wd, 4 * nnz * sizeof *dst->wd);
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
            memcpy(out->wd + 4 * at, src->wd + 4 * k, 4 * sizeof *out->wd);
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
        const double *q = rows->wd + 4 * k;
        for (int c = 0; c < 3; c++)
            x[c] += q[0] * e->center[c] + q[1] * e->frame[0][c] + q[2] * e->frame[1][c] +
                    q[3] * e->frame[2][c];
    }
    memcpy(out, x, sizeof x);
}
