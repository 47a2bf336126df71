/* kelvinlet_session — the Kelvinlet method's deformer (the editor's and
 * ffd_deformer's): the brushes of a rig (kelvinlet.c), its controls the
 * grab brushes' handles (center + displacement; dragging one sets that
 * grab's displacement), its rig the brushes as they are now. There is no
 * linear map: a grab's response is a 3 by 3 matrix, not a scalar weight
 * (kelvinlet_rig.c solves a rig's constraints with those blocks). */
#include "kelvinlet/kelvinlet_method.h"
#include "session/session.h"

#include <math.h>
#include <string.h>

typedef struct kelvinlet_method {
    sess_method base;
    ffd_kelvinlet *kel;
    ffd_kelvinlet_brush *begin; /* the brushes at the start of a drag */
    size_t *grab;               /* control id -> brush index */
    size_t grabs;
} kelvinlet_method;

struct sess_binding {
    double *points;
    size_t n;
};

static kelvinlet_method *as_kel(const sess_method *m)
{
    return (kelvinlet_method *)(void *)m;
}

static size_t brush_count(const kelvinlet_method *km)
{
    return ffd_kelvinlet_brush_count(km->kel);
}

static void kel_destroy(sess_method *m)
{
    kelvinlet_method *km = as_kel(m);
    ffd_kelvinlet_destroy(km->kel);
    ffd_free(km->begin);
    ffd_free(km->grab);
    ffd_free(km);
}

static ffd_status kel_eval(sess_method *m, double *out, ffd_error *err)
{
    return ffd_kelvinlet_eval(as_kel(m)->kel, m->ctx->rest, m->ctx->n, out, err);
}

static size_t kel_count(const sess_method *m)
{
    return as_kel(m)->grabs;
}

static void kel_controls(const sess_method *m, double *out)
{
    const kelvinlet_method *km = as_kel(m);
    for (size_t g = 0; g < km->grabs; g++) {
        const ffd_kelvinlet_brush *br = ffd_kelvinlet_brush_at(km->kel, km->grab[g]);
        for (int a = 0; a < 3; a++)
            out[3 * g + a] = br->center[a] + br->displacement[a];
    }
}

/* The rig's section viewing the live brushes (borrowed). */
static void section_view(const kelvinlet_method *km, ffd_rig_kelvinlet *kr)
{
    kr->brush_count = brush_count(km);
    kr->brushes = (ffd_kelvinlet_brush *)ffd_kelvinlet_brush_at(km->kel, 0);
    ffd_kelvinlet_get_options(km->kel, &kr->options);
}

static ffd_status kel_describe(const sess_method *m, cJSON *params, cJSON *controls,
                               ffd_error *err)
{
    const kelvinlet_method *km = as_kel(m);
    ffd_rig_kelvinlet kr;
    ffd_rig rig;
    ffd_rig_view(&rig, &ffd_method_kelvinlet, NULL, 0);
    section_view(km, &kr);
    rig.section = &kr;
    /* params: the material and combination (the rig's keys); controls: the
     * brushes as the rig writes them, each grab with its control id */
    int ok = ffd_method_kelvinlet.write(&rig, params);
    cJSON *brushes = ok ? cJSON_DetachItemFromObjectCaseSensitive(params, "brushes") : NULL;
    ok = ok && brushes && cJSON_AddItemToObject(controls, "brushes", brushes) &&
         cJSON_AddArrayToObject(controls, "edges");
    size_t g = 0;
    cJSON *b;
    if (ok)
        cJSON_ArrayForEach(b, brushes)
        {
            const cJSON *type = cJSON_GetObjectItemCaseSensitive(b, "type");
            if (ok && cJSON_IsString(type) && !strcmp(type->valuestring, "grab"))
                ok = cJSON_AddNumberToObject(b, "control", (double)g++) != NULL;
        }
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
}

static ffd_status kel_begin(sess_method *m, const uint32_t *ids, size_t k, int arap,
                            ffd_error *err)
{
    kelvinlet_method *km = as_kel(m);
    size_t count = brush_count(km);
    (void)ids, (void)k, (void)arap;
    ffd_free(km->begin);
    km->begin = ffd_malloc_array(count ? count : 1, sizeof *km->begin);
    if (!km->begin)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag_begin: out of memory");
    if (count)
        memcpy(km->begin, ffd_kelvinlet_brush_at(km->kel, 0), count * sizeof *km->begin);
    return FFD_OK;
}

