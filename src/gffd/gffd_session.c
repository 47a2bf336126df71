/* session_gffd — the editor's GFFD method (Qin, Hua, Fang, Bao, Peng, "GFFD:
 * Generalized free-form deformation with scalar fields", 2003): a skeleton
 * of primitives whose vertices are the controls; the mesh tracks the
 * edited skeleton's field (§3, Fig. 5).
 *
 * The state is the rest skeleton and its edits since rest, the rig's
 * "edits" (docs/rig.md "GFFD rigs"): a "vertices" edit for a primitive
 * whose vertices were dragged (one per primitive, from the rest fit, while
 * it has no rigid edit), and a "rotate" (about an explicit centre) or
 * "translate" edit for each rotation of a whole primitive, and each
 * translation of one that was rotated: these reach the library as the
 * motion itself (ffd_gffd_transform), so that a point or a straight
 * polyline turned about itself turns the mesh. The deformer always holds
 * the edits' replay, which is what ffd_rig_apply does with the rig this
 * method writes, and the current skeleton vertices are read back from it
 * (ffd_gffd_set_vertices refits or moves a field depending on where it was
 * fitted, so only this replay, not the drag's history, reproduces the rig).
 *
 * Skeleton editing (op "primitive") changes the rest skeleton: the mesh is
 * re-bound at rest to the new rest skeleton (its field values e_0 change
 * where the edited primitive reaches), and every other primitive keeps its
 * edits from its rest. An added primitive starts
 * unedited (its rest is where it is given); a primitive whose radius
 * changes keeps its rest geometry and its edits. The distance unit u is
 * fixed when the method is created (the automatic one resolved then), so
 * that the kept primitives' fields do not change scale. User
 * correspondences of a loaded rig refer to the old skeleton and are dropped. */
#include "gffd/gffd_method.h"
#include "gffd/gffd.h"
#include "session/session.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEFAULT_SPAN 0.8   /* the default polyline spans 80 % of the longest extent */
#define DEFAULT_RADIUS 0.3 /* its radius, times the diagonal */
#define DEFAULT_VERTICES 5

typedef struct gf_method {
    sess_method base;
    ffd_rig_primitive *rest; /* the rest skeleton (owned) */
    size_t count;
    size_t *offset;              /* count + 1: primitive i's vertices are controls offset[i].. */
    double *cur;                 /* offset[count] by 3: the current skeleton */
    ffd_gffd_options opt;        /* unit resolved */
    double *corr_from, *corr_to; /* a loaded rig's correspondences (eq. 4) */
    size_t corr_count;
    ffd_gffd *g;
    ffd_rig_gffd_edit *edits; /* since rest, in order (all == 0, rotations with a centre) */
    size_t edit_count;
    int synced;                   /* g holds the replay of edits, cur its skeleton */
    struct gf_snapshot *begin;    /* drag: the state at begin */
    ffd_gffd_skeleton *field; /* rest fields for influence (lazy) */
} gf_method;

static const sess_vtable gffd_vtable;

typedef struct gf_snapshot {
    size_t n;
    double *cur;
    ffd_rig_gffd_edit *edits;
    size_t edit_count;
} gf_snapshot;
static void gf_snapshot_free(void *blob);

static void edits_free(ffd_rig_gffd_edit *e, size_t n)
{
    for (size_t i = 0; e && i < n; i++)
        ffd_free(e[i].vertices);
    ffd_free(e);
}

/* A deep copy of n edits with room for cap >= n. */
static ffd_rig_gffd_edit *edits_copy(const ffd_rig_gffd_edit *src, size_t n, size_t cap)
{
    ffd_rig_gffd_edit *e = ffd_calloc(cap ? cap : 1, sizeof *e);
    for (size_t i = 0; e && i < n; i++) {
        e[i] = src[i];
        e[i].vertices = NULL;
        if (src[i].vertices) {
            if (!(e[i].vertices = ffd_malloc_array(src[i].vertex_count, 3 * sizeof(double)))) {
                edits_free(e, i);
                return NULL;
            }
            memcpy(e[i].vertices, src[i].vertices, src[i].vertex_count * 3 * sizeof(double));
        }
    }
    return e;
}

/* ---- skeletons ------------------------------------------------------- */

static void skeleton_free(ffd_rig_primitive *s, size_t count)
{
    for (size_t i = 0; s && i < count; i++)
        ffd_rig_primitive_free(&s[i]);
    ffd_free(s);
}

static int primitive_copy(ffd_rig_primitive *dst, const ffd_rig_primitive *src)
{
    *dst = *src;
    dst->vertices = ffd_malloc_array(src->vertex_count, 3 * sizeof(double));
    dst->face_offsets =
        src->face_count ? ffd_malloc_array(src->face_count + 1, sizeof(uint32_t)) : NULL;
    size_t corners = src->face_count ? src->face_offsets[src->face_count] : 0;
    dst->face_indices = corners ? ffd_malloc_array(corners, sizeof(uint32_t)) : NULL;
    if (!dst->vertices || (src->face_count && !dst->face_offsets) ||
        (corners && !dst->face_indices)) {
        ffd_rig_primitive_free(dst);
        return 0;
    }
    memcpy(dst->vertices, src->vertices, src->vertex_count * 3 * sizeof(double));
    if (src->face_count) {
        memcpy(dst->face_offsets, src->face_offsets, (src->face_count + 1) * sizeof(uint32_t));
        memcpy(dst->face_indices, src->face_indices, corners * sizeof(uint32_t));
    }
    return 1;
}

