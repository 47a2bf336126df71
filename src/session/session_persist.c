/* session_persist — work is never lost (docs/editor.md "Work is never
 * lost"): the history's named steps, the autosave record of the session
 * (mesh, rig with pins, each step's name and rig) written atomically, and
 * the resume that brings it back on the same mesh. */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L /* gmtime_r */
#endif
#include "session/session_persist.h"

#include "mesh/mesh.h"

#include <stdio.h>
#include <string.h>
#include <time.h>

/* ---------- step names ---------- */

static const char *method_title(const char *method)
{
    static const char *const titles[][2] = {
        {"lattice", "lattice"}, {"tspline", "T-spline"}, {"pbffd", "PB-FFD"},
        {"gffd", "GFFD"},       {"cage", "cage"},        {"kelvinlet", "Kelvinlet"},
        {"rbf", "RBF"},         {"idw", "IDW"}};
    for (size_t i = 0; i < sizeof titles / sizeof *titles; i++)
        if (!strcmp(method, titles[i][0]))
            return titles[i][1];
    return method;
}

void sess_name_create(char *buf, size_t size, const char *method, const cJSON *body)
{
    const cJSON *r = cJSON_GetObjectItemCaseSensitive(body, "resolution");
    const cJSON *a = cJSON_GetArrayItem(r, 0), *b = cJSON_GetArrayItem(r, 1),
                *c = cJSON_GetArrayItem(r, 2);
    if (cJSON_GetArraySize(r) == 3 && cJSON_IsNumber(a) && cJSON_IsNumber(b) && cJSON_IsNumber(c))
        snprintf(buf, size, "Create %s %d\xc3\x97%d\xc3\x97%d", method_title(method),
                 (int)a->valuedouble, (int)b->valuedouble, (int)c->valuedouble);
    else
        snprintf(buf, size, "Create %s", method_title(method));
}

void sess_name_drag(char *buf, size_t size, int mode, const uint32_t *ids, size_t k)
{
    static const char *const verbs[] = {"Drag", "Rotate", "Scale"};
    const char *verb = verbs[mode >= 0 && mode <= 2 ? mode : 0];
    if (k == 1)
        snprintf(buf, size, "%s control %u", verb, ids[0]);
    else
        snprintf(buf, size, "%s %zu controls", verb, k);
}

