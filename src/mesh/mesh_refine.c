/* mesh — refinement: new vertices (weighted averages of earlier ones) and a
 * new face set, written in the source's own format and encoding and read
 * back (see ffd_mesh_refine in mesh.h).
 *
 * Common to every format:
 * - The plan is validated first (FFD_ERR_INVALID with the offending item).
 * - Each new vertex's weights are flattened onto original vertices
 *   (duplicates merged, exact zeros dropped); positions, per-vertex values
 *   and per-corner values of new vertices are these weighted sums.
 * - Original vertices keep their current positions and normals: the source
 *   bytes are copied with the values that changed rewritten (as a write to
 *   the same format does), so an identity plan (no new vertex, every face its
 *   own single child) reproduces the source byte for byte.
 * - A child whose corners equal its parent's (same order) is copied from the
 *   source as it stands; other children are generated.
 * - Interpolated normals (PLY nx/ny/nz, NOFF, OBJ vn) are rescaled to the
 *   weighted mean length of the parents' normals (unit parents give a unit
 *   normal); a zero average stays zero.
 * - Numbers are written as the shortest text that reads back exactly (in
 *   ascii PLY, new x y z nx ny nz at double precision whatever the type, as a
 *   deformed write does). An extra OFF vertex value (colour, texture
 *   coordinate) is rounded to an integer when all its parents' values were
 *   written as integers (OFF reads integer colours as 0..255); extra OBJ v
 *   values (colours in 0..1, w) are never rounded.
 * - Binary files: a position that does not fit the file's scalar type is
 *   FFD_ERR_RANGE (as for a deformed write).
 *
 * The format's part (how new vertices and faces are written in that
 * format's own way) is its codec's refine entry, in the format's file
 * (mesh_obj.c, mesh_ply.c, mesh_off.c, mesh_stl.c; see mesh_codec.h); this
 * file holds the format-independent plan and the helpers the codecs share.
 *
 * A mesh made by ffd_mesh_create is refined from arrays. */
#include "mesh_codec.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ======================================================================
 * Plan: validation, flattening, positions
 * ====================================================================== */

static ffd_status validate(const ffd_mesh *m, const ffd_refine_plan *p, ffd_error *err)
{
    size_t nv = m->vertex_count, nf = m->face_count, nnew = p->new_vertex_count;
    if (nnew && !p->new_vertices)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: new_vertices is NULL");
    if (nv > UINT32_MAX || nnew > (size_t)UINT32_MAX - nv)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "ffd_mesh_refine: %zu + %zu vertices do not fit 32-bit indices", nv, nnew);
    for (size_t j = 0; j < nnew; j++) {
        const ffd_refine_vertex *r = &p->new_vertices[j];
        if (r->parent_count < 1 || r->parent_count > 4)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_mesh_refine: new vertex %zu has parent_count %u, expected 1..4", j,
                            r->parent_count);
        double sum = 0;
        for (uint32_t k = 0; k < r->parent_count; k++) {
            if (r->parent[k] >= nv + j)
                return ffd_fail(err, FFD_ERR_INVALID,
                                "ffd_mesh_refine: new vertex %zu (index %zu): parent %u is not an "
                                "earlier vertex",
                                j, nv + j, r->parent[k]);
            if (!isfinite(r->weight[k]))
                return ffd_fail(err, FFD_ERR_INVALID,
                                "ffd_mesh_refine: new vertex %zu: weight %u is not finite", j, k);
            sum += r->weight[k];
        }
        if (!(fabs(sum - 1.0) <= 1e-9))
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_mesh_refine: new vertex %zu: weights sum to %.17g, expected 1", j,
                            sum);
    }
    size_t nfo = p->face_count, ntot = nv + nnew;
    if (nfo == 0) {
        if (nf)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_mesh_refine: the plan has no faces but every one of the mesh's %zu "
                            "faces needs a child",
                            nf);
        return FFD_OK;
    }
    if (!p->face_offsets || !p->face_indices || !p->face_parent)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: the plan's face arrays are NULL");
    if (p->face_offsets[0] != 0)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: face_offsets[0] must be 0");
    const ffd_mesh_codec *codec = m->src ? ffd_mesh_codec_find(m->format) : NULL;
    bool triangles = codec && codec->triangles_only;
    for (size_t f = 0; f < nfo; f++) {
        uint32_t b = p->face_offsets[f], e = p->face_offsets[f + 1];
        if (e < b || e - b < 3)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_mesh_refine: face %zu has fewer than 3 vertices", f);
        if (triangles && e - b != 3)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_mesh_refine: face %zu has %u vertices; %s faces must be triangles",
                            f, e - b, codec->name);
    }
    for (size_t i = 0; i < p->face_offsets[nfo]; i++)
        if (p->face_indices[i] >= ntot)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_mesh_refine: face index %u out of range (%zu vertices)",
                            p->face_indices[i], ntot);
    for (size_t f = 0; f < nfo; f++) {
        uint32_t par = p->face_parent[f];
        if (par >= nf)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_mesh_refine: face %zu: parent face %u out of range (%zu faces)", f,
                            par, nf);
        uint32_t want = f ? p->face_parent[f - 1] : 0;
        if (par < want)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_mesh_refine: face %zu: face_parent decreases (%u after %u); the "
                            "children of a face must be listed together, in face order",
                            f, par, want);
        if (par > want + (f ? 1u : 0u))
            return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: original face %u has no child",
                            want + (f ? 1u : 0u));
    }
    if ((size_t)p->face_parent[nfo - 1] + 1 != nf)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: original face %u has no child",
                        p->face_parent[nfo - 1] + 1);
    return FFD_OK;
}

