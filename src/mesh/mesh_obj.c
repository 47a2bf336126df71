/* mesh — Wavefront OBJ reader and writer.
 *
 * Read: v (x y z and any extra values, e.g. w or vertex colours, kept in the
 * source bytes), vt (counted), vn, f with corners v, v/vt, v//vn, v/vt/vn and
 * negative (relative) indices. Positive indices may refer to elements defined
 * later in the file. Every other line (comments, o, g, s, usemtl, mtllib, l,
 * p, ...) is kept verbatim. An f line with fewer than 3 corners is a parse
 * error; points and polylines belong in p and l lines, which are kept as they
 * are. Index 0 or out of range is FFD_ERR_RANGE. A vn no face uses has
 * anchor FFD_NO_ANCHOR and is left alone by set_positions. Line continuation
 * with a trailing backslash is not supported (parse error on v/vn/vt/f lines;
 * other lines are kept as they are). A NUL byte anywhere is a parse error
 * (binary data, not an OBJ file). A UTF-8 byte order mark before the first
 * line is skipped (and kept in the source bytes, so a write keeps it). */
#include "mesh.h"

#include <math.h>
#include <string.h>

typedef struct {
    const char *name;
    const char *s, *end;
    size_t line;
} obj_ctx;

static const char *line_end(const char *p, const char *end)
{
    const char *e = memchr(p, '\n', (size_t)(end - p));
    return e ? e : end;
}

static const char *skip_blank(const char *p, const char *e)
{
    while (p < e && ffd_is_blank(*p))
        p++;
    return p;
}

/* Reads numbers of a v/vn/vt line; the first `keep` go to out/spans. Returns
 * the count or a negative status (message set). */
static int read_numbers(obj_ctx *c, const char *p, const char *e, int keep, double *out,
                        ffd_span *spans, ffd_error *err, ffd_status *st)
{
    int n = 0;
    for (;;) {
        p = skip_blank(p, e);
        if (p >= e || *p == '#')
            return n;
        const char *start = p;
        double v;
        int r = ffd_parse_number(&p, e, true, &v);
        if (r <= 0) {
            const char *t = r < 0 ? p : start;
            int len = 0;
            while (t + len < e && !ffd_is_space(t[len]) && len < 20)
                len++;
            *st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected a number, found '%.*s'", c->name,
                           c->line, len, t);
            return -1;
        }
        if (n < keep) {
            if (!isfinite(v)) {
                *st = ffd_fail(err, FFD_ERR_NONFINITE, "%s:%zu: coordinate %d is not finite (%.*s)",
                               c->name, c->line, n + 1, (int)(p - start), start);
                return -1;
            }
            out[n] = v;
            spans[n].offset = (size_t)(start - c->s);
            spans[n].length = (uint32_t)(p - start);
            spans[n].kind = FFD_SPAN_TEXT;
        }
        n++;
    }
}

/* Parses an optionally signed integer; 0 when none. */
int ffd_obj_parse_int(const char **pp, const char *e, long long *out)
{
    const char *p = *pp;
    bool neg = false;
    if (p < e && (*p == '-' || *p == '+')) {
        neg = *p == '-';
        p++;
    }
    if (p >= e || *p < '0' || *p > '9')
        return 0;
    long long v = 0;
    while (p < e && *p >= '0' && *p <= '9') {
        if (v < (1LL << 40))
            v = v * 10 + (*p - '0');
        p++;
    }
    *out = neg ? -v : v;
    *pp = p;
    return 1;
}

/* Resolves an OBJ index (1-based or negative) against `current` defined so
 * far and `total` in the file. */
