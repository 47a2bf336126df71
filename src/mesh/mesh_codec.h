/* mesh_codec — a mesh file format as one descriptor (a codec), and the one
 * table of codecs that reading, writing and refinement look formats up in.
 *
 * Each format lives in one file (mesh_obj.c, mesh_ply.c, mesh_off.c,
 * mesh_stl.c) that defines its codec, `const ffd_mesh_codec
 * ffd_mesh_codec_<format>`, and keeps every other function static: its
 * reader, its writers, and its part of refinement (how new vertices and
 * faces are written in that format). mesh.c, mesh_write.c and mesh_refine.c
 * never switch on the format; they call ffd_mesh_codec_find and the codec's
 * entries. Adding a format (glTF) is: a value in ffd_format (include/ffd.h),
 * one file defining its codec, its line in the table (mesh_codec.c) and its
 * extern below; docs/mesh-formats.md walks through it.
 *
 * There is no content sniffing: the file extension (ffd_format_from_path)
 * or the caller's ffd_format chooses the codec; a codec's read may tell its
 * encodings apart (STL: binary by size, else ascii). */
#ifndef FFD_MESH_CODEC_H
#define FFD_MESH_CODEC_H

#include "mesh.h"

/* ======================================================================
 * Refinement: what a codec's refine entry is given
 * ====================================================================== */

/* A validated plan (ffd_mesh_refine) prepared for the codec: flattened
 * parents of the new vertices and every position. */
typedef struct ffd_refine_ctx {
    const ffd_mesh *m;
    const ffd_refine_plan *p;
    size_t nv, nnew, ntot, nf, nfo; /* original/new/all vertices, original/new faces */
    size_t *flat_off;               /* nnew + 1 */
    uint32_t *flat_idx;             /* flattened parents (original vertices) */
    double *flat_w;
    double *pos;          /* 3 * ntot: current positions, then the new ones */
    size_t *child_begin;  /* nf + 1: first child of each original face */
    const char *nl;       /* line end for generated lines */
} ffd_refine_ctx;

/* Whether plan face f lists exactly the corners of original face F. */
bool ffd_refine_same_face(const ffd_refine_ctx *c, size_t f, size_t F);
/* Normal of new vertex j from per-original-vertex normals (weighted mean,
 * rescaled to the weighted mean length of the parents' normals). */
void ffd_refine_blend_normals(const ffd_refine_ctx *c, size_t j, const double *normals,
                              double out[3]);
/* Distinct edges of the plan's faces (self-loops not counted); false on OOM. */
bool ffd_refine_count_edges(const ffd_refine_ctx *c, size_t *edges);
/* Copies src[from, to) with the position and normal values that changed
 * rewritten (spans are in file order; none straddles from or to). */
void ffd_refine_put_source(ffd_buf *b, const ffd_mesh *m, size_t from, size_t to);
/* Binary sources: a changed position must fit the file's scalar type (FFD_ERR_RANGE). */
ffd_status ffd_refine_check_binary_fits(const ffd_mesh *m, ffd_error *err);

/* Output cursor over the source: flush copies (patched) up to an offset;
 * setting copied past bytes drops them. */
typedef struct ffd_refine_cursor {
    ffd_buf *b;
    const ffd_mesh *m;
    size_t copied;
} ffd_refine_cursor;
void ffd_refine_flush_to(ffd_refine_cursor *k, size_t to);

/* Extra per-vertex numbers of text formats (OBJ v, OFF): the values after
 * x y z of each vertex line, and whether each was written as an integer. */
typedef struct ffd_refine_extras {
    size_t *off; /* nv + 1 */
    double *val;
    uint8_t *isint;
    size_t n, cap, cap2;
} ffd_refine_extras;
void ffd_refine_extras_free(ffd_refine_extras *x);
/* Appends the numbers of [p, e) after the first skip as vertex i's extras; false on OOM. */
bool ffd_refine_extras_add(ffd_refine_extras *x, size_t i, const char *p, const char *e,
                           size_t skip);
/* " v1 v2 ..." for new vertex j: the extras its parents have in common
 * (int_rule: rounded when all parents wrote integers). */
void ffd_refine_put_extras(ffd_buf *b, const ffd_refine_ctx *c, size_t j,
                           const ffd_refine_extras *x, bool int_rule);

