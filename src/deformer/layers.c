/* layers — the generic layers around every method's deformer
 * (docs/constraints.md; the rig keys: rig/rig_layers.c). A rig with
 * weights, strength, constraints or a fold policy gets its method's
 * deformer wrapped in one more sess_method, so that ffd_rig_apply,
 * ffd_deformer and the editor's session all go through the same code:
 *
 *  - weights and strength: x'_i = x_i + s w_i (f(x_i) - x_i)
 *    (Blender's and Maya's vertex-group weights; s w_i == 0 keeps x_i and
 *    s w_i == 1 keeps f(x_i) bit for bit); the Jacobian I + s w_i (J_f - I),
 *    linear map rows and sensitivity products scaled by s w_i;
 *  - constrained FFD (manip/constrained.c): after the rig's moves and each
 *    committed control move, the minimal change of the controls that keeps
 *    the volume, the barycentre or the linear constraints;
 *  - fold policy: a control move that would fold the method's map (its
 *    fold check) is refused or shortened by bisection.
 *
 * Every other operation is the method's own, forwarded. */
#include "deformer/method.h"
#include "manip/manip.h"
#include "mesh/mesh.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define FOLD_BISECTIONS 20 /* the shortened step is within 2^-20 of the largest fold-free one */

/* A linear map whose rows are another's times c_i. */
typedef struct scaled_map {
    ffd_linear_map inner;
    const double *scale;
    double strength;
} scaled_map;

typedef struct layered {
    sess_method base;
    sess_method *inner;
    ffd_rig_layers *layers;   /* a copy */
    double *scale;            /* per vertex s w_i (ctx->n); NULL: the strength everywhere */
    double volume0, barycentre0[3];
    sess_binding *vertices;   /* the inner method's binding of the rest vertices (constraints) */
    /* the drag in progress (fold policy) */
    uint32_t *drag_ids;
    size_t drag_k;
    double *drag_last;        /* drag_k by 3: the last accepted targets */
    /* what the layers did last (the report) */
    int constrained;
    ffd_cffd_result cffd;
    double fold_fraction;     /* the fraction of the last control move kept (1: all) */
    size_t fold_folded;       /* folded cells of the requested move (0: it did not fold) */
    scaled_map dm_map;        /* the holder of the session's scaled linear_map */
} layered;

typedef struct lbinding {
    sess_binding *inner;
    size_t n;
    double *rest;             /* n by 3 */
    const double *scale;      /* per point (n == ctx->n), or NULL */
    double strength;
    void (*inner_free)(sess_binding *b); /* the inner method's binding_free */
    scaled_map map;           /* the holder of map_points' scaled map (borrows the binding) */
} lbinding;

typedef struct lblob {
    const sess_vtable *vt;    /* the inner method's */
    void *blob;
} lblob;

static const sess_vtable layered_vt;

static layered *L(sess_method *m)
{
    return (layered *)m;
}

static const layered *CL(const sess_method *m)
{
    return (const layered *)m;
}

const sess_vtable *ffd_sess_caps(const sess_method *m)
{
    return m->vt == &layered_vt ? CL(m)->inner->vt : m->vt;
}

static const char *name_of(const sess_method *m)
{
    return CL(m)->inner->vt->name;
}

static ffd_status unsupported(const sess_method *m, const char *what, ffd_error *err)
{
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: the %s method has no %s", what, name_of(m), what);
}

/* ---- weights and strength ---- */

static double point_scale(const double *scale, double strength, size_t i)
{
    return scale ? scale[i] : strength;
}

/* out = rest + c (f - rest), out holding f on entry. */
static void blend(const double *rest, const double *scale, double strength, size_t n, double *out)
{
    for (size_t i = 0; i < n; i++) {
        double c = point_scale(scale, strength, i);
        if (c == 1.0)
            continue;
        for (int a = 0; a < 3; a++) {
            double x = rest[3 * i + a];
            out[3 * i + a] = c == 0.0 ? x : x + c * (out[3 * i + a] - x);
        }
    }
}

/* J' = I + c (J - I) per point (n by 9). */
static void blend_jacobian(const double *scale, double strength, size_t n, double *J)
{
    for (size_t i = 0; i < n; i++) {
        double c = point_scale(scale, strength, i);
        if (c == 1.0)
            continue;
        for (int r = 0; r < 3; r++)
            for (int k = 0; k < 3; k++) {
                double id = r == k ? 1.0 : 0.0, *e = J + 9 * i + 3 * r + k;
                *e = c == 0.0 ? id : id + c * (*e - id);
            }
    }
}

static void scale_rows(const double *scale, double strength, size_t n, double *v)
{
    for (size_t i = 0; i < n; i++) {
        double c = point_scale(scale, strength, i);
        if (c != 1.0)
            for (int a = 0; a < 3; a++)
                v[3 * i + a] *= c;
    }
}

