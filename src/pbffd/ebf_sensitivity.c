/* pbffd — sensitivities of the bound points to the EBF frames (PB-FFD eq. 7,
 * McDonnell & Qin; docs/sensitivities.md, "PB-FFD frames").
 *
 * A bound point is x'_i = x_base_i + W (P - P_base) + D (A - A_base) (eq. 7),
 * D_ij = w_ij (alpha, beta, gamma)_ij, its parameters in control j's frame
 * A_j = (a, b, c) (eq. 3). The rows are fixed (set_frame keeps the
 * parameterisation), so x' is linear in every frame. The design variables of
 * control j are six: a rotation vector omega (the frame turned about the
 * control's centre, axis m becoming exp([omega]x) A_j[m]) and three scalings
 * s (axis m becoming s_m A_j[m]), taken at the current frame (omega = 0,
 * s = 1). With v_ij = sum_m D_ij[m] A_j[m] and g_ij = D_ij:
 *   d x'_i / d omega_j = [e_0 x v_ij, e_1 x v_ij, e_2 x v_ij] = -[v_ij]x
 *   d x'_i / d s_jm    = g_ij[m] A_j[m]
 * A control of a coarser level l moves the centres of level l-1 through that
 * level's absolute rows (eq. 10: P^{l-1}_p = c_p + sum_q W_pq P^l_q +
 * D_pq A^l_q), and they move the bound points through W^{l-2} ... W^0 and the
 * bound points' W (eq. 9; ebf_map.c composes the same product): g_iq is then
 * sum_p (W_mesh W^0 ... W^{l-2})_ip D^{l-1}_pq. Columns are 6 q + (0, 1, 2)
 * for omega and 6 q + 3 + m for s_m; the master is no column (immovable). */
#include "pbffd/pbffd.h"

#include <string.h>

/* One nonzero 3 x 6 block of the matrix: point i against control q. */
typedef struct frame_block {
    uint32_t q;
    double g[3]; /* d x'_i / d s_qm = g[m] A_q[m] */
    double v[3]; /* d x'_i / d omega_q = -[v]x */
} frame_block;

/* Scratch for composing rows of a coarser level (dense over the widest level). */
typedef struct frame_scratch {
    size_t level;
    double *acc;   /* widest */
    double *gacc;  /* 3 x widest */
    unsigned char *seen;
    uint32_t *list[2];
    double *val[2];
} frame_scratch;

static void scratch_free(frame_scratch *s)
{
    ffd_free(s->acc);
    ffd_free(s->gacc);
    ffd_free(s->seen);
    ffd_free(s->list[0]);
    ffd_free(s->list[1]);
    ffd_free(s->val[0]);
    ffd_free(s->val[1]);
    memset(s, 0, sizeof *s);
}

static ffd_status scratch_init(const ffd_pbffd *pb, size_t level, frame_scratch *s, ffd_error *err)
{
    memset(s, 0, sizeof *s);
    if (level >= pb->level_count)
        return ffd_fail(err, FFD_ERR_RANGE, "level %zu out of range (%zu levels)", level,
                        pb->level_count);
    s->level = level;
    if (level == 0)
        return FFD_OK;
    size_t widest = 1;
    for (size_t l = 0; l < pb->level_count; l++)
        if (pb->levels[l].count > widest)
            widest = pb->levels[l].count;
    s->acc = ffd_malloc_array(widest, sizeof *s->acc);
    s->gacc = ffd_malloc_array(widest, 3 * sizeof *s->gacc);
    s->seen = ffd_calloc(widest, 1);
    s->list[0] = ffd_malloc_array(widest, sizeof *s->list[0]);
    s->list[1] = ffd_malloc_array(widest, sizeof *s->list[1]);
    s->val[0] = ffd_malloc_array(widest, sizeof *s->val[0]);
    s->val[1] = ffd_malloc_array(widest, sizeof *s->val[1]);
    if (!s->acc || !s->gacc || !s->seen || !s->list[0] || !s->list[1] || !s->val[0] ||
        !s->val[1]) {
        scratch_free(s);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the frame sensitivities");
    }
    return FFD_OK;
}

