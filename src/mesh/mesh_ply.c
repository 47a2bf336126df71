/* mesh — PLY (Stanford polygon file) codec: reader, writer, transcoder,
 * refinement (mesh_codec.h).
 *
 * Read: format ascii / binary_little_endian / binary_big_endian 1.0; scalar
 * types char uchar short ushort int uint float double and their aliases
 * int8 uint8 int16 uint16 int32 uint32 float32 float64; list properties with
 * any integer count type and any item type. The "vertex" element must have
 * x, y, z; nx, ny, nz become per-vertex normals; the "face" element's list
 * "vertex_indices" (or "vertex_index") gives the faces. Every other property
 * and element stays in the source bytes. Ascii data is a whitespace separated
 * stream (line numbers in messages); binary errors name the byte offset.
 * Declared counts are checked against the bytes left before allocating; data
 * after the last element (other than whitespace in ascii) is an error, as is
 * a face with fewer than 3 vertices. A UTF-8 byte order mark before "ply"
 * is skipped (and kept in the source bytes, so writes and transcodes keep it). */
#include "mesh_codec.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    const char *name;
    size_t name_len;
    int type;       /* FFD_SPAN_* */
    int count_type; /* list count type, 0 for a scalar property */
} ply_prop;

typedef struct {
    const char *name;
    size_t name_len;
    uint64_t count;
    size_t count_offset, count_len; /* where the count stands in the header */
    ply_prop *props;
    size_t nprops, cap;
} ply_elem;

typedef struct {
    ply_elem *elems;
    size_t n, cap;
    ffd_encoding enc;
    size_t data;                  /* offset of the first data byte */
    size_t lines;                 /* header lines */
    size_t format_begin, format_end; /* the format line, without its line terminator */
} ply_header;

/* What a property is to the mesh: x y z and nx ny nz of the vertex element,
 * the face element's vertex index list; every other property is ROLE_OTHER. */
enum { ROLE_OTHER = 0, ROLE_X, ROLE_Y, ROLE_Z, ROLE_NX, ROLE_NY, ROLE_NZ, ROLE_FACE_LIST };
/* The reader follows the roles of a vertex or face element's first properties only. */
#define ROLE_PROPERTY_MAX 64


static const struct {
    const char *name;
    int type;
} type_names[] = {
    {"char", FFD_SPAN_I8},     {"uchar", FFD_SPAN_U8},     {"short", FFD_SPAN_I16},
    {"ushort", FFD_SPAN_U16},  {"int", FFD_SPAN_I32},      {"uint", FFD_SPAN_U32},
    {"float", FFD_SPAN_F32},   {"double", FFD_SPAN_F64},   {"int8", FFD_SPAN_I8},
    {"uint8", FFD_SPAN_U8},    {"int16", FFD_SPAN_I16},    {"uint16", FFD_SPAN_U16},
    {"int32", FFD_SPAN_I32},   {"uint32", FFD_SPAN_U32},   {"float32", FFD_SPAN_F32},
    {"float64", FFD_SPAN_F64},
};

static int type_of(const char *t, size_t n)
{
    for (size_t i = 0; i < sizeof type_names / sizeof type_names[0]; i++)
        if (strlen(type_names[i].name) == n && memcmp(type_names[i].name, t, n) == 0)
            return type_names[i].type;
    return 0;
}

static const char *type_name(int type)
{
    for (size_t i = 0; i < 8; i++)
        if (type_names[i].type == type)
            return type_names[i].name;
    return "?";
}

static bool is_int_type(int type)
{
    return type >= FFD_SPAN_I8 && type <= FFD_SPAN_U32;
}

static bool name_is(const char *s, size_t n, const char *lit)
{
    return strlen(lit) == n && memcmp(s, lit, n) == 0;
}

static void ply_header_free(ply_header *h)
{
    for (size_t i = 0; i < h->n; i++)
        ffd_free(h->elems[i].props);
    ffd_free(h->elems);
}

/* Splits [p, e) into up to max words. */
static int words(const char *p, const char *e, const char **w, size_t *wl, int max)
{
    int n = 0;
    while (p < e) {
        while (p < e && ffd_is_blank(*p))
            p++;
        if (p >= e)
            break;
        const char *s = p;
        while (p < e && !ffd_is_blank(*p))
            p++;
        if (n < max) {
            w[n] = s;
            wl[n] = (size_t)(p - s);
        }
        n++;
    }
    return n;
}

/* Parses and checks a PLY header (messages "name:line: ..."); element and
 * property names point into src. Free with ply_header_free, also after
 * a failure. */