static size_t scaled_row(const void *self, size_t i, uint32_t *columns, double *weights)
{
    const scaled_map *s = self;
    size_t k = s->inner.row(s->inner.self, i, columns, weights);
    double c = point_scale(s->scale, s->strength, i);
    if (c == 1.0)
        return k;
    if (c == 0.0)
        return 0;
    for (size_t e = 0; e < k; e++)
        weights[e] *= c;
    return k;
}

static void wrap_map(ffd_linear_map *map, scaled_map *holder, const double *scale, double strength)
{
    holder->inner = *map;
    holder->scale = scale;
    holder->strength = strength;
    map->self = holder;
    map->row = scaled_row;
}

/* ---- the drag's fold policy ---- */

/* 1 when the inner map folds now (the method's fold check). */
static ffd_status folds(layered *l, int *folded, ffd_error *err)
{
    ffd_fold_report r;
    memset(&r, 0, sizeof r);
    ffd_status st = l->inner->vt->fold_check(l->inner, &r, err);
    *folded = !st && r.folded > 0;
    if (!st && r.folded)
        l->fold_folded = r.folded;
    ffd_fold_report_free(&r);
    return st;
}

static int fold_policy(const layered *l)
{
    return l->inner->vt->fold_check ? l->layers->fold_policy : FFD_FOLD_ALLOW;
}

/* Puts controls ids at last + t (targets - last) through the inner set_controls. */
static ffd_status set_fraction(layered *l, const uint32_t *ids, size_t k, const double *last,
                               const double *targets, double t, double *scratch, ffd_error *err)
{
    for (size_t c = 0; c < 3 * k; c++)
        scratch[c] = t == 1.0 ? targets[c] : last[c] + t * (targets[c] - last[c]);
    return l->inner->vt->set_controls(l->inner, ids, k, scratch, err);
}

/* After the inner method put the controls at targets: refuse or shorten
 * the move from last when the map folds. */
static ffd_status police(layered *l, const uint32_t *ids, size_t k, const double *last,
                         const double *targets, ffd_error *err)
{
    l->fold_fraction = 1.0;
    l->fold_folded = 0;
    int folded = 0;
    ffd_status st = folds(l, &folded, err);
    if (st || !folded)
        return st;
    double *scratch = ffd_malloc_array(k ? k : 1, 3 * sizeof *scratch);
    if (!scratch)
        return ffd_fail(err, FFD_ERR_NOMEM, "fold_policy: out of memory");
    if (l->layers->fold_policy == FFD_FOLD_REFUSE) {
        size_t cells = l->fold_folded;
        st = set_fraction(l, ids, k, last, targets, 0.0, scratch, err);
        l->fold_fraction = 0.0;
        ffd_free(scratch);
        return st ? st
                  : ffd_fail(err, FFD_ERR_INVALID,
                             SESS_CONFLICT "fold_policy: \"refuse\": the move folds the %s "
                                           "map (%zu cells with det J <= 0); it was not made",
                             name_of(&l->base), cells);
    }
    double lo = 0.0, hi = 1.0;
    for (int b = 0; b < FOLD_BISECTIONS && !st; b++) {
        double mid = 0.5 * (lo + hi);
        if (!(st = set_fraction(l, ids, k, last, targets, mid, scratch, err)) &&
            !(st = folds(l, &folded, err))) {
            if (folded)
                hi = mid;
            else
                lo = mid;
        }
    }
    if (!st)
        st = set_fraction(l, ids, k, last, targets, lo, scratch, err);
    l->fold_fraction = lo;
    ffd_free(scratch);
    return st;
}

/* ---- constraints ---- */

static ffd_status vertex_binding(layered *l, ffd_error *err)
{
    if (l->vertices)
        return FFD_OK;
    if (!l->inner->vt->bind || !l->inner->vt->map_points)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "preserve/linear_constraints: the %s method has no linear map to "
                        "constrain (docs/constraints.md)",
                        name_of(&l->base));
    const sess_ctx *ctx = l->base.ctx;
    return l->inner->vt->bind(l->inner, ctx->rest, ctx->n, &l->vertices, err);
}

/* Every control at positions (control_count by 3), as one drag. */
static ffd_status put_controls(sess_method *inner, const double *positions, ffd_error *err)
{
    size_t count = inner->vt->control_count(inner);
    uint32_t *ids = ffd_malloc_array(count ? count : 1, sizeof *ids);
    if (!ids)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for %zu controls", count);
    for (size_t c = 0; c < count; c++)
        ids[c] = (uint32_t)c;
    ffd_status st = inner->vt->begin(inner, ids, count, 0, err);
    if (!st) {
        st = inner->vt->set_controls(inner, ids, count, positions, err);
        inner->vt->end(inner, st == FFD_OK);
    }
    ffd_free(ids);
    return st;
}

