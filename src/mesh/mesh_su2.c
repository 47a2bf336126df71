/* mesh_su2 — the SU2 native mesh format, .su2 (mesh_codec.h, docs/volume.md
 * "SU2"; https://su2code.github.io/docs_v7/Mesh-File/).
 *
 * A text file of keyword lines "KEY= value" and the data lines after them:
 *   NDIME= 2|3            the dimension (first: it says how many coordinates a point has)
 *   NELEM= k              k element lines "type n1 .. nm [index]"
 *   NPOIN= n [domain]     n point lines "x y [z] [index ...]" (the second count,
 *                         SU2's domain points before the halo, is read past)
 *   NMARK= m              then m times: MARKER_TAG= name, MARKER_ELEMS= k and k
 *                         element lines (the boundary elements of that marker)
 * '%' starts a comment (to the end of the line); blank lines anywhere.
 * Element types are VTK ids (3 line, 5 triangle, 9 quad, 10 tetra, 12
 * hexahedron, 13 prism, 14 pyramid) in VTK's node order: SU2's CPrism face
 * table (Common/include/geometry/primal_grid/CPrism.hpp: {3,4,1,0},
 * {5,2,1,4}, {2,5,3,0}, {0,1,2}, {5,4,3}) lists vtkWedge's faces, so no
 * type is reordered. Node ids are 0-based.
 *
 * Cells: the NELEM elements, then each marker's elements, in file order
 * (keywords may come in any order after NDIME=), with an integer cell field
 * "su2:tag" as meshio names it: 0 for the NELEM elements, and per marker the
 * value meshio gives it (the marker's name when it is an integer, else the
 * previous marker's tag + 1). The markers' names stay in the source bytes
 * and in the codec's state. A 2D mesh (NDIME= 2) keeps its points 2D: z is
 * 0 in memory and a write back to SU2 refuses a z that is not 0.
 *
 * Refused, naming what was found: NZONE= above 1 (multi-zone files: split
 * the zones), FFD_NBOX= above 0 (SU2's own FFD boxes), unknown keywords,
 * element types SU2 does not define, counts the bytes left cannot hold (before
 * any allocation), NaN/Inf coordinates, node ids out of range.
 *
 * Writing from data: NDIME= 2 when the mesh has no 3D cell and every z is
 * 0, else 3; NELEM= the cells of the mesh's highest dimension (voxel and
 * pixel cells reordered as hexahedra and quads); the cells one dimension
 * lower are markers grouped by their "su2:tag" value (ascending, named
 * "marker_<tag>"), or one marker "marker_1" without that field; cells of
 * lower dimensions (a volume's edges and vertices) have no place in SU2 and
 * are not written; a polygon, strip or quadratic cell is refused.
 *
 * Hand-written because no library keeps the byte offset of each
 * coordinate, which is what lets a deformed mesh differ from its source only
 * in the coordinates that moved. */
#include "mesh_cells.h"
#include "mesh_codec.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SU2_TAG_FIELD "su2:tag"
/* Fewest bytes a data line can take, for checking counts against the bytes left. */
#define SU2_MIN_POINT_LINE 4    /* "0 0\n" */
#define SU2_MIN_ELEMENT_LINE 6  /* "3 0 1\n" */
#define SU2_MIN_MARKER 27       /* "MARKER_TAG=a\nMARKER_ELEMS=0\n" */
#define SU2_MAX_NODES 8         /* a hexahedron */

/* The codec's record of its source: the dimension, the markers' names and tags. */
typedef struct {
    int dimension;
    size_t marker_count, names_cap, tags_cap;
    char **names;
    double *tags;
} su2_state;

static void state_free(void *p)
{
    su2_state *s = p;
    if (!s)
        return;
    for (size_t i = 0; i < s->marker_count; i++)
        ffd_free(s->names[i]);
    ffd_free(s->names);
    ffd_free(s->tags);
    ffd_free(s);
}

