/* tsv_proxy — the proxy of proxy-driven FFD (Zhang, Zheng & Cai 2020, §3.2):
 * cell occupancy by the object, the outside flood fill and the proxy faces
 * (design §5); and the graph arrays of the proxy-driven ARAP (design §6,
 * "Neighbourhoods" and "Proxy Laplacian"), built from the lattice.
 *
 * Occupancy works in the object's parameter space [0,1]^3, where a cell's box
 * is its sigma box mapped per axis by the global Greville coordinate gamma
 * (design §5.1). Primitives (fan triangles of the faces, segments and points)
 * are binned in a uniform grid; each cell then tests only the primitives of
 * the bins its box overlaps, with the separating-axis test of Akenine-Moller
 * (2001). Cells are independent, so the loop runs in parallel and the result
 * does not depend on the thread count.
 *
 * ffd_tsv_proxy_build is all or nothing: on an error neither cells[].occupied /
 * cells[].outside nor *proxy change. The proxy polygons start at the ring's
 * (lo,lo) corner and run so that their normal points to the outside side.
 * ffd_tsv_arap_graph_build's proxy_uv polygons are counter-clockwise (positive
 * signed area) in index order: (gamma_a, gamma_b) on the face's in-plane axes
 * a < b, or (gamma_b, gamma_a) where that order would be clockwise. */
#include "tspline/tsv.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Closed-box tolerance in gamma units: a primitive within this of a cell box
 * counts as meeting it, so one lying on a shared face occupies both sides (design §5.1). */
#define TSV_OCC_EPS 1e-12
/* Uniform primitive grid: at most this many bins per axis. */
#define TSV_GRID_MAX 128
/* Grid shrinks while the bin entries exceed this many per primitive (plus the bin count). */
#define TSV_GRID_FILL 8

/* ---------------------------------------------------------------------
 * Small helpers
 * --------------------------------------------------------------------- */

static int tsv_cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* Sorts and removes duplicates; returns the new count. */
static size_t tsv_sort_unique_u32(uint32_t *v, size_t n)
{
    if (n == 0)
        return 0;
    qsort(v, n, sizeof *v, tsv_cmp_u32);
    size_t m = 1;
    for (size_t i = 1; i < n; i++)
        if (v[i] != v[m - 1])
            v[m++] = v[i];
    return m;
}

/* In-plane axes (a, b) of a face with this normal, increasing order (tsv.h). */
static void tsv_plane_axes(int normal, int *a, int *b)
{
    *a = normal == 0 ? 1 : 0;
    *b = normal == 2 ? 1 : 2;
}

/* ---------------------------------------------------------------------
 * Triangle-box overlap (Akenine-Moller 2001), design §5.1
 * --------------------------------------------------------------------- */

/* Separating-axis test of triangle (t0, t1, t2) against the box centred at
 * c with half sizes h grown by eps on every side: the 3 box normals, the 9
 * edge-cross-axis directions and the triangle normal. Degenerate triangles
 * (segments, points) reduce to the tests whose axes do not vanish. */
static int tsv_tri_box_overlap(const double c[3], const double h[3], const double *t0,
                               const double *t1, const double *t2, double eps)
{
    double v[3][3], e[3][3];
    for (int a = 0; a < 3; a++) {
        v[0][a] = t0[a] - c[a];
        v[1][a] = t1[a] - c[a];
        v[2][a] = t2[a] - c[a];
    }
    /* the box normals: bounding boxes overlap */
    for (int a = 0; a < 3; a++) {
        double mn = v[0][a], mx = v[0][a];
        for (int k = 1; k < 3; k++) {
            mn = v[k][a] < mn ? v[k][a] : mn;
            mx = v[k][a] > mx ? v[k][a] : mx;
        }
        if (mn > h[a] + eps || mx < -h[a] - eps)
            return 0;
    }
    for (int a = 0; a < 3; a++) {
        e[0][a] = v[1][a] - v[0][a];
        e[1][a] = v[2][a] - v[1][a];
        e[2][a] = v[0][a] - v[2][a];
    }
    /* the nine axes e_i x u_j */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
            double ax[3];
            ax[j] = 0.0;
            ax[j1] = e[i][j2];
            ax[j2] = -e[i][j1];
            double p0 = ax[j1] * v[0][j1] + ax[j2] * v[0][j2];
            double p1 = ax[j1] * v[1][j1] + ax[j2] * v[1][j2];
            double p2 = ax[j1] * v[2][j1] + ax[j2] * v[2][j2];
            double mn = p0 < p1 ? p0 : p1, mx = p0 > p1 ? p0 : p1;
            mn = p2 < mn ? p2 : mn;
            mx = p2 > mx ? p2 : mx;
            double r = (h[j1] + eps) * fabs(ax[j1]) + (h[j2] + eps) * fabs(ax[j2]);
            if (mn > r || mx < -r)
                return 0;
        }
    /* the triangle's plane */
    double n[3] = {e[0][1] * e[1][2] - e[0][2] * e[1][1], e[0][2] * e[1][0] - e[0][0] * e[1][2],
                   e[0][0] * e[1][1] - e[0][1] * e[1][0]};
    double d = n[0] * v[0][0] + n[1] * v[0][1] + n[2] * v[0][2];
    double r = (h[0] + eps) * fabs(n[0]) + (h[1] + eps) * fabs(n[1]) + (h[2] + eps) * fabs(n[2]);
    return fabs(d) <= r;
}

/* ---------------------------------------------------------------------
 * Occupancy (design §5.1)
 * --------------------------------------------------------------------- */

/* The object's primitives in parameter space: three point ids each (fan
 * triangles; a segment repeats its end, a point itself three times), their
 * bounds and, once the grid is chosen, their bin ranges. */
typedef struct tsv_prims {
    const double *params;
    uint32_t *vid;   /* 3 per primitive */
    double *bound;   /* 6 per primitive: min[3], max[3] */
    uint16_t *bin;   /* 6 per primitive: first bin[3], last bin[3] */
    size_t n;
} tsv_prims;