/* The minimal change of the current controls that meets the constraints. */
static ffd_status constrain(layered *l, ffd_error *err)
{
    const ffd_rig_layers *ly = l->layers;
    if (!ly->preserve && !ly->linear_count)
        return FFD_OK;
    const sess_ctx *ctx = l->base.ctx;
    sess_method *in = l->inner;
    ffd_status st = vertex_binding(l, err);
    if (st)
        return st;
    size_t nc = in->vt->control_count(in), n = ctx->n;
    ffd_linear_map map;
    scaled_map holder;
    ffd_cffd_linear *lin = ly->linear_count ? ffd_calloc(ly->linear_count, sizeof *lin) : NULL;
    double *P = ffd_malloc_array(nc ? nc : 1, 3 * sizeof *P);
    double *X = ffd_malloc_array(n ? n : 1, 3 * sizeof *X);
    double *Pout = ffd_malloc_array(nc ? nc : 1, 3 * sizeof *Pout);
    double *Xout = ffd_malloc_array(n ? n : 1, 3 * sizeof *Xout);
    unsigned char *free_ = NULL;
    int masked = !ly->mask_axes[0] || !ly->mask_axes[1] || !ly->mask_axes[2] || ly->mask_controls;
    if ((ly->linear_count && !lin) || !P || !X || !Pout || !Xout ||
        (masked && !(free_ = ffd_calloc(nc ? nc : 1, 3)))) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "constraints: out of memory");
        goto done;
    }
    if (masked) {
        for (size_t c = 0; c < nc; c++)
            for (int a = 0; a < 3; a++)
                free_[3 * c + a] = ly->mask_controls ? 0 : (unsigned char)ly->mask_axes[a];
        for (size_t t = 0; t < ly->mask_control_count; t++) {
            uint32_t c = ly->mask_controls[t];
            if (c >= nc) {
                st = ffd_fail(err, FFD_ERR_RANGE,
                              "constraint_mask.controls[%zu]: control %u out of range (%zu controls)",
                              t, c, nc);
                goto done;
            }
            for (int a = 0; a < 3; a++)
                free_[3 * (size_t)c + a] = (unsigned char)ly->mask_axes[a];
        }
    }
    for (size_t c = 0; c < ly->linear_count; c++) {
        const ffd_rig_linear_constraint *rc = &ly->linear[c];
        lin[c] = (ffd_cffd_linear){rc->over == FFD_LINEAR_OVER_CONTROLS ? FFD_CFFD_OVER_CONTROLS
                                                                         : FFD_CFFD_OVER_POINTS,
                                   rc->term_count, rc->index, rc->axis, rc->coef, rc->value};
    }
    in->vt->controls(in, P);
    if ((st = in->vt->eval(in, X, err)) || (st = in->vt->map_points(in, l->vertices, &map, err)))
        goto done;
    blend(ctx->rest, l->scale, ly->strength, n, X);
    wrap_map(&map, &holder, l->scale, ly->strength);
    ffd_cffd_problem pb = {
        .map = &map,
        .control_count = nc,
        .controls = P,
        .points = X,
        .free = free_,
        .preserve_volume = (ly->preserve & FFD_PRESERVE_VOLUME) != 0,
        .volume = l->volume0,
        .face_offsets = ffd_mesh_face_offsets(ctx->mesh),
        .face_indices = ffd_mesh_face_indices(ctx->mesh),
        .face_count = ffd_mesh_face_count(ctx->mesh),
        .preserve_barycentre = (ly->preserve & FFD_PRESERVE_BARYCENTRE) != 0,
        .barycentre = {l->barycentre0[0], l->barycentre0[1], l->barycentre0[2]},
        .linear = lin,
        .linear_count = ly->linear_count,
        .scale = ctx->diag,
    };
    if ((st = ffd_cffd_solve(&pb, Pout, Xout, NULL, &l->cffd, err)))
        goto done;
    l->constrained = 1;
    if (l->cffd.change_norm > 0)
        st = put_controls(in, Pout, err);
done:
    ffd_free(lin);
    ffd_free(P);
    ffd_free(X);
    ffd_free(Pout);
    ffd_free(Xout);
    ffd_free(free_);
    return st;
}

/* ---- the vtable ---- */

static void lay_destroy(sess_method *m)
{
    layered *l = L(m);
    if (l->vertices)
        l->inner->vt->binding_free(l->vertices);
    l->inner->vt->destroy(l->inner);
    ffd_rig_layers_free(l->layers);
    ffd_free(l->scale);
    ffd_free(l->drag_ids);
    ffd_free(l->drag_last);
    ffd_free(l);
}

