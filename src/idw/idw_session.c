/* idw_session — the IDW method's deformer (sess_vtable: the editor and
 * ffd_deformer): the controls are the IDW's control points, dragged
 * directly or through direct manipulation over the normalised weights; its
 * rig is the control points at rest plus one move per displaced point. */
#include "idw/idw.h"
#include "idw/idw_method.h"
#include "session/session.h"

#include <string.h>

typedef struct idw_method {
    sess_method base;
    ffd_idw *idw;
    ffd_idw_options options;
    ffd_idw_rows mesh_rows; /* the rest mesh's vertices, for the linear map */
    double *begin;          /* control points at the start of a drag */
} idw_method;

struct sess_binding {
    double *points; /* n by 3, the bound points at rest */
    size_t n;
    ffd_idw_rows rows;
};

static idw_method *as_idw(const sess_method *m)
{
    return (idw_method *)(void *)m;
}

static void idw_destroy(sess_method *m)
{
    idw_method *r = as_idw(m);
    ffd_idw_destroy(r->idw);
    ffd_free(r->begin);
    ffd_free(r);
}

static ffd_status idw_eval(sess_method *m, double *out, ffd_error *err)
{
    return ffd_idw_eval(as_idw(m)->idw, m->ctx->rest, m->ctx->n, out, err);
}

static size_t idw_count(const sess_method *m)
{
    return ffd_idw_control_count(as_idw(m)->idw);
}

static void idw_controls(const sess_method *m, double *out)
{
    memcpy(out, ffd_idw_control_points(as_idw(m)->idw), idw_count(m) * 3 * sizeof *out);
}

static ffd_status idw_describe(const sess_method *m, cJSON *params, cJSON *controls,
                               ffd_error *err)
{
    const idw_method *r = as_idw(m);
    const char *weighting = ffd_rig_idw_weighting_name(r->options.weighting);
    int ok = cJSON_AddArrayToObject(controls, "edges") &&
             ffd_sess_add_item(params, "power", ffd_sess_number(r->options.power)) &&
             cJSON_AddStringToObject(params, "weighting", weighting);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
}

static ffd_status idw_begin(sess_method *m, const uint32_t *ids, size_t k, int arap,
                            ffd_error *err)
{
    idw_method *r = as_idw(m);
    (void)ids, (void)k, (void)arap;
    ffd_free(r->begin);
    r->begin = ffd_malloc_array(idw_count(m), 3 * sizeof *r->begin);
    if (!r->begin)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag_begin: out of memory");
    idw_controls(m, r->begin);
    return FFD_OK;
}

/* The drag's start plus a change: controls ids at targets, or every control + dv. */
static ffd_status set_from_begin(idw_method *r, const uint32_t *ids, size_t k,
                                 const double *targets, const double *dv, ffd_error *err)
{
    size_t c = idw_count(&r->base);
    double *p = ffd_malloc_array(c, 3 * sizeof *p);
    if (!p)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    memcpy(p, r->begin ? r->begin : ffd_idw_control_points(r->idw), c * 3 * sizeof *p);
    for (size_t i = 0; i < k; i++)
        memcpy(p + 3 * (size_t)ids[i], targets + 3 * i, 3 * sizeof *p);
    for (size_t i = 0; dv && i < 3 * c; i++)
        p[i] += dv[i];
    ffd_status st = ffd_idw_set_control_points(r->idw, p, err);
    ffd_free(p);
    return st;
}

static ffd_status idw_set_controls(sess_method *m, const uint32_t *ids, size_t k,
                                   const double *targets, ffd_error *err)
{
    return set_from_begin(as_idw(m), ids, k, targets, NULL, err);
}

static ffd_status idw_linear_map(sess_method *m, ffd_linear_map *map, ffd_error *err)
{
    idw_method *r = as_idw(m);
    (void)err;
    ffd_idw_linear_map(&r->mesh_rows, m->ctx->n, map);
    return FFD_OK;
}

static ffd_status idw_set_variables(sess_method *m, const double *dv, ffd_error *err)
{
    return set_from_begin(as_idw(m), NULL, 0, NULL, dv, err);
}

