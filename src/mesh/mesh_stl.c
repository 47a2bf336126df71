/* mesh — STL codec (ascii and binary): reader, writer, refinement (mesh_codec.h).
 *
 * STL is stored unwelded: facet f has vertices 3f, 3f+1, 3f+2 and face
 * (3f, 3f+1, 3f+2); its facet normal is normal f, anchored at vertex 3f.
 * Binary is recognised by its size (84 + 50 * triangle count, see the
 * constants below); otherwise a file starting with "solid" is ascii;
 * anything else is a binary file whose size disagrees with its count (parse
 * error naming the byte offset).
 * Ascii may hold several solids one after the other; keywords are matched
 * case-insensitively; each loop must have exactly 3 vertices. A UTF-8 byte
 * order mark before an ascii file's "solid" is skipped (and kept in the
 * source bytes). */
#include "mesh_codec.h"

#include <math.h>
#include <string.h>
#include <strings.h>

/* Binary STL layout: an 80-byte free-form header, a uint32 triangle count,
 * then one 50-byte record per facet: 12 float32 (the normal, then the three
 * corners) and a uint16 attribute. All little-endian. */
#define STL_HEADER_SIZE 80
#define STL_PREAMBLE_SIZE 84 /* header and triangle count: the first facet's offset */
#define STL_FACET_SIZE 50
#define STL_FACET_VALUES 12    /* normal x y z, then x y z of the three corners */
#define STL_FLOAT_SIZE 4
#define STL_ATTRIBUTE_OFFSET 48 /* within a facet record */
#define STL_ATTRIBUTE_SIZE 2
#define STL_FLOAT_MAX 3.4028234663852886e38 /* the largest float32 */
/* What the writer puts in the header (the rest is zero). */
#define STL_WRITER_HEADER "binary STL written by ffdkit"

/* ======================================================================
 * Binary
 * ====================================================================== */