static ffd_status lay_eval(sess_method *m, double *out, ffd_error *err)
{
    layered *l = L(m);
    ffd_status st = l->inner->vt->eval(l->inner, out, err);
    if (!st)
        blend(m->ctx->rest, l->scale, l->layers->strength, m->ctx->n, out);
    return st;
}

static size_t lay_control_count(const sess_method *m)
{
    return CL(m)->inner->vt->control_count(CL(m)->inner);
}

static void lay_controls(const sess_method *m, double *out)
{
    CL(m)->inner->vt->controls(CL(m)->inner, out);
}

static ffd_status lay_describe(const sess_method *m, cJSON *params, cJSON *controls, ffd_error *err)
{
    return CL(m)->inner->vt->describe(CL(m)->inner, params, controls, err);
}

static ffd_status lay_begin(sess_method *m, const uint32_t *ids, size_t k, int arap, ffd_error *err)
{
    layered *l = L(m);
    ffd_free(l->drag_ids);
    ffd_free(l->drag_last);
    l->drag_ids = NULL;
    l->drag_last = NULL;
    l->drag_k = 0;
    if (fold_policy(l) != FFD_FOLD_ALLOW && k) {
        size_t count = l->inner->vt->control_count(l->inner);
        double *all = ffd_malloc_array(count, 3 * sizeof *all);
        l->drag_ids = ffd_malloc_array(k, sizeof *l->drag_ids);
        l->drag_last = ffd_malloc_array(k, 3 * sizeof *l->drag_last);
        if (!all || !l->drag_ids || !l->drag_last) {
            ffd_free(all);
            return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
        }
        l->inner->vt->controls(l->inner, all);
        for (size_t c = 0; c < k; c++) {
            l->drag_ids[c] = ids[c];
            memcpy(l->drag_last + 3 * c, all + 3 * (size_t)ids[c], 3 * sizeof *all);
        }
        l->drag_k = k;
        ffd_free(all);
    }
    return l->inner->vt->begin(l->inner, ids, k, arap, err);
}

/* The drag's ids are the begin's (the session and ffd_deformer drag what they began). */
static int same_drag(const layered *l, const uint32_t *ids, size_t k)
{
    return l->drag_ids && k == l->drag_k && memcmp(ids, l->drag_ids, k * sizeof *ids) == 0;
}

static ffd_status lay_set_controls(sess_method *m, const uint32_t *ids, size_t k,
                                   const double *targets, ffd_error *err)
{
    layered *l = L(m);
    ffd_status st = l->inner->vt->set_controls(l->inner, ids, k, targets, err);
    if (st || fold_policy(l) == FFD_FOLD_ALLOW || !same_drag(l, ids, k))
        return st;
    if (!(st = police(l, ids, k, l->drag_last, targets, err)) && l->fold_fraction == 1.0)
        memcpy(l->drag_last, targets, 3 * k * sizeof *targets);
    else if (!st)
        for (size_t c = 0; c < 3 * k; c++)
            l->drag_last[c] += l->fold_fraction * (targets[c] - l->drag_last[c]);
    return st;
}

static ffd_status lay_set_motion(sess_method *m, const uint32_t *ids, size_t k,
                                 const double *targets, const double axis[3], double angle,
                                 const double center[3], const double delta[3], ffd_error *err)
{
    layered *l = L(m);
    if (!l->inner->vt->set_motion)
        return lay_set_controls(m, ids, k, targets, err);
    ffd_status st = l->inner->vt->set_motion(l->inner, ids, k, targets, axis, angle, center, delta,
                                             err);
    if (st || fold_policy(l) == FFD_FOLD_ALLOW || !same_drag(l, ids, k))
        return st;
    int folded = 0;
    if ((st = folds(l, &folded, err)) || !folded) {
        if (!st)
            memcpy(l->drag_last, targets, 3 * k * sizeof *targets);
        return st;
    }
    /* a folding turn: refused or shortened along the straight path of its points */
    return lay_set_controls(m, ids, k, targets, err);
}

static ffd_status lay_linear_map(sess_method *m, ffd_linear_map *map, ffd_error *err)
{
    layered *l = L(m);
    if (!l->inner->vt->linear_map)
        return unsupported(m, "linear map", err);
    ffd_status st = l->inner->vt->linear_map(l->inner, map, err);
    /* the session's map borrows m: its holder lives in l */
    if (!st && (l->scale || l->layers->strength != 1.0))
        wrap_map(map, &l->dm_map, l->scale, l->layers->strength);
    return st;
}

static ffd_status lay_set_variables(sess_method *m, const double *dv, ffd_error *err)
{
    return L(m)->inner->vt->set_variables(L(m)->inner, dv, err);
}

