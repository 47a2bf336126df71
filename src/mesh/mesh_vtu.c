/* mesh_vtu.c — VTK XML unstructured grid (.vtu), the VTK file formats
 * document ("VTK XML File Formats", kitware.com/vtk file-formats), read and
 * written losslessly: nodes, cells (VTK types and order, no mapping), point
 * and cell data as fields.
 *
 * Why hand-written: the lossless write needs the byte offset of every
 * coordinate (ascii: the number's text; raw appended: the scalar's bytes) and
 * the extent of every encoded array (base64, zlib blocks), which no XML or
 * VTK library reports. The XML is read by a small, strict scanner for the
 * subset VTK writes: a prolog, comments, elements and attributes with the
 * five predefined entities in attribute values; CDATA, DOCTYPE and entities
 * in text are refused. The appended data is not XML: it is located from its
 * '_' marker, and </AppendedData> is searched from the end of the file.
 *
 * Docs: docs/volume.md ("VTU"). */
#include "mesh_cells.h"
#include "mesh_codec.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#ifdef FFD_HAVE_ZLIB
#include <zlib.h>
#endif

/* deflate cannot expand data by more than 1032:1 (zlib technical details),
 * so a compressed array claiming more is refused before allocating. */
#define DEFLATE_MAX_RATIO 1032u
/* Uncompressed bytes per zlib block when writing (VTK's default). */
#define VTU_BLOCK_SIZE 32768u

/* ======================================================================
 * The source as read: what the lossless write needs
 * ====================================================================== */

enum { FMT_ASCII, FMT_BINARY, FMT_APPENDED };
enum { SEC_OTHER, SEC_POINTS, SEC_CELLS, SEC_POINTDATA, SEC_CELLDATA };
#define KIND_BAD (-1)

typedef struct vtu_array {
    size_t tag;            /* byte offset of "<DataArray" */
    const char *name_b, *name_e; /* Name attribute value (raw) */
    const char *type_b, *type_e;
    int kind;              /* FFD_SPAN_I8..F64, FFD_FIELD_I64/U64, KIND_BAD */
    uint32_t components;
    int format;            /* FMT_* */
    uint64_t offset;       /* appended: offset from the byte after '_' */
    size_t offset_b, offset_e; /* the offset attribute's value bytes (appended) */
    size_t cb, ce;         /* inline content (text between the tags) */
    int section;
    /* filled when decoded */
    size_t enc_b, enc_e;   /* the encoded bytes in src (base64 text or raw header + data) */
    bool separate;         /* base64: header encoded apart from the data */
    uint64_t block_size;   /* compressed: the file's block size */
} vtu_array;

typedef struct vtu_state {
    bool big_endian, header64, compressed;
    int points_format;       /* FMT_* of the Points array */
    int points_kind;         /* FFD_SPAN_F32 / F64 */
    vtu_array points;        /* its record (enc_b/enc_e, separate, block size) */
    bool appended_base64;
    size_t appended_start;   /* byte after '_' */
    size_t appended_end;     /* the '<' of </AppendedData> */
    size_t noffsets;         /* appended arrays: their offsets and attribute ranges */
    uint64_t *offsets;
    size_t *offset_b, *offset_e;
    double *orig;            /* the positions as read (3 per node) */
} vtu_state;

static void state_free(void *p)
{
    vtu_state *s = p;
    if (!s)
        return;
    ffd_free(s->offsets);
    ffd_free(s->offset_b);
    ffd_free(s->offset_e);
    ffd_free(s->orig);
    ffd_free(s);
}

/* ======================================================================
 * Reading context and messages
 * ====================================================================== */

typedef struct reader {
    ffd_mesh *m;
    const char *name;
    const char *s, *e; /* the source */
    ffd_error *err;
    vtu_state *st;
    vtu_array *arrays;
    size_t narrays, cap;
} reader;

static size_t line_of(const reader *r, size_t off)
{
    size_t line = 1;
    for (const char *p = r->s; p < r->s + off && p < r->e; p++)
        line += *p == '\n';
    return line;
}

#define FAIL_AT(r, off, status, ...) fail_at(r, off, status, __VA_ARGS__)
static ffd_status fail_at(const reader *r, size_t off, ffd_status status, const char *fmt, ...)
    FFD_PRINTF(4, 5);
static ffd_status fail_at(const reader *r, size_t off, ffd_status status, const char *fmt, ...)
{
    char msg[200];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return ffd_fail(r->err, status, "%s:%zu: %s", r->name, line_of(r, off), msg);
}

/* Appended and decoded bytes have no lines: byte offsets. */
static ffd_status fail_byte(const reader *r, size_t off, ffd_status status, const char *fmt, ...)
    FFD_PRINTF(4, 5);
static ffd_status fail_byte(const reader *r, size_t off, ffd_status status, const char *fmt, ...)
{
    char msg[200];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return ffd_fail(r->err, status, "%s: byte %zu: %s", r->name, off, msg);
}

static bool range_is(const char *b, const char *e, const char *lit)
{
    size_t n = strlen(lit);
    return b && (size_t)(e - b) == n && memcmp(b, lit, n) == 0;
}

/* ======================================================================
 * Scalar types
 * ====================================================================== */

static const struct {
    const char *name;
    int kind;
} type_names[] = {
    {"Int8", FFD_SPAN_I8},     {"UInt8", FFD_SPAN_U8},     {"Int16", FFD_SPAN_I16},
    {"UInt16", FFD_SPAN_U16},  {"Int32", FFD_SPAN_I32},    {"UInt32", FFD_SPAN_U32},
    {"Float32", FFD_SPAN_F32}, {"Float64", FFD_SPAN_F64},  {"Int64", FFD_FIELD_I64},
    {"UInt64", FFD_FIELD_U64},
};

static int kind_of_type(const char *b, const char *e)
{
    for (size_t i = 0; i < sizeof type_names / sizeof type_names[0]; i++)
        if (range_is(b, e, type_names[i].name))
            return type_names[i].kind;
    return KIND_BAD;
}

static const char *type_name_of(int kind)
{
    for (size_t i = 0; i < sizeof type_names / sizeof type_names[0]; i++)
        if (type_names[i].kind == kind)
            return type_names[i].name;
    return "Float64";
}

static size_t kind_size(int kind)
{
    return kind == FFD_FIELD_I64 || kind == FFD_FIELD_U64 ? 8 : ffd_span_kind_size(kind);
}

static uint64_t load_u64(const unsigned char *p, size_t n, bool be)
{
    uint64_t v = 0;
    for (size_t i = 0; i < n; i++)
        v |= (uint64_t)p[be ? n - 1 - i : i] << (8 * i);
    return v;
}

static void store_u64(unsigned char *p, size_t n, bool be, uint64_t v)
{
    for (size_t i = 0; i < n; i++)
        p[be ? n - 1 - i : i] = (unsigned char)(v >> (8 * i));
}

static double read_value(const unsigned char *p, int kind, bool be)
{
    if (kind == FFD_FIELD_I64)
        return (double)(int64_t)load_u64(p, 8, be);
    if (kind == FFD_FIELD_U64)
        return (double)load_u64(p, 8, be);
    return ffd_read_scalar(p, kind, be);
}

static void write_value(unsigned char *p, int kind, bool be, double v)
{
    if (kind == FFD_FIELD_I64)
        store_u64(p, 8, be, (uint64_t)(int64_t)llround(v));
    else if (kind == FFD_FIELD_U64)
        store_u64(p, 8, be, v <= 0 ? 0 : (uint64_t)llround(v));
    else
        ffd_write_scalar(p, kind, be, v);
}

/* ======================================================================
 * base64 (RFC 4648). VTK encodes an array's header and data either as one
 * stream or as two, each padded: decoding group by group, with '=' ending
 * only its own group, reads both the same way.
 * ====================================================================== */

static int b64_value(unsigned char c)
{
    if (c >= 'A' && c <= 'Z')
        return c - 'A';
    if (c >= 'a' && c <= 'z')
        return c - 'a' + 26;
    if (c >= '0' && c <= '9')
        return c - '0' + 52;
    if (c == '+')
        return 62;
    if (c == '/')
        return 63;
    return -1;
}

/* Decodes [b, e) (blanks skipped) into out (room for 3/4 of the length);
 * returns the byte count, or SIZE_MAX with *bad the offending position. */
