/* mesh — Wavefront OBJ codec: reader, writer, refinement (mesh_codec.h).
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
#include "mesh_codec.h"

#include <math.h>
#include <stdlib.h>
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
            spans[n].kind = FFD_SPAN_TEXT;
        }
        n++;
    }
}

/* Parses an optionally signed integer; 0 when none. */
/* An OBJ integer (optional sign, digits; magnitude saturated near 2^40) at
 * *pp before e: 1 and advances *pp, or 0 when none starts there. */
static int obj_parse_int(const char **pp, const char *e, long long *out)
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

static ffd_status obj_read(ffd_mesh *m, const char *name, ffd_error *err)
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
                bool ok = obj_parse_int(&r, e, &iv) == 1;
                if (ok && r < e && *r == '/') {
                    r++;
                    if (r < e && *r != '/') {
                        ok = obj_parse_int(&r, e, &it) == 1;
                        has_t = true;
                    }
                    if (ok && r < e && *r == '/') {
                        r++;
                        ok = obj_parse_int(&r, e, &in) == 1;
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

static ffd_status obj_write(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
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
            ffd_buf_put(b, " ", 1);
            ffd_buf_uint(b, v);
            if (vn) {
                ffd_buf_put(b, "//", 2);
                ffd_buf_uint(b, v);
            }
        }
        ffd_buf_puts(b, "\n");
    }
    (void)err;
    return FFD_OK;
}

/* ======================================================================
 * Refinement (see mesh_refine.c for the format-independent part)
 * ====================================================================== */

/* OBJ: new v / vt / vn records go after the last existing v / vt / vn line
 * (identical new vt / vn records are shared); the children of a face replace
 * its f line, with absolute indices in the line's corner style, the first
 * child keeping the line's trailing comment. A corner of a new vertex takes
 * the weighted vt / vn of the parent face's corners at the flattened
 * parents; a parent vertex that is not a corner of that face (an invalid
 * plan for the resampler) takes its first corner anywhere in the mesh that
 * has the attribute, else the face's first corner. A face line whose
 * corners do not all have a vt (or vn) gives children without one. l and p
 * lines with negative indices after inserted records are rewritten with
 * absolute indices; free-form statements (curv, surf, ...) are copied as
 * they are, so negative indices there would shift.
 * */

/* No vt / vn record (a corner without one, an empty hash slot). */
#define NO_RECORD UINT32_MAX
/* 64-bit FNV-1a, hashing the new vt / vn records to share identical ones. */
#define FNV_OFFSET_BASIS 1469598103934665603ull
#define FNV_PRIME 1099511628211ull
/* Corner style of a face line: every corner has a vt, every corner has a vn. */
#define FACE_HAS_VT 1u
#define FACE_HAS_VN 2u

typedef struct {
    double *val; /* 3 per record */
    uint8_t *cnt;
    size_t n, cap, cap2;
    uint32_t *tab;
    size_t tcap;
} recset;

static void recset_free(recset *r)
{
    ffd_free(r->val);
    ffd_free(r->cnt);
    ffd_free(r->tab);
}

static uint64_t rec_hash(const double *v, uint8_t cnt)
{
    uint64_t h = FNV_OFFSET_BASIS ^ cnt;
    const unsigned char *p = (const unsigned char *)v;
    for (size_t i = 0; i < cnt * sizeof(double); i++) {
        h ^= p[i];
        h *= FNV_PRIME;
    }
    return h ^ (h >> 29);
}

static bool rec_equal(const recset *r, uint32_t i, const double *v, uint8_t cnt)
{
    return r->cnt[i] == cnt && memcmp(r->val + 3 * (size_t)i, v, cnt * sizeof(double)) == 0;
}

