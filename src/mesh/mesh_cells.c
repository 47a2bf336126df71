/* mesh_cells — cell types (VTK's), building cells, extracting the boundary
 * surface of a volume mesh, surfaces as cells for the volume writers, and
 * point and cell data. See mesh_cells.h and docs/volume.md. */
#include "mesh_cells.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ======================================================================
 * The cell types (VTK ids and node orders; faces outwards, as vtkCell's
 * face tables list them)
 * ====================================================================== */

#define NOFACES {0}, {{0}}
#define TET_FACES {3, 3, 3, 3}, {{0, 1, 3}, {1, 2, 3}, {2, 0, 3}, {0, 2, 1}}
#define HEX_FACES                                                                              \
    {4, 4, 4, 4, 4, 4}, {{0, 4, 7, 3}, {1, 2, 6, 5}, {0, 1, 5, 4}, {3, 7, 6, 2}, {0, 3, 2, 1}, \
                         {4, 5, 6, 7}}
#define WEDGE_FACES {3, 3, 4, 4, 4}, {{0, 1, 2}, {3, 5, 4}, {0, 3, 4, 1}, {1, 4, 5, 2}, {2, 5, 3, 0}}
#define PYRAMID_FACES {4, 3, 3, 3, 3}, {{0, 3, 2, 1}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}}

static const ffd_cell_type cell_types[] = {
    /* vtk  dim nodes corners min faces name */
    {FFD_CELL_VERTEX, 0, 1, 1, 1, 0, "vertex", NOFACES},
    {FFD_CELL_POLY_VERTEX, 0, 0, 0, 1, 0, "poly_vertex", NOFACES},
    {FFD_CELL_LINE, 1, 2, 2, 2, 0, "line", NOFACES},
    {FFD_CELL_POLY_LINE, 1, 0, 0, 2, 0, "poly_line", NOFACES},
    {FFD_CELL_TRIANGLE, 2, 3, 3, 3, 0, "triangle", NOFACES},
    {FFD_CELL_TRIANGLE_STRIP, 2, 0, 0, 3, 0, "triangle_strip", NOFACES},
    {FFD_CELL_POLYGON, 2, 0, 0, 3, 0, "polygon", NOFACES},
    {FFD_CELL_PIXEL, 2, 4, 4, 4, 0, "pixel", NOFACES},
    {FFD_CELL_QUAD, 2, 4, 4, 4, 0, "quad", NOFACES},
    {FFD_CELL_TETRA, 3, 4, 4, 4, 4, "tetra", TET_FACES},
    {FFD_CELL_VOXEL, 3, 8, 8, 8, 6, "voxel",
     {4, 4, 4, 4, 4, 4},
     {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}}},
    {FFD_CELL_HEXAHEDRON, 3, 8, 8, 8, 6, "hexahedron", HEX_FACES},
    {FFD_CELL_WEDGE, 3, 6, 6, 6, 5, "wedge", WEDGE_FACES},
    {FFD_CELL_PYRAMID, 3, 5, 5, 5, 5, "pyramid", PYRAMID_FACES},
    {FFD_CELL_QUADRATIC_EDGE, 1, 3, 2, 3, 0, "line3", NOFACES},
    {FFD_CELL_QUADRATIC_TRIANGLE, 2, 6, 3, 6, 0, "triangle6", NOFACES},
    {FFD_CELL_QUADRATIC_QUAD, 2, 8, 4, 8, 0, "quad8", NOFACES},
    {FFD_CELL_BIQUADRATIC_QUAD, 2, 9, 4, 9, 0, "quad9", NOFACES},
    {FFD_CELL_QUADRATIC_TETRA, 3, 10, 4, 10, 4, "tetra10", TET_FACES},
    {FFD_CELL_QUADRATIC_HEXAHEDRON, 3, 20, 8, 20, 6, "hexahedron20", HEX_FACES},
    {FFD_CELL_TRIQUADRATIC_HEXAHEDRON, 3, 27, 8, 27, 6, "hexahedron27", HEX_FACES},
    {FFD_CELL_QUADRATIC_WEDGE, 3, 15, 6, 15, 5, "wedge15", WEDGE_FACES},
    {FFD_CELL_QUADRATIC_PYRAMID, 3, 13, 5, 13, 5, "pyramid13", PYRAMID_FACES},
};
#define CELL_TYPE_COUNT (sizeof cell_types / sizeof cell_types[0])

