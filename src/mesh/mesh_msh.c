/* mesh_msh.c — Gmsh MSH codec: versions 2.2 and 4.1, ascii and binary
 * (little-endian), read losslessly; written from data as MSH 2.2.
 *
 * Reference: the Gmsh reference manual, section "MSH file format" (4.1) and
 * "Legacy formats" (2.2); element types and node orders from its "Node
 * ordering" section. Hand-written because the lossless write needs the byte
 * offset of every node coordinate (no library keeps them): a read keeps the
 * file and a span per coordinate, and writing back to .msh in the same
 * encoding rewrites only the coordinates that changed (ffd_mesh_patch_spans).
 *
 * Cells are VTK's (mesh_cells.h): Gmsh types map to VTK ids and Gmsh node
 * orders to VTK's (gmsh_types below; tet10, hex20, hex27, prism15 and
 * pyramid13 differ, and Gmsh's prism has its base (0,1,2) counter-clockwise
 * seen from (3,4,5) where VTK's wedge has it clockwise, so prisms swap nodes
 * 1-2 and 4-5). Physical and elementary tags become the integer cell fields
 * "gmsh:physical" and "gmsh:geometrical" (meshio's names). Every other
 * section is kept as bytes. Docs: docs/volume.md, "### Gmsh". */
#include "mesh_cells.h"
#include "mesh_codec.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ======================================================================
 * Element types: Gmsh id -> VTK id and node order
 * ====================================================================== */

typedef struct gmsh_type {
    int gmsh;                /* Gmsh element type */
    uint8_t vtk;             /* FFD_CELL_*; 0: no VTK counterpart (refused) */
    uint8_t nodes;           /* node count */
    const char *name;        /* Gmsh's name, for messages */
    const uint8_t *to_vtk;   /* VTK node i is Gmsh node to_vtk[i]; NULL: same order */
} gmsh_type;

static const uint8_t tet10_order[] = {0, 1, 2, 3, 4, 5, 6, 7, 9, 8};
static const uint8_t hex20_order[] = {0, 1, 2,  3, 4,  5,  6,  7,  8,  11,
                                      13, 9, 16, 18, 19, 17, 10, 12, 14, 15};
static const uint8_t hex27_order[] = {0,  1,  2,  3,  4,  5,  6,  7,  8,  11, 13, 9,  16, 18,
                                      19, 17, 10, 12, 14, 15, 22, 23, 21, 24, 20, 25, 26};
/* Prisms: base and top reversed (1<->2, 4<->5), edges follow. */
static const uint8_t prism6_order[] = {0, 2, 1, 3, 5, 4};
static const uint8_t prism15_order[] = {0, 2, 1, 3, 5, 4, 7, 9, 6, 13, 14, 12, 8, 11, 10};
static const uint8_t pyramid13_order[] = {0, 1, 2, 3, 4, 5, 8, 10, 6, 7, 9, 11, 12};

static const gmsh_type gmsh_types[] = {
    {1, FFD_CELL_LINE, 2, "line", NULL},
    {2, FFD_CELL_TRIANGLE, 3, "triangle", NULL},
    {3, FFD_CELL_QUAD, 4, "quadrangle", NULL},
    {4, FFD_CELL_TETRA, 4, "tetrahedron", NULL},
    {5, FFD_CELL_HEXAHEDRON, 8, "hexahedron", NULL},
    {6, FFD_CELL_WEDGE, 6, "prism", prism6_order},
    {7, FFD_CELL_PYRAMID, 5, "pyramid", NULL},
    {8, FFD_CELL_QUADRATIC_EDGE, 3, "line3", NULL},
    {9, FFD_CELL_QUADRATIC_TRIANGLE, 6, "triangle6", NULL},
    {10, FFD_CELL_BIQUADRATIC_QUAD, 9, "quadrangle9", NULL},
    {11, FFD_CELL_QUADRATIC_TETRA, 10, "tetrahedron10", tet10_order},
    {12, FFD_CELL_TRIQUADRATIC_HEXAHEDRON, 27, "hexahedron27", hex27_order},
    {13, 0, 18, "prism18", NULL},
    {14, 0, 14, "pyramid14", NULL},
    {15, FFD_CELL_VERTEX, 1, "point", NULL},
    {16, FFD_CELL_QUADRATIC_QUAD, 8, "quadrangle8", NULL},
    {17, FFD_CELL_QUADRATIC_HEXAHEDRON, 20, "hexahedron20", hex20_order},
    {18, FFD_CELL_QUADRATIC_WEDGE, 15, "prism15", prism15_order},
    {19, FFD_CELL_QUADRATIC_PYRAMID, 13, "pyramid13", pyramid13_order},
};
#define GMSH_TYPE_COUNT (sizeof gmsh_types / sizeof gmsh_types[0])

static const gmsh_type *gmsh_type_of(long long id)
{
    for (size_t i = 0; i < GMSH_TYPE_COUNT; i++)
        if (gmsh_types[i].gmsh == id)
            return &gmsh_types[i];
    return NULL;
}

static const gmsh_type *gmsh_type_of_vtk(unsigned vtk)
{
    for (size_t i = 0; i < GMSH_TYPE_COUNT; i++)
        if (gmsh_types[i].vtk && gmsh_types[i].vtk == vtk)
            return &gmsh_types[i];
    return NULL;
}

/* ======================================================================
 * Reader state and messages
 * ====================================================================== */

/* An entity of a 4.1 $Entities section: its first physical tag (0: none). */
typedef struct entity {
    int dim;
    long long tag;
    long long physical;
} entity;

typedef struct reader {
    ffd_mesh *m;
    const char *name;
    const char *s, *end; /* the source */
    const char *p;       /* cursor */
    bool binary;
    int major; /* 2 or 4 */
    ffd_error *err;

    uint64_t *node_tags; /* per vertex: its Gmsh tag */
    size_t node_tag_cap;
    uint32_t *by_tag; /* vertex indices sorted by tag (NULL: tags are 1..n in order) */
    bool tags_identity;

    entity *entities;
    size_t entity_count, entity_cap;
    bool have_entities, have_partitioned;
    size_t partitioned_from; /* the first entity of $PartitionedEntities (0: none) */

    /* per cell: where its record starts, its physical and elementary tag */
    uint64_t *cell_at;
    double *physical, *geometrical;
    size_t cell_at_cap, physical_cap, geometrical_cap;
    bool any_physical, any_geometrical;

    bool have_nodes, have_elements;
    const char *section_at; /* the "$Name" of the section being read */
} reader;