static void lay_end(sess_method *m, int commit)
{
    layered *l = L(m);
    l->inner->vt->end(l->inner, commit);
    ffd_free(l->drag_ids);
    ffd_free(l->drag_last);
    l->drag_ids = NULL;
    l->drag_last = NULL;
    l->drag_k = 0;
    if (commit) {
        /* a committed move is projected onto the constraints (a failure keeps
         * the move as it is; the next rig replay reports it) */
        ffd_error ignored;
        (void)constrain(l, &ignored);
    }
}

static ffd_status lay_snapshot(const sess_method *m, void **blob, ffd_error *err)
{
    const layered *l = CL(m);
    lblob *b = ffd_calloc(1, sizeof *b);
    if (!b)
        return ffd_fail(err, FFD_ERR_NOMEM, "snapshot: out of memory");
    b->vt = l->inner->vt;
    ffd_status st = l->inner->vt->snapshot(l->inner, &b->blob, err);
    if (st) {
        ffd_free(b);
        return st;
    }
    *blob = b;
    return FFD_OK;
}

static ffd_status lay_restore(sess_method *m, const void *blob, ffd_error *err)
{
    const lblob *b = blob;
    if (b->vt != L(m)->inner->vt)
        return ffd_fail(err, FFD_ERR_INVALID, "undo: the history does not match the deformer");
    return L(m)->inner->vt->restore(L(m)->inner, b->blob, err);
}

static void lay_snapshot_free(void *blob)
{
    lblob *b = blob;
    if (!b)
        return;
    b->vt->snapshot_free(b->blob);
    ffd_free(b);
}

static ffd_status lay_reset(sess_method *m, ffd_error *err)
{
    ffd_status st = L(m)->inner->vt->reset(L(m)->inner, err);
    return st ? st : constrain(L(m), err);
}

static ffd_status lay_rig(const sess_method *m, cJSON *root, ffd_error *err)
{
    ffd_status st = CL(m)->inner->vt->rig(CL(m)->inner, root, err);
    if (!st && !ffd_rig_write_layers(CL(m)->layers, root))
        st = ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
    return st;
}

static ffd_status lay_influence(sess_method *m, const uint32_t *ids, size_t k, float *w,
                                ffd_error *err)
{
    layered *l = L(m);
    ffd_status st = l->inner->vt->influence(l->inner, ids, k, w, err);
    for (size_t i = 0; !st && i < m->ctx->n; i++) {
        double c = fabs(point_scale(l->scale, l->layers->strength, i));
        w[i] = (float)fmin(1.0, w[i] * c);
    }
    return st;
}

static ffd_status lay_op(sess_method *m, const char *op, const cJSON *body, int *undo_kind,
                         ffd_error *err)
{
    layered *l = L(m);
    ffd_status st = l->inner->vt->op(l->inner, op, body, undo_kind, err);
    if (!st && l->vertices && *undo_kind == SESS_UNDO_REBUILD) {
        /* the structure changed: bind again when the constraints need it */
        l->inner->vt->binding_free(l->vertices);
        l->vertices = NULL;
    }
    return st;
}

static ffd_status lay_bind(sess_method *m, const double *points, size_t n, sess_binding **out,
                           ffd_error *err)
{
    layered *l = L(m);
    if (!l->inner->vt->bind)
        return unsupported(m, "binding of other points", err);
    if (l->scale && n != m->ctx->n)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "bind: the rig's weights are per vertex (%zu vertices): a deformer with "
                        "weights binds %zu points, not %zu",
                        m->ctx->n, m->ctx->n, n);
    lbinding *b = ffd_calloc(1, sizeof *b);
    if (!b || !(b->rest = ffd_malloc_array(n ? n : 1, 3 * sizeof *b->rest))) {
        ffd_free(b);
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    }
    memcpy(b->rest, points, n * 3 * sizeof *points);
    b->n = n;
    b->scale = l->scale;
    b->strength = l->layers->strength;
    b->inner_free = l->inner->vt->binding_free;
    ffd_status st = l->inner->vt->bind(l->inner, points, n, &b->inner, err);
    if (st) {
        ffd_free(b->rest);
        ffd_free(b);
        return st;
    }
    *out = (sess_binding *)b;
    return FFD_OK;
}

static void lay_binding_free(sess_binding *sb)
{
    lbinding *b = (lbinding *)sb;
    if (!b)
        return;
    if (b->inner)
        b->inner_free(b->inner);
    ffd_free(b->rest);
    ffd_free(b);
}

static ffd_status lay_eval_points(sess_method *m, const sess_binding *sb, double *out,
                                  ffd_error *err)
{
    const lbinding *b = (const lbinding *)sb;
    ffd_status st = L(m)->inner->vt->eval_points(L(m)->inner, b->inner, out, err);
    if (!st)
        blend(b->rest, b->scale, b->strength, b->n, out);
    return st;
}