/* VTK id -> 1 + index in cell_types (0: unknown): the look-up is on every face's path. */
static const uint8_t type_index[256] = {
    [FFD_CELL_VERTEX] = 1,  [FFD_CELL_POLY_VERTEX] = 2, [FFD_CELL_LINE] = 3,
    [FFD_CELL_POLY_LINE] = 4, [FFD_CELL_TRIANGLE] = 5, [FFD_CELL_TRIANGLE_STRIP] = 6,
    [FFD_CELL_POLYGON] = 7, [FFD_CELL_PIXEL] = 8, [FFD_CELL_QUAD] = 9, [FFD_CELL_TETRA] = 10,
    [FFD_CELL_VOXEL] = 11, [FFD_CELL_HEXAHEDRON] = 12, [FFD_CELL_WEDGE] = 13,
    [FFD_CELL_PYRAMID] = 14, [FFD_CELL_QUADRATIC_EDGE] = 15, [FFD_CELL_QUADRATIC_TRIANGLE] = 16,
    [FFD_CELL_QUADRATIC_QUAD] = 17, [FFD_CELL_BIQUADRATIC_QUAD] = 18,
    [FFD_CELL_QUADRATIC_TETRA] = 19, [FFD_CELL_QUADRATIC_HEXAHEDRON] = 20,
    [FFD_CELL_TRIQUADRATIC_HEXAHEDRON] = 21, [FFD_CELL_QUADRATIC_WEDGE] = 22,
    [FFD_CELL_QUADRATIC_PYRAMID] = 23,
};

const ffd_cell_type *ffd_cell_type_of(unsigned vtk_id)
{
    if (vtk_id > 255 || !type_index[vtk_id])
        return NULL;
    return &cell_types[type_index[vtk_id] - 1];
}

bool ffd_cell_node_count_ok(const ffd_cell_type *t, size_t n)
{
    return t->nodes ? n == t->nodes : n >= t->min_nodes;
}

const char *ffd_cell_type_name(unsigned vtk_id)
{
    const ffd_cell_type *t = ffd_cell_type_of(vtk_id);
    return t ? t->name : NULL;
}

int ffd_cell_type_dimension(unsigned vtk_id)
{
    const ffd_cell_type *t = ffd_cell_type_of(vtk_id);
    return t ? t->dimension : -1;
}

/* ======================================================================
 * Building
 * ====================================================================== */

bool ffd_mesh_reserve_cells(ffd_mesh *m, size_t cells, size_t indices)
{
    if (cells >= SIZE_MAX / 2)
        return false;
    if (cells > m->cell_cap) {
        size_t cap = m->cell_cap ? m->cell_cap : 16;
        while (cap < cells)
            cap *= 2;
        uint8_t *t = ffd_realloc_array(m->cell_types, cap, sizeof(uint8_t));
        if (!t)
            return false;
        m->cell_types = t;
        uint64_t *o = ffd_realloc_array(m->cell_offsets, cap + 1, sizeof(uint64_t));
        if (!o)
            return false;
        if (!m->cell_offsets)
            o[0] = 0;
        m->cell_offsets = o;
        m->cell_cap = cap;
    }
    if (indices > m->cell_index_cap &&
        !ffd_grow((void **)&m->cell_indices, &m->cell_index_cap, indices, sizeof(uint32_t)))
        return false;
    return true;
}