typedef struct {
    uint32_t v;
    double w;
} wpair;

static int cmp_wpair(const void *a, const void *b)
{
    uint32_t x = ((const wpair *)a)->v, y = ((const wpair *)b)->v;
    return (x > y) - (x < y);
}

/* Flattened parents of every new vertex, the positions, the child ranges. */
static bool prepare(ffd_refine_ctx *c)
{
    const ffd_mesh *m = c->m;
    const ffd_refine_plan *p = c->p;
    size_t nv = c->nv;
    c->flat_off = ffd_malloc_array(c->nnew + 1, sizeof *c->flat_off);
    if (!c->flat_off)
        return false;
    c->flat_off[0] = 0;
    wpair *tmp = NULL;
    size_t tcap = 0, icap = 0, wcap = 0, total = 0;
    for (size_t j = 0; j < c->nnew; j++) {
        const ffd_refine_vertex *r = &p->new_vertices[j];
        size_t n = 0;
        for (uint32_t k = 0; k < r->parent_count; k++) {
            uint32_t q = r->parent[k];
            double w = r->weight[k];
            size_t b = 0, e = 0;
            if (q >= nv) {
                b = c->flat_off[q - nv];
                e = c->flat_off[q - nv + 1];
            }
            size_t need = q < nv ? n + 1 : n + (e - b);
            if (need < n || !ffd_grow((void **)&tmp, &tcap, need ? need : 1, sizeof *tmp))
                goto oom;
            if (q < nv) {
                tmp[n].v = q;
                tmp[n++].w = w;
            } else {
                for (size_t i = b; i < e; i++) {
                    tmp[n].v = c->flat_idx[i];
                    tmp[n++].w = w * c->flat_w[i];
                }
            }
        }
        if (n > 1)
            qsort(tmp, n, sizeof *tmp, cmp_wpair);
        size_t u = 0;
        for (size_t i = 0; i < n; i++) {
            if (u && tmp[u - 1].v == tmp[i].v)
                tmp[u - 1].w += tmp[i].w;
            else
                tmp[u++] = tmp[i];
        }
        size_t z = 0;
        for (size_t i = 0; i < u; i++)
            if (tmp[i].w != 0.0)
                tmp[z++] = tmp[i];
        if (z == 0)
            z = 1; /* cannot happen with weights summing to 1; keep one parent anyway */
        if (total + z < total ||
            !ffd_grow((void **)&c->flat_idx, &icap, total + z, sizeof(uint32_t)) ||
            !ffd_grow((void **)&c->flat_w, &wcap, total + z, sizeof(double)))
            goto oom;
        for (size_t i = 0; i < z; i++) {
            c->flat_idx[total + i] = tmp[i].v;
            c->flat_w[total + i] = tmp[i].w;
        }
        total += z;
        c->flat_off[j + 1] = total;
    }
    ffd_free(tmp);
    tmp = NULL;
    c->pos = ffd_malloc_array(c->ntot ? c->ntot : 1, 3 * sizeof(double));
    c->child_begin = ffd_malloc_array(c->nf + 1, sizeof *c->child_begin);
    if (!c->pos || !c->child_begin)
        return false;
    if (nv)
        memcpy(c->pos, m->positions, 3 * sizeof(double) * nv);
    for (size_t j = 0; j < c->nnew; j++)
        for (int d = 0; d < 3; d++) {
            double s = 0;
            for (size_t i = c->flat_off[j]; i < c->flat_off[j + 1]; i++)
                s += c->flat_w[i] * m->positions[3 * (size_t)c->flat_idx[i] + (size_t)d];
            c->pos[3 * (nv + j) + (size_t)d] = s;
        }
    for (size_t f = 0; f < c->nfo; f++)
        if (f == 0 || p->face_parent[f] != p->face_parent[f - 1])
            c->child_begin[p->face_parent[f]] = f;
    c->child_begin[c->nf] = c->nfo;
    return true;
oom:
    ffd_free(tmp);
    return false;
}

