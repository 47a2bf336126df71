/* rig — the rig JSON format: the syntax checks, the value readers every
 * method's section reader shares (rig_json.h), and the root, which hands the
 * rig to the section reader of the method its "deformer" names (the method
 * registry, deformer/method.h: each method's src/<method>/<method>_rig_json.c);
 * the writer of the shared keys; also the dispatch of .prm files.
 *
 * With the rig_json_<method>.c files, the only files that read cJSON
 * (rig_json.h). Every rejected value is reported with the file name and the
 * JSON path of the offending key ("rig.json: moves[1].delta: expected an
 * array of 3 finite numbers"); syntax errors with line and column.
 * docs/rig.md describes the format. */
#define _XOPEN_SOURCE 700 /* realpath */
#include "rig/rig_json.h"

#include "deformer/method.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

/* Rig files are small; these bounds turn hostile input into a clear error. */
#define RIG_MAX_BYTES ((size_t)64 << 20)
#define RIG_MAX_DEPTH 64

ffd_rig *ffd_rig_new(const char *name)
{
    ffd_rig *rig = ffd_calloc(1, sizeof *rig);
    if (!rig)
        return NULL;
    rig->name = ffd_strdup(name ? name : "rig");
    if (!rig->name) {
        ffd_free(rig);
        return NULL;
    }
    rig->basis = FFD_BASIS_BSPLINE;
    rig->resolution[0] = rig->resolution[1] = rig->resolution[2] = 5;
    rig->box_auto = 1;
    rig->margin = 0.05;
    rig->outside = FFD_OUTSIDE_FIXED;
    rig->method = ffd_method_default();
    return rig;
}

void ffd_rig_destroy(ffd_rig *rig)
{
    if (!rig)
        return;
    ffd_free(rig->name);
    ffd_free(rig->constraints);
    ffd_free(rig->pins);
    ffd_rig_layers_free(rig->layers);
    if (rig->method && rig->method->release)
        rig->method->release(rig);
    ffd_free(rig->section);
    for (size_t i = 0; i < rig->input_file_count; i++)
        ffd_free(rig->input_files[i]);
    ffd_free(rig->input_files);
    ffd_free(rig);
}

size_t ffd_rig_input_count(const ffd_rig *rig)
{
    return rig ? rig->input_file_count : 0;
}

const char *ffd_rig_input_path(const ffd_rig *rig, size_t i)
{
    return rig && i < rig->input_file_count ? rig->input_files[i] : NULL;
}

/* ======================================================================
 * Syntax: positions, nesting depth, cJSON
 * ====================================================================== */

/* Offset of the first bracket nested deeper than RIG_MAX_DEPTH, or size when none.
 * Checked before cJSON so that its recursion never sees hostile depths. */
static size_t too_deep_at(const char *text, size_t size)
{
    size_t depth = 0;
    int in_string = 0;
    for (size_t i = 0; i < size; i++) {
        char ch = text[i];
        if (in_string) {
            if (ch == '\\')
                i++;
            else if (ch == '"')
                in_string = 0;
        } else if (ch == '"') {
            in_string = 1;
        } else if (ch == '[' || ch == '{') {
            if (++depth > RIG_MAX_DEPTH)
                return i;
        } else if ((ch == ']' || ch == '}') && depth > 0) {
            depth--;
        }
    }
    return size;
}

static ffd_status syntax_error(const char *name, const char *text, size_t size, size_t offset,
                               const char *what, ffd_error *err)
{
    size_t line, col;
    if (offset > size)
        offset = size;
    ffd_text_line_col(text, offset, &line, &col);
    if (offset >= size)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu:%zu: invalid JSON: %s at end of file", name,
                        line, col, what);
    char near[24];
    size_t n = 0;
    for (size_t i = offset; i < size && n + 1 < sizeof near && text[i] != '\n'; i++)
        near[n++] = isprint((unsigned char)text[i]) ? text[i] : '?';
    near[n] = 0;
    if (n == 0)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu:%zu: invalid JSON: %s at the end of the line", name,
                        line, col, what);
    return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu:%zu: invalid JSON: %s near '%s'", name, line,
                    col, what, near);
}