/* Node count of an SU2 element type; 0 for a type SU2 does not define. */
static unsigned su2_nodes(unsigned type)
{
    switch (type) {
    case FFD_CELL_LINE: return 2;
    case FFD_CELL_TRIANGLE: return 3;
    case FFD_CELL_QUAD: return 4;
    case FFD_CELL_TETRA: return 4;
    case FFD_CELL_HEXAHEDRON: return 8;
    case FFD_CELL_WEDGE: return 6;
    case FFD_CELL_PYRAMID: return 5;
    default: return 0;
    }
}

/* ======================================================================
 * Reading
 * ====================================================================== */

typedef struct {
    const char *name;
    const char *s, *at, *end;
    size_t line;
    /* content of the current line: [b, e) */
    const char *b, *e;
    uint64_t *cell_lines; /* the line of each cell, for finish_cells' messages */
    size_t cell_lines_cap;
} su2_ctx;

/* The next line with content, '%' comments and blanks stripped. */
static bool next_content(su2_ctx *c)
{
    ffd_text_line l;
    while (ffd_text_next_line(&c->at, c->end, &l)) {
        c->line++;
        const char *b = ffd_text_skip_blanks(l.p, l.ce);
        const char *e = memchr(b, '%', (size_t)(l.ce - b));
        if (!e)
            e = l.ce;
        while (e > b && ffd_is_blank(e[-1]))
            e--;
        if (e > b) {
            c->b = b;
            c->e = e;
            return true;
        }
    }
    return false;
}

static ffd_status found(const su2_ctx *c, const char *t, ffd_status st, const char *what,
                        ffd_error *err)
{
    int len = 0;
    while (t + len < c->e && len < 24)
        len++;
    if (len == 0)
        return ffd_fail(err, st, "%s:%zu: expected %s, found end of line", c->name, c->line, what);
    return ffd_fail(err, st, "%s:%zu: expected %s, found '%.*s'", c->name, c->line, what, len, t);
}

/* The numbers of the current line from *p on, at most max (more: returns max + 1). */
static int numbers(const su2_ctx *c, const char *p, double *v, const char **at, int max,
                   ffd_status *st, ffd_error *err)
{
    int n = 0;
    for (;;) {
        p = ffd_text_skip_blanks(p, c->e);
        if (p >= c->e)
            return n;
        if (n == max)
            return max + 1;
        const char *q = p;
        if (ffd_parse_number(&q, c->e, false, &v[n]) != 1) {
            *st = found(c, p, FFD_ERR_PARSE, "a number", err);
            return -1;
        }
        if (at)
            at[n] = p;
        n++;
        p = q;
    }
}

/* "KEY= value": the key [*kb, *ke) and the value's start. */
static bool keyword(const su2_ctx *c, const char **ke, const char **value)
{
    const char *q = c->b;
    while (q < c->e && ((*q >= 'A' && *q <= 'Z') || (*q >= '0' && *q <= '9') || *q == '_'))
        q++;
    *ke = q;
    q = ffd_text_skip_blanks(q, c->e);
    if (*ke == c->b || q >= c->e || *q != '=')
        return false;
    *value = ffd_text_skip_blanks(q + 1, c->e);
    return true;
}

static bool key_is(const su2_ctx *c, const char *ke, const char *k)
{
    size_t n = strlen(k);
    return (size_t)(ke - c->b) == n && memcmp(c->b, k, n) == 0;
}

/* A count after a keyword: a non-negative integer, and (when min_line)
 * that many data lines must fit in the bytes left. */
static ffd_status count_value(su2_ctx *c, const char *value, const char *key, size_t min_line,
                              bool more, uint64_t *out, ffd_error *err)
{
    double v[2];
    ffd_status st = FFD_OK;
    int n = numbers(c, value, v, NULL, 2, &st, err);
    if (n < 0)
        return st;
    if (n < 1 || n > (more ? 2 : 1))
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected %s followed by %s count", c->name,
                        c->line, key, more ? "one or two" : "one");
    for (int i = 0; i < n; i++)
        if (!(v[i] >= 0 && v[i] == floor(v[i]) && v[i] <= 1e18))
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected a non-negative integer after %s, found %.17g",
                            c->name, c->line, key, v[i]);
    *out = (uint64_t)v[0];
    if (n == 2 && v[1] > v[0])
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: %s %.17g domain points, more than the %llu points",
                        c->name, c->line, key, v[1], (unsigned long long)*out);
    size_t left = (size_t)(c->end - c->at);
    if (min_line && *out > left / min_line + 1)
        return ffd_fail(err, FFD_ERR_PARSE,
                        "%s:%zu: %s %llu cannot fit in the %zu bytes left in the file", c->name,
                        c->line, key, (unsigned long long)*out, left);
    return FFD_OK;
}