static void idw_end(sess_method *m, int commit)
{
    idw_method *r = as_idw(m);
    if (!commit && r->begin)
        ffd_idw_set_control_points(r->idw, r->begin, NULL);
    ffd_free(r->begin);
    r->begin = NULL;
}

static ffd_status idw_snapshot(const sess_method *m, void **blob, ffd_error *err)
{
    size_t c = idw_count(m);
    double *copy = ffd_malloc_array(c + 1, 3 * sizeof *copy);
    if (!copy)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the undo history");
    copy[0] = (double)c;
    idw_controls(m, copy + 3);
    *blob = copy;
    return FFD_OK;
}

static ffd_status idw_restore(sess_method *m, const void *blob, ffd_error *err)
{
    const double *copy = blob;
    if ((size_t)copy[0] != idw_count(m))
        return ffd_fail(err, FFD_ERR_INVALID, "undo: the history does not match the IDW");
    return ffd_idw_set_control_points(as_idw(m)->idw, copy + 3, err);
}

static ffd_status idw_reset(sess_method *m, ffd_error *err)
{
    const ffd_idw *idw = as_idw(m)->idw;
    return ffd_idw_set_control_points(as_idw(m)->idw, ffd_idw_rest_points(idw), err);
}

/* The state as a rig: the rest control points and one move per displaced one. */
static ffd_status idw_rig(const sess_method *m, cJSON *root, ffd_error *err)
{
    const idw_method *r = as_idw(m);
    const size_t N = idw_count(m);
    const double *p = ffd_idw_control_points(r->idw), *c = ffd_idw_rest_points(r->idw);
    ffd_rig_idw section = {.options = r->options, .control_points = (double *)c, .count = N};
    ffd_rig rig;
    ffd_rig_view(&rig, &ffd_method_idw, NULL, 0);
    rig.section = &section;
    section.moves = ffd_malloc_array(N, sizeof *section.moves);
    if (!section.moves)
        return ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
    for (size_t j = 0; j < N; j++) {
        const double *q = p + 3 * j, *q0 = c + 3 * j;
        if (q[0] == q0[0] && q[1] == q0[1] && q[2] == q0[2])
            continue;
        ffd_rig_idw_move *mv = &section.moves[section.move_count++];
        mv->index = (uint32_t)j;
        for (int a = 0; a < 3; a++)
            mv->delta[a] = q[a] - q0[a];
    }
    int ok = ffd_method_idw.write(&rig, root);
    ffd_free(section.moves);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
}

static ffd_status idw_influence(sess_method *m, const uint32_t *ids, size_t k, float *w,
                                ffd_error *err)
{
    ffd_linear_map map;
    ffd_status st = idw_linear_map(m, &map, err);
    return st ? st : ffd_sess_map_influence(&map, 1, m->ctx->n, ids, k, w, err);
}

static ffd_status idw_op(sess_method *m, const char *op, const cJSON *body, int *undo_kind,
                         ffd_error *err)
{
    (void)m, (void)body, (void)undo_kind;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not an IDW operation", op);
}

/* ---- any point set (ffd_deformer_bind): the IDW needs the points only ---- */

static ffd_status idw_bind(sess_method *m, const double *points, size_t n, sess_binding **out,
                           ffd_error *err)
{
    sess_binding *b = ffd_calloc(1, sizeof *b);
    double *copy = ffd_malloc_array(n ? n : 1, 3 * sizeof *copy);
    if (!b || !copy) {
        ffd_free(b);
        ffd_free(copy);
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    }
    memcpy(copy, points, n * 3 * sizeof *copy);
    b->points = copy;
    b->n = n;
    b->rows.idw = as_idw(m)->idw;
    b->rows.points = copy;
    *out = b;
    return FFD_OK;
}

static void idw_binding_free(sess_binding *b)
{
    if (!b)
        return;
    ffd_free(b->points);
    ffd_free(b);
}

static ffd_status idw_eval_points(sess_method *m, const sess_binding *b, double *out,
                                  ffd_error *err)
{
    return ffd_idw_eval(as_idw(m)->idw, b->points, b->n, out, err);
}

