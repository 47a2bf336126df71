/* mesh_vtk.c — the legacy VTK codec (.vtk: "# vtk DataFile Version 2.0" to
 * "5.1"), as described in "The VTK User's Guide", chapter 19 "VTK File
 * Formats" (Kitware), and as VTK's vtkDataReader/vtkDataWriter and meshio
 * read and write it.
 *
 * Read: DATASET UNSTRUCTURED_GRID (POINTS, CELLS, CELL_TYPES) and DATASET
 * POLYDATA (POINTS, VERTICES, LINES, POLYGONS, TRIANGLE_STRIPS), ASCII and
 * BINARY (big-endian). Cell lists in both layouts: the old one ("CELLS n
 * size", each cell its node count then its nodes) and 5.1's ("CELLS n+1 m",
 * OFFSETS and CONNECTIVITY arrays of any integer type). Every POINTS
 * coordinate gets a span (text: where the number starts; binary: F32/F64 at
 * its byte offset), so writing back to .vtk in the same encoding copies the
 * file and rewrites only the coordinates that changed (ffd_mesh_patch_spans).
 * Numeric POINT_DATA / CELL_DATA arrays (SCALARS, COLOR_SCALARS, VECTORS,
 * NORMALS, TEXTURE_COORDINATES, TENSORS, TENSORS6, GLOBAL_IDS,
 * PEDIGREE_IDS, FIELD arrays) become fields; string arrays, lookup tables,
 * METADATA and dataset FIELD data are skipped (their bytes stay in the
 * source, so same-format writes keep them).
 *
 * Written from data: version 5.1, DATASET UNSTRUCTURED_GRID always (it
 * holds every cell type, in the mesh's cell order), OFFSETS/CONNECTIVITY as
 * vtktypeint64, double points, fields as SCALARS (1 component), VECTORS (3)
 * or FIELD arrays (others). Hand-written rather than through VTK or meshio:
 * no library reports where each coordinate lives in the file, which the
 * lossless writes need. Docs: docs/volume.md "Legacy VTK". */
#include "mesh_cells.h"
#include "mesh_codec.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* ======================================================================
 * Data types (VTK names)
 * ====================================================================== */

enum { KIND_BIT = 100, KIND_STRING = 101 };

typedef struct vtk_type {
    const char *name;
    int kind;      /* FFD_SPAN_I8..F64, FFD_FIELD_I64/U64, KIND_BIT, KIND_STRING */
    unsigned size; /* bytes in binary files (0: bit and string) */
} vtk_type;

static const vtk_type vtk_types[] = {
    {"bit", KIND_BIT, 0},
    {"unsigned_char", FFD_SPAN_U8, 1},
    {"char", FFD_SPAN_I8, 1},
    {"signed_char", FFD_SPAN_I8, 1},
    {"unsigned_short", FFD_SPAN_U16, 2},
    {"short", FFD_SPAN_I16, 2},
    {"unsigned_int", FFD_SPAN_U32, 4},
    {"int", FFD_SPAN_I32, 4},
    {"unsigned_long", FFD_FIELD_U64, 8},
    {"long", FFD_FIELD_I64, 8},
    {"float", FFD_SPAN_F32, 4},
    {"double", FFD_SPAN_F64, 8},
    {"vtktypeint8", FFD_SPAN_I8, 1},
    {"vtktypeuint8", FFD_SPAN_U8, 1},
    {"vtktypeint16", FFD_SPAN_I16, 2},
    {"vtktypeuint16", FFD_SPAN_U16, 2},
    {"vtktypeint32", FFD_SPAN_I32, 4},
    {"vtktypeuint32", FFD_SPAN_U32, 4},
    {"vtktypeint64", FFD_FIELD_I64, 8},
    {"vtktypeuint64", FFD_FIELD_U64, 8},
    {"vtkIdType", FFD_SPAN_I32, 4}, /* vtkDataWriter writes id arrays as 32-bit int */
    {"string", KIND_STRING, 0},
    {"utf8_string", KIND_STRING, 0},
};

static const vtk_type type_int32 = {"int", FFD_SPAN_I32, 4};
static const vtk_type type_float = {"float", FFD_SPAN_F32, 4};
static const vtk_type type_uchar = {"unsigned_char", FFD_SPAN_U8, 1};

static bool word_is(const char *p, size_t n, const char *lit)
{
    size_t k = strlen(lit);
    if (n != k)
        return false;
    for (size_t i = 0; i < n; i++) {
        char a = p[i], b = lit[i];
        if (a >= 'a' && a <= 'z')
            a = (char)(a - 'a' + 'A');
        if (b >= 'a' && b <= 'z')
            b = (char)(b - 'a' + 'A');
        if (a != b)
            return false;
    }
    return true;
}

static const vtk_type *type_named(const char *p, size_t n)
{
    for (size_t i = 0; i < sizeof vtk_types / sizeof vtk_types[0]; i++)
        if (word_is(p, n, vtk_types[i].name))
            return &vtk_types[i];
    return NULL;
}

/* The VTK name of a field kind for writing 5.1 files: the sized
 * vtktype* names for integers, as meshio writes them (meshio's 5.1 reader
 * takes a plain "int" for 64 bits), double for anything else. */
static const char *kind_type_name(int kind)
{
    switch (kind) {
    case FFD_SPAN_I8: return "vtktypeint8";
    case FFD_SPAN_U8: return "vtktypeuint8";
    case FFD_SPAN_I16: return "vtktypeint16";
    case FFD_SPAN_U16: return "vtktypeuint16";
    case FFD_SPAN_I32: return "vtktypeint32";
    case FFD_SPAN_U32: return "vtktypeuint32";
    case FFD_SPAN_F32: return "float";
    case FFD_FIELD_I64: return "vtktypeint64";
    case FFD_FIELD_U64: return "vtktypeuint64";
    default: return "double";
    }
}

static uint64_t load_be(const unsigned char *p, unsigned size)
{
    uint64_t v = 0;
    for (unsigned i = 0; i < size; i++)
        v = v << 8 | p[i];
    return v;
}

static double decode(const unsigned char *p, const vtk_type *t)
{
    if (t->kind == FFD_FIELD_I64)
        return (double)(int64_t)load_be(p, 8);
    if (t->kind == FFD_FIELD_U64)
        return (double)load_be(p, 8);
    return ffd_read_scalar(p, t->kind, true);
}

/* ======================================================================
 * The reader: a cursor over the source, messages with line or byte
 * ====================================================================== */