static ffd_status gffd_bind(const sess_ctx *ctx, const ffd_rig_primitive *rest, size_t count,
                            const ffd_gffd_options *opt, const char *what, ffd_gffd **g,
                            ffd_error *err)
{
    ffd_gffd_primitive *p = ffd_malloc_array(count, sizeof *p);
    if (!p)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", what);
    for (size_t i = 0; i < count; i++)
        ffd_rig_primitive_public(&rest[i], &p[i]);
    ffd_error inner = {{0}};
    ffd_status s = FFD_OK;
    /* limits (ffd_limits): each field's dense matrix and factorisation */
    ffd_budget budget;
    ffd_budget_init(&budget, &ctx->limits);
    size_t max_samples = opt && opt->max_samples ? opt->max_samples : 4000;
    for (size_t i = 0; i < count && !s; i++) {
        double m = ffd_gffd_estimate_samples(&p[i], max_samples), bytes, work;
        char ms[32];
        ffd_gffd_estimate_fit(m, p[i].face_count, &bytes, &work);
        s = ffd_budget_charge(&budget, bytes, work, &inner,
                              "skeleton[%zu]: a field of about %s samples (max_samples %zu)", i,
                              ffd_format_count(m, ms, sizeof ms), max_samples);
    }
    /* the fields (§2) and e_0 = E(P) of every vertex at rest (§3) */
    if (!s)
        s = ffd_gffd_create(p, count, ctx->rest, ctx->n, opt, g, &inner);
    ffd_free(p);
    return s ? ffd_fail(err, s, "%s: %s", what, inner.message) : FFD_OK;
}

/* The replay of the edits on g, as ffd_rig_apply does it (rigid edits
 * through ffd_rig_gffd_apply_edit itself); cur becomes g's skeleton. */
static ffd_status replay_skeleton(gf_method *m, ffd_error *err)
{
    ffd_error inner = {{0}};
    m->synced = 0;
    ffd_rig rig;
    ffd_rig_gffd section;
    ffd_rig_view(&rig, &ffd_method_gffd, &section, sizeof section);
    rig.name = (char *)"skeleton";
    section.edits = m->edits;
    section.edit_count = m->edit_count;
    ffd_status s = ffd_gffd_reset(m->g, &inner);
    for (size_t i = 0; !s && i < m->edit_count; i++) {
        const ffd_rig_gffd_edit *e = &m->edits[i];
        if (e->kind == FFD_RIG_EDIT_VERTICES)
            s = ffd_gffd_set_vertices(m->g, e->primitive, e->vertices, &inner);
        else if ((s = ffd_rig_gffd_apply_edit(&rig, m->g, i, &inner)))
            return ffd_fail(err, s, "%s", inner.message);
    }
    if (!s && m->corr_count)
        s = ffd_gffd_set_correspondences(m->g, m->corr_from, m->corr_to, m->corr_count, &inner);
    if (s)
        return ffd_fail(err, s, "skeleton: %s", inner.message);
    for (size_t i = 0; i < m->count; i++) {
        ffd_gffd_primitive p;
        ffd_gffd_get_primitive(m->g, i, &p, NULL);
        memcpy(m->cur + 3 * m->offset[i], p.vertices, p.vertex_count * 3 * sizeof *m->cur);
    }
    m->synced = 1;
    return FFD_OK;
}

/* The edits become next (taken, freed on error) and the deformer replays
 * them; on error the state stays as it was. */
static ffd_status set_edits(gf_method *m, ffd_rig_gffd_edit *next, size_t n, ffd_error *err)
{
    ffd_rig_gffd_edit *old = m->edits;
    size_t old_count = m->edit_count;
    m->edits = next;
    m->edit_count = n;
    ffd_status s = replay_skeleton(m, err);
    if (s) {
        m->edits = old;
        m->edit_count = old_count;
        edits_free(next, n);
        replay_skeleton(m, NULL); /* a failure leaves synced = 0: eval retries */
    } else {
        edits_free(old, old_count);
    }
    return s;
}

static void gf_destroy(sess_method *base)
{
    gf_method *m = (gf_method *)base;
    if (!m)
        return;
    skeleton_free(m->rest, m->count);
    ffd_free(m->offset);
    ffd_free(m->cur);
    ffd_free(m->corr_from);
    ffd_free(m->corr_to);
    ffd_gffd_destroy(m->g);
    edits_free(m->edits, m->edit_count);
    gf_snapshot_free(m->begin);
    ffd_gffd_skeleton_destroy(m->field);
    ffd_free(m);
}

/* A method around a bound deformer; takes rest and g (freed on error). cur
 * starts as g's current skeleton. */
static ffd_status gf_new(const sess_ctx *ctx, ffd_rig_primitive *rest, size_t count,
                         const ffd_gffd_options *opt, ffd_gffd *g, gf_method **out, ffd_error *err)
{
    gf_method *m = ffd_calloc(1, sizeof *m);
    size_t *offset = ffd_malloc_array(count + 1, sizeof *offset);
    double *cur = NULL;
    if (offset) {
        offset[0] = 0;
        for (size_t i = 0; i < count; i++)
            offset[i + 1] = offset[i] + rest[i].vertex_count;
        cur = ffd_malloc_array(offset[count] ? offset[count] : 1, 3 * sizeof *cur);
    }
    if (!m || !offset || !cur) {
        ffd_free(m);
        ffd_free(offset);
        ffd_free(cur);
        skeleton_free(rest, count);
        ffd_gffd_destroy(g);
        return ffd_fail(err, FFD_ERR_NOMEM, "gffd: out of memory");
    }
    for (size_t i = 0; i < count; i++) {
        ffd_gffd_primitive p;
        ffd_gffd_get_primitive(g, i, &p, NULL);
        memcpy(cur + 3 * offset[i], p.vertices, p.vertex_count * 3 * sizeof *cur);
    }
    m->base.vt = &gffd_vtable;
    m->base.ctx = ctx;
    m->rest = rest;
    m->count = count;
    m->offset = offset;
    m->cur = cur;
    m->opt = *opt;
    m->opt.unit = ffd_gffd_unit(g);
    m->g = g;
    m->synced = 1;
    *out = m;
    return FFD_OK;
}

/* ---- create and load ------------------------------------------------- */