static ffd_status ply_parse_header(const unsigned char *src, size_t size, const char *name,
                                ply_header *h, ffd_error *err)
{
    memset(h, 0, sizeof *h);
    const char *s = (const char *)src, *end = s + size;
    const char *p = s + ffd_utf8_bom_length(s, size); /* before "ply": skipped, kept in the source */
    bool have_format = false;
    for (size_t line = 1;; line++) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        if (!nl)
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected %s, found end of file", name, line,
                            line == 1 ? "'ply'" : "'end_header'");
        const char *le = nl;
        const char *w[6];
        size_t wl[6];
        int nw = words(p, le, w, wl, 6);
        if (line == 1) {
            if (nw != 1 || !name_is(w[0], wl[0], "ply"))
                return ffd_fail(err, FFD_ERR_PARSE, "%s:1: expected 'ply' as the first line", name);
        } else if (nw == 0) {
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected a header keyword, found an empty line",
                            name, line);
        } else if (name_is(w[0], wl[0], "format")) {
            if (have_format)
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: second 'format' line", name, line);
            if (nw != 3 || !name_is(w[2], wl[2], "1.0"))
                return ffd_fail(err, FFD_ERR_PARSE,
                                "%s:%zu: expected 'format ascii|binary_little_endian|binary_big_endian 1.0'",
                                name, line);
            if (name_is(w[1], wl[1], "ascii"))
                h->enc = FFD_ENCODING_ASCII;
            else if (name_is(w[1], wl[1], "binary_little_endian"))
                h->enc = FFD_ENCODING_BINARY_LE;
            else if (name_is(w[1], wl[1], "binary_big_endian"))
                h->enc = FFD_ENCODING_BINARY_BE;
            else
                return ffd_fail(err, FFD_ERR_PARSE,
                                "%s:%zu: unknown PLY format '%.*s' (expected ascii, binary_little_endian or binary_big_endian)",
                                name, line, (int)(wl[1] > 40 ? 40 : wl[1]), w[1]);
            have_format = true;
            h->format_begin = (size_t)(p - s);
            h->format_end = (size_t)(le - s);
            if (le > p && le[-1] == '\r')
                h->format_end--;
        } else if (name_is(w[0], wl[0], "comment") || name_is(w[0], wl[0], "obj_info")) {
            /* kept in the source */
        } else if (name_is(w[0], wl[0], "element")) {
            if (nw != 3)
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected 'element <name> <count>'", name,
                                line);
            uint64_t cnt = 0;
            for (size_t i = 0; i < wl[2]; i++) {
                char c = w[2][i];
                if (c < '0' || c > '9' || cnt > (UINT64_MAX - 9) / 10)
                    return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected an element count, found '%.*s'",
                                    name, line, (int)(wl[2] > 30 ? 30 : wl[2]), w[2]);
                cnt = cnt * 10 + (uint64_t)(c - '0');
            }
            if (!ffd_grow((void **)&h->elems, &h->cap, h->n + 1, sizeof *h->elems))
                return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
            ply_elem *el = &h->elems[h->n++];
            memset(el, 0, sizeof *el);
            el->name = w[1];
            el->name_len = wl[1];
            el->count = cnt;
            el->count_offset = (size_t)(w[2] - s);
            el->count_len = wl[2];
        } else if (name_is(w[0], wl[0], "property")) {
            if (h->n == 0)
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: 'property' before any 'element'", name, line);
            ply_prop pr = {0};
            if (nw >= 2 && name_is(w[1], wl[1], "list")) {
                if (nw != 5)
                    return ffd_fail(err, FFD_ERR_PARSE,
                                    "%s:%zu: expected 'property list <count type> <item type> <name>'",
                                    name, line);
                pr.count_type = type_of(w[2], wl[2]);
                pr.type = type_of(w[3], wl[3]);
                if (!pr.count_type || !pr.type)
                    return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: unknown property type '%.*s'", name, line,
                                    (int)(pr.count_type ? wl[3] : wl[2]), pr.count_type ? w[3] : w[2]);
                if (!is_int_type(pr.count_type))
                    return ffd_fail(err, FFD_ERR_PARSE,
                                    "%s:%zu: list count type must be an integer type, found '%.*s'",
                                    name, line, (int)wl[2], w[2]);
                pr.name = w[4];
                pr.name_len = wl[4];
            } else {
                if (nw != 3)
                    return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected 'property <type> <name>'",
                                    name, line);
                pr.type = type_of(w[1], wl[1]);
                if (!pr.type)
                    return ffd_fail(err, FFD_ERR_PARSE,
                                    "%s:%zu: unknown property type '%.*s' (expected char, uchar, short, ushort, int, uint, float, double or a sized alias)",
                                    name, line, (int)(wl[1] > 30 ? 30 : wl[1]), w[1]);
                pr.name = w[2];
                pr.name_len = wl[2];
            }
            ply_elem *el = &h->elems[h->n - 1];
            if (!ffd_grow((void **)&el->props, &el->cap, el->nprops + 1, sizeof *el->props))
                return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
            el->props[el->nprops++] = pr;
        } else if (name_is(w[0], wl[0], "end_header")) {
            if (!have_format)
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: 'end_header' before a 'format' line", name,
                                line);
            h->data = (size_t)(nl + 1 - s);
            h->lines = line;
            return FFD_OK;
        } else {
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: unknown header keyword '%.*s'", name, line,
                            (int)(wl[0] > 30 ? 30 : wl[0]), w[0]);
        }
        p = nl + 1;
    }
}

/* ======================================================================
 * Data walk (reading, and optionally re-encoding into out)
 * ====================================================================== */

typedef struct {
    const char *name;
    const unsigned char *src;
    size_t size, pos, line;
    ffd_encoding enc;
    const ffd_mesh *subst; /* transcoding: current positions/normals */
    ffd_buf *out;
    ffd_encoding out_enc;
    bool first_on_line;
    const char *collect; /* ffd_ply_vertex_property: the vertex property to copy */
    double *collected;   /* one value per vertex */
} walker;

/* A property's name in messages (at most 60 characters): "%.*s" arguments. */
#define PROP_NAME(pr) (int)((pr)->name_len > 60 ? 60 : (pr)->name_len), (pr)->name

static ffd_status read_value(walker *w, int type, const ply_prop *pr, uint64_t index, double *v,
                             ffd_span *span, ffd_error *err)
{
    if (w->enc != FFD_ENCODING_ASCII) {
        size_t n = ffd_span_kind_size(type);
        if (w->size - w->pos < n)
            return ffd_fail(err, FFD_ERR_PARSE,
                            "%s: byte %zu: expected %s '%.*s' of element %llu, found end of file (truncated)",
                            w->name, w->pos, type_name(type), PROP_NAME(pr), (unsigned long long)index);
        *v = ffd_read_scalar(w->src + w->pos, type, w->enc == FFD_ENCODING_BINARY_BE);
        span->offset = w->pos;
        span->kind = (uint8_t)type;
        w->pos += n;
        return FFD_OK;
    }
    const char *s = (const char *)w->src, *end = s + w->size, *p = s + w->pos;
    while (p < end && ffd_is_space(*p)) {
        if (*p == '\n')
            w->line++;
        p++;
    }
    if (p >= end)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected %s '%.*s' of element %llu, found end of file",
                        w->name, w->line, type_name(type), PROP_NAME(pr), (unsigned long long)index);
    const char *start = p;
    int r = ffd_parse_number(&p, end, false, v);
    if (r <= 0) {
        const char *t = r < 0 ? p : start;
        int len = 0;
        while (t + len < end && !ffd_is_space(t[len]) && len < 20)
            len++;
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected a number for '%.*s', found '%.*s'",
                        w->name, w->line, PROP_NAME(pr), len, t);
    }
    span->offset = (size_t)(start - s);
    span->kind = FFD_SPAN_TEXT;
    w->pos = (size_t)(p - s);
    return FFD_OK;
}