/* Whether plan face f lists exactly the corners of original face F. */
bool ffd_refine_same_face(const ffd_refine_ctx *c, size_t f, size_t F)
{
    const uint32_t *po = c->p->face_offsets, *mo = c->m->face_offsets;
    size_t n = po[f + 1] - po[f];
    if (n != (size_t)(mo[F + 1] - mo[F]))
        return false;
    return memcmp(c->p->face_indices + po[f], c->m->face_indices + mo[F], n * sizeof(uint32_t)) == 0;
}

/* Normal of new vertex j from per-original-vertex normals (see the header). */
void ffd_refine_blend_normals(const ffd_refine_ctx *c, size_t j, const double *normals,
                              double out[3])
{
    double len = 0;
    out[0] = out[1] = out[2] = 0;
    for (size_t i = c->flat_off[j]; i < c->flat_off[j + 1]; i++) {
        const double *n = normals + 3 * (size_t)c->flat_idx[i];
        double w = c->flat_w[i];
        for (int d = 0; d < 3; d++)
            out[d] += w * n[d];
        len += w * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    }
    double l = sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2]);
    if (l > 0 && isfinite(l) && len > 0 && isfinite(len))
        for (int d = 0; d < 3; d++)
            out[d] *= len / l;
}

static int cmp_u64(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return (a > b) - (a < b);
}

/* Edges of the plan's faces (self-loops not counted). */
bool ffd_refine_count_edges(const ffd_refine_ctx *c, size_t *edges)
{
    size_t n = c->nfo ? c->p->face_offsets[c->nfo] : 0, ne = 0;
    uint64_t *e = ffd_malloc_array(n ? n : 1, sizeof *e);
    if (!e)
        return false;
    for (size_t f = 0; f < c->nfo; f++) {
        uint32_t b = c->p->face_offsets[f], en = c->p->face_offsets[f + 1];
        for (uint32_t k = b; k < en; k++) {
            uint32_t u = c->p->face_indices[k], v = c->p->face_indices[k + 1 < en ? k + 1 : b];
            if (u == v)
                continue;
            if (u > v) {
                uint32_t t = u;
                u = v;
                v = t;
            }
            e[ne++] = ((uint64_t)u << 32) | v;
        }
    }
    qsort(e, ne, sizeof *e, cmp_u64);
    size_t u = 0;
    for (size_t i = 0; i < ne; i++)
        if (i == 0 || e[i] != e[i - 1])
            u++;
    ffd_free(e);
    *edges = u;
    return true;
}