typedef struct vtk_reader {
    const char *name;
    const char *s;
    size_t n, pos;
    bool binary;
    ffd_mesh *m;
    size_t *cell_pos; /* source offset of each cell's node list, for messages */
    size_t cell_pos_cap;
    bool cell_pos_binary; /* those offsets are in binary data */
    int assoc;            /* -1 before POINT_DATA / CELL_DATA */
    size_t assoc_count;
} vtk_reader;

typedef struct word {
    const char *p;
    size_t len;
    size_t off;
} word;

/* "name:line" of a text position, or "name: byte N" of one in binary data. */
static void locate(const vtk_reader *r, size_t off, bool in_binary, char *buf, size_t size)
{
    if (in_binary) {
        snprintf(buf, size, "%s: byte %zu", r->name, off);
        return;
    }
    size_t line = 1;
    for (const char *p = r->s, *e = r->s + (off < r->n ? off : r->n); (p = memchr(p, '\n', (size_t)(e - p))) != NULL; p++)
        line++;
    snprintf(buf, size, "%s:%zu", r->name, line);
}

static ffd_status fail_at(const vtk_reader *r, ffd_error *err, ffd_status st, size_t off,
                          bool in_binary, const char *fmt, ...) FFD_PRINTF(6, 7);
static ffd_status fail_at(const vtk_reader *r, ffd_error *err, ffd_status st, size_t off,
                          bool in_binary, const char *fmt, ...)
{
    char at[300], what[512];
    locate(r, off, in_binary, at, sizeof at);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return ffd_fail(err, st, "%s: %s", at, what);
}

static void cell_locator(const void *user, size_t cell, char *buf, size_t size)
{
    const vtk_reader *r = user;
    locate(r, r->cell_pos[cell], r->cell_pos_binary, buf, size);
}

static void skip_space(vtk_reader *r)
{
    while (r->pos < r->n && ffd_is_space((unsigned char)r->s[r->pos]))
        r->pos++;
}

/* The words of the line at pos (after blank lines), at most max; pos moves
 * past the line's end. Returns the word count, max + 1 when more follow, 0
 * at the end of the file. */
static int read_line(vtk_reader *r, word *w, int max)
{
    skip_space(r);
    int k = 0;
    while (r->pos < r->n && r->s[r->pos] != '\n') {
        if (ffd_is_blank((unsigned char)r->s[r->pos])) {
            r->pos++;
            continue;
        }
        size_t b = r->pos;
        while (r->pos < r->n && !ffd_is_space((unsigned char)r->s[r->pos]))
            r->pos++;
        if (k < max)
            w[k] = (word){r->s + b, r->pos - b, b};
        if (k <= max)
            k++;
    }
    if (r->pos < r->n)
        r->pos++;
    return k;
}

/* A count word: a non-negative decimal integer. */
static bool parse_count(const word *w, uint64_t *v)
{
    if (w->len == 0 || w->len > 19)
        return false;
    uint64_t x = 0;
    for (size_t i = 0; i < w->len; i++) {
        if (w->p[i] < '0' || w->p[i] > '9')
            return false;
        x = x * 10 + (uint64_t)(w->p[i] - '0');
    }
    *v = x;
    return true;
}

static ffd_status count_word(const vtk_reader *r, const word *w, const char *what, uint64_t *v,
                             ffd_error *err)
{
    if (!parse_count(w, v))
        return fail_at(r, err, FFD_ERR_PARSE, w->off, false, "expected %s, found '%.*s'", what,
                       (int)(w->len > 40 ? 40 : w->len), w->p);
    return FFD_OK;
}

static ffd_status type_word(const vtk_reader *r, const word *w, const vtk_type **t, ffd_error *err)
{
    *t = type_named(w->p, w->len);
    if (!*t)
        return fail_at(r, err, FFD_ERR_UNSUPPORTED, w->off, false,
                       "unknown data type '%.*s' (expected bit, unsigned_char, char, short, "
                       "unsigned_short, int, unsigned_int, long, unsigned_long, float, double, "
                       "vtktypeint64, ..., string)",
                       (int)(w->len > 40 ? 40 : w->len), w->p);
    return FFD_OK;
}

/* Before count values of type t (what names them): checks they can fit in
 * the bytes left (so a huge count is refused before any allocation) and, in
 * a binary file, steps over them; *base is where binary values start. */
static ffd_status begin_values(vtk_reader *r, const vtk_type *t, uint64_t count, const char *what,
                               size_t *base, ffd_error *err)
{
    size_t left = r->n - r->pos;
    *base = r->pos;
    if (!r->binary) {
        /* every text value takes a character and a separator */
        if (count > left / 2 + 1)
            return fail_at(r, err, FFD_ERR_PARSE, r->pos, false,
                           "%llu values of %s cannot fit in the %zu bytes left (a file cut "
                           "short, or a wrong count)",
                           (unsigned long long)count, what, left);
        return FFD_OK;
    }
    if (t->kind == KIND_STRING) {
        if (count > left)
            return fail_at(r, err, FFD_ERR_PARSE, r->pos, true,
                           "%llu strings of %s cannot fit in the %zu bytes left",
                           (unsigned long long)count, what, left);
        return FFD_OK;
    }
    uint64_t bytes = t->kind == KIND_BIT ? count / 8 + (count % 8 != 0)
                                         : (count > UINT64_MAX / t->size ? UINT64_MAX : count * t->size);
    if (bytes > left)
        return fail_at(r, err, FFD_ERR_PARSE, r->pos, true,
                       "%llu values of %s (%s) need %llu bytes, only %zu are left",
                       (unsigned long long)count, what, t->name, (unsigned long long)bytes, left);
    r->pos += (size_t)bytes;
    return FFD_OK;
}

/* Value i of a block begun by begin_values: the next number of a text file,
 * or the binary value at base. *off: where it is. */
static ffd_status value_at(vtk_reader *r, const vtk_type *t, size_t base, uint64_t i,
                           const char *what, double *v, size_t *off, ffd_error *err)
{
    if (r->binary) {
        if (t->kind == KIND_BIT) {
            *off = base + (size_t)(i / 8);
            *v = (double)((unsigned char)r->s[*off] >> (7 - i % 8) & 1u);
        } else {
            *off = base + (size_t)i * t->size;
            *v = decode((const unsigned char *)r->s + *off, t);
        }
        return FFD_OK;
    }
    skip_space(r);
    *off = r->pos;
    if (r->pos >= r->n)
        return fail_at(r, err, FFD_ERR_PARSE, r->pos, false,
                       "expected value %llu of %s, found end of file", (unsigned long long)i, what);
    const char *p = r->s + r->pos;
    int got = ffd_parse_number(&p, r->s + r->n, false, v);
    if (got != 1) {
        const char *q = r->s + r->pos, *e = ffd_text_word_end(q, r->s + r->n);
        return fail_at(r, err, FFD_ERR_PARSE, r->pos, false,
                       "expected value %llu of %s (a number), found '%.*s'", (unsigned long long)i,
                       what, (int)(e - q > 40 ? 40 : e - q), q);
    }
    r->pos = (size_t)(p - r->s);
    return FFD_OK;
}

