/* rig — the rig JSON format: reading it into an ffd_rig, and dispatching .prm files.
 *
 * With rig_json_tspline.c, the only files that include cJSON (rig_json.h). Every rejected value is reported with the
 * file name and the JSON path of the offending key ("rig.json: moves[1].delta:
 * expected an array of 3 finite numbers"); syntax errors with line and column.
 * docs/rig.md describes the format. */
#include "rig/rig_json.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

/* Rig files are small; these bounds turn hostile input into a clear error. */
#define RIG_MAX_BYTES ((size_t)64 << 20)
#define RIG_MAX_DEPTH 64
#define RIG_MAX_RESOLUTION 1024u

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
    return rig;
}

void ffd_rig_destroy(ffd_rig *rig)
{
    if (!rig)
        return;
    ffd_free(rig->name);
    ffd_free(rig->moves);
    ffd_free(rig->constraints);
    ffd_free(rig->pb.controls);
    ffd_free(rig->pb.moves);
    ffd_free(rig->pb.frames);
    for (size_t i = 0; i < rig->pb.curve_count; i++) {
        ffd_free(rig->pb.curves[i].points);
        ffd_free(rig->pb.curves[i].moves);
    }
    ffd_free(rig->pb.curves);
    for (size_t i = 0; i < rig->gffd.skeleton_count; i++)
        ffd_rig_primitive_free(&rig->gffd.skeleton[i]);
    ffd_free(rig->gffd.skeleton);
    for (size_t i = 0; i < rig->gffd.replace_count; i++)
        ffd_rig_primitive_free(&rig->gffd.replace[i]);
    ffd_free(rig->gffd.replace);
    for (size_t i = 0; i < rig->gffd.edit_count; i++)
        ffd_free(rig->gffd.edits[i].vertices);
    ffd_free(rig->gffd.edits);
    ffd_free(rig->gffd.corr_from);
    ffd_free(rig->gffd.corr_to);
    ffd_rig_tspline_free(&rig->tsv);
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


ffd_status ffd_rig_expected(const parser *p, const char *path, const char *what)
{
    return ffd_fail(p->err, FFD_ERR_PARSE, "%s: %s: expected %s", p->name, path, what);
}

ffd_status ffd_rig_read_number(const parser *p, const cJSON *item, const char *path, double *out)
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
ffd_status ffd_rig_read_vec3(const parser *p, const cJSON *item, const char *path, double out[3])
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
ffd_status ffd_rig_read_uint3(const parser *p, const cJSON *item, const char *path, uint32_t out[3])
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
ffd_status ffd_rig_read_enum(const parser *p, const cJSON *item, const char *path,
                            const char *const *names, const char *what, int *out)
{
    int v = cJSON_IsString(item) ? ffd_rig_lookup(item->valuestring, names) : -1;
    if (v < 0)
        return ffd_rig_expected(p, path, what);
    *out = v;
    return FFD_OK;
}

/* Rejects keys outside allowed (NULL-terminated) and keys given twice. */
ffd_status ffd_rig_check_keys(const parser *p, const cJSON *object, const char *path,
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

/* ======================================================================
 * Sections
 * ====================================================================== */

static ffd_status read_box(const parser *p, const cJSON *item, ffd_rig *rig)
{
    if (cJSON_IsString(item)) {
        if (strcmp(item->valuestring, "auto") != 0)
            return ffd_rig_expected(p, "box", "\"auto\" or an object {\"origin\": [x,y,z], \"axes\": "
                                      "[[..],[..],[..]]}");
        rig->box_auto = 1;
        return FFD_OK;
    }
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, "box",
                        "\"auto\" or an object {\"origin\": [x,y,z], \"axes\": [[..],[..],[..]]}");
    static const char *const keys[] = {"origin", "axes", NULL};
    ffd_status s = ffd_rig_check_keys(p, item, "box", keys, "\"origin\", \"axes\"");
    if (s)
        return s;
    const cJSON *origin = cJSON_GetObjectItemCaseSensitive(item, "origin");
    const cJSON *axes = cJSON_GetObjectItemCaseSensitive(item, "axes");
    if (!origin)
        return ffd_rig_expected(p, "box.origin", "an array of 3 finite numbers (missing)");
    if (!axes)
        return ffd_rig_expected(p, "box.axes", "an array of 3 axes (missing)");
    if ((s = ffd_rig_read_vec3(p, origin, "box.origin", rig->box.origin)))
        return s;
    if (!cJSON_IsArray(axes) || cJSON_GetArraySize(axes) != 3)
        return ffd_rig_expected(p, "box.axes", "an array of 3 axes, each an array of 3 finite numbers");
    int i = 0;
    const cJSON *axis;
    cJSON_ArrayForEach(axis, axes)
    {
        char path[RIG_PATH_MAX];
        snprintf(path, sizeof path, "box.axes[%d]", i);
        if ((s = ffd_rig_read_vec3(p, axis, path, rig->box.axes[i])))
            return s;
        i++;
    }
    rig->box_auto = 0;
    return FFD_OK;
}

static ffd_status read_moves(const parser *p, const cJSON *item, ffd_rig *rig)
{
    if (!cJSON_IsArray(item))
        return ffd_rig_expected(p, "moves", "an array of {\"index\": [i,j,k], \"delta\": [dx,dy,dz]}");
    size_t n = (size_t)cJSON_GetArraySize(item);
    if (n) {
        rig->moves = ffd_calloc(n, sizeof *rig->moves);
        if (!rig->moves)
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory for %zu moves", p->name, n);
    }
    static const char *const keys[] = {"index", "delta", NULL};
    size_t i = 0;
    const cJSON *m;
    cJSON_ArrayForEach(m, item)
    {
        char path[RIG_PATH_MAX], sub[RIG_PATH_MAX + 16];
        snprintf(path, sizeof path, "moves[%zu]", i);
        if (!cJSON_IsObject(m))
            return ffd_rig_expected(p, path, "an object {\"index\": [i,j,k], \"delta\": [dx,dy,dz]}");
        ffd_status s = ffd_rig_check_keys(p, m, path, keys, "\"index\", \"delta\"");
        if (s)
            return s;
        ffd_rig_move *move = &rig->moves[i];
        const cJSON *index = cJSON_GetObjectItemCaseSensitive(m, "index");
        const cJSON *delta = cJSON_GetObjectItemCaseSensitive(m, "delta");
        snprintf(sub, sizeof sub, "%s.index", path);
        if (!index)
            return ffd_rig_expected(p, sub, "an array of 3 non-negative integers (missing)");
        if ((s = ffd_rig_read_uint3(p, index, sub, move->index)))
            return s;
        snprintf(sub, sizeof sub, "%s.delta", path);
        if (!delta)
            return ffd_rig_expected(p, sub, "an array of 3 finite numbers (missing)");
        if ((s = ffd_rig_read_vec3(p, delta, sub, move->delta)))
            return s;
        i++;
    }
    rig->move_count = n;
    return FFD_OK;
}

/* "version", if given, is 1. */
ffd_status ffd_rig_read_version(const parser *p, const cJSON *root)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(root, "version");
    if (item && (!cJSON_IsNumber(item) || item->valuedouble != 1.0))
        return ffd_rig_expected(p, "version", "1 (the only rig version)");
    return FFD_OK;
}

/* The top-level keys of a rig of one deformer: each in keys (else "not a
 * key of "deformer": "NAME" rigs, expected one of TEXT"), none twice; and
 * the version. */
ffd_status ffd_rig_check_deformer_root(const parser *p, const cJSON *root, const char *deformer,
                                   const char *const *keys, const char *keys_text)
{
    const cJSON *item;
    cJSON_ArrayForEach(item, root)
    {
        if (ffd_rig_lookup(item->string, keys) < 0)
            return ffd_fail(p->err, FFD_ERR_PARSE,
                            "%s: %.64s: not a key of \"deformer\": \"%s\" rigs, expected one of %s",
                            p->name, item->string, deformer, keys_text);
    }
    ffd_status s = ffd_rig_check_keys(p, root, "", keys, "");
    return s ? s : ffd_rig_read_version(p, root);
}