static size_t line_of(const char *s, const char *at)
{
    size_t line = 1;
    for (const char *q = s; q < at; q++)
        line += *q == '\n';
    return line;
}

/* "name:line: what" (ascii) or "name: byte N: what" (binary) at position at. */
static ffd_status fail_at(reader *r, const char *at, ffd_status status, const char *fmt, ...)
    FFD_PRINTF(4, 5);
static ffd_status fail_at(reader *r, const char *at, ffd_status status, const char *fmt, ...)
{
    char what[200];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    if (at > r->end)
        at = r->end;
    if (r->binary)
        return ffd_fail(r->err, status, "%s: byte %zu: %s", r->name, (size_t)(at - r->s), what);
    return ffd_fail(r->err, status, "%s:%zu: %s", r->name, line_of(r->s, at), what);
}

static ffd_status oom(reader *r)
{
    return ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory", r->name);
}

typedef struct cell_where {
    const char *name, *s;
    const uint64_t *at;
    bool binary;
} cell_where;

static void locate_cell(const void *user, size_t cell, char *buf, size_t size)
{
    const cell_where *w = user;
    if (w->binary)
        snprintf(buf, size, "%s: byte %llu", w->name, (unsigned long long)w->at[cell]);
    else
        snprintf(buf, size, "%s:%zu", w->name, line_of(w->s, w->s + w->at[cell]));
}

/* ======================================================================
 * Tokens: ascii words and numbers, binary scalars
 * ====================================================================== */

/* Whitespace, in either encoding (between sections, before "$End"). */
static void skip_ws(reader *r)
{
    while (r->p < r->end && ffd_is_space((unsigned char)*r->p))
        r->p++;
}

/* Whitespace between ascii tokens; nothing in binary data. */
static void skip_space(reader *r)
{
    if (!r->binary)
        skip_ws(r);
}

static size_t bytes_left(const reader *r)
{
    return (size_t)(r->end - r->p);
}

/* An ascii integer (optional sign, digits) ending at whitespace or the end. */
static ffd_status read_int(reader *r, const char *what, long long *out)
{
    skip_space(r);
    const char *q = r->p;
    bool neg = false;
    if (q < r->end && (*q == '-' || *q == '+'))
        neg = *q++ == '-';
    const char *digits = q;
    unsigned long long v = 0;
    while (q < r->end && *q >= '0' && *q <= '9') {
        if (v > (unsigned long long)(INT64_MAX - 9) / 10)
            return fail_at(r, r->p, FFD_ERR_RANGE, "%s is too large", what);
        v = v * 10 + (unsigned)(*q++ - '0');
    }
    if (q == digits || (q < r->end && !ffd_is_space((unsigned char)*q))) {
        if (r->p >= r->end)
            return fail_at(r, r->p, FFD_ERR_PARSE, "expected %s, found the end of the file",
                           what);
        return fail_at(r, r->p, FFD_ERR_PARSE, "expected %s (an integer)", what);
    }
    *out = neg ? -(long long)v : (long long)v;
    r->p = q;
    return FFD_OK;
}

/* A non-negative count or tag. */
static ffd_status read_count(reader *r, const char *what, long long *out)
{
    const char *at = (skip_space(r), r->p);
    ffd_status s = read_int(r, what, out);
    if (s == FFD_OK && *out < 0)
        return fail_at(r, at, FFD_ERR_RANGE, "%s %lld is negative", what, *out);
    return s;
}

/* An ascii real; *span records where it lives. */
static ffd_status read_real(reader *r, const char *what, double *out, ffd_span *span)
{
    skip_space(r);
    const char *at = r->p;
    int k = ffd_parse_number(&r->p, r->end, false, out);
    if (k != 1) {
        if (at >= r->end)
            return fail_at(r, at, FFD_ERR_PARSE, "expected %s, found the end of the file", what);
        return fail_at(r, at, FFD_ERR_PARSE, "expected %s (a number)", what);
    }
    if (!isfinite(*out))
        return fail_at(r, at, FFD_ERR_NONFINITE, "%s is not finite", what);
    if (span)
        *span = (ffd_span){.offset = (uint64_t)(at - r->s), .kind = FFD_SPAN_TEXT};
    return FFD_OK;
}

static ffd_status need_bytes(reader *r, size_t n, const char *what)
{
    if (bytes_left(r) < n)
        return fail_at(r, r->p, FFD_ERR_PARSE, "%s: %zu bytes expected, %zu left", what, n,
                       bytes_left(r));
    return FFD_OK;
}

static long long bin_i32(reader *r)
{
    long long v = (int32_t)ffd_read_scalar((const unsigned char *)r->p, FFD_SPAN_I32, false);
    r->p += 4;
    return v;
}

static unsigned long long bin_u64(reader *r)
{
    const unsigned char *q = (const unsigned char *)r->p;
    unsigned long long v = 0;
    for (int k = 7; k >= 0; k--)
        v = v << 8 | q[k];
    r->p += 8;
    return v;
}

/* A binary size_t (8 bytes) that must fit a long long. */
static ffd_status bin_count(reader *r, const char *what, long long *out)
{
    ffd_status s = need_bytes(r, 8, what);
    if (s)
        return s;
    const char *at = r->p;
    unsigned long long v = bin_u64(r);
    if (v > INT64_MAX)
        return fail_at(r, at, FFD_ERR_RANGE, "%s %llu is too large", what, v);
    *out = (long long)v;
    return FFD_OK;
}

static ffd_status bin_int(reader *r, const char *what, long long *out)
{
    ffd_status s = need_bytes(r, 4, what);
    if (s)
        return s;
    *out = bin_i32(r);
    return FFD_OK;
}

/* A count, tag or integer of either encoding: 4.1 binary counts and tags
 * are size_t (wide) or int. */
static ffd_status read_num(reader *r, bool wide, const char *what, long long *out)
{
    if (!r->binary)
        return read_int(r, what, out);
    return wide ? bin_count(r, what, out) : bin_int(r, what, out);
}