static ffd_status idw_jacobian_points(sess_method *m, const sess_binding *b, double *out,
                                      ffd_error *err)
{
    return ffd_idw_jacobian(as_idw(m)->idw, b->points, b->n, out, err);
}

static ffd_status idw_map_points(sess_method *m, const sess_binding *b, ffd_linear_map *map,
                                 ffd_error *err)
{
    (void)m, (void)err;
    ffd_idw_linear_map(&b->rows, b->n, map);
    return FFD_OK;
}

static void *idw_handle(sess_method *m)
{
    return as_idw(m)->idw;
}

static const sess_vtable idw_vtable = {
    .name = "idw",
    .destroy = idw_destroy,
    .eval = idw_eval,
    .control_count = idw_count,
    .controls = idw_controls,
    .describe = idw_describe,
    .begin = idw_begin,
    .set_controls = idw_set_controls,
    .linear_map = idw_linear_map,
    .set_variables = idw_set_variables,
    .end = idw_end,
    .snapshot = idw_snapshot,
    .restore = idw_restore,
    .snapshot_free = ffd_free,
    .reset = idw_reset,
    .rig = idw_rig,
    .influence = idw_influence,
    .op = idw_op,
    .bind = idw_bind,
    .binding_free = idw_binding_free,
    .eval_points = idw_eval_points,
    .jacobian_points = idw_jacobian_points,
    .map_points = idw_map_points,
    .handle = idw_handle,
};

/* The deformer of a rig: the IDW on its control points, then the rig
 * replayed as ffd deform applies it (moves, deformed points, constraints)
 * and the control points set where the replay left them. */
ffd_status ffd_sess_idw_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                             ffd_error *err)
{
    const ffd_rig_idw *section = ffd_rig_idw_of(rig);
    ffd_status st = ffd_sess_check_controls(ctx, (double)section->count, rig->name, err);
    if (st)
        return st;
    idw_method *r = ffd_calloc(1, sizeof *r);
    if (!r)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    r->base.vt = &idw_vtable;
    r->base.ctx = ctx;
    r->options = section->options;
    ffd_error inner = {{0}};
    if ((st = ffd_idw_create(section->control_points, section->count, &section->options, &r->idw,
                             &inner))) {
        idw_destroy(&r->base);
        return ffd_fail(err, st, "%s: control_points: %s", rig->name, inner.message);
    }
    r->mesh_rows.idw = r->idw;
    r->mesh_rows.points = ctx->rest;
    if (section->deformed || section->move_count || rig->constraint_count) {
        ffd_rig_report report = {0};
        st = ffd_sess_apply_rig(ctx, rig, &report, err);
        if (!st && report.control_count != section->count)
            st = ffd_fail(err, FFD_ERR_INVALID, "%s: the rig's IDW does not match", rig->name);
        if (!st)
            st = ffd_idw_set_control_points(r->idw, report.control_points, err);
        ffd_rig_report_free(&report);
        if (st) {
            idw_destroy(&r->base);
            return st;
        }
    }
    *out = &r->base;
    return FFD_OK;
}

/* The editor's defaults (ffd_method.create_body): without "control_points",
 * the 27 points of a 3 x 3 x 3 grid over the mesh's bounding box grown by a
 * tenth of its diagonal. */
ffd_status ffd_sess_idw_create_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p)
{
    if (cJSON_GetObjectItemCaseSensitive(body, "control_points"))
        return FFD_OK;
    cJSON *points = cJSON_AddArrayToObject(body, "control_points");
    int ok = points != NULL;
    for (int i = 0; ok && i < 27; i++) {
        double q[3];
        for (int a = 0; a < 3; a++) {
            int k = a == 0 ? i / 9 : a == 1 ? i / 3 % 3 : i % 3;
            double lo = ctx->min[a] - 0.1 * ctx->diag, hi = ctx->max[a] + 0.1 * ctx->diag;
            q[a] = lo + 0.5 * k * (hi - lo);
        }
        ok = ffd_sess_add_to_array(points, cJSON_CreateDoubleArray(q, 3));
    }
    return ok ? FFD_OK : ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
}