/* {"axis": [x,y,z], "angle": radians} and, when center is not NULL, an
 * optional "center": [x,y,z] (*has_center says whether it was given). */
ffd_status ffd_rig_read_rotation(const parser *p, const cJSON *item, const char *path,
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

ffd_status ffd_rig_read_constraints(const parser *p, const cJSON *item, const char *where,
                                ffd_rig_constraint **out, size_t *count)
{
    if (!cJSON_IsArray(item))
        return ffd_rig_expected(p, where,
                        "an array of {\"vertex\": id, \"target\": [x,y,z]} or "
                        "{\"point\": [x,y,z], \"target\": [x,y,z]}");
    size_t n = (size_t)cJSON_GetArraySize(item);
    if (n) {
        *out = ffd_calloc(n, sizeof **out);
        if (!*out)
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory for %zu constraints",
                            p->name, n);
    }
    static const char *const keys[] = {"vertex", "point", "target", NULL};
    size_t i = 0;
    const cJSON *c;
    cJSON_ArrayForEach(c, item)
    {
        char path[RIG_PATH_MAX], sub[RIG_PATH_MAX + 16];
        snprintf(path, sizeof path, "%.60s[%zu]", where, i);
        if (!cJSON_IsObject(c))
            return ffd_rig_expected(p, path,
                            "an object {\"vertex\": id, \"target\": [x,y,z]} or "
                            "{\"point\": [x,y,z], \"target\": [x,y,z]}");
        ffd_status s = ffd_rig_check_keys(p, c, path, keys, "\"vertex\", \"point\", \"target\"");
        if (s)
            return s;
        ffd_rig_constraint *con = &(*out)[i];
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
        if ((s = ffd_rig_read_vec3(p, target, sub, con->target)))
            return s;
        i++;
    }
    *count = n;
    return FFD_OK;
}

/* ======================================================================
 * PB-FFD sections (docs/rig.md, "PB-FFD rigs")
 * ====================================================================== */

/* A non-negative integer that fits uint32_t. */
ffd_status ffd_rig_read_index(const parser *p, const cJSON *item, const char *path,
                             const char *what, uint32_t *out)
{
    if (!ffd_rig_is_uint32(item))
        return ffd_rig_expected(p, path, what);
    *out = (uint32_t)item->valuedouble;
    return FFD_OK;
}

ffd_status ffd_rig_read_positive(const parser *p, const cJSON *item, const char *path, double *out)
{
    ffd_status s = ffd_rig_read_number(p, item, path, out);
    if (!s && !(*out > 0))
        return ffd_fail(p->err, FFD_ERR_INVALID, "%s: %s: %g: expected a number > 0", p->name,
                        path, *out);
    return s;
}

/* Three vectors [[..],[..],[..]]. */
static ffd_status read_frame(const parser *p, const cJSON *item, const char *path,
                             double frame[3][3])
{
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != 3)
        return ffd_rig_expected(p, path, "an array of 3 axes, each an array of 3 finite numbers");
    int i = 0;
    const cJSON *axis;
    cJSON_ArrayForEach(axis, item)
    {
        char sub[RIG_PATH_MAX + 8];
        snprintf(sub, sizeof sub, "%s[%d]", path, i);
        ffd_status s = ffd_rig_read_vec3(p, axis, sub, frame[i]);
        if (s)
            return s;
        i++;
    }
    return FFD_OK;
}

static ffd_status read_placement(const parser *p, const cJSON *item, ffd_rig_pbffd *pb)
{
    static const char *const keys[] = {"interior", "exterior", "offset", "radius_factor",
                                       "surface",  "voronoi_sites", "cover", NULL};
    static const char *const surfaces[] = {"auto", "closed", "open", NULL};
    ffd_status s = ffd_rig_check_keys(p, item, "controls", keys,
                              "\"interior\", \"exterior\", \"offset\", \"radius_factor\", "
                              "\"surface\", \"voronoi_sites\", \"cover\"");
    if (s)
        return s;
    ffd_placement_options *o = &pb->placement;
    const cJSON *v;
    uint32_t count = 0;
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "interior"))) {
        if ((s = ffd_rig_read_index(p, v, "controls.interior", "a positive integer", &count)))
            return s;
        if (count == 0)
            return ffd_rig_expected(p, "controls.interior", "a positive integer");
        o->interior_count = count;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "exterior"))) {
        if ((s = ffd_rig_read_index(p, v, "controls.exterior", "a positive integer", &count)))
            return s;
        if (count == 0)
            return ffd_rig_expected(p, "controls.exterior", "a positive integer");
        o->exterior_count = count;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "offset"))) {
        if ((s = ffd_rig_read_positive(p, v, "controls.offset", &o->offset)))
            return s;
        if (o->offset > 1)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: controls.offset: %g: expected a fraction of the bounding-box "
                            "diagonal in (0, 1]",
                            p->name, o->offset);
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "radius_factor"))) {
        if ((s = ffd_rig_read_positive(p, v, "controls.radius_factor", &o->radius_factor)))
            return s;
        if (o->radius_factor > 100)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: controls.radius_factor: %g: expected a number in (0, 100]",
                            p->name, o->radius_factor);
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "surface"))) {
        int k = 0;
        if ((s = ffd_rig_read_enum(p, v, "controls.surface", surfaces,
                           "\"auto\", \"closed\" or \"open\"", &k)))
            return s;
        o->surface = k == 0 ? FFD_SURFACE_AUTO : k == 1 ? FFD_SURFACE_CLOSED : FFD_SURFACE_OPEN;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "voronoi_sites"))) {
        if ((s = ffd_rig_read_index(p, v, "controls.voronoi_sites", "a positive integer", &count)))
            return s;
        if (count < 5)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: controls.voronoi_sites: %u: expected at least 5", p->name, count);
        o->voronoi_sites = count;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "cover"))) {
        if (!cJSON_IsBool(v))
            return ffd_rig_expected(p, "controls.cover", "true or false");
        o->no_cover = cJSON_IsFalse(v);
    }
    pb->controls_auto = 1;
    return FFD_OK;
}

static ffd_status read_control(const parser *p, const cJSON *c, const char *path, ffd_ebf *ebf)
{
    static const char *const keys[] = {"center", "radius", "frame", "enabled", NULL};
    char sub[RIG_PATH_MAX + 16];
    if (!cJSON_IsObject(c))
        return ffd_rig_expected(p, path, "an object {\"center\": [x,y,z], \"radius\": r}");
    ffd_status s = ffd_rig_check_keys(p, c, path, keys,
                              "\"center\", \"radius\", \"frame\", \"enabled\"");
    if (s)
        return s;
    const cJSON *center = cJSON_GetObjectItemCaseSensitive(c, "center");
    const cJSON *radius = cJSON_GetObjectItemCaseSensitive(c, "radius");
    const cJSON *frame = cJSON_GetObjectItemCaseSensitive(c, "frame");
    const cJSON *enabled = cJSON_GetObjectItemCaseSensitive(c, "enabled");
    snprintf(sub, sizeof sub, "%s.center", path);
    if (!center)
        return ffd_rig_expected(p, sub, "an array of 3 finite numbers (missing)");
    if ((s = ffd_rig_read_vec3(p, center, sub, ebf->center)))
        return s;
    snprintf(sub, sizeof sub, "%s.radius", path);
    if (!radius)
        return ffd_rig_expected(p, sub, "a number > 0 or an array of 3 (missing)");
    if (cJSON_IsArray(radius)) {
        if ((s = ffd_rig_read_vec3(p, radius, sub, ebf->radius)))
            return s;
    } else {
        if ((s = ffd_rig_read_number(p, radius, sub, &ebf->radius[0])))
            return s;
        ebf->radius[1] = ebf->radius[2] = ebf->radius[0];
    }
    for (int a = 0; a < 3; a++)
        if (!(ebf->radius[a] > 0))
            return ffd_fail(p->err, FFD_ERR_INVALID, "%s: %s: %g: expected a radius > 0",
                            p->name, sub, ebf->radius[a]);
    if (frame) {
        snprintf(sub, sizeof sub, "%s.frame", path);
        if ((s = read_frame(p, frame, sub, ebf->frame)))
            return s;
    } else {
        /* axis-aligned, lengths = the ROI semi-axes (§3.2.1: frame lengths = radius) */
        memset(ebf->frame, 0, sizeof ebf->frame);
        for (int a = 0; a < 3; a++)
            ebf->frame[a][a] = ebf->radius[a];
    }
    if (enabled) {
        snprintf(sub, sizeof sub, "%s.enabled", path);
        if (!cJSON_IsBool(enabled))
            return ffd_rig_expected(p, sub, "true or false");
        ebf->disabled = cJSON_IsFalse(enabled);
    }
    return FFD_OK;
}

