/* tsv_arap — the proxy-driven ARAP solve of Zhang, Zheng & Cai 2020 (paper
 * §3.4, eqs. 3-8; design §6): one-form, proxy Laplacian, volumetric
 * Laplacian and target terms, one CHOLMOD factorisation shared by the three
 * coordinates, local rotations refitted after every solve.
 *
 * Works on plain arrays (tsv_arap_graph); everything that does not depend on
 * the rotations or the targets is precomputed at create, so a solve is a
 * tight right-hand-side assembly, one cached triangular solve with three
 * columns and a 3x3 SVD per point.
 *
 * CHOLMOD allocation: SuiteSparse 5 (CHOLMOD 3) allocates through the
 * process-wide SuiteSparse_config function table, not through
 * cholmod_common. On the first create we point that table at the library
 * allocator, but only when it still holds the C library defaults (a host
 * that installed its own functions keeps them). SuiteSparse asks that the
 * table be changed before threads use it; the switch happens once, under a
 * critical section. CHOLMOD printing is off (print = 0, no error handler). */
#include "tspline/tsv.h"

#include <cholmod.h>

#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------------------
 * CHOLMOD through the library allocator
 * --------------------------------------------------------------------- */

static void *arap_ss_malloc(size_t size)
{
    return ffd_malloc(size);
}

static void *arap_ss_calloc(size_t count, size_t size)
{
    return ffd_calloc(count, size);
}

static void *arap_ss_realloc(void *ptr, size_t size)
{
    return ffd_realloc(ptr, size);
}

static void arap_ss_free(void *ptr)
{
    ffd_free(ptr);
}

static void route_cholmod_allocation(void)
{
#pragma omp critical(tsv_arap_suitesparse_config)
    {
        if (SuiteSparse_config.malloc_func == malloc && SuiteSparse_config.calloc_func == calloc &&
            SuiteSparse_config.realloc_func == realloc && SuiteSparse_config.free_func == free) {
            SuiteSparse_config.malloc_func = arap_ss_malloc;
            SuiteSparse_config.calloc_func = arap_ss_calloc;
            SuiteSparse_config.realloc_func = arap_ss_realloc;
            SuiteSparse_config.free_func = arap_ss_free;
        }
    }
}

/* ---------------------------------------------------------------------
 * Data
 * --------------------------------------------------------------------- */

/* Compressed rows; symmetric adjacencies have val NULL unless weighted. */
typedef struct arap_csr {
    size_t *ptr; /* rows + 1 */
    uint32_t *col;
    double *val;
} arap_csr;

/* A rotated differential operator L (rows of eq. 5 or eq. 6): row r belongs
 * to vertex row_vertex[r], includes its diagonal, and has the reference
 * differential delta_r = (L p)_i. */
typedef struct arap_operator {
    size_t rows;
    uint32_t *row_vertex;
    size_t *ptr;
    uint32_t *col;
    double *coef;   /* L entries */
    double *wcoef;  /* weight * L entries, for the right-hand side */
    double *delta;  /* 3 per row */
    double weight;
} arap_operator;

struct tsv_arap {
    size_t n;
    double *ref;                 /* n by 3 reference positions p */
    uint8_t *roles;
    /* one-form (eq. 7): undirected lattice edges and their reference vectors */
    uint32_t *edges;
    double *edge_vec;            /* p_j - p_i per edge */
    size_t edge_count;
    double w_one_form, w_target;
    arap_operator proxy_laplacian;      /* eq. 5 */
    arap_operator volumetric_laplacian; /* eq. 6 */
    arap_csr rot;                /* N_L(i) u N_V(i) for the rotation fit */
    double *rot_dp;              /* p_j - p_i per rot entry */
    double *R;                   /* n 3x3 rotations, row-major */
    uint32_t *soft;              /* target term (eq. 4) rows */
    size_t soft_count;
    uint32_t *hard;              /* fixed rows */
    size_t hard_count;
    size_t *couple_ptr;          /* per hard column: free rows and A entries moved to B */
    uint32_t *couple_row;
    double *couple_val;
    double *rhs;                 /* n by 3 assembly buffer */
    double *sv;                  /* n by 3 last solution (for the rotation fit) */
    size_t free_count;
    int started;
    cholmod_common cc;
    cholmod_factor *L;
    cholmod_dense *B, *X, *Y, *E;
};

static void csr_free(arap_csr *c)
{
    ffd_free(c->ptr);
    ffd_free(c->col);
    ffd_free(c->val);
    memset(c, 0, sizeof *c);
}

static void operator_free(arap_operator *op)
{
    ffd_free(op->row_vertex);
    ffd_free(op->ptr);
    ffd_free(op->col);
    ffd_free(op->coef);
    ffd_free(op->wcoef);
    ffd_free(op->delta);
    memset(op, 0, sizeof *op);
}

/* Symmetric adjacency of n vertices from m undirected pairs (both directions
 * stored, self pairs skipped); duplicates merged, values summed when val is
 * given (one per pair). Rows sorted by column. */
static ffd_status csr_from_pairs(size_t n, const uint32_t *pairs, size_t m, const double *val,
                                 arap_csr *out, ffd_error *err)
{
    memset(out, 0, sizeof *out);
    size_t *cnt = ffd_calloc(n + 1, sizeof *cnt);
    if (!cnt)
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory (adjacency)");
    size_t total = 0;
    for (size_t k = 0; k < m; k++) {
        uint32_t a = pairs[2 * k], b = pairs[2 * k + 1];
        if (a == b)
            continue;
        cnt[a + 1]++;
        cnt[b + 1]++;
        total += 2;
    }
    for (size_t i = 0; i < n; i++)
        cnt[i + 1] += cnt[i];
    uint32_t *col = ffd_malloc_array(total ? total : 1, sizeof *col);
    double *v = val ? ffd_malloc_array(total ? total : 1, sizeof *v) : NULL;
    size_t *fill = ffd_malloc_array(n + 1, sizeof *fill);
    if (!col || (val && !v) || !fill) {
        ffd_free(cnt);
        ffd_free(col);
        ffd_free(v);
        ffd_free(fill);
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory (adjacency)");
    }
    memcpy(fill, cnt, (n + 1) * sizeof *fill);
    for (size_t k = 0; k < m; k++) {
        uint32_t a = pairs[2 * k], b = pairs[2 * k + 1];
        if (a == b)
            continue;
        size_t pa = fill[a]++, pb = fill[b]++;
        col[pa] = b;
        col[pb] = a;
        if (v)
            v[pa] = v[pb] = val[k];
    }
    /* sort each row (insertion sort: rows are short), merge duplicates in place */
    size_t w = 0;
    for (size_t i = 0; i < n; i++) {
        size_t lo = cnt[i], hi = cnt[i + 1];
        for (size_t a = lo + 1; a < hi; a++) {
            uint32_t c = col[a];
            double x = v ? v[a] : 0.0;
            size_t b = a;
            while (b > lo && col[b - 1] > c) {
                col[b] = col[b - 1];
                if (v)
                    v[b] = v[b - 1];
                b--;
            }
            col[b] = c;
            if (v)
                v[b] = x;
        }
        size_t start = w;
        for (size_t a = lo; a < hi; a++) {
            if (w > start && col[w - 1] == col[a]) {
                if (v)
                    v[w - 1] += v[a];
                continue;
            }
            col[w] = col[a];
            if (v)
                v[w] = v[a];
            w++;
        }
        cnt[i] = start;
    }
    cnt[n] = w;
    ffd_free(fill);
    out->ptr = cnt;
    out->col = col;
    out->val = v;
    return FFD_OK;
}

/* ---------------------------------------------------------------------
 * Proxy Laplacian (eq. 5): ear clipping in uv, cotangent weights in 3-D
 * --------------------------------------------------------------------- */

