/* mesh — STL reader and writer (ascii and binary).
 *
 * STL is stored unwelded: facet f has vertices 3f, 3f+1, 3f+2 and face
 * (3f, 3f+1, 3f+2); its facet normal is normal f, anchored at vertex 3f.
 * Binary is recognised by its size (84 + 50 * triangle count); otherwise a
 * file starting with "solid" is ascii; anything else is a binary file whose
 * size disagrees with its count (parse error naming the byte offset).
 * Ascii may hold several solids one after the other; keywords are matched
 * case-insensitively; each loop must have exactly 3 vertices. A UTF-8 byte
 * order mark before an ascii file's "solid" is skipped (and kept in the
 * source bytes). */
#include "mesh.h"

#include <math.h>
#include <string.h>
#include <strings.h>

/* ======================================================================
 * Binary
 * ====================================================================== */

static ffd_status read_binary(ffd_mesh *m, const char *name, ffd_error *err)
{
    const unsigned char *s = m->src;
    size_t size = m->src_size;
    if (size < 84)
        return ffd_fail(err, FFD_ERR_PARSE,
                        "%s: byte %zu: truncated binary STL, expected an 84-byte header", name, size);
    uint32_t n = (uint32_t)ffd_read_scalar(s + 80, FFD_SPAN_U32, false);
    if ((size - 84) / 50 != n || (size - 84) % 50 != 0)
        return ffd_fail(err, FFD_ERR_PARSE,
                        "%s: byte 80: binary STL declares %u triangles (%llu bytes expected) but the file has %zu bytes",
                        name, n, 84ULL + 50ULL * n, size);
    m->encoding = FFD_ENCODING_BINARY_LE;
    m->facet_normals = 1;
    if (!ffd_mesh_reserve(m, 3 * (size_t)n, n, 3 * (size_t)n, n))
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %u triangles", name, n);
    for (size_t f = 0; f < n; f++) {
        size_t off = 84 + 50 * f;
        double v[12];
        ffd_span sp[12];
        for (int j = 0; j < 12; j++) {
            sp[j].offset = off + 4 * (size_t)j;
            sp[j].length = 4;
            sp[j].kind = FFD_SPAN_F32;
            v[j] = ffd_read_scalar(s + sp[j].offset, FFD_SPAN_F32, false);
            if (!isfinite(v[j]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "%s: byte %zu: non-finite %s in triangle %zu",
                                name, sp[j].offset, j < 3 ? "normal" : "coordinate", f);
        }
        uint32_t base = (uint32_t)(3 * f);
        ffd_mesh_push_normal(m, v, sp, base);
        for (int k = 0; k < 3; k++) {
            ffd_mesh_push_vertex(m, v + 3 + 3 * k, sp + 3 + 3 * k);
            ffd_mesh_push_index(m, base + (uint32_t)k);
        }
        ffd_mesh_end_face(m);
    }
    return FFD_OK;
}

/* ======================================================================
 * Ascii
 * ====================================================================== */

typedef struct {
    const char *name;
    const char *s, *p, *end;
    size_t line;
} stl_ctx;

/* Skips whitespace (counting lines); returns the token [p, *te). */
static const char *token(stl_ctx *c, const char **te)
{
    while (c->p < c->end && ffd_is_space(*c->p)) {
        if (*c->p == '\n')
            c->line++;
        c->p++;
    }
    const char *t = c->p;
    while (c->p < c->end && !ffd_is_space(*c->p))
        c->p++;
    *te = c->p;
    return t;
}

static ffd_status expect_word(stl_ctx *c, const char *word, ffd_error *err)
{
    const char *e;
    const char *t = token(c, &e);
    size_t n = strlen(word);
    if ((size_t)(e - t) == n && strncasecmp(t, word, n) == 0)
        return FFD_OK;
    if (t == e)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected '%s', found end of file", c->name,
                        c->line, word);
    return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected '%s', found '%.*s'", c->name, c->line,
                    word, (int)(e - t > 20 ? 20 : e - t), t);
}

