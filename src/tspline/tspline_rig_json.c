/* tspline_rig_json.c — "deformer": "tspline" rigs (docs/rig.md, "T-spline
 * rigs"): a lattice size and a sequence of steps, each a refinement, a
 * proxy-driven ARAP deformation, a direct move of control points, or direct
 * manipulation of object vertices. */
#include "tspline/tspline_method.h"
#include "rig/rig_json.h"

#include <stdio.h>
#include <string.h>

#define TSV_RIG_MAX_RES 256u

static const char *const selector_keys[] = {"points", "near", "box", "edges", "faces", "cells", NULL};
#define SELECTOR_TEXT "\"points\", \"near\", \"box\", \"edges\", \"faces\" or \"cells\""

static void selection_free(ffd_rig_tsv_selection *s)
{
    ffd_free(s->ids);
    s->ids = NULL;
}

static void step_free(void *element)
{
    ffd_rig_tsv_step *st = element;
    ffd_free(st->refinements);
    for (size_t h = 0; h < st->handle_count; h++)
        selection_free(&st->handles[h].sel);
    ffd_free(st->handles);
    for (size_t f = 0; f < st->freeze_count; f++)
        selection_free(&st->freeze[f]);
    ffd_free(st->freeze);
    ffd_free(st->constraints);
}

void ffd_rig_tspline_free(ffd_rig_tspline *t)
{
    for (size_t i = 0; i < t->step_count; i++)
        step_free(&t->steps[i]);
    ffd_free(t->steps);
    memset(t, 0, sizeof *t);
}

static ffd_status read_id(const ffd_rig_parser *p, const cJSON *v, const char *path,
                          void *element, void *ctx)
{
    (void)ctx;
    return ffd_rig_read_index(p, v, path, "an id (a non-negative integer)", element);
}

/* A non-empty array of non-negative integers. */
static ffd_status read_ids(const ffd_rig_parser *p, const cJSON *item, const char *path, uint32_t **ids,
                           size_t *count)
{
    static const char what[] = "a non-empty array of ids (non-negative integers)";
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) == 0)
        return ffd_rig_expected(p, path, what);
    void *read;
    ffd_status s = ffd_rig_read_array(p, item, path, what, sizeof **ids, read_id, NULL, NULL,
                                      &read, count);
    *ids = read;
    return s;
}

/* The one selector key of an object that may hold other keys too. */
static ffd_status read_selection(const ffd_rig_parser *p, const cJSON *obj, const char *path,
                                 ffd_rig_tsv_selection *sel)
{
    const cJSON *found = NULL;
    int kind = -1;
    for (int k = 0; selector_keys[k]; k++) {
        const cJSON *it = cJSON_GetObjectItemCaseSensitive(obj, selector_keys[k]);
        if (!it)
            continue;
        if (found)
            return ffd_rig_expected(p, path, "exactly one of " SELECTOR_TEXT);
        found = it;
        kind = k;
    }
    if (!found)
        return ffd_rig_expected(p, path, "one of " SELECTOR_TEXT " (which control points)");
    char sub[RIG_PATH_MAX + 64];
    snprintf(sub, sizeof sub, "%.100s.%s", path, selector_keys[kind]);
    memset(sel, 0, sizeof *sel);
    ffd_status s = FFD_OK;
    switch (kind) {
    case 0:
        sel->kind = FFD_RIG_SELECT_POINTS;
        return read_ids(p, found, sub, &sel->ids, &sel->id_count);
    case 1:
        sel->kind = FFD_RIG_SELECT_NEAR;
        return ffd_rig_read_vec3(p, found, sub, sel->near);
    case 2: {
        static const char *const keys[] = {"min", "max", NULL};
        sel->kind = FFD_RIG_SELECT_BOX;
        if (!cJSON_IsObject(found))
            return ffd_rig_expected(p, sub, "an object {\"min\": [x,y,z], \"max\": [x,y,z]}");
        if ((s = ffd_rig_check_keys(p, found, sub, keys, "\"min\", \"max\"")))
            return s;
        char k2[RIG_PATH_MAX + 128];
        snprintf(k2, sizeof k2, "%.100s.min", sub);
        const cJSON *mn = cJSON_GetObjectItemCaseSensitive(found, "min");
        const cJSON *mx = cJSON_GetObjectItemCaseSensitive(found, "max");
        if (!mn)
            return ffd_rig_expected(p, k2, "an array of 3 finite numbers (missing)");
        if ((s = ffd_rig_read_vec3(p, mn, k2, sel->box_min)))
            return s;
        snprintf(k2, sizeof k2, "%.100s.max", sub);
        if (!mx)
            return ffd_rig_expected(p, k2, "an array of 3 finite numbers (missing)");
        if ((s = ffd_rig_read_vec3(p, mx, k2, sel->box_max)))
            return s;
        for (int a = 0; a < 3; a++)
            if (sel->box_min[a] > sel->box_max[a])
                return ffd_fail(p->err, FFD_ERR_INVALID,
                                "%s: %s: min[%d] %g is above max[%d] %g", p->name, sub, a,
                                sel->box_min[a], a, sel->box_max[a]);
        return FFD_OK;
    }
    default:
        sel->kind = kind == 3 ? FFD_RIG_SELECT_EDGES
                              : kind == 4 ? FFD_RIG_SELECT_FACES : FFD_RIG_SELECT_CELLS;
        return read_ids(p, found, sub, &sel->ids, &sel->id_count);
    }
}

