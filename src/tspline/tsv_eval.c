/* tsv — evaluation of the tailored cubic T-spline volume (Zhang, Zheng &
 * Cai 2020, eq. 1; design §2): F(s,t,u) = sum_v W_v P_v B_v(s,t,u) with
 * B_v = N[s_v](s) N[t_v](t) N[u_v](u). The univariate basis is Cox-de Boor on
 * the kappa values of the five sigma knots; a uniform grid of G^3 bins over
 * [0,1]^3 lists the vertices whose support meets each bin; the transfer
 * matrix Phi caches W_v B_v at the object's fixed parameters.
 *
 * Bound points are evaluated in displacement form, x' = x + Phi (P - P_rest):
 * the rest channel has linear precision (sum_v W_v B_v P_rest,v = the box map
 * of (s,t,u) = x, design §1.4-1.5, carried exactly through refinement), so
 * this is eq. 1 in exact arithmetic; in floating point the identity is exact
 * and points whose support holds no moved control point keep their bits. */
#include "tspline/tsv.h"

#include <math.h>
#include <stdbool.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

struct tsv_support {
    size_t nv;
    double (*kv)[3][5]; /* kappa values of the local knot vectors */
    uint32_t (*kid)[3]; /* per axis, the id of kv[v][axis] among the distinct knot vectors:
                           vertices with bitwise equal knot vectors share the basis values */
    double *W;
    uint32_t G;
    size_t *binptr;     /* G^3 + 1 */
    uint32_t *binv;
    size_t max;         /* most candidates in a bin */
    /* Per bin and axis, the distinct knot vectors of its candidates (a
     * representative vertex each, binaxv[binaxptr[3 b + d] ..]) and per
     * candidate their local numbers binloc[binptr[b] + i][d]: a point
     * evaluates each distinct univariate basis once (about 4 per axis in a
     * regular region) and a candidate's blending function is a product of
     * three of them. bintensor[b] = 0 when an axis has more than
     * TSV_BIN_AXIS_MAX (each candidate is then evaluated on its own). */
    uint32_t *binaxptr; /* 3 G^3 + 1 */
    uint32_t *binaxv;
    uint8_t (*binloc)[3];
    uint8_t *bintensor;
};

#define TSV_BIN_AXIS_MAX 64

/* Cox-de Boor on knot values t[0..4] (zero denominators give 0). */
static double basis_kappa(const double t[5], double x, double *dx)
{
    double N[4];
    if (x < t[0] || x > t[4]) {
        if (dx)
            *dx = 0.0;
        return 0.0;
    }
    /* degree 0: right-open indicators, closed at x = 1 (design §2) */
    for (int i = 0; i < 4; i++)
        N[i] = ((t[i] <= x && x < t[i + 1]) || (x == 1.0 && t[i + 1] == 1.0 && t[i] < 1.0)) ? 1.0
                                                                                           : 0.0;
    for (int p = 1; p <= 2; p++)
        for (int i = 0; i + p < 4; i++) {
            double dl = t[i + p] - t[i], dr = t[i + p + 1] - t[i + 1];
            double l = dl > 0.0 ? (x - t[i]) / dl * N[i] : 0.0;
            double r = dr > 0.0 ? (t[i + p + 1] - x) / dr * N[i + 1] : 0.0;
            N[i] = l + r;
        }
    double dl = t[3] - t[0], dr = t[4] - t[1];
    if (dx)
        *dx = 3.0 * ((dl > 0.0 ? N[0] / dl : 0.0) - (dr > 0.0 ? N[1] / dr : 0.0));
    return (dl > 0.0 ? (x - t[0]) / dl * N[0] : 0.0) + (dr > 0.0 ? (t[4] - x) / dr * N[1] : 0.0);
}

double ffd_tsv_basis(const double knots[5], double x, double *dx)
{
    double t[5];
    for (int i = 0; i < 5; i++)
        t[i] = tsv_kappa(knots[i]);
    return basis_kappa(t, x, dx);
}

/* Numbers the distinct knot vectors of each axis (bitwise equality, so that
 * a shared value is exactly the one basis_kappa gives each vertex): an open
 * hash of the 40 bytes per vertex and axis. false on OOM. */