/* ======================================================================
 * Values: each helper names the JSON path of what it rejects
 * ====================================================================== */


ffd_status ffd_rig_expected(const ffd_rig_parser *p, const char *path, const char *what)
{
    return ffd_fail(p->err, FFD_ERR_PARSE, "%s: %s: expected %s", p->name, path, what);
}

ffd_status ffd_rig_read_number(const ffd_rig_parser *p, const cJSON *item, const char *path, double *out)
{
    if (!cJSON_IsNumber(item))
        return ffd_rig_expected(p, path, "a number");
    if (!isfinite(item->valuedouble))
        return ffd_fail(p->err, FFD_ERR_NONFINITE, "%s: %s: expected a finite number, got %g",
                        p->name, path, item->valuedouble);
    *out = item->valuedouble;
    return FFD_OK;
}

/* An array of exactly 3 finite numbers. */
ffd_status ffd_rig_read_vec3(const ffd_rig_parser *p, const cJSON *item, const char *path, double out[3])
{
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != 3)
        return ffd_rig_expected(p, path, "an array of 3 finite numbers");
    int i = 0;
    const cJSON *v;
    cJSON_ArrayForEach(v, item)
    {
        if (!cJSON_IsNumber(v))
            return ffd_rig_expected(p, path, "an array of 3 finite numbers");
        if (!isfinite(v->valuedouble))
            return ffd_fail(p->err, FFD_ERR_NONFINITE,
                            "%s: %s[%d]: expected a finite number, got %g", p->name, path, i,
                            v->valuedouble);
        out[i++] = v->valuedouble;
    }
    return FFD_OK;
}

int ffd_rig_is_uint32(const cJSON *item)
{
    return cJSON_IsNumber(item) && item->valuedouble >= 0 && item->valuedouble <= 4294967295.0 &&
           floor(item->valuedouble) == item->valuedouble;
}

/* An array of exactly 3 non-negative integers. */
ffd_status ffd_rig_read_uint3(const ffd_rig_parser *p, const cJSON *item, const char *path, uint32_t out[3])
{
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != 3)
        return ffd_rig_expected(p, path, "an array of 3 non-negative integers");
    int i = 0;
    const cJSON *v;
    cJSON_ArrayForEach(v, item)
    {
        if (!ffd_rig_is_uint32(v))
            return ffd_rig_expected(p, path, "an array of 3 non-negative integers");
        out[i++] = (uint32_t)v->valuedouble;
    }
    return FFD_OK;
}

/* Index of s in the NULL-terminated list, or -1. */
int ffd_rig_lookup(const char *s, const char *const *names)
{
    for (int i = 0; names[i]; i++)
        if (strcmp(s, names[i]) == 0)
            return i;
    return -1;
}

/* One of a fixed set of strings; what describes the set for the message. */
ffd_status ffd_rig_read_enum(const ffd_rig_parser *p, const cJSON *item, const char *path,
                            const char *const *names, const char *what, int *out)
{
    int v = cJSON_IsString(item) ? ffd_rig_lookup(item->valuestring, names) : -1;
    if (v < 0)
        return ffd_rig_expected(p, path, what);
    *out = v;
    return FFD_OK;
}

/* Rejects keys outside allowed (NULL-terminated) and keys given twice. */
ffd_status ffd_rig_check_keys(const ffd_rig_parser *p, const cJSON *object, const char *path,
                             const char *const *allowed, const char *allowed_text)
{
    const cJSON *a;
    cJSON_ArrayForEach(a, object)
    {
        char where[RIG_PATH_MAX + 80];
        if (ffd_rig_lookup(a->string, allowed) < 0) {
            snprintf(where, sizeof where, "%s%s%.64s", path, *path ? "." : "", a->string);
            return ffd_fail(p->err, FFD_ERR_PARSE, "%s: %s: unknown key, expected one of %s",
                            p->name, where, allowed_text);
        }
        for (const cJSON *b = object->child; b != a; b = b->next) {
            if (strcmp(a->string, b->string) == 0) {
                snprintf(where, sizeof where, "%s%s%.64s", path, *path ? "." : "", a->string);
                return ffd_fail(p->err, FFD_ERR_PARSE, "%s: %s: key given twice", p->name, where);
            }
        }
    }
    return FFD_OK;
}