static void selection_release(void *element)
{
    selection_free(element);
}

/* A selection alone: {"points": [..]} etc. */
static ffd_status read_selection_element(const ffd_rig_parser *p, const cJSON *c,
                                         const char *path, void *element, void *ctx)
{
    (void)ctx;
    if (!cJSON_IsObject(c))
        return ffd_rig_expected(p, path, "an object {" SELECTOR_TEXT ": ...}");
    ffd_status s = ffd_rig_check_keys(p, c, path, selector_keys, SELECTOR_TEXT);
    return s ? s : read_selection(p, c, path, element);
}

static ffd_status read_selections(const ffd_rig_parser *p, const cJSON *item, const char *path,
                                  ffd_rig_tsv_selection **out, size_t *count)
{
    void *read;
    ffd_status s = ffd_rig_read_array(p, item, path,
                                      "an array of selections {" SELECTOR_TEXT ": ...}",
                                      sizeof **out, read_selection_element, selection_release,
                                      NULL, &read, count);
    *out = read;
    return s;
}

static void handle_release(void *element)
{
    selection_free(&((ffd_rig_tsv_handle *)element)->sel);
}

/* A selection with "delta" or "rotate". */
static ffd_status read_handle(const ffd_rig_parser *p, const cJSON *c, const char *sub,
                              void *element, void *ctx)
{
    static const char *const keys[] = {"points", "near", "box", "edges", "faces", "cells",
                                       "delta",  "rotate", NULL};
    ffd_rig_tsv_handle *h = element;
    char k2[RIG_PATH_MAX + 192];
    (void)ctx;
    if (!cJSON_IsObject(c))
        return ffd_rig_expected(p, sub, "an object {selection, \"delta\" or \"rotate\"}");
    ffd_status s = ffd_rig_check_keys(p, c, sub, keys, SELECTOR_TEXT ", \"delta\", \"rotate\"");
    if (s || (s = read_selection(p, c, sub, &h->sel)))
        return s;
    const cJSON *delta = cJSON_GetObjectItemCaseSensitive(c, "delta");
    const cJSON *rotate = cJSON_GetObjectItemCaseSensitive(c, "rotate");
    if ((delta != NULL) == (rotate != NULL))
        return ffd_rig_expected(p, sub, "either \"delta\" or \"rotate\" (one of them)");
    if (delta) {
        snprintf(k2, sizeof k2, "%.100s.delta", sub);
        h->has_delta = 1;
        return ffd_rig_read_vec3(p, delta, k2, h->delta);
    }
    snprintf(k2, sizeof k2, "%.100s.rotate", sub);
    h->has_rotate = 1;
    return ffd_rig_read_rotation(p, rotate, k2, h->axis, &h->angle, h->center, &h->has_center);
}