static ffd_status read_elements(su2_ctx *c, ffd_mesh *m, uint64_t k, const char *what,
                                ffd_error *err)
{
    for (uint64_t i = 0; i < k; i++) {
        if (!next_content(c))
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected %s element %llu of %llu, found end of file",
                            c->name, c->line + 1, what, (unsigned long long)i + 1,
                            (unsigned long long)k);
        double v[SU2_MAX_NODES + 2];
        ffd_status st = FFD_OK;
        const char *at[SU2_MAX_NODES + 2];
        int n = numbers(c, c->b, v, at, SU2_MAX_NODES + 2, &st, err);
        if (n < 0)
            return st;
        if (!(v[0] >= 0 && v[0] <= 255 && v[0] == floor(v[0])) || !su2_nodes((unsigned)v[0])) {
            if (isfinite(v[0]) && v[0] >= 0 && v[0] <= 255 && v[0] == floor(v[0]))
                return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                                "%s:%zu: element type %u is not an SU2 type (3 line, 5 triangle, 9 quad, 10 tetra, 12 hexahedron, 13 prism, 14 pyramid)",
                                c->name, c->line, (unsigned)v[0]);
            return found(c, at[0], FFD_ERR_PARSE, "an element type", err);
        }
        unsigned type = (unsigned)v[0], nodes = su2_nodes(type);
        if (n != (int)nodes + 1 && n != (int)nodes + 2)
            return ffd_fail(err, FFD_ERR_PARSE,
                            "%s:%zu: a type-%u element has %u node ids (and an optional index), found %d numbers",
                            c->name, c->line, type, nodes, n - 1 > SU2_MAX_NODES + 1 ? n : n - 1);
        uint32_t ids[SU2_MAX_NODES];
        for (unsigned j = 0; j < nodes; j++) {
            double x = v[1 + j];
            if (!(x >= 0 && x == floor(x) && x <= 4294967295.0)) {
                if (x < 0 || x > 4294967295.0)
                    return ffd_fail(err, FFD_ERR_RANGE, "%s:%zu: node %.17g out of range", c->name,
                                    c->line, x);
                return found(c, at[1 + j], FFD_ERR_PARSE, "a node id (a non-negative integer)", err);
            }
            ids[j] = (uint32_t)x;
        }
        if (m->cell_count == c->cell_lines_cap &&
            !ffd_grow((void **)&c->cell_lines, &c->cell_lines_cap, m->cell_count + 1,
                      sizeof(uint64_t)))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", c->name);
        c->cell_lines[m->cell_count] = c->line;
        if (!ffd_mesh_push_cell(m, (uint8_t)type, ids, nodes))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory at element %llu", c->name,
                            (unsigned long long)i + 1);
    }
    return FFD_OK;
}

static void where_cell(const void *user, size_t cell, char *buf, size_t size)
{
    const su2_ctx *c = user;
    snprintf(buf, size, "%s:%llu", c->name, (unsigned long long)c->cell_lines[cell]);
}

/* meshio's rule for a marker's tag: its name when that is an integer, else the previous + 1. */
static double marker_tag(const char *name, double previous)
{
    char *e;
    long long v = strtoll(name, &e, 10);
    if (e != name && *e == 0 && name[0] != 0)
        return (double)v;
    return previous + 1;
}