bool ffd_mesh_push_cell(ffd_mesh *m, uint8_t vtk_type, const uint32_t *nodes, size_t n)
{
    if (n > UINT32_MAX || m->cell_index_count > SIZE_MAX - n)
        return false;
    if (!ffd_mesh_reserve_cells(m, m->cell_count + 1, m->cell_index_count + n))
        return false;
    if (n)
        memcpy(m->cell_indices + m->cell_index_count, nodes, n * sizeof(uint32_t));
    m->cell_index_count += n;
    m->cell_types[m->cell_count] = vtk_type;
    m->cell_offsets[++m->cell_count] = m->cell_index_count;
    return true;
}

void ffd_mesh_free_cells(ffd_mesh *m)
{
    ffd_free(m->cell_types);
    ffd_free(m->cell_offsets);
    ffd_free(m->cell_indices);
    ffd_free(m->face_cells);
    for (size_t i = 0; i < m->field_count; i++) {
        ffd_free(m->fields[i].name);
        ffd_free(m->fields[i].values);
    }
    ffd_free(m->fields);
    ffd_free(m->node_tags);
    m->node_tags = NULL;
    m->cell_types = NULL;
    m->cell_offsets = NULL;
    m->cell_indices = NULL;
    m->face_cells = NULL;
    m->fields = NULL;
    m->cell_count = m->cell_cap = m->cell_index_count = m->cell_index_cap = 0;
    m->field_count = m->field_cap = 0;
}

/* ======================================================================
 * Faces of the mesh from its cells
 * ====================================================================== */

static void locate(char *buf, size_t size, const char *name, ffd_cell_locator where,
                   const void *user, size_t cell)
{
    if (where)
        where(user, cell, buf, size);
    else
        snprintf(buf, size, "%s: cell %zu", name, cell);
}

/* Appends face (corner list) of cell c as a mesh face. */
static bool push_face(ffd_mesh *m, const uint32_t *ids, size_t n, uint32_t cell, size_t *face_cap)
{
    for (size_t k = 0; k < n; k++)
        if (!ffd_mesh_push_index(m, ids[k]))
            return false;
    if (!ffd_mesh_end_face(m))
        return false;
    if (m->face_count > *face_cap &&
        !ffd_grow((void **)&m->face_cells, face_cap, m->face_count, sizeof(uint32_t)))
        return false;
    m->face_cells[m->face_count - 1] = cell;
    return true;
}

/* The corners of local face f of cell c, in order; returns the count. */
static size_t cell_face(const ffd_mesh *m, const ffd_cell_type *t, size_t c, unsigned f,
                        uint32_t out[4])
{
    const uint32_t *nodes = m->cell_indices + m->cell_offsets[c];
    for (unsigned k = 0; k < t->face_size[f]; k++)
        out[k] = nodes[t->face_nodes[f][k]];
    return t->face_size[f];
}

static void sort_small(uint32_t *v, size_t n)
{
    for (size_t i = 1; i < n; i++)
        for (size_t j = i; j > 0 && v[j - 1] > v[j]; j--) {
            uint32_t x = v[j];
            v[j] = v[j - 1];
            v[j - 1] = x;
        }
}

/* Boundary of the 3D cells: every local face of a 3D cell whose corner set
 * no other 3D cell face has. Faces are bucketed by their smallest corner
 * (a counting sort, linear and deterministic) and compared within their
 * bucket. Boundary faces are emitted in cell order, then local face order. */
