/* rig_layers — the rig keys every method shares (docs/constraints.md):
 * per-vertex "weights" and a global "strength" (Blender's and Maya's
 * vertex-group weights: x'_i = x_i + s w_i (f(x_i) - x_i)), constrained
 * FFD ("preserve", "linear_constraints", "constraint_mask": PyGeM's VFFD,
 * BFFD and CFFD) and fold-free moves ("fold_policy"). The rig reader takes
 * them out of the rig before the method's own reader sees it, so a new
 * method has them without a line of its own; deformer/layers.c applies
 * them around the method's deformer. */
#include "rig/rig_json.h"
#include "mesh/mesh.h"
#include "session/session.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

const char *const ffd_rig_layer_keys[] = {"weights",           "strength",        "preserve",
                                          "linear_constraints", "constraint_mask", "fold_policy",
                                          NULL};

int ffd_rig_layers_trivial(const ffd_rig_layers *l)
{
    return !l || (l->strength == 1.0 && l->weights_kind == FFD_WEIGHTS_NONE && !l->preserve &&
                  !l->linear_count && l->fold_policy == FFD_FOLD_ALLOW);
}

static void linear_free(ffd_rig_linear_constraint *c)
{
    ffd_free(c->index);
    ffd_free(c->axis);
    ffd_free(c->coef);
}

void ffd_rig_layers_free(ffd_rig_layers *l)
{
    if (!l)
        return;
    ffd_free(l->weights_name);
    ffd_free(l->weights_path);
    ffd_free(l->weights);
    for (size_t i = 0; i < l->linear_count; i++)
        linear_free(&l->linear[i]);
    ffd_free(l->linear);
    ffd_free(l->mask_controls);
    ffd_free(l);
}

static void *dup_array(const void *a, size_t n, size_t size, int *ok)
{
    if (!a || !n)
        return NULL;
    void *b = ffd_malloc_array(n, size);
    if (!b)
        *ok = 0;
    else
        memcpy(b, a, n * size);
    return b;
}

ffd_rig_layers *ffd_rig_layers_copy(const ffd_rig_layers *l)
{
    if (!l)
        return NULL;
    ffd_rig_layers *c = ffd_calloc(1, sizeof *c);
    if (!c)
        return NULL;
    *c = *l;
    c->weights_name = c->weights_path = NULL;
    c->weights = NULL;
    c->linear = NULL;
    c->mask_controls = NULL;
    c->linear_count = 0;
    int ok = 1;
    if (l->weights_name && !(c->weights_name = ffd_strdup(l->weights_name)))
        ok = 0;
    if (l->weights_path && !(c->weights_path = ffd_strdup(l->weights_path)))
        ok = 0;
    c->weights = dup_array(l->weights, l->weight_count, sizeof *l->weights, &ok);
    c->mask_controls = dup_array(l->mask_controls, l->mask_control_count, sizeof(uint32_t), &ok);
    if (ok && l->linear_count &&
        !(c->linear = ffd_calloc(l->linear_count, sizeof *c->linear)))
        ok = 0;
    for (size_t i = 0; ok && i < l->linear_count; i++) {
        const ffd_rig_linear_constraint *a = &l->linear[i];
        ffd_rig_linear_constraint *b = &c->linear[i];
        *b = *a;
        b->index = NULL;
        b->axis = NULL;
        b->coef = NULL;
        c->linear_count = i + 1;
        b->index = dup_array(a->index, a->term_count, sizeof *a->index, &ok);
        b->axis = dup_array(a->axis, a->term_count, sizeof *a->axis, &ok);
        b->coef = dup_array(a->coef, a->term_count, sizeof *a->coef, &ok);
    }
    if (!ok) {
        ffd_rig_layers_free(c);
        return NULL;
    }
    return c;
}

/* ---- reading ---- */

static char *resolve_path(const char *name, const char *file)
{
    const char *slash = strrchr(name, '/');
    if (file[0] == '/' || !slash)
        return ffd_strdup(file);
    size_t dir = (size_t)(slash - name) + 1, n = strlen(file);
    char *out = ffd_malloc(dir + n + 1);
    if (!out)
        return NULL;
    memcpy(out, name, dir);
    memcpy(out + dir, file, n + 1);
    return out;
}