static ffd_status read_su2(ffd_mesh *m, const char *name, ffd_error *err)
{
    su2_ctx c = {0};
    c.name = name;
    c.s = (const char *)m->src;
    c.at = c.s + ffd_utf8_bom_length(m->src, m->src_size);
    c.end = c.s + m->src_size;
    m->encoding = FFD_ENCODING_ASCII;
    ffd_status st = FFD_OK;
    su2_state *state = ffd_calloc(1, sizeof *state);
    double *tags = NULL;
    size_t tags_cap = 0;
    if (!state)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    m->codec_state = state;
    m->codec_state_free = state_free;

    bool have_elem = false, have_poin = false, have_nmark = false, open_marker = false;
    uint64_t nmark = 0;
    double previous_tag = 0, tag = 0;
    size_t ndime_line = 0;
    while (next_content(&c)) {
        const char *ke, *value;
        if (!keyword(&c, &ke, &value)) {
            st = found(&c, c.b, FFD_ERR_PARSE,
                       "a keyword (NDIME=, NELEM=, NPOIN=, NMARK=, MARKER_TAG=, MARKER_ELEMS=)", err);
            goto fail;
        }
        uint64_t k = 0;
        if (key_is(&c, ke, "NDIME")) {
            if (state->dimension) {
                st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: a second NDIME= (the first on line %zu)",
                              name, c.line, ndime_line);
                goto fail;
            }
            if ((st = count_value(&c, value, "NDIME=", 0, false, &k, err)))
                goto fail;
            if (k != 2 && k != 3) {
                st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: NDIME= %llu, expected 2 or 3", name,
                              c.line, (unsigned long long)k);
                goto fail;
            }
            state->dimension = (int)k;
            ndime_line = c.line;
            continue;
        }
        if (key_is(&c, ke, "NZONE") || key_is(&c, ke, "IZONE")) {
            if ((st = count_value(&c, value, key_is(&c, ke, "NZONE") ? "NZONE=" : "IZONE=", 0,
                                  false, &k, err)))
                goto fail;
            if (k > 1) {
                st = ffd_fail(err, FFD_ERR_UNSUPPORTED,
                              "%s:%zu: multi-zone SU2 files (%.*s= %llu) are not supported: write each zone to its own file",
                              name, c.line, (int)(ke - c.b), c.b, (unsigned long long)k);
                goto fail;
            }
            continue;
        }
        if (key_is(&c, ke, "FFD_NBOX") || key_is(&c, ke, "FFD_NLEVEL")) {
            if ((st = count_value(&c, value, key_is(&c, ke, "FFD_NBOX") ? "FFD_NBOX=" : "FFD_NLEVEL=",
                                  0, false, &k, err)))
                goto fail;
            if (k > 0 && key_is(&c, ke, "FFD_NBOX")) {
                st = ffd_fail(err, FFD_ERR_UNSUPPORTED,
                              "%s:%zu: SU2 FFD boxes in the mesh file (FFD_NBOX= %llu) are not read; remove them (SU2_DEF writes them)",
                              name, c.line, (unsigned long long)k);
                goto fail;
            }
            continue;
        }
        if (!state->dimension) {
            st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected NDIME= before %.*s=", name, c.line,
                          (int)(ke - c.b > 24 ? 24 : ke - c.b), c.b);
            goto fail;
        }
        if (key_is(&c, ke, "NELEM")) {
            if (have_elem) {
                st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: a second NELEM=", name, c.line);
                goto fail;
            }
            have_elem = true;
            if ((st = count_value(&c, value, "NELEM=", SU2_MIN_ELEMENT_LINE, false, &k, err)))
                goto fail;
            size_t first = m->cell_count;
            if ((st = read_elements(&c, m, k, "NELEM", err)))
                goto fail;
            if (!ffd_grow((void **)&tags, &tags_cap, m->cell_count + 1, sizeof(double))) {
                st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
                goto fail;
            }
            for (size_t i = first; i < m->cell_count; i++)
                tags[i] = 0;
        } else if (key_is(&c, ke, "NPOIN")) {
            if (have_poin) {
                st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: a second NPOIN=", name, c.line);
                goto fail;
            }
            have_poin = true;
            if ((st = count_value(&c, value, "NPOIN=", SU2_MIN_POINT_LINE, true, &k, err)))
                goto fail;
            if (k > UINT32_MAX) {
                st = ffd_fail(err, FFD_ERR_RANGE, "%s:%zu: NPOIN= %llu, more than 4294967295", name,
                              c.line, (unsigned long long)k);
                goto fail;
            }
            if (!ffd_mesh_reserve(m, (size_t)k, 0, 0, 0)) {
                st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %llu points", name,
                              (unsigned long long)k);
                goto fail;
            }
            int dim = state->dimension;
            for (uint64_t i = 0; i < k; i++) {
                if (!next_content(&c)) {
                    st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected point %llu of %llu, found end of file",
                                  name, c.line + 1, (unsigned long long)i + 1, (unsigned long long)k);
                    goto fail;
                }
                double v[6] = {0};
                const char *at[6];
                int n = numbers(&c, c.b, v, at, 5, &st, err);
                if (n < 0)
                    goto fail;
                if (n < dim || n > dim + 2) {
                    st = ffd_fail(err, FFD_ERR_PARSE,
                                  "%s:%zu: expected %d coordinates (and an optional index) for point %llu, found %d numbers",
                                  name, c.line, dim, (unsigned long long)i + 1, n > 5 ? 6 : n);
                    goto fail;
                }
                ffd_span sp[3];
                for (int d = 0; d < dim; d++) {
                    if (!isfinite(v[d])) {
                        st = ffd_fail(err, FFD_ERR_NONFINITE,
                                      "%s:%zu: coordinate %c of point %llu is not finite", name,
                                      c.line, "xyz"[d], (unsigned long long)i + 1);
                        goto fail;
                    }
                    sp[d].offset = (uint64_t)(at[d] - c.s);
                    sp[d].kind = FFD_SPAN_TEXT;
                }
                if (dim == 2) {
                    v[2] = 0; /* no z in the file: the patch below never writes it */
                    sp[2] = sp[1];
                }
                if (!ffd_mesh_push_vertex(m, v, sp)) {
                    st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
                    goto fail;
                }
            }
        } else if (key_is(&c, ke, "NMARK")) {
            if (have_nmark) {
                st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: a second NMARK=", name, c.line);
                goto fail;
            }
            have_nmark = true;
            if ((st = count_value(&c, value, "NMARK=", SU2_MIN_MARKER, false, &nmark, err)))
                goto fail;
        } else if (key_is(&c, ke, "MARKER_TAG")) {
            if (!have_nmark || state->marker_count >= nmark || open_marker) {
                st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: %s", name, c.line,
                              !have_nmark ? "MARKER_TAG= before NMARK="
                              : open_marker ? "MARKER_TAG= where MARKER_ELEMS= was expected"
                                            : "more MARKER_TAG= than NMARK= says");
                goto fail;
            }
            size_t len = (size_t)(c.e - value);
            char *tname = ffd_malloc(len + 1);
            if (!tname || !ffd_grow((void **)&state->names, &state->names_cap,
                                    state->marker_count + 1, sizeof(char *))) {
                ffd_free(tname);
                st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
                goto fail;
            }
            memcpy(tname, value, len);
            tname[len] = 0;
            if (!ffd_grow((void **)&state->tags, &state->tags_cap, state->marker_count + 1,
                          sizeof(double))) {
                ffd_free(tname);
                st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
                goto fail;
            }
            tag = marker_tag(tname, previous_tag);
            previous_tag = tag;
            state->names[state->marker_count] = tname;
            state->tags[state->marker_count] = tag;
            state->marker_count++;
            open_marker = true;
        } else if (key_is(&c, ke, "MARKER_ELEMS")) {
            if (!open_marker) {
                st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: MARKER_ELEMS= without a MARKER_TAG= before it",
                              name, c.line);
                goto fail;
            }
            open_marker = false;
            if ((st = count_value(&c, value, "MARKER_ELEMS=", SU2_MIN_ELEMENT_LINE, false, &k, err)))
                goto fail;
            size_t first = m->cell_count;
            if ((st = read_elements(&c, m, k, "marker", err)))
                goto fail;
            if (!ffd_grow((void **)&tags, &tags_cap, m->cell_count + 1, sizeof(double))) {
                st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
                goto fail;
            }
            for (size_t i = first; i < m->cell_count; i++)
                tags[i] = tag;
        } else {
            st = ffd_fail(err, FFD_ERR_UNSUPPORTED,
                          "%s:%zu: keyword %.*s= is not one the SU2 reader knows (NDIME, NELEM, NPOIN, NMARK, MARKER_TAG, MARKER_ELEMS)",
                          name, c.line, (int)(ke - c.b > 24 ? 24 : ke - c.b), c.b);
            goto fail;
        }
    }
    if (!state->dimension || !have_poin || !have_elem) {
        st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected %s, found end of file", name, c.line + 1,
                      !state->dimension ? "NDIME=" : !have_elem ? "NELEM=" : "NPOIN=");
        goto fail;
    }
    if (open_marker || state->marker_count != nmark) {
        st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected %s, found end of file", name,
                      c.line + 1, open_marker ? "MARKER_ELEMS=" : "another MARKER_TAG= (NMARK= says more)");
        goto fail;
    }
    if ((st = ffd_mesh_finish_cells(m, name, where_cell, &c, err)))
        goto fail;
    if (m->cell_count &&
        !ffd_mesh_add_field(m, SU2_TAG_FIELD, FFD_FIELD_CELL, 1, FFD_SPAN_I32, tags, m->cell_count)) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
        goto fail;
    }
    ffd_free(tags);
    ffd_free(c.cell_lines);
    return FFD_OK;
