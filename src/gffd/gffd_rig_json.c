/* rig_json_gffd — "deformer": "gffd" rigs (docs/rig.md, "GFFD rigs";
 * docs/gffd.md): generalized FFD (Yoon & Kim), a skeleton of primitives
 * (points, polylines, patches, polyhedra; given or read from files), the
 * field's options, and the skeleton's change — edits (§5, first way) or a
 * replacement with correspondences (second way). The GFFD section reader in
 * the method registry (ffd_method_gffd.parse). */
#include "gffd/gffd_method.h"
#include "rig/rig_json.h"

#include <stdio.h>
#include <string.h>

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
static ffd_status list_skeleton_files(const ffd_rig_parser *p, const cJSON *array, ffd_rig *rig)
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

/* Faces [[i,j,k,...], ...] as offsets and indices. */
static ffd_status read_faces(const ffd_rig_parser *p, const cJSON *item, const char *path,
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

ffd_status ffd_rig_read_primitive(const ffd_rig_parser *p, const cJSON *item, const char *path,
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
        char list[RIG_PATH_MAX + 64]; /* the top-level key: "skeleton", "replace" */
        snprintf(list, sizeof list, "%.*s", (int)strcspn(path, "[."), path);
        if ((s = ffd_rig_check_input(p, list, file->valuestring, resolved))) {
            ffd_free(resolved);
            return s;
        }
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
    if ((s = ffd_rig_read_points(p, verts, sub, min, &prim->vertices, &prim->vertex_count)))
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

static ffd_status read_primitive_element(const ffd_rig_parser *p, const cJSON *item,
                                         const char *path, void *element, void *ctx)
{
    (void)ctx;
    return ffd_rig_read_primitive(p, item, path, element);
}

static void primitive_free(void *element)
{
    ffd_rig_primitive_free(element);
}

ffd_status ffd_rig_read_skeleton(const ffd_rig_parser *p, const cJSON *item, const char *key,
                                 ffd_rig_primitive **out, size_t *count)
{
    static const char what[] = "an array of at least one primitive {\"type\": ..., \"radius\": "
                               "r, ...}";
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) < 1)
        return ffd_rig_expected(p, key, what);
    void *prims;
    ffd_status s = ffd_rig_read_array(p, item, key, what, sizeof **out, read_primitive_element,
                                      primitive_free, NULL, &prims, count);
    *out = prims;
    return s;
}

static ffd_status read_gffd_edit(const ffd_rig_parser *p, const cJSON *m, const char *path,
                                 void *element, void *ctx)
{
    ffd_rig_gffd_edit *e = element;
    (void)ctx;
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
        return ffd_rig_read_points(p, v, sub, 1, &e->vertices, &e->vertex_count);
    }
}

static void gffd_edit_free(void *element)
{
    ffd_free(((ffd_rig_gffd_edit *)element)->vertices);
}

static ffd_status read_gffd_edits(const ffd_rig_parser *p, const cJSON *item, ffd_rig_gffd *g)
{
    void *edits;
    ffd_status s = ffd_rig_read_array(p, item, "edits", "an array of skeleton edits",
                                      sizeof *g->edits, read_gffd_edit, gffd_edit_free, NULL,
                                      &edits, &g->edit_count);
    g->edits = edits;
    return s;
}

/* A user correspondence: a point of the rest skeleton and where it goes. */
typedef struct correspondence {
    double from[3], to[3];
} correspondence;

static const char correspondences_what[] = "an array of {\"from\": [x,y,z], \"to\": [x,y,z]}";

static ffd_status read_correspondence(const ffd_rig_parser *p, const cJSON *c, const char *path,
                                      void *element, void *ctx)
{
    static const char *const keys[] = {"from", "to", NULL};
    correspondence *corr = element;
    char sub[RIG_PATH_MAX + 72];
    (void)ctx;
    if (!cJSON_IsObject(c))
        return ffd_rig_expected(p, path, correspondences_what + 12);
    ffd_status s = ffd_rig_check_keys(p, c, path, keys, "\"from\", \"to\"");
    if (s)
        return s;
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(c, "from");
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(c, "to");
    snprintf(sub, sizeof sub, "%s.from", path);
    if (!f)
        return ffd_rig_expected(p, sub, "a point [x,y,z] on the rest skeleton (missing)");
    if ((s = ffd_rig_read_vec3(p, f, sub, corr->from)))
        return s;
    snprintf(sub, sizeof sub, "%s.to", path);
    if (!t)
        return ffd_rig_expected(p, sub, "a point [x,y,z] on the new skeleton (missing)");
    return ffd_rig_read_vec3(p, t, sub, corr->to);
}

