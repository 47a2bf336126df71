/* session_lattice — the lattice method of the editor (Sederberg-Parry /
 * B-spline lattice, Hsu et al. direct manipulation): control points are the
 * lattice's l*m*n points; its rig is the box made explicit plus one move per
 * displaced control point (delta = current - rest). */
#include "lattice/lattice.h"
#include "lattice/lattice_method.h"
#include "lattice/lattice.h"
#include "session/session.h"

#include <string.h>

typedef struct lattice_method {
    sess_method base;
    ffd_lattice *lattice;
    ffd_lattice_binding *binding;
    ffd_outside outside;
    double falloff;                  /* outside "falloff": the distance and curve */
    ffd_falloff_curve falloff_curve;
    double margin;
    double *begin;   /* control points at the start of a drag */
} lattice_method;

static const char *const basis_names[] = {"bspline", "bernstein", NULL};
static const char *const outside_names[] = {"fixed", "clamp", "extrapolate", "falloff", NULL};

/* Binds points with the lattice's outside rule (and its falloff). */
static ffd_status bind_points(const lattice_method *l, const double *points, size_t n,
                              ffd_lattice_binding **out, ffd_error *err)
{
    if (l->outside == FFD_OUTSIDE_FALLOFF)
        return ffd_lattice_bind_falloff(l->lattice, points, n, l->falloff, l->falloff_curve, out,
                                        err);
    return ffd_lattice_bind(l->lattice, points, n, l->outside, out, err);
}

static lattice_method *as_lattice(const sess_method *m)
{
    return (lattice_method *)(void *)m;
}

static void lat_destroy(sess_method *m)
{
    lattice_method *l = as_lattice(m);
    ffd_lattice_binding_destroy(l->binding);
    ffd_lattice_destroy(l->lattice);
    ffd_free(l->begin);
    ffd_free(l);
}

static ffd_status lat_eval(sess_method *m, double *out, ffd_error *err)
{
    lattice_method *l = as_lattice(m);
    return ffd_lattice_eval(l->lattice, l->binding, out, err);
}

static size_t lat_count(const sess_method *m)
{
    return ffd_lattice_control_count(as_lattice(m)->lattice);
}

static void lat_controls(const sess_method *m, double *out)
{
    const ffd_lattice *lat = as_lattice(m)->lattice;
    memcpy(out, ffd_lattice_control_points(lat), lat_count(m) * 3 * sizeof *out);
}

static ffd_status lat_describe(const sess_method *m, cJSON *params, cJSON *controls,
                               ffd_error *err)
{
    const lattice_method *l = as_lattice(m);
    uint32_t r[3];
    ffd_lattice_resolution(l->lattice, r);
    const char *basis = basis_names[ffd_lattice_basis(l->lattice) == FFD_BASIS_BERNSTEIN];
    cJSON *edges = cJSON_CreateArray();
    int ok = edges && cJSON_AddItemToObject(controls, "edges", edges);
    if (!ok)
        cJSON_Delete(edges);
    /* the variant (docs/lattice-variants.md): interpolation per axis, coordinates;
     * a closed theta axis also joins its last ring to its first */
    static const char *const interp_names[] = {"bspline", "linear", "cardinal", "catmull-rom",
                                               "bspline", "bernstein"};
    static const char *const coordinate_names[] = {"cartesian", "cylindrical", "spherical"};
    ffd_lattice_shape shape;
    ffd_lattice_get_shape(l->lattice, &shape);
    const int closed = l->lattice->gen && ffd_lattice_general_axis(l->lattice, 1)->periodic;
    for (uint32_t i = 0; ok && i < r[0]; i++)
        for (uint32_t j = 0; ok && j < r[1]; j++)
            for (uint32_t k = 0; ok && k < r[2]; k++) {
                uint32_t id = (i * r[1] + j) * r[2] + k;
                ok = (i + 1 == r[0] || ffd_sess_add_edge(edges, id, id + r[1] * r[2])) &&
                     (j + 1 == r[1] || ffd_sess_add_edge(edges, id, id + r[2])) &&
                     (k + 1 == r[2] || ffd_sess_add_edge(edges, id, id + 1)) &&
                     (!closed || j + 1 != r[1] || ffd_sess_add_edge(edges, id, i * r[1] * r[2] + k));
            }
    cJSON *interp = ok ? cJSON_CreateArray() : NULL;
    ok = ok && ffd_sess_add_item(params, "interpolation", interp);
    for (int a = 0; ok && a < 3; a++) {
        ffd_interp it = shape.interp[a];
        const char *name = it == FFD_INTERP_DEFAULT ? basis : interp_names[it];
        ok = ffd_sess_add_to_array(interp, cJSON_CreateString(name));
    }
    ok = ok && ffd_sess_add_item(params, "tension", ffd_sess_vec3(shape.tension)) &&
         ffd_sess_add_item(params, "continuity", ffd_sess_vec3(shape.continuity)) &&
         cJSON_AddStringToObject(params, "coordinates", coordinate_names[shape.coordinates]);
    ok = ok && ffd_sess_add_item(params, "resolution", ffd_sess_uint_array(r, 3)) &&
         cJSON_AddStringToObject(params, "basis", basis) &&
         cJSON_AddNumberToObject(params, "margin", l->margin) &&
         cJSON_AddStringToObject(params, "outside", outside_names[l->outside]) &&
         (l->outside != FFD_OUTSIDE_FALLOFF ||
          cJSON_AddNumberToObject(params, "falloff", l->falloff)) &&
         ffd_sess_add_item(controls, "resolution", ffd_sess_uint_array(r, 3)) &&
         cJSON_AddStringToObject(controls, "basis", basis);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
}