/* "Refine T-spline cell 12", "Freeze 3 points", "Remove primitive 1", ... */
void sess_name_op(char *buf, size_t size, const char *method, const char *op, const cJSON *body)
{
    const char *title = method_title(method);
    const cJSON *points = cJSON_GetObjectItemCaseSensitive(body, "points");
    int k = cJSON_GetArraySize(points);
    if (!strcmp(op, "refine")) {
        const cJSON *ins = cJSON_GetObjectItemCaseSensitive(body, "insertions");
        const cJSON *one = cJSON_GetArraySize(ins) == 1 ? cJSON_GetArrayItem(ins, 0) : NULL;
        static const char *const kinds[] = {"cell", "face", "edge"};
        for (int i = 0; one && i < 3; i++) {
            const cJSON *id = cJSON_GetObjectItemCaseSensitive(one, kinds[i]);
            if (cJSON_IsNumber(id)) {
                snprintf(buf, size, "Refine %s %s %d", title, kinds[i], (int)id->valuedouble);
                return;
            }
            if (cJSON_IsObject(id)) {
                snprintf(buf, size, "Refine %s %s at a point", title, kinds[i]);
                return;
            }
        }
        if (one && cJSON_GetObjectItemCaseSensitive(one, "cells"))
            snprintf(buf, size, "Refine every %s proxy cell", title);
        else
            snprintf(buf, size, "Refine %s (%d insertions)", title, cJSON_GetArraySize(ins));
    } else if (!strcmp(op, "freeze")) {
        const cJSON *frozen = cJSON_GetObjectItemCaseSensitive(body, "frozen");
        snprintf(buf, size, "%s %d point%s", cJSON_IsFalse(frozen) ? "Unfreeze" : "Freeze", k,
                 k == 1 ? "" : "s");
    } else if (!strcmp(op, "frame")) {
        snprintf(buf, size, "%s %d %s frame%s",
                 cJSON_GetObjectItemCaseSensitive(body, "scale") ? "Scale" : "Turn", k, title,
                 k == 1 ? "" : "s");
    } else if (!strcmp(op, "curve")) {
        snprintf(buf, size, "Add a %s curve", title);
    } else if (!strcmp(op, "primitive") || !strcmp(op, "brush")) {
        const cJSON *add = cJSON_GetObjectItemCaseSensitive(body, "add");
        const cJSON *rm = cJSON_GetObjectItemCaseSensitive(body, "remove");
        const cJSON *index = cJSON_GetObjectItemCaseSensitive(body, "index");
        const cJSON *type = cJSON_GetObjectItemCaseSensitive(add, "type");
        const char *what = !strcmp(op, "brush") ? "brush" : "primitive";
        if (add)
            snprintf(buf, size, "Add a %s%s%s", cJSON_IsString(type) ? type->valuestring : "",
                     cJSON_IsString(type) ? " " : "", what);
        else if (cJSON_IsNumber(rm))
            snprintf(buf, size, "Remove %s %d", what, (int)rm->valuedouble);
        else if (cJSON_IsNumber(index))
            snprintf(buf, size, "Edit %s %d", what, (int)index->valuedouble);
        else
            snprintf(buf, size, "Edit a %s", what);
    } else if (!strcmp(op, "level")) {
        const cJSON *level = cJSON_GetObjectItemCaseSensitive(body, "level");
        snprintf(buf, size, "Edit %s level %d", title,
                 cJSON_IsNumber(level) ? (int)level->valuedouble : 0);
    } else {
        snprintf(buf, size, "%c%s (%s)", op[0] >= 'a' && op[0] <= 'z' ? op[0] - 'a' + 'A' : op[0],
                 op + 1, title);
    }
}

void sess_name_file(char *buf, size_t size, const char *verb, const char *path)
{
    const char *base = path ? strrchr(path, '/') : NULL;
    base = base ? base + 1 : path ? path : "";
    snprintf(buf, size, "%s %s", verb, base);
}

/* ---------- the history ---------- */

static cJSON *history_json(const ffd_session *s)
{
    cJSON *h = cJSON_CreateObject(), *steps = cJSON_CreateArray();
    if (!h || !steps || !cJSON_AddItemToObject(h, "steps", steps)) {
        cJSON_Delete(h);
        cJSON_Delete(steps);
        return NULL;
    }
    if (!cJSON_AddNumberToObject(h, "current", (double)sess_history_current(s))) {
        cJSON_Delete(h);
        return NULL;
    }
    for (size_t i = 0; i < sess_history_count(s); i++)
        if (!ffd_sess_add_to_array(steps, cJSON_CreateString(sess_history_name(s, i)))) {
            cJSON_Delete(h);
            return NULL;
        }
    return h;
}

int sess_persist_state(const ffd_session *s, cJSON *root)
{
    if (!ffd_sess_add_item(root, "history", history_json(s)))
        return 0;
    const char *note = sess_autosave_note(s);
    return !note || ffd_sess_add_item(root, "autosave", cJSON_Parse(note));
}

ffd_status ffd_session_history(const ffd_session *s, char **json, size_t *size, ffd_error *err)
{
    if (!s || !json || !size)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_session_history: NULL argument");
    cJSON *h = history_json(s);
    char *printed = h ? cJSON_PrintUnformatted(h) : NULL;
    cJSON_Delete(h);
    *json = printed ? ffd_strdup(printed) : NULL;
    cJSON_free(printed);
    if (!*json)
        return ffd_fail(err, FFD_ERR_NOMEM, "history: out of memory");
    *size = strlen(*json);
    return FFD_OK;
}

/* ---------- the autosave ---------- */