static void block_finish(const ffd_ebf *ctl, frame_block *b)
{
    const ffd_ebf *e = &ctl[b->q];
    for (int c = 0; c < 3; c++)
        b->v[c] = b->g[0] * e->frame[0][c] + b->g[1] * e->frame[1][c] + b->g[2] * e->frame[2][c];
}

/* The blocks of bound point i, ascending in q; returns their count (at most
 * the level's control count). */
static size_t point_blocks(const ffd_pbffd *pb, frame_scratch *s, size_t i, frame_block *out)
{
    const ffd_ebf_rows *R = &pb->mesh;
    size_t nb = 0;
    if (s->level == 0) {
        /* columns of a row are distinct and ascending (ebf_space_weights) */
        for (size_t k = R->start[i]; k < R->start[i + 1]; k++) {
            frame_block *b = &out[nb++];
            b->q = R->col[k];
            memcpy(b->g, R->d + 3 * k, sizeof b->g);
            block_finish(pb->levels[0].cur, b);
        }
        return nb;
    }
    /* W_mesh W^0 ... W^{l-2}: the row pushed up to level l-1 (as ebf_map.c) */
    uint32_t *cur = s->list[0], *next = s->list[1];
    double *cv = s->val[0], *nv = s->val[1];
    size_t nnz = 0;
    for (size_t k = R->start[i]; k < R->start[i + 1]; k++) {
        cur[nnz] = R->col[k];
        cv[nnz] = R->w[k];
        nnz++;
    }
    for (size_t l = 0; l + 1 < s->level; l++) {
        const ffd_ebf_rows *W = &pb->levels[l].rows;
        size_t nn = 0;
        for (size_t e = 0; e < nnz; e++)
            for (size_t k = W->start[cur[e]]; k < W->start[cur[e] + 1]; k++) {
                uint32_t q = W->col[k];
                if (!s->seen[q]) {
                    s->seen[q] = 1;
                    s->acc[q] = 0.0;
                    next[nn++] = q;
                }
                s->acc[q] += cv[e] * W->w[k];
            }
        for (size_t e = 0; e < nn; e++) {
            nv[e] = s->acc[next[e]];
            s->seen[next[e]] = 0;
        }
        nnz = nn;
        uint32_t *tl = cur;
        cur = next;
        next = tl;
        double *tv = cv;
        cv = nv;
        nv = tv;
    }
    /* then level l-1's D over level l (eq. 10) */
    const ffd_ebf_rows *U = &pb->levels[s->level - 1].rows;
    size_t nn = 0;
    for (size_t e = 0; e < nnz; e++)
        for (size_t k = U->start[cur[e]]; k < U->start[cur[e] + 1]; k++) {
            uint32_t q = U->col[k];
            double *g = s->gacc + 3 * (size_t)q;
            if (!s->seen[q]) {
                s->seen[q] = 1;
                g[0] = g[1] = g[2] = 0.0;
                next[nn++] = q;
            }
            for (int m = 0; m < 3; m++)
                g[m] += cv[e] * U->d[3 * k + m];
        }
    /* ascending columns (insertion sort: rows are short) */
    for (size_t a = 1; a < nn; a++) {
        uint32_t t = next[a];
        size_t b = a;
        for (; b > 0 && next[b - 1] > t; b--)
            next[b] = next[b - 1];
        next[b] = t;
    }
    for (size_t e = 0; e < nn; e++) {
        frame_block *b = &out[nb++];
        b->q = next[e];
        memcpy(b->g, s->gacc + 3 * (size_t)next[e], sizeof b->g);
        s->seen[next[e]] = 0;
        block_finish(pb->levels[s->level].cur, b);
    }
    return nb;
}

/* Row c (0..2) of a block: its five structural nonzeros, columns ascending.
 * Column 6q + k (omega_k) holds (e_k x v)_c, which is 0 for k == c. */
