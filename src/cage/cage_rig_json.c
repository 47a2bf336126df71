/* cage_rig_json — "deformer": "cage" rigs (docs/cage.md): the cage (a mesh
 * file any reader of the library reads, inline vertices and faces, or
 * "auto"), its coordinates (mean value, Ju et al. 2005; harmonic, Joshi et
 * al. 2007) with the harmonic grid's resolution and the outside rule, the
 * cage vertices' moves (or a deformed cage file of the same connectivity),
 * and the constraints of direct manipulation. The section reader, writer
 * and release of the method registry (ffd_method_cage). */
#include "cage/cage_method.h"
#include "rig/rig_json.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *const ffd_rig_keys_cage[] = {"cage", "margin", "coordinates", "resolution", "outside",
                                         "moves", "deformed", NULL};

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

/* The faces (offsets, indices; nf faces over nv vertices) fan-triangulated
 * into the section; FFD_ERR_RANGE naming the face of an index >= nv. */
static ffd_status triangulate(const ffd_rig_parser *p, const char *key, const uint32_t *off,
                              const uint32_t *idx, size_t nf, size_t nv, ffd_rig_cage *c)
{
    size_t nt = 0;
    for (size_t f = 0; f < nf; f++) {
        if (off[f + 1] - off[f] < 3)
            return ffd_fail(p->err, FFD_ERR_INVALID, "%s: %s: face %zu has %u corners, expected "
                            ">= 3", p->name, key, f, off[f + 1] - off[f]);
        nt += off[f + 1] - off[f] - 2;
    }
    c->triangles = ffd_malloc_array(nt ? nt : 1, 3 * sizeof(uint32_t));
    c->face_of = ffd_malloc_array(nt ? nt : 1, sizeof(uint32_t));
    if (!c->triangles || !c->face_of)
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    size_t t = 0;
    for (size_t f = 0; f < nf; f++)
        for (uint32_t k = off[f] + 1; k + 1 < off[f + 1]; k++, t++) {
            const uint32_t v[3] = {idx[off[f]], idx[k], idx[k + 1]};
            for (int a = 0; a < 3; a++) {
                if (v[a] >= nv)
                    return ffd_fail(p->err, FFD_ERR_RANGE, "%s: %s: face %zu: vertex index %u "
                                    "out of range (%zu vertices)", p->name, key, f, v[a], nv);
                c->triangles[3 * t + a] = v[a];
            }
            c->face_of[t] = (uint32_t)f;
        }
    c->triangle_count = nt;
    return FFD_OK;
}

/* STL keeps no shared vertices: corners at the same position are one vertex. */
typedef struct weld_key {
    const double *p;
    uint32_t i;
} weld_key;

static int weld_cmp(const void *pa, const void *pb)
{
    const weld_key *a = pa, *b = pb;
    for (int k = 0; k < 3; k++)
        if (a->p[k] != b->p[k])
            return a->p[k] < b->p[k] ? -1 : 1;
    return a->i < b->i ? -1 : a->i > b->i;
}