static ffd_status lat_begin(sess_method *m, const uint32_t *ids, size_t k, int arap,
                            ffd_error *err)
{
    lattice_method *l = as_lattice(m);
    size_t c = lat_count(m);
    ffd_free(l->begin);
    l->begin = ffd_malloc_array(c, 3 * sizeof *l->begin);
    if (!l->begin)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag_begin: out of memory");
    lat_controls(m, l->begin);
    return FFD_OK;
}

/* The drag's start plus a change: controls ids at targets, or every variable + dv. */
static ffd_status lat_set_from_begin(lattice_method *l, const uint32_t *ids, size_t k,
                                     const double *targets, const double *dv, ffd_error *err)
{
    size_t c = lat_count(&l->base);
    double *p = ffd_malloc_array(c, 3 * sizeof *p);
    if (!p)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    memcpy(p, l->begin, c * 3 * sizeof *p);
    for (size_t i = 0; i < k; i++)
        memcpy(p + 3 * (size_t)ids[i], targets + 3 * i, 3 * sizeof *p);
    for (size_t i = 0; dv && i < 3 * c; i++)
        p[i] += dv[i];
    ffd_status st = ffd_lattice_set_control_points(l->lattice, p, err);
    ffd_free(p);
    return st;
}

static ffd_status lat_set_controls(sess_method *m, const uint32_t *ids, size_t k,
                                   const double *targets, ffd_error *err)
{
    return lat_set_from_begin(as_lattice(m), ids, k, targets, NULL, err);
}

static ffd_status lat_linear_map(sess_method *m, ffd_linear_map *map, ffd_error *err)
{
    lattice_method *l = as_lattice(m);
    ffd_lattice_linear_map(l->lattice, l->binding, map);
    if (map->variable_count != lat_count(m))
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "the lattice exposes %zu variables, expected %zu",
                        map->variable_count, lat_count(m));
    return FFD_OK;
}

static ffd_status lat_set_variables(sess_method *m, const double *dv, ffd_error *err)
{
    return lat_set_from_begin(as_lattice(m), NULL, 0, NULL, dv, err);
}

static void lat_end(sess_method *m, int commit)
{
    lattice_method *l = as_lattice(m);
    if (!commit && l->begin)
        ffd_lattice_set_control_points(l->lattice, l->begin, NULL);
    ffd_free(l->begin);
    l->begin = NULL;
}

static ffd_status lat_snapshot(const sess_method *m, void **blob, ffd_error *err)
{
    size_t c = lat_count(m);
    double *copy = ffd_malloc_array(c + 1, 3 * sizeof *copy);
    if (!copy)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the undo history");
    copy[0] = (double)c;
    lat_controls(m, copy + 3);
    *blob = copy;
    return FFD_OK;
}