static double cross2(const double *o, const double *a, const double *b)
{
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

static double angle2(const double *o, const double *a, const double *b)
{
    double ux = a[0] - o[0], uy = a[1] - o[1], vx = b[0] - o[0], vy = b[1] - o[1];
    return atan2(fabs(ux * vy - uy * vx), ux * vx + uy * vy);
}

/* Is d inside or on triangle (a,b,c) of orientation sign s? */
static int in_triangle2(const double *a, const double *b, const double *c, const double *d,
                        double s)
{
    return s * cross2(a, b, d) >= 0.0 && s * cross2(b, c, d) >= 0.0 && s * cross2(c, a, d) >= 0.0;
}

static int same2(const double *a, const double *b)
{
    return a[0] == b[0] && a[1] == b[1];
}

/* Ear clipping of a k-gon (uv: 2 per corner): skips ears of area below
 * 1e-12 of the face, takes the ear with the largest minimum angle. tri
 * receives local corner triples; returns the triangle count. live: k entries
 * of scratch. */
static size_t ear_clip(const double *uv, size_t k, uint32_t *live, uint32_t *tri)
{
    double area2 = 0.0;
    for (size_t q = 0; q < k; q++) {
        const double *a = uv + 2 * q, *b = uv + 2 * ((q + 1) % k);
        area2 += a[0] * b[1] - a[1] * b[0];
    }
    if (!(fabs(area2) > 0.0))
        return 0;
    double s = area2 > 0.0 ? 1.0 : -1.0;
    double tol = 1e-12 * fabs(area2); /* on doubled areas */
    size_t m = k, nt = 0;
    for (size_t q = 0; q < k; q++)
        live[q] = (uint32_t)q;
    while (m >= 3) {
        size_t best = SIZE_MAX;
        double best_angle = -1.0;
        for (int pass = 0; pass < 2 && best == SIZE_MAX; pass++) {
            for (size_t q = 0; q < m; q++) {
                uint32_t ia = live[(q + m - 1) % m], ib = live[q], ic = live[(q + 1) % m];
                const double *a = uv + 2 * ia, *b = uv + 2 * ib, *c = uv + 2 * ic;
                if (s * cross2(a, b, c) < tol || !(s * cross2(a, b, c) > 0.0))
                    continue;
                if (pass == 0 && m > 3) {
                    int blocked = 0;
                    for (size_t r = 0; r < m && !blocked; r++) {
                        uint32_t id = live[r];
                        if (id == ia || id == ib || id == ic)
                            continue;
                        const double *d = uv + 2 * id;
                        if (same2(d, a) || same2(d, b) || same2(d, c))
                            continue;
                        blocked = in_triangle2(a, b, c, d, s);
                    }
                    if (blocked)
                        continue;
                }
                double ang = fmin(angle2(a, b, c), fmin(angle2(b, c, a), angle2(c, a, b)));
                if (ang > best_angle) {
                    best_angle = ang;
                    best = q;
                }
            }
        }
        if (best == SIZE_MAX)
            break; /* what is left is degenerate */
        tri[3 * nt] = live[(best + m - 1) % m];
        tri[3 * nt + 1] = live[best];
        tri[3 * nt + 2] = live[(best + 1) % m];
        nt++;
        memmove(live + best, live + best + 1, (m - best - 1) * sizeof *live);
        m--;
    }
    return nt;
}

/* Plain quad: both diagonal splits valid (each triangle of area >= 1e-12 of the face)? */
static int quad_both_splits(const double *uv)
{
    double area2 = cross2(uv, uv + 2, uv + 4) + cross2(uv, uv + 4, uv + 6);
    if (!(fabs(area2) > 0.0))
        return 0;
    double s = area2 > 0.0 ? 1.0 : -1.0, tol = 1e-12 * fabs(area2);
    static const int T[4][3] = {{0, 1, 2}, {0, 2, 3}, {1, 2, 3}, {1, 3, 0}};
    for (int t = 0; t < 4; t++) {
        double a = s * cross2(uv + 2 * T[t][0], uv + 2 * T[t][1], uv + 2 * T[t][2]);
        if (!(a >= tol && a > 0.0))
            return 0;
    }
    return 1;
}

typedef struct cot_pairs {
    uint32_t *pairs;
    double *w;
    size_t count, cap_p, cap_w;
} cot_pairs;

static int cot_push(cot_pairs *cp, uint32_t i, uint32_t j, double w)
{
    if (!ffd_grow((void **)&cp->pairs, &cp->cap_p, 2 * (cp->count + 1), sizeof *cp->pairs) ||
        !ffd_grow((void **)&cp->w, &cp->cap_w, cp->count + 1, sizeof *cp->w))
        return 0;
    cp->pairs[2 * cp->count] = i;
    cp->pairs[2 * cp->count + 1] = j;
    cp->w[cp->count] = w;
    cp->count++;
    return 1;
}

/* Half cotangent weights of triangle (a,b,c) times omega, on the reference. */
static int cot_triangle(cot_pairs *cp, const double *ref, uint32_t a, uint32_t b, uint32_t c,
                        double omega)
{
    if (a == b || b == c || c == a)
        return 1;
    const uint32_t v[3] = {a, b, c};
    for (int k = 0; k < 3; k++) {
        uint32_t o = v[k], i = v[(k + 1) % 3], j = v[(k + 2) % 3];
        double u[3], w[3];
        for (int d = 0; d < 3; d++) {
            u[d] = ref[3 * i + d] - ref[3 * o + d];
            w[d] = ref[3 * j + d] - ref[3 * o + d];
        }
        double cx = u[1] * w[2] - u[2] * w[1], cy = u[2] * w[0] - u[0] * w[2],
               cz = u[0] * w[1] - u[1] * w[0];
        double cr = sqrt(cx * cx + cy * cy + cz * cz);
        double dot = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
        double nu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        double nw = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        double cot = cr > 1e-14 * nu * nw && cr > 0.0 ? dot / cr : 0.0; /* degenerate: 0 */
        if (!cot_push(cp, i, j, 0.5 * omega * cot))
            return 0;
    }
    return 1;
}

/* Operator rows from a weighted adjacency: m_ij = w_ij / sum (uniform when
 * the sum is below 1e-12), entries of weight 0 dropped; rows with skip[i] left out. */
static ffd_status operator_from_weights(const arap_csr *adj, size_t n, const uint8_t *skip,
                                        const double *ref, double weight, arap_operator *op,
                                        ffd_error *err)
{
    memset(op, 0, sizeof *op);
    op->weight = weight;
    size_t rows = 0, nnz = 0;
    for (size_t i = 0; i < n; i++) {
        size_t deg = adj->ptr[i + 1] - adj->ptr[i];
        if (deg && !(skip && skip[i])) {
            rows++;
            nnz += deg + 1;
        }
    }
    op->rows = rows;
    op->row_vertex = ffd_malloc_array(rows ? rows : 1, sizeof *op->row_vertex);
    op->ptr = ffd_malloc_array(rows + 1, sizeof *op->ptr);
    op->col = ffd_malloc_array(nnz ? nnz : 1, sizeof *op->col);
    op->coef = ffd_malloc_array(nnz ? nnz : 1, sizeof *op->coef);
    op->wcoef = ffd_malloc_array(nnz ? nnz : 1, sizeof *op->wcoef);
    op->delta = ffd_malloc_array(rows ? 3 * rows : 1, sizeof *op->delta);
    if (!op->row_vertex || !op->ptr || !op->col || !op->coef || !op->wcoef || !op->delta) {
        operator_free(op);
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory (Laplacian)");
    }
    size_t r = 0, e = 0;
    op->ptr[0] = 0;
    for (size_t i = 0; i < n; i++) {
        size_t lo = adj->ptr[i], hi = adj->ptr[i + 1];
        if (lo == hi || (skip && skip[i]))
            continue;
        double sum = 0.0;
        for (size_t k = lo; k < hi; k++)
            sum += adj->val[k];
        int uniform = !(sum >= 1e-12) || !isfinite(sum);
        double d[3] = {ref[3 * i], ref[3 * i + 1], ref[3 * i + 2]};
        op->row_vertex[r] = (uint32_t)i;
        op->col[e] = (uint32_t)i;
        op->coef[e] = 1.0;
        e++;
        for (size_t k = lo; k < hi; k++) {
            double mij = uniform ? 1.0 / (double)(hi - lo) : adj->val[k] / sum;
            if (mij == 0.0)
                continue;
            uint32_t j = adj->col[k];
            op->col[e] = j;
            op->coef[e] = -mij;
            e++;
            for (int c = 0; c < 3; c++)
                d[c] -= mij * ref[3 * j + c];
        }
        memcpy(op->delta + 3 * r, d, sizeof d);
        r++;
        op->ptr[r] = e;
    }
    for (size_t k = 0; k < e; k++)
        op->wcoef[k] = weight * op->coef[k];
    return FFD_OK;
}

static ffd_status build_proxy_laplacian(const tsv_arap_graph *g, const uint8_t *roles,
                                        double weight, arap_operator *op, ffd_error *err)
{
    memset(op, 0, sizeof *op);
    op->weight = weight;
    if (!g->proxy_face_count || weight == 0.0) {
        op->ptr = ffd_calloc(1, sizeof *op->ptr);
        return op->ptr ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory");
    }
    size_t kmax = 0;
    for (size_t f = 0; f < g->proxy_face_count; f++) {
        size_t k = g->proxy_offsets[f + 1] - g->proxy_offsets[f];
        kmax = k > kmax ? k : kmax;
    }
    /* The rows are those of the manifold proxy's points (eq. 5 on the mesh
     * M): a lattice point where the proxy has several sheets (inside cells
     * that touch only along an edge or at a vertex, tsv_proxy.c) gets one
     * row per sheet, each over its own fan, all rotated by that point's R_i;
     * summing the fans into one row would mix the sheets' differential
     * coordinates (at a corner contact they cancel). Columns are mapped back
     * to lattice points below. Without points, each lattice point is one. */
    const size_t np = g->proxy_points ? g->proxy_point_count : g->n;
    const uint32_t *corner_id = g->proxy_points ? g->proxy_points : g->proxy_indices;
    const uint32_t *ctl = g->proxy_point_controls;
    cot_pairs cp = {0};
    uint32_t *live = ffd_malloc_array(kmax ? kmax : 1, sizeof *live);
    uint32_t *tri = ffd_malloc_array(kmax ? 3 * kmax : 1, sizeof *tri);
    double *pref = g->proxy_points ? ffd_malloc_array(np ? np : 1, 3 * sizeof *pref) : NULL;
    const double *ref = g->proxy_points ? pref : g->ref;
    ffd_status st = FFD_OK;
    if (!live || !tri || (g->proxy_points && !pref)) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory (proxy triangulation)");
        goto done;
    }
    if (g->proxy_points)
        for (size_t p = 0; p < np; p++)
            memcpy(pref + 3 * p, g->ref + 3 * (size_t)ctl[p], 3 * sizeof *pref);
    for (size_t f = 0; f < g->proxy_face_count; f++) {
        size_t off = g->proxy_offsets[f], k = g->proxy_offsets[f + 1] - off;
        const uint32_t *id = corner_id + off;
        const double *uv = g->proxy_uv + 2 * off;
        if (k < 3)
            continue;
        int ok = 1;
        if (k == 4 && quad_both_splits(uv)) {
            /* plain quad: the average of its two diagonal splits (symmetric) */
            ok = cot_triangle(&cp, ref, id[0], id[1], id[2], 0.5) &&
                 cot_triangle(&cp, ref, id[0], id[2], id[3], 0.5) &&
                 cot_triangle(&cp, ref, id[1], id[2], id[3], 0.5) &&
                 cot_triangle(&cp, ref, id[1], id[3], id[0], 0.5);
        } else {
            size_t nt = ear_clip(uv, k, live, tri);
            for (size_t t = 0; t < nt && ok; t++)
                ok = cot_triangle(&cp, ref, id[tri[3 * t]], id[tri[3 * t + 1]],
                                  id[tri[3 * t + 2]], 1.0);
        }
        if (!ok) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory (cotangent weights)");
            goto done;
        }
    }
    arap_csr adj;
    st = csr_from_pairs(np, cp.pairs, cp.count, cp.w, &adj, err);
    if (st != FFD_OK)
        goto done;
    /* summed over all incident triangles; negative weights clamped to 0 */
    for (size_t k = 0; k < adj.ptr[np]; k++)
        if (!(adj.val[k] > 0.0))
            adj.val[k] = 0.0;
    /* S_M: rows of M \ C only */
    uint8_t *skip = ffd_malloc_array(np ? np : 1, 1);
    if (!skip) {
        csr_free(&adj);
        st = ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory");
        goto done;
    }
    for (size_t i = 0; i < np; i++)
        skip[i] = roles[ctl && g->proxy_points ? ctl[i] : i] != TSV_FREE;
    st = operator_from_weights(&adj, np, skip, ref, weight, op, err);
    ffd_free(skip);
    csr_free(&adj);
    /* points back to lattice points: a row's vertex and its columns (the
     * assembly sums repeated columns, which a fan through both copies of a
     * split edge can give) */
    if (st == FFD_OK && g->proxy_points) {
        for (size_t r = 0; r < op->rows; r++)
            op->row_vertex[r] = ctl[op->row_vertex[r]];
        for (size_t e = 0; e < op->ptr[op->rows]; e++)
            op->col[e] = ctl[op->col[e]];
    }