/* ======================================================================
 * Output helpers
 * ====================================================================== */

/* A number written as an integer (the value is already integral). */
static void put_int(ffd_buf *b, double v)
{
    char t[64];
    if (v == 0)
        v = 0; /* no "-0" */
    if (fabs(v) < 1e18) {
        int n = snprintf(t, sizeof t, "%.0f", v);
        ffd_buf_put(b, t, (size_t)n);
    } else {
        ffd_buf_double(b, v);
    }
}

static size_t span_lower(const ffd_span *s, size_t n, size_t off)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (s[mid].offset < off)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

static bool span_changed(const ffd_mesh *m, const ffd_span *s, double v)
{
    double o = ffd_span_value(m, s);
    return memcmp(&o, &v, sizeof v) != 0;
}

/* Copies src[from, to) with the position and normal values that changed
 * rewritten (spans are in file order; none straddles from or to). */
void ffd_refine_put_source(ffd_buf *b, const ffd_mesh *m, size_t from, size_t to)
{
    if (to <= from)
        return;
    size_t np = m->position_spans ? 3 * m->vertex_count : 0;
    size_t nn = m->normal_spans ? 3 * m->normal_count : 0;
    size_t ip = span_lower(m->position_spans, np, from), in = span_lower(m->normal_spans, nn, from);
    if (m->encoding != FFD_ENCODING_ASCII) {
        size_t base = b->size;
        bool be = m->encoding == FFD_ENCODING_BINARY_BE;
        ffd_buf_put(b, m->src + from, to - from);
        if (b->oom)
            return;
        for (; ip < np && m->position_spans[ip].offset < to; ip++)
            if (span_changed(m, &m->position_spans[ip], m->positions[ip]))
                ffd_write_scalar(b->data + base + (m->position_spans[ip].offset - from),
                                 m->position_spans[ip].kind, be, m->positions[ip]);
        for (; in < nn && m->normal_spans[in].offset < to; in++)
            if (span_changed(m, &m->normal_spans[in], m->normals[in]))
                ffd_write_scalar(b->data + base + (m->normal_spans[in].offset - from),
                                 m->normal_spans[in].kind, be, m->normals[in]);
        return;
    }
    size_t at = from;
    for (;;) {
        bool hp = ip < np && m->position_spans[ip].offset < to;
        bool hn = in < nn && m->normal_spans[in].offset < to;
        if (!hp && !hn)
            break;
        const ffd_span *s;
        double v;
        if (hp && (!hn || m->position_spans[ip].offset < m->normal_spans[in].offset)) {
            s = &m->position_spans[ip];
            v = m->positions[ip++];
        } else {
            s = &m->normal_spans[in];
            v = m->normals[in++];
        }
        if (!span_changed(m, s, v))
            continue;
        ffd_buf_put(b, m->src + at, s->offset - at);
        ffd_buf_double(b, v);
        at = s->offset + ffd_span_length(m, s);
    }
    ffd_buf_put(b, m->src + at, to - at);
}

/* Binary sources: a changed position must fit the file's scalar type. */
ffd_status ffd_refine_check_binary_fits(const ffd_mesh *m, ffd_error *err)
{
    if (m->encoding == FFD_ENCODING_ASCII || !m->position_spans)
        return FFD_OK;
    for (size_t i = 0; i < 3 * m->vertex_count; i++)
        if (span_changed(m, &m->position_spans[i], m->positions[i]) &&
            !ffd_scalar_fits(m->position_spans[i].kind, m->positions[i]))
            return ffd_fail(err, FFD_ERR_RANGE,
                            "ffd_mesh_refine: vertex %zu: coordinate %g does not fit the file's "
                            "binary type",
                            i / 3, m->positions[i]);
    return FFD_OK;
}