static void emit(walker *w, int type, double v)
{
    if (!w->out)
        return;
    if (w->out_enc == FFD_ENCODING_ASCII) {
        char tmp[40];
        int n;
        if (type == FFD_SPAN_F32)
            n = ffd_format_float(tmp, (float)v);
        else if (type == FFD_SPAN_F64)
            n = ffd_format_double(tmp, v);
        else {
            unsigned char b[8];
            ffd_write_scalar(b, type, false, v);
            n = ffd_format_int(tmp, (int64_t)ffd_read_scalar(b, type, false));
        }
        if (!w->first_on_line)
            ffd_buf_put(w->out, " ", 1);
        ffd_buf_put(w->out, tmp, (size_t)n);
        w->first_on_line = false;
    } else {
        unsigned char b[8];
        ffd_write_scalar(b, type, w->out_enc == FFD_ENCODING_BINARY_BE, v);
        ffd_buf_put(w->out, b, ffd_span_kind_size(type));
    }
}

static const char *loc_fmt(const walker *w, char *buf, size_t n)
{
    if (w->enc == FFD_ENCODING_ASCII)
        snprintf(buf, n, "%s:%zu", w->name, w->line);
    else
        snprintf(buf, n, "%s: byte %zu", w->name, w->pos);
    return buf;
}

/* The machine's byte order when the compiler says it (0 little, 1 big), else -1. */
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define HOST_BIG_ENDIAN 0
#elif defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
#define HOST_BIG_ENDIAN 1
#else
#define HOST_BIG_ENDIAN (-1)
#endif

/* A binary scalar; float and double in the machine's byte order directly. */
static inline double scalar_at(const unsigned char *p, int kind, bool big_endian)
{
    bool native = (int)big_endian == HOST_BIG_ENDIAN;
    if (native && kind == FFD_SPAN_F32) {
        float f;
        memcpy(&f, p, 4);
        return (double)f;
    }
    if (native && kind == FFD_SPAN_F64) {
        double d;
        memcpy(&d, p, 8);
        return d;
    }
    return ffd_read_scalar(p, kind, big_endian);
}

/* The vertex element of a binary file whose properties are all scalars:
 * fixed-size records (the caller checked that count of them fit the data),
 * x y z (and nx ny nz) straight into the mesh's arrays, reserved for count.
 * Returns how many records it took; it stops before a non-finite value. */
static uint64_t read_binary_vertices(walker *w, const ply_elem *el, const int *role,
                                     bool has_normal, ffd_mesh *m)
{
    size_t at[6] = {0}, rec = 0;
    int type[6] = {0};
    for (size_t k = 0; k < el->nprops; k++) {
        if (el->props[k].count_type)
            return 0;
        if (role[k] >= ROLE_X && role[k] <= ROLE_NZ) {
            at[role[k] - ROLE_X] = rec;
            type[role[k] - ROLE_X] = el->props[k].type;
        }
        rec += ffd_span_kind_size(el->props[k].type);
    }
    bool be = w->enc == FFD_ENCODING_BINARY_BE;
    int nval = has_normal ? 6 : 3;
    size_t base = m->vertex_count;
    uint64_t i = 0;
    for (; i < el->count; i++) {
        size_t r = w->pos + (size_t)i * rec;
        double v[6] = {0, 0, 0, 0, 0, 0};
        bool finite = true;
        for (int d = 0; d < nval; d++) {
            if (d >= 3 && !type[d])
                continue; /* a normal with only some of nx ny nz: 0 */
            v[d] = scalar_at(w->src + r + at[d], type[d], be);
            finite &= isfinite(v[d]) != 0;
        }
        if (!finite)
            break;
        size_t vi = base + (size_t)i;
        for (int d = 0; d < 3; d++) {
            m->positions[3 * vi + (size_t)d] = v[d];
            m->position_spans[3 * vi + (size_t)d] = (ffd_span){r + at[d], (uint64_t)type[d]};
        }
        if (has_normal) {
            size_t ni = m->normal_count + (size_t)i;
            for (int d = 0; d < 3; d++) {
                m->normals[3 * ni + (size_t)d] = v[3 + d];
                m->normal_spans[3 * ni + (size_t)d] =
                    type[3 + d] ? (ffd_span){r + at[3 + d], (uint64_t)type[3 + d]} : (ffd_span){0, 0};
            }
            m->normal_anchors[ni] = (uint32_t)i;
        }
    }
    m->vertex_count += (size_t)i;
    if (has_normal)
        m->normal_count += (size_t)i;
    w->pos += (size_t)i * rec;
    return i;
}

/* The face element of a binary file made of the index list alone (integer
 * indices): faces straight into the mesh. *taken is how many it read; it
 * stops before a face that is truncated, short or out of range. */
static ffd_status read_binary_faces(walker *w, const ply_elem *el, uint64_t vertex_count,
                                    ffd_mesh *m, uint64_t *taken, ffd_error *err)
{
    const ply_prop *pr = &el->props[0];
    size_t csz = ffd_span_kind_size(pr->count_type), isz = ffd_span_kind_size(pr->type);
    bool be = w->enc == FFD_ENCODING_BINARY_BE;
    uint64_t i = 0;
    for (; i < el->count; i++) {
        size_t left = w->size - w->pos;
        if (left < csz)
            break;
        double cnt = ffd_read_scalar(w->src + w->pos, pr->count_type, be);
        if (!(cnt >= 3) || cnt > (double)((left - csz) / isz))
            break;
        size_t n = (size_t)cnt;
        const unsigned char *q = w->src + w->pos + csz;
        bool ok = true;
        for (size_t j = 0; j < n && ok; j++) {
            double v = ffd_read_scalar(q + j * isz, pr->type, be);
            ok = v >= 0 && v < (double)vertex_count;
        }
        if (!ok)
            break;
        if (m->index_count + n > UINT32_MAX ||
            !ffd_grow((void **)&m->face_indices, &m->index_cap, m->index_count + n,
                      sizeof(uint32_t)))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", w->name);
        for (size_t j = 0; j < n; j++)
            m->face_indices[m->index_count++] =
                (uint32_t)ffd_read_scalar(q + j * isz, pr->type, be);
        if (!ffd_mesh_end_face(m))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", w->name);
        w->pos += csz + n * isz;
    }
    *taken = i;
    return FFD_OK;
}