done:
    ffd_free(pref);
    ffd_free(cp.pairs);
    ffd_free(cp.w);
    ffd_free(live);
    ffd_free(tri);
    return st;
}

/* Volumetric Laplacian (eq. 6): v_ij = (1/|p_i-p_j|) / sum_k (1/|p_i-p_k|). */
static ffd_status build_volumetric_laplacian(const tsv_arap_graph *g, double weight,
                                             arap_operator *op, ffd_error *err)
{
    memset(op, 0, sizeof *op);
    op->weight = weight;
    if (weight == 0.0) {
        op->ptr = ffd_calloc(1, sizeof *op->ptr);
        return op->ptr ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory");
    }
    arap_csr adj;
    ffd_status st = csr_from_pairs(g->n, g->vol, g->vol_count, NULL, &adj, err);
    if (st != FFD_OK)
        return st;
    size_t nnz = adj.ptr[g->n];
    adj.val = ffd_malloc_array(nnz ? nnz : 1, sizeof *adj.val);
    if (!adj.val) {
        csr_free(&adj);
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory (volumetric Laplacian)");
    }
    for (size_t i = 0; i < g->n; i++)
        for (size_t k = adj.ptr[i]; k < adj.ptr[i + 1]; k++) {
            const double *a = g->ref + 3 * i, *b = g->ref + 3 * (size_t)adj.col[k];
            double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
            double len = sqrt(dx * dx + dy * dy + dz * dz);
            adj.val[k] = len > 0.0 ? 1.0 / len : 0.0; /* coincident: uniform fallback below */
        }
    for (size_t i = 0; i < g->n; i++) {
        int bad = 0;
        for (size_t k = adj.ptr[i]; k < adj.ptr[i + 1]; k++)
            bad |= !(adj.val[k] > 0.0) || !isfinite(adj.val[k]);
        if (bad)
            for (size_t k = adj.ptr[i]; k < adj.ptr[i + 1]; k++)
                adj.val[k] = 1.0;
    }
    st = operator_from_weights(&adj, g->n, NULL, g->ref, weight, op, err);
    csr_free(&adj);
    return st;
}

