/* session_pbffd — the editor's PB-FFD method (McDonnell & Qin, "PB-FFD: A
 * Point-based Technique for Free-Form Deformation"): a control set placed
 * automatically (§3.2.1) or taken from a rig, its hierarchy (§3.4), moves
 * and frame edits of the shown level, and deformation curves (§3.5).
 *
 * The state is a log replayed on the deformer, in the order ffd_rig_apply
 * replays the rig this method writes (docs/rig.md "PB-FFD rigs"):
 *     reset, the moves in order, the frames (absolute), then each curve
 *     created on the result of everything before it, its moves replayed.
 * A drag moves incrementally (or, once frames exist, replays with the drag's
 * moves before the frames, as the rig will) and is logged when it ends, one
 * move per control; the log is then replayed, so that the state is always
 * the log's replay and snapshots restore bitwise. A move made after a frame
 * edit is therefore replayed before it: with a hierarchy, a move is
 * re-parameterised in the coarser level as the rig will do it. */
#include "pbffd/pbffd_method.h"
#include "pbffd/pbffd.h"
#include "session/session.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define CURVE_RADIUS_FACTOR 0.15 /* default curve ROI radius, times the diagonal */

typedef struct pb_move {
    uint32_t level, index;
    double delta[3];
} pb_move;

typedef struct pb_frame {
    uint32_t level, index;
    double frame[3][3]; /* absolute: the matrix A of eq. 7 */
} pb_frame;

typedef struct pb_curve {
    double *points; /* count by 3, as created */
    size_t count;
    double radius;
    uint32_t samples;
    ffd_rig_curve_move *moves;
    size_t move_count, move_cap;
    ffd_pbffd_curve *obj; /* built on the result before it; NULL: stale */
} pb_curve;

typedef struct pb_drag {
    int active;
    size_t level, ebf_count, point_count;
    double *begin;      /* every control at begin (EBFs of level, then curve points) */
    double *want;       /* ebf_count by 3: the drag's total move per EBF */
    double *applied;    /* ebf_count by 3: moved incrementally so far */
    double *cp_want;    /* curve points by 3 */
    double *cp_applied; /* curve points by 3, on the curve objects */
    size_t curve_from;  /* first curve whose points moved; SIZE_MAX: none */
} pb_drag;

typedef struct pb_method {
    sess_method base;
    ffd_ebf *controls; /* level 0 as created: the rig's explicit "controls" */
    size_t control_count;
    ffd_pbffd_options opt;
    int placed;
    size_t interior, exterior; /* placed counts (placed only) */
    ffd_pbffd *pb;             /* bound to ctx->rest */
    size_t level;              /* shown and edited */
    pb_move *moves;
    size_t move_count, move_cap;
    pb_frame *frames;
    size_t frame_count, frame_cap;
    pb_curve *curves;
    size_t curve_count;
    double *scratch; /* n by 3 */
    pb_drag drag;
} pb_method;

typedef struct pb_snapshot {
    size_t level;
    pb_move *moves;
    size_t move_count;
    pb_frame *frames;
    size_t frame_count;
    size_t curve_count;
    ffd_rig_curve_move **curve_moves;
    size_t *curve_move_count;
} pb_snapshot;

static const sess_vtable pbffd_vtable;

static int nonzero3(const double v[3])
{
    return v[0] != 0 || v[1] != 0 || v[2] != 0;
}

static size_t ebf_count(const pb_method *m)
{
    return ffd_pbffd_control_count(m->pb, m->level);
}

static size_t curve_point_count(const pb_method *m)
{
    size_t t = 0;
    for (size_t c = 0; c < m->curve_count; c++)
        t += m->curves[c].count;
    return t;
}

/* Control id -> curve c, point i (ids after the level's EBFs). */
static void curve_of(const pb_method *m, size_t id, size_t *c, size_t *i)
{
    size_t off = ebf_count(m);
    for (*c = 0; *c < m->curve_count && id >= off + m->curves[*c].count; (*c)++)
        off += m->curves[*c].count;
    *i = id - off;
}

/* First curve point of curve c among the drag's cp arrays. */
static size_t curve_base(const pb_method *m, size_t c)
{
    size_t off = 0;
    for (size_t j = 0; j < c; j++)
        off += m->curves[j].count;
    return off;
}

/* ---- replay ---------------------------------------------------------- */

static void drop_curves(pb_method *m, size_t from)
{
    for (size_t c = from; c < m->curve_count; c++) {
        ffd_pbffd_curve_destroy(m->curves[c].obj);
        m->curves[c].obj = NULL;
    }
}

/* The PB-FFD stage from the log: reset, moves (and the drag's), frames. */
static ffd_status replay_pb(pb_method *m, ffd_error *err)
{
    ffd_error inner = {{0}};
    ffd_status s = FFD_OK;
    ffd_pbffd_reset(m->pb);
    drop_curves(m, 0);
    for (size_t i = 0; !s && i < m->move_count; i++)
        if ((s = ffd_pbffd_move(m->pb, m->moves[i].level, m->moves[i].index, m->moves[i].delta,
                                &inner)))
            return ffd_fail(err, s, "replay: moves[%zu]: %s", i, inner.message);
    if (m->drag.active)
        for (size_t j = 0; j < m->drag.ebf_count; j++) {
            double *want = m->drag.want + 3 * j;
            if (nonzero3(want) && (s = ffd_pbffd_move(m->pb, m->drag.level, j, want, &inner)))
                return ffd_fail(err, s, "drag: control %zu: %s", j, inner.message);
            memcpy(m->drag.applied + 3 * j, want, 3 * sizeof *want);
        }
    for (size_t i = 0; i < m->frame_count; i++) {
        const pb_frame *f = &m->frames[i];
        if ((s = ffd_pbffd_set_frame(m->pb, f->level, f->index, (const double(*)[3])f->frame,
                                     &inner)))
            return ffd_fail(err, s, "replay: frames[%zu]: %s", i, inner.message);
    }
    return FFD_OK;
}

/* The input of curve c: the result of everything before it (scratch). */
static ffd_status curve_input(pb_method *m, size_t c, ffd_error *err)
{
    if (c == 0)
        return ffd_pbffd_eval(m->pb, m->scratch, err);
    return ffd_pbffd_curve_eval(m->curves[c - 1].obj, m->scratch, err);
}

/* Builds curve c on its input and replays its moves (and the drag's). */
static ffd_status build_curve(pb_method *m, size_t c, ffd_error *err)
{
    pb_curve *cv = &m->curves[c];
    ffd_error inner = {{0}};
    ffd_pbffd_options o = {0};
    o.sigma = m->opt.sigma; /* as the rig's curves (pbffd_rig.c) */
    ffd_status s = curve_input(m, c, &inner);
    if (!s)
        s = ffd_pbffd_curve_create(cv->points, cv->count, cv->radius, cv->samples, m->scratch,
                                   m->base.ctx->n, &o, &cv->obj, &inner);
    for (size_t k = 0; !s && k < cv->move_count; k++)
        s = ffd_pbffd_curve_move(cv->obj, cv->moves[k].index, cv->moves[k].delta, &inner);
    if (!s && m->drag.active) {
        size_t base = curve_base(m, c);
        for (size_t i = 0; !s && i < cv->count; i++) {
            double *want = m->drag.cp_want + 3 * (base + i);
            if (nonzero3(want))
                s = ffd_pbffd_curve_move(cv->obj, i, want, &inner);
            memcpy(m->drag.cp_applied + 3 * (base + i), want, 3 * sizeof *want);
        }
    }
    if (s) {
        ffd_pbffd_curve_destroy(cv->obj);
        cv->obj = NULL;
        return ffd_fail(err, s, "curves[%zu]: %s", c, inner.message);
    }
    return FFD_OK;
}