void ffd_refine_flush_to(ffd_refine_cursor *k, size_t to)
{
    if (to > k->copied) {
        ffd_refine_put_source(k->b, k->m, k->copied, to);
        k->copied = to;
    }
}

static const char *detect_nl(const ffd_mesh *m)
{
    const unsigned char *nl = memchr(m->src, '\n', m->src_size);
    return nl && nl > m->src && nl[-1] == '\r' ? "\r\n" : "\n";
}

/* ---- extra per-vertex numbers of text formats (OBJ v, OFF) ------------- */

void ffd_refine_extras_free(ffd_refine_extras *x)
{
    ffd_free(x->off);
    ffd_free(x->val);
    ffd_free(x->isint);
}

static bool is_int_token(const char *t, const char *e)
{
    if (t < e && (*t == '-' || *t == '+'))
        t++;
    if (t >= e)
        return false;
    for (; t < e; t++)
        if (*t < '0' || *t > '9')
            return false;
    return true;
}

/* Appends the numbers of [p, e) after the first skip as vertex i's extras. */
bool ffd_refine_extras_add(ffd_refine_extras *x, size_t i, const char *p, const char *e,
                           size_t skip)
{
    size_t k = 0;
    for (;;) {
        while (p < e && ffd_is_blank(*p))
            p++;
        if (p >= e)
            break;
        const char *t = p;
        while (p < e && !ffd_is_blank(*p))
            p++;
        if (k++ < skip)
            continue;
        if (!ffd_grow((void **)&x->val, &x->cap, x->n + 1, sizeof(double)) ||
            !ffd_grow((void **)&x->isint, &x->cap2, x->n + 1, 1))
            return false;
        x->val[x->n] = strtod(t, NULL);
        x->isint[x->n++] = is_int_token(t, p);
    }
    x->off[i + 1] = x->n;
    return true;
}

/* " v1 v2 ..." for new vertex j: the extras its parents have in common
 * (int_rule: rounded when all parents wrote integers). */
void ffd_refine_put_extras(ffd_buf *b, const ffd_refine_ctx *c, size_t j,
                           const ffd_refine_extras *x, bool int_rule)
{
    size_t cnt = SIZE_MAX;
    for (size_t i = c->flat_off[j]; i < c->flat_off[j + 1]; i++) {
        uint32_t v = c->flat_idx[i];
        size_t n = x->off[v + 1] - x->off[v];
        cnt = n < cnt ? n : cnt;
    }
    for (size_t k = 0; k < cnt; k++) {
        double s = 0;
        bool all_int = true;
        for (size_t i = c->flat_off[j]; i < c->flat_off[j + 1]; i++) {
            size_t at = x->off[c->flat_idx[i]] + k;
            s += c->flat_w[i] * x->val[at];
            all_int = all_int && x->isint[at];
        }
        ffd_buf_puts(b, " ");
        if (int_rule && all_int && isfinite(s))
            put_int(b, nearbyint(s));
        else
            ffd_buf_double(b, s);
    }
}

const char *ffd_text_skip_blanks(const char *p, const char *e)
{
    while (p < e && ffd_is_blank(*p))
        p++;
    return p;
}

const char *ffd_text_word_end(const char *q, const char *e)
{
    while (q < e && !ffd_is_blank(*q))
        q++;
    return q;
}

const char *ffd_text_hash_in(const char *p, const char *e)
{
    const char *h = memchr(p, '#', (size_t)(e - p));
    return h ? h : e;
}

