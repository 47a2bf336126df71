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
 * OBJ: new v / vt / vn records go after the last existing v / vt / vn line
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
 *
 * PLY: element counts rewritten in the header; new vertex records appended
 * to the vertex element (scalars interpolated, integers rounded and clamped;
 * a list property is copied from the heaviest parent); face records
 * replaced by their children, each copying its parent's other properties,
 * with the original list count and index types (a count or index that does
 * not fit them is FFD_ERR_RANGE). Other elements are copied.
 *
 * OFF: counts rewritten (the edge count is recomputed when it was not 0);
 * new vertex lines after the last vertex line; each child face line copies
 * its parent's trailing values (colour), the first also its comment.
 *
 * STL: each child facet is written in its parent's layout (ascii: the same
 * keywords, spacing and line ends; binary: the parent's attribute bytes)
 * with its normal computed from the triangle. Plans must hold triangles.
 *
 * A mesh made by ffd_mesh_create is refined from arrays. */
#include "mesh.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define NONE UINT32_MAX

/* ======================================================================
 * Plan: validation, flattening, positions
 * ====================================================================== */

typedef struct {
    const ffd_mesh *m;
    const ffd_refine_plan *p;
    size_t nv, nnew, ntot, nf, nfo; /* original/new/all vertices, original/new faces */
    size_t *flat_off;               /* nnew + 1 */
    uint32_t *flat_idx;             /* flattened parents (original vertices) */
    double *flat_w;
    double *pos;          /* 3 * ntot: current positions, then the new ones */
    size_t *child_begin;  /* nf + 1: first child of each original face */
    const char *nl;       /* line end for generated lines */
} rctx;

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
    bool stl = m->format == FFD_FORMAT_STL && m->src;
    for (size_t f = 0; f < nfo; f++) {
        uint32_t b = p->face_offsets[f], e = p->face_offsets[f + 1];
        if (e < b || e - b < 3)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_mesh_refine: face %zu has fewer than 3 vertices", f);
        if (stl && e - b != 3)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "ffd_mesh_refine: face %zu has %u vertices; STL faces must be triangles",
                            f, e - b);
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
static bool prepare(rctx *c)
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
static bool same_face(const rctx *c, size_t f, size_t F)
{
    const uint32_t *po = c->p->face_offsets, *mo = c->m->face_offsets;
    size_t n = po[f + 1] - po[f];
    if (n != (size_t)(mo[F + 1] - mo[F]))
        return false;
    return memcmp(c->p->face_indices + po[f], c->m->face_indices + mo[F], n * sizeof(uint32_t)) == 0;
}

/* Normal of new vertex j from per-original-vertex normals (see the header). */
static void blend_normals(const rctx *c, size_t j, const double *normals, double out[3])
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
static bool count_edges(const rctx *c, size_t *edges)
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

static void put_u(ffd_buf *b, uint64_t v)
{
    char t[24];
    int n = snprintf(t, sizeof t, "%llu", (unsigned long long)v);
    ffd_buf_put(b, t, (size_t)n);
}

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
static void put_src(ffd_buf *b, const ffd_mesh *m, size_t from, size_t to)
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
        at = s->offset + s->length;
    }
    ffd_buf_put(b, m->src + at, to - at);
}

/* Binary sources: a changed position must fit the file's scalar type. */
static ffd_status check_binary_fits(const ffd_mesh *m, ffd_error *err)
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

/* Output cursor over the source: flush copies (patched) up to an offset,
 * skip drops source bytes. */
typedef struct {
    ffd_buf *b;
    const ffd_mesh *m;
    size_t copied;
} cursor;

static void flush_to(cursor *k, size_t to)
{
    if (to > k->copied) {
        put_src(k->b, k->m, k->copied, to);
        k->copied = to;
    }
}

static const char *detect_nl(const ffd_mesh *m)
{
    const unsigned char *nl = memchr(m->src, '\n', m->src_size);
    return nl && nl > m->src && nl[-1] == '\r' ? "\r\n" : "\n";
}