/* Refuses a count that the bytes left cannot hold at min_bytes each. */
static ffd_status check_count(reader *r, const char *at, long long n, size_t min_bytes,
                              const char *what)
{
    if (n < 0)
        return fail_at(r, at, FFD_ERR_RANGE, "%s %lld is negative", what, n);
    if ((unsigned long long)n > bytes_left(r) / min_bytes)
        return fail_at(r, at, FFD_ERR_RANGE,
                       "%s %lld is more than the %zu bytes left can hold", what, n,
                       bytes_left(r));
    return FFD_OK;
}

/* The header of MSH 4.1's $Nodes and $Elements: the entity block count,
 * the item count and the smallest and largest tag (read past), both counts
 * checked against the bytes left (an item takes at least item_binary or
 * item_ascii bytes, an entity block 20 or 8). item names it: "node". */
static ffd_status read_blocks_header_41(reader *r, const char *item, size_t item_binary,
                                        size_t item_ascii, long long *blocks, long long *n)
{
    char count[48], smallest[48], largest[48], name[48];
    snprintf(count, sizeof count, "the %s count", item);
    snprintf(smallest, sizeof smallest, "the smallest %s tag", item);
    snprintf(largest, sizeof largest, "the largest %s tag", item);
    snprintf(name, sizeof name, "%s count", item);
    long long min_tag, max_tag;
    ffd_status s;
    const char *at = (skip_space(r), r->p);
    if ((s = read_num(r, true, "the entity block count", blocks)) ||
        (s = read_num(r, true, count, n)) || (s = read_num(r, true, smallest, &min_tag)) ||
        (s = read_num(r, true, largest, &max_tag)))
        return s;
    if ((s = check_count(r, at, *n, r->binary ? item_binary : item_ascii, name)))
        return s;
    return check_count(r, at, *blocks, r->binary ? 20 : 8, "entity block count");
}

/* After a section's content: "$End<name>" on its own line. */
static ffd_status expect_end(reader *r, const char *section)
{
    skip_ws(r);
    size_t n = strlen(section);
    if (bytes_left(r) < 4 + n || memcmp(r->p, "$End", 4) != 0 || memcmp(r->p + 4, section, n) ||
        (r->p + 4 + n < r->end && !ffd_is_space((unsigned char)r->p[4 + n])))
        return fail_at(r, r->p, FFD_ERR_PARSE, "expected $End%s", section);
    r->p += 4 + n;
    return FFD_OK;
}

/* ======================================================================
 * Sections
 * ====================================================================== */

static ffd_status read_mesh_format(reader *r)
{
    skip_space(r);
    const char *at = r->p;
    double version;
    ffd_status s = read_real(r, "the version", &version, NULL);
    if (s)
        return s;
    if (version >= 4.1 && version < 4.2)
        r->major = 4;
    else if (version >= 2.0 && version < 2.3)
        r->major = 2;
    else
        return fail_at(r, at, FFD_ERR_UNSUPPORTED,
                       "MSH version %g is not supported (2.2 and 4.1 are)", version);
    long long file_type, data_size;
    if ((s = read_int(r, "the file type", &file_type)) || (s = read_int(r, "the data size",
                                                                        &data_size)))
        return s;
    if (file_type != 0 && file_type != 1)
        return fail_at(r, at, FFD_ERR_PARSE, "file type %lld is neither 0 (ascii) nor 1 (binary)",
                       file_type);
    r->binary = file_type == 1;
    if (r->binary) {
        if (data_size != 8)
            return fail_at(r, at, FFD_ERR_UNSUPPORTED,
                           "data size %lld is not supported (binary MSH needs 8)", data_size);
        /* the rest of the line, then the endianness check: int 1 */
        while (r->p < r->end && *r->p != '\n')
            r->p++;
        if (r->p < r->end)
            r->p++;
        if ((s = need_bytes(r, 4, "the endianness check")))
            return s;
        const unsigned char *q = (const unsigned char *)r->p;
        if (q[0] == 0 && q[1] == 0 && q[2] == 0 && q[3] == 1)
            return fail_at(r, r->p, FFD_ERR_UNSUPPORTED,
                           "big-endian binary MSH is not supported (only little-endian)");
        if (!(q[0] == 1 && q[1] == 0 && q[2] == 0 && q[3] == 0))
            return fail_at(r, r->p, FFD_ERR_PARSE, "the endianness check is not the integer 1");
        r->p += 4;
    }
    r->m->encoding = r->binary ? FFD_ENCODING_BINARY_LE : FFD_ENCODING_ASCII;
    return expect_end(r, "MeshFormat");
}

static ffd_status add_entity(reader *r, int dim, long long tag, long long physical)
{
    if (r->entity_count == r->entity_cap &&
        !ffd_grow((void **)&r->entities, &r->entity_cap, r->entity_count + 1, sizeof(entity)))
        return oom(r);
    r->entities[r->entity_count++] = (entity){dim, tag, physical};
    return FFD_OK;
}

/* 4.1 $Entities: the physical tags of each entity (the section stays as
 * bytes). partitioned: $PartitionedEntities, the entities of a piece of a
 * partitioned mesh (`gmsh -part N -part_split`), which its $Nodes and
 * $Elements blocks name: after a partition count and the ghost entities,
 * each entity has its parent's dimension and tag and its partitions after
 * its tag; the rest is as in $Entities. */