/* Puts every brush back as in saved (count of them). */
static ffd_status put_brushes(kelvinlet_method *km, const ffd_kelvinlet_brush *saved,
                              ffd_error *err)
{
    for (size_t j = 0; j < brush_count(km); j++) {
        ffd_status st = ffd_kelvinlet_set_brush(km->kel, j, &saved[j], err);
        if (st)
            return st;
    }
    return FFD_OK;
}

static ffd_status kel_set_controls(sess_method *m, const uint32_t *ids, size_t k,
                                   const double *targets, ffd_error *err)
{
    kelvinlet_method *km = as_kel(m);
    size_t count = brush_count(km);
    for (size_t i = 0; i < k; i++) {
        if (ids[i] >= km->grabs)
            return ffd_fail(err, FFD_ERR_RANGE, "drag: control %u out of range (%zu grab handles)",
                            ids[i], km->grabs);
        for (int a = 0; a < 3; a++)
            if (!isfinite(targets[3 * i + a]) || fabs(targets[3 * i + a]) > SESS_COORD_MAX)
                return ffd_fail(err, FFD_ERR_NONFINITE, "drag: target %zu is not finite", i);
    }
    ffd_kelvinlet_brush *next = ffd_malloc_array(count ? count : 1, sizeof *next);
    if (!next)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    if (count)
        memcpy(next, km->begin ? km->begin : ffd_kelvinlet_brush_at(km->kel, 0),
               count * sizeof *next);
    for (size_t i = 0; i < k; i++) {
        ffd_kelvinlet_brush *br = &next[km->grab[ids[i]]];
        for (int a = 0; a < 3; a++)
            br->displacement[a] = targets[3 * i + a] - br->center[a];
    }
    ffd_status st = put_brushes(km, next, err);
    ffd_free(next);
    return st;
}

static void kel_end(sess_method *m, int commit)
{
    kelvinlet_method *km = as_kel(m);
    if (!commit && km->begin)
        put_brushes(km, km->begin, NULL);
    ffd_free(km->begin);
    km->begin = NULL;
}

/* Undo: a copy of every brush (their count first). */
static ffd_status kel_snapshot(const sess_method *m, void **blob, ffd_error *err)
{
    const kelvinlet_method *km = as_kel(m);
    size_t count = brush_count(km);
    size_t *copy = ffd_malloc(sizeof(ffd_kelvinlet_brush) * (count + 1));
    if (!copy)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the undo history");
    copy[0] = count;
    if (count)
        memcpy((ffd_kelvinlet_brush *)(void *)copy + 1, ffd_kelvinlet_brush_at(km->kel, 0),
               count * sizeof(ffd_kelvinlet_brush));
    *blob = copy;
    return FFD_OK;
}

static ffd_status kel_restore(sess_method *m, const void *blob, ffd_error *err)
{
    const size_t *copy = blob;
    if (copy[0] != brush_count(as_kel(m)))
        return ffd_fail(err, FFD_ERR_INVALID, "undo: the history does not match the brushes");
    return put_brushes(as_kel(m), (const ffd_kelvinlet_brush *)(const void *)copy + 1, err);
}

static ffd_status kel_reset(sess_method *m, ffd_error *err)
{
    kelvinlet_method *km = as_kel(m);
    for (size_t j = 0; j < brush_count(km); j++) {
        ffd_kelvinlet_brush br = *ffd_kelvinlet_brush_at(km->kel, j);
        ffd_kelvinlet_brush_make_inert(&br);
        ffd_status st = ffd_kelvinlet_set_brush(km->kel, j, &br, err);
        if (st)
            return st;
    }
    return FFD_OK;
}

/* The brushes as they are now, written by the rig's own writer. */
static ffd_status kel_rig(const sess_method *m, cJSON *root, ffd_error *err)
{
    ffd_rig_kelvinlet kr;
    ffd_rig rig;
    ffd_rig_view(&rig, &ffd_method_kelvinlet, NULL, 0);
    section_view(as_kel(m), &kr);
    rig.section = &kr;
    return ffd_method_kelvinlet.write(&rig, root) ? FFD_OK
                                                  : ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
}

/* Influence of grab handles: per vertex the largest column norm of the
 * grabs' blocks (the displacement a unit drag of the handle gives), which
 * is 1 at the brush's center, clamped to [0, 1]. The blocks of a sequence
 * are those of the same brushes superposed. */
