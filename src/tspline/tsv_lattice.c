/* tsv — the refinable T-lattice of the tailored cubic T-spline volume
 * (Zhang, Zheng & Cai 2020, §3.1; design §1): axis registries, vertices,
 * edges, minimal faces and cells, their indexes, ray casting for the local
 * knot vectors (paper eq. 1, design §1.3) and the three topological splits
 * (design §3.1).
 *
 * Initial element ids (n_s, n_t, n_u vertex planes per axis):
 *   vertex (i,j,l):            (i*n_t + j)*n_u + l
 *   edges along s first, then t, then u:
 *     s-edge (i<n_s-1, j, l):  E0 + (i*n_t + j)*n_u + l,          E0 = 0
 *     t-edge (i, j<n_t-1, l):  E1 + (i*(n_t-1) + j)*n_u + l,      E1 = (n_s-1)n_t n_u
 *     u-edge (i, j, l<n_u-1):  E2 + (i*n_t + j)*(n_u-1) + l,      E2 = E1 + n_s(n_t-1)n_u
 *   faces with normal s first, then t, then u (plane index first):
 *     normal s (i, j<n_t-1, l<n_u-1): F0 + (i*(n_t-1) + j)*(n_u-1) + l
 *     normal t (i<n_s-1, j, l<n_u-1): F1 + (i*n_t + j)*(n_u-1) + l
 *     normal u (i<n_s-1, j<n_t-1, l): F2 + (i*(n_t-1) + j)*n_u + l
 *   cell (i,j,k):              (i*(n_t-1) + j)*(n_u-1) + k
 * A split keeps the element's id for its part below the split value and
 * appends the other parts, so ids stay dense.
 *
 * Indexes (struct tsv_lattice_index): a vertex hash (sigma triple -> id), an
 * edge-line hash ((axis, c0, c1) -> edge ids sorted by lo), a face-plane hash
 * ((normal, c) -> face ids), and a cell locator: a uniform grid of bins over
 * sigma (G bins over [0,1] plus one bin for each end layer) listing the
 * cells whose closed box overlaps the bin. Face hits of the ray casting use
 * the locator: a point of plane sigma_d = c lies on a minimal face normal to
 * d iff some cell containing it (closed) has lo_d == c or hi_d == c, because
 * the minimal faces tile every cell's boundary. */
#include "tspline/tsv.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ===================================================================
 * Small containers
 * =================================================================== */

typedef struct idlist {
    uint32_t *v;
    size_t n, cap;
} idlist;

static bool idlist_push(idlist *l, uint32_t id)
{
    if (!ffd_grow((void **)&l->v, &l->cap, l->n + 1, sizeof *l->v))
        return false;
    l->v[l->n++] = id;
    return true;
}

static bool idlist_insert(idlist *l, size_t at, uint32_t id)
{
    if (!ffd_grow((void **)&l->v, &l->cap, l->n + 1, sizeof *l->v))
        return false;
    memmove(l->v + at + 1, l->v + at, (l->n - at) * sizeof *l->v);
    l->v[at] = id;
    l->n++;
    return true;
}

/* Open-addressing hash: (tag, k0, k1, k2) -> value; keys are exact registry copies. */
typedef struct hent {
    double k[3];
    int32_t tag;
    uint32_t val; /* UINT32_MAX: empty slot */
} hent;

typedef struct htab {
    hent *e;
    size_t cap, n; /* cap a power of two */
} htab;

static uint64_t mix64(uint64_t x)
{
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ull;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebull;
    x ^= x >> 31;
    return x;
}

static uint64_t hkey(int32_t tag, const double k[3])
{
    uint64_t h = mix64((uint64_t)(uint32_t)tag + 0x9e3779b97f4a7c15ull);
    for (int i = 0; i < 3; i++) {
        uint64_t b;
        double d = k[i] + 0.0; /* -0.0 -> +0.0 */
        memcpy(&b, &d, sizeof b);
        h = mix64(h ^ (b + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2)));
    }
    return h;
}

static uint32_t htab_get(const htab *t, int32_t tag, const double k[3])
{
    if (!t->cap)
        return UINT32_MAX;
    size_t m = t->cap - 1, i = (size_t)hkey(tag, k) & m;
    for (;;) {
        const hent *e = &t->e[i];
        if (e->val == UINT32_MAX)
            return UINT32_MAX;
        if (e->tag == tag && e->k[0] == k[0] && e->k[1] == k[1] && e->k[2] == k[2])
            return e->val;
        i = (i + 1) & m;
    }
}

static void htab_put_raw(hent *tab, size_t cap, int32_t tag, const double k[3], uint32_t val)
{
    size_t m = cap - 1, i = (size_t)hkey(tag, k) & m;
    while (tab[i].val != UINT32_MAX)
        i = (i + 1) & m;
    tab[i].tag = tag;
    tab[i].k[0] = k[0];
    tab[i].k[1] = k[1];
    tab[i].k[2] = k[2];
    tab[i].val = val;
}

/* Inserts a key known to be absent. */
static bool htab_put(htab *t, int32_t tag, const double k[3], uint32_t val)
{
    if (2 * (t->n + 1) > t->cap) {
        size_t nc = t->cap ? 2 * t->cap : 64;
        while (2 * (t->n + 1) > nc)
            nc *= 2;
        hent *ne = ffd_malloc_array(nc, sizeof *ne);
        if (!ne)
            return false;
        for (size_t i = 0; i < nc; i++)
            ne[i].val = UINT32_MAX;
        for (size_t i = 0; i < t->cap; i++)
            if (t->e[i].val != UINT32_MAX)
                htab_put_raw(ne, nc, t->e[i].tag, t->e[i].k, t->e[i].val);
        ffd_free(t->e);
        t->e = ne;
        t->cap = nc;
    }
    htab_put_raw(t->e, t->cap, tag, k, val);
    t->n++;
    return true;
}

/* ===================================================================
 * The index
 * =================================================================== */

struct tsv_lattice_index {
    htab vhash;            /* (0, sg) -> vertex */
    htab lhash;            /* (axis, c0, c1, 0) -> line */
    idlist *lines;         /* edge ids of a line sorted by lo */
    size_t nlines, cap_lines;
    htab phash;            /* (normal, c, 0, 0) -> plane */
    idlist *planes;        /* face ids of a plane */
    size_t nplanes, cap_planes;
    uint32_t G[3];         /* inner bins per axis; G+2 bins in all */
    idlist *bins;          /* cell locator */
};

static void index_free(tsv_lattice_index *X)
{
    if (!X)
        return;
    ffd_free(X->vhash.e);
    ffd_free(X->lhash.e);
    ffd_free(X->phash.e);
    for (size_t i = 0; i < X->nlines; i++)
        ffd_free(X->lines[i].v);
    ffd_free(X->lines);
    for (size_t i = 0; i < X->nplanes; i++)
        ffd_free(X->planes[i].v);
    ffd_free(X->planes);
    if (X->bins) {
        size_t nb = (size_t)(X->G[0] + 2) * (X->G[1] + 2) * (X->G[2] + 2);
        for (size_t i = 0; i < nb; i++)
            ffd_free(X->bins[i].v);
        ffd_free(X->bins);
    }
    ffd_free(X);
}