/* FNV-1a 64 of the rest mesh: vertex positions (their bits) and faces. */
static void mesh_hash(const ffd_mesh *mesh, char out[40])
{
    uint64_t h = 14695981039346656037ULL;
    const unsigned char *bytes[3];
    size_t sizes[3];
    size_t n = ffd_mesh_vertex_count(mesh), nf = ffd_mesh_face_count(mesh);
    const uint32_t *off = ffd_mesh_face_offsets(mesh);
    bytes[0] = (const unsigned char *)ffd_mesh_positions(mesh);
    sizes[0] = 3 * n * sizeof(double);
    bytes[1] = (const unsigned char *)off;
    sizes[1] = off ? (nf + 1) * sizeof *off : 0;
    bytes[2] = (const unsigned char *)ffd_mesh_face_indices(mesh);
    sizes[2] = off && bytes[2] ? off[nf] * sizeof(uint32_t) : 0;
    for (int a = 0; a < 3; a++)
        for (size_t i = 0; bytes[a] && i < sizes[a]; i++) {
            h ^= bytes[a][i];
            h *= 1099511628211ULL;
        }
    snprintf(out, 40, "fnv1a64:%016llx", (unsigned long long)h);
}

static void time_text(time_t t, char out[32])
{
    struct tm tm;
    if (gmtime_r(&t, &tm))
        strftime(out, 32, "%Y-%m-%dT%H:%M:%SZ", &tm);
    else
        snprintf(out, 32, "%lld", (long long)t);
}

static size_t text_size(const char *text)
{
    return text ? strlen(text) : 0;
}

/* A rig text as a JSON item (raw: printed as is) or null. */
static cJSON *rig_item(char *text)
{
    cJSON *item = text ? cJSON_CreateRaw(text) : cJSON_CreateNull();
    ffd_free(text);
    return item;
}