/* ---------------------------------------------------------------------
 * Normal equations (eq. 8): A = w_1F D'D + w_M L_M' S_M L_M + w_V L_V' L_V + w_C S_C
 * --------------------------------------------------------------------- */

typedef struct transposed {
    size_t *ptr; /* n + 1 */
    uint32_t *row;
    double *val;
} transposed;

static ffd_status operator_transpose(const arap_operator *op, size_t n, transposed *t,
                                     ffd_error *err)
{
    size_t nnz = op->ptr[op->rows];
    t->ptr = ffd_calloc(n + 1, sizeof *t->ptr);
    t->row = ffd_malloc_array(nnz ? nnz : 1, sizeof *t->row);
    t->val = ffd_malloc_array(nnz ? nnz : 1, sizeof *t->val);
    size_t *fill = ffd_malloc_array(n + 1, sizeof *fill);
    if (!t->ptr || !t->row || !t->val || !fill) {
        ffd_free(fill);
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory (assembly)");
    }
    for (size_t k = 0; k < nnz; k++)
        t->ptr[op->col[k] + 1]++;
    for (size_t i = 0; i < n; i++)
        t->ptr[i + 1] += t->ptr[i];
    memcpy(fill, t->ptr, (n + 1) * sizeof *fill);
    for (size_t r = 0; r < op->rows; r++)
        for (size_t k = op->ptr[r]; k < op->ptr[r + 1]; k++) {
            size_t p = fill[op->col[k]]++;
            t->row[p] = (uint32_t)r;
            t->val[p] = op->coef[k];
        }
    ffd_free(fill);
    return FFD_OK;
}

static void transposed_free(transposed *t)
{
    ffd_free(t->ptr);
    ffd_free(t->row);
    ffd_free(t->val);
}

static void sort_u32(uint32_t *a, size_t n)
{
    for (size_t i = 1; i < n; i++) {
        uint32_t x = a[i];
        size_t j = i;
        while (j > 0 && a[j - 1] > x) {
            a[j] = a[j - 1];
            j--;
        }
        a[j] = x;
    }
}

/* Builds the upper triangle of A (CSC, rows sorted) with the hard rows and
 * columns replaced by the identity (explicit zeros kept) and the couplings
 * A_{F,C} moved to a->couple_*; returns it as a CHOLMOD matrix. */
static ffd_status assemble_matrix(tsv_arap *a, const arap_csr *one_form, cholmod_sparse **out,
                                  ffd_error *err)
{
    size_t n = a->n;
    ffd_status st = FFD_OK;
    transposed tm = {0}, tv = {0};
    double *acc = ffd_malloc_array(n, sizeof *acc);
    size_t *mark = ffd_malloc_array(n, sizeof *mark);
    uint32_t *list = ffd_malloc_array(n, sizeof *list);
    size_t *colptr = ffd_malloc_array(n + 1, sizeof *colptr);
    uint32_t *rows = NULL;
    double *vals = NULL;
    size_t cap_r = 0, cap_v = 0, nnz = 0;
    size_t cap_cr = 0, cap_cv = 0, ncpl = 0;
    a->couple_ptr = ffd_malloc_array(a->hard_count + 1, sizeof *a->couple_ptr);
    if (!acc || !mark || !list || !colptr || !a->couple_ptr) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory (assembly)");
        goto done;
    }
    if ((st = operator_transpose(&a->proxy_laplacian, n, &tm, err)) != FFD_OK ||
        (st = operator_transpose(&a->volumetric_laplacian, n, &tv, err)) != FFD_OK)
        goto done;
    for (size_t i = 0; i < n; i++)
        mark[i] = SIZE_MAX;
    size_t hc = 0;
    colptr[0] = 0;
    a->couple_ptr[0] = 0;
    const arap_operator *ops[2] = {&a->proxy_laplacian, &a->volumetric_laplacian};
    const transposed *tr[2] = {&tm, &tv};
    for (size_t j = 0; j < n; j++) {
        size_t len = 0;
#define ARAP_ADD(c_, v_)                                                                   \
    do {                                                                                   \
        uint32_t c__ = (c_);                                                               \
        if (mark[c__] != j) {                                                              \
            mark[c__] = j;                                                                 \
            acc[c__] = 0.0;                                                                \
            list[len++] = c__;                                                             \
        }                                                                                  \
        acc[c__] += (v_);                                                                  \
    } while (0)
        ARAP_ADD((uint32_t)j, 0.0);
        /* one-form (eq. 7): every undirected edge twice, as (i,j) and (j,i) */
        for (size_t k = one_form->ptr[j]; k < one_form->ptr[j + 1]; k++) {
            double mult = one_form->val[k];
            ARAP_ADD((uint32_t)j, 2.0 * a->w_one_form * mult);
            ARAP_ADD(one_form->col[k], -2.0 * a->w_one_form * mult);
        }
        /* proxy (eq. 5) and volumetric (eq. 6) Laplacians: column j of w L'L */
        for (int o = 0; o < 2; o++) {
            const arap_operator *op = ops[o];
            for (size_t t = tr[o]->ptr[j]; t < tr[o]->ptr[j + 1]; t++) {
                size_t r = tr[o]->row[t];
                double s = op->weight * tr[o]->val[t];
                for (size_t k = op->ptr[r]; k < op->ptr[r + 1]; k++)
                    ARAP_ADD(op->col[k], s * op->coef[k]);
            }
        }
        /* target term (eq. 4), soft rows */
        if (a->roles[j] == TSV_SOFT)
            ARAP_ADD((uint32_t)j, a->w_target);
#undef ARAP_ADD
        int hard_j = a->roles[j] == TSV_HARD;
        if (hard_j) {
            for (size_t q = 0; q < len; q++) {
                uint32_t c = list[q];
                if (c == j || a->roles[c] == TSV_HARD || acc[c] == 0.0)
                    continue;
                if (!ffd_grow((void **)&a->couple_row, &cap_cr, ncpl + 1, sizeof *a->couple_row) ||
                    !ffd_grow((void **)&a->couple_val, &cap_cv, ncpl + 1, sizeof *a->couple_val)) {
                    st = ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory (assembly)");
                    goto done;
                }
                a->couple_row[ncpl] = c;
                a->couple_val[ncpl] = acc[c];
                ncpl++;
            }
            a->couple_ptr[++hc] = ncpl;
        }
        /* upper triangle of column j */
        size_t keep = 0;
        for (size_t q = 0; q < len; q++)
            if (list[q] <= j)
                list[keep++] = list[q];
        sort_u32(list, keep);
        if (!ffd_grow((void **)&rows, &cap_r, nnz + keep, sizeof *rows) ||
            !ffd_grow((void **)&vals, &cap_v, nnz + keep, sizeof *vals)) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory (assembly)");
            goto done;
        }
        for (size_t q = 0; q < keep; q++) {
            uint32_t c = list[q];
            double v = acc[c];
            if (hard_j || a->roles[c] == TSV_HARD)
                v = c == j ? 1.0 : 0.0; /* identity, explicit zeros */
            rows[nnz] = c;
            vals[nnz] = v;
            nnz++;
        }
        colptr[j + 1] = nnz;
    }
    if (nnz > (size_t)INT_MAX || n > (size_t)INT_MAX) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: matrix too large (%zu entries)", nnz);
        goto done;
    }
    cholmod_sparse *A = cholmod_allocate_sparse(n, n, nnz, 1, 1, 1, CHOLMOD_REAL, &a->cc);
    if (!A) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory (CHOLMOD matrix)");
        goto done;
    }
    int *Ap = A->p, *Ai = A->i;
    double *Ax = A->x;
    for (size_t j = 0; j <= n; j++)
        Ap[j] = (int)colptr[j];
    for (size_t k = 0; k < nnz; k++) {
        Ai[k] = (int)rows[k];
        Ax[k] = vals[k];
    }
    *out = A;