/* Index of the record (v, cnt), added when new. */
static bool recset_add(recset *r, const double v[3], uint8_t cnt, uint32_t *index)
{
    if (r->n >= UINT32_MAX - 1)
        return false;
    if ((r->n + 1) * 2 > r->tcap) {
        size_t cap = r->tcap ? 2 * r->tcap : 64;
        uint32_t *t = ffd_malloc_array(cap, sizeof *t);
        if (!t)
            return false;
        for (size_t i = 0; i < cap; i++)
            t[i] = NO_RECORD;
        for (size_t i = 0; i < r->n; i++) {
            size_t h = (size_t)rec_hash(r->val + 3 * i, r->cnt[i]) & (cap - 1);
            while (t[h] != NO_RECORD)
                h = (h + 1) & (cap - 1);
            t[h] = (uint32_t)i;
        }
        ffd_free(r->tab);
        r->tab = t;
        r->tcap = cap;
    }
    size_t h = (size_t)rec_hash(v, cnt) & (r->tcap - 1);
    while (r->tab[h] != NO_RECORD) {
        if (rec_equal(r, r->tab[h], v, cnt)) {
            *index = r->tab[h];
            return true;
        }
        h = (h + 1) & (r->tcap - 1);
    }
    if (!ffd_grow((void **)&r->val, &r->cap, 3 * (r->n + 1), sizeof(double)) ||
        !ffd_grow((void **)&r->cnt, &r->cap2, r->n + 1, 1))
        return false;
    memcpy(r->val + 3 * r->n, v, 3 * sizeof(double));
    r->cnt[r->n] = cnt;
    r->tab[h] = (uint32_t)r->n;
    *index = (uint32_t)r->n++;
    return true;
}

typedef struct {
    ffd_refine_ctx *c;
    const char *s, *end;
    ffd_refine_extras vx;     /* v extras */
    double *vt;    /* 3 per vt record */
    uint8_t *vtn;  /* values per vt record (<= 3 kept) */
    size_t nt, vt_cap, vtn_cap;
    uint32_t *ct, *cn;    /* per original corner: vt / vn index, NONE when absent */
    uint8_t *fneg;        /* per face: negative index on its line */
    uint8_t *fstyle;      /* per face: FACE_HAS_VT | FACE_HAS_VN */
    uint32_t *first;      /* per vertex: first corner using it */
    size_t last_v, last_vt, last_vn; /* offset after the last v / vt / vn line */
    recset nvt, nvn;
    uint32_t *kt, *kn; /* per plan corner: vt / vn (NONE: none) */
} objw;

static bool kw_is(const char *q, const char *k, const char *lit)
{
    size_t n = strlen(lit);
    return (size_t)(k - q) == n && memcmp(q, lit, n) == 0;
}

/* One corner v[/[t][/n]]; false on anything else. */
static bool obj_corner(const char **pp, const char *e, long long idx[3], bool has[2])
{
    const char *p = *pp;
    has[0] = has[1] = false;
    if (!obj_parse_int(&p, e, &idx[0]))
        return false;
    if (p < e && *p == '/') {
        p++;
        if (p < e && *p != '/') {
            if (!obj_parse_int(&p, e, &idx[1]))
                return false;
            has[0] = true;
        }
        if (p < e && *p == '/') {
            p++;
            if (!obj_parse_int(&p, e, &idx[2]))
                return false;
            has[1] = true;
        }
    }
    if (p < e && !ffd_is_blank(*p) && *p != '#')
        return false;
    *pp = p;
    return true;
}

static uint32_t obj_resolve(long long idx, size_t current)
{
    long long r = idx > 0 ? idx - 1 : (long long)current + idx;
    return r < 0 || r >= (long long)UINT32_MAX ? NO_RECORD : (uint32_t)r;
}