static ffd_status read_handles(const ffd_rig_parser *p, const cJSON *item, const char *path,
                               ffd_rig_tsv_handle **out, size_t *count)
{
    static const char what[] = "a non-empty array of {selection, \"delta\": [x,y,z]} or "
                               "{selection, \"rotate\": {\"axis\", \"angle\"}}";
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) == 0)
        return ffd_rig_expected(p, path, what);
    void *read;
    ffd_status s = ffd_rig_read_array(p, item, path, what, sizeof **out, read_handle,
                                      handle_release, NULL, &read, count);
    *out = read;
    return s;
}

static ffd_status read_refinement(const ffd_rig_parser *p, const cJSON *c, const char *sub,
                                  void *element, void *ctx)
{
    static const char *const keys[] = {"cell", "face", "edge", "cells", "ratio", NULL};
    ffd_rig_tsv_refinement *r = element;
    char k2[RIG_PATH_MAX + 192];
    (void)ctx;
    if (!cJSON_IsObject(c))
        return ffd_rig_expected(p, sub, "an object {\"cell\"|\"face\"|\"edge\": id}");
    ffd_status s = ffd_rig_check_keys(p, c, sub, keys,
                                  "\"cell\", \"face\", \"edge\", \"cells\", \"ratio\"");
    if (s)
        return s;
    const cJSON *which = NULL;
    int count = 0;
    for (int k = 0; k < 4; k++) {
        const cJSON *it = cJSON_GetObjectItemCaseSensitive(c, keys[k]);
        if (it) {
            count++;
            which = it;
            r->kind = k == 0 || k == 3 ? FFD_TSV_CELL : k == 1 ? FFD_TSV_FACE : FFD_TSV_EDGE;
            r->proxy_cells = k == 3;
        }
    }
    if (count != 1)
        return ffd_rig_expected(p, sub, "exactly one of \"cell\", \"face\", \"edge\", \"cells\"");
    snprintf(k2, sizeof k2, "%.100s.%s", sub, which->string);
    if (r->proxy_cells) {
        if (!cJSON_IsString(which) || strcmp(which->valuestring, "proxy") != 0)
            return ffd_rig_expected(p, k2, "\"proxy\" (octree-split every cell inside the proxy)");
    } else if (cJSON_IsObject(which)) {
        static const char *const near_keys[] = {"near", NULL};
        if ((s = ffd_rig_check_keys(p, which, k2, near_keys, "\"near\"")))
            return s;
        const cJSON *near = cJSON_GetObjectItemCaseSensitive(which, "near");
        char k3[RIG_PATH_MAX + 256];
        snprintf(k3, sizeof k3, "%.100s.near", k2);
        if (!near)
            return ffd_rig_expected(p, k3, "an array of 3 finite numbers (missing)");
        r->by_near = 1;
        if ((s = ffd_rig_read_vec3(p, near, k3, r->near)))
            return s;
    } else if ((s = ffd_rig_read_index(p, which, k2, "an id or {\"near\": [x,y,z]}", &r->id))) {
        return s;
    }
    const cJSON *ratio = cJSON_GetObjectItemCaseSensitive(c, "ratio");
    if (ratio) {
        snprintf(k2, sizeof k2, "%.100s.ratio", sub);
        if (r->kind != FFD_TSV_EDGE)
            return ffd_fail(p->err, FFD_ERR_PARSE, "%s: %s: only for an \"edge\" insertion",
                            p->name, k2);
        if ((s = ffd_rig_read_number(p, ratio, k2, &r->ratio)))
            return s;
        if (!(r->ratio > 0 && r->ratio < 1))
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: %s: %g: expected a number in (0, 1) (where the point goes "
                            "along the edge's knot interval)",
                            p->name, k2, r->ratio);
    }
    return FFD_OK;
}

ffd_status ffd_rig_read_tsv_refinements(const ffd_rig_parser *p, const cJSON *item, const char *path,
                                        ffd_rig_tsv_step *st)
{
    static const char what[] = "a non-empty array of {\"cell\"|\"face\"|\"edge\": id or "
                               "{\"near\": [x,y,z]}} or {\"cells\": \"proxy\"}";
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) == 0)
        return ffd_rig_expected(p, path, what);
    void *read;
    ffd_status s = ffd_rig_read_array(p, item, path, what, sizeof *st->refinements,
                                      read_refinement, NULL, NULL, &read, &st->refinement_count);
    st->refinements = read;
    return s;
}