/* Uniform grid of primitives over [0,1]^3 (CSR, primitive ids ascending per bin). */
typedef struct tsv_grid {
    int g;            /* bins per axis */
    size_t *start;    /* g^3 + 1 */
    uint32_t *item;
} tsv_grid;

static void tsv_prims_free(tsv_prims *P)
{
    ffd_free(P->vid);
    ffd_free(P->bound);
    ffd_free(P->bin);
    memset(P, 0, sizeof *P);
}

static void tsv_grid_free(tsv_grid *G)
{
    ffd_free(G->start);
    ffd_free(G->item);
    memset(G, 0, sizeof *G);
}

static void tsv_prim_set(tsv_prims *P, size_t k, uint32_t i0, uint32_t i1, uint32_t i2)
{
    uint32_t *id = P->vid + 3 * k;
    double *b = P->bound + 6 * k;
    const double *t0 = P->params + 3 * (size_t)i0, *t1 = P->params + 3 * (size_t)i1,
                 *t2 = P->params + 3 * (size_t)i2;
    id[0] = i0, id[1] = i1, id[2] = i2;
    for (int a = 0; a < 3; a++) {
        double mn = t0[a], mx = t0[a];
        mn = t1[a] < mn ? t1[a] : mn;
        mx = t1[a] > mx ? t1[a] : mx;
        mn = t2[a] < mn ? t2[a] : mn;
        mx = t2[a] > mx ? t2[a] : mx;
        b[a] = mn;
        b[3 + a] = mx;
    }
}

/* Fan-triangulates the faces (design §5.1); points no face uses become point
 * primitives (all points when there are no faces). */
static ffd_status tsv_prims_build(const tsv_object *obj, tsv_prims *P, ffd_error *err)
{
    memset(P, 0, sizeof *P);
    P->params = obj->params;
    const size_t nf = obj->face_offsets ? obj->face_count : 0;
    if (nf > 0 && obj->face_offsets[0] != 0)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_tsv_proxy_build: face_offsets[0] is %u, not 0",
                        (unsigned)obj->face_offsets[0]);
    uint8_t *used = NULL;
    if (nf > 0 && obj->n > 0) {
        used = ffd_calloc(obj->n, 1);
        if (!used)
            return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory");
    }
    size_t count = 0;
    for (size_t f = 0; f < nf; f++) {
        uint32_t b = obj->face_offsets[f], e = obj->face_offsets[f + 1];
        if (e < b) {
            ffd_free(used);
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_tsv_proxy_build: face_offsets decrease at face %zu", f);
        }
        for (uint32_t k = b; k < e; k++) {
            uint32_t i = obj->face_indices[k];
            if (i >= obj->n) {
                ffd_free(used);
                return ffd_fail(err, FFD_ERR_RANGE,
                                "ffd_tsv_proxy_build: face %zu uses point %u: there are %zu points", f,
                                (unsigned)i, obj->n);
            }
            used[i] = 1;
        }
        uint32_t m = e - b;
        count += m >= 3 ? (size_t)(m - 2) : (m > 0 ? 1 : 0);
    }
    for (size_t i = 0; i < obj->n; i++)
        if (!used || !used[i])
            count++;
    if (count > UINT32_MAX) {
        ffd_free(used);
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: too many primitives (%zu)", count);
    }
    if (count > 0) {
        P->vid = ffd_malloc_array(count, 3 * sizeof *P->vid);
        P->bound = ffd_malloc_array(count, 6 * sizeof *P->bound);
        P->bin = ffd_malloc_array(count, 6 * sizeof *P->bin);
        if (!P->vid || !P->bound || !P->bin) {
            ffd_free(used);
            tsv_prims_free(P);
            return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory");
        }
    }
    size_t k = 0;
    for (size_t f = 0; f < nf; f++) {
        const uint32_t *ix = obj->face_indices + obj->face_offsets[f];
        uint32_t m = obj->face_offsets[f + 1] - obj->face_offsets[f];
        if (m >= 3)
            for (uint32_t j = 1; j + 1 < m; j++)
                tsv_prim_set(P, k++, ix[0], ix[j], ix[j + 1]);
        else if (m == 2)
            tsv_prim_set(P, k++, ix[0], ix[1], ix[1]);
        else if (m == 1)
            tsv_prim_set(P, k++, ix[0], ix[0], ix[0]);
    }
    for (size_t i = 0; i < obj->n; i++)
        if (!used || !used[i]) {
            uint32_t ii = (uint32_t)i;
            tsv_prim_set(P, k++, ii, ii, ii);
        }
    P->n = k;
    ffd_free(used);
    return FFD_OK;
}

/* Bin of parameter x on a grid of g bins over [0,1] (clamped). */
static int tsv_bin(double x, int g)
{
    double b = x * (double)g;
    if (!(b > 0.0)) /* also NaN */
        return 0;
    if (b >= (double)(g - 1))
        return g - 1;
    return (int)b; /* truncation = floor for b > 0 */
}

/* Entries a grid of g bins per axis would hold (saturates at SIZE_MAX). */
static size_t tsv_grid_entries(const tsv_prims *P, int g)
{
    size_t total = 0;
    for (size_t k = 0; k < P->n; k++) {
        const double *b = P->bound + 6 * k;
        size_t c = 1;
        for (int a = 0; a < 3; a++)
            c *= (size_t)(tsv_bin(b[3 + a], g) - tsv_bin(b[a], g) + 1);
        if (total > SIZE_MAX - c)
            return SIZE_MAX;
        total += c;
    }
    return total;
}

