/* mesh — Object File Format (OFF) reader and writer.
 *
 * Read: a header keyword [ST][C][N]OFF (NOFF: a normal nx ny nz after each
 * vertex's x y z; C and ST only add values, kept in the source bytes), then
 * "V F E" (on the keyword line or the next content line; E is ignored), then
 * V vertex lines and F face lines "n i1 .. in [colour values]". '#' starts a
 * comment anywhere; blank and comment lines may appear anywhere. One vertex
 * or face per line. A face with fewer than 3 vertices, a header count that
 * disagrees with the data (missing lines, or data after the last face), and
 * anything that is not a number where one is expected are parse errors.
 * 4OFF, nOFF and binary OFF are FFD_ERR_UNSUPPORTED. A UTF-8 byte order mark
 * before the header is skipped (and kept in the source bytes). */
#include "mesh.h"

#include <math.h>
#include <string.h>

typedef struct {
    const char *name;
    const char *s, *p, *end;
    size_t line;      /* line of the content line last returned */
    size_t next_line; /* line number of p */
} off_ctx;

/* Next line with content (comments stripped): [*b, *e). false at end of file. */
static bool next_content(off_ctx *c, const char **b, const char **e)
{
    while (c->p < c->end) {
        const char *le = memchr(c->p, '\n', (size_t)(c->end - c->p));
        if (!le)
            le = c->end;
        const char *q = c->p;
        c->line = ++c->next_line;
        c->p = le < c->end ? le + 1 : c->end;
        while (q < le && ffd_is_blank(*q))
            q++;
        size_t span = le > q ? (size_t)(le - q) : 0;
        const char *h = span ? memchr(q, '#', span) : NULL;
        const char *ce = h ? h : le;
        while (ce > q && ffd_is_blank(ce[-1]))
            ce--;
        if (ce > q) {
            *b = q;
            *e = ce;
            return true;
        }
    }
    return false;
}

static ffd_status bad_token(off_ctx *c, const char *t, const char *e, const char *what,
                            ffd_error *err)
{
    int len = 0;
    while (t + len < e && !ffd_is_space(t[len]) && len < 20)
        len++;
    return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected %s, found '%.*s'", c->name, c->line,
                    what, len, t);
}

/* Reads a number at p (blanks skipped). 1 ok, 0 end of line, negative: error set. */
static int number(off_ctx *c, const char **p, const char *e, const char *what, double *v,
                  ffd_span *span, ffd_error *err, ffd_status *st)
{
    const char *q = *p;
    while (q < e && ffd_is_blank(*q))
        q++;
    if (q >= e) {
        *p = q;
        return 0;
    }
    const char *start = q;
    int r = ffd_parse_number(&q, e, false, v);
    if (r <= 0) {
        *st = bad_token(c, r < 0 ? q : start, e, what, err);
        return -1;
    }
    if (span) {
        span->offset = (size_t)(start - c->s);
        span->length = (uint32_t)(q - start);
        span->kind = FFD_SPAN_TEXT;
    }
    *p = q;
    return 1;
}

static bool is_count(double v, double max)
{
    return v >= 0 && v <= max && v == floor(v);
}