static size_t b64_decode(const char *b, const char *e, unsigned char *out, const char **bad)
{
    size_t n = 0;
    int q[4], k = 0;
    for (const char *p = b; p < e; p++) {
        unsigned char c = (unsigned char)*p;
        if (ffd_is_space(c))
            continue;
        if (c == '=') {
            if (k < 2) {
                *bad = p;
                return SIZE_MAX;
            }
            int pad = 4 - k;
            for (int j = 1; j < pad; j++) { /* the rest of the group's padding */
                const char *t = p + j;
                if (t >= e || *t != '=') {
                    *bad = p;
                    return SIZE_MAX;
                }
            }
            p += pad - 1;
            out[n++] = (unsigned char)(q[0] << 2 | q[1] >> 4);
            if (k == 3)
                out[n++] = (unsigned char)((q[1] & 15) << 4 | q[2] >> 2);
            k = 0;
            continue;
        }
        int v = b64_value(c);
        if (v < 0) {
            *bad = p;
            return SIZE_MAX;
        }
        q[k++] = v;
        if (k == 4) {
            out[n++] = (unsigned char)(q[0] << 2 | q[1] >> 4);
            out[n++] = (unsigned char)((q[1] & 15) << 4 | q[2] >> 2);
            out[n++] = (unsigned char)((q[2] & 3) << 6 | q[3]);
            k = 0;
        }
    }
    if (k) {
        *bad = e;
        return SIZE_MAX;
    }
    return n;
}