static uint32_t bin_of(const tsv_lattice_index *X, int a, double s)
{
    uint32_t G = X->G[a];
    if (s < 0.0)
        return 0;
    if (s >= 1.0)
        return G + 1;
    uint32_t b = (uint32_t)(s * G);
    return 1 + (b >= G ? G - 1 : b);
}

static size_t bin_id(const tsv_lattice_index *X, const uint32_t b[3])
{
    return ((size_t)b[0] * (X->G[1] + 2) + b[1]) * (X->G[2] + 2) + b[2];
}

static void edge_line_key(const tsv_edge *e, double k[3])
{
    k[0] = e->c[0];
    k[1] = e->c[1];
    k[2] = 0.0;
}

/* Line key of the line through q along axis. */
static void line_key(int axis, const double q[3], double k[3])
{
    int a = (axis + 1) % 3, b = (axis + 2) % 3;
    if (a > b) {
        int t = a;
        a = b;
        b = t;
    }
    k[0] = q[a];
    k[1] = q[b];
    k[2] = 0.0;
}

static uint32_t line_find(const tsv_lattice_index *X, int axis, const double k[3])
{
    return htab_get(&X->lhash, axis, k);
}

static idlist *line_get_or_add(tsv_lattice_index *X, int axis, const double k[3])
{
    uint32_t li = htab_get(&X->lhash, axis, k);
    if (li != UINT32_MAX)
        return &X->lines[li];
    if (!ffd_grow((void **)&X->lines, &X->cap_lines, X->nlines + 1, sizeof *X->lines))
        return NULL;
    if (!htab_put(&X->lhash, axis, k, (uint32_t)X->nlines))
        return NULL;
    idlist *l = &X->lines[X->nlines++];
    memset(l, 0, sizeof *l);
    return l;
}

static idlist *plane_get(const tsv_lattice_index *X, int normal, double c)
{
    double k[3] = {c, 0.0, 0.0};
    uint32_t pi = htab_get(&X->phash, normal, k);
    return pi == UINT32_MAX ? NULL : &X->planes[pi];
}

static idlist *plane_get_or_add(tsv_lattice_index *X, int normal, double c)
{
    double k[3] = {c, 0.0, 0.0};
    uint32_t pi = htab_get(&X->phash, normal, k);
    if (pi != UINT32_MAX)
        return &X->planes[pi];
    if (!ffd_grow((void **)&X->planes, &X->cap_planes, X->nplanes + 1, sizeof *X->planes))
        return NULL;
    if (!htab_put(&X->phash, normal, k, (uint32_t)X->nplanes))
        return NULL;
    idlist *l = &X->planes[X->nplanes++];
    memset(l, 0, sizeof *l);
    return l;
}

/* Adds cell c to the bins its closed box overlaps (skipping bins in [skip_lo, skip_hi]). */
static bool bins_add_cell(tsv_lattice_index *X, const tsv_cell *C, uint32_t c, const uint32_t *skip_lo,
                          const uint32_t *skip_hi)
{
    uint32_t lo[3], hi[3], b[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = bin_of(X, a, C->lo[a]);
        hi[a] = bin_of(X, a, C->hi[a]);
    }
    for (b[0] = lo[0]; b[0] <= hi[0]; b[0]++)
        for (b[1] = lo[1]; b[1] <= hi[1]; b[1]++)
            for (b[2] = lo[2]; b[2] <= hi[2]; b[2]++) {
                if (skip_lo && b[0] >= skip_lo[0] && b[0] <= skip_hi[0] && b[1] >= skip_lo[1] &&
                    b[1] <= skip_hi[1] && b[2] >= skip_lo[2] && b[2] <= skip_hi[2])
                    continue;
                if (!idlist_push(&X->bins[bin_id(X, b)], c))
                    return false;
            }
    return true;
}

/* Removes cell c from the bins in its old bin range that its new box no longer overlaps. */
static void bins_shrink_cell(tsv_lattice_index *X, const uint32_t olo[3], const uint32_t ohi[3],
                             const tsv_cell *C, uint32_t c)
{
    uint32_t lo[3], hi[3], b[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = bin_of(X, a, C->lo[a]);
        hi[a] = bin_of(X, a, C->hi[a]);
    }
    for (b[0] = olo[0]; b[0] <= ohi[0]; b[0]++)
        for (b[1] = olo[1]; b[1] <= ohi[1]; b[1]++)
            for (b[2] = olo[2]; b[2] <= ohi[2]; b[2]++) {
                if (b[0] >= lo[0] && b[0] <= hi[0] && b[1] >= lo[1] && b[1] <= hi[1] &&
                    b[2] >= lo[2] && b[2] <= hi[2])
                    continue;
                idlist *l = &X->bins[bin_id(X, b)];
                for (size_t i = 0; i < l->n; i++)
                    if (l->v[i] == c) {
                        l->v[i] = l->v[--l->n];
                        break;
                    }
            }
}

/* Builds every index from the element arrays (create and clone). */
static ffd_status index_build(tsv_lattice *L)
{
    tsv_lattice_index *X = ffd_calloc(1, sizeof *X);
    if (!X)
        return FFD_ERR_NOMEM;
    for (int a = 0; a < 3; a++) {
        uint32_t g = L->res[a] > 3 ? 2 * (L->res[a] - 3) : 1;
        X->G[a] = g > 128 ? 128 : g;
    }
    size_t nb = (size_t)(X->G[0] + 2) * (X->G[1] + 2) * (X->G[2] + 2);
    X->bins = ffd_calloc(nb, sizeof *X->bins);
    if (!X->bins)
        goto fail;
    for (size_t v = 0; v < L->nv; v++)
        if (!htab_put(&X->vhash, 0, L->verts[v].sg, (uint32_t)v))
            goto fail;
    for (size_t e = 0; e < L->ne; e++) {
        double k[3];
        edge_line_key(&L->edges[e], k);
        idlist *l = line_get_or_add(X, L->edges[e].axis, k);
        if (!l)
            goto fail;
        /* insertion by lo (lines are short) */
        size_t at = l->n;
        while (at > 0 && L->edges[l->v[at - 1]].lo > L->edges[e].lo)
            at--;
        if (!idlist_insert(l, at, (uint32_t)e))
            goto fail;
    }
    for (size_t f = 0; f < L->nf; f++) {
        idlist *p = plane_get_or_add(X, L->faces[f].normal, L->faces[f].c);
        if (!p || !idlist_push(p, (uint32_t)f))
            goto fail;
    }
    for (size_t c = 0; c < L->nc; c++)
        if (!bins_add_cell(X, &L->cells[c], (uint32_t)c, NULL, NULL))
            goto fail;
    L->index = X;
    return FFD_OK;
fail:
    index_free(X);
    return FFD_ERR_NOMEM;
}

/* ===================================================================
 * Registries
 * =================================================================== */