/* Bins the primitives by their bounding boxes (design §5.1: never cells x triangles). */
static ffd_status tsv_grid_build(tsv_prims *P, tsv_grid *G, ffd_error *err)
{
    memset(G, 0, sizeof *G);
    int g = (int)ceil(cbrt((double)P->n));
    g = g < 1 ? 1 : (g > TSV_GRID_MAX ? TSV_GRID_MAX : g);
    size_t total = tsv_grid_entries(P, g);
    while (g > 1 && total > TSV_GRID_FILL * P->n + (size_t)g * (size_t)g * (size_t)g) {
        g = (g + 1) / 2;
        total = tsv_grid_entries(P, g);
    }
    size_t nb = (size_t)g * (size_t)g * (size_t)g;
    G->g = g;
    G->start = ffd_calloc(nb + 1, sizeof *G->start);
    G->item = ffd_malloc_array(total ? total : 1, sizeof *G->item);
    if (!G->start || !G->item) {
        tsv_grid_free(G);
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory (primitive grid)");
    }
    for (size_t k = 0; k < P->n; k++)
        for (int a = 0; a < 3; a++) {
            P->bin[6 * k + a] = (uint16_t)tsv_bin(P->bound[6 * k + a], g);
            P->bin[6 * k + 3 + a] = (uint16_t)tsv_bin(P->bound[6 * k + 3 + a], g);
        }
    for (int pass = 0; pass < 2; pass++) {
        for (size_t k = 0; k < P->n; k++) {
            const uint16_t *lo = P->bin + 6 * k, *hi = lo + 3;
            for (int x = lo[0]; x <= hi[0]; x++)
                for (int y = lo[1]; y <= hi[1]; y++)
                    for (int z = lo[2]; z <= hi[2]; z++) {
                        size_t bin = ((size_t)x * (size_t)g + (size_t)y) * (size_t)g + (size_t)z;
                        if (pass == 0)
                            G->start[bin + 1]++;
                        else
                            G->item[G->start[bin]++] = (uint32_t)k;
                    }
        }
        if (pass == 0) {
            for (size_t i = 0; i < nb; i++)
                G->start[i + 1] += G->start[i];
        } else {
            /* the fill advanced start[bin] to the next bin's start: shift back */
            memmove(G->start + 1, G->start, nb * sizeof *G->start);
            G->start[0] = 0;
        }
    }
    return FFD_OK;
}

/* Does the object meet the cell whose parameter box is [lo, hi]? Each
 * primitive is tested once: in the first bin of the overlap of its bin range
 * with the cell's. */
static int tsv_cell_meets(const tsv_prims *P, const tsv_grid *G, const double lo[3],
                          const double hi[3])
{
    const int g = G->g;
    double c[3], h[3];
    int blo[3], bhi[3];
    for (int a = 0; a < 3; a++) {
        c[a] = 0.5 * (lo[a] + hi[a]);
        h[a] = 0.5 * (hi[a] - lo[a]);
        blo[a] = tsv_bin(lo[a] - TSV_OCC_EPS, g);
        bhi[a] = tsv_bin(hi[a] + TSV_OCC_EPS, g);
    }
    for (int x = blo[0]; x <= bhi[0]; x++)
        for (int y = blo[1]; y <= bhi[1]; y++)
            for (int z = blo[2]; z <= bhi[2]; z++) {
                size_t bin = ((size_t)x * (size_t)g + (size_t)y) * (size_t)g + (size_t)z;
                const int at[3] = {x, y, z};
                for (size_t q = G->start[bin]; q < G->start[bin + 1]; q++) {
                    size_t k = G->item[q];
                    const double *b = P->bound + 6 * k;
                    const uint16_t *pb = P->bin + 6 * k;
                    int test = 1;
                    for (int a = 0; a < 3 && test; a++) {
                        if (b[a] > hi[a] + TSV_OCC_EPS || b[3 + a] < lo[a] - TSV_OCC_EPS)
                            test = 0; /* bounds apart */
                        else
                            test = at[a] == (pb[a] > blo[a] ? pb[a] : blo[a]);
                    }
                    if (!test)
                        continue;
                    const uint32_t *id = P->vid + 3 * k;
                    if (tsv_tri_box_overlap(c, h, P->params + 3 * (size_t)id[0],
                                            P->params + 3 * (size_t)id[1],
                                            P->params + 3 * (size_t)id[2], TSV_OCC_EPS))
                        return 1;
                }
            }
    return 0;
}

/* occ[c] = does the object meet cell c (design §5.1). */
static ffd_status tsv_occupancy(const tsv_lattice *L, const tsv_object *obj, uint8_t *occ,
                                ffd_error *err)
{
    tsv_prims P;
    ffd_status st = tsv_prims_build(obj, &P, err);
    if (st != FFD_OK)
        return st;
    if (P.n == 0) {
        memset(occ, 0, L->nc);
        return FFD_OK;
    }
    tsv_grid G;
    st = tsv_grid_build(&P, &G, err);
    double *box = st == FFD_OK ? ffd_malloc_array(L->nc ? L->nc : 1, 6 * sizeof(double)) : NULL;
    if (st == FFD_OK && !box)
        st = ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory");
    if (st != FFD_OK) {
        tsv_grid_free(&G);
        tsv_prims_free(&P);
        return st;
    }
    /* cell boxes in parameter space: sigma box mapped by gamma per axis (design §5.1) */
    for (size_t c = 0; c < L->nc; c++)
        for (int a = 0; a < 3; a++) {
            box[6 * c + a] = ffd_tsv_gamma(L, a, L->cells[c].lo[a]);
            box[6 * c + 3 + a] = ffd_tsv_gamma(L, a, L->cells[c].hi[a]);
        }
    const long long nc = (long long)L->nc;
#pragma omp parallel for schedule(dynamic, 16) if (nc > 64)
    for (long long cc = 0; cc < nc; cc++) {
        size_t c = (size_t)cc;
        occ[c] = (uint8_t)tsv_cell_meets(&P, &G, box + 6 * c, box + 6 * c + 3);
    }
    ffd_free(box);
    tsv_grid_free(&G);
    tsv_prims_free(&P);
    return FFD_OK;
}

