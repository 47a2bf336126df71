/* gffd — where a primitive's distance field is sampled (§2, Fig. 1; the
 * rules are documented in ffd.h above ffd_gffd_tracking), with the exact
 * (signed for a polyhedron) distance at every sample.
 *
 * Shells at r/3, 2r/3, r and 4r/3 around
 *   POINT       the point: 6 axes and 8 cube diagonals;
 *   POLYLINE    stations at the vertices and evenly along each segment, at
 *               most r/2 apart: 6 directions, 60 degrees apart, in the plane
 *               normal to the curve (at an interior vertex the plane that
 *               bisects the two segments; at a 180-degree reversal the plane
 *               normal to the incoming segment); at each end, the outward
 *               tangent and the 4 directions at 45 degrees to it towards
 *               the in-plane axes;
 *   PATCH       stations at the vertices (those of some triangle) and at the
 *               centroid of every triangle whose longest edge exceeds r/2:
 *               both normal directions (the angle-weighted vertex normal, so
 *               that it does not depend on how a polygon was triangulated;
 *               the triangle's normal at a centroid); at boundary vertices
 *               also the outward direction in the tangent plane (the sum of
 *               the adjacent boundary edges' outward in-plane normals,
 *               projected into the vertex's tangent plane);
 *   POLYHEDRON  as PATCH; a closed mesh has no boundary.
 * Samples within 1e-12 x the geometry's bounding-box diagonal of an earlier
 * one are dropped (the first is kept). */
#include "gffd/gffd.h"

#include <assert.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#define MERGE_REL 1e-12

/* A polyline whose samples before merging exceed this many times the limit
 * is refused before they are generated (merging could not bring them under). */
#define RAW_FACTOR 8
/* Without a limit (max_samples == 0), more than this is out of memory. */
#define RAW_MAX 1e9

#define SHELLS 4

typedef struct sbuf {
    double *p; /* n by 3 */
    size_t n, cap;
} sbuf;




/* Normalises v in place; returns its length before (0: left unchanged). */
static double normalize3(double v[3])
{
    double l = sqrt(dot3(v, v));
    if (l > 0) {
        v[0] /= l;
        v[1] /= l;
        v[2] /= l;
    }
    return l;
}

static bool push(sbuf *b, const double c[3], const double dir[3], double s)
{
    if (b->n == b->cap && !ffd_grow((void **)&b->p, &b->cap, b->n + 1, 3 * sizeof(double)))
        return false;
    double *q = b->p + 3 * b->n++;
    for (int k = 0; k < 3; k++)
        q[k] = dir ? c[k] + s * dir[k] : c[k];
    return true;
}

/* A unit basis (u, v) of the plane normal to the unit vector n. */
static void plane_basis(const double n[3], double u[3], double v[3])
{
    int k = 0;
    if (fabs(n[1]) < fabs(n[k]))
        k = 1;
    if (fabs(n[2]) < fabs(n[k]))
        k = 2;
    double e[3] = {0, 0, 0};
    e[k] = 1;
    cross3(n, e, u);
    normalize3(u);
    cross3(n, u, v);
    normalize3(v);
}

/* ---- POINT --------------------------------------------------------------- */

static bool sample_point(const ffd_gffd_geometry *g, const double shell[SHELLS], sbuf *b)
{
    const double a = 1 / sqrt(3.0);
    const double dirs[14][3] = {
        {1, 0, 0},  {-1, 0, 0}, {0, 1, 0},   {0, -1, 0},  {0, 0, 1},   {0, 0, -1},
        {a, a, a},  {a, a, -a}, {a, -a, a},  {a, -a, -a}, {-a, a, a},  {-a, a, -a},
        {-a, -a, a}, {-a, -a, -a},
    };
    if (!push(b, g->vertices, NULL, 0))
        return false;
    for (int s = 0; s < SHELLS; s++)
        for (int d = 0; d < 14; d++)
            if (!push(b, g->vertices, dirs[d], shell[s]))
                return false;
    return true;
}

/* ---- POLYLINE ------------------------------------------------------------ */

/* Subdivisions of a segment of length len so that stations are at most
 * r/2 apart (a hair of slack so that len = k r/2 gives k, not k + 1). */
static double segment_pieces(double len, double r)
{
    double k = ceil(len / (0.5 * r) * (1 - 1e-12));
    return k < 1 ? 1 : k;
}

