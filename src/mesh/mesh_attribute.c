/* mesh_attribute — per-vertex scalar attributes for the rig's "weights"
 * (docs/constraints.md): a volume format's point field, a PLY vertex
 * property, or an OBJ comment block of "#NAME value" lines, one per vertex
 * in vertex order (docs/mesh-formats.md). OBJ readers ignore comments, so
 * such a file stays a valid OBJ for every other tool. */
#include "mesh.h"
#include "mesh_cells.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* "#NAME value" lines: the i-th gives vertex i's value. */
static ffd_status obj_comment_block(const ffd_mesh *m, const char *name, double **out, int *found,
                                    ffd_error *err)
{
    size_t nl = strlen(name), n = 0, line = 1, nv = m->vertex_count;
    const char *s = (const char *)m->src, *end = s + m->src_size;
    double *v = ffd_malloc_array(nv ? nv : 1, sizeof *v);
    if (!v)
        return ffd_fail(err, FFD_ERR_NOMEM, "weights: out of memory");
    *found = 0;
    for (const char *q = s; q < end; line++) {
        const char *e = memchr(q, '\n', (size_t)(end - q));
        const char *le = e ? e : end;
        if (le - q > (ptrdiff_t)nl && q[0] == '#' && memcmp(q + 1, name, nl) == 0 &&
            ffd_is_blank(q[1 + nl])) {
            *found = 1;
            const char *c = q + 1 + nl;
            while (c < le && ffd_is_blank(*c))
                c++;
            double x;
            const char *at = c;
            int r = ffd_parse_number(&c, le, false, &x);
            while (c < le && ffd_is_blank(*c))
                c++;
            if (r <= 0 || c < le) {
                ffd_free(v);
                return ffd_fail(err, FFD_ERR_PARSE,
                                "mesh:%zu: \"#%s\": expected one number, found '%.*s'", line, name,
                                (int)(le - at > 20 ? 20 : le - at), at);
            }
            if (!isfinite(x)) {
                ffd_free(v);
                return ffd_fail(err, FFD_ERR_NONFINITE, "mesh:%zu: \"#%s\": the value is not finite",
                                line, name);
            }
            if (n == nv) {
                ffd_free(v);
                return ffd_fail(err, FFD_ERR_PARSE,
                                "mesh:%zu: \"#%s\": more values than the %zu vertices", line, name,
                                nv);
            }
            v[n++] = x;
        }
        q = e ? e + 1 : end;
    }
    if (*found && n != nv) {
        ffd_free(v);
        return ffd_fail(err, FFD_ERR_PARSE, "mesh: \"#%s\": %zu values for %zu vertices", name, n,
                        nv);
    }
    if (!*found) {
        ffd_free(v);
        return FFD_OK;
    }
    *out = v;
    return FFD_OK;
}

ffd_status ffd_mesh_vertex_attribute(const ffd_mesh *m, const char *name, double **out,
                                     ffd_error *err)
{
    *out = NULL;
    size_t nv = m->vertex_count;
    for (size_t f = 0; f < m->field_count; f++) {
        const ffd_mesh_field *fd = &m->fields[f];
        if (fd->association != FFD_FIELD_POINT || strcmp(fd->name, name) != 0)
            continue;
        if (fd->components != 1)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "point field \"%s\" has %u components, expected one per vertex", name,
                            fd->components);
        double *v = ffd_malloc_array(nv ? nv : 1, sizeof *v);
        if (!v)
            return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
        for (size_t i = 0; i < nv; i++)
            if (!isfinite(v[i] = fd->values[i])) {
                ffd_free(v);
                return ffd_fail(err, FFD_ERR_NONFINITE,
                                "point field \"%s\": the value of vertex %zu is not finite", name, i);
            }
        *out = v;
        return FFD_OK;
    }
    int found = 0;
    ffd_status st = FFD_OK;
    if (m->src && m->format == FFD_FORMAT_OBJ)
        st = obj_comment_block(m, name, out, &found, err);
    else if (m->src && m->format == FFD_FORMAT_PLY)
        st = ffd_ply_vertex_property(m, name, out, &found, err);
    if (st)
        return st;
    if (!found)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "the mesh has no vertex attribute \"%s\" (a point field, a PLY vertex "
                        "property or OBJ \"#%s value\" lines)",
                        name, name);
    for (size_t i = 0; i < nv; i++)
        if (!isfinite((*out)[i])) {
            ffd_free(*out);
            *out = NULL;
            return ffd_fail(err, FFD_ERR_NONFINITE,
                            "vertex attribute \"%s\": the value of vertex %zu is not finite", name, i);
        }
    return FFD_OK;
}