/* One polyline along the mesh's longest axis through its box centre. */
static ffd_status default_skeleton(const sess_ctx *ctx, ffd_rig_primitive **out, ffd_error *err)
{
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if (ctx->max[a] - ctx->min[a] > ctx->max[axis] - ctx->min[axis])
            axis = a;
    ffd_rig_primitive *p = ffd_calloc(1, sizeof *p);
    double *v = ffd_malloc_array(DEFAULT_VERTICES, 3 * sizeof *v);
    if (!p || !v) {
        ffd_free(p);
        ffd_free(v);
        return ffd_fail(err, FFD_ERR_NOMEM, "create: out of memory");
    }
    const double extent = ctx->max[axis] - ctx->min[axis];
    for (int i = 0; i < DEFAULT_VERTICES; i++)
        for (int a = 0; a < 3; a++) {
            double c = 0.5 * (ctx->min[a] + ctx->max[a]);
            double t = (double)i / (DEFAULT_VERTICES - 1) - 0.5;
            v[3 * i + a] = a == axis ? c + DEFAULT_SPAN * extent * t : c;
        }
    p->kind = FFD_GFFD_POLYLINE;
    p->vertices = v;
    p->vertex_count = DEFAULT_VERTICES;
    p->radius = DEFAULT_RADIUS * ctx->diag;
    *out = p;
    return FFD_OK;
}

/* The editor's "create": the body is a GFFD rig's creation part
 * (ffd_method_create); this hook is what the editor does differently from a
 * rig: no "resample" (it adds vertices), no skeleton "file" (an editing
 * session reads no files), and the default skeleton when none is given. */
ffd_status ffd_sess_gffd_create_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p)
{
    if (cJSON_GetObjectItemCaseSensitive(body, "resample"))
        return ffd_fail(p->err, FFD_ERR_INVALID,
                        "%s: resample: adaptive resampling adds vertices, which an editing "
                        "session cannot; use ffd deform with a rig for that",
                        p->name);
    const cJSON *skeleton = cJSON_GetObjectItemCaseSensitive(body, "skeleton"), *c;
    size_t i = 0;
    if (cJSON_IsArray(skeleton))
        cJSON_ArrayForEach(c, skeleton)
        {
            if (cJSON_IsObject(c) && cJSON_GetObjectItemCaseSensitive(c, "file"))
                return ffd_fail(p->err, FFD_ERR_PARSE,
                                "%s: skeleton[%zu].file: files are not read here; give the "
                                "geometry inline (\"vertices\", \"faces\")",
                                p->name, i);
            i++;
        }
    if (skeleton)
        return FFD_OK;
    /* the default skeleton, written as the rig's primitive (numbers kept exactly) */
    ffd_error inner = {{0}};
    ffd_rig_primitive *d = NULL;
    if (default_skeleton(ctx, &d, &inner))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    cJSON *array = cJSON_AddArrayToObject(body, "skeleton");
    cJSON *prim = array ? cJSON_CreateObject() : NULL, *vertices = NULL;
    int ok = ffd_sess_add_to_array(array, prim) &&
             cJSON_AddStringToObject(prim, "type", ffd_rig_gffd_kind_name(d->kind)) &&
             (vertices = cJSON_AddArrayToObject(prim, "vertices")) &&
             cJSON_AddNumberToObject(prim, "radius", d->radius);
    for (size_t v = 0; ok && v < d->vertex_count; v++)
        ok = ffd_sess_add_to_array(vertices, cJSON_CreateDoubleArray(d->vertices + 3 * v, 3));
    ffd_rig_primitive_free(d);
    ffd_free(d);
    return ok ? FFD_OK : ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
}

ffd_status ffd_sess_gffd_create(const sess_ctx *ctx, const cJSON *body, sess_method **out,
                                ffd_error *err)
{
    return ffd_method_create(&ffd_method_gffd, ctx, body, out, err);
}

static ffd_status copy_correspondences(gf_method *m, const ffd_rig_gffd *r, ffd_error *err)
{
    if (!r->corr_count)
        return FFD_OK;
    m->corr_from = ffd_malloc_array(r->corr_count, 3 * sizeof(double));
    m->corr_to = ffd_malloc_array(r->corr_count, 3 * sizeof(double));
    if (!m->corr_from || !m->corr_to)
        return ffd_fail(err, FFD_ERR_NOMEM, "load: out of memory");
    memcpy(m->corr_from, r->corr_from, r->corr_count * 3 * sizeof(double));
    memcpy(m->corr_to, r->corr_to, r->corr_count * 3 * sizeof(double));
    m->corr_count = r->corr_count;
    return FFD_OK;
}

ffd_status ffd_sess_gffd_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                          ffd_error *err)
{
    *out = NULL;
    const ffd_rig_gffd *r = ffd_rig_gffd_of(rig);
    if (rig->method != &ffd_method_gffd)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: not a \"gffd\" rig", rig->name);
    if (r->replace)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: replace: the editor edits a skeleton, it does not replace it; use "
                        "ffd deform for a rig with \"replace\"",
                        rig->name);
    if (r->resample)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: resample: adaptive resampling adds vertices, which an editing "
                        "session cannot; use ffd deform for a rig with \"resample\"",
                        rig->name);
    ffd_rig_primitive *rest = ffd_calloc(r->skeleton_count, sizeof *rest);
    size_t count = 0;
    while (rest && count < r->skeleton_count && primitive_copy(&rest[count], &r->skeleton[count]))
        count++;
    if (count < r->skeleton_count) {
        skeleton_free(rest, count);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    }
    ffd_gffd *g = NULL;
    ffd_status s = gffd_bind(ctx, rest, count, &r->options, rig->name, &g, err);
    /* the rig's edits in file order give the current skeleton (§5); each
     * becomes one edit per primitive it touches: a rigid one as itself
     * (with its centre resolved as ffd_rig_gffd_apply_edit does), any
     * other as the vertices it gives */
    size_t cap = 0, n = 0;
    for (size_t i = 0; i < r->edit_count; i++)
        cap += r->edits[i].all ? count : 1;
    ffd_rig_gffd_edit *edits = s ? NULL : ffd_calloc(cap ? cap : 1, sizeof *edits);
    if (!s && !edits)
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    for (size_t i = 0; !s && i < r->edit_count; i++) {
        const ffd_rig_gffd_edit *e = &r->edits[i];
        size_t first = e->all ? 0 : e->primitive, last = e->all ? count : first + 1;
        double center[3];
        ffd_rig_gffd_edit_center(e, g, center);
        if ((s = ffd_rig_gffd_apply_edit(rig, g, i, err)))
            break;
        for (size_t j = first; j < last; j++, n++) {
            ffd_rig_gffd_edit *d = &edits[n];
            if (e->kind == FFD_RIG_EDIT_ROTATE || e->kind == FFD_RIG_EDIT_TRANSLATE) {
                *d = *e;
                d->vertices = NULL;
                d->vertex_count = 0;
                d->has_center = e->kind == FFD_RIG_EDIT_ROTATE;
                memcpy(d->center, center, sizeof center);
            } else {
                ffd_gffd_primitive p;
                ffd_gffd_get_primitive(g, j, &p, NULL);
                memset(d, 0, sizeof *d);
                d->kind = FFD_RIG_EDIT_VERTICES;
                d->vertex_count = p.vertex_count;
                if (!(d->vertices = ffd_malloc_array(p.vertex_count, 3 * sizeof(double)))) {
                    s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
                    break;
                }
                memcpy(d->vertices, p.vertices, p.vertex_count * 3 * sizeof(double));
            }
            d->all = 0;
            d->primitive = (uint32_t)j;
        }
    }
    if (s) {
        edits_free(edits, cap);
        ffd_gffd_destroy(g);
        skeleton_free(rest, count);
        return s;
    }
    gf_method *m = NULL;
    if ((s = gf_new(ctx, rest, count, &r->options, g, &m, err))) {
        edits_free(edits, cap);
        return s;
    }
    m->edits = edits;
    m->edit_count = n;
    if ((s = copy_correspondences(m, r, err)) || (s = replay_skeleton(m, err))) {
        gf_destroy(&m->base);
        return s;
    }
    *out = &m->base;
    return FFD_OK;
}

