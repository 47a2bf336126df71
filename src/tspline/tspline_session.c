/* session_tspline — the proxy-driven T-spline method of the editor (Zhang,
 * Zheng & Cai 2020): controls are the T-lattice's points; dragging them runs
 * the proxy ARAP solve (§3.4) with the dragged points as handles and the
 * frozen points fixed; "refine" inserts edges, faces or cells (§3.2-3.3) at
 * any time. Its rig: the refinement edits in order (ids resolved), then one
 * "move" step putting every displaced point where it is (refinement is
 * exact, so refining first and moving afterwards gives the same map). */
#include "tspline/tspline_method.h"
#include "session/session.h"
#include "tspline/tsv.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

typedef struct refine_edit {
    ffd_tsv_insertion *ins;
    size_t count;
} refine_edit;

typedef struct tspline_method {
    sess_method base;
    ffd_tsv *t;
    uint32_t res[3];
    double padding;
    refine_edit *edits;
    size_t edit_count;
    /* the drag in progress */
    double *begin;
    ffd_tsv_arap *arap;
} tspline_method;

static tspline_method *as_tsv(const sess_method *m)
{
    return (tspline_method *)(void *)m;
}

static void edits_free(refine_edit *edits, size_t count)
{
    for (size_t i = 0; i < count; i++)
        ffd_free(edits[i].ins);
    ffd_free(edits);
}

static void tsv_destroy_method(sess_method *m)
{
    tspline_method *t = as_tsv(m);
    ffd_tsv_arap_destroy(t->arap);
    ffd_tsv_destroy(t->t);
    edits_free(t->edits, t->edit_count);
    ffd_free(t->begin);
    ffd_free(t);
}

static ffd_status tsv_eval_method(sess_method *m, double *out, ffd_error *err)
{
    return ffd_tsv_eval(as_tsv(m)->t, out, err);
}

static size_t tsv_count(const sess_method *m)
{
    return ffd_tsv_control_count(as_tsv(m)->t);
}

static void tsv_controls(const sess_method *m, double *out)
{
    memcpy(out, ffd_tsv_control_points(as_tsv(m)->t), tsv_count(m) * 3 * sizeof *out);
}

/* o[key] = the proxy's faces as arrays of index (control ids or points). */
static int add_faces(cJSON *o, const char *key, const uint32_t *index, const ffd_tsv_proxy *proxy)
{
    cJSON *faces = cJSON_CreateArray();
    int ok = ffd_sess_add_item(o, key, faces);
    for (size_t f = 0; ok && f < proxy->face_count; f++)
        ok = ffd_sess_add_to_array(faces, ffd_sess_uint_array(index + proxy->face_offsets[f],
                                                      proxy->face_offsets[f + 1] -
                                                          proxy->face_offsets[f]));
    return ok;
}