fail:
    ffd_free(tags);
    ffd_free(c.cell_lines);
    return st;
}

/* ======================================================================
 * Writing
 * ====================================================================== */

/* Same file: the generic patch, or for a 2D file the x and y spans only
 * (z has no bytes: a z that is not 0 cannot be written). */
static ffd_status patch_su2(const ffd_mesh *m, ffd_buf *b, ffd_error *err)
{
    const su2_state *s = m->codec_state;
    if (!s || s->dimension != 2)
        return ffd_mesh_patch_spans(m, b, err);
    for (size_t i = 0; i < m->vertex_count; i++)
        if (m->positions[3 * i + 2] != 0)
            return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                            "point %zu has z = %.17g but the SU2 file is 2D (NDIME= 2): it holds x and y only",
                            i, m->positions[3 * i + 2]);
    size_t pos = 0;
    for (size_t i = 0; i < 3 * m->vertex_count; i++) {
        if (i % 3 == 2)
            continue;
        const ffd_span *sp = &m->position_spans[i];
        if (m->positions[i] == ffd_span_value(m, sp))
            continue;
        ffd_buf_put(b, m->src + pos, sp->offset - pos);
        ffd_buf_double(b, m->positions[i]);
        pos = sp->offset + ffd_span_length(m, sp);
    }
    ffd_buf_put(b, m->src + pos, m->src_size - pos);
    return FFD_OK;
}