static ffd_status resolve(obj_ctx *c, long long idx, size_t current, size_t total,
                          const char *what, uint32_t *out, ffd_error *err)
{
    if (idx == 0)
        return ffd_fail(err, FFD_ERR_RANGE, "%s:%zu: %s index 0 is invalid (OBJ indices start at 1)",
                        c->name, c->line, what);
    if (idx >= (1LL << 40) || idx <= -(1LL << 40)) /* ffd_obj_parse_int stopped accumulating */
        return ffd_fail(err, FFD_ERR_RANGE, "%s:%zu: %s index out of range (2^40 or more in magnitude; %zu %s defined)",
                        c->name, c->line, what, idx > 0 ? total : current,
                        what[0] == 'v' ? "vertices" : what[0] == 't' ? "texcoords" : "normals");
    long long r = idx > 0 ? idx - 1 : (long long)current + idx;
    if (r < 0 || (unsigned long long)r >= (idx > 0 ? total : current))
        return ffd_fail(err, FFD_ERR_RANGE, "%s:%zu: %s index %lld out of range (%zu %s defined)",
                        c->name, c->line, what, idx, idx > 0 ? total : current,
                        what[0] == 'v' ? "vertices" : what[0] == 't' ? "texcoords" : "normals");
    *out = (uint32_t)r;
    return FFD_OK;
}