static bool number_knot_vectors(tsv_support *S)
{
    size_t cap = 16;
    while (cap < 2 * S->nv)
        cap *= 2;
    uint32_t *slot = ffd_malloc_array(cap, sizeof *slot);
    if (!slot)
        return false;
    for (int d = 0; d < 3; d++) {
        uint32_t next = 0;
        for (size_t i = 0; i < cap; i++)
            slot[i] = UINT32_MAX;
        for (size_t v = 0; v < S->nv; v++) {
            uint64_t h = 1469598103934665603ull, bits;
            for (int i = 0; i < 5; i++) {
                memcpy(&bits, &S->kv[v][d][i], sizeof bits);
                h = (h ^ bits) * 1099511628211ull;
                h ^= h >> 29;
            }
            size_t j = (size_t)h & (cap - 1);
            while (slot[j] != UINT32_MAX &&
                   memcmp(S->kv[slot[j]][d], S->kv[v][d], sizeof S->kv[v][d]) != 0)
                j = (j + 1) & (cap - 1);
            if (slot[j] == UINT32_MAX) {
                slot[j] = (uint32_t)v;
                S->kid[v][d] = next++;
            } else {
                S->kid[v][d] = S->kid[slot[j]][d];
            }
        }
    }
    ffd_free(slot);
    return true;
}

static uint32_t bin1(uint32_t G, double x)
{
    if (!(x > 0.0))
        return 0;
    uint32_t b = (uint32_t)(x * G);
    return b >= G ? G - 1 : b;
}

/* The per-bin tables of distinct knot vectors (struct tsv_support). false on OOM. */
static bool bin_tables(tsv_support *S, size_t nb)
{
    size_t total = S->binptr[nb];
    uint32_t nk[3] = {0, 0, 0};
    for (size_t v = 0; v < S->nv; v++)
        for (int d = 0; d < 3; d++)
            if (S->kid[v][d] + 1 > nk[d])
                nk[d] = S->kid[v][d] + 1;
    S->binaxptr = ffd_malloc_array(3 * nb + 1, sizeof *S->binaxptr);
    S->binaxv = ffd_malloc_array(total ? 3 * total : 1, sizeof *S->binaxv);
    S->binloc = ffd_malloc_array(total ? total : 1, sizeof *S->binloc);
    S->bintensor = ffd_malloc_array(nb, 1);
    /* stamp[d][kid]: the last bin (+1) that numbered kid, local[d][kid] its number there */
    uint32_t *stamp = ffd_calloc((size_t)nk[0] + nk[1] + nk[2] + 1, sizeof *stamp);
    uint8_t *local = ffd_malloc_array((size_t)nk[0] + nk[1] + nk[2] + 1, 1);
    bool ok = S->binaxptr && S->binaxv && S->binloc && S->bintensor && stamp && local;
    if (ok) {
        size_t m = 0;
        S->binaxptr[0] = 0;
        for (size_t b = 0; b < nb; b++) {
            bool tensor = true;
            for (int d = 0; d < 3; d++) {
                uint32_t *st = stamp + (d == 0 ? 0 : d == 1 ? nk[0] : nk[0] + nk[1]);
                uint8_t *lc = local + (d == 0 ? 0 : d == 1 ? nk[0] : nk[0] + nk[1]);
                uint32_t count = 0;
                for (size_t i = S->binptr[b]; i < S->binptr[b + 1]; i++) {
                    uint32_t v = S->binv[i], k = S->kid[v][d];
                    if (st[k] != (uint32_t)b + 1) {
                        st[k] = (uint32_t)b + 1;
                        if (count < TSV_BIN_AXIS_MAX) {
                            lc[k] = (uint8_t)count;
                            S->binaxv[m + count] = v;
                        }
                        count++;
                    }
                    S->binloc[i][d] = lc[k];
                }
                if (count > TSV_BIN_AXIS_MAX) {
                    tensor = false;
                    count = TSV_BIN_AXIS_MAX;
                }
                m += count;
                S->binaxptr[3 * b + d + 1] = (uint32_t)m;
            }
            S->bintensor[b] = tensor;
        }
    }
    ffd_free(stamp);
    ffd_free(local);
    return ok;
}