static ffd_status obj_scan(objw *o, ffd_error *err)
{
    const ffd_mesh *m = o->c->m;
    size_t cur_v = 0, cur_t = 0, cur_n = 0, face = 0, ci = 0;
    const char *at = o->s + ffd_utf8_bom_length(o->s, (size_t)(o->end - o->s)); /* as obj_read */
    ffd_text_line l;
    while (ffd_text_next_line(&at, o->end, &l)) {
        const char *q = skip_blank(l.p, l.ce), *k = ffd_text_word_end(q, l.ce);
        const char *ce = ffd_text_hash_in(k, l.ce);
        if (kw_is(q, k, "v")) {
            if (cur_v >= m->vertex_count)
                goto mismatch;
            if (!ffd_refine_extras_add(&o->vx, cur_v, k, ce, 3))
                goto oom;
            cur_v++;
            o->last_v = (size_t)(l.next - o->s);
        } else if (kw_is(q, k, "vt")) {
            if (!ffd_grow((void **)&o->vt, &o->vt_cap, 3 * (o->nt + 1), sizeof(double)) ||
                !ffd_grow((void **)&o->vtn, &o->vtn_cap, o->nt + 1, 1))
                goto oom;
            double *v = o->vt + 3 * o->nt;
            v[0] = v[1] = v[2] = 0;
            uint8_t n = 0;
            for (const char *p = k;;) {
                p = skip_blank(p, ce);
                if (p >= ce)
                    break;
                const char *t = p;
                p = ffd_text_word_end(p, ce);
                if (n < 3)
                    v[n++] = strtod(t, NULL);
            }
            o->vtn[o->nt++] = n;
            cur_t++;
            o->last_vt = (size_t)(l.next - o->s);
        } else if (kw_is(q, k, "vn")) {
            cur_n++;
            o->last_vn = (size_t)(l.next - o->s);
        } else if (kw_is(q, k, "f")) {
            if (face >= m->face_count)
                goto mismatch;
            bool neg = false, all_t = true, all_n = true;
            for (const char *p = k;;) {
                p = skip_blank(p, l.ce);
                if (p >= l.ce || *p == '#')
                    break;
                const char *t0 = p;
                long long idx[3] = {0, 0, 0};
                bool has[2];
                if (!obj_corner(&p, l.ce, idx, has))
                    goto mismatch;
                for (const char *t = t0; t < p; t++)
                    neg = neg || *t == '-';
                uint32_t v = obj_resolve(idx[0], cur_v);
                if (ci >= m->face_offsets[face + 1] || m->face_indices[ci] != v)
                    goto mismatch;
                o->ct[ci] = has[0] ? obj_resolve(idx[1], cur_t) : NO_RECORD;
                o->cn[ci] = has[1] ? obj_resolve(idx[2], cur_n) : NO_RECORD;
                if ((has[0] && o->ct[ci] >= o->c->m->texcoord_count) ||
                    (has[1] && o->cn[ci] >= m->normal_count))
                    goto mismatch;
                all_t = all_t && has[0];
                all_n = all_n && has[1];
                ci++;
            }
            if (ci != m->face_offsets[face + 1])
                goto mismatch;
            o->fneg[face] = neg;
            o->fstyle[face] = (uint8_t)((all_t ? FACE_HAS_VT : 0) | (all_n ? FACE_HAS_VN : 0));
            face++;
        }
    }
    if (cur_v != m->vertex_count || cur_n != m->normal_count || face != m->face_count ||
        o->nt != m->texcoord_count)
        goto mismatch;
    return FFD_OK;
mismatch:
    return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: the mesh does not match its OBJ source");
oom:
    return ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_refine: out of memory");
}

/* The corner whose attr (ct or cn) a corner of vertex v in face F takes. */
static uint32_t attr_corner(const objw *o, size_t F, uint32_t v, const uint32_t *attr)
{
    const ffd_mesh *m = o->c->m;
    for (uint32_t k = m->face_offsets[F]; k < m->face_offsets[F + 1]; k++)
        if (m->face_indices[k] == v)
            return k;
    uint32_t k = o->first[v];
    if (k != NO_RECORD && attr[k] != NO_RECORD)
        return k;
    return m->face_offsets[F];
}