/* ---- evaluation and controls ----------------------------------------- */

static ffd_status gf_eval(sess_method *base, double *out, ffd_error *err)
{
    gf_method *m = (gf_method *)base;
    ffd_status s = m->synced ? FFD_OK : replay_skeleton(m, err);
    ffd_error inner = {{0}};
    /* tracking (Fig. 5): every influenced vertex back to its value e_0 */
    if (!s && (s = ffd_gffd_track(m->g, out, NULL, &inner)))
        s = ffd_fail(err, s, "tracking: %s", inner.message);
    return s;
}

static size_t gf_control_count(const sess_method *base)
{
    const gf_method *m = (const gf_method *)base;
    return m->offset[m->count];
}

static void gf_controls(const sess_method *base, double *out)
{
    const gf_method *m = (const gf_method *)base;
    memcpy(out, m->cur, m->offset[m->count] * 3 * sizeof *out);
}

static int cmp_edge(const void *a, const void *b)
{
    const uint32_t *x = a, *y = b;
    return x[0] != y[0] ? (x[0] > y[0]) - (x[0] < y[0]) : (x[1] > y[1]) - (x[1] < y[1]);
}

/* Polyline segments and face sides (shared sides once), as control ids. */
static int add_edges(const gf_method *m, cJSON *edges)
{
    size_t total = 0;
    for (size_t i = 0; i < m->count; i++)
        total += m->rest[i].face_count ? m->rest[i].face_offsets[m->rest[i].face_count]
                                       : m->rest[i].vertex_count;
    uint32_t *e = ffd_malloc_array(total ? total : 1, 2 * sizeof *e);
    if (!e)
        return 0;
    size_t k = 0;
    for (size_t i = 0; i < m->count; i++) {
        const ffd_rig_primitive *p = &m->rest[i];
        const uint32_t o = (uint32_t)m->offset[i];
        for (size_t v = 0; !p->face_count && v + 1 < p->vertex_count; v++, k++) {
            e[2 * k] = o + (uint32_t)v;
            e[2 * k + 1] = o + (uint32_t)v + 1;
        }
        for (size_t f = 0; f < p->face_count; f++) {
            uint32_t b = p->face_offsets[f], n = p->face_offsets[f + 1] - b;
            for (uint32_t c = 0; c < n; c++, k++) {
                uint32_t x = o + p->face_indices[b + c], y = o + p->face_indices[b + (c + 1) % n];
                e[2 * k] = x < y ? x : y;
                e[2 * k + 1] = x < y ? y : x;
            }
        }
    }
    qsort(e, k, 2 * sizeof *e, cmp_edge);
    int ok = 1;
    for (size_t j = 0; ok && j < k; j++)
        if (j == 0 || cmp_edge(e + 2 * j, e + 2 * (j - 1)) != 0)
            ok = ffd_sess_add_edge(edges, e[2 * j], e[2 * j + 1]);
    ffd_free(e);
    return ok;
}

static ffd_status gf_describe(const sess_method *base, cJSON *params, cJSON *controls,
                              ffd_error *err)
{
    const gf_method *m = (const gf_method *)base;
    cJSON *prims = NULL, *edges = NULL;
    int ok =
        cJSON_AddNumberToObject(params, "unit", m->opt.unit) &&
        cJSON_AddStringToObject(params, "tracking",
                                m->opt.tracking == FFD_GFFD_TRACK_WARP ? "warp" : "gradient") &&
        (prims = cJSON_AddArrayToObject(controls, "primitives")) &&
        (edges = cJSON_AddArrayToObject(controls, "edges")) &&
        cJSON_AddNumberToObject(controls, "influenced", (double)ffd_gffd_influenced_count(m->g)) &&
        add_edges(m, edges);
    for (size_t i = 0; ok && i < m->count; i++) {
        const ffd_rig_primitive *p = &m->rest[i];
        cJSON *o = cJSON_CreateObject();
        ok = ffd_sess_add_to_array(prims, o) && cJSON_AddStringToObject(o, "type", ffd_rig_gffd_kind_name(p->kind)) &&
             cJSON_AddNumberToObject(o, "radius", p->radius) &&
             cJSON_AddNumberToObject(o, "offset", (double)m->offset[i]) &&
             cJSON_AddNumberToObject(o, "count", (double)p->vertex_count) &&
             ffd_sess_add_item(o, "faces", ffd_rig_gffd_faces_json(p, m->offset[i]));
    }
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
}