ffd_status ffd_tsv_support_build(const tsv_lattice *L, tsv_support **out, ffd_error *err)
{
    *out = NULL;
    tsv_support *S = ffd_calloc(1, sizeof *S);
    if (!S)
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv support: out of memory");
    S->nv = L->nv;
    double g = ceil(2.0 * cbrt((double)(L->nv ? L->nv : 1)));
    S->G = g < 1.0 ? 1u : (g > 64.0 ? 64u : (uint32_t)g);
    uint32_t G = S->G;
    size_t nb = (size_t)G * G * G;
    S->kv = ffd_malloc_array(L->nv ? L->nv : 1, sizeof *S->kv);
    S->kid = ffd_malloc_array(L->nv ? L->nv : 1, sizeof *S->kid);
    S->W = ffd_malloc_array(L->nv ? L->nv : 1, sizeof *S->W);
    S->binptr = ffd_calloc(nb + 1, sizeof *S->binptr);
    if (!S->kv || !S->kid || !S->W || !S->binptr)
        goto nomem;
    for (size_t v = 0; v < L->nv; v++) {
        double k[3][5];
        ffd_tsv_infer_knots(L, (uint32_t)v, k);
        for (int d = 0; d < 3; d++)
            for (int i = 0; i < 5; i++)
                S->kv[v][d][i] = tsv_kappa(k[d][i]);
        S->W[v] = L->verts[v].W;
    }
    if (!number_knot_vectors(S))
        goto nomem;
    /* two passes: counts, then the CSR lists (ascending vertex ids) */
    for (int pass = 0; pass < 2; pass++) {
        for (size_t v = 0; v < L->nv; v++) {
            uint32_t lo[3], hi[3], b[3];
            for (int d = 0; d < 3; d++) {
                lo[d] = bin1(G, S->kv[v][d][0]);
                hi[d] = bin1(G, S->kv[v][d][4]);
            }
            for (b[0] = lo[0]; b[0] <= hi[0]; b[0]++)
                for (b[1] = lo[1]; b[1] <= hi[1]; b[1]++)
                    for (b[2] = lo[2]; b[2] <= hi[2]; b[2]++) {
                        size_t id = ((size_t)b[0] * G + b[1]) * G + b[2];
                        if (pass == 0)
                            S->binptr[id + 1]++;
                        else
                            S->binv[S->binptr[id]++] = (uint32_t)v;
                    }
        }
        if (pass == 0) {
            for (size_t i = 0; i < nb; i++) {
                if (S->binptr[i + 1] > S->max)
                    S->max = S->binptr[i + 1];
                S->binptr[i + 1] += S->binptr[i];
            }
            S->binv = ffd_malloc_array(S->binptr[nb] ? S->binptr[nb] : 1, sizeof *S->binv);
            if (!S->binv)
                goto nomem;
        } else {
            /* the fill advanced each start to the next bin's start: shift back */
            for (size_t i = nb; i > 0; i--)
                S->binptr[i] = S->binptr[i - 1];
            S->binptr[0] = 0;
        }
    }
    if (!bin_tables(S, nb))
        goto nomem;
    *out = S;
    return FFD_OK;
nomem:
    ffd_tsv_support_destroy(S);
    return ffd_fail(err, FFD_ERR_NOMEM, "tsv support: out of memory");
}

void ffd_tsv_support_destroy(tsv_support *S)
{
    if (!S)
        return;
    ffd_free(S->kv);
    ffd_free(S->kid);
    ffd_free(S->W);
    ffd_free(S->binptr);
    ffd_free(S->binv);
    ffd_free(S->binaxptr);
    ffd_free(S->binaxv);
    ffd_free(S->binloc);
    ffd_free(S->bintensor);
    ffd_free(S);
}

size_t ffd_tsv_support_max(const tsv_support *S)
{
    return S->max;
}

/* W_v B_v at x (and its gradient) for one candidate on its own; false when
 * outside the closed support. */
static bool blend(const tsv_support *S, uint32_t v, const double x[3], double *w, double g[3])
{
    double(*k)[5] = S->kv[v];
    double N[3], dN[3];
    for (int d = 0; d < 3; d++)
        if (x[d] < k[d][0] || x[d] > k[d][4])
            return false;
    for (int d = 0; d < 3; d++)
        N[d] = basis_kappa(k[d], x[d], g ? &dN[d] : NULL);
    double W = S->W[v];
    *w = W * N[0] * N[1] * N[2];
    if (g) {
        g[0] = W * dN[0] * N[1] * N[2];
        g[1] = W * N[0] * dN[1] * N[2];
        g[2] = W * N[0] * N[1] * dN[2];
    }
    return true;
}

/* The candidates of the bin holding x and the distinct univariate bases of
 * the bin at x (struct tsv_support's tables), each evaluated once: every
 * blending function and derivative of the point from one Cox-de Boor
 * evaluation per distinct knot vector (eq. 1's B_v = N N N). */
typedef struct point_basis {
    const uint32_t *c;          /* candidates */
    size_t nc;
    uint8_t (*loc)[3];          /* their local numbers, NULL: evaluate each on its own */
    uint8_t in[3][TSV_BIN_AXIS_MAX];   /* x in the closed support of the local basis */
    double N[3][TSV_BIN_AXIS_MAX], dN[3][TSV_BIN_AXIS_MAX];
} point_basis;