/* "version", if given, is 1. */
ffd_status ffd_rig_read_version(const ffd_rig_parser *p, const cJSON *root)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(root, "version");
    if (item && (!cJSON_IsNumber(item) || item->valuedouble != 1.0))
        return ffd_rig_expected(p, "version", "1 (the only rig version)");
    return FFD_OK;
}

/* The method that has key among its rig keys, other than own (registry
 * order), or NULL. */
static const ffd_method *key_owner(const char *key, const ffd_method *own)
{
    for (size_t i = 0; i < ffd_method_count(); i++) {
        const ffd_method *m = ffd_method_at(i);
        if (m != own && ffd_rig_lookup(key, m->rig_keys) >= 0)
            return m;
    }
    return NULL;
}

/* '"a", "b", "c"': the keys of a NULL-terminated list, for messages. */
static void keys_text(const char *const *keys, char *buf, size_t size)
{
    size_t used = 0;
    buf[0] = 0;
    for (size_t i = 0; keys && keys[i] && used < size; i++) {
        int w = snprintf(buf + used, size - used, "%s\"%s\"", i ? ", " : "", keys[i]);
        used += w > 0 ? (size_t)w : 0;
    }
}

/* The top-level keys of a rig of one method: each "version", "deformer" or
 * one of the method's rig keys (else "not a key of "deformer": "NAME" rigs,
 * expected one of ..."), none twice; and the version. */
ffd_status ffd_rig_check_deformer_root(const ffd_rig_parser *p, const cJSON *root,
                                       const ffd_method *method)
{
    static const char *const common[] = {"version", "deformer", NULL};
    char text[1024];
    keys_text(method->rig_keys, text, sizeof text);
    const cJSON *item;
    cJSON_ArrayForEach(item, root)
    {
        if (ffd_rig_lookup(item->string, common) < 0 &&
            ffd_rig_lookup(item->string, method->rig_keys) < 0)
            return ffd_fail(p->err, FFD_ERR_PARSE,
                            "%s: %.64s: not a key of \"deformer\": \"%s\" rigs, expected one of %s",
                            p->name, item->string, method->name, text);
    }
    /* every key is allowed: only the duplicates remain */
    cJSON_ArrayForEach(item, root)
    {
        for (const cJSON *b = root->child; b != item; b = b->next)
            if (strcmp(item->string, b->string) == 0)
                return ffd_fail(p->err, FFD_ERR_PARSE, "%s: %.64s: key given twice", p->name,
                                item->string);
    }
    return ffd_rig_read_version(p, root);
}

/* {"axis": [x,y,z], "angle": radians} and, when center is not NULL, an
 * optional "center": [x,y,z] (*has_center says whether it was given). */
ffd_status ffd_rig_read_rotation(const ffd_rig_parser *p, const cJSON *item, const char *path,
                             double axis[3], double *angle, double center[3], int *has_center)
{
    static const char *const keys[] = {"axis", "angle", "center", NULL};
    static const char *const keys_no_center[] = {"axis", "angle", NULL};
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, path, center ? "an object {\"axis\": [x,y,z], \"angle\": radians, "
                                              "\"center\": [x,y,z] (optional)}"
                                            : "an object {\"axis\": [x,y,z], \"angle\": radians}");
    ffd_status s = ffd_rig_check_keys(p, item, path, center ? keys : keys_no_center,
                                  center ? "\"axis\", \"angle\", \"center\"" : "\"axis\", \"angle\"");
    if (s)
        return s;
    char leaf[RIG_PATH_MAX + 64];
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(item, "axis");
    snprintf(leaf, sizeof leaf, "%.100s.axis", path);
    if (!v)
        return ffd_rig_expected(p, leaf, "an array of 3 finite numbers (missing)");
    if ((s = ffd_rig_read_vec3(p, v, leaf, axis)))
        return s;
    if (axis[0] == 0 && axis[1] == 0 && axis[2] == 0)
        return ffd_fail(p->err, FFD_ERR_INVALID, "%s: %s: the zero vector is no axis", p->name,
                        leaf);
    v = cJSON_GetObjectItemCaseSensitive(item, "angle");
    snprintf(leaf, sizeof leaf, "%.100s.angle", path);
    if (!v)
        return ffd_rig_expected(p, leaf, "an angle in radians (missing)");
    if ((s = ffd_rig_read_number(p, v, leaf, angle)))
        return s;
    if (center && (v = cJSON_GetObjectItemCaseSensitive(item, "center"))) {
        snprintf(leaf, sizeof leaf, "%.100s.center", path);
        *has_center = 1;
        return ffd_rig_read_vec3(p, v, leaf, center);
    }
    return FFD_OK;
}