/* ---- drags, snapshots, reset ----------------------------------------- */

static ffd_status gf_snapshot_take(const sess_method *base, void **blob, ffd_error *err);
static ffd_status gf_restore(sess_method *base, const void *blob, ffd_error *err);

static ffd_status gf_begin(sess_method *base, const uint32_t *ids, size_t k, int arap,
                           ffd_error *err)
{
    gf_method *m = (gf_method *)base;
    void *blob = NULL;
    ffd_status s = gf_snapshot_take(base, &blob, err);
    gf_snapshot_free(m->begin);
    m->begin = blob;
    return s ? ffd_fail(err, s, "drag_begin: out of memory") : FFD_OK;
}

/* The edits of one drag step from the begin state (or the current one):
 * the controls' new positions are to; a primitive in whole (whole[i], may
 * be NULL) moves by motion, a rotate edit, or a translate edit when it was
 * rotated before (else its vertices tell the translation); any other
 * primitive whose vertices changed gets them as a vertices edit: its only
 * edit while it has no rigid one (none at rest), else after them. */
static ffd_status step_edits(gf_method *m, const double *to, const unsigned char *whole,
                             const ffd_rig_gffd_edit *motion, ffd_error *err)
{
    const ffd_rig_gffd_edit *base = m->begin ? m->begin->edits : m->edits;
    const size_t nb = m->begin ? m->begin->edit_count : m->edit_count;
    const double *from = m->begin ? m->begin->cur : m->cur;
    ffd_rig_gffd_edit *e = edits_copy(base, nb, nb + m->count);
    size_t n = nb;
    if (!e)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    for (size_t i = 0; i < m->count; i++) {
        const size_t vc = m->rest[i].vertex_count;
        const double *v = to + 3 * m->offset[i];
        size_t last = n; /* its last edit */
        int rigid = 0;
        for (size_t j = 0; j < n; j++)
            if (e[j].primitive == i) {
                last = j;
                rigid |= e[j].kind != FFD_RIG_EDIT_VERTICES;
            }
        if (whole && whole[i] && (motion->kind == FFD_RIG_EDIT_ROTATE || rigid)) {
            e[n] = *motion;
            e[n++].primitive = (uint32_t)i;
            continue;
        }
        if (memcmp(v, from + 3 * m->offset[i], vc * 3 * sizeof *v) == 0)
            continue;
        double *copy = ffd_malloc_array(vc, 3 * sizeof *copy);
        if (!copy) {
            edits_free(e, n);
            return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
        }
        memcpy(copy, v, vc * 3 * sizeof *copy);
        if (rigid && e[last].kind == FFD_RIG_EDIT_VERTICES) {
            ffd_free(e[last].vertices);
            e[last].vertices = copy;
            continue;
        }
        if (!rigid) { /* vertices only: one edit from rest, none at rest */
            size_t k = 0;
            for (size_t j = 0; j < n; j++)
                if (e[j].primitive == i)
                    ffd_free(e[j].vertices);
                else
                    e[k++] = e[j];
            n = k;
            if (memcmp(v, m->rest[i].vertices, vc * 3 * sizeof *v) == 0) {
                ffd_free(copy);
                continue;
            }
        }
        memset(&e[n], 0, sizeof e[n]);
        e[n].kind = FFD_RIG_EDIT_VERTICES;
        e[n].primitive = (uint32_t)i;
        e[n].vertices = copy;
        e[n++].vertex_count = vc;
    }
    return set_edits(m, e, n, err);
}