static ffd_status read_entities(reader *r, bool partitioned)
{
    long long n[4];
    ffd_status s;
    if (partitioned) {
        long long parts, ghosts;
        r->partitioned_from = r->entity_count;
        const char *at = (skip_space(r), r->p);
        if ((s = read_num(r, true, "the partition count", &parts)) ||
            (s = check_count(r, at, parts, 1, "partition count")))
            return s;
        at = (skip_space(r), r->p);
        if ((s = read_num(r, true, "the ghost entity count", &ghosts)) ||
            (s = check_count(r, at, ghosts, r->binary ? 8 : 4, "ghost entity count")))
            return s;
        for (long long g = 0; g < ghosts; g++) {
            long long t;
            if ((s = read_num(r, false, "a ghost entity tag", &t)) ||
                (s = read_num(r, false, "a ghost entity's partition", &t)))
                return s;
        }
    }
    for (int d = 0; d < 4; d++)
        if ((s = read_num(r, true, "an entity count", &n[d])))
            return s;
    for (int d = 0; d < 4; d++) {
        const char *at = r->p;
        if ((s = check_count(r, at, n[d], r->binary ? 4 + 24 + 8 : 8, "entity count")))
            return s;
        for (long long e = 0; e < n[d]; e++) {
            long long tag, nphys, physical = 0;
            if ((s = read_num(r, false, "an entity tag", &tag)))
                return s;
            if (partitioned) {
                long long parent, nparts, t;
                if ((s = read_num(r, false, "the parent entity's dimension", &parent)) ||
                    (s = read_num(r, false, "the parent entity's tag", &parent)))
                    return s;
                at = (skip_space(r), r->p);
                if ((s = read_num(r, true, "an entity's partition count", &nparts)) ||
                    (s = check_count(r, at, nparts, r->binary ? 4 : 2, "partition count")))
                    return s;
                for (long long k = 0; k < nparts; k++)
                    if ((s = read_num(r, false, "a partition tag", &t)))
                        return s;
            }
            int reals = d == 0 ? 3 : 6;
            for (int k = 0; k < reals; k++) {
                double v;
                if (r->binary) {
                    if ((s = need_bytes(r, 8, "an entity coordinate")))
                        return s;
                    r->p += 8;
                } else if ((s = read_real(r, "an entity coordinate", &v, NULL)))
                    return s;
            }
            at = r->p;
            if ((s = read_num(r, true, "a physical tag count", &nphys)) ||
                (s = check_count(r, at, nphys, r->binary ? 4 : 2, "physical tag count")))
                return s;
            for (long long k = 0; k < nphys; k++) {
                long long t;
                if ((s = read_num(r, false, "a physical tag", &t)))
                    return s;
                if (k == 0)
                    physical = t;
            }
            if (d > 0) {
                long long nb;
                at = r->p;
                if ((s = read_num(r, true, "a bounding entity count", &nb)) ||
                    (s = check_count(r, at, nb, r->binary ? 4 : 2, "bounding entity count")))
                    return s;
                for (long long k = 0; k < nb; k++) {
                    long long t;
                    if ((s = read_num(r, false, "a bounding entity tag", &t)))
                        return s;
                }
            }
            if ((s = add_entity(r, d, tag, physical)))
                return s;
        }
    }
    if (partitioned) {
        r->have_partitioned = true;
        return expect_end(r, "PartitionedEntities");
    }
    r->have_entities = true;
    return expect_end(r, "Entities");
}

static ffd_status push_node(reader *r, uint64_t tag, const double xyz[3], const ffd_span sp[3])
{
    size_t i = r->m->vertex_count;
    if (i == r->node_tag_cap &&
        !ffd_grow((void **)&r->node_tags, &r->node_tag_cap, i + 1, sizeof(uint64_t)))
        return oom(r);
    if (!ffd_mesh_push_vertex(r->m, xyz, sp))
        return oom(r);
    r->node_tags[i] = tag;
    return FFD_OK;
}

/* One node's x y z at r->p. */
static ffd_status read_xyz(reader *r, double xyz[3], ffd_span sp[3])
{
    if (!r->binary) {
        static const char *const what[3] = {"the node's x", "the node's y", "the node's z"};
        for (int k = 0; k < 3; k++) {
            ffd_status s = read_real(r, what[k], &xyz[k], &sp[k]);
            if (s)
                return s;
        }
        return FFD_OK;
    }
    for (int k = 0; k < 3; k++) {
        xyz[k] = ffd_read_scalar((const unsigned char *)r->p, FFD_SPAN_F64, false);
        if (!isfinite(xyz[k]))
            return fail_at(r, r->p, FFD_ERR_NONFINITE, "a node coordinate is not finite");
        sp[k] = (ffd_span){.offset = (uint64_t)(r->p - r->s), .kind = FFD_SPAN_F64};
        r->p += 8;
    }
    return FFD_OK;
}

/* Node tags sorted with their vertex index. */
typedef struct tag_pair {
    uint64_t tag;
    uint32_t index;
} tag_pair;

static int compare_pairs(const void *a, const void *b)
{
    const tag_pair *x = a, *y = b;
    return x->tag < y->tag ? -1 : x->tag > y->tag;
}

/* After $Nodes: the lookup from node tag to vertex index. */
static ffd_status index_node_tags(reader *r, const char *section_at)
{
    size_t n = r->m->vertex_count;
    r->tags_identity = true;
    for (size_t i = 0; i < n && r->tags_identity; i++)
        r->tags_identity = r->node_tags[i] == i + 1;
    if (r->tags_identity)
        return FFD_OK;
    tag_pair *pairs = ffd_malloc_array(n, sizeof(tag_pair));
    r->by_tag = ffd_malloc_array(n ? n : 1, sizeof(uint32_t));
    if (!pairs || !r->by_tag) {
        ffd_free(pairs);
        return oom(r);
    }
    for (size_t i = 0; i < n; i++)
        pairs[i] = (tag_pair){r->node_tags[i], (uint32_t)i};
    qsort(pairs, n, sizeof *pairs, compare_pairs);
    for (size_t i = 0; i < n; i++) {
        if (i > 0 && pairs[i].tag == pairs[i - 1].tag) {
            unsigned long long t = pairs[i].tag;
            ffd_free(pairs);
            return fail_at(r, section_at, FFD_ERR_PARSE, "node tag %llu is defined twice", t);
        }
        r->by_tag[i] = pairs[i].index;
    }
    ffd_free(pairs);
    return FFD_OK;
}

/* The vertex index of node tag t, or -1. */
static long long node_index(const reader *r, long long t)
{
    size_t n = r->m->vertex_count;
    if (r->tags_identity)
        return t >= 1 && (unsigned long long)t <= n ? t - 1 : -1;
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        uint64_t x = r->node_tags[r->by_tag[mid]];
        if (x == (uint64_t)t)
            return r->by_tag[mid];
        if (x < (uint64_t)t)
            lo = mid + 1;
        else
            hi = mid;
    }
    return -1;
}