static size_t block_row(const ffd_ebf *ctl, const frame_block *b, int c, uint32_t *col, double *val)
{
    /* e_k x v = (0, -v2, v1), (v2, 0, -v0), (-v1, v0, 0) for k = 0, 1, 2 */
    static const int sgn[3][3] = {{0, 1, -1}, {-1, 0, 1}, {1, -1, 0}}; /* sgn[c][k] */
    const uint32_t base = 6u * b->q;
    size_t n = 0;
    for (int k = 0; k < 3; k++) {
        if (k == c)
            continue;
        int other = 3 - c - k; /* (e_k x v)_c = sgn v_other */
        col[n] = base + (uint32_t)k;
        val[n] = sgn[c][k] * b->v[other];
        n++;
    }
    for (int m = 0; m < 3; m++) {
        col[n] = base + 3u + (uint32_t)m;
        val[n] = b->g[m] * ctl[b->q].frame[m][c];
        n++;
    }
    return n;
}

static ffd_status check_columns(const ffd_pbffd *pb, size_t level, ffd_error *err)
{
    if (level < pb->level_count && pb->levels[level].count > UINT32_MAX / 6)
        return ffd_fail(err, FFD_ERR_INVALID, "level %zu: %zu controls: too many for 32-bit columns",
                        level, pb->levels[level].count);
    return FFD_OK;
}

ffd_status ffd_pb_frame_sensitivities_csr(const ffd_pbffd *pb, size_t level, size_t **ptr_out,
                                          uint32_t **col_out, double **val_out, ffd_error *err)
{
    *ptr_out = NULL;
    *col_out = NULL;
    *val_out = NULL;
    frame_scratch s;
    ffd_status st = check_columns(pb, level, err);
    if (st || (st = scratch_init(pb, level, &s, err)) != FFD_OK)
        return st;
    const size_t n = pb->n, m = pb->levels[level].count;
    const ffd_ebf *ctl = pb->levels[level].cur;
    frame_block *blk = ffd_malloc_array(m ? m : 1, sizeof *blk);
    size_t *ptr = ffd_malloc_array(3 * n + 1, sizeof *ptr);
    uint32_t *col = NULL;
    double *val = NULL;
    if (!blk || !ptr)
        goto nomem;
    /* first pass: the block count per point, for the sizes */
    size_t total = 0;
    for (size_t i = 0; i < n; i++) {
        size_t nb = point_blocks(pb, &s, i, blk);
        for (int c = 0; c < 3; c++)
            ptr[3 * i + c] = total + 5 * nb * (size_t)c;
        total += 15 * nb;
    }
    ptr[3 * n] = total;
    col = ffd_malloc_array(total ? total : 1, sizeof *col);
    val = ffd_malloc_array(total ? total : 1, sizeof *val);
    if (!col || !val)
        goto nomem;
    for (size_t i = 0; i < n; i++) {
        size_t nb = point_blocks(pb, &s, i, blk);
        for (int c = 0; c < 3; c++) {
            size_t at = ptr[3 * i + c];
            for (size_t b = 0; b < nb; b++)
                at += block_row(ctl, &blk[b], c, col + at, val + at);
        }
    }
    ffd_free(blk);
    scratch_free(&s);
    *ptr_out = ptr;
    *col_out = col;
    *val_out = val;
    return FFD_OK;
nomem:
    ffd_free(blk);
    ffd_free(ptr);
    ffd_free(col);
    ffd_free(val);
    scratch_free(&s);
    return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the frame sensitivities");
}