static ffd_status lay_jacobian_points(sess_method *m, const sess_binding *sb, double *out,
                                      ffd_error *err)
{
    const lbinding *b = (const lbinding *)sb;
    if (!L(m)->inner->vt->jacobian_points)
        return unsupported(m, "Jacobian", err);
    ffd_status st = L(m)->inner->vt->jacobian_points(L(m)->inner, b->inner, out, err);
    if (!st)
        blend_jacobian(b->scale, b->strength, b->n, out);
    return st;
}

static ffd_status lay_map_points(sess_method *m, const sess_binding *sb, ffd_linear_map *map,
                                 ffd_error *err)
{
    lbinding *b = (lbinding *)sb;
    if (!L(m)->inner->vt->map_points)
        return unsupported(m, "linear map", err);
    ffd_status st = L(m)->inner->vt->map_points(L(m)->inner, b->inner, map, err);
    if (st)
        return st;
    if (b->scale || b->strength != 1.0)
        wrap_map(map, &b->map, b->scale, b->strength); /* the map borrows the binding */
    return FFD_OK;
}

static void *lay_handle(sess_method *m)
{
    sess_method *in = L(m)->inner;
    return in->vt->handle ? in->vt->handle(in) : NULL;
}

static ffd_status lay_sensitivity_product(sess_method *m, const sess_binding *sb, const double *v,
                                          double *out, ffd_error *err)
{
    const lbinding *b = (const lbinding *)sb;
    ffd_status st = L(m)->inner->vt->sensitivity_product(L(m)->inner, b->inner, v, out, err);
    if (!st)
        scale_rows(b->scale, b->strength, b->n, out);
    return st;
}

static ffd_status lay_sensitivity_transpose_product(sess_method *m, const sess_binding *sb,
                                                    const double *w, double *out, ffd_error *err)
{
    const lbinding *b = (const lbinding *)sb;
    double *ws = ffd_malloc_array(b->n ? b->n : 1, 3 * sizeof *ws);
    if (!ws)
        return ffd_fail(err, FFD_ERR_NOMEM, "sensitivity transpose product: out of memory");
    memcpy(ws, w, b->n * 3 * sizeof *w);
    scale_rows(b->scale, b->strength, b->n, ws);
    ffd_status st =
        L(m)->inner->vt->sensitivity_transpose_product(L(m)->inner, b->inner, ws, out, err);
    ffd_free(ws);
    return st;
}

static ffd_status lay_fold_check(sess_method *m, ffd_fold_report *out, ffd_error *err)
{
    if (!L(m)->inner->vt->fold_check)
        return unsupported(m, "fold check", err);
    return L(m)->inner->vt->fold_check(L(m)->inner, out, err);
}

static const sess_vtable layered_vt = {
    .name = NULL, /* the inner method's: ffd_sess_caps */
    .destroy = lay_destroy,
    .eval = lay_eval,
    .control_count = lay_control_count,
    .controls = lay_controls,
    .describe = lay_describe,
    .begin = lay_begin,
    .set_controls = lay_set_controls,
    .linear_map = lay_linear_map,
    .set_variables = lay_set_variables,
    .end = lay_end,
    .set_motion = lay_set_motion,
    .snapshot = lay_snapshot,
    .restore = lay_restore,
    .snapshot_free = lay_snapshot_free,
    .reset = lay_reset,
    .rig = lay_rig,
    .influence = lay_influence,
    .op = lay_op,
    .bind = lay_bind,
    .binding_free = lay_binding_free,
    .eval_points = lay_eval_points,
    .jacobian_points = lay_jacobian_points,
    .map_points = lay_map_points,
    .handle = lay_handle,
    .sensitivity_product = lay_sensitivity_product,
    .sensitivity_transpose_product = lay_sensitivity_transpose_product,
    .fold_check = lay_fold_check,
};

/* ---- loading ---- */

/* The per-vertex scale s w_i from the rig's weights (NULL: none given). */
static ffd_status vertex_scale(const sess_ctx *ctx, const ffd_rig *rig, double **out,
                               ffd_error *err)
{
    const ffd_rig_layers *ly = rig->layers;
    *out = NULL;
    if (ly->weights_kind == FFD_WEIGHTS_NONE)
        return FFD_OK;
    double *w = NULL;
    if (ly->weights_kind == FFD_WEIGHTS_ATTRIBUTE) {
        ffd_error inner = {{0}};
        ffd_status st = ffd_mesh_vertex_attribute(ctx->mesh, ly->weights_name, &w, &inner);
        if (st)
            return ffd_fail(err, st, "%s: weights.attribute: %s", rig->name, inner.message);
    } else {
        if (ly->weight_count != ctx->n)
            return ffd_fail(err, FFD_ERR_INVALID, "%s: weights%s%s: %zu weights for %zu vertices",
                            rig->name, ly->weights_kind == FFD_WEIGHTS_FILE ? ": " : ".values",
                            ly->weights_kind == FFD_WEIGHTS_FILE ? ly->weights_name : "",
                            ly->weight_count, ctx->n);
        if (!(w = ffd_malloc_array(ctx->n ? ctx->n : 1, sizeof *w)))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
        memcpy(w, ly->weights, ctx->n * sizeof *w);
    }
    for (size_t i = 0; i < ctx->n; i++)
        w[i] *= ly->strength; /* exact when the strength is 1 */
    *out = w;
    return FFD_OK;
}