static void b64_encode(ffd_buf *b, const unsigned char *p, size_t n)
{
    static const char abc[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char g[4];
    for (size_t i = 0; i < n; i += 3) {
        unsigned v = (unsigned)p[i] << 16 | (i + 1 < n ? (unsigned)p[i + 1] << 8 : 0) |
                     (i + 2 < n ? p[i + 2] : 0);
        g[0] = abc[v >> 18];
        g[1] = abc[v >> 12 & 63];
        g[2] = i + 1 < n ? abc[v >> 6 & 63] : '=';
        g[3] = i + 2 < n ? abc[v & 63] : '=';
        ffd_buf_put(b, g, 4);
    }
}

static size_t b64_chars(size_t bytes)
{
    return (bytes + 2) / 3 * 4;
}

/* ======================================================================
 * The XML scanner
 * ====================================================================== */

typedef struct attr {
    const char *name_b, *name_e, *val_b, *val_e;
} attr;

#define MAX_ATTRS 16
typedef struct tag {
    size_t at;                 /* '<' */
    const char *name_b, *name_e;
    attr attrs[MAX_ATTRS];
    int nattrs;
    bool closing, empty;
    const char *end;           /* after '>' */
} tag;

static bool is_name_char(unsigned char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
           c == '_' || c == ':' || c == '.' || c == '-';
}

static const char *skip_ws(const char *p, const char *e)
{
    while (p < e && ffd_is_space((unsigned char)*p))
        p++;
    return p;
}

static const attr *find_attr(const tag *t, const char *name)
{
    for (int i = 0; i < t->nattrs; i++)
        if (range_is(t->attrs[i].name_b, t->attrs[i].name_e, name))
            return &t->attrs[i];
    return NULL;
}

/* Parses the tag at p ('<'); '&' in values must be a predefined entity. */
static ffd_status parse_tag(reader *r, const char *p, tag *t)
{
    memset(t, 0, sizeof *t);
    t->at = (size_t)(p - r->s);
    const char *e = r->e;
    p++;
    if (p < e && *p == '/') {
        t->closing = true;
        p++;
    }
    t->name_b = p;
    while (p < e && is_name_char((unsigned char)*p))
        p++;
    t->name_e = p;
    if (t->name_b == t->name_e)
        return FAIL_AT(r, t->at, FFD_ERR_PARSE, "expected an element name after '<'");
    for (;;) {
        const char *q = skip_ws(p, e);
        if (q >= e)
            return FAIL_AT(r, t->at, FFD_ERR_PARSE, "unterminated tag <%.*s",
                           (int)(t->name_e - t->name_b), t->name_b);
        if (*q == '>') {
            t->end = q + 1;
            return FFD_OK;
        }
        if (*q == '/' && !t->closing && q + 1 < e && q[1] == '>') {
            t->empty = true;
            t->end = q + 2;
            return FFD_OK;
        }
        if (t->closing || q == p)
            return FAIL_AT(r, (size_t)(q - r->s), FFD_ERR_PARSE,
                           "expected '>' or an attribute in <%.*s>", (int)(t->name_e - t->name_b),
                           t->name_b);
        if (t->nattrs == MAX_ATTRS)
            return FAIL_AT(r, (size_t)(q - r->s), FFD_ERR_UNSUPPORTED,
                           "more than %d attributes in <%.*s>", MAX_ATTRS,
                           (int)(t->name_e - t->name_b), t->name_b);
        attr *a = &t->attrs[t->nattrs++];
        a->name_b = q;
        while (q < e && is_name_char((unsigned char)*q))
            q++;
        a->name_e = q;
        q = skip_ws(q, e);
        if (a->name_b == a->name_e || q >= e || *q != '=')
            return FAIL_AT(r, (size_t)(q - r->s), FFD_ERR_PARSE,
                           "expected name=\"value\" in <%.*s>", (int)(t->name_e - t->name_b),
                           t->name_b);
        q = skip_ws(q + 1, e);
        if (q >= e || (*q != '"' && *q != '\''))
            return FAIL_AT(r, (size_t)(q - r->s), FFD_ERR_PARSE, "expected a quoted value for %.*s",
                           (int)(a->name_e - a->name_b), a->name_b);
        char quote = *q++;
        a->val_b = q;
        while (q < e && *q != quote) {
            if (*q == '<')
                return FAIL_AT(r, (size_t)(q - r->s), FFD_ERR_PARSE, "'<' in the value of %.*s",
                               (int)(a->name_e - a->name_b), a->name_b);
            q++;
        }
        if (q >= e)
            return FAIL_AT(r, (size_t)(a->val_b - r->s), FFD_ERR_PARSE,
                           "unterminated value of %.*s", (int)(a->name_e - a->name_b), a->name_b);
        a->val_e = q;
        p = q + 1;
    }
}

/* An attribute value with the predefined entities replaced, into buf. */
static ffd_status attr_text(reader *r, const char *b, const char *e, char *buf, size_t size)
{
    static const struct {
        const char *ent;
        char c;
    } ents[] = {{"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
    size_t n = 0;
    for (const char *p = b; p < e;) {
        if (n + 1 >= size)
            return FAIL_AT(r, (size_t)(b - r->s), FFD_ERR_UNSUPPORTED,
                           "attribute value longer than %zu bytes", size - 1);
        if (*p != '&') {
            buf[n++] = *p++;
            continue;
        }
        size_t i = 0;
        for (; i < sizeof ents / sizeof ents[0]; i++) {
            size_t len = strlen(ents[i].ent);
            if ((size_t)(e - p) >= len && memcmp(p, ents[i].ent, len) == 0) {
                buf[n++] = ents[i].c;
                p += len;
                break;
            }
        }
        if (i == sizeof ents / sizeof ents[0])
            return FAIL_AT(r, (size_t)(p - r->s), FFD_ERR_UNSUPPORTED,
                           "entity reference other than &amp; &lt; &gt; &quot; &apos;");
    }
    buf[n] = '\0';
    return FFD_OK;
}

static ffd_status attr_u64(reader *r, const tag *t, const char *name, bool required,
                           uint64_t dflt, uint64_t *out)
{
    const attr *a = find_attr(t, name);
    *out = dflt;
    if (!a) {
        if (required)
            return FAIL_AT(r, t->at, FFD_ERR_PARSE, "<%.*s> has no %s attribute",
                           (int)(t->name_e - t->name_b), t->name_b, name);
        return FFD_OK;
    }
    const char *p = skip_ws(a->val_b, a->val_e);
    uint64_t v = 0;
    if (p == a->val_e)
        goto bad;
    for (; p < a->val_e && *p >= '0' && *p <= '9'; p++) {
        if (v > (UINT64_MAX - 9) / 10)
            return FAIL_AT(r, (size_t)(a->val_b - r->s), FFD_ERR_RANGE, "%s %.*s is too large",
                           name, (int)(a->val_e - a->val_b), a->val_b);
        v = v * 10 + (uint64_t)(*p - '0');
    }
    if (skip_ws(p, a->val_e) != a->val_e)
        goto bad;
    *out = v;
    return FFD_OK;
bad:
    return FAIL_AT(r, (size_t)(a->val_b - r->s), FFD_ERR_PARSE,
                   "%s=\"%.*s\": expected a non-negative integer", name,
                   (int)(a->val_e - a->val_b), a->val_b);
}

/* ======================================================================
 * Structure: the elements, their DataArrays
 * ====================================================================== */

typedef struct piece_info {
    uint64_t points, cells;
    size_t at;
} piece_info;

static ffd_status read_root(reader *r, const tag *t)
{
    vtu_state *st = r->st;
    const attr *a = find_attr(t, "type");
    if (!a || !range_is(a->val_b, a->val_e, "UnstructuredGrid"))
        return FAIL_AT(r, t->at, FFD_ERR_UNSUPPORTED,
                       "VTKFile type \"%.*s\": only UnstructuredGrid is read (.vtu)",
                       a ? (int)(a->val_e - a->val_b) : 0, a ? a->val_b : "");
    a = find_attr(t, "byte_order");
    if (a && range_is(a->val_b, a->val_e, "BigEndian"))
        st->big_endian = true;
    else if (a && !range_is(a->val_b, a->val_e, "LittleEndian"))
        return FAIL_AT(r, t->at, FFD_ERR_PARSE,
                       "byte_order \"%.*s\": expected LittleEndian or BigEndian",
                       (int)(a->val_e - a->val_b), a->val_b);
    a = find_attr(t, "header_type");
    if (a && range_is(a->val_b, a->val_e, "UInt64"))
        st->header64 = true;
    else if (a && !range_is(a->val_b, a->val_e, "UInt32"))
        return FAIL_AT(r, t->at, FFD_ERR_UNSUPPORTED,
                       "header_type \"%.*s\": expected UInt32 or UInt64",
                       (int)(a->val_e - a->val_b), a->val_b);
    a = find_attr(t, "compressor");
    if (a) {
        if (!range_is(a->val_b, a->val_e, "vtkZLibDataCompressor"))
            return FAIL_AT(r, t->at, FFD_ERR_UNSUPPORTED,
                           "compressor \"%.*s\": only vtkZLibDataCompressor (zlib) is read",
                           (int)(a->val_e - a->val_b), a->val_b);
#ifndef FFD_HAVE_ZLIB
        return FAIL_AT(r, t->at, FFD_ERR_UNSUPPORTED,
                       "compressor vtkZLibDataCompressor: this ffdkit was built without zlib");
#endif
        st->compressed = true;
    }
    return FFD_OK;
}

static ffd_status read_data_array_tag(reader *r, const tag *t, int section)
{
    if (r->narrays == r->cap &&
        !ffd_grow((void **)&r->arrays, &r->cap, r->narrays + 1, sizeof(vtu_array)))
        return ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory", r->name);
    vtu_array *a = &r->arrays[r->narrays++];
    memset(a, 0, sizeof *a);
    a->tag = t->at;
    a->section = section;
    const attr *x = find_attr(t, "Name");
    if (x) {
        a->name_b = x->val_b;
        a->name_e = x->val_e;
    }
    x = find_attr(t, "type");
    if (!x)
        return FAIL_AT(r, t->at, FFD_ERR_PARSE, "<DataArray> has no type attribute");
    a->type_b = x->val_b;
    a->type_e = x->val_e;
    a->kind = kind_of_type(x->val_b, x->val_e);
    uint64_t comps;
    ffd_status s = attr_u64(r, t, "NumberOfComponents", false, 1, &comps);
    if (s)
        return s;
    if (comps == 0 || comps > 1024)
        return FAIL_AT(r, t->at, FFD_ERR_RANGE, "NumberOfComponents %llu: expected 1 to 1024",
                       (unsigned long long)comps);
    a->components = (uint32_t)comps;
    x = find_attr(t, "format");
    if (!x)
        return FAIL_AT(r, t->at, FFD_ERR_PARSE, "<DataArray> has no format attribute");
    if (range_is(x->val_b, x->val_e, "ascii"))
        a->format = FMT_ASCII;
    else if (range_is(x->val_b, x->val_e, "binary"))
        a->format = FMT_BINARY;
    else if (range_is(x->val_b, x->val_e, "appended"))
        a->format = FMT_APPENDED;
    else
        return FAIL_AT(r, t->at, FFD_ERR_PARSE,
                       "format \"%.*s\": expected ascii, binary or appended",
                       (int)(x->val_e - x->val_b), x->val_b);
    if (a->format == FMT_APPENDED) {
        if ((s = attr_u64(r, t, "offset", true, 0, &a->offset)))
            return s;
        x = find_attr(t, "offset");
        a->offset_b = (size_t)(x->val_b - r->s);
        a->offset_e = (size_t)(x->val_e - r->s);
    }
    return FFD_OK;
}

/* Walks the XML; fills r->arrays, the piece and the appended data range. */
static ffd_status scan(reader *r, piece_info *piece)
{
    enum { MAX_DEPTH = 32 };
    tag stack[MAX_DEPTH];
    int depth = 0;
    int pieces = 0;
    bool root_seen = false;
    const char *p = r->s, *e = r->e;
    if (e - p >= 3 && memcmp(p, "\xEF\xBB\xBF", 3) == 0)
        p += 3;
    vtu_array *open_array = NULL; /* a DataArray whose content is being read */
    for (;;) {
        const char *text = p;
        while (p < e && *p != '<')
            p++;
        /* text between tags: an open DataArray's content, else blanks only */
        if (open_array && open_array->ce == 0) {
            open_array->cb = (size_t)(text - r->s);
            open_array->ce = (size_t)(p - r->s);
        } else {
            const char *q = skip_ws(text, p);
            if (q < p)
                return FAIL_AT(r, (size_t)(q - r->s), FFD_ERR_PARSE,
                               "unexpected text '%.*s' outside a DataArray",
                               (int)(p - q > 20 ? 20 : p - q), q);
        }
        if (p >= e)
            break;
        size_t at = (size_t)(p - r->s);
        if (e - p >= 4 && memcmp(p, "<!--", 4) == 0) {
            const char *q = strstr(p + 4, "-->");
            if (!q || q >= e)
                return FAIL_AT(r, at, FFD_ERR_PARSE, "unterminated comment");
            p = q + 3;
            continue;
        }
        if (e - p >= 2 && p[1] == '?') {
            const char *q = strstr(p + 2, "?>");
            if (root_seen || !q || q >= e)
                return FAIL_AT(r, at, FFD_ERR_PARSE, "expected the <?xml ...?> prolog before <VTKFile>");
            p = q + 2;
            continue;
        }
        if (e - p >= 2 && p[1] == '!')
            return FAIL_AT(r, at, FFD_ERR_UNSUPPORTED,
                           "%.9s: CDATA sections and DOCTYPE declarations are not read", p);
        tag t;
        ffd_status s = parse_tag(r, p, &t);
        if (s)
            return s;
        p = t.end;
        if (t.closing) {
            if (depth == 0 || (size_t)(t.name_e - t.name_b) !=
                                  (size_t)(stack[depth - 1].name_e - stack[depth - 1].name_b) ||
                memcmp(t.name_b, stack[depth - 1].name_b, (size_t)(t.name_e - t.name_b)) != 0)
                return FAIL_AT(r, at, FFD_ERR_PARSE, "</%.*s> does not close the open element",
                               (int)(t.name_e - t.name_b), t.name_b);
            depth--;
            open_array = NULL;
            if (depth == 0) {
                const char *q = skip_ws(p, e);
                while (q < e && e - q >= 4 && memcmp(q, "<!--", 4) == 0) {
                    const char *c = strstr(q + 4, "-->");
                    if (!c || c >= e)
                        return FAIL_AT(r, (size_t)(q - r->s), FFD_ERR_PARSE, "unterminated comment");
                    q = skip_ws(c + 3, e);
                }
                if (q < e)
                    return FAIL_AT(r, (size_t)(q - r->s), FFD_ERR_PARSE,
                                   "unexpected bytes after </VTKFile>");
                return pieces ? FFD_OK
                              : FAIL_AT(r, at, FFD_ERR_PARSE, "no <Piece> in the UnstructuredGrid");
            }
            continue;
        }
        if (open_array) {
            /* a child of a DataArray (VTK 9's InformationKey): its text ends here */
            open_array = NULL;
        }
        if (depth == 0) {
            if (root_seen || !range_is(t.name_b, t.name_e, "VTKFile"))
                return FAIL_AT(r, at, FFD_ERR_PARSE, "expected <VTKFile>, found <%.*s>",
                               (int)(t.name_e - t.name_b), t.name_b);
            root_seen = true;
            if ((s = read_root(r, &t)))
                return s;
        } else {
            const char *parent_b = stack[depth - 1].name_b, *parent_e = stack[depth - 1].name_e;
            if (range_is(t.name_b, t.name_e, "PolyData") ||
                range_is(t.name_b, t.name_e, "StructuredGrid") ||
                range_is(t.name_b, t.name_e, "ImageData"))
                return FAIL_AT(r, at, FFD_ERR_UNSUPPORTED, "<%.*s>: only UnstructuredGrid is read",
                               (int)(t.name_e - t.name_b), t.name_b);
            if (range_is(t.name_b, t.name_e, "Piece")) {
                if (++pieces > 1)
                    return FAIL_AT(r, at, FFD_ERR_UNSUPPORTED,
                                   "a second <Piece>: files of several pieces are not read "
                                   "(merge them into one piece first)");
                piece->at = at;
                if ((s = attr_u64(r, &t, "NumberOfPoints", true, 0, &piece->points)) ||
                    (s = attr_u64(r, &t, "NumberOfCells", true, 0, &piece->cells)))
                    return s;
            } else if (range_is(t.name_b, t.name_e, "DataArray")) {
                int section = range_is(parent_b, parent_e, "Points")      ? SEC_POINTS
                              : range_is(parent_b, parent_e, "Cells")     ? SEC_CELLS
                              : range_is(parent_b, parent_e, "PointData") ? SEC_POINTDATA
                              : range_is(parent_b, parent_e, "CellData")  ? SEC_CELLDATA
                                                                          : SEC_OTHER;
                if ((s = read_data_array_tag(r, &t, section)))
                    return s;
                if (!t.empty)
                    open_array = &r->arrays[r->narrays - 1];
            } else if (range_is(t.name_b, t.name_e, "AppendedData")) {
                const attr *a = find_attr(&t, "encoding");
                if (a && range_is(a->val_b, a->val_e, "base64"))
                    r->st->appended_base64 = true;
                else if (!a || !range_is(a->val_b, a->val_e, "raw"))
                    return FAIL_AT(r, at, FFD_ERR_PARSE,
                                   "<AppendedData> encoding: expected \"raw\" or \"base64\"");
                if (t.empty)
                    return FAIL_AT(r, at, FFD_ERR_PARSE, "empty <AppendedData/>");
                const char *q = skip_ws(p, e);
                if (q >= e || *q != '_')
                    return FAIL_AT(r, (size_t)(q - r->s), FFD_ERR_PARSE,
                                   "expected '_' at the start of the appended data");
                r->st->appended_start = (size_t)(q + 1 - r->s);
                /* the raw bytes may hold anything: the closing tag is the last one */
                const char *close = NULL;
                static const char endtag[] = "</AppendedData>";
                for (const char *c = e - (sizeof endtag - 1); c > q; c--)
                    if (memcmp(c, endtag, sizeof endtag - 1) == 0) {
                        close = c;
                        break;
                    }
                if (!close)
                    return FAIL_AT(r, at, FFD_ERR_PARSE, "no </AppendedData> after the appended data");
                r->st->appended_end = (size_t)(close - r->s);
                p = close + sizeof endtag - 1;
                continue; /* the element is closed */
            }
        }
        if (!t.empty) {
            if (depth == MAX_DEPTH)
                return FAIL_AT(r, at, FFD_ERR_UNSUPPORTED, "elements nested deeper than %d",
                               MAX_DEPTH);
            stack[depth++] = t;
        }
    }
    return FAIL_AT(r, (size_t)(e - r->s), FFD_ERR_PARSE,
                   root_seen ? "unexpected end of file: expected </VTKFile>"
                             : "expected <VTKFile type=\"UnstructuredGrid\">");
}

/* ======================================================================
 * Decoding a DataArray
 * ====================================================================== */

static void array_label(const vtu_array *a, char *buf, size_t size)
{
    if (a->name_b)
        snprintf(buf, size, "DataArray \"%.*s\"", (int)(a->name_e - a->name_b > 60 ? 60 : a->name_e - a->name_b),
                 a->name_b);
    else
        snprintf(buf, size, "DataArray");
}

/* Upper bound of the values an array's bytes can hold, to refuse a count
 * before allocating for it. */
static uint64_t max_values(const reader *r, const vtu_array *a)
{
    size_t bytes;
    uint64_t size = a->kind == KIND_BAD ? 1 : kind_size(a->kind);
    if (a->format == FMT_ASCII)
        return (a->ce - a->cb + 1) / 2 + 1; /* a digit and a separator each */
    if (a->format == FMT_BINARY)
        bytes = (a->ce - a->cb) / 4 * 3;
    else {
        size_t start = r->st->appended_start + (size_t)a->offset;
        bytes = a->offset > r->st->appended_end - r->st->appended_start ? 0 : r->st->appended_end - start;
        if (r->st->appended_base64)
            bytes = bytes / 4 * 3;
    }
    uint64_t b = bytes;
    if (r->st->compressed)
        b = b > UINT64_MAX / DEFLATE_MAX_RATIO ? UINT64_MAX : b * DEFLATE_MAX_RATIO;
    return b / size + 1;
}

static ffd_status check_count(const reader *r, const vtu_array *a, const char *what,
                              uint64_t count)
{
    char label[96];
    array_label(a, label, sizeof label);
    if (a->format == FMT_APPENDED && !r->st->appended_start)
        return FAIL_AT(r, a->tag, FFD_ERR_PARSE, "%s is appended but the file has no <AppendedData>",
                       label);
    uint64_t mv = max_values(r, a);
    if (count > UINT64_MAX / a->components || count * a->components > mv)
        return FAIL_AT(r, a->tag, FFD_ERR_PARSE,
                       "%s %llu needs more values than the %zu bytes of %s can hold", what,
                       (unsigned long long)count,
                       a->format == FMT_APPENDED ? r->st->appended_end - r->st->appended_start
                                                 : a->ce - a->cb,
                       label);
    return FFD_OK;
}

/* The binary payload (header + data) of a non-ascii array: decoded base64,
 * or the raw appended bytes in src. *owned is set when it was allocated. */
static ffd_status payload_of(reader *r, vtu_array *a, const unsigned char **out, size_t *size,
                             unsigned char **owned, size_t *base)
{
    vtu_state *st = r->st;
    size_t hsize = st->header64 ? 8 : 4;
    char label[96];
    array_label(a, label, sizeof label);
    *owned = NULL;
    if (a->format == FMT_BINARY) {
        /* inline base64: the whole content */
        const char *b = r->s + a->cb, *e = r->s + a->ce;
        while (b < e && ffd_is_space((unsigned char)*b))
            b++;
        while (e > b && ffd_is_space((unsigned char)e[-1]))
            e--;
        a->enc_b = (size_t)(b - r->s);
        a->enc_e = (size_t)(e - r->s);
        unsigned char *buf = ffd_malloc((size_t)(e - b) / 4 * 3 + 3);
        if (!buf)
            return ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory decoding %s", r->name, label);
        const char *bad = NULL;
        size_t n = b64_decode(b, e, buf, &bad);
        if (n == SIZE_MAX) {
            ffd_free(buf);
            return FAIL_AT(r, (size_t)(bad - r->s), FFD_ERR_PARSE, "%s: invalid base64", label);
        }
        /* separately encoded header: its base64 chunk ends in padding */
        uint64_t hbytes = hsize;
        if (st->compressed && n >= hsize) {
            uint64_t nb = load_u64(buf, hsize, st->big_endian);
            hbytes = nb < (uint64_t)(e - b) ? (3 + nb) * hsize : 0;
        }
        size_t hc = b64_chars((size_t)hbytes);
        a->separate = hbytes % 3 && (size_t)(e - b) >= hc && b[hc - 1] == '=';
        *out = buf;
        *owned = buf;
        *size = n;
        *base = a->enc_b;
        return FFD_OK;
    }
    if (!st->appended_start)
        return FAIL_AT(r, a->tag, FFD_ERR_PARSE, "%s is appended but the file has no <AppendedData>",
                       label);
    size_t len = st->appended_end - st->appended_start;
    if (a->offset >= len)
        return FAIL_AT(r, a->tag, FFD_ERR_PARSE, "%s: offset %llu is past the %zu bytes of appended data",
                       label, (unsigned long long)a->offset, len);
    size_t start = st->appended_start + (size_t)a->offset;
    if (!st->appended_base64) {
        *out = (const unsigned char *)r->s + start;
        *size = st->appended_end - start;
        *base = start;
        a->enc_b = start; /* enc_e set by unpack */
        return FFD_OK;
    }
    /* appended base64: the extent follows from the header */
    const char *b = r->s + start, *e = r->s + st->appended_end;
    unsigned char h[8 * 3 + 8];
    const char *bad = NULL;
    size_t hc = b64_chars(hsize);
    if ((size_t)(e - b) < hc || b64_decode(b, b + hc, h, &bad) == SIZE_MAX)
        return fail_byte(r, start, FFD_ERR_PARSE, "%s: expected a base64 header", label);
    uint64_t first = load_u64(h, hsize, st->big_endian);
    uint64_t hbytes = hsize, dbytes = first;
    if (st->compressed) {
        if (first > (uint64_t)(e - b))
            return fail_byte(r, start, FFD_ERR_PARSE, "%s: %llu compressed blocks in %zu bytes", label,
                             (unsigned long long)first, (size_t)(e - b));
        hbytes = (3 + first) * hsize;
    }
    size_t hchars = b64_chars((size_t)hbytes);
    if ((size_t)(e - b) < hchars)
        return fail_byte(r, start, FFD_ERR_PARSE, "%s: truncated header", label);
    unsigned char *hb = ffd_malloc((size_t)hbytes + 3);
    if (!hb)
        return ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory", r->name);
    if (b64_decode(b, b + hchars, hb, &bad) == SIZE_MAX) {
        ffd_free(hb);
        return fail_byte(r, (size_t)(bad - r->s), FFD_ERR_PARSE, "%s: invalid base64", label);
    }
    if (st->compressed) {
        dbytes = 0;
        for (uint64_t k = 0; k < first; k++) {
            uint64_t c = load_u64(hb + (3 + k) * hsize, hsize, st->big_endian);
            if (c > (uint64_t)(e - b)) {
                ffd_free(hb);
                return fail_byte(r, start, FFD_ERR_PARSE, "%s: compressed block of %llu bytes in %zu",
                                 label, (unsigned long long)c, (size_t)(e - b));
            }
            dbytes += c;
        }
    }
    ffd_free(hb);
    a->separate = hbytes % 3 && b[hchars - 1] == '=';
    uint64_t chars = a->separate ? hchars + (dbytes + 2) / 3 * 4 : (hbytes + dbytes + 2) / 3 * 4;
    if (dbytes > (uint64_t)(e - b) || chars > (uint64_t)(e - b))
        return fail_byte(r, start, FFD_ERR_PARSE,
                         "%s: %llu data bytes need more than the %zu base64 characters left", label,
                         (unsigned long long)dbytes, (size_t)(e - b));
    unsigned char *buf = ffd_malloc((size_t)chars / 4 * 3 + 3);
    if (!buf)
        return ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory decoding %s", r->name, label);
    size_t n = b64_decode(b, b + chars, buf, &bad);
    if (n == SIZE_MAX) {
        ffd_free(buf);
        return fail_byte(r, (size_t)(bad - r->s), FFD_ERR_PARSE, "%s: invalid base64", label);
    }
    a->enc_b = start;
    a->enc_e = start + (size_t)chars;
    *out = buf;
    *owned = buf;
    *size = n;
    *base = start;
    return FFD_OK;
}

/* Header + data (payload) to the array's raw value bytes. *data points into
 * the payload (uncompressed) or at an allocated buffer (*owned). For raw
 * appended data sets a->enc_e. */
static ffd_status unpack(reader *r, vtu_array *a, const unsigned char *pl, size_t plsize,
                         size_t base, const unsigned char **data, size_t *nbytes,
                         unsigned char **owned)
{
    vtu_state *st = r->st;
    size_t hsize = st->header64 ? 8 : 4;
    char label[96];
    array_label(a, label, sizeof label);
    *owned = NULL;
    if (plsize < hsize)
        return fail_byte(r, base, FFD_ERR_PARSE, "%s: truncated: expected a %zu-byte header", label,
                         hsize);
    uint64_t first = load_u64(pl, hsize, st->big_endian);
    if (!st->compressed) {
        if (first > plsize - hsize)
            return fail_byte(r, base, FFD_ERR_PARSE,
                             "%s: header says %llu bytes, only %zu follow", label,
                             (unsigned long long)first, plsize - hsize);
        *data = pl + hsize;
        *nbytes = (size_t)first;
        if (a->format == FMT_APPENDED && !st->appended_base64)
            a->enc_e = base + hsize + (size_t)first;
        return FFD_OK;
    }
#ifdef FFD_HAVE_ZLIB
    uint64_t nb = first;
    if (nb > (plsize - hsize) / hsize || 3 + nb > (plsize) / hsize)
        return fail_byte(r, base, FFD_ERR_PARSE, "%s: %llu compressed blocks: the header does not fit",
                         label, (unsigned long long)nb);
    uint64_t bs = load_u64(pl + hsize, hsize, st->big_endian);
    uint64_t last = load_u64(pl + 2 * hsize, hsize, st->big_endian);
    size_t hbytes = (size_t)(3 + nb) * hsize;
    uint64_t csum = 0;
    for (uint64_t k = 0; k < nb; k++) {
        uint64_t c = load_u64(pl + (3 + k) * hsize, hsize, st->big_endian);
        if (c > plsize)
            return fail_byte(r, base, FFD_ERR_PARSE, "%s: block %llu: %llu compressed bytes", label,
                             (unsigned long long)k, (unsigned long long)c);
        csum += c;
    }
    if (csum > plsize - hbytes)
        return fail_byte(r, base, FFD_ERR_PARSE,
                         "%s: compressed blocks of %llu bytes, only %zu follow the header", label,
                         (unsigned long long)csum, plsize - hbytes);
    if (nb && (last > bs || (last == 0 && bs != 0)))
        return fail_byte(r, base, FFD_ERR_PARSE, "%s: last block size %llu exceeds block size %llu",
                         label, (unsigned long long)last, (unsigned long long)bs);
    uint64_t total = nb ? (nb - 1) * bs + last : 0;
    if (nb && (bs > UINT64_MAX / nb || total / DEFLATE_MAX_RATIO > csum))
        return fail_byte(r, base, FFD_ERR_PARSE,
                         "%s: %llu uncompressed bytes cannot come from %llu compressed ones", label,
                         (unsigned long long)total, (unsigned long long)csum);
    a->block_size = bs;
    unsigned char *out = ffd_malloc(total ? (size_t)total : 1);
    if (!out)
        return ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory inflating %s", r->name, label);
    size_t at = hbytes, put = 0;
    for (uint64_t k = 0; k < nb; k++) {
        uint64_t c = load_u64(pl + (3 + k) * hsize, hsize, st->big_endian);
        uLongf want = (uLongf)(k + 1 == nb ? last : bs);
        uLongf got = want;
        int zs = uncompress(out + put, &got, pl + at, (uLong)c);
        if (zs != Z_OK || got != want) {
            ffd_free(out);
            return fail_byte(r, base + (a->format == FMT_APPENDED && !st->appended_base64 ? at : 0),
                             FFD_ERR_PARSE, "%s: block %llu does not inflate to %lu bytes (zlib: %s)",
                             label, (unsigned long long)k, (unsigned long)want,
                             zs == Z_OK ? "short" : zError(zs));
        }
        at += (size_t)c;
        put += (size_t)got;
    }
    if (a->format == FMT_APPENDED && !st->appended_base64)
        a->enc_e = base + at;
    *data = out;
    *owned = out;
    *nbytes = (size_t)total;
    return FFD_OK;
#else
    (void)data;
    (void)nbytes;
    return fail_byte(r, base, FFD_ERR_UNSUPPORTED, "%s: compressed data needs zlib", label);
#endif
}

/* Decodes an array's values as doubles. count: the tuples expected, or
 * SIZE_MAX for "as many as there are" (*count_out then says). spans: for
 * the Points array, one per value. */
static ffd_status decode_array(reader *r, vtu_array *a, uint64_t count, double **values,
                               size_t *count_out, ffd_span *spans)
{
    char label[96];
    array_label(a, label, sizeof label);
    *values = NULL;
    if (a->kind == KIND_BAD)
        return FAIL_AT(r, a->tag, FFD_ERR_UNSUPPORTED,
                       "%s of type %.*s: only numeric arrays (Int8 .. Float64) are read", label,
                       (int)(a->type_e - a->type_b), a->type_b);
    if (count != SIZE_MAX) {
        ffd_status s = check_count(r, a, "a count of", count);
        if (s)
            return s;
    }
    size_t comps = a->components;
    if (a->format == FMT_ASCII) {
        size_t cap = count != SIZE_MAX ? (size_t)count * comps : 16, n = 0;
        double *v = ffd_malloc_array(cap ? cap : 1, sizeof(double));
        if (!v)
            return ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory reading %s", r->name, label);
        const char *p = r->s + a->cb, *e = r->s + a->ce;
        for (;;) {
            p = skip_ws(p, e);
            if (p >= e)
                break;
            const char *at = p;
            double x;
            int got = ffd_parse_number(&p, e, false, &x);
            if (got != 1) {
                const char *we = at;
                while (we < e && we - at < 20 && !ffd_is_space((unsigned char)*we))
                    we++;
                ffd_free(v);
                return FAIL_AT(r, (size_t)(at - r->s), FFD_ERR_PARSE,
                               "%s: expected a number, found '%.*s'", label, (int)(we - at), at);
            }
            if (count != SIZE_MAX && n == cap) {
                ffd_free(v);
                return FAIL_AT(r, (size_t)(at - r->s), FFD_ERR_PARSE,
                               "%s: more than the %llu values expected", label,
                               (unsigned long long)(count * comps));
            }
            if (n == cap && !ffd_grow((void **)&v, &cap, n + 1, sizeof(double))) {
                ffd_free(v);
                return ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory reading %s", r->name, label);
            }
            if (!isfinite(x)) {
                ffd_free(v);
                return FAIL_AT(r, (size_t)(at - r->s), FFD_ERR_NONFINITE, "%s: non-finite value '%.*s'",
                               label, (int)(p - at > 20 ? 20 : p - at), at);
            }
            if (spans)
                spans[n] = (ffd_span){(uint64_t)(at - r->s), FFD_SPAN_TEXT};
            v[n++] = x;
        }
        if (count != SIZE_MAX && n != count * comps) {
            ffd_free(v);
            return FAIL_AT(r, a->ce, FFD_ERR_PARSE, "%s: expected %llu values, found %zu", label,
                           (unsigned long long)(count * comps), n);
        }
        if (n % comps) {
            ffd_free(v);
            return FAIL_AT(r, a->ce, FFD_ERR_PARSE, "%s: %zu values are not a multiple of %zu components",
                           label, n, comps);
        }
        *values = v;
        if (count_out)
            *count_out = n / comps;
        return FFD_OK;
    }
    const unsigned char *pl = NULL, *data = NULL;
    size_t plsize = 0, base = 0, nbytes = 0;
    unsigned char *own1 = NULL, *own2 = NULL;
    ffd_status s = payload_of(r, a, &pl, &plsize, &own1, &base);
    if (s)
        return s;
    s = unpack(r, a, pl, plsize, base, &data, &nbytes, &own2);
    if (s) {
        ffd_free(own1);
        return s;
    }
    size_t es = kind_size(a->kind);
    size_t n = nbytes / es;
    if (nbytes % (es * comps) || (count != SIZE_MAX && n != count * comps)) {
        ffd_free(own1);
        ffd_free(own2);
        if (count != SIZE_MAX)
            return FAIL_AT(r, a->tag, FFD_ERR_PARSE, "%s: %zu bytes of data, expected %llu values of %zu bytes",
                           label, nbytes, (unsigned long long)(count * comps), es);
        return FAIL_AT(r, a->tag, FFD_ERR_PARSE, "%s: %zu bytes are not whole %zu-component tuples of %zu bytes",
                       label, nbytes, comps, es);
    }
    double *v = ffd_malloc_array(n ? n : 1, sizeof(double));
    if (!v) {
        ffd_free(own1);
        ffd_free(own2);
        return ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory reading %s", r->name, label);
    }
    bool raw = a->format == FMT_APPENDED && !r->st->appended_base64 && !r->st->compressed;
    for (size_t i = 0; i < n; i++) {
        v[i] = read_value(data + i * es, a->kind, r->st->big_endian);
        if (!isfinite(v[i])) {
            size_t off = raw ? (size_t)(data + i * es - (const unsigned char *)r->s) : base;
            ffd_free(v);
            ffd_free(own1);
            ffd_free(own2);
            return fail_byte(r, off, FFD_ERR_NONFINITE, "%s: non-finite value %zu", label, i);
        }
        if (spans)
            spans[i] = (ffd_span){raw ? (uint64_t)(data + i * es - (const unsigned char *)r->s)
                                      : (uint64_t)a->tag,
                                  (uint64_t)a->kind};
    }
    ffd_free(own1);
    ffd_free(own2);
    *values = v;
    if (count_out)
        *count_out = n / comps;
    return FFD_OK;
}

/* ======================================================================
 * Reading
 * ====================================================================== */

typedef struct cell_where {
    const reader *r;
    const vtu_array *types;
} cell_where;

static void locate_cell(const void *user, size_t cell, char *buf, size_t size)
{
    const cell_where *w = user;
    if (w->types->format == FMT_ASCII)
        snprintf(buf, size, "%s:%zu: cell %zu", w->r->name, line_of(w->r, w->types->tag), cell);
    else
        snprintf(buf, size, "%s: byte %zu: cell %zu", w->r->name, w->types->enc_b, cell);
}

static vtu_array *find_array(reader *r, int section, const char *name)
{
    for (size_t i = 0; i < r->narrays; i++)
        if (r->arrays[i].section == section &&
            (!name || range_is(r->arrays[i].name_b, r->arrays[i].name_e, name)))
            return &r->arrays[i];
    return NULL;
}

static ffd_status read_cells(reader *r, const piece_info *pc)
{
    ffd_mesh *m = r->m;
    vtu_array *conn = find_array(r, SEC_CELLS, "connectivity");
    vtu_array *offs = find_array(r, SEC_CELLS, "offsets");
    vtu_array *types = find_array(r, SEC_CELLS, "types");
    if (find_array(r, SEC_CELLS, "faces") || find_array(r, SEC_CELLS, "faceoffsets"))
        return FAIL_AT(r, find_array(r, SEC_CELLS, "faces") ? find_array(r, SEC_CELLS, "faces")->tag
                                                            : find_array(r, SEC_CELLS, "faceoffsets")->tag,
                       FFD_ERR_UNSUPPORTED, "polyhedron cells (faces/faceoffsets arrays) are not read");
    if (!pc->cells)
        return ffd_mesh_finish_cells(m, r->name, NULL, NULL, r->err);
    if (!conn || !offs || !types)
        return FAIL_AT(r, pc->at, FFD_ERR_PARSE,
                       "<Cells> needs DataArrays named connectivity, offsets and types");
    double *c = NULL, *o = NULL, *t = NULL;
    size_t nconn = 0;
    ffd_status s;
    if ((s = decode_array(r, offs, pc->cells, &o, NULL, NULL)) ||
        (s = decode_array(r, types, pc->cells, &t, NULL, NULL)) ||
        (s = decode_array(r, conn, SIZE_MAX, &c, &nconn, NULL)))
        goto done;
    if (!ffd_mesh_reserve_cells(m, (size_t)pc->cells, nconn)) {
        s = ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory for %llu cells", r->name,
                     (unsigned long long)pc->cells);
        goto done;
    }
    uint64_t prev = 0;
    for (size_t k = 0; k < pc->cells; k++) {
        double ok = o[k], tk = t[k];
        if (ok != floor(ok) || ok < (double)prev || ok > (double)nconn) {
            s = FAIL_AT(r, offs->tag, FFD_ERR_PARSE,
                        "offsets: cell %zu ends at %.17g, expected an integer from %llu to %zu", k, ok,
                        (unsigned long long)prev, nconn);
            goto done;
        }
        if (tk != floor(tk) || tk < 0 || tk > 255) {
            s = FAIL_AT(r, types->tag, FFD_ERR_PARSE, "types: cell %zu has type %.17g", k, tk);
            goto done;
        }
        uint64_t end = (uint64_t)ok;
        for (uint64_t i = prev; i < end; i++) {
            double id = c[i];
            if (id != floor(id) || id < 0 || id >= 4294967296.0) {
                s = FAIL_AT(r, conn->tag, FFD_ERR_RANGE, "connectivity: cell %zu has node id %.17g",
                            k, id);
                goto done;
            }
            m->cell_indices[i] = (uint32_t)id;
        }
        m->cell_types[k] = (uint8_t)tk;
        m->cell_offsets[k + 1] = end;
        prev = end;
    }
    if (prev != nconn) {
        s = FAIL_AT(r, offs->tag, FFD_ERR_PARSE,
                    "offsets: the last cell ends at %llu, connectivity has %zu ids",
                    (unsigned long long)prev, nconn);
        goto done;
    }
    m->cell_count = (size_t)pc->cells;
    m->cell_index_count = nconn;
    {
        cell_where w = {r, types};
        s = ffd_mesh_finish_cells(m, r->name, locate_cell, &w, r->err);
    }
done:
    ffd_free(c);
    ffd_free(o);
    ffd_free(t);
    return s;
}

static ffd_status read_fields(reader *r, const piece_info *pc)
{
    for (size_t i = 0; i < r->narrays; i++) {
        vtu_array *a = &r->arrays[i];
        if (a->section != SEC_POINTDATA && a->section != SEC_CELLDATA)
            continue;
        bool point = a->section == SEC_POINTDATA;
        char name[256] = "";
        ffd_status s;
        if (a->name_b && (s = attr_text(r, a->name_b, a->name_e, name, sizeof name)))
            return s;
        double *v = NULL;
        uint64_t count = point ? pc->points : pc->cells;
        if ((s = decode_array(r, a, count, &v, NULL, NULL)))
            return s;
        bool ok = ffd_mesh_add_field(r->m, name, point ? FFD_FIELD_POINT : FFD_FIELD_CELL,
                                     a->components, a->kind, v, (size_t)count);
        ffd_free(v);
        if (!ok)
            return ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory", r->name);
    }
    return FFD_OK;
}

static ffd_status read_vtu(ffd_mesh *m, const char *name, ffd_error *err)
{
    reader r = {m, name, (const char *)m->src, (const char *)m->src + m->src_size, err, NULL, NULL, 0, 0};
    r.st = ffd_calloc(1, sizeof(vtu_state));
    if (!r.st)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    m->codec_state = r.st;
    m->codec_state_free = state_free;
    piece_info pc = {0};
    double *pts = NULL;
    ffd_status s = scan(&r, &pc);
    if (s)
        goto done;
    vtu_array *pa = find_array(&r, SEC_POINTS, NULL);
    if (!pa) {
        s = FAIL_AT(&r, pc.at, FFD_ERR_PARSE, "<Piece> has no <Points> DataArray");
        goto done;
    }
    if (pa->kind != FFD_SPAN_F32 && pa->kind != FFD_SPAN_F64) {
        s = FAIL_AT(&r, pa->tag, FFD_ERR_UNSUPPORTED, "Points of type %.*s: expected Float32 or Float64",
                    (int)(pa->type_e - pa->type_b), pa->type_b);
        goto done;
    }
    if (pa->components != 3) {
        s = FAIL_AT(&r, pa->tag, FFD_ERR_PARSE, "Points have %u components, expected 3",
                    (unsigned)pa->components);
        goto done;
    }
    if (pc.points > UINT32_MAX) {
        s = FAIL_AT(&r, pc.at, FFD_ERR_RANGE, "NumberOfPoints %llu: more than the library handles",
                    (unsigned long long)pc.points);
        goto done;
    }
    if ((s = check_count(&r, pa, "NumberOfPoints", pc.points)))
        goto done;
    if (pc.cells > UINT32_MAX) {
        s = FAIL_AT(&r, pc.at, FFD_ERR_RANGE, "NumberOfCells %llu: more than the library handles",
                    (unsigned long long)pc.cells);
        goto done;
    }
    vtu_array *ta = find_array(&r, SEC_CELLS, "types");
    if (ta && (s = check_count(&r, ta, "NumberOfCells", pc.cells)))
        goto done;
    size_t n = (size_t)pc.points;
    if (!ffd_mesh_reserve(m, n, 0, 0, 0)) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu points", name, n);
        goto done;
    }
    if ((s = decode_array(&r, pa, pc.points, &pts, NULL, m->position_spans)))
        goto done;
    if (n) /* a piece of a partitioned mesh may have no points (docs/mpi.md) */
        memcpy(m->positions, pts, 3 * n * sizeof(double));
    m->vertex_count = n;
    r.st->orig = pts;
    pts = NULL;
    r.st->points = *pa;
    r.st->points_format = pa->format;
    r.st->points_kind = pa->kind;
    m->encoding = pa->format == FMT_ASCII    ? FFD_ENCODING_ASCII
                  : pa->format == FMT_BINARY ? FFD_ENCODING_BASE64
                                             : (r.st->appended_base64 ? FFD_ENCODING_BASE64
                                                                      : FFD_ENCODING_RAW);
    /* the appended arrays, whose offsets move when the Points payload changes size */
    for (size_t i = 0; i < r.narrays; i++)
        if (r.arrays[i].format == FMT_APPENDED) {
            size_t k = r.st->noffsets, cap = k;
            if (!ffd_grow((void **)&r.st->offsets, &cap, k + 1, sizeof(uint64_t)) ||
                !(cap = k, ffd_grow((void **)&r.st->offset_b, &cap, k + 1, sizeof(size_t))) ||
                !(cap = k, ffd_grow((void **)&r.st->offset_e, &cap, k + 1, sizeof(size_t)))) {
                s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
                goto done;
            }
            r.st->offsets[k] = r.arrays[i].offset;
            r.st->offset_b[k] = r.arrays[i].offset_b;
            r.st->offset_e[k] = r.arrays[i].offset_e;
            r.st->noffsets++;
        }
    if ((s = read_cells(&r, &pc)))
        goto done;
    s = read_fields(&r, &pc);
done:
    ffd_free(pts);
    ffd_free(r.arrays);
    return s;
}

/* ======================================================================
 * Writing: encoding an array
 * ====================================================================== */

/* Header (+ zlib blocks) + data as the file stores a binary array. */
static ffd_status pack(const unsigned char *data, size_t n, bool compress, bool header64, bool be,
                       uint64_t block_size, ffd_buf *out, size_t *header_bytes, ffd_error *err)
{
    size_t hs = header64 ? 8 : 4;
    unsigned char h[8];
    if (!compress) {
        if (!header64 && n > UINT32_MAX)
            return ffd_fail(err, FFD_ERR_RANGE, "VTU: an array of %zu bytes does not fit a UInt32 header", n);
        store_u64(h, hs, be, n);
        ffd_buf_put(out, h, hs);
        ffd_buf_put(out, data, n);
        *header_bytes = hs;
        return FFD_OK;
    }
#ifdef FFD_HAVE_ZLIB
    uint64_t bs = block_size ? block_size : VTU_BLOCK_SIZE;
    size_t nb = n ? (size_t)((n + bs - 1) / bs) : 0;
    size_t last = nb ? n - (nb - 1) * (size_t)bs : 0;
    size_t hdr = out->size;
    *header_bytes = (3 + nb) * hs;
    unsigned char *zero = ffd_calloc(*header_bytes ? *header_bytes : 1, 1);
    if (!zero)
        return ffd_fail(err, FFD_ERR_NOMEM, "VTU: out of memory");
    ffd_buf_put(out, zero, *header_bytes);
    ffd_free(zero);
    uLong bound = compressBound((uLong)bs);
    unsigned char *z = ffd_malloc(bound);
    if (!z)
        return ffd_fail(err, FFD_ERR_NOMEM, "VTU: out of memory");
    for (size_t k = 0; k < nb; k++) {
        size_t len = k + 1 == nb ? last : (size_t)bs;
        uLongf zl = bound;
        if (compress2(z, &zl, data + k * (size_t)bs, (uLong)len, Z_DEFAULT_COMPRESSION) != Z_OK) {
            ffd_free(z);
            return ffd_fail(err, FFD_ERR_NOMEM, "VTU: zlib failed to compress a block");
        }
        ffd_buf_put(out, z, zl);
        if (!out->oom)
            store_u64(out->data + hdr + (3 + k) * hs, hs, be, zl);
    }
    ffd_free(z);
    if (!out->oom) {
        store_u64(out->data + hdr, hs, be, nb);
        store_u64(out->data + hdr + hs, hs, be, bs);
        store_u64(out->data + hdr + 2 * hs, hs, be, last);
    }
    return FFD_OK;
#else
    (void)data;
    (void)be;
    (void)block_size;
    (void)out;
    (void)header_bytes;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "VTU: compressed output needs zlib (this ffdkit was built without it)");
#endif
}