static cJSON *proxy_json(const ffd_tsv *t)
{
    ffd_tsv_proxy proxy;
    ffd_tsv_get_proxy(t, &proxy);
    cJSON *o = cJSON_CreateObject();
    int ok = o && add_faces(o, "faces", proxy.face_indices, &proxy);
    /* the same faces as a closed 2-manifold: "face_points" index
     * "point_controls", one entry per sheet of each control point (all at
     * its position; dragging the control point moves them all) */
    ok = ok && add_faces(o, "face_points", proxy.face_points, &proxy);
    ok = ok && ffd_sess_add_item(o, "point_controls",
                             ffd_sess_uint_array(proxy.point_controls, proxy.point_count));
    ok = ok && ffd_sess_add_item(o, "points", ffd_sess_uint_array(proxy.vertices,
                                                                  proxy.vertex_count)) &&
         cJSON_AddNumberToObject(o, "inside_cells", (double)proxy.inside_cells);
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

static ffd_status tsv_describe(const sess_method *m, cJSON *params, cJSON *controls,
                               ffd_error *err)
{
    const tspline_method *t = as_tsv(m);
    size_t ne = ffd_tsv_element_count(t->t, FFD_TSV_EDGE), nv = tsv_count(m);
    cJSON *edges = cJSON_CreateArray(), *frozen = cJSON_CreateArray();
    /* ffd_sess_add_item deletes an item it could not add */
    int ok = ffd_sess_add_item(controls, "edges", edges);
    if (ok)
        ok = ffd_sess_add_item(controls, "frozen", frozen);
    else
        cJSON_Delete(frozen);
    for (size_t e = 0; ok && e < ne; e++) {
        uint32_t ends[2];
        int axis;
        ok = ffd_tsv_edge(t->t, (uint32_t)e, ends, &axis, NULL) == FFD_OK &&
             ffd_sess_add_edge(edges, ends[0], ends[1]);
    }
    for (size_t v = 0; ok && v < nv; v++) {
        cJSON *id;
        if (!ffd_tsv_frozen(t->t, (uint32_t)v))
            continue;
        ok = (id = cJSON_CreateNumber((double)v)) && cJSON_AddItemToArray(frozen, id);
    }
    cJSON *proxy = ok ? proxy_json(t->t) : NULL;
    ok = ok && proxy && cJSON_AddItemToObject(controls, "proxy", proxy);
    if (!ok && proxy)
        cJSON_Delete(proxy);
    ok = ok && cJSON_AddNumberToObject(controls, "cells", (double)ffd_tsv_element_count(t->t, FFD_TSV_CELL)) &&
         cJSON_AddNumberToObject(controls, "faces", (double)ffd_tsv_element_count(t->t, FFD_TSV_FACE)) &&
         cJSON_AddNumberToObject(controls, "edges_count", (double)ne) &&
         cJSON_AddNumberToObject(controls, "max_weight_deviation",
                                 ffd_tsv_max_weight_deviation(t->t)) &&
         cJSON_AddNumberToObject(controls, "refinements", (double)t->edit_count) &&
         ffd_sess_add_item(params, "resolution", ffd_sess_uint_array(t->res, 3)) &&
         cJSON_AddNumberToObject(params, "padding", t->padding);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
}

/* A drag: the dragged points are ARAP handles (§3.4) unless arap is 0. */
static ffd_status tsv_begin(sess_method *m, const uint32_t *ids, size_t k, int arap,
                            ffd_error *err)
{
    tspline_method *t = as_tsv(m);
    ffd_free(t->begin);
    t->begin = ffd_malloc_array(tsv_count(m), 3 * sizeof *t->begin);
    if (!t->begin)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag_begin: out of memory");
    tsv_controls(m, t->begin);
    if (k && arap) {
        ffd_error inner = {{0}};
        ffd_budget budget;
        ffd_budget_init(&budget, &m->ctx->limits);
        ffd_status st = ffd_rig_tsv_charge_arap(t->t, 0, &budget, &inner);
        if (!st)
            st = ffd_tsv_arap_begin(t->t, ids, k, NULL, &t->arap, &inner);
        if (st) {
            ffd_free(t->begin);
            t->begin = NULL;
            return ffd_fail(err, st, "drag_begin: %s", inner.message);
        }
    }
    return FFD_OK;
}

static ffd_status tsv_set_from_begin(tspline_method *t, const uint32_t *ids, size_t k,
                                     const double *targets, const ffd_linear_map *map,
                                     const double *dv, ffd_error *err)
{
    size_t c = tsv_count(&t->base);
    double *p = ffd_malloc_array(c, 3 * sizeof *p);
    if (!p)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    memcpy(p, t->begin, c * 3 * sizeof *p);
    for (size_t i = 0; i < k; i++)
        memcpy(p + 3 * (size_t)ids[i], targets + 3 * i, 3 * sizeof *p);
    for (size_t v = 0; dv && v < c; v++) {
        uint32_t x = map->tie ? map->tie[v] : (uint32_t)v;
        if (x == FFD_TIE_FIXED)
            continue;
        for (int a = 0; a < 3; a++)
            p[3 * v + a] += dv[3 * (size_t)x + a];
    }
    ffd_status st = ffd_tsv_set_control_points(t->t, p, err);
    ffd_free(p);
    return st;
}

static ffd_status tsv_set_controls(sess_method *m, const uint32_t *ids, size_t k,
                                   const double *targets, ffd_error *err)
{
    tspline_method *t = as_tsv(m);
    if (t->arap) {
        ffd_tsv_arap_report report;
        return ffd_tsv_arap_solve(t->arap, targets, &report, err);
    }
    return tsv_set_from_begin(t, ids, k, targets, NULL, NULL, err);
}

static ffd_status tsv_linear_map(sess_method *m, ffd_linear_map *map, ffd_error *err)
{
    return ffd_tsv_linear_map(as_tsv(m)->t, map, err);
}

static ffd_status tsv_set_variables(sess_method *m, const double *dv, ffd_error *err)
{
    ffd_linear_map map;
    ffd_status st = tsv_linear_map(m, &map, err);
    return st ? st : tsv_set_from_begin(as_tsv(m), NULL, 0, NULL, &map, dv, err);
}

static void tsv_end(sess_method *m, int commit)
{
    tspline_method *t = as_tsv(m);
    if (!commit && t->begin)
        ffd_tsv_set_control_points(t->t, t->begin, NULL);
    ffd_tsv_arap_destroy(t->arap);
    t->arap = NULL;
    ffd_free(t->begin);
    t->begin = NULL;
}

/* Snapshot: [count, points (3 count), frozen flags (count)]. */
static ffd_status tsv_snapshot(const sess_method *m, void **blob, ffd_error *err)
{
    size_t c = tsv_count(m);
    double *copy = ffd_malloc_array(4 * c + 1, sizeof *copy);
    if (!copy)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the undo history");
    copy[0] = (double)c;
    tsv_controls(m, copy + 1);
    for (size_t v = 0; v < c; v++)
        copy[1 + 3 * c + v] = ffd_tsv_frozen(as_tsv(m)->t, (uint32_t)v);
    *blob = copy;
    return FFD_OK;
}

static ffd_status tsv_restore(sess_method *m, const void *blob, ffd_error *err)
{
    const double *copy = blob;
    size_t c = tsv_count(m);
    if ((size_t)copy[0] != c)
        return ffd_fail(err, FFD_ERR_INVALID, "undo: the history does not match the T-lattice");
    ffd_status st = ffd_tsv_set_control_points(as_tsv(m)->t, copy + 1, err);
    for (size_t v = 0; !st && v < c; v++)
        st = ffd_tsv_set_frozen(as_tsv(m)->t, (uint32_t)v, copy[1 + 3 * c + v] != 0, err);
    return st;
}

static ffd_status tsv_reset_method(sess_method *m, ffd_error *err)
{
    ffd_tsv_reset(as_tsv(m)->t);
    return FFD_OK;
}

/* The state as a rig: a refine step per refinement edit, then one move step
 * with a move per displaced control point, written by the rig's own writer
 * (tspline_rig_json.c). */
static ffd_status tsv_rig(const sess_method *m, cJSON *root, ffd_error *err)
{
    const tspline_method *t = as_tsv(m);
    const size_t points = tsv_count(m);
    size_t insertions = 0;
    for (size_t e = 0; e < t->edit_count; e++)
        insertions += t->edits[e].count;
    ffd_rig rig;
    ffd_rig_tspline ts;
    ffd_rig_view(&rig, &ffd_method_tspline, &ts, sizeof ts);
    memcpy(ts.resolution, t->res, sizeof ts.resolution);
    ts.options.padding = t->padding;
    ts.steps = ffd_calloc(t->edit_count + 1, sizeof *ts.steps);
    ffd_rig_tsv_refinement *refs = ffd_calloc(insertions ? insertions : 1, sizeof *refs);
    ffd_rig_tsv_handle *moves = ffd_calloc(points ? points : 1, sizeof *moves);
    uint32_t *ids = ffd_malloc_array(points ? points : 1, sizeof *ids);
    int ok = ts.steps && refs && moves && ids;
    for (size_t e = 0, r = 0; ok && e < t->edit_count; e++) {
        ffd_rig_tsv_step *st = &ts.steps[ts.step_count++];
        st->kind = FFD_RIG_STEP_REFINE;
        st->refinements = refs + r;
        st->refinement_count = t->edits[e].count;
        for (size_t i = 0; i < t->edits[e].count; i++, r++) {
            refs[r].kind = t->edits[e].ins[i].kind;
            refs[r].id = t->edits[e].ins[i].id;
            refs[r].ratio = t->edits[e].ins[i].ratio;
        }
    }
    const double *P = ffd_tsv_control_points(t->t);
    size_t moved = 0;
    for (size_t v = 0; ok && v < points; v++) {
        double rest[3];
        ffd_rig_tsv_handle *h = &moves[moved];
        ok = ffd_tsv_rest_point(t->t, (uint32_t)v, rest, NULL) == FFD_OK;
        for (int a = 0; a < 3; a++)
            h->delta[a] = P[3 * v + a] - rest[a];
        if (!ok || (h->delta[0] == 0 && h->delta[1] == 0 && h->delta[2] == 0))
            continue;
        ids[moved] = (uint32_t)v;
        h->sel.kind = FFD_RIG_SELECT_POINTS;
        h->sel.ids = &ids[moved];
        h->sel.id_count = 1;
        h->has_delta = 1;
        moved++;
    }
    if (ok && moved) {
        ffd_rig_tsv_step *st = &ts.steps[ts.step_count++];
        st->kind = FFD_RIG_STEP_MOVE;
        st->handles = moves;
        st->handle_count = moved;
    }
    ok = ok && ffd_method_tspline.write(&rig, root);
    ffd_free(ts.steps);
    ffd_free(refs);
    ffd_free(moves);
    ffd_free(ids);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
}

static ffd_status tsv_influence(sess_method *m, const uint32_t *ids, size_t k, float *w,
                                ffd_error *err)
{
    ffd_linear_map map;
    ffd_status st = tsv_linear_map(m, &map, err);
    return st ? st : ffd_sess_map_influence(&map, 1, m->ctx->n, ids, k, w, err);
}

/* One refinement edit (§3.2-3.3): insertions resolved, applied, logged. */
static ffd_status refine_apply(tspline_method *t, const ffd_rig_tsv_step *step, const char *what,
                               ffd_error *err)
{
    ffd_tsv_insertion *ins = NULL;
    size_t count = 0;
    ffd_error inner = {{0}};
    ffd_status st = ffd_rig_tsv_resolve(t->t, step, &ins, &count, &inner);
    refine_edit *grown = NULL;
    if (!st && count == 0)
        st = ffd_fail(&inner, FFD_ERR_INVALID, "nothing to refine (no cell inside the proxy)");
    if (!st) {
        ffd_budget budget;
        ffd_budget_init(&budget, &t->base.ctx->limits);
        st = ffd_rig_tsv_charge_refine(t->t, ins, count, &budget, &inner);
    }
    if (!st && !(grown = ffd_realloc_array(t->edits, t->edit_count + 1, sizeof *grown)))
        st = ffd_fail(&inner, FFD_ERR_NOMEM, "out of memory");
    if (!st) {
        t->edits = grown;
        ffd_tsv_refine_report report;
        st = ffd_tsv_refine(t->t, ins, count, &report, &inner);
    }
    if (st) {
        ffd_free(ins);
        return ffd_fail(err, st, "%s: %s", what, inner.message);
    }
    t->edits[t->edit_count++] = (refine_edit){ins, count};
    return FFD_OK;
}

static ffd_status op_refine(tspline_method *t, const cJSON *body, ffd_error *err)
{
    static const char *const keys[] = {"insertions", NULL};
    ffd_rig_parser p = {"refine", err, NULL};
    ffd_status st = ffd_rig_check_keys(&p, body, "body", keys, "insertions");
    const cJSON *list = cJSON_GetObjectItemCaseSensitive(body, "insertions");
    if (!st && !list)
        st = ffd_rig_expected(&p, "insertions", "an array of insertions (missing)");
    ffd_rig_tsv_step step = {0};
    if (!st)
        st = ffd_rig_read_tsv_refinements(&p, list, "insertions", &step);
    if (!st)
        st = refine_apply(t, &step, "refine", err);
    ffd_free(step.refinements);
    return st;
}

static ffd_status op_freeze(tspline_method *t, const cJSON *body, ffd_error *err)
{
    static const char *const keys[] = {"points", "frozen", NULL};
    ffd_rig_parser p = {"freeze", err, NULL};
    uint32_t *ids = NULL;
    size_t k = 0;
    ffd_status st = ffd_rig_check_keys(&p, body, "body", keys, "points, frozen");
    const cJSON *frozen = cJSON_GetObjectItemCaseSensitive(body, "frozen");
    if (!st && frozen && !cJSON_IsBool(frozen))
        st = ffd_rig_expected(&p, "frozen", "true or false");
    if (!st)
        st = ffd_sess_read_ids(&p, cJSON_GetObjectItemCaseSensitive(body, "points"), "points",
                           tsv_count(&t->base), &ids, &k);
    for (size_t i = 0; !st && i < k; i++)
        st = ffd_tsv_set_frozen(t->t, ids[i], !frozen || cJSON_IsTrue(frozen), err);
    ffd_free(ids);
    return st;
}

static ffd_status tsv_op(sess_method *m, const char *op, const cJSON *body, int *undo_kind,
                         ffd_error *err)
{
    tspline_method *t = as_tsv(m);
    if (!strcmp(op, "refine")) {
        *undo_kind = SESS_UNDO_REBUILD;
        return op_refine(t, body, err);
    }
    if (!strcmp(op, "freeze")) {
        *undo_kind = SESS_UNDO_STATE;
        /* all or nothing: validate first, then apply */
        void *blob = NULL;
        ffd_status st = tsv_snapshot(m, &blob, err);
        if (!st && (st = op_freeze(t, body, err)))
            tsv_restore(m, blob, NULL);
        ffd_free(blob);
        return st;
    }
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not a T-spline operation", op);
}

/* Any point set (ffd_deformer_bind), at the end of this file. */
static ffd_status tsv_bind_points(sess_method *m, const double *points, size_t n,
                                  sess_binding **out, ffd_error *err);
static void tsv_binding_free(sess_binding *b);
static ffd_status tsv_eval_points(sess_method *m, const sess_binding *b, double *out,
                                  ffd_error *err);
static ffd_status tsv_jacobian_points(sess_method *m, const sess_binding *b, double *out,
                                      ffd_error *err);
static ffd_status tsv_map_points(sess_method *m, const sess_binding *b, ffd_linear_map *map,
                                 ffd_error *err);
static void *tsv_handle(sess_method *m);
static ffd_status tsv_fold_check(sess_method *m, ffd_fold_report *out, ffd_error *err);

static const sess_vtable tspline_vtable = {
    .name = "tspline",
    .destroy = tsv_destroy_method,
    .eval = tsv_eval_method,
    .control_count = tsv_count,
    .controls = tsv_controls,
    .describe = tsv_describe,
    .begin = tsv_begin,
    .set_controls = tsv_set_controls,
    .linear_map = tsv_linear_map,
    .set_variables = tsv_set_variables,
    .end = tsv_end,
    .snapshot = tsv_snapshot,
    .restore = tsv_restore,
    .snapshot_free = ffd_free,
    .reset = tsv_reset_method,
    .rig = tsv_rig,
    .influence = tsv_influence,
    .op = tsv_op,
    .bind = tsv_bind_points,
    .binding_free = tsv_binding_free,
    .eval_points = tsv_eval_points,
    .jacobian_points = tsv_jacobian_points,
    .map_points = tsv_map_points,
    .handle = tsv_handle,
    .fold_check = tsv_fold_check,
};

static ffd_status tspline_build(const sess_ctx *ctx, const uint32_t res[3], double padding,
                                const char *what, tspline_method **out, ffd_error *err)
{
    /* refinements add points later; the initial lattice is what set-up costs */
    ffd_status st = ffd_sess_check_controls(ctx, (double)res[0] * res[1] * res[2], what, err);
    if (st)
        return st;
    tspline_method *t = ffd_calloc(1, sizeof *t);
    if (!t)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", what);
    t->base.vt = &tspline_vtable;
    t->base.ctx = ctx;
    memcpy(t->res, res, sizeof t->res);
    t->padding = padding;
    ffd_tsv_options options = {padding};
    ffd_error inner = {{0}};
    st = ffd_tsv_create(ctx->rest, ctx->n, ffd_mesh_face_offsets(ctx->mesh),
                                   ffd_mesh_face_indices(ctx->mesh),
                                   ffd_mesh_face_count(ctx->mesh), res, &options, &t->t, &inner);
    if (st) {
        tsv_destroy_method(&t->base);
        return ffd_fail(err, st, "%s: %s", what, inner.message);
    }
    *out = t;
    return FFD_OK;
}

/* The editor's "create": the rig's creation keys, with the rig's defaults
 * (ffd_method_create). */
ffd_status ffd_sess_tspline_create(const sess_ctx *ctx, const cJSON *body, sess_method **out,
                                   ffd_error *err)
{
    return ffd_method_create(&ffd_method_tspline, ctx, body, out, err);
}

ffd_status ffd_sess_tspline_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                             ffd_error *err)
{
    const ffd_rig_tspline *rt = ffd_rig_tspline_of(rig);
    tspline_method *t = NULL;
    ffd_status st = tspline_build(ctx, rt->resolution, rt->options.padding, rig->name, &t, err);
    /* the rig's refinements, in order (the other steps only move points) */
    for (size_t i = 0; !st && i < rt->step_count; i++)
        if (rt->steps[i].kind == FFD_RIG_STEP_REFINE) {
            char what[64];
            snprintf(what, sizeof what, "%s: steps[%zu].refine", rig->name, i);
            st = refine_apply(t, &rt->steps[i], what, err);
        }
    /* where its deform, move and constraints steps leave the points (a rig
     * without steps, the editor's create, leaves them at rest, as built) */
    ffd_rig_report report = {0};
    const int replay = rt->step_count > 0;
    if (!st && replay)
        st = ffd_sess_apply_rig(ctx, rig, &report, err);
    if (!st && replay && report.control_count != tsv_count(&t->base))
        st = ffd_fail(err, FFD_ERR_INVALID, "%s: the rig's T-lattice does not match", rig->name);
    if (!st && replay)
        st = ffd_tsv_set_control_points(t->t, report.control_points, err);
    ffd_rig_report_free(&report);
    if (st) {
        if (t)
            tsv_destroy_method(&t->base);
        return st;
    }
    *out = &t->base;
    return FFD_OK;
}