static ffd_status read_nodes(reader *r)
{
    if (r->have_nodes)
        return fail_at(r, r->section_at, FFD_ERR_PARSE, "a second $Nodes section");
    r->have_nodes = true;
    const char *section_at = r->p;
    ffd_status s;
    double xyz[3];
    ffd_span sp[3];
    if (r->major == 2) {
        long long n;
        skip_ws(r);
        const char *at = r->p;
        /* the count is an ascii line in both encodings */
        bool binary = r->binary;
        r->binary = false;
        s = read_count(r, "the node count", &n);
        r->binary = binary;
        if (s)
            return s;
        if (binary && r->p < r->end && *r->p == '\r')
            r->p++;
        if (binary && r->p < r->end && *r->p == '\n')
            r->p++;
        if ((s = check_count(r, at, n, binary ? 28 : 8, "node count")))
            return s;
        if (!ffd_mesh_reserve(r->m, (size_t)n, 0, 0, 0))
            return oom(r);
        for (long long i = 0; i < n; i++) {
            long long tag;
            const char *tag_at = (skip_space(r), r->p);
            if (binary) {
                if ((s = need_bytes(r, 28, "a node")))
                    return s;
                r->p = tag_at;
                tag = bin_i32(r);
            } else if ((s = read_int(r, "a node tag", &tag)))
                return s;
            if (tag < 1)
                return fail_at(r, tag_at, FFD_ERR_RANGE, "node tag %lld is not positive", tag);
            if ((s = read_xyz(r, xyz, sp)) || (s = push_node(r, (uint64_t)tag, xyz, sp)))
                return s;
        }
    } else {
        long long blocks, n;
        if ((s = read_blocks_header_41(r, "node", 32, 8, &blocks, &n)))
            return s;
        if (!ffd_mesh_reserve(r->m, (size_t)n, 0, 0, 0))
            return oom(r);
        long long total = 0;
        for (long long b = 0; b < blocks; b++) {
            long long dim, tag, parametric, count;
            const char *block_at = (skip_space(r), r->p);
            if ((s = read_num(r, false, "the block's entity dimension", &dim)) ||
                (s = read_num(r, false, "the block's entity tag", &tag)) ||
                (s = read_num(r, false, "the block's parametric flag", &parametric)) ||
                (s = read_num(r, true, "the block's node count", &count)))
                return s;
            if (parametric != 0)
                return fail_at(r, block_at, FFD_ERR_UNSUPPORTED,
                               "parametric nodes (entity %lld of dimension %lld) are not "
                               "supported: their parametric coordinates would not follow the "
                               "deformation",
                               tag, dim);
            if (count < 0 || count > n - total)
                return fail_at(r, block_at, FFD_ERR_RANGE,
                               "the block's %lld nodes exceed the section's node count %lld",
                               count, n);
            const char *tags_at = r->p;
            if (r->binary) {
                if ((s = need_bytes(r, (size_t)count * 32, "a node block")))
                    return s;
                r->p += (size_t)count * 8; /* the tags, read below */
            } else {
                for (long long i = 0; i < count; i++) {
                    long long t;
                    if ((s = read_int(r, "a node tag", &t)))
                        return s;
                }
            }
            /* the tags again, now with their nodes */
            const char *xyz_at = r->p;
            const char *tp = tags_at;
            for (long long i = 0; i < count; i++) {
                long long t;
                const char *here = r->p;
                r->p = tp;
                const char *t_at = (skip_space(r), r->p);
                if ((s = read_num(r, true, "a node tag", &t)))
                    return s;
                tp = r->p;
                r->p = i == 0 ? xyz_at : here;
                if (t < 1)
                    return fail_at(r, t_at, FFD_ERR_RANGE, "node tag %lld is not positive", t);
                if ((s = read_xyz(r, xyz, sp)) || (s = push_node(r, (uint64_t)t, xyz, sp)))
                    return s;
            }
            total += count;
        }
        if (total != n)
            return fail_at(r, section_at, FFD_ERR_PARSE,
                           "the node blocks hold %lld nodes, the header says %lld", total, n);
    }
    if ((s = index_node_tags(r, section_at)))
        return s;
    return expect_end(r, "Nodes");
}

static ffd_status push_element(reader *r, const char *at, const gmsh_type *t,
                               const long long *tags, double physical, double geometrical)
{
    uint32_t ids[27];
    for (unsigned k = 0; k < t->nodes; k++) {
        long long gk = tags[t->to_vtk ? t->to_vtk[k] : k];
        long long v = node_index(r, gk);
        if (v < 0)
            return fail_at(r, at, FFD_ERR_RANGE, "node tag %lld of a %s is not in $Nodes", gk,
                           t->name);
        ids[k] = (uint32_t)v;
    }
    size_t c = r->m->cell_count;
    if (!ffd_grow((void **)&r->cell_at, &r->cell_at_cap, c + 1, sizeof(uint64_t)) ||
        !ffd_grow((void **)&r->physical, &r->physical_cap, c + 1, sizeof(double)) ||
        !ffd_grow((void **)&r->geometrical, &r->geometrical_cap, c + 1, sizeof(double)))
        return oom(r);
    if (!ffd_mesh_push_cell(r->m, t->vtk, ids, t->nodes))
        return oom(r);
    r->cell_at[c] = (uint64_t)(at - r->s);
    r->physical[c] = physical;
    r->geometrical[c] = geometrical;
    return FFD_OK;
}

static ffd_status element_type(reader *r, const char *at, long long id, const gmsh_type **out)
{
    const gmsh_type *t = gmsh_type_of(id);
    if (!t)
        return fail_at(r, at, FFD_ERR_UNSUPPORTED,
                       "element type %lld is not supported (types 1-19 but 13 and 14 are)", id);
    if (!t->vtk)
        return fail_at(r, at, FFD_ERR_UNSUPPORTED,
                       "element type %lld (%s) is not supported: it has no VTK cell type", id,
                       t->name);
    *out = t;
    return FFD_OK;
}

/* The first physical tag of entity (dim, tag) in $Entities, 0 when none. */
static double physical_of_entity(const reader *r, long long dim, long long tag)
{
    /* a piece's $PartitionedEntities first: its blocks name them */
    for (size_t k = 0; k < r->entity_count; k++) {
        size_t i = (r->partitioned_from + k) % r->entity_count;
        if (r->entities[i].dim == dim && r->entities[i].tag == tag)
            return (double)r->entities[i].physical;
    }
    return 0;
}