static ffd_status build_curves(pb_method *m, ffd_error *err)
{
    for (size_t c = 0; c < m->curve_count; c++) {
        if (m->curves[c].obj)
            continue;
        drop_curves(m, c); /* each later curve stands on this one */
        ffd_status s = build_curve(m, c, err);
        if (s)
            return s;
    }
    return FFD_OK;
}

/* Current points of curve c: the object's, or replayed as curve_move does. */
static void curve_points(const pb_method *m, size_t c, double *out)
{
    const pb_curve *cv = &m->curves[c];
    if (cv->obj) {
        memcpy(out, ffd_pbffd_curve_control_points(cv->obj), cv->count * 3 * sizeof *out);
        return;
    }
    memcpy(out, cv->points, cv->count * 3 * sizeof *out);
    for (size_t k = 0; k < cv->move_count; k++)
        for (int a = 0; a < 3; a++)
            out[3 * cv->moves[k].index + a] += cv->moves[k].delta[a];
    if (m->drag.active) {
        size_t base = curve_base(m, c);
        for (size_t i = 0; i < cv->count; i++)
            for (int a = 0; a < 3; a++)
                out[3 * i + a] += m->drag.cp_want[3 * (base + i) + a];
    }
}

/* ---- construction ---------------------------------------------------- */

static void curve_free(pb_curve *cv)
{
    ffd_pbffd_curve_destroy(cv->obj);
    ffd_free(cv->points);
    ffd_free(cv->moves);
}

static void drag_free(pb_drag *d)
{
    ffd_free(d->begin);
    ffd_free(d->want);
    ffd_free(d->applied);
    ffd_free(d->cp_want);
    ffd_free(d->cp_applied);
    memset(d, 0, sizeof *d);
}

static void pb_destroy(sess_method *base)
{
    pb_method *m = (pb_method *)base;
    if (!m)
        return;
    drag_free(&m->drag);
    for (size_t c = 0; c < m->curve_count; c++)
        curve_free(&m->curves[c]);
    ffd_free(m->curves);
    ffd_pbffd_destroy(m->pb);
    ffd_free(m->controls);
    ffd_free(m->moves);
    ffd_free(m->frames);
    ffd_free(m->scratch);
    ffd_free(m);
}

/* A method around a bound deformer; takes controls and pb (freed on error). */
static ffd_status pb_new(const sess_ctx *ctx, ffd_ebf *controls, size_t count,
                         const ffd_pbffd_options *opt, ffd_pbffd *pb, pb_method **out,
                         ffd_error *err)
{
    pb_method *m = ffd_calloc(1, sizeof *m);
    double *scratch = ffd_malloc_array(ctx->n ? ctx->n : 1, 3 * sizeof *scratch);
    if (!m || !scratch) {
        ffd_free(m);
        ffd_free(scratch);
        ffd_free(controls);
        ffd_pbffd_destroy(pb);
        return ffd_fail(err, FFD_ERR_NOMEM, "pbffd: out of memory");
    }
    m->base.vt = &pbffd_vtable;
    m->base.ctx = ctx;
    m->controls = controls;
    m->control_count = count;
    m->opt = *opt;
    m->pb = pb;
    m->scratch = scratch;
    *out = m;
    return FFD_OK;
}

static ffd_status push_move(pb_method *m, size_t level, size_t index, const double d[3])
{
    if (!ffd_grow((void **)&m->moves, &m->move_cap, m->move_count + 1, sizeof *m->moves))
        return FFD_ERR_NOMEM;
    pb_move *e = &m->moves[m->move_count++];
    e->level = (uint32_t)level;
    e->index = (uint32_t)index;
    memcpy(e->delta, d, sizeof e->delta);
    return FFD_OK;
}

/* The frame of (level, index) in the frames log: replaced, or appended. */
static ffd_status put_frame(pb_frame **frames, size_t *count, size_t *cap, size_t level,
                            size_t index, const double frame[3][3])
{
    size_t i = 0;
    while (i < *count && ((*frames)[i].level != level || (*frames)[i].index != index))
        i++;
    if (i == *count) {
        if (!ffd_grow((void **)frames, cap, *count + 1, sizeof **frames))
            return FFD_ERR_NOMEM;
        (*frames)[i].level = (uint32_t)level;
        (*frames)[i].index = (uint32_t)index;
        (*count)++;
    }
    memcpy((*frames)[i].frame, frame, sizeof(*frames)[i].frame);
    return FFD_OK;
}

/* ---- create ----------------------------------------------------------
 * The body is a PB-FFD rig's creation part (ffd_method_create); this hook
 * is what the editor does differently from a rig. */

#define EDITOR_PLACED 60 /* the editor's interior and exterior counts */

/* The old body's top-level placement options, the same as inside "controls". */
static const char *const old_placement_keys[] = {"interior", "exterior", "offset",
                                                 "radius_factor", "voronoi_sites", NULL};

ffd_status ffd_sess_pbffd_create_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p)
{
    (void)ctx;
    /* automatic placement ("controls" absent or "auto") with the editor's counts */
    cJSON *controls = cJSON_GetObjectItemCaseSensitive(body, "controls");
    if (!controls || (cJSON_IsString(controls) && !strcmp(controls->valuestring, "auto"))) {
        cJSON *placement = cJSON_CreateObject();
        if (!placement || !(controls ? cJSON_ReplaceItemInObjectCaseSensitive(body, "controls", placement)
                                     : cJSON_AddItemToObject(body, "controls", placement))) {
            cJSON_Delete(placement);
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        }
        controls = placement;
    }
    for (const char *const *k = old_placement_keys; *k; k++) {
        cJSON *item = cJSON_GetObjectItemCaseSensitive(body, *k);
        if (!item)
            continue;
        if (!cJSON_IsObject(controls))
            return ffd_fail(p->err, FFD_ERR_PARSE,
                            "%s: %s: a placement option (the old form of controls.%s), but "
                            "\"controls\" does not place them",
                            p->name, *k, *k);
        if (cJSON_GetObjectItemCaseSensitive(controls, *k))
            return ffd_fail(p->err, FFD_ERR_PARSE,
                            "%s: %s: given twice, at the top level (the old form) and as "
                            "controls.%s",
                            p->name, *k, *k);
        cJSON_DetachItemViaPointer(body, item);
        if (!cJSON_AddItemToObject(controls, *k, item)) {
            cJSON_Delete(item);
            return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
        }
    }
    if (cJSON_IsObject(controls)) {
        if (!cJSON_GetObjectItemCaseSensitive(controls, "interior"))
            cJSON_AddNumberToObject(controls, "interior", EDITOR_PLACED);
        if (!cJSON_GetObjectItemCaseSensitive(controls, "exterior"))
            cJSON_AddNumberToObject(controls, "exterior", EDITOR_PLACED);
    }
    return FFD_OK;
}

ffd_status ffd_sess_pbffd_create(const sess_ctx *ctx, const cJSON *body, sess_method **out,
                                 ffd_error *err)
{
    return ffd_method_create(&ffd_method_pbffd, ctx, body, out, err);
}

/* ---- load ------------------------------------------------------------ */