/* ---- extra per-vertex numbers of text formats (OBJ v, OFF) ------------- */

typedef struct {
    size_t *off; /* nv + 1 */
    double *val;
    uint8_t *isint;
    size_t n, cap, cap2;
} extras;

static void extras_free(extras *x)
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
static bool extras_add(extras *x, size_t i, const char *p, const char *e, size_t skip)
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
static void put_extras(ffd_buf *b, const rctx *c, size_t j, const extras *x, bool int_rule)
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

static void put_xyz(ffd_buf *b, const double *v)
{
    for (int d = 0; d < 3; d++) {
        ffd_buf_puts(b, " ");
        ffd_buf_double(b, v[d]);
    }
}

/* Physical lines of text sources. */
typedef struct {
    const char *p;    /* line start */
    const char *ce;   /* content end (before "\r\n" / "\n") */
    const char *next; /* start of the next line */
} tline;

static bool next_line(const char **at, const char *end, tline *l)
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
static bool has_lf(const tline *l)
{
    return l->next > l->ce && l->next[-1] == '\n';
}

static void put_term(ffd_buf *b, const tline *l, bool last, const char *nl)
{
    if (has_lf(l) || last)
        ffd_buf_put(b, l->ce, (size_t)(l->next - l->ce));
    else
        ffd_buf_puts(b, nl);
}

/* After a copied line, before inserted lines: a line end if it had none. */
static void ensure_lf(ffd_buf *b, const tline *l, const char *nl)
{
    if (!has_lf(l))
        ffd_buf_puts(b, l->next > l->ce ? "\n" : nl); /* a final lone CR gets its LF */
}

/* ======================================================================
 * OBJ
 * ====================================================================== */

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
    uint64_t h = 1469598103934665603ull ^ cnt;
    const unsigned char *p = (const unsigned char *)v;
    for (size_t i = 0; i < cnt * sizeof(double); i++) {
        h ^= p[i];
        h *= 1099511628211ull;
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
            t[i] = NONE;
        for (size_t i = 0; i < r->n; i++) {
            size_t h = (size_t)rec_hash(r->val + 3 * i, r->cnt[i]) & (cap - 1);
            while (t[h] != NONE)
                h = (h + 1) & (cap - 1);
            t[h] = (uint32_t)i;
        }
        ffd_free(r->tab);
        r->tab = t;
        r->tcap = cap;
    }
    size_t h = (size_t)rec_hash(v, cnt) & (r->tcap - 1);
    while (r->tab[h] != NONE) {
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
    rctx *c;
    const char *s, *end;
    extras vx;     /* v extras */
    double *vt;    /* 3 per vt record */
    uint8_t *vtn;  /* values per vt record (<= 3 kept) */
    size_t nt, vt_cap, vtn_cap;
    uint32_t *ct, *cn;    /* per original corner: vt / vn index, NONE when absent */
    uint8_t *fneg;        /* per face: negative index on its line */
    uint8_t *fstyle;      /* per face: 1 all corners have vt, 2 all have vn */
    uint32_t *first;      /* per vertex: first corner using it */
    size_t last_v, last_vt, last_vn; /* offset after the last v / vt / vn line */
    recset nvt, nvn;
    uint32_t *kt, *kn; /* per plan corner: vt / vn (NONE: none) */
} objw;

static const char *skip_blanks(const char *p, const char *e)
{
    while (p < e && ffd_is_blank(*p))
        p++;
    return p;
}