static ffd_status lat_restore(sess_method *m, const void *blob, ffd_error *err)
{
    const double *copy = blob;
    if ((size_t)copy[0] != lat_count(m))
        return ffd_fail(err, FFD_ERR_INVALID, "undo: the history does not match the lattice");
    return ffd_lattice_set_control_points(as_lattice(m)->lattice, copy + 3, err);
}

static ffd_status lat_reset(sess_method *m, ffd_error *err)
{
    ffd_lattice_reset(as_lattice(m)->lattice);
    return FFD_OK;
}

/* Control point (i,j,k)'s displacement from rest into d; 1 when it moved. */
static int control_moved(const ffd_lattice *lattice, const uint32_t r[3], uint32_t i, uint32_t j,
                         uint32_t k, double d[3])
{
    double rest[3];
    size_t e = (size_t)(i * r[1] + j) * r[2] + k;
    if (lattice->gen && ffd_lattice_general_representative(lattice, e) != e)
        return 0; /* a tied control point: its group's move is its representative's */
    const double *q = ffd_lattice_control_points(lattice) + 3 * e;
    ffd_lattice_rest_point(lattice, i, j, k, rest);
    for (int a = 0; a < 3; a++)
        d[a] = q[a] - rest[a];
    return q[0] != rest[0] || q[1] != rest[1] || q[2] != rest[2];
}

/* The state as a rig: its box, basis, resolution and outside rule, and a
 * move per displaced control point, written by the rig's own writer
 * (lattice_rig_json.c). */
static ffd_status lat_rig(const sess_method *m, cJSON *root, ffd_error *err)
{
    const lattice_method *l = as_lattice(m);
    ffd_rig rig;
    ffd_rig_lattice section;
    ffd_rig_view(&rig, &ffd_method_lattice, &section, sizeof section);
    section.falloff = l->falloff;
    section.falloff_curve = l->falloff_curve;
    rig.basis = ffd_lattice_basis(l->lattice);
    rig.outside = l->outside;
    ffd_lattice_resolution(l->lattice, rig.resolution);
    ffd_lattice_box(l->lattice, &rig.box);
    ffd_lattice_get_shape(l->lattice, &rig.shape);
    const uint32_t *r = rig.resolution;
    size_t moved = 0; /* the displaced control points: one move each */
    double d[3];
    for (uint32_t i = 0; i < r[0]; i++)
        for (uint32_t j = 0; j < r[1]; j++)
            for (uint32_t k = 0; k < r[2]; k++)
                moved += (size_t)control_moved(l->lattice, r, i, j, k, d);
    rig.moves = ffd_malloc_array(moved ? moved : 1, sizeof *rig.moves);
    if (!rig.moves)
        return ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
    for (uint32_t i = 0; i < r[0]; i++)
        for (uint32_t j = 0; j < r[1]; j++)
            for (uint32_t k = 0; k < r[2]; k++) {
                if (!control_moved(l->lattice, r, i, j, k, d))
                    continue;
                ffd_rig_move *mv = &rig.moves[rig.move_count++];
                memcpy(mv->delta, d, sizeof d);
                mv->index[0] = i;
                mv->index[1] = j;
                mv->index[2] = k;
            }
    int ok = ffd_method_lattice.write(&rig, root);
    ffd_free(rig.moves);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
}

static ffd_status lat_influence(sess_method *m, const uint32_t *ids, size_t k, float *w,
                                ffd_error *err)
{
    ffd_linear_map map;
    ffd_status st = lat_linear_map(m, &map, err);
    return st ? st : ffd_sess_map_influence(&map, 0, m->ctx->n, ids, k, w, err);
}

static ffd_status lat_op(sess_method *m, const char *op, const cJSON *body, int *undo_kind,
                         ffd_error *err)
{
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not a lattice operation", op);
}

/* any point set: at the end of the file */
static ffd_status lat_bind(sess_method *m, const double *points, size_t n, sess_binding **out,
                           ffd_error *err);
static void lat_binding_free(sess_binding *b);
static ffd_status lat_eval_points(sess_method *m, const sess_binding *b, double *out,
                                  ffd_error *err);