static int compare_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* One element line: the SU2 type and the nodes (voxel and pixel reordered). */
static void put_element(ffd_buf *b, const ffd_cells_view *v, size_t c)
{
    static const uint8_t voxel[8] = {0, 1, 3, 2, 4, 5, 7, 6};
    unsigned t = v->types[c];
    const uint32_t *ids = v->indices + v->offsets[c];
    size_t n = (size_t)(v->offsets[c + 1] - v->offsets[c]);
    const uint8_t *order = NULL;
    if (t == FFD_CELL_VOXEL || t == FFD_CELL_PIXEL) {
        order = voxel;
        t = t == FFD_CELL_VOXEL ? FFD_CELL_HEXAHEDRON : FFD_CELL_QUAD;
    }
    ffd_buf_uint(b, t);
    for (size_t k = 0; k < n; k++) {
        ffd_buf_puts(b, " ");
        ffd_buf_uint(b, ids[order ? order[k] : k]);
    }
    ffd_buf_puts(b, "\n");
}

static ffd_status write_su2(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    (void)enc;
    ffd_cells_view v;
    ffd_status st = ffd_cells_view_of(m, &v, err);
    if (st)
        return st;
    int top = -1;
    for (size_t c = 0; c < v.count; c++) {
        int d = ffd_cell_type_dimension(v.types[c]);
        if (d > top)
            top = d;
    }
    bool flat = top < 3;
    for (size_t i = 0; flat && i < m->vertex_count; i++)
        flat = m->positions[3 * i + 2] == 0;
    int dim = flat ? 2 : 3;
    /* every written cell must be an SU2 type */
    size_t interior = 0, boundary = 0;
    for (size_t c = 0; c < v.count; c++) {
        int d = ffd_cell_type_dimension(v.types[c]);
        if (d != top && d != top - 1)
            continue;
        unsigned t = v.types[c];
        if (!su2_nodes(t) && t != FFD_CELL_VOXEL && t != FFD_CELL_PIXEL) {
            ffd_cells_view_free(&v);
            return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                            "cell %zu is a %s: SU2 has lines, triangles, quads, tetrahedra, hexahedra, prisms and pyramids only",
                            c, ffd_cell_type_name(t));
        }
        if (d == top)
            interior++;
        else
            boundary++;
    }
    const ffd_mesh_field *tagf = NULL;
    for (size_t f = 0; f < m->field_count; f++)
        if (m->fields[f].association == FFD_FIELD_CELL && m->fields[f].components == 1 &&
            strcmp(m->fields[f].name, SU2_TAG_FIELD) == 0 && m->cell_count)
            tagf = &m->fields[f];

    ffd_buf_printf(b, "NDIME= %d\n", dim);
    ffd_buf_printf(b, "NELEM= %zu\n", interior);
    for (size_t c = 0; c < v.count; c++)
        if (ffd_cell_type_dimension(v.types[c]) == top)
            put_element(b, &v, c);
    ffd_buf_printf(b, "NPOIN= %zu\n", m->vertex_count);
    for (size_t i = 0; i < m->vertex_count; i++) {
        const double *p = m->positions + 3 * i;
        ffd_buf_double(b, p[0]);
        ffd_buf_puts(b, " ");
        ffd_buf_double(b, p[1]);
        if (dim == 3) {
            ffd_buf_puts(b, " ");
            ffd_buf_double(b, p[2]);
        }
        ffd_buf_puts(b, "\n");
    }
    /* markers: the distinct tags of the boundary cells, ascending */
    double *ut = ffd_malloc((boundary ? boundary : 1) * sizeof(double));
    if (!ut) {
        ffd_cells_view_free(&v);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory listing the markers");
    }
    size_t nu = 0;
    for (size_t c = 0; c < v.count; c++)
        if (top > 0 && ffd_cell_type_dimension(v.types[c]) == top - 1)
            ut[nu++] = tagf ? tagf->values[c] : 1;
    qsort(ut, nu, sizeof(double), compare_double);
    size_t distinct = 0;
    for (size_t i = 0; i < nu; i++)
        if (i == 0 || ut[i] != ut[i - 1])
            ut[distinct++] = ut[i];
    ffd_buf_printf(b, "NMARK= %zu\n", distinct);
    const su2_state *s = m->src && m->format == FFD_FORMAT_SU2 ? m->codec_state : NULL;
    for (size_t u = 0; u < distinct; u++) {
        const char *known = NULL;
        for (size_t k = 0; s && k < s->marker_count; k++)
            if (s->tags[k] == ut[u])
                known = s->names[k];
        if (known)
            ffd_buf_printf(b, "MARKER_TAG= %s\n", known);
        else
            ffd_buf_printf(b, "MARKER_TAG= marker_%.17g\n", ut[u]);
        size_t count = 0;
        for (size_t c = 0; c < v.count; c++)
            if (ffd_cell_type_dimension(v.types[c]) == top - 1 &&
                (tagf ? tagf->values[c] : 1) == ut[u])
                count++;
        ffd_buf_printf(b, "MARKER_ELEMS= %zu\n", count);
        for (size_t c = 0; c < v.count; c++)
            if (ffd_cell_type_dimension(v.types[c]) == top - 1 &&
                (tagf ? tagf->values[c] : 1) == ut[u])
                put_element(b, &v, c);
    }
    ffd_free(ut);
    ffd_cells_view_free(&v);
    return FFD_OK;
}

static const char *const su2_extensions[] = {"su2", NULL};

const ffd_mesh_codec ffd_mesh_codec_su2 = {
    .format = FFD_FORMAT_SU2,
    .name = "SU2",
    .extensions = su2_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII),
    .read = read_su2,
    .patch = patch_su2,
    .write = write_su2,
};