static size_t reg_lower_bound(const tsv_registry *r, double x)
{
    size_t lo = 0, hi = r->n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (r->v[mid] < x)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

ffd_status ffd_tsv_registry_get(tsv_lattice *L, int axis, double v, double *sigma, ffd_error *err)
{
    tsv_registry *r = &L->reg[axis];
    if (!(v > 0.0 && v < 1.0))
        return ffd_fail(err, FFD_ERR_INVALID, "knot value %.17g outside (0,1)", v);
    size_t i = reg_lower_bound(r, v);
    /* nearest existing value within the snap distance */
    double best = 0.0;
    int found = 0;
    if (i < r->n && fabs(r->v[i] - v) <= TSV_REGISTRY_SNAP) {
        best = r->v[i];
        found = 1;
    }
    if (i > 0 && fabs(r->v[i - 1] - v) <= TSV_REGISTRY_SNAP &&
        (!found || fabs(r->v[i - 1] - v) < fabs(best - v))) {
        best = r->v[i - 1];
        found = 1;
    }
    if (found) {
        *sigma = best;
        return FFD_OK;
    }
    if (!ffd_grow((void **)&r->v, &r->cap, r->n + 1, sizeof *r->v))
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv registry: out of memory");
    memmove(r->v + i + 1, r->v + i, (r->n - i) * sizeof *r->v);
    r->v[i] = v + 0.0;
    r->n++;
    *sigma = r->v[i];
    return FFD_OK;
}

double ffd_tsv_registry_prev(const tsv_lattice *L, int axis, double sigma)
{
    const tsv_registry *r = &L->reg[axis];
    size_t i = reg_lower_bound(r, sigma);
    return i > 0 ? r->v[i - 1] : r->v[0] - 1.0;
}

double ffd_tsv_registry_next(const tsv_lattice *L, int axis, double sigma)
{
    const tsv_registry *r = &L->reg[axis];
    size_t i = reg_lower_bound(r, sigma);
    if (i < r->n && r->v[i] == sigma)
        i++;
    return i < r->n ? r->v[i] : r->v[r->n - 1] + 1.0;
}

double ffd_tsv_gamma(const tsv_lattice *L, int axis, double sigma)
{
    /* design §5.1: the global Greville coordinate */
    return (tsv_kappa(ffd_tsv_registry_prev(L, axis, sigma)) + tsv_kappa(sigma) +
            tsv_kappa(ffd_tsv_registry_next(L, axis, sigma))) /
           3.0;
}

/* ===================================================================
 * Creation, destruction, clone
 * =================================================================== */

static double plane_sigma(uint32_t i, uint32_t n)
{
    /* vertex planes -1, 0, k, 2k, ..., 1, 2 with k = 1/(n-3) */
    if (i == 0)
        return -1.0;
    if (i == n - 1)
        return 2.0;
    if (i == n - 2)
        return 1.0;
    return (double)(i - 1) / (double)(n - 3);
}

ffd_status ffd_tsv_lattice_create(const double box_min[3], const double box_max[3],
                              const uint32_t res[3], tsv_lattice **out, ffd_error *err)
{
    *out = NULL;
    for (int a = 0; a < 3; a++)
        if (res[a] < 4 || res[a] > 4096)
            return ffd_fail(err, FFD_ERR_INVALID, "tsv lattice: resolution %u on axis %d (4..4096)",
                            res[a], a);
    tsv_lattice *L = ffd_calloc(1, sizeof *L);
    if (!L)
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv lattice: out of memory");
    uint32_t ns = res[0], nt = res[1], nu = res[2];
    for (int a = 0; a < 3; a++) {
        L->res[a] = res[a];
        L->box_min[a] = box_min[a];
        L->box_max[a] = box_max[a];
        tsv_registry *r = &L->reg[a];
        r->n = res[a] + 4;
        r->cap = r->n;
        r->v = ffd_malloc_array(r->n, sizeof *r->v);
        if (!r->v)
            goto nomem;
        r->v[0] = -3.0;
        r->v[1] = -2.0;
        for (uint32_t i = 0; i < res[a]; i++)
            r->v[2 + i] = plane_sigma(i, res[a]);
        r->v[r->n - 2] = 3.0;
        r->v[r->n - 1] = 4.0;
    }
    size_t nv = (size_t)ns * nt * nu;
    size_t ne = (size_t)(ns - 1) * nt * nu + (size_t)ns * (nt - 1) * nu + (size_t)ns * nt * (nu - 1);
    size_t nf = (size_t)ns * (nt - 1) * (nu - 1) + (size_t)(ns - 1) * nt * (nu - 1) +
                (size_t)(ns - 1) * (nt - 1) * nu;
    size_t nc = (size_t)(ns - 1) * (nt - 1) * (nu - 1);
    if (nv >= UINT32_MAX || ne >= UINT32_MAX || nf >= INT32_MAX)
        goto toobig;
    L->verts = ffd_calloc(nv, sizeof *L->verts);
    L->edges = ffd_calloc(ne, sizeof *L->edges);
    L->faces = ffd_calloc(nf, sizeof *L->faces);
    L->cells = ffd_calloc(nc, sizeof *L->cells);
    if (!L->verts || !L->edges || !L->faces || !L->cells)
        goto nomem;
    L->nv = L->cap_v = nv;
    L->ne = L->cap_e = ne;
    L->nf = L->cap_f = nf;
    L->nc = L->cap_c = nc;
    const uint32_t n3[3] = {ns, nt, nu};
    double *sg[3], *gr[3];
    for (int a = 0; a < 3; a++) {
        sg[a] = L->reg[a].v + 2;
        gr[a] = NULL;
    }
    for (int a = 0; a < 3; a++) {
        gr[a] = ffd_malloc_array(n3[a], sizeof(double));
        if (!gr[a]) {
            for (int b = 0; b < a; b++)
                ffd_free(gr[b]);
            goto nomem;
        }
        for (uint32_t i = 0; i < n3[a]; i++) {
            /* design §1.4: Greville abscissa of plane i */
            double g = (tsv_kappa(sg[a][(int)i - 1]) + tsv_kappa(sg[a][i]) + tsv_kappa(sg[a][i + 1])) / 3.0;
            gr[a][i] = box_min[a] + g * (box_max[a] - box_min[a]);
        }
    }
    for (uint32_t i = 0; i < ns; i++)
        for (uint32_t j = 0; j < nt; j++)
            for (uint32_t l = 0; l < nu; l++) {
                tsv_vertex *v = &L->verts[((size_t)i * nt + j) * nu + l];
                v->sg[0] = sg[0][i];
                v->sg[1] = sg[1][j];
                v->sg[2] = sg[2][l];
                v->W = 1.0;
                for (int ch = 0; ch < TSV_NCH; ch++) {
                    v->P[ch][0] = gr[0][i];
                    v->P[ch][1] = gr[1][j];
                    v->P[ch][2] = gr[2][l];
                }
            }
    for (int a = 0; a < 3; a++)
        ffd_free(gr[a]);
    size_t e = 0;
    for (int ax = 0; ax < 3; ax++) {
        uint32_t lim[3] = {ns, nt, nu};
        lim[ax]--;
        uint32_t idx[3];
        for (idx[0] = 0; idx[0] < lim[0]; idx[0]++)
            for (idx[1] = 0; idx[1] < lim[1]; idx[1]++)
                for (idx[2] = 0; idx[2] < lim[2]; idx[2]++) {
                    tsv_edge *E = &L->edges[e++];
                    E->axis = ax;
                    int k = 0;
                    for (int b = 0; b < 3; b++)
                        if (b != ax)
                            E->c[k++] = sg[b][idx[b]];
                    E->lo = sg[ax][idx[ax]];
                    E->hi = sg[ax][idx[ax] + 1];
                    uint32_t j1[3] = {idx[0], idx[1], idx[2]};
                    j1[ax]++;
                    E->v0 = (uint32_t)(((size_t)idx[0] * nt + idx[1]) * nu + idx[2]);
                    E->v1 = (uint32_t)(((size_t)j1[0] * nt + j1[1]) * nu + j1[2]);
                }
    }
    size_t f = 0;
    for (int nn = 0; nn < 3; nn++) {
        uint32_t lim[3] = {ns - 1, nt - 1, nu - 1};
        lim[nn]++;
        uint32_t idx[3];
        for (idx[0] = 0; idx[0] < lim[0]; idx[0]++)
            for (idx[1] = 0; idx[1] < lim[1]; idx[1]++)
                for (idx[2] = 0; idx[2] < lim[2]; idx[2]++) {
                    tsv_face *F = &L->faces[f++];
                    F->normal = nn;
                    F->c = sg[nn][idx[nn]];
                    int k = 0;
                    for (int b = 0; b < 3; b++)
                        if (b != nn) {
                            F->lo[k] = sg[b][idx[b]];
                            F->hi[k] = sg[b][idx[b] + 1];
                            k++;
                        }
                    uint32_t cn[3] = {idx[0], idx[1], idx[2]};
                    F->cell_pos = idx[nn] == n3[nn] - 1
                                      ? -1
                                      : (int32_t)((cn[0] * (nt - 1) + cn[1]) * (nu - 1) + cn[2]);
                    if (idx[nn] == 0) {
                        F->cell_neg = -1;
                    } else {
                        cn[nn]--;
                        F->cell_neg = (int32_t)((cn[0] * (nt - 1) + cn[1]) * (nu - 1) + cn[2]);
                    }
                }
    }
    for (uint32_t i = 0; i + 1 < ns; i++)
        for (uint32_t j = 0; j + 1 < nt; j++)
            for (uint32_t l = 0; l + 1 < nu; l++) {
                tsv_cell *C = &L->cells[((size_t)i * (nt - 1) + j) * (nu - 1) + l];
                uint32_t idx[3] = {i, j, l};
                for (int a = 0; a < 3; a++) {
                    C->lo[a] = sg[a][idx[a]];
                    C->hi[a] = sg[a][idx[a] + 1];
                }
            }
    if (index_build(L) != FFD_OK)
        goto nomem;
    *out = L;
    return FFD_OK;
toobig:
    ffd_tsv_lattice_destroy(L);
    return ffd_fail(err, FFD_ERR_INVALID, "tsv lattice: too many control points");
nomem:
    ffd_tsv_lattice_destroy(L);
    return ffd_fail(err, FFD_ERR_NOMEM, "tsv lattice: out of memory");
}

static void lattice_free_contents(tsv_lattice *L)
{
    for (int a = 0; a < 3; a++)
        ffd_free(L->reg[a].v);
    ffd_free(L->verts);
    ffd_free(L->edges);
    ffd_free(L->faces);
    ffd_free(L->cells);
    index_free(L->index);
}

void ffd_tsv_lattice_destroy(tsv_lattice *L)
{
    if (!L)
        return;
    lattice_free_contents(L);
    ffd_free(L);
}

static void *dup_array(const void *p, size_t n, size_t elem)
{
    void *q = ffd_malloc_array(n ? n : 1, elem);
    if (q && n)
        memcpy(q, p, n * elem);
    return q;
}

tsv_lattice *ffd_tsv_lattice_clone(const tsv_lattice *L)
{
    tsv_lattice *C = ffd_calloc(1, sizeof *C);
    if (!C)
        return NULL;
    *C = *L;
    for (int a = 0; a < 3; a++)
        C->reg[a].v = NULL;
    C->verts = NULL;
    C->edges = NULL;
    C->faces = NULL;
    C->cells = NULL;
    C->index = NULL;
    for (int a = 0; a < 3; a++) {
        C->reg[a].v = dup_array(L->reg[a].v, L->reg[a].n, sizeof(double));
        C->reg[a].cap = L->reg[a].n;
        if (!C->reg[a].v)
            goto fail;
    }
    C->verts = dup_array(L->verts, L->nv, sizeof *L->verts);
    C->edges = dup_array(L->edges, L->ne, sizeof *L->edges);
    C->faces = dup_array(L->faces, L->nf, sizeof *L->faces);
    C->cells = dup_array(L->cells, L->nc, sizeof *L->cells);
    if (!C->verts || !C->edges || !C->faces || !C->cells)
        goto fail;
    C->cap_v = L->nv ? L->nv : 1;
    C->cap_e = L->ne ? L->ne : 1;
    C->cap_f = L->nf ? L->nf : 1;
    C->cap_c = L->nc ? L->nc : 1;
    if (index_build(C) != FFD_OK)
        goto fail;
    return C;
fail:
    ffd_tsv_lattice_destroy(C);
    return NULL;
}

void ffd_tsv_lattice_swap_in(tsv_lattice *dst, tsv_lattice *src)
{
    lattice_free_contents(dst);
    *dst = *src;
    ffd_free(src);
}

/* ===================================================================
 * Lookups
 * =================================================================== */

uint32_t ffd_tsv_vertex_find(const tsv_lattice *L, const double sg[3])
{
    return htab_get(&L->index->vhash, 0, sg);
}

/* Edge along axis through q containing q[axis] in its closed range (lowest such), or UINT32_MAX. */
static uint32_t edge_on_line(const tsv_lattice *L, int axis, const double q[3])
{
    double k[3];
    line_key(axis, q, k);
    uint32_t li = line_find(L->index, axis, k);
    if (li == UINT32_MAX)
        return UINT32_MAX;
    const idlist *l = &L->index->lines[li];
    double x = q[axis];
    /* first edge with hi >= x */
    size_t lo = 0, hi = l->n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (L->edges[l->v[mid]].hi < x)
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo < l->n && L->edges[l->v[lo]].lo <= x)
        return l->v[lo];
    return UINT32_MAX;
}