static const char constraints_what[] = "an array of {\"vertex\": id, \"target\": [x,y,z]} or "
                                       "{\"point\": [x,y,z], \"target\": [x,y,z]}";

static ffd_status read_constraint(const ffd_rig_parser *p, const cJSON *c, const char *path,
                                  void *element, void *ctx)
{
    static const char *const keys[] = {"vertex", "point", "target", NULL};
    ffd_rig_constraint *con = element;
    char sub[RIG_PATH_MAX + 80];
    (void)ctx;
    if (!cJSON_IsObject(c))
        return ffd_rig_expected(p, path,
                                "an object {\"vertex\": id, \"target\": [x,y,z]} or "
                                "{\"point\": [x,y,z], \"target\": [x,y,z]}");
    ffd_status s = ffd_rig_check_keys(p, c, path, keys, "\"vertex\", \"point\", \"target\"");
    if (s)
        return s;
    const cJSON *vertex = cJSON_GetObjectItemCaseSensitive(c, "vertex");
    const cJSON *point = cJSON_GetObjectItemCaseSensitive(c, "point");
    const cJSON *target = cJSON_GetObjectItemCaseSensitive(c, "target");
    if ((vertex != NULL) == (point != NULL))
        return ffd_rig_expected(p, path, vertex ? "either \"vertex\" or \"point\", not both"
                                                : "a \"vertex\" or a \"point\" key");
    if (vertex) {
        snprintf(sub, sizeof sub, "%s.vertex", path);
        if (!ffd_rig_is_uint32(vertex))
            return ffd_rig_expected(p, sub, "a vertex id (a non-negative integer)");
        con->kind = FFD_RIG_CONSTRAINT_VERTEX;
        con->vertex = (uint32_t)vertex->valuedouble;
    } else {
        snprintf(sub, sizeof sub, "%s.point", path);
        con->kind = FFD_RIG_CONSTRAINT_POINT;
        if ((s = ffd_rig_read_vec3(p, point, sub, con->point)))
            return s;
    }
    snprintf(sub, sizeof sub, "%s.target", path);
    if (!target)
        return ffd_rig_expected(p, sub, "an array of 3 finite numbers (missing)");
    return ffd_rig_read_vec3(p, target, sub, con->target);
}

ffd_status ffd_rig_read_constraints(const ffd_rig_parser *p, const cJSON *item, const char *where,
                                    ffd_rig_constraint **out, size_t *count)
{
    void *constraints;
    ffd_status s = ffd_rig_read_array(p, item, where, constraints_what, sizeof **out,
                                      read_constraint, NULL, NULL, &constraints, count);
    *out = constraints;
    return s;
}

static ffd_status read_point(const ffd_rig_parser *p, const cJSON *item, const char *path,
                             void *element, void *ctx)
{
    (void)ctx;
    return ffd_rig_read_vec3(p, item, path, element);
}