static void point_basis_at(const tsv_support *S, const double x[3], bool grad, point_basis *pb)
{
    uint32_t G = S->G;
    size_t id = ((size_t)bin1(G, x[0]) * G + bin1(G, x[1])) * G + bin1(G, x[2]);
    pb->c = S->binv + S->binptr[id];
    pb->nc = S->binptr[id + 1] - S->binptr[id];
    pb->loc = NULL;
    if (!S->bintensor[id])
        return;
    pb->loc = S->binloc + S->binptr[id];
    for (int d = 0; d < 3; d++)
        for (uint32_t j = S->binaxptr[3 * id + d], a = 0; j < S->binaxptr[3 * id + d + 1];
             j++, a++) {
            const double *k = S->kv[S->binaxv[j]][d];
            pb->in[d][a] = !(x[d] < k[0] || x[d] > k[4]);
            if (pb->in[d][a])
                pb->N[d][a] = basis_kappa(k, x[d], grad ? &pb->dN[d][a] : NULL);
        }
}

/* blend() for candidate i of pb, from the shared univariate values: the same
 * products in the same order, so the same bits. */
static bool point_blend(const tsv_support *S, const point_basis *pb, size_t i, const double x[3],
                        double *w, double g[3])
{
    if (!pb->loc)
        return blend(S, pb->c[i], x, w, g);
    const uint8_t *l = pb->loc[i];
    if (!pb->in[0][l[0]] || !pb->in[1][l[1]] || !pb->in[2][l[2]])
        return false;
    double N0 = pb->N[0][l[0]], N1 = pb->N[1][l[1]], N2 = pb->N[2][l[2]];
    double W = S->W[pb->c[i]];
    *w = W * N0 * N1 * N2;
    if (g) {
        g[0] = W * pb->dN[0][l[0]] * N1 * N2;
        g[1] = W * N0 * pb->dN[1][l[1]] * N2;
        g[2] = W * N0 * N1 * pb->dN[2][l[2]];
    }
    return true;
}

size_t ffd_tsv_support_eval(const tsv_support *S, const double stu[3], uint32_t *ids, double *w,
                        double *grad)
{
    size_t m = 0;
    point_basis pb;
    point_basis_at(S, stu, grad != NULL, &pb);
    const uint32_t *c = pb.c;
    for (size_t i = 0; i < pb.nc; i++) {
        double val, g[3];
        if (!point_blend(S, &pb, i, stu, &val, grad ? g : NULL))
            continue;
        if (val == 0.0 && (!grad || (g[0] == 0.0 && g[1] == 0.0 && g[2] == 0.0)))
            continue;
        ids[m] = c[i];
        w[m] = val;
        if (grad)
            memcpy(grad + 3 * m, g, sizeof g);
        m++;
    }
    return m;
}

/* Sum over the blending functions at stu (clamped) of W_v B_v c_v and its
 * gradient, where c_v is channel P[channel] of vertex v, or (displacement)
 * the current position minus the rest one. */
static void eval_sum(const tsv_lattice *L, const tsv_support *S, int channel, bool displacement,
                     const double stu[3], double out[3], double *jac)
{
    double x[3];
    for (int d = 0; d < 3; d++)
        x[d] = stu[d] < 0.0 ? 0.0 : (stu[d] > 1.0 ? 1.0 : stu[d]);
    out[0] = out[1] = out[2] = 0.0;
    if (jac)
        memset(jac, 0, 9 * sizeof *jac);
    point_basis pb;
    point_basis_at(S, x, jac != NULL, &pb);
    const uint32_t *c = pb.c;
    for (size_t i = 0; i < pb.nc; i++) {
        double val, g[3];
        if (!point_blend(S, &pb, i, x, &val, jac ? g : NULL))
            continue;
        const tsv_vertex *V = &L->verts[c[i]];
        double P[3];
        for (int r = 0; r < 3; r++)
            P[r] = displacement ? V->P[TSV_CURRENT][r] - V->P[TSV_REST][r] : V->P[channel][r];
        for (int r = 0; r < 3; r++) {
            out[r] += val * P[r];
            if (jac)
                for (int k = 0; k < 3; k++)
                    jac[r * 3 + k] += g[k] * P[r];
        }
    }
}

void ffd_tsv_eval_point(const tsv_lattice *L, const tsv_support *S, int channel, const double stu[3],
                    double out[3], double *jac)
{
    eval_sum(L, S, channel, false, stu, out, jac);
}

