/* mesh — internal header of the mesh module: the mesh type, the source-span
 * bookkeeping that makes writes lossless, and what the formats share (text
 * and binary scalars, the output buffer, refinement plans). The formats
 * themselves are codecs (mesh_codec.h), one file each.
 *
 * Lossless design: a mesh read from a file keeps the file's bytes (src). For
 * every vertex coordinate and every stored normal coordinate it records where
 * the value lives in src (a span: byte offset and length for text, byte offset
 * and scalar type for binary). Writing to the same format copies src and
 * rewrites only the spans whose current value differs (numerically: -0.0 is
 * 0.0) from the value that span holds, so an unchanged mesh is reproduced
 * byte for byte and a deformed one differs only in the positions and normals
 * that changed. */
#ifndef FFD_MESH_H
#define FFD_MESH_H

#include "core/core.h"

#include <stdbool.h>
#include <stdint.h>

/* Span kinds: text, or the binary scalar type (PLY names; STL uses F32). */
enum {
    FFD_SPAN_TEXT = 0,
    FFD_SPAN_I8,
    FFD_SPAN_U8,
    FFD_SPAN_I16,
    FFD_SPAN_U16,
    FFD_SPAN_I32,
    FFD_SPAN_U32,
    FFD_SPAN_F32,
    FFD_SPAN_F64
};

/* Anchor of a normal no face uses (OBJ vn never referenced): set_positions leaves it alone. */
#define FFD_NO_ANCHOR UINT32_MAX

/* 8 bytes, 3 per vertex (issue 17: 24 bytes of bookkeeping per vertex, was
 * 48). The length is not stored: a binary value is its kind's size, a text
 * value is the number strtod reads at offset (every reader made the span from
 * exactly that extent, ffd_parse_number), see ffd_span_length. */
typedef struct ffd_span {
    uint64_t offset : 56; /* byte offset in src (sources < 64 PiB) */
    uint64_t kind : 8;    /* FFD_SPAN_* */
} ffd_span;

struct ffd_mesh {
    ffd_format format;     /* source format; FFD_FORMAT_AUTO for ffd_mesh_create */
    ffd_encoding encoding; /* source encoding (ASCII, BINARY_LE, BINARY_BE) */
    unsigned char *src;    /* source bytes, NUL-terminated (NULL when created from arrays) */
    size_t src_size;

    size_t vertex_count, vertex_cap;
    double *positions;        /* 3 per vertex */
    ffd_span *position_spans; /* 3 per vertex, NULL when src is NULL */

    size_t face_count, face_cap;
    uint32_t *face_offsets; /* face_count + 1 */
    size_t index_count, index_cap;
    uint32_t *face_indices;

    size_t normal_count, normal_cap;
    double *normals;
    ffd_span *normal_spans;
    uint32_t *normal_anchors;
    int vertex_normals; /* normal i belongs to vertex i (PLY nx/ny/nz, NOFF) */
    int facet_normals;  /* normal f belongs to face f (STL) */

    /* Tangents (glTF TANGENT): x y z w, w the bitangent's handedness (+-1);
     * tangent i belongs to vertex tangent_anchors[i]. No spans: the codec
     * that reads them keeps their locations (mesh_gltf.c). */
    size_t tangent_count, tangent_cap;
    double *tangents; /* 4 per tangent */
    uint32_t *tangent_anchors;

    size_t texcoord_count;

    /* Cells of the volume formats (mesh_cells.h, docs/volume.md): VTK cell
     * types and node order; a mesh with a 3D cell is a volume mesh and its
     * faces above are the boundary of its 3D cells (face_cells: the cell of
     * each face; also for faces made of 2D cells). */
    size_t cell_count, cell_cap;
    uint8_t *cell_types;
    uint64_t *cell_offsets; /* cell_count + 1 (NULL without cells) */
    size_t cell_index_count, cell_index_cap;
    uint32_t *cell_indices;
    uint32_t *face_cells;
    bool volume;
    /* Point and cell data of the volume formats (struct ffd_mesh_field, mesh_cells.h). */
    size_t field_count, field_cap;
    struct ffd_mesh_field *fields;
    /* Gmsh node tags, one per vertex (mesh_msh.c; NULL for other formats):
     * a partitioned mesh's global numbering (ffd_mesh_node_tags). */
    uint64_t *node_tags;