/* A weights file's text: one number per vertex, one per line, in vertex
 * order; blank lines and lines starting with '#' are skipped. */
ffd_status ffd_rig_parse_weights(const char *text, size_t size, const char *file, double **out,
                                 size_t *count, ffd_error *err)
{
    const char *s = text, *end = s + size;
    size_t cap = 0, n = 0, line = 1;
    double *w = NULL;
    ffd_status st = FFD_OK;
    *out = NULL;
    *count = 0;
    for (const char *q = s; q < end; line++) {
        const char *nl = memchr(q, '\n', (size_t)(end - q));
        const char *le = nl ? nl : end;
        const char *c = q;
        while (c < le && ffd_is_space(*c))
            c++;
        if (c < le && *c != '#') {
            double v;
            const char *at = c;
            int r = ffd_parse_number(&c, le, true, &v);
            while (c < le && ffd_is_space(*c))
                c++;
            if (r <= 0 || (c < le && *c != '#')) {
                int len = 0;
                while (at + len < le && !ffd_is_space(at[len]) && len < 20)
                    len++;
                st = ffd_fail(err, FFD_ERR_PARSE,
                              "%s:%zu: expected one weight (a number) per line, found '%.*s'", file,
                              line, len, at);
                break;
            }
            if (!isfinite(v)) {
                st = ffd_fail(err, FFD_ERR_NONFINITE, "%s:%zu: the weight is not finite (%g)",
                              file, line, v);
                break;
            }
            if (n == cap) {
                size_t nc = cap ? 2 * cap : 1024;
                double *g = ffd_realloc_array(w, nc, sizeof *g);
                if (!g) {
                    st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", file);
                    break;
                }
                w = g;
                cap = nc;
            }
            w[n++] = v;
        }
        q = nl ? nl + 1 : end;
    }
    if (st) {
        ffd_free(w);
        return st;
    }
    *out = w;
    *count = n;
    return FFD_OK;
}

static ffd_status read_weights_file(const ffd_rig_parser *p, const char *path, const char *file,
                                    ffd_rig_layers *l)
{
    unsigned char *data = NULL;
    size_t size = 0;
    ffd_error inner = {0};
    if (ffd_read_file(path, &data, &size, &inner))
        return ffd_fail(p->err, FFD_ERR_IO, "%s: weights: %s", p->name, inner.message);
    ffd_status st = ffd_rig_parse_weights((const char *)data, size, file, &l->weights,
                                          &l->weight_count, p->err);
    ffd_free(data);
    return st;
}

static ffd_status read_weights(const ffd_rig_parser *p, const cJSON *item, ffd_rig *rig,
                               ffd_rig_layers *l)
{
    static const char *const keys[] = {"attribute", "file", "values", NULL};
    static const char what[] = "{\"attribute\": NAME}, {\"file\": PATH} or {\"values\": [w, ...]}";
    ffd_status s;
    if (!cJSON_IsObject(item) || cJSON_GetArraySize(item) != 1)
        return ffd_rig_expected(p, "weights", what);
    if ((s = ffd_rig_check_keys(p, item, "weights", keys, "\"attribute\", \"file\" or \"values\"")))
        return s;
    const cJSON *v;
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "attribute"))) {
        if (!cJSON_IsString(v) || !*v->valuestring)
            return ffd_rig_expected(p, "weights.attribute", "the name of a vertex attribute");
        l->weights_kind = FFD_WEIGHTS_ATTRIBUTE;
        if (!(l->weights_name = ffd_strdup(v->valuestring)))
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        return FFD_OK;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "file"))) {
        if (!cJSON_IsString(v) || !*v->valuestring)
            return ffd_rig_expected(p, "weights.file", "a file name");
        l->weights_kind = FFD_WEIGHTS_FILE;
        if (!(l->weights_name = ffd_strdup(v->valuestring)) ||
            !(l->weights_path = resolve_path(p->name, v->valuestring)))
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        if ((s = ffd_rig_check_input(p, "weights.file", l->weights_name, l->weights_path)))
            return s;
        if ((s = read_weights_file(p, l->weights_path, l->weights_name, l)))
            return s;
        char *copy = ffd_strdup(l->weights_path);
        char **files = copy ? ffd_realloc_array(rig->input_files, rig->input_file_count + 1,
                                                sizeof *files)
                            : NULL;
        if (!files) {
            ffd_free(copy);
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        }
        rig->input_files = files;
        files[rig->input_file_count++] = copy;
        return FFD_OK;
    }
    v = cJSON_GetObjectItemCaseSensitive(item, "values");
    if (!cJSON_IsArray(v))
        return ffd_rig_expected(p, "weights.values", "an array of numbers, one per vertex");
    size_t n = (size_t)cJSON_GetArraySize(v), i = 0;
    l->weights_kind = FFD_WEIGHTS_VALUES;
    if (n && !(l->weights = ffd_malloc_array(n, sizeof *l->weights)))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    l->weight_count = n;
    const cJSON *e;
    cJSON_ArrayForEach(e, v)
    {
        char path[48];
        snprintf(path, sizeof path, "weights.values[%zu]", i);
        if ((s = ffd_rig_read_number(p, e, path, &l->weights[i])))
            return s;
        i++;
    }
    return FFD_OK;
}