static ffd_status read_weights(const ffd_rig_parser *p, const cJSON *item, const char *path,
                               ffd_tsv_arap_options *o)
{
    static const char *const keys[] = {"one_form", "proxy", "volume", "target", NULL};
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, path, "an object {\"one_form\", \"proxy\", \"volume\", \"target\"}");
    ffd_status s = ffd_rig_check_keys(p, item, path, keys,
                                  "\"one_form\", \"proxy\", \"volume\", \"target\"");
    if (s)
        return s;
    double *dst[4] = {&o->w_one_form, &o->w_proxy, &o->w_volume, &o->w_target};
    for (int k = 0; k < 4; k++) {
        const cJSON *w = cJSON_GetObjectItemCaseSensitive(item, keys[k]);
        if (!w)
            continue;
        char sub[RIG_PATH_MAX + 64];
        snprintf(sub, sizeof sub, "%.100s.%s", path, keys[k]);
        if ((s = ffd_rig_read_positive(p, w, sub, dst[k])))
            return s;
        if (*dst[k] > 1e6)
            return ffd_fail(p->err, FFD_ERR_INVALID, "%s: %s: %g: expected a weight in (0, 1e6]",
                            p->name, sub, *dst[k]);
    }
    return FFD_OK;
}

static ffd_status read_bool(const ffd_rig_parser *p, const cJSON *item, const char *path, int *out)
{
    if (!cJSON_IsBool(item))
        return ffd_rig_expected(p, path, "true or false");
    *out = cJSON_IsTrue(item) ? 1 : 0;
    return FFD_OK;
}

static ffd_status read_deform(const ffd_rig_parser *p, const cJSON *item, const char *path,
                              ffd_rig_tsv_step *st)
{
    static const char *const keys[] = {"handles", "freeze", "weights", "iterations",
                                       "soft",    "only_target", NULL};
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, path, "an object {\"handles\": [..], \"freeze\": [..], ...}");
    ffd_status s = ffd_rig_check_keys(p, item, path, keys,
                                  "\"handles\", \"freeze\", \"weights\", \"iterations\", "
                                  "\"soft\", \"only_target\"");
    if (s)
        return s;
    char sub[RIG_PATH_MAX + 128];
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(item, "handles");
    snprintf(sub, sizeof sub, "%.100s.handles", path);
    if (!it)
        return ffd_rig_expected(p, sub, "an array of handles (missing: a deformation moves something)");
    if ((s = read_handles(p, it, sub, &st->handles, &st->handle_count)))
        return s;
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "freeze"))) {
        snprintf(sub, sizeof sub, "%.100s.freeze", path);
        if ((s = read_selections(p, it, sub, &st->freeze, &st->freeze_count)))
            return s;
    }
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "weights"))) {
        snprintf(sub, sizeof sub, "%.100s.weights", path);
        if ((s = read_weights(p, it, sub, &st->arap)))
            return s;
    }
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "iterations"))) {
        snprintf(sub, sizeof sub, "%.100s.iterations", path);
        if ((s = ffd_rig_read_index(p, it, sub, "an integer in 1..1000", &st->arap.iterations)))
            return s;
        if (st->arap.iterations < 1 || st->arap.iterations > 1000)
            return ffd_rig_expected(p, sub, "an integer in 1..1000");
    }
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "soft"))) {
        snprintf(sub, sizeof sub, "%.100s.soft", path);
        if ((s = read_bool(p, it, sub, &st->arap.soft)))
            return s;
    }
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "only_target"))) {
        snprintf(sub, sizeof sub, "%.100s.only_target", path);
        if ((s = read_bool(p, it, sub, &st->arap.only_target)))
            return s;
    }
    return FFD_OK;
}