ffd_status ffd_session_autosave_text(const ffd_session *s, const char *mesh_path, char **json,
                                     size_t *size, ffd_error *err)
{
    if (!s || !json || !size)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_session_autosave: NULL argument");
    *json = NULL;
    if (sess_dragging(s))
        return ffd_fail(err, FFD_ERR_INVALID, SESS_CONFLICT "autosave: a drag is in progress");
    const ffd_mesh *mesh = ffd_session_mesh(s);
    char hash[40], saved[32];
    time_t now = time(NULL);
    mesh_hash(mesh, hash);
    time_text(now, saved);
    size_t count = sess_history_count(s), current = sess_history_current(s);
    /* the steps kept: at most FFD_AUTOSAVE_STEPS, the newest, the present among them */
    size_t first = count > FFD_AUTOSAVE_STEPS ? count - FFD_AUTOSAVE_STEPS : 0;
    if (first > current)
        first = current;
    size_t last = first + FFD_AUTOSAVE_STEPS < count ? first + FFD_AUTOSAVE_STEPS : count;
    /* and at most autosave_max_bytes of rig text: the present, then the
     * steps before it, newest first, then those after it */
    char **texts = ffd_calloc(last - first, sizeof *texts);
    if (!texts)
        return ffd_fail(err, FFD_ERR_NOMEM, "autosave: out of memory");
    ffd_status st = FFD_OK;
    for (size_t i = first; !st && i < last; i++)
        st = sess_history_rig(s, i, &texts[i - first], err);
    size_t lo = current, hi = current + 1;
    size_t bytes = text_size(texts[current - first]);
    size_t budget = sess_autosave_max_bytes(s);
    while (lo > first && bytes + text_size(texts[lo - 1 - first]) <= budget)
        bytes += text_size(texts[--lo - first]);
    while (hi < last && bytes + text_size(texts[hi - first]) <= budget)
        bytes += text_size(texts[hi++ - first]);
    for (size_t i = first; i < last; i++)
        if (i < lo || i >= hi) {
            ffd_free(texts[i - first]);
            texts[i - first] = NULL;
        }
    char **kept = texts + (lo - first);
    first = lo;
    last = hi;
    /* every item goes into root as soon as it is made: root owns it, on error too */
    cJSON *root = cJSON_CreateObject();
    cJSON *mesh_obj = NULL, *h = NULL, *list = NULL;
    int ok = root && ffd_sess_add_item(root, "format", cJSON_CreateString("ffd-autosave")) &&
             cJSON_AddNumberToObject(root, "version", 1) &&
             cJSON_AddStringToObject(root, "saved", saved) &&
             cJSON_AddNumberToObject(root, "saved_unix", (double)now) &&
             ffd_sess_add_item(root, "mesh", mesh_obj = cJSON_CreateObject());
    ok = ok && cJSON_AddStringToObject(mesh_obj, "name", ffd_session_name(s)) &&
         (!mesh_path || cJSON_AddStringToObject(mesh_obj, "path", mesh_path)) &&
         cJSON_AddNumberToObject(mesh_obj, "vertices", (double)ffd_mesh_vertex_count(mesh)) &&
         cJSON_AddNumberToObject(mesh_obj, "faces", (double)ffd_mesh_face_count(mesh)) &&
         cJSON_AddStringToObject(mesh_obj, "hash", hash);
    if (!st && !ok)
        st = ffd_fail(err, FFD_ERR_NOMEM, "autosave: out of memory");
    char *text = NULL;
    if (!st && !(st = sess_state_rig(s, &text, err)))
        ok = ffd_sess_add_item(root, "rig", rig_item(text));
    ok = ok && ffd_sess_add_item(root, "history", h = cJSON_CreateObject()) &&
         cJSON_AddNumberToObject(h, "current", (double)(current - first)) &&
         cJSON_AddNumberToObject(h, "dropped", (double)first) &&
         ffd_sess_add_item(h, "steps", list = cJSON_CreateArray());
    for (size_t i = first; !st && ok && i < last; i++) {
        cJSON *step = cJSON_CreateObject();
        ok = ffd_sess_add_to_array(list, step) &&
             cJSON_AddStringToObject(step, "name", sess_history_name(s, i));
        if (ok) {
            ok = ffd_sess_add_item(step, "rig", rig_item(kept[i - first]));
            kept[i - first] = NULL; /* rig_item took it */
        }
    }
    for (size_t i = 0; i < last - first; i++)
        ffd_free(kept[i]);
    ffd_free(texts);
    char *printed = !st && ok ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (st)
        return st;
    if (!printed)
        return ffd_fail(err, FFD_ERR_NOMEM, "autosave: out of memory");
    *json = ffd_strdup(printed);
    cJSON_free(printed);
    if (!*json)
        return ffd_fail(err, FFD_ERR_NOMEM, "autosave: out of memory");
    *size = strlen(*json);
    return FFD_OK;
}

ffd_status ffd_session_autosave(const ffd_session *s, const char *path, const char *mesh_path,
                                ffd_error *err)
{
    if (!path)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_session_autosave: NULL path");
    char *json = NULL;
    size_t size = 0;
    ffd_status st = ffd_session_autosave_text(s, mesh_path, &json, &size, err);
    if (!st)
        st = ffd_write_file_atomic(path, json, size, err);
    ffd_free(json);
    return st;
}

/* The state's "autosave" note: applied or not, and why. */
static void set_note(ffd_session *s, int resumed, const char *saved, double saved_unix,
                     size_t steps, size_t current, const char *reason)
{
    cJSON *note = cJSON_CreateObject();
    int ok = note && cJSON_AddBoolToObject(note, "resumed", resumed) &&
             (!saved || cJSON_AddStringToObject(note, "saved", saved)) &&
             (!saved || cJSON_AddNumberToObject(note, "saved_unix", saved_unix)) &&
             (!resumed || (cJSON_AddNumberToObject(note, "steps", (double)steps) &&
                           cJSON_AddNumberToObject(note, "current", (double)current))) &&
             (!reason || cJSON_AddStringToObject(note, "reason", reason));
    char *printed = ok ? cJSON_PrintUnformatted(note) : NULL;
    cJSON_Delete(note);
    char *copy = printed ? ffd_strdup(printed) : NULL;
    cJSON_free(printed);
    sess_set_autosave_note(s, copy);
}

