/* cage — the cage deformer (include/ffd_cage.h): the cage and its checks
 * (closed, manifold, consistently oriented, non-degenerate), binding points
 * to their mean value (Ju et al. 2005) or harmonic (Joshi et al. 2007)
 * coordinates, the evaluation x' = x + sum_j w_j (v_j - v0_j) and the
 * binding as a linear map (dense rows over the cage's vertices). */
#include "cage/cage.h"
#include "math/tolerance.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

struct ffd_cage_binding {
    size_t n, nv;
    double *points;    /* n by 3, at rest */
    double *weights;   /* n by nv */
    uint8_t *inside;   /* n */
    uint8_t *zero;     /* n: 1 when the row is all zero (a fixed outside point) */
    size_t inside_count;
};

/* ---- the cage's checks ---- */

typedef struct half_edge {
    uint32_t lo, hi; /* the edge's vertices, lo < hi */
    uint32_t he;     /* 3 t + c: from corner c of triangle t to corner c + 1 */
} half_edge;

static int half_edge_cmp(const void *pa, const void *pb)
{
    const half_edge *a = pa, *b = pb;
    if (a->lo != b->lo)
        return a->lo < b->lo ? -1 : 1;
    if (a->hi != b->hi)
        return a->hi < b->hi ? -1 : 1;
    return a->he < b->he ? -1 : a->he > b->he;
}

#define FACE(t) (face_of ? face_of[t] : (uint32_t)(t))

/* Closed and edge-manifold (every edge on exactly two triangles), oriented
 * consistently (the two run it in opposite directions), every vertex's
 * triangles one fan; twin[he] receives each half-edge's opposite. */
static ffd_status check_edges(const uint32_t *tri, size_t nt, size_t nv, const uint32_t *face_of,
                              uint32_t *twin, ffd_error *err)
{
    size_t nh = 3 * nt;
    half_edge *h = ffd_malloc_array(nh, sizeof *h);
    uint32_t *fan = ffd_calloc(nv, sizeof *fan);
    ffd_status st = FFD_OK;
    if (!h || !fan) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "cage: out of memory for %zu triangles", nt);
        goto done;
    }
    for (size_t e = 0; e < nh; e++) {
        uint32_t a = tri[e], b = tri[e - e % 3 + (e % 3 + 1) % 3];
        h[e].lo = a < b ? a : b;
        h[e].hi = a < b ? b : a;
        h[e].he = (uint32_t)e;
    }
    qsort(h, nh, sizeof *h, half_edge_cmp);
    for (size_t e = 0; e < nh;) {
        size_t g = e + 1;
        while (g < nh && h[g].lo == h[e].lo && h[g].hi == h[e].hi)
            g++;
        uint32_t t0 = h[e].he / 3;
        if (g - e == 1) {
            st = ffd_fail(err, FFD_ERR_INVALID,
                          "cage: edge (%u, %u) of face %u is on no other face: the cage is not "
                          "closed", h[e].lo, h[e].hi, FACE(t0));
            goto done;
        }
        if (g - e > 2) {
            st = ffd_fail(err, FFD_ERR_INVALID,
                          "cage: edge (%u, %u) is on %zu faces (%u, %u, %u, ...): the cage is "
                          "not manifold", h[e].lo, h[e].hi, g - e, FACE(t0),
                          FACE(h[e + 1].he / 3), FACE(h[e + 2].he / 3));
            goto done;
        }
        uint32_t a = h[e].he, b = h[e + 1].he;
        if (tri[a] == tri[b]) {
            st = ffd_fail(err, FFD_ERR_INVALID,
                          "cage: edge (%u, %u): faces %u and %u run it in the same direction: "
                          "the cage is not consistently oriented", h[e].lo, h[e].hi, FACE(a / 3),
                          FACE(b / 3));
            goto done;
        }
        twin[a] = b;
        twin[b] = a;
        e = g;
    }
    /* every vertex on one fan: the triangles met walking around it from one
     * of them are all its triangles */
    for (size_t e = 0; e < nh; e++)
        fan[tri[e]]++;
    for (size_t v = 0; v < nv; v++)
        if (!fan[v]) {
            st = ffd_fail(err, FFD_ERR_INVALID, "cage: vertex %zu is on no face", v);
            goto done;
        }
    for (size_t e = 0; e < nh; e++) {
        uint32_t v = tri[e];
        if (fan[v] == UINT32_MAX)
            continue; /* walked already */
        size_t steps = 0;
        uint32_t he = (uint32_t)e; /* leaves v */
        do {
            uint32_t into = he - he % 3 + (he % 3 + 2) % 3; /* the half-edge entering v */
            he = twin[into];
            steps++;
        } while (he != e && steps <= nh);
        if (steps != fan[v]) {
            st = ffd_fail(err, FFD_ERR_INVALID,
                          "cage: vertex %u: its %u faces do not form one fan (the cage touches "
                          "itself there): the cage is not manifold", v, fan[v]);
            goto done;
        }
        fan[v] = UINT32_MAX;
    }