/* to: the current controls with ids at targets (n by 3, allocated). */
static ffd_status drag_targets(gf_method *m, const uint32_t *ids, size_t k, const double *targets,
                               double **to, ffd_error *err)
{
    const size_t n = m->offset[m->count];
    *to = NULL;
    for (size_t i = 0; i < k; i++) {
        if (ids[i] >= n)
            return ffd_fail(err, FFD_ERR_RANGE, "drag: control %u out of range (%zu controls)",
                            ids[i], n);
        for (int a = 0; a < 3; a++)
            if (!isfinite(targets[3 * i + a]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "drag: targets[%zu]: not finite", i);
    }
    double *next = ffd_malloc_array(n ? n : 1, 3 * sizeof *next);
    if (!next)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    memcpy(next, m->begin ? m->begin->cur : m->cur, n * 3 * sizeof *next);
    for (size_t i = 0; i < k; i++)
        memcpy(next + 3 * ids[i], targets + 3 * i, 3 * sizeof *next);
    *to = next;
    return FFD_OK;
}

static ffd_status gf_set_controls(sess_method *base, const uint32_t *ids, size_t k,
                                  const double *targets, ffd_error *err)
{
    gf_method *m = (gf_method *)base;
    double *to = NULL;
    /* the skeleton edit (§5, first way), then tracking at eval */
    ffd_status s = drag_targets(m, ids, k, targets, &to, err);
    if (!s)
        s = step_edits(m, to, NULL, NULL, err);
    ffd_free(to);
    return s;
}

/* A rotation or translation: primitives dragged in whole move by the
 * motion itself (ffd_gffd_transform through the rig's rotate and translate
 * edits), the others by their vertices. */
static ffd_status gf_set_motion(sess_method *base, const uint32_t *ids, size_t k,
                                const double *targets, const double axis[3], double angle,
                                const double center[3], const double delta[3], ffd_error *err)
{
    gf_method *m = (gf_method *)base;
    double *to = NULL;
    ffd_status s = drag_targets(m, ids, k, targets, &to, err);
    if (s)
        return s;
    const size_t n = m->offset[m->count];
    unsigned char *chosen = ffd_calloc(n ? n : 1, 1), *whole = ffd_calloc(m->count, 1);
    if (!chosen || !whole) {
        ffd_free(to);
        ffd_free(chosen);
        ffd_free(whole);
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    }
    for (size_t i = 0; i < k; i++)
        chosen[ids[i]] = 1;
    int moves = angle != 0 || delta[0] != 0 || delta[1] != 0 || delta[2] != 0;
    for (size_t i = 0; moves && i < m->count; i++) {
        whole[i] = 1;
        for (size_t v = m->offset[i]; v < m->offset[i + 1]; v++)
            whole[i] &= chosen[v];
    }
    ffd_rig_gffd_edit motion;
    memset(&motion, 0, sizeof motion);
    if (angle != 0) {
        motion.kind = FFD_RIG_EDIT_ROTATE;
        memcpy(motion.axis, axis, sizeof motion.axis);
        motion.angle = angle;
        motion.has_center = 1;
        memcpy(motion.center, center, sizeof motion.center);
    } else {
        motion.kind = FFD_RIG_EDIT_TRANSLATE;
        memcpy(motion.delta, delta, sizeof motion.delta);
    }
    s = step_edits(m, to, whole, &motion, err);
    ffd_free(to);
    ffd_free(chosen);
    ffd_free(whole);
    return s;
}

static void gf_end(sess_method *base, int commit)
{
    gf_method *m = (gf_method *)base;
    gf_snapshot *b = m->begin;
    if (!b)
        return;
    m->begin = NULL;
    if (!commit)
        gf_restore(base, b, NULL);
    gf_snapshot_free(b);
}

static void gf_snapshot_free(void *blob)
{
    gf_snapshot *b = blob;
    if (b) {
        ffd_free(b->cur);
        edits_free(b->edits, b->edit_count);
    }
    ffd_free(b);
}

static ffd_status gf_snapshot_take(const sess_method *base, void **blob, ffd_error *err)
{
    const gf_method *m = (const gf_method *)base;
    gf_snapshot *b = ffd_calloc(1, sizeof *b);
    *blob = NULL;
    if (b) {
        b->n = m->offset[m->count];
        b->cur = ffd_malloc_array(b->n ? b->n : 1, 3 * sizeof *b->cur);
        b->edits = edits_copy(m->edits, m->edit_count, m->edit_count);
        b->edit_count = m->edit_count;
    }
    if (!b || !b->cur || !b->edits) {
        if (b && !b->edits)
            b->edit_count = 0;
        gf_snapshot_free(b);
        return ffd_fail(err, FFD_ERR_NOMEM, "snapshot: out of memory");
    }
    memcpy(b->cur, m->cur, b->n * 3 * sizeof *b->cur);
    *blob = b;
    return FFD_OK;
}

static ffd_status gf_restore(sess_method *base, const void *blob, ffd_error *err)
{
    gf_method *m = (gf_method *)base;
    const gf_snapshot *b = blob;
    if (b->n != m->offset[m->count])
        return ffd_fail(err, FFD_ERR_INVALID,
                        "restore: the snapshot has %zu skeleton vertices, the method %zu", b->n,
                        m->offset[m->count]);
    ffd_rig_gffd_edit *e = edits_copy(b->edits, b->edit_count, b->edit_count);
    if (!e)
        return ffd_fail(err, FFD_ERR_NOMEM, "restore: out of memory");
    return set_edits(m, e, b->edit_count, err);
}

static ffd_status gf_reset(sess_method *base, ffd_error *err)
{
    gf_method *m = (gf_method *)base;
    return set_edits(m, NULL, 0, err);
}

/* ---- the rig --------------------------------------------------------- */

/* The state as a rig: the rest skeleton, the edits since, the options and
 * the correspondences, written by the rig's own writer (gffd_rig_json.c). */
static ffd_status gf_rig(const sess_method *base, cJSON *root, ffd_error *err)
{
    const gf_method *m = (const gf_method *)base;
    ffd_rig rig;
    ffd_rig_gffd g; /* borrows the state's arrays */
    ffd_rig_view(&rig, &ffd_method_gffd, &g, sizeof g);
    g.skeleton = m->rest;
    g.skeleton_count = m->count;
    g.edits = m->edits;
    g.edit_count = m->edit_count;
    g.corr_from = m->corr_from;
    g.corr_to = m->corr_to;
    g.corr_count = m->corr_count;
    g.options = m->opt;
    return ffd_method_gffd.write(&rig, root) ? FFD_OK
                                              : ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
}

/* ---- influence: the primitives' share of the merged field ------------ */

static ffd_status rest_fields(gf_method *m, ffd_error *err)
{
    if (m->field)
        return FFD_OK;
    ffd_gffd_primitive *p = ffd_malloc_array(m->count, sizeof *p);
    if (!p)
        return ffd_fail(err, FFD_ERR_NOMEM, "influence: out of memory");
    for (size_t i = 0; i < m->count; i++)
        ffd_rig_primitive_public(&m->rest[i], &p[i]);
    ffd_error inner = {{0}};
    ffd_status s = ffd_gffd_skeleton_create(
        p, m->count, m->opt.max_samples ? m->opt.max_samples : 4000, &m->field, &inner);
    ffd_free(p);
    if (s)
        return ffd_fail(err, s, "influence: %s", inner.message);
    ffd_gffd_skeleton_set_unit(m->field, m->opt.unit);
    return FFD_OK;
}

/* Per vertex at rest: sum of E_i over the chosen primitives over E (eq. 1-2).
 */
static ffd_status gf_influence(sess_method *base, const uint32_t *ids, size_t k, float *w,
                               ffd_error *err)
{
    gf_method *m = (gf_method *)base;
    const sess_ctx *ctx = m->base.ctx;
    unsigned char *chosen = ffd_calloc(m->count, 1);
    if (!chosen)
        return ffd_fail(err, FFD_ERR_NOMEM, "influence: out of memory");
    for (size_t i = 0; i < k; i++)
        for (size_t j = 0; j < m->count; j++)
            if (ids[i] >= m->offset[j] && ids[i] < m->offset[j + 1])
                chosen[j] = 1;
    ffd_status s = rest_fields(m, err);
    const ffd_gffd_skeleton *field = m->field;
    long long n = s ? 0 : (long long)ctx->n;
#pragma omp parallel for schedule(static)
    for (long long v = 0; v < n; v++) {
        const double *x = ctx->rest + 3 * v;
        double e = ffd_gffd_skeleton_field(field, x, NULL), share = 0;
        for (size_t j = 0; e > 0 && j < field->count; j++) {
            if (!chosen[j])
                continue;
            ffd_gffd_skeleton one = *field; /* primitive j alone: E_j */
            one.count = 1;
            one.parts = &field->parts[j];
            share += ffd_gffd_skeleton_field(&one, x, NULL);
        }
        double r = e > 0 ? share / e : 0;
        w[v] = (float)(r < 0 ? 0 : r > 1 ? 1 : r);
    }
    ffd_free(chosen);
    return s;
}

/* ---- op primitive: skeleton editing ------------------------------------ */

/* The new rest skeleton (rest with one change) and the current vertices it
 * keeps; replaces m's contents on success. */
static ffd_status rebuild(gf_method *m, ffd_rig_primitive *rest, size_t count,
                          ffd_rig_gffd_edit *edits, size_t edit_count, ffd_error *err)
{
    ffd_gffd *g = NULL;
    gf_method *n = NULL;
    ffd_status s = gffd_bind(m->base.ctx, rest, count, &m->opt, "primitive", &g, err);
    if (s) {
        skeleton_free(rest, count);
        edits_free(edits, edit_count);
        return s;
    }
    if ((s = gf_new(m->base.ctx, rest, count, &m->opt, g, &n, err))) {
        edits_free(edits, edit_count);
        return s;
    }
    n->edits = edits;
    n->edit_count = edit_count;
    if ((s = replay_skeleton(n, err))) {
        gf_destroy(&n->base);
        return s;
    }
    gf_method old = *m;
    *m = *n;
    *n = old;
    gf_destroy(&n->base);
    return FFD_OK;
}

static ffd_status primitive_op(gf_method *m, const ffd_rig_primitive *add, size_t index,
                               double radius, int remove, ffd_error *err)
{
    size_t count = m->count + (add ? 1 : 0) - (remove ? 1 : 0);
    ffd_rig_primitive *rest = ffd_calloc(count, sizeof *rest);
    /* the kept primitives keep their edits (renumbered past a removed one) */
    ffd_rig_gffd_edit *edits = edits_copy(m->edits, m->edit_count, m->edit_count);
    size_t k = 0, n = 0;
    int ok = rest && edits;
    for (size_t i = 0; ok && i < m->count; i++) {
        if (remove && i == index)
            continue;
        ok = primitive_copy(&rest[k], &m->rest[i]);
        if (ok && !add && !remove && i == index)
            rest[k].radius = radius;
        k += ok;
    }
    if (ok && add)
        k += ok = primitive_copy(&rest[k], add);
    for (size_t i = 0; edits && i < m->edit_count; i++) {
        if (remove && edits[i].primitive == index) {
            ffd_free(edits[i].vertices);
            continue;
        }
        edits[n] = edits[i];
        edits[n++].primitive -= remove && edits[i].primitive > index;
    }
    if (!ok) {
        skeleton_free(rest, k);
        edits_free(edits, n);
        return ffd_fail(err, FFD_ERR_NOMEM, "primitive: out of memory");
    }
    return rebuild(m, rest, count, edits, n, err);
}

static ffd_status read_index(const ffd_rig_parser *p, const cJSON *body, const char *key, size_t count,
                             size_t *index)
{
    uint32_t i = 0;
    ffd_status s = ffd_rig_read_index(p, cJSON_GetObjectItemCaseSensitive(body, key), key,
                                  "a primitive index", &i);
    if (!s && i >= count)
        s = ffd_fail(p->err, FFD_ERR_RANGE, "%s: %s: %u out of range (%zu primitives)", p->name,
                     key, i, count);
    *index = i;
    return s;
}

static ffd_status op_primitive(gf_method *m, const cJSON *body, int *undo, ffd_error *err)
{
    static const char *const keys[] = {"add", "index", "radius", "remove", NULL};
    ffd_rig_parser p = {"primitive", err, NULL};
    const cJSON *add = cJSON_GetObjectItemCaseSensitive(body, "add");
    const cJSON *index = cJSON_GetObjectItemCaseSensitive(body, "index");
    const cJSON *radius = cJSON_GetObjectItemCaseSensitive(body, "radius");
    const cJSON *remove = cJSON_GetObjectItemCaseSensitive(body, "remove");
    ffd_status s = ffd_rig_check_keys(&p, body, "", keys, "\"add\", \"index\", \"radius\", \"remove\"");
    if (s)
        return s;
    if ((add != NULL) + (remove != NULL) + (index != NULL || radius != NULL) != 1)
        return ffd_rig_expected(&p, "body",
                            "one of {\"add\": primitive}, {\"index\": i, "
                            "\"radius\": r} or {\"remove\": i}");
    size_t i = 0;
    double r = 0;
    if (add) {
        if (cJSON_IsObject(add) && cJSON_GetObjectItemCaseSensitive(add, "file"))
            return ffd_fail(err, FFD_ERR_PARSE,
                            "primitive: add.file: files are not read "
                            "here; give the geometry inline (\"vertices\", \"faces\")");
        ffd_rig_primitive prim;
        memset(&prim, 0, sizeof prim);
        if (!(s = ffd_rig_read_primitive(&p, add, "add", &prim)))
            s = primitive_op(m, &prim, 0, 0, 0, err);
        ffd_rig_primitive_free(&prim);
    } else if (remove) {
        if (!(s = read_index(&p, body, "remove", m->count, &i)) && m->count == 1)
            s = ffd_fail(err, FFD_ERR_INVALID,
                         SESS_CONFLICT "primitive: remove: the skeleton's only primitive cannot "
                                       "be removed");
        if (!s)
            s = primitive_op(m, NULL, i, 0, 1, err);
    } else {
        if (!index)
            return ffd_rig_expected(&p, "index", "a primitive index (missing)");
        if (!radius)
            return ffd_rig_expected(&p, "radius", "the influence radius r_s > 0 (missing)");
        if (!(s = read_index(&p, body, "index", m->count, &i)) &&
            !(s = ffd_rig_read_positive(&p, radius, "radius", &r)))
            s = primitive_op(m, NULL, i, r, 0, err);
    }
    if (!s)
        *undo = SESS_UNDO_REBUILD;
    return s;
}

static ffd_status gf_op(sess_method *base, const char *op, const cJSON *body, int *undo,
                        ffd_error *err)
{
    gf_method *m = (gf_method *)base;
    if (strcmp(op, "primitive") != 0)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not an operation of the gffd method", op);
    if (!cJSON_IsObject(body))
        return ffd_fail(err, FFD_ERR_PARSE, "primitive: expected a JSON object");
    return op_primitive(m, body, undo, err);
}

/* Any point set (ffd_deformer_bind), at the end of this file. */
static ffd_status gf_bind_points(sess_method *base, const double *points, size_t n,
                                 sess_binding **out, ffd_error *err);
static void gf_binding_free(sess_binding *b);
static ffd_status gf_eval_points(sess_method *base, const sess_binding *b, double *out,
                                 ffd_error *err);
static void *gf_handle(sess_method *base);

/* No sensitivities (docs/sensitivities.md, "GFFD"). A tracked point x
 * satisfies the field-value condition E(x, S) = e0 only to the tracking
 * tolerance, and implicit differentiation of it, grad_x E . dx =
 * -(dE/dS) dS, fixes only the component of dx along grad_x E. The rest of
 * the motion is decided by the path gffd_track.c takes (gradient steps from
 * the rest position with halvings and a secant, the warp's fallback, the
 * rigid shortcut, the influence band's blend), which switches branches and
 * stops at a tolerance: it has no derivative to give. */
static ffd_status gf_no_sensitivity(ffd_error *err)
{
    return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                    "sensitivities: the gffd method has no sensitivities: its deformed points "
                    "are not a linear map of its controls, and tracking gives them no derivative: a "
                    "tracked point keeps its field value only to the tracking tolerance, and "
                    "that condition fixes only the motion along the field's gradient; the rest "
                    "comes from the tracking path (docs/sensitivities.md, \"GFFD\")");
}