static ffd_status extract_boundary(ffd_mesh *m, const char *name, ffd_error *err)
{
    size_t nv = m->vertex_count, total = 0;
    for (size_t c = 0; c < m->cell_count; c++) {
        const ffd_cell_type *t = ffd_cell_type_of(m->cell_types[c]);
        if (t->dimension == 3)
            total += t->face_count;
    }
    uint32_t *bucket_start = ffd_calloc(nv + 1, sizeof(uint32_t));
    uint64_t *ref = total ? ffd_malloc(total * sizeof(uint64_t)) : NULL; /* cell << 3 | face */
    uint8_t *shared = total ? ffd_calloc(total, 1) : NULL;
    uint64_t *first = ffd_malloc((m->cell_count + 1) * sizeof(uint64_t)); /* first face of cell */
    if (!bucket_start || (total && (!ref || !shared)) || !first || total > UINT32_MAX) {
        ffd_free(bucket_start);
        ffd_free(ref);
        ffd_free(shared);
        ffd_free(first);
        return total > UINT32_MAX
                   ? ffd_fail(err, FFD_ERR_INVALID,
                              "%s: %zu cell faces, more than the 4294967295 the library handles",
                              name, total)
                   : ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory extracting the boundary", name);
    }
    uint32_t key[4];
    size_t at = 0;
    for (size_t c = 0; c < m->cell_count; c++) {
        const ffd_cell_type *t = ffd_cell_type_of(m->cell_types[c]);
        first[c] = at;
        if (t->dimension != 3)
            continue;
        for (unsigned f = 0; f < t->face_count; f++, at++) {
            size_t n = cell_face(m, t, c, f, key);
            sort_small(key, n);
            bucket_start[key[0] + 1]++;
        }
    }
    first[m->cell_count] = at;
    for (size_t i = 0; i < nv; i++)
        bucket_start[i + 1] += bucket_start[i];
    /* place: a running cursor per bucket (reuse a copy of the starts) */
    uint32_t *cursor = ffd_malloc((nv + 1) * sizeof(uint32_t));
    if (!cursor) {
        ffd_free(bucket_start);
        ffd_free(ref);
        ffd_free(shared);
        ffd_free(first);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory extracting the boundary", name);
    }
    memcpy(cursor, bucket_start, (nv + 1) * sizeof(uint32_t));
    for (size_t c = 0; c < m->cell_count; c++) {
        const ffd_cell_type *t = ffd_cell_type_of(m->cell_types[c]);
        if (t->dimension != 3)
            continue;
        for (unsigned f = 0; f < t->face_count; f++) {
            size_t n = cell_face(m, t, c, f, key);
            sort_small(key, n);
            ref[cursor[key[0]]++] = (uint64_t)c << 3 | f;
        }
    }
    ffd_free(cursor);
    /* each bucket's faces get their sorted keys once, then are compared pairwise */
    uint32_t (*keys)[4] = NULL;
    size_t keys_cap = 0;
    for (size_t b = 0; b < nv; b++) {
        size_t k = bucket_start[b + 1] - bucket_start[b];
        if (k < 2)
            continue;
        if (k > keys_cap) {
            void *grown = ffd_realloc_array(keys, k, sizeof *keys);
            if (!grown) {
                ffd_free(keys);
                ffd_free(bucket_start);
                ffd_free(ref);
                ffd_free(shared);
                ffd_free(first);
                return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory extracting the boundary",
                                name);
            }
            keys = grown;
            keys_cap = k;
        }
        const uint64_t *r = ref + bucket_start[b];
        for (size_t i = 0; i < k; i++) {
            size_t ci = (size_t)(r[i] >> 3);
            unsigned fi = (unsigned)(r[i] & 7);
            size_t ni = cell_face(m, ffd_cell_type_of(m->cell_types[ci]), ci, fi, keys[i]);
            sort_small(keys[i], ni);
            if (ni == 3)
                keys[i][3] = UINT32_MAX; /* a triangle never matches a quad */
        }
        for (size_t i = 0; i < k; i++)
            for (size_t j = i + 1; j < k; j++)
                if (memcmp(keys[i], keys[j], sizeof keys[i]) == 0) {
                    shared[first[r[i] >> 3] + (r[i] & 7)] = 1;
                    shared[first[r[j] >> 3] + (r[j] & 7)] = 1;
                }
    }
    ffd_free(keys);
    ffd_free(bucket_start);
    ffd_free(ref);
    size_t face_cap = 0;
    ffd_status st = FFD_OK;
    for (size_t c = 0; c < m->cell_count && st == FFD_OK; c++) {
        const ffd_cell_type *t = ffd_cell_type_of(m->cell_types[c]);
        if (t->dimension != 3)
            continue;
        for (unsigned f = 0; f < t->face_count; f++) {
            if (shared[first[c] + f])
                continue;
            size_t n = cell_face(m, t, c, f, key);
            if (!push_face(m, key, n, (uint32_t)c, &face_cap)) {
                st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory extracting the boundary", name);
                break;
            }
        }
    }
    ffd_free(shared);
    ffd_free(first);
    return st;
}