static ffd_status walk(walker *w, const ply_header *h, ffd_mesh *m, ffd_error *err)
{
    char loc[300];
    ffd_status st;
    const ply_elem *vert = NULL;
    for (size_t i = 0; i < h->n; i++)
        if (name_is(h->elems[i].name, h->elems[i].name_len, "vertex")) {
            vert = &h->elems[i];
            break;
        }
    if (!vert)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: the header declares no 'vertex' element", w->name,
                        h->lines);
    for (size_t i = 0; i < h->n; i++)
        if (&h->elems[i] != vert && name_is(h->elems[i].name, h->elems[i].name_len, "vertex"))
            return ffd_fail(err, FFD_ERR_PARSE,
                            "%s:%zu: the header declares the 'vertex' element twice", w->name,
                            h->lines);
    if (vert->nprops == 0)
        return ffd_fail(err, FFD_ERR_PARSE,
                        "%s:%zu: the 'vertex' element has no properties (expected x, y, z)",
                        w->name, h->lines);
    for (size_t ei = 0; ei < h->n; ei++) {
        const ply_elem *el = &h->elems[ei];
        if (el->nprops == 0)
            continue;
        bool is_vert = el == vert;
        bool is_face = name_is(el->name, el->name_len, "face");
        int role[ROLE_PROPERTY_MAX]; /* per property: ROLE_* */
        size_t min_bytes = 0;
        bool has_normal = false, has_xyz[3] = {false, false, false};
        for (size_t k = 0; k < el->nprops; k++) {
            const ply_prop *pr = &el->props[k];
            int r = ROLE_OTHER;
            if (is_vert && !pr->count_type) {
                static const char *const names[6] = {"x", "y", "z", "nx", "ny", "nz"};
                for (int d = 0; d < 6; d++)
                    if (name_is(pr->name, pr->name_len, names[d]))
                        r = ROLE_X + d;
                if (name_is(pr->name, pr->name_len, "u") || name_is(pr->name, pr->name_len, "s") ||
                    name_is(pr->name, pr->name_len, "texture_u"))
                    m->texcoord_count = (size_t)vert->count;
            }
            if (is_face && pr->count_type &&
                (name_is(pr->name, pr->name_len, "vertex_indices") ||
                 name_is(pr->name, pr->name_len, "vertex_index")))
                r = ROLE_FACE_LIST;
            if (r >= ROLE_X && r <= ROLE_Z)
                has_xyz[r - ROLE_X] = true;
            if (r >= ROLE_NX && r <= ROLE_NZ)
                has_normal = true;
            if (k < ROLE_PROPERTY_MAX)
                role[k] = r;
            min_bytes += w->enc == FFD_ENCODING_ASCII ? 2
                                                       : ffd_span_kind_size(pr->count_type ? pr->count_type
                                                                                           : pr->type);
        }
        if (el->nprops > ROLE_PROPERTY_MAX && (is_vert || is_face))
            return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: element '%.*s' has more than 64 properties",
                            w->name, (int)el->name_len, el->name);
        if (is_vert && !(has_xyz[0] && has_xyz[1] && has_xyz[2]))
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: the 'vertex' element lacks x, y and z properties",
                            w->name, h->lines);
        size_t remaining = w->size - w->pos + (w->enc == FFD_ENCODING_ASCII ? 1 : 0);
        if (el->count > remaining / min_bytes)
            return ffd_fail(err, FFD_ERR_PARSE,
                            "%s: header declares %llu '%.*s' elements (at least %zu bytes each) but only %zu bytes of data remain",
                            loc_fmt(w, loc, sizeof loc), (unsigned long long)el->count,
                            (int)el->name_len, el->name, min_bytes, w->size - w->pos);
        if (is_vert && el->count > UINT32_MAX)
            return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: %llu vertices is more than this library supports",
                            loc_fmt(w, loc, sizeof loc), (unsigned long long)el->count);
        if (is_vert && !ffd_mesh_reserve(m, (size_t)el->count, 0, 0, has_normal ? (size_t)el->count : 0))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", w->name);
        if (is_face && !ffd_mesh_reserve(m, 0, (size_t)el->count, 3 * (size_t)el->count, 0))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", w->name);
        if (is_vert)
            m->vertex_normals = has_normal;
        /* Binary records take a direct path while they are well formed; the
         * general loop below takes over at the first record that is not (and
         * reports it), so messages and results are the same either way. */
        uint64_t first = 0;
        if (w->enc != FFD_ENCODING_ASCII && !w->out && is_vert && !w->collect)
            first = read_binary_vertices(w, el, role, has_normal, m);
        else if (w->enc != FFD_ENCODING_ASCII && !w->out && is_face && el->nprops == 1 &&
                 role[0] == ROLE_FACE_LIST && is_int_type(el->props[0].type)) {
            if ((st = read_binary_faces(w, el, vert->count, m, &first, err)) != FFD_OK)
                return st;
        }
        for (uint64_t i = first; i < el->count; i++) {
            double xyz[6] = {0, 0, 0, 0, 0, 0};
            ffd_span sp[6];
            memset(sp, 0, sizeof sp);
            for (size_t k = 0; k < el->nprops; k++) {
                const ply_prop *pr = &el->props[k];
                int r = k < ROLE_PROPERTY_MAX ? role[k] : ROLE_OTHER;
                double v;
                ffd_span span;
                if (!pr->count_type) {
                    size_t at = w->pos;
                    if ((st = read_value(w, pr->type, pr, i, &v, &span, err)) != FFD_OK)
                        return st;
                    if (is_vert && w->collect && name_is(pr->name, pr->name_len, w->collect))
                        w->collected[i] = v;
                    if (r >= ROLE_X && r <= ROLE_NZ) {
                        if (!isfinite(v)) {
                            w->pos = at;
                            return ffd_fail(err, FFD_ERR_NONFINITE, "%s: non-finite '%.*s' of vertex %llu",
                                            loc_fmt(w, loc, sizeof loc), PROP_NAME(pr), (unsigned long long)i);
                        }
                        if (!ffd_scalar_fits(pr->type, v)) {
                            w->pos = at;
                            return ffd_fail(err, FFD_ERR_RANGE,
                                            "%s: '%.*s' of vertex %llu is %g, outside the range of "
                                            "its type %s",
                                            loc_fmt(w, loc, sizeof loc), PROP_NAME(pr), (unsigned long long)i,
                                            v, type_name(pr->type));
                        }
                        xyz[r - ROLE_X] = v;
                        sp[r - ROLE_X] = span;
                        if (w->subst) {
                            v = r <= ROLE_Z ? w->subst->positions[3 * i + (size_t)(r - ROLE_X)]
                                       : w->subst->normals[3 * i + (size_t)(r - ROLE_NX)];
                            if (!ffd_scalar_fits(pr->type, v))
                                return ffd_fail(err, FFD_ERR_RANGE,
                                                "vertex %llu: '%.*s' = %g does not fit the file's %s "
                                                "property",
                                                (unsigned long long)i, PROP_NAME(pr), v,
                                                type_name(pr->type));
                        }
                    }
                    emit(w, pr->type, v);
                    continue;
                }
                double cnt;
                size_t at = w->pos;
                if ((st = read_value(w, pr->count_type, pr, i, &cnt, &span, err)) != FFD_OK)
                    return st;
                size_t isz = w->enc == FFD_ENCODING_ASCII ? 2 : ffd_span_kind_size(pr->type);
                if (cnt < 0 || cnt != floor(cnt) ||
                    cnt > (double)((w->size - w->pos + 1) / isz)) {
                    w->pos = at;
                    return ffd_fail(err, FFD_ERR_PARSE,
                                    "%s: list '%.*s' of element %llu has count %g, expected a count the remaining data can hold",
                                    loc_fmt(w, loc, sizeof loc), PROP_NAME(pr), (unsigned long long)i, cnt);
                }
                if (r == ROLE_FACE_LIST && cnt < 3)
                    return ffd_fail(err, FFD_ERR_PARSE, "%s: face %llu has %g vertices, expected at least 3",
                                    loc_fmt(w, loc, sizeof loc), (unsigned long long)i, cnt);
                emit(w, pr->count_type, cnt);
                for (size_t j = 0; j < (size_t)cnt; j++) {
                    at = w->pos;
                    if ((st = read_value(w, pr->type, pr, i, &v, &span, err)) != FFD_OK)
                        return st;
                    if (r == ROLE_FACE_LIST) {
                        if (v != floor(v) || v < 0 || v >= (double)vert->count) {
                            w->pos = at;
                            return ffd_fail(err, v != floor(v) ? FFD_ERR_PARSE : FFD_ERR_RANGE,
                                            "%s: face index %g out of range (%llu vertices)",
                                            loc_fmt(w, loc, sizeof loc), v,
                                            (unsigned long long)vert->count);
                        }
                        if (!ffd_mesh_push_index(m, (uint32_t)v))
                            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", w->name);
                    }
                    emit(w, pr->type, v);
                }
                if (r == ROLE_FACE_LIST && !ffd_mesh_end_face(m))
                    return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", w->name);
            }
            if (w->out && w->out_enc == FFD_ENCODING_ASCII) {
                ffd_buf_put(w->out, "\n", 1);
                w->first_on_line = true;
            }
            if (is_vert) {
                ffd_mesh_push_vertex(m, xyz, sp);
                if (has_normal)
                    ffd_mesh_push_normal(m, xyz + 3, sp + 3, (uint32_t)i);
            }
        }
    }
    if (w->enc == FFD_ENCODING_ASCII) {
        const char *s = (const char *)w->src;
        size_t p = w->pos;
        while (p < w->size && ffd_is_space(s[p])) {
            if (s[p] == '\n')
                w->line++;
            p++;
        }
        if (p < w->size)
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: unexpected data after the last element declared in the header",
                            w->name, w->line);
    } else if (w->pos != w->size) {
        return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: %zu unexpected bytes after the last element declared in the header",
                        w->name, w->pos, w->size - w->pos);
    }
    return FFD_OK;
}