/* ---------------------------------------------------------------------
 * Outside flood fill (design §5.2)
 * --------------------------------------------------------------------- */

/* out[c] = cell c is outside: not occupied (occ) and reached from the domain
 * boundary across shared minimal faces. Enclosed cavities stay inside. */
static ffd_status tsv_flood_outside(const tsv_lattice *L, const uint8_t *occ, uint8_t *out,
                                    ffd_error *err)
{
    const size_t nc = L->nc, nf = L->nf;
    memset(out, 0, nc);
    if (nc == 0)
        return FFD_OK;
    size_t *start = ffd_calloc(nc + 1, sizeof *start);
    uint32_t *queue = ffd_malloc_array(nc, sizeof *queue);
    uint32_t *nbr = NULL;
    size_t pairs = 0;
    for (size_t f = 0; f < nf; f++)
        if (L->faces[f].cell_neg >= 0 && L->faces[f].cell_pos >= 0)
            pairs++;
    if (start && queue)
        nbr = ffd_malloc_array(pairs ? 2 * pairs : 1, sizeof *nbr);
    if (!start || !queue || !nbr) {
        ffd_free(start);
        ffd_free(queue);
        ffd_free(nbr);
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory (flood fill)");
    }
    /* cell adjacency across shared faces, CSR */
    for (size_t f = 0; f < nf; f++) {
        const tsv_face *F = &L->faces[f];
        if (F->cell_neg >= 0 && F->cell_pos >= 0) {
            start[(size_t)F->cell_neg + 1]++;
            start[(size_t)F->cell_pos + 1]++;
        }
    }
    for (size_t c = 0; c < nc; c++)
        start[c + 1] += start[c];
    for (size_t f = 0; f < nf; f++) {
        const tsv_face *F = &L->faces[f];
        if (F->cell_neg >= 0 && F->cell_pos >= 0) {
            nbr[start[F->cell_neg]++] = (uint32_t)F->cell_pos;
            nbr[start[F->cell_pos]++] = (uint32_t)F->cell_neg;
        }
    }
    memmove(start + 1, start, nc * sizeof *start);
    start[0] = 0;
    /* seeds: free cells on the domain boundary */
    size_t head = 0, tail = 0;
    for (size_t f = 0; f < nf; f++) {
        const tsv_face *F = &L->faces[f];
        int32_t c = F->cell_neg < 0 ? F->cell_pos : (F->cell_pos < 0 ? F->cell_neg : -1);
        if (c >= 0 && !occ[c] && !out[c]) {
            out[c] = 1;
            queue[tail++] = (uint32_t)c;
        }
    }
    while (head < tail) {
        uint32_t c = queue[head++];
        for (size_t q = start[c]; q < start[c + 1]; q++) {
            uint32_t d = nbr[q];
            if (!occ[d] && !out[d]) {
                out[d] = 1;
                queue[tail++] = d;
            }
        }
    }
    ffd_free(start);
    ffd_free(queue);
    ffd_free(nbr);
    return FFD_OK;
}

/* ---------------------------------------------------------------------
 * Proxy faces (design §5.3)
 * --------------------------------------------------------------------- */

void ffd_tsv_proxy_free(tsv_proxy *proxy)
{
    if (!proxy)
        return;
    ffd_free(proxy->face_offsets);
    ffd_free(proxy->face_indices);
    ffd_free(proxy->face_cells);
    ffd_free(proxy->lattice_face);
    ffd_free(proxy->vertices);
    ffd_free(proxy->point_controls);
    ffd_free(proxy->face_points);
    memset(proxy, 0, sizeof *proxy);
}

/* Is this side of a face outside the proxy (beyond the domain or an outside cell)? */
static int tsv_side_outside(const uint8_t *out, int32_t cell)
{
    return cell < 0 || out[cell];
}

/* Twice the signed area of ring ids in the sigma coordinates of axes (a, b). */
static double tsv_ring_area(const tsv_lattice *L, const uint32_t *ids, size_t m, int a, int b)
{
    double s = 0.0;
    for (size_t i = 0; i < m; i++) {
        const double *p = L->verts[ids[i]].sg, *q = L->verts[ids[(i + 1) % m]].sg;
        s += p[a] * q[b] - q[a] * p[b];
    }
    return s;
}

/* Extracts the proxy faces into P (empty on entry): every minimal face with
 * exactly one outside side, its ring oriented so that the normal points to
 * the outside side (design §5.3). */