/* ---- any point set (ffd_deformer_bind) ------------------------------- */

/* The points' parameters in the T-lattice's box and their rows of Phi
 * (tsv_points), evaluated in displacement form like the mesh's vertices.
 * A refinement (op "refine", or ffd_tsv_refine through the handle) changes
 * the lattice: Phi is rebuilt at the next evaluation (the lattice's version
 * says when); control edits, reset and restore only move control points,
 * which the evaluation reads. The cache sits behind a pointer because
 * evaluation gets the binding const. */
struct sess_binding {
    tsv_points *p;
};

static void tsv_binding_free(sess_binding *b)
{
    if (!b)
        return;
    ffd_tsv_points_free(b->p);
    ffd_free(b->p);
    ffd_free(b);
}

static ffd_status tsv_bind_points(sess_method *m, const double *points, size_t n,
                                  sess_binding **out, ffd_error *err)
{
    *out = NULL;
    sess_binding *b = ffd_calloc(1, sizeof *b);
    if (b)
        b->p = ffd_calloc(1, sizeof *b->p);
    if (!b || !b->p) {
        ffd_free(b);
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    }
    ffd_error inner = {{0}};
    ffd_status st = ffd_tsv_points_bind(as_tsv(m)->t, points, n, b->p, &inner);
    if (st) {
        tsv_binding_free(b);
        return ffd_fail(err, st, "bind: %s", inner.message);
    }
    *out = b;
    return FFD_OK;
}