/* Steps over count strings: one per line in text files, length-prefixed in
 * binary ones (vtkDataWriter's encoding: the top two bits of the first byte
 * say how many bytes hold the length). */
static ffd_status skip_strings(vtk_reader *r, uint64_t count, const char *what, ffd_error *err)
{
    for (uint64_t i = 0; i < count; i++) {
        if (r->pos >= r->n)
            return fail_at(r, err, FFD_ERR_PARSE, r->pos, r->binary,
                           "expected string %llu of %s, found end of file", (unsigned long long)i,
                           what);
        if (!r->binary) {
            const char *nl = memchr(r->s + r->pos, '\n', r->n - r->pos);
            r->pos = nl ? (size_t)(nl - r->s) + 1 : r->n;
            continue;
        }
        unsigned char b = (unsigned char)r->s[r->pos];
        unsigned head = b >> 6 == 3 ? 1 : b >> 6 == 2 ? 2 : b >> 6 == 1 ? 4 : 8;
        if (r->n - r->pos < head)
            return fail_at(r, err, FFD_ERR_PARSE, r->pos, true,
                           "string %llu of %s: its length runs past the end of the file",
                           (unsigned long long)i, what);
        uint64_t len = load_be((const unsigned char *)r->s + r->pos, head) &
                       (head == 8 ? UINT64_MAX >> 2 : (UINT64_C(1) << (8 * head - 2)) - 1);
        if (len > r->n - r->pos - head)
            return fail_at(r, err, FFD_ERR_PARSE, r->pos, true,
                           "string %llu of %s: %llu bytes, only %zu are left",
                           (unsigned long long)i, what, (unsigned long long)len,
                           r->n - r->pos - head);
        r->pos += head + (size_t)len;
    }
    return FFD_OK;
}

/* ======================================================================
 * POINTS
 * ====================================================================== */

static ffd_status read_points(vtk_reader *r, const word *w, int nw, ffd_error *err)
{
    ffd_mesh *m = r->m;
    if (nw != 3)
        return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "expected 'POINTS <count> <type>'");
    if (m->vertex_count)
        return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "a second POINTS section");
    uint64_t n = 0;
    const vtk_type *t;
    ffd_status st = count_word(r, &w[1], "a point count", &n, err);
    if (!st)
        st = type_word(r, &w[2], &t, err);
    if (st)
        return st;
    if (t->kind != FFD_SPAN_F32 && t->kind != FFD_SPAN_F64)
        return fail_at(r, err, FFD_ERR_UNSUPPORTED, w[2].off, false,
                       "POINTS of type '%s': ffdkit reads float or double points", t->name);
    if (n > UINT32_MAX)
        return fail_at(r, err, FFD_ERR_UNSUPPORTED, w[1].off, false,
                       "%llu points, more than the 4294967295 the library handles",
                       (unsigned long long)n);
    size_t base;
    if ((st = begin_values(r, t, 3 * n, "POINTS", &base, err)))
        return st;
    if (!ffd_mesh_reserve(m, (size_t)n, 0, 0, 0))
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %llu points", r->name,
                        (unsigned long long)n);
    for (size_t i = 0; i < n; i++) {
        double xyz[3];
        ffd_span sp[3];
        for (int d = 0; d < 3; d++) {
            size_t off;
            if ((st = value_at(r, t, base, 3 * (uint64_t)i + (uint64_t)d, "POINTS", &xyz[d], &off, err)))
                return st;
            if (!isfinite(xyz[d]))
                return fail_at(r, err, FFD_ERR_NONFINITE, off, r->binary,
                               "coordinate %d of point %zu is not finite (%g)", d, i, xyz[d]);
            sp[d].offset = off;
            sp[d].kind = r->binary ? (unsigned)t->kind : FFD_SPAN_TEXT;
        }
        if (!ffd_mesh_push_vertex(m, xyz, sp))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %llu points", r->name,
                            (unsigned long long)n);
    }
    return FFD_OK;
}

/* ======================================================================
 * Cells: CELLS (unstructured grid) and the polydata sections
 * ====================================================================== */

/* Polydata sections, in the order VTK numbers their cells. */
enum { SECTION_UG = 0, SECTION_VERTICES, SECTION_LINES, SECTION_POLYGONS, SECTION_STRIPS };

/* The VTK type of a polydata cell of k nodes (vtkPolyData::GetCellType). */
static uint8_t poly_cell_type(int section, uint64_t k)
{
    switch (section) {
    case SECTION_VERTICES: return k == 1 ? FFD_CELL_VERTEX : FFD_CELL_POLY_VERTEX;
    case SECTION_LINES: return k == 2 ? FFD_CELL_LINE : FFD_CELL_POLY_LINE;
    case SECTION_POLYGONS:
        return k == 3 ? FFD_CELL_TRIANGLE : k == 4 ? FFD_CELL_QUAD : FFD_CELL_POLYGON;
    default: return FFD_CELL_TRIANGLE_STRIP;
    }
}

static ffd_status node_id(const vtk_reader *r, double v, size_t off, uint32_t *id, ffd_error *err)
{
    if (!(v >= 0 && v < 4294967295.0) || v != floor(v))
        return fail_at(r, err, v != floor(v) ? FFD_ERR_PARSE : FFD_ERR_RANGE, off, r->binary,
                       "node id %g out of range (%zu points)", v, r->m->vertex_count);
    *id = (uint32_t)v;
    return FFD_OK;
}

static ffd_status reserve_cells(vtk_reader *r, uint64_t cells, uint64_t indices, ffd_error *err)
{
    ffd_mesh *m = r->m;
    if (cells > UINT32_MAX || indices > SIZE_MAX / 8 ||
        !ffd_mesh_reserve_cells(m, m->cell_count + (size_t)cells, m->cell_index_count + (size_t)indices) ||
        !ffd_grow((void **)&r->cell_pos, &r->cell_pos_cap, m->cell_count + (size_t)cells + 1, sizeof(size_t)))
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %llu cells", r->name,
                        (unsigned long long)cells);
    return FFD_OK;
}

static void close_cell(vtk_reader *r, uint8_t type, size_t pos)
{
    ffd_mesh *m = r->m;
    r->cell_pos[m->cell_count] = pos;
    m->cell_types[m->cell_count] = type;
    m->cell_offsets[++m->cell_count] = m->cell_index_count;
}