/* vt and vn of every corner of the plan's faces (new records as needed). */
static bool obj_corners(objw *o)
{
    const ffd_refine_ctx *c = o->c;
    const ffd_mesh *m = c->m;
    size_t ni = c->nfo ? c->p->face_offsets[c->nfo] : 0;
    o->first = ffd_malloc_array(c->nv ? c->nv : 1, sizeof *o->first);
    o->kt = ffd_malloc_array(ni ? ni : 1, sizeof *o->kt);
    o->kn = ffd_malloc_array(ni ? ni : 1, sizeof *o->kn);
    if (!o->first || !o->kt || !o->kn)
        return false;
    for (size_t i = 0; i < c->nv; i++)
        o->first[i] = NO_RECORD;
    for (size_t k = m->index_count; k-- > 0;)
        o->first[m->face_indices[k]] = (uint32_t)k;
    for (size_t f = 0; f < c->nfo; f++) {
        size_t F = c->p->face_parent[f];
        bool has_t = o->fstyle[F] & FACE_HAS_VT, has_n = o->fstyle[F] & FACE_HAS_VN;
        for (uint32_t q = c->p->face_offsets[f]; q < c->p->face_offsets[f + 1]; q++) {
            uint32_t v = c->p->face_indices[q];
            o->kt[q] = o->kn[q] = NO_RECORD;
            if (v < c->nv) {
                if (has_t)
                    o->kt[q] = o->ct[attr_corner(o, F, v, o->ct)];
                if (has_n)
                    o->kn[q] = o->cn[attr_corner(o, F, v, o->cn)];
                continue;
            }
            size_t j = v - c->nv;
            if (has_t) {
                double val[3] = {0, 0, 0};
                uint8_t cnt = 3;
                for (size_t i = c->flat_off[j]; i < c->flat_off[j + 1]; i++) {
                    uint32_t t = o->ct[attr_corner(o, F, c->flat_idx[i], o->ct)];
                    cnt = o->vtn[t] < cnt ? o->vtn[t] : cnt;
                    for (int d = 0; d < 3; d++)
                        val[d] += c->flat_w[i] * o->vt[3 * (size_t)t + (size_t)d];
                }
                for (int d = cnt; d < 3; d++)
                    val[d] = 0;
                uint32_t r;
                if (!recset_add(&o->nvt, val, cnt, &r))
                    return false;
                o->kt[q] = (uint32_t)(o->nt + r);
            }
            if (has_n) {
                double val[3] = {0, 0, 0}, len = 0;
                for (size_t i = c->flat_off[j]; i < c->flat_off[j + 1]; i++) {
                    uint32_t n = o->cn[attr_corner(o, F, c->flat_idx[i], o->cn)];
                    const double *nv = m->normals + 3 * (size_t)n;
                    for (int d = 0; d < 3; d++)
                        val[d] += c->flat_w[i] * nv[d];
                    len += c->flat_w[i] * sqrt(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]);
                }
                double l = sqrt(val[0] * val[0] + val[1] * val[1] + val[2] * val[2]);
                if (l > 0 && isfinite(l) && len > 0 && isfinite(len))
                    for (int d = 0; d < 3; d++)
                        val[d] *= len / l;
                uint32_t r;
                if (!recset_add(&o->nvn, val, 3, &r))
                    return false;
                o->kn[q] = (uint32_t)(m->normal_count + r);
            }
        }
    }
    return true;
}

/* An l or p line with absolute indices; false (nothing kept) when a token
 * is not v or v/vt. */