/* The packed bytes as base64: header and data apart (VTK's way, and always
 * for compressed data) or together (meshio's uncompressed arrays). */
static void put_base64(ffd_buf *b, const ffd_buf *packed, size_t header_bytes, bool separate)
{
    if (separate) {
        b64_encode(b, packed->data, header_bytes);
        b64_encode(b, packed->data + header_bytes, packed->size - header_bytes);
    } else
        b64_encode(b, packed->data, packed->size);
}

/* ======================================================================
 * Writing: same format and settings, from the source
 * ====================================================================== */

static bool positions_changed(const ffd_mesh *m, const vtu_state *st)
{
    for (size_t i = 0; i < 3 * m->vertex_count; i++)
        if (m->positions[i] != st->orig[i])
            return true;
    return false;
}

static ffd_status patch_vtu(const ffd_mesh *m, ffd_buf *b, ffd_error *err)
{
    const vtu_state *st = m->codec_state;
    size_t n = 3 * m->vertex_count;
    if (!positions_changed(m, st)) {
        ffd_buf_put(b, m->src, m->src_size);
        return FFD_OK;
    }
    if (st->points_format == FMT_ASCII)
        return ffd_mesh_patch_spans(m, b, err);
    int kind = st->points_kind;
    for (size_t i = 0; i < n; i++)
        if (m->positions[i] != st->orig[i] && !ffd_scalar_fits(kind, m->positions[i]))
            return ffd_fail(err, FFD_ERR_RANGE,
                            "vertex %zu: coordinate %g does not fit the file's Float32", i / 3,
                            m->positions[i]);
    if (st->points_format == FMT_APPENDED && !st->appended_base64 && !st->compressed) {
        ffd_buf_put(b, m->src, m->src_size);
        if (b->oom)
            return ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing %zu bytes", m->src_size);
        for (size_t i = 0; i < n; i++)
            if (m->positions[i] != st->orig[i])
                ffd_write_scalar(b->data + m->position_spans[i].offset, kind, st->big_endian,
                                 m->positions[i]);
        return FFD_OK;
    }
    /* encoded Points (base64, zlib): re-encode that array, copy the rest */
    size_t es = ffd_span_kind_size(kind);
    unsigned char *raw = ffd_malloc_array(n ? n : 1, es);
    if (!raw)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing the points");
    for (size_t i = 0; i < n; i++)
        ffd_write_scalar(raw + i * es, kind, st->big_endian, m->positions[i]);
    ffd_buf packed = {0}, enc = {0};
    size_t hb = 0;
    ffd_status s = pack(raw, n * es, st->compressed, st->header64, st->big_endian,
                        st->points.block_size, &packed, &hb, err);
    ffd_free(raw);
    if (s)
        goto done;
    if (packed.oom) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing the points");
        goto done;
    }
    bool base64 = st->points_format == FMT_BINARY || st->appended_base64;
    if (base64)
        put_base64(&enc, &packed, hb, st->points.separate);
    else
        ffd_buf_put(&enc, packed.data, packed.size);
    const ffd_buf *newbytes = base64 ? &enc : &packed;
    size_t ob = st->points.enc_b, oe = st->points.enc_e;
    long long delta = (long long)newbytes->size - (long long)(oe - ob);
    uint64_t poff = st->points.offset;
    size_t pos = 0;
    /* appended offsets after the Points array move by delta (their attributes come first) */
    if (st->points_format == FMT_APPENDED && delta)
        for (size_t k = 0; k < st->noffsets; k++) {
            if (st->offsets[k] <= poff)
                continue;
            ffd_buf_put(b, m->src + pos, st->offset_b[k] - pos);
            ffd_buf_uint(b, (uint64_t)((long long)st->offsets[k] + delta));
            pos = st->offset_e[k];
        }
    ffd_buf_put(b, m->src + pos, ob - pos);
    ffd_buf_put(b, newbytes->data, newbytes->size);
    ffd_buf_put(b, m->src + oe, m->src_size - oe);