static ffd_status load_curves(pb_method *m, const ffd_rig_pbffd *r, ffd_error *err)
{
    if (!r->curve_count)
        return FFD_OK;
    if (!(m->curves = ffd_calloc(r->curve_count, sizeof *m->curves)))
        return ffd_fail(err, FFD_ERR_NOMEM, "load: out of memory for %zu curves", r->curve_count);
    m->curve_count = r->curve_count;
    for (size_t c = 0; c < r->curve_count; c++) {
        const ffd_rig_curve *rc = &r->curves[c];
        pb_curve *cv = &m->curves[c];
        cv->points = ffd_malloc_array(rc->point_count, 3 * sizeof *cv->points);
        cv->moves = ffd_malloc_array(rc->move_count ? rc->move_count : 1, sizeof *cv->moves);
        if (!cv->points || !cv->moves)
            return ffd_fail(err, FFD_ERR_NOMEM, "load: out of memory for curves[%zu]", c);
        memcpy(cv->points, rc->points, rc->point_count * 3 * sizeof *cv->points);
        if (rc->move_count)
            memcpy(cv->moves, rc->moves, rc->move_count * sizeof *cv->moves);
        cv->count = rc->point_count;
        cv->radius = rc->radius;
        cv->samples = rc->samples;
        cv->move_cap = rc->move_count ? rc->move_count : 1;
        cv->move_count = rc->move_count;
    }
    return FFD_OK;
}

/* Vertex constraints (§3.3) as moves at constraint_level; point constraints
 * would bind points beyond the mesh's vertices (and move the master): refused.
 */
static ffd_status check_constraints(const ffd_rig *rig, size_t n, ffd_error *err)
{
    for (size_t c = 0; c < rig->constraint_count; c++) {
        const ffd_rig_constraint *con = &rig->constraints[c];
        if (con->kind == FFD_RIG_CONSTRAINT_POINT)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "%s: constraints[%zu].point: point constraints bind points beyond "
                            "the mesh's vertices, which an editing session does not hold; use "
                            "vertex constraints (pins), or apply the rig with ffd deform",
                            rig->name, c);
        if (con->vertex >= n)
            return ffd_fail(err, FFD_ERR_RANGE,
                            "%s: constraints[%zu].vertex: %u out of range (mesh has %zu "
                            "vertices)",
                            rig->name, c, con->vertex, n);
    }
    return FFD_OK;
}

static ffd_status load_constraints(pb_method *m, const ffd_rig *rig, ffd_error *err)
{
    const size_t k = rig->constraint_count, level = ffd_rig_pbffd_of(rig)->constraint_level;
    if (!k)
        return FFD_OK;
    const size_t controls = ffd_pbffd_control_count(m->pb, level);
    size_t *rows = ffd_malloc_array(k, sizeof *rows);
    double *delta = ffd_calloc(controls ? controls : 1, 3 * sizeof *delta);
    ffd_manip_result result;
    ffd_error inner = {{0}};
    ffd_status s =
        rows && delta ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    for (size_t c = 0; !s && c < k; c++)
        rows[c] = rig->constraints[c].vertex;
    if (!s && (s = ffd_pbffd_eval(m->pb, m->scratch, &inner)))
        s = ffd_fail(err, s, "%s: evaluating: %s", rig->name, inner.message);
    if (!s)
        s = ffd_rig_pb_constraint_delta(rig, m->pb, rows, m->scratch, delta, &result, err);
    for (size_t j = 0; !s && j < controls; j++)
        if (nonzero3(delta + 3 * j) && push_move(m, level, j, delta + 3 * j))
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    ffd_free(rows);
    ffd_free(delta);
    return s;
}

/* The rig's moves and frames, logged with their resolved controls. */
static ffd_status load_edits(pb_method *m, const ffd_rig *rig, ffd_error *err)
{
    const ffd_rig_pbffd *r = ffd_rig_pbffd_of(rig);
    size_t total = r->move_count + r->frame_count;
    size_t *resolved = ffd_malloc_array(total ? total : 1, sizeof *resolved);
    double(*frames)[3][3] = ffd_malloc_array(r->frame_count ? r->frame_count : 1, sizeof *frames);
    ffd_status s = resolved && frames
                       ? ffd_rig_pb_apply_edits(rig, m->pb, resolved, frames, err)
                       : ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    for (size_t i = 0; !s && i < r->move_count; i++)
        if (push_move(m, r->moves[i].level, resolved[i], r->moves[i].delta))
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    for (size_t i = 0; !s && i < r->frame_count; i++)
        if (put_frame(&m->frames, &m->frame_count, &m->frame_cap, r->frames[i].level,
                      resolved[r->move_count + i], (const double(*)[3])frames[i]))
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    ffd_free(resolved);
    ffd_free(frames);
    return s;
}

ffd_status ffd_sess_pbffd_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                           ffd_error *err)
{
    *out = NULL;
    if (rig->method != &ffd_method_pbffd)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: not a \"pbffd\" rig", rig->name);
    ffd_status s = check_constraints(rig, ctx->n, err);
    if (s)
        return s;
    const ffd_rig_pbffd *r = ffd_rig_pbffd_of(rig);
    ffd_error inner = {{0}};
    ffd_ebf *controls = NULL;
    size_t count = r->control_count;
    ffd_placement_report report;
    memset(&report, 0, sizeof report);
    if (r->controls_auto) {
        if ((s = ffd_pbffd_place(ctx->mesh, &r->placement, &controls, &count, &report, &inner)))
            return ffd_rig_wrap(err, s, rig->name, "controls (automatic placement)", &inner);
    } else {
        if (!(controls = ffd_malloc_array(count, sizeof *controls)))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
        memcpy(controls, r->controls, count * sizeof *controls);
    }
    ffd_pbffd *pb = NULL;
    if ((s = ffd_pbffd_create(controls, count, ctx->rest, ctx->n, &r->options, &pb, &inner))) {
        ffd_free(controls);
        return ffd_rig_wrap(err, s, rig->name, r->controls_auto ? "controls (placed)" : "controls",
                            &inner);
    }
    pb_method *m = NULL;
    if ((s = pb_new(ctx, controls, count, &r->options, pb, &m, err)))
        return s;
    m->placed = r->controls_auto;
    m->interior = report.interior_count;
    m->exterior = report.exterior_count;
    /* moves, frames, constraints as ffd_rig_apply_pbffd; then the log's own
     * replay (the constraints' moves come before the frames there) */
    if ((s = load_edits(m, rig, err)) || (s = load_constraints(m, rig, err)) ||
        (s = replay_pb(m, err)) || (s = load_curves(m, r, err))) {
        pb_destroy(&m->base);
        return s;
    }
    *out = &m->base;
    return FFD_OK;
}

/* ---- evaluation and controls ------------------------------------------ */

static ffd_status pb_eval(sess_method *base, double *out, ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    if (!m->curve_count)
        return ffd_pbffd_eval(m->pb, out, err);
    ffd_status s = build_curves(m, err);
    if (s)
        return s;
    /* curves (§3.5): the last one's points hold everything before it */
    return ffd_pbffd_curve_eval(m->curves[m->curve_count - 1].obj, out, err);
}

static size_t pb_control_count(const sess_method *base)
{
    const pb_method *m = (const pb_method *)base;
    return ebf_count(m) + curve_point_count(m);
}

static void pb_controls(const sess_method *base, double *out)
{
    const pb_method *m = (const pb_method *)base;
    size_t k = ebf_count(m);
    for (size_t j = 0; j < k; j++) {
        ffd_ebf e;
        if (ffd_pbffd_control(m->pb, m->level, j, &e, NULL) == FFD_OK)
            memcpy(out + 3 * j, e.center, sizeof e.center);
    }
    out += 3 * k;
    for (size_t c = 0; c < m->curve_count; c++) {
        curve_points(m, c, out);
        out += 3 * m->curves[c].count;
    }
}