static bool cell_contains(const tsv_cell *C, const double q[3])
{
    return C->lo[0] <= q[0] && q[0] <= C->hi[0] && C->lo[1] <= q[1] && q[1] <= C->hi[1] &&
           C->lo[2] <= q[2] && q[2] <= C->hi[2];
}

static const idlist *bin_at(const tsv_lattice *L, const double q[3])
{
    const tsv_lattice_index *X = L->index;
    uint32_t b[3] = {bin_of(X, 0, q[0]), bin_of(X, 1, q[1]), bin_of(X, 2, q[2])};
    return &X->bins[bin_id(X, b)];
}

static void face_inplane(int normal, int *a, int *b)
{
    *a = normal == 0 ? 1 : 0;
    *b = normal == 2 ? 1 : 2;
}

static bool face_contains_closed(const tsv_face *F, const double q[3])
{
    int a, b;
    face_inplane(F->normal, &a, &b);
    return q[F->normal] == F->c && F->lo[0] <= q[a] && q[a] <= F->hi[0] && F->lo[1] <= q[b] &&
           q[b] <= F->hi[1];
}

/* A minimal face normal to d at q (via the cell locator), existence only. */
static bool face_hit(const tsv_lattice *L, int d, const double q[3])
{
    const idlist *bin = bin_at(L, q);
    for (size_t i = 0; i < bin->n; i++) {
        const tsv_cell *C = &L->cells[bin->v[i]];
        if ((C->lo[d] == q[d] || C->hi[d] == q[d]) && cell_contains(C, q))
            return true;
    }
    return false;
}