ffd_status ffd_rig_read_point_move(const ffd_rig_parser *p, const cJSON *m, const char *path,
                                   void *element, void *ctx)
{
    static const char *const keys[] = {"index", "delta", NULL};
    ffd_rig_point_move *move = element;
    const char *what = ctx;
    char sub[RIG_PATH_MAX + 80], expected[96];
    if (!cJSON_IsObject(m))
        return ffd_rig_expected(p, path, "an object {\"index\": i, \"delta\": [dx,dy,dz]}");
    ffd_status s = ffd_rig_check_keys(p, m, path, keys, "\"index\", \"delta\"");
    if (s)
        return s;
    const cJSON *index = cJSON_GetObjectItemCaseSensitive(m, "index");
    const cJSON *delta = cJSON_GetObjectItemCaseSensitive(m, "delta");
    snprintf(sub, sizeof sub, "%s.index", path);
    if (!index) {
        snprintf(expected, sizeof expected, "%s (missing)", what);
        return ffd_rig_expected(p, sub, expected);
    }
    snprintf(expected, sizeof expected, "%s (an integer >= 0)", what);
    if ((s = ffd_rig_read_index(p, index, sub, expected, &move->index)))
        return s;
    snprintf(sub, sizeof sub, "%s.delta", path);
    if (!delta)
        return ffd_rig_expected(p, sub, "an array of 3 finite numbers (missing)");
    return ffd_rig_read_vec3(p, delta, sub, move->delta);
}

ffd_status ffd_rig_read_points(const ffd_rig_parser *p, const cJSON *item, const char *path,
                               size_t min, double **out, size_t *count)
{
    char what[64];
    snprintf(what, sizeof what, "an array of at least %zu points [x,y,z]", min);
    if (!cJSON_IsArray(item) || (size_t)cJSON_GetArraySize(item) < min)
        return ffd_rig_expected(p, path, what);
    void *points;
    ffd_status s = ffd_rig_read_array(p, item, path, what, 3 * sizeof(double), read_point, NULL,
                                      NULL, &points, count);
    *out = points;
    return s;
}

/* A non-negative integer that fits uint32_t. */
ffd_status ffd_rig_read_index(const ffd_rig_parser *p, const cJSON *item, const char *path,
                             const char *what, uint32_t *out)
{
    if (!ffd_rig_is_uint32(item))
        return ffd_rig_expected(p, path, what);
    *out = (uint32_t)item->valuedouble;
    return FFD_OK;
}

ffd_status ffd_rig_read_positive(const ffd_rig_parser *p, const cJSON *item, const char *path, double *out)
{
    ffd_status s = ffd_rig_read_number(p, item, path, out);
    if (!s && !(*out > 0))
        return ffd_fail(p->err, FFD_ERR_INVALID, "%s: %s: %g: expected a number > 0", p->name,
                        path, *out);
    return s;
}
/* ======================================================================
 * Arrays: "read an array of X"
 * ====================================================================== */

ffd_status ffd_rig_read_array(const ffd_rig_parser *p, const cJSON *item, const char *key,
                              const char *what, size_t size, ffd_rig_element_reader read,
                              ffd_rig_element_free release, void *ctx, void **out, size_t *count)
{
    *out = NULL;
    *count = 0;
    if (!cJSON_IsArray(item))
        return ffd_rig_expected(p, key, what);
    size_t n = (size_t)cJSON_GetArraySize(item);
    if (n == 0)
        return FFD_OK;
    char *elements = ffd_calloc(n, size);
    if (!elements)
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: %s: out of memory for %zu elements", p->name,
                        key, n);
    size_t i = 0;
    const cJSON *element;
    cJSON_ArrayForEach(element, item)
    {
        char path[RIG_PATH_MAX + 64];
        snprintf(path, sizeof path, "%.100s[%zu]", key, i);
        ffd_status s = read(p, element, path, elements + i * size, ctx);
        if (s) {
            /* every element is zeroed or (partly) read: each can be released */
            for (size_t j = 0; release && j < n; j++)
                release(elements + j * size);
            ffd_free(elements);
            return s;
        }
        i++;
    }
    *out = elements;
    *count = n;
    return FFD_OK;
}

/* ======================================================================
 * Root: the method the rig's "deformer" names reads the rest
 * ====================================================================== */