/* Reads a cage mesh file (resolved) into vertices and faces of the section. */
static ffd_status read_cage_file(const ffd_rig_parser *p, const char *key, const char *resolved,
                                 ffd_rig_cage *c)
{
    ffd_mesh *m = NULL;
    ffd_error inner = {{0}};
    ffd_status s = ffd_mesh_read(resolved, &m, &inner);
    if (s)
        return ffd_fail(p->err, s, "%s: %s: %s", p->name, key, inner.message);
    size_t nv = ffd_mesh_vertex_count(m), nf = ffd_mesh_face_count(m);
    const double *pos = ffd_mesh_positions(m);
    uint32_t *map = NULL;
    weld_key *keys = NULL;
    if (nf == 0) {
        s = ffd_fail(p->err, FFD_ERR_INVALID, "%s: %s: %s has no faces: a cage is a closed "
                     "triangle mesh", p->name, key, resolved);
        goto done;
    }
    c->vertices = ffd_malloc_array(nv, 3 * sizeof(double));
    map = ffd_malloc_array(nv, sizeof *map);
    if (!c->vertices || !map) {
        s = ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        goto done;
    }
    size_t kept = 0;
    if (ffd_format_from_path(resolved) == FFD_FORMAT_STL) {
        if (!(keys = ffd_malloc_array(nv, sizeof *keys))) {
            s = ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
            goto done;
        }
        for (size_t i = 0; i < nv; i++)
            keys[i] = (weld_key){pos + 3 * i, (uint32_t)i};
        qsort(keys, nv, sizeof *keys, weld_cmp);
        /* the welded vertices keep the order of their first corner */
        for (size_t i = 0; i < nv; i++)
            map[i] = UINT32_MAX;
        for (size_t a = 0; a < nv;) {
            size_t b = a + 1;
            while (b < nv && !memcmp(keys[b].p, keys[a].p, 3 * sizeof(double)))
                b++;
            for (size_t q = a; q < b; q++)
                map[keys[q].i] = keys[a].i; /* the lowest index of the group */
            a = b;
        }
        for (size_t i = 0; i < nv; i++)
            if (map[i] == i) {
                memcpy(c->vertices + 3 * kept, pos + 3 * i, 3 * sizeof(double));
                map[i] = (uint32_t)kept++;
            } else {
                map[i] = map[map[i]];
            }
    } else {
        memcpy(c->vertices, pos, nv * 3 * sizeof(double));
        for (size_t i = 0; i < nv; i++)
            map[i] = (uint32_t)i;
        kept = nv;
    }
    c->vertex_count = kept;
    const uint32_t *off = ffd_mesh_face_offsets(m), *idx = ffd_mesh_face_indices(m);
    uint32_t *mapped = ffd_malloc_array(off[nf] ? off[nf] : 1, sizeof *mapped);
    if (!mapped) {
        s = ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        goto done;
    }
    for (uint32_t k = 0; k < off[nf]; k++)
        mapped[k] = map[idx[k]];
    s = triangulate(p, key, off, mapped, nf, kept, c);
    ffd_free(mapped);
done:
    ffd_free(map);
    ffd_free(keys);
    ffd_mesh_destroy(m);
    return s;
}

/* A file the rig names: resolved, checked against the file policy, listed
 * in the rig's input files; *out ffd_free'd by the caller. */
static ffd_status input_file(const ffd_rig_parser *p, ffd_rig *rig, const char *key,
                             const char *file, char **out)
{
    char *resolved = resolve_path(p->name, file);
    char **files = resolved ? ffd_realloc_array(rig->input_files, rig->input_file_count + 1,
                                                sizeof *files)
                            : NULL;
    if (!files) {
        ffd_free(resolved);
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    }
    rig->input_files = files;
    ffd_status s = ffd_rig_check_input(p, key, file, resolved);
    if (s) {
        ffd_free(resolved);
        return s;
    }
    if (!(files[rig->input_file_count] = ffd_strdup(resolved))) {
        ffd_free(resolved);
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    }
    rig->input_file_count++;
    *out = resolved;
    return FFD_OK;
}