static ffd_status read_controls(const parser *p, const cJSON *item, ffd_rig_pbffd *pb)
{
    static const char what[] =
        "\"auto\", an object of placement options, or an array of "
        "{\"center\": [x,y,z], \"radius\": r, \"frame\": [[..],[..],[..]]}";
    if (cJSON_IsString(item)) {
        if (strcmp(item->valuestring, "auto") != 0)
            return ffd_rig_expected(p, "controls", what);
        pb->controls_auto = 1;
        return FFD_OK;
    }
    if (cJSON_IsObject(item))
        return read_placement(p, item, pb);
    if (!cJSON_IsArray(item))
        return ffd_rig_expected(p, "controls", what);
    size_t n = (size_t)cJSON_GetArraySize(item);
    if (n == 0)
        return ffd_rig_expected(p, "controls", "at least one control point (or \"auto\")");
    pb->controls = ffd_calloc(n, sizeof *pb->controls);
    if (!pb->controls)
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory for %zu controls", p->name, n);
    size_t i = 0;
    const cJSON *c;
    cJSON_ArrayForEach(c, item)
    {
        char path[RIG_PATH_MAX];
        snprintf(path, sizeof path, "controls[%zu]", i);
        ffd_status s = read_control(p, c, path, &pb->controls[i]);
        if (s)
            return s;
        i++;
    }
    pb->control_count = n;
    pb->controls_auto = 0;
    return FFD_OK;
}

static ffd_status read_master(const parser *p, const cJSON *item, ffd_pbffd_options *o)
{
    if (cJSON_IsBool(item)) {
        o->no_master = cJSON_IsFalse(item);
        return FFD_OK;
    }
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, "master", "true, false or {\"radius\": r, \"weight\": w}");
    static const char *const keys[] = {"radius", "weight", NULL};
    ffd_status s = ffd_rig_check_keys(p, item, "master", keys, "\"radius\", \"weight\"");
    if (s)
        return s;
    const cJSON *v;
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "radius"))) {
        if ((s = ffd_rig_read_number(p, v, "master.radius", &o->master_radius)))
            return s;
        if (o->master_radius < 1)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: master.radius: %g: expected a number >= 1 (a multiple of the "
                            "bounding sphere's radius)",
                            p->name, o->master_radius);
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "weight")) &&
        (s = ffd_rig_read_positive(p, v, "master.weight", &o->master_weight)))
        return s;
    return FFD_OK;
}

/* "moves" ({"control", "level", "delta"}) and "frames" ({"control", "level",
 * "frame"} or {"control", "level", "rotate": {"axis", "angle"}, "scale"}). */
static ffd_status read_pb_edits(const parser *p, const cJSON *item, const char *key, int frames,
                                ffd_rig_pb_edit **out, size_t *count)
{
    static const char *const move_keys[] = {"control", "near", "level", "delta", NULL};
    static const char *const frame_keys[] = {"control", "near",   "level", "frame",
                                             "rotate",  "scale",  NULL};
    static const char move_what[] = "an array of {\"control\": i, \"level\": l, \"delta\": "
                                    "[dx,dy,dz]}";
    static const char frame_what[] = "an array of {\"control\": i, \"level\": l, \"frame\": "
                                     "[[..],[..],[..]]} or {\"control\": i, \"rotate\": "
                                     "{\"axis\": [x,y,z], \"angle\": a}, \"scale\": [sx,sy,sz]}";
    if (!cJSON_IsArray(item))
        return ffd_rig_expected(p, key, frames ? frame_what : move_what);
    size_t n = (size_t)cJSON_GetArraySize(item);
    if (n && !(*out = ffd_calloc(n, sizeof **out)))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory for %zu %s", p->name, n, key);
    size_t i = 0;
    const cJSON *m;
    cJSON_ArrayForEach(m, item)
    {
        char path[RIG_PATH_MAX], sub[RIG_PATH_MAX + 24];
        snprintf(path, sizeof path, "%s[%zu]", key, i);
        if (!cJSON_IsObject(m))
            return ffd_rig_expected(p, path, frames ? frame_what + 12 : move_what + 12);
        ffd_status s = frames ? ffd_rig_check_keys(p, m, path, frame_keys,
                                           "\"control\", \"near\", \"level\", \"frame\", "
                                           "\"rotate\", \"scale\"")
                              : ffd_rig_check_keys(p, m, path, move_keys,
                                           "\"control\", \"near\", \"level\", \"delta\"");
        if (s)
            return s;
        ffd_rig_pb_edit *e = &(*out)[i];
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(m, "control");
        const cJSON *near = cJSON_GetObjectItemCaseSensitive(m, "near");
        if ((v != NULL) == (near != NULL))
            return ffd_rig_expected(p, path, v ? "either \"control\" or \"near\", not both"
                                       : "a \"control\" index or a \"near\" point");
        if (v) {
            snprintf(sub, sizeof sub, "%s.control", path);
            if ((s = ffd_rig_read_index(p, v, sub, "a control index (a non-negative integer)",
                                &e->control)))
                return s;
        } else {
            snprintf(sub, sizeof sub, "%s.near", path);
            if ((s = ffd_rig_read_vec3(p, near, sub, e->near)))
                return s;
            e->by_near = 1;
        }
        if ((v = cJSON_GetObjectItemCaseSensitive(m, "level"))) {
            snprintf(sub, sizeof sub, "%s.level", path);
            if ((s = ffd_rig_read_index(p, v, sub, "a level (0 = finest)", &e->level)))
                return s;
        }
        if (!frames) {
            snprintf(sub, sizeof sub, "%s.delta", path);
            if (!(v = cJSON_GetObjectItemCaseSensitive(m, "delta")))
                return ffd_rig_expected(p, sub, "an array of 3 finite numbers (missing)");
            if ((s = ffd_rig_read_vec3(p, v, sub, e->delta)))
                return s;
            e->has_delta = 1;
            i++;
            continue;
        }
        const cJSON *frame = cJSON_GetObjectItemCaseSensitive(m, "frame");
        const cJSON *rotate = cJSON_GetObjectItemCaseSensitive(m, "rotate");
        const cJSON *scale = cJSON_GetObjectItemCaseSensitive(m, "scale");
        if (frame && (rotate || scale))
            return ffd_rig_expected(p, path, "either \"frame\" or \"rotate\"/\"scale\", not both");
        if (!frame && !rotate && !scale)
            return ffd_rig_expected(p, path, "a \"frame\", \"rotate\" or \"scale\" key");
        if (frame) {
            snprintf(sub, sizeof sub, "%s.frame", path);
            if ((s = read_frame(p, frame, sub, e->frame)))
                return s;
            e->frame_kind = 1;
            i++;
            continue;
        }
        e->frame_kind = 2;
        e->scale[0] = e->scale[1] = e->scale[2] = 1;
        e->axis[2] = 1;
        if (rotate) {
            snprintf(sub, sizeof sub, "%s.rotate", path);
            if ((s = ffd_rig_read_rotation(p, rotate, sub, e->axis, &e->angle, NULL, NULL)))
                return s;
        }
        if (scale) {
            snprintf(sub, sizeof sub, "%s.scale", path);
            if ((s = ffd_rig_read_vec3(p, scale, sub, e->scale)))
                return s;
            for (int a = 0; a < 3; a++)
                if (e->scale[a] == 0)
                    return ffd_fail(p->err, FFD_ERR_INVALID,
                                    "%s: %s[%d]: a zero scale flattens the frame", p->name, sub,
                                    a);
        }
        i++;
    }
    *count = n;
    return FFD_OK;
}

