/* gffd_resample.c — adaptive resampling of the embedded mesh (Qin et al.
 * 2003, §4, Fig. 6): edges stretched by the deformation get midpoints whose
 * field value is the average of their ends', cells are re-polygonised, and
 * the new points are tracked too, until no edge qualifies. */
#include "gffd/gffd.h"
#include "mesh/mesh.h"

#include <math.h>
#include <string.h>

#define NO_VERTEX UINT32_MAX

ffd_status ffd_gffd_track_with(const ffd_gffd *g, const double *points, const double *e0,
                               const double *weight, size_t n, double *out,
                               ffd_gffd_track_report *report, ffd_error *err);

/* ---- an edge table: undirected edge -> reference length, midpoint ---- */

typedef struct edge_slot {
    uint64_t key;  /* (min << 32 | max) + 1; 0 = empty */
    double ref;    /* reference length */
    uint32_t mid;  /* midpoint made this round, or NO_VERTEX */
} edge_slot;

typedef struct edge_table {
    edge_slot *slots;
    size_t cap, count; /* cap a power of two */
} edge_table;

static uint64_t edge_key(uint32_t a, uint32_t b)
{
    uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
    return (((uint64_t)lo << 32) | hi) + 1;
}

static size_t edge_hash(uint64_t k, size_t cap)
{
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdULL;
    k ^= k >> 33;
    return (size_t)k & (cap - 1);
}

static edge_slot *edge_find(const edge_table *t, uint32_t a, uint32_t b)
{
    uint64_t k = edge_key(a, b);
    for (size_t i = edge_hash(k, t->cap);; i = (i + 1) & (t->cap - 1)) {
        if (t->slots[i].key == k)
            return &t->slots[i];
        if (t->slots[i].key == 0)
            return NULL;
    }
}

static bool edge_reserve(edge_table *t, size_t need)
{
    if ((need + 1) * 2 <= t->cap)
        return true;
    size_t cap = t->cap ? t->cap : 64;
    while ((need + 1) * 2 > cap) {
        if (cap > SIZE_MAX / 4)
            return false;
        cap *= 2;
    }
    edge_slot *s = ffd_calloc(cap, sizeof *s);
    if (!s)
        return false;
    for (size_t i = 0; i < t->cap; i++)
        if (t->slots[i].key) {
            size_t j = edge_hash(t->slots[i].key, cap);
            while (s[j].key)
                j = (j + 1) & (cap - 1);
            s[j] = t->slots[i];
        }
    ffd_free(t->slots);
    t->slots = s;
    t->cap = cap;
    return true;
}

/* Inserts the edge if absent (reserve first). */
static edge_slot *edge_put(edge_table *t, uint32_t a, uint32_t b, double ref)
{
    uint64_t k = edge_key(a, b);
    size_t i = edge_hash(k, t->cap);
    while (t->slots[i].key && t->slots[i].key != k)
        i = (i + 1) & (t->cap - 1);
    if (!t->slots[i].key) {
        t->slots[i].key = k;
        t->slots[i].ref = ref;
        t->slots[i].mid = NO_VERTEX;
        t->count++;
    }
    return &t->slots[i];
}

/* ---- growing arrays ---- */

typedef struct state {
    /* vertices: rest positions, deformed positions, field values, blend weights */
    size_t nv, cap_v;
    double *rest, *def, *value, *weight;
    /* new vertices of the plan */
    size_t nnew, cap_new;
    ffd_refine_vertex *newv;
    /* faces: offsets, indices, parent, reference length */
    size_t nf, cap_f, ni, cap_i;
    uint32_t *off, *idx, *parent;
    double *fref;
    edge_table edges;
} state;

static bool grow_vertices(state *s, size_t need)
{
    size_t cap = s->cap_v;
    if (!ffd_grow((void **)&s->rest, &cap, need, 3 * sizeof(double)))
        return false;
    cap = s->cap_v;
    if (!ffd_grow((void **)&s->def, &cap, need, 3 * sizeof(double)))
        return false;
    cap = s->cap_v;
    if (!ffd_grow((void **)&s->value, &cap, need, sizeof(double)))
        return false;
    cap = s->cap_v;
    if (!ffd_grow((void **)&s->weight, &cap, need, sizeof(double)))
        return false;
    s->cap_v = cap;
    return true;
}

static void state_free(state *s)
{
    ffd_free(s->rest);
    ffd_free(s->def);
    ffd_free(s->value);
    ffd_free(s->weight);
    ffd_free(s->newv);
    ffd_free(s->off);
    ffd_free(s->idx);
    ffd_free(s->parent);
    ffd_free(s->fref);
    ffd_free(s->edges.slots);
}