/* Inline faces: an array of arrays of >= 3 vertex indices. */
static ffd_status read_faces(const ffd_rig_parser *p, const cJSON *item, size_t nv,
                             ffd_rig_cage *c)
{
    static const char what[] = "an array of faces, each an array of >= 3 vertex indices";
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) < 1)
        return ffd_rig_expected(p, "cage.faces", what);
    size_t nf = (size_t)cJSON_GetArraySize(item), corners = 0;
    const cJSON *f, *v;
    cJSON_ArrayForEach(f, item)
    {
        if (!cJSON_IsArray(f) || cJSON_GetArraySize(f) < 3)
            return ffd_rig_expected(p, "cage.faces", what);
        corners += (size_t)cJSON_GetArraySize(f);
    }
    uint32_t *off = ffd_malloc_array(nf + 1, sizeof *off);
    uint32_t *idx = ffd_malloc_array(corners, sizeof *idx);
    ffd_status s = FFD_OK;
    if (!off || !idx || corners > UINT32_MAX) {
        s = ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        goto done;
    }
    size_t fi = 0, k = 0;
    off[0] = 0;
    cJSON_ArrayForEach(f, item)
    {
        cJSON_ArrayForEach(v, f)
        {
            char path[RIG_PATH_MAX];
            snprintf(path, sizeof path, "cage.faces[%zu]", fi);
            if ((s = ffd_rig_read_index(p, v, path, "an array of >= 3 vertex indices", &idx[k])))
                goto done;
            k++;
        }
        off[++fi] = (uint32_t)k;
    }
    s = triangulate(p, "cage.faces", off, idx, nf, nv, c);
done:
    ffd_free(off);
    ffd_free(idx);
    return s;
}

static ffd_status read_cage(const ffd_rig_parser *p, const cJSON *item, ffd_rig *rig,
                            ffd_rig_cage *c)
{
    static const char what[] = "a cage mesh file, \"auto\", or {\"vertices\": [[x,y,z], ...], "
                               "\"faces\": [[i,j,k], ...]}";
    if (cJSON_IsString(item)) {
        if (!item->valuestring[0])
            return ffd_rig_expected(p, "cage", what);
        if (!strcmp(item->valuestring, "auto")) {
            c->cage_auto = 1;
            return FFD_OK;
        }
        char *resolved = NULL;
        ffd_status s = input_file(p, rig, "cage", item->valuestring, &resolved);
        if (!s && !(c->file = ffd_strdup(item->valuestring)))
            s = ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        if (!s)
            s = read_cage_file(p, "cage", resolved, c);
        ffd_free(resolved);
        return s;
    }
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, "cage", what);
    static const char *const keys[] = {"vertices", "faces", NULL};
    ffd_status s = ffd_rig_check_keys(p, item, "cage", keys, "\"vertices\", \"faces\"");
    if (s)
        return s;
    const cJSON *verts = cJSON_GetObjectItemCaseSensitive(item, "vertices");
    const cJSON *faces = cJSON_GetObjectItemCaseSensitive(item, "faces");
    if (!verts)
        return ffd_rig_expected(p, "cage.vertices", "an array of at least 4 points (missing)");
    if (!faces)
        return ffd_rig_expected(p, "cage.faces", "an array of faces (missing)");
    if ((s = ffd_rig_read_points(p, verts, "cage.vertices", 4, &c->vertices, &c->vertex_count)))
        return s;
    return read_faces(p, faces, c->vertex_count, c);
}

/* "deformed": the cage file moved: same vertices and faces, read as moves. */
static ffd_status read_deformed(const ffd_rig_parser *p, const cJSON *item, ffd_rig *rig,
                                ffd_rig_cage *c)
{
    if (!cJSON_IsString(item) || !item->valuestring[0])
        return ffd_rig_expected(p, "deformed", "a cage mesh file");
    if (!c->vertices || c->cage_auto)
        return ffd_rig_expected(p, "deformed", "a \"cage\" given as a file or inline (the "
                                "deformed cage of an \"auto\" cage has no file)");
    char *resolved = NULL;
    ffd_rig_cage d = {0};
    ffd_status s = input_file(p, rig, "deformed", item->valuestring, &resolved);
    if (!s)
        s = read_cage_file(p, "deformed", resolved, &d);
    if (!s && (d.vertex_count != c->vertex_count || d.triangle_count != c->triangle_count ||
               memcmp(d.triangles, c->triangles, 3 * d.triangle_count * sizeof(uint32_t))))
        s = ffd_fail(p->err, FFD_ERR_INVALID,
                     "%s: deformed: %s has %zu vertices and %zu triangles, not the cage's "
                     "connectivity (%zu vertices, %zu triangles, the same faces in the same "
                     "order)", p->name, resolved, d.vertex_count, d.triangle_count,
                     c->vertex_count, c->triangle_count);
    size_t moved = 0;
    for (size_t i = 0; !s && i < c->vertex_count; i++)
        moved += memcmp(d.vertices + 3 * i, c->vertices + 3 * i, 3 * sizeof(double)) != 0;
    if (!s && moved && !(c->moves = ffd_malloc_array(moved, sizeof *c->moves)))
        s = ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    for (size_t i = 0; !s && i < c->vertex_count; i++) {
        if (!memcmp(d.vertices + 3 * i, c->vertices + 3 * i, 3 * sizeof(double)))
            continue;
        ffd_rig_cage_move *m = &c->moves[c->move_count++];
        m->index = (uint32_t)i;
        for (int a = 0; a < 3; a++)
            m->delta[a] = d.vertices[3 * i + a] - c->vertices[3 * i + a];
    }
    ffd_free(resolved);
    ffd_free(d.vertices);
    ffd_free(d.triangles);
    ffd_free(d.face_of);
    return s;
}

