/* math — k-d tree for nearest-neighbour queries.
 *
 * An implicit, balanced tree: the points are permuted so that every range
 * [lo, hi) longer than a leaf keeps its median along the range's widest axis
 * at mid = lo + (hi - lo) / 2, smaller coordinates before it and larger after.
 * No nodes are stored beyond that axis per median slot. Queries descend the
 * near side first and visit the far side while its splitting plane is not
 * farther than the current k-th best (ties included, so that equal distances
 * resolve to the lower original index whatever the tree shape). */
#include "math/spatial.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

enum { LEAF_SIZE = 8 };

struct ffd_kdtree {
    size_t n;
    double *p;       /* n by 3, permuted */
    size_t *id;      /* original index of each slot */
    unsigned char *axis; /* splitting axis of the median slot of each range */
};

static void swap_slots(ffd_kdtree *t, size_t a, size_t b)
{
    double tmp[3];
    memcpy(tmp, t->p + 3 * a, sizeof tmp);
    memcpy(t->p + 3 * a, t->p + 3 * b, sizeof tmp);
    memcpy(t->p + 3 * b, tmp, sizeof tmp);
    size_t ti = t->id[a];
    t->id[a] = t->id[b];
    t->id[b] = ti;
}

/* Orders [lo, hi) along axis d so that slot nth holds the value it would have
 * if sorted, smaller-or-equal before it and greater-or-equal after (Hoare
 * partition around a median-of-three; deterministic). */
static void select_nth(ffd_kdtree *t, size_t lo, size_t hi, size_t nth, int d)
{
    while (hi - lo > 2) {
        size_t mid = lo + (hi - lo) / 2;
        double a = t->p[3 * lo + d], b = t->p[3 * mid + d], c = t->p[3 * (hi - 1) + d];
        double pivot = a < b ? (b < c ? b : (a < c ? c : a)) : (a < c ? a : (b < c ? c : b));
        size_t i = lo, j = hi - 1;
        for (;;) {
            while (t->p[3 * i + d] < pivot)
                i++;
            while (t->p[3 * j + d] > pivot)
                j--;
            if (i >= j)
                break;
            swap_slots(t, i, j);
            i++;
            j--;
        }
        /* now [lo, j] <= pivot <= [j+1, hi) */
        if (nth <= j)
            hi = j + 1;
        else
            lo = j + 1;
    }
    if (hi - lo == 2 && t->p[3 * lo + d] > t->p[3 * (lo + 1) + d])
        swap_slots(t, lo, lo + 1);
}

static void build(ffd_kdtree *t, size_t lo, size_t hi)
{
    while (hi - lo > LEAF_SIZE) {
        double mn[3], mx[3];
        for (int c = 0; c < 3; c++)
            mn[c] = mx[c] = t->p[3 * lo + c];
        for (size_t i = lo + 1; i < hi; i++)
            for (int c = 0; c < 3; c++) {
                double v = t->p[3 * i + c];
                if (v < mn[c])
                    mn[c] = v;
                if (v > mx[c])
                    mx[c] = v;
            }
        int d = 0;
        for (int c = 1; c < 3; c++)
            if (mx[c] - mn[c] > mx[d] - mn[d])
                d = c;
        size_t mid = lo + (hi - lo) / 2;
        select_nth(t, lo, hi, mid, d);
        t->axis[mid] = (unsigned char)d;
        build(t, lo, mid);
        lo = mid + 1; /* the right half iteratively */
    }
}