done:
    ffd_buf_free(&packed);
    ffd_buf_free(&enc);
    return s;
}

/* ======================================================================
 * Writing: from data
 * ====================================================================== */

typedef struct writer {
    ffd_buf *b;
    ffd_buf app; /* appended raw data */
    ffd_encoding enc;
    bool compress;
    ffd_error *err;
} writer;

static void put_escaped(ffd_buf *b, const char *s)
{
    for (; *s; s++)
        switch (*s) {
        case '&': ffd_buf_puts(b, "&amp;"); break;
        case '<': ffd_buf_puts(b, "&lt;"); break;
        case '>': ffd_buf_puts(b, "&gt;"); break;
        case '"': ffd_buf_puts(b, "&quot;"); break;
        default: ffd_buf_put(b, s, 1);
        }
}

static bool is_integer_kind(int kind)
{
    return kind != FFD_SPAN_F32 && kind != FFD_SPAN_F64;
}

/* One DataArray of n values; get(i) gives value i. */
typedef double (*value_fn)(const void *user, size_t i);

static ffd_status put_array(writer *w, const char *name, int kind, uint32_t comps, size_t n,
                            value_fn get, const void *user)
{
    ffd_buf *b = w->b;
    ffd_buf_puts(b, "      <DataArray type=\"");
    ffd_buf_puts(b, type_name_of(kind));
    ffd_buf_puts(b, "\"");
    if (name) {
        ffd_buf_puts(b, " Name=\"");
        put_escaped(b, name);
        ffd_buf_puts(b, "\"");
    }
    if (comps != 1)
        ffd_buf_printf(b, " NumberOfComponents=\"%u\"", (unsigned)comps);
    if (w->enc == FFD_ENCODING_ASCII) {
        ffd_buf_puts(b, " format=\"ascii\">\n");
        char tmp[32];
        for (size_t i = 0; i < n; i++) {
            double v = get(user, i);
            int len = is_integer_kind(kind) ? ffd_format_int(tmp, (int64_t)llround(v))
                                            : kind == FFD_SPAN_F32 ? ffd_format_float(tmp, (float)v)
                                                                   : ffd_format_double(tmp, v);
            if (i % (comps == 1 ? 12 : comps * (comps <= 3 ? 4 : 1)) == 0)
                ffd_buf_puts(b, i ? "\n          " : "          ");
            else
                ffd_buf_puts(b, " ");
            ffd_buf_put(b, tmp, (size_t)len);
        }
        ffd_buf_puts(b, "\n      </DataArray>\n");
        return FFD_OK;
    }
    size_t es = kind_size(kind);
    unsigned char *raw = ffd_malloc_array(n ? n : 1, es);
    if (!raw)
        return ffd_fail(w->err, FFD_ERR_NOMEM, "VTU: out of memory");
    for (size_t i = 0; i < n; i++)
        write_value(raw + i * es, kind, false, get(user, i));
    ffd_buf packed = {0};
    size_t hb = 0;
    ffd_status s = pack(raw, n * es, w->compress, true, false, 0, &packed, &hb, w->err);
    ffd_free(raw);
    if (s) {
        ffd_buf_free(&packed);
        return s;
    }
    if (w->enc == FFD_ENCODING_BASE64) {
        ffd_buf_puts(b, " format=\"binary\">\n          ");
        put_base64(b, &packed, hb, true);
        ffd_buf_puts(b, "\n      </DataArray>\n");
    } else {
        ffd_buf_puts(b, " format=\"appended\" offset=\"");
        ffd_buf_uint(b, w->app.size);
        ffd_buf_puts(b, "\"/>\n");
        ffd_buf_put(&w->app, packed.data, packed.size);
    }
    bool oom = packed.oom;
    ffd_buf_free(&packed);
    return oom ? ffd_fail(w->err, FFD_ERR_NOMEM, "VTU: out of memory") : FFD_OK;
}