static ffd_status ply_read(ffd_mesh *m, const char *name, ffd_error *err)
{
    ply_header h;
    ffd_status st = ply_parse_header(m->src, m->src_size, name, &h, err);
    if (st == FFD_OK) {
        m->encoding = h.enc;
        walker w = {name, m->src, m->src_size, h.data, h.lines, h.enc, NULL, NULL, 0, true, NULL, NULL};
        w.line = h.lines + 1; /* data starts on the line after end_header */
        st = walk(&w, &h, m, err);
    }
    ply_header_free(&h);
    return st;
}

ffd_status ffd_ply_vertex_property(const ffd_mesh *m, const char *property, double **out,
                                   int *found, ffd_error *err)
{
    *out = NULL;
    *found = 0;
    ply_header h;
    ffd_status st = ply_parse_header(m->src, m->src_size, "mesh", &h, err);
    if (st)
        return st;
    const ply_elem *vert = NULL;
    for (size_t i = 0; i < h.n; i++)
        if (name_is(h.elems[i].name, h.elems[i].name_len, "vertex"))
            vert = &h.elems[i];
    for (size_t k = 0; vert && k < vert->nprops; k++)
        if (!vert->props[k].count_type && name_is(vert->props[k].name, vert->props[k].name_len, property))
            *found = 1;
    if (*found) {
        ffd_mesh *scratch = ffd_mesh_alloc(FFD_FORMAT_PLY);
        double *v = ffd_malloc_array(vert->count ? (size_t)vert->count : 1, sizeof *v);
        if (!scratch || !v) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
        } else {
            walker w = {"mesh", m->src, m->src_size, h.data, h.lines, h.enc, NULL, NULL, 0, true,
                        property, v};
            w.line = h.lines + 1;
            st = walk(&w, &h, scratch, err);
        }
        ffd_mesh_destroy(scratch);
        if (st)
            ffd_free(v);
        else
            *out = v;
    }
    ply_header_free(&h);
    return st;
}

static const char *enc_name(ffd_encoding enc)
{
    return enc == FFD_ENCODING_BINARY_LE   ? "binary_little_endian"
           : enc == FFD_ENCODING_BINARY_BE ? "binary_big_endian"
                                           : "ascii";
}

static ffd_status ply_transcode(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    ply_header h;
    ffd_error inner = {{0}};
    ffd_status st = ply_parse_header(m->src, m->src_size, "<source>", &h, &inner);
    if (st == FFD_OK) {
        ffd_buf_put(b, m->src, h.format_begin);
        ffd_buf_printf(b, "format %s 1.0", enc_name(enc));
        ffd_buf_put(b, m->src + h.format_end, h.data - h.format_end);
        ffd_mesh *scratch = ffd_mesh_alloc(FFD_FORMAT_PLY);
        if (!scratch) {
            ply_header_free(&h);
            return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
        }
        walker w = {"<source>", m->src, m->src_size, h.data, h.lines + 1, h.enc, m, b, enc, true, NULL, NULL};
        st = walk(&w, &h, scratch, &inner);
        ffd_mesh_destroy(scratch);
    }
    ply_header_free(&h);
    if (st != FFD_OK)
        return ffd_fail(err, st, "re-encoding the PLY source: %s", inner.message);
    return FFD_OK;
}

/* ======================================================================
 * Writing from data
 * ====================================================================== */

