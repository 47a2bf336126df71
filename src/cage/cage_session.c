/* cage_session — the cage method's deformer (the editor's and
 * ffd_deformer's): the controls are the cage's vertices; its rig is the
 * cage written inline (an "auto" cage made explicit) plus one move per
 * displaced vertex (delta = current - rest). */
#include "cage/cage_method.h"
#include "session/session.h"

#include <string.h>

typedef struct cage_method {
    sess_method base;
    ffd_cage *cage;
    ffd_cage_binding *binding;
    ffd_cage_options options;
    double *begin; /* cage vertices at the start of a drag */
} cage_method;

static cage_method *as_cage(const sess_method *m)
{
    return (cage_method *)(void *)m;
}

static void cage_destroy(sess_method *m)
{
    cage_method *c = as_cage(m);
    ffd_cage_binding_destroy(c->binding);
    ffd_cage_destroy(c->cage);
    ffd_free(c->begin);
    ffd_free(c);
}

static ffd_status cage_eval(sess_method *m, double *out, ffd_error *err)
{
    cage_method *c = as_cage(m);
    return ffd_cage_eval(c->cage, c->binding, out, err);
}

static size_t cage_count(const sess_method *m)
{
    return ffd_cage_vertex_count(as_cage(m)->cage);
}

static void cage_controls(const sess_method *m, double *out)
{
    memcpy(out, ffd_cage_vertices(as_cage(m)->cage), cage_count(m) * 3 * sizeof *out);
}

static const char *const coordinate_names[] = {"mean_value", "harmonic"};
static const char *const outside_names[] = {"", "extend", "fixed", "clamp"};

static ffd_status cage_describe(const sess_method *m, cJSON *params, cJSON *controls,
                                ffd_error *err)
{
    const cage_method *c = as_cage(m);
    const ffd_cage *cage = c->cage;
    size_t nt = ffd_cage_triangle_count(cage);
    const uint32_t *tri = ffd_cage_triangles(cage);
    const int harmonic = ffd_cage_coordinate_kind(cage) == FFD_CAGE_HARMONIC;
    cJSON *edges = cJSON_CreateArray(), *faces = NULL;
    int ok = edges && cJSON_AddItemToObject(controls, "edges", edges);
    if (!ok)
        cJSON_Delete(edges);
    for (size_t h = 0; ok && h < 3 * nt; h++) {
        uint32_t a = tri[h], b = tri[h - h % 3 + (h % 3 + 1) % 3];
        ok = a > b || ffd_sess_add_edge(edges, a, b);
    }
    ok = ok && (faces = cJSON_AddArrayToObject(controls, "triangles")) != NULL;
    for (size_t t = 0; ok && t < nt; t++)
        ok = ffd_sess_add_to_array(faces, ffd_sess_uint_array(tri + 3 * t, 3));
    ok = ok &&
         cJSON_AddStringToObject(params, "coordinates", coordinate_names[harmonic]) &&
         cJSON_AddStringToObject(params, "outside", outside_names[ffd_cage_outside_rule(cage)]) &&
         (!harmonic || cJSON_AddNumberToObject(params, "resolution",
                                               c->options.resolution
                                                   ? c->options.resolution
                                                   : FFD_CAGE_RESOLUTION_DEFAULT)) &&
         cJSON_AddStringToObject(controls, "coordinates", coordinate_names[harmonic]);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
}

static ffd_status cage_begin(sess_method *m, const uint32_t *ids, size_t k, int arap,
                             ffd_error *err)
{
    cage_method *c = as_cage(m);
    (void)ids, (void)k, (void)arap;
    ffd_free(c->begin);
    c->begin = ffd_malloc_array(cage_count(m), 3 * sizeof *c->begin);
    if (!c->begin)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag_begin: out of memory");
    cage_controls(m, c->begin);
    return FFD_OK;
}

/* The drag's start plus a change: vertices ids at targets, or every vertex + dv. */
static ffd_status set_from_begin(cage_method *c, const uint32_t *ids, size_t k,
                                 const double *targets, const double *dv, ffd_error *err)
{
    size_t nv = cage_count(&c->base);
    double *p = ffd_malloc_array(nv, 3 * sizeof *p);
    if (!p)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    memcpy(p, c->begin, nv * 3 * sizeof *p);
    for (size_t i = 0; i < k; i++)
        memcpy(p + 3 * (size_t)ids[i], targets + 3 * i, 3 * sizeof *p);
    for (size_t i = 0; dv && i < 3 * nv; i++)
        p[i] += dv[i];
    ffd_status st = ffd_cage_set_vertices(c->cage, p, err);
    ffd_free(p);
    return st;
}