ffd_status ffd_rig_read_linear_root(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    static const char *const common[] = {"version", "deformer", "rcond", "constraints",
                                         "limit_step", NULL};
    const ffd_method *own = rig->method;
    const cJSON *item;
    ffd_status s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "deformer"))) {
        /* a "deformer" the registry knows went to its method (read_root):
         * this names what else is wrong with it */
        char names[256];
        if (!cJSON_IsString(item) || !ffd_method_find(item->valuestring))
            return ffd_rig_expected(p, "deformer", ffd_method_names(names, sizeof names));
    }
    /* a key of another method: named as such */
    cJSON_ArrayForEach(item, root)
    {
        const ffd_method *other;
        if (ffd_rig_lookup(item->string, common) < 0 &&
            ffd_rig_lookup(item->string, own->rig_keys) < 0 &&
            (other = key_owner(item->string, own)))
            return ffd_fail(p->err, FFD_ERR_PARSE,
                            "%s: %.64s: only for \"deformer\": \"%s\" rigs (this rig's deformer "
                            "is \"%s\")",
                            p->name, item->string, other->name, own->name);
    }
    size_t n_own = 0;
    while (own->rig_keys && own->rig_keys[n_own])
        n_own++;
    const char *keys[32 + 5];
    if (n_own > 32)
        return ffd_fail(p->err, FFD_ERR_INVALID, "%s: the %s method has more than 32 rig keys",
                        p->name, own->name);
    size_t n = 0;
    for (size_t i = 0; common[i]; i++)
        keys[n++] = common[i];
    for (size_t i = 0; i < n_own; i++)
        keys[n++] = own->rig_keys[i];
    keys[n] = NULL;
    char text[1024];
    keys_text(keys, text, sizeof text);
    if ((s = ffd_rig_check_keys(p, root, "", keys, text)) || (s = ffd_rig_read_version(p, root)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "rcond"))) {
        if ((s = ffd_rig_read_number(p, item, "rcond", &rig->rcond)))
            return s;
        if (rig->rcond < 0 || rig->rcond >= 1)
            return ffd_rig_expected(p, "rcond", "a number in [0, 1) (0: the solver's default)");
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "limit_step"))) {
        if (!cJSON_IsBool(item))
            return ffd_rig_expected(p, "limit_step", "true or false");
        rig->limit_step = cJSON_IsTrue(item);
        if (rig->limit_step && strcmp(own->name, "lattice") != 0)
            return ffd_fail(p->err, FFD_ERR_UNSUPPORTED,
                            "%s: limit_step: only \"deformer\": \"lattice\" rigs limit the step "
                            "so far (this rig's deformer is \"%s\")",
                            p->name, own->name);
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "constraints"))) {
        if ((s = ffd_rig_read_constraints(p, item, "constraints", &rig->constraints, &rig->constraint_count)))
            return s;
    }
    return FFD_OK;
}

/* The method named by "deformer" reads the rig (ffd_method.parse); with no
 * "deformer", or one no method has, the registry's default method's reader,
 * which reads the rig as its own or names what is wrong. */
static ffd_status read_root(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    if (!cJSON_IsObject(root))
        return ffd_fail(p->err, FFD_ERR_PARSE, "%s: expected a JSON object at the top level",
                        p->name);
    const cJSON *which = cJSON_GetObjectItemCaseSensitive(root, "deformer");
    const ffd_method *method = cJSON_IsString(which) ? ffd_method_find(which->valuestring) : NULL;
    if (!method)
        method = ffd_method_default();
    rig->method = method;
    if (method->section_size && !(rig->section = ffd_calloc(1, method->section_size)))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    /* the generic layers (rig_layers.c) are read here, for every method, and
     * the method's reader reads the rest */
    ffd_status s = ffd_rig_read_layers(p, root, rig);
    int pins = cJSON_GetObjectItemCaseSensitive(root, "pins") != NULL;
    if (!s && pins)
        s = ffd_rig_read_pins(p, cJSON_GetObjectItemCaseSensitive(root, "pins"), rig);
    if (s || (!rig->layers && !pins))
        return s ? s : method->parse(p, root, rig);
    unsigned long oom = ffd_json_alloc_failures();
    cJSON *rest = cJSON_Duplicate(root, 1);
    for (size_t i = 0; rest && ffd_rig_layer_keys[i]; i++)
        cJSON_DeleteItemFromObjectCaseSensitive(rest, ffd_rig_layer_keys[i]);
    if (rest)
        cJSON_DeleteItemFromObjectCaseSensitive(rest, "pins");
    s = rest && ffd_json_alloc_failures() == oom
            ? method->parse(p, rest, rig)
            : ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    cJSON_Delete(rest);
    return s;
}