/* ---- describe -------------------------------------------------------- */

/* One EBF in the state: unit frame directions and "enabled". */
static cJSON *ebf_json(const ffd_ebf *e)
{
    double frame[3][3];
    for (int a = 0; a < 3; a++) {
        double len = sqrt(e->frame[a][0] * e->frame[a][0] + e->frame[a][1] * e->frame[a][1] +
                          e->frame[a][2] * e->frame[a][2]);
        for (int b = 0; b < 3; b++)
            frame[a][b] = e->frame[a][b] / len;
    }
    cJSON *o = cJSON_CreateObject();
    int ok = o && ffd_sess_add_item(o, "radius", ffd_sess_vec3(e->radius)) &&
             ffd_sess_add_item(o, "frame", ffd_sess_matrix3((const double(*)[3])frame)) &&
             cJSON_AddBoolToObject(o, "enabled", !e->disabled);
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

static cJSON *curves_json(const pb_method *m, cJSON *edges)
{
    cJSON *a = cJSON_CreateArray();
    size_t off = ebf_count(m);
    for (size_t c = 0; a && c < m->curve_count; c++) {
        const pb_curve *cv = &m->curves[c];
        cJSON *o = cJSON_CreateObject();
        if (!ffd_sess_add_to_array(a, o) || !cJSON_AddNumberToObject(o, "offset", (double)off) ||
            !cJSON_AddNumberToObject(o, "count", (double)cv->count) ||
            !cJSON_AddNumberToObject(o, "radius", cv->radius)) {
            cJSON_Delete(a);
            return NULL;
        }
        for (size_t i = 0; i + 1 < cv->count; i++)
            if (!ffd_sess_add_edge(edges, (uint32_t)(off + i), (uint32_t)(off + i + 1))) {
                cJSON_Delete(a);
                return NULL;
            }
        off += cv->count;
    }
    return a;
}

static ffd_status pb_describe(const sess_method *base, cJSON *params, cJSON *controls,
                              ffd_error *err)
{
    const pb_method *m = (const pb_method *)base;
    const size_t levels = ffd_pbffd_level_count(m->pb), k = ebf_count(m);
    int ok = (m->placed ? cJSON_AddNumberToObject(params, "interior", (double)m->interior) &&
                              cJSON_AddNumberToObject(params, "exterior", (double)m->exterior)
                        : cJSON_AddNullToObject(params, "interior") &&
                              cJSON_AddNullToObject(params, "exterior")) &&
             cJSON_AddNumberToObject(params, "levels", (double)levels) &&
             cJSON_AddNumberToObject(params, "sigma", m->opt.sigma > 0 ? m->opt.sigma : 3.0) &&
             cJSON_AddNumberToObject(controls, "level", (double)m->level) &&
             cJSON_AddNumberToObject(controls, "levels", (double)levels);
    cJSON *ebfs = ok ? cJSON_CreateArray() : NULL;
    ok = ok && ffd_sess_add_item(controls, "ebfs", ebfs);
    for (size_t j = 0; ok && j < k; j++) {
        ffd_ebf e;
        ok = ffd_pbffd_control(m->pb, m->level, j, &e, NULL) == FFD_OK &&
             ffd_sess_add_to_array(ebfs, ebf_json(&e));
    }
    cJSON *edges = ok ? cJSON_CreateArray() : NULL;
    ok = ok && ffd_sess_add_item(controls, "edges", edges);
    ok = ok && ffd_sess_add_item(controls, "curves", curves_json(m, edges));
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
}

/* ---- drags ----------------------------------------------------------- */

/* Room in the logs for what end(commit) appends, so that it cannot fail. */
static int reserve_logs(pb_method *m, size_t ebfs)
{
    if (!ffd_grow((void **)&m->moves, &m->move_cap, m->move_count + ebfs + 1, sizeof *m->moves))
        return 0;
    for (size_t c = 0; c < m->curve_count; c++) {
        pb_curve *cv = &m->curves[c];
        if (!ffd_grow((void **)&cv->moves, &cv->move_cap, cv->move_count + cv->count,
                      sizeof *cv->moves))
            return 0;
    }
    return 1;
}

static void pb_end(sess_method *base, int commit);

static ffd_status pb_begin(sess_method *base, const uint32_t *ids, size_t k, int arap,
                           ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    if (m->drag.active)
        pb_end(base, 0);
    pb_drag *d = &m->drag;
    d->level = m->level;
    d->ebf_count = ebf_count(m);
    d->point_count = curve_point_count(m);
    const size_t total = d->ebf_count + d->point_count;
    d->begin = ffd_malloc_array(total ? total : 1, 3 * sizeof *d->begin);
    d->want = ffd_calloc(d->ebf_count ? d->ebf_count : 1, 3 * sizeof *d->want);
    d->applied = ffd_calloc(d->ebf_count ? d->ebf_count : 1, 3 * sizeof *d->applied);
    d->cp_want = ffd_calloc(d->point_count ? d->point_count : 1, 3 * sizeof *d->cp_want);
    d->cp_applied = ffd_calloc(d->point_count ? d->point_count : 1, 3 * sizeof *d->cp_applied);
    if (!d->begin || !d->want || !d->applied || !d->cp_want || !d->cp_applied ||
        !reserve_logs(m, d->ebf_count)) {
        drag_free(d);
        return ffd_fail(err, FFD_ERR_NOMEM, "drag_begin: out of memory");
    }
    pb_controls(base, d->begin);
    d->curve_from = SIZE_MAX;
    d->active = 1;
    return FFD_OK;
}

/* Brings the deformer to the drag's wanted moves: incrementally, or by a
 * replay once frames exist (the rig replays moves before frames). */
static ffd_status apply_drag(pb_method *m, ffd_error *err)
{
    pb_drag *d = &m->drag;
    ffd_error inner = {{0}};
    int ebf_changed = 0;
    for (size_t j = 0; j < d->ebf_count; j++)
        for (int a = 0; a < 3; a++)
            ebf_changed |= d->want[3 * j + a] != d->applied[3 * j + a];
    ffd_status s = FFD_OK;
    if (ebf_changed && m->frame_count) {
        if ((s = replay_pb(m, err)))
            return s;
    } else if (ebf_changed) {
        for (size_t j = 0; j < d->ebf_count; j++) {
            double *w = d->want + 3 * j, *ap = d->applied + 3 * j;
            double step[3] = {w[0] - ap[0], w[1] - ap[1], w[2] - ap[2]};
            if (!nonzero3(step))
                continue;
            if ((s = ffd_pbffd_move(m->pb, d->level, j, step, &inner)))
                return ffd_fail(err, s, "drag: control %zu: %s", j, inner.message);
            memcpy(ap, w, 3 * sizeof *w);
        }
        drop_curves(m, 0);
    }
    for (size_t c = 0, base = 0; c < m->curve_count; base += m->curves[c++].count) {
        pb_curve *cv = &m->curves[c];
        for (size_t i = 0; cv->obj && i < cv->count; i++) {
            double *w = d->cp_want + 3 * (base + i), *ap = d->cp_applied + 3 * (base + i);
            double step[3] = {w[0] - ap[0], w[1] - ap[1], w[2] - ap[2]};
            if (!nonzero3(step))
                continue;
            if ((s = ffd_pbffd_curve_move(cv->obj, i, step, &inner)))
                return ffd_fail(err, s, "drag: curve %zu point %zu: %s", c, i, inner.message);
            memcpy(ap, w, 3 * sizeof *w);
            drop_curves(m, c + 1);
        }
    }
    return FFD_OK;
}

/* Sets the wanted moves through fn, applies them; on error the wanted moves
 * before are restored and re-applied. */
static ffd_status drag_to(pb_method *m, const uint32_t *ids, size_t k, const double *targets,
                          const double *dv, ffd_error *err)
{
    pb_drag *d = &m->drag;
    double *old = ffd_malloc_array(d->ebf_count + d->point_count + 1, 3 * sizeof *old);
    if (!old)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    memcpy(old, d->want, d->ebf_count * 3 * sizeof *old);
    memcpy(old + 3 * d->ebf_count, d->cp_want, d->point_count * 3 * sizeof *old);
    size_t curve_from = d->curve_from;
    if (dv)
        memcpy(d->want, dv, d->ebf_count * 3 * sizeof *dv);
    for (size_t i = 0; i < k; i++) {
        const double *b = d->begin + 3 * ids[i], *t = targets + 3 * i;
        double *w =
            ids[i] < d->ebf_count ? d->want + 3 * ids[i] : d->cp_want + 3 * (ids[i] - d->ebf_count);
        for (int a = 0; a < 3; a++)
            w[a] = t[a] - b[a];
        if (ids[i] >= d->ebf_count) {
            size_t c, j;
            curve_of(m, ids[i], &c, &j);
            if (c < d->curve_from)
                d->curve_from = c;
        }
    }
    ffd_status s = apply_drag(m, err);
    if (s) {
        memcpy(d->want, old, d->ebf_count * 3 * sizeof *old);
        memcpy(d->cp_want, old + 3 * d->ebf_count, d->point_count * 3 * sizeof *old);
        d->curve_from = curve_from;
        if (apply_drag(m, NULL))
            replay_pb(m, NULL);
    }
    ffd_free(old);
    return s;
}

static ffd_status check_finite(const double *v, size_t n, const char *what, ffd_error *err)
{
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(v[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "drag: %s[%zu]: not finite", what, i / 3);
    return FFD_OK;
}

static ffd_status pb_set_controls(sess_method *base, const uint32_t *ids, size_t k,
                                  const double *targets, ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    if (!m->drag.active || m->drag.level != m->level)
        return ffd_fail(err, FFD_ERR_INVALID, SESS_CONFLICT "drag: no drag in progress");
    for (size_t i = 0; i < k; i++)
        if (ids[i] >= m->drag.ebf_count + m->drag.point_count)
            return ffd_fail(err, FFD_ERR_RANGE, "drag: control %u out of range (%zu controls)",
                            ids[i], m->drag.ebf_count + m->drag.point_count);
    ffd_status s = check_finite(targets, k, "targets", err);
    return s ? s : drag_to(m, ids, k, targets, NULL, err);
}

static ffd_status pb_linear_map(sess_method *base, ffd_linear_map *map, ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    ffd_error inner = {{0}};
    ffd_status s = ffd_pbffd_linear_map(m->pb, m->level, map, &inner);
    return s ? ffd_fail(err, s, "linear map: %s", inner.message) : FFD_OK;
}

static ffd_status pb_set_variables(sess_method *base, const double *dv, ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    if (!m->drag.active || m->drag.level != m->level)
        return ffd_fail(err, FFD_ERR_INVALID, SESS_CONFLICT "drag: no drag in progress");
    ffd_status s = check_finite(dv, m->drag.ebf_count, "variables", err);
    return s ? s : drag_to(m, NULL, 0, NULL, dv, err);
}

static void pb_end(sess_method *base, int commit)
{
    pb_method *m = (pb_method *)base;
    pb_drag *d = &m->drag;
    if (!d->active)
        return;
    int ebf_moved = 0;
    for (size_t j = 0; j < d->ebf_count; j++) {
        ebf_moved |= nonzero3(d->want + 3 * j) || nonzero3(d->applied + 3 * j);
        if (commit && nonzero3(d->want + 3 * j))
            push_move(m, d->level, j, d->want + 3 * j); /* reserved at begin */
    }
    for (size_t c = 0, b = 0; commit && c < m->curve_count; b += m->curves[c++].count) {
        pb_curve *cv = &m->curves[c];
        for (size_t i = 0; i < cv->count; i++)
            if (nonzero3(d->cp_want + 3 * (b + i))) {
                ffd_rig_curve_move *e = &cv->moves[cv->move_count++];
                e->index = (uint32_t)i;
                memcpy(e->delta, d->cp_want + 3 * (b + i), sizeof e->delta);
            }
    }
    size_t curve_from = d->curve_from;
    drag_free(d);
    /* the state becomes the log's replay (what the rig replays) */
    if (ebf_moved)
        replay_pb(m, NULL);
    else if (curve_from != SIZE_MAX)
        drop_curves(m, curve_from);
}

/* ---- snapshots and reset --------------------------------------------- */

static void pb_snapshot_free(void *blob)
{
    pb_snapshot *b = blob;
    if (!b)
        return;
    ffd_free(b->moves);
    ffd_free(b->frames);
    for (size_t c = 0; b->curve_moves && c < b->curve_count; c++)
        ffd_free(b->curve_moves[c]);
    ffd_free(b->curve_moves);
    ffd_free(b->curve_move_count);
    ffd_free(b);
}

static void *copy_of(const void *src, size_t count, size_t size)
{
    void *p = ffd_malloc_array(count ? count : 1, size);
    if (p && count)
        memcpy(p, src, count * size);
    return p;
}

static ffd_status pb_snapshot_take(const sess_method *base, void **blob, ffd_error *err)
{
    const pb_method *m = (const pb_method *)base;
    *blob = NULL;
    pb_snapshot *b = ffd_calloc(1, sizeof *b);
    int ok = b != NULL;
    if (ok) {
        b->level = m->level;
        b->moves = copy_of(m->moves, m->move_count, sizeof *m->moves);
        b->move_count = m->move_count;
        b->frames = copy_of(m->frames, m->frame_count, sizeof *m->frames);
        b->frame_count = m->frame_count;
        b->curve_moves = ffd_calloc(m->curve_count + 1, sizeof *b->curve_moves);
        b->curve_move_count = ffd_calloc(m->curve_count + 1, sizeof *b->curve_move_count);
        b->curve_count = m->curve_count;
        ok = b->moves && b->frames && b->curve_moves && b->curve_move_count;
    }
    for (size_t c = 0; ok && c < m->curve_count; c++) {
        const pb_curve *cv = &m->curves[c];
        b->curve_moves[c] = copy_of(cv->moves, cv->move_count, sizeof *cv->moves);
        b->curve_move_count[c] = cv->move_count;
        ok = b->curve_moves[c] != NULL;
    }
    if (!ok) {
        pb_snapshot_free(b);
        return ffd_fail(err, FFD_ERR_NOMEM, "snapshot: out of memory");
    }
    *blob = b;
    return FFD_OK;
}

static ffd_status pb_restore(sess_method *base, const void *blob, ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    const pb_snapshot *b = blob;
    if (b->curve_count != m->curve_count)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "restore: the snapshot has %zu curves, the "
                        "method %zu",
                        b->curve_count, m->curve_count);
    /* copy everything first: on error nothing changes */
    pb_move *moves = copy_of(b->moves, b->move_count, sizeof *moves);
    pb_frame *frames = copy_of(b->frames, b->frame_count, sizeof *frames);
    ffd_rig_curve_move **cm = ffd_calloc(b->curve_count + 1, sizeof *cm);
    int ok = moves && frames && cm;
    for (size_t c = 0; ok && c < b->curve_count; c++)
        ok = (cm[c] = copy_of(b->curve_moves[c], b->curve_move_count[c], sizeof **cm)) != NULL;
    if (!ok) {
        for (size_t c = 0; cm && c < b->curve_count; c++)
            ffd_free(cm[c]);
        ffd_free(cm);
        ffd_free(moves);
        ffd_free(frames);
        return ffd_fail(err, FFD_ERR_NOMEM, "restore: out of memory");
    }
    drag_free(&m->drag);
    ffd_free(m->moves);
    ffd_free(m->frames);
    m->moves = moves;
    m->move_count = m->move_cap = b->move_count;
    m->frames = frames;
    m->frame_count = m->frame_cap = b->frame_count;
    for (size_t c = 0; c < m->curve_count; c++) {
        pb_curve *cv = &m->curves[c];
        ffd_free(cv->moves);
        cv->moves = cm[c];
        cv->move_count = cv->move_cap = b->curve_move_count[c];
    }
    ffd_free(cm);
    m->level = b->level < ffd_pbffd_level_count(m->pb) ? b->level : 0;
    return replay_pb(m, err);
}

static ffd_status pb_reset(sess_method *base, ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    drag_free(&m->drag);
    m->move_count = 0;
    m->frame_count = 0;
    for (size_t c = 0; c < m->curve_count; c++)
        m->curves[c].move_count = 0;
    return replay_pb(m, err);
}

/* ---- the rig --------------------------------------------------------- */

/* The state as a rig: its explicit controls, options, the logs of moves and
 * frame edits and the curves, written by the rig's own writer
 * (pbffd_rig_json.c). */
static ffd_status pb_rig(const sess_method *base, cJSON *root, ffd_error *err)
{
    const pb_method *m = (const pb_method *)base;
    ffd_rig rig;
    ffd_rig_pbffd pb; /* borrows the controls; the logs in the rig's form */
    ffd_rig_view(&rig, &ffd_method_pbffd, &pb, sizeof pb);
    pb.controls = m->controls;
    pb.control_count = m->control_count;
    pb.options = m->opt;
    pb.moves = ffd_calloc(m->move_count ? m->move_count : 1, sizeof *pb.moves);
    pb.frames = ffd_calloc(m->frame_count ? m->frame_count : 1, sizeof *pb.frames);
    pb.curves = ffd_calloc(m->curve_count ? m->curve_count : 1, sizeof *pb.curves);
    int ok = pb.moves && pb.frames && pb.curves;
    for (size_t i = 0; ok && i < m->move_count; i++) {
        ffd_rig_pb_edit *e = &pb.moves[pb.move_count++];
        e->level = m->moves[i].level;
        e->control = m->moves[i].index;
        e->has_delta = 1;
        memcpy(e->delta, m->moves[i].delta, sizeof e->delta);
    }
    for (size_t i = 0; ok && i < m->frame_count; i++) {
        ffd_rig_pb_edit *e = &pb.frames[pb.frame_count++];
        e->level = m->frames[i].level;
        e->control = m->frames[i].index;
        e->frame_kind = 1;
        memcpy(e->frame, m->frames[i].frame, sizeof e->frame);
    }
    for (size_t c = 0; ok && c < m->curve_count; c++) {
        const pb_curve *cv = &m->curves[c];
        ffd_rig_curve *rc = &pb.curves[pb.curve_count++];
        rc->points = cv->points;
        rc->point_count = cv->count;
        rc->radius = cv->radius;
        rc->samples = cv->samples;
        rc->moves = cv->moves;
        rc->move_count = cv->move_count;
    }
    ok = ok && ffd_method_pbffd.write(&rig, root);
    ffd_free(pb.moves);
    ffd_free(pb.frames);
    ffd_free(pb.curves);
    return ok ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
}

/* ---- influence ------------------------------------------------------- */

static ffd_status pb_influence(sess_method *base, const uint32_t *ids, size_t k, float *w,
                               ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    const size_t n = m->base.ctx->n, e = ebf_count(m);
    uint32_t *ebf_ids = ffd_malloc_array(k ? k : 1, sizeof *ebf_ids);
    unsigned char *chosen = ffd_calloc(m->curve_count + 1, 1);
    ffd_status s =
        ebf_ids && chosen ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "influence: out of memory");
    size_t ke = 0;
    for (size_t i = 0; !s && i < k; i++) {
        size_t c, j;
        curve_of(m, ids[i], &c, &j);
        if (ids[i] < e)
            ebf_ids[ke++] = ids[i];
        else if (c < m->curve_count)
            chosen[c] = 1;
    }
    ffd_linear_map map;
    if (!s && !ke)
        memset(w, 0, n * sizeof *w);
    else if (!s && !(s = pb_linear_map(base, &map, err)))
        s = ffd_sess_map_influence(&map, 1, n, ebf_ids, ke, w, err); /* sum of weights (eq. 5) */
    if (!s && m->curve_count)
        s = build_curves(m, err);
    for (size_t c = 0; !s && c < m->curve_count; c++)
        for (size_t i = 0; chosen[c] && i < n; i++)
            if (ffd_pbffd_curve_point_inside(m->curves[c].obj, i))
                w[i] = 1;
    ffd_free(ebf_ids);
    ffd_free(chosen);
    return s;
}