static ffd_status read_preserve(const ffd_rig_parser *p, const cJSON *item, ffd_rig_layers *l)
{
    static const char *const names[] = {"volume", "barycentre", NULL};
    if (!cJSON_IsArray(item))
        return ffd_rig_expected(p, "preserve", "an array of \"volume\" and \"barycentre\"");
    const cJSON *e;
    size_t i = 0;
    cJSON_ArrayForEach(e, item)
    {
        char path[32];
        snprintf(path, sizeof path, "preserve[%zu]", i++);
        int k;
        ffd_status s = ffd_rig_read_enum(p, e, path, names, "\"volume\" or \"barycentre\"", &k);
        if (s)
            return s;
        unsigned bit = k == 0 ? FFD_PRESERVE_VOLUME : FFD_PRESERVE_BARYCENTRE;
        if (l->preserve & bit)
            return ffd_fail(p->err, FFD_ERR_PARSE, "%s: %s: \"%s\" given twice", p->name, path,
                            names[k]);
        l->preserve |= bit;
    }
    return FFD_OK;
}

/* {"over": "points"|"controls", "terms": [[index, axis, coef], ...], "value": b} */
static ffd_status read_linear(const ffd_rig_parser *p, const cJSON *item, const char *path,
                              void *element, void *ctx)
{
    (void)ctx;
    static const char *const keys[] = {"over", "terms", "value", NULL};
    static const char *const overs[] = {"points", "controls", NULL};
    ffd_rig_linear_constraint *c = element;
    char sub[RIG_PATH_MAX + 96];
    ffd_status s;
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, path,
                                "{\"over\": \"points\" or \"controls\", \"terms\": [[index, axis, "
                                "coefficient], ...], \"value\": number}");
    if ((s = ffd_rig_check_keys(p, item, path, keys, "\"over\", \"terms\" and \"value\"")))
        return s;
    const cJSON *over = cJSON_GetObjectItemCaseSensitive(item, "over");
    const cJSON *terms = cJSON_GetObjectItemCaseSensitive(item, "terms");
    const cJSON *value = cJSON_GetObjectItemCaseSensitive(item, "value");
    snprintf(sub, sizeof sub, "%s.over", path);
    if (over && (s = ffd_rig_read_enum(p, over, sub, overs, "\"points\" or \"controls\"", &c->over)))
        return s;
    snprintf(sub, sizeof sub, "%s.value", path);
    if (!value)
        return ffd_rig_expected(p, sub, "a number (the constraint's right-hand side)");
    if ((s = ffd_rig_read_number(p, value, sub, &c->value)))
        return s;
    snprintf(sub, sizeof sub, "%s.terms", path);
    if (!cJSON_IsArray(terms) || cJSON_GetArraySize(terms) < 1)
        return ffd_rig_expected(p, sub, "a non-empty array of [index, axis (0, 1 or 2), coefficient]");
    size_t n = (size_t)cJSON_GetArraySize(terms), t = 0;
    c->index = ffd_malloc_array(n, sizeof *c->index);
    c->axis = ffd_malloc_array(n, sizeof *c->axis);
    c->coef = ffd_malloc_array(n, sizeof *c->coef);
    if (!c->index || !c->axis || !c->coef)
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    c->term_count = n;
    const cJSON *e;
    cJSON_ArrayForEach(e, terms)
    {
        snprintf(sub, sizeof sub, "%s.terms[%zu]", path, t);
        uint32_t axis;
        if (!cJSON_IsArray(e) || cJSON_GetArraySize(e) != 3)
            return ffd_rig_expected(p, sub, "[index, axis (0, 1 or 2), coefficient]");
        if ((s = ffd_rig_read_index(p, cJSON_GetArrayItem(e, 0), sub, "an index", &c->index[t])) ||
            (s = ffd_rig_read_index(p, cJSON_GetArrayItem(e, 1), sub, "an axis", &axis)))
            return s;
        if (axis > 2)
            return ffd_rig_expected(p, sub, "[index, axis (0, 1 or 2), coefficient]");
        c->axis[t] = (uint8_t)axis;
        if ((s = ffd_rig_read_number(p, cJSON_GetArrayItem(e, 2), sub, &c->coef[t])))
            return s;
        t++;
    }
    return FFD_OK;
}