static double dist3(const double *a, const double *b)
{
    double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return sqrt(d0 * d0 + d1 * d1 + d2 * d2);
}

/* A new vertex: the average of parents (1/k each); rest position and field value alike. */
static uint32_t new_vertex(state *s, const uint32_t *parents, uint32_t k)
{
    size_t cap = s->cap_new;
    if (!ffd_grow((void **)&s->newv, &cap, s->nnew + 1, sizeof *s->newv))
        return NO_VERTEX;
    s->cap_new = cap;
    if (!grow_vertices(s, s->nv + 1))
        return NO_VERTEX;
    ffd_refine_vertex *v = &s->newv[s->nnew++];
    memset(v, 0, sizeof *v);
    v->parent_count = k;
    uint32_t m = (uint32_t)s->nv++;
    double *r = s->rest + 3 * (size_t)m;
    r[0] = r[1] = r[2] = 0;
    s->value[m] = 0;
    s->weight[m] = 0;
    for (uint32_t j = 0; j < k; j++) {
        v->parent[j] = parents[j];
        v->weight[j] = 1.0 / k;
        for (int c = 0; c < 3; c++)
            r[c] += s->rest[3 * (size_t)parents[j] + c] / k;
        s->value[m] += s->value[parents[j]] / k; /* Fig. 6: d = average of the ends */
        s->weight[m] += s->weight[parents[j]] / k; /* and so the band's weight */
    }
    return m;
}

/* Output faces of one round. */
typedef struct faces {
    size_t nf, cap_f, ni, cap_i;
    uint32_t *off, *idx, *parent;
    double *fref;
} faces;

static void faces_free(faces *o)
{
    ffd_free(o->off);
    ffd_free(o->idx);
    ffd_free(o->parent);
    ffd_free(o->fref);
}

static bool emit(faces *o, const uint32_t *v, uint32_t k, uint32_t parent, double ref)
{
    size_t c = o->cap_f;
    if (!ffd_grow((void **)&o->off, &c, o->nf + 2, sizeof(uint32_t)))
        return false;
    c = o->cap_f;
    if (!ffd_grow((void **)&o->parent, &c, o->nf + 2, sizeof(uint32_t)))
        return false;
    c = o->cap_f;
    if (!ffd_grow((void **)&o->fref, &c, o->nf + 2, sizeof(double)))
        return false;
    o->cap_f = c;
    if (!ffd_grow((void **)&o->idx, &o->cap_i, o->ni + k, sizeof(uint32_t)) ||
        o->ni + k > UINT32_MAX)
        return false;
    if (o->nf == 0)
        o->off[0] = 0;
    memcpy(o->idx + o->ni, v, k * sizeof(uint32_t));
    o->ni += k;
    o->parent[o->nf] = parent;
    o->fref[o->nf] = ref;
    o->off[++o->nf] = (uint32_t)o->ni;
    return true;
}

/* Re-polygonises one cell (Fig. 6 "repolygonize the current cell"). v: its
 * k corners, m[j] the midpoint of edge (v[j], v[j+1]) or NO_VERTEX. */