static ffd_status read_correspondences(const ffd_rig_parser *p, const cJSON *item, ffd_rig_gffd *g)
{
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) < 1)
        return ffd_rig_expected(p, "correspondences", correspondences_what);
    void *read;
    size_t n;
    ffd_status s = ffd_rig_read_array(p, item, "correspondences", correspondences_what,
                                      sizeof(correspondence), read_correspondence, NULL, NULL,
                                      &read, &n);
    if (s)
        return s;
    const correspondence *corr = read;
    g->corr_from = ffd_malloc_array(n, 3 * sizeof(double));
    g->corr_to = ffd_malloc_array(n, 3 * sizeof(double));
    if (g->corr_from && g->corr_to) {
        for (size_t i = 0; i < n; i++) {
            memcpy(g->corr_from + 3 * i, corr[i].from, sizeof corr[i].from);
            memcpy(g->corr_to + 3 * i, corr[i].to, sizeof corr[i].to);
        }
        g->corr_count = n;
    }
    ffd_free(read);
    return g->corr_count ? FFD_OK : ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
}

static ffd_status read_resample(const ffd_rig_parser *p, const cJSON *item, ffd_rig_gffd *g)
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

const char *const ffd_rig_keys_gffd[] = {"skeleton", "unit", "tolerance", "max_iterations", "tracking", "max_samples", "edits", "replace", "correspondences", "resample", NULL};