ffd_status ffd_rig_check_input(const ffd_rig_parser *p, const char *key, const char *file,
                               const char *path)
{
    if (!p->files)
        return FFD_OK;
    if (!p->files->root)
        return ffd_fail(p->err, FFD_ERR_INVALID,
                        "%s: %s: refers to the file \"%s\": an uploaded rig cannot read "
                        "files (load it from the server's directory instead)",
                        p->name, key, file);
    /* a file that does not resolve is reported by its reader */
    char *real = realpath(path, NULL);
    char *real_root = realpath(p->files->root, NULL);
    size_t rl = real_root ? strlen(real_root) : 0;
    ffd_status s = FFD_OK;
    if (real && real_root &&
        !(strncmp(real, real_root, rl) == 0 && (real[rl] == '/' || real[rl] == 0)))
        s = ffd_fail(p->err, FFD_ERR_INVALID,
                     "%s: %s: the file \"%s\" is outside the server's directory", p->name, key,
                     file);
    free(real);
    free(real_root);
    return s;
}

ffd_status ffd_rig_parse_json(const char *text, size_t size, const char *name, ffd_rig **out,
                              ffd_error *err)
{
    return ffd_rig_parse_json_files(text, size, name, NULL, out, err);
}

ffd_status ffd_rig_parse_json_files(const char *text, size_t size, const char *name,
                                    const ffd_rig_files *files, ffd_rig **out, ffd_error *err)
{
    *out = NULL;
    name = ffd_name_or(name, "rig");
    if (!text && size)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: no text", name);
    if (size > RIG_MAX_BYTES)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: %zu bytes, rig files are limited to 64 MiB",
                        name, size);
    /* RFC 8259 §8.1 lets a parser ignore a UTF-8 byte order mark, and editors
     * on Windows write one; offsets in messages stay those of the file. */
    size_t bom = ffd_utf8_bom_length(text, size);
    size_t start = bom;
    while (start < size && isspace((unsigned char)text[start]))
        start++;
    if (start == size)
        return ffd_fail(err, FFD_ERR_PARSE, "%s: empty file, expected a JSON object", name);
    /* JSON allows no control character but tab, line feed and carriage return
     * (cJSON would skip a NUL or a form feed as whitespace). */
    for (size_t i = 0; i < size; i++) {
        unsigned char ch = (unsigned char)text[i];
        if (ch < 0x20 && ch != '\t' && ch != '\n' && ch != '\r') {
            char what[96];
            snprintf(what, sizeof what, "control character 0x%02x (binary data? write it as \\u%04x inside a string)",
                     ch, ch);
            return syntax_error(name, text, size, i, what, err);
        }
    }
    size_t deep = too_deep_at(text, size);
    if (deep < size)
        return syntax_error(name, text, size, deep, "nested deeper than 64 levels", err);
    ffd_status nul = ffd_json_refuse_nul(text, size, name, err);
    if (nul)
        return nul;

    const char *end = NULL;
    unsigned long oom = ffd_json_alloc_failures();
    cJSON *root = cJSON_ParseWithLengthOpts(text + bom, size - bom, &end, 0);
    if (!root && ffd_json_alloc_failures() != oom)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory parsing JSON", name);
    if (!root) {
        size_t at = end && end >= text ? (size_t)(end - text) : 0;
        return syntax_error(name, text, size, at, "syntax error", err);
    }
    size_t rest = (size_t)(end - text);
    while (rest < size && isspace((unsigned char)text[rest]))
        rest++;
    if (rest < size) {
        cJSON_Delete(root);
        return syntax_error(name, text, size, rest, "unexpected text after the JSON value", err);
    }

    ffd_status s = ffd_rig_parse_tree(root, name, files, out, err);
    cJSON_Delete(root);
    return s;
}