/* 2.2 ascii: elm-number elm-type number-of-tags tags... nodes... */
static ffd_status read_elements_22_ascii(reader *r, long long n)
{
    ffd_status s;
    long long nodes[27];
    for (long long e = 0; e < n; e++) {
        long long number, type, ntags;
        const char *at = (skip_space(r), r->p);
        const gmsh_type *t = NULL;
        if ((s = read_int(r, "an element number", &number)) ||
            (s = read_int(r, "an element type", &type)) ||
            (s = element_type(r, at, type, &t)) ||
            (s = read_count(r, "the element's tag count", &ntags)))
            return s;
        double physical = 0, geometrical = 0;
        for (long long k = 0; k < ntags; k++) {
            long long tag;
            if ((s = read_int(r, "an element tag", &tag)))
                return s;
            if (k == 0)
                physical = (double)tag, r->any_physical = true;
            if (k == 1)
                geometrical = (double)tag, r->any_geometrical = true;
        }
        for (unsigned k = 0; k < t->nodes; k++)
            if ((s = read_int(r, "a node tag of the element", &nodes[k])))
                return s;
        if ((s = push_element(r, at, t, nodes, physical, geometrical)))
            return s;
    }
    return FFD_OK;
}

/* 2.2 binary: blocks of (type, count, number-of-tags) then count records of
 * int32: number, tags, nodes. */
static ffd_status read_elements_22_binary(reader *r, long long n)
{
    ffd_status s;
    long long nodes[27];
    long long done = 0;
    while (done < n) {
        const char *at = r->p;
        if ((s = need_bytes(r, 12, "an element block header")))
            return s;
        long long type = bin_i32(r), count = bin_i32(r), ntags = bin_i32(r);
        const gmsh_type *t = NULL;
        if ((s = element_type(r, at, type, &t)))
            return s;
        if (count < 1 || count > n - done)
            return fail_at(r, at, FFD_ERR_RANGE,
                           "element block of %lld elements (%lld of %lld left)", count,
                           n - done, n);
        if (ntags < 0 || ntags > 1000)
            return fail_at(r, at, FFD_ERR_RANGE, "element tag count %lld", ntags);
        size_t record = 4 * (1 + (size_t)ntags + t->nodes);
        if ((unsigned long long)count > bytes_left(r) / record)
            return fail_at(r, at, FFD_ERR_RANGE,
                           "element block of %lld elements is more than the %zu bytes left "
                           "can hold",
                           count, bytes_left(r));
        for (long long e = 0; e < count; e++) {
            const char *rec = r->p;
            r->p += 4; /* number */
            double physical = 0, geometrical = 0;
            for (long long k = 0; k < ntags; k++) {
                long long tag = bin_i32(r);
                if (k == 0)
                    physical = (double)tag, r->any_physical = true;
                if (k == 1)
                    geometrical = (double)tag, r->any_geometrical = true;
            }
            for (unsigned k = 0; k < t->nodes; k++)
                nodes[k] = bin_i32(r);
            if ((s = push_element(r, rec, t, nodes, physical, geometrical)))
                return s;
        }
        done += count;
    }
    return FFD_OK;
}

static ffd_status read_elements(reader *r)
{
    if (r->have_elements)
        return fail_at(r, r->section_at, FFD_ERR_PARSE, "a second $Elements section");
    if (!r->have_nodes)
        return fail_at(r, r->section_at, FFD_ERR_PARSE, "$Elements before $Nodes");
    r->have_elements = true;
    ffd_status s;
    const char *section_at = r->p;
    if (r->major == 2) {
        long long n;
        const char *at = (skip_ws(r), r->p);
        bool binary = r->binary;
        r->binary = false;
        s = read_count(r, "the element count", &n);
        r->binary = binary;
        if (s)
            return s;
        if (binary && r->p < r->end && *r->p == '\r')
            r->p++;
        if (binary && r->p < r->end && *r->p == '\n')
            r->p++;
        if ((s = check_count(r, at, n, binary ? 12 : 8, "element count")))
            return s;
        s = binary ? read_elements_22_binary(r, n) : read_elements_22_ascii(r, n);
        if (s)
            return s;
    } else {
        long long blocks, n;
        if ((s = read_blocks_header_41(r, "element", 16, 4, &blocks, &n)))
            return s;
        long long total = 0, nodes[27];
        for (long long b = 0; b < blocks; b++) {
            long long dim, tag, type, count;
            const char *block_at = (skip_space(r), r->p);
            const gmsh_type *t = NULL;
            if ((s = read_num(r, false, "the block's entity dimension", &dim)) ||
                (s = read_num(r, false, "the block's entity tag", &tag)) ||
                (s = read_num(r, false, "the block's element type", &type)) ||
                (s = element_type(r, block_at, type, &t)) ||
                (s = read_num(r, true, "the block's element count", &count)))
                return s;
            if (count < 0 || count > n - total)
                return fail_at(r, block_at, FFD_ERR_RANGE,
                               "the block's %lld elements exceed the section's element count "
                               "%lld",
                               count, n);
            if (r->binary && (unsigned long long)count > bytes_left(r) / (8 * (1 + t->nodes)))
                return fail_at(r, block_at, FFD_ERR_RANGE,
                               "element block of %lld elements is more than the %zu bytes "
                               "left can hold",
                               count, bytes_left(r));
            double physical = physical_of_entity(r, dim, tag);
            r->any_geometrical = true;
            r->any_physical = r->any_physical || r->have_entities || r->have_partitioned;
            for (long long e = 0; e < count; e++) {
                long long number;
                const char *rec = (skip_space(r), r->p);
                if ((s = read_num(r, true, "an element tag", &number)))
                    return s;
                for (unsigned k = 0; k < t->nodes; k++)
                    if ((s = read_num(r, true, "a node tag of the element", &nodes[k])))
                        return s;
                if ((s = push_element(r, rec, t, nodes, physical, (double)tag)))
                    return s;
            }
            total += count;
        }
        if (total != n)
            return fail_at(r, section_at, FFD_ERR_PARSE,
                           "the element blocks hold %lld elements, the header says %lld", total,
                           n);
    }
    return expect_end(r, "Elements");
}