static ffd_status gf_sensitivity_product(sess_method *m, const sess_binding *b, const double *v,
                                         double *out, ffd_error *err)
{
    (void)m;
    (void)b;
    (void)v;
    (void)out;
    return gf_no_sensitivity(err);
}

static ffd_status gf_sensitivity_transpose_product(sess_method *m, const sess_binding *b,
                                                   const double *w, double *out, ffd_error *err)
{
    (void)m;
    (void)b;
    (void)w;
    (void)out;
    return gf_no_sensitivity(err);
}

static const sess_vtable gffd_vtable = {
    .name = "gffd",
    .destroy = gf_destroy,
    .eval = gf_eval,
    .control_count = gf_control_count,
    .controls = gf_controls,
    .describe = gf_describe,
    .begin = gf_begin,
    .set_controls = gf_set_controls,
    .linear_map = NULL, /* GFFD is not linear in its controls */
    .set_variables = NULL,
    .end = gf_end,
    .set_motion = gf_set_motion,
    .snapshot = gf_snapshot_take,
    .restore = gf_restore,
    .snapshot_free = gf_snapshot_free,
    .reset = gf_reset,
    .rig = gf_rig,
    .influence = gf_influence,
    .op = gf_op,
    .bind = gf_bind_points,
    .binding_free = gf_binding_free,
    .eval_points = gf_eval_points,
    .jacobian_points = NULL, /* tracking has no derivative to give (docs/gffd.md) */
    .map_points = NULL,      /* GFFD is not linear in its skeleton */
    .handle = gf_handle,
    .sensitivity_product = gf_sensitivity_product,
    .sensitivity_transpose_product = gf_sensitivity_transpose_product,
};