/* Phi for the current lattice (rebuilt after a refinement). */
static ffd_status tsv_points_current(sess_method *m, const sess_binding *b, const char *what,
                                     ffd_error *err)
{
    ffd_error inner = {{0}};
    ffd_status st = ffd_tsv_points_update(as_tsv(m)->t, b->p, &inner);
    return st ? ffd_fail(err, st, "%s: %s", what, inner.message) : FFD_OK;
}

static ffd_status tsv_eval_points(sess_method *m, const sess_binding *b, double *out,
                                  ffd_error *err)
{
    ffd_status st = tsv_points_current(m, b, "eval", err);
    if (!st)
        ffd_tsv_points_eval(as_tsv(m)->t, b->p, out);
    return st;
}

static ffd_status tsv_jacobian_points(sess_method *m, const sess_binding *b, double *out,
                                      ffd_error *err)
{
    ffd_status st = tsv_points_current(m, b, "jacobian", err);
    if (!st)
        ffd_tsv_points_jacobian(as_tsv(m)->t, b->p, out);
    return st;
}

static ffd_status tsv_map_points(sess_method *m, const sess_binding *b, ffd_linear_map *map,
                                 ffd_error *err)
{
    ffd_status st = tsv_points_current(m, b, "linear map", err);
    ffd_error inner = {{0}};
    if (!st && (st = ffd_tsv_points_map(as_tsv(m)->t, b->p, map, &inner)))
        st = ffd_fail(err, st, "linear map: %s", inner.message);
    return st;
}

static void *tsv_handle(sess_method *m)
{
    return as_tsv(m)->t;
}

/* The T-spline's own fold check (ffd_tsv_check_folds, 3^3 samples per cell)
 * as the generic report; its inverted faces stay in the rig report. */
static ffd_status tsv_fold_check(sess_method *m, ffd_fold_report *out, ffd_error *err)
{
    ffd_tsv_fold_report f;
    ffd_status st = ffd_tsv_check_folds(as_tsv(m)->t, 0, &f, err);
    if (st)
        return st;
    out->cells = "T-spline cell";
    out->cells_checked = f.cells_checked;
    out->samples = 27 * f.cells_checked;
    out->folded = f.folded_cell_count;
    out->min_det = f.cells_checked ? f.min_det : NAN;
    out->cell_ids = f.folded_cells;
    f.folded_cells = NULL;
    ffd_tsv_fold_report_free(&f);
    return FFD_OK;
}