static const char *keyword_end(const char *q, const char *e)
{
    while (q < e && !ffd_is_blank(*q))
        q++;
    return q;
}

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
    if (!ffd_obj_parse_int(&p, e, &idx[0]))
        return false;
    if (p < e && *p == '/') {
        p++;
        if (p < e && *p != '/') {
            if (!ffd_obj_parse_int(&p, e, &idx[1]))
                return false;
            has[0] = true;
        }
        if (p < e && *p == '/') {
            p++;
            if (!ffd_obj_parse_int(&p, e, &idx[2]))
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
    return r < 0 || r >= (long long)UINT32_MAX ? NONE : (uint32_t)r;
}

static const char *hash_in(const char *p, const char *e)
{
    const char *h = memchr(p, '#', (size_t)(e - p));
    return h ? h : e;
}

static ffd_status obj_scan(objw *o, ffd_error *err)
{
    const ffd_mesh *m = o->c->m;
    size_t cur_v = 0, cur_t = 0, cur_n = 0, face = 0, ci = 0;
    const char *at = o->s + ffd_utf8_bom_length(o->s, (size_t)(o->end - o->s)); /* as ffd_obj_read */
    tline l;
    while (next_line(&at, o->end, &l)) {
        const char *q = skip_blanks(l.p, l.ce), *k = keyword_end(q, l.ce);
        const char *ce = hash_in(k, l.ce);
        if (kw_is(q, k, "v")) {
            if (cur_v >= m->vertex_count)
                goto mismatch;
            if (!extras_add(&o->vx, cur_v, k, ce, 3))
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
                p = skip_blanks(p, ce);
                if (p >= ce)
                    break;
                const char *t = p;
                p = keyword_end(p, ce);
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
                p = skip_blanks(p, l.ce);
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
                o->ct[ci] = has[0] ? obj_resolve(idx[1], cur_t) : NONE;
                o->cn[ci] = has[1] ? obj_resolve(idx[2], cur_n) : NONE;
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
            o->fstyle[face] = (uint8_t)((all_t ? 1 : 0) | (all_n ? 2 : 0));
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
    if (k != NONE && attr[k] != NONE)
        return k;
    return m->face_offsets[F];
}

/* vt and vn of every corner of the plan's faces (new records as needed). */
static bool obj_corners(objw *o)
{
    const rctx *c = o->c;
    const ffd_mesh *m = c->m;
    size_t ni = c->nfo ? c->p->face_offsets[c->nfo] : 0;
    o->first = ffd_malloc_array(c->nv ? c->nv : 1, sizeof *o->first);
    o->kt = ffd_malloc_array(ni ? ni : 1, sizeof *o->kt);
    o->kn = ffd_malloc_array(ni ? ni : 1, sizeof *o->kn);
    if (!o->first || !o->kt || !o->kn)
        return false;
    for (size_t i = 0; i < c->nv; i++)
        o->first[i] = NONE;
    for (size_t k = m->index_count; k-- > 0;)
        o->first[m->face_indices[k]] = (uint32_t)k;
    for (size_t f = 0; f < c->nfo; f++) {
        size_t F = c->p->face_parent[f];
        bool has_t = o->fstyle[F] & 1, has_n = o->fstyle[F] & 2;
        for (uint32_t q = c->p->face_offsets[f]; q < c->p->face_offsets[f + 1]; q++) {
            uint32_t v = c->p->face_indices[q];
            o->kt[q] = o->kn[q] = NONE;
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
static bool obj_rewrite_lp(ffd_buf *b, const tline *l, const char *k, size_t cur_v, size_t cur_t,
                           bool last, const char *nl)
{
    size_t mark = b->size;
    ffd_buf_put(b, l->p, (size_t)(k - l->p));
    const char *p = k;
    for (;;) {
        p = skip_blanks(p, l->ce);
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
        put_u(b, (uint64_t)v + 1);
        if (has[0]) {
            ffd_buf_puts(b, "/");
            put_u(b, (uint64_t)obj_resolve(idx[1], cur_t) + 1);
        }
    }
    if (p < l->ce) {
        ffd_buf_puts(b, " ");
        ffd_buf_put(b, p, (size_t)(l->ce - p));
    }
    put_term(b, l, last, nl);
    return true;
}

static void obj_put_new_v(ffd_buf *b, const objw *o, const char *nl)
{
    const rctx *c = o->c;
    for (size_t j = 0; j < c->nnew; j++) {
        ffd_buf_puts(b, "v");
        put_xyz(b, c->pos + 3 * (c->nv + j));
        put_extras(b, c, j, &o->vx, false);
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

static void obj_write(ffd_buf *b, const objw *o)
{
    const rctx *c = o->c;
    const char *nl = c->nl;
    bool ins_v = c->nnew > 0, ins_t = o->nvt.n > 0, ins_n = o->nvn.n > 0;
    size_t cur_v = 0, cur_t = 0, face = 0;
    size_t bom = ffd_utf8_bom_length(o->s, (size_t)(o->end - o->s));
    ffd_buf_put(b, o->s, bom); /* kept, as the source's other bytes */
    const char *at = o->s + bom;
    tline l;
    while (next_line(&at, o->end, &l) && !b->oom) {
        const char *q = skip_blanks(l.p, l.ce), *k = keyword_end(q, l.ce);
        size_t off = (size_t)(l.p - o->s);
        bool after_v = ins_v && off >= o->last_v, after_t = ins_t && off >= o->last_vt;
        bool after_n = ins_n && off >= o->last_vn;
        if (kw_is(q, k, "f")) {
            size_t F = face++;
            bool shifted = o->fneg[F] && (after_v || after_t || after_n);
            const char *h = hash_in(k, l.ce);
            for (size_t f = c->child_begin[F]; f < c->child_begin[F + 1]; f++) {
                bool last = f + 1 == c->child_begin[F + 1];
                if (!shifted && same_face(c, f, F)) {
                    ffd_buf_put(b, l.p, (size_t)(l.ce - l.p));
                    put_term(b, &l, last, nl);
                    continue;
                }
                ffd_buf_put(b, l.p, (size_t)(k - l.p));
                for (uint32_t i = c->p->face_offsets[f]; i < c->p->face_offsets[f + 1]; i++) {
                    ffd_buf_puts(b, " ");
                    put_u(b, (uint64_t)c->p->face_indices[i] + 1);
                    if (o->kt[i] != NONE) {
                        ffd_buf_puts(b, "/");
                        put_u(b, (uint64_t)o->kt[i] + 1);
                    }
                    if (o->kn[i] != NONE) {
                        ffd_buf_puts(b, o->kt[i] != NONE ? "/" : "//");
                        put_u(b, (uint64_t)o->kn[i] + 1);
                    }
                }
                if (f == c->child_begin[F] && h < l.ce) {
                    ffd_buf_puts(b, " ");
                    ffd_buf_put(b, h, (size_t)(l.ce - h));
                }
                put_term(b, &l, last, nl);
            }
            continue;
        }
        bool lp = kw_is(q, k, "l") || kw_is(q, k, "p");
        if (lp && (after_v || after_t) && memchr(k, '-', (size_t)(hash_in(k, l.ce) - k)) &&
            obj_rewrite_lp(b, &l, k, cur_v, cur_t, true, nl))
            continue;
        put_src(b, c->m, off, (size_t)(l.next - o->s));
        bool is_v = kw_is(q, k, "v"), is_t = kw_is(q, k, "vt"), is_n = kw_is(q, k, "vn");
        cur_v += is_v;
        cur_t += is_t;
        size_t end_off = (size_t)(l.next - o->s);
        if ((is_v && ins_v && end_off == o->last_v) || (is_t && ins_t && end_off == o->last_vt) ||
            (is_n && ins_n && end_off == o->last_vn)) {
            ensure_lf(b, &l, nl);
            if (is_v)
                obj_put_new_v(b, o, nl);
            else if (is_t)
                obj_put_records(b, &o->nvt, "vt", nl);
            else
                obj_put_records(b, &o->nvn, "vn", nl);
        }
    }
}

static ffd_status refine_obj(rctx *c, ffd_buf *b, ffd_error *err)
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
    obj_write(b, &o);
done:
    extras_free(&o.vx);
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
 * OFF
 * ====================================================================== */

typedef struct {
    tline l;
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

static ffd_status refine_off(rctx *c, ffd_buf *b, ffd_error *err)
{
    const ffd_mesh *m = c->m;
    const char *s = (const char *)m->src, *end = s + m->src_size;
    ffd_status st = FFD_OK;
    extras vx;
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
    tline l;
    for (const char *at = s + ffd_utf8_bom_length(s, m->src_size); next_line(&at, end, &l);) {
        const char *q = skip_blanks(l.p, l.ce), *ce = hash_in(q, l.ce);
        while (ce > q && ffd_is_blank(ce[-1]))
            ce--;
        if (ce <= q)
            continue;
        const char *p = q;
        if (state == 0) {
            state = 1;
            p = skip_blanks(keyword_end(q, ce), ce);
            if (p >= ce)
                continue;
        }
        if (state == 1) {
            for (; nc < 3; nc++) {
                p = skip_blanks(p, ce);
                if (p >= ce)
                    break;
                const char *t = p;
                p = keyword_end(p, ce);
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
            if (!extras_add(&vx, vi, q, ce, skip))
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
            p = keyword_end(q, ce);
            size_t n = (size_t)(m->face_offsets[fi + 1] - m->face_offsets[fi]);
            if (strtod(q, NULL) != (double)n)
                goto mismatch;
            for (size_t i = 0; i < n; i++)
                p = keyword_end(skip_blanks(p, ce), ce);
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
    if (nc == 3 && cnt_val[2] != 0 && !count_edges(c, &edges))
        goto oom;
    double want[3] = {(double)c->ntot, (double)c->nfo,
                      nc == 3 && cnt_val[2] != 0 ? (double)edges : cnt_val[2]};
    cursor k = {b, m, 0};
    for (int i = 0; i < nc; i++)
        if (want[i] != cnt_val[i]) {
            flush_to(&k, cnt_off[i]);
            put_u(b, (uint64_t)want[i]);
            k.copied = cnt_off[i] + cnt_len[i];
        }
    flush_to(&k, last_v);
    if (c->nnew) {
        if (last_v == 0 || s[last_v - 1] != '\n')
            ffd_buf_puts(b, last_v && s[last_v - 1] == '\r' ? "\n" : c->nl);
        for (size_t j = 0; j < c->nnew; j++) {
            put_vec3(b, c->pos + 3 * (c->nv + j));
            if (normals) {
                double n[3];
                blend_normals(c, j, m->normals, n);
                put_xyz(b, n);
            }
            put_extras(b, c, j, &vx, true);
            ffd_buf_puts(b, c->nl);
        }
    }
    for (size_t F = 0; F < c->nf && !b->oom; F++) {
        const off_face *o = &faces[F];
        flush_to(&k, (size_t)(o->l.p - s));
        for (size_t f = c->child_begin[F]; f < c->child_begin[F + 1]; f++) {
            bool last = f + 1 == c->child_begin[F + 1];
            if (same_face(c, f, F)) {
                ffd_buf_put(b, o->l.p, (size_t)(o->l.ce - o->l.p));
            } else {
                ffd_buf_put(b, o->l.p, (size_t)(o->first - o->l.p));
                put_u(b, c->p->face_offsets[f + 1] - c->p->face_offsets[f]);
                for (uint32_t i = c->p->face_offsets[f]; i < c->p->face_offsets[f + 1]; i++) {
                    ffd_buf_puts(b, " ");
                    put_u(b, c->p->face_indices[i]);
                }
                const char *te = f == c->child_begin[F] ? o->l.ce : o->data_end;
                ffd_buf_put(b, o->tail, (size_t)(te - o->tail));
            }
            put_term(b, &o->l, last, c->nl);
        }
        k.copied = (size_t)(o->l.next - s);
    }
    flush_to(&k, m->src_size);
    goto done;
mismatch:
    st = ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: the mesh does not match its OFF source");
    goto done;
oom:
    st = ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_refine: out of memory");
done:
    extras_free(&vx);
    ffd_free(faces);
    return st;
}

/* ======================================================================
 * PLY
 * ====================================================================== */

typedef struct {
    const char *name;
    size_t nlen;
    int type, count_type; /* FFD_SPAN_*; count_type 0 for a scalar */
    int role;             /* 0 other, 1..3 x y z, 4..6 nx ny nz, 7 face index list */
} pprop;

typedef struct {
    const char *name;
    size_t nlen;
    uint64_t count;
    size_t coff, clen; /* the count in the header */
    pprop *props;
    size_t np, cap;
    int kind;         /* 0 other, 1 the vertex element, 2 a face element */
    size_t face_base; /* kind 2: its first face */
} pelem;

static bool pname(const char *s, size_t n, const char *lit)
{
    return strlen(lit) == n && memcmp(s, lit, n) == 0;
}

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
static ffd_status ply_parse_header(const ffd_mesh *m, pelem **out, size_t *nout, size_t *data,
                                   ffd_error *err)
{
    ply_header h;
    ffd_error inner = {{0}};
    ffd_status st = ffd_ply_parse_header(m->src, m->src_size, "<source>", &h, &inner);
    if (st != FFD_OK)
        ffd_ply_header_free(&h); /* the parser leaves what it built to the caller */
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
        if (!have_vertex && pname(e->name, e->nlen, "vertex")) {
            e->kind = 1;
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
            if (e->kind == 1 && !pr->count_type) {
                static const char *const names[6] = {"x", "y", "z", "nx", "ny", "nz"};
                for (int d = 0; d < 6; d++)
                    if (pname(pr->name, pr->nlen, names[d]))
                        pr->role = d + 1;
            }
            bool list_name = pname(pr->name, pr->nlen, "vertex_indices") ||
                             pname(pr->name, pr->nlen, "vertex_index");
            if (pname(e->name, e->nlen, "face") && pr->count_type && list_name) {
                if (e->kind == 2) {
                    pelems_free(el, h.n);
                    ffd_ply_header_free(&h);
                    return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                                    "ffd_mesh_refine: a PLY face element with two vertex index lists");
                }
                pr->role = 7;
                e->kind = 2;
            }
        }
    }
    *data = h.data;
    *out = el;
    *nout = h.n;
    ffd_ply_header_free(&h);
    return FFD_OK;
oom:
    pelems_free(el, h.n);
    ffd_ply_header_free(&h);
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
        n = snprintf(tmp, sizeof tmp, "%.0f", ffd_read_scalar(t, type, false));
    }
    ffd_buf_put(b, tmp, (size_t)n);
}

typedef struct {
    rctx *c;
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
    const rctx *c = w->c;
    const ffd_mesh *m = c->m;
    const pelem *el = w->vert;
    size_t np = el->np;
    bool normals = m->vertex_normals && m->normal_count == c->nv && m->normal_count;
    for (size_t j = 0; j < c->nnew && !b->oom; j++) {
        double n[3] = {0, 0, 0};
        if (normals)
            blend_normals(c, j, m->normals, n);
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
            if (pr->role >= 1 && pr->role <= 3)
                v = c->pos[3 * (c->nv + j) + (size_t)(pr->role - 1)];
            else if (pr->role >= 4 && pr->role <= 6)
                v = n[pr->role - 4];
            else {
                v = 0;
                for (size_t i = c->flat_off[j]; i < c->flat_off[j + 1]; i++)
                    v += c->flat_w[i] * w->vals[(size_t)c->flat_idx[i] * np + k];
            }
            bool geo = pr->role >= 1 && pr->role <= 6;
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
    const rctx *c = w->c;
    const ffd_mesh *m = c->m;
    if (same_face(c, f, c->p->face_parent[f])) {
        ffd_buf_put(b, m->src + rs, re - rs);
        return FFD_OK;
    }
    for (size_t k = 0; k < el->np; k++) {
        const pprop *pr = &el->props[k];
        if (k && w->ascii)
            ffd_buf_puts(b, " ");
        if (pr->role != 7) {
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

static ffd_status ply_write(plyw *w, ffd_buf *b, ffd_error *err)
{
    const rctx *c = w->c;
    const ffd_mesh *m = c->m;
    cursor k = {b, m, 0};
    for (size_t e = 0; e < w->nel; e++) {
        const pelem *el = &w->el[e];
        uint64_t want = el->count;
        if (el->kind == 1)
            want = c->ntot;
        else if (el->kind == 2)
            want = c->child_begin[el->face_base + el->count] - c->child_begin[el->face_base];
        if (want != el->count) {
            flush_to(&k, el->coff);
            put_u(b, want);
            k.copied = el->coff + el->clen;
        }
    }
    flush_to(&k, w->data);
    prd r = {m->src, m->src_size, w->data, w->ascii, w->be};
    ffd_status st;
    for (size_t e = 0; e < w->nel && !b->oom; e++) {
        const pelem *el = &w->el[e];
        if (el->np == 0)
            continue;
        for (uint64_t i = 0; i < el->count; i++) {
            if (el->kind == 2 && w->ascii)
                while (r.pos < r.size && ffd_is_space(r.s[r.pos]))
                    r.pos++;
            size_t rs = r.pos;
            if (!prd_record(&r, el, NULL, el->kind == 2 ? w->rng : NULL))
                return ffd_fail(err, FFD_ERR_INVALID,
                                "ffd_mesh_refine: the mesh does not match its PLY source");
            if (el->kind != 2)
                continue;
            size_t F = el->face_base + (size_t)i;
            flush_to(&k, rs);
            for (size_t f = c->child_begin[F]; f < c->child_begin[F + 1]; f++) {
                if (f > c->child_begin[F] && w->ascii)
                    ffd_buf_puts(b, c->nl);
                if ((st = ply_child(w, b, el, f, rs, r.pos, err)) != FFD_OK)
                    return st;
            }
            k.copied = r.pos;
        }
        if (el->kind == 1) {
            flush_to(&k, r.pos);
            if ((st = ply_new_vertices(w, b, err)) != FFD_OK)
                return st;
        }
    }
    flush_to(&k, m->src_size);
    return FFD_OK;
}

static ffd_status refine_ply(rctx *c, ffd_buf *b, ffd_error *err)
{
    const ffd_mesh *m = c->m;
    plyw w;
    memset(&w, 0, sizeof w);
    w.c = c;
    w.ascii = m->encoding == FFD_ENCODING_ASCII;
    w.be = m->encoding == FFD_ENCODING_BINARY_BE;
    ffd_status st = check_binary_fits(m, err);
    if (st != FFD_OK)
        return st;
    if ((st = ply_parse_header(m, &w.el, &w.nel, &w.data, err)) != FFD_OK)
        return st;
    size_t maxnp = 1, faces = 0;
    for (size_t e = 0; e < w.nel; e++) {
        pelem *el = &w.el[e];
        maxnp = el->np > maxnp ? el->np : maxnp;
        if (el->kind == 1)
            w.vert = el;
        if (el->kind == 2 && el->np) {
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
    st = ply_write(&w, b, err);
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
 * STL
 * ====================================================================== */

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
    q = skip_word(s, m->src_size, skip_word(s, m->src_size, last->offset + last->length));
    while (q < m->src_size && ffd_is_blank(s[q]) && s[q] != '\r')
        q++;
    if (q + 1 < m->src_size && s[q] == '\r' && s[q + 1] == '\n')
        q += 2;
    else if (q < m->src_size && s[q] == '\n')
        q++;
    *fe = q;
}

static ffd_status refine_stl(rctx *c, ffd_buf *b, ffd_error *err)
{
    const ffd_mesh *m = c->m;
    if (!m->facet_normals || m->normal_count != c->nf || !m->normal_spans || !m->position_spans)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: the mesh does not match its STL source");
    if (c->nfo > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_RANGE, "ffd_mesh_refine: %zu triangles do not fit in binary STL",
                        c->nfo);
    ffd_status st = check_binary_fits(m, err);
    if (st != FFD_OK)
        return st;
    bool binary = m->encoding != FFD_ENCODING_ASCII;
    if (binary && m->src_size != 84 + 50 * c->nf)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: the mesh does not match its STL source");
    cursor k = {b, m, 0};
    if (binary) {
        unsigned char cnt[4];
        ffd_buf_put(b, m->src, 80);
        ffd_write_scalar(cnt, FFD_SPAN_U32, false, (double)c->nfo);
        ffd_buf_put(b, cnt, 4);
    }
    for (size_t F = 0; F < c->nf && !b->oom; F++) {
        size_t fs = 84 + 50 * F, fe = fs + 50;
        if (!binary) {
            stl_facet_range(m, F, &fs, &fe);
            if (fs < k.copied)
                fs = k.copied;
            flush_to(&k, fs);
        }
        for (size_t f = c->child_begin[F]; f < c->child_begin[F + 1]; f++) {
            if (same_face(c, f, F)) {
                put_src(b, m, fs, fe);
                continue;
            }
            const uint32_t *ix = c->p->face_indices + c->p->face_offsets[f];
            double v[12];
            ffd_triangle_normal(c->pos + 3 * (size_t)ix[0], c->pos + 3 * (size_t)ix[1],
                                c->pos + 3 * (size_t)ix[2], v);
            for (int t = 0; t < 3; t++)
                memcpy(v + 3 + 3 * t, c->pos + 3 * (size_t)ix[t], 3 * sizeof(double));
            if (binary) {
                for (int i = 0; i < 12; i++) {
                    unsigned char t4[4];
                    if (!ffd_scalar_fits(FFD_SPAN_F32, v[i]))
                        return ffd_fail(err, FFD_ERR_RANGE,
                                        "ffd_mesh_refine: face %zu: coordinate %g does not fit "
                                        "binary STL's float32",
                                        f, v[i]);
                    ffd_write_scalar(t4, FFD_SPAN_F32, false, v[i]);
                    ffd_buf_put(b, t4, 4);
                }
                ffd_buf_put(b, m->src + fs + 48, 2);
                continue;
            }
            /* the parent's text with its 12 numbers replaced */
            const ffd_span *sp[12];
            for (int d = 0; d < 3; d++)
                sp[d] = &m->normal_spans[3 * F + (size_t)d];
            for (int t = 0; t < 3; t++)
                for (int d = 0; d < 3; d++)
                    sp[3 + 3 * t + d] =
                        &m->position_spans[3 * (size_t)m->face_indices[m->face_offsets[F] + (uint32_t)t] +
                                           (size_t)d];
            for (int i = 1; i < 12; i++) /* file order (it is already, normally) */
                for (int j = i; j > 0 && sp[j - 1]->offset > sp[j]->offset; j--) {
                    const ffd_span *ts = sp[j];
                    double tv = v[j];
                    sp[j] = sp[j - 1];
                    v[j] = v[j - 1];
                    sp[j - 1] = ts;
                    v[j - 1] = tv;
                }
            size_t at = fs;
            for (int i = 0; i < 12; i++) {
                if (sp[i]->offset < at || sp[i]->offset + sp[i]->length > fe)
                    return ffd_fail(err, FFD_ERR_INVALID,
                                    "ffd_mesh_refine: the mesh does not match its STL source");
                ffd_buf_put(b, m->src + at, sp[i]->offset - at);
                ffd_buf_double(b, v[i]);
                at = sp[i]->offset + sp[i]->length;
            }
            ffd_buf_put(b, m->src + at, fe - at);
        }
        k.copied = fe;
    }
    if (!binary)
        flush_to(&k, m->src_size);
    return FFD_OK;
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
    ffd_status st = validate(m, plan, err);
    if (st != FFD_OK)
        return st;
    rctx c;
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
    switch (m->format) {
    case FFD_FORMAT_OBJ: st = refine_obj(&c, &b, err); break;
    case FFD_FORMAT_PLY: st = refine_ply(&c, &b, err); break;
    case FFD_FORMAT_OFF: st = refine_off(&c, &b, err); break;
    case FFD_FORMAT_STL: st = refine_stl(&c, &b, err); break;
    default: st = ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_refine: unknown mesh format"); break;
    }
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