/* "CELLS n size" then n lists "k id_1 .. id_k" (int in binary files). */
static ffd_status read_count_lists(vtk_reader *r, int section, uint64_t n, uint64_t size,
                                   const char *kw, ffd_error *err)
{
    ffd_mesh *m = r->m;
    size_t base;
    if (n > size)
        return fail_at(r, err, FFD_ERR_PARSE, r->pos, r->binary,
                       "%s declares %llu cells in %llu values (each cell needs at least its count)",
                       kw, (unsigned long long)n, (unsigned long long)size);
    ffd_status st = begin_values(r, &type_int32, size, kw, &base, err);
    if (st)
        return st;
    if ((st = reserve_cells(r, n, size, err)))
        return st;
    r->cell_pos_binary = r->binary;
    uint64_t at = 0;
    for (uint64_t c = 0; c < n; c++) {
        double v;
        size_t off;
        if (at >= size)
            return fail_at(r, err, FFD_ERR_PARSE, r->pos, r->binary,
                           "%s declares %llu values, used up before cell %llu of %llu", kw,
                           (unsigned long long)size, (unsigned long long)c, (unsigned long long)n);
        if ((st = value_at(r, &type_int32, base, at++, kw, &v, &off, err)))
            return st;
        if (!(v >= 0) || v != floor(v) || v > (double)(size - at))
            return fail_at(r, err, FFD_ERR_PARSE, off, r->binary,
                           "cell %llu has %g nodes, more than the %llu values %s has left",
                           (unsigned long long)c, v, (unsigned long long)(size - at), kw);
        uint64_t k = (uint64_t)v;
        for (uint64_t j = 0; j < k; j++) {
            double id;
            size_t ioff;
            if ((st = value_at(r, &type_int32, base, at++, kw, &id, &ioff, err)))
                return st;
            if ((st = node_id(r, id, ioff, &m->cell_indices[m->cell_index_count], err)))
                return st;
            m->cell_index_count++;
        }
        close_cell(r, section == SECTION_UG ? 0 : poly_cell_type(section, k), off);
    }
    if (at != size)
        return fail_at(r, err, FFD_ERR_PARSE, r->binary ? base + (size_t)at * 4 : r->pos, r->binary,
                       "%s declares %llu values but its %llu cells hold %llu", kw,
                       (unsigned long long)size, (unsigned long long)n, (unsigned long long)at);
    return FFD_OK;
}

/* 5.1: "CELLS n+1 m", "OFFSETS type" n+1 values, "CONNECTIVITY type" m values. */
static ffd_status read_offset_arrays(vtk_reader *r, int section, uint64_t noff, uint64_t size,
                                     const char *kw, ffd_error *err)
{
    ffd_mesh *m = r->m;
    word w[3];
    size_t line = r->pos;
    int nw = read_line(r, w, 2);
    const vtk_type *t;
    ffd_status st;
    if (nw != 2)
        return fail_at(r, err, FFD_ERR_PARSE, line, false, "expected 'OFFSETS <type>'");
    if ((st = type_word(r, &w[1], &t, err)))
        return st;
    if (t->kind == KIND_STRING || t->kind == KIND_BIT || t->kind == FFD_SPAN_F32 || t->kind == FFD_SPAN_F64)
        return fail_at(r, err, FFD_ERR_PARSE, w[1].off, false, "OFFSETS of type '%s', expected an integer type", t->name);
    if (noff == 0)
        return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false,
                       "%s declares 0 offsets, expected the cell count + 1", kw);
    uint64_t n = noff - 1;
    size_t base;
    if ((st = begin_values(r, t, noff, "OFFSETS", &base, err)))
        return st;
    if (size > (r->binary ? r->n - r->pos : (r->n - r->pos) / 2 + 1))
        return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false,
                       "%llu connectivity values cannot fit in the %zu bytes left",
                       (unsigned long long)size, r->n - r->pos);
    if ((st = reserve_cells(r, n, size, err)))
        return st;
    /* offsets go to the mesh's cell_offsets, relative to the cells before */
    size_t first = m->cell_count, index0 = m->cell_index_count;
    uint64_t prev = 0;
    for (uint64_t c = 0; c <= n; c++) {
        double v;
        size_t off;
        if ((st = value_at(r, t, base, c, "OFFSETS", &v, &off, err)))
            return st;
        if (!(v >= (double)prev) || v != floor(v) || v > (double)size || (c == 0 && v != 0) ||
            (c == n && v != (double)size))
            return fail_at(r, err, FFD_ERR_PARSE, off, r->binary,
                           "offset %llu is %g, expected %s", (unsigned long long)c, v,
                           c == 0 ? "0" : c == n ? "the connectivity size" : "a non-decreasing offset within the connectivity");
        prev = (uint64_t)v;
        if (c)
            m->cell_offsets[first + c] = index0 + prev;
    }
    nw = read_line(r, w, 2);
    line = w[0].off;
    if (nw != 2 || !word_is(w[0].p, w[0].len, "CONNECTIVITY"))
        return fail_at(r, err, FFD_ERR_PARSE, nw ? line : r->pos, false, "expected 'CONNECTIVITY <type>' after the offsets");
    if ((st = type_word(r, &w[1], &t, err)))
        return st;
    if (t->kind == KIND_STRING || t->kind == KIND_BIT)
        return fail_at(r, err, FFD_ERR_PARSE, w[1].off, false, "CONNECTIVITY of type '%s', expected an integer type", t->name);
    if ((st = begin_values(r, t, size, "CONNECTIVITY", &base, err)))
        return st;
    size_t c = first;
    r->cell_pos_binary = r->binary;
    for (uint64_t j = 0; j < size; j++) {
        double v;
        size_t off;
        if ((st = value_at(r, t, base, j, "CONNECTIVITY", &v, &off, err)))
            return st;
        while (c < first + n && m->cell_offsets[c] == index0 + j)
            r->cell_pos[c++] = off;
        if ((st = node_id(r, v, off, &m->cell_indices[index0 + j], err)))
            return st;
    }
    while (c < first + n)
        r->cell_pos[c++] = r->binary ? base + (size_t)size * t->size : r->pos;
    for (size_t k = first; k < first + n; k++)
        m->cell_types[k] = section == SECTION_UG ? 0 : poly_cell_type(section, m->cell_offsets[k + 1] - m->cell_offsets[k]);
    m->cell_count = first + (size_t)n;
    m->cell_index_count = index0 + (size_t)size;
    return FFD_OK;
}