static ffd_status read_constrain(const ffd_rig_parser *p, const cJSON *item, const char *path,
                                 ffd_rig_tsv_step *st)
{
    static const char *const keys[] = {"targets", "freeze", NULL};
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, path, "an object {\"targets\": [{\"vertex\", \"target\"}], "
                                     "\"freeze\": [..]}");
    ffd_status s = ffd_rig_check_keys(p, item, path, keys, "\"targets\", \"freeze\"");
    if (s)
        return s;
    char sub[RIG_PATH_MAX + 128];
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(item, "targets");
    snprintf(sub, sizeof sub, "%.100s.targets", path);
    if (!it)
        return ffd_rig_expected(p, sub, "an array of {\"vertex\": id, \"target\": [x,y,z]} (missing)");
    if ((s = ffd_rig_read_constraints(p, it, sub, &st->constraints, &st->constraint_count)))
        return s;
    for (size_t i = 0; i < st->constraint_count; i++)
        if (st->constraints[i].kind != FFD_RIG_CONSTRAINT_VERTEX)
            return ffd_fail(p->err, FFD_ERR_PARSE,
                            "%s: %s[%zu].point: T-spline rigs constrain object vertices "
                            "(\"vertex\": id); a point in space has no binding",
                            p->name, sub, i);
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "freeze"))) {
        snprintf(sub, sizeof sub, "%.100s.freeze", path);
        if ((s = read_selections(p, it, sub, &st->freeze, &st->freeze_count)))
            return s;
    }
    return FFD_OK;
}

static ffd_status read_step(const ffd_rig_parser *p, const cJSON *c, const char *sub,
                            void *element, void *ctx)
{
    static const char *const kinds[] = {"refine", "deform", "move", "constraints", NULL};
    ffd_rig_tsv_step *st = element;
    char k2[RIG_PATH_MAX + 64];
    (void)ctx;
    if (!cJSON_IsObject(c) || cJSON_GetArraySize(c) != 1)
        return ffd_rig_expected(p, sub, "an object with one key: \"refine\", \"deform\", "
                                        "\"move\" or \"constraints\"");
    ffd_status s = ffd_rig_check_keys(p, c, sub, kinds,
                                      "\"refine\", \"deform\", \"move\", \"constraints\"");
    if (s)
        return s;
    const cJSON *body = c->child;
    int k = ffd_rig_lookup(body->string, kinds);
    snprintf(k2, sizeof k2, "%.100s.%s", sub, body->string);
    st->kind = (ffd_rig_tsv_step_kind)k;
    if (k == 0)
        return ffd_rig_read_tsv_refinements(p, body, k2, st);
    if (k == 1)
        return read_deform(p, body, k2, st);
    if (k == 2)
        return read_handles(p, body, k2, &st->handles, &st->handle_count);
    return read_constrain(p, body, k2, st);
}

static ffd_status read_steps(const ffd_rig_parser *p, const cJSON *item, ffd_rig_tspline *t)
{
    void *steps;
    ffd_status s = ffd_rig_read_array(p, item, "steps",
                                      "an array of steps {\"refine\"|\"deform\"|\"move\"|"
                                      "\"constraints\": ...}",
                                      sizeof *t->steps, read_step, step_free, NULL, &steps,
                                      &t->step_count);
    t->steps = steps;
    return s;
}

const char *const ffd_rig_keys_tspline[] = {"resolution", "padding", "steps", "fold_samples", NULL};

ffd_status ffd_rig_parse_tspline(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    ffd_rig_tspline *t = ffd_rig_tspline_of(rig);
    t->resolution[0] = t->resolution[1] = t->resolution[2] = 6;
    const cJSON *item;
    ffd_status s = ffd_rig_check_deformer_root(p, root, &ffd_method_tspline);
    if (s)
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "resolution"))) {
        if ((s = ffd_rig_read_uint3(p, item, "resolution", t->resolution)))
            return s;
        for (int a = 0; a < 3; a++)
            if (t->resolution[a] < 4 || t->resolution[a] > TSV_RIG_MAX_RES)
                return ffd_fail(p->err, FFD_ERR_INVALID,
                                "%s: resolution[%d]: %u: expected 4 to %u control points (a cubic "
                                "T-spline volume needs at least 4 per axis)",
                                p->name, a, t->resolution[a], TSV_RIG_MAX_RES);
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "padding"))) {
        if ((s = ffd_rig_read_number(p, item, "padding", &t->options.padding)))
            return s;
        if (t->options.padding < 0 || t->options.padding > 100)
            return ffd_rig_expected(p, "padding", "a number in [0, 100] (fraction of the extent)");
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "fold_samples"))) {
        if ((s = ffd_rig_read_index(p, item, "fold_samples", "an integer in 1..64", &t->fold_samples)))
            return s;
        if (t->fold_samples < 1 || t->fold_samples > 64)
            return ffd_rig_expected(p, "fold_samples", "an integer in 1..64");
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "steps")) && (s = read_steps(p, item, t)))
        return s;
    return FFD_OK;
}