ffd_status ffd_pb_frame_sensitivity_product(const ffd_pbffd *pb, size_t level, const double *v,
                                            double *out, int transpose, ffd_error *err)
{
    frame_scratch s;
    ffd_status st = check_columns(pb, level, err);
    if (st || (st = scratch_init(pb, level, &s, err)) != FFD_OK)
        return st;
    const size_t n = pb->n, m = pb->levels[level].count;
    const ffd_ebf *ctl = pb->levels[level].cur;
    frame_block *blk = ffd_malloc_array(m ? m : 1, sizeof *blk);
    if (!blk) {
        scratch_free(&s);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the frame sensitivities");
    }
    if (transpose)
        memset(out, 0, 6 * m * sizeof *out);
    for (size_t i = 0; i < n; i++) {
        size_t nb = point_blocks(pb, &s, i, blk);
        if (!transpose) {
            /* d x'_i = sum_q omega_q x v_iq + sum_m s_qm g_iq[m] A_q[m] */
            double d[3] = {0, 0, 0};
            for (size_t b = 0; b < nb; b++) {
                const frame_block *B = &blk[b];
                const double *om = v + 6 * (size_t)B->q, *sc = om + 3;
                const ffd_ebf *e = &ctl[B->q];
                d[0] += om[1] * B->v[2] - om[2] * B->v[1];
                d[1] += om[2] * B->v[0] - om[0] * B->v[2];
                d[2] += om[0] * B->v[1] - om[1] * B->v[0];
                for (int a = 0; a < 3; a++)
                    for (int c = 0; c < 3; c++)
                        d[c] += sc[a] * B->g[a] * e->frame[a][c];
            }
            memcpy(out + 3 * i, d, sizeof d);
        } else {
            /* w . (omega x v) = omega . (v x w); w . (s g A) = s g (A . w) */
            const double *w = v + 3 * i;
            for (size_t b = 0; b < nb; b++) {
                const frame_block *B = &blk[b];
                double *om = out + 6 * (size_t)B->q, *sc = om + 3;
                const ffd_ebf *e = &ctl[B->q];
                om[0] += B->v[1] * w[2] - B->v[2] * w[1];
                om[1] += B->v[2] * w[0] - B->v[0] * w[2];
                om[2] += B->v[0] * w[1] - B->v[1] * w[0];
                for (int a = 0; a < 3; a++)
                    sc[a] += B->g[a] * (e->frame[a][0] * w[0] + e->frame[a][1] * w[1] +
                                        e->frame[a][2] * w[2]);
            }
        }
    }
    ffd_free(blk);
    scratch_free(&s);
    return FFD_OK;
}

/* ---- the public API ---- */

ffd_status ffd_pbffd_frame_sensitivities(const ffd_pbffd *pb, size_t level, ffd_sparse *out,
                                         ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_pbffd_frame_sensitivities: out is NULL");
    memset(out, 0, sizeof *out);
    if (!pb)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_pbffd_frame_sensitivities: NULL deformer");
    size_t *ptr;
    uint32_t *col;
    double *val;
    ffd_status st = ffd_pb_frame_sensitivities_csr(pb, level, &ptr, &col, &val, err);
    if (st)
        return st;
    out->rows = 3 * pb->n;
    out->cols = 6 * pb->levels[level].count;
    out->nnz = ptr[3 * pb->n];
    out->row_ptr = ptr;
    out->col = col;
    out->val = val;
    return FFD_OK;
}

ffd_status ffd_pbffd_frame_sensitivity_product(const ffd_pbffd *pb, size_t level, const double *v,
                                               double *out, ffd_error *err)
{
    if (!pb || (!v && level < pb->level_count && pb->levels[level].count) || (!out && pb->n))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_pbffd_frame_sensitivity_product: NULL argument");
    return ffd_pb_frame_sensitivity_product(pb, level, v, out, 0, err);
}

ffd_status ffd_pbffd_frame_sensitivity_transpose_product(const ffd_pbffd *pb, size_t level,
                                                         const double *w, double *out,
                                                         ffd_error *err)
{
    if (!pb || (!w && pb->n) || (!out && level < pb->level_count && pb->levels[level].count))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "ffd_pbffd_frame_sensitivity_transpose_product: NULL argument");
    return ffd_pb_frame_sensitivity_product(pb, level, w, out, 1, err);
}
