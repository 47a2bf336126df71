/* session_util — JSON helpers shared by the session's method files. */
#include "session/session.h"

#include <math.h>
#include <stdint.h>

#include <stdio.h>
#include <string.h>

/* The controls already named (ffd_sess_read_ids). */
typedef struct id_set {
    size_t count;        /* controls */
    unsigned char *seen; /* count */
} id_set;

static ffd_status read_control_id(const ffd_rig_parser *p, const cJSON *v, const char *where,
                                  void *element, void *ctx)
{
    id_set *set = ctx;
    if (!ffd_rig_is_uint32(v))
        return ffd_rig_expected(p, where, "a control id (a non-negative integer)");
    if ((size_t)v->valuedouble >= set->count)
        return ffd_fail(p->err, FFD_ERR_RANGE, "%s: %s: control %.0f out of range (%zu controls)",
                        p->name, where, v->valuedouble, set->count);
    if (set->seen[(size_t)v->valuedouble])
        return ffd_fail(p->err, FFD_ERR_INVALID, "%s: %s: control %.0f given twice", p->name,
                        where, v->valuedouble);
    set->seen[(size_t)v->valuedouble] = 1;
    *(uint32_t *)element = (uint32_t)v->valuedouble;
    return FFD_OK;
}

ffd_status ffd_sess_read_ids(const ffd_rig_parser *p, const cJSON *item, const char *path, size_t count,
                         uint32_t **ids, size_t *k)
{
    *ids = NULL;
    *k = 0;
    if (!cJSON_IsArray(item))
        return ffd_rig_expected(p, path, "an array of control ids");
    size_t m = (size_t)cJSON_GetArraySize(item);
    if (m == 0)
        return ffd_fail(p->err, FFD_ERR_INVALID, "%s: %s: expected at least one control id",
                        p->name, path);
    id_set set = {count, count ? ffd_calloc(count, 1) : NULL};
    if (count && !set.seen)
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory for %zu ids", p->name, m);
    void *read;
    ffd_status s = ffd_rig_read_array(p, item, path, "an array of control ids", sizeof **ids,
                                      read_control_id, NULL, &set, &read, k);
    ffd_free(set.seen);
    *ids = read;
    return s;
}

/* cJSON prints a double with 15 digits whenever they read back within an
 * epsilon, which is not always the same double; a rig must replay to the
 * same positions (a straight PB-FFD curve's frames turn with the last bit of
 * its points), so numbers are printed with 17 digits. */
cJSON *ffd_sess_number(double v)
{
    char text[40];
    snprintf(text, sizeof text, "%.17g", v);
    return cJSON_CreateRaw(text);
}

