/* mesh — Object File Format (OFF) codec: reader, writer, refinement (mesh_codec.h).
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
#include "mesh_codec.h"

#include <math.h>
#include <stdlib.h>
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
        span->kind = FFD_SPAN_TEXT;
    }
    *p = q;
    return 1;
}

static bool is_count(double v, double max)
{
    return v >= 0 && v <= max && v == floor(v);
}

static ffd_status off_read(ffd_mesh *m, const char *name, ffd_error *err)
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

static ffd_status off_write(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    ffd_buf_printf(b, "OFF\n%zu %zu 0\n", m->vertex_count, m->face_count);
    for (size_t i = 0; i < m->vertex_count && !b->oom; i++) {
        ffd_buf_vec3_line(b, "", m->positions + 3 * i);
    }
    for (size_t f = 0; f < m->face_count && !b->oom; f++) {
        ffd_buf_uint(b, m->face_offsets[f + 1] - m->face_offsets[f]);
        for (uint32_t k = m->face_offsets[f]; k < m->face_offsets[f + 1]; k++) {
            ffd_buf_put(b, " ", 1);
            ffd_buf_uint(b, m->face_indices[k]);
        }
        ffd_buf_puts(b, "\n");
    }
    (void)err;
    return FFD_OK;
}

/* ======================================================================
 * Refinement (see mesh_refine.c for the format-independent part)
 * ====================================================================== */

/* OFF: counts rewritten (the edge count is recomputed when it was not 0);
 * new vertex lines after the last vertex line; each child face line copies
 * its parent's trailing values (colour), the first also its comment. */

typedef struct {
    ffd_text_line l;
    const char *first;    /* the vertex count */
    const char *tail;     /* after the last index */
    const char *data_end; /* end of the values (before a comment) */
} off_face;

static void put_vec3(ffd_buf *b, const double *v)
{
    ffd_buf_double(b, v[0]);
    ffd_buf_puts(b, " ");
    ffd_buf_double(b, v[1]);
    ffd_buf_puts(b, " ");
    ffd_buf_double(b, v[2]);
}