static ffd_status bad_autosave(const char *name, const char *what, ffd_error *err)
{
    return ffd_fail(err, FFD_ERR_PARSE, "%s: %s: not an autosave this version of ffd writes", name,
                    what);
}

/* Reads and checks the record; fills names and rigs (count entries,
 * ffd_free each rig text). */
static ffd_status read_autosave(ffd_session *s, const cJSON *root, const char *name,
                                char ***names_out, char ***rigs_out, size_t *count,
                                size_t *current, ffd_error *err)
{
    const cJSON *format = cJSON_GetObjectItemCaseSensitive(root, "format");
    const cJSON *version = cJSON_GetObjectItemCaseSensitive(root, "version");
    const cJSON *mesh = cJSON_GetObjectItemCaseSensitive(root, "mesh");
    const cJSON *history = cJSON_GetObjectItemCaseSensitive(root, "history");
    if (!cJSON_IsString(format) || strcmp(format->valuestring, "ffd-autosave") != 0)
        return bad_autosave(name, "format", err);
    if (!cJSON_IsNumber(version) || version->valuedouble != 1)
        return bad_autosave(name, "version", err);
    const cJSON *hash = cJSON_GetObjectItemCaseSensitive(mesh, "hash");
    const cJSON *vertices = cJSON_GetObjectItemCaseSensitive(mesh, "vertices");
    const cJSON *faces = cJSON_GetObjectItemCaseSensitive(mesh, "faces");
    if (!cJSON_IsString(hash) || !cJSON_IsNumber(vertices) || !cJSON_IsNumber(faces))
        return bad_autosave(name, "mesh", err);
    const ffd_mesh *now = ffd_session_mesh(s);
    char own[40];
    mesh_hash(now, own);
    if (strcmp(own, hash->valuestring) != 0 && vertices->valuedouble == (double)ffd_mesh_vertex_count(now) &&
        faces->valuedouble == (double)ffd_mesh_face_count(now))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: saved for another version of %s (the same %zu vertices and %zu faces, "
                        "but other positions or faces: the mesh file changed since)",
                        name, ffd_session_name(s), ffd_mesh_vertex_count(now),
                        ffd_mesh_face_count(now));
    if (strcmp(own, hash->valuestring) != 0)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: saved for another version of %s (%.0f vertices and %.0f faces then, "
                        "%zu and %zu now; the mesh file changed since)",
                        name, ffd_session_name(s), vertices->valuedouble, faces->valuedouble,
                        ffd_mesh_vertex_count(now), ffd_mesh_face_count(now));
    const cJSON *steps = cJSON_GetObjectItemCaseSensitive(history, "steps");
    const cJSON *cur = cJSON_GetObjectItemCaseSensitive(history, "current");
    int n = cJSON_GetArraySize(steps);
    if (!cJSON_IsArray(steps) || n < 1 || !cJSON_IsNumber(cur) || cur->valuedouble < 0 ||
        cur->valuedouble >= n || cur->valuedouble != (double)(int)cur->valuedouble)
        return bad_autosave(name, "history", err);
    char **names = ffd_calloc((size_t)n, sizeof *names), **rigs = ffd_calloc((size_t)n, sizeof *rigs);
    ffd_status st = names && rigs ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    int i = 0;
    const cJSON *step;
    cJSON_ArrayForEach(step, steps)
    {
        if (st)
            break;
        const cJSON *sn = cJSON_GetObjectItemCaseSensitive(step, "name");
        const cJSON *rig = cJSON_GetObjectItemCaseSensitive(step, "rig");
        if (!cJSON_IsString(sn) || !(cJSON_IsObject(rig) || cJSON_IsNull(rig))) {
            st = bad_autosave(name, "history step", err);
            break;
        }
        names[i] = ffd_strdup(sn->valuestring);
        char *printed = cJSON_IsObject(rig) ? cJSON_PrintUnformatted(rig) : NULL;
        rigs[i] = printed ? ffd_strdup(printed) : NULL;
        cJSON_free(printed);
        if (!names[i] || (cJSON_IsObject(rig) && !rigs[i]))
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
        i++;
    }
    if (st) {
        for (int j = 0; names && rigs && j < n; j++) {
            ffd_free(names[j]);
            ffd_free(rigs[j]);
        }
        ffd_free(names);
        ffd_free(rigs);
        return st;
    }
    *names_out = names;
    *rigs_out = rigs;
    *count = (size_t)n;
    *current = (size_t)cur->valuedouble;
    return FFD_OK;
}