bool ffd_text_next_line(const char **at, const char *end, ffd_text_line *l)
{
    const char *p = *at;
    if (p >= end)
        return false;
    const char *e = memchr(p, '\n', (size_t)(end - p));
    if (!e)
        e = end;
    l->p = p;
    l->next = e < end ? e + 1 : end;
    l->ce = e > p && e[-1] == '\r' ? e - 1 : e;
    *at = l->next;
    return true;
}

/* Line end after a generated child: the line's own, or nl before more lines. */
static bool has_lf(const ffd_text_line *l)
{
    return l->next > l->ce && l->next[-1] == '\n';
}

void ffd_text_put_term(ffd_buf *b, const ffd_text_line *l, bool last, const char *nl)
{
    if (has_lf(l) || last)
        ffd_buf_put(b, l->ce, (size_t)(l->next - l->ce));
    else
        ffd_buf_puts(b, nl);
}

/* After a copied line, before inserted lines: a line end if it had none. */
void ffd_text_ensure_lf(ffd_buf *b, const ffd_text_line *l, const char *nl)
{
    if (!has_lf(l))
        ffd_buf_puts(b, l->next > l->ce ? "\n" : nl); /* a final lone CR gets its LF */
}


/* ======================================================================
 * Entry point
 * ====================================================================== */

ffd_status ffd_mesh_refine(const ffd_mesh *m, const ffd_refine_plan *plan, ffd_mesh **out,
                           ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: out is NULL");
    *out = NULL;
    if (!m || !plan)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: mesh or plan is NULL");
    if (m->cell_count)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "refinement (GFFD resampling) is for surface meshes: this mesh has %zu "
                        "cells, which it would not refine (docs/volume.md)",
                        m->cell_count);
    ffd_status st = validate(m, plan, err);
    if (st != FFD_OK)
        return st;
    ffd_refine_ctx c;
    memset(&c, 0, sizeof c);
    c.m = m;
    c.p = plan;
    c.nv = m->vertex_count;
    c.nnew = plan->new_vertex_count;
    c.ntot = c.nv + c.nnew;
    c.nf = m->face_count;
    c.nfo = plan->face_count;
    ffd_buf b = {0};
    if (!prepare(&c)) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_refine: out of memory");
        goto done;
    }
    if (!m->src) {
        ffd_error inner = {{0}};
        st = ffd_mesh_create(c.pos, c.ntot, c.nfo ? plan->face_offsets : NULL,
                             c.nfo ? plan->face_indices : NULL, c.nfo, out, &inner);
        if (st != FFD_OK)
            st = ffd_fail(err, st, "ffd_mesh_refine: %s", inner.message);
        goto done;
    }
    c.nl = detect_nl(m);
    const ffd_mesh_codec *codec = ffd_mesh_codec_find(m->format);
    if (codec && !codec->refine)
        st = ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s files cannot be refined (docs/volume.md)",
                      codec->name);
    else if (codec)
        st = codec->refine(&c, &b, err);
    else
        st = ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: unknown mesh format");
    if (st == FFD_OK && !b.data && !b.oom) { /* cannot happen: every format has a header */
        b.data = ffd_malloc(1);
        b.oom = !b.data;
    }
    if (st == FFD_OK && b.oom)
        st = ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_refine: out of memory writing the mesh");
    if (st != FFD_OK) {
        ffd_buf_free(&b);
        goto done;
    }
    b.data[b.size] = 0;
    {
        ffd_error inner = {{0}};
        st = ffd_mesh_read_owned(b.data, b.size, m->format, "<refined mesh>", out, &inner);
        if (st != FFD_OK)
            st = ffd_fail(err, st, "ffd_mesh_refine: the refined mesh does not read back: %s",
                          inner.message);
    }
done:
    ffd_free(c.flat_off);
    ffd_free(c.flat_idx);
    ffd_free(c.flat_w);
    ffd_free(c.pos);
    ffd_free(c.child_begin);
    return st;
}