static ffd_status ply_write(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    bool normals = m->vertex_normals && m->normal_count == m->vertex_count;
    uint32_t max_face = 0;
    for (size_t f = 0; f < m->face_count; f++) {
        uint32_t n = m->face_offsets[f + 1] - m->face_offsets[f];
        max_face = n > max_face ? n : max_face;
    }
    int count_type = max_face <= 255 ? FFD_SPAN_U8 : FFD_SPAN_U32;
    ffd_buf_printf(b, "ply\nformat %s 1.0\ncomment written by ffdkit\nelement vertex %zu\n"
                      "property double x\nproperty double y\nproperty double z\n",
                   enc_name(enc), m->vertex_count);
    if (normals)
        ffd_buf_puts(b, "property double nx\nproperty double ny\nproperty double nz\n");
    ffd_buf_printf(b, "element face %zu\nproperty list %s int vertex_indices\nend_header\n",
                   m->face_count, type_name(count_type));
    walker w = {"", NULL, 0, 0, 0, FFD_ENCODING_ASCII, NULL, b, enc, true, NULL, NULL};
    for (size_t i = 0; i < m->vertex_count && !b->oom; i++) {
        for (int d = 0; d < 3; d++)
            emit(&w, FFD_SPAN_F64, m->positions[3 * i + (size_t)d]);
        for (int d = 0; normals && d < 3; d++)
            emit(&w, FFD_SPAN_F64, m->normals[3 * i + (size_t)d]);
        if (enc == FFD_ENCODING_ASCII) {
            ffd_buf_put(b, "\n", 1);
            w.first_on_line = true;
        }
    }
    for (size_t f = 0; f < m->face_count && !b->oom; f++) {
        emit(&w, count_type, m->face_offsets[f + 1] - m->face_offsets[f]);
        for (uint32_t k = m->face_offsets[f]; k < m->face_offsets[f + 1]; k++)
            emit(&w, FFD_SPAN_I32, m->face_indices[k]);
        if (enc == FFD_ENCODING_ASCII) {
            ffd_buf_put(b, "\n", 1);
            w.first_on_line = true;
        }
    }
    (void)err;
    return FFD_OK;
}

/* ======================================================================
 * Refinement (see mesh_refine.c for the format-independent part)
 * ====================================================================== */

/* PLY: element counts rewritten in the header; new vertex records appended
 * to the vertex element (scalars interpolated, integers rounded and clamped;
 * a list property is copied from the heaviest parent); face records
 * replaced by their children, each copying its parent's other properties,
 * with the original list count and index types (a count or index that does
 * not fit them is FFD_ERR_RANGE). Other elements are copied. */

/* What an element is to refinement: the first "vertex", a "face" with an index list. */
enum { ELEMENT_OTHER = 0, ELEMENT_VERTEX, ELEMENT_FACE };

typedef struct {
    const char *name;
    size_t nlen;
    int type, count_type; /* FFD_SPAN_*; count_type 0 for a scalar */
    int role;             /* ROLE_* */
} pprop;

typedef struct {
    const char *name;
    size_t nlen;
    uint64_t count;
    size_t coff, clen; /* the count in the header */
    pprop *props;
    size_t np, cap;
    int kind;         /* ELEMENT_* */
    size_t face_base; /* ELEMENT_FACE: its first face */
} pelem;

static void pelems_free(pelem *el, size_t n)
{
    for (size_t i = 0; i < n && el; i++)
        ffd_free(el[i].props);
    ffd_free(el);
}

/* The header of a PLY the reader accepted, read by the reader's own
 * header parser and annotated with what refinement needs: the roles of the
 * vertex coordinates and normals, the face index list. *data: offset of
 * the data. */
static ffd_status ply_refine_header(const ffd_mesh *m, pelem **out, size_t *nout, size_t *data,
                                   ffd_error *err)
{
    ply_header h;
    ffd_error inner = {{0}};
    ffd_status st = ply_parse_header(m->src, m->src_size, "<source>", &h, &inner);
    if (st != FFD_OK)
        ply_header_free(&h); /* the parser leaves what it built to the caller */
    if (st == FFD_ERR_NOMEM)
        return ffd_fail(err, st, "ffd_mesh_refine: out of memory");
    if (st != FFD_OK)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: the mesh does not match its PLY source");
    pelem *el = ffd_calloc(h.n ? h.n : 1, sizeof *el);
    if (!el)
        goto oom;
    bool have_vertex = false;
    for (size_t i = 0; i < h.n; i++) {
        const ply_elem *he = &h.elems[i];
        pelem *e = &el[i];
        e->name = he->name;
        e->nlen = he->name_len;
        e->count = he->count;
        e->coff = he->count_offset;
        e->clen = he->count_len;
        if (!have_vertex && name_is(e->name, e->nlen, "vertex")) {
            e->kind = ELEMENT_VERTEX;
            have_vertex = true;
        }
        if (he->nprops && !(e->props = ffd_calloc(he->nprops, sizeof *e->props)))
            goto oom;
        e->cap = e->np = he->nprops;
        for (size_t k = 0; k < he->nprops; k++) {
            const ply_prop *hp = &he->props[k];
            pprop *pr = &e->props[k];
            pr->name = hp->name;
            pr->nlen = hp->name_len;
            pr->type = hp->type;
            pr->count_type = hp->count_type;
            if (e->kind == ELEMENT_VERTEX && !pr->count_type) {
                static const char *const names[6] = {"x", "y", "z", "nx", "ny", "nz"};
                for (int d = 0; d < 6; d++)
                    if (name_is(pr->name, pr->nlen, names[d]))
                        pr->role = ROLE_X + d;
            }
            bool list_name = name_is(pr->name, pr->nlen, "vertex_indices") ||
                             name_is(pr->name, pr->nlen, "vertex_index");
            if (name_is(e->name, e->nlen, "face") && pr->count_type && list_name) {
                if (e->kind == ELEMENT_FACE) {
                    pelems_free(el, h.n);
                    ply_header_free(&h);
                    return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                                    "ffd_mesh_refine: a PLY face element with two vertex index lists");
                }
                pr->role = ROLE_FACE_LIST;
                e->kind = ELEMENT_FACE;
            }
        }
    }
    *data = h.data;
    *out = el;
    *nout = h.n;
    ply_header_free(&h);
    return FFD_OK;
oom:
    pelems_free(el, h.n);
    ply_header_free(&h);
    return ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_refine: out of memory");
}