static ffd_status lat_jacobian_points(sess_method *m, const sess_binding *b, double *out,
                                      ffd_error *err);
static ffd_status lat_map_points(sess_method *m, const sess_binding *b, ffd_linear_map *map,
                                 ffd_error *err);
static ffd_status lat_sensitivity_product(sess_method *m, const sess_binding *b, const double *v,
                                          double *out, ffd_error *err);
static ffd_status lat_sensitivity_transpose(sess_method *m, const sess_binding *b, const double *w,
                                            double *out, ffd_error *err);
static void *lat_handle(sess_method *m);
static ffd_status lat_fold_check(sess_method *m, ffd_fold_report *out, ffd_error *err)
{
    return ffd_lattice_fold_check(as_lattice(m)->lattice, out, err);
}

static const sess_vtable lattice_vtable = {
    .name = "lattice",
    .destroy = lat_destroy,
    .eval = lat_eval,
    .control_count = lat_count,
    .controls = lat_controls,
    .describe = lat_describe,
    .begin = lat_begin,
    .set_controls = lat_set_controls,
    .linear_map = lat_linear_map,
    .set_variables = lat_set_variables,
    .end = lat_end,
    .snapshot = lat_snapshot,
    .restore = lat_restore,
    .snapshot_free = ffd_free,
    .reset = lat_reset,
    .rig = lat_rig,
    .influence = lat_influence,
    .op = lat_op,
    .bind = lat_bind,
    .binding_free = lat_binding_free,
    .eval_points = lat_eval_points,
    .jacobian_points = lat_jacobian_points,
    .map_points = lat_map_points,
    .sensitivity_product = lat_sensitivity_product,
    .sensitivity_transpose_product = lat_sensitivity_transpose,
    .handle = lat_handle,
    .fold_check = lat_fold_check,
};

/* Builds the lattice and binds the rest mesh. */
static ffd_status lattice_build(const sess_ctx *ctx, ffd_basis basis, const uint32_t res[3],
                                const ffd_box *box, const ffd_lattice_shape *shape,
                                const ffd_rig *rig, double margin, const char *what,
                                sess_method **out, ffd_error *err)
{
    ffd_status st = ffd_sess_check_controls(ctx, (double)res[0] * res[1] * res[2], what, err);
    if (st)
        return st;
    lattice_method *l = ffd_calloc(1, sizeof *l);
    if (!l)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", what);
    l->base.vt = &lattice_vtable;
    l->base.ctx = ctx;
    l->outside = rig->outside;
    l->falloff = ffd_rig_lattice_of(rig)->falloff;
    l->falloff_curve = ffd_rig_lattice_of(rig)->falloff_curve;
    l->margin = margin;
    ffd_error inner = {{0}};
    st = ffd_lattice_create_shaped(basis, box, res, shape, &l->lattice, &inner);
    if (!st)
        st = bind_points(l, ctx->rest, ctx->n, &l->binding, &inner);
    if (st) {
        lat_destroy(&l->base);
        return ffd_fail(err, st, "%s: %s", what, inner.message);
    }
    *out = &l->base;
    return FFD_OK;
}

/* The editor's "create": the rig's creation keys, with the rig's defaults
 * (ffd_method_create). */
ffd_status ffd_sess_lattice_create(const sess_ctx *ctx, const cJSON *body, sess_method **out,
                                   ffd_error *err)
{
    return ffd_method_create(&ffd_method_lattice, ctx, body, out, err);
}