done:
    ffd_free(h);
    ffd_free(fan);
    return st;
}

ffd_status ffd_cage_create(const double *vertices, size_t nv, const uint32_t *triangles,
                           size_t nt, const uint32_t *face_of, const ffd_cage_options *options,
                           ffd_cage **out, ffd_error *err)
{
    ffd_cage_options opt = {0};
    if (options)
        opt = *options;
    *out = NULL;
    if (!vertices || !triangles || nv < 4 || nt < 4)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "cage: %zu vertices and %zu triangles: a closed cage needs at least 4 "
                        "of each", nv, nt);
    if (nv > UINT32_MAX || nt > UINT32_MAX / 3)
        return ffd_fail(err, FFD_ERR_INVALID, "cage: too large");
    uint32_t res = opt.resolution ? opt.resolution : FFD_CAGE_RESOLUTION_DEFAULT;
    if (opt.coordinates == FFD_CAGE_HARMONIC &&
        (res < 4 || res > FFD_CAGE_RESOLUTION_MAX))
        return ffd_fail(err, FFD_ERR_INVALID, "cage: resolution %u out of range (4 to %u)", res,
                        FFD_CAGE_RESOLUTION_MAX);
    if (opt.coordinates == FFD_CAGE_HARMONIC && opt.outside == FFD_CAGE_OUTSIDE_EXTEND)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "cage: harmonic coordinates are not defined outside the cage: outside "
                        "\"fixed\" or \"clamp\"");
    for (size_t i = 0; i < 3 * nv; i++)
        if (!isfinite(vertices[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "cage: vertex %zu is not finite", i / 3);
    for (size_t i = 0; i < 3 * nt; i++)
        if (triangles[i] >= nv)
            return ffd_fail(err, FFD_ERR_RANGE,
                            "cage: face %u: vertex index %u out of range (%zu vertices)",
                            FACE(i / 3), triangles[i], nv);

    ffd_cage *c = ffd_calloc(1, sizeof *c);
    uint32_t *twin = ffd_malloc_array(3 * nt, sizeof *twin);
    if (!c || !twin) {
        ffd_free(c);
        ffd_free(twin);
        return ffd_fail(err, FFD_ERR_NOMEM, "cage: out of memory");
    }
    ffd_status st = FFD_OK;
    c->nv = nv;
    c->nt = nt;
    c->kind = opt.coordinates;
    c->outside = opt.outside ? opt.outside
                             : opt.coordinates == FFD_CAGE_HARMONIC ? FFD_CAGE_OUTSIDE_FIXED
                                                                    : FFD_CAGE_OUTSIDE_EXTEND;
    c->rest = ffd_malloc_array(nv, 3 * sizeof(double));
    c->current = ffd_malloc_array(nv, 3 * sizeof(double));
    c->tri = ffd_malloc_array(nt, 3 * sizeof(uint32_t));
    if (!c->rest || !c->current || !c->tri) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "cage: out of memory");
        goto fail;
    }
    memcpy(c->rest, vertices, nv * 3 * sizeof(double));
    memcpy(c->current, vertices, nv * 3 * sizeof(double));
    memcpy(c->tri, triangles, nt * 3 * sizeof(uint32_t));
    for (int a = 0; a < 3; a++) {
        c->lo[a] = INFINITY;
        c->hi[a] = -INFINITY;
    }
    for (size_t i = 0; i < nv; i++)
        for (int a = 0; a < 3; a++) {
            c->lo[a] = fmin(c->lo[a], vertices[3 * i + a]);
            c->hi[a] = fmax(c->hi[a], vertices[3 * i + a]);
        }
    double d2 = 0;
    for (int a = 0; a < 3; a++)
        d2 += (c->hi[a] - c->lo[a]) * (c->hi[a] - c->lo[a]);
    c->diag = sqrt(d2);
    /* degenerate triangles: a repeated vertex or (almost) no area */
    double volume = 0;
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *ix = c->tri + 3 * t;
        const double *p = c->rest + 3 * (size_t)ix[0], *q = c->rest + 3 * (size_t)ix[1],
                     *r = c->rest + 3 * (size_t)ix[2];
        double e1[3], e2[3], n[3];
        for (int a = 0; a < 3; a++) {
            e1[a] = q[a] - p[a];
            e2[a] = r[a] - p[a];
        }
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double area = 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (ix[0] == ix[1] || ix[1] == ix[2] || ix[0] == ix[2] ||
            !(area > FFD_TOL_CAGE_AREA * d2)) {
            st = ffd_fail(err, FFD_ERR_INVALID,
                          "cage: face %u: degenerate triangle (%u, %u, %u) of area %.3g",
                          FACE(t), ix[0], ix[1], ix[2], area);
            goto fail;
        }
        volume += (p[0] * n[0] + p[1] * n[1] + p[2] * n[2]) / 6.0;
    }
    if ((st = check_edges(c->tri, nt, nv, face_of, twin, err)))
        goto fail;
    if (!(fabs(volume) > FFD_TOL_CAGE_AREA * d2 * c->diag)) {
        st = ffd_fail(err, FFD_ERR_INVALID, "cage: encloses no volume (%.3g)", volume);
        goto fail;
    }
    if (volume < 0) /* inward: turn it outwards */
        for (size_t t = 0; t < nt; t++) {
            uint32_t s = c->tri[3 * t + 1];
            c->tri[3 * t + 1] = c->tri[3 * t + 2];
            c->tri[3 * t + 2] = s;
        }
    if ((st = ffd_inside_index_create(c->rest, nv, c->tri, nt, &c->inside, err)))
        goto fail;
    if (c->kind == FFD_CAGE_HARMONIC && (st = ffd_cage_harmonic_solve(c, res, err)))
        goto fail;
    ffd_free(twin);
    *out = c;
    return FFD_OK;