static ffd_status numbers3(stl_ctx *c, double v[3], ffd_span sp[3], ffd_error *err)
{
    for (int j = 0; j < 3; j++) {
        const char *e;
        const char *t = token(c, &e);
        const char *q = t;
        double x;
        if (t == e)
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected a number, found end of file",
                            c->name, c->line);
        if (ffd_parse_number(&q, e, false, &x) != 1 || q != e)
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected a number, found '%.*s'", c->name,
                            c->line, (int)(e - t > 20 ? 20 : e - t), t);
        if (!isfinite(x))
            return ffd_fail(err, FFD_ERR_NONFINITE, "%s:%zu: non-finite number '%.*s'", c->name,
                            c->line, (int)(e - t > 20 ? 20 : e - t), t);
        v[j] = x;
        sp[j].offset = (size_t)(t - c->s);
        sp[j].length = (uint32_t)(e - t);
        sp[j].kind = FFD_SPAN_TEXT;
    }
    return FFD_OK;
}

static void skip_rest_of_line(stl_ctx *c)
{
    while (c->p < c->end && *c->p != '\n')
        c->p++;
}

static ffd_status read_ascii(ffd_mesh *m, const char *name, ffd_error *err)
{
    stl_ctx c = {name, (const char *)m->src,
                 (const char *)m->src + ffd_utf8_bom_length(m->src, m->src_size),
                 (const char *)m->src + m->src_size, 1};
    m->encoding = FFD_ENCODING_ASCII;
    m->facet_normals = 1;
    ffd_status st;
    /* Facets are at least ~100 bytes; reserve from the size to avoid regrowth. */
    size_t guess = m->src_size / 200;
    if (!ffd_mesh_reserve(m, 3 * guess, guess, 3 * guess, guess))
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    if ((st = expect_word(&c, "solid", err)) != FFD_OK)
        return st;
    skip_rest_of_line(&c);
    for (;;) {
        const char *e;
        const char *t = token(&c, &e);
        size_t len = (size_t)(e - t);
        if (len == 8 && strncasecmp(t, "endsolid", 8) == 0) {
            skip_rest_of_line(&c);
            t = token(&c, &e);
            if (t == e)
                return FFD_OK;
            if ((size_t)(e - t) == 5 && strncasecmp(t, "solid", 5) == 0) {
                skip_rest_of_line(&c);
                continue;
            }
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected 'solid' or end of file, found '%.*s'",
                            name, c.line, (int)(e - t > 20 ? 20 : e - t), t);
        }
        if (!(len == 5 && strncasecmp(t, "facet", 5) == 0)) {
            if (t == e)
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected 'facet' or 'endsolid', found end of file",
                                name, c.line);
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected 'facet' or 'endsolid', found '%.*s'",
                            name, c.line, (int)(len > 20 ? 20 : len), t);
        }
        double n[3], v[9];
        ffd_span ns[3], vs[9];
        if ((st = expect_word(&c, "normal", err)) != FFD_OK || (st = numbers3(&c, n, ns, err)) != FFD_OK ||
            (st = expect_word(&c, "outer", err)) != FFD_OK || (st = expect_word(&c, "loop", err)) != FFD_OK)
            return st;
        for (int k = 0; k < 3; k++)
            if ((st = expect_word(&c, "vertex", err)) != FFD_OK ||
                (st = numbers3(&c, v + 3 * k, vs + 3 * k, err)) != FFD_OK)
                return st;
        if ((st = expect_word(&c, "endloop", err)) != FFD_OK ||
            (st = expect_word(&c, "endfacet", err)) != FFD_OK)
            return st;
        if (m->vertex_count > UINT32_MAX - 3)
            return ffd_fail(err, FFD_ERR_NOMEM, "%s:%zu: too many vertices", name, c.line);
        uint32_t base = (uint32_t)m->vertex_count;
        bool ok = ffd_mesh_push_normal(m, n, ns, base);
        for (int k = 0; k < 3 && ok; k++)
            ok = ffd_mesh_push_vertex(m, v + 3 * k, vs + 3 * k) &&
                 ffd_mesh_push_index(m, base + (uint32_t)k);
        if (!ok || !ffd_mesh_end_face(m))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    }
}