ffd_status ffd_session_resume(ffd_session *s, const char *text, size_t size, const char *name,
                              const char *kept_as, ffd_error *err)
{
    if (!s || !text)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_session_resume: NULL argument");
    name = name ? name : "autosave";
    ffd_error inner = {{0}};
    cJSON *root = cJSON_ParseWithLength(text, size);
    const cJSON *saved = cJSON_GetObjectItemCaseSensitive(root, "saved");
    const cJSON *saved_unix = cJSON_GetObjectItemCaseSensitive(root, "saved_unix");
    const char *when = cJSON_IsString(saved) ? saved->valuestring : NULL;
    double when_unix = cJSON_IsNumber(saved_unix) ? saved_unix->valuedouble : 0;
    char **names = NULL, **rigs = NULL;
    size_t count = 0, current = 0;
    ffd_status st = root ? read_autosave(s, root, name, &names, &rigs, &count, &current, &inner)
                         : ffd_fail(&inner, FFD_ERR_PARSE, "%s: not JSON (a cut-off write?)", name);
    if (!st) {
        st = sess_history_restore(s, (const char *const *)names, (const char *const *)rigs, count,
                                  current, &inner);
        if (st) {
            char msg[sizeof inner.message];
            snprintf(msg, sizeof msg, "%s", inner.message);
            ffd_fail(&inner, st, "%s: %s", name, msg);
        }
    }
    for (size_t i = 0; i < count; i++) {
        ffd_free(names[i]);
        ffd_free(rigs[i]);
    }
    ffd_free(names);
    ffd_free(rigs);
    if (st) {
        char reason[sizeof inner.message + 300];
        snprintf(reason, sizeof reason, "%s%s%s", inner.message, kept_as ? "; kept as " : "",
                 kept_as ? kept_as : "");
        set_note(s, 0, when, when_unix, 0, 0, reason);
        cJSON_Delete(root);
        return ffd_fail(err, st, "%s", reason);
    }
    set_note(s, 1, when, when_unix, count, current, NULL);
    cJSON_Delete(root);
    return FFD_OK;
}

void ffd_session_note_autosave(ffd_session *s, const char *key, const char *json)
{
    if (!s || !key)
        return;
    const char *old = sess_autosave_note(s);
    cJSON *note = old ? cJSON_Parse(old) : cJSON_CreateObject();
    if (!note)
        return;
    cJSON_DeleteItemFromObjectCaseSensitive(note, key);
    cJSON *value = json ? cJSON_Parse(json) : NULL;
    char *printed = NULL;
    if (!json || ffd_sess_add_item(note, key, value))
        printed = cJSON_PrintUnformatted(note);
    cJSON_Delete(note);
    char *copy = printed ? ffd_strdup(printed) : NULL;
    cJSON_free(printed);
    if (copy)
        sess_set_autosave_note(s, copy);
}

void ffd_session_set_autosave_file(ffd_session *s, const char *file)
{
    cJSON *value = file ? cJSON_CreateString(file) : NULL;
    char *printed = value ? cJSON_PrintUnformatted(value) : NULL;
    cJSON_Delete(value);
    if (file && !printed)
        return;
    ffd_session_note_autosave(s, "file", printed);
    cJSON_free(printed);
}
