/* rbf_session — the RBF method's deformer (sess_vtable: the editor and
 * ffd_deformer): the controls are the RBF's control points, dragged
 * directly or through direct manipulation over the cardinal functions; its
 * rig is the control points at rest plus one move per displaced point. */
#include "rbf/rbf.h"
#include "rbf/rbf_method.h"
#include "session/session.h"

#include <string.h>

typedef struct rbf_method {
    sess_method base;
    ffd_rbf_morph *rbf;
    ffd_rbf_options options;
    ffd_rbf_morph_rows mesh_rows; /* the rest mesh's vertices, for the linear map */
    double *begin;          /* control points at the start of a drag */
} rbf_method;

struct sess_binding {
    double *points; /* n by 3, the bound points at rest */
    size_t n;
    ffd_rbf_morph_rows rows;
};

static rbf_method *as_rbf(const sess_method *m)
{
    return (rbf_method *)(void *)m;
}

static void rbf_destroy(sess_method *m)
{
    rbf_method *r = as_rbf(m);
    ffd_rbf_morph_destroy(r->rbf);
    ffd_free(r->begin);
    ffd_free(r);
}

static ffd_status rbf_eval(sess_method *m, double *out, ffd_error *err)
{
    return ffd_rbf_morph_eval(as_rbf(m)->rbf, m->ctx->rest, m->ctx->n, out, err);
}

static size_t rbf_count(const sess_method *m)
{
    return ffd_rbf_morph_control_count(as_rbf(m)->rbf);
}

static void rbf_controls(const sess_method *m, double *out)
{
    memcpy(out, ffd_rbf_morph_control_points(as_rbf(m)->rbf), rbf_count(m) * 3 * sizeof *out);
}

static ffd_status rbf_describe(const sess_method *m, cJSON *params, cJSON *controls,
                               ffd_error *err)
{
    const rbf_method *r = as_rbf(m);
    const char *kernel = ffd_rbf_kernel_name(r->options.kernel);
    int ok = cJSON_AddArrayToObject(controls, "edges") &&
             cJSON_AddStringToObject(params, "kernel", kernel) &&
             ffd_sess_add_item(params, "radius", ffd_sess_number(r->options.radius)) &&
             cJSON_AddNumberToObject(params, "power", r->options.power) &&
             cJSON_AddStringToObject(controls, "kernel", kernel);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
}

static ffd_status rbf_begin(sess_method *m, const uint32_t *ids, size_t k, int arap,
                            ffd_error *err)
{
    rbf_method *r = as_rbf(m);
    (void)ids, (void)k, (void)arap;
    ffd_free(r->begin);
    r->begin = ffd_malloc_array(rbf_count(m), 3 * sizeof *r->begin);
    if (!r->begin)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag_begin: out of memory");
    rbf_controls(m, r->begin);
    return FFD_OK;
}

/* The drag's start plus a change: controls ids at targets, or every control + dv. */
static ffd_status set_from_begin(rbf_method *r, const uint32_t *ids, size_t k,
                                 const double *targets, const double *dv, ffd_error *err)
{
    size_t c = rbf_count(&r->base);
    double *p = ffd_malloc_array(c, 3 * sizeof *p);
    if (!p)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    memcpy(p, r->begin ? r->begin : ffd_rbf_morph_control_points(r->rbf), c * 3 * sizeof *p);
    for (size_t i = 0; i < k; i++)
        memcpy(p + 3 * (size_t)ids[i], targets + 3 * i, 3 * sizeof *p);
    for (size_t i = 0; dv && i < 3 * c; i++)
        p[i] += dv[i];
    ffd_status st = ffd_rbf_morph_set_control_points(r->rbf, p, err);
    ffd_free(p);
    return st;
}

static ffd_status rbf_set_controls(sess_method *m, const uint32_t *ids, size_t k,
                                   const double *targets, ffd_error *err)
{
    return set_from_begin(as_rbf(m), ids, k, targets, NULL, err);
}

static ffd_status rbf_linear_map(sess_method *m, ffd_linear_map *map, ffd_error *err)
{
    rbf_method *r = as_rbf(m);
    (void)err;
    ffd_rbf_morph_linear_map(&r->mesh_rows, m->ctx->n, map);
    return FFD_OK;
}