/* Without 3D cells: the 2D cells are the faces (corners only; a pixel in
 * quad order; a triangle strip as its triangles, every other one reversed). */
static ffd_status faces_from_2d_cells(ffd_mesh *m, const char *name, ffd_error *err)
{
    size_t face_cap = 0;
    for (size_t c = 0; c < m->cell_count; c++) {
        const ffd_cell_type *t = ffd_cell_type_of(m->cell_types[c]);
        if (t->dimension != 2)
            continue;
        const uint32_t *v = m->cell_indices + m->cell_offsets[c];
        size_t n = (size_t)(m->cell_offsets[c + 1] - m->cell_offsets[c]);
        bool ok = true;
        if (t->vtk == FFD_CELL_TRIANGLE_STRIP) {
            for (size_t k = 0; k + 2 < n && ok; k++) {
                uint32_t tri[3] = {v[k], v[k + 1], v[k + 2]};
                if (k & 1) {
                    tri[0] = v[k + 1];
                    tri[1] = v[k];
                }
                ok = push_face(m, tri, 3, (uint32_t)c, &face_cap);
            }
        } else if (t->vtk == FFD_CELL_PIXEL) {
            uint32_t q[4] = {v[0], v[1], v[3], v[2]};
            ok = push_face(m, q, 4, (uint32_t)c, &face_cap);
        } else {
            ok = push_face(m, v, t->corners ? t->corners : n, (uint32_t)c, &face_cap);
        }
        if (!ok)
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory making faces of the cells", name);
    }
    return FFD_OK;
}

ffd_status ffd_mesh_finish_cells(ffd_mesh *m, const char *name, ffd_cell_locator where,
                                 const void *user, ffd_error *err)
{
    char at[256];
    name = ffd_name_or(name, "<memory>");
    if (m->cell_count > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: %zu cells, more than the 4294967295 the library handles", name,
                        m->cell_count);
    bool volume = false;
    for (size_t c = 0; c < m->cell_count; c++) {
        const ffd_cell_type *t = ffd_cell_type_of(m->cell_types[c]);
        size_t n = (size_t)(m->cell_offsets[c + 1] - m->cell_offsets[c]);
        if (!t) {
            locate(at, sizeof at, name, where, user, c);
            return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                            "%s: cell type %u is not one the library reads (docs/volume.md lists them)",
                            at, (unsigned)m->cell_types[c]);
        }
        if (!ffd_cell_node_count_ok(t, n)) {
            locate(at, sizeof at, name, where, user, c);
            if (t->nodes)
                return ffd_fail(err, FFD_ERR_PARSE, "%s: a %s cell has %u nodes, not %zu", at,
                                t->name, (unsigned)t->nodes, n);
            return ffd_fail(err, FFD_ERR_PARSE, "%s: a %s cell needs at least %u nodes, not %zu",
                            at, t->name, (unsigned)t->min_nodes, n);
        }
        const uint32_t *v = m->cell_indices + m->cell_offsets[c];
        for (size_t k = 0; k < n; k++)
            if (v[k] >= m->vertex_count) {
                locate(at, sizeof at, name, where, user, c);
                return ffd_fail(err, FFD_ERR_RANGE, "%s: node %u out of range (%zu nodes)", at,
                                v[k], m->vertex_count);
            }
        if (t->dimension == 3)
            volume = true;
    }
    m->volume = volume;
    m->face_count = 0;
    m->index_count = 0;
    return volume ? extract_boundary(m, name, err) : faces_from_2d_cells(m, name, err);
}

/* ======================================================================
 * Cells to write
 * ====================================================================== */