/* The station and 6 directions per shell in the plane normal to n. */
static bool ring(sbuf *b, const double c[3], const double n[3], const double shell[SHELLS])
{
    static const double cs[6][2] = {
        {1, 0}, {0.5, 0.86602540378443865}, {-0.5, 0.86602540378443865},
        {-1, 0}, {-0.5, -0.86602540378443865}, {0.5, -0.86602540378443865},
    };
    double u[3], v[3];
    plane_basis(n, u, v);
    if (!push(b, c, NULL, 0))
        return false;
    for (int s = 0; s < SHELLS; s++)
        for (int k = 0; k < 6; k++) {
            double d[3];
            for (int i = 0; i < 3; i++)
                d[i] = cs[k][0] * u[i] + cs[k][1] * v[i];
            if (!push(b, c, d, shell[s]))
                return false;
        }
    return true;
}

/* An end cap: the outward tangent o and 4 directions at 45 degrees to it
 * (towards +-u, +-v of the end's normal plane), per shell. */
static bool cap(sbuf *b, const double c[3], const double o[3], const double shell[SHELLS])
{
    const double h = 1 / sqrt(2.0);
    double u[3], v[3], d[5][3];
    plane_basis(o, u, v);
    for (int i = 0; i < 3; i++) {
        d[0][i] = o[i];
        d[1][i] = h * (o[i] + u[i]);
        d[2][i] = h * (o[i] - u[i]);
        d[3][i] = h * (o[i] + v[i]);
        d[4][i] = h * (o[i] - v[i]);
    }
    for (int s = 0; s < SHELLS; s++)
        for (int k = 0; k < 5; k++)
            if (!push(b, c, d[k], shell[s]))
                return false;
    return true;
}

static bool sample_polyline(const ffd_gffd_geometry *g, const double shell[SHELLS], sbuf *b)
{
    size_t nv = g->vertex_count;
    const double *V = g->vertices;
    assert(nv >= 2);
    double tprev[3] = {0, 0, 0};
    for (size_t i = 0; i < nv; i++) {
        double t[3] = {0, 0, 0}, len = 0, n[3];
        if (i + 1 < nv) {
            sub3(V + 3 * i + 3, V + 3 * i, t);
            len = normalize3(t);
            assert(len > 0);
        }
        if (i == 0) {
            memcpy(n, t, sizeof n);
        } else if (i + 1 == nv) {
            memcpy(n, tprev, sizeof n);
        } else {
            for (int k = 0; k < 3; k++)
                n[k] = tprev[k] + t[k];
            if (!(normalize3(n) > 1e-8)) /* reversal: the plane normal to the incoming segment */
                memcpy(n, tprev, sizeof n);
        }
        if (!ring(b, V + 3 * i, n, shell))
            return false;
        if (i == 0) {
            double o[3] = {-t[0], -t[1], -t[2]};
            if (!cap(b, V, o, shell))
                return false;
        }
        if (i + 1 == nv) {
            if (!cap(b, V + 3 * i, tprev, shell))
                return false;
            break;
        }
        double pieces = segment_pieces(len, g->radius);
        for (double k = 1; k < pieces; k++) {
            double c[3], f = k / pieces;
            for (int j = 0; j < 3; j++)
                c[j] = V[3 * i + j] + f * (V[3 * i + 3 + j] - V[3 * i + j]);
            if (!ring(b, c, t, shell))
                return false;
        }
        memcpy(tprev, t, sizeof tprev);
    }
    return true;
}

/* Samples of a polyline before merging (as a double: it may be huge). */
static double polyline_raw_count(const ffd_gffd_geometry *g)
{
    double stations = 1;
    for (size_t i = 0; i + 1 < g->vertex_count; i++) {
        double d[3];
        sub3(g->vertices + 3 * i + 3, g->vertices + 3 * i, d);
        stations += segment_pieces(sqrt(dot3(d, d)), g->radius);
    }
    return stations * (1 + 6 * SHELLS) + 2 * 5 * SHELLS;
}

/* ---- PATCH, POLYHEDRON ----------------------------------------------------- */

typedef struct edge_rec {
    uint32_t a, b; /* a < b */
    uint32_t tri;
    uint32_t third; /* the triangle's other vertex */
} edge_rec;