ffd_status ffd_rig_parse_cage(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    static const char *const coords[] = {"mean_value", "harmonic", NULL};
    static const char *const outsides[] = {"extend", "fixed", "clamp", NULL};
    ffd_rig_cage *c = ffd_rig_cage_of(rig);
    const cJSON *item;
    c->margin = 0.05;
    ffd_status s = ffd_rig_read_linear_root(p, root, rig);
    if (s)
        return s;
    if (!(item = cJSON_GetObjectItemCaseSensitive(root, "cage")))
        return ffd_rig_expected(p, "cage", "a cage mesh file, \"auto\", or {\"vertices\", "
                                "\"faces\"} (missing)");
    if ((s = read_cage(p, item, rig, c)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "margin"))) {
        if (!c->cage_auto)
            return ffd_rig_expected(p, "margin", "no margin: it is for \"cage\": \"auto\"");
        if ((s = ffd_rig_read_number(p, item, "margin", &c->margin)))
            return s;
        if (c->margin < 0)
            return ffd_rig_expected(p, "margin", "a number >= 0");
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "coordinates"))) {
        int k = 0;
        if ((s = ffd_rig_read_enum(p, item, "coordinates", coords,
                                   "\"mean_value\" or \"harmonic\"", &k)))
            return s;
        c->options.coordinates = k ? FFD_CAGE_HARMONIC : FFD_CAGE_MEAN_VALUE;
    }
    const int harmonic = c->options.coordinates == FFD_CAGE_HARMONIC;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "resolution"))) {
        if (!harmonic)
            return ffd_rig_expected(p, "resolution", "no resolution: it is the grid of "
                                    "\"coordinates\": \"harmonic\"");
        if ((s = ffd_rig_read_index(p, item, "resolution", "an integer", &c->options.resolution)))
            return s;
        if (c->options.resolution < 4 || c->options.resolution > FFD_CAGE_RESOLUTION_MAX)
            return ffd_fail(p->err, FFD_ERR_INVALID, "%s: resolution: %u out of range: expected "
                            "4 to %u grid cells along the cage's longest side", p->name,
                            c->options.resolution, FFD_CAGE_RESOLUTION_MAX);
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "outside"))) {
        int k = 0;
        if ((s = ffd_rig_read_enum(p, item, "outside", outsides,
                                   "\"extend\", \"fixed\" or \"clamp\"", &k)))
            return s;
        c->options.outside = k == 0 ? FFD_CAGE_OUTSIDE_EXTEND
                             : k == 1 ? FFD_CAGE_OUTSIDE_FIXED
                                      : FFD_CAGE_OUTSIDE_CLAMP;
        if (harmonic && k == 0)
            return ffd_rig_expected(p, "outside", "\"fixed\" or \"clamp\" (harmonic coordinates "
                                    "are not defined outside the cage)");
    }
    const cJSON *moves = cJSON_GetObjectItemCaseSensitive(root, "moves");
    const cJSON *deformed = cJSON_GetObjectItemCaseSensitive(root, "deformed");
    if (moves && deformed)
        return ffd_rig_expected(p, "deformed", "either \"moves\" or \"deformed\", not both");
    if (moves) {
        void *out;
        s = ffd_rig_read_array(p, moves, "moves", "an array of {\"index\": i, \"delta\": "
                               "[dx,dy,dz]}", sizeof *c->moves, ffd_rig_read_point_move, NULL,
                               (void *)"a cage vertex index", &out,
                               &c->move_count);
        c->moves = out;
        if (s)
            return s;
    }
    if (deformed && (s = read_deformed(p, deformed, rig, c)))
        return s;
    size_t nv = c->cage_auto ? CAGE_AUTO_VERTICES : c->vertex_count;
    for (size_t i = 0; i < c->move_count; i++)
        if (c->moves[i].index >= nv)
            return ffd_fail(p->err, FFD_ERR_RANGE, "%s: moves[%zu].index: %u out of range (the "
                            "cage has %zu vertices; indices start at 0)", p->name, i,
                            c->moves[i].index, nv);
    return FFD_OK;
}

