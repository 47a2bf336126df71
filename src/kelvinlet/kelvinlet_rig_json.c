/* kelvinlet_rig_json — "deformer": "kelvinlet" rigs (docs/kelvinlet.md): a
 * list of regularised Kelvinlet brushes (de Goes and James 2017: grab,
 * twist, scale, pinch), the material's Poisson ratio, how the brushes
 * combine, the multi-scale falloff, and the constraints of direct
 * manipulation solved over the grabs. The method's section reader and
 * writer in the registry (ffd_method_kelvinlet.parse, .write). */
#include "kelvinlet/kelvinlet_method.h"
#include "rig/rig_json.h"

#include <stdio.h>
#include <string.h>

/* Default material: nearly incompressible, like the paper's examples of
 * volume-preserving sculpting. */
#define KELVINLET_DEFAULT_NU 0.45

const char *const ffd_rig_keys_kelvinlet[] = {"brushes", "poisson_ratio", "combine", "steps",
                                              "multiscale", "ratio", NULL};

static const char *const type_text = "\"grab\", \"twist\", \"scale\" or \"pinch\"";

/* The keys each brush type has (besides "type", "center", "radius"). */
static const char *const *type_keys(ffd_kelvinlet_type t, const char **text)
{
    static const char *const grab[] = {"type", "center", "radius", "displacement", NULL};
    static const char *const twist[] = {"type", "center", "radius", "axis", "angle", NULL};
    static const char *const scale[] = {"type", "center", "radius", "factor", NULL};
    static const char *const pinch[] = {"type", "center", "radius", "pinch", NULL};
    switch (t) {
    case FFD_KELVINLET_TWIST:
        *text = "\"type\", \"center\", \"radius\", \"axis\", \"angle\"";
        return twist;
    case FFD_KELVINLET_SCALE:
        *text = "\"type\", \"center\", \"radius\", \"factor\"";
        return scale;
    case FFD_KELVINLET_PINCH:
        *text = "\"type\", \"center\", \"radius\", \"pinch\"";
        return pinch;
    default:
        *text = "\"type\", \"center\", \"radius\", \"displacement\"";
        return grab;
    }
}

static ffd_status read_matrix3(const ffd_rig_parser *p, const cJSON *item, const char *path,
                               double m[3][3])
{
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != 3)
        return ffd_rig_expected(p, path, "3 rows, each an array of 3 finite numbers");
    char sub[RIG_PATH_MAX + 64];
    int i = 0;
    const cJSON *row;
    cJSON_ArrayForEach(row, item)
    {
        snprintf(sub, sizeof sub, "%s[%d]", path, i);
        ffd_status s = ffd_rig_read_vec3(p, row, sub, m[i]);
        if (s)
            return s;
        i++;
    }
    return FFD_OK;
}

ffd_status ffd_rig_read_kelvinlet_brush(const ffd_rig_parser *p, const cJSON *item,
                                        const char *path, void *element, void *ctx)
{
    ffd_kelvinlet_brush *br = element;
    char sub[RIG_PATH_MAX + 32];
    (void)ctx;
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, path, "an object {\"type\": ..., \"center\": [x,y,z], "
                                         "\"radius\": r, ...}");
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(item, "type");
    snprintf(sub, sizeof sub, "%s.type", path);
    if (!v)
        return ffd_rig_expected(p, sub, "one of \"grab\", \"twist\", \"scale\", \"pinch\" (missing)");
    int t = 0;
    ffd_status s = ffd_rig_read_enum(p, v, sub, ffd_kelvinlet_type_names, type_text, &t);
    if (s)
        return s;
    br->type = (ffd_kelvinlet_type)t;
    ffd_kelvinlet_brush_make_inert(br);
    const char *allowed_text;
    const char *const *allowed = type_keys(br->type, &allowed_text);
    if ((s = ffd_rig_check_keys(p, item, path, allowed, allowed_text)))
        return s;
    snprintf(sub, sizeof sub, "%s.center", path);
    if (!(v = cJSON_GetObjectItemCaseSensitive(item, "center")))
        return ffd_rig_expected(p, sub, "an array of 3 finite numbers (missing)");
    if ((s = ffd_rig_read_vec3(p, v, sub, br->center)))
        return s;
    snprintf(sub, sizeof sub, "%s.radius", path);
    if (!(v = cJSON_GetObjectItemCaseSensitive(item, "radius")))
        return ffd_rig_expected(p, sub, "a number > 0 (missing)");
    if ((s = ffd_rig_read_positive(p, v, sub, &br->radius)))
        return s;
    switch (br->type) {
    case FFD_KELVINLET_GRAB:
        snprintf(sub, sizeof sub, "%s.displacement", path);
        if ((v = cJSON_GetObjectItemCaseSensitive(item, "displacement")))
            s = ffd_rig_read_vec3(p, v, sub, br->displacement);
        break;
    case FFD_KELVINLET_TWIST:
        snprintf(sub, sizeof sub, "%s.axis", path);
        if (!(v = cJSON_GetObjectItemCaseSensitive(item, "axis")))
            return ffd_rig_expected(p, sub, "an array of 3 finite numbers, not all 0 (missing)");
        if ((s = ffd_rig_read_vec3(p, v, sub, br->axis)))
            return s;
        snprintf(sub, sizeof sub, "%s.angle", path);
        if ((v = cJSON_GetObjectItemCaseSensitive(item, "angle")))
            s = ffd_rig_read_number(p, v, sub, &br->angle);
        break;
    case FFD_KELVINLET_SCALE:
        snprintf(sub, sizeof sub, "%s.factor", path);
        if ((v = cJSON_GetObjectItemCaseSensitive(item, "factor")))
            s = ffd_rig_read_positive(p, v, sub, &br->factor);
        break;
    case FFD_KELVINLET_PINCH:
        snprintf(sub, sizeof sub, "%s.pinch", path);
        if ((v = cJSON_GetObjectItemCaseSensitive(item, "pinch")))
            s = read_matrix3(p, v, sub, br->pinch);
        break;
    }
    return s;
}