static bool split_cell(state *s, faces *o, const uint32_t *v, uint32_t k, const uint32_t *m,
                       uint32_t parent, double ref)
{
    uint32_t splits = 0;
    for (uint32_t j = 0; j < k; j++)
        splits += m[j] != NO_VERTEX;
    if (splits == 0)
        return emit(o, v, k, parent, ref);
    if (k == 3) {
        if (splits == 3) {
            uint32_t t0[3] = {v[0], m[0], m[2]}, t1[3] = {m[0], v[1], m[1]},
                     t2[3] = {m[2], m[1], v[2]}, t3[3] = {m[0], m[1], m[2]};
            return emit(o, t0, 3, parent, ref) && emit(o, t1, 3, parent, ref) &&
                   emit(o, t2, 3, parent, ref) && emit(o, t3, 3, parent, ref);
        }
        /* rotate so that edge 0 is split, and (for two splits) edge 1 too */
        uint32_t r = 0;
        if (splits == 1)
            while (m[r] == NO_VERTEX)
                r++;
        else
            while (!(m[r] != NO_VERTEX && m[(r + 1) % 3] != NO_VERTEX))
                r++;
        uint32_t a = v[r], b = v[(r + 1) % 3], c = v[(r + 2) % 3];
        uint32_t mab = m[r], mbc = m[(r + 1) % 3];
        if (splits == 1) {
            uint32_t t0[3] = {a, mab, c}, t1[3] = {mab, b, c};
            return emit(o, t0, 3, parent, ref) && emit(o, t1, 3, parent, ref);
        }
        /* corner triangle at b, then the quad (a, mab, mbc, c) by its shorter diagonal */
        uint32_t t0[3] = {mab, b, mbc};
        if (!emit(o, t0, 3, parent, ref))
            return false;
        double d1 = dist3(s->def + 3 * (size_t)a, s->def + 3 * (size_t)mbc);
        double d2 = dist3(s->def + 3 * (size_t)mab, s->def + 3 * (size_t)c);
        if (d1 <= d2) {
            uint32_t t1[3] = {a, mab, mbc}, t2[3] = {a, mbc, c};
            return emit(o, t1, 3, parent, ref) && emit(o, t2, 3, parent, ref);
        }
        uint32_t t1[3] = {a, mab, c}, t2[3] = {mab, mbc, c};
        return emit(o, t1, 3, parent, ref) && emit(o, t2, 3, parent, ref);
    }
    if (k == 4 && splits == 4) {
        uint32_t z = new_vertex(s, v, 4); /* the centre: average of the corners */
        if (z == NO_VERTEX)
            return false;
        uint32_t q0[4] = {v[0], m[0], z, m[3]}, q1[4] = {m[0], v[1], m[1], z},
                 q2[4] = {z, m[1], v[2], m[2]}, q3[4] = {m[3], z, m[2], v[3]};
        return emit(o, q0, 4, parent, ref) && emit(o, q1, 4, parent, ref) &&
               emit(o, q2, 4, parent, ref) && emit(o, q3, 4, parent, ref);
    }
    if (k == 4 && splits == 2 && m[0] != NO_VERTEX && m[2] != NO_VERTEX) {
        uint32_t q0[4] = {v[0], m[0], m[2], v[3]}, q1[4] = {m[0], v[1], v[2], m[2]};
        return emit(o, q0, 4, parent, ref) && emit(o, q1, 4, parent, ref);
    }
    if (k == 4 && splits == 2 && m[1] != NO_VERTEX && m[3] != NO_VERTEX) {
        uint32_t q0[4] = {v[0], v[1], m[1], m[3]}, q1[4] = {m[3], m[1], v[2], v[3]};
        return emit(o, q0, 4, parent, ref) && emit(o, q1, 4, parent, ref);
    }
    /* any other cell takes the midpoints into its boundary */
    uint32_t ring[2 * 255];
    if (k > 255)
        return false;
    uint32_t n = 0;
    for (uint32_t j = 0; j < k; j++) {
        ring[n++] = v[j];
        if (m[j] != NO_VERTEX)
            ring[n++] = m[j];
    }
    return emit(o, ring, n, parent, ref);
}

static void merge_report(ffd_gffd_track_report *into, ffd_gffd_track_report *r, uint32_t id_base,
                         bool *oom)
{
    into->tracked += r->tracked;
    into->converged += r->converged;
    into->fallback_count += r->fallback_count;
    into->iterations += r->iterations;
    into->max_error = fmax(into->max_error, r->max_error);
    if (r->failed_count) {
        uint32_t *f = ffd_realloc_array(into->failed, into->failed_count + r->failed_count,
                                        sizeof(uint32_t));
        if (!f) {
            *oom = true;
        } else {
            for (size_t i = 0; i < r->failed_count; i++)
                f[into->failed_count + i] = r->failed[i] + id_base;
            into->failed = f;
            into->failed_count += r->failed_count;
        }
    }
    ffd_gffd_track_report_free(r);
}

/* Tracks vertices first.. of s (their rest positions and averaged values)
 * into s->def and adds to the report; false with *st set on failure. */
static bool track_new(const ffd_gffd *g, state *s, size_t first, ffd_gffd_track_report *into,
                      ffd_status *st, ffd_error *err)
{
    if (first == s->nv)
        return true;
    ffd_gffd_track_report r;
    *st = ffd_gffd_track_with(g, s->rest + 3 * first, s->value + first, s->weight + first,
                              s->nv - first, s->def + 3 * first, &r, err);
    if (*st != FFD_OK)
        return false;
    bool oom = false;
    merge_report(into, &r, (uint32_t)first, &oom);
    if (oom)
        *st = ffd_fail(err, FFD_ERR_NOMEM, "resample: out of memory");
    return !oom;
}

void ffd_gffd_resample_report_free(ffd_gffd_resample_report *report)
{
    if (!report)
        return;
    ffd_gffd_track_report_free(&report->track);
    memset(report, 0, sizeof *report);
}