static ffd_status read_curve(const parser *p, const cJSON *c, const char *path, ffd_rig_curve *curve)
{
    static const char *const keys[] = {"points", "radius", "samples", "moves", NULL};
    static const char *const move_keys[] = {"index", "delta", NULL};
    char sub[RIG_PATH_MAX + 16];
    if (!cJSON_IsObject(c))
        return ffd_rig_expected(p, path, "an object {\"points\": [[x,y,z], ...], \"radius\": r, "
                                 "\"moves\": [...]}");
    ffd_status s = ffd_rig_check_keys(p, c, path, keys, "\"points\", \"radius\", \"samples\", \"moves\"");
    if (s)
        return s;
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(c, "points");
    snprintf(sub, sizeof sub, "%s.points", path);
    if (!v || !cJSON_IsArray(v) || cJSON_GetArraySize(v) < 2)
        return ffd_rig_expected(p, sub, "an array of at least 2 points [x,y,z]");
    size_t n = (size_t)cJSON_GetArraySize(v);
    if (!(curve->points = ffd_malloc_array(n, 3 * sizeof(double))))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    curve->point_count = n;
    size_t i = 0;
    const cJSON *pt;
    cJSON_ArrayForEach(pt, v)
    {
        char leaf[RIG_PATH_MAX + 40];
        snprintf(leaf, sizeof leaf, "%s[%zu]", sub, i);
        if ((s = ffd_rig_read_vec3(p, pt, leaf, curve->points + 3 * i)))
            return s;
        i++;
    }
    snprintf(sub, sizeof sub, "%s.radius", path);
    if (!(v = cJSON_GetObjectItemCaseSensitive(c, "radius")))
        return ffd_rig_expected(p, sub, "a number > 0 (missing)");
    if ((s = ffd_rig_read_positive(p, v, sub, &curve->radius)))
        return s;
    if ((v = cJSON_GetObjectItemCaseSensitive(c, "samples"))) {
        snprintf(sub, sizeof sub, "%s.samples", path);
        if ((s = ffd_rig_read_index(p, v, sub, "a non-negative integer (0: automatic)", &curve->samples)))
            return s;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(c, "moves"))) {
        snprintf(sub, sizeof sub, "%s.moves", path);
        if (!cJSON_IsArray(v))
            return ffd_rig_expected(p, sub, "an array of {\"index\": i, \"delta\": [dx,dy,dz]}");
        size_t k = (size_t)cJSON_GetArraySize(v);
        if (k && !(curve->moves = ffd_calloc(k, sizeof *curve->moves)))
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        size_t j = 0;
        const cJSON *m;
        cJSON_ArrayForEach(m, v)
        {
            char mp[RIG_PATH_MAX + 40], leaf[RIG_PATH_MAX + 64];
            snprintf(mp, sizeof mp, "%s[%zu]", sub, j);
            if (!cJSON_IsObject(m))
                return ffd_rig_expected(p, mp, "an object {\"index\": i, \"delta\": [dx,dy,dz]}");
            if ((s = ffd_rig_check_keys(p, m, mp, move_keys, "\"index\", \"delta\"")))
                return s;
            const cJSON *ix = cJSON_GetObjectItemCaseSensitive(m, "index");
            const cJSON *d = cJSON_GetObjectItemCaseSensitive(m, "delta");
            snprintf(leaf, sizeof leaf, "%s.index", mp);
            if (!ix)
                return ffd_rig_expected(p, leaf, "a curve point index (missing)");
            if ((s = ffd_rig_read_index(p, ix, leaf, "a curve point index", &curve->moves[j].index)))
                return s;
            if (curve->moves[j].index >= n)
                return ffd_fail(p->err, FFD_ERR_RANGE,
                                "%s: %s: %u out of range (the curve has %zu points)", p->name,
                                leaf, curve->moves[j].index, n);
            snprintf(leaf, sizeof leaf, "%s.delta", mp);
            if (!d)
                return ffd_rig_expected(p, leaf, "an array of 3 finite numbers (missing)");
            if ((s = ffd_rig_read_vec3(p, d, leaf, curve->moves[j].delta)))
                return s;
            j++;
        }
        curve->move_count = k;
    }
    return FFD_OK;
}

static ffd_status read_curves(const parser *p, const cJSON *item, ffd_rig_pbffd *pb)
{
    if (!cJSON_IsArray(item))
        return ffd_rig_expected(p, "curves", "an array of {\"points\": [[x,y,z], ...], \"radius\": r, "
                                     "\"moves\": [...]}");
    size_t n = (size_t)cJSON_GetArraySize(item);
    if (n && !(pb->curves = ffd_calloc(n, sizeof *pb->curves)))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    pb->curve_count = n; /* so that destroy frees what was read */
    size_t i = 0;
    const cJSON *c;
    cJSON_ArrayForEach(c, item)
    {
        char path[RIG_PATH_MAX];
        snprintf(path, sizeof path, "curves[%zu]", i);
        ffd_status s = read_curve(p, c, path, &pb->curves[i]);
        if (s)
            return s;
        i++;
    }
    return FFD_OK;
}

static ffd_status validate_pbffd(const parser *p, const ffd_rig_pbffd *pb)
{
    uint32_t levels = pb->options.levels ? pb->options.levels : 1;
    const ffd_rig_pb_edit *lists[2] = {pb->moves, pb->frames};
    size_t counts[2] = {pb->move_count, pb->frame_count};
    const char *keys[2] = {"moves", "frames"};
    for (int l = 0; l < 2; l++)
        for (size_t i = 0; i < counts[l]; i++)
            if (lists[l][i].level >= levels)
                return ffd_fail(p->err, FFD_ERR_RANGE,
                                "%s: %s[%zu].level: %u out of range (the rig has %u level%s; "
                                "0 is the finest)",
                                p->name, keys[l], i, lists[l][i].level, levels,
                                levels == 1 ? "" : "s");
    if (pb->constraint_level >= levels)
        return ffd_fail(p->err, FFD_ERR_RANGE,
                        "%s: constraint_level: %u out of range (the rig has %u level%s)", p->name,
                        pb->constraint_level, levels, levels == 1 ? "" : "s");
    /* explicit controls: indices are known now (placed ones are checked at apply time) */
    if (!pb->controls_auto)
        for (int l = 0; l < 2; l++)
            for (size_t i = 0; i < counts[l]; i++)
                if (lists[l][i].level == 0 && !lists[l][i].by_near &&
                    lists[l][i].control >= pb->control_count)
                    return ffd_fail(p->err, FFD_ERR_RANGE,
                                    "%s: %s[%zu].control: %u out of range (%zu controls)",
                                    p->name, keys[l], i, lists[l][i].control, pb->control_count);
    return FFD_OK;
}

