/* lattice_nested — nested lattices: building the tree, keeping the
 * children's control points on their parents' maps, binding points to the
 * deepest lattice that holds them, evaluation, Jacobians and the composed
 * linear map (lattice_nested.h; SU2's parent/child FFD boxes, pyGeo's
 * child FFDs; rows as Hsu et al. 1992 eq. 2, composed through the
 * parents). */
#include "lattice/lattice_nested.h"
#include "math/tolerance.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* A child box's corners may stick out of the parent's box by this much
 * (in the parent's local coordinates) and still count as inside. */
#define NEST_TOL 1e-9

static size_t count_nodes(const ffd_rig_lattice_child *c, size_t k)
{
    size_t total = k;
    for (size_t i = 0; i < k; i++)
        total += count_nodes(c[i].children, c[i].child_count);
    return total;
}

static void local_of(const ffd_lattice *lat, const double x[3], double loc[3])
{
    double d[3];
    for (int c = 0; c < 3; c++)
        d[c] = x[c] - lat->box.origin[c];
    /* the arithmetic of ffd_lattice_bind, so that both agree on inside */
    for (int c = 0; c < 3; c++)
        loc[c] = lat->dual[c][0] * d[0] + lat->dual[c][1] * d[1] + lat->dual[c][2] * d[2];
}

static int box_holds(const ffd_lattice *lat, const double x[3], double tol)
{
    double loc[3];
    local_of(lat, x, loc);
    for (int c = 0; c < 3; c++)
        if (!(loc[c] >= -tol && loc[c] <= 1.0 + tol))
            return 0;
    return 1;
}

/* ---- composing rows ----
 * A row of a point bound to node x: the lattice's entries (slot, w) put in
 * tmp = buffer[2U, 2U + n0), turned into (control, w) sorted and merged;
 * the ancestors' part sum_j w_j emb_j accumulated by sorted merges in two
 * halves of buffer[0, 2U); then the node's own entries appended. */

static void sort_merge(uint32_t *c, double *w, size_t *k)
{
    size_t n = *k, m = 0;
    for (size_t a = 1; a < n; a++) { /* insertion sort: the rows come nearly sorted */
        uint32_t xc = c[a];
        double xw = w[a];
        size_t b = a;
        for (; b > 0 && c[b - 1] > xc; b--) {
            c[b] = c[b - 1];
            w[b] = w[b - 1];
        }
        c[b] = xc;
        w[b] = xw;
    }
    for (size_t e = 0; e < n; e++) {
        if (m && c[m - 1] == c[e]) {
            w[m - 1] += w[e];
        } else {
            c[m] = c[e];
            w[m] = w[e];
            m++;
        }
    }
    *k = m;
}

static size_t compose_row(const ffd_nested *nest, size_t x, const ffd_linear_map *m, size_t i,
                          uint32_t *cols, double *w)
{
    const ffd_nested_node *node = &nest->nodes[x];
    const size_t U = node->emb_union;
    uint32_t *tc = cols + 2 * U;
    double *tw = w + 2 * U;
    size_t k = m->row(m->self, i, tc, tw);
    for (size_t e = 0; e < k; e++)
        tc[e] = m->tie ? m->tie[tc[e]] : tc[e];
    sort_merge(tc, tw, &k);
    if (node->parent < 0)
        return k; /* U == 0: already in place */
    size_t len = 0;
    uint32_t *ac = cols, *bc = cols + U;
    double *aw = w, *bw = w + U;
    for (size_t e = 0; e < k; e++) {
        double s = tw[e];
        if (s == 0.0)
            continue;
        size_t r0 = node->emb_start[tc[e]], r1 = node->emb_start[tc[e] + 1], p = 0, q = r0, o = 0;
        while (p < len || q < r1) {
            if (q == r1 || (p < len && ac[p] < node->emb_col[q])) {
                bc[o] = ac[p];
                bw[o++] = aw[p++];
            } else if (p == len || node->emb_col[q] < ac[p]) {
                bc[o] = node->emb_col[q];
                bw[o++] = s * node->emb_w[q++];
            } else {
                bc[o] = ac[p];
                bw[o++] = aw[p++] + s * node->emb_w[q++];
            }
        }
        len = o;
        uint32_t *tcp = ac;
        ac = bc;
        bc = tcp;
        double *twp = aw;
        aw = bw;
        bw = twp;
    }
    if (ac != cols) {
        memmove(cols, ac, len * sizeof *cols);
        memmove(w, aw, len * sizeof *w);
    }
    for (size_t e = 0; e < k; e++) { /* forward: len + e <= 2U + e */
        cols[len + e] = (uint32_t)(node->first + tc[e]);
        w[len + e] = tw[e];
    }
    return len + k;
}

static size_t lattice_row_count(const ffd_lattice *lat)
{
    return lat->basis == FFD_BASIS_BSPLINE ? 64 : ffd_lattice_control_count(lat);
}

/* The embedding rows of child x: its rest control points through its parent. */
static ffd_status build_embedding(ffd_nested *nest, size_t x, ffd_error *err)
{
    ffd_nested_node *node = &nest->nodes[x];
    const ffd_nested_node *par = &nest->nodes[node->parent];
    ffd_linear_map m;
    ffd_lattice_linear_map(par->lat, node->anchor, &m);
    uint32_t *cols = ffd_malloc_array(par->row_cap, sizeof *cols);
    double *w = ffd_malloc_array(par->row_cap, sizeof *w);
    unsigned char *seen = ffd_calloc(nest->control_count ? nest->control_count : 1, 1);
    node->emb_start = ffd_malloc_array(node->count + 1, sizeof *node->emb_start);
    size_t cap = node->count * 8, used = 0;
    node->emb_col = ffd_malloc_array(cap, sizeof *node->emb_col);
    node->emb_w = ffd_malloc_array(cap, sizeof *node->emb_w);
    ffd_status st = FFD_OK;
    if (!cols || !w || !seen || !node->emb_start || !node->emb_col || !node->emb_w)
        goto oom;
    for (size_t j = 0; j < node->count; j++) {
        size_t k = compose_row(nest, (size_t)node->parent, &m, j, cols, w);
        node->emb_start[j] = used;
        if (used + k > cap) {
            size_t nc = 2 * cap + k;
            uint32_t *c2 = ffd_realloc_array(node->emb_col, nc, sizeof *c2);
            if (!c2)
                goto oom;
            node->emb_col = c2;
            double *w2 = ffd_realloc_array(node->emb_w, nc, sizeof *w2);
            if (!w2)
                goto oom;
            node->emb_w = w2;
            cap = nc;
        }
        for (size_t e = 0; e < k; e++) {
            node->emb_col[used + e] = cols[e];
            node->emb_w[used + e] = w[e];
            if (!seen[cols[e]]) {
                seen[cols[e]] = 1;
                node->emb_union++;
            }
        }
        used += k;
    }
    node->emb_start[node->count] = used;
    node->row_cap = 2 * node->emb_union + lattice_row_count(node->lat);
    goto done;
oom:
    st = ffd_fail(err, FFD_ERR_NOMEM, "nested lattices: out of memory");
done:
    ffd_free(cols);
    ffd_free(w);
    ffd_free(seen);
    return st;
}

/* ---- building the tree ---- */

typedef struct build_ctx {
    ffd_nested *nest;
    const double *rest;
    size_t n;
    const char *name;
    ffd_error *err;
} build_ctx;

static ffd_status add_children(build_ctx *b, const ffd_rig_lattice_child *children, size_t k,
                               size_t parent, const char *path);

static ffd_status add_node(build_ctx *b, const ffd_rig_lattice_child *c, size_t parent,
                           const char *path)
{
    ffd_nested *nest = b->nest;
    size_t x = nest->node_count++;
    ffd_nested_node *node = &nest->nodes[x];
    const ffd_nested_node *par = &nest->nodes[parent];
    ffd_error inner = {{0}};
    ffd_status st;
    node->parent = (int)parent;
    node->depth = par->depth + 1;
    ffd_box box = c->box;
    if (c->box_auto) {
        double *pts = ffd_malloc_array(c->vertex_count, 3 * sizeof *pts);
        if (!pts)
            return ffd_fail(b->err, FFD_ERR_NOMEM, "%s: out of memory", b->name);
        for (size_t v = 0; v < c->vertex_count; v++) {
            if (c->vertices[v] >= b->n) {
                ffd_free(pts);
                return ffd_fail(b->err, FFD_ERR_RANGE,
                                "%s: %s.vertices[%zu]: %u out of range (mesh has %zu vertices)",
                                b->name, path, v, c->vertices[v], b->n);
            }
            memcpy(pts + 3 * v, b->rest + 3 * (size_t)c->vertices[v], 3 * sizeof *pts);
        }
        st = ffd_box_fit(pts, c->vertex_count, c->margin, &box, &inner);
        ffd_free(pts);
        if (st)
            return ffd_fail(b->err, st, "%s: %s.box \"auto\": %s", b->name, path, inner.message);
    }
    if ((st = ffd_lattice_create(c->basis, &box, c->resolution, &node->lat, &inner)))
        return ffd_fail(b->err, st, "%s: %s.box: %s", b->name, path, inner.message);
    /* the child's box lies in its parent's: its eight corners */
    for (int corner = 0; corner < 8; corner++) {
        double q[3];
        for (int r = 0; r < 3; r++)
            q[r] = box.origin[r] + (corner & 1 ? box.axes[0][r] : 0) +
                   (corner & 2 ? box.axes[1][r] : 0) + (corner & 4 ? box.axes[2][r] : 0);
        if (!box_holds(par->lat, q, NEST_TOL))
            return ffd_fail(b->err, FFD_ERR_INVALID,
                            "%s: %s.box: corner [%.9g, %.9g, %.9g] is outside the parent "
                            "lattice's box (a child lattice lies inside its parent)",
                            b->name, path, q[0], q[1], q[2]);
    }
    node->count = ffd_lattice_control_count(node->lat);
    node->first = nest->control_count;
    nest->control_count += node->count;
    node->own = ffd_calloc(node->count, 3 * sizeof *node->own);
    if (!node->own)
        return ffd_fail(b->err, FFD_ERR_NOMEM, "%s: out of memory", b->name);
    /* CLAMP: a corner within NEST_TOL outside still follows the parent */
    if ((st = ffd_lattice_bind(par->lat, node->lat->P_rest, node->count, FFD_OUTSIDE_CLAMP,
                               &node->anchor, &inner)))
        return ffd_fail(b->err, st, "%s: %s: %s", b->name, path, inner.message);
    if ((st = build_embedding(nest, x, b->err)))
        return st;
    if (node->row_cap > nest->max_row)
        nest->max_row = node->row_cap;
    char sub[160];
    if (snprintf(sub, sizeof sub, "%s.children", path) < 0)
        sub[0] = 0;
    return add_children(b, c->children, c->child_count, x, sub);
}

static ffd_status add_children(build_ctx *b, const ffd_rig_lattice_child *children, size_t k,
                               size_t parent, const char *path)
{
    for (size_t i = 0; i < k; i++) {
        char sub[160];
        if (snprintf(sub, sizeof sub, "%s[%zu]", path, i) < 0)
            sub[0] = 0;
        ffd_status st = add_node(b, &children[i], parent, sub);
        if (st)
            return st;
    }
    return FFD_OK;
}

ffd_status ffd_nested_create(const ffd_rig *rig, const double *rest, size_t n, ffd_nested **out,
                             ffd_error *err)
{
    *out = NULL;
    const ffd_rig_lattice *section = ffd_rig_lattice_of(rig);
    ffd_nested *nest = ffd_calloc(1, sizeof *nest);
    size_t total = 1 + count_nodes(section->children, section->child_count);
    if (!nest || !(nest->nodes = ffd_calloc(total, sizeof *nest->nodes))) {
        ffd_free(nest);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    }
    nest->outside = rig->outside;
    nest->falloff = section->falloff;
    nest->falloff_curve = section->falloff_curve;
    ffd_error inner = {{0}};
    ffd_status st;
    ffd_box box = rig->box;
    if (rig->box_auto && (st = ffd_box_fit(rest, n, rig->margin, &box, &inner))) {
        st = ffd_rig_wrap(err, st, rig->name, "box \"auto\"", &inner);
        goto fail;
    }
    ffd_nested_node *root = &nest->nodes[0];
    if ((st = ffd_lattice_create(rig->basis, &box, rig->resolution, &root->lat, &inner))) {
        st = ffd_rig_wrap(err, st, rig->name, rig->box_auto ? "box \"auto\"" : "box", &inner);
        goto fail;
    }
    nest->node_count = 1;
    root->parent = -1;
    root->count = nest->control_count = ffd_lattice_control_count(root->lat);
    root->row_cap = nest->max_row = lattice_row_count(root->lat);
    build_ctx b = {nest, rest, n, rig->name, err};
    if ((st = add_children(&b, section->children, section->child_count, 0, "children")))
        goto fail;
    *out = nest;
    return FFD_OK;
fail:
    ffd_nested_destroy(nest);
    return st;
}

void ffd_nested_destroy(ffd_nested *nest)
{
    if (!nest)
        return;
    for (size_t x = 0; x < nest->node_count; x++) {
        ffd_nested_node *node = &nest->nodes[x];
        ffd_lattice_destroy(node->lat);
        ffd_lattice_binding_destroy(node->anchor);
        ffd_free(node->own);
        ffd_free(node->emb_start);
        ffd_free(node->emb_col);
        ffd_free(node->emb_w);
    }
    ffd_free(nest->nodes);
    ffd_free(nest);
}

/* ---- control state ---- */

/* Child x's control points: its parent's map at their rest positions plus its own. */
static ffd_status sync_node(ffd_nested *nest, size_t x, double *work, ffd_error *err)
{
    ffd_nested_node *node = &nest->nodes[x];
    ffd_status st = ffd_lattice_eval(nest->nodes[node->parent].lat, node->anchor, work, err);
    if (st)
        return st;
    for (size_t e = 0; e < 3 * node->count; e++)
        if (node->own[e] != 0.0) /* a zero own displacement keeps the parent's bits */
            work[e] += node->own[e];
    return ffd_lattice_set_control_points(node->lat, work, err);
}

static double *work_buffer(const ffd_nested *nest)
{
    size_t most = 1;
    for (size_t x = 0; x < nest->node_count; x++)
        if (nest->nodes[x].count > most)
            most = nest->nodes[x].count;
    return ffd_malloc_array(most, 3 * sizeof(double));
}

ffd_status ffd_nested_sync(ffd_nested *nest, ffd_error *err)
{
    double *work = work_buffer(nest);
    if (!work)
        return ffd_fail(err, FFD_ERR_NOMEM, "nested lattices: out of memory");
    ffd_status st = FFD_OK;
    for (size_t x = 1; x < nest->node_count && !st; x++)
        st = sync_node(nest, x, work, err);
    ffd_free(work);
    return st;
}

size_t ffd_nested_node_of_control(const ffd_nested *nest, size_t id)
{
    size_t x = 0;
    while (x + 1 < nest->node_count && nest->nodes[x + 1].first <= id)
        x++;
    return x;
}

void ffd_nested_controls(const ffd_nested *nest, double *out)
{
    for (size_t x = 0; x < nest->node_count; x++) {
        const ffd_nested_node *node = &nest->nodes[x];
        memcpy(out + 3 * node->first, ffd_lattice_control_points(node->lat),
               node->count * 3 * sizeof *out);
    }
}

void ffd_nested_variables(const ffd_nested *nest, double *out)
{
    for (size_t x = 0; x < nest->node_count; x++) {
        const ffd_nested_node *node = &nest->nodes[x];
        memcpy(out + 3 * node->first, x ? node->own : ffd_lattice_control_points(node->lat),
               node->count * 3 * sizeof *out);
    }
}

ffd_status ffd_nested_set_variables(ffd_nested *nest, const double *v, ffd_error *err)
{
    for (size_t i = 0; i < 3 * nest->control_count; i++)
        if (!isfinite(v[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "control point %zu is not finite", i / 3);
    for (size_t x = 1; x < nest->node_count; x++)
        memcpy(nest->nodes[x].own, v + 3 * nest->nodes[x].first,
               nest->nodes[x].count * 3 * sizeof *v);
    ffd_status st = ffd_lattice_set_control_points(nest->nodes[0].lat, v, err);
    return st ? st : ffd_nested_sync(nest, err);
}

ffd_status ffd_nested_set_controls(ffd_nested *nest, const uint32_t *ids, size_t k,
                                   const double *targets, ffd_error *err)
{
    for (size_t i = 0; i < k; i++) {
        if (ids[i] >= nest->control_count)
            return ffd_fail(err, FFD_ERR_RANGE, "control %u out of range (%zu controls)", ids[i],
                            nest->control_count);
        for (int c = 0; c < 3; c++)
            if (!isfinite(targets[3 * i + c]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "control %u: target is not finite",
                                ids[i]);
    }
    double *work = work_buffer(nest);
    if (!work)
        return ffd_fail(err, FFD_ERR_NOMEM, "nested lattices: out of memory");
    ffd_nested_node *root = &nest->nodes[0];
    memcpy(work, ffd_lattice_control_points(root->lat), root->count * 3 * sizeof *work);
    for (size_t i = 0; i < k; i++)
        if (ids[i] < root->count)
            memcpy(work + 3 * (size_t)ids[i], targets + 3 * i, 3 * sizeof *work);
    ffd_status st = ffd_lattice_set_control_points(root->lat, work, err);
    /* depth-first, so each parent is final before its children */
    for (size_t x = 1; x < nest->node_count && !st; x++) {
        ffd_nested_node *node = &nest->nodes[x];
        if ((st = ffd_lattice_eval(nest->nodes[node->parent].lat, node->anchor, work, err)))
            break;
        for (size_t i = 0; i < k; i++)
            if (ids[i] >= node->first && ids[i] < node->first + node->count) {
                size_t j = ids[i] - node->first;
                for (int c = 0; c < 3; c++)
                    node->own[3 * j + c] = targets[3 * i + c] - work[3 * j + c];
            }
        st = sync_node(nest, x, work, err);
    }
    ffd_free(work);
    return st;
}

ffd_status ffd_nested_move(ffd_nested *nest, size_t x, const uint32_t index[3],
                           const double delta[3], ffd_error *err)
{
    ffd_nested_node *node = &nest->nodes[x];
    if (x == 0)
        return ffd_lattice_move(node->lat, index, delta, err);
    const uint32_t *r = node->lat->res;
    if (index[0] >= r[0] || index[1] >= r[1] || index[2] >= r[2])
        return ffd_fail(err, FFD_ERR_RANGE, "control point index [%u,%u,%u] out of range (lattice "
                                            "is %ux%ux%u)",
                        index[0], index[1], index[2], r[0], r[1], r[2]);
    double *o = node->own + 3 * (((size_t)index[0] * r[1] + index[1]) * r[2] + index[2]);
    for (int c = 0; c < 3; c++)
        if (!isfinite(delta[c]) || !isfinite(o[c] + delta[c]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "control point move is not finite");
    for (int c = 0; c < 3; c++)
        o[c] += delta[c];
    return FFD_OK; /* the caller syncs once after its moves */
}

void ffd_nested_reset(ffd_nested *nest)
{
    for (size_t x = 0; x < nest->node_count; x++) {
        ffd_lattice_reset(nest->nodes[x].lat);
        if (x)
            memset(nest->nodes[x].own, 0, nest->nodes[x].count * 3 * sizeof(double));
    }
}

/* ---- binding, evaluation ---- */

void ffd_nested_binding_destroy(ffd_nested_binding *b)
{
    if (!b)
        return;
    for (size_t x = 0; x < b->node_count; x++) {
        if (b->bind)
            ffd_lattice_binding_destroy(b->bind[x]);
        if (b->index)
            ffd_free(b->index[x]);
    }
    ffd_free(b->bind);
    ffd_free(b->index);
    ffd_free(b->count);
    ffd_free(b->node_of);
    ffd_free(b->slot);
    ffd_free(b);
}

ffd_status ffd_nested_bind(const ffd_nested *nest, const double *points, size_t n,
                           ffd_nested_binding **out, ffd_error *err)
{
    *out = NULL;
    const size_t nn = nest->node_count;
    ffd_nested_binding *b = ffd_calloc(1, sizeof *b);
    double *pts = NULL;
    if (b)
        b->node_count = nn;
    ffd_status st = FFD_OK;
    if (!b || !(b->node_of = ffd_malloc_array(n ? n : 1, sizeof *b->node_of)) ||
        !(b->slot = ffd_malloc_array(n ? n : 1, sizeof *b->slot)) ||
        !(b->bind = ffd_calloc(nn, sizeof *b->bind)) ||
        !(b->index = ffd_calloc(nn, sizeof *b->index)) ||
        !(b->count = ffd_calloc(nn, sizeof *b->count)))
        goto oom;
    b->n = n;
    b->node_count = nn;
    for (size_t i = 0; i < n; i++) {
        const double *x = points + 3 * i;
        if (!(isfinite(x[0]) && isfinite(x[1]) && isfinite(x[2]))) {
            ffd_nested_binding_destroy(b);
            return ffd_fail(err, FFD_ERR_NONFINITE, "point %zu has a non-finite coordinate", i);
        }
        /* descend: the first child (in order) whose box holds the point */
        size_t at = 0;
        for (size_t y = 1; y < nn; y++) {
            const ffd_nested_node *c = &nest->nodes[y];
            if ((size_t)c->parent == at && box_holds(c->lat, x, FFD_TOL_BOUNDARY))
                at = y;
        }
        b->node_of[i] = (uint32_t)at;
        b->slot[i] = (uint32_t)b->count[at]++;
    }
    size_t most = 0;
    for (size_t x = 0; x < nn; x++) {
        if (b->count[x] > most)
            most = b->count[x];
        if (b->count[x] && !(b->index[x] = ffd_malloc_array(b->count[x], sizeof(uint32_t))))
            goto oom;
    }
    for (size_t i = 0; i < n; i++)
        b->index[b->node_of[i]][b->slot[i]] = (uint32_t)i;
    if (!(pts = ffd_malloc_array(most ? most : 1, 3 * sizeof *pts)))
        goto oom;
    for (size_t x = 0; x < nn; x++) {
        if (!b->count[x])
            continue;
        for (size_t s = 0; s < b->count[x]; s++)
            memcpy(pts + 3 * s, points + 3 * (size_t)b->index[x][s], 3 * sizeof *pts);
        /* the root with the rig's outside rule; a child holds its points
         * (the same test as the lattice's: CLAMP only guards rounding) */
        st = x == 0 && nest->outside == FFD_OUTSIDE_FALLOFF
                 ? ffd_lattice_bind_falloff(nest->nodes[0].lat, pts, b->count[0], nest->falloff,
                                            nest->falloff_curve, &b->bind[0], err)
             : x == 0 ? ffd_lattice_bind(nest->nodes[0].lat, pts, b->count[0], nest->outside,
                                         &b->bind[0], err)
                      : ffd_lattice_bind(nest->nodes[x].lat, pts, b->count[x], FFD_OUTSIDE_CLAMP,
                                       &b->bind[x], err);
        if (st) {
            ffd_free(pts);
            ffd_nested_binding_destroy(b);
            return st;
        }
    }
    ffd_free(pts);
    *out = b;
    return FFD_OK;
oom:
    ffd_free(pts);
    ffd_nested_binding_destroy(b);
    return ffd_fail(err, FFD_ERR_NOMEM, "out of memory binding %zu points", n);
}

int ffd_nested_inside(const ffd_nested_binding *b, size_t i)
{
    double stu[3];
    return b->node_of[i] != 0 || ffd_lattice_binding_params(b->bind[0], b->slot[i], stu);
}

/* Each node's points evaluated by its lattice (stride doubles a point) and scattered. */
static ffd_status eval_nodes(const ffd_nested *nest, const ffd_nested_binding *b, int jacobian,
                             double *out, ffd_error *err)
{
    const size_t stride = jacobian ? 9 : 3;
    size_t most = 1;
    for (size_t x = 0; x < nest->node_count; x++)
        if (b->count[x] > most)
            most = b->count[x];
    double *tmp = ffd_malloc_array(most, stride * sizeof *tmp);
    if (!tmp)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory evaluating %zu points", b->n);
    ffd_status st = FFD_OK;
    for (size_t x = 0; x < nest->node_count && !st; x++) {
        if (!b->count[x])
            continue;
        const ffd_lattice *lat = nest->nodes[x].lat;
        st = jacobian ? ffd_lattice_jacobian(lat, b->bind[x], tmp, err)
                      : ffd_lattice_eval(lat, b->bind[x], tmp, err);
        for (size_t s = 0; !st && s < b->count[x]; s++)
            memcpy(out + stride * b->index[x][s], tmp + stride * s, stride * sizeof *out);
    }
    ffd_free(tmp);
    return st;
}

ffd_status ffd_nested_eval(const ffd_nested *nest, const ffd_nested_binding *b, double *out,
                           ffd_error *err)
{
    return eval_nodes(nest, b, 0, out, err);
}

ffd_status ffd_nested_jacobian(const ffd_nested *nest, const ffd_nested_binding *b, double *out,
                               ffd_error *err)
{
    return eval_nodes(nest, b, 1, out, err);
}

static size_t nested_row(const void *self, size_t i, uint32_t *cols, double *w)
{
    const ffd_nested_map *nm = self;
    size_t x = nm->bind->node_of[i];
    ffd_linear_map m;
    ffd_lattice_linear_map(nm->nest->nodes[x].lat, nm->bind->bind[x], &m);
    return compose_row(nm->nest, x, &m, nm->bind->slot[i], cols, w);
}

void ffd_nested_linear_map(const ffd_nested_map *self, ffd_linear_map *map)
{
    memset(map, 0, sizeof *map);
    map->self = self;
    map->point_count = self->bind->n;
    map->column_count = self->nest->control_count;
    map->variable_count = self->nest->control_count;
    map->max_row_nnz = self->nest->max_row;
    map->row = nested_row;
}