static ffd_status kel_influence(sess_method *m, const uint32_t *ids, size_t k, float *w,
                                ffd_error *err)
{
    kelvinlet_method *km = as_kel(m);
    const size_t n = m->ctx->n;
    ffd_kelvinlet_options o;
    ffd_kelvinlet_get_options(km->kel, &o);
    o.combine = FFD_KELVINLET_SUPERPOSE;
    o.steps = 1;
    ffd_kelvinlet *sup = NULL;
    ffd_status st = ffd_kelvinlet_create(ffd_kelvinlet_brush_at(km->kel, 0), brush_count(km), &o,
                                         &sup, err);
    if (st)
        return st;
    double *blocks = ffd_malloc_array(n ? n : 1, 9 * km->grabs * sizeof *blocks + 1);
    if (!blocks) {
        ffd_kelvinlet_destroy(sup);
        return ffd_fail(err, FFD_ERR_NOMEM, "influence: out of memory");
    }
    for (size_t i = 0; i < n; i++)
        w[i] = 0;
    if (km->grabs)
        st = ffd_kelvinlet_grab_blocks(sup, m->ctx->rest, n, blocks, err);
    for (size_t i = 0; !st && i < n && km->grabs; i++)
        for (size_t q = 0; q < k; q++) {
            if (ids[q] >= km->grabs)
                continue;
            const double *K = blocks + 9 * (i * km->grabs + ids[q]);
            for (int c = 0; c < 3; c++) {
                double v = sqrt(K[c] * K[c] + K[3 + c] * K[3 + c] + K[6 + c] * K[6 + c]);
                float f = (float)fmin(1.0, v);
                if (f > w[i])
                    w[i] = f;
            }
        }
    ffd_free(blocks);
    ffd_kelvinlet_destroy(sup);
    return st;
}

/* The grab index of the brushes (control id -> brush). */
static ffd_status index_grabs(kelvinlet_method *km, ffd_error *err)
{
    size_t count = brush_count(km);
    size_t *grab = ffd_malloc_array(count ? count : 1, sizeof *grab);
    if (!grab)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    km->grabs = 0;
    for (size_t j = 0; j < count; j++)
        if (ffd_kelvinlet_brush_at(km->kel, j)->type == FFD_KELVINLET_GRAB)
            grab[km->grabs++] = j;
    ffd_free(km->grab);
    km->grab = grab;
    return FFD_OK;
}

/* "brush": {"add": {a brush as in a rig}} appends one, {"remove": i}
 * removes brush i (docs/kelvinlet.md, "In the editor"). The brushes are
 * rebuilt with the same options; on error nothing changed. */
static ffd_status op_brush(kelvinlet_method *km, const cJSON *body, int *undo_kind,
                           ffd_error *err)
{
    static const char *const keys[] = {"add", "remove", NULL};
    ffd_rig_parser p = {"brush", err, NULL};
    ffd_status st = ffd_rig_check_keys(&p, body, "brush", keys, "\"add\", \"remove\"");
    if (st)
        return st;
    const cJSON *add = cJSON_GetObjectItemCaseSensitive(body, "add");
    const cJSON *remove = cJSON_GetObjectItemCaseSensitive(body, "remove");
    if (!add == !remove)
        return ffd_fail(err, FFD_ERR_PARSE, "brush: expected one of \"add\" or \"remove\"");
    size_t count = brush_count(km), index = 0;
    ffd_kelvinlet_brush added;
    memset(&added, 0, sizeof added);
    ffd_kelvinlet_options o;
    ffd_kelvinlet_get_options(km->kel, &o);
    if (add) {
        if ((st = ffd_rig_read_kelvinlet_brush(&p, add, "add", &added, NULL)) ||
            (st = ffd_kelvinlet_check_brush(&added, o.poisson_ratio, "brush: add", err)))
            return st;
        for (int a = 0; a < 3; a++)
            if (fabs(added.center[a]) > SESS_COORD_MAX)
                return ffd_fail(err, FFD_ERR_INVALID, "brush: add.center: too far away");
    } else {
        uint32_t i;
        if ((st = ffd_rig_read_index(&p, remove, "remove", "a brush index", &i)))
            return st;
        if (i >= count)
            return ffd_fail(err, FFD_ERR_RANGE, "brush: remove: %u out of range (%zu brushes)", i,
                            count);
        index = i;
    }
    size_t next_count = add ? count + 1 : count - 1;
    ffd_kelvinlet_brush *next = ffd_malloc_array(next_count ? next_count : 1, sizeof *next);
    if (!next)
        return ffd_fail(err, FFD_ERR_NOMEM, "brush: out of memory");
    size_t k = 0;
    for (size_t j = 0; j < count; j++)
        if (add || j != index)
            next[k++] = *ffd_kelvinlet_brush_at(km->kel, j);
    if (add)
        next[k++] = added;
    ffd_kelvinlet *kel = NULL;
    st = ffd_kelvinlet_create(next, k, &o, &kel, err);
    ffd_free(next);
    if (st)
        return st;
    ffd_kelvinlet *old = km->kel;
    km->kel = kel;
    if ((st = index_grabs(km, err))) {
        km->kel = old;
        ffd_kelvinlet_destroy(kel);
        return st;
    }
    ffd_kelvinlet_destroy(old);
    *undo_kind = SESS_UNDO_REBUILD;
    return FFD_OK;
}