/* ---- ops: level, frame, curve ----------------------------------------- */

static ffd_status op_level(pb_method *m, const cJSON *body, int *undo, ffd_error *err)
{
    static const char *const keys[] = {"level", NULL};
    ffd_rig_parser p = {"level", err, NULL};
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(body, "level");
    uint32_t level = 0;
    ffd_status s = ffd_rig_check_keys(&p, body, "", keys, "\"level\"");
    if (!s && !v)
        s = ffd_rig_expected(&p, "level", "a level (0 = finest) (missing)");
    if (!s)
        s = ffd_rig_read_index(&p, v, "level", "a level (0 = finest)", &level);
    if (!s && level >= ffd_pbffd_level_count(m->pb))
        s = ffd_fail(err, FFD_ERR_RANGE,
                     "level: level: %u out of range (%zu levels; 0 is the "
                     "finest)",
                     level, ffd_pbffd_level_count(m->pb));
    if (s)
        return s;
    m->level = level;
    *undo = SESS_UNDO_NONE;
    return FFD_OK;
}

/* {"points", "axis", "angle"} and/or {"points", "scale"}: as a rig frame edit.
 */
static ffd_status read_frame_edit(const ffd_rig_parser *p, const cJSON *body, ffd_rig_pb_edit *e)
{
    static const char *const keys[] = {"points", "axis", "angle", "scale", NULL};
    ffd_status s = ffd_rig_check_keys(p, body, "", keys, "\"points\", \"axis\", \"angle\", \"scale\"");
    const cJSON *axis = cJSON_GetObjectItemCaseSensitive(body, "axis");
    const cJSON *angle = cJSON_GetObjectItemCaseSensitive(body, "angle");
    const cJSON *scale = cJSON_GetObjectItemCaseSensitive(body, "scale");
    memset(e, 0, sizeof *e);
    e->frame_kind = 2;
    e->scale[0] = e->scale[1] = e->scale[2] = 1;
    e->axis[2] = 1;
    if (s)
        return s;
    if (!axis && !scale)
        return ffd_rig_expected(p, "axis", "\"axis\" and \"angle\", or \"scale\" (missing)");
    if ((axis != NULL) != (angle != NULL))
        return ffd_rig_expected(p, axis ? "angle" : "axis",
                            axis ? "an angle in radians (missing)"
                                 : "an array of 3 finite numbers (missing)");
    if (axis && ((s = ffd_rig_read_vec3(p, axis, "axis", e->axis)) ||
                 (s = ffd_rig_read_number(p, angle, "angle", &e->angle))))
        return s;
    if (axis && !nonzero3(e->axis))
        return ffd_fail(p->err, FFD_ERR_INVALID, "%s: axis: the zero vector is no axis", p->name);
    if (scale && (s = ffd_rig_read_vec3(p, scale, "scale", e->scale)))
        return s;
    for (int a = 0; a < 3; a++)
        if (e->scale[a] == 0)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: scale[%d]: a zero scale flattens the "
                            "frame",
                            p->name, a);
    return FFD_OK;
}