static int edge_cmp(const void *pa, const void *pb)
{
    const edge_rec *x = pa, *y = pb;
    if (x->a != y->a)
        return x->a < y->a ? -1 : 1;
    if (x->b != y->b)
        return x->b < y->b ? -1 : 1;
    return x->tri < y->tri ? -1 : x->tri > y->tri;
}

static const double *vtx(const ffd_gffd_geometry *g, uint32_t i)
{
    return g->vertices + 3 * (size_t)i;
}

/* normals: vertex_count by 3 (angle-weighted, unit; zero for vertices of
 * no triangle); outward: vertex_count by 3 (unit outward boundary
 * direction in the tangent plane; zero elsewhere), or NULL to skip. */
static bool mesh_directions(const ffd_gffd_geometry *g, double *normals, double *outward)
{
    size_t nv = g->vertex_count, nt = g->tri_count;
    double *best = ffd_calloc(nv, sizeof *best); /* largest adjacent triangle (fallback) */
    double *fallback = ffd_calloc(3 * nv, sizeof *fallback);
    double *anglesum = ffd_calloc(nv, sizeof *anglesum);
    if (!best || !fallback || !anglesum) {
        ffd_free(best);
        ffd_free(fallback);
        ffd_free(anglesum);
        return false;
    }
    memset(normals, 0, 3 * nv * sizeof *normals);
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *tri = g->tris + 3 * t;
        double e1[3], e2[3], n[3];
        sub3(vtx(g, tri[1]), vtx(g, tri[0]), e1);
        sub3(vtx(g, tri[2]), vtx(g, tri[0]), e2);
        cross3(e1, e2, n);
        double area2 = normalize3(n);
        for (int k = 0; k < 3; k++) {
            uint32_t i = tri[k];
            double a[3], c[3], x[3];
            sub3(vtx(g, tri[(k + 1) % 3]), vtx(g, i), a);
            sub3(vtx(g, tri[(k + 2) % 3]), vtx(g, i), c);
            cross3(a, c, x);
            double angle = atan2(sqrt(dot3(x, x)), dot3(a, c));
            for (int j = 0; j < 3; j++)
                normals[3 * i + j] += angle * n[j];
            anglesum[i] += angle;
            if (area2 > best[i]) {
                best[i] = area2;
                memcpy(fallback + 3 * i, n, 3 * sizeof *n);
            }
        }
    }
    for (size_t i = 0; i < nv; i++) {
        double *n = normals + 3 * i;
        /* normals cancelling (a fold): the largest adjacent triangle's */
        if (!(normalize3(n) > 1e-9 * anglesum[i]))
            memcpy(n, fallback + 3 * i, 3 * sizeof *n);
    }
    ffd_free(best);
    ffd_free(fallback);
    ffd_free(anglesum);
    if (!outward)
        return true;

    /* boundary edges: in exactly one triangle */
    memset(outward, 0, 3 * nv * sizeof *outward);
    edge_rec *e = ffd_malloc_array(3 * nt, sizeof *e);
    if (!e)
        return false;
    for (size_t t = 0; t < nt; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = g->tris[3 * t + k], b = g->tris[3 * t + (k + 1) % 3];
            edge_rec *r = e + 3 * t + k;
            r->a = a < b ? a : b;
            r->b = a < b ? b : a;
            r->tri = (uint32_t)t;
            r->third = g->tris[3 * t + (k + 2) % 3];
        }
    qsort(e, 3 * nt, sizeof *e, edge_cmp);
    for (size_t i = 0; i < 3 * nt;) {
        size_t j = i + 1;
        while (j < 3 * nt && e[j].a == e[i].a && e[j].b == e[i].b)
            j++;
        if (j == i + 1) {
            /* outward normal of the edge in its triangle's plane */
            double d[3], w[3];
            sub3(vtx(g, e[i].b), vtx(g, e[i].a), d);
            normalize3(d);
            sub3(vtx(g, e[i].a), vtx(g, e[i].third), w);
            double h = dot3(w, d);
            for (int k = 0; k < 3; k++)
                w[k] -= h * d[k];
            normalize3(w);
            for (int k = 0; k < 3; k++) {
                outward[3 * (size_t)e[i].a + k] += w[k];
                outward[3 * (size_t)e[i].b + k] += w[k];
            }
        }
        i = j;
    }
    ffd_free(e);
    for (size_t i = 0; i < nv; i++) {
        double *o = outward + 3 * i, *n = normals + 3 * i;
        double h = dot3(o, n);
        for (int k = 0; k < 3; k++)
            o[k] -= h * n[k];
        /* no outward direction (no boundary edge, or a boundary folded back) */
        if (!(normalize3(o) > 1e-9))
            o[0] = o[1] = o[2] = 0;
    }
    return true;
}