cJSON *ffd_sess_array(const double *v, size_t n)
{
    cJSON *a = cJSON_CreateArray();
    for (size_t i = 0; a && i < n; i++) {
        cJSON *x = ffd_sess_number(v[i]);
        if (!x || !cJSON_AddItemToArray(a, x)) {
            cJSON_Delete(x);
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}

cJSON *ffd_sess_vec3(const double v[3])
{
    return ffd_sess_array(v, 3);
}

cJSON *ffd_sess_matrix3(const double m[3][3])
{
    cJSON *a = cJSON_CreateArray();
    for (int r = 0; a && r < 3; r++) {
        cJSON *row = ffd_sess_vec3(m[r]);
        if (!row || !cJSON_AddItemToArray(a, row)) {
            cJSON_Delete(row);
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}

cJSON *ffd_sess_uint_array(const uint32_t *v, size_t n)
{
    cJSON *a = cJSON_CreateArray();
    for (size_t i = 0; a && i < n; i++) {
        cJSON *x = cJSON_CreateNumber(v[i]);
        if (!x || !cJSON_AddItemToArray(a, x)) {
            cJSON_Delete(x);
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}

int ffd_sess_add_edge(cJSON *edges, uint32_t a, uint32_t b)
{
    uint32_t e[2] = {a, b};
    cJSON *x = ffd_sess_uint_array(e, 2);
    if (!x || !cJSON_AddItemToArray(edges, x)) {
        cJSON_Delete(x);
        return 0;
    }
    return 1;
}

ffd_status ffd_sess_map_influence(const ffd_linear_map *map, int by_column, size_t n,
                              const uint32_t *ids, size_t k, float *w, ffd_error *err)
{
    size_t range = by_column ? map->column_count : map->variable_count;
    unsigned char *chosen = ffd_calloc(range ? range : 1, 1);
    uint32_t *cols = ffd_malloc_array(map->max_row_nnz ? map->max_row_nnz : 1, sizeof *cols);
    double *weights = ffd_malloc_array(map->max_row_nnz ? map->max_row_nnz : 1, sizeof *weights);
    if (!chosen || !cols || !weights) {
        ffd_free(chosen);
        ffd_free(cols);
        ffd_free(weights);
        return ffd_fail(err, FFD_ERR_NOMEM, "influence: out of memory");
    }
    for (size_t i = 0; i < k; i++)
        if (ids[i] < range)
            chosen[ids[i]] = 1;
    for (size_t i = 0; i < n && i < map->point_count; i++) {
        size_t nnz = map->row(map->self, i, cols, weights);
        double sum = 0;
        for (size_t e = 0; e < nnz; e++) {
            uint32_t v = by_column || !map->tie ? cols[e] : map->tie[cols[e]];
            if (v != FFD_TIE_FIXED && chosen[v])
                sum += weights[e];
        }
        w[i] = (float)(sum < 0 ? 0 : sum > 1 ? 1 : sum);
    }
    ffd_free(chosen);
    ffd_free(cols);
    ffd_free(weights);
    return FFD_OK;
}

ffd_status ffd_sess_clone_mesh(const ffd_mesh *mesh, ffd_mesh **out, ffd_error *err)
{
    /* A mesh made from arrays (ffd_mesh_create: no source file, no normals)
     * is its positions and faces: copied directly, not printed and parsed
     * (for 1M points the text round trip took seconds). */
    if (ffd_mesh_source_format(mesh) == FFD_FORMAT_AUTO && ffd_mesh_cell_count(mesh))
        return ffd_mesh_create_cells(ffd_mesh_positions(mesh), ffd_mesh_vertex_count(mesh),
                                     ffd_mesh_cell_types(mesh), ffd_mesh_cell_offsets(mesh),
                                     ffd_mesh_cell_indices(mesh), ffd_mesh_cell_count(mesh), out,
                                     err);
    if (ffd_mesh_source_format(mesh) == FFD_FORMAT_AUTO && ffd_mesh_normal_count(mesh) == 0)
        return ffd_mesh_create(ffd_mesh_positions(mesh), ffd_mesh_vertex_count(mesh),
                               ffd_mesh_face_offsets(mesh), ffd_mesh_face_indices(mesh),
                               ffd_mesh_face_count(mesh), out, err);
    ffd_write_options o = {ffd_mesh_source_format(mesh), FFD_ENCODING_SAME, 0};
    if (o.format == FFD_FORMAT_AUTO)
        o.format = FFD_FORMAT_PLY;
    unsigned char *data = NULL;
    size_t size = 0;
    ffd_status st = ffd_mesh_write_memory(mesh, &o, &data, &size, err);
    if (!st)
        st = ffd_mesh_read_memory(data, size, o.format, "mesh", out, err);
    ffd_free(data);
    return st;
}

ffd_status ffd_sess_apply_rig(const sess_ctx *ctx, const ffd_rig *rig, ffd_rig_report *report,
                          ffd_error *err)
{
    /* the method's own part: the generic layers wrap the method's deformer
     * built from it (deformer/layers.c), they are not applied twice */
    ffd_rig own = *rig;
    own.layers = NULL;
    ffd_mesh *copy = NULL;
    ffd_status st = ffd_sess_clone_mesh(ctx->mesh, &copy, err);
    if (!st)
        st = ffd_rig_apply_limited(&own, copy, &ctx->limits, report, err);
    ffd_mesh_destroy(copy);
    return st;
}

int ffd_sess_add_item(cJSON *object, const char *key, cJSON *item)
{
    if (!item || !cJSON_AddItemToObject(object, key, item)) {
        cJSON_Delete(item);
        return 0;
    }
    return 1;
}

int ffd_sess_add_to_array(cJSON *array, cJSON *item)
{
    if (!item || !cJSON_AddItemToArray(array, item)) {
        cJSON_Delete(item);
        return 0;
    }
    return 1;
}

void ffd_sess_ctx_init(sess_ctx *ctx, const ffd_mesh *mesh, size_t max_controls,
                   const ffd_limits *limits)
{
    memset(ctx, 0, sizeof *ctx);
    ctx->mesh = mesh;
    ctx->n = ffd_mesh_vertex_count(mesh);
    ctx->rest = ffd_mesh_positions(mesh);
    for (int a = 0; a < 3; a++) {
        ctx->min[a] = INFINITY;
        ctx->max[a] = -INFINITY;
    }
    for (size_t i = 0; i < ctx->n; i++)
        for (int a = 0; a < 3; a++) {
            double v = ctx->rest[3 * i + a];
            ctx->min[a] = v < ctx->min[a] ? v : ctx->min[a];
            ctx->max[a] = v > ctx->max[a] ? v : ctx->max[a];
        }
    double d2 = 0;
    for (int a = 0; a < 3; a++)
        d2 += (ctx->max[a] - ctx->min[a]) * (ctx->max[a] - ctx->min[a]);
    ctx->diag = d2 > 0 ? sqrt(d2) : 1;
    ctx->max_controls = max_controls ? max_controls : SIZE_MAX;
    if (limits)
        ctx->limits = *limits;
}

ffd_status ffd_sess_check_controls(const sess_ctx *ctx, double count, const char *what,
                               ffd_error *err)
{
    if (count > (double)ctx->max_controls)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: %.0f control points: more than the editor's limit of %zu", what,
                        count, ctx->max_controls);
    return FFD_OK;
}

ffd_status ffd_sess_rig_text(const sess_method *m, char **text, ffd_error *err)
{
    cJSON *root = cJSON_CreateObject();
    if (!root || !cJSON_AddNumberToObject(root, "version", 1) ||
        !cJSON_AddStringToObject(root, "deformer", ffd_sess_caps(m)->name)) {
        cJSON_Delete(root);
        return ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
    }
    ffd_status st = m->vt->rig(m, root, err);
    if (!st) {
        char *printed = cJSON_Print(root);
        *text = printed ? ffd_strdup(printed) : NULL;
        cJSON_free(printed);
        if (!*text)
            st = ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
    }
    cJSON_Delete(root);
    return st;
}

ffd_status ffd_sess_parse_body(const char *op, const char *body, size_t size, cJSON **doc,
                               ffd_error *err)
{
    *doc = NULL;
    cJSON *d = NULL;
    if (body && size) {
        const char *end = NULL;
        ffd_status nul = ffd_json_refuse_nul(body, size, op, err);
        if (nul)
            return nul;
        unsigned long oom = ffd_json_alloc_failures();
        d = cJSON_ParseWithLengthOpts(body, size, &end, 0);
        if (!d && ffd_json_alloc_failures() != oom)
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory parsing JSON", op);
        while (d && end < body + size && (*end == ' ' || *end == '\t' || *end == '\n' ||
                                          *end == '\r'))
            end++;
        if (!d || end != body + size) {
            size_t at = end && end >= body ? (size_t)(end - body) : 0;
            const char *why = d ? " (text after the value)" : "";
            cJSON_Delete(d);
            return ffd_fail(err, FFD_ERR_PARSE, "%s: malformed JSON at byte %zu%s", op, at, why);
        }
    } else if (!(d = cJSON_CreateObject()))
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", op);
    if (!cJSON_IsObject(d)) {
        cJSON_Delete(d);
        return ffd_fail(err, FFD_ERR_PARSE, "%s: expected a JSON object", op);
    }
    *doc = d;
    return FFD_OK;
}