static ffd_status tsv_proxy_faces(const tsv_lattice *L, const uint8_t *out, tsv_proxy *P,
                                  ffd_error *err)
{
    size_t cap_f = 0, cap_i = 0, nidx = 0;
    size_t count = 0;
    for (size_t f = 0; f < L->nf; f++) {
        const tsv_face *F = &L->faces[f];
        if (tsv_side_outside(out, F->cell_neg) != tsv_side_outside(out, F->cell_pos))
            count++;
    }
    P->face_offsets = ffd_malloc_array(count + 1, sizeof *P->face_offsets);
    P->face_cells = ffd_malloc_array(count ? count : 1, sizeof *P->face_cells);
    P->lattice_face = ffd_malloc_array(count ? count : 1, sizeof *P->lattice_face);
    cap_f = count;
    if (!P->face_offsets || !P->face_cells || !P->lattice_face)
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory (proxy faces)");
    if (!ffd_grow((void **)&P->face_indices, &cap_i, 4 * count + 1, sizeof *P->face_indices))
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory (proxy faces)");
    P->face_offsets[0] = 0;
    size_t k = 0;
    for (size_t f = 0; f < L->nf && k < cap_f; f++) {
        const tsv_face *F = &L->faces[f];
        int out_neg = tsv_side_outside(out, F->cell_neg);
        int out_pos = tsv_side_outside(out, F->cell_pos);
        if (out_neg == out_pos)
            continue;
        uint32_t *ring = NULL;
        size_t m = 0;
        ffd_status st = ffd_tsv_face_ring(L, (uint32_t)f, &ring, &m, err);
        if (st != FFD_OK)
            return st;
        if (nidx + m > UINT32_MAX) {
            ffd_free(ring);
            return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: proxy too large");
        }
        if (!ffd_grow((void **)&P->face_indices, &cap_i, nidx + m, sizeof *P->face_indices)) {
            ffd_free(ring);
            return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory (proxy faces)");
        }
        /* the ring's normal along the face normal: sign of its (a,b) area
         * times the handedness of (normal, a, b); outward = towards the outside side */
        int a, b;
        tsv_plane_axes(F->normal, &a, &b);
        double hand = F->normal == 1 ? -1.0 : 1.0;
        double dir = hand * tsv_ring_area(L, ring, m, a, b);
        double want = out_pos ? 1.0 : -1.0;
        uint32_t *dst = P->face_indices + nidx;
        if (dir * want >= 0.0) {
            memcpy(dst, ring, m * sizeof *ring);
        } else {
            /* reversed, still starting at the ring's first corner */
            dst[0] = ring[0];
            for (size_t i = 1; i < m; i++)
                dst[i] = ring[m - i];
        }
        ffd_free(ring);
        nidx += m;
        P->face_cells[k] = (uint32_t)(out_pos ? F->cell_neg : F->cell_pos);
        P->lattice_face[k] = (uint32_t)f;
        P->face_offsets[++k] = (uint32_t)nidx;
    }
    P->face_count = k;
    /* the proxy vertices: distinct ids ascending (design §5.4) */
    P->vertices = ffd_malloc_array(nidx ? nidx : 1, sizeof *P->vertices);
    if (!P->vertices)
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory (proxy vertices)");
    if (nidx)
        memcpy(P->vertices, P->face_indices, nidx * sizeof *P->vertices);
    P->vertex_count = tsv_sort_unique_u32(P->vertices, nidx);
    return FFD_OK;
}

/* ---------------------------------------------------------------------
 * Sheets: the proxy as a closed 2-manifold
 * --------------------------------------------------------------------- */

/* Where two inside cells share only an edge, four proxy faces meet at that
 * edge; where they share only a vertex, the faces around it form two fans.
 * The manifold proxy splits such edges and vertices per sheet, by the rule
 * of voxel surfaces that faces of one inside cell stay connected:
 *  1. each half-edge (corner q to the next corner of its face) gets a twin,
 *     a half-edge of the reverse direction between the same lattice points:
 *     one of the same inside cell where there is one (the two faces of a
 *     cell at its edge), else the remaining one (at an edge with two faces
 *     there is exactly one);
 *  2. the corners at one control point are joined through the twins (corner
 *     q and the corner at the same point in its twin's face, the next one
 *     round the point); every corner then has two neighbours, so each class
 *     is one cycle, a fan: one sheet, one point of the manifold proxy;
 *  3. where the two inside cells at a four-face edge are also joined through
 *     faces around both of its ends, step 2 leaves one point at each end and
 *     the mesh would hold that edge twice (four faces on one pair of points).
 *     That edge is paired the other way, through its two outside cells,
 *     which splits both of its ends into two fans; then step 2 again.
 * Points are numbered by control id, then by their lowest corner, so on a
 * proxy with no contact point k is vertices[k] and face_points mirrors
 * face_indices. */

typedef struct half_edge {
    uint64_t key;  /* lower point << 32 | higher point */
    uint32_t q;    /* the corner it starts at */
} half_edge;