    bool source_is_path; /* read by ffd_mesh_read: the codec may read files beside it */
    void *codec_state; /* a codec's own record of the source (glTF), freed with the mesh */
    void (*codec_state_free)(void *state);
};

/* ---- building (mesh.c) -------------------------------------------------- */

/* A zeroed mesh of the given source format with face_offsets = {0}; NULL on OOM. */
ffd_mesh *ffd_mesh_alloc(ffd_format format);
/* Ensure capacity; false on overflow or OOM. */
bool ffd_mesh_reserve(ffd_mesh *m, size_t vertices, size_t faces, size_t indices, size_t normals);
bool ffd_mesh_push_vertex(ffd_mesh *m, const double xyz[3], const ffd_span spans[3]);
bool ffd_mesh_push_normal(ffd_mesh *m, const double n[3], const ffd_span spans[3], uint32_t anchor);
/* A tangent (x y z w) of vertex anchor; false on overflow or OOM. */
bool ffd_mesh_push_tangent(ffd_mesh *m, const double t[4], uint32_t anchor);
bool ffd_mesh_push_index(ffd_mesh *m, uint32_t index);
bool ffd_mesh_end_face(ffd_mesh *m); /* closes the face made of the indices pushed since the last */

/* ---- vertex attributes (mesh_attribute.c; the rig's "weights") ---------- */

/* The per-vertex scalar attribute name of the mesh, *out vertex_count values
 * (ffd_free): a point field of one component (volume formats), a scalar
 * vertex property of a PLY file, or the "#NAME value" lines of an OBJ file
 * (one per vertex, in vertex order; docs/mesh-formats.md). FFD_ERR_INVALID
 * when the mesh has no such attribute, FFD_ERR_PARSE naming the line of an
 * OBJ value that is not a number or a count that differs from the vertex
 * count, FFD_ERR_NONFINITE for NaN or infinite values. */
ffd_status ffd_mesh_vertex_attribute(const ffd_mesh *m, const char *name, double **out,
                                     ffd_error *err);
/* The PLY part: *found 0 when the vertex element has no scalar property of
 * that name (mesh_ply.c). */
ffd_status ffd_ply_vertex_property(const ffd_mesh *m, const char *property, double **out,
                                   int *found, ffd_error *err);

/* ---- text and binary scalars (mesh.c) ----------------------------------- */

/* Blank within a line: space, tab, CR, VT, FF (not LF). */
static inline bool ffd_is_blank(int c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}
static inline bool ffd_is_space(int c)
{
    return ffd_is_blank(c) || c == '\n';
}
/* Parses one number starting exactly at *p (no leading blanks skipped); the
 * number must end at whitespace, at '#' when hash_ends is set, or at end.
 * Returns 1 and advances *p; 0 when no number starts at *p; -1 when garbage
 * follows the digits (*p then points at the garbage). */
int ffd_parse_number(const char **p, const char *end, bool hash_ends, double *out);
/* strtod (same value, same end) without its cost for plain decimals. */
double ffd_strtod(const char *s, char **end);
/* Shortest "%.Ng" (N = 15..17) that reads back as v, byte for byte what the
 * printf loop gives but without printf for most values; returns the length. buf >= 32. */
int ffd_format_double(char *buf, double v);
/* Same for a value of float precision (6..9 digits). */
int ffd_format_float(char *buf, float v);
/* Size in bytes of a binary span kind (0 for text). */
size_t ffd_span_kind_size(int kind);
/* Reads a binary scalar of the kind at p. */
double ffd_read_scalar(const unsigned char *p, int kind, bool big_endian);
/* Writes v as kind (integers rounded and clamped) at p. */
/* Whether v can be stored in a binary/typed property of this kind without clamping. */
bool ffd_scalar_fits(int kind, double v);
void ffd_write_scalar(unsigned char *p, int kind, bool big_endian, double v);
/* The value a span held in the source. */
double ffd_span_value(const ffd_mesh *m, const ffd_span *s);
/* The number of source bytes the span covers. */
size_t ffd_span_length(const ffd_mesh *m, const ffd_span *s);