/* A section kept as bytes: skip to its "$End<name>" line. */
static ffd_status skip_section(reader *r, const char *name, size_t len, const char *at)
{
    char end[72];
    if (len > 64)
        return fail_at(r, at, FFD_ERR_PARSE, "section name too long");
    memcpy(end, "$End", 4);
    memcpy(end + 4, name, len);
    size_t n = 4 + len;
    for (const char *q = r->p; q + n <= r->end; q++) {
        q = memchr(q, '$', (size_t)(r->end - q));
        if (!q || q + n > r->end)
            break;
        if (memcmp(q, end, n) == 0 && (q == r->s || q[-1] == '\n') &&
            (q + n == r->end || ffd_is_space((unsigned char)q[n]))) {
            r->p = q + n;
            return FFD_OK;
        }
    }
    return fail_at(r, at, FFD_ERR_PARSE, "section $%.*s has no $End%.*s", (int)len, name,
                   (int)len, name);
}

static bool section_is(const char *name, size_t len, const char *what)
{
    return strlen(what) == len && memcmp(name, what, len) == 0;
}

static ffd_status read_sections(reader *r)
{
    ffd_status s;
    bool first = true;
    for (;;) {
        skip_ws(r);
        if (r->p >= r->end)
            break;
        const char *at = r->p;
        if (*r->p != '$')
            return fail_at(r, at, FFD_ERR_PARSE, "expected a section ($Name)");
        const char *name = r->p + 1, *e = name;
        while (e < r->end && !ffd_is_space((unsigned char)*e))
            e++;
        size_t len = (size_t)(e - name);
        /* past the name's line: binary data starts on the next */
        r->p = e;
        r->section_at = at;
        while (r->p < r->end && ffd_is_blank((unsigned char)*r->p))
            r->p++;
        if (r->p < r->end && *r->p == '\n')
            r->p++;
        if (first && !section_is(name, len, "MeshFormat"))
            return fail_at(r, at, FFD_ERR_PARSE, "expected $MeshFormat first");
        first = false;
        if (section_is(name, len, "MeshFormat"))
            s = r->major ? fail_at(r, at, FFD_ERR_PARSE, "a second $MeshFormat")
                         : read_mesh_format(r);
        else if (section_is(name, len, "Nodes"))
            s = read_nodes(r);
        else if (section_is(name, len, "Elements"))
            s = read_elements(r);
        else if (section_is(name, len, "Entities") && r->major == 4)
            s = r->have_entities ? fail_at(r, at, FFD_ERR_PARSE, "a second $Entities")
                                 : read_entities(r, false);
        else if (section_is(name, len, "PartitionedEntities") && r->major == 4)
            s = r->have_partitioned ? fail_at(r, at, FFD_ERR_PARSE, "a second $PartitionedEntities")
                                    : read_entities(r, true);
        else if (section_is(name, len, "PartitionedEntities"))
            s = fail_at(r, at, FFD_ERR_PARSE, "$PartitionedEntities in an MSH 2 file (MSH 4 "
                        "only; MSH 2 keeps partitions as element tags)");
        else if (section_is(name, len, "ParametricNodes"))
            s = fail_at(r, at, FFD_ERR_UNSUPPORTED,
                        "$ParametricNodes is not supported: their parametric coordinates "
                        "would not follow the deformation");
        else if (len >= 3 && memcmp(name, "End", 3) == 0)
            s = fail_at(r, at, FFD_ERR_PARSE, "$%.*s without its section", (int)len, name);
        else
            s = skip_section(r, name, len, at);
        if (s)
            return s;
    }
    if (first)
        return fail_at(r, r->p, FFD_ERR_PARSE, "expected $MeshFormat, found an empty file");
    if (!r->have_nodes)
        return fail_at(r, r->p, FFD_ERR_PARSE, "no $Nodes section");
    if (!r->have_elements)
        return fail_at(r, r->p, FFD_ERR_PARSE, "no $Elements section");
    return FFD_OK;
}

static ffd_status read_msh(ffd_mesh *m, const char *name, ffd_error *err)
{
    reader r = {.m = m, .name = name, .err = err};
    r.s = (const char *)m->src;
    r.end = r.s + m->src_size;
    r.p = r.s;
    ffd_status s = read_sections(&r);
    if (s == FFD_OK && r.any_physical &&
        !ffd_mesh_add_field(m, "gmsh:physical", FFD_FIELD_CELL, 1, FFD_SPAN_I32, r.physical,
                            m->cell_count))
        s = oom(&r);
    if (s == FFD_OK && r.any_geometrical &&
        !ffd_mesh_add_field(m, "gmsh:geometrical", FFD_FIELD_CELL, 1, FFD_SPAN_I32,
                            r.geometrical, m->cell_count))
        s = oom(&r);
    if (s == FFD_OK) {
        cell_where w = {name, r.s, r.cell_at, r.binary};
        s = ffd_mesh_finish_cells(m, name, locate_cell, &w, err);
    }
    if (s == FFD_OK) { /* the mesh keeps them (ffd_mesh_node_tags) */
        ffd_free(m->node_tags);
        m->node_tags = r.node_tags;
        r.node_tags = NULL;
    }
    ffd_free(r.node_tags);
    ffd_free(r.by_tag);
    ffd_free(r.entities);
    ffd_free(r.cell_at);
    ffd_free(r.physical);
    ffd_free(r.geometrical);
    return s;
}

/* ======================================================================
 * Writing from data: MSH 2.2
 * ====================================================================== */

/* The Gmsh type and node order of a cell to write, mapping the VTK types
 * Gmsh lacks (pixel, voxel, polygons of 3 or 4 nodes). */
