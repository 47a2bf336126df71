/* deformer — the public ffd_deformer (ffd.h "Deformers"): any method behind
 * one interface. A deformer is the method's own deformer (sess_method, built
 * by the registry's load from a rig on a private copy of the mesh) plus a
 * binding of any point set (the method's bind). Control edits go through the
 * method's drag operations (begin / set_controls / end), so that every
 * method keeps its own meaning of moving a control. */
#include "deformer/method.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

struct ffd_deformer {
    const ffd_method *method;
    ffd_mesh *mesh;          /* a copy of the mesh the rig was made for */
    sess_ctx ctx;            /* over mesh */
    sess_method *m;
    sess_binding *binding;   /* the bound points */
    size_t point_count;
};

static ffd_status unsupported(const ffd_deformer *d, const char *what, ffd_error *err)
{
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: the %s method has no %s", what,
                    d->method->name, what);
}

ffd_status ffd_deformer_create(const ffd_rig *rig, const ffd_mesh *mesh, const ffd_limits *limits,
                               ffd_deformer **out, ffd_error *err)
{
    if (!rig || !mesh || !out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_deformer_create: NULL argument");
    *out = NULL;
    const ffd_method *method = ffd_method_of_rig(rig);
    if (!method)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: unknown deformer", rig->name);
    if (ffd_mesh_vertex_count(mesh) == 0)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: the mesh has no vertices", rig->name);
    ffd_deformer *d = ffd_calloc(1, sizeof *d);
    if (!d)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    d->method = method;
    ffd_status st = ffd_sess_clone_mesh(mesh, &d->mesh, err);
    if (!st) {
        ffd_sess_ctx_init(&d->ctx, d->mesh, 0, limits);
        st = ffd_method_load(method, &d->ctx, rig, &d->m, err);
    }
    if (!st)
        st = ffd_deformer_bind(d, d->ctx.rest, d->ctx.n, err);
    if (st) {
        ffd_deformer_destroy(d);
        return st;
    }
    *out = d;
    return FFD_OK;
}

ffd_status ffd_deformer_create_json(const char *text, size_t size, const char *name,
                                    const ffd_mesh *mesh, const ffd_limits *limits,
                                    ffd_deformer **out, ffd_error *err)
{
    ffd_rig *rig = NULL;
    ffd_status st = ffd_rig_parse_json(text, size, name, &rig, err);
    if (!st)
        st = ffd_deformer_create(rig, mesh, limits, out, err);
    ffd_rig_destroy(rig);
    return st;
}

void ffd_deformer_destroy(ffd_deformer *d)
{
    if (!d)
        return;
    if (d->binding)
        d->m->vt->binding_free(d->binding);
    if (d->m)
        d->m->vt->destroy(d->m);
    ffd_mesh_destroy(d->mesh);
    ffd_free(d);
}

const char *ffd_deformer_method(const ffd_deformer *d)
{
    return d->method->name;
}

void *ffd_deformer_handle(ffd_deformer *d, const char *method)
{
    if (!d || !method || strcmp(method, d->method->name) || !ffd_sess_caps(d->m)->handle)
        return NULL;
    return d->m->vt->handle(d->m);
}

ffd_status ffd_deformer_bind(ffd_deformer *d, const double *points, size_t n, ffd_error *err)
{
    if (!d || (!points && n))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_deformer_bind: NULL argument");
    if (!ffd_sess_caps(d->m)->bind)
        return unsupported(d, "binding of other points", err);
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(points[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "bind: point %zu: coordinate %zu is not finite",
                            i / 3, i % 3);
    sess_binding *b = NULL;
    ffd_status st = d->m->vt->bind(d->m, points, n, &b, err);
    if (st)
        return st;
    if (d->binding)
        d->m->vt->binding_free(d->binding);
    d->binding = b;
    d->point_count = n;
    return FFD_OK;
}

size_t ffd_deformer_point_count(const ffd_deformer *d)
{
    return d->point_count;
}

ffd_status ffd_deformer_eval(ffd_deformer *d, double *out, ffd_error *err)
{
    return d->m->vt->eval_points(d->m, d->binding, out, err);
}

ffd_status ffd_deformer_jacobian(ffd_deformer *d, double *out, ffd_error *err)
{
    if (!ffd_sess_caps(d->m)->jacobian_points)
        return unsupported(d, "Jacobian", err);
    return d->m->vt->jacobian_points(d->m, d->binding, out, err);
}

ffd_status ffd_deformer_linear_map(ffd_deformer *d, ffd_linear_map *map, ffd_error *err)
{
    if (!ffd_sess_caps(d->m)->map_points)
        return unsupported(d, "linear map", err);
    return d->m->vt->map_points(d->m, d->binding, map, err);
}

size_t ffd_deformer_control_count(const ffd_deformer *d)
{
    return d->m->vt->control_count(d->m);
}

void ffd_deformer_controls(const ffd_deformer *d, double *out)
{
    d->m->vt->controls(d->m, out);
}

/* Puts controls ids[0..k) (all when ids is NULL) at positions, or at their
 * current positions plus positions when relative: one drag of the method. */
static ffd_status place_controls(ffd_deformer *d, const uint32_t *ids, size_t k,
                                 const double *positions, int relative, ffd_error *err)
{
    const char *what = relative ? "move_controls" : "set_controls";
    size_t count = ffd_deformer_control_count(d);
    if (!ids && k != count)
        return ffd_fail(err, FFD_ERR_RANGE, "%s: %zu positions for %zu controls", what, k, count);
    if (k && !positions)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: NULL positions", what);
    for (size_t c = 0; c < k; c++) {
        if (ids && ids[c] >= count)
            return ffd_fail(err, FFD_ERR_RANGE, "%s: control %u out of range (%zu controls)", what,
                            ids[c], count);
        for (int a = 0; a < 3; a++)
            if (!isfinite(positions[3 * c + a]) || fabs(positions[3 * c + a]) > SESS_COORD_MAX)
                return ffd_fail(err, FFD_ERR_NONFINITE,
                                "%s: entry %zu: coordinate %d is not finite or beyond %g", what, c,
                                a, SESS_COORD_MAX);
    }
    if (k == 0)
        return FFD_OK;
    uint32_t *all = NULL;
    double *current = ffd_malloc_array(count, 3 * sizeof *current);
    double *targets = ffd_malloc_array(k, 3 * sizeof *targets);
    if (!ids && (all = ffd_malloc_array(k, sizeof *all)))
        for (size_t c = 0; c < k; c++)
            all[c] = (uint32_t)c;
    ffd_status st = FFD_OK;
    if (!current || !targets || (!ids && !all)) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu controls", what, k);
        goto done;
    }
    const uint32_t *use = ids ? ids : all;
    for (size_t c = 0; c < k; c++)
        for (size_t j = c + 1; ids && j < k; j++)
            if (ids[c] == ids[j]) {
                st = ffd_fail(err, FFD_ERR_INVALID, "%s: control %u given twice", what, ids[c]);
                goto done;
            }
    if (relative && d->m->vt->move_by_variables) {
        /* the deltas on the variables, zero elsewhere (a whole-count
         * buffer: current is reused for it) */
        memset(current, 0, count * 3 * sizeof *current);
        for (size_t c = 0; c < k; c++)
            memcpy(current + 3 * (size_t)use[c], positions + 3 * c, 3 * sizeof *current);
        if ((st = d->m->vt->begin(d->m, use, k, 0, err)))
            goto done;
        st = d->m->vt->set_variables(d->m, current, err);
        d->m->vt->end(d->m, st == FFD_OK);
        goto done;
    }
    ffd_deformer_controls(d, current);
    for (size_t c = 0; c < k; c++)
        for (int a = 0; a < 3; a++)
            targets[3 * c + a] = positions[3 * c + a] + (relative ? current[3 * use[c] + a] : 0);
    if ((st = d->m->vt->begin(d->m, use, k, 0, err)))
        goto done;
    st = d->m->vt->set_controls(d->m, use, k, targets, err);
    d->m->vt->end(d->m, st == FFD_OK);
done:
    ffd_free(all);
    ffd_free(current);
    ffd_free(targets);
    return st;
}

ffd_status ffd_deformer_set_controls(ffd_deformer *d, const uint32_t *ids, size_t k,
                                     const double *positions, ffd_error *err)
{
    return place_controls(d, ids, k, positions, 0, err);
}

ffd_status ffd_deformer_move_controls(ffd_deformer *d, const uint32_t *ids, size_t k,
                                      const double *deltas, ffd_error *err)
{
    return place_controls(d, ids, k, deltas, 1, err);
}

ffd_status ffd_deformer_reset(ffd_deformer *d, ffd_error *err)
{
    return d->m->vt->reset(d->m, err);
}

ffd_status ffd_deformer_report(const ffd_deformer *d, char **json, size_t *size, ffd_error *err)
{
    *json = NULL;
    if (size)
        *size = 0;
    cJSON *root = cJSON_CreateObject(), *params = cJSON_CreateObject();
    cJSON *controls = cJSON_CreateObject();
    int ok = root && params && controls && cJSON_AddStringToObject(root, "method", d->method->name)
             && ffd_sess_add_item(root, "points", ffd_sess_number((double)d->point_count))
             && ffd_sess_add_item(controls, "count",
                              ffd_sess_number((double)ffd_deformer_control_count(d)));
    ffd_status st = ok ? d->m->vt->describe(d->m, params, controls, err)
                       : ffd_fail(err, FFD_ERR_NOMEM, "report: out of memory");
    /* the generic layers' outcome (constraints' residuals, fold fraction) */
    if (!st && ffd_layers_outcome(d->m, root))
        st = ffd_fail(err, FFD_ERR_NOMEM, "report: out of memory");
    if (!st) {
        int added = ffd_sess_add_item(root, "controls", controls); /* takes controls, even on failure */
        controls = NULL;
        if (added) {
            added = ffd_sess_add_item(root, "params", params);
            params = NULL;
        }
        if (!added)
            st = ffd_fail(err, FFD_ERR_NOMEM, "report: out of memory");
    }
    if (!st) {
        char *text = cJSON_PrintUnformatted(root);
        *json = text ? ffd_strdup(text) : NULL;
        cJSON_free(text);
        if (!*json)
            st = ffd_fail(err, FFD_ERR_NOMEM, "report: out of memory");
        else if (size)
            *size = strlen(*json);
    }
    cJSON_Delete(params);
    cJSON_Delete(controls);
    cJSON_Delete(root);
    return st;
}

ffd_status ffd_deformer_command(ffd_deformer *d, const char *op, const char *body, size_t size,
                                ffd_error *err)
{
    if (!d || !op || (!body && size))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_deformer_command: NULL argument");
    const char *const *ops = d->method->ops;
    size_t i = 0;
    while (ops && ops[i] && strcmp(ops[i], op))
        i++;
    if (!ops || !ops[i]) {
        char list[256] = "";
        for (size_t j = 0; ops && ops[j]; j++)
            snprintf(list + strlen(list), sizeof list - strlen(list), "%s\"%s\"", j ? ", " : "",
                     ops[j]);
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not an operation of the %s method (%s%s)",
                        op, d->method->name, *list ? "its operations: " : "it has none", list);
    }
    cJSON *doc = NULL;
    ffd_status st = ffd_sess_parse_body(op, body, size, &doc, err);
    if (st)
        return st;
    int undo_kind = SESS_UNDO_NONE;
    st = d->m->vt->op(d->m, op, doc, &undo_kind, err);
    cJSON_Delete(doc);
    return st;
}

ffd_status ffd_deformer_rig(const ffd_deformer *d, char **json, size_t *size, ffd_error *err)
{
    if (!d || !json)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_deformer_rig: NULL argument");
    *json = NULL;
    ffd_status st = ffd_sess_rig_text(d->m, json, err);
    if (size)
        *size = st ? 0 : strlen(*json);
    return st;
}

sess_method *ffd_deformer_session_method(ffd_deformer *d, const sess_binding **binding)
{
    *binding = d->binding;
    return d->m;
}

ffd_status ffd_deformer_fold_check(ffd_deformer *d, ffd_fold_report *out, ffd_error *err)
{
    if (!d || !out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_deformer_fold_check: NULL argument");
    memset(out, 0, sizeof *out);
    out->min_det = NAN;
    if (!ffd_sess_caps(d->m)->fold_check)
        return unsupported(d, "fold check", err);
    return d->m->vt->fold_check(d->m, out, err);
}

void ffd_fold_report_free(ffd_fold_report *report)
{
    if (!report)
        return;
    ffd_free(report->cell_ids);
    memset(report, 0, sizeof *report);
}