static ffd_status read_pbffd_key(const parser *p, const cJSON *item, ffd_rig *rig)
{
    ffd_rig_pbffd *pb = &rig->pb;
    const char *key = item->string;
    ffd_status s;
    if (strcmp(key, "controls") == 0)
        return read_controls(p, item, pb);
    if (strcmp(key, "sigma") == 0) {
        if ((s = ffd_rig_read_positive(p, item, "sigma", &pb->options.sigma)))
            return s;
        if (pb->options.sigma < 0.05 || pb->options.sigma > 1e6)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: sigma: %g: expected a number in [0.05, 1e6] (below 0.05 the "
                            "kernel underflows inside its region of influence)",
                            p->name, pb->options.sigma);
        return FFD_OK;
    }
    if (strcmp(key, "master") == 0)
        return read_master(p, item, &pb->options);
    if (strcmp(key, "levels") == 0) {
        if ((s = ffd_rig_read_index(p, item, "levels", "a positive integer", &pb->options.levels)))
            return s;
        if (pb->options.levels < 1 || pb->options.levels > 32)
            return ffd_fail(p->err, FFD_ERR_INVALID, "%s: levels: %u: expected 1 to 32", p->name,
                            pb->options.levels);
        return FFD_OK;
    }
    if (strcmp(key, "constraint_level") == 0)
        return ffd_rig_read_index(p, item, "constraint_level", "a level (0 = finest)",
                          &pb->constraint_level);
    if (strcmp(key, "moves") == 0)
        return read_pb_edits(p, item, "moves", 0, &pb->moves, &pb->move_count);
    if (strcmp(key, "frames") == 0)
        return read_pb_edits(p, item, "frames", 1, &pb->frames, &pb->frame_count);
    if (strcmp(key, "curves") == 0)
        return read_curves(p, item, pb);
    return FFD_OK;
}


/* ======================================================================
 * GFFD sections (docs/rig.md, "GFFD rigs")
 * ====================================================================== */

/* path resolved against the rig file's directory (name), unless absolute. */
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

/* Lists the "file"s of a skeleton array that was read (ffd_rig_read_skeleton)
 * in rig->input_files, resolved as they were read, so that tools can refuse
 * to write over them (ffd_rig_input_path). */
static ffd_status list_skeleton_files(const parser *p, const cJSON *array, ffd_rig *rig)
{
    const cJSON *item;
    cJSON_ArrayForEach(item, array)
    {
        const cJSON *file = cJSON_GetObjectItemCaseSensitive(item, "file");
        if (!cJSON_IsString(file))
            continue;
        char *path = resolve_path(p->name, file->valuestring);
        char **files = path ? ffd_realloc_array(rig->input_files, rig->input_file_count + 1,
                                                sizeof *files)
                            : NULL;
        if (!files) {
            ffd_free(path);
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        }
        rig->input_files = files;
        files[rig->input_file_count++] = path;
    }
    return FFD_OK;
}

/* An array of [x,y,z] points; at least min of them. */
static ffd_status read_points(const parser *p, const cJSON *item, const char *path, size_t min,
                              double **out, size_t *count)
{
    char what[64];
    snprintf(what, sizeof what, "an array of at least %zu points [x,y,z]", min);
    if (!cJSON_IsArray(item) || (size_t)cJSON_GetArraySize(item) < min)
        return ffd_rig_expected(p, path, what);
    size_t n = (size_t)cJSON_GetArraySize(item);
    if (n && !(*out = ffd_malloc_array(n, 3 * sizeof(double))))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    *count = n;
    size_t i = 0;
    const cJSON *pt;
    cJSON_ArrayForEach(pt, item)
    {
        char leaf[RIG_PATH_MAX + 40];
        snprintf(leaf, sizeof leaf, "%s[%zu]", path, i);
        ffd_status s = ffd_rig_read_vec3(p, pt, leaf, *out + 3 * i);
        if (s)
            return s;
        i++;
    }
    return FFD_OK;
}

/* Faces [[i,j,k,...], ...] as offsets and indices. */
static ffd_status read_faces(const parser *p, const cJSON *item, const char *path,
                             ffd_rig_primitive *prim)
{
    static const char what[] = "an array of faces, each an array of >= 3 vertex indices";
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) < 1)
        return ffd_rig_expected(p, path, what);
    size_t n = (size_t)cJSON_GetArraySize(item), corners = 0;
    const cJSON *f;
    cJSON_ArrayForEach(f, item)
    {
        if (!cJSON_IsArray(f) || cJSON_GetArraySize(f) < 3)
            return ffd_rig_expected(p, path, what);
        corners += (size_t)cJSON_GetArraySize(f);
    }
    if (corners > UINT32_MAX)
        return ffd_rig_expected(p, path, "fewer corners");
    prim->face_offsets = ffd_malloc_array(n + 1, sizeof(uint32_t));
    prim->face_indices = ffd_malloc_array(corners, sizeof(uint32_t));
    if (!prim->face_offsets || !prim->face_indices)
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    size_t i = 0, c = 0;
    prim->face_offsets[0] = 0;
    cJSON_ArrayForEach(f, item)
    {
        const cJSON *v;
        cJSON_ArrayForEach(v, f)
        {
            if (!ffd_rig_is_uint32(v)) {
                char leaf[RIG_PATH_MAX + 40];
                snprintf(leaf, sizeof leaf, "%s[%zu]", path, i);
                return ffd_rig_expected(p, leaf, "vertex indices (non-negative integers)");
            }
            prim->face_indices[c++] = (uint32_t)v->valuedouble;
        }
        prim->face_offsets[++i] = (uint32_t)c;
    }
    prim->face_count = n;
    return FFD_OK;
}

ffd_status ffd_rig_read_primitive(const parser *p, const cJSON *item, const char *path,
                              ffd_rig_primitive *prim)
{
    static const char *const keys[] = {"type", "radius", "position", "vertices", "faces", "file",
                                       "name", NULL};
    static const char *const kinds[] = {"point", "polyline", "patch", "polyhedron", NULL};
    char sub[RIG_PATH_MAX + 24];
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, path, "a primitive {\"type\": \"point\"|\"polyline\"|\"patch\"|"
                                 "\"polyhedron\", \"radius\": r, ...}");
    ffd_status s = ffd_rig_check_keys(p, item, path, keys,
                              "\"type\", \"radius\", \"position\", \"vertices\", \"faces\", "
                              "\"file\", \"name\"");
    if (s)
        return s;
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(item, "type");
    snprintf(sub, sizeof sub, "%s.type", path);
    int kind = 0;
    if (!v)
        return ffd_rig_expected(p, sub, "\"point\", \"polyline\", \"patch\" or \"polyhedron\" (missing)");
    if ((s = ffd_rig_read_enum(p, v, sub, kinds, "\"point\", \"polyline\", \"patch\" or \"polyhedron\"",
                       &kind)))
        return s;
    prim->kind = (ffd_gffd_kind)kind;
    snprintf(sub, sizeof sub, "%s.radius", path);
    if (!(v = cJSON_GetObjectItemCaseSensitive(item, "radius")))
        return ffd_rig_expected(p, sub, "the influence radius r_s > 0 (missing)");
    if ((s = ffd_rig_read_positive(p, v, sub, &prim->radius)))
        return s;
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "name")) && !cJSON_IsString(v)) {
        snprintf(sub, sizeof sub, "%s.name", path);
        return ffd_rig_expected(p, sub, "a string");
    }
    const cJSON *pos = cJSON_GetObjectItemCaseSensitive(item, "position");
    const cJSON *verts = cJSON_GetObjectItemCaseSensitive(item, "vertices");
    const cJSON *faces = cJSON_GetObjectItemCaseSensitive(item, "faces");
    const cJSON *file = cJSON_GetObjectItemCaseSensitive(item, "file");
    if (prim->kind == FFD_GFFD_POINT) {
        if (verts || faces || file)
            return ffd_rig_expected(p, path, "a point with a \"position\" only");
        snprintf(sub, sizeof sub, "%s.position", path);
        if (!pos)
            return ffd_rig_expected(p, sub, "an array of 3 finite numbers (missing)");
        if (!(prim->vertices = ffd_malloc(3 * sizeof(double))))
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        prim->vertex_count = 1;
        return ffd_rig_read_vec3(p, pos, sub, prim->vertices);
    }
    if (pos)
        return ffd_rig_expected(p, path, "\"vertices\" or \"file\" (\"position\" is for points)");
    if (file) {
        if (verts || faces)
            return ffd_rig_expected(p, path, "either \"file\" or \"vertices\", not both");
        snprintf(sub, sizeof sub, "%s.file", path);
        if (!cJSON_IsString(file) || !file->valuestring[0])
            return ffd_rig_expected(p, sub, "a file name");
        char *resolved = resolve_path(p->name, file->valuestring);
        if (!resolved)
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        ffd_error inner = {{0}};
        ffd_rig_primitive loaded = {0};
        s = ffd_rig_load_primitive(resolved, &loaded, &inner);
        ffd_free(resolved);
        if (s)
            return ffd_fail(p->err, s, "%s: %s: %s", p->name, sub, inner.message);
        if ((prim->kind == FFD_GFFD_POLYLINE) != (loaded.face_count == 0)) {
            ffd_rig_primitive_free(&loaded);
            return ffd_rig_expected(p, sub, prim->kind == FFD_GFFD_POLYLINE
                                        ? "a polyline file (OBJ v and l lines), not a mesh"
                                        : "a mesh file with faces");
        }
        loaded.kind = prim->kind;
        loaded.radius = prim->radius;
        *prim = loaded;
        return FFD_OK;
    }
    snprintf(sub, sizeof sub, "%s.vertices", path);
    if (!verts)
        return ffd_rig_expected(p, sub, "an array of points [x,y,z], or a \"file\" (missing)");
    size_t min = prim->kind == FFD_GFFD_POLYLINE ? 2 : 3;
    if ((s = read_points(p, verts, sub, min, &prim->vertices, &prim->vertex_count)))
        return s;
    snprintf(sub, sizeof sub, "%s.faces", path);
    if (prim->kind == FFD_GFFD_POLYLINE) {
        if (faces)
            return ffd_rig_expected(p, sub, "no faces: a polyline joins its vertices in order");
        return FFD_OK;
    }
    if (!faces)
        return ffd_rig_expected(p, sub, "an array of faces (missing)");
    return read_faces(p, faces, sub, prim);
}