static bool sample_mesh(const ffd_gffd_geometry *g, const double shell[SHELLS], sbuf *b)
{
    size_t nv = g->vertex_count, nt = g->tri_count;
    int boundary = g->kind == FFD_GFFD_PATCH;
    double *normals = ffd_malloc_array(3 * nv, sizeof *normals);
    double *outward = boundary ? ffd_malloc_array(3 * nv, sizeof *outward) : NULL;
    bool ok = normals && (!boundary || outward) && mesh_directions(g, normals, outward);
    unsigned char *used = ok ? ffd_calloc(nv, 1) : NULL;
    ok = ok && used;
    for (size_t t = 0; ok && t < 3 * nt; t++)
        used[g->tris[t]] = 1;
    for (size_t i = 0; ok && i < nv; i++) {
        if (!used[i])
            continue; /* not on the surface */
        const double *c = vtx(g, (uint32_t)i), *n = normals + 3 * i;
        double m[3] = {-n[0], -n[1], -n[2]};
        ok = push(b, c, NULL, 0);
        for (int s = 0; ok && s < SHELLS; s++)
            ok = push(b, c, n, shell[s]) && push(b, c, m, shell[s]);
        if (boundary) {
            const double *o = outward + 3 * i;
            if (dot3(o, o) > 0)
                for (int s = 0; ok && s < SHELLS; s++)
                    ok = push(b, c, o, shell[s]);
        }
    }
    double wide2 = 0.25 * g->radius * g->radius;
    for (size_t t = 0; ok && t < nt; t++) {
        const uint32_t *tri = g->tris + 3 * t;
        const double *p0 = vtx(g, tri[0]), *p1 = vtx(g, tri[1]), *p2 = vtx(g, tri[2]);
        double e0[3], e1[3], e2[3];
        sub3(p1, p0, e0);
        sub3(p2, p1, e1);
        sub3(p0, p2, e2);
        double l = dot3(e0, e0);
        l = dot3(e1, e1) > l ? dot3(e1, e1) : l;
        l = dot3(e2, e2) > l ? dot3(e2, e2) : l;
        if (!(l > wide2))
            continue;
        double n[3], m[3], c[3];
        cross3(e0, e1, n);
        normalize3(n);
        for (int k = 0; k < 3; k++) {
            c[k] = (p0[k] + p1[k] + p2[k]) / 3;
            m[k] = -n[k];
        }
        ok = push(b, c, NULL, 0);
        for (int s = 0; ok && s < SHELLS; s++)
            ok = push(b, c, n, shell[s]) && push(b, c, m, shell[s]);
    }
    ffd_free(normals);
    ffd_free(outward);
    ffd_free(used);
    return ok;
}

/* ---- merging --------------------------------------------------------------- */

typedef struct keyed {
    double key;
    size_t index;
} keyed;

static int keyed_cmp(const void *pa, const void *pb)
{
    const keyed *x = pa, *y = pb;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->index < y->index ? -1 : x->index > y->index;
}

