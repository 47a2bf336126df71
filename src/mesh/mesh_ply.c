/* mesh — PLY (Stanford polygon file) reader, writer and transcoder.
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
#include "mesh.h"

#include <math.h>
#include <stdio.h>
#include <string.h>


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

void ffd_ply_header_free(ply_header *h)
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

ffd_status ffd_ply_parse_header(const unsigned char *src, size_t size, const char *name,
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
} walker;

static ffd_status read_value(walker *w, int type, const char *what, uint64_t index, double *v,
                             ffd_span *span, ffd_error *err)
{
    if (w->enc != FFD_ENCODING_ASCII) {
        size_t n = ffd_span_kind_size(type);
        if (w->size - w->pos < n)
            return ffd_fail(err, FFD_ERR_PARSE,
                            "%s: byte %zu: expected %s '%s' of element %llu, found end of file (truncated)",
                            w->name, w->pos, type_name(type), what, (unsigned long long)index);
        *v = ffd_read_scalar(w->src + w->pos, type, w->enc == FFD_ENCODING_BINARY_BE);
        span->offset = w->pos;
        span->length = (uint32_t)n;
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
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected %s '%s' of element %llu, found end of file",
                        w->name, w->line, type_name(type), what, (unsigned long long)index);
    const char *start = p;
    int r = ffd_parse_number(&p, end, false, v);
    if (r <= 0) {
        const char *t = r < 0 ? p : start;
        int len = 0;
        while (t + len < end && !ffd_is_space(t[len]) && len < 20)
            len++;
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected a number for '%s', found '%.*s'",
                        w->name, w->line, what, len, t);
    }
    span->offset = (size_t)(start - s);
    span->length = (uint32_t)(p - start);
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
            n = snprintf(tmp, sizeof tmp, "%.0f", ffd_read_scalar(b, type, false));
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
        int role[64]; /* per property: 0 none, 1..3 xyz, 4..6 normal, 7 face list */
        size_t min_bytes = 0;
        bool has_normal = false, has_xyz[3] = {false, false, false};
        for (size_t k = 0; k < el->nprops; k++) {
            const ply_prop *pr = &el->props[k];
            int r = 0;
            if (is_vert && !pr->count_type) {
                static const char *const names[6] = {"x", "y", "z", "nx", "ny", "nz"};
                for (int d = 0; d < 6; d++)
                    if (name_is(pr->name, pr->name_len, names[d]))
                        r = d + 1;
                if (name_is(pr->name, pr->name_len, "u") || name_is(pr->name, pr->name_len, "s") ||
                    name_is(pr->name, pr->name_len, "texture_u"))
                    m->texcoord_count = (size_t)vert->count;
            }
            if (is_face && pr->count_type &&
                (name_is(pr->name, pr->name_len, "vertex_indices") ||
                 name_is(pr->name, pr->name_len, "vertex_index")))
                r = 7;
            if (r >= 1 && r <= 3)
                has_xyz[r - 1] = true;
            if (r >= 4 && r <= 6)
                has_normal = true;
            if (k < 64)
                role[k] = r;
            min_bytes += w->enc == FFD_ENCODING_ASCII ? 2
                                                       : ffd_span_kind_size(pr->count_type ? pr->count_type
                                                                                           : pr->type);
        }
        if (el->nprops > 64 && (is_vert || is_face))
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
        for (uint64_t i = 0; i < el->count; i++) {
            double xyz[6] = {0, 0, 0, 0, 0, 0};
            ffd_span sp[6];
            memset(sp, 0, sizeof sp);
            for (size_t k = 0; k < el->nprops; k++) {
                const ply_prop *pr = &el->props[k];
                int r = k < 64 ? role[k] : 0;
                char what[80];
                snprintf(what, sizeof what, "%.*s", (int)(pr->name_len > 60 ? 60 : pr->name_len), pr->name);
                double v;
                ffd_span span;
                if (!pr->count_type) {
                    size_t at = w->pos;
                    if ((st = read_value(w, pr->type, what, i, &v, &span, err)) != FFD_OK)
                        return st;
                    if (r >= 1 && r <= 6) {
                        if (!isfinite(v)) {
                            w->pos = at;
                            return ffd_fail(err, FFD_ERR_NONFINITE, "%s: non-finite '%s' of vertex %llu",
                                            loc_fmt(w, loc, sizeof loc), what, (unsigned long long)i);
                        }
                        if (!ffd_scalar_fits(pr->type, v)) {
                            w->pos = at;
                            return ffd_fail(err, FFD_ERR_RANGE,
                                            "%s: '%s' of vertex %llu is %g, outside the range of "
                                            "its type %s",
                                            loc_fmt(w, loc, sizeof loc), what, (unsigned long long)i,
                                            v, type_name(pr->type));
                        }
                        xyz[r - 1] = v;
                        sp[r - 1] = span;
                        if (w->subst) {
                            v = r <= 3 ? w->subst->positions[3 * i + (size_t)(r - 1)]
                                       : w->subst->normals[3 * i + (size_t)(r - 4)];
                            if (!ffd_scalar_fits(pr->type, v))
                                return ffd_fail(err, FFD_ERR_RANGE,
                                                "vertex %llu: '%s' = %g does not fit the file's %s "
                                                "property",
                                                (unsigned long long)i, what, v,
                                                type_name(pr->type));
                        }
                    }
                    emit(w, pr->type, v);
                    continue;
                }
                double cnt;
                size_t at = w->pos;
                if ((st = read_value(w, pr->count_type, what, i, &cnt, &span, err)) != FFD_OK)
                    return st;
                size_t isz = w->enc == FFD_ENCODING_ASCII ? 2 : ffd_span_kind_size(pr->type);
                if (cnt < 0 || cnt != floor(cnt) ||
                    cnt > (double)((w->size - w->pos + 1) / isz)) {
                    w->pos = at;
                    return ffd_fail(err, FFD_ERR_PARSE,
                                    "%s: list '%s' of element %llu has count %g, expected a count the remaining data can hold",
                                    loc_fmt(w, loc, sizeof loc), what, (unsigned long long)i, cnt);
                }
                if (r == 7 && cnt < 3)
                    return ffd_fail(err, FFD_ERR_PARSE, "%s: face %llu has %g vertices, expected at least 3",
                                    loc_fmt(w, loc, sizeof loc), (unsigned long long)i, cnt);
                emit(w, pr->count_type, cnt);
                for (size_t j = 0; j < (size_t)cnt; j++) {
                    at = w->pos;
                    if ((st = read_value(w, pr->type, what, i, &v, &span, err)) != FFD_OK)
                        return st;
                    if (r == 7) {
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
                if (r == 7 && !ffd_mesh_end_face(m))
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

ffd_status ffd_ply_read(ffd_mesh *m, const char *name, ffd_error *err)
{
    ply_header h;
    ffd_status st = ffd_ply_parse_header(m->src, m->src_size, name, &h, err);
    if (st == FFD_OK) {
        m->encoding = h.enc;
        walker w = {name, m->src, m->src_size, h.data, h.lines, h.enc, NULL, NULL, 0, true};
        w.line = h.lines + 1; /* data starts on the line after end_header */
        st = walk(&w, &h, m, err);
    }
    ffd_ply_header_free(&h);
    return st;
}

static const char *enc_name(ffd_encoding enc)
{
    return enc == FFD_ENCODING_BINARY_LE   ? "binary_little_endian"
           : enc == FFD_ENCODING_BINARY_BE ? "binary_big_endian"
                                           : "ascii";
}

ffd_status ffd_ply_transcode(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    ply_header h;
    ffd_error inner = {{0}};
    ffd_status st = ffd_ply_parse_header(m->src, m->src_size, "<source>", &h, &inner);
    if (st == FFD_OK) {
        ffd_buf_put(b, m->src, h.format_begin);
        ffd_buf_printf(b, "format %s 1.0", enc_name(enc));
        ffd_buf_put(b, m->src + h.format_end, h.data - h.format_end);
        ffd_mesh *scratch = ffd_mesh_alloc(FFD_FORMAT_PLY);
        if (!scratch) {
            ffd_ply_header_free(&h);
            return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
        }
        walker w = {"<source>", m->src, m->src_size, h.data, h.lines + 1, h.enc, m, b, enc, true};
        st = walk(&w, &h, scratch, &inner);
        ffd_mesh_destroy(scratch);
    }
    ffd_ply_header_free(&h);
    if (st != FFD_OK)
        return ffd_fail(err, st, "re-encoding the PLY source: %s", inner.message);
    return FFD_OK;
}

/* ======================================================================
 * Writing from data
 * ====================================================================== */

ffd_status ffd_ply_write(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
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
    walker w = {"", NULL, 0, 0, 0, FFD_ENCODING_ASCII, NULL, b, enc, true};
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