ffd_status ffd_rig_parse_tree(const cJSON *root, const char *name, const ffd_rig_files *files,
                              ffd_rig **out, ffd_error *err)
{
    *out = NULL;
    name = ffd_name_or(name, "rig");
    ffd_rig *rig = ffd_rig_new(name);
    if (!rig)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    ffd_rig_parser p = {name, err, files};
    ffd_status s = read_root(&p, root, rig);
    if (s) {
        ffd_rig_destroy(rig);
        return s;
    }
    *out = rig;
    return FFD_OK;
}

/* ======================================================================
 * Writer: the rig as its reader reads it
 * ====================================================================== */

static cJSON *constraints_json(const ffd_rig *rig)
{
    cJSON *a = cJSON_CreateArray();
    for (size_t i = 0; a && i < rig->constraint_count; i++) {
        const ffd_rig_constraint *c = &rig->constraints[i];
        cJSON *o = cJSON_CreateObject();
        int ok = ffd_sess_add_to_array(a, o) &&
                 (c->kind == FFD_RIG_CONSTRAINT_VERTEX
                      ? cJSON_AddNumberToObject(o, "vertex", c->vertex) != NULL
                      : ffd_sess_add_item(o, "point", ffd_sess_vec3(c->point))) &&
                 ffd_sess_add_item(o, "target", ffd_sess_vec3(c->target));
        if (!ok) {
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}

void ffd_rig_view(ffd_rig *rig, const ffd_method *method, void *section, size_t size)
{
    memset(rig, 0, sizeof *rig);
    if (section)
        memset(section, 0, size);
    rig->method = method;
    rig->section = section;
}

ffd_status ffd_rig_write_json(const ffd_rig *rig, char **text, ffd_error *err)
{
    *text = NULL;
    if (!rig || !rig->method || !rig->method->write)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_rig_write_json: no rig, or its method has no writer");
    cJSON *root = cJSON_CreateObject();
    int ok = root && cJSON_AddNumberToObject(root, "version", 1) &&
             cJSON_AddStringToObject(root, "deformer", rig->method->name) &&
             rig->method->write(rig, root) &&
             (!(rig->rcond > 0) || ffd_sess_add_item(root, "rcond", ffd_sess_number(rig->rcond))) &&
             (!rig->limit_step || cJSON_AddTrueToObject(root, "limit_step")) &&
             (!rig->constraint_count ||
              ffd_sess_add_item(root, "constraints", constraints_json(rig))) &&
             ffd_rig_write_layers(rig->layers, root) &&
             (!rig->pin_count ||
              ffd_sess_add_item(root, "pins", ffd_rig_pins_json(rig->pins, rig->pin_count)));
    char *printed = ok ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    *text = printed ? ffd_strdup(printed) : NULL;
    cJSON_free(printed);
    return *text ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory writing the rig", rig->name);
}

static int has_prm_extension(const char *path)
{
    size_t n = strlen(path);
    return n >= 4 && strcasecmp(path + n - 4, ".prm") == 0;
}

ffd_status ffd_rig_read(const char *path, ffd_rig **out, ffd_error *err)
{
    *out = NULL;
    struct stat st;
    if (stat(path, &st) == 0 && S_ISREG(st.st_mode) && (size_t)st.st_size > RIG_MAX_BYTES)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: %lld bytes, rig files are limited to 64 MiB", path,
                        (long long)st.st_size);
    unsigned char *data;
    size_t size;
    ffd_status s = ffd_read_file(path, &data, &size, err);
    if (s)
        return s;
    if (has_prm_extension(path))
        s = ffd_rig_parse_prm((const char *)data, size, path, out, err);
    else
        s = ffd_rig_parse_json((const char *)data, size, path, out, err);
    ffd_free(data);
    return s;
}