static ffd_status read_cells(vtk_reader *r, const word *w, int nw, int section, ffd_error *err)
{
    char kw[32];
    snprintf(kw, sizeof kw, "%.*s", (int)(w[0].len < 20 ? w[0].len : 20), w[0].p);
    if (nw != 3)
        return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "expected '%s <count> <size>'", kw);
    uint64_t n = 0, size = 0;
    ffd_status st = count_word(r, &w[1], "a cell count", &n, err);
    if (!st)
        st = count_word(r, &w[2], "a list size", &size, err);
    if (st)
        return st;
    /* 5.1 layout: OFFSETS on the next line (in binary files right at the data) */
    size_t save = r->pos;
    if (!r->binary)
        skip_space(r);
    bool offsets = r->n - r->pos >= 7 && word_is(r->s + r->pos, 7, "OFFSETS") &&
                   (r->n - r->pos == 7 || ffd_is_space((unsigned char)r->s[r->pos + 7]));
    r->pos = save;
    if (offsets)
        return read_offset_arrays(r, section, n, size, kw, err);
    return read_count_lists(r, section, n, size, kw, err);
}

static ffd_status read_cell_types(vtk_reader *r, const word *w, int nw, size_t ug_cells, ffd_error *err)
{
    ffd_mesh *m = r->m;
    uint64_t n = 0;
    ffd_status st;
    if (nw != 2)
        return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "expected 'CELL_TYPES <count>'");
    if ((st = count_word(r, &w[1], "a cell count", &n, err)))
        return st;
    if (n != ug_cells)
        return fail_at(r, err, FFD_ERR_PARSE, w[1].off, false,
                       "CELL_TYPES lists %llu cells, CELLS %zu", (unsigned long long)n, ug_cells);
    size_t base;
    if ((st = begin_values(r, &type_int32, n, "CELL_TYPES", &base, err)))
        return st;
    for (size_t c = 0; c < n; c++) {
        double v;
        size_t off;
        if ((st = value_at(r, &type_int32, base, c, "CELL_TYPES", &v, &off, err)))
            return st;
        if (v == 42)
            return fail_at(r, err, FFD_ERR_UNSUPPORTED, off, r->binary,
                           "cell %zu is a polyhedron (type 42): polyhedron cells are not supported", c);
        if (!(v >= 0 && v <= 255) || v != floor(v) || !ffd_cell_type_of((unsigned)v))
            return fail_at(r, err, FFD_ERR_UNSUPPORTED, off, r->binary,
                           "cell %zu has type %g, not one the library reads (docs/volume.md lists them)", c, v);
        m->cell_types[c] = (uint8_t)v;
    }
    return FFD_OK;
}

/* ======================================================================
 * POINT_DATA and CELL_DATA
 * ====================================================================== */

/* VTK writes blanks and '%' in names as %XX (vtkDataWriter::EncodeString). */
static int hex_value(char c)
{
    return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10
                                          : c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1;
}

static char *decode_name(const word *w)
{
    char *s = ffd_malloc(w->len + 1);
    if (!s)
        return NULL;
    size_t k = 0;
    for (size_t i = 0; i < w->len; i++) {
        if (w->p[i] == '%' && i + 2 < w->len && hex_value(w->p[i + 1]) >= 0 &&
            hex_value(w->p[i + 2]) >= 0) {
            s[k++] = (char)(hex_value(w->p[i + 1]) * 16 + hex_value(w->p[i + 2]));
            i += 2;
        } else {
            s[k++] = w->p[i];
        }
    }
    s[k] = 0;
    return s;
}

/* tuples x comps values of type t; kept as a field named nm (when the
 * tuple count matches the section's and the type is numeric), else skipped.
 * scale: for COLOR_SCALARS in binary files (bytes to [0, 1]). */
static ffd_status read_array(vtk_reader *r, const word *nm, const vtk_type *t, uint64_t comps,
                             uint64_t tuples, bool keep, double scale, int kind, ffd_error *err)
{
    char what[64];
    snprintf(what, sizeof what, "'%.*s'", (int)(nm->len < 40 ? nm->len : 40), nm->p);
    if (comps == 0 || comps > 1u << 20)
        return fail_at(r, err, FFD_ERR_PARSE, nm->off, false,
                       "array %s has %llu components, expected 1 to 1048576", what,
                       (unsigned long long)comps);
    if (tuples > UINT64_MAX / comps)
        return fail_at(r, err, FFD_ERR_PARSE, nm->off, false, "array %s is too large", what);
    uint64_t count = comps * tuples;
    size_t base;
    ffd_status st;
    if (t->kind == KIND_STRING) {
        if ((st = begin_values(r, t, count, what, &base, err)))
            return st;
        return skip_strings(r, count, what, err);
    }
    if ((st = begin_values(r, t, count, what, &base, err)))
        return st;
    keep = keep && r->assoc >= 0 && tuples == r->assoc_count;
    double *vals = keep ? ffd_malloc_array(count ? (size_t)count : 1, sizeof(double)) : NULL;
    if (keep && !vals)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for array %s", r->name, what);
    for (uint64_t i = 0; i < count; i++) {
        double v;
        size_t off;
        if ((st = value_at(r, t, base, i, what, &v, &off, err))) {
            ffd_free(vals);
            return st;
        }
        /* a float array holds floats, whatever digits a text file gave */
        if (vals)
            vals[i] = t->kind == FFD_SPAN_F32 ? (double)(float)(v * scale) : v * scale;
    }
    if (!keep)
        return FFD_OK;
    char *name = decode_name(nm);
    bool ok = name && ffd_mesh_add_field(r->m, name, r->assoc, (uint32_t)comps,
                                         kind ? kind : t->kind == KIND_BIT ? FFD_SPAN_U8 : t->kind,
                                         vals, (size_t)tuples);
    ffd_free(name);
    ffd_free(vals);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for array %s", r->name, what);
}

/* METADATA: an INFORMATION block up to the next blank line (VTK 9). */
static void skip_metadata(vtk_reader *r)
{
    while (r->pos < r->n) {
        const char *e = memchr(r->s + r->pos, '\n', r->n - r->pos);
        size_t end = e ? (size_t)(e - r->s) : r->n;
        bool blank = true;
        for (size_t i = r->pos; i < end; i++)
            blank = blank && ffd_is_blank((unsigned char)r->s[i]);
        r->pos = e ? end + 1 : r->n;
        if (blank)
            return;
    }
}