static ffd_status cage_set_controls(sess_method *m, const uint32_t *ids, size_t k,
                                    const double *targets, ffd_error *err)
{
    return set_from_begin(as_cage(m), ids, k, targets, NULL, err);
}

static ffd_status cage_linear_map(sess_method *m, ffd_linear_map *map, ffd_error *err)
{
    cage_method *c = as_cage(m);
    (void)err;
    ffd_cage_linear_map(c->cage, c->binding, map);
    return FFD_OK;
}

static ffd_status cage_set_variables(sess_method *m, const double *dv, ffd_error *err)
{
    return set_from_begin(as_cage(m), NULL, 0, NULL, dv, err);
}

static void cage_end(sess_method *m, int commit)
{
    cage_method *c = as_cage(m);
    if (!commit && c->begin)
        ffd_cage_set_vertices(c->cage, c->begin, NULL);
    ffd_free(c->begin);
    c->begin = NULL;
}

static ffd_status cage_snapshot(const sess_method *m, void **blob, ffd_error *err)
{
    size_t nv = cage_count(m);
    double *copy = ffd_malloc_array(nv + 1, 3 * sizeof *copy);
    if (!copy)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the undo history");
    copy[0] = (double)nv;
    cage_controls(m, copy + 3);
    *blob = copy;
    return FFD_OK;
}

static ffd_status cage_restore(sess_method *m, const void *blob, ffd_error *err)
{
    const double *copy = blob;
    if ((size_t)copy[0] != cage_count(m))
        return ffd_fail(err, FFD_ERR_INVALID, "undo: the history does not match the cage");
    return ffd_cage_set_vertices(as_cage(m)->cage, copy + 3, err);
}

static ffd_status cage_reset(sess_method *m, ffd_error *err)
{
    (void)err;
    ffd_cage_reset(as_cage(m)->cage);
    return FFD_OK;
}

/* The state as a rig: the rest cage inline, its coordinates, and a move
 * per displaced vertex, written by the rig's own writer (cage_rig_json.c). */
static ffd_status cage_rig(const sess_method *m, cJSON *root, ffd_error *err)
{
    const cage_method *c = as_cage(m);
    const ffd_cage *cage = c->cage;
    ffd_rig rig;
    ffd_rig_cage section;
    ffd_rig_view(&rig, &ffd_method_cage, &section, sizeof section);
    size_t nv = ffd_cage_vertex_count(cage);
    const double *rest = ffd_cage_rest_vertices(cage), *cur = ffd_cage_vertices(cage);
    section.vertices = (double *)rest;
    section.vertex_count = nv;
    section.triangles = (uint32_t *)ffd_cage_triangles(cage);
    section.triangle_count = ffd_cage_triangle_count(cage);
    section.options = c->options;
    section.moves = ffd_malloc_array(nv, sizeof *section.moves);
    if (!section.moves)
        return ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
    for (size_t j = 0; j < nv; j++) {
        const double *p = cur + 3 * j, *q = rest + 3 * j;
        if (p[0] == q[0] && p[1] == q[1] && p[2] == q[2])
            continue;
        ffd_rig_cage_move *mv = &section.moves[section.move_count++];
        mv->index = (uint32_t)j;
        for (int a = 0; a < 3; a++)
            mv->delta[a] = p[a] - q[a];
    }
    int ok = ffd_method_cage.write(&rig, root);
    ffd_free(section.moves);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
}

static ffd_status cage_influence(sess_method *m, const uint32_t *ids, size_t k, float *w,
                                 ffd_error *err)
{
    ffd_linear_map map;
    ffd_status st = cage_linear_map(m, &map, err);
    return st ? st : ffd_sess_map_influence(&map, 1, m->ctx->n, ids, k, w, err);
}

static ffd_status cage_op(sess_method *m, const char *op, const cJSON *body, int *undo_kind,
                          ffd_error *err)
{
    (void)m, (void)body, (void)undo_kind;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not a cage operation", op);
}