static ffd_status rbf_set_variables(sess_method *m, const double *dv, ffd_error *err)
{
    return set_from_begin(as_rbf(m), NULL, 0, NULL, dv, err);
}

static void rbf_end(sess_method *m, int commit)
{
    rbf_method *r = as_rbf(m);
    if (!commit && r->begin)
        ffd_rbf_morph_set_control_points(r->rbf, r->begin, NULL);
    ffd_free(r->begin);
    r->begin = NULL;
}

static ffd_status rbf_snapshot(const sess_method *m, void **blob, ffd_error *err)
{
    size_t c = rbf_count(m);
    double *copy = ffd_malloc_array(c + 1, 3 * sizeof *copy);
    if (!copy)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the undo history");
    copy[0] = (double)c;
    rbf_controls(m, copy + 3);
    *blob = copy;
    return FFD_OK;
}

static ffd_status rbf_restore(sess_method *m, const void *blob, ffd_error *err)
{
    const double *copy = blob;
    if ((size_t)copy[0] != rbf_count(m))
        return ffd_fail(err, FFD_ERR_INVALID, "undo: the history does not match the RBF");
    return ffd_rbf_morph_set_control_points(as_rbf(m)->rbf, copy + 3, err);
}

static ffd_status rbf_reset(sess_method *m, ffd_error *err)
{
    const ffd_rbf_morph *rbf = as_rbf(m)->rbf;
    return ffd_rbf_morph_set_control_points(as_rbf(m)->rbf, ffd_rbf_morph_rest_points(rbf), err);
}

/* The state as a rig: the rest control points and one move per displaced one. */
static ffd_status rbf_rig(const sess_method *m, cJSON *root, ffd_error *err)
{
    const rbf_method *r = as_rbf(m);
    const size_t N = rbf_count(m);
    const double *p = ffd_rbf_morph_control_points(r->rbf), *c = ffd_rbf_morph_rest_points(r->rbf);
    ffd_rig_rbf section = {.options = r->options, .control_points = (double *)c, .count = N};
    ffd_rig rig;
    ffd_rig_view(&rig, &ffd_method_rbf, NULL, 0);
    rig.section = &section;
    section.moves = ffd_malloc_array(N, sizeof *section.moves);
    if (!section.moves)
        return ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
    for (size_t j = 0; j < N; j++) {
        const double *q = p + 3 * j, *q0 = c + 3 * j;
        if (q[0] == q0[0] && q[1] == q0[1] && q[2] == q0[2])
            continue;
        ffd_rig_rbf_move *mv = &section.moves[section.move_count++];
        mv->index = (uint32_t)j;
        for (int a = 0; a < 3; a++)
            mv->delta[a] = q[a] - q0[a];
    }
    int ok = ffd_method_rbf.write(&rig, root);
    ffd_free(section.moves);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
}

static ffd_status rbf_influence(sess_method *m, const uint32_t *ids, size_t k, float *w,
                                ffd_error *err)
{
    ffd_linear_map map;
    ffd_status st = rbf_linear_map(m, &map, err);
    return st ? st : ffd_sess_map_influence(&map, 1, m->ctx->n, ids, k, w, err);
}

static ffd_status rbf_op(sess_method *m, const char *op, const cJSON *body, int *undo_kind,
                         ffd_error *err)
{
    (void)m, (void)body, (void)undo_kind;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not an RBF operation", op);
}

/* ---- any point set (ffd_deformer_bind): the RBF needs the points only ---- */

static ffd_status rbf_bind(sess_method *m, const double *points, size_t n, sess_binding **out,
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
    b->rows.rbf = as_rbf(m)->rbf;
    b->rows.points = copy;
    *out = b;
    return FFD_OK;
}

static void rbf_binding_free(sess_binding *b)
{
    if (!b)
        return;
    ffd_free(b->points);
    ffd_free(b);
}

static ffd_status rbf_eval_points(sess_method *m, const sess_binding *b, double *out,
                                  ffd_error *err)
{
    return ffd_rbf_morph_eval(as_rbf(m)->rbf, b->points, b->n, out, err);
}

static ffd_status rbf_jacobian_points(sess_method *m, const sess_binding *b, double *out,
                                      ffd_error *err)
{
    return ffd_rbf_morph_jacobian(as_rbf(m)->rbf, b->points, b->n, out, err);
}