/* "FIELD name k" then k arrays "name comps tuples type" (or NULL_ARRAY). */
static ffd_status read_field(vtk_reader *r, const word *w, int nw, ffd_error *err)
{
    uint64_t k = 0;
    ffd_status st;
    if (nw != 3)
        return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "expected 'FIELD <name> <array count>'");
    if ((st = count_word(r, &w[2], "an array count", &k, err)))
        return st;
    for (uint64_t a = 0; a < k; a++) {
        word aw[5];
        size_t line = r->pos;
        int na = read_line(r, aw, 4);
        if (na == 0)
            return fail_at(r, err, FFD_ERR_PARSE, line, false,
                           "expected array %llu of FIELD '%.*s', found end of file",
                           (unsigned long long)a, (int)(w[1].len < 40 ? w[1].len : 40), w[1].p);
        if (na == 1 && word_is(aw[0].p, aw[0].len, "NULL_ARRAY"))
            continue;
        if (na == 1 && word_is(aw[0].p, aw[0].len, "METADATA")) {
            a--; /* the previous array's METADATA block is not an array */
            skip_metadata(r);
            continue;
        }
        uint64_t comps = 0, tuples = 0;
        const vtk_type *t;
        if (na != 4)
            return fail_at(r, err, FFD_ERR_PARSE, aw[0].off, false,
                           "expected '<array name> <components> <tuples> <type>'");
        if ((st = count_word(r, &aw[1], "a component count", &comps, err)) ||
            (st = count_word(r, &aw[2], "a tuple count", &tuples, err)) ||
            (st = type_word(r, &aw[3], &t, err)) ||
            (st = read_array(r, &aw[0], t, comps, tuples, true, 1.0, 0, err)))
            return st;
    }
    return FFD_OK;
}

/* SCALARS, VECTORS, ... of POINT_DATA / CELL_DATA. */
static ffd_status read_attribute(vtk_reader *r, const word *w, int nw, ffd_error *err)
{
    const char *kw = NULL;
    uint64_t comps = 0;
    const vtk_type *t = NULL;
    ffd_status st;
    int type_at = 2;
    if (word_is(w[0].p, w[0].len, "SCALARS")) {
        kw = "SCALARS <name> <type> [<components>]";
        if (nw == 4) {
            if ((st = count_word(r, &w[3], "a component count", &comps, err)))
                return st;
        } else if (nw == 3) {
            comps = 1;
        }
        if (nw != 3 && nw != 4)
            nw = -1;
    } else if (word_is(w[0].p, w[0].len, "VECTORS") || word_is(w[0].p, w[0].len, "NORMALS")) {
        kw = "VECTORS|NORMALS <name> <type>", comps = 3;
        nw = nw == 3 ? 3 : -1;
    } else if (word_is(w[0].p, w[0].len, "TENSORS")) {
        kw = "TENSORS <name> <type>", comps = 9;
        nw = nw == 3 ? 3 : -1;
    } else if (word_is(w[0].p, w[0].len, "TENSORS6")) {
        kw = "TENSORS6 <name> <type>", comps = 6;
        nw = nw == 3 ? 3 : -1;
    } else if (word_is(w[0].p, w[0].len, "GLOBAL_IDS") || word_is(w[0].p, w[0].len, "PEDIGREE_IDS")) {
        kw = "GLOBAL_IDS|PEDIGREE_IDS <name> <type>", comps = 1;
        nw = nw == 3 ? 3 : -1;
    } else if (word_is(w[0].p, w[0].len, "TEXTURE_COORDINATES")) {
        kw = "TEXTURE_COORDINATES <name> <dimension> <type>", type_at = 3;
        if (nw == 4 && (st = count_word(r, &w[2], "a dimension", &comps, err)))
            return st;
        nw = nw == 4 ? 4 : -1;
    } else if (word_is(w[0].p, w[0].len, "COLOR_SCALARS")) {
        kw = "COLOR_SCALARS <name> <components>";
        if (nw != 3)
            return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "expected '%s'", kw);
        if ((st = count_word(r, &w[2], "a component count", &comps, err)))
            return st;
        /* floats in [0, 1] in text files, unsigned chars in binary ones */
        return read_array(r, &w[1], r->binary ? &type_uchar : &type_float, comps, r->assoc_count,
                          true, r->binary ? 1.0 / 255.0 : 1.0, FFD_SPAN_F32, err);
    } else { /* LOOKUP_TABLE <name> <size>: size RGBA colours */
        uint64_t size = 0;
        if (nw != 3)
            return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "expected 'LOOKUP_TABLE <name> <size>'");
        if ((st = count_word(r, &w[2], "a table size", &size, err)))
            return st;
        if (size > UINT64_MAX / 4)
            return fail_at(r, err, FFD_ERR_PARSE, w[2].off, false, "lookup table too large");
        return read_array(r, &w[1], r->binary ? &type_uchar : &type_float, 4, size, false, 1.0, 0, err);
    }
    if (nw < 0)
        return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "expected '%s'", kw);
    if ((st = type_word(r, &w[type_at], &t, err)))
        return st;
    if (word_is(w[0].p, w[0].len, "SCALARS")) {
        /* its LOOKUP_TABLE line (optional for meshio and VTK) */
        size_t save = r->pos;
        word lw[3];
        int nl = read_line(r, lw, 2);
        if (!(nl == 2 && word_is(lw[0].p, lw[0].len, "LOOKUP_TABLE")))
            r->pos = save;
    }
    return read_array(r, &w[1], t, comps, r->assoc_count, true, 1.0, 0, err);
}

/* ======================================================================
 * The file
 * ====================================================================== */