ffd_status ffd_rig_read_skeleton(const parser *p, const cJSON *item, const char *key,
                             ffd_rig_primitive **out, size_t *count)
{
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) < 1)
        return ffd_rig_expected(p, key, "an array of at least one primitive {\"type\": ..., \"radius\": "
                                "r, ...}");
    size_t n = (size_t)cJSON_GetArraySize(item);
    if (!(*out = ffd_calloc(n, sizeof **out)))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    *count = n; /* so that destroy frees what was read */
    size_t i = 0;
    const cJSON *c;
    cJSON_ArrayForEach(c, item)
    {
        char path[RIG_PATH_MAX];
        snprintf(path, sizeof path, "%s[%zu]", key, i);
        ffd_status s = ffd_rig_read_primitive(p, c, path, &(*out)[i]);
        if (s)
            return s;
        i++;
    }
    return FFD_OK;
}

static ffd_status read_gffd_edit(const parser *p, const cJSON *m, const char *path,
                                 ffd_rig_gffd_edit *e)
{
    static const char *const keys[] = {"primitive", "translate", "rotate", "scale", "center",
                                       "vertex",    "move",      "vertices", NULL};
    char sub[RIG_PATH_MAX + 40];
    if (!cJSON_IsObject(m))
        return ffd_rig_expected(p, path, "an edit {\"primitive\": i or \"all\", and one of "
                                 "\"translate\", \"rotate\", \"scale\", \"move\", \"vertices\"}");
    ffd_status s = ffd_rig_check_keys(p, m, path, keys,
                              "\"primitive\", \"translate\", \"rotate\", \"scale\", \"center\", "
                              "\"vertex\", \"move\", \"vertices\"");
    if (s)
        return s;
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(m, "primitive");
    snprintf(sub, sizeof sub, "%s.primitive", path);
    if (!v)
        return ffd_rig_expected(p, sub, "a primitive index or \"all\" (missing)");
    if (cJSON_IsString(v) && strcmp(v->valuestring, "all") == 0)
        e->all = 1;
    else if ((s = ffd_rig_read_index(p, v, sub, "a primitive index or \"all\"", &e->primitive)))
        return s;
    const char *ops[] = {"translate", "rotate", "scale", "move", "vertices"};
    int op = -1;
    for (int k = 0; k < 5; k++)
        if (cJSON_GetObjectItemCaseSensitive(m, ops[k])) {
            if (op >= 0)
                return ffd_rig_expected(p, path, "one of \"translate\", \"rotate\", \"scale\", \"move\", "
                                         "\"vertices\" per edit");
            op = k;
        }
    if (op < 0)
        return ffd_rig_expected(p, path, "one of \"translate\", \"rotate\", \"scale\", \"move\", "
                                 "\"vertices\"");
    const cJSON *center = cJSON_GetObjectItemCaseSensitive(m, "center");
    const cJSON *vertex = cJSON_GetObjectItemCaseSensitive(m, "vertex");
    if (center && op != 1 && op != 2)
        return ffd_rig_expected(p, path, "\"center\" only with \"rotate\" or \"scale\"");
    if ((vertex != NULL) != (op == 3))
        return ffd_rig_expected(p, path, "\"vertex\" together with \"move\"");
    if (center) {
        snprintf(sub, sizeof sub, "%s.center", path);
        if ((s = ffd_rig_read_vec3(p, center, sub, e->center)))
            return s;
        e->has_center = 1;
    }
    v = cJSON_GetObjectItemCaseSensitive(m, ops[op]);
    snprintf(sub, sizeof sub, "%s.%s", path, ops[op]);
    switch (op) {
    case 0:
        e->kind = FFD_RIG_EDIT_TRANSLATE;
        return ffd_rig_read_vec3(p, v, sub, e->delta);
    case 1:
        e->kind = FFD_RIG_EDIT_ROTATE;
        return ffd_rig_read_rotation(p, v, sub, e->axis, &e->angle, NULL, NULL);
    case 2:
        e->kind = FFD_RIG_EDIT_SCALE;
        if (cJSON_IsNumber(v)) {
            if ((s = ffd_rig_read_number(p, v, sub, &e->scale[0])))
                return s;
            e->scale[1] = e->scale[2] = e->scale[0];
        } else if ((s = ffd_rig_read_vec3(p, v, sub, e->scale))) {
            return s;
        }
        return FFD_OK;
    case 3:
        e->kind = FFD_RIG_EDIT_MOVE;
        if (e->all)
            return ffd_rig_expected(p, path, "a primitive index with \"move\" (not \"all\")");
        snprintf(sub, sizeof sub, "%s.vertex", path);
        if ((s = ffd_rig_read_index(p, vertex, sub, "a vertex index of the primitive", &e->vertex)))
            return s;
        snprintf(sub, sizeof sub, "%s.move", path);
        return ffd_rig_read_vec3(p, v, sub, e->delta);
    default:
        e->kind = FFD_RIG_EDIT_VERTICES;
        if (e->all)
            return ffd_rig_expected(p, path, "a primitive index with \"vertices\" (not \"all\")");
        return read_points(p, v, sub, 1, &e->vertices, &e->vertex_count);
    }
}

static ffd_status read_gffd_edits(const parser *p, const cJSON *item, ffd_rig_gffd *g)
{
    if (!cJSON_IsArray(item))
        return ffd_rig_expected(p, "edits", "an array of skeleton edits");
    size_t n = (size_t)cJSON_GetArraySize(item);
    if (n && !(g->edits = ffd_calloc(n, sizeof *g->edits)))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    g->edit_count = n;
    size_t i = 0;
    const cJSON *m;
    cJSON_ArrayForEach(m, item)
    {
        char path[RIG_PATH_MAX];
        snprintf(path, sizeof path, "edits[%zu]", i);
        ffd_status s = read_gffd_edit(p, m, path, &g->edits[i]);
        if (s)
            return s;
        i++;
    }
    return FFD_OK;
}