static ffd_status op_frame(pb_method *m, const cJSON *body, int *undo, ffd_error *err)
{
    ffd_rig_parser p = {"frame", err, NULL};
    ffd_rig_pb_edit e;
    ffd_status s = read_frame_edit(&p, body, &e);
    const cJSON *points = cJSON_GetObjectItemCaseSensitive(body, "points");
    uint32_t *ids = NULL;
    size_t k = 0, e_count = ebf_count(m);
    if (!s && !points)
        s = ffd_rig_expected(&p, "points", "an array of control ids (missing)");
    if (!s)
        s = ffd_sess_read_ids(&p, points, "points", pb_control_count(&m->base), &ids, &k);
    for (size_t i = 0; !s && i < k; i++)
        if (ids[i] >= e_count)
            s = ffd_fail(err, FFD_ERR_INVALID,
                         "frame: points[%zu]: control %u is a curve point: "
                         "frames belong to the EBFs (0..%zu)",
                         i, ids[i], e_count - 1);
    /* the new frames go into a copy of the log; the log's replay applies them */
    pb_frame *frames = s ? NULL : copy_of(m->frames, m->frame_count, sizeof *frames);
    size_t count = m->frame_count, cap = m->frame_count ? m->frame_count : 1;
    if (!s && !frames)
        s = ffd_fail(err, FFD_ERR_NOMEM, "frame: out of memory");
    for (size_t i = 0; !s && i < k; i++) {
        ffd_ebf c;
        double f[3][3];
        ffd_pbffd_control(m->pb, m->level, ids[i], &c, NULL);
        ffd_rig_pb_edited_frame(&e, (const double(*)[3])c.frame, f);
        if (put_frame(&frames, &count, &cap, m->level, ids[i], (const double(*)[3])f))
            s = ffd_fail(err, FFD_ERR_NOMEM, "frame: out of memory");
    }
    ffd_free(ids);
    if (s) {
        ffd_free(frames);
        return s;
    }
    pb_frame *old = m->frames;
    size_t old_count = m->frame_count, old_cap = m->frame_cap;
    m->frames = frames;
    m->frame_count = count;
    m->frame_cap = cap;
    ffd_error inner = {{0}};
    if ((s = replay_pb(m, &inner))) {
        m->frames = old;
        m->frame_count = old_count;
        m->frame_cap = old_cap;
        replay_pb(m, NULL);
        ffd_free(frames);
        return ffd_fail(err, s, "frame: %s", inner.message);
    }
    ffd_free(old);
    *undo = SESS_UNDO_STATE;
    return FFD_OK;
}