static ffd_status read_sections(vtk_reader *r, bool polydata, ffd_error *err)
{
    ffd_mesh *m = r->m;
    int last_section = 0;
    size_t ug_cells = 0;
    bool have_cells = false, have_types = false, have_points = false;
    size_t cells_line = 0;
    ffd_status st;
    for (;;) {
        word w[6];
        int nw = read_line(r, w, 5);
        if (nw == 0)
            break;
        const char *k = w[0].p;
        size_t kl = w[0].len;
        if (word_is(k, kl, "POINTS")) {
            if ((st = read_points(r, w, nw, err)))
                return st;
            have_points = true;
        } else if (word_is(k, kl, "FIELD")) {
            if ((st = read_field(r, w, nw, err)))
                return st;
        } else if (word_is(k, kl, "METADATA")) {
            skip_metadata(r);
        } else if (!polydata && word_is(k, kl, "CELLS")) {
            if (have_cells)
                return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "a second CELLS section");
            if (r->assoc >= 0)
                return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "CELLS after POINT_DATA or CELL_DATA");
            cells_line = w[0].off;
            if ((st = read_cells(r, w, nw, SECTION_UG, err)))
                return st;
            have_cells = true;
            ug_cells = m->cell_count;
        } else if (!polydata && word_is(k, kl, "CELL_TYPES")) {
            if (!have_cells || have_types)
                return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false,
                               have_types ? "a second CELL_TYPES section" : "CELL_TYPES before CELLS");
            if ((st = read_cell_types(r, w, nw, ug_cells, err)))
                return st;
            have_types = true;
        } else if (polydata && (word_is(k, kl, "VERTICES") || word_is(k, kl, "LINES") ||
                                word_is(k, kl, "POLYGONS") || word_is(k, kl, "TRIANGLE_STRIPS"))) {
            int section = word_is(k, kl, "VERTICES") ? SECTION_VERTICES
                          : word_is(k, kl, "LINES")  ? SECTION_LINES
                          : word_is(k, kl, "POLYGONS") ? SECTION_POLYGONS
                                                       : SECTION_STRIPS;
            if (section <= last_section)
                return fail_at(r, err, FFD_ERR_UNSUPPORTED, w[0].off, false,
                               "%.*s after a later or the same section: polydata sections must come once each, "
                               "in VTK's cell order (VERTICES, LINES, POLYGONS, TRIANGLE_STRIPS)",
                               (int)kl, k);
            if (r->assoc >= 0)
                return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "%.*s after POINT_DATA or CELL_DATA", (int)kl, k);
            last_section = section;
            if ((st = read_cells(r, w, nw, section, err)))
                return st;
        } else if (word_is(k, kl, "POINT_DATA") || word_is(k, kl, "CELL_DATA")) {
            bool point = word_is(k, kl, "POINT_DATA");
            uint64_t n = 0;
            if (nw != 2)
                return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "expected '%.*s <count>'", (int)kl, k);
            if ((st = count_word(r, &w[1], "a count", &n, err)))
                return st;
            size_t want = point ? m->vertex_count : m->cell_count;
            if (n != want)
                return fail_at(r, err, FFD_ERR_PARSE, w[1].off, false, "%.*s %llu, but the file has %zu %s",
                               (int)kl, k, (unsigned long long)n, want, point ? "points" : "cells");
            r->assoc = point ? FFD_FIELD_POINT : FFD_FIELD_CELL;
            r->assoc_count = want;
        } else if (word_is(k, kl, "SCALARS") || word_is(k, kl, "COLOR_SCALARS") ||
                   word_is(k, kl, "LOOKUP_TABLE") || word_is(k, kl, "VECTORS") ||
                   word_is(k, kl, "NORMALS") || word_is(k, kl, "TEXTURE_COORDINATES") ||
                   word_is(k, kl, "TENSORS") || word_is(k, kl, "TENSORS6") ||
                   word_is(k, kl, "GLOBAL_IDS") || word_is(k, kl, "PEDIGREE_IDS")) {
            if (r->assoc < 0)
                return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "%.*s before POINT_DATA or CELL_DATA",
                               (int)kl, k);
            if ((st = read_attribute(r, w, nw, err)))
                return st;
        } else {
            return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false,
                           "unknown keyword '%.*s' in a %s dataset", (int)(kl > 40 ? 40 : kl), k,
                           polydata ? "POLYDATA" : "UNSTRUCTURED_GRID");
        }
        if (!have_points && (have_cells || last_section))
            return fail_at(r, err, FFD_ERR_PARSE, w[0].off, false, "cells before POINTS");
    }
    if (!have_points)
        return fail_at(r, err, FFD_ERR_PARSE, r->n, false, "expected a POINTS section, found end of file");
    if (have_cells && !have_types)
        return fail_at(r, err, FFD_ERR_PARSE, cells_line, false, "CELLS without CELL_TYPES");
    return FFD_OK;
}

static ffd_status read_vtk(ffd_mesh *m, const char *name, ffd_error *err)
{
    vtk_reader r = {0};
    r.name = ffd_name_or(name, "<memory>");
    r.s = (const char *)m->src;
    r.n = m->src_size;
    r.m = m;
    r.assoc = -1;
    static const char magic[] = "# vtk DataFile Version";
    if (r.n < sizeof magic - 1 || !word_is(r.s, sizeof magic - 1, magic))
        return ffd_fail(err, FFD_ERR_PARSE, "%s:1: expected '# vtk DataFile Version <x.y>'", r.name);
    /* the version line and the title line: anything */
    for (int line = 1; line <= 2; line++) {
        const char *nl = memchr(r.s + r.pos, '\n', r.n - r.pos);
        if (!nl) {
            bool title = line == 1 || r.pos == r.n;
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%d: expected %s, found end of file", r.name,
                            title ? 2 : 3, title ? "a title line" : "ASCII or BINARY");
        }
        r.pos = (size_t)(nl - r.s) + 1;
    }
    word w[4];
    size_t at = r.pos;
    int nw = read_line(&r, w, 3);
    if (nw != 1 || !(word_is(w[0].p, w[0].len, "ASCII") || word_is(w[0].p, w[0].len, "BINARY")))
        return fail_at(&r, err, FFD_ERR_PARSE, nw ? w[0].off : at, false, "expected ASCII or BINARY, found '%.*s'",
                       nw ? (int)(w[0].len > 40 ? 40 : w[0].len) : 0, nw ? w[0].p : "");
    r.binary = word_is(w[0].p, w[0].len, "BINARY");
    m->encoding = r.binary ? FFD_ENCODING_BINARY_BE : FFD_ENCODING_ASCII;
    at = r.pos;
    nw = read_line(&r, w, 3);
    if (nw != 2 || !word_is(w[0].p, w[0].len, "DATASET"))
        return fail_at(&r, err, FFD_ERR_PARSE, nw ? w[0].off : at, false,
                       "expected 'DATASET UNSTRUCTURED_GRID' or 'DATASET POLYDATA'");
    bool polydata = word_is(w[1].p, w[1].len, "POLYDATA");
    if (!polydata && !word_is(w[1].p, w[1].len, "UNSTRUCTURED_GRID"))
        return fail_at(&r, err, FFD_ERR_UNSUPPORTED, w[1].off, false,
                       "DATASET %.*s is not supported (UNSTRUCTURED_GRID and POLYDATA are)",
                       (int)(w[1].len > 40 ? 40 : w[1].len), w[1].p);
    ffd_status st = read_sections(&r, polydata, err);
    if (!st)
        st = ffd_mesh_finish_cells(m, r.name, cell_locator, &r, err);
    ffd_free(r.cell_pos);
    return st;
}

/* ======================================================================
 * Writing from data
 * ====================================================================== */

static void put_be(ffd_buf *b, uint64_t v, unsigned size)
{
    unsigned char t[8];
    for (unsigned i = 0; i < size; i++)
        t[i] = (unsigned char)(v >> (8 * (size - 1 - i)));
    ffd_buf_put(b, t, size);
}