done:
    transposed_free(&tm);
    transposed_free(&tv);
    ffd_free(acc);
    ffd_free(mark);
    ffd_free(list);
    ffd_free(colptr);
    ffd_free(rows);
    ffd_free(vals);
    return st;
}

/* ---------------------------------------------------------------------
 * Rotations: one-sided Jacobi SVD of S_i, R_i = V U' with the reflection fix
 * --------------------------------------------------------------------- */

static void fit_rotation(const double S[9], double R[9])
{
    /* S column-major (S[a + 3b] = S_ab). Columns of S V -> sigma_k u_k. */
    double a[3][3], v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int c = 0; c < 3; c++)
        for (int r = 0; r < 3; r++)
            a[c][r] = S[r + 3 * c];
    static const int P[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    /* cyclic sweeps; quadratic convergence: once every pair of a sweep was
     * within 1e-8 of orthogonal, the rotations just applied left them at
     * rounding level and no further sweep is needed */
    for (int sweep = 0; sweep < 16; sweep++) {
        int rotated = 0, large = 0;
        for (int k = 0; k < 3; k++) {
            int p = P[k][0], q = P[k][1];
            double al = 0, be = 0, ga = 0;
            for (int r = 0; r < 3; r++) {
                al += a[p][r] * a[p][r];
                be += a[q][r] * a[q][r];
                ga += a[p][r] * a[q][r];
            }
            if (!(ga * ga > 16.0 * DBL_EPSILON * DBL_EPSILON * al * be))
                continue;
            rotated = 1;
            large |= ga * ga > 1e-16 * al * be;
            double zeta = (be - al) / (2.0 * ga);
            double t = copysign(1.0, zeta) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
            double cs = 1.0 / sqrt(1.0 + t * t), sn = cs * t;
            for (int r = 0; r < 3; r++) {
                double x = a[p][r], y = a[q][r];
                a[p][r] = cs * x - sn * y;
                a[q][r] = sn * x + cs * y;
                x = v[p][r];
                y = v[q][r];
                v[p][r] = cs * x - sn * y;
                v[q][r] = sn * x + cs * y;
            }
        }
        if (!rotated || !large)
            break;
    }
    double sg[3];
    for (int k = 0; k < 3; k++)
        sg[k] = sqrt(a[k][0] * a[k][0] + a[k][1] * a[k][1] + a[k][2] * a[k][2]);
    int k1 = 0;
    for (int k = 1; k < 3; k++)
        if (sg[k] > sg[k1])
            k1 = k;
    int k2 = k1 == 0 ? 1 : 0;
    for (int k = 0; k < 3; k++)
        if (k != k1 && sg[k] > sg[k2])
            k2 = k;
    if (!(sg[k1] > 0.0) || !isfinite(sg[k1])) {
        memset(R, 0, 9 * sizeof *R);
        R[0] = R[4] = R[8] = 1.0;
        return;
    }
    double u1[3], u2[3], u3[3], v3[3];
    for (int r = 0; r < 3; r++)
        u1[r] = a[k1][r] / sg[k1];
    double d = 0.0;
    if (sg[k2] > 1e-12 * sg[k1]) {
        for (int r = 0; r < 3; r++)
            u2[r] = a[k2][r];
        for (int r = 0; r < 3; r++)
            d += u2[r] * u1[r];
        for (int r = 0; r < 3; r++)
            u2[r] -= d * u1[r];
    } else {
        /* rank 1: any unit vector orthogonal to u1 */
        int m = 0;
        for (int r = 1; r < 3; r++)
            if (fabs(u1[r]) < fabs(u1[m]))
                m = r;
        double e[3] = {0, 0, 0};
        e[m] = 1.0;
        u2[0] = u1[1] * e[2] - u1[2] * e[1];
        u2[1] = u1[2] * e[0] - u1[0] * e[2];
        u2[2] = u1[0] * e[1] - u1[1] * e[0];
    }
    double nu2 = sqrt(u2[0] * u2[0] + u2[1] * u2[1] + u2[2] * u2[2]);
    for (int r = 0; r < 3; r++)
        u2[r] /= nu2;
    /* third columns as cross products: det U = det V = +1, i.e. the column of
     * the smallest singular value is negated whenever V U' would reflect */
    u3[0] = u1[1] * u2[2] - u1[2] * u2[1];
    u3[1] = u1[2] * u2[0] - u1[0] * u2[2];
    u3[2] = u1[0] * u2[1] - u1[1] * u2[0];
    const double *v1 = v[k1], *v2 = v[k2];
    v3[0] = v1[1] * v2[2] - v1[2] * v2[1];
    v3[1] = v1[2] * v2[0] - v1[0] * v2[2];
    v3[2] = v1[0] * v2[1] - v1[1] * v2[0];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            R[3 * r + c] = v1[r] * u1[c] + v2[r] * u2[c] + v3[r] * u3[c];
}

/* S_i = sum_j (p_j - p_i)(x_j - x_i)' over N_L(i) u N_V(i), uniform weights. */
static void fit_rotations(tsv_arap *a, const double *x)
{
    size_t n = a->n;
    /* serial on purpose: with OpenMP here a 2-core machine ran the drag step
     * 4x slower (its threads and OpenBLAS's contend) */
    for (size_t i = 0; i < n; i++) {
        double S[9] = {0};
        const double *xi = x + 3 * i;
        for (size_t k = a->rot.ptr[i]; k < a->rot.ptr[i + 1]; k++) {
            const double *dp = a->rot_dp + 3 * k, *xj = x + 3 * (size_t)a->rot.col[k];
            const double dx[3] = {xj[0] - xi[0], xj[1] - xi[1], xj[2] - xi[2]};
            for (int c = 0; c < 3; c++)
                for (int r = 0; r < 3; r++)
                    S[r + 3 * c] += dp[r] * dx[c];
        }
        fit_rotation(S, a->R + 9 * i);
    }
}

/* ---------------------------------------------------------------------
 * Right-hand side with the current rotations
 * --------------------------------------------------------------------- */

static inline void rot_apply(const double *R, const double *v, double *out)
{
    out[0] = R[0] * v[0] + R[1] * v[1] + R[2] * v[2];
    out[1] = R[3] * v[0] + R[4] * v[1] + R[5] * v[2];
    out[2] = R[6] * v[0] + R[7] * v[1] + R[8] * v[2];
}