static int cmp_half_edge(const void *a, const void *b)
{
    const half_edge *x = a, *y = b;
    if (x->key != y->key)
        return (x->key > y->key) - (x->key < y->key);
    return (x->q > y->q) - (x->q < y->q);
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static uint32_t uf_find(uint32_t *parent, uint32_t q)
{
    uint32_t r = q;
    while (parent[r] != r)
        r = parent[r];
    while (parent[q] != r) { /* path compression */
        uint32_t up = parent[q];
        parent[q] = r;
        q = up;
    }
    return r;
}

/* Step 2: parent[] classes of corners joined through the twins; every
 * class's root is its lowest corner. */
static void tsv_sheet_classes(const uint32_t *next, const uint32_t *twin, size_t nidx,
                              uint32_t *parent)
{
    for (size_t q = 0; q < nidx; q++)
        parent[q] = (uint32_t)q;
    for (size_t q = 0; q < nidx; q++) {
        uint32_t a = uf_find(parent, (uint32_t)q), b = uf_find(parent, next[twin[q]]);
        if (a < b)
            parent[b] = a;
        else if (b < a)
            parent[a] = b;
    }
}

/* Does the four-face edge whose forward half-edges are f0, f1 join the
 * same two points twice? */
static int tsv_edge_doubled(uint32_t *parent, const uint32_t *next, uint32_t f0, uint32_t f1)
{
    return uf_find(parent, f0) == uf_find(parent, f1) &&
           uf_find(parent, next[f0]) == uf_find(parent, next[f1]);
}

/* Fills P->point_count, point_controls and face_points from P's faces. */
static ffd_status tsv_proxy_sheets(tsv_proxy *P, ffd_error *err)
{
    const size_t nf = P->face_count, nidx = nf ? P->face_offsets[nf] : 0;
    uint32_t *next = ffd_malloc_array(nidx ? nidx : 1, sizeof *next);
    uint32_t *twin = ffd_malloc_array(nidx ? nidx : 1, sizeof *twin);
    uint32_t *face = ffd_malloc_array(nidx ? nidx : 1, sizeof *face);
    uint32_t *parent = ffd_malloc_array(nidx ? nidx : 1, sizeof *parent);
    uint32_t *quad = ffd_malloc_array(nidx ? nidx : 1, sizeof *quad); /* 2 per four-face edge */
    half_edge *he = ffd_malloc_array(nidx ? nidx : 1, sizeof *he);
    P->face_points = ffd_malloc_array(nidx ? nidx : 1, sizeof *P->face_points);
    ffd_status st = FFD_OK;
    size_t nquad = 0;
    if (!next || !twin || !face || !parent || !quad || !he || !P->face_points) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory (proxy sheets)");
        goto done;
    }
    for (size_t f = 0; f < nf; f++) {
        uint32_t b0 = P->face_offsets[f], b1 = P->face_offsets[f + 1];
        for (uint32_t q = b0; q < b1; q++) {
            next[q] = q + 1 < b1 ? q + 1 : b0;
            face[q] = (uint32_t)f;
            uint64_t a = P->face_indices[q], b = P->face_indices[next[q]];
            he[q].key = a < b ? a << 32 | b : b << 32 | a;
            he[q].q = q;
        }
    }
    /* step 1: the twins */
    qsort(he, nidx, sizeof *he, cmp_half_edge);
    for (size_t g0 = 0; g0 < nidx;) {
        size_t g1 = g0 + 1;
        while (g1 < nidx && he[g1].key == he[g0].key)
            g1++;
        uint32_t lower = (uint32_t)(he[g0].key >> 32);
        uint32_t fwd[2], nfwd = 0;
        for (int pass = 0; pass < 2; pass++)
            for (size_t i = g0; i < g1; i++) {
                uint32_t qi = he[i].q;
                if (P->face_indices[qi] != lower || he[i].key == UINT64_MAX)
                    continue;
                for (size_t j = g0; j < g1; j++) {
                    uint32_t qj = he[j].q;
                    if (P->face_indices[qj] == lower || he[j].key == UINT64_MAX ||
                        (pass == 0 && P->face_cells[face[qi]] != P->face_cells[face[qj]]))
                        continue;
                    twin[qi] = qj;
                    twin[qj] = qi;
                    he[i].key = he[j].key = UINT64_MAX; /* paired (keys are < 2^64 - 1) */
                    if (nfwd < 2)
                        fwd[nfwd] = qi;
                    nfwd++;
                    break;
                }
            }
        for (size_t i = g0; i < g1; i++)
            if (he[i].key != UINT64_MAX) {
                uint32_t q = he[i].q;
                st = ffd_fail(err, FFD_ERR_INVALID,
                              "ffd_tsv_proxy_build: proxy edge (%u, %u) of face %u has no reverse "
                              "half-edge: the proxy is not closed",
                              (unsigned)P->face_indices[q], (unsigned)P->face_indices[next[q]],
                              (unsigned)face[q]);
                goto done;
            }
        if (nfwd == 2) {
            quad[2 * nquad] = fwd[0];
            quad[2 * nquad + 1] = fwd[1];
            nquad++;
        }
        g0 = g1;
    }
    /* steps 2 and 3 */
    tsv_sheet_classes(next, twin, nidx, parent);
    size_t flipped = 0;
    for (size_t k = 0; k < nquad; k++) {
        uint32_t f0 = quad[2 * k], f1 = quad[2 * k + 1];
        if (!tsv_edge_doubled(parent, next, f0, f1))
            continue;
        uint32_t b0 = twin[f0], b1 = twin[f1];
        twin[f0] = b1, twin[b1] = f0;
        twin[f1] = b0, twin[b0] = f1;
        flipped++;
    }
    if (flipped) {
        tsv_sheet_classes(next, twin, nidx, parent);
        for (size_t k = 0; k < nquad; k++)
            if (tsv_edge_doubled(parent, next, quad[2 * k], quad[2 * k + 1])) {
                uint32_t q = quad[2 * k];
                st = ffd_fail(err, FFD_ERR_INVALID,
                              "ffd_tsv_proxy_build: proxy edge (%u, %u) cannot be split into two "
                              "sheets",
                              (unsigned)P->face_indices[q], (unsigned)P->face_indices[next[q]]);
                goto done;
            }
    }
    /* one point per class: (control id, lowest corner), ascending */
    uint64_t *key = (uint64_t *)(void *)he; /* reused: sizeof(half_edge) >= sizeof(uint64_t) */
    size_t np = 0;
    for (size_t q = 0; q < nidx; q++)
        if (uf_find(parent, (uint32_t)q) == q)
            key[np++] = (uint64_t)P->face_indices[q] << 32 | q;
    qsort(key, np, sizeof *key, cmp_u64);
    P->point_controls = ffd_malloc_array(np ? np : 1, sizeof *P->point_controls);
    if (!P->point_controls) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory (proxy sheets)");
        goto done;
    }
    uint32_t *point_of_root = twin; /* reused: the twins are no longer needed */
    for (size_t k = 0; k < np; k++) {
        P->point_controls[k] = (uint32_t)(key[k] >> 32);
        point_of_root[key[k] & 0xffffffffu] = (uint32_t)k;
    }
    for (size_t q = 0; q < nidx; q++)
        P->face_points[q] = point_of_root[uf_find(parent, (uint32_t)q)];
    P->point_count = np;
done:
    ffd_free(next);
    ffd_free(twin);
    ffd_free(face);
    ffd_free(parent);
    ffd_free(quad);
    ffd_free(he);
    return st;
}