ffd_status ffd_cells_view_of(const ffd_mesh *m, ffd_cells_view *v, ffd_error *err)
{
    memset(v, 0, sizeof *v);
    if (m->cell_count) {
        v->count = m->cell_count;
        v->types = m->cell_types;
        v->offsets = m->cell_offsets;
        v->indices = m->cell_indices;
        return FFD_OK;
    }
    size_t nf = m->face_count;
    v->own_types = ffd_malloc(nf ? nf : 1);
    v->own_offsets = ffd_malloc((nf + 1) * sizeof(uint64_t));
    if (!v->own_types || !v->own_offsets) {
        ffd_cells_view_free(v);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory listing the faces as cells");
    }
    for (size_t f = 0; f <= nf; f++)
        v->own_offsets[f] = m->face_offsets[f];
    for (size_t f = 0; f < nf; f++) {
        uint32_t n = m->face_offsets[f + 1] - m->face_offsets[f];
        v->own_types[f] = n == 3 ? FFD_CELL_TRIANGLE : n == 4 ? FFD_CELL_QUAD : FFD_CELL_POLYGON;
    }
    v->count = nf;
    v->types = v->own_types;
    v->offsets = v->own_offsets;
    v->indices = m->face_indices;
    return FFD_OK;
}

void ffd_cells_view_free(ffd_cells_view *v)
{
    ffd_free(v->own_types);
    ffd_free(v->own_offsets);
    memset(v, 0, sizeof *v);
}

/* ======================================================================
 * Fields
 * ====================================================================== */

bool ffd_mesh_add_field(ffd_mesh *m, const char *name, int association, uint32_t components,
                        int kind, const double *values, size_t count)
{
    if (components == 0 || (count && count > SIZE_MAX / sizeof(double) / components))
        return false;
    if (m->field_count == m->field_cap &&
        !ffd_grow((void **)&m->fields, &m->field_cap, m->field_count + 1, sizeof(ffd_mesh_field)))
        return false;
    size_t len = strlen(name);
    ffd_mesh_field f = {0};
    f.name = ffd_malloc(len + 1);
    f.values = ffd_malloc(count ? count * components * sizeof(double) : 1);
    if (!f.name || !f.values) {
        ffd_free(f.name);
        ffd_free(f.values);
        return false;
    }
    memcpy(f.name, name, len + 1);
    if (count)
        memcpy(f.values, values, count * components * sizeof(double));
    f.association = association;
    f.components = components;
    f.kind = kind;
    m->fields[m->field_count++] = f;
    return true;
}

/* ======================================================================
 * Public accessors and creation from arrays
 * ====================================================================== */

size_t ffd_mesh_cell_count(const ffd_mesh *mesh) { return mesh ? mesh->cell_count : 0; }
const uint8_t *ffd_mesh_cell_types(const ffd_mesh *mesh)
{
    return mesh && mesh->cell_count ? mesh->cell_types : NULL;
}
const uint64_t *ffd_mesh_cell_offsets(const ffd_mesh *mesh)
{
    return mesh && mesh->cell_count ? mesh->cell_offsets : NULL;
}
const uint32_t *ffd_mesh_cell_indices(const ffd_mesh *mesh)
{
    return mesh && mesh->cell_count ? mesh->cell_indices : NULL;
}
int ffd_mesh_is_volume(const ffd_mesh *mesh) { return mesh && mesh->volume; }
const uint32_t *ffd_mesh_face_cells(const ffd_mesh *mesh)
{
    return mesh && mesh->cell_count ? mesh->face_cells : NULL;
}

size_t ffd_mesh_field_count(const ffd_mesh *mesh) { return mesh ? mesh->field_count : 0; }

const uint64_t *ffd_mesh_node_tags(const ffd_mesh *mesh) { return mesh ? mesh->node_tags : NULL; }

ffd_status ffd_mesh_field_get(const ffd_mesh *mesh, size_t i, ffd_field_info *info, ffd_error *err)
{
    if (!mesh || !info || i >= mesh->field_count)
        return ffd_fail(err, FFD_ERR_RANGE, "ffd_mesh_field_get: field %zu out of range (%zu fields)",
                        i, mesh ? mesh->field_count : 0);
    const ffd_mesh_field *f = &mesh->fields[i];
    info->name = f->name;
    info->association = f->association;
    info->components = f->components;
    info->count = f->association == FFD_FIELD_POINT ? mesh->vertex_count : mesh->cell_count;
    info->values = f->values;
    return FFD_OK;
}