fail:
    ffd_free(twin);
    ffd_cage_destroy(c);
    return st;
}

void ffd_cage_destroy(ffd_cage *cage)
{
    if (!cage)
        return;
    ffd_inside_index_destroy(cage->inside);
    ffd_cage_grid_free(cage->grid);
    ffd_free(cage->rest);
    ffd_free(cage->current);
    ffd_free(cage->tri);
    ffd_free(cage);
}

size_t ffd_cage_vertex_count(const ffd_cage *cage)
{
    return cage->nv;
}

size_t ffd_cage_triangle_count(const ffd_cage *cage)
{
    return cage->nt;
}

const uint32_t *ffd_cage_triangles(const ffd_cage *cage)
{
    return cage->tri;
}

const double *ffd_cage_rest_vertices(const ffd_cage *cage)
{
    return cage->rest;
}

const double *ffd_cage_vertices(const ffd_cage *cage)
{
    return cage->current;
}

ffd_cage_coordinates ffd_cage_coordinate_kind(const ffd_cage *cage)
{
    return cage->kind;
}

ffd_cage_outside ffd_cage_outside_rule(const ffd_cage *cage)
{
    return cage->outside;
}

ffd_status ffd_cage_set_vertices(ffd_cage *cage, const double *vertices, ffd_error *err)
{
    for (size_t i = 0; i < 3 * cage->nv; i++)
        if (!isfinite(vertices[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "cage: vertex %zu is not finite", i / 3);
    memcpy(cage->current, vertices, cage->nv * 3 * sizeof(double));
    return FFD_OK;
}

ffd_status ffd_cage_move(ffd_cage *cage, uint32_t index, const double delta[3], ffd_error *err)
{
    if (index >= cage->nv)
        return ffd_fail(err, FFD_ERR_RANGE, "cage: vertex %u out of range (%zu vertices)", index,
                        cage->nv);
    double v[3];
    for (int a = 0; a < 3; a++) {
        v[a] = cage->current[3 * (size_t)index + a] + delta[a];
        if (!isfinite(v[a]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "cage: vertex %u: moved to a non-finite "
                            "position", index);
    }
    memcpy(cage->current + 3 * (size_t)index, v, sizeof v);
    return FFD_OK;
}

void ffd_cage_reset(ffd_cage *cage)
{
    memcpy(cage->current, cage->rest, cage->nv * 3 * sizeof(double));
}

/* ---- binding ---- */

/* Point x's row w (nv) under the cage's coordinates and outside rule;
 * returns 1 when x is inside the cage or on it. */
static int bind_point(const ffd_cage *c, const double x[3], double *w, double *scratch)
{
    const double on_cage = FFD_TOL_CAGE_VERTEX * c->diag;
    if (c->kind == FFD_CAGE_MEAN_VALUE) {
        if (c->outside == FFD_CAGE_OUTSIDE_EXTEND) {
            int on = ffd_cage_mean_value(c, x, w, scratch);
            return on || ffd_inside_index_test(c->inside, x);
        }
        if (ffd_inside_index_test(c->inside, x)) {
            ffd_cage_mean_value(c, x, w, scratch);
            return 1;
        }
    } else {
        int all_inside;
        int valued = ffd_cage_harmonic_weights(c, x, w, &all_inside);
        if (valued && all_inside)
            return 1;
        /* near the cage: on it, the hat functions; else the parity decides */
        if (valued && ffd_inside_index_test(c->inside, x)) {
            if (ffd_cage_hat(c, x, scratch) <= on_cage * on_cage)
                memcpy(w, scratch, c->nv * sizeof *w);
            return 1;
        }
    }
    double d2 = ffd_cage_hat(c, x, w);
    if (d2 <= on_cage * on_cage)
        return 1;
    if (c->outside == FFD_CAGE_OUTSIDE_FIXED)
        memset(w, 0, c->nv * sizeof *w);
    return 0;
}

ffd_status ffd_cage_bind(const ffd_cage *cage, const double *points, size_t n,
                         ffd_cage_binding **out, ffd_error *err)
{
    const size_t nv = cage->nv;
    *out = NULL;
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(points[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "cage: point %zu is not finite", i / 3);
    ffd_cage_binding *b = ffd_calloc(1, sizeof *b);
    if (!b)
        return ffd_fail(err, FFD_ERR_NOMEM, "cage: out of memory");
    b->n = n;
    b->nv = nv;
    b->points = ffd_malloc_array(n ? n : 1, 3 * sizeof(double));
    b->weights = ffd_malloc_array(n ? n : 1, nv * sizeof(double));
    b->inside = ffd_calloc(n ? n : 1, 1);
    b->zero = ffd_calloc(n ? n : 1, 1);
    if (!b->points || !b->weights || !b->inside || !b->zero) {
        ffd_cage_binding_destroy(b);
        return ffd_fail(err, FFD_ERR_NOMEM, "cage: out of memory for the coordinates of %zu "
                        "points over %zu cage vertices", n, nv);
    }
    if (n)
        memcpy(b->points, points, n * 3 * sizeof(double));
    int nomem = 0;
#pragma omp parallel
    {
        double *scratch = ffd_malloc_array(nv, 4 * sizeof(double));
        if (!scratch) {
#pragma omp atomic write
            nomem = 1;
        }
#pragma omp for schedule(dynamic, 256)
        for (long long i = 0; i < (long long)n; i++) {
            if (!scratch)
                continue;
            double *w = b->weights + (size_t)i * nv;
            b->inside[i] = (uint8_t)bind_point(cage, points + 3 * i, w, scratch);
            int zero = 1;
            for (size_t j = 0; j < nv && zero; j++)
                zero = w[j] == 0;
            b->zero[i] = (uint8_t)zero;
        }
        ffd_free(scratch);
    }
    if (nomem) {
        ffd_cage_binding_destroy(b);
        return ffd_fail(err, FFD_ERR_NOMEM, "cage: out of memory");
    }
    for (size_t i = 0; i < n; i++)
        b->inside_count += b->inside[i];
    *out = b;
    return FFD_OK;
}

void ffd_cage_binding_destroy(ffd_cage_binding *binding)
{
    if (!binding)
        return;
    ffd_free(binding->points);
    ffd_free(binding->weights);
    ffd_free(binding->inside);
    ffd_free(binding->zero);
    ffd_free(binding);
}

size_t ffd_cage_binding_count(const ffd_cage_binding *binding)
{
    return binding->n;
}

size_t ffd_cage_binding_inside_count(const ffd_cage_binding *binding)
{
    return binding->inside_count;
}

const double *ffd_cage_binding_weights(const ffd_cage_binding *binding, size_t i)
{
    return i < binding->n ? binding->weights + i * binding->nv : NULL;
}

/* ---- evaluation ---- */

ffd_status ffd_cage_eval(const ffd_cage *cage, const ffd_cage_binding *binding, double *out,
                         ffd_error *err)
{
    const size_t nv = cage->nv, n = binding->n;
    if (binding->nv != nv)
        return ffd_fail(err, FFD_ERR_INVALID, "cage: the binding is for %zu cage vertices, the "
                        "cage has %zu", binding->nv, nv);
    uint32_t *moved = ffd_malloc_array(nv, sizeof *moved);
    double *dv = ffd_malloc_array(nv, 3 * sizeof *dv);
    if (!moved || !dv) {
        ffd_free(moved);
        ffd_free(dv);
        return ffd_fail(err, FFD_ERR_NOMEM, "cage: out of memory");
    }
    size_t k = 0; /* only the moved vertices are added: a cage at rest is the identity */
    for (size_t j = 0; j < nv; j++) {
        const double *p = cage->current + 3 * j, *q = cage->rest + 3 * j;
        if (p[0] == q[0] && p[1] == q[1] && p[2] == q[2])
            continue;
        for (int a = 0; a < 3; a++)
            dv[3 * k + a] = p[a] - q[a];
        moved[k++] = (uint32_t)j;
    }
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < (long long)n; i++) {
        const double *x = binding->points + 3 * i, *w = binding->weights + (size_t)i * nv;
        double d[3] = {0, 0, 0};
        int any = 0;
        for (size_t m = 0; m < k && !binding->zero[i]; m++) {
            double wj = w[moved[m]];
            if (wj == 0)
                continue;
            any = 1;
            for (int a = 0; a < 3; a++)
                d[a] += wj * dv[3 * m + a];
        }
        for (int a = 0; a < 3; a++)
            out[3 * i + a] = any ? x[a] + d[a] : x[a];
    }
    ffd_free(moved);
    ffd_free(dv);
    return FFD_OK;
}

/* ---- the linear map: dense rows over the cage's vertices ---- */

static size_t cage_row(const void *self, size_t i, uint32_t *columns, double *weights)
{
    const ffd_cage_binding *b = self;
    if (b->zero[i])
        return 0;
    for (size_t j = 0; j < b->nv; j++) {
        columns[j] = (uint32_t)j;
        weights[j] = b->weights[i * b->nv + j];
    }
    return b->nv;
}

void ffd_cage_linear_map(const ffd_cage *cage, const ffd_cage_binding *binding,
                         ffd_linear_map *map)
{
    (void)cage;
    map->self = binding;
    map->point_count = binding->n;
    map->column_count = binding->nv;
    map->variable_count = binding->nv;
    map->max_row_nnz = binding->nv;
    map->tie = NULL;
    map->row = cage_row;
}