static ffd_status read_curve_body(const ffd_rig_parser *p, const cJSON *body, double diag, pb_curve *cv)
{
    static const char *const keys[] = {"points", "radius", "samples", NULL};
    ffd_status s = ffd_rig_check_keys(p, body, "", keys, "\"points\", \"radius\", \"samples\"");
    if (s)
        return s;
    const cJSON *pts = cJSON_GetObjectItemCaseSensitive(body, "points"), *v;
    if (!cJSON_IsArray(pts) || cJSON_GetArraySize(pts) < 2)
        return ffd_rig_expected(p, "points", "an array of at least 2 points [x,y,z]");
    cv->count = (size_t)cJSON_GetArraySize(pts);
    if (!(cv->points = ffd_malloc_array(cv->count, 3 * sizeof *cv->points)))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "curve: out of memory");
    size_t i = 0;
    cJSON_ArrayForEach(v, pts)
    {
        char where[32];
        snprintf(where, sizeof where, "points[%zu]", i);
        if ((s = ffd_rig_read_vec3(p, v, where, cv->points + 3 * i++)))
            return s;
    }
    cv->radius = CURVE_RADIUS_FACTOR * diag;
    if ((v = cJSON_GetObjectItemCaseSensitive(body, "radius")) &&
        (s = ffd_rig_read_positive(p, v, "radius", &cv->radius)))
        return s;
    if ((v = cJSON_GetObjectItemCaseSensitive(body, "samples")))
        return ffd_rig_read_index(p, v, "samples", "a non-negative integer (0: automatic)",
                              &cv->samples);
    return FFD_OK;
}

static ffd_status op_curve(pb_method *m, const cJSON *body, int *undo, ffd_error *err)
{
    ffd_rig_parser p = {"curve", err, NULL};
    pb_curve cv;
    memset(&cv, 0, sizeof cv);
    ffd_status s = read_curve_body(&p, body, m->base.ctx->diag, &cv);
    pb_curve *grown = s ? NULL : ffd_realloc_array(m->curves, m->curve_count + 1, sizeof cv);
    if (!s && !grown)
        s = ffd_fail(err, FFD_ERR_NOMEM, "curve: out of memory");
    if (s) {
        curve_free(&cv);
        return s;
    }
    m->curves = grown;
    m->curves[m->curve_count] = cv;
    /* a new curve stands on the result of everything before it (§3.5) */
    ffd_error inner = {{0}};
    if ((s = build_curves(m, &inner)) || (s = build_curve(m, m->curve_count, &inner))) {
        curve_free(&m->curves[m->curve_count]);
        return ffd_fail(err, s, "curve: %s", inner.message);
    }
    m->curve_count++;
    *undo = SESS_UNDO_REBUILD;
    return FFD_OK;
}

static ffd_status pb_op(sess_method *base, const char *op, const cJSON *body, int *undo,
                        ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    static const cJSON empty = {0};
    if (!body)
        body = &empty;
    if (!cJSON_IsObject(body) && body != &empty)
        return ffd_fail(err, FFD_ERR_PARSE, "%s: expected a JSON object", op);
    if (strcmp(op, "level") == 0)
        return op_level(m, body, undo, err);
    if (strcmp(op, "frame") == 0)
        return op_frame(m, body, undo, err);
    if (strcmp(op, "curve") == 0)
        return op_curve(m, body, undo, err);
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not an operation of the pbffd method", op);
}

/* any point set: at the end of the file */
static ffd_status pb_bind(sess_method *base, const double *points, size_t n, sess_binding **out,
                          ffd_error *err);
static void pb_binding_free(sess_binding *b);
static ffd_status pb_eval_points(sess_method *base, const sess_binding *b, double *out,
                                 ffd_error *err);
static ffd_status pb_jacobian_points(sess_method *base, const sess_binding *b, double *out,
                                     ffd_error *err);
static ffd_status pb_map_points(sess_method *base, const sess_binding *b, ffd_linear_map *map,
                                ffd_error *err);
