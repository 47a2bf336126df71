/* lattice_nested_session — the deformer of a lattice rig with "children"
 * (nested lattices, lattice_nested.h) for the editor and ffd_deformer:
 * the controls are every lattice's control points, the root's then each
 * child's depth-first; dragging a root point carries its children's points
 * along, dragging a child point changes its own displacement only. Its rig
 * is the root's box and moves plus each child with its box made explicit
 * and its own moves (lattice_nested_rig_json.c writes it). */
#include "lattice/lattice_nested.h"
#include "session/session.h"

#include <string.h>

typedef struct nested_method {
    sess_method base;
    ffd_nested *nest;
    ffd_nested_binding *binding;
    double margin;
    double *begin; /* variables at the start of a drag */
    ffd_nested_map map;
} nested_method;

static nested_method *as_nested(const sess_method *m)
{
    return (nested_method *)(void *)m;
}

static void nm_destroy(sess_method *m)
{
    nested_method *l = as_nested(m);
    ffd_nested_binding_destroy(l->binding);
    ffd_nested_destroy(l->nest);
    ffd_free(l->begin);
    ffd_free(l);
}

static ffd_status nm_eval(sess_method *m, double *out, ffd_error *err)
{
    nested_method *l = as_nested(m);
    return ffd_nested_eval(l->nest, l->binding, out, err);
}

static size_t nm_count(const sess_method *m)
{
    return as_nested(m)->nest->control_count;
}

static void nm_controls(const sess_method *m, double *out)
{
    ffd_nested_controls(as_nested(m)->nest, out);
}

/* The tree for the editor: each lattice's first control, count, depth and
 * resolution (it draws the children in their own colour). */