typedef struct {
    const unsigned char *s;
    size_t size, pos;
    bool ascii, be;
} prd;

static bool prd_value(prd *r, int type, double *v, size_t *start, size_t *stop)
{
    if (!r->ascii) {
        size_t n = ffd_span_kind_size(type);
        if (r->size - r->pos < n)
            return false;
        *start = r->pos;
        *v = ffd_read_scalar(r->s + r->pos, type, r->be);
        r->pos += n;
        *stop = r->pos;
        return true;
    }
    while (r->pos < r->size && ffd_is_space(r->s[r->pos]))
        r->pos++;
    if (r->pos >= r->size)
        return false;
    const char *t = (const char *)r->s + r->pos;
    char *e;
    *v = strtod(t, &e);
    if (e == t || e > (const char *)r->s + r->size)
        return false;
    *start = r->pos;
    r->pos = (size_t)(e - (const char *)r->s);
    *stop = r->pos;
    return true;
}

/* One record: scalar values (lists: their count) into vals, each
 * property's [start, stop) into rng (both optional). */
static bool prd_record(prd *r, const pelem *el, double *vals, size_t *rng)
{
    for (size_t k = 0; k < el->np; k++) {
        const pprop *pr = &el->props[k];
        double v;
        size_t a, z;
        if (!prd_value(r, pr->count_type ? pr->count_type : pr->type, &v, &a, &z))
            return false;
        if (pr->count_type) {
            if (!(v >= 0) || v > (double)r->size)
                return false;
            for (size_t i = 0; i < (size_t)v; i++) {
                double t;
                size_t a2;
                if (!prd_value(r, pr->type, &t, &a2, &z))
                    return false;
            }
        }
        if (vals)
            vals[k] = v;
        if (rng) {
            rng[2 * k] = a;
            rng[2 * k + 1] = z;
        }
    }
    return true;
}

static void put_typed(ffd_buf *b, bool ascii, bool be, int type, double v, bool full)
{
    if (!ascii) {
        unsigned char t[8];
        ffd_write_scalar(t, type, be, v);
        ffd_buf_put(b, t, ffd_span_kind_size(type));
        return;
    }
    char tmp[48];
    int n;
    if (type == FFD_SPAN_F64 || (full && type == FFD_SPAN_F32))
        n = ffd_format_double(tmp, v);
    else if (type == FFD_SPAN_F32)
        n = ffd_format_float(tmp, (float)v);
    else {
        unsigned char t[8];
        ffd_write_scalar(t, type, false, v);
        n = ffd_format_int(tmp, (int64_t)ffd_read_scalar(t, type, false));
    }
    ffd_buf_put(b, tmp, (size_t)n);
}

typedef struct {
    ffd_refine_ctx *c;
    pelem *el;
    size_t nel, data;
    const pelem *vert;
    double *vals;   /* nv * vert->np */
    size_t *recs;   /* nv: start of each vertex record */
    size_t *rng;    /* 2 * max np */
    bool ascii, be;
} plyw;

static ffd_status ply_new_vertices(plyw *w, ffd_buf *b, ffd_error *err)
{
    const ffd_refine_ctx *c = w->c;
    const ffd_mesh *m = c->m;
    const pelem *el = w->vert;
    size_t np = el->np;
    bool normals = m->vertex_normals && m->normal_count == c->nv && m->normal_count;
    for (size_t j = 0; j < c->nnew && !b->oom; j++) {
        double n[3] = {0, 0, 0};
        if (normals)
            ffd_refine_blend_normals(c, j, m->normals, n);
        if (w->ascii)
            ffd_buf_puts(b, c->nl);
        for (size_t k = 0; k < np; k++) {
            const pprop *pr = &el->props[k];
            if (k && w->ascii)
                ffd_buf_puts(b, " ");
            if (pr->count_type) {
                /* a list: the heaviest parent's */
                size_t best = c->flat_off[j];
                for (size_t i = best + 1; i < c->flat_off[j + 1]; i++)
                    if (c->flat_w[i] > c->flat_w[best])
                        best = i;
                prd r = {m->src, m->src_size, w->recs[c->flat_idx[best]], w->ascii, w->be};
                if (!prd_record(&r, el, NULL, w->rng))
                    return ffd_fail(err, FFD_ERR_INVALID,
                                    "ffd_mesh_refine: the mesh does not match its PLY source");
                ffd_buf_put(b, m->src + w->rng[2 * k], w->rng[2 * k + 1] - w->rng[2 * k]);
                continue;
            }
            double v;
            if (pr->role >= ROLE_X && pr->role <= ROLE_Z)
                v = c->pos[3 * (c->nv + j) + (size_t)(pr->role - ROLE_X)];
            else if (pr->role >= ROLE_NX && pr->role <= ROLE_NZ)
                v = n[pr->role - ROLE_NX];
            else {
                v = 0;
                for (size_t i = c->flat_off[j]; i < c->flat_off[j + 1]; i++)
                    v += c->flat_w[i] * w->vals[(size_t)c->flat_idx[i] * np + k];
            }
            bool geo = pr->role >= ROLE_X && pr->role <= ROLE_NZ;
            if (geo && !w->ascii && !ffd_scalar_fits(pr->type, v))
                return ffd_fail(err, FFD_ERR_RANGE,
                                "ffd_mesh_refine: new vertex %zu: '%.*s' = %g does not fit the "
                                "file's type",
                                j, (int)(pr->nlen > 60 ? 60 : pr->nlen), pr->name, v);
            put_typed(b, w->ascii, w->be, pr->type, v, geo);
        }
    }
    return FFD_OK;
}