/* The writer (ffd_method.write): the cage inline (or "auto" with its
 * margin), the coordinates, and the moves, as the reader above reads them. */
int ffd_rig_write_cage(const ffd_rig *rig, cJSON *root)
{
    static const char *const coords[] = {"mean_value", "harmonic"};
    static const char *const outsides[] = {"", "extend", "fixed", "clamp"};
    const ffd_rig_cage *c = ffd_rig_cage_of(rig);
    int ok = 1;
    if (c->cage_auto) {
        ok = cJSON_AddStringToObject(root, "cage", "auto") &&
             ffd_sess_add_item(root, "margin", ffd_sess_number(c->margin));
    } else {
        cJSON *cage = cJSON_AddObjectToObject(root, "cage");
        cJSON *verts = cage ? cJSON_AddArrayToObject(cage, "vertices") : NULL;
        cJSON *faces = verts ? cJSON_AddArrayToObject(cage, "faces") : NULL;
        ok = faces != NULL;
        for (size_t i = 0; ok && i < c->vertex_count; i++)
            ok = ffd_sess_add_to_array(verts, ffd_sess_vec3(c->vertices + 3 * i));
        for (size_t t = 0; ok && t < c->triangle_count; t++)
            ok = ffd_sess_add_to_array(faces, ffd_sess_uint_array(c->triangles + 3 * t, 3));
    }
    ok = ok && cJSON_AddStringToObject(root, "coordinates",
                                       coords[c->options.coordinates == FFD_CAGE_HARMONIC]);
    if (ok && c->options.coordinates == FFD_CAGE_HARMONIC)
        ok = cJSON_AddNumberToObject(root, "resolution",
                                     c->options.resolution ? c->options.resolution
                                                           : FFD_CAGE_RESOLUTION_DEFAULT) != NULL;
    if (ok && c->options.outside)
        ok = cJSON_AddStringToObject(root, "outside", outsides[c->options.outside]) != NULL;
    cJSON *moves = ok ? cJSON_AddArrayToObject(root, "moves") : NULL;
    ok = ok && moves;
    for (size_t i = 0; ok && i < c->move_count; i++) {
        cJSON *m = cJSON_CreateObject();
        ok = ffd_sess_add_to_array(moves, m) &&
             cJSON_AddNumberToObject(m, "index", c->moves[i].index) &&
             ffd_sess_add_item(m, "delta", ffd_sess_vec3(c->moves[i].delta));
    }
    return ok;
}

void ffd_rig_release_cage(ffd_rig *rig)
{
    ffd_rig_cage *c = ffd_rig_cage_of(rig);
    ffd_free(c->vertices);
    ffd_free(c->triangles);
    ffd_free(c->face_of);
    ffd_free(c->file);
    ffd_free(c->moves);
}