static void linear_release(void *element)
{
    linear_free(element);
}

static ffd_status read_mask(const ffd_rig_parser *p, const cJSON *item, ffd_rig_layers *l)
{
    static const char *const keys[] = {"axes", "controls", NULL};
    ffd_status s;
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, "constraint_mask",
                                "{\"axes\": [bool, bool, bool], \"controls\": [id, ...]}");
    if ((s = ffd_rig_check_keys(p, item, "constraint_mask", keys, "\"axes\" and \"controls\"")))
        return s;
    const cJSON *axes = cJSON_GetObjectItemCaseSensitive(item, "axes");
    if (axes) {
        if (!cJSON_IsArray(axes) || cJSON_GetArraySize(axes) != 3)
            return ffd_rig_expected(p, "constraint_mask.axes", "an array of 3 booleans");
        for (int a = 0; a < 3; a++) {
            const cJSON *b = cJSON_GetArrayItem(axes, a);
            if (!cJSON_IsBool(b))
                return ffd_rig_expected(p, "constraint_mask.axes", "an array of 3 booleans");
            l->mask_axes[a] = cJSON_IsTrue(b);
        }
    }
    const cJSON *ids = cJSON_GetObjectItemCaseSensitive(item, "controls");
    if (ids) {
        if (!cJSON_IsArray(ids) || cJSON_GetArraySize(ids) < 1)
            return ffd_rig_expected(p, "constraint_mask.controls", "a non-empty array of control ids");
        size_t n = (size_t)cJSON_GetArraySize(ids), i = 0;
        if (!(l->mask_controls = ffd_malloc_array(n, sizeof *l->mask_controls)))
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        l->mask_control_count = n;
        const cJSON *e;
        cJSON_ArrayForEach(e, ids)
        {
            char path[64];
            snprintf(path, sizeof path, "constraint_mask.controls[%zu]", i);
            if ((s = ffd_rig_read_index(p, e, path, "a control id", &l->mask_controls[i])))
                return s;
            i++;
        }
    }
    return FFD_OK;
}

ffd_status ffd_rig_read_layers(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    int any = 0;
    for (size_t i = 0; ffd_rig_layer_keys[i]; i++)
        any |= cJSON_GetObjectItemCaseSensitive(root, ffd_rig_layer_keys[i]) != NULL;
    if (!any)
        return FFD_OK;
    ffd_rig_layers *l = ffd_calloc(1, sizeof *l);
    if (!l)
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    rig->layers = l; /* released with the rig, on error too */
    l->strength = 1.0;
    l->mask_axes[0] = l->mask_axes[1] = l->mask_axes[2] = 1;
    const cJSON *item;
    ffd_status s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "strength")) &&
        (s = ffd_rig_read_number(p, item, "strength", &l->strength)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "weights")) &&
        (s = read_weights(p, item, rig, l)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "preserve")) &&
        (s = read_preserve(p, item, l)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "linear_constraints"))) {
        void *out = NULL;
        if ((s = ffd_rig_read_array(p, item, "linear_constraints", "an array of linear constraints",
                                    sizeof(ffd_rig_linear_constraint), read_linear, linear_release,
                                    NULL, &out, &l->linear_count)))
            return s;
        l->linear = out;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "constraint_mask"))) {
        if ((s = read_mask(p, item, l)))
            return s;
        if (!l->preserve && !l->linear_count)
            return ffd_fail(p->err, FFD_ERR_PARSE,
                            "%s: constraint_mask: without \"preserve\" or \"linear_constraints\" "
                            "there is nothing to constrain",
                            p->name);
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "fold_policy"))) {
        static const char *const names[] = {"allow", "refuse", "shorten", NULL};
        if ((s = ffd_rig_read_enum(p, item, "fold_policy", names,
                                   "\"allow\", \"refuse\" or \"shorten\"", &l->fold_policy)))
            return s;
    }
    return FFD_OK;
}