static void *pb_handle(sess_method *base);

static const sess_vtable pbffd_vtable = {
    .name = "pbffd",
    .destroy = pb_destroy,
    .eval = pb_eval,
    .control_count = pb_control_count,
    .controls = pb_controls,
    .describe = pb_describe,
    .begin = pb_begin,
    .set_controls = pb_set_controls,
    .linear_map = pb_linear_map,
    .set_variables = pb_set_variables,
    .end = pb_end,
    .snapshot = pb_snapshot_take,
    .restore = pb_restore,
    .snapshot_free = pb_snapshot_free,
    .reset = pb_reset,
    .rig = pb_rig,
    .influence = pb_influence,
    .op = pb_op,
    .bind = pb_bind,
    .binding_free = pb_binding_free,
    .eval_points = pb_eval_points,
    .jacobian_points = pb_jacobian_points,
    .map_points = pb_map_points,
    .handle = pb_handle,
};

/* ---- any point set (ffd_deformer_bind) ---------------------------------
 * The points get the rows they would have got as vertices of the mesh
 * (ffd_pb_points_bind: level 0's base state, which the log's replay never
 * changes) and are evaluated in the same displacement form; each curve
 * (§3.5) parameterises its input points when it is built, so the points are
 * bound to every curve again at evaluation, at their positions after
 * everything before it, as build_curve binds the vertices. Control changes,
 * undo, levels, frames and curves are thus seen at evaluation. */

typedef struct pb_map_cache {
    ffd_pb_map_state *map; /* the last map_points' state (the map borrows it) */
    ffd_pb_points fresh;   /* its rows when the control set was edited since bind */
} pb_map_cache;

struct sess_binding {
    ffd_pb_points points;
    pb_map_cache *cache;
};

static void map_cache_clear(pb_map_cache *c)
{
    ffd_pb_map_state_free(c->map);
    c->map = NULL;
    ffd_pb_points_free(&c->fresh);
}

static ffd_status pb_bind(sess_method *base, const double *points, size_t n, sess_binding **out,
                          ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    sess_binding *b = ffd_calloc(1, sizeof *b);
    pb_map_cache *cache = ffd_calloc(1, sizeof *cache);
    if (!b || !cache) {
        ffd_free(b);
        ffd_free(cache);
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    }
    ffd_status s = ffd_pb_points_bind(m->pb, points, n, &b->points, err);
    if (s) {
        ffd_free(b);
        ffd_free(cache);
        return s;
    }
    b->cache = cache;
    *out = b;
    return FFD_OK;
}

static void pb_binding_free(sess_binding *b)
{
    if (!b)
        return;
    map_cache_clear(b->cache);
    ffd_free(b->cache);
    ffd_pb_points_free(&b->points);
    ffd_free(b);
}

/* Positions after the PB-FFD stage and curves [0, c) into y (n by 3), and,
 * when J is not NULL, the Jacobians of that map (n by 9; Jc scratch n by 9):
 * curve by curve, as pb_eval and build_curve treat the vertices. */
static ffd_status points_through(pb_method *m, const sess_binding *b, size_t c, double *y,
                                 double *J, double *Jc, ffd_error *err)
{
    ffd_status s = ffd_pb_points_eval(m->pb, &b->points, y, err);
    if (!s && J)
        s = ffd_pb_points_jacobian(m->pb, &b->points, J, err);
    if (!s && c)
        s = build_curves(m, err);
    const size_t n = b->points.n;
    for (size_t k = 0; !s && k < c; k++) {
        const ffd_pbffd *cpb = ffd_pb_curve_deformer(m->curves[k].obj);
        ffd_pb_points in;
        ffd_error inner = {{0}};
        s = ffd_pb_points_bind(cpb, y, n, &in, &inner);
        if (!s && J)
            s = ffd_pb_points_jacobian(cpb, &in, Jc, &inner);
        if (!s)
            s = ffd_pb_points_eval(cpb, &in, y, &inner);
        ffd_pb_points_free(&in);
        if (s)
            return ffd_fail(err, s, "curves[%zu]: %s", k, inner.message);
        /* chain rule: d(curve(y))/dx = Jc(y) J */
        for (size_t i = 0; J && i < n; i++) {
            const double *A = Jc + 9 * i;
            double *B = J + 9 * i, P[9];
            for (int r = 0; r < 3; r++)
                for (int q = 0; q < 3; q++)
                    P[3 * r + q] = A[3 * r] * B[q] + A[3 * r + 1] * B[3 + q] + A[3 * r + 2] * B[6 + q];
            memcpy(B, P, sizeof P);
        }
    }
    return s;
}

static ffd_status pb_eval_points(sess_method *base, const sess_binding *b, double *out,
                                 ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    return points_through(m, b, m->curve_count, out, NULL, NULL, err);
}

static ffd_status pb_jacobian_points(sess_method *base, const sess_binding *b, double *out,
                                     ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    const size_t n = b->points.n;
    double *y = ffd_malloc_array(n ? n : 1, 3 * sizeof *y);
    double *Jc = m->curve_count ? ffd_malloc_array(n ? n : 1, 9 * sizeof *Jc) : NULL;
    ffd_status s = y && (Jc || !m->curve_count)
                       ? points_through(m, b, m->curve_count, y, out, Jc, err)
                       : ffd_fail(err, FFD_ERR_NOMEM, "Jacobian: out of memory for %zu points", n);
    ffd_free(y);
    ffd_free(Jc);
    return s;
}

/* PB-FFD §3.3, eq. 8 (and eq. 10 for a coarser level): the rows of W over
 * the shown level's controls, which are the control ids. A curve's samples
 * follow a Catmull-Rom spline of its points with rotation-minimising frames,
 * and its kernels re-parameterise their input: with a curve the bound points
 * are not linear in the controls. Nor are they when a frame of a coarser
 * level was edited: a moved control is re-parameterised in the coarser level
 * at its new position (§3.4), where the frame's change reaches it through
 * its D row (eq. 10), which depends on that position. */
static ffd_status pb_map_points(sess_method *base, const sess_binding *b, ffd_linear_map *map,
                                ffd_error *err)
{
    pb_method *m = (pb_method *)base;
    if (m->curve_count)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "linear map: the deformer has %zu curves (§3.5): their points move "
                        "samples along a Catmull-Rom spline with rotating frames, and the curves' "
                        "kernels act on the deformed points: the points are not linear in the "
                        "controls",
                        m->curve_count);
    for (size_t i = 0; i < m->frame_count; i++)
        if (m->frames[i].level > m->level)
            return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                            "linear map: frames[%zu] edits control %u of level %u, coarser than "
                            "the shown level %zu: a moved control is re-parameterised there at "
                            "its new position, so the points are not linear in the controls",
                            i, m->frames[i].index, m->frames[i].level, m->level);
    pb_map_cache *c = b->cache;
    map_cache_clear(c);
    const ffd_pb_points *use;
    ffd_status s = ffd_pb_points_current(m->pb, &b->points, &c->fresh, &use, err);
    if (!s)
        s = ffd_pb_rows_linear_map(m->pb, m->level, &use->rows, map, &c->map, err);
    if (!s && map->variable_count != pb_control_count(base))
        s = ffd_fail(err, FFD_ERR_UNSUPPORTED, "linear map: %zu variables for %zu controls",
                     map->variable_count, pb_control_count(base));
    if (s)
        map_cache_clear(c);
    return s;
}

static void *pb_handle(sess_method *base)
{
    return ((pb_method *)base)->pb;
}