ffd_status ffd_method_load(const ffd_method *method, const sess_ctx *ctx, const ffd_rig *rig,
                           sess_method **out, ffd_error *err)
{
    *out = NULL;
    sess_method *inner = NULL;
    ffd_status st = method->load(ctx, rig, &inner, err);
    if (st || ffd_rig_layers_trivial(rig->layers)) {
        *out = inner;
        return st;
    }
    layered *l = ffd_calloc(1, sizeof *l);
    if (!l) {
        inner->vt->destroy(inner);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    }
    l->base.vt = &layered_vt;
    l->base.ctx = ctx;
    l->inner = inner;
    l->fold_fraction = 1.0;
    if (!(l->layers = ffd_rig_layers_copy(rig->layers))) {
        lay_destroy(&l->base);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    }
    if ((st = vertex_scale(ctx, rig, &l->scale, err))) {
        lay_destroy(&l->base);
        return st;
    }
    /* what the constraints keep: the rest mesh's volume and barycentre */
    l->volume0 = ffd_cffd_volume(ctx->rest, ffd_mesh_face_offsets(ctx->mesh),
                                 ffd_mesh_face_indices(ctx->mesh), ffd_mesh_face_count(ctx->mesh));
    for (size_t i = 0; i < ctx->n; i++)
        for (int a = 0; a < 3; a++)
            l->barycentre0[a] += ctx->rest[3 * i + a];
    for (int a = 0; a < 3; a++)
        l->barycentre0[a] /= ctx->n ? (double)ctx->n : 1.0;
    ffd_error inner_err = {{0}};
    /* the rig's own moves: the fold policy from rest to them, then the constraints */
    if (l->layers->fold_policy != FFD_FOLD_ALLOW && !inner->vt->fold_check)
        st = ffd_fail(err, FFD_ERR_UNSUPPORTED,
                      "%s: fold_policy: the %s method has no fold check (the lattice and the "
                      "T-spline have one; docs/constraints.md)",
                      rig->name, name_of(&l->base));
    else if (fold_policy(l) != FFD_FOLD_ALLOW) {
        size_t count = inner->vt->control_count(inner);
        double *moved = ffd_malloc_array(count ? count : 1, 3 * sizeof *moved);
        double *rest = ffd_malloc_array(count ? count : 1, 3 * sizeof *rest);
        uint32_t *ids = ffd_malloc_array(count ? count : 1, sizeof *ids);
        void *blob = NULL;
        if (!moved || !rest || !ids)
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
        if (!st) {
            for (size_t c = 0; c < count; c++)
                ids[c] = (uint32_t)c;
            inner->vt->controls(inner, moved);
            /* the controls at rest, then the state as loaded again */
            if (!(st = inner->vt->snapshot(inner, &blob, &inner_err)) &&
                !(st = inner->vt->reset(inner, &inner_err))) {
                inner->vt->controls(inner, rest);
                st = inner->vt->restore(inner, blob, &inner_err);
            }
            if (blob)
                inner->vt->snapshot_free(blob);
            if (!st && !(st = inner->vt->begin(inner, ids, count, 0, &inner_err))) {
                st = police(l, ids, count, rest, moved, &inner_err);
                inner->vt->end(inner, st == FFD_OK);
            }
            if (st)
                st = ffd_fail(err, st, "%s: %s", rig->name, inner_err.message);
        }
        ffd_free(moved);
        ffd_free(rest);
        ffd_free(ids);
    }
    if (!st && (st = constrain(l, &inner_err)))
        st = ffd_fail(err, st, "%s: %s", rig->name, inner_err.message);
    if (st) {
        lay_destroy(&l->base);
        return st;
    }
    *out = &l->base;
    return FFD_OK;
}