/* Drops every sample within tol of an earlier kept one; compacts b. */
static bool merge(sbuf *b, double tol)
{
    size_t n = b->n;
    /* sorted along an oblique direction: |key_i - key_j| <= |p_i - p_j| */
    static const double dir[3] = {0.52106572871208200, 0.61588044574040060,
                                  0.59093656389452450};
    keyed *order = ffd_malloc_array(n, sizeof *order);
    size_t *pos = ffd_malloc_array(n, sizeof *pos);
    unsigned char *keep = ffd_malloc_array(n, 1);
    if (!order || !pos || !keep) {
        ffd_free(order);
        ffd_free(pos);
        ffd_free(keep);
        return false;
    }
    for (size_t i = 0; i < n; i++) {
        order[i].key = dot3(b->p + 3 * i, dir);
        order[i].index = i;
    }
    qsort(order, n, sizeof *order, keyed_cmp);
    for (size_t q = 0; q < n; q++)
        pos[order[q].index] = q;
    double tol2 = tol * tol;
    for (size_t i = 0; i < n; i++) {
        const double *p = b->p + 3 * i;
        double key = order[pos[i]].key;
        int k = 1;
        for (size_t q = pos[i]; k && q-- > 0 && key - order[q].key <= tol;) {
            size_t j = order[q].index;
            double d[3];
            sub3(p, b->p + 3 * j, d);
            if (j < i && keep[j] && dot3(d, d) <= tol2)
                k = 0;
        }
        for (size_t q = pos[i] + 1; k && q < n && order[q].key - key <= tol; q++) {
            size_t j = order[q].index;
            double d[3];
            sub3(p, b->p + 3 * j, d);
            if (j < i && keep[j] && dot3(d, d) <= tol2)
                k = 0;
        }
        keep[i] = (unsigned char)k;
    }
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (keep[i]) {
            if (m != i)
                memmove(b->p + 3 * m, b->p + 3 * i, 3 * sizeof(double));
            m++;
        }
    b->n = m;
    ffd_free(order);
    ffd_free(pos);
    ffd_free(keep);
    return true;
}

/* ---- entry ------------------------------------------------------------------ */

ffd_status ffd_gffd_samples(const ffd_gffd_geometry *g, size_t max_samples, double **samples,
                            double **values, size_t *count, ffd_error *err)
{
    *samples = NULL;
    *values = NULL;
    *count = 0;
    assert(g->vertex_count >= 1 && g->radius > 0);
    double r = g->radius;
    const double shell[SHELLS] = {r / 3, 2 * r / 3, r, 4 * r / 3};
    if (g->kind == FFD_GFFD_POLYLINE) {
        double raw = polyline_raw_count(g);
        if (max_samples > 0 && raw > (double)RAW_FACTOR * (double)max_samples)
            return ffd_fail(err, FFD_ERR_INVALID, "%.0f samples exceed max_samples (%zu)", raw,
                            max_samples);
        if (!(raw <= RAW_MAX))
            return ffd_fail(err, FFD_ERR_NOMEM, "%.0f samples: too many", raw);
    }
    sbuf b = {NULL, 0, 0};
    bool ok;
    switch (g->kind) {
    case FFD_GFFD_POINT:
        ok = sample_point(g, shell, &b);
        break;
    case FFD_GFFD_POLYLINE:
        ok = sample_polyline(g, shell, &b);
        break;
    case FFD_GFFD_PATCH:
    case FFD_GFFD_POLYHEDRON:
        ok = sample_mesh(g, shell, &b);
        break;
    default:
        assert(!"unknown primitive kind");
        ok = false;
    }
    /* the geometry's bounding-box diagonal sets the merging tolerance */
    double lo[3], hi[3];
    for (int k = 0; k < 3; k++)
        lo[k] = hi[k] = g->vertices[k];
    for (size_t i = 1; i < g->vertex_count; i++)
        for (int k = 0; k < 3; k++) {
            double v = g->vertices[3 * i + k];
            lo[k] = v < lo[k] ? v : lo[k];
            hi[k] = v > hi[k] ? v : hi[k];
        }
    double diag[3];
    sub3(hi, lo, diag);
    ok = ok && merge(&b, MERGE_REL * sqrt(dot3(diag, diag)));
    if (!ok) {
        ffd_free(b.p);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the field samples");
    }
    if (max_samples > 0 && b.n > max_samples) {
        ffd_free(b.p);
        return ffd_fail(err, FFD_ERR_INVALID, "%zu samples exceed max_samples (%zu)", b.n,
                        max_samples);
    }
    double *v = ffd_malloc_array(b.n, sizeof *v);
    if (!v) {
        ffd_free(b.p);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the field samples");
    }
    long long n = (long long)b.n;
    /* distances cost O(triangles) each: parallel when that adds up */
    int parallel = (double)b.n * (double)(g->tri_count + g->vertex_count) > 1e6;
    (void)parallel;
#pragma omp parallel for schedule(dynamic, 16) if (parallel)
    for (long long i = 0; i < n; i++)
        v[i] = ffd_gffd_geometry_distance(g, b.p + 3 * i);
    *samples = b.p;
    *values = v;
    *count = b.n;
    return FFD_OK;
}