ffd_status ffd_kdtree_create(const double *points, size_t n, ffd_kdtree **out, ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_kdtree_create: NULL argument");
    *out = NULL;
    if (n && !points)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_kdtree_create: NULL points");
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(points[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "k-d tree: point %zu is not finite", i / 3);
    ffd_kdtree *t = ffd_calloc(1, sizeof *t);
    if (!t)
        return ffd_fail(err, FFD_ERR_NOMEM, "k-d tree: out of memory");
    t->n = n;
    t->p = ffd_malloc_array(n ? 3 * n : 1, sizeof *t->p);
    t->id = ffd_malloc_array(n ? n : 1, sizeof *t->id);
    t->axis = ffd_calloc(n ? n : 1, 1);
    if (!t->p || !t->id || !t->axis) {
        ffd_kdtree_destroy(t);
        return ffd_fail(err, FFD_ERR_NOMEM, "k-d tree of %zu points: out of memory", n);
    }
    if (n)
        memcpy(t->p, points, 3 * n * sizeof *t->p);
    for (size_t i = 0; i < n; i++)
        t->id[i] = i;
    build(t, 0, n);
    *out = t;
    return FFD_OK;
}

void ffd_kdtree_destroy(ffd_kdtree *tree)
{
    if (!tree)
        return;
    ffd_free(tree->p);
    ffd_free(tree->id);
    ffd_free(tree->axis);
    ffd_free(tree);
}

size_t ffd_kdtree_count(const ffd_kdtree *tree)
{
    return tree ? tree->n : 0;
}

/* ---- queries -------------------------------------------------------------- */

typedef struct query {
    const double *q;
    double min_d2; /* points at squared distance <= min_d2 are skipped (-1: none) */
    size_t k, found;
    size_t *id;    /* k best, closest first */
    double *d2;
} query;

/* a before b: closer, or as close with a lower index */
static int better(double da, size_t ia, double db, size_t ib)
{
    return da < db || (da == db && ia < ib);
}

static void offer(query *s, double d, size_t id)
{
    if (!(d > s->min_d2))
        return;
    if (s->found == s->k && !better(d, id, s->d2[s->k - 1], s->id[s->k - 1]))
        return;
    size_t pos = s->found < s->k ? s->found++ : s->k - 1;
    while (pos > 0 && better(d, id, s->d2[pos - 1], s->id[pos - 1])) {
        s->d2[pos] = s->d2[pos - 1];
        s->id[pos] = s->id[pos - 1];
        pos--;
    }
    s->d2[pos] = d;
    s->id[pos] = id;
}

static double slot_d2(const ffd_kdtree *t, size_t i, const double *q)
{
    double dx = t->p[3 * i] - q[0], dy = t->p[3 * i + 1] - q[1], dz = t->p[3 * i + 2] - q[2];
    return dx * dx + dy * dy + dz * dz;
}

static void search(const ffd_kdtree *t, size_t lo, size_t hi, query *s)
{
    while (hi - lo > LEAF_SIZE) {
        size_t mid = lo + (hi - lo) / 2;
        int d = t->axis[mid];
        double diff = s->q[d] - t->p[3 * mid + d];
        offer(s, slot_d2(t, mid, s->q), t->id[mid]);
        size_t nlo = lo, nhi = mid, flo = mid + 1, fhi = hi;
        if (diff >= 0) {
            nlo = mid + 1;
            nhi = hi;
            flo = lo;
            fhi = mid;
        }
        search(t, nlo, nhi, s);
        if (s->found == s->k && diff * diff > s->d2[s->k - 1])
            return;
        lo = flo;
        hi = fhi;
    }
    for (size_t i = lo; i < hi; i++)
        offer(s, slot_d2(t, i, s->q), t->id[i]);
}

static size_t run_query(const ffd_kdtree *t, const double q[3], double min_d2, size_t k,
                        size_t *index, double *dist2)
{
    if (!t || t->n == 0 || k == 0)
        return 0;
    query s = {q, min_d2, k, 0, index, dist2};
    search(t, 0, t->n, &s);
    return s.found;
}

size_t ffd_kdtree_nearest(const ffd_kdtree *tree, const double q[3], double *dist2)
{
    size_t id = SIZE_MAX;
    double d = INFINITY;
    run_query(tree, q, -1.0, 1, &id, &d);
    if (dist2)
        *dist2 = d;
    return id;
}

size_t ffd_kdtree_nearest_distinct(const ffd_kdtree *tree, const double q[3], double *dist2)
{
    size_t id = SIZE_MAX;
    double d = INFINITY;
    run_query(tree, q, 0.0, 1, &id, &d);
    if (dist2)
        *dist2 = d;
    return id;
}

size_t ffd_kdtree_k_nearest(const ffd_kdtree *tree, const double q[3], size_t k, size_t *index,
                            double *dist2)
{
    if (!tree || tree->n == 0 || k == 0)
        return 0;
    if (k > tree->n)
        k = tree->n;
    if (dist2)
        return run_query(tree, q, -1.0, k, index, dist2);
    /* distances are needed internally */
    double small[16];
    double *d = k <= 16 ? small : ffd_malloc_array(k, sizeof *d);
    if (!d)
        return 0;
    size_t found = run_query(tree, q, -1.0, k, index, d);
    if (d != small)
        ffd_free(d);
    return found;
}

/* ---- point-in-solid by ray parity -------------------------------------------- */

struct ffd_inside_index {
    const double *x;   /* borrowed positions */
    uint32_t *tri;     /* nt by 3 */
    size_t g[2];       /* grid cells along x and y */
    double lo[2], cell[2];
    size_t *start;     /* g[0]*g[1]+1 offsets into items */
    uint32_t *items;   /* triangle indices, by cell */
};

static size_t cell_of(const ffd_inside_index *ix, int a, double v)
{
    double f = (v - ix->lo[a]) / ix->cell[a];
    if (!(f > 0))
        return 0;
    if (f >= (double)ix->g[a])
        return ix->g[a] - 1;
    return (size_t)f;
}

static void tri_cells(const ffd_inside_index *ix, size_t t, size_t c0[2], size_t c1[2])
{
    for (int a = 0; a < 2; a++) {
        double mn = INFINITY, mx = -INFINITY;
        for (int k = 0; k < 3; k++) {
            double v = ix->x[3 * (size_t)ix->tri[3 * t + k] + a];
            mn = fmin(mn, v);
            mx = fmax(mx, v);
        }
        c0[a] = cell_of(ix, a, mn);
        c1[a] = cell_of(ix, a, mx);
    }
}

ffd_status ffd_inside_index_create(const double *positions, size_t nv, const uint32_t *triangles,
                                   size_t nt, ffd_inside_index **out, ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_inside_index_create: NULL argument");
    *out = NULL;
    if ((nt && !triangles) || (nv && !positions))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_inside_index_create: NULL argument");
    for (size_t i = 0; i < 3 * nt; i++)
        if (triangles[i] >= nv)
            return ffd_fail(err, FFD_ERR_RANGE, "inside index: triangle %zu: vertex %u of %zu",
                            i / 3, triangles[i], nv);
    ffd_inside_index *ix = ffd_calloc(1, sizeof *ix);
    if (!ix)
        return ffd_fail(err, FFD_ERR_NOMEM, "inside index: out of memory");
    ix->x = positions;
    ix->tri = ffd_malloc_array(nt ? 3 * nt : 1, sizeof *ix->tri);
    if (!ix->tri)
        goto nomem;
    if (nt)
        memcpy(ix->tri, triangles, 3 * nt * sizeof *ix->tri);
    /* about two triangles per cell over the xy extent of the triangles */
    double mn[2] = {INFINITY, INFINITY}, mx[2] = {-INFINITY, -INFINITY};
    for (size_t i = 0; i < 3 * nt; i++)
        for (int a = 0; a < 2; a++) {
            mn[a] = fmin(mn[a], positions[3 * (size_t)triangles[i] + a]);
            mx[a] = fmax(mx[a], positions[3 * (size_t)triangles[i] + a]);
        }
    size_t side = (size_t)sqrt((double)nt / 2.0);
    if (side < 1)
        side = 1;
    if (side > 1024)
        side = 1024;
    for (int a = 0; a < 2; a++) {
        ix->g[a] = side;
        ix->lo[a] = nt ? mn[a] : 0;
        double ext = nt ? mx[a] - mn[a] : 0;
        ix->cell[a] = ext > 0 ? ext / (double)side : 1.0;
    }
    size_t cells = ix->g[0] * ix->g[1];
    ix->start = ffd_calloc(cells + 1, sizeof *ix->start);
    if (!ix->start)
        goto nomem;
    for (size_t t = 0; t < nt; t++) {
        size_t c0[2], c1[2];
        tri_cells(ix, t, c0, c1);
        for (size_t i = c0[0]; i <= c1[0]; i++)
            for (size_t j = c0[1]; j <= c1[1]; j++)
                ix->start[i * ix->g[1] + j + 1]++;
    }
    for (size_t c = 0; c < cells; c++)
        ix->start[c + 1] += ix->start[c];
    ix->items = ffd_malloc_array(ix->start[cells] ? ix->start[cells] : 1, sizeof *ix->items);
    size_t *fill = ffd_malloc_array(cells, sizeof *fill);
    if (!ix->items || !fill) {
        ffd_free(fill);
        goto nomem;
    }
    memcpy(fill, ix->start, cells * sizeof *fill);
    for (size_t t = 0; t < nt; t++) {
        size_t c0[2], c1[2];
        tri_cells(ix, t, c0, c1);
        for (size_t i = c0[0]; i <= c1[0]; i++)
            for (size_t j = c0[1]; j <= c1[1]; j++)
                ix->items[fill[i * ix->g[1] + j]++] = (uint32_t)t;
    }
    ffd_free(fill);
    *out = ix;
    return FFD_OK;
nomem:
    ffd_inside_index_destroy(ix);
    return ffd_fail(err, FFD_ERR_NOMEM, "inside index of %zu triangles: out of memory", nt);
}

void ffd_inside_index_destroy(ffd_inside_index *index)
{
    if (!index)
        return;
    ffd_free(index->tri);
    ffd_free(index->start);
    ffd_free(index->items);
    ffd_free(index);
}

/* Side of q (in xy) of the directed edge u -> v: +1 left, -1 right. The
 * determinant is always evaluated from the lower index to the higher, so
 * the two triangles sharing an edge see exactly opposite answers; zero
 * counts as left of the canonical direction. */
static int edge_side(const double *x, uint32_t u, uint32_t v, const double *q)
{
    uint32_t a = u < v ? u : v, b = u < v ? v : u;
    const double *pa = x + 3 * (size_t)a, *pb = x + 3 * (size_t)b;
    double o = (pb[0] - pa[0]) * (q[1] - pa[1]) - (pb[1] - pa[1]) * (q[0] - pa[0]);
    /* q on the edge's line: decided as for q moved by (eps, eps^2), the
     * same move for every edge (simulation of simplicity), so a ray through
     * a vertex or an edge crosses exactly one of the triangles around it */
    if (o == 0)
        o = pb[1] != pa[1] ? -(pb[1] - pa[1]) : pb[0] - pa[0];
    int s = o >= 0 ? 1 : -1;
    return u < v ? s : -s;
}

int ffd_inside_index_test(const ffd_inside_index *index, const double q[3])
{
    const ffd_inside_index *ix = index;
    if (!ix || !ix->start[ix->g[0] * ix->g[1]])
        return 0;
    double f0 = (q[0] - ix->lo[0]) / ix->cell[0], f1 = (q[1] - ix->lo[1]) / ix->cell[1];
    if (!(f0 >= 0) || !(f1 >= 0) || f0 > (double)ix->g[0] || f1 > (double)ix->g[1])
        return 0; /* outside the xy extent: the ray meets nothing */
    size_t c = cell_of(ix, 0, q[0]) * ix->g[1] + cell_of(ix, 1, q[1]);
    int crossings = 0;
    for (size_t k = ix->start[c]; k < ix->start[c + 1]; k++) {
        const uint32_t *t = ix->tri + 3 * (size_t)ix->items[k];
        const double *a = ix->x + 3 * (size_t)t[0], *b = ix->x + 3 * (size_t)t[1],
                     *d = ix->x + 3 * (size_t)t[2];
        double area = (b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0]);
        if (area == 0)
            continue; /* vertical: its neighbours carry the crossing */
        int want = area > 0 ? 1 : -1;
        if (edge_side(ix->x, t[0], t[1], q) != want || edge_side(ix->x, t[1], t[2], q) != want ||
            edge_side(ix->x, t[2], t[0], q) != want)
            continue;
        /* height of the triangle's plane above q */
        double l1 = ((q[0] - a[0]) * (d[1] - a[1]) - (q[1] - a[1]) * (d[0] - a[0])) / area;
        double l2 = ((b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0])) / area;
        double z = a[2] + l1 * (b[2] - a[2]) + l2 * (d[2] - a[2]);
        if (z > q[2])
            crossings++;
    }
    return crossings & 1;
}