static double get_double(const void *user, size_t i)
{
    return ((const double *)user)[i];
}
static double get_u32(const void *user, size_t i)
{
    return ((const uint32_t *)user)[i];
}
static double get_u64_plus1(const void *user, size_t i)
{
    return (double)((const uint64_t *)user)[i + 1];
}
static double get_u8(const void *user, size_t i)
{
    return ((const uint8_t *)user)[i];
}

static ffd_status write_vtu_data(const ffd_mesh *m, const ffd_write_options *o, ffd_buf *b,
                                 ffd_error *err)
{
    ffd_cells_view v;
    ffd_status s = ffd_cells_view_of(m, &v, err);
    if (s)
        return s;
    writer w = {b, {0}, o->encoding, o->compress != 0, err};
    ffd_buf_puts(b, "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
                    "byte_order=\"LittleEndian\" header_type=\"UInt64\"");
    if (w.compress)
        ffd_buf_puts(b, " compressor=\"vtkZLibDataCompressor\"");
    ffd_buf_puts(b, ">\n  <UnstructuredGrid>\n");
    ffd_buf_printf(b, "    <Piece NumberOfPoints=\"%zu\" NumberOfCells=\"%zu\">\n", m->vertex_count,
                   v.count);
    ffd_buf_puts(b, "    <Points>\n");
    if ((s = put_array(&w, NULL, FFD_SPAN_F64, 3, 3 * m->vertex_count, get_double, m->positions)))
        goto done;
    ffd_buf_puts(b, "    </Points>\n    <Cells>\n");
    size_t nidx = v.count ? (size_t)v.offsets[v.count] : 0;
    if ((s = put_array(&w, "connectivity", FFD_FIELD_I64, 1, nidx, get_u32, v.indices)) ||
        (s = put_array(&w, "offsets", FFD_FIELD_I64, 1, v.count, get_u64_plus1, v.offsets)) ||
        (s = put_array(&w, "types", FFD_SPAN_U8, 1, v.count, get_u8, v.types)))
        goto done;
    ffd_buf_puts(b, "    </Cells>\n");
    for (int assoc = FFD_FIELD_POINT; assoc <= FFD_FIELD_CELL; assoc++) {
        size_t count = assoc == FFD_FIELD_POINT ? m->vertex_count : m->cell_count;
        bool any = false;
        for (size_t i = 0; i < m->field_count; i++) {
            const ffd_mesh_field *f = &m->fields[i];
            if (f->association != assoc)
                continue;
            if (!any)
                ffd_buf_puts(b, assoc == FFD_FIELD_POINT ? "    <PointData>\n" : "    <CellData>\n");
            any = true;
            if ((s = put_array(&w, f->name, f->kind, f->components, count * f->components,
                               get_double, f->values)))
                goto done;
        }
        if (any)
            ffd_buf_puts(b, assoc == FFD_FIELD_POINT ? "    </PointData>\n" : "    </CellData>\n");
    }
    ffd_buf_puts(b, "    </Piece>\n  </UnstructuredGrid>\n");
    if (w.enc == FFD_ENCODING_RAW) {
        ffd_buf_puts(b, "  <AppendedData encoding=\"raw\">\n   _");
        ffd_buf_put(b, w.app.data, w.app.size);
        ffd_buf_puts(b, "\n  </AppendedData>\n");
    }
    ffd_buf_puts(b, "</VTKFile>\n");
done:
    ffd_buf_free(&w.app);
    ffd_cells_view_free(&v);
    return s;
}