static ffd_status kel_op(sess_method *m, const char *op, const cJSON *body, int *undo_kind,
                         ffd_error *err)
{
    if (strcmp(op, "brush") != 0)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not an operation of the kelvinlet method",
                        op);
    if (!cJSON_IsObject(body))
        return ffd_fail(err, FFD_ERR_PARSE, "brush: expected a JSON object");
    return op_brush(as_kel(m), body, undo_kind, err);
}

/* ---- any point set (ffd_deformer_bind): the brushes need only the points ---- */

static ffd_status kel_bind(sess_method *m, const double *points, size_t n, sess_binding **out,
                           ffd_error *err)
{
    (void)m;
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(points[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "bind: point %zu is not finite", i / 3);
    sess_binding *b = ffd_calloc(1, sizeof *b);
    double *copy = ffd_malloc_array(n ? n : 1, 3 * sizeof *copy);
    if (!b || !copy) {
        ffd_free(b);
        ffd_free(copy);
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    }
    if (n)
        memcpy(copy, points, 3 * n * sizeof *copy);
    b->points = copy;
    b->n = n;
    *out = b;
    return FFD_OK;
}

static void kel_binding_free(sess_binding *b)
{
    if (!b)
        return;
    ffd_free(b->points);
    ffd_free(b);
}

static ffd_status kel_eval_points(sess_method *m, const sess_binding *b, double *out,
                                  ffd_error *err)
{
    return ffd_kelvinlet_eval(as_kel(m)->kel, b->points, b->n, out, err);
}

static ffd_status kel_jacobian_points(sess_method *m, const sess_binding *b, double *out,
                                      ffd_error *err)
{
    return ffd_kelvinlet_jacobian(as_kel(m)->kel, b->points, b->n, out, err);
}

static void *kel_handle(sess_method *m)
{
    return as_kel(m)->kel;
}

static const sess_vtable kelvinlet_vtable = {
    .name = "kelvinlet",
    .destroy = kel_destroy,
    .eval = kel_eval,
    .control_count = kel_count,
    .controls = kel_controls,
    .describe = kel_describe,
    .begin = kel_begin,
    .set_controls = kel_set_controls,
    .end = kel_end,
    .snapshot = kel_snapshot,
    .restore = kel_restore,
    .snapshot_free = ffd_free,
    .reset = kel_reset,
    .rig = kel_rig,
    .influence = kel_influence,
    .op = kel_op,
    .bind = kel_bind,
    .binding_free = kel_binding_free,
    .eval_points = kel_eval_points,
    .jacobian_points = kel_jacobian_points,
    .handle = kel_handle,
};

/* The rig's brushes with its constraints solved (kelvinlet_rig.c), as
 * ffd_rig_apply does them, so that the deformer shows what ffd deform
 * writes. */
ffd_status ffd_sess_kelvinlet_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                                   ffd_error *err)
{
    ffd_budget budget;
    ffd_budget_init(&budget, &ctx->limits);
    kelvinlet_method *km = ffd_calloc(1, sizeof *km);
    if (!km)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    km->base.vt = &kelvinlet_vtable;
    km->base.ctx = ctx;
    ffd_status st = ffd_kelvinlet_from_rig(rig, ctx->rest, ctx->n, &budget, &km->kel, NULL, NULL,
                                           NULL, err);
    if (!st)
        st = index_grabs(km, err);
    if (st) {
        kel_destroy(&km->base);
        return st;
    }
    *out = &km->base;
    return FFD_OK;
}