static ffd_status rbf_map_points(sess_method *m, const sess_binding *b, ffd_linear_map *map,
                                 ffd_error *err)
{
    (void)m, (void)err;
    ffd_rbf_morph_linear_map(&b->rows, b->n, map);
    return FFD_OK;
}

static ffd_status rbf_sensitivity_product(sess_method *m, const sess_binding *b, const double *v,
                                          double *out, ffd_error *err)
{
    return ffd_rbf_morph_product(as_rbf(m)->rbf, b->points, b->n, v, out, err);
}

static ffd_status rbf_sensitivity_transpose(sess_method *m, const sess_binding *b,
                                            const double *w, double *out, ffd_error *err)
{
    return ffd_rbf_morph_transpose_product(as_rbf(m)->rbf, b->points, b->n, w, out, err);
}

static void *rbf_handle(sess_method *m)
{
    return as_rbf(m)->rbf;
}

static const sess_vtable rbf_vtable = {
    .name = "rbf",
    .destroy = rbf_destroy,
    .eval = rbf_eval,
    .control_count = rbf_count,
    .controls = rbf_controls,
    .describe = rbf_describe,
    .begin = rbf_begin,
    .set_controls = rbf_set_controls,
    .linear_map = rbf_linear_map,
    .set_variables = rbf_set_variables,
    .end = rbf_end,
    .snapshot = rbf_snapshot,
    .restore = rbf_restore,
    .snapshot_free = ffd_free,
    .reset = rbf_reset,
    .rig = rbf_rig,
    .influence = rbf_influence,
    .op = rbf_op,
    .bind = rbf_bind,
    .binding_free = rbf_binding_free,
    .eval_points = rbf_eval_points,
    .jacobian_points = rbf_jacobian_points,
    .map_points = rbf_map_points,
    .sensitivity_product = rbf_sensitivity_product,
    .sensitivity_transpose_product = rbf_sensitivity_transpose,
    .handle = rbf_handle,
};

/* The deformer of a rig: the RBF on its control points, then the rig
 * replayed as ffd deform applies it (moves, deformed points, constraints)
 * and the control points set where the replay left them. */
ffd_status ffd_sess_rbf_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                             ffd_error *err)
{
    const ffd_rig_rbf *section = ffd_rig_rbf_of(rig);
    ffd_status st = ffd_sess_check_controls(ctx, (double)section->count, rig->name, err);
    if (st)
        return st;
    rbf_method *r = ffd_calloc(1, sizeof *r);
    if (!r)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    r->base.vt = &rbf_vtable;
    r->base.ctx = ctx;
    r->options = section->options;
    ffd_error inner = {{0}};
    if ((st = ffd_rbf_morph_create(section->control_points, section->count, &section->options, &r->rbf,
                             &inner))) {
        rbf_destroy(&r->base);
        return ffd_fail(err, st, "%s: control_points: %s", rig->name, inner.message);
    }
    r->mesh_rows.rbf = r->rbf;
    r->mesh_rows.points = ctx->rest;
    if (section->deformed || section->move_count || rig->constraint_count) {
        ffd_rig_report report = {0};
        st = ffd_sess_apply_rig(ctx, rig, &report, err);
        if (!st && report.control_count != section->count)
            st = ffd_fail(err, FFD_ERR_INVALID, "%s: the rig's RBF does not match", rig->name);
        if (!st)
            st = ffd_rbf_morph_set_control_points(r->rbf, report.control_points, err);
        ffd_rig_report_free(&report);
        if (st) {
            rbf_destroy(&r->base);
            return st;
        }
    }
    *out = &r->base;
    return FFD_OK;
}

/* The editor's defaults (ffd_method.create_body): without "control_points",
 * the 27 points of a 3 x 3 x 3 grid over the mesh's bounding box grown by a
 * tenth of its diagonal, and a radius of half the diagonal (PyGeM's 0.5 is in
 * model units, too small for most meshes). */
ffd_status ffd_sess_rbf_create_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p)
{
    if (!cJSON_GetObjectItemCaseSensitive(body, "radius") &&
        !cJSON_AddNumberToObject(body, "radius", 0.5 * ctx->diag))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
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