ffd_status ffd_mesh_create_cells(const double *positions, size_t vertex_count,
                                 const uint8_t *types, const uint64_t *offsets,
                                 const uint32_t *indices, size_t cell_count, ffd_mesh **out,
                                 ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_create_cells: out is NULL");
    *out = NULL;
    if (cell_count && (!types || !offsets || !indices))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_create_cells: cells are NULL");
    if (cell_count && offsets[0] != 0)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_create_cells: offsets[0] must be 0");
    for (size_t c = 0; c < cell_count; c++)
        if (offsets[c + 1] < offsets[c])
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_mesh_create_cells: offsets decrease at cell %zu", c);
    ffd_mesh *m = NULL;
    ffd_status st = ffd_mesh_create(positions, vertex_count, NULL, NULL, 0, &m, err);
    if (st)
        return st;
    size_t nidx = cell_count ? (size_t)offsets[cell_count] : 0;
    if (!ffd_mesh_reserve_cells(m, cell_count, nidx)) {
        ffd_mesh_destroy(m);
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_create_cells: out of memory");
    }
    if (cell_count) {
        memcpy(m->cell_types, types, cell_count);
        memcpy(m->cell_offsets, offsets, (cell_count + 1) * sizeof(uint64_t));
        memcpy(m->cell_indices, indices, nidx * sizeof(uint32_t));
    }
    m->cell_count = cell_count;
    m->cell_index_count = nidx;
    st = ffd_mesh_finish_cells(m, "ffd_mesh_create_cells", NULL, NULL, err);
    if (st) {
        ffd_mesh_destroy(m);
        return st;
    }
    *out = m;
    return FFD_OK;
}

/* ---- the canonical order of faces ---- */

typedef struct face_key {
    const uint32_t *sorted, *corner;
    uint32_t count, face;
} face_key;

static int compare_face_keys(const void *a, const void *b)
{
    const face_key *f = a, *g = b;
    if (f->count != g->count)
        return f->count < g->count ? -1 : 1;
    for (uint32_t k = 0; k < f->count; k++)
        if (f->sorted[k] != g->sorted[k])
            return f->sorted[k] < g->sorted[k] ? -1 : 1;
    for (uint32_t k = 0; k < f->count; k++)
        if (f->corner[k] != g->corner[k])
            return f->corner[k] < g->corner[k] ? -1 : 1;
    return (f->face > g->face) - (f->face < g->face);
}

static int compare_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

bool ffd_faces_canonical_order(const uint32_t *offsets, const uint32_t *indices, size_t count,
                               uint32_t **order_out, uint32_t **sorted_out)
{
    size_t corners = count ? offsets[count] : 0;
    uint32_t *sorted = ffd_malloc_array(corners ? corners : 1, sizeof *sorted);
    face_key *keys = ffd_malloc_array(count ? count : 1, sizeof *keys);
    uint32_t *order = ffd_malloc_array(count ? count : 1, sizeof *order);
    bool ok = sorted && keys && order;
    if (ok) {
        if (corners)
            memcpy(sorted, indices, corners * sizeof *sorted);
        for (size_t f = 0; f < count; f++) {
            uint32_t b = offsets[f], e = offsets[f + 1];
            qsort(sorted + b, e - b, sizeof *sorted, compare_u32);
            keys[f] = (face_key){sorted + b, indices + b, e - b, (uint32_t)f};
        }
        if (count)
            qsort(keys, count, sizeof *keys, compare_face_keys);
        for (size_t f = 0; f < count; f++)
            order[f] = keys[f].face;
    }
    ffd_free(keys);
    if (ok && sorted_out)
        *sorted_out = sorted;
    else
        ffd_free(sorted);
    if (ok)
        *order_out = order;
    else
        ffd_free(order);
    return ok;
}