static ffd_status gmsh_cell(const ffd_cells_view *v, size_t c, const gmsh_type **out,
                            uint32_t nodes[27], ffd_error *err)
{
    const uint32_t *ids = v->indices + v->offsets[c];
    size_t n = (size_t)(v->offsets[c + 1] - v->offsets[c]);
    unsigned vtk = v->types[c];
    static const uint8_t pixel[] = {0, 1, 3, 2}, voxel[] = {0, 1, 3, 2, 4, 5, 7, 6};
    const uint8_t *order = NULL;
    if (vtk == FFD_CELL_PIXEL)
        vtk = FFD_CELL_QUAD, order = pixel;
    else if (vtk == FFD_CELL_VOXEL)
        vtk = FFD_CELL_HEXAHEDRON, order = voxel;
    else if (vtk == FFD_CELL_POLYGON && (n == 3 || n == 4))
        vtk = n == 3 ? FFD_CELL_TRIANGLE : FFD_CELL_QUAD;
    const gmsh_type *t = gmsh_type_of_vtk(vtk);
    if (!t || t->nodes != n) {
        const char *name = ffd_cell_type_name(v->types[c]);
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "MSH: cell %zu (%s, %zu nodes) has no Gmsh element type", c,
                        name ? name : "unknown", n);
    }
    /* VTK node i is Gmsh node to_vtk[i] */
    for (size_t k = 0; k < n; k++) {
        uint32_t id = ids[order ? order[k] : k];
        nodes[t->to_vtk ? t->to_vtk[k] : k] = id;
    }
    *out = t;
    return FFD_OK;
}

/* The values of an integer cell field named name with one component, or NULL. */
static const double *tag_field(const ffd_mesh *m, const char *name)
{
    for (size_t i = 0; i < m->field_count; i++)
        if (m->fields[i].association == FFD_FIELD_CELL && m->fields[i].components == 1 &&
            strcmp(m->fields[i].name, name) == 0)
            return m->fields[i].values;
    return NULL;
}

static void put_i32(ffd_buf *b, long long v)
{
    unsigned char q[4];
    ffd_write_scalar(q, FFD_SPAN_I32, false, (double)v);
    ffd_buf_put(b, q, 4);
}

static ffd_status write_msh(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    bool binary = enc == FFD_ENCODING_BINARY_LE;
    size_t nv = m->vertex_count;
    if (nv >= INT32_MAX)
        return ffd_fail(err, FFD_ERR_RANGE, "MSH: %zu nodes do not fit MSH 2.2's int tags", nv);
    ffd_cells_view v;
    ffd_status s = ffd_cells_view_of(m, &v, err);
    if (s)
        return s;
    if (v.count >= INT32_MAX) {
        ffd_cells_view_free(&v);
        return ffd_fail(err, FFD_ERR_RANGE, "MSH: %zu cells do not fit MSH 2.2's int tags",
                        v.count);
    }
    /* the tags only when the mesh has them (else none: 0 tags per element) */
    const double *physical = m->cell_count ? tag_field(m, "gmsh:physical") : NULL;
    const double *geometrical = m->cell_count ? tag_field(m, "gmsh:geometrical") : NULL;
    int ntags = physical || geometrical ? 2 : 0;

    ffd_buf_puts(b, binary ? "$MeshFormat\n2.2 1 8\n" : "$MeshFormat\n2.2 0 8\n");
    if (binary) {
        put_i32(b, 1);
        ffd_buf_puts(b, "\n");
    }
    ffd_buf_puts(b, "$EndMeshFormat\n$Nodes\n");
    ffd_buf_uint(b, nv);
    ffd_buf_puts(b, "\n");
    for (size_t i = 0; i < nv; i++) {
        const double *p = m->positions + 3 * i;
        if (binary) {
            unsigned char q[28];
            ffd_write_scalar(q, FFD_SPAN_I32, false, (double)(i + 1));
            for (int k = 0; k < 3; k++)
                ffd_write_scalar(q + 4 + 8 * k, FFD_SPAN_F64, false, p[k]);
            ffd_buf_put(b, q, sizeof q);
        } else {
            ffd_buf_uint(b, i + 1);
            ffd_buf_xyz(b, p);
            ffd_buf_puts(b, "\n");
        }
    }
    ffd_buf_puts(b, binary ? "\n$EndNodes\n$Elements\n" : "$EndNodes\n$Elements\n");
    ffd_buf_uint(b, v.count);
    ffd_buf_puts(b, "\n");
    uint32_t nodes[27];
    for (size_t c = 0; c < v.count && s == FFD_OK;) {
        const gmsh_type *t = NULL;
        if ((s = gmsh_cell(&v, c, &t, nodes, err)))
            break;
        /* binary: a block of the cells of one type that follow */
        size_t run = 1;
        if (binary) {
            const gmsh_type *u;
            uint32_t scratch[27];
            while (c + run < v.count && gmsh_cell(&v, c + run, &u, scratch, NULL) == FFD_OK &&
                   u == t)
                run++;
            put_i32(b, t->gmsh);
            put_i32(b, (long long)run);
            put_i32(b, ntags);
        }
        for (size_t e = c; e < c + run; e++) {
            if (e > c && (s = gmsh_cell(&v, e, &t, nodes, err)))
                break;
            long long tags[2] = {physical ? (long long)physical[e] : 0,
                                 geometrical ? (long long)geometrical[e] : 0};
            if (binary) {
                put_i32(b, (long long)e + 1);
                for (int k = 0; k < ntags; k++)
                    put_i32(b, tags[k]);
                for (unsigned k = 0; k < t->nodes; k++)
                    put_i32(b, (long long)nodes[k] + 1);
            } else {
                ffd_buf_printf(b, "%zu %d %d", e + 1, t->gmsh, ntags);
                for (int k = 0; k < ntags; k++)
                    ffd_buf_printf(b, " %lld", tags[k]);
                for (unsigned k = 0; k < t->nodes; k++) {
                    ffd_buf_puts(b, " ");
                    ffd_buf_uint(b, (uint64_t)nodes[k] + 1);
                }
                ffd_buf_puts(b, "\n");
            }
        }
        c += run;
    }
    ffd_cells_view_free(&v);
    if (s)
        return s;
    ffd_buf_puts(b, binary ? "\n$EndElements\n" : "$EndElements\n");
    return FFD_OK;
}

static const char *const msh_extensions[] = {"msh", NULL};

const ffd_mesh_codec ffd_mesh_codec_msh = {
    .format = FFD_FORMAT_MSH,
    .name = "MSH",
    .extensions = msh_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII) | FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_LE),
    .read = read_msh,
    .patch = ffd_mesh_patch_spans,
    .write = write_msh,
};