static bool obj_rewrite_lp(ffd_buf *b, const ffd_text_line *l, const char *k, size_t cur_v,
                           size_t cur_t, bool last, const char *nl)
{
    size_t mark = b->size;
    ffd_buf_put(b, l->p, (size_t)(k - l->p));
    const char *p = k;
    for (;;) {
        p = skip_blank(p, l->ce);
        if (p >= l->ce || *p == '#')
            break;
        long long idx[3] = {0, 0, 0};
        bool has[2];
        if (!obj_corner(&p, l->ce, idx, has) || has[1]) {
            if (!b->oom)
                b->size = mark;
            return false;
        }
        uint32_t v = obj_resolve(idx[0], cur_v);
        ffd_buf_puts(b, " ");
        ffd_buf_uint(b, (uint64_t)v + 1);
        if (has[0]) {
            ffd_buf_puts(b, "/");
            ffd_buf_uint(b, (uint64_t)obj_resolve(idx[1], cur_t) + 1);
        }
    }
    if (p < l->ce) {
        ffd_buf_puts(b, " ");
        ffd_buf_put(b, p, (size_t)(l->ce - p));
    }
    ffd_text_put_term(b, l, last, nl);
    return true;
}

static void obj_put_new_v(ffd_buf *b, const objw *o, const char *nl)
{
    const ffd_refine_ctx *c = o->c;
    for (size_t j = 0; j < c->nnew; j++) {
        ffd_buf_puts(b, "v");
        ffd_buf_xyz(b, c->pos + 3 * (c->nv + j));
        ffd_refine_put_extras(b, c, j, &o->vx, false);
        ffd_buf_puts(b, nl);
    }
}

static void obj_put_records(ffd_buf *b, const recset *r, const char *kw, const char *nl)
{
    for (size_t i = 0; i < r->n; i++) {
        ffd_buf_puts(b, kw);
        for (uint8_t d = 0; d < r->cnt[i]; d++) {
            ffd_buf_puts(b, " ");
            ffd_buf_double(b, r->val[3 * i + d]);
        }
        ffd_buf_puts(b, nl);
    }
}

static void obj_refine_lines(ffd_buf *b, const objw *o)
{
    const ffd_refine_ctx *c = o->c;
    const char *nl = c->nl;
    bool ins_v = c->nnew > 0, ins_t = o->nvt.n > 0, ins_n = o->nvn.n > 0;
    size_t cur_v = 0, cur_t = 0, face = 0;
    size_t bom = ffd_utf8_bom_length(o->s, (size_t)(o->end - o->s));
    ffd_buf_put(b, o->s, bom); /* kept, as the source's other bytes */
    const char *at = o->s + bom;
    ffd_text_line l;
    while (ffd_text_next_line(&at, o->end, &l) && !b->oom) {
        const char *q = skip_blank(l.p, l.ce), *k = ffd_text_word_end(q, l.ce);
        size_t off = (size_t)(l.p - o->s);
        bool after_v = ins_v && off >= o->last_v, after_t = ins_t && off >= o->last_vt;
        bool after_n = ins_n && off >= o->last_vn;
        if (kw_is(q, k, "f")) {
            size_t F = face++;
            bool shifted = o->fneg[F] && (after_v || after_t || after_n);
            const char *h = ffd_text_hash_in(k, l.ce);
            for (size_t f = c->child_begin[F]; f < c->child_begin[F + 1]; f++) {
                bool last = f + 1 == c->child_begin[F + 1];
                if (!shifted && ffd_refine_same_face(c, f, F)) {
                    ffd_buf_put(b, l.p, (size_t)(l.ce - l.p));
                    ffd_text_put_term(b, &l, last, nl);
                    continue;
                }
                ffd_buf_put(b, l.p, (size_t)(k - l.p));
                for (uint32_t i = c->p->face_offsets[f]; i < c->p->face_offsets[f + 1]; i++) {
                    ffd_buf_puts(b, " ");
                    ffd_buf_uint(b, (uint64_t)c->p->face_indices[i] + 1);
                    if (o->kt[i] != NO_RECORD) {
                        ffd_buf_puts(b, "/");
                        ffd_buf_uint(b, (uint64_t)o->kt[i] + 1);
                    }
                    if (o->kn[i] != NO_RECORD) {
                        ffd_buf_puts(b, o->kt[i] != NO_RECORD ? "/" : "//");
                        ffd_buf_uint(b, (uint64_t)o->kn[i] + 1);
                    }
                }
                if (f == c->child_begin[F] && h < l.ce) {
                    ffd_buf_puts(b, " ");
                    ffd_buf_put(b, h, (size_t)(l.ce - h));
                }
                ffd_text_put_term(b, &l, last, nl);
            }
            continue;
        }
        bool lp = kw_is(q, k, "l") || kw_is(q, k, "p");
        if (lp && (after_v || after_t) && memchr(k, '-', (size_t)(ffd_text_hash_in(k, l.ce) - k)) &&
            obj_rewrite_lp(b, &l, k, cur_v, cur_t, true, nl))
            continue;
        ffd_refine_put_source(b, c->m, off, (size_t)(l.next - o->s));
        bool is_v = kw_is(q, k, "v"), is_t = kw_is(q, k, "vt"), is_n = kw_is(q, k, "vn");
        cur_v += is_v;
        cur_t += is_t;
        size_t end_off = (size_t)(l.next - o->s);
        if ((is_v && ins_v && end_off == o->last_v) || (is_t && ins_t && end_off == o->last_vt) ||
            (is_n && ins_n && end_off == o->last_vn)) {
            ffd_text_ensure_lf(b, &l, nl);
            if (is_v)
                obj_put_new_v(b, o, nl);
            else if (is_t)
                obj_put_records(b, &o->nvt, "vt", nl);
            else
                obj_put_records(b, &o->nvn, "vn", nl);
        }
    }
}