ffd_status ffd_tsv_proxy_build(tsv_lattice *L, const tsv_object *obj, tsv_proxy *proxy,
                           ffd_error *err)
{
    if (!L || !obj || !proxy || (obj->n > 0 && !obj->params) ||
        (obj->face_offsets && obj->face_count > 0 && !obj->face_indices))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_tsv_proxy_build: NULL argument");
    /* all or nothing: the cells' flags and *proxy change only on success */
    uint8_t *occ = ffd_malloc_array(L->nc ? L->nc : 1, 2);
    if (!occ)
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_proxy_build: out of memory");
    uint8_t *out = occ + L->nc;
    tsv_proxy P;
    memset(&P, 0, sizeof P);
    ffd_status st = tsv_occupancy(L, obj, occ, err);
    if (st == FFD_OK)
        st = tsv_flood_outside(L, occ, out, err);
    if (st == FFD_OK)
        st = tsv_proxy_faces(L, out, &P, err);
    if (st == FFD_OK)
        st = tsv_proxy_sheets(&P, err);
    if (st != FFD_OK) {
        ffd_tsv_proxy_free(&P);
        ffd_free(occ);
        return st;
    }
    for (size_t c = 0; c < L->nc; c++) {
        L->cells[c].occupied = occ[c];
        L->cells[c].outside = out[c];
        P.occupied_cells += occ[c] != 0;
        P.inside_cells += out[c] == 0;
    }
    ffd_free(occ);
    ffd_tsv_proxy_free(proxy);
    *proxy = P;
    return FFD_OK;
}

/* ---------------------------------------------------------------------
 * ARAP graph arrays (design §6)
 * --------------------------------------------------------------------- */

void ffd_tsv_arap_graph_free(tsv_arap_graph *g)
{
    if (!g)
        return;
    /* the arrays are owned by the graph (ffd_tsv_arap_graph_build) */
    ffd_free((void *)g->ref);
    ffd_free((void *)g->edges);
    ffd_free((void *)g->vol);
    ffd_free((void *)g->proxy_offsets);
    ffd_free((void *)g->proxy_indices);
    ffd_free((void *)g->proxy_uv);
    ffd_free((void *)g->proxy_points);
    ffd_free((void *)g->proxy_point_controls);
    memset(g, 0, sizeof *g);
}

/* Appends the undirected pair (i, j) as the key min << 32 | max. */
static int tsv_pair_push(uint64_t **keys, size_t *n, size_t *cap, uint32_t i, uint32_t j)
{
    if (i == j)
        return 1;
    if (*n >= *cap && !ffd_grow((void **)keys, cap, *n + 1, sizeof **keys))
        return 0;
    uint64_t lo = i < j ? i : j, hi = i < j ? j : i;
    (*keys)[(*n)++] = lo << 32 | hi;
    return 1;
}

/* The volumetric graph G_V (design §6 "Neighbourhoods"): lattice edges, all
 * corner pairs of each cell, and each hanging point of a cell's boundary
 * joined to the cell's corners; each undirected pair once, ascending,
 * zero-length pairs (coincident reference positions) dropped. */
static ffd_status tsv_vol_graph(const tsv_lattice *L, const double *ref, uint32_t **out,
                                size_t *count, ffd_error *err)
{
    uint64_t *keys = NULL;
    size_t n = 0, cap = 0;
    uint32_t *pts = NULL;
    if (!ffd_grow((void **)&keys, &cap, L->ne + 28 * L->nc + 1, sizeof *keys))
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_arap_graph_build: out of memory");
    for (size_t e = 0; e < L->ne; e++) /* cannot fail: capacity reserved */
        (void)tsv_pair_push(&keys, &n, &cap, L->edges[e].v0, L->edges[e].v1);
    for (size_t c = 0; c < L->nc; c++) {
        const tsv_cell *C = &L->cells[c];
        size_t m = 0;
        ffd_status st = ffd_tsv_cell_points(L, (uint32_t)c, &pts, &m, err);
        if (st != FFD_OK) {
            ffd_free(keys);
            return st;
        }
        uint32_t corner[8];
        int nk = 0;
        for (size_t i = 0; i < m; i++) {
            const double *sg = L->verts[pts[i]].sg;
            int is_corner = 1;
            for (int a = 0; a < 3; a++)
                is_corner &= sg[a] == C->lo[a] || sg[a] == C->hi[a];
            if (is_corner && nk < 8)
                corner[nk++] = pts[i];
        }
        int ok = 1;
        for (int i = 0; i < nk && ok; i++)
            for (int j = i + 1; j < nk && ok; j++)
                ok = tsv_pair_push(&keys, &n, &cap, corner[i], corner[j]);
        for (size_t i = 0; i < m && ok; i++) {
            int is_corner = 0;
            for (int j = 0; j < nk; j++)
                is_corner |= corner[j] == pts[i];
            for (int j = 0; j < nk && ok && !is_corner; j++)
                ok = tsv_pair_push(&keys, &n, &cap, pts[i], corner[j]);
        }
        ffd_free(pts);
        pts = NULL;
        if (!ok) {
            ffd_free(keys);
            return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_arap_graph_build: out of memory");
        }
    }
    /* bucket the pairs by their lower end, then sort each short bucket: each
     * pair once, ascending (i, j) */
    const size_t nv = L->nv;
    size_t *start = ffd_calloc(nv + 1, sizeof *start);
    uint32_t *col = ffd_malloc_array(n ? n : 1, sizeof *col);
    uint32_t *vol = ffd_malloc_array(n ? n : 1, 2 * sizeof *vol);
    if (!start || !col || !vol) {
        ffd_free(keys);
        ffd_free(start);
        ffd_free(col);
        ffd_free(vol);
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_arap_graph_build: out of memory");
    }
    for (size_t q = 0; q < n; q++)
        start[(keys[q] >> 32) + 1]++;
    for (size_t v = 0; v < nv; v++)
        start[v + 1] += start[v];
    for (size_t q = 0; q < n; q++)
        col[start[keys[q] >> 32]++] = (uint32_t)(keys[q] & 0xffffffffu);
    memmove(start + 1, start, nv * sizeof *start);
    start[0] = 0;
    ffd_free(keys);
    size_t k = 0;
    for (size_t i = 0; i < nv; i++) {
        uint32_t *b = col + start[i];
        size_t m = start[i + 1] - start[i];
        for (size_t x = 1; x < m; x++) { /* insertion sort: buckets hold a few dozen */
            uint32_t t = b[x];
            size_t y = x;
            for (; y > 0 && b[y - 1] > t; y--)
                b[y] = b[y - 1];
            b[y] = t;
        }
        const double *p = ref + 3 * i;
        for (size_t x = 0; x < m; x++) {
            if (x > 0 && b[x] == b[x - 1])
                continue;
            const double *r = ref + 3 * (size_t)b[x];
            if (p[0] == r[0] && p[1] == r[1] && p[2] == r[2])
                continue; /* coincident reference positions: zero length */
            vol[2 * k] = (uint32_t)i;
            vol[2 * k + 1] = b[x];
            k++;
        }
    }
    ffd_free(start);
    ffd_free(col);
    uint32_t *shrunk = ffd_realloc(vol, (k ? k : 1) * 2 * sizeof *vol);
    *out = shrunk ? shrunk : vol;
    *count = k;
    return FFD_OK;
}