static void assemble_rhs(tsv_arap *a, const double *q)
{
    double *b = a->rhs;
    memset(b, 0, 3 * a->n * sizeof *b);
    /* one-form (eq. 7): (i,j) adds w R_i e to b_j and -w R_i e to b_i; (j,i) likewise */
    for (size_t e = 0; e < a->edge_count; e++) {
        uint32_t i = a->edges[2 * e], j = a->edges[2 * e + 1];
        const double *Ri = a->R + 9 * (size_t)i, *Rj = a->R + 9 * (size_t)j;
        const double *ev = a->edge_vec + 3 * e;
        double w = a->w_one_form, t[3];
        for (int r = 0; r < 3; r++)
            t[r] = w * ((Ri[3 * r] + Rj[3 * r]) * ev[0] + (Ri[3 * r + 1] + Rj[3 * r + 1]) * ev[1] +
                        (Ri[3 * r + 2] + Rj[3 * r + 2]) * ev[2]);
        for (int r = 0; r < 3; r++) {
            b[3 * (size_t)j + r] += t[r];
            b[3 * (size_t)i + r] -= t[r];
        }
    }
    /* proxy (eq. 5) and volumetric (eq. 6) Laplacians: b += w L' (R_i (L p)_i) */
    const arap_operator *ops[2] = {&a->proxy_laplacian, &a->volumetric_laplacian};
    for (int o = 0; o < 2; o++) {
        const arap_operator *op = ops[o];
        for (size_t r = 0; r < op->rows; r++) {
            double t[3];
            rot_apply(a->R + 9 * (size_t)op->row_vertex[r], op->delta + 3 * r, t);
            for (size_t k = op->ptr[r]; k < op->ptr[r + 1]; k++) {
                double c = op->wcoef[k];
                double *bj = b + 3 * (size_t)op->col[k];
                bj[0] += c * t[0];
                bj[1] += c * t[1];
                bj[2] += c * t[2];
            }
        }
    }
    /* target term (eq. 4) */
    for (size_t s = 0; s < a->soft_count; s++) {
        size_t i = a->soft[s];
        for (int r = 0; r < 3; r++)
            b[3 * i + r] += a->w_target * q[3 * i + r];
    }
    /* hard rows: b_F -= A_FC q_C, b_C = q_C */
    for (size_t h = 0; h < a->hard_count; h++) {
        size_t c = a->hard[h];
        for (size_t k = a->couple_ptr[h]; k < a->couple_ptr[h + 1]; k++) {
            size_t f = a->couple_row[k];
            double v = a->couple_val[k];
            for (int r = 0; r < 3; r++)
                b[3 * f + r] -= v * q[3 * c + r];
        }
    }
    for (size_t h = 0; h < a->hard_count; h++) {
        size_t c = a->hard[h];
        for (int r = 0; r < 3; r++)
            b[3 * c + r] = q[3 * c + r];
    }
}

/* ---------------------------------------------------------------------
 * Create / destroy / solve
 * --------------------------------------------------------------------- */

void ffd_tsv_arap_solver_destroy(tsv_arap *a)
{
    if (!a)
        return;
    if (a->started) {
        cholmod_free_factor(&a->L, &a->cc);
        cholmod_free_dense(&a->B, &a->cc);
        cholmod_free_dense(&a->X, &a->cc);
        cholmod_free_dense(&a->Y, &a->cc);
        cholmod_free_dense(&a->E, &a->cc);
        cholmod_finish(&a->cc);
    }
    ffd_free(a->ref);
    ffd_free(a->roles);
    ffd_free(a->edges);
    ffd_free(a->edge_vec);
    operator_free(&a->proxy_laplacian);
    operator_free(&a->volumetric_laplacian);
    csr_free(&a->rot);
    ffd_free(a->rot_dp);
    ffd_free(a->R);
    ffd_free(a->soft);
    ffd_free(a->hard);
    ffd_free(a->couple_ptr);
    ffd_free(a->couple_row);
    ffd_free(a->couple_val);
    ffd_free(a->rhs);
    ffd_free(a->sv);
    ffd_free(a);
}

static ffd_status check_pairs(const uint32_t *pairs, size_t m, size_t n, const char *what,
                              ffd_error *err)
{
    if (m && !pairs)
        return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: %s is NULL", what);
    for (size_t k = 0; k < 2 * m; k++)
        if (pairs[k] >= n)
            return ffd_fail(err, FFD_ERR_RANGE, "tsv_arap: %s %zu: vertex %u out of range (%zu)",
                            what, k / 2, (unsigned)pairs[k], n);
    return FFD_OK;
}

static ffd_status check_graph(const tsv_arap_graph *g, const uint8_t *roles,
                              const tsv_arap_weights *w, ffd_error *err)
{
    ffd_status st;
    if (g->n && (!g->ref || !roles))
        return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: NULL reference positions or roles");
    if (g->n > (size_t)INT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: too many lattice points (%zu)", g->n);
    for (size_t i = 0; i < 3 * g->n; i++)
        if (!isfinite(g->ref[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "tsv_arap: reference point %zu is not finite",
                            i / 3);
    if ((st = check_pairs(g->edges, g->edge_count, g->n, "lattice edge", err)) != FFD_OK ||
        (st = check_pairs(g->vol, g->vol_count, g->n, "volumetric pair", err)) != FFD_OK)
        return st;
    if (g->proxy_face_count) {
        if (!g->proxy_offsets || !g->proxy_indices || !g->proxy_uv)
            return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: NULL proxy arrays");
        if (g->proxy_offsets[0] != 0)
            return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: proxy offsets must start at 0");
        for (size_t f = 0; f < g->proxy_face_count; f++)
            if (g->proxy_offsets[f + 1] < g->proxy_offsets[f])
                return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: proxy offsets decrease at face %zu",
                                f);
        size_t corners = g->proxy_offsets[g->proxy_face_count];
        for (size_t k = 0; k < corners; k++) {
            if (g->proxy_indices[k] >= g->n)
                return ffd_fail(err, FFD_ERR_RANGE, "tsv_arap: proxy corner %zu: vertex %u out of "
                                "range (%zu)", k, (unsigned)g->proxy_indices[k], g->n);
            if (!isfinite(g->proxy_uv[2 * k]) || !isfinite(g->proxy_uv[2 * k + 1]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "tsv_arap: proxy corner %zu: uv not finite",
                                k);
        }
        if (g->proxy_points) {
            if (!g->proxy_point_controls)
                return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: NULL proxy point controls");
            for (size_t p = 0; p < g->proxy_point_count; p++)
                if (g->proxy_point_controls[p] >= g->n)
                    return ffd_fail(err, FFD_ERR_RANGE, "tsv_arap: proxy point %zu: vertex %u out "
                                    "of range (%zu)", p, (unsigned)g->proxy_point_controls[p], g->n);
            for (size_t k = 0; k < corners; k++)
                if (g->proxy_points[k] >= g->proxy_point_count ||
                    g->proxy_point_controls[g->proxy_points[k]] != g->proxy_indices[k])
                    return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: proxy corner %zu: point %u "
                                    "is not on vertex %u", k, (unsigned)g->proxy_points[k],
                                    (unsigned)g->proxy_indices[k]);
        }
    }
    const double ws[4] = {w->one_form, w->proxy, w->volume, w->target};
    for (int k = 0; k < 4; k++)
        if (!isfinite(ws[k]) || ws[k] < 0.0)
            return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: weights must be finite and >= 0");
    size_t constrained = 0, soft = 0;
    for (size_t i = 0; i < g->n; i++) {
        if (roles[i] > TSV_SOFT)
            return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: point %zu: unknown role %u", i,
                            (unsigned)roles[i]);
        constrained += roles[i] != TSV_FREE;
        soft += roles[i] == TSV_SOFT;
    }
    if (!constrained)
        return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: nothing constrained: the ARAP system is "
                        "singular");
    if (soft && !(w->target > 0.0))
        return ffd_fail(err, FFD_ERR_INVALID, "tsv_arap: soft constraints need a target weight > 0");
    return FFD_OK;
}