ffd_status ffd_rig_parse_gffd(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    static const char *const trackings[] = {"gradient", "warp", NULL};
    ffd_rig_gffd *g = ffd_rig_gffd_of(rig);
    const cJSON *item;
    ffd_status s = ffd_rig_check_deformer_root(p, root, &ffd_method_gffd);
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

/* ======================================================================
 * Writer: the section as the reader above reads it
 * ====================================================================== */

static const char *const kind_names[] = {"point", "polyline", "patch", "polyhedron", NULL};

const char *ffd_rig_gffd_kind_name(ffd_gffd_kind kind)
{
    return kind_names[kind];
}

static cJSON *points_json(const double *v, size_t n)
{
    cJSON *a = cJSON_CreateArray();
    for (size_t i = 0; a && i < n; i++)
        if (!ffd_sess_add_to_array(a, ffd_sess_array(v + 3 * i, 3))) {
            cJSON_Delete(a);
            return NULL;
        }
    return a;
}

cJSON *ffd_rig_gffd_faces_json(const ffd_rig_primitive *p, size_t offset)
{
    cJSON *a = cJSON_CreateArray();
    for (size_t f = 0; a && f < p->face_count; f++) {
        cJSON *face = cJSON_CreateArray();
        int ok = ffd_sess_add_to_array(a, face);
        for (uint32_t c = p->face_offsets[f]; ok && c < p->face_offsets[f + 1]; c++)
            ok = ffd_sess_add_to_array(face, cJSON_CreateNumber((double)(offset + p->face_indices[c])));
        if (!ok) {
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}

/* A primitive with its geometry inline (a "file" was read into it). */
static cJSON *primitive_json(const ffd_rig_primitive *p)
{
    cJSON *o = cJSON_CreateObject();
    int ok = o && cJSON_AddStringToObject(o, "type", kind_names[p->kind]) &&
             ffd_sess_add_item(o, "radius", ffd_sess_number(p->radius));
    if (ok && p->kind == FFD_GFFD_POINT)
        ok = ffd_sess_add_item(o, "position", ffd_sess_array(p->vertices, 3));
    else if (ok)
        ok = ffd_sess_add_item(o, "vertices", points_json(p->vertices, p->vertex_count)) &&
             (!p->face_count || ffd_sess_add_item(o, "faces", ffd_rig_gffd_faces_json(p, 0)));
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

static int add_skeleton(cJSON *root, const char *key, const ffd_rig_primitive *p, size_t count)
{
    cJSON *a = cJSON_AddArrayToObject(root, key);
    int ok = a != NULL;
    for (size_t i = 0; ok && i < count; i++)
        ok = ffd_sess_add_to_array(a, primitive_json(&p[i]));
    return ok;
}

static int add_options(cJSON *root, const ffd_gffd_options *o)
{
    return (!(o->unit > 0) || ffd_sess_add_item(root, "unit", ffd_sess_number(o->unit))) &&
           cJSON_AddStringToObject(root, "tracking",
                                   o->tracking == FFD_GFFD_TRACK_WARP ? "warp" : "gradient") &&
           (!(o->tolerance > 0) || ffd_sess_add_item(root, "tolerance", ffd_sess_number(o->tolerance))) &&
           (!o->max_iterations ||
            cJSON_AddNumberToObject(root, "max_iterations", o->max_iterations)) &&
           (!o->max_samples ||
            cJSON_AddNumberToObject(root, "max_samples", (double)o->max_samples));
}

static cJSON *edit_json(const ffd_rig_gffd_edit *d)
{
    cJSON *e = cJSON_CreateObject(), *r = NULL;
    int ok = e && (d->all ? cJSON_AddStringToObject(e, "primitive", "all") != NULL
                          : cJSON_AddNumberToObject(e, "primitive", (double)d->primitive) != NULL);
    switch (d->kind) {
    case FFD_RIG_EDIT_ROTATE:
        ok = ok && (r = cJSON_AddObjectToObject(e, "rotate")) &&
             ffd_sess_add_item(r, "axis", ffd_sess_array(d->axis, 3)) &&
             ffd_sess_add_item(r, "angle", ffd_sess_number(d->angle));
        break;
    case FFD_RIG_EDIT_TRANSLATE:
        ok = ok && ffd_sess_add_item(e, "translate", ffd_sess_array(d->delta, 3));
        break;
    case FFD_RIG_EDIT_SCALE:
        ok = ok && ffd_sess_add_item(e, "scale", ffd_sess_array(d->scale, 3));
        break;
    case FFD_RIG_EDIT_MOVE:
        ok = ok && cJSON_AddNumberToObject(e, "vertex", (double)d->vertex) &&
             ffd_sess_add_item(e, "move", ffd_sess_array(d->delta, 3));
        break;
    default:
        ok = ok && ffd_sess_add_item(e, "vertices", points_json(d->vertices, d->vertex_count));
    }
    ok = ok && (!d->has_center || ffd_sess_add_item(e, "center", ffd_sess_array(d->center, 3)));
    if (!ok) {
        cJSON_Delete(e);
        return NULL;
    }
    return e;
}

static cJSON *correspondences_json(const ffd_rig_gffd *g)
{
    cJSON *a = cJSON_CreateArray();
    for (size_t i = 0; a && i < g->corr_count; i++) {
        cJSON *o = cJSON_CreateObject();
        if (!ffd_sess_add_to_array(a, o) ||
            !ffd_sess_add_item(o, "from", ffd_sess_array(g->corr_from + 3 * i, 3)) ||
            !ffd_sess_add_item(o, "to", ffd_sess_array(g->corr_to + 3 * i, 3))) {
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}

static int add_resample(cJSON *root, const ffd_rig_gffd *g)
{
    const ffd_gffd_resample_options *o = &g->resample_options;
    if (!o->ratio && !o->max_rounds && !o->max_vertices)
        return cJSON_AddBoolToObject(root, "resample", g->resample != 0) != NULL;
    cJSON *r = cJSON_AddObjectToObject(root, "resample");
    return r && (!o->ratio || ffd_sess_add_item(r, "ratio", ffd_sess_number(o->ratio))) &&
           (!o->max_rounds || cJSON_AddNumberToObject(r, "max_rounds", o->max_rounds)) &&
           (!o->max_vertices || cJSON_AddNumberToObject(r, "max_vertices", (double)o->max_vertices));
}

int ffd_rig_write_gffd(const ffd_rig *rig, cJSON *root)
{
    const ffd_rig_gffd *g = ffd_rig_gffd_of(rig);
    cJSON *edits = NULL;
    int ok = add_skeleton(root, "skeleton", g->skeleton, g->skeleton_count) &&
             add_options(root, &g->options) &&
             (g->replace_count || (edits = cJSON_AddArrayToObject(root, "edits"))) &&
             (!g->corr_count || ffd_sess_add_item(root, "correspondences", correspondences_json(g))) &&
             (!g->replace_count || add_skeleton(root, "replace", g->replace, g->replace_count)) &&
             (!g->resample || add_resample(root, g));
    for (size_t i = 0; ok && edits && i < g->edit_count; i++)
        ok = ffd_sess_add_to_array(edits, edit_json(&g->edits[i]));
    return ok;
}

void ffd_rig_release_gffd(ffd_rig *rig)
{
    ffd_rig_gffd *g = ffd_rig_gffd_of(rig);
    if (!g)
        return;
    for (size_t i = 0; i < g->skeleton_count; i++)
        ffd_rig_primitive_free(&g->skeleton[i]);
    ffd_free(g->skeleton);
    for (size_t i = 0; i < g->replace_count; i++)
        ffd_rig_primitive_free(&g->replace[i]);
    ffd_free(g->replace);
    for (size_t i = 0; i < g->edit_count; i++)
        ffd_free(g->edits[i].vertices);
    ffd_free(g->edits);
    ffd_free(g->corr_from);
    ffd_free(g->corr_to);
}