/* compress: 1 zlib, -1 none, 0 as the source when writing back to its own
 * format and encoding (so a compressed file is patched, not rewritten), else none. */
static ffd_status write_vtu_options(const ffd_mesh *m, const ffd_write_options *o, ffd_buf *b,
                                    ffd_error *err)
{
    if (o->compress > 0 && o->encoding == FFD_ENCODING_ASCII)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "VTU: compression applies to base64 or raw appended arrays, not ascii");
#ifndef FFD_HAVE_ZLIB
    if (o->compress > 0)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "VTU: compressed output needs zlib (this ffdkit was built without it)");
#endif
    const vtu_state *st = m->src && m->format == FFD_FORMAT_VTU ? m->codec_state : NULL;
    if (st && o->encoding == m->encoding &&
        (o->compress == 0 || (o->compress > 0) == st->compressed))
        return patch_vtu(m, b, err);
    ffd_write_options w = *o;
    w.compress = o->compress > 0;
    return write_vtu_data(m, &w, b, err);
}

static ffd_status write_vtu(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    ffd_write_options o = {FFD_FORMAT_VTU, enc, 0};
    return write_vtu_data(m, &o, b, err);
}

static const char *const vtu_extensions[] = {"vtu", NULL};

const ffd_mesh_codec ffd_mesh_codec_vtu = {
    .format = FFD_FORMAT_VTU,
    .name = "VTU",
    .extensions = vtu_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII) | FFD_CODEC_ENCODING(FFD_ENCODING_BASE64) |
                 FFD_CODEC_ENCODING(FFD_ENCODING_RAW),
    .read = read_vtu,
    .patch = patch_vtu,
    .write = write_vtu,
    .write_options = write_vtu_options,
};