/* ---- writing ---- */

static cJSON *linear_json(const ffd_rig_linear_constraint *c)
{
    cJSON *o = cJSON_CreateObject(), *terms = cJSON_CreateArray();
    int ok = o && terms &&
             cJSON_AddStringToObject(o, "over", c->over == FFD_LINEAR_OVER_CONTROLS ? "controls"
                                                                                     : "points");
    for (size_t t = 0; ok && t < c->term_count; t++) {
        cJSON *e = cJSON_CreateArray();
        ok = ffd_sess_add_to_array(terms, e) &&
             ffd_sess_add_to_array(e, cJSON_CreateNumber(c->index[t])) &&
             ffd_sess_add_to_array(e, cJSON_CreateNumber(c->axis[t])) &&
             ffd_sess_add_to_array(e, ffd_sess_number(c->coef[t]));
    }
    ok = ok && ffd_sess_add_item(o, "terms", terms);
    terms = NULL;
    ok = ok && ffd_sess_add_item(o, "value", ffd_sess_number(c->value));
    cJSON_Delete(terms);
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

int ffd_rig_write_layers(const ffd_rig_layers *l, cJSON *root)
{
    if (!l)
        return 1;
    int ok = 1;
    if (l->strength != 1.0)
        ok = ffd_sess_add_item(root, "strength", ffd_sess_number(l->strength));
    if (ok && l->weights_kind != FFD_WEIGHTS_NONE) {
        cJSON *w = cJSON_CreateObject();
        ok = ffd_sess_add_item(root, "weights", w);
        if (ok && l->weights_kind == FFD_WEIGHTS_ATTRIBUTE)
            ok = cJSON_AddStringToObject(w, "attribute", l->weights_name) != NULL;
        else if (ok && l->weights_kind == FFD_WEIGHTS_FILE)
            ok = cJSON_AddStringToObject(w, "file", l->weights_name) != NULL;
        else if (ok)
            ok = ffd_sess_add_item(w, "values", ffd_sess_array(l->weights, l->weight_count));
    }
    if (ok && l->preserve) {
        cJSON *a = cJSON_CreateArray();
        ok = ffd_sess_add_item(root, "preserve", a) &&
             (!(l->preserve & FFD_PRESERVE_VOLUME) ||
              ffd_sess_add_to_array(a, cJSON_CreateString("volume"))) &&
             (!(l->preserve & FFD_PRESERVE_BARYCENTRE) ||
              ffd_sess_add_to_array(a, cJSON_CreateString("barycentre")));
    }
    if (ok && l->linear_count) {
        cJSON *a = cJSON_CreateArray();
        ok = ffd_sess_add_item(root, "linear_constraints", a);
        for (size_t i = 0; ok && i < l->linear_count; i++)
            ok = ffd_sess_add_to_array(a, linear_json(&l->linear[i]));
    }
    int masked = !l->mask_axes[0] || !l->mask_axes[1] || !l->mask_axes[2] || l->mask_controls;
    if (ok && masked) {
        cJSON *m = cJSON_CreateObject(), *axes = cJSON_CreateArray();
        ok = ffd_sess_add_item(root, "constraint_mask", m) && ffd_sess_add_item(m, "axes", axes);
        for (int a = 0; ok && a < 3; a++)
            ok = ffd_sess_add_to_array(axes, cJSON_CreateBool(l->mask_axes[a]));
        if (ok && l->mask_controls)
            ok = ffd_sess_add_item(m, "controls",
                                   ffd_sess_uint_array(l->mask_controls, l->mask_control_count));
    }
    if (ok && l->fold_policy != FFD_FOLD_ALLOW)
        ok = cJSON_AddStringToObject(root, "fold_policy",
                                     l->fold_policy == FFD_FOLD_REFUSE ? "refuse" : "shorten") != NULL;
    return ok;
}