ffd_status ffd_layers_outcome(const sess_method *m, cJSON *details)
{
    if (m->vt != &layered_vt)
        return FFD_OK;
    const layered *l = CL(m);
    cJSON *o = cJSON_CreateObject();
    int ok = ffd_sess_add_item(details, "layers", o) &&
             ffd_sess_add_item(o, "strength", ffd_sess_number(l->layers->strength)) &&
             (!l->scale || cJSON_AddNumberToObject(o, "weights", (double)m->ctx->n));
    if (ok && l->constrained) {
        cJSON *c = cJSON_CreateObject();
        ok = ffd_sess_add_item(o, "constraints", c) &&
             cJSON_AddNumberToObject(c, "count", (double)l->cffd.constraint_count) &&
             ffd_sess_add_item(c, "max_residual", ffd_sess_number(l->cffd.max_residual)) &&
             ffd_sess_add_item(c, "change_norm", ffd_sess_number(l->cffd.change_norm)) &&
             cJSON_AddNumberToObject(c, "iterations", (double)l->cffd.iterations) &&
             cJSON_AddNumberToObject(c, "rank", (double)l->cffd.rank);
    }
    if (ok && l->layers->fold_policy != FFD_FOLD_ALLOW) {
        cJSON *f = cJSON_CreateObject();
        ok = ffd_sess_add_item(o, "fold", f) &&
             cJSON_AddStringToObject(f, "policy", l->layers->fold_policy == FFD_FOLD_REFUSE
                                                      ? "refuse"
                                                      : "shorten") &&
             ffd_sess_add_item(f, "fraction", ffd_sess_number(l->fold_fraction)) &&
             cJSON_AddNumberToObject(f, "folded_cells", (double)l->fold_folded);
    }
    return ok ? FFD_OK : FFD_ERR_NOMEM;
}

/* ---- the editor's weights (session "weights" op) ---- */

ffd_status ffd_layers_weights(const sess_method *m, double *out, ffd_error *err)
{
    size_t n = m->ctx->n;
    const ffd_rig_layers *ly = m->vt == &layered_vt ? CL(m)->layers : NULL;
    if (!ly || ly->weights_kind == FFD_WEIGHTS_NONE) {
        for (size_t i = 0; i < n; i++)
            out[i] = 1.0;
        return FFD_OK;
    }
    if (ly->weights_kind != FFD_WEIGHTS_ATTRIBUTE) {
        memcpy(out, ly->weights, n * sizeof *out);
        return FFD_OK;
    }
    double *w = NULL;
    ffd_status st = ffd_mesh_vertex_attribute(m->ctx->mesh, ly->weights_name, &w, err);
    if (!st) {
        memcpy(out, w, n * sizeof *out);
        ffd_free(w);
    }
    return st;
}

ffd_status ffd_layers_set_weights(sess_method **m, const double *w, ffd_error *err)
{
    sess_method *in = *m;
    const sess_ctx *ctx = in->ctx;
    size_t n = ctx->n;
    if (in->vt != &layered_vt && !w)
        return FFD_OK; /* no weights, none asked for */
    double *values = NULL, *scale = NULL;
    if (w && (!(values = ffd_malloc_array(n ? n : 1, sizeof *values)) ||
              !(scale = ffd_malloc_array(n ? n : 1, sizeof *scale)))) {
        ffd_free(values);
        return ffd_fail(err, FFD_ERR_NOMEM, "weights: out of memory for %zu vertices", n);
    }
    layered *l = NULL;
    if (in->vt == &layered_vt) {
        l = L(in);
    } else {
        /* a method without layers gets them: strength 1, no constraints */
        l = ffd_calloc(1, sizeof *l);
        ffd_rig_layers *ly = l ? ffd_calloc(1, sizeof *ly) : NULL;
        if (!ly) {
            ffd_free(l);
            ffd_free(values);
            ffd_free(scale);
            return ffd_fail(err, FFD_ERR_NOMEM, "weights: out of memory");
        }
        ly->strength = 1.0;
        ly->mask_axes[0] = ly->mask_axes[1] = ly->mask_axes[2] = 1;
        l->base.vt = &layered_vt;
        l->base.ctx = ctx;
        l->inner = in;
        l->layers = ly;
        l->fold_fraction = 1.0;
        *m = &l->base;
    }
    ffd_rig_layers *ly = l->layers;
    ffd_free(ly->weights);
    ffd_free(ly->weights_name);
    ffd_free(ly->weights_path);
    ly->weights_name = ly->weights_path = NULL;
    ly->weights = values;
    ly->weight_count = w ? n : 0;
    ly->weights_kind = w ? FFD_WEIGHTS_VALUES : FFD_WEIGHTS_NONE;
    ffd_free(l->scale);
    l->scale = scale;
    for (size_t i = 0; w && i < n; i++) {
        values[i] = w[i];
        scale[i] = w[i] * ly->strength; /* as vertex_scale: exact when the strength is 1 */
    }
    /* a replay of the rig projects its controls onto the constraints with
     * these weights: so does the session */
    return constrain(l, err);
}