static void put_value(ffd_buf *b, bool binary, int kind, double v)
{
    if (binary) {
        unsigned char t[8];
        if (kind == FFD_FIELD_I64)
            put_be(b, (uint64_t)(int64_t)v, 8);
        else if (kind == FFD_FIELD_U64)
            put_be(b, (uint64_t)v, 8);
        else {
            int k = kind >= FFD_SPAN_I8 && kind <= FFD_SPAN_F64 ? kind : FFD_SPAN_F64;
            ffd_write_scalar(t, k, true, v);
            ffd_buf_put(b, t, ffd_span_kind_size(k));
        }
        return;
    }
    char t[32];
    int n;
    if (kind == FFD_SPAN_F32)
        n = ffd_format_float(t, (float)v);
    else if (kind >= FFD_SPAN_I8 && kind <= FFD_SPAN_U32 && isfinite(v))
        n = ffd_format_int(t, (int64_t)v);
    else if (kind == FFD_FIELD_I64 && isfinite(v))
        n = ffd_format_int(t, (int64_t)v);
    else if (kind == FFD_FIELD_U64 && isfinite(v)) {
        ffd_buf_uint(b, (uint64_t)v);
        return;
    } else
        n = ffd_format_double(t, v);
    ffd_buf_put(b, t, (size_t)n);
}

/* A name as one word: blanks, '%' and non-printable bytes as %XX. */
static void put_name(ffd_buf *b, const char *s)
{
    if (!*s)
        s = "unnamed";
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c <= ' ' || c == '%' || c >= 127)
            ffd_buf_printf(b, "%%%02X", c);
        else
            ffd_buf_put(b, s, 1);
    }
}

static void put_values(ffd_buf *b, bool binary, const ffd_mesh_field *f, size_t tuples)
{
    for (size_t i = 0; i < tuples; i++) {
        for (uint32_t c = 0; c < f->components; c++) {
            if (!binary && c)
                ffd_buf_puts(b, " ");
            put_value(b, binary, f->kind, f->values[i * f->components + c]);
        }
        if (!binary)
            ffd_buf_puts(b, "\n");
    }
    if (binary)
        ffd_buf_puts(b, "\n");
}

static void put_fields(ffd_buf *b, const ffd_mesh *m, bool binary, int assoc, size_t count)
{
    size_t simple = 0, other = 0;
    for (size_t i = 0; i < m->field_count; i++)
        if (m->fields[i].association == assoc) {
            if (m->fields[i].components == 1 || m->fields[i].components == 3)
                simple++;
            else
                other++;
        }
    if (!simple && !other)
        return;
    ffd_buf_printf(b, "%s %zu\n", assoc == FFD_FIELD_POINT ? "POINT_DATA" : "CELL_DATA", count);
    for (size_t i = 0; i < m->field_count; i++) {
        const ffd_mesh_field *f = &m->fields[i];
        if (f->association != assoc || (f->components != 1 && f->components != 3))
            continue;
        ffd_buf_puts(b, f->components == 1 ? "SCALARS " : "VECTORS ");
        put_name(b, f->name);
        ffd_buf_printf(b, " %s%s\n", kind_type_name(f->kind),
                       f->components == 1 ? " 1\nLOOKUP_TABLE default" : "");
        put_values(b, binary, f, count);
    }
    if (!other)
        return;
    ffd_buf_printf(b, "FIELD FieldData %zu\n", other);
    for (size_t i = 0; i < m->field_count; i++) {
        const ffd_mesh_field *f = &m->fields[i];
        if (f->association != assoc || f->components == 1 || f->components == 3)
            continue;
        put_name(b, f->name);
        ffd_buf_printf(b, " %u %zu %s\n", (unsigned)f->components, count, kind_type_name(f->kind));
        put_values(b, binary, f, count);
    }
}

static ffd_status write_vtk(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    bool binary = enc == FFD_ENCODING_BINARY_BE;
    if (enc != FFD_ENCODING_ASCII && !binary)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "legacy VTK is ascii or binary (big-endian); this encoding is not available");
    ffd_cells_view v;
    ffd_status st = ffd_cells_view_of(m, &v, err);
    if (st)
        return st;
    ffd_buf_printf(b, "# vtk DataFile Version 5.1\nwritten by ffdkit\n%s\nDATASET UNSTRUCTURED_GRID\n",
                   binary ? "BINARY" : "ASCII");
    size_t nv = m->vertex_count;
    ffd_buf_printf(b, "POINTS %zu double\n", nv);
    for (size_t i = 0; i < nv; i++) {
        if (binary) {
            for (int d = 0; d < 3; d++)
                put_value(b, true, FFD_SPAN_F64, m->positions[3 * i + (size_t)d]);
        } else {
            ffd_buf_vec3_line(b, "", m->positions + 3 * i);
        }
    }
    if (binary)
        ffd_buf_puts(b, "\n");
    uint64_t nidx = v.offsets[v.count];
    ffd_buf_printf(b, "CELLS %zu %llu\nOFFSETS vtktypeint64\n", v.count + 1, (unsigned long long)nidx);
    for (size_t c = 0; c <= v.count; c++) {
        if (binary) {
            put_be(b, v.offsets[c], 8);
        } else {
            ffd_buf_uint(b, v.offsets[c]);
            ffd_buf_puts(b, "\n");
        }
    }
    ffd_buf_puts(b, binary ? "\nCONNECTIVITY vtktypeint64\n" : "CONNECTIVITY vtktypeint64\n");
    for (size_t c = 0; c < v.count; c++) {
        for (uint64_t k = v.offsets[c]; k < v.offsets[c + 1]; k++) {
            if (binary) {
                put_be(b, v.indices[k], 8);
            } else {
                if (k > v.offsets[c])
                    ffd_buf_puts(b, " ");
                ffd_buf_uint(b, v.indices[k]);
            }
        }
        if (!binary && v.offsets[c + 1] > v.offsets[c])
            ffd_buf_puts(b, "\n");
    }
    ffd_buf_printf(b, "%sCELL_TYPES %zu\n", binary ? "\n" : "", v.count);
    for (size_t c = 0; c < v.count; c++) {
        if (binary) {
            put_be(b, v.types[c], 4);
        } else {
            ffd_buf_uint(b, v.types[c]);
            ffd_buf_puts(b, "\n");
        }
    }
    if (binary)
        ffd_buf_puts(b, "\n");
    put_fields(b, m, binary, FFD_FIELD_POINT, nv);
    put_fields(b, m, binary, FFD_FIELD_CELL, v.count);
    ffd_cells_view_free(&v);
    if (b->oom)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing the VTK file");
    return FFD_OK;
}

static const char *const vtk_extensions[] = {"vtk", NULL};

const ffd_mesh_codec ffd_mesh_codec_vtk = {
    .format = FFD_FORMAT_VTK,
    .name = "VTK",
    .extensions = vtk_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII) | FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_BE),
    .read = read_vtk,
    .patch = ffd_mesh_patch_spans,
    .write = write_vtk,
};