static ffd_status ply_child(plyw *w, ffd_buf *b, const pelem *el, size_t f, size_t rs, size_t re,
                            ffd_error *err)
{
    const ffd_refine_ctx *c = w->c;
    const ffd_mesh *m = c->m;
    if (ffd_refine_same_face(c, f, c->p->face_parent[f])) {
        ffd_buf_put(b, m->src + rs, re - rs);
        return FFD_OK;
    }
    for (size_t k = 0; k < el->np; k++) {
        const pprop *pr = &el->props[k];
        if (k && w->ascii)
            ffd_buf_puts(b, " ");
        if (pr->role != ROLE_FACE_LIST) {
            ffd_buf_put(b, m->src + w->rng[2 * k], w->rng[2 * k + 1] - w->rng[2 * k]);
            continue;
        }
        uint32_t fb = c->p->face_offsets[f], fe = c->p->face_offsets[f + 1];
        if (!ffd_scalar_fits(pr->count_type, (double)(fe - fb)))
            return ffd_fail(err, FFD_ERR_RANGE,
                            "ffd_mesh_refine: face %zu: %u vertices do not fit the PLY list count "
                            "type",
                            f, fe - fb);
        put_typed(b, w->ascii, w->be, pr->count_type, (double)(fe - fb), false);
        for (uint32_t i = fb; i < fe; i++) {
            double v = c->p->face_indices[i];
            if (!ffd_scalar_fits(pr->type, v))
                return ffd_fail(err, FFD_ERR_RANGE,
                                "ffd_mesh_refine: face %zu: vertex index %.0f does not fit the PLY "
                                "index type",
                                f, v);
            if (w->ascii)
                ffd_buf_puts(b, " ");
            put_typed(b, w->ascii, w->be, pr->type, v, false);
        }
    }
    return FFD_OK;
}

static ffd_status ply_refine_records(plyw *w, ffd_buf *b, ffd_error *err)
{
    const ffd_refine_ctx *c = w->c;
    const ffd_mesh *m = c->m;
    ffd_refine_cursor k = {b, m, 0};
    for (size_t e = 0; e < w->nel; e++) {
        const pelem *el = &w->el[e];
        uint64_t want = el->count;
        if (el->kind == ELEMENT_VERTEX)
            want = c->ntot;
        else if (el->kind == ELEMENT_FACE)
            want = c->child_begin[el->face_base + el->count] - c->child_begin[el->face_base];
        if (want != el->count) {
            ffd_refine_flush_to(&k, el->coff);
            ffd_buf_uint(b, want);
            k.copied = el->coff + el->clen;
        }
    }
    ffd_refine_flush_to(&k, w->data);
    prd r = {m->src, m->src_size, w->data, w->ascii, w->be};
    ffd_status st;
    for (size_t e = 0; e < w->nel && !b->oom; e++) {
        const pelem *el = &w->el[e];
        if (el->np == 0)
            continue;
        for (uint64_t i = 0; i < el->count; i++) {
            if (el->kind == ELEMENT_FACE && w->ascii)
                while (r.pos < r.size && ffd_is_space(r.s[r.pos]))
                    r.pos++;
            size_t rs = r.pos;
            if (!prd_record(&r, el, NULL, el->kind == ELEMENT_FACE ? w->rng : NULL))
                return ffd_fail(err, FFD_ERR_INVALID,
                                "ffd_mesh_refine: the mesh does not match its PLY source");
            if (el->kind != ELEMENT_FACE)
                continue;
            size_t F = el->face_base + (size_t)i;
            ffd_refine_flush_to(&k, rs);
            for (size_t f = c->child_begin[F]; f < c->child_begin[F + 1]; f++) {
                if (f > c->child_begin[F] && w->ascii)
                    ffd_buf_puts(b, c->nl);
                if ((st = ply_child(w, b, el, f, rs, r.pos, err)) != FFD_OK)
                    return st;
            }
            k.copied = r.pos;
        }
        if (el->kind == ELEMENT_VERTEX) {
            ffd_refine_flush_to(&k, r.pos);
            if ((st = ply_new_vertices(w, b, err)) != FFD_OK)
                return st;
        }
    }
    ffd_refine_flush_to(&k, m->src_size);
    return FFD_OK;
}

static ffd_status ply_refine(ffd_refine_ctx *c, ffd_buf *b, ffd_error *err)
{
    const ffd_mesh *m = c->m;
    plyw w;
    memset(&w, 0, sizeof w);
    w.c = c;
    w.ascii = m->encoding == FFD_ENCODING_ASCII;
    w.be = m->encoding == FFD_ENCODING_BINARY_BE;
    ffd_status st = ffd_refine_check_binary_fits(m, err);
    if (st != FFD_OK)
        return st;
    if ((st = ply_refine_header(m, &w.el, &w.nel, &w.data, err)) != FFD_OK)
        return st;
    size_t maxnp = 1, faces = 0;
    for (size_t e = 0; e < w.nel; e++) {
        pelem *el = &w.el[e];
        maxnp = el->np > maxnp ? el->np : maxnp;
        if (el->kind == ELEMENT_VERTEX)
            w.vert = el;
        if (el->kind == ELEMENT_FACE && el->np) {
            el->face_base = faces;
            if (el->count > c->nf - faces)
                goto mismatch;
            faces += (size_t)el->count;
        }
    }
    if (!w.vert || w.vert->count != c->nv || faces != c->nf)
        goto mismatch;
    w.rng = ffd_malloc_array(maxnp, 2 * sizeof(size_t));
    w.vals = ffd_malloc_array(c->nv ? c->nv : 1, (w.vert->np ? w.vert->np : 1) * sizeof(double));
    w.recs = ffd_malloc_array(c->nv ? c->nv : 1, sizeof(size_t));
    if (!w.rng || !w.vals || !w.recs) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_refine: out of memory");
        goto done;
    }
    {
        /* the values of the vertex element */
        prd r = {m->src, m->src_size, w.data, w.ascii, w.be};
        for (size_t e = 0; e < w.nel; e++) {
            const pelem *el = &w.el[e];
            if (el->np == 0)
                continue;
            for (uint64_t i = 0; i < el->count; i++) {
                bool isv = el == w.vert;
                if (isv)
                    w.recs[i] = r.pos;
                if (!prd_record(&r, el, isv ? w.vals + (size_t)i * el->np : NULL, NULL))
                    goto mismatch;
            }
            if (el == w.vert)
                break;
        }
    }
    st = ply_refine_records(&w, b, err);
    goto done;
mismatch:
    st = ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: the mesh does not match its PLY source");
done:
    pelems_free(w.el, w.nel);
    ffd_free(w.rng);
    ffd_free(w.vals);
    ffd_free(w.recs);
    return st;
}

/* ======================================================================
 * The codec
 * ====================================================================== */

static const char *const ply_extensions[] = {"ply", NULL};

const ffd_mesh_codec ffd_mesh_codec_ply = {
    .format = FFD_FORMAT_PLY,
    .name = "PLY",
    .extensions = ply_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII) |
                 FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_LE) |
                 FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_BE),
    .triangles_only = false,
    .read = ply_read,
    .patch = ffd_mesh_patch_spans,
    .transcode = ply_transcode,
    .write = ply_write,
    .refine = ply_refine,
};