/* ---- growable output buffer (mesh_write.c) ------------------------------ */

typedef struct ffd_buf {
    unsigned char *data;
    size_t size, cap;
    bool oom;
} ffd_buf;
void ffd_buf_put(ffd_buf *b, const void *p, size_t n);
void ffd_buf_puts(ffd_buf *b, const char *s);
void ffd_buf_printf(ffd_buf *b, const char *fmt, ...) FFD_PRINTF(2, 3);
void ffd_buf_double(ffd_buf *b, double v); /* shortest round-trip text */
/* "<prefix>x y z\n" with shortest round-trip numbers (prefix may be ""). */
void ffd_buf_vec3_line(ffd_buf *b, const char *prefix, const double p[3]);
void ffd_buf_uint(ffd_buf *b, uint64_t v); /* decimal */
/* Decimal text of v ("%lld" without printf); returns the length. buf >= 24. */
int ffd_format_int(char *buf, int64_t v);
void ffd_buf_xyz(ffd_buf *b, const double *v); /* " x y z", shortest round-trip numbers */
void ffd_buf_free(ffd_buf *b);

/* ---- reading ----------------------------------------------------------- */

/* Reads data (NUL at data[size]) as format through the format's codec
 * (mesh_codec.h); takes ownership of data in all cases. */
ffd_status ffd_mesh_read_owned(unsigned char *data, size_t size, ffd_format format,
                               const char *name, ffd_mesh **out, ffd_error *err);

/* Unit normal of triangle (a, b, c) or zero for a degenerate one. */
void ffd_triangle_normal(const double *a, const double *b, const double *c, double n[3]);

/* ---- refinement: new vertices and faces, same format (mesh_refine.c) ---- */

/* A new vertex: the weighted average of earlier vertices (original ones,
 * or new ones that come before it in the plan). Weights sum to 1. */
typedef struct ffd_refine_vertex {
    uint32_t parent_count; /* 1..4 */
    uint32_t parent[4];
    double weight[4];
} ffd_refine_vertex;

/* A refinement: new vertices get indices vertex_count, vertex_count+1, ...
 * in order; the faces replace all of the mesh's faces. face_parent[f] is
 * the original face new face f lies in (every original face with at least
 * one child; an unchanged face is its own single child). The children of a
 * face must be listed together, in the order the original faces appear. */
typedef struct ffd_refine_plan {
    size_t new_vertex_count;
    const ffd_refine_vertex *new_vertices;
    size_t face_count;
    const uint32_t *face_offsets; /* face_count + 1 */
    const uint32_t *face_indices; /* into old and new vertices */
    const uint32_t *face_parent;  /* face_count */
} ffd_refine_plan;

/* Builds *out: the mesh refined by the plan, in m's format and encoding,
 * written as a file of that format and read back (so *out is a normal,
 * lossless mesh whose src is the new file). Everything the source holds is
 * kept: every non-position element, property, comment and statement; new
 * vertices interpolate every per-vertex property (PLY properties of any
 * type, integers rounded and clamped; OFF and OBJ vertex colours; PLY
 * normals) with the plan's weights flattened onto original vertices, and
 * every per-corner attribute within the parent face (OBJ vt and vn: new vt
 * and vn records are appended after the last existing ones); new faces
 * copy their parent's per-face data (PLY face properties other than the
 * index list, OFF face colours, STL attribute bytes, the OBJ group,
 * material and smoothing context: the children of a face take its place
 * in the file). Positions of new vertices are the weighted average of the
 * current positions. A mesh made by ffd_mesh_create gets the same from
 * arrays. FFD_ERR_INVALID (bad plan: index out of range, weights, parent
 * order), FFD_ERR_NOMEM. */
ffd_status ffd_mesh_refine(const ffd_mesh *m, const ffd_refine_plan *plan, ffd_mesh **out,
                           ffd_error *err);

#endif