static ffd_status off_refine(ffd_refine_ctx *c, ffd_buf *b, ffd_error *err)
{
    const ffd_mesh *m = c->m;
    const char *s = (const char *)m->src, *end = s + m->src_size;
    ffd_status st = FFD_OK;
    ffd_refine_extras vx;
    memset(&vx, 0, sizeof vx);
    vx.off = ffd_malloc_array(c->nv + 1, sizeof *vx.off);
    off_face *faces = ffd_malloc_array(c->nf ? c->nf : 1, sizeof *faces);
    if (!vx.off || !faces)
        goto oom;
    vx.off[0] = 0;
    size_t cnt_off[3] = {0, 0, 0}, cnt_len[3] = {0, 0, 0};
    double cnt_val[3] = {0, 0, 0};
    int nc = 0, state = 0;
    size_t vi = 0, fi = 0, last_v = 0, skip = m->vertex_normals ? 6 : 3;
    bool normals = m->vertex_normals && m->normal_count == c->nv && m->normal_count;
    ffd_text_line l;
    for (const char *at = s + ffd_utf8_bom_length(s, m->src_size); ffd_text_next_line(&at, end, &l);) {
        const char *q = ffd_text_skip_blanks(l.p, l.ce), *ce = ffd_text_hash_in(q, l.ce);
        while (ce > q && ffd_is_blank(ce[-1]))
            ce--;
        if (ce <= q)
            continue;
        const char *p = q;
        if (state == 0) {
            state = 1;
            p = ffd_text_skip_blanks(ffd_text_word_end(q, ce), ce);
            if (p >= ce)
                continue;
        }
        if (state == 1) {
            for (; nc < 3; nc++) {
                p = ffd_text_skip_blanks(p, ce);
                if (p >= ce)
                    break;
                const char *t = p;
                p = ffd_text_word_end(p, ce);
                cnt_off[nc] = (size_t)(t - s);
                cnt_len[nc] = (size_t)(p - t);
                cnt_val[nc] = strtod(t, NULL);
            }
            if (nc < 2 || cnt_val[0] != (double)c->nv || cnt_val[1] != (double)c->nf)
                goto mismatch;
            last_v = (size_t)(l.next - s);
            state = c->nv ? 2 : c->nf ? 3 : 4;
            continue;
        }
        if (state == 2) {
            if (!ffd_refine_extras_add(&vx, vi, q, ce, skip))
                goto oom;
            last_v = (size_t)(l.next - s);
            if (++vi == c->nv)
                state = c->nf ? 3 : 4;
            continue;
        }
        if (state == 3) {
            off_face *F = &faces[fi];
            F->l = l;
            F->first = q;
            p = ffd_text_word_end(q, ce);
            size_t n = (size_t)(m->face_offsets[fi + 1] - m->face_offsets[fi]);
            if (strtod(q, NULL) != (double)n)
                goto mismatch;
            for (size_t i = 0; i < n; i++)
                p = ffd_text_word_end(ffd_text_skip_blanks(p, ce), ce);
            F->tail = p;
            F->data_end = ce;
            if (++fi == c->nf)
                state = 4;
            continue;
        }
        goto mismatch;
    }
    if (state != 4)
        goto mismatch;

    size_t edges = 0;
    if (nc == 3 && cnt_val[2] != 0 && !ffd_refine_count_edges(c, &edges))
        goto oom;
    double want[3] = {(double)c->ntot, (double)c->nfo,
                      nc == 3 && cnt_val[2] != 0 ? (double)edges : cnt_val[2]};
    ffd_refine_cursor k = {b, m, 0};
    for (int i = 0; i < nc; i++)
        if (want[i] != cnt_val[i]) {
            ffd_refine_flush_to(&k, cnt_off[i]);
            ffd_buf_uint(b, (uint64_t)want[i]);
            k.copied = cnt_off[i] + cnt_len[i];
        }
    ffd_refine_flush_to(&k, last_v);
    if (c->nnew) {
        if (last_v == 0 || s[last_v - 1] != '\n')
            ffd_buf_puts(b, last_v && s[last_v - 1] == '\r' ? "\n" : c->nl);
        for (size_t j = 0; j < c->nnew; j++) {
            put_vec3(b, c->pos + 3 * (c->nv + j));
            if (normals) {
                double n[3];
                ffd_refine_blend_normals(c, j, m->normals, n);
                ffd_buf_xyz(b, n);
            }
            ffd_refine_put_extras(b, c, j, &vx, true);
            ffd_buf_puts(b, c->nl);
        }
    }
    for (size_t F = 0; F < c->nf && !b->oom; F++) {
        const off_face *o = &faces[F];
        ffd_refine_flush_to(&k, (size_t)(o->l.p - s));
        for (size_t f = c->child_begin[F]; f < c->child_begin[F + 1]; f++) {
            bool last = f + 1 == c->child_begin[F + 1];
            if (ffd_refine_same_face(c, f, F)) {
                ffd_buf_put(b, o->l.p, (size_t)(o->l.ce - o->l.p));
            } else {
                ffd_buf_put(b, o->l.p, (size_t)(o->first - o->l.p));
                ffd_buf_uint(b, c->p->face_offsets[f + 1] - c->p->face_offsets[f]);
                for (uint32_t i = c->p->face_offsets[f]; i < c->p->face_offsets[f + 1]; i++) {
                    ffd_buf_puts(b, " ");
                    ffd_buf_uint(b, c->p->face_indices[i]);
                }
                const char *te = f == c->child_begin[F] ? o->l.ce : o->data_end;
                ffd_buf_put(b, o->tail, (size_t)(te - o->tail));
            }
            ffd_text_put_term(b, &o->l, last, c->nl);
        }
        k.copied = (size_t)(o->l.next - s);
    }
    ffd_refine_flush_to(&k, m->src_size);
    goto done;
mismatch:
    st = ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: the mesh does not match its OFF source");
    goto done;
oom:
    st = ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_refine: out of memory");
done:
    ffd_refine_extras_free(&vx);
    ffd_free(faces);
    return st;
}

/* ======================================================================
 * The codec
 * ====================================================================== */

static const char *const off_extensions[] = {"off", NULL};

const ffd_mesh_codec ffd_mesh_codec_off = {
    .format = FFD_FORMAT_OFF,
    .name = "OFF",
    .extensions = off_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII),
    .triangles_only = false,
    .read = off_read,
    .patch = ffd_mesh_patch_spans,
    .transcode = NULL,
    .write = off_write,
    .refine = off_refine,
};