static ffd_status read_correspondences(const parser *p, const cJSON *item, ffd_rig_gffd *g)
{
    static const char *const keys[] = {"from", "to", NULL};
    static const char what[] = "an array of {\"from\": [x,y,z], \"to\": [x,y,z]}";
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) < 1)
        return ffd_rig_expected(p, "correspondences", what);
    size_t n = (size_t)cJSON_GetArraySize(item);
    g->corr_from = ffd_malloc_array(n, 3 * sizeof(double));
    g->corr_to = ffd_malloc_array(n, 3 * sizeof(double));
    if (!g->corr_from || !g->corr_to)
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    size_t i = 0;
    const cJSON *c;
    cJSON_ArrayForEach(c, item)
    {
        char path[RIG_PATH_MAX], sub[RIG_PATH_MAX + 8];
        snprintf(path, sizeof path, "correspondences[%zu]", i);
        if (!cJSON_IsObject(c))
            return ffd_rig_expected(p, path, what + 12);
        ffd_status s = ffd_rig_check_keys(p, c, path, keys, "\"from\", \"to\"");
        if (s)
            return s;
        const cJSON *f = cJSON_GetObjectItemCaseSensitive(c, "from");
        const cJSON *t = cJSON_GetObjectItemCaseSensitive(c, "to");
        snprintf(sub, sizeof sub, "%s.from", path);
        if (!f)
            return ffd_rig_expected(p, sub, "a point [x,y,z] on the rest skeleton (missing)");
        if ((s = ffd_rig_read_vec3(p, f, sub, g->corr_from + 3 * i)))
            return s;
        snprintf(sub, sizeof sub, "%s.to", path);
        if (!t)
            return ffd_rig_expected(p, sub, "a point [x,y,z] on the new skeleton (missing)");
        if ((s = ffd_rig_read_vec3(p, t, sub, g->corr_to + 3 * i)))
            return s;
        i++;
    }
    g->corr_count = n;
    return FFD_OK;
}

static ffd_status read_resample(const parser *p, const cJSON *item, ffd_rig_gffd *g)
{
    static const char *const keys[] = {"ratio", "max_rounds", "max_vertices", NULL};
    if (cJSON_IsBool(item)) {
        g->resample = cJSON_IsTrue(item);
        return FFD_OK;
    }
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, "resample", "true, false or {\"ratio\": 1.8, \"max_rounds\": 8, "
                                       "\"max_vertices\": n}");
    ffd_status s = ffd_rig_check_keys(p, item, "resample", keys,
                              "\"ratio\", \"max_rounds\", \"max_vertices\"");
    if (s)
        return s;
    g->resample = 1;
    const cJSON *v;
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "ratio"))) {
        if ((s = ffd_rig_read_number(p, v, "resample.ratio", &g->resample_options.ratio)))
            return s;
        if (!(g->resample_options.ratio > 1) || g->resample_options.ratio > 1e6)
            return ffd_rig_expected(p, "resample.ratio", "a number > 1 (an edge splits when its length "
                                                 "grows by this factor)");
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "max_rounds"))) {
        if ((s = ffd_rig_read_index(p, v, "resample.max_rounds", "an integer in 1..64",
                            &g->resample_options.max_rounds)))
            return s;
        if (g->resample_options.max_rounds < 1 || g->resample_options.max_rounds > 64)
            return ffd_rig_expected(p, "resample.max_rounds", "an integer in 1..64");
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "max_vertices"))) {
        uint32_t mv = 0;
        if ((s = ffd_rig_read_index(p, v, "resample.max_vertices", "a positive integer", &mv)))
            return s;
        if (mv == 0)
            return ffd_rig_expected(p, "resample.max_vertices", "a positive integer");
        g->resample_options.max_vertices = mv;
    }
    return FFD_OK;
}

static ffd_status read_gffd_root(const parser *p, const cJSON *root, ffd_rig *rig)
{
    static const char *const keys[] = {"version",   "deformer",       "skeleton",       "unit",
                                       "tolerance", "max_iterations", "tracking",       "max_samples",
                                       "edits",     "replace",        "correspondences", "resample",
                                       NULL};
    static const char *const trackings[] = {"gradient", "warp", NULL};
    ffd_rig_gffd *g = &rig->gffd;
    const cJSON *item;
    ffd_status s = ffd_rig_check_deformer_root(p, root, "gffd", keys,
                                           "\"skeleton\", \"unit\", \"tolerance\", "
                                           "\"max_iterations\", \"tracking\", \"max_samples\", "
                                           "\"edits\", \"replace\", \"correspondences\", "
                                           "\"resample\"");
    if (s)
        return s;
    if (!(item = cJSON_GetObjectItemCaseSensitive(root, "skeleton")))
        return ffd_rig_expected(p, "skeleton", "an array of primitives (missing)");
    if ((s = ffd_rig_read_skeleton(p, item, "skeleton", &g->skeleton, &g->skeleton_count)) ||
        (s = list_skeleton_files(p, item, rig)))
        return s;
    ffd_gffd_options *o = &g->options;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "unit"))) {
        if ((s = ffd_rig_read_positive(p, item, "unit", &o->unit)))
            return s;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "tolerance"))) {
        if ((s = ffd_rig_read_positive(p, item, "tolerance", &o->tolerance)))
            return s;
        if (o->tolerance > 1)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: tolerance: %g: expected a number in (0, 1] (in units of "
                            "\"unit\")",
                            p->name, o->tolerance);
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "max_iterations"))) {
        if ((s = ffd_rig_read_index(p, item, "max_iterations", "an integer in 1..100000",
                            &o->max_iterations)))
            return s;
        if (o->max_iterations < 1 || o->max_iterations > 100000)
            return ffd_rig_expected(p, "max_iterations", "an integer in 1..100000");
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "max_samples"))) {
        uint32_t ms = 0;
        if ((s = ffd_rig_read_index(p, item, "max_samples", "an integer in 1..20000", &ms)))
            return s;
        if (ms < 1 || ms > 20000)
            return ffd_rig_expected(p, "max_samples", "an integer in 1..20000");
        o->max_samples = ms;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "tracking"))) {
        int t = 0;
        if ((s = ffd_rig_read_enum(p, item, "tracking", trackings, "\"gradient\" or \"warp\"", &t)))
            return s;
        o->tracking = t ? FFD_GFFD_TRACK_WARP : FFD_GFFD_TRACK_GRADIENT;
    }
    const cJSON *edits = cJSON_GetObjectItemCaseSensitive(root, "edits");
    const cJSON *replace = cJSON_GetObjectItemCaseSensitive(root, "replace");
    if (edits && replace)
        return ffd_fail(p->err, FFD_ERR_PARSE,
                        "%s: edits: a rig either edits its skeleton or replaces it, not both",
                        p->name);
    if (edits && (s = read_gffd_edits(p, edits, g)))
        return s;
    if (replace && (s = ffd_rig_read_skeleton(p, replace, "replace", &g->replace, &g->replace_count)))
        return s;
    if (replace && (s = list_skeleton_files(p, replace, rig)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "correspondences")) &&
        (s = read_correspondences(p, item, g)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "resample")) &&
        (s = read_resample(p, item, g)))
        return s;
    /* edits name primitives and vertices of the skeleton: check them now */
    for (size_t i = 0; i < g->edit_count; i++) {
        const ffd_rig_gffd_edit *e = &g->edits[i];
        if (e->all)
            continue;
        if (e->primitive >= g->skeleton_count)
            return ffd_fail(p->err, FFD_ERR_RANGE,
                            "%s: edits[%zu].primitive: %u out of range (the skeleton has %zu "
                            "primitive%s)",
                            p->name, i, e->primitive, g->skeleton_count,
                            g->skeleton_count == 1 ? "" : "s");
        size_t nv = g->skeleton[e->primitive].vertex_count;
        if (e->kind == FFD_RIG_EDIT_MOVE && e->vertex >= nv)
            return ffd_fail(p->err, FFD_ERR_RANGE,
                            "%s: edits[%zu].vertex: %u out of range (skeleton[%u] has %zu "
                            "vertices)",
                            p->name, i, e->vertex, e->primitive, nv);
        if (e->kind == FFD_RIG_EDIT_VERTICES && e->vertex_count != nv)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: edits[%zu].vertices: %zu vertices, but skeleton[%u] has %zu: an "
                            "edit keeps the skeleton's structure; to change it, use \"replace\" "
                            "with \"correspondences\"",
                            p->name, i, e->vertex_count, e->primitive, nv);
    }
    if (o->tracking == FFD_GFFD_TRACK_WARP && g->replace && !g->corr_count)
        return ffd_fail(p->err, FFD_ERR_INVALID,
                        "%s: replace: warp tracking after a skeleton replacement needs "
                        "\"correspondences\" (points of the old skeleton and where they go)",
                        p->name);
    return FFD_OK;
}