ffd_status ffd_stl_read(ffd_mesh *m, const char *name, ffd_error *err)
{
    size_t size = m->src_size;
    if (size >= 84) {
        uint32_t n = (uint32_t)ffd_read_scalar(m->src + 80, FFD_SPAN_U32, false);
        if ((size - 84) % 50 == 0 && (size - 84) / 50 == n)
            return read_binary(m, name, err);
    }
    const char *p = (const char *)m->src, *end = p + size;
    p += ffd_utf8_bom_length(p, size);
    while (p < end && ffd_is_space(*p))
        p++;
    if ((size_t)(end - p) >= 5 && strncasecmp(p, "solid", 5) == 0)
        return read_ascii(m, name, err);
    return read_binary(m, name, err);
}

/* ======================================================================
 * Writing from data
 * ====================================================================== */

static void put_f32(ffd_buf *b, double v)
{
    unsigned char t[4];
    ffd_write_scalar(t, FFD_SPAN_F32, false, v);
    ffd_buf_put(b, t, 4);
}

static void put3(ffd_buf *b, const char *prefix, const double *v)
{
    ffd_buf_puts(b, prefix);
    for (int k = 0; k < 3; k++) {
        ffd_buf_puts(b, " ");
        ffd_buf_double(b, v[k]);
    }
    ffd_buf_puts(b, "\n");
}

ffd_status ffd_stl_write(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    bool binary = enc == FFD_ENCODING_BINARY_LE;
    size_t tris = 0;
    for (size_t f = 0; f < m->face_count; f++)
        tris += m->face_offsets[f + 1] - m->face_offsets[f] - 2;
    if (binary) {
        if (tris > UINT32_MAX)
            return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%zu triangles do not fit in binary STL", tris);
        for (size_t i = 0; i < 3 * m->vertex_count; i++)
            if (fabs(m->positions[i]) > 3.4028234663852886e38)
                return ffd_fail(err, FFD_ERR_RANGE, "vertex %zu does not fit in binary STL's float32",
                                i / 3);
        unsigned char hdr[84];
        memset(hdr, 0, sizeof hdr);
        memcpy(hdr, "binary STL written by ffdkit", 28);
        ffd_write_scalar(hdr + 80, FFD_SPAN_U32, false, (double)tris);
        ffd_buf_put(b, hdr, 84);
    } else {
        ffd_buf_puts(b, "solid ffdkit\n");
    }
    bool stored = m->facet_normals && m->normal_count == m->face_count;
    const double *P = m->positions;
    for (size_t f = 0; f < m->face_count && !b->oom; f++) {
        const uint32_t *ix = m->face_indices + m->face_offsets[f];
        uint32_t cnt = m->face_offsets[f + 1] - m->face_offsets[f];
        for (uint32_t k = 1; k + 1 < cnt; k++) {
            const double *a = P + 3 * ix[0], *bb = P + 3 * ix[k], *cc = P + 3 * ix[k + 1];
            double n[3];
            if (stored && cnt == 3)
                memcpy(n, m->normals + 3 * f, sizeof n);
            else
                ffd_triangle_normal(a, bb, cc, n);
            if (binary) {
                static const unsigned char attr[2] = {0, 0};
                for (int d = 0; d < 3; d++)
                    put_f32(b, n[d]);
                for (int d = 0; d < 3; d++)
                    put_f32(b, a[d]);
                for (int d = 0; d < 3; d++)
                    put_f32(b, bb[d]);
                for (int d = 0; d < 3; d++)
                    put_f32(b, cc[d]);
                ffd_buf_put(b, attr, 2);
            } else {
                put3(b, "  facet normal", n);
                ffd_buf_puts(b, "    outer loop\n");
                put3(b, "      vertex", a);
                put3(b, "      vertex", bb);
                put3(b, "      vertex", cc);
                ffd_buf_puts(b, "    endloop\n  endfacet\n");
            }
        }
    }
    if (!binary)
        ffd_buf_puts(b, "endsolid ffdkit\n");
    return FFD_OK;
}