ffd_status ffd_tsv_arap_graph_build(const tsv_lattice *L, const tsv_proxy *proxy,
                                tsv_arap_graph *g, ffd_error *err)
{
    if (!L || !proxy || !g)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_tsv_arap_graph_build: NULL argument");
    memset(g, 0, sizeof *g);
    const size_t nv = L->nv, ne = L->ne, nfp = proxy->face_count;
    const size_t nidx = nfp ? proxy->face_offsets[nfp] : 0;
    for (size_t f = 0; f < nfp; f++)
        if (proxy->lattice_face[f] >= L->nf)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_tsv_arap_graph_build: proxy face %zu: lattice face %u: there are "
                            "%zu faces (stale proxy)",
                            f, (unsigned)proxy->lattice_face[f], L->nf);
    for (size_t q = 0; q < nidx; q++)
        if (proxy->face_indices[q] >= nv)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_tsv_arap_graph_build: proxy point %u: there are %zu lattice points "
                            "(stale proxy)",
                            (unsigned)proxy->face_indices[q], nv);
    double *ref = ffd_malloc_array(nv ? nv : 1, 3 * sizeof *ref);
    uint32_t *edges = ffd_malloc_array(ne ? ne : 1, 2 * sizeof *edges);
    uint32_t *poff = ffd_malloc_array(nfp + 1, sizeof *poff);
    uint32_t *pidx = ffd_malloc_array(nidx ? nidx : 1, sizeof *pidx);
    double *uv = ffd_malloc_array(nidx ? nidx : 1, 2 * sizeof *uv);
    /* the manifold proxy's points (one E_M row each), when the proxy has them */
    const int sheets = proxy->face_points != NULL && proxy->point_controls != NULL;
    const size_t npt = sheets ? proxy->point_count : 0;
    uint32_t *ppts = sheets ? ffd_malloc_array(nidx ? nidx : 1, sizeof *ppts) : NULL;
    uint32_t *pctl = sheets ? ffd_malloc_array(npt ? npt : 1, sizeof *pctl) : NULL;
    uint32_t *vol = NULL;
    size_t nvol = 0;
    ffd_status st = FFD_OK;
    if (!ref || !edges || !poff || !pidx || !uv || (sheets && (!ppts || !pctl))) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "ffd_tsv_arap_graph_build: out of memory");
        goto fail;
    }
    /* the reference positions p (design §6) */
    for (size_t v = 0; v < nv; v++)
        memcpy(ref + 3 * v, L->verts[v].P[TSV_REFERENCE], 3 * sizeof *ref);
    /* N_L: every lattice edge once (lower end first) */
    for (size_t e = 0; e < ne; e++) {
        edges[2 * e] = L->edges[e].v0;
        edges[2 * e + 1] = L->edges[e].v1;
    }
    st = tsv_vol_graph(L, ref, &vol, &nvol, err);
    if (st != FFD_OK)
        goto fail;
    /* E_M: the proxy polygons with their in-plane gamma coordinates; each uv
     * polygon is made counter-clockwise (positive area) in index order by
     * swapping to (gamma_b, gamma_a) where (gamma_a, gamma_b) is clockwise */
    poff[0] = 0;
    for (size_t f = 0; f < nfp; f++) {
        uint32_t b0 = proxy->face_offsets[f], b1 = proxy->face_offsets[f + 1];
        poff[f + 1] = b1;
        int a, b;
        tsv_plane_axes(L->faces[proxy->lattice_face[f]].normal, &a, &b);
        double area = 0.0;
        for (uint32_t q = b0; q < b1; q++) {
            uint32_t v = proxy->face_indices[q];
            pidx[q] = v;
            uv[2 * q] = ffd_tsv_gamma(L, a, L->verts[v].sg[a]);
            uv[2 * q + 1] = ffd_tsv_gamma(L, b, L->verts[v].sg[b]);
        }
        for (uint32_t q = b0; q < b1; q++) {
            uint32_t r = q + 1 < b1 ? q + 1 : b0;
            area += uv[2 * q] * uv[2 * r + 1] - uv[2 * r] * uv[2 * q + 1];
        }
        if (area < 0.0)
            for (uint32_t q = b0; q < b1; q++) {
                double t = uv[2 * q];
                uv[2 * q] = uv[2 * q + 1];
                uv[2 * q + 1] = t;
            }
    }
    g->n = nv;
    g->ref = ref;
    g->edges = edges;
    g->edge_count = ne;
    g->vol = vol;
    g->vol_count = nvol;
    g->proxy_offsets = poff;
    g->proxy_indices = pidx;
    g->proxy_face_count = nfp;
    g->proxy_uv = uv;
    if (sheets) {
        memcpy(ppts, proxy->face_points, nidx * sizeof *ppts);
        memcpy(pctl, proxy->point_controls, npt * sizeof *pctl);
        g->proxy_points = ppts;
        g->proxy_point_controls = pctl;
        g->proxy_point_count = npt;
    }
    return FFD_OK;
fail:
    ffd_free(ppts);
    ffd_free(pctl);
    ffd_free(ref);
    ffd_free(edges);
    ffd_free(poff);
    ffd_free(pidx);
    ffd_free(uv);
    ffd_free(vol);
    return st;
}