void ffd_tsv_lattice_locate(const tsv_lattice *L, const double q[3], int *dim, uint32_t *id)
{
    uint32_t v = ffd_tsv_vertex_find(L, q);
    if (v != UINT32_MAX) {
        *dim = 0;
        *id = v;
        return;
    }
    for (int a = 0; a < 3; a++) {
        uint32_t e = edge_on_line(L, a, q);
        if (e != UINT32_MAX) {
            *dim = 1;
            *id = e;
            return;
        }
    }
    for (int n = 0; n < 3; n++) {
        const idlist *p = plane_get(L->index, n, q[n]);
        if (!p)
            continue;
        for (size_t i = 0; i < p->n; i++)
            if (face_contains_closed(&L->faces[p->v[i]], q)) {
                *dim = 2;
                *id = p->v[i];
                return;
            }
    }
    const idlist *bin = bin_at(L, q);
    for (size_t i = 0; i < bin->n; i++)
        if (cell_contains(&L->cells[bin->v[i]], q)) {
            *dim = 3;
            *id = bin->v[i];
            return;
        }
    *dim = -1;
    *id = UINT32_MAX;
}

/* ===================================================================
 * Ray casting (design §1.3)
 * =================================================================== */

/* Is plane sigma_d = s hit at the point q (q[d] == s)? */
static bool covered(const tsv_lattice *L, int d, const double q[3])
{
    if (ffd_tsv_vertex_find(L, q) != UINT32_MAX)
        return true;
    if (face_hit(L, d, q))
        return true;
    for (int e = 0; e < 3; e++)
        if (e != d && edge_on_line(L, e, q) != UINT32_MAX)
            return true;
    return false;
}

void ffd_tsv_infer_knots(const tsv_lattice *L, uint32_t v, double knots[3][5])
{
    const tsv_vertex *V = &L->verts[v];
    for (int d = 0; d < 3; d++) {
        const tsv_registry *r = &L->reg[d];
        double a = V->sg[d], q[3] = {V->sg[0], V->sg[1], V->sg[2]};
        size_t i0 = reg_lower_bound(r, a);
        knots[d][2] = a;
        /* +d: frame padding 3, 4 */
        int hits = 0;
        for (size_t i = i0 + 1; i < r->n && hits < 2; i++) {
            double s = r->v[i];
            if (s > TSV_SIGMA_MAX)
                break;
            q[d] = s;
            if (covered(L, d, q))
                knots[d][3 + hits++] = s;
        }
        if (hits == 0)
            knots[d][3] = 3.0;
        if (hits <= 1)
            knots[d][4] = hits == 0 ? 4.0 : 3.0;
        /* -d: frame padding -2, -3 */
        hits = 0;
        for (size_t i = i0; i-- > 0 && hits < 2;) {
            double s = r->v[i];
            if (s < TSV_SIGMA_MIN)
                break;
            q[d] = s;
            if (covered(L, d, q))
                knots[d][1 - hits++] = s;
        }
        if (hits == 0) {
            knots[d][1] = -2.0;
            knots[d][0] = -3.0;
        } else if (hits == 1) {
            knots[d][0] = -2.0;
        }
    }
}

/* ===================================================================
 * Element creation
 * =================================================================== */

static ffd_status add_vertex(tsv_lattice *L, const double sg[3], uint32_t *out)
{
    if (L->nv >= UINT32_MAX - 1)
        return FFD_ERR_NOMEM;
    if (!ffd_grow((void **)&L->verts, &L->cap_v, L->nv + 1, sizeof *L->verts))
        return FFD_ERR_NOMEM;
    tsv_vertex *V = &L->verts[L->nv];
    memset(V, 0, sizeof *V);
    V->sg[0] = sg[0];
    V->sg[1] = sg[1];
    V->sg[2] = sg[2];
    V->W = 1.0;
    if (!htab_put(&L->index->vhash, 0, V->sg, (uint32_t)L->nv))
        return FFD_ERR_NOMEM;
    *out = (uint32_t)L->nv++;
    return FFD_OK;
}

/* Appends edge E and inserts it in its line after position `after` (or sorted). */
static ffd_status add_edge(tsv_lattice *L, const tsv_edge *E, uint32_t *out)
{
    if (L->ne >= UINT32_MAX - 1)
        return FFD_ERR_NOMEM;
    if (!ffd_grow((void **)&L->edges, &L->cap_e, L->ne + 1, sizeof *L->edges))
        return FFD_ERR_NOMEM;
    double k[3];
    edge_line_key(E, k);
    idlist *l = line_get_or_add(L->index, E->axis, k);
    if (!l)
        return FFD_ERR_NOMEM;
    size_t lo = 0, hi = l->n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (L->edges[l->v[mid]].lo < E->lo)
            lo = mid + 1;
        else
            hi = mid;
    }
    if (!idlist_insert(l, lo, (uint32_t)L->ne))
        return FFD_ERR_NOMEM;
    L->edges[L->ne] = *E;
    *out = (uint32_t)L->ne++;
    return FFD_OK;
}

static ffd_status add_face(tsv_lattice *L, const tsv_face *F, uint32_t *out)
{
    if (L->nf >= INT32_MAX - 1)
        return FFD_ERR_NOMEM;
    if (!ffd_grow((void **)&L->faces, &L->cap_f, L->nf + 1, sizeof *L->faces))
        return FFD_ERR_NOMEM;
    idlist *p = plane_get_or_add(L->index, F->normal, F->c);
    if (!p || !idlist_push(p, (uint32_t)L->nf))
        return FFD_ERR_NOMEM;
    L->faces[L->nf] = *F;
    *out = (uint32_t)L->nf++;
    return FFD_OK;
}

/* ===================================================================
 * Splits (design §3.1). On FFD_ERR_NOMEM a split may leave partial
 * structure behind; ffd_tsv_lattice_refine works on a snapshot and rolls back.
 * =================================================================== */

ffd_status ffd_tsv_split_edge(tsv_lattice *L, uint32_t e, double x, uint32_t *new_vertex,
                          ffd_error *err)
{
    if (e >= L->ne)
        return ffd_fail(err, FFD_ERR_RANGE, "edge %u: there are %zu edges", e, L->ne);
    tsv_edge E = L->edges[e];
    if (!(E.lo < x && x < E.hi))
        return ffd_fail(err, FFD_ERR_INVALID, "edge %u: split value %.17g outside (%.17g, %.17g)", e,
                        x, E.lo, E.hi);
    double q[3];
    int k = 0;
    for (int b = 0; b < 3; b++)
        q[b] = b == E.axis ? x : E.c[k++];
    uint32_t v, ne;
    ffd_status st = add_vertex(L, q, &v);
    if (st != FFD_OK)
        return ffd_fail(err, st, "tsv split_edge: out of memory");
    tsv_edge E2 = E;
    E2.lo = x;
    E2.v0 = v;
    /* reserve before mutating e so that a failure leaves the lattice consistent */
    st = add_edge(L, &E2, &ne);
    if (st != FFD_OK)
        return ffd_fail(err, st, "tsv split_edge: out of memory");
    L->edges[e].hi = x;
    L->edges[e].v1 = v;
    if (new_vertex)
        *new_vertex = v;
    L->version++;
    return FFD_OK;
}

