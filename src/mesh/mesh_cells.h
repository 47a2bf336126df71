/* mesh_cells — the cells of volume meshes (and of the polygonal cells of
 * the volume formats' surface files), the one table of cell types every
 * volume codec, the boundary extraction and the cell checks read, and the
 * point and cell data (fields) those formats carry.
 *
 * Cell types are VTK's (FFD_CELL_* in include/ffd.h), with VTK's node
 * order; a codec whose format orders nodes otherwise (Gmsh, SU2) maps them
 * when it reads and maps back when it writes from data. A mesh with at least
 * one 3D cell is a volume mesh: its faces (m->face_*) are the boundary
 * surface of its 3D cells, extracted by ffd_mesh_finish_cells, each face
 * oriented outwards for a positively oriented cell, so every method and
 * every surface tool (PB-FFD placement, the T-spline proxy, the editor)
 * sees the volume's skin while every node is deformed. A mesh whose cells
 * are all 0D/1D/2D (VTK polydata, a surface .msh or .su2) has its 2D cells
 * as faces (triangle strips as triangles, quadratic faces by their corners).
 *
 * Docs: docs/volume.md. */
#ifndef FFD_MESH_CELLS_H
#define FFD_MESH_CELLS_H

#include "mesh.h"

/* What the library knows of a cell type. */
typedef struct ffd_cell_type {
    uint8_t vtk;            /* VTK id (FFD_CELL_*) */
    uint8_t dimension;      /* 0, 1, 2, 3 */
    uint8_t nodes;          /* node count; 0: any (poly vertex, poly line, strip, polygon, polyhedron) */
    uint8_t corners;        /* corner (linear) nodes: the first `corners` nodes */
    uint8_t min_nodes;      /* for variable-size types: the fewest nodes */
    uint8_t face_count;     /* 3D: faces */
    const char *name;       /* "tetra", "hexahedron", ... (VTK's, lower case: meshio's names) */
    /* 3D: face f has face_size[f] corners, face_nodes[f][0..size), local
     * corner ids, outwards (right-hand rule) for a positive cell. */
    uint8_t face_size[6];
    uint8_t face_nodes[6][4];
} ffd_cell_type;

/* The canonical order of count faces (offsets/indices as a mesh's): by
 * corner count, then the corners sorted, then the corners as given, then
 * the face's id. A sum over the faces in this order depends on the set of
 * faces, not on their order in a file (PB-FFD placement), and two faces on
 * the same corners are neighbours in it (the surface a distributed run
 * gathers, deformer/distributed.c). *order receives the face ids in that
 * order; with sorted not NULL, *sorted receives each face's corners sorted,
 * at the face's offsets (both ffd_free'd by the caller). false when out of
 * memory (nothing to free). */
bool ffd_faces_canonical_order(const uint32_t *offsets, const uint32_t *indices, size_t count,
                               uint32_t **order, uint32_t **sorted);

/* The type of a VTK id, or NULL for one the library does not read
 * (polyhedron 42, higher-order Lagrange cells, ...). */
const ffd_cell_type *ffd_cell_type_of(unsigned vtk_id);
/* Whether n nodes make a valid cell of type t. */
bool ffd_cell_node_count_ok(const ffd_cell_type *t, size_t n);

/* ---- building (mesh_cells.c) -------------------------------------------- */

/* Appends a cell: its VTK type and n node ids (checked later, by
 * ffd_mesh_finish_cells). false on overflow or OOM. */
bool ffd_mesh_push_cell(ffd_mesh *m, uint8_t vtk_type, const uint32_t *nodes, size_t n);
bool ffd_mesh_reserve_cells(ffd_mesh *m, size_t cells, size_t indices);

/* After a reader pushed every vertex and cell: checks every cell (known
 * type, node count, node ids < vertex_count) and builds the faces: the
 * boundary of the 3D cells (a face of one 3D cell that no other 3D cell
 * shares, matched by its corner set) or, without 3D cells, the 2D cells.
 * The reader must not push faces itself. name and the locator callback
 * put the file position of a bad cell in the message: where(user, cell)
 * writes "name:line" or "name: byte N" for cell c into buf (may be NULL:
 * "name: cell c"). FFD_ERR_PARSE / FFD_ERR_RANGE / FFD_ERR_NOMEM. */
typedef void (*ffd_cell_locator)(const void *user, size_t cell, char *buf, size_t size);
ffd_status ffd_mesh_finish_cells(ffd_mesh *m, const char *name, ffd_cell_locator where,
                                 const void *user, ffd_error *err);

/* The cells to write for mesh m in a volume format: its own cells, or, for
 * a mesh without cells (a surface read from OBJ/PLY/..., or made from
 * arrays), its faces as triangle / quad / polygon cells. The view borrows m
 * or owns arrays freed by ffd_cells_view_free. */
typedef struct ffd_cells_view {
    size_t count;
    const uint8_t *types;
    const uint64_t *offsets; /* count + 1 */
    const uint32_t *indices;
    uint8_t *own_types;
    uint64_t *own_offsets;
} ffd_cells_view;
ffd_status ffd_cells_view_of(const ffd_mesh *m, ffd_cells_view *v, ffd_error *err);
void ffd_cells_view_free(ffd_cells_view *v);

/* ---- point and cell data ------------------------------------------------ */

/* A field's values, as doubles (every numeric type a volume format stores
 * fits: integers up to 2^53 exactly), and the scalar type the source used
 * (FFD_SPAN_I8 .. FFD_SPAN_F64, or FFD_FIELD_I64/U64 below) so a writer of
 * another format can keep it. */
#define FFD_FIELD_I64 (FFD_SPAN_F64 + 1)
#define FFD_FIELD_U64 (FFD_SPAN_F64 + 2)

typedef struct ffd_mesh_field {
    char *name;
    int association;     /* FFD_FIELD_POINT or FFD_FIELD_CELL (include/ffd.h) */
    uint32_t components;
    int kind;            /* FFD_SPAN_I8..F64, FFD_FIELD_I64, FFD_FIELD_U64 */
    double *values;      /* (vertex_count or cell_count) * components */
} ffd_mesh_field;

/* Adds a field (name and values copied; values has count * components
 * entries, count = the mesh's vertex or cell count at finish time, which the
 * writer checks). false on OOM. */
bool ffd_mesh_add_field(ffd_mesh *m, const char *name, int association, uint32_t components,
                        int kind, const double *values, size_t count);
void ffd_mesh_free_cells(ffd_mesh *m);

#endif