/* ---- any point set (ffd_deformer_bind): the cage never changes its
 * structure, so a binding made once stays valid across every control change */

struct sess_binding {
    ffd_cage_binding *cage;
};

static ffd_status cage_bind(sess_method *m, const double *points, size_t n, sess_binding **out,
                            ffd_error *err)
{
    sess_binding *b = ffd_calloc(1, sizeof *b);
    if (!b)
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    ffd_error inner = {{0}};
    ffd_status st = ffd_cage_bind(as_cage(m)->cage, points, n, &b->cage, &inner);
    if (st) {
        ffd_free(b);
        return ffd_fail(err, st, "bind: %s", inner.message);
    }
    *out = b;
    return FFD_OK;
}

static void cage_binding_free(sess_binding *b)
{
    if (!b)
        return;
    ffd_cage_binding_destroy(b->cage);
    ffd_free(b);
}

static ffd_status cage_eval_points(sess_method *m, const sess_binding *b, double *out,
                                   ffd_error *err)
{
    return ffd_cage_eval(as_cage(m)->cage, b->cage, out, err);
}

static ffd_status cage_map_points(sess_method *m, const sess_binding *b, ffd_linear_map *map,
                                  ffd_error *err)
{
    (void)err;
    ffd_cage_linear_map(as_cage(m)->cage, b->cage, map);
    return FFD_OK;
}

static void *cage_handle(sess_method *m)
{
    return as_cage(m)->cage;
}

static const sess_vtable cage_vtable = {
    .name = "cage",
    .destroy = cage_destroy,
    .eval = cage_eval,
    .control_count = cage_count,
    .controls = cage_controls,
    .describe = cage_describe,
    .begin = cage_begin,
    .set_controls = cage_set_controls,
    .linear_map = cage_linear_map,
    .set_variables = cage_set_variables,
    .end = cage_end,
    .snapshot = cage_snapshot,
    .restore = cage_restore,
    .snapshot_free = ffd_free,
    .reset = cage_reset,
    .rig = cage_rig,
    .influence = cage_influence,
    .op = cage_op,
    .bind = cage_bind,
    .binding_free = cage_binding_free,
    .eval_points = cage_eval_points,
    .map_points = cage_map_points,
    .handle = cage_handle,
};

ffd_status ffd_sess_cage_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                              ffd_error *err)
{
    const ffd_rig_cage *section = ffd_rig_cage_of(rig);
    size_t nv = section->cage_auto ? CAGE_AUTO_VERTICES : section->vertex_count;
    size_t nt = section->cage_auto ? CAGE_AUTO_TRIANGLES : section->triangle_count;
    ffd_status st = ffd_sess_check_controls(ctx, (double)nv, rig->name, err);
    if (st)
        return st;
    /* the rig's moves and constraints, as ffd deform applies them (which
     * charges the limits); else the cage at rest, charged here */
    const int replay = section->move_count || rig->constraint_count;
    ffd_budget budget;
    ffd_budget_init(&budget, &ctx->limits);
    if (!replay && (st = ffd_rig_cage_charge(rig, ctx->n, nv, nt, &budget, err)))
        return st;
    ffd_rig_report report = {0};
    if (replay && (st = ffd_sess_apply_rig(ctx, rig, &report, err)))
        return st;
    cage_method *c = ffd_calloc(1, sizeof *c);
    if (!c) {
        ffd_rig_report_free(&report);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    }
    c->base.vt = &cage_vtable;
    c->base.ctx = ctx;
    c->options = section->options;
    ffd_error inner = {{0}};
    st = ffd_rig_cage_create(rig, ctx->rest, ctx->n, &c->cage, err);
    if (!st && (st = ffd_cage_bind(c->cage, ctx->rest, ctx->n, &c->binding, &inner)))
        st = ffd_fail(err, st, "%s: %s", rig->name, inner.message);
    if (!st && replay && report.control_count != ffd_cage_vertex_count(c->cage))
        st = ffd_fail(err, FFD_ERR_INVALID, "%s: the rig's cage does not match", rig->name);
    if (!st && replay)
        st = ffd_cage_set_vertices(c->cage, report.control_points, err);
    ffd_rig_report_free(&report);
    if (st) {
        cage_destroy(&c->base);
        return st;
    }
    *out = &c->base;
    return FFD_OK;
}