ffd_status ffd_obj_read(ffd_mesh *m, const char *name, ffd_error *err)
{
    obj_ctx c = {name, (const char *)m->src, (const char *)m->src + m->src_size, 0};
    /* OBJ is text: unknown statements are kept, so binary data (say, a binary
     * STL with the wrong extension) would otherwise read as an empty mesh. */
    const char *nul = memchr(c.s, '\0', (size_t)(c.end - c.s));
    if (nul) {
        size_t line = 1;
        for (const char *p = c.s; p < nul; p++)
            line += *p == '\n';
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: NUL byte (byte %zu): expected a text OBJ file, found binary data",
                        name, line, (size_t)(nul - c.s));
    }
    /* The byte order mark would glue itself to the first keyword and lose
     * that line (a first 'v' line shifts every face by one vertex). */
    const char *first = c.s + ffd_utf8_bom_length(c.s, m->src_size);
    /* Pass 1: totals, for preallocation and forward references. */
    size_t nv = 0, nn = 0, nt = 0, nf = 0, ncorner = 0;
    for (const char *p = first; p < c.end;) {
        const char *e = line_end(p, c.end);
        const char *q = skip_blank(p, e);
        if (e - q >= 2 && q[0] == 'v' && ffd_is_blank(q[1]))
            nv++;
        else if (e - q >= 3 && q[0] == 'v' && q[1] == 'n' && ffd_is_blank(q[2]))
            nn++;
        else if (e - q >= 3 && q[0] == 'v' && q[1] == 't' && ffd_is_blank(q[2]))
            nt++;
        else if (e - q >= 2 && q[0] == 'f' && ffd_is_blank(q[1])) {
            nf++;
            for (const char *r = q + 1; r < e; r++)
                if (ffd_is_blank(r[-1]) && !ffd_is_blank(*r))
                    ncorner++;
        }
        p = e + 1;
    }
    if (!ffd_mesh_reserve(m, nv, nf, ncorner, nn))
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    for (size_t i = 0; i < nn; i++)
        m->normal_anchors[i] = FFD_NO_ANCHOR;
    m->texcoord_count = nt;

    size_t cur_t = 0;
    ffd_status st = FFD_OK;
    for (const char *p = first; p < c.end;) {
        const char *e = line_end(p, c.end);
        c.line++;
        const char *q = skip_blank(p, e);
        const char *k = q;
        while (k < e && !ffd_is_blank(*k))
            k++;
        size_t klen = (size_t)(k - q);
        if (klen == 1 && q[0] == 'v') {
            double xyz[3];
            ffd_span sp[3];
            int n = read_numbers(&c, k, e, 3, xyz, sp, err, &st);
            if (n < 0)
                return st;
            if (n < 3)
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected 3 coordinates after 'v', found %d",
                                name, c.line, n);
            if (!ffd_mesh_push_vertex(m, xyz, sp))
                return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
        } else if (klen == 2 && q[0] == 'v' && q[1] == 'n') {
            double xyz[3];
            ffd_span sp[3];
            int n = read_numbers(&c, k, e, 3, xyz, sp, err, &st);
            if (n < 0)
                return st;
            if (n != 3)
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected 3 numbers after 'vn', found %d",
                                name, c.line, n);
            uint32_t anchor = m->normal_anchors[m->normal_count];
            if (!ffd_mesh_push_normal(m, xyz, sp, anchor))
                return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
        } else if (klen == 2 && q[0] == 'v' && q[1] == 't') {
            double tmp[3];
            ffd_span sp[3];
            int n = read_numbers(&c, k, e, 0, tmp, sp, err, &st);
            if (n < 0)
                return st;
            if (n < 1)
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected a texture coordinate after 'vt'",
                                name, c.line);
            cur_t++;
        } else if (klen == 1 && q[0] == 'f') {
            size_t corners = 0;
            const char *r = k;
            for (;;) {
                r = skip_blank(r, e);
                if (r >= e || *r == '#')
                    break;
                const char *tok = r;
                long long iv = 0, it = 0, in = 0;
                bool has_t = false, has_n = false;
                bool ok = ffd_obj_parse_int(&r, e, &iv) == 1;
                if (ok && r < e && *r == '/') {
                    r++;
                    if (r < e && *r != '/') {
                        ok = ffd_obj_parse_int(&r, e, &it) == 1;
                        has_t = true;
                    }
                    if (ok && r < e && *r == '/') {
                        r++;
                        ok = ffd_obj_parse_int(&r, e, &in) == 1;
                        has_n = true;
                    }
                }
                if (!ok || (r < e && !ffd_is_blank(*r) && *r != '#')) {
                    int len = 0;
                    while (tok + len < e && !ffd_is_blank(tok[len]) && len < 20)
                        len++;
                    return ffd_fail(err, FFD_ERR_PARSE,
                                    "%s:%zu: expected a face corner v, v/vt, v//vn or v/vt/vn, found '%.*s'",
                                    name, c.line, len, tok);
                }
                uint32_t v, t, n;
                if ((st = resolve(&c, iv, m->vertex_count, nv, "vertex", &v, err)) != FFD_OK)
                    return st;
                if (has_t && (st = resolve(&c, it, cur_t, nt, "texcoord", &t, err)) != FFD_OK)
                    return st;
                if (has_n) {
                    if ((st = resolve(&c, in, m->normal_count, nn, "normal", &n, err)) != FFD_OK)
                        return st;
                    if (m->normal_anchors[n] == FFD_NO_ANCHOR)
                        m->normal_anchors[n] = v;
                }
                if (!ffd_mesh_push_index(m, v))
                    return ffd_fail(err, FFD_ERR_NOMEM, "%s:%zu: out of memory", name, c.line);
                corners++;
            }
            if (corners < 3)
                return ffd_fail(err, FFD_ERR_PARSE,
                                "%s:%zu: face has %zu vertices, expected at least 3", name, c.line,
                                corners);
            if (!ffd_mesh_end_face(m))
                return ffd_fail(err, FFD_ERR_NOMEM, "%s:%zu: out of memory", name, c.line);
        }
        p = e + 1;
    }
    return FFD_OK;
}

ffd_status ffd_obj_write(const ffd_mesh *m, ffd_buf *b, ffd_error *err)
{
    bool vn = m->vertex_normals && m->normal_count == m->vertex_count;
    ffd_buf_printf(b, "# written by ffdkit: %zu vertices, %zu faces\n", m->vertex_count,
                   m->face_count);
    for (size_t i = 0; i < m->vertex_count; i++) {
        ffd_buf_vec3_line(b, "v ", m->positions + 3 * i);
    }
    for (size_t i = 0; vn && i < m->normal_count; i++) {
        ffd_buf_vec3_line(b, "vn ", m->normals + 3 * i);
    }
    for (size_t f = 0; f < m->face_count && !b->oom; f++) {
        ffd_buf_puts(b, "f");
        for (uint32_t k = m->face_offsets[f]; k < m->face_offsets[f + 1]; k++) {
            uint32_t v = m->face_indices[k] + 1;
            if (vn)
                ffd_buf_printf(b, " %u//%u", v, v);
            else
                ffd_buf_printf(b, " %u", v);
        }
        ffd_buf_puts(b, "\n");
    }
    (void)err;
    return FFD_OK;
}