static ffd_status factorize(tsv_arap *a, const arap_csr *one_form, ffd_error *err)
{
    route_cholmod_allocation();
    cholmod_start(&a->cc);
    a->started = 1;
    a->cc.print = 0;
    a->cc.error_handler = NULL;
    a->cc.supernodal = CHOLMOD_AUTO;
    cholmod_sparse *A = NULL;
    ffd_status st = assemble_matrix(a, one_form, &A, err);
    if (st != FFD_OK)
        return st;
    a->L = cholmod_analyze(A, &a->cc);
    if (a->L)
        cholmod_factorize(A, a->L, &a->cc);
    cholmod_free_sparse(&A, &a->cc);
    if (a->cc.status == CHOLMOD_OUT_OF_MEMORY || !a->L)
        return ffd_fail(err, a->cc.status == CHOLMOD_OUT_OF_MEMORY ? FFD_ERR_NOMEM : FFD_ERR_NUMERIC,
                        "tsv_arap: CHOLMOD analysis failed (status %d)", a->cc.status);
    if (a->cc.status == CHOLMOD_NOT_POSDEF || a->L->minor < a->L->n)
        return ffd_fail(err, FFD_ERR_NUMERIC, "tsv_arap: the ARAP matrix is not positive definite "
                        "(column %zu): a part of the lattice has no constrained point or zero "
                        "weights", (size_t)a->L->minor);
    if (a->cc.status < CHOLMOD_OK)
        return ffd_fail(err, FFD_ERR_NUMERIC, "tsv_arap: CHOLMOD factorisation failed (status %d)",
                        a->cc.status);
    /* supernodal factorisation (BLAS-3), then the factor as simplicial LL':
     * its solves with three columns are as fast and never enter the BLAS,
     * whose thread hand-offs dominated the supernodal solves of this size */
    if (a->L->is_super &&
        !cholmod_change_factor(CHOLMOD_REAL, 1, 0, 1, 1, a->L, &a->cc))
        return ffd_fail(err, a->cc.status == CHOLMOD_OUT_OF_MEMORY ? FFD_ERR_NOMEM : FFD_ERR_NUMERIC,
                        "tsv_arap: CHOLMOD factor conversion failed (status %d)", a->cc.status);
    /* right-hand side and solve workspace, allocated once */
    a->B = cholmod_zeros(a->n, 3, CHOLMOD_REAL, &a->cc);
    if (!a->B || !cholmod_solve2(CHOLMOD_A, a->L, a->B, NULL, &a->X, NULL, &a->Y, &a->E, &a->cc))
        return ffd_fail(err, a->cc.status == CHOLMOD_OUT_OF_MEMORY ? FFD_ERR_NOMEM : FFD_ERR_NUMERIC,
                        "tsv_arap: CHOLMOD solve set-up failed (status %d)", a->cc.status);
    return FFD_OK;
}

ffd_status ffd_tsv_arap_solver_create(const tsv_arap_graph *g, const uint8_t *roles,
                           const tsv_arap_weights *w, tsv_arap **out, ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_tsv_arap_solver_create: out is NULL");
    *out = NULL;
    if (!g || !w)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_tsv_arap_solver_create: NULL graph or weights");
    ffd_status st = check_graph(g, roles, w, err);
    if (st != FFD_OK)
        return st;
    size_t n = g->n;
    tsv_arap *a = ffd_calloc(1, sizeof *a);
    if (!a)
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory");
    a->n = n;
    a->w_one_form = w->one_form;
    a->w_target = w->target;
    arap_csr one_form = {0};
    uint32_t *all_pairs = NULL;
    a->ref = ffd_malloc_array(3 * n, sizeof *a->ref);
    a->roles = ffd_malloc_array(n, 1);
    a->R = ffd_malloc_array(9 * n, sizeof *a->R);
    a->rhs = ffd_malloc_array(3 * n, sizeof *a->rhs);
    a->sv = ffd_malloc_array(3 * n, sizeof *a->sv);
    if (!a->ref || !a->roles || !a->R || !a->rhs || !a->sv)
        goto nomem;
    memcpy(a->ref, g->ref, 3 * n * sizeof *a->ref);
    memcpy(a->roles, roles, n);
    for (size_t i = 0; i < n; i++) {
        double *R = a->R + 9 * i;
        memset(R, 0, 9 * sizeof *R);
        R[0] = R[4] = R[8] = 1.0;
        if (roles[i] == TSV_HARD)
            a->hard_count++;
        else if (roles[i] == TSV_SOFT)
            a->soft_count++;
    }
    a->free_count = n - a->hard_count;
    a->hard = ffd_malloc_array(a->hard_count ? a->hard_count : 1, sizeof *a->hard);
    a->soft = ffd_malloc_array(a->soft_count ? a->soft_count : 1, sizeof *a->soft);
    if (!a->hard || !a->soft)
        goto nomem;
    for (size_t i = 0, h = 0, s = 0; i < n; i++) {
        if (roles[i] == TSV_HARD)
            a->hard[h++] = (uint32_t)i;
        else if (roles[i] == TSV_SOFT)
            a->soft[s++] = (uint32_t)i;
    }
    if (a->free_count == 0) { /* everything fixed: the solve returns the targets */
        *out = a;
        return FFD_OK;
    }
    /* one-form (eq. 7): edges without self loops, reference edge vectors */
    a->edges = ffd_malloc_array(g->edge_count ? 2 * g->edge_count : 1, sizeof *a->edges);
    a->edge_vec = ffd_malloc_array(g->edge_count ? 3 * g->edge_count : 1, sizeof *a->edge_vec);
    if (!a->edges || !a->edge_vec)
        goto nomem;
    if (w->one_form != 0.0)
        for (size_t e = 0; e < g->edge_count; e++) {
            uint32_t i = g->edges[2 * e], j = g->edges[2 * e + 1];
            if (i == j)
                continue;
            a->edges[2 * a->edge_count] = i;
            a->edges[2 * a->edge_count + 1] = j;
            for (int c = 0; c < 3; c++)
                a->edge_vec[3 * a->edge_count + c] = g->ref[3 * (size_t)j + c] -
                                                     g->ref[3 * (size_t)i + c];
            a->edge_count++;
        }
    /* the one-form's edge multiplicities, for D'D */
    double *ones = ffd_malloc_array(a->edge_count ? a->edge_count : 1, sizeof *ones);
    if (!ones)
        goto nomem;
    for (size_t e = 0; e < a->edge_count; e++)
        ones[e] = 1.0;
    st = csr_from_pairs(n, a->edges, a->edge_count, ones, &one_form, err);
    ffd_free(ones);
    if (st != FFD_OK)
        goto fail;
    /* rotation neighbourhoods N_L(i) u N_V(i) */
    size_t m = g->edge_count + g->vol_count;
    all_pairs = ffd_malloc_array(m ? 2 * m : 1, sizeof *all_pairs);
    if (!all_pairs)
        goto nomem;
    if (g->edge_count)
        memcpy(all_pairs, g->edges, 2 * g->edge_count * sizeof *all_pairs);
    if (g->vol_count)
        memcpy(all_pairs + 2 * g->edge_count, g->vol, 2 * g->vol_count * sizeof *all_pairs);
    if ((st = csr_from_pairs(n, all_pairs, m, NULL, &a->rot, err)) != FFD_OK)
        goto fail;
    ffd_free(all_pairs);
    all_pairs = NULL;
    a->rot_dp = ffd_malloc_array(a->rot.ptr[n] ? 3 * a->rot.ptr[n] : 1, sizeof *a->rot_dp);
    if (!a->rot_dp)
        goto nomem;
    for (size_t i = 0; i < n; i++)
        for (size_t k = a->rot.ptr[i]; k < a->rot.ptr[i + 1]; k++)
            for (int c = 0; c < 3; c++)
                a->rot_dp[3 * k + c] = g->ref[3 * (size_t)a->rot.col[k] + c] - g->ref[3 * i + c];
    if ((st = build_proxy_laplacian(g, roles, w->proxy, &a->proxy_laplacian, err)) != FFD_OK ||
        (st = build_volumetric_laplacian(g, w->volume, &a->volumetric_laplacian, err)) != FFD_OK ||
        (st = factorize(a, &one_form, err)) != FFD_OK)
        goto fail;
    csr_free(&one_form);
    *out = a;
    return FFD_OK;
nomem:
    st = ffd_fail(err, FFD_ERR_NOMEM, "tsv_arap: out of memory");
fail:
    ffd_free(all_pairs);
    csr_free(&one_form);
    ffd_tsv_arap_solver_destroy(a);
    return st;
}