/* Checks that need several keys: resolution bounds for the basis, move indices. */
static ffd_status validate(const parser *p, const ffd_rig *rig)
{
    static const char *const basis_names[] = {"bspline", "bernstein"};
    uint32_t lo = ffd_basis_min_resolution(rig->basis);
    for (int a = 0; a < 3; a++) {
        uint32_t r = rig->resolution[a];
        if (r < lo)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: resolution[%d]: %u is below the minimum %u control points of "
                            "the %s basis",
                            p->name, a, r, lo, basis_names[rig->basis]);
        if (r > RIG_MAX_RESOLUTION)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: resolution[%d]: %u is above the maximum %u control points",
                            p->name, a, r, RIG_MAX_RESOLUTION);
    }
    for (size_t i = 0; i < rig->move_count; i++) {
        const uint32_t *ix = rig->moves[i].index;
        for (int a = 0; a < 3; a++)
            if (ix[a] >= rig->resolution[a])
                return ffd_fail(p->err, FFD_ERR_RANGE,
                                "%s: moves[%zu].index: [%u, %u, %u] out of range for a "
                                "%u x %u x %u lattice (indices start at 0)",
                                p->name, i, ix[0], ix[1], ix[2], rig->resolution[0],
                                rig->resolution[1], rig->resolution[2]);
    }
    return FFD_OK;
}

/* Keys of one deformer only; the other's are refused with a message naming it. */
static const char *const lattice_only[] = {"basis", "resolution", "box", "margin", "outside", NULL};
static const char *const pbffd_only[] = {"controls", "sigma",  "master", "levels",
                                         "frames",   "curves", "constraint_level", NULL};
static const char *const gffd_only[] = {"skeleton", "unit",    "tolerance",       "max_iterations",
                                        "tracking", "max_samples", "edits",       "replace",
                                        "correspondences", "resample", NULL};

static ffd_status read_root(const parser *p, const cJSON *root, ffd_rig *rig)
{
    static const char *const keys[] = {"version", "deformer", "basis",   "resolution", "box",
                                       "margin",  "outside",  "rcond",   "moves",
                                       "constraints", "controls", "sigma", "master", "levels",
                                       "frames",  "curves",   "constraint_level", NULL};
    static const char *const deformers[] = {"lattice", "pbffd", "gffd", NULL};
    static const char *const bases[] = {"bspline", "bernstein", NULL};
    static const char *const outsides[] = {"fixed", "clamp", "extrapolate", NULL};
    const cJSON *item;
    if (!cJSON_IsObject(root))
        return ffd_fail(p->err, FFD_ERR_PARSE, "%s: expected a JSON object at the top level",
                        p->name);
    const cJSON *which = cJSON_GetObjectItemCaseSensitive(root, "deformer");
    if (cJSON_IsString(which) && strcmp(which->valuestring, "gffd") == 0) {
        rig->deformer = FFD_RIG_GFFD;
        return read_gffd_root(p, root, rig);
    }
    if (cJSON_IsString(which) && strcmp(which->valuestring, "tspline") == 0) {
        rig->deformer = FFD_RIG_TSPLINE;
        return ffd_rig_read_tspline_root(p, root, rig);
    }
    cJSON_ArrayForEach(item, root)
    {
        if (ffd_rig_lookup(item->string, gffd_only) >= 0)
            return ffd_fail(p->err, FFD_ERR_PARSE,
                            "%s: %.64s: only for \"deformer\": \"gffd\" rigs", p->name,
                            item->string);
    }
    ffd_status s = ffd_rig_check_keys(p, root, "", keys,
                              "\"version\", \"deformer\", \"rcond\", \"moves\", \"constraints\", "
                              "lattice: \"basis\", \"resolution\", \"box\", \"margin\", "
                              "\"outside\"; pbffd: \"controls\", \"sigma\", \"master\", "
                              "\"levels\", \"frames\", \"curves\", \"constraint_level\"");
    if (s)
        return s;
    if ((s = ffd_rig_read_version(p, root)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "deformer"))) {
        int d = 0;
        if ((s = ffd_rig_read_enum(p, item, "deformer", deformers,
                           "\"lattice\", \"pbffd\", \"gffd\" or \"tspline\"", &d)))
            return s;
        rig->deformer = d ? FFD_RIG_PBFFD : FFD_RIG_LATTICE;
    }
    const char *const *foreign = rig->deformer == FFD_RIG_PBFFD ? lattice_only : pbffd_only;
    cJSON_ArrayForEach(item, root)
    {
        if (ffd_rig_lookup(item->string, foreign) >= 0)
            return ffd_fail(p->err, FFD_ERR_PARSE,
                            "%s: %.64s: only for \"deformer\": \"%s\" rigs (this rig's deformer "
                            "is \"%s\")",
                            p->name, item->string,
                            rig->deformer == FFD_RIG_PBFFD ? "lattice" : "pbffd",
                            rig->deformer == FFD_RIG_PBFFD ? "pbffd" : "lattice");
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "rcond"))) {
        if ((s = ffd_rig_read_number(p, item, "rcond", &rig->rcond)))
            return s;
        if (rig->rcond < 0 || rig->rcond >= 1)
            return ffd_rig_expected(p, "rcond", "a number in [0, 1) (0: the solver's default)");
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "constraints"))) {
        if ((s = ffd_rig_read_constraints(p, item, "constraints", &rig->constraints, &rig->constraint_count)))
            return s;
    }
    if (rig->deformer == FFD_RIG_PBFFD) {
        rig->pb.controls_auto = 1;
        cJSON_ArrayForEach(item, root)
        {
            if ((s = read_pbffd_key(p, item, rig)))
                return s;
        }
        return validate_pbffd(p, &rig->pb);
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "basis"))) {
        int b = 0;
        if ((s = ffd_rig_read_enum(p, item, "basis", bases, "\"bspline\" or \"bernstein\"", &b)))
            return s;
        rig->basis = b ? FFD_BASIS_BERNSTEIN : FFD_BASIS_BSPLINE;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "resolution"))) {
        if ((s = ffd_rig_read_uint3(p, item, "resolution", rig->resolution)))
            return s;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "box"))) {
        if ((s = read_box(p, item, rig)))
            return s;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "margin"))) {
        if ((s = ffd_rig_read_number(p, item, "margin", &rig->margin)))
            return s;
        if (rig->margin < 0)
            return ffd_rig_expected(p, "margin", "a number >= 0");
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "outside"))) {
        int o = 0;
        if ((s = ffd_rig_read_enum(p, item, "outside", outsides,
                           "\"fixed\", \"clamp\" or \"extrapolate\"", &o)))
            return s;
        rig->outside = o == 0 ? FFD_OUTSIDE_FIXED : o == 1 ? FFD_OUTSIDE_CLAMP
                                                           : FFD_OUTSIDE_EXTRAPOLATE;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "moves"))) {
        if ((s = read_moves(p, item, rig)))
            return s;
    }
    return validate(p, rig);
}

ffd_status ffd_rig_parse_json(const char *text, size_t size, const char *name, ffd_rig **out,
                              ffd_error *err)
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

    ffd_rig *rig = ffd_rig_new(name);
    if (!rig) {
        cJSON_Delete(root);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    }
    parser p = {name, err};
    ffd_status s = read_root(&p, root, rig);
    cJSON_Delete(root);
    if (s) {
        ffd_rig_destroy(rig);
        return s;
    }
    *out = rig;
    return FFD_OK;
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