ffd_status ffd_rig_parse_kelvinlet(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    ffd_rig_kelvinlet *kr = ffd_rig_kelvinlet_of(rig);
    const cJSON *item;
    ffd_status s = ffd_rig_read_linear_root(p, root, rig);
    if (s)
        return s;
    if (rig->limit_step)
        return ffd_fail(p->err, FFD_ERR_PARSE,
                        "%s: limit_step: only for \"deformer\": \"lattice\" rigs (this rig's "
                        "deformer is \"kelvinlet\")",
                        p->name);
    kr->options.poisson_ratio = KELVINLET_DEFAULT_NU;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "poisson_ratio")) &&
        (s = ffd_rig_read_number(p, item, "poisson_ratio", &kr->options.poisson_ratio)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "combine"))) {
        int c = 0;
        if ((s = ffd_rig_read_enum(p, item, "combine", ffd_kelvinlet_combine_names,
                                   "\"superpose\" or \"sequence\"", &c)))
            return s;
        kr->options.combine = (ffd_kelvinlet_combine)c;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "multiscale"))) {
        int m = 0;
        if ((s = ffd_rig_read_enum(p, item, "multiscale", ffd_kelvinlet_multiscale_names,
                                   "\"single\", \"biscale\" or \"triscale\"", &m)))
            return s;
        kr->options.multiscale = (ffd_kelvinlet_multiscale)m;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "steps"))) {
        uint32_t n;
        if ((s = ffd_rig_read_index(p, item, "steps", "an integer >= 1", &n)))
            return s;
        if (n == 0)
            return ffd_rig_expected(p, "steps", "an integer >= 1");
        kr->options.steps = n;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "ratio")) &&
        (s = ffd_rig_read_number(p, item, "ratio", &kr->options.ratio)))
        return s;
    ffd_error inner = {{0}};
    if ((s = ffd_kelvinlet_check_options(&kr->options, p->name, &inner)))
        return ffd_fail(p->err, s, "%s", inner.message);
    if (!(item = cJSON_GetObjectItemCaseSensitive(root, "brushes")))
        return ffd_rig_expected(p, "brushes", "an array of brushes (missing)");
    void *brushes = NULL;
    s = ffd_rig_read_array(p, item, "brushes", "an array of brush objects", sizeof *kr->brushes,
                           ffd_rig_read_kelvinlet_brush, NULL, NULL, &brushes, &kr->brush_count);
    kr->brushes = brushes;
    if (s)
        return s;
    for (size_t i = 0; i < kr->brush_count; i++) {
        char where[RIG_PATH_MAX + 64];
        snprintf(where, sizeof where, "%s: brushes[%zu]", p->name, i);
        if ((s = ffd_kelvinlet_check_brush(&kr->brushes[i], kr->options.poisson_ratio, where,
                                           p->err)))
            return s;
    }
    return FFD_OK;
}

/* The writer (ffd_method.write): what the reader above reads back. */
int ffd_rig_write_kelvinlet(const ffd_rig *rig, cJSON *root)
{
    const ffd_rig_kelvinlet *kr = ffd_rig_kelvinlet_of(rig);
    const ffd_kelvinlet_options *o = &kr->options;
    cJSON *brushes = NULL;
    int ok = ffd_sess_add_item(root, "poisson_ratio", ffd_sess_number(o->poisson_ratio)) &&
             cJSON_AddStringToObject(root, "combine", ffd_kelvinlet_combine_names[o->combine]) &&
             cJSON_AddStringToObject(root, "multiscale",
                                     ffd_kelvinlet_multiscale_names[o->multiscale]) &&
             (brushes = cJSON_AddArrayToObject(root, "brushes"));
    if (ok && o->steps > 1)
        ok = cJSON_AddNumberToObject(root, "steps", o->steps) != NULL;
    if (ok && o->ratio != 0)
        ok = ffd_sess_add_item(root, "ratio", ffd_sess_number(o->ratio));
    for (size_t i = 0; ok && i < kr->brush_count; i++) {
        const ffd_kelvinlet_brush *br = &kr->brushes[i];
        cJSON *b = cJSON_CreateObject();
        ok = ffd_sess_add_to_array(brushes, b) &&
             cJSON_AddStringToObject(b, "type", ffd_kelvinlet_type_names[br->type]) &&
             ffd_sess_add_item(b, "center", ffd_sess_vec3(br->center)) &&
             ffd_sess_add_item(b, "radius", ffd_sess_number(br->radius));
        switch (br->type) {
        case FFD_KELVINLET_GRAB:
            ok = ok && ffd_sess_add_item(b, "displacement", ffd_sess_vec3(br->displacement));
            break;
        case FFD_KELVINLET_TWIST:
            ok = ok && ffd_sess_add_item(b, "axis", ffd_sess_vec3(br->axis)) &&
                 ffd_sess_add_item(b, "angle", ffd_sess_number(br->angle));
            break;
        case FFD_KELVINLET_SCALE:
            ok = ok && ffd_sess_add_item(b, "factor", ffd_sess_number(br->factor));
            break;
        case FFD_KELVINLET_PINCH:
            ok = ok && ffd_sess_add_item(b, "pinch",
                                         ffd_sess_matrix3((const double(*)[3])br->pinch));
            break;
        }
    }
    return ok;
}

void ffd_rig_release_kelvinlet(ffd_rig *rig)
{
    ffd_free(ffd_rig_kelvinlet_of(rig)->brushes);
}