static cJSON *lattices_json(const ffd_nested *nest)
{
    cJSON *a = cJSON_CreateArray();
    for (size_t x = 0; a && x < nest->node_count; x++) {
        const ffd_nested_node *node = &nest->nodes[x];
        cJSON *o = cJSON_CreateObject();
        if (!ffd_sess_add_to_array(a, o) ||
            !cJSON_AddNumberToObject(o, "first", (double)node->first) ||
            !cJSON_AddNumberToObject(o, "count", (double)node->count) ||
            !cJSON_AddNumberToObject(o, "depth", node->depth) ||
            !cJSON_AddNumberToObject(o, "parent", node->parent) ||
            !ffd_sess_add_item(o, "resolution", ffd_sess_uint_array(node->lat->res, 3))) {
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}

static ffd_status nm_describe(const sess_method *m, cJSON *params, cJSON *controls,
                              ffd_error *err)
{
    static const char *const basis_names[] = {"bspline", "bernstein"};
    static const char *const outside_names[] = {"fixed", "clamp", "extrapolate", "falloff"};
    const nested_method *l = as_nested(m);
    const ffd_lattice *root = l->nest->nodes[0].lat;
    const char *basis = basis_names[root->basis == FFD_BASIS_BERNSTEIN];
    size_t ne = 0;
    uint32_t *e = ffd_nested_edges(l->nest, &ne);
    cJSON *edges = cJSON_CreateArray();
    int ok = e && edges && cJSON_AddItemToObject(controls, "edges", edges);
    if (!ok)
        cJSON_Delete(edges);
    for (size_t k = 0; ok && k < ne; k++)
        ok = ffd_sess_add_edge(edges, e[2 * k], e[2 * k + 1]);
    ffd_free(e);
    ok = ok && ffd_sess_add_item(params, "resolution", ffd_sess_uint_array(root->res, 3)) &&
         cJSON_AddStringToObject(params, "basis", basis) &&
         cJSON_AddNumberToObject(params, "margin", l->margin) &&
         cJSON_AddStringToObject(params, "outside", outside_names[l->nest->outside]) &&
         ffd_sess_add_item(controls, "resolution", ffd_sess_uint_array(root->res, 3)) &&
         cJSON_AddStringToObject(controls, "basis", basis) &&
         ffd_sess_add_item(controls, "lattices", lattices_json(l->nest));
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
}

static ffd_status nm_begin(sess_method *m, const uint32_t *ids, size_t k, int arap,
                           ffd_error *err)
{
    nested_method *l = as_nested(m);
    (void)ids, (void)k, (void)arap;
    ffd_free(l->begin);
    l->begin = ffd_malloc_array(nm_count(m), 3 * sizeof *l->begin);
    if (!l->begin)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag_begin: out of memory");
    ffd_nested_variables(l->nest, l->begin);
    return FFD_OK;
}

static ffd_status nm_set_controls(sess_method *m, const uint32_t *ids, size_t k,
                                  const double *targets, ffd_error *err)
{
    nested_method *l = as_nested(m);
    ffd_status st = l->begin ? ffd_nested_set_variables(l->nest, l->begin, err) : FFD_OK;
    return st ? st : ffd_nested_set_controls(l->nest, ids, k, targets, err);
}

static ffd_status nm_linear_map(sess_method *m, ffd_linear_map *map, ffd_error *err)
{
    nested_method *l = as_nested(m);
    (void)err;
    l->map.nest = l->nest;
    l->map.bind = l->binding;
    ffd_nested_linear_map(&l->map, map);
    return FFD_OK;
}

static ffd_status nm_set_variables(sess_method *m, const double *dv, ffd_error *err)
{
    nested_method *l = as_nested(m);
    size_t c = nm_count(m);
    double *v = ffd_malloc_array(c, 3 * sizeof *v);
    if (!v)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    if (l->begin)
        memcpy(v, l->begin, c * 3 * sizeof *v);
    else
        ffd_nested_variables(l->nest, v);
    for (size_t i = 0; i < 3 * c; i++)
        v[i] += dv[i];
    ffd_status st = ffd_nested_set_variables(l->nest, v, err);
    ffd_free(v);
    return st;
}

static void nm_end(sess_method *m, int commit)
{
    nested_method *l = as_nested(m);
    if (!commit && l->begin)
        ffd_nested_set_variables(l->nest, l->begin, NULL);
    ffd_free(l->begin);
    l->begin = NULL;
}

static ffd_status nm_snapshot(const sess_method *m, void **blob, ffd_error *err)
{
    size_t c = nm_count(m);
    double *copy = ffd_malloc_array(c + 1, 3 * sizeof *copy);
    if (!copy)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the undo history");
    copy[0] = (double)c;
    ffd_nested_variables(as_nested(m)->nest, copy + 3);
    *blob = copy;
    return FFD_OK;
}

static ffd_status nm_restore(sess_method *m, const void *blob, ffd_error *err)
{
    const double *copy = blob;
    if ((size_t)copy[0] != nm_count(m))
        return ffd_fail(err, FFD_ERR_INVALID, "undo: the history does not match the lattices");
    return ffd_nested_set_variables(as_nested(m)->nest, copy + 3, err);
}

static ffd_status nm_reset(sess_method *m, ffd_error *err)
{
    (void)err;
    ffd_nested_reset(as_nested(m)->nest);
    return FFD_OK;
}

/* One move per control point whose displacement (root: from rest; child:
 * its own) is not zero; *moves allocated. */
static int node_moves(const ffd_nested *nest, size_t x, ffd_rig_move **moves, size_t *count)
{
    const ffd_nested_node *node = &nest->nodes[x];
    const uint32_t *r = node->lat->res;
    *count = 0;
    *moves = ffd_malloc_array(node->count ? node->count : 1, sizeof **moves);
    if (!*moves)
        return 0;
    for (size_t j = 0; j < node->count; j++) {
        double d[3];
        for (int c = 0; c < 3; c++)
            d[c] = x ? node->own[3 * j + c] : node->lat->P[3 * j + c] - node->lat->P_rest[3 * j + c];
        if (d[0] == 0 && d[1] == 0 && d[2] == 0)
            continue;
        ffd_rig_move *mv = &(*moves)[(*count)++];
        memcpy(mv->delta, d, sizeof d);
        mv->index[0] = (uint32_t)(j / ((size_t)r[1] * r[2]));
        mv->index[1] = (uint32_t)(j / r[2] % r[1]);
        mv->index[2] = (uint32_t)(j % r[2]);
    }
    return 1;
}

static ffd_status nm_rig(const sess_method *m, cJSON *root, ffd_error *err)
{
    const nested_method *l = as_nested(m);
    const ffd_nested *nest = l->nest;
    const size_t nn = nest->node_count;
    ffd_rig rig;
    ffd_rig_lattice section;
    ffd_rig_view(&rig, &ffd_method_lattice, &section, sizeof section);
    section.falloff = nest->falloff;
    section.falloff_curve = nest->falloff_curve;
    rig.basis = nest->nodes[0].lat->basis;
    rig.outside = nest->outside;
    ffd_lattice_resolution(nest->nodes[0].lat, rig.resolution);
    ffd_lattice_box(nest->nodes[0].lat, &rig.box);
    /* the children of each node take consecutive slots of all[], in order */
    ffd_rig_lattice_child *all = ffd_calloc(nn, sizeof *all);
    size_t *start = ffd_calloc(nn + 1, sizeof *start), *used = ffd_calloc(nn, sizeof *used);
    int ok = all && start && used && node_moves(nest, 0, &rig.moves, &rig.move_count);
    if (ok) {
        for (size_t x = 1; x < nn; x++)
            start[nest->nodes[x].parent + 1]++;
        for (size_t x = 0; x < nn; x++)
            start[x + 1] += start[x];
        for (size_t x = 1; ok && x < nn; x++) {
            const ffd_nested_node *node = &nest->nodes[x];
            size_t p = (size_t)node->parent;
            ffd_rig_lattice_child *c = &all[start[p] + used[p]++];
            c->basis = node->lat->basis;
            ffd_lattice_resolution(node->lat, c->resolution);
            ffd_lattice_box(node->lat, &c->box);
            c->children = all + start[x];
            c->child_count = start[x + 1] - start[x];
            ok = node_moves(nest, x, &c->moves, &c->move_count);
        }
        section.children = all;
        section.child_count = start[1];
    }
    ok = ok && ffd_method_lattice.write(&rig, root);
    for (size_t x = 0; all && x < nn; x++)
        ffd_free(all[x].moves);
    ffd_free(all);
    ffd_free(start);
    ffd_free(used);
    ffd_free(rig.moves);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
}

static ffd_status nm_influence(sess_method *m, const uint32_t *ids, size_t k, float *w,
                               ffd_error *err)
{
    ffd_linear_map map;
    ffd_status st = nm_linear_map(m, &map, err);
    return st ? st : ffd_sess_map_influence(&map, 0, m->ctx->n, ids, k, w, err);
}

static ffd_status nm_op(sess_method *m, const char *op, const cJSON *body, int *undo_kind,
                        ffd_error *err)
{
    (void)m, (void)body, (void)undo_kind;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not a lattice operation", op);
}

/* ---- any point set (ffd_deformer_bind): the tree never changes shape ---- */

struct sess_binding {
    ffd_nested_binding *nested;
    ffd_nested_map map;
};

static ffd_status nm_bind(sess_method *m, const double *points, size_t n, sess_binding **out,
                          ffd_error *err)
{
    nested_method *l = as_nested(m);
    sess_binding *b = ffd_calloc(1, sizeof *b);
    if (!b)
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    ffd_error inner = {{0}};
    ffd_status st = ffd_nested_bind(l->nest, points, n, &b->nested, &inner);
    if (st) {
        ffd_free(b);
        return ffd_fail(err, st, "bind: %s", inner.message);
    }
    *out = b;
    return FFD_OK;
}

static void nm_binding_free(sess_binding *b)
{
    if (!b)
        return;
    ffd_nested_binding_destroy(b->nested);
    ffd_free(b);
}

static ffd_status nm_eval_points(sess_method *m, const sess_binding *b, double *out,
                                 ffd_error *err)
{
    return ffd_nested_eval(as_nested(m)->nest, b->nested, out, err);
}

static ffd_status nm_jacobian_points(sess_method *m, const sess_binding *b, double *out,
                                     ffd_error *err)
{
    return ffd_nested_jacobian(as_nested(m)->nest, b->nested, out, err);
}

/* The composed rows (lattice_nested.c); the map borrows the binding. */
static ffd_status nm_map_points(sess_method *m, const sess_binding *b, ffd_linear_map *map,
                                ffd_error *err)
{
    sess_binding *mb = (sess_binding *)b;
    (void)err;
    mb->map.nest = as_nested(m)->nest;
    mb->map.bind = b->nested;
    ffd_nested_linear_map(&mb->map, map);
    return FFD_OK;
}

static void *nm_handle(sess_method *m)
{
    return as_nested(m)->nest->nodes[0].lat; /* the root lattice */
}

static const sess_vtable nested_vtable = {
    .name = "lattice",
    .destroy = nm_destroy,
    .eval = nm_eval,
    .control_count = nm_count,
    .controls = nm_controls,
    .describe = nm_describe,
    .begin = nm_begin,
    .set_controls = nm_set_controls,
    .linear_map = nm_linear_map,
    .set_variables = nm_set_variables,
    .move_by_variables = 1,
    .end = nm_end,
    .snapshot = nm_snapshot,
    .restore = nm_restore,
    .snapshot_free = ffd_free,
    .reset = nm_reset,
    .rig = nm_rig,
    .influence = nm_influence,
    .op = nm_op,
    .bind = nm_bind,
    .binding_free = nm_binding_free,
    .eval_points = nm_eval_points,
    .jacobian_points = nm_jacobian_points,
    .map_points = nm_map_points,
    .handle = nm_handle,
};

/* The tree over the session's rest mesh, with the rig's moves and
 * constraints replayed as ffd deform applies them (lattice_nested_rig.c),
 * then every control point set to where the replay left it. */
ffd_status ffd_sess_lattice_nested_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                                        ffd_error *err)
{
    nested_method *l = ffd_calloc(1, sizeof *l);
    if (!l)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    l->base.vt = &nested_vtable;
    l->base.ctx = ctx;
    l->margin = rig->margin;
    ffd_rig_report report = {0};
    uint32_t *ids = NULL;
    ffd_error inner = {{0}};
    /* the replay first (it charges the limits before anything large is
     * built); always: besides the root's moves and constraints, any child
     * may hold moves */
    ffd_status st = ffd_sess_apply_rig(ctx, rig, &report, err);
    if (!st)
        st = ffd_sess_check_controls(ctx, (double)report.control_count, rig->name, err);
    if (!st)
        st = ffd_nested_create(rig, ctx->rest, ctx->n, &l->nest, err);
    if (!st && (st = ffd_nested_bind(l->nest, ctx->rest, ctx->n, &l->binding, &inner)))
        st = ffd_fail(err, st, "%s: %s", rig->name, inner.message);
    if (!st) {
        size_t c = l->nest->control_count;
        if (report.control_count != c)
            st = ffd_fail(err, FFD_ERR_INVALID, "%s: the rig's lattices do not match", rig->name);
        else if (!(ids = ffd_malloc_array(c, sizeof *ids)))
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
        for (size_t i = 0; !st && i < c; i++)
            ids[i] = (uint32_t)i;
        if (!st)
            st = ffd_nested_set_controls(l->nest, ids, c, report.control_points, err);
    }
    ffd_free(ids);
    ffd_rig_report_free(&report);
    if (st) {
        nm_destroy(&l->base);
        return st;
    }
    *out = &l->base;
    return FFD_OK;
}