ffd_status ffd_gffd_resample(const ffd_gffd *g, const ffd_mesh *mesh,
                             const ffd_gffd_resample_options *options, ffd_mesh **out,
                             ffd_gffd_resample_report *report, ffd_error *err)
{
    *out = NULL;
    ffd_gffd_resample_report rep;
    memset(&rep, 0, sizeof rep);
    if (report)
        memset(report, 0, sizeof *report);
    ffd_gffd_resample_options o = {0};
    if (options)
        o = *options;
    if (!isfinite(o.ratio) || o.ratio < 0 || (o.ratio > 0 && o.ratio <= 1))
        return ffd_fail(err, FFD_ERR_INVALID, "resample ratio %g: expected > 1 (0: default 1.8)",
                        o.ratio);
    if (o.ratio == 0)
        o.ratio = 1.8;
    if (o.max_rounds == 0)
        o.max_rounds = 8;
    if (o.max_rounds > 64)
        return ffd_fail(err, FFD_ERR_INVALID, "resample max_rounds %u: expected <= 64",
                        o.max_rounds);
    size_t nv = ffd_mesh_vertex_count(mesh);
    if (nv != ffd_gffd_point_count(g))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "resample: the mesh has %zu vertices but %zu points were bound", nv,
                        ffd_gffd_point_count(g));
    if (o.max_vertices == 0)
        o.max_vertices = nv > SIZE_MAX / 16 ? SIZE_MAX : 16 * nv;
    if (o.max_vertices > UINT32_MAX - 1)
        o.max_vertices = UINT32_MAX - 1;

    state s;
    memset(&s, 0, sizeof s);
    faces cur;
    memset(&cur, 0, sizeof cur);
    ffd_status st = FFD_OK;
    size_t nf = ffd_mesh_face_count(mesh);
    const uint32_t *off = ffd_mesh_face_offsets(mesh), *idx = ffd_mesh_face_indices(mesh);
    const double *rest = ffd_mesh_positions(mesh);
    const double *e0 = ffd_gffd_bound_values(g);

    if (!grow_vertices(&s, nv ? nv : 1))
        goto oom;
    s.nv = nv;
    memcpy(s.rest, rest, nv * 3 * sizeof(double));
    memcpy(s.value, e0, nv * sizeof(double));
    memcpy(s.weight, ffd_gffd_bound_weights(g), nv * sizeof(double));
    {
        ffd_gffd_track_report r;
        st = ffd_gffd_track_with(g, s.rest, s.value, s.weight, nv, s.def, &r, err);
        if (st != FFD_OK)
            goto fail;
        rep.track = r;
    }
    /* the original cells: an edge's reference is its rest length, a cell's the mean of its edges */
    if (!edge_reserve(&s.edges, off[nf]))
        goto oom;
    for (size_t f = 0; f < nf; f++) {
        uint32_t a = off[f], b = off[f + 1];
        double sum = 0;
        for (uint32_t c = a; c < b; c++) {
            uint32_t u = idx[c], w = idx[c + 1 < b ? c + 1 : a];
            double len = dist3(rest + 3 * (size_t)u, rest + 3 * (size_t)w);
            sum += len;
            edge_put(&s.edges, u, w, len);
        }
        if (!emit(&cur, idx + a, b - a, (uint32_t)f, b > a ? sum / (b - a) : 0))
            goto oom;
    }

    for (uint32_t round = 0;; round++) {
        /* mark the edges whose deformed length grew by >= ratio (Fig. 6) */
        size_t marked = 0;
        for (size_t i = 0; i < s.edges.cap; i++)
            s.edges.slots[i].mid = NO_VERTEX;
        for (size_t f = 0; f < cur.nf; f++)
            for (uint32_t c = cur.off[f]; c < cur.off[f + 1]; c++) {
                uint32_t u = cur.idx[c], w = cur.idx[c + 1 < cur.off[f + 1] ? c + 1 : cur.off[f]];
                edge_slot *e = edge_find(&s.edges, u, w);
                double ref = e ? e->ref : cur.fref[f];
                if (e && e->mid == NO_VERTEX - 1)
                    continue; /* already marked from the other side */
                double len = dist3(s.def + 3 * (size_t)u, s.def + 3 * (size_t)w);
                if (ref > 0 && len >= o.ratio * ref) {
                    if (!e) {
                        if (!edge_reserve(&s.edges, s.edges.count + 1))
                            goto oom;
                        e = edge_put(&s.edges, u, w, ref);
                    }
                    if (e->mid == NO_VERTEX) {
                        e->mid = NO_VERTEX - 1; /* marked; the midpoint comes below */
                        marked++;
                    }
                }
            }
        if (marked == 0)
            break;
        if (round >= o.max_rounds || s.nv + marked > o.max_vertices) {
            rep.long_edges = marked;
            rep.capped = 1;
            break;
        }
        rep.rounds++;
        size_t first_new = s.nv;
        /* midpoints, in face order so that the numbering is deterministic */
        for (size_t f = 0; f < cur.nf; f++)
            for (uint32_t c = cur.off[f]; c < cur.off[f + 1]; c++) {
                uint32_t u = cur.idx[c], w = cur.idx[c + 1 < cur.off[f + 1] ? c + 1 : cur.off[f]];
                edge_slot *e = edge_find(&s.edges, u, w);
                if (!e || e->mid != NO_VERTEX - 1)
                    continue;
                uint32_t ends[2] = {u < w ? u : w, u < w ? w : u};
                uint32_t m = new_vertex(&s, ends, 2);
                if (m == NO_VERTEX)
                    goto oom;
                e = edge_find(&s.edges, u, w); /* (the table does not move here) */
                e->mid = m;
                rep.split_edges++;
            }
        /* move the new points (Fig. 6: "conforming to the deformation constraints") */
        if (!track_new(g, &s, first_new, &rep.track, &st, err))
            goto fail;
        /* halves inherit the parent's reference length */
        if (!edge_reserve(&s.edges, s.edges.count + 2 * marked))
            goto oom;
        for (size_t f = 0; f < cur.nf; f++)
            for (uint32_t c = cur.off[f]; c < cur.off[f + 1]; c++) {
                uint32_t u = cur.idx[c], w = cur.idx[c + 1 < cur.off[f + 1] ? c + 1 : cur.off[f]];
                edge_slot *e = edge_find(&s.edges, u, w);
                if (!e || e->mid == NO_VERTEX || e->mid == NO_VERTEX - 1)
                    continue;
                double ref = e->ref;
                uint32_t m = e->mid;
                edge_put(&s.edges, u, m, ref);
                edge_put(&s.edges, m, w, ref);
            }
        /* re-polygonise every cell */
        size_t first_centre = s.nv;
        faces next;
        memset(&next, 0, sizeof next);
        for (size_t f = 0; f < cur.nf; f++) {
            uint32_t a = cur.off[f], k = cur.off[f + 1] - a;
            uint32_t mids[255];
            if (k > 255) {
                st = ffd_fail(err, FFD_ERR_UNSUPPORTED,
                              "resample: a face of %u vertices (at most 255 are supported)", k);
                faces_free(&next);
                goto fail;
            }
            for (uint32_t j = 0; j < k; j++) {
                edge_slot *e = edge_find(&s.edges, cur.idx[a + j], cur.idx[a + (j + 1) % k]);
                mids[j] = e ? e->mid : NO_VERTEX;
            }
            if (!split_cell(&s, &next, cur.idx + a, k, mids, cur.parent[f], cur.fref[f])) {
                faces_free(&next);
                goto oom;
            }
        }
        faces_free(&cur);
        cur = next;
        rep.added_vertices += s.nv - first_new;
        if (!track_new(g, &s, first_centre, &rep.track, &st, err)) /* cell centres */
            goto fail;
    }

    {
        ffd_refine_plan plan;
        plan.new_vertex_count = s.nnew;
        plan.new_vertices = s.newv;
        plan.face_count = cur.nf;
        plan.face_offsets = cur.off;
        plan.face_indices = cur.idx;
        plan.face_parent = cur.parent;
        ffd_mesh *m = NULL;
        if (nf == 0) {
            plan.face_offsets = off; /* no faces: nothing to refine */
        }
        st = ffd_mesh_refine(mesh, &plan, &m, err);
        if (st != FFD_OK)
            goto fail;
        st = ffd_mesh_set_positions(m, s.def, NULL, err);
        if (st != FFD_OK) {
            ffd_mesh_destroy(m);
            goto fail;
        }
        *out = m;
    }
    if (report)
        *report = rep;
    else
        ffd_gffd_resample_report_free(&rep);
    faces_free(&cur);
    state_free(&s);
    return FFD_OK;
oom:
    st = ffd_fail(err, FFD_ERR_NOMEM, "resample: out of memory");
fail:
    ffd_gffd_resample_report_free(&rep);
    faces_free(&cur);
    state_free(&s);
    return st;
}