/* Vertex at q on a line along axis a: the existing one, or a split of the edge containing it. */
static ffd_status vertex_on_line(tsv_lattice *L, int a, const double q[3], uint32_t *v, ffd_error *err)
{
    *v = ffd_tsv_vertex_find(L, q);
    if (*v != UINT32_MAX)
        return FFD_OK;
    uint32_t e = edge_on_line(L, a, q);
    if (e == UINT32_MAX)
        return ffd_fail(err, FFD_ERR_NUMERIC, "tsv lattice: no edge along axis %d at (%g, %g, %g)", a,
                        q[0], q[1], q[2]);
    return ffd_tsv_split_edge(L, e, q[a], v, err);
}

ffd_status ffd_tsv_split_face(tsv_lattice *L, uint32_t f, int axis, double x, ffd_error *err)
{
    if (f >= L->nf)
        return ffd_fail(err, FFD_ERR_RANGE, "face %u: there are %zu faces", f, L->nf);
    tsv_face F = L->faces[f];
    int a, b;
    face_inplane(F.normal, &a, &b);
    if (axis != a && axis != b)
        return ffd_fail(err, FFD_ERR_INVALID, "face %u: axis %d is its normal", f, axis);
    int ia = axis == a ? 0 : 1, ib = 1 - ia, bx = axis == a ? b : a;
    if (!(F.lo[ia] < x && x < F.hi[ia]))
        return ffd_fail(err, FFD_ERR_INVALID, "face %u: split value %.17g outside (%.17g, %.17g)", f,
                        x, F.lo[ia], F.hi[ia]);
    /* ends of the cutting edge on the two sides parallel to axis */
    double q0[3], q1[3];
    q0[F.normal] = q1[F.normal] = F.c;
    q0[axis] = q1[axis] = x;
    q0[bx] = F.lo[ib];
    q1[bx] = F.hi[ib];
    uint32_t v0, v1, ne, nf;
    ffd_status st = vertex_on_line(L, axis, q0, &v0, err);
    if (st == FFD_OK)
        st = vertex_on_line(L, axis, q1, &v1, err);
    if (st != FFD_OK)
        return st;
    tsv_edge E;
    memset(&E, 0, sizeof E);
    E.axis = bx;
    int k = 0;
    for (int c = 0; c < 3; c++)
        if (c != bx)
            E.c[k++] = q0[c];
    E.lo = F.lo[ib];
    E.hi = F.hi[ib];
    E.v0 = v0;
    E.v1 = v1;
    st = add_edge(L, &E, &ne);
    if (st != FFD_OK)
        return ffd_fail(err, st, "tsv split_face: out of memory");
    tsv_face F2 = F;
    F2.lo[ia] = x;
    st = add_face(L, &F2, &nf);
    if (st != FFD_OK)
        return ffd_fail(err, st, "tsv split_face: out of memory");
    L->faces[f].hi[ia] = x;
    L->version++;
    return FFD_OK;
}

ffd_status ffd_tsv_split_cell(tsv_lattice *L, uint32_t c, int axis, double x, ffd_error *err)
{
    if (c >= L->nc)
        return ffd_fail(err, FFD_ERR_RANGE, "cell %u: there are %zu cells", c, L->nc);
    if (axis < 0 || axis > 2)
        return ffd_fail(err, FFD_ERR_INVALID, "cell %u: axis %d", c, axis);
    tsv_cell C = L->cells[c];
    if (!(C.lo[axis] < x && x < C.hi[axis]))
        return ffd_fail(err, FFD_ERR_INVALID, "cell %u: split value %.17g outside (%.17g, %.17g)", c,
                        x, C.lo[axis], C.hi[axis]);
    if (L->nc >= INT32_MAX - 1)
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv split_cell: too many cells");
    ffd_status st;
    /* 1. split the faces on C's four sides parallel to axis that straddle x */
    for (int n = 0; n < 3; n++) {
        if (n == axis)
            continue;
        int a, b;
        face_inplane(n, &a, &b);
        int ia = axis == a ? 0 : 1, io = 1 - ia, other = axis == a ? b : a;
        for (int side = 0; side < 2; side++) {
            double cval = side ? C.hi[n] : C.lo[n];
            idlist *p = plane_get(L->index, n, cval);
            if (!p)
                continue;
            size_t count = p->n; /* faces appended by the splits below are halves already done */
            for (size_t i = 0; i < count; i++) {
                uint32_t g = p->v[i];
                const tsv_face *G = &L->faces[g];
                if (G->lo[ia] < x && x < G->hi[ia] && G->lo[io] >= C.lo[other] &&
                    G->hi[io] <= C.hi[other]) {
                    st = ffd_tsv_split_face(L, g, axis, x, err);
                    if (st != FFD_OK)
                        return st;
                    p = plane_get(L->index, n, cval); /* the list may have moved */
                }
            }
        }
    }
    /* 2. the new cell above x and the internal face */
    if (!ffd_grow((void **)&L->cells, &L->cap_c, L->nc + 1, sizeof *L->cells))
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv split_cell: out of memory");
    uint32_t c2 = (uint32_t)L->nc;
    tsv_face F;
    memset(&F, 0, sizeof F);
    F.normal = axis;
    F.c = x;
    {
        int a, b;
        face_inplane(axis, &a, &b);
        F.lo[0] = C.lo[a];
        F.hi[0] = C.hi[a];
        F.lo[1] = C.lo[b];
        F.hi[1] = C.hi[b];
    }
    F.cell_neg = (int32_t)c;
    F.cell_pos = (int32_t)c2;
    tsv_cell C2 = C;
    C2.lo[axis] = x;
    uint32_t olo[3], ohi[3];
    for (int a = 0; a < 3; a++) {
        olo[a] = bin_of(L->index, a, C.lo[a]);
        ohi[a] = bin_of(L->index, a, C.hi[a]);
    }
    L->cells[c2] = C2;
    uint32_t nf;
    if (!bins_add_cell(L->index, &C2, c2, NULL, NULL) || add_face(L, &F, &nf) != FFD_OK) {
        /* undo: c2 out of every bin (c is unchanged so far) */
        tsv_cell gone = C2;
        for (int a = 0; a < 3; a++)
            gone.lo[a] = gone.hi[a] = -1.0; /* bin range of the corner bin only */
        bins_shrink_cell(L->index, olo, ohi, &gone, c2);
        uint32_t z[3] = {0, 0, 0};
        idlist *l0 = &L->index->bins[bin_id(L->index, z)];
        for (size_t i = 0; i < l0->n; i++)
            if (l0->v[i] == c2)
                l0->v[i] = l0->v[--l0->n];
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv split_cell: out of memory");
    }
    L->nc++;
    L->cells[c].hi[axis] = x;
    bins_shrink_cell(L->index, olo, ohi, &L->cells[c], c);
    /* 3. refresh side cells of C's boundary faces now bordering the upper part */
    for (int n = 0; n < 3; n++) {
        for (int side = 0; side < 2; side++) {
            double cval = side ? C.hi[n] : C.lo[n];
            if (n == axis && !side)
                continue; /* the lower end stays with c */
            const idlist *p = plane_get(L->index, n, cval);
            if (!p)
                continue;
            int a, b;
            face_inplane(n, &a, &b);
            for (size_t i = 0; i < p->n; i++) {
                tsv_face *G = &L->faces[p->v[i]];
                int32_t *slot = side ? &G->cell_neg : &G->cell_pos;
                if (*slot != (int32_t)c)
                    continue;
                if (n == axis) {
                    *slot = (int32_t)c2;
                } else {
                    int ia = axis == a ? 0 : 1;
                    if (G->lo[ia] >= x)
                        *slot = (int32_t)c2;
                }
            }
        }
    }
    L->version++;
    return FFD_OK;
}