ffd_status ffd_tsv_arap_solver_solve(tsv_arap *a, const double *targets, double *x, uint32_t iterations,
                          ffd_error *err)
{
    if (!a || !x || (!targets && (a->hard_count || a->soft_count)))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_tsv_arap_solver_solve: NULL argument");
    for (size_t i = 0; i < a->n; i++)
        if (a->roles[i] != TSV_FREE)
            for (int c = 0; c < 3; c++)
                if (!isfinite(targets[3 * i + c]))
                    return ffd_fail(err, FFD_ERR_NONFINITE, "ffd_tsv_arap_solver_solve: target of point %zu "
                                    "is not finite", i);
    size_t n = a->n;
    if (a->free_count == 0) {
        memcpy(x, targets, 3 * n * sizeof *x);
        return FFD_OK;
    }
    for (uint32_t it = 0; it < iterations; it++) {
        assemble_rhs(a, targets);
        double *Bx = a->B->x;
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++)
                Bx[i + n * (size_t)c] = a->rhs[3 * i + c];
        if (!cholmod_solve2(CHOLMOD_A, a->L, a->B, NULL, &a->X, NULL, &a->Y, &a->E, &a->cc))
            return ffd_fail(err, a->cc.status == CHOLMOD_OUT_OF_MEMORY ? FFD_ERR_NOMEM
                                                                       : FFD_ERR_NUMERIC,
                            "ffd_tsv_arap_solver_solve: CHOLMOD solve failed (status %d)", a->cc.status);
        const double *Xx = a->X->x;
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++)
                a->sv[3 * i + c] = Xx[i + n * (size_t)c];
        for (size_t h = 0; h < a->hard_count; h++) {
            size_t i = a->hard[h];
            for (int c = 0; c < 3; c++)
                a->sv[3 * i + c] = targets[3 * i + c]; /* exactly */
        }
        for (size_t i = 0; i < 3 * n; i++)
            if (!isfinite(a->sv[i]))
                return ffd_fail(err, FFD_ERR_NUMERIC, "ffd_tsv_arap_solver_solve: the solution is not finite");
        fit_rotations(a, a->sv);
    }
    if (iterations)
        memcpy(x, a->sv, 3 * n * sizeof *x);
    return FFD_OK;
}

/* ---------------------------------------------------------------------
 * The global step at fixed rotations, linearised in the targets
 * --------------------------------------------------------------------- */

/* One global step solves M x = b(R) + B q (design §6): M is the factored
 * matrix (identity on the hard rows and columns), b(R) the rotated terms
 * (eq. 5-7), B q the targets' part: w_target q_i on a soft row (eq. 4),
 * -A_fc q_c on a free row f coupled to a hard point c, q_c on a hard row.
 * At fixed rotations x is affine in q and dx = M^-1 B dq exactly; M is
 * symmetric, so the transpose is B^T M^-1. One solve with the cached factor
 * either way. */
ffd_status ffd_tsv_arap_solver_linear(tsv_arap *a, const double *in, double *out, int transpose,
                                      ffd_error *err)
{
    size_t n = a->n;
    if (a->free_count == 0) { /* x = q: B = I, M = I */
        memcpy(out, in, 3 * n * sizeof *out);
        return FFD_OK;
    }
    double *Bx = a->B->x;
    if (!transpose) {
        double *b = a->rhs;
        memset(b, 0, 3 * n * sizeof *b);
        for (size_t s = 0; s < a->soft_count; s++)
            for (int r = 0; r < 3; r++)
                b[3 * (size_t)a->soft[s] + r] = a->w_target * in[3 * (size_t)a->soft[s] + r];
        for (size_t h = 0; h < a->hard_count; h++) {
            size_t c = a->hard[h];
            for (size_t k = a->couple_ptr[h]; k < a->couple_ptr[h + 1]; k++)
                for (int r = 0; r < 3; r++)
                    b[3 * (size_t)a->couple_row[k] + r] -= a->couple_val[k] * in[3 * c + r];
            for (int r = 0; r < 3; r++)
                b[3 * c + r] = in[3 * c + r];
        }
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++)
                Bx[i + n * (size_t)c] = b[3 * i + c];
    } else {
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++)
                Bx[i + n * (size_t)c] = in[3 * i + c];
    }
    if (!cholmod_solve2(CHOLMOD_A, a->L, a->B, NULL, &a->X, NULL, &a->Y, &a->E, &a->cc))
        return ffd_fail(err, a->cc.status == CHOLMOD_OUT_OF_MEMORY ? FFD_ERR_NOMEM : FFD_ERR_NUMERIC,
                        "tsv_arap: CHOLMOD solve failed (status %d)", a->cc.status);
    const double *Xx = a->X->x;
    if (!transpose) {
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++)
                out[3 * i + c] = Xx[i + n * (size_t)c];
        for (size_t h = 0; h < a->hard_count; h++) /* exactly, as the solve sets them */
            for (int r = 0; r < 3; r++)
                out[3 * (size_t)a->hard[h] + r] = in[3 * (size_t)a->hard[h] + r];
        return FFD_OK;
    }
    /* B^T y: soft rows w_target y_i, hard rows y_c - sum_f A_fc y_f, free rows 0 */
    memset(out, 0, 3 * n * sizeof *out);
    for (size_t s = 0; s < a->soft_count; s++)
        for (int r = 0; r < 3; r++)
            out[3 * (size_t)a->soft[s] + r] = a->w_target * Xx[a->soft[s] + n * (size_t)r];
    for (size_t h = 0; h < a->hard_count; h++) {
        size_t c = a->hard[h];
        for (int r = 0; r < 3; r++) {
            double acc = in[3 * c + r]; /* y_c = g_c: M is the identity there */
            for (size_t k = a->couple_ptr[h]; k < a->couple_ptr[h + 1]; k++)
                acc -= a->couple_val[k] * Xx[a->couple_row[k] + n * (size_t)r];
            out[3 * c + r] = acc;
        }
    }
    return FFD_OK;
}

/* The global step alone at the current rotations (no refit): what
 * ffd_tsv_arap_solver_linear differentiates; for tests. */
ffd_status ffd_tsv_arap_solver_global_step(tsv_arap *a, const double *targets, double *x,
                                           ffd_error *err)
{
    size_t n = a->n;
    if (a->free_count == 0) {
        memcpy(x, targets, 3 * n * sizeof *x);
        return FFD_OK;
    }
    assemble_rhs(a, targets);
    double *Bx = a->B->x;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            Bx[i + n * (size_t)c] = a->rhs[3 * i + c];
    if (!cholmod_solve2(CHOLMOD_A, a->L, a->B, NULL, &a->X, NULL, &a->Y, &a->E, &a->cc))
        return ffd_fail(err, a->cc.status == CHOLMOD_OUT_OF_MEMORY ? FFD_ERR_NOMEM : FFD_ERR_NUMERIC,
                        "tsv_arap: CHOLMOD solve failed (status %d)", a->cc.status);
    const double *Xx = a->X->x;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            x[3 * i + c] = Xx[i + n * (size_t)c];
    for (size_t h = 0; h < a->hard_count; h++)
        for (int c = 0; c < 3; c++)
            x[3 * (size_t)a->hard[h] + c] = targets[3 * (size_t)a->hard[h] + c];
    return FFD_OK;
}