void ffd_tsv_eval_displacement(const tsv_lattice *L, const tsv_support *S, const double stu[3],
                           double out[3], double *jac)
{
    eval_sum(L, S, TSV_CURRENT, true, stu, out, jac);
}

/* ===================================================================
 * Transfer matrix Phi (design §2)
 * =================================================================== */

static void clamp01(const double *in, double x[3])
{
    for (int d = 0; d < 3; d++)
        x[d] = in[d] < 0.0 ? 0.0 : (in[d] > 1.0 ? 1.0 : in[d]);
}

ffd_status ffd_tsv_phi_build(const tsv_lattice *L, const tsv_support *S, const double *params,
                         size_t n, tsv_phi *phi, ffd_error *err)
{
    (void)L;
    memset(phi, 0, sizeof *phi);
    phi->rows = n;
    phi->cols = S->nv;
    phi->rowptr = ffd_calloc(n + 1, sizeof *phi->rowptr);
    if (!phi->rowptr)
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv phi: out of memory");
    /* pass 1: nonzeros per row (independent rows: any thread count) */
    long long nn = (long long)n;
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < nn; i++) {
        double x[3];
        clamp01(params + 3 * (size_t)i, x);
        size_t m = 0;
        point_basis pb;
        point_basis_at(S, x, false, &pb);
        for (size_t k = 0; k < pb.nc; k++) {
            double val;
            if (point_blend(S, &pb, k, x, &val, NULL) && val != 0.0)
                m++;
        }
        phi->rowptr[i + 1] = m;
    }
    for (size_t i = 0; i < n; i++)
        phi->rowptr[i + 1] += phi->rowptr[i];
    size_t nnz = phi->rowptr[n];
    phi->col = ffd_malloc_array(nnz ? nnz : 1, sizeof *phi->col);
    phi->val = ffd_malloc_array(nnz ? nnz : 1, sizeof *phi->val);
    if (!phi->col || !phi->val) {
        ffd_tsv_phi_free(phi);
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv phi: out of memory");
    }
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < nn; i++) {
        double x[3];
        clamp01(params + 3 * (size_t)i, x);
        size_t m = phi->rowptr[i];
        point_basis pb;
        point_basis_at(S, x, false, &pb);
        for (size_t k = 0; k < pb.nc; k++) {
            double val;
            if (point_blend(S, &pb, k, x, &val, NULL) && val != 0.0) {
                phi->col[m] = pb.c[k];
                phi->val[m] = val;
                m++;
            }
        }
    }
    return FFD_OK;
}

void ffd_tsv_phi_free(tsv_phi *phi)
{
    if (!phi)
        return;
    ffd_free(phi->rowptr);
    ffd_free(phi->col);
    ffd_free(phi->val);
    memset(phi, 0, sizeof *phi);
}

void ffd_tsv_phi_apply_displacement(const tsv_phi *phi, const tsv_lattice *L, const double *points,
                                double *out)
{
    long long nn = (long long)phi->rows;
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < nn; i++) {
        double acc[3] = {0.0, 0.0, 0.0};
        for (size_t k = phi->rowptr[i]; k < phi->rowptr[i + 1]; k++) {
            const tsv_vertex *V = &L->verts[phi->col[k]];
            for (int r = 0; r < 3; r++)
                acc[r] += phi->val[k] * (V->P[TSV_CURRENT][r] - V->P[TSV_REST][r]);
        }
        const double *x = points + 3 * i;
        double *o = out + 3 * i;
        /* a zero displacement leaves the point bitwise (-0.0 + 0.0 would be +0.0) */
        for (int r = 0; r < 3; r++)
            o[r] = acc[r] != 0.0 ? x[r] + acc[r] : x[r];
    }
}

void ffd_tsv_phi_apply(const tsv_phi *phi, const tsv_lattice *L, int channel, double *out)
{
    long long nn = (long long)phi->rows;
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < nn; i++) {
        double acc[3] = {0.0, 0.0, 0.0};
        for (size_t k = phi->rowptr[i]; k < phi->rowptr[i + 1]; k++) {
            const double *P = L->verts[phi->col[k]].P[channel];
            acc[0] += phi->val[k] * P[0];
            acc[1] += phi->val[k] * P[1];
            acc[2] += phi->val[k] * P[2];
        }
        out[3 * i] = acc[0];
        out[3 * i + 1] = acc[1];
        out[3 * i + 2] = acc[2];
    }
}