/* ---- any point set (ffd_deformer_bind) ------------------------------- */

/* The binding keeps the points only: what binding records (§3: e_0 in the
 * rest field, the band's weight) depends on the rest skeleton, which a
 * primitive edit replaces (a new ffd_gffd), so it is derived again at each
 * evaluation, in the loop ffd_gffd_create runs for the mesh (cheap next to
 * tracking), and the points are tracked against the current skeleton as
 * the mesh's vertices are (ffd_gffd_track_with). */
struct sess_binding {
    size_t n;
    double *points; /* n by 3 */
};

static void gf_binding_free(sess_binding *b)
{
    if (!b)
        return;
    ffd_free(b->points);
    ffd_free(b);
}

static ffd_status gf_bind_points(sess_method *base, const double *points, size_t n,
                                 sess_binding **out, ffd_error *err)
{
    (void)base;
    *out = NULL;
    sess_binding *b = ffd_calloc(1, sizeof *b);
    if (b)
        b->points = ffd_malloc_array(n ? n : 1, 3 * sizeof *b->points);
    if (!b || !b->points) {
        gf_binding_free(b);
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    }
    if (n)
        memcpy(b->points, points, n * 3 * sizeof *b->points);
    b->n = n;
    *out = b;
    return FFD_OK;
}

static ffd_status gf_eval_points(sess_method *base, const sess_binding *b, double *out,
                                 ffd_error *err)
{
    gf_method *m = (gf_method *)base;
    ffd_status s = m->synced ? FFD_OK : replay_skeleton(m, err);
    if (s)
        return s;
    double *e0 = ffd_malloc_array(b->n ? b->n : 1, sizeof *e0);
    double *weight = ffd_malloc_array(b->n ? b->n : 1, sizeof *weight);
    if (!e0 || !weight) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "eval: out of memory for %zu points", b->n);
    } else {
        ffd_error inner = {{0}};
        ffd_gffd_bind_values(m->g, b->points, b->n, e0, weight);
        /* tracking (Fig. 5), as gf_eval's */
        if ((s = ffd_gffd_track_with(m->g, b->points, e0, weight, b->n, out, NULL, &inner)))
            s = ffd_fail(err, s, "tracking: %s", inner.message);
    }
    ffd_free(e0);
    ffd_free(weight);
    return s;
}

static void *gf_handle(sess_method *base)
{
    return ((gf_method *)base)->g;
}