ffd_status ffd_sess_lattice_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                             ffd_error *err)
{
    if (ffd_rig_lattice_of(rig)->child_count) /* nested lattices: lattice_nested_session.c */
        return ffd_sess_lattice_nested_load(ctx, rig, out, err);
    ffd_box box = rig->box;
    ffd_error inner = {{0}};
    ffd_status st;
    if (rig->box_auto && (st = ffd_box_fit(ctx->rest, ctx->n, rig->margin, &box, &inner)))
        return ffd_fail(err, st, "%s: box \"auto\": %s", rig->name, inner.message);
    ffd_lattice_shape shape;
    if ((st = ffd_rig_lattice_shape(rig, ctx->rest, ctx->n, &shape, &inner)))
        return ffd_fail(err, st, "%s: frame \"auto\": %s", rig->name, inner.message);
    const uint32_t *r = rig->resolution;
    if ((st = ffd_sess_check_controls(ctx, (double)r[0] * r[1] * r[2], rig->name, err)))
        return st;
    /* The rig's moves and constraints, as ffd deform applies them; a rig
     * without any (the editor's create) leaves the lattice at rest, as built. */
    const int replay = rig->move_count || rig->constraint_count;
    ffd_rig_report report = {0};
    if (replay && (st = ffd_sess_apply_rig(ctx, rig, &report, err)))
        return st;
    sess_method *m = NULL;
    st = lattice_build(ctx, rig->basis, rig->resolution, &box, &shape, rig, rig->margin,
                       rig->name, &m, err);
    if (!st && replay && report.control_count != lat_count(m))
        st = ffd_fail(err, FFD_ERR_INVALID, "%s: the rig's lattice does not match", rig->name);
    if (!st && replay)
        st = ffd_lattice_set_control_points(as_lattice(m)->lattice, report.control_points, err);
    ffd_rig_report_free(&report);
    if (st) {
        if (m)
            lat_destroy(m);
        return st;
    }
    *out = m;
    return FFD_OK;
}

/* ---- any point set (ffd_deformer_bind) ----
 * The lattice's structure (box, resolution, basis, outside policy) never
 * changes after creation (the method has no structural op), so a binding of
 * the points made once by ffd_lattice_bind, the same call that binds the
 * mesh's vertices, stays valid across every control change. */

struct sess_binding {
    ffd_lattice_binding *lattice;
};

static ffd_status lat_bind(sess_method *m, const double *points, size_t n, sess_binding **out,
                           ffd_error *err)
{
    lattice_method *l = as_lattice(m);
    sess_binding *b = ffd_calloc(1, sizeof *b);
    if (!b)
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    ffd_error inner = {{0}};
    ffd_status st = bind_points(l, points, n, &b->lattice, &inner);
    if (st) {
        ffd_free(b);
        return ffd_fail(err, st, "bind: %s", inner.message);
    }
    *out = b;
    return FFD_OK;
}

static void lat_binding_free(sess_binding *b)
{
    if (!b)
        return;
    ffd_lattice_binding_destroy(b->lattice);
    ffd_free(b);
}

static ffd_status lat_eval_points(sess_method *m, const sess_binding *b, double *out,
                                  ffd_error *err)
{
    return ffd_lattice_eval(as_lattice(m)->lattice, b->lattice, out, err);
}

/* W v and W^T w blockwise, as the evaluation (lattice_eval.c,
 * lattice_sensitivity.c); W itself goes through lat_map_points
 * (deformer/sensitivities.c). */
static ffd_status lat_sensitivity_product(sess_method *m, const sess_binding *b, const double *v,
                                          double *out, ffd_error *err)
{
    return ffd_lattice_sensitivity_product(as_lattice(m)->lattice, b->lattice, v, out, err);
}

static ffd_status lat_sensitivity_transpose(sess_method *m, const sess_binding *b, const double *w,
                                            double *out, ffd_error *err)
{
    return ffd_lattice_sensitivity_transpose(as_lattice(m)->lattice, b->lattice, w, out, err);
}

static ffd_status lat_jacobian_points(sess_method *m, const sess_binding *b, double *out,
                                      ffd_error *err)
{
    return ffd_lattice_jacobian(as_lattice(m)->lattice, b->lattice, out, err);
}

/* Hsu et al. eq. 2 and 6: the rows B over the raw slots (the B-spline's
 * tripled border) and the tie S onto the l*m*n control points, which are the
 * method's control ids. */
static ffd_status lat_map_points(sess_method *m, const sess_binding *b, ffd_linear_map *map,
                                 ffd_error *err)
{
    lattice_method *l = as_lattice(m);
    ffd_lattice_linear_map(l->lattice, b->lattice, map);
    if (map->variable_count != lat_count(m))
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "linear map: the lattice exposes %zu variables, expected %zu",
                        map->variable_count, lat_count(m));
    return FFD_OK;
}

static void *lat_handle(sess_method *m)
{
    return as_lattice(m)->lattice;
}