/* ======================================================================
 * Writer: the section as the reader above reads it (ffd_method.write)
 * ====================================================================== */

static int add_ids(cJSON *o, const char *key, const uint32_t *ids, size_t n)
{
    return ffd_sess_add_item(o, key, ffd_sess_uint_array(ids, n));
}

/* The selector key of sel, added to o. */
static int add_selection(cJSON *o, const ffd_rig_tsv_selection *sel)
{
    cJSON *box;
    switch (sel->kind) {
    case FFD_RIG_SELECT_NEAR:
        return ffd_sess_add_item(o, "near", ffd_sess_vec3(sel->near));
    case FFD_RIG_SELECT_BOX:
        return (box = cJSON_AddObjectToObject(o, "box")) &&
               ffd_sess_add_item(box, "min", ffd_sess_vec3(sel->box_min)) &&
               ffd_sess_add_item(box, "max", ffd_sess_vec3(sel->box_max));
    default: /* the id selectors, in selector_keys order */
        return add_ids(o, selector_keys[sel->kind == FFD_RIG_SELECT_POINTS  ? 0
                                        : sel->kind == FFD_RIG_SELECT_EDGES ? 3
                                        : sel->kind == FFD_RIG_SELECT_FACES ? 4
                                                                            : 5],
                       sel->ids, sel->id_count);
    }
}

static int add_handles(cJSON *parent, const char *key, const ffd_rig_tsv_handle *h, size_t n)
{
    cJSON *a = cJSON_AddArrayToObject(parent, key);
    int ok = a != NULL;
    for (size_t i = 0; ok && i < n; i++) {
        cJSON *o = cJSON_CreateObject(), *r = NULL;
        ok = ffd_sess_add_to_array(a, o) && add_selection(o, &h[i].sel);
        if (ok && h[i].has_delta)
            ok = ffd_sess_add_item(o, "delta", ffd_sess_vec3(h[i].delta));
        else if (ok)
            ok = (r = cJSON_AddObjectToObject(o, "rotate")) &&
                 ffd_sess_add_item(r, "axis", ffd_sess_vec3(h[i].axis)) &&
                 ffd_sess_add_item(r, "angle", ffd_sess_number(h[i].angle)) &&
                 (!h[i].has_center || ffd_sess_add_item(r, "center", ffd_sess_vec3(h[i].center)));
    }
    return ok;
}

static int add_freeze(cJSON *parent, const ffd_rig_tsv_selection *sel, size_t n)
{
    cJSON *a = n ? cJSON_AddArrayToObject(parent, "freeze") : NULL;
    int ok = !n || a;
    for (size_t i = 0; ok && i < n; i++) {
        cJSON *o = cJSON_CreateObject();
        ok = ffd_sess_add_to_array(a, o) && add_selection(o, &sel[i]);
    }
    return ok;
}

static int add_refinements(cJSON *step, const ffd_rig_tsv_step *st)
{
    static const char *const kinds[] = {"edge", "face", "cell"};
    cJSON *a = cJSON_AddArrayToObject(step, "refine");
    int ok = a != NULL;
    for (size_t i = 0; ok && i < st->refinement_count; i++) {
        const ffd_rig_tsv_refinement *r = &st->refinements[i];
        cJSON *o = cJSON_CreateObject(), *near = NULL;
        ok = ffd_sess_add_to_array(a, o);
        if (ok && r->proxy_cells)
            ok = cJSON_AddStringToObject(o, "cells", "proxy") != NULL;
        else if (ok && r->by_near)
            ok = (near = cJSON_AddObjectToObject(o, kinds[r->kind])) &&
                 ffd_sess_add_item(near, "near", ffd_sess_vec3(r->near));
        else if (ok)
            ok = cJSON_AddNumberToObject(o, kinds[r->kind], r->id) != NULL;
        ok = ok && (r->kind != FFD_TSV_EDGE || r->ratio == 0 ||
                    cJSON_AddNumberToObject(o, "ratio", r->ratio));
    }
    return ok;
}

