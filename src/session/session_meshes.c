/* session — several meshes in one session (session.h "Several meshes"):
 * the parts' concatenation that the deformer binds, their description in
 * the state, and each part's own deformed mesh (its rig replayed on it
 * alone, as ffd deform would on its file). The session (session.c) swaps
 * its point set and rebinds the deformer. */
#include "session/session.h"

#include "mesh/mesh.h"

#include <string.h>

ffd_status ffd_sess_meshes_concat(sess_meshes *m, ffd_mesh **out, ffd_error *err)
{
    *out = NULL;
    size_t n = 0, faces = 0, corners = 0;
    for (size_t i = 0; i < m->count; i++) {
        const ffd_mesh *part = m->parts[i].mesh;
        if (ffd_mesh_is_volume(part))
            return ffd_fail(err, FFD_ERR_INVALID,
                            "%s: a volume mesh cannot share a session with other meshes",
                            m->parts[i].name);
        m->parts[i].first = n;
        m->parts[i].count = ffd_mesh_vertex_count(part);
        n += m->parts[i].count;
        faces += ffd_mesh_face_count(part);
        corners += ffd_mesh_face_offsets(part)[ffd_mesh_face_count(part)];
    }
    if (n > UINT32_MAX / 4 || corners > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "%zu vertices: too many for the editor", n);
    double *pos = ffd_malloc_array(n ? n : 1, 3 * sizeof *pos);
    uint32_t *off = ffd_malloc_array(faces + 1, sizeof *off);
    uint32_t *idx = ffd_malloc_array(corners ? corners : 1, sizeof *idx);
    ffd_status st = FFD_OK;
    if (!pos || !off || !idx) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "out of memory for %zu vertices", n);
        goto done;
    }
    size_t f = 0, c = 0;
    off[0] = 0;
    for (size_t i = 0; i < m->count; i++) {
        const ffd_mesh *part = m->parts[i].mesh;
        const uint32_t *po = ffd_mesh_face_offsets(part), *pi = ffd_mesh_face_indices(part);
        size_t pf = ffd_mesh_face_count(part);
        memcpy(pos + 3 * m->parts[i].first, ffd_mesh_positions(part),
               3 * m->parts[i].count * sizeof *pos);
        for (size_t j = 0; j < po[pf]; j++)
            idx[c + j] = pi[j] + (uint32_t)m->parts[i].first;
        for (size_t j = 0; j < pf; j++)
            off[f + j + 1] = (uint32_t)c + po[j + 1];
        f += pf;
        c += po[pf];
    }
    st = ffd_mesh_create(pos, n, off, idx, faces, out, err);
done:
    ffd_free(pos);
    ffd_free(off);
    ffd_free(idx);
    return st;
}

void ffd_sess_meshes_free(sess_meshes *m)
{
    for (size_t i = 0; i < m->count; i++) {
        ffd_mesh_destroy(m->parts[i].mesh);
        ffd_free(m->parts[i].name);
    }
    ffd_free(m->parts);
    m->parts = NULL;
    m->count = 0;
}

static int add_part(cJSON *arr, const char *name, size_t first, const ffd_mesh *mesh)
{
    cJSON *o = cJSON_CreateObject();
    if (!ffd_sess_add_to_array(arr, o))
        return 0;
    return cJSON_AddStringToObject(o, "name", name) &&
           cJSON_AddNumberToObject(o, "first", (double)first) &&
           cJSON_AddNumberToObject(o, "vertices", (double)ffd_mesh_vertex_count(mesh)) &&
           cJSON_AddNumberToObject(o, "faces", (double)ffd_mesh_face_count(mesh));
}

int ffd_sess_meshes_json(const sess_meshes *m, const char *name, const ffd_mesh *mesh,
                         cJSON *root)
{
    cJSON *arr = cJSON_CreateArray();
    if (!ffd_sess_add_item(root, "meshes", arr))
        return 0;
    if (!m->count)
        return add_part(arr, name, 0, mesh);
    for (size_t i = 0; i < m->count; i++)
        if (!add_part(arr, m->parts[i].name, m->parts[i].first, m->parts[i].mesh))
            return 0;
    return 1;
}

ffd_status ffd_sess_meshes_deformed(const sess_meshes *m, size_t index, const char *rig,
                                    const ffd_limits *limits, ffd_mesh **out, ffd_error *err)
{
    *out = NULL;
    if (index >= m->count)
        return ffd_fail(err, FFD_ERR_RANGE, "mesh %zu out of range (%zu meshes)", index,
                        m->count);
    ffd_mesh *copy = NULL;
    ffd_status st = ffd_sess_clone_mesh(m->parts[index].mesh, &copy, err);
    if (st || !rig) {
        *out = copy;
        return st;
    }
    ffd_rig *parsed = NULL;
    if (!(st = ffd_rig_parse_json(rig, strlen(rig), "session", &parsed, err)))
        st = ffd_rig_apply_limited(parsed, copy, limits, NULL, err);
    ffd_rig_destroy(parsed);
    if (st)
        ffd_mesh_destroy(copy);
    else
        *out = copy;
    return st;
}
