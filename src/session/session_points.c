/* session_points — the deformer of a scattered-control-point method (RBF,
 * IDW; session_points.h): the method's operations on its control points
 * behind the session's vtable. */
#include "session/session_points.h"

#include <string.h>

typedef struct points_method {
    sess_method base;
    const sess_points_kind *kind;
    const ffd_point_morph_ops *ops;
    void *morph;
    void *options;             /* kind->options_size bytes */
    ffd_point_rows mesh_rows;  /* the rest mesh's vertices, for the linear map */
    double *begin;             /* control points at the start of a drag */
} points_method;

struct sess_binding {
    double *points; /* n by 3, the bound points at rest */
    size_t n;
    ffd_point_rows rows;
};

static points_method *as_points(const sess_method *m)
{
    return (points_method *)(void *)m;
}

void ffd_sess_points_destroy(sess_method *m)
{
    points_method *r = as_points(m);
    if (r->morph)
        r->ops->destroy(r->morph);
    ffd_free(r->options);
    ffd_free(r->begin);
    ffd_free(r);
}

ffd_status ffd_sess_points_eval(sess_method *m, double *out, ffd_error *err)
{
    return as_points(m)->ops->eval(as_points(m)->morph, m->ctx->rest, m->ctx->n, out, err);
}

size_t ffd_sess_points_count(const sess_method *m)
{
    return as_points(m)->ops->count(as_points(m)->morph);
}

void ffd_sess_points_controls(const sess_method *m, double *out)
{
    memcpy(out, as_points(m)->ops->points(as_points(m)->morph), ffd_sess_points_count(m) * 3 * sizeof *out);
}

ffd_status ffd_sess_points_describe(const sess_method *m, cJSON *params, cJSON *controls,
                               ffd_error *err)
{
    const points_method *r = as_points(m);
    int ok = cJSON_AddArrayToObject(controls, "edges") &&
             r->kind->describe(r->options, params, controls);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
}

ffd_status ffd_sess_points_begin(sess_method *m, const uint32_t *ids, size_t k, int arap,
                            ffd_error *err)
{
    points_method *r = as_points(m);
    (void)ids, (void)k, (void)arap;
    ffd_free(r->begin);
    r->begin = ffd_malloc_array(ffd_sess_points_count(m), 3 * sizeof *r->begin);
    if (!r->begin)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag_begin: out of memory");
    ffd_sess_points_controls(m, r->begin);
    return FFD_OK;
}

/* The drag's start plus a change: controls ids at targets, or every control + dv. */
static ffd_status set_from_begin(points_method *r, const uint32_t *ids, size_t k,
                                 const double *targets, const double *dv, ffd_error *err)
{
    size_t c = ffd_sess_points_count(&r->base);
    double *p = ffd_malloc_array(c, 3 * sizeof *p);
    if (!p)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    memcpy(p, r->begin ? r->begin : r->ops->points(r->morph), c * 3 * sizeof *p);
    for (size_t i = 0; i < k; i++)
        memcpy(p + 3 * (size_t)ids[i], targets + 3 * i, 3 * sizeof *p);
    for (size_t i = 0; dv && i < 3 * c; i++)
        p[i] += dv[i];
    ffd_status st = r->ops->set_points(r->morph, p, err);
    ffd_free(p);
    return st;
}

ffd_status ffd_sess_points_set_controls(sess_method *m, const uint32_t *ids, size_t k,
                                   const double *targets, ffd_error *err)
{
    return set_from_begin(as_points(m), ids, k, targets, NULL, err);
}

ffd_status ffd_sess_points_linear_map(sess_method *m, ffd_linear_map *map, ffd_error *err)
{
    points_method *r = as_points(m);
    (void)err;
    r->ops->linear_map(&r->mesh_rows, m->ctx->n, map);
    return FFD_OK;
}

ffd_status ffd_sess_points_set_variables(sess_method *m, const double *dv, ffd_error *err)
{
    return set_from_begin(as_points(m), NULL, 0, NULL, dv, err);
}

void ffd_sess_points_end(sess_method *m, int commit)
{
    points_method *r = as_points(m);
    if (!commit && r->begin)
        r->ops->set_points(r->morph, r->begin, NULL);
    ffd_free(r->begin);
    r->begin = NULL;
}

ffd_status ffd_sess_points_snapshot(const sess_method *m, void **blob, ffd_error *err)
{
    size_t c = ffd_sess_points_count(m);
    double *copy = ffd_malloc_array(c + 1, 3 * sizeof *copy);
    if (!copy)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the undo history");
    copy[0] = (double)c;
    ffd_sess_points_controls(m, copy + 3);
    *blob = copy;
    return FFD_OK;
}

ffd_status ffd_sess_points_restore(sess_method *m, const void *blob, ffd_error *err)
{
    const double *copy = blob;
    const points_method *r = as_points(m);
    if ((size_t)copy[0] != ffd_sess_points_count(m))
        return ffd_fail(err, FFD_ERR_INVALID, "undo: the history does not match the %s",
                        r->ops->label);
    return r->ops->set_points(r->morph, copy + 3, err);
}

ffd_status ffd_sess_points_reset(sess_method *m, ffd_error *err)
{
    const points_method *r = as_points(m);
    return r->ops->set_points(r->morph, r->ops->rest(r->morph), err);
}