static ffd_status read_binary(ffd_mesh *m, const char *name, ffd_error *err)
{
    const unsigned char *s = m->src;
    size_t size = m->src_size;
    if (size < STL_PREAMBLE_SIZE)
        return ffd_fail(err, FFD_ERR_PARSE,
                        "%s: byte %zu: truncated binary STL, expected an 84-byte header", name, size);
    uint32_t n = (uint32_t)ffd_read_scalar(s + STL_HEADER_SIZE, FFD_SPAN_U32, false);
    if ((size - STL_PREAMBLE_SIZE) / STL_FACET_SIZE != n ||
        (size - STL_PREAMBLE_SIZE) % STL_FACET_SIZE != 0)
        return ffd_fail(err, FFD_ERR_PARSE,
                        "%s: byte 80: binary STL declares %u triangles (%llu bytes expected) but the file has %zu bytes",
                        name, n, 84ULL + 50ULL * n, size);
    m->encoding = FFD_ENCODING_BINARY_LE;
    m->facet_normals = 1;
    if (!ffd_mesh_reserve(m, 3 * (size_t)n, n, 3 * (size_t)n, n))
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %u triangles", name, n);
    for (size_t f = 0; f < n; f++) {
        size_t off = STL_PREAMBLE_SIZE + STL_FACET_SIZE * f;
        double v[STL_FACET_VALUES];
        ffd_span sp[STL_FACET_VALUES];
        for (int j = 0; j < STL_FACET_VALUES; j++) {
            sp[j].offset = off + STL_FLOAT_SIZE * (size_t)j;
            sp[j].kind = FFD_SPAN_F32;
            v[j] = ffd_read_scalar(s + sp[j].offset, FFD_SPAN_F32, false);
            if (!isfinite(v[j]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "%s: byte %zu: non-finite %s in triangle %zu",
                                name, (size_t)sp[j].offset, j < 3 ? "normal" : "coordinate", f);
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

static ffd_status stl_read(ffd_mesh *m, const char *name, ffd_error *err)
{
    size_t size = m->src_size;
    if (size >= STL_PREAMBLE_SIZE) {
        uint32_t n = (uint32_t)ffd_read_scalar(m->src + STL_HEADER_SIZE, FFD_SPAN_U32, false);
        if ((size - STL_PREAMBLE_SIZE) % STL_FACET_SIZE == 0 &&
            (size - STL_PREAMBLE_SIZE) / STL_FACET_SIZE == n)
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
    unsigned char t[STL_FLOAT_SIZE];
    ffd_write_scalar(t, FFD_SPAN_F32, false, v);
    ffd_buf_put(b, t, STL_FLOAT_SIZE);
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

static ffd_status stl_write(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    bool binary = enc == FFD_ENCODING_BINARY_LE;
    size_t tris = 0;
    for (size_t f = 0; f < m->face_count; f++)
        tris += m->face_offsets[f + 1] - m->face_offsets[f] - 2;
    if (binary) {
        if (tris > UINT32_MAX)
            return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%zu triangles do not fit in binary STL", tris);
        for (size_t i = 0; i < 3 * m->vertex_count; i++)
            if (fabs(m->positions[i]) > STL_FLOAT_MAX)
                return ffd_fail(err, FFD_ERR_RANGE, "vertex %zu does not fit in binary STL's float32",
                                i / 3);
        unsigned char hdr[STL_PREAMBLE_SIZE];
        memset(hdr, 0, sizeof hdr);
        memcpy(hdr, STL_WRITER_HEADER, sizeof STL_WRITER_HEADER - 1);
        ffd_write_scalar(hdr + STL_HEADER_SIZE, FFD_SPAN_U32, false, (double)tris);
        ffd_buf_put(b, hdr, STL_PREAMBLE_SIZE);
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
                static const unsigned char attr[STL_ATTRIBUTE_SIZE] = {0, 0};
                for (int d = 0; d < 3; d++)
                    put_f32(b, n[d]);
                for (int d = 0; d < 3; d++)
                    put_f32(b, a[d]);
                for (int d = 0; d < 3; d++)
                    put_f32(b, bb[d]);
                for (int d = 0; d < 3; d++)
                    put_f32(b, cc[d]);
                ffd_buf_put(b, attr, STL_ATTRIBUTE_SIZE);
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

/* ======================================================================
 * Refinement (see mesh_refine.c for the format-independent part)
 * ====================================================================== */

/* STL: each child facet is written in its parent's layout (ascii: the same
 * keywords, spacing and line ends; binary: the parent's attribute bytes)
 * with its normal computed from the triangle. Plans must hold triangles. */

static size_t skip_word_back(const unsigned char *s, size_t q)
{
    while (q > 0 && ffd_is_space(s[q - 1]))
        q--;
    while (q > 0 && !ffd_is_space(s[q - 1]))
        q--;
    return q;
}

static size_t skip_word(const unsigned char *s, size_t n, size_t q)
{
    while (q < n && ffd_is_space(s[q]))
        q++;
    while (q < n && !ffd_is_space(s[q]))
        q++;
    return q;
}

/* ascii facet F's text: from its "facet" (with the line's indentation) to
 * after "endfacet" and its line end. */
static void stl_facet_range(const ffd_mesh *m, size_t F, size_t *fs, size_t *fe)
{
    const unsigned char *s = m->src;
    size_t q = skip_word_back(s, skip_word_back(s, m->normal_spans[3 * F].offset));
    size_t ls = q;
    while (ls > 0 && ffd_is_blank(s[ls - 1]))
        ls--;
    if (ls == 0 || s[ls - 1] == '\n')
        q = ls;
    *fs = q;
    size_t v2 = m->face_indices[m->face_offsets[F] + 2];
    const ffd_span *last = &m->position_spans[3 * v2 + 2];
    q = skip_word(s, m->src_size, skip_word(s, m->src_size, last->offset + ffd_span_length(m, last)));
    while (q < m->src_size && ffd_is_blank(s[q]) && s[q] != '\r')
        q++;
    if (q + 1 < m->src_size && s[q] == '\r' && s[q + 1] == '\n')
        q += 2;
    else if (q < m->src_size && s[q] == '\n')
        q++;
    *fe = q;
}

static ffd_status stl_refine(ffd_refine_ctx *c, ffd_buf *b, ffd_error *err)
{
    const ffd_mesh *m = c->m;
    if (!m->facet_normals || m->normal_count != c->nf || !m->normal_spans || !m->position_spans)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: the mesh does not match its STL source");
    if (c->nfo > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_RANGE, "ffd_mesh_refine: %zu triangles do not fit in binary STL",
                        c->nfo);
    ffd_status st = ffd_refine_check_binary_fits(m, err);
    if (st != FFD_OK)
        return st;
    bool binary = m->encoding != FFD_ENCODING_ASCII;
    if (binary && m->src_size != STL_PREAMBLE_SIZE + STL_FACET_SIZE * c->nf)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: the mesh does not match its STL source");
    ffd_refine_cursor k = {b, m, 0};
    if (binary) {
        unsigned char cnt[STL_PREAMBLE_SIZE - STL_HEADER_SIZE];
        ffd_buf_put(b, m->src, STL_HEADER_SIZE);
        ffd_write_scalar(cnt, FFD_SPAN_U32, false, (double)c->nfo);
        ffd_buf_put(b, cnt, sizeof cnt);
    }
    for (size_t F = 0; F < c->nf && !b->oom; F++) {
        size_t fs = STL_PREAMBLE_SIZE + STL_FACET_SIZE * F, fe = fs + STL_FACET_SIZE;
        if (!binary) {
            stl_facet_range(m, F, &fs, &fe);
            if (fs < k.copied)
                fs = k.copied;
            ffd_refine_flush_to(&k, fs);
        }
        for (size_t f = c->child_begin[F]; f < c->child_begin[F + 1]; f++) {
            if (ffd_refine_same_face(c, f, F)) {
                ffd_refine_put_source(b, m, fs, fe);
                continue;
            }
            const uint32_t *ix = c->p->face_indices + c->p->face_offsets[f];
            double v[STL_FACET_VALUES];
            ffd_triangle_normal(c->pos + 3 * (size_t)ix[0], c->pos + 3 * (size_t)ix[1],
                                c->pos + 3 * (size_t)ix[2], v);
            for (int t = 0; t < 3; t++)
                memcpy(v + 3 + 3 * t, c->pos + 3 * (size_t)ix[t], 3 * sizeof(double));
            if (binary) {
                for (int i = 0; i < STL_FACET_VALUES; i++) {
                    unsigned char t4[STL_FLOAT_SIZE];
                    if (!ffd_scalar_fits(FFD_SPAN_F32, v[i]))
                        return ffd_fail(err, FFD_ERR_RANGE,
                                        "ffd_mesh_refine: face %zu: coordinate %g does not fit "
                                        "binary STL's float32",
                                        f, v[i]);
                    ffd_write_scalar(t4, FFD_SPAN_F32, false, v[i]);
                    ffd_buf_put(b, t4, STL_FLOAT_SIZE);
                }
                ffd_buf_put(b, m->src + fs + STL_ATTRIBUTE_OFFSET, STL_ATTRIBUTE_SIZE);
                continue;
            }
            /* the parent's text with its 12 numbers replaced */
            const ffd_span *sp[STL_FACET_VALUES];
            for (int d = 0; d < 3; d++)
                sp[d] = &m->normal_spans[3 * F + (size_t)d];
            for (int t = 0; t < 3; t++)
                for (int d = 0; d < 3; d++)
                    sp[3 + 3 * t + d] =
                        &m->position_spans[3 * (size_t)m->face_indices[m->face_offsets[F] + (uint32_t)t] +
                                           (size_t)d];
            for (int i = 1; i < STL_FACET_VALUES; i++) /* file order (it is already, normally) */
                for (int j = i; j > 0 && sp[j - 1]->offset > sp[j]->offset; j--) {
                    const ffd_span *ts = sp[j];
                    double tv = v[j];
                    sp[j] = sp[j - 1];
                    v[j] = v[j - 1];
                    sp[j - 1] = ts;
                    v[j - 1] = tv;
                }
            size_t at = fs;
            for (int i = 0; i < STL_FACET_VALUES; i++) {
                size_t len = ffd_span_length(m, sp[i]);
                if (sp[i]->offset < at || sp[i]->offset + len > fe)
                    return ffd_fail(err, FFD_ERR_INVALID,
                                    "ffd_mesh_refine: the mesh does not match its STL source");
                ffd_buf_put(b, m->src + at, sp[i]->offset - at);
                ffd_buf_double(b, v[i]);
                at = sp[i]->offset + len;
            }
            ffd_buf_put(b, m->src + at, fe - at);
        }
        k.copied = fe;
    }
    if (!binary)
        ffd_refine_flush_to(&k, m->src_size);
    return FFD_OK;
}

/* ======================================================================
 * The codec
 * ====================================================================== */

static const char *const stl_extensions[] = {"stl", NULL};

const ffd_mesh_codec ffd_mesh_codec_stl = {
    .format = FFD_FORMAT_STL,
    .name = "STL",
    .extensions = stl_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII) |
                 FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_LE),
    .triangles_only = true,
    .read = stl_read,
    .patch = ffd_mesh_patch_spans,
    .transcode = NULL,
    .write = stl_write,
    .refine = stl_refine,
};