/* ===================================================================
 * Boundary vertex lists
 * =================================================================== */

/* Appends the vertices of the line along axis through q in [lo, hi) (ascending) or (lo, hi] (descending). */
static bool side_vertices(const tsv_lattice *L, int axis, const double q[3], double lo, double hi,
                          bool descending, idlist *out)
{
    double k[3];
    line_key(axis, q, k);
    uint32_t li = line_find(L->index, axis, k);
    if (li == UINT32_MAX)
        return true;
    const idlist *l = &L->index->lines[li];
    if (!descending) {
        for (size_t i = 0; i < l->n; i++) {
            const tsv_edge *E = &L->edges[l->v[i]];
            if (E->lo >= lo && E->lo < hi && !idlist_push(out, E->v0))
                return false;
        }
    } else {
        for (size_t i = l->n; i-- > 0;) {
            const tsv_edge *E = &L->edges[l->v[i]];
            if (E->hi <= hi && E->hi > lo && !idlist_push(out, E->v1))
                return false;
        }
    }
    return true;
}

static bool face_ring_append(const tsv_lattice *L, const tsv_face *F, idlist *out)
{
    int a, b;
    face_inplane(F->normal, &a, &b);
    double q[3];
    q[F->normal] = F->c;
    /* (lo,lo) -> (hi,lo) -> (hi,hi) -> (lo,hi) in the (a,b) plane */
    q[b] = F->lo[1];
    q[a] = 0.0;
    if (!side_vertices(L, a, q, F->lo[0], F->hi[0], false, out))
        return false;
    q[a] = F->hi[0];
    if (!side_vertices(L, b, q, F->lo[1], F->hi[1], false, out))
        return false;
    q[b] = F->hi[1];
    if (!side_vertices(L, a, q, F->lo[0], F->hi[0], true, out))
        return false;
    q[a] = F->lo[0];
    return side_vertices(L, b, q, F->lo[1], F->hi[1], true, out);
}

ffd_status ffd_tsv_face_ring(const tsv_lattice *L, uint32_t f, uint32_t **ids, size_t *count,
                         ffd_error *err)
{
    *ids = NULL;
    *count = 0;
    if (f >= L->nf)
        return ffd_fail(err, FFD_ERR_RANGE, "face %u: there are %zu faces", f, L->nf);
    idlist out = {0};
    if (!face_ring_append(L, &L->faces[f], &out)) {
        ffd_free(out.v);
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv face_ring: out of memory");
    }
    *ids = out.v;
    *count = out.n;
    return FFD_OK;
}

static int cmp_u32(const void *x, const void *y)
{
    uint32_t a = *(const uint32_t *)x, b = *(const uint32_t *)y;
    return a < b ? -1 : a > b;
}

ffd_status ffd_tsv_cell_points(const tsv_lattice *L, uint32_t c, uint32_t **ids, size_t *count,
                           ffd_error *err)
{
    *ids = NULL;
    *count = 0;
    if (c >= L->nc)
        return ffd_fail(err, FFD_ERR_RANGE, "cell %u: there are %zu cells", c, L->nc);
    const tsv_cell *C = &L->cells[c];
    idlist out = {0};
    for (int n = 0; n < 3; n++) {
        int a, b;
        face_inplane(n, &a, &b);
        for (int side = 0; side < 2; side++) {
            double cval = side ? C->hi[n] : C->lo[n];
            const idlist *p = plane_get(L->index, n, cval);
            if (!p)
                continue;
            for (size_t i = 0; i < p->n; i++) {
                const tsv_face *G = &L->faces[p->v[i]];
                if (G->lo[0] >= C->lo[a] && G->hi[0] <= C->hi[a] && G->lo[1] >= C->lo[b] &&
                    G->hi[1] <= C->hi[b] && !face_ring_append(L, G, &out)) {
                    ffd_free(out.v);
                    return ffd_fail(err, FFD_ERR_NOMEM, "tsv cell_points: out of memory");
                }
            }
        }
    }
    if (out.n)
        qsort(out.v, out.n, sizeof *out.v, cmp_u32);
    size_t m = 0;
    for (size_t i = 0; i < out.n; i++)
        if (m == 0 || out.v[m - 1] != out.v[i])
            out.v[m++] = out.v[i];
    *ids = out.v;
    *count = m;
    return FFD_OK;
}

/* ===================================================================
 * Validation (design §1.2 invariants 1-4, side cells)
 * =================================================================== */

static double box_area(const double lo[2], const double hi[2])
{
    return (hi[0] - lo[0]) * (hi[1] - lo[1]);
}