static ffd_status obj_refine(ffd_refine_ctx *c, ffd_buf *b, ffd_error *err)
{
    const ffd_mesh *m = c->m;
    objw o;
    memset(&o, 0, sizeof o);
    o.c = c;
    o.s = (const char *)m->src;
    o.end = o.s + m->src_size;
    ffd_status st = FFD_OK;
    size_t ni = m->index_count ? m->index_count : 1, nf = m->face_count ? m->face_count : 1;
    o.vx.off = ffd_malloc_array(c->nv + 1, sizeof *o.vx.off);
    o.ct = ffd_malloc_array(ni, sizeof *o.ct);
    o.cn = ffd_malloc_array(ni, sizeof *o.cn);
    o.fneg = ffd_malloc(nf);
    o.fstyle = ffd_malloc(nf);
    if (!o.vx.off || !o.ct || !o.cn || !o.fneg || !o.fstyle) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_refine: out of memory");
        goto done;
    }
    o.vx.off[0] = 0;
    if ((st = obj_scan(&o, err)) != FFD_OK)
        goto done;
    if (!obj_corners(&o)) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_refine: out of memory");
        goto done;
    }
    obj_refine_lines(b, &o);
done:
    ffd_refine_extras_free(&o.vx);
    ffd_free(o.vt);
    ffd_free(o.vtn);
    ffd_free(o.ct);
    ffd_free(o.cn);
    ffd_free(o.fneg);
    ffd_free(o.fstyle);
    ffd_free(o.first);
    ffd_free(o.kt);
    ffd_free(o.kn);
    recset_free(&o.nvt);
    recset_free(&o.nvn);
    return st;
}

/* ======================================================================
 * The codec
 * ====================================================================== */

static const char *const obj_extensions[] = {"obj", NULL};

const ffd_mesh_codec ffd_mesh_codec_obj = {
    .format = FFD_FORMAT_OBJ,
    .name = "OBJ",
    .extensions = obj_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII),
    .triangles_only = false,
    .read = obj_read,
    .patch = ffd_mesh_patch_spans,
    .transcode = NULL,
    .write = obj_write,
    .refine = obj_refine,
};