static int add_deform(cJSON *step, const ffd_rig_tsv_step *st)
{
    const ffd_tsv_arap_options *o = &st->arap;
    cJSON *d = cJSON_AddObjectToObject(step, "deform"), *w = NULL;
    int weights = o->w_one_form > 0 || o->w_proxy > 0 || o->w_volume > 0 || o->w_target > 0;
    return d && add_handles(d, "handles", st->handles, st->handle_count) &&
           add_freeze(d, st->freeze, st->freeze_count) &&
           (!weights ||
            ((w = cJSON_AddObjectToObject(d, "weights")) &&
             (!(o->w_one_form > 0) || ffd_sess_add_item(w, "one_form", ffd_sess_number(o->w_one_form))) &&
             (!(o->w_proxy > 0) || ffd_sess_add_item(w, "proxy", ffd_sess_number(o->w_proxy))) &&
             (!(o->w_volume > 0) || ffd_sess_add_item(w, "volume", ffd_sess_number(o->w_volume))) &&
             (!(o->w_target > 0) || ffd_sess_add_item(w, "target", ffd_sess_number(o->w_target))))) &&
           (!o->iterations || cJSON_AddNumberToObject(d, "iterations", o->iterations)) &&
           (!o->soft || cJSON_AddTrueToObject(d, "soft")) &&
           (!o->only_target || cJSON_AddTrueToObject(d, "only_target"));
}

static int add_constrain(cJSON *step, const ffd_rig_tsv_step *st)
{
    cJSON *c = cJSON_AddObjectToObject(step, "constraints");
    cJSON *t = c ? cJSON_AddArrayToObject(c, "targets") : NULL;
    int ok = t != NULL;
    for (size_t i = 0; ok && i < st->constraint_count; i++) {
        cJSON *o = cJSON_CreateObject();
        ok = ffd_sess_add_to_array(t, o) &&
             cJSON_AddNumberToObject(o, "vertex", st->constraints[i].vertex) &&
             ffd_sess_add_item(o, "target", ffd_sess_vec3(st->constraints[i].target));
    }
    return ok && add_freeze(c, st->freeze, st->freeze_count);
}

int ffd_rig_write_tspline(const ffd_rig *rig, cJSON *root)
{
    const ffd_rig_tspline *t = ffd_rig_tspline_of(rig);
    cJSON *steps = cJSON_AddArrayToObject(root, "steps");
    int ok = steps && ffd_sess_add_item(root, "resolution", ffd_sess_uint_array(t->resolution, 3)) &&
             cJSON_AddNumberToObject(root, "padding", t->options.padding) &&
             (!t->fold_samples || cJSON_AddNumberToObject(root, "fold_samples", t->fold_samples));
    for (size_t i = 0; ok && i < t->step_count; i++) {
        const ffd_rig_tsv_step *st = &t->steps[i];
        cJSON *step = cJSON_CreateObject();
        ok = ffd_sess_add_to_array(steps, step);
        if (ok && st->kind == FFD_RIG_STEP_REFINE)
            ok = add_refinements(step, st);
        else if (ok && st->kind == FFD_RIG_STEP_DEFORM)
            ok = add_deform(step, st);
        else if (ok && st->kind == FFD_RIG_STEP_MOVE)
            ok = add_handles(step, "move", st->handles, st->handle_count);
        else if (ok)
            ok = add_constrain(step, st);
    }
    return ok;
}

void ffd_rig_release_tspline(ffd_rig *rig)
{
    if (ffd_rig_tspline_of(rig))
        ffd_rig_tspline_free(ffd_rig_tspline_of(rig));
}