ffd_status ffd_tsv_lattice_validate(const tsv_lattice *L, ffd_error *err)
{
    const double tol = 1e-9;
    /* vertices: hash agreement */
    for (size_t v = 0; v < L->nv; v++)
        if (ffd_tsv_vertex_find(L, L->verts[v].sg) != v)
            return ffd_fail(err, FFD_ERR_NUMERIC, "vertex %zu: not in the vertex hash", v);
    /* 1. cells tile [-1,2]^3: total volume 27 and no two overlap */
    double vol = 0.0;
    for (size_t c = 0; c < L->nc; c++) {
        const tsv_cell *C = &L->cells[c];
        for (int a = 0; a < 3; a++)
            if (!(C->lo[a] < C->hi[a]) || C->lo[a] < TSV_SIGMA_MIN || C->hi[a] > TSV_SIGMA_MAX)
                return ffd_fail(err, FFD_ERR_NUMERIC, "cell %zu: bad box on axis %d", c, a);
        vol += (C->hi[0] - C->lo[0]) * (C->hi[1] - C->lo[1]) * (C->hi[2] - C->lo[2]);
        double mid[3];
        for (int a = 0; a < 3; a++)
            mid[a] = 0.5 * (C->lo[a] + C->hi[a]);
        const idlist *bin = bin_at(L, mid);
        bool self = false;
        for (size_t i = 0; i < bin->n; i++) {
            const tsv_cell *D = &L->cells[bin->v[i]];
            if (bin->v[i] == c) {
                self = true;
                continue;
            }
            if (D->lo[0] < C->hi[0] && C->lo[0] < D->hi[0] && D->lo[1] < C->hi[1] &&
                C->lo[1] < D->hi[1] && D->lo[2] < C->hi[2] && C->lo[2] < D->hi[2])
                return ffd_fail(err, FFD_ERR_NUMERIC, "cells %zu and %u overlap", c, bin->v[i]);
        }
        if (!self)
            return ffd_fail(err, FFD_ERR_NUMERIC, "cell %zu: missing from the locator", c);
    }
    if (fabs(vol - 27.0) > tol)
        return ffd_fail(err, FFD_ERR_NUMERIC, "cells cover volume %.17g, not 27", vol);
    /* 2. faces: side cells bound them; per-cell side areas add up */
    double *side = ffd_calloc(L->nc ? 6 * L->nc : 1, sizeof *side);
    if (!side)
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv validate: out of memory");
    ffd_status st = FFD_OK;
    double plane_area[3][4] = {{0}};
    for (size_t f = 0; f < L->nf && st == FFD_OK; f++) {
        const tsv_face *F = &L->faces[f];
        int a, b;
        face_inplane(F->normal, &a, &b);
        int n = F->normal;
        if (!(F->lo[0] < F->hi[0] && F->lo[1] < F->hi[1])) {
            st = ffd_fail(err, FFD_ERR_NUMERIC, "face %zu: empty rectangle", f);
            break;
        }
        for (int s = 0; s < 2; s++) {
            int32_t cc = s ? F->cell_pos : F->cell_neg;
            if (cc < 0) {
                if (F->c != (s ? TSV_SIGMA_MAX : TSV_SIGMA_MIN)) {
                    st = ffd_fail(err, FFD_ERR_NUMERIC, "face %zu: no cell on its %s side", f,
                                  s ? "+" : "-");
                    break;
                }
                continue;
            }
            if ((size_t)cc >= L->nc) {
                st = ffd_fail(err, FFD_ERR_NUMERIC, "face %zu: side cell %d out of range", f, cc);
                break;
            }
            const tsv_cell *C = &L->cells[cc];
            if ((s ? C->lo[n] : C->hi[n]) != F->c || F->lo[0] < C->lo[a] || F->hi[0] > C->hi[a] ||
                F->lo[1] < C->lo[b] || F->hi[1] > C->hi[b]) {
                st = ffd_fail(err, FFD_ERR_NUMERIC, "face %zu: not on the %s side of its cell %d", f,
                              s ? "-" : "+", cc);
                break;
            }
            side[6 * (size_t)cc + 2 * n + (s ? 0 : 1)] += box_area(F->lo, F->hi);
        }
        static const double layer[4] = {-1.0, 0.0, 1.0, 2.0};
        for (int k = 0; k < 4; k++)
            if (F->c == layer[k])
                plane_area[n][k] += box_area(F->lo, F->hi);
    }
    for (size_t c = 0; c < L->nc && st == FFD_OK; c++) {
        const tsv_cell *C = &L->cells[c];
        for (int n = 0; n < 3 && st == FFD_OK; n++) {
            int a, b;
            face_inplane(n, &a, &b);
            double want = (C->hi[a] - C->lo[a]) * (C->hi[b] - C->lo[b]);
            for (int s = 0; s < 2; s++)
                if (fabs(side[6 * c + 2 * n + s] - want) > tol) {
                    st = ffd_fail(err, FFD_ERR_NUMERIC,
                                  "cell %zu: faces on its %s side %d cover %.17g of %.17g", c,
                                  s ? "+" : "-", n, side[6 * c + 2 * n + s], want);
                    break;
                }
        }
    }
    ffd_free(side);
    if (st != FFD_OK)
        return st;
    /* 4. the planes -1, 0, 1, 2 are covered */
    for (int n = 0; n < 3; n++)
        for (int k = 0; k < 4; k++)
            if (fabs(plane_area[n][k] - 9.0) > tol)
                return ffd_fail(err, FFD_ERR_NUMERIC, "plane %d of axis %d covered %.17g of 9", k - 1,
                                n, plane_area[n][k]);
    /* 3. edges join consecutive vertices; no vertex inside an edge or a face */
    for (size_t e = 0; e < L->ne; e++) {
        const tsv_edge *E = &L->edges[e];
        const tsv_vertex *A = &L->verts[E->v0], *B = &L->verts[E->v1];
        int k = 0;
        for (int c = 0; c < 3; c++) {
            if (c == E->axis)
                continue;
            if (A->sg[c] != E->c[k] || B->sg[c] != E->c[k])
                return ffd_fail(err, FFD_ERR_NUMERIC, "edge %zu: ends off its line", e);
            k++;
        }
        if (A->sg[E->axis] != E->lo || B->sg[E->axis] != E->hi || !(E->lo < E->hi))
            return ffd_fail(err, FFD_ERR_NUMERIC, "edge %zu: ends do not match its range", e);
    }
    for (size_t v = 0; v < L->nv; v++) {
        const double *q = L->verts[v].sg;
        for (int a = 0; a < 3; a++) {
            uint32_t e = edge_on_line(L, a, q);
            if (e != UINT32_MAX && L->edges[e].lo < q[a] && q[a] < L->edges[e].hi)
                return ffd_fail(err, FFD_ERR_NUMERIC, "vertex %zu: inside edge %u", v, e);
            const idlist *p = plane_get(L->index, a, q[a]);
            if (!p)
                continue;
            int i0, i1;
            face_inplane(a, &i0, &i1);
            for (size_t i = 0; i < p->n; i++) {
                const tsv_face *F = &L->faces[p->v[i]];
                if (F->lo[0] < q[i0] && q[i0] < F->hi[0] && F->lo[1] < q[i1] && q[i1] < F->hi[1])
                    return ffd_fail(err, FFD_ERR_NUMERIC, "vertex %zu: inside face %u", v, p->v[i]);
            }
        }
    }
    for (size_t e = 0; e < L->ne; e++) {
        const tsv_edge *E = &L->edges[e];
        double q[3];
        int k = 0;
        for (int c = 0; c < 3; c++)
            q[c] = c == E->axis ? 0.5 * (E->lo + E->hi) : E->c[k++];
        for (int n = 0; n < 3; n++) {
            if (n == E->axis)
                continue;
            const idlist *p = plane_get(L->index, n, q[n]);
            if (!p)
                continue;
            int i0, i1;
            face_inplane(n, &i0, &i1);
            for (size_t i = 0; i < p->n; i++) {
                const tsv_face *F = &L->faces[p->v[i]];
                if (F->lo[0] < q[i0] && q[i0] < F->hi[0] && F->lo[1] < q[i1] && q[i1] < F->hi[1])
                    return ffd_fail(err, FFD_ERR_NUMERIC, "edge %zu: inside face %u", e, p->v[i]);
            }
        }
    }
    return FFD_OK;
}

double ffd_tsv_lattice_max_weight_deviation(const tsv_lattice *L)
{
    double m = 0;
    for (size_t v = 0; v < L->nv; v++) {
        double d = fabs(L->verts[v].W - 1);
        if (d > m)
            m = d;
    }
    return m;
}