/* The state as a rig: the rest control points and one move per displaced one. */
ffd_status ffd_sess_points_rig(const sess_method *m, cJSON *root, ffd_error *err)
{
    const points_method *r = as_points(m);
    const size_t N = ffd_sess_points_count(m);
    const double *p = r->ops->points(r->morph), *c = r->ops->rest(r->morph);
    ffd_rig_points section = {.control_points = (double *)c, .count = N};
    section.moves = ffd_malloc_array(N, sizeof *section.moves);
    if (!section.moves)
        return ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
    for (size_t j = 0; j < N; j++) {
        const double *q = p + 3 * j, *q0 = c + 3 * j;
        if (q[0] == q0[0] && q[1] == q0[1] && q[2] == q0[2])
            continue;
        ffd_rig_point_move *mv = &section.moves[section.move_count++];
        mv->index = (uint32_t)j;
        for (int a = 0; a < 3; a++)
            mv->delta[a] = q[a] - q0[a];
    }
    int ok = r->kind->write_rig(r->options, &section, root);
    ffd_free(section.moves);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
}

ffd_status ffd_sess_points_influence(sess_method *m, const uint32_t *ids, size_t k, float *w,
                                ffd_error *err)
{
    ffd_linear_map map;
    ffd_status st = ffd_sess_points_linear_map(m, &map, err);
    return st ? st : ffd_sess_map_influence(&map, 1, m->ctx->n, ids, k, w, err);
}

ffd_status ffd_sess_points_op(sess_method *m, const char *op, const cJSON *body, int *undo_kind,
                         ffd_error *err)
{
    (void)body, (void)undo_kind;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not an %s operation", op,
                    as_points(m)->ops->label);
}

/* ---- any point set (ffd_deformer_bind): the morph needs the points only ---- */

ffd_status ffd_sess_points_bind(sess_method *m, const double *points, size_t n, sess_binding **out,
                           ffd_error *err)
{
    sess_binding *b = ffd_calloc(1, sizeof *b);
    double *copy = ffd_malloc_array(n ? n : 1, 3 * sizeof *copy);
    if (!b || !copy) {
        ffd_free(b);
        ffd_free(copy);
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    }
    if (n)
        memcpy(copy, points, n * 3 * sizeof *copy);
    b->points = copy;
    b->n = n;
    b->rows.morph = as_points(m)->morph;
    b->rows.points = copy;
    *out = b;
    return FFD_OK;
}

void ffd_sess_points_binding_free(sess_binding *b)
{
    if (!b)
        return;
    ffd_free(b->points);
    ffd_free(b);
}

ffd_status ffd_sess_points_eval_points(sess_method *m, const sess_binding *b, double *out,
                                  ffd_error *err)
{
    return as_points(m)->ops->eval(as_points(m)->morph, b->points, b->n, out, err);
}

ffd_status ffd_sess_points_jacobian_points(sess_method *m, const sess_binding *b, double *out,
                                      ffd_error *err)
{
    return as_points(m)->ops->jacobian(as_points(m)->morph, b->points, b->n, out, err);
}

ffd_status ffd_sess_points_map_points(sess_method *m, const sess_binding *b, ffd_linear_map *map,
                                 ffd_error *err)
{
    (void)err;
    as_points(m)->ops->linear_map(&b->rows, b->n, map);
    return FFD_OK;
}

ffd_status ffd_sess_points_sensitivity_product(sess_method *m, const sess_binding *b, const double *v,
                                          double *out, ffd_error *err)
{
    return as_points(m)->ops->product(as_points(m)->morph, b->points, b->n, v, out, err);
}

ffd_status ffd_sess_points_sensitivity_transpose(sess_method *m, const sess_binding *b,
                                            const double *w, double *out, ffd_error *err)
{
    return as_points(m)->ops->transpose_product(as_points(m)->morph, b->points, b->n, w, out, err);
}

void *ffd_sess_points_handle(sess_method *m)
{
    return as_points(m)->morph;
}

ffd_status ffd_sess_points_load(const sess_points_kind *kind, const sess_ctx *ctx,
                                const ffd_rig *rig, sess_method **out, ffd_error *err)
{
    const ffd_point_morph_ops *ops = kind->ops;
    const ffd_rig_points *section = ops->points_of(rig);
    ffd_status st = ffd_sess_check_controls(ctx, (double)section->count, rig->name, err);
    if (st)
        return st;
    points_method *r = ffd_calloc(1, sizeof *r);
    if (r)
        r->options = ffd_malloc(kind->options_size);
    if (!r || !r->options) {
        ffd_free(r);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    }
    r->base.vt = kind->vtable;
    r->base.ctx = ctx;
    r->kind = kind;
    r->ops = ops;
    memcpy(r->options, kind->options_of(rig), kind->options_size);
    ffd_error inner = {{0}};
    if ((st = ops->create(rig, &r->morph, &inner))) {
        ffd_sess_points_destroy(&r->base);
        return ffd_fail(err, st, "%s: control_points: %s", rig->name, inner.message);
    }
    r->mesh_rows.morph = r->morph;
    r->mesh_rows.points = ctx->rest;
    if (section->deformed || section->move_count || rig->constraint_count) {
        ffd_rig_report report = {0};
        st = ffd_sess_apply_rig(ctx, rig, &report, err);
        if (!st && report.control_count != section->count)
            st = ffd_fail(err, FFD_ERR_INVALID, "%s: the rig's %s does not match", rig->name,
                          ops->label);
        if (!st)
            st = ops->set_points(r->morph, report.control_points, err);
        ffd_rig_report_free(&report);
        if (st) {
            ffd_sess_points_destroy(&r->base);
            return st;
        }
    }
    *out = &r->base;
    return FFD_OK;
}

ffd_status ffd_sess_points_default_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p)
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