ffd_status ffd_off_read(ffd_mesh *m, const char *name, ffd_error *err)
{
    off_ctx c = {name, (const char *)m->src,
                 (const char *)m->src + ffd_utf8_bom_length(m->src, m->src_size),
                 (const char *)m->src + m->src_size, 0, 0};
    const char *b, *e;
    ffd_status st = FFD_OK;
    if (!next_content(&c, &b, &e))
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected an OFF header, found end of file",
                        name, c.next_line + 1);
    const char *k = b;
    while (k < e && !ffd_is_blank(*k))
        k++;
    size_t klen = (size_t)(k - b);
    const char *kw = b;
    bool normals = false;
    if (klen >= 2 && kw[0] == 'S' && kw[1] == 'T') {
        m->texcoord_count = 1; /* marker, set to V below */
        kw += 2;
        klen -= 2;
    }
    if (klen >= 1 && kw[0] == 'C') {
        kw++;
        klen--;
    }
    if (klen >= 1 && kw[0] == 'N') {
        normals = true;
        kw++;
        klen--;
    }
    if (klen >= 4 && (kw[0] == '4' || kw[0] == 'n') && memcmp(kw + 1, "OFF", 3) == 0 && klen == 4)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s:%zu: %.*s (4D or n-dimensional OFF) is not supported",
                        name, c.line, (int)(k - b), b);
    if (klen != 3 || memcmp(kw, "OFF", 3) != 0)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected an OFF header ([ST][C][N]OFF), found '%.*s'",
                        name, c.line, (int)(k - b > 20 ? 20 : k - b), b);
    const char *p = k;
    while (p < e && ffd_is_blank(*p))
        p++;
    if (p < e && strncmp(p, "BINARY", 6) == 0)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s:%zu: binary OFF is not supported", name, c.line);
    if (p >= e) {
        if (!next_content(&c, &b, &e))
            return ffd_fail(err, FFD_ERR_PARSE,
                            "%s:%zu: expected vertex, face and edge counts, found end of file", name,
                            c.next_line + 1);
        p = b;
    }
    double counts[3] = {0, 0, 0};
    int nc = 0;
    for (; nc < 3; nc++) {
        int r = number(&c, &p, e, "a vertex, face or edge count", &counts[nc], NULL, err, &st);
        if (r < 0)
            return st;
        if (r == 0)
            break;
        if (counts[nc] > 4294967295.0 && counts[nc] == floor(counts[nc]))
            return ffd_fail(err, FFD_ERR_PARSE,
                            "%s:%zu: %s count %.17g is above the supported maximum 4294967295", name,
                            c.line, nc == 0 ? "vertex" : nc == 1 ? "face" : "edge", counts[nc]);
        if (!is_count(counts[nc], 4294967295.0))
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected a non-negative integer count, found %.17g",
                            name, c.line, counts[nc]);
    }
    if (nc < 2)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected vertex, face and edge counts", name,
                        c.line);
    while (p < e && ffd_is_blank(*p))
        p++;
    if (p < e)
        return bad_token(&c, p, e, "end of line after the counts", err);
    size_t nv = (size_t)counts[0], nf = (size_t)counts[1];
    /* Reserve no more than the remaining bytes can hold (a vertex line takes
     * at least 6 bytes, a face line 8): a header that lies about its counts
     * then fails at the first missing line, without a huge allocation. */
    size_t remaining = (size_t)(c.end - c.p);
    size_t rv = nv < remaining / 6 + 1 ? nv : remaining / 6 + 1;
    size_t rf = nf < remaining / 8 + 1 ? nf : remaining / 8 + 1;
    if (!ffd_mesh_reserve(m, rv, rf, 3 * rf, normals ? rv : 0))
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    m->vertex_normals = normals;
    if (m->texcoord_count)
        m->texcoord_count = nv;

    for (size_t i = 0; i < nv; i++) {
        if (!next_content(&c, &b, &e))
            return ffd_fail(err, FFD_ERR_PARSE,
                            "%s:%zu: expected vertex %zu of %zu, found end of file", name,
                            c.next_line + 1, i + 1, nv);
        double v[6];
        ffd_span sp[6];
        int want = normals ? 6 : 3;
        p = b;
        for (int j = 0; j < want; j++) {
            int r = number(&c, &p, e, "a coordinate", &v[j], &sp[j], err, &st);
            if (r < 0)
                return st;
            if (r == 0)
                return ffd_fail(err, FFD_ERR_PARSE,
                                "%s:%zu: expected %d values for vertex %zu, found %d", name, c.line,
                                want, i + 1, j);
            if (!isfinite(v[j]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "%s:%zu: value %d of vertex %zu is not finite",
                                name, c.line, j + 1, i + 1);
        }
        double extra;
        int r;
        while ((r = number(&c, &p, e, "a number", &extra, NULL, err, &st)) == 1) {
        }
        if (r < 0)
            return st;
        if (!ffd_mesh_push_vertex(m, v, sp) ||
            (normals && !ffd_mesh_push_normal(m, v + 3, sp + 3, (uint32_t)i)))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    }
    for (size_t f = 0; f < nf; f++) {
        if (!next_content(&c, &b, &e))
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected face %zu of %zu, found end of file",
                            name, c.next_line + 1, f + 1, nf);
        p = b;
        double n;
        int r = number(&c, &p, e, "a face vertex count", &n, NULL, err, &st);
        if (r < 0)
            return st;
        if (!is_count(n, 4294967295.0) || n < 3)
            return ffd_fail(err, FFD_ERR_PARSE,
                            "%s:%zu: face %zu has %g vertices, expected an integer >= 3", name, c.line,
                            f + 1, n);
        size_t cnt = (size_t)n;
        if (cnt > (size_t)(e - p))
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: face %zu declares %zu vertices, more than the line holds",
                            name, c.line, f + 1, cnt);
        for (size_t j = 0; j < cnt; j++) {
            double iv;
            r = number(&c, &p, e, "a vertex index", &iv, NULL, err, &st);
            if (r < 0)
                return st;
            if (r == 0)
                return ffd_fail(err, FFD_ERR_PARSE,
                                "%s:%zu: face %zu declares %zu vertices but lists %zu", name, c.line,
                                f + 1, cnt, j);
            if (iv != floor(iv))
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected an integer vertex index, found %g",
                                name, c.line, iv);
            if (iv < 0 || iv >= (double)nv)
                return ffd_fail(err, FFD_ERR_RANGE, "%s:%zu: face index %.0f out of range (%zu vertices)",
                                name, c.line, iv, nv);
            if (!ffd_mesh_push_index(m, (uint32_t)iv))
                return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
        }
        double extra;
        while ((r = number(&c, &p, e, "a number", &extra, NULL, err, &st)) == 1) {
        }
        if (r < 0)
            return st;
        if (!ffd_mesh_end_face(m))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    }
    if (next_content(&c, &b, &e))
        return ffd_fail(err, FFD_ERR_PARSE,
                        "%s:%zu: unexpected data after the %zu vertices and %zu faces the header declares",
                        name, c.line, nv, nf);
    return FFD_OK;
}

ffd_status ffd_off_write(const ffd_mesh *m, ffd_buf *b, ffd_error *err)
{
    ffd_buf_printf(b, "OFF\n%zu %zu 0\n", m->vertex_count, m->face_count);
    for (size_t i = 0; i < m->vertex_count && !b->oom; i++) {
        ffd_buf_vec3_line(b, "", m->positions + 3 * i);
    }
    for (size_t f = 0; f < m->face_count && !b->oom; f++) {
        ffd_buf_printf(b, "%u", m->face_offsets[f + 1] - m->face_offsets[f]);
        for (uint32_t k = m->face_offsets[f]; k < m->face_offsets[f + 1]; k++)
            ffd_buf_printf(b, " %u", m->face_indices[k]);
        ffd_buf_puts(b, "\n");
    }
    (void)err;
    return FFD_OK;
}