/* Physical lines of text sources. */
typedef struct ffd_text_line {
    const char *p;    /* line start */
    const char *ce;   /* content end (before "\r\n" / "\n") */
    const char *next; /* start of the next line */
} ffd_text_line;
/* The line at *at (advanced past it); false at end. */
bool ffd_text_next_line(const char **at, const char *end, ffd_text_line *l);
/* The first non-blank at or after p (e when none). */
const char *ffd_text_skip_blanks(const char *p, const char *e);
/* The end of the word starting at q (first blank or e). */
const char *ffd_text_word_end(const char *q, const char *e);
/* The first '#' in [p, e), or e. */
const char *ffd_text_hash_in(const char *p, const char *e);
/* Line end after a generated child: the line's own, or nl before more lines. */
void ffd_text_put_term(ffd_buf *b, const ffd_text_line *l, bool last, const char *nl);
/* After a copied line, before inserted lines: a line end if it had none. */
void ffd_text_ensure_lf(ffd_buf *b, const ffd_text_line *l, const char *nl);

/* ======================================================================
 * The codec
 * ====================================================================== */

/* Bit of an encoding in ffd_mesh_codec.encodings. */
#define FFD_CODEC_ENCODING(e) (1u << (unsigned)(e))

typedef struct ffd_mesh_codec {
    ffd_format format;
    const char *name;              /* in messages: "OBJ" */
    const char *const *extensions; /* lower case, without the dot, NULL-terminated */
    unsigned encodings;            /* FFD_CODEC_ENCODING bits it can write (ASCII, BINARY_*) */
    bool triangles_only;           /* refinement plans must hold triangles */

    /* Parses m->src (m->src_size bytes, NUL-terminated) into m: vertices,
     * faces, normals, with a span for every stored position and normal
     * coordinate; sets m->encoding. name prefixes messages. */
    ffd_status (*read)(ffd_mesh *m, const char *name, ffd_error *err);
    /* Same format and encoding as the source: m->src with the changed
     * positions and normals rewritten in place (ffd_mesh_patch_spans for a
     * format whose values are all spans). */
    ffd_status (*patch)(const ffd_mesh *m, ffd_buf *b, ffd_error *err);
    /* Same format, another encoding, everything kept; NULL: write from data. */
    ffd_status (*transcode)(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err);
    /* From data (another source format, or a mesh made by ffd_mesh_create);
     * enc is one of the codec's encodings. */
    ffd_status (*write)(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err);
    /* The refined mesh as a file of the source's format and encoding
     * (see ffd_mesh_refine); c->m->src is set. */
    ffd_status (*refine)(ffd_refine_ctx *c, ffd_buf *b, ffd_error *err);
    /* Optional: ffd_mesh_write to path in the encoding the source (or the
     * path's extension) implies, for a format whose file comes with others
     * (glTF's external buffers) or whose extension names the encoding. */
    ffd_status (*write_file)(const ffd_mesh *m, const char *path, ffd_error *err);
    /* Optional: every write with the whole options (o->format is the codec's,
     * o->encoding resolved from SAME), for a format with options beyond the
     * encoding (VTU's compression); patch/transcode/write are then the
     * codec's own business. NULL: the dispatch above. */
    ffd_status (*write_options)(const ffd_mesh *m, const ffd_write_options *o, ffd_buf *b,
                                ffd_error *err);
} ffd_mesh_codec;

extern const ffd_mesh_codec ffd_mesh_codec_obj;
extern const ffd_mesh_codec ffd_mesh_codec_ply;
extern const ffd_mesh_codec ffd_mesh_codec_off;
extern const ffd_mesh_codec ffd_mesh_codec_stl;
extern const ffd_mesh_codec ffd_mesh_codec_gltf;
/* Volume formats (cells: mesh_cells.h). refine is NULL: refinement is for surfaces. */
extern const ffd_mesh_codec ffd_mesh_codec_vtk;
extern const ffd_mesh_codec ffd_mesh_codec_vtu;
extern const ffd_mesh_codec ffd_mesh_codec_msh;
extern const ffd_mesh_codec ffd_mesh_codec_su2;
extern const ffd_mesh_codec ffd_mesh_codec_xyz;
extern const ffd_mesh_codec ffd_mesh_codec_npy;

/* The codec of a format; NULL for FFD_FORMAT_AUTO or an unknown value. */
const ffd_mesh_codec *ffd_mesh_codec_find(ffd_format format);
/* The codec whose extensions include ext (no dot, any case); NULL when none. */
const ffd_mesh_codec *ffd_mesh_codec_for_extension(const char *ext);
/* "a, b, c or d" over every codec: their first extensions with a dot
 * (names false) or their names (names true), for messages. */
const char *ffd_mesh_codec_list(bool names, char *buf, size_t size);
/* Room for ffd_mesh_codec_list's text. */
#define FFD_MESH_CODEC_LIST_SIZE 256

/* The generic patch: every changed value of a span rewritten in the
 * source's bytes (text: shortest round-trip; binary: the span's type). */
ffd_status ffd_mesh_patch_spans(const ffd_mesh *m, ffd_buf *b, ffd_error *err);

#endif
