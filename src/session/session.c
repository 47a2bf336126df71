/* session — the editor's model (ffd.h "Editing sessions"): the rest mesh,
 * one method (session.h), pins, the drag in progress, undo/redo, and the
 * frame / state / rig / export views of it. docs/editor.md lists the ops. */
#include "session/session.h"
#include "session/session_persist.h"
#include "deformer/method.h"

#include "mesh/mesh.h"

#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { UNDO_STATE = 1, UNDO_REBUILD, UNDO_SWAP };

typedef ffd_rig_pin pin; /* the rig's pins are the session's (docs/rig.md "pins") */
static ffd_status state_rig(const ffd_session *s, int with_pins, char **text, ffd_error *err);

typedef struct undo_entry {
    int kind;
    void *blob;           /* UNDO_STATE: the method's snapshot */
    char *rig;            /* UNDO_REBUILD: the rig text */
    sess_method *method;  /* UNDO_SWAP: the other method (NULL: none) */
    const sess_vtable *blob_vt;
    pin *pins;            /* the pins (always) */
    size_t pin_count;
    char label[SESS_STEP_NAME]; /* the history step's name: the change made from this state */
    char *state_rig;      /* this state as rig text with its pins (NULL: no deformer): the
                             history's record (session_persist.c) */
} undo_entry;

typedef struct undo_stack {
    undo_entry *items;
    size_t count, cap;
} undo_stack;

enum { DRAG_NONE = 0, DRAG_CONTROLS, DRAG_VERTEX };
enum { MODE_TRANSLATE = 0, MODE_ROTATE, MODE_SCALE };

typedef struct drag_state {
    int kind;
    undo_entry before;     /* captured at drag_begin */
    /* controls */
    uint32_t *ids;
    size_t k;
    double *start;         /* k by 3: positions at begin */
    int mode;
    double center[3];
    /* vertex (direct manipulation): constraints = pins then the vertex */
    size_t *rows;
    double *current;       /* constraints by 3, at begin */
    double *targets;
    double *delta;         /* variables by 3 */
    size_t constraints;
    ffd_linear_map map;
} drag_state;

struct ffd_session {
    ffd_mesh *mesh;
    char *name;
    sess_ctx ctx;
    ffd_session_options options;
    sess_method *method;
    double *positions;     /* n by 3: the method's current result (rest without one) */
    pin *pins;
    size_t pin_count;
    float *residuals;      /* last direct-manipulation solve: pins (then the dragged vertex) */
    size_t residual_count;
    int pins_met;          /* last solve: the pins held (0: they contradict each other) */
    double drag_residual;  /* last solve: the dragged vertex's distance to its target */
    drag_state drag;
    sess_meshes meshes;    /* several meshes: the parts of mesh (session_meshes.c) */
    undo_stack undo, redo;
    uint32_t revision;
    double busy_ms;        /* duration of the last command */
    double weights_stroke; /* the last "weights" op's stroke id and the revision it made */
    uint32_t weights_revision;
    sess_frames *frames;   /* delta frames for drag steps (session_frame.c) */
    char first_step[SESS_STEP_NAME]; /* the name of the history's first step */
    char *autosave_note;   /* JSON object for the state's "autosave" (session_persist.c) */
};

/* ---------- small utilities ---------- */

static ffd_status conflict(ffd_error *err, const char *fmt, const char *op)
{
    return ffd_fail(err, FFD_ERR_INVALID, SESS_CONFLICT "%s: %s", op, fmt);
}

/* Positions a request asks for stay within SESS_COORD_MAX (the float32
 * frame must stay finite). */
static ffd_status check_coords(const double *v, size_t count, const char *op, const char *what,
                               ffd_error *err)
{
    for (size_t i = 0; i < 3 * count; i++)
        if (!(fabs(v[i]) <= SESS_COORD_MAX))
            return ffd_fail(err, FFD_ERR_NONFINITE, "%s: %s: coordinate %g beyond %g", op, what,
                            v[i], SESS_COORD_MAX);
    return FFD_OK;
}

static void entry_free(undo_entry *e)
{
    if (e->blob && e->blob_vt)
        e->blob_vt->snapshot_free(e->blob);
    ffd_free(e->rig);
    if (e->method)
        e->method->vt->destroy(e->method);
    ffd_free(e->pins);
    ffd_free(e->state_rig);
    memset(e, 0, sizeof *e);
}

static void stack_clear(undo_stack *st)
{
    for (size_t i = 0; i < st->count; i++)
        entry_free(&st->items[i]);
    st->count = 0;
}

static ffd_status stack_push(ffd_session *s, undo_stack *st, undo_entry *e, ffd_error *err)
{
    if (st->count == s->options.max_undo) {
        if (st == &s->undo) /* the oldest step goes: the next one is the first */
            snprintf(s->first_step, sizeof s->first_step, "%s", st->items[0].label);
        entry_free(&st->items[0]);
        memmove(st->items, st->items + 1, (st->count - 1) * sizeof *st->items);
        st->count--;
    }
    if (!ffd_grow((void **)&st->items, &st->cap, st->count + 1, sizeof *st->items)) {
        entry_free(e);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the undo history");
    }
    st->items[st->count++] = *e;
    memset(e, 0, sizeof *e);
    return FFD_OK;
}

static ffd_status copy_pins(const ffd_session *s, pin **out, size_t *count, ffd_error *err)
{
    *out = NULL;
    *count = s->pin_count;
    if (!s->pin_count)
        return FFD_OK;
    *out = ffd_malloc_array(s->pin_count, sizeof **out);
    if (!*out)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for pins");
    memcpy(*out, s->pins, s->pin_count * sizeof **out);
    return FFD_OK;
}

/* Re-evaluates the method into s->positions. */
static ffd_status refresh(ffd_session *s, ffd_error *err)
{
    s->revision++;
    if (!s->method) {
        memcpy(s->positions, s->ctx.rest, s->ctx.n * 3 * sizeof *s->positions);
        return FFD_OK;
    }
    return s->method->vt->eval(s->method, s->positions, err);
}

/* ---------- rig text and rebuilding ---------- */

static ffd_status method_from_rig(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                                  ffd_error *err)
{
    const ffd_method *method = ffd_method_of_rig(rig);
    if (!method)
        return ffd_fail(err, FFD_ERR_INVALID, "rig: unknown deformer");
    return ffd_method_load(method, ctx, rig, out, err);
}

/* files: what the rig may read besides itself (NULL: anything). */
static ffd_status method_from_text(const sess_ctx *ctx, const char *text, size_t size,
                                   const char *name, const ffd_rig_files *files,
                                   sess_method **out, ffd_error *err)
{
    ffd_rig *rig = NULL;
    ffd_status st = ffd_rig_parse_json_files(text, size, name, files, &rig, err);
    if (!st)
        st = method_from_rig(ctx, rig, out, err);
    ffd_rig_destroy(rig);
    return st;
}

/* ---------- undo entries ---------- */

/* What undo needs to come back to the present state, for an entry of kind. */
static ffd_status capture(ffd_session *s, int kind, const char *label, undo_entry *e,
                          ffd_error *err)
{
    memset(e, 0, sizeof *e);
    e->kind = kind;
    snprintf(e->label, sizeof e->label, "%s", label);
    ffd_status st = copy_pins(s, &e->pins, &e->pin_count, err);
    if (!st)
        st = sess_state_rig(s, &e->state_rig, err);
    if (st) {
        entry_free(e);
        return st;
    }
    if (kind == UNDO_STATE && s->method) {
        e->blob_vt = s->method->vt;
        st = s->method->vt->snapshot(s->method, &e->blob, err);
    } else if (kind == UNDO_REBUILD && s->method) {
        st = ffd_sess_rig_text(s->method, &e->rig, err);
    }
    if (st)
        entry_free(e);
    return st;
}

/* Brings the session to the state e describes; on success the present
 * state is in *inverse (same kind) and e is consumed. */
static ffd_status apply_entry(ffd_session *s, undo_entry *e, undo_entry *inverse, ffd_error *err)
{
    ffd_status st;
    if (e->kind == UNDO_SWAP) {
        memset(inverse, 0, sizeof *inverse);
        inverse->kind = UNDO_SWAP;
        snprintf(inverse->label, sizeof inverse->label, "%s", e->label);
        if ((st = copy_pins(s, &inverse->pins, &inverse->pin_count, err)) ||
            (st = sess_state_rig(s, &inverse->state_rig, err))) {
            entry_free(inverse);
            return st;
        }
        inverse->method = s->method;
        s->method = e->method;
        e->method = NULL;
    } else {
        if ((st = capture(s, e->kind, e->label, inverse, err)))
            return st;
        if (e->kind == UNDO_STATE && s->method) {
            if (e->blob_vt != s->method->vt)
                st = ffd_fail(err, FFD_ERR_INVALID, "undo: the history does not match the deformer");
            else
                st = s->method->vt->restore(s->method, e->blob, err);
        } else if (e->kind == UNDO_REBUILD) { /* no rig: no deformer (a resumed history) */
            sess_method *m = NULL;
            if (e->rig)
                st = method_from_text(&s->ctx, e->rig, strlen(e->rig), "undo", NULL, &m, err);
            if (!st) {
                if (s->method)
                    s->method->vt->destroy(s->method);
                s->method = m;
            }
        }
        if (st) {
            entry_free(inverse);
            return st;
        }
    }
    ffd_free(s->pins);
    s->pins = e->pins;
    s->pin_count = e->pin_count;
    e->pins = NULL;
    s->residual_count = 0;
    entry_free(e);
    return FFD_OK;
}

/* A change failed half-way: back to the state before (e, consumed); returns st. */
static ffd_status roll_back(ffd_session *s, undo_entry *e, ffd_status st)
{
    undo_entry inverse;
    if (apply_entry(s, e, &inverse, NULL) == FFD_OK)
        entry_free(&inverse);
    else
        entry_free(e);
    refresh(s, NULL);
    return st;
}

static ffd_status undo_redo(ffd_session *s, undo_stack *from, undo_stack *to, const char *op,
                            ffd_error *err)
{
    if (!from->count)
        return conflict(err, "nothing to undo or redo", op);
    undo_entry inverse;
    undo_entry *e = &from->items[from->count - 1];
    ffd_status st = apply_entry(s, e, &inverse, err);
    if (st)
        return st;
    from->count--;
    if ((st = stack_push(s, to, &inverse, err)))
        return st;
    return refresh(s, err);
}

/* Records a successful change: before goes on the undo stack, redo is cleared. */
static ffd_status commit(ffd_session *s, undo_entry *before, ffd_error *err)
{
    stack_clear(&s->redo);
    return stack_push(s, &s->undo, before, err);
}

/* ---------- creating and loading ---------- */

/* Makes m (taken over) the session's method, the old one kept for undo;
 * pins belong to the old deformer and go with it. On error m is destroyed
 * and nothing changes. */
static ffd_status install(ffd_session *s, sess_method *m, const char *label, ffd_error *err)
{
    undo_entry before;
    ffd_status st = capture(s, UNDO_SWAP, label, &before, err);
    if (st) {
        m->vt->destroy(m);
        return st;
    }
    before.method = s->method;
    s->method = m;
    ffd_free(s->pins);
    s->pins = NULL;
    s->pin_count = 0;
    s->residual_count = 0;
    if ((st = refresh(s, err))) {
        s->method = before.method;
        before.method = NULL;
        s->pins = before.pins;
        s->pin_count = before.pin_count;
        before.pins = NULL;
        entry_free(&before);
        m->vt->destroy(m);
        refresh(s, NULL);
        return st;
    }
    return commit(s, &before, err);
}


/* The body is the creation part of a rig of the method it names
 * (ffd_method_create: the rig reader, then the method's load). */
static ffd_status op_create(ffd_session *s, const ffd_rig_parser *p, const cJSON *body, ffd_error *err)
{
    const ffd_method *method = NULL;
    ffd_status st = ffd_method_of_body(p, body, &method);
    if (st)
        return st;
    sess_method *m = NULL;
    st = ffd_method_create(method, &s->ctx, body, &m, err);
    if (st)
        return st;
    char label[SESS_STEP_NAME];
    sess_name_create(label, sizeof label, method->name, body);
    return install(s, m, label, err);
}

ffd_status ffd_session_load_rig(ffd_session *s, const char *text, size_t size, const char *name,
                                const char *root, ffd_error *err)
{
    if (!s || !text)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_session_load_rig: NULL argument");
    if (s->drag.kind)
        return conflict(err, "a drag is in progress", "rig/load");
    name = name ? name : "rig";
    /* an uploaded rig (no root) reads no file; one loaded from the
     * server's directory only files under it */
    const ffd_rig_files files = {root};
    sess_method *m = NULL;
    ffd_rig *rig = NULL;
    pin *pins = NULL;
    size_t pin_count = 0;
    /* the rig's pins come back with it (docs/rig.md "pins") */
    ffd_status st = ffd_rig_parse_json_files(text, size, name, &files, &rig, err);
    if (!st)
        st = ffd_rig_check_pins(rig, s->ctx.n, err);
    if (!st && rig->pin_count) {
        pins = ffd_malloc_array(rig->pin_count, sizeof *pins);
        if (!pins)
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for pins", name);
        else
            memcpy(pins, rig->pins, rig->pin_count * sizeof *pins);
        pin_count = rig->pin_count;
    }
    if (!st)
        st = method_from_rig(&s->ctx, rig, &m, err);
    ffd_rig_destroy(rig);
    char label[SESS_STEP_NAME];
    sess_name_file(label, sizeof label, "Load rig", name);
    if (!st)
        st = install(s, m, label, err);
    if (st) {
        ffd_free(pins);
        return st;
    }
    s->pins = pins;
    s->pin_count = pin_count;
    return FFD_OK;
}

/* ---------- direct manipulation ---------- */

static void drag_free(drag_state *d)
{
    ffd_free(d->ids);
    ffd_free(d->start);
    ffd_free(d->rows);
    ffd_free(d->current);
    ffd_free(d->targets);
    ffd_free(d->delta);
    entry_free(&d->before);
    memset(d, 0, sizeof *d);
}

/* Sets up the constraint rows (pins, then vertex unless it is UINT32_MAX or
 * pinned already) against the current positions. */
static ffd_status dm_setup(ffd_session *s, uint32_t vertex, const char *op, ffd_error *err)
{
    drag_state *d = &s->drag;
    sess_method *m = s->method;
    if (!ffd_sess_caps(m)->linear_map)
        return conflict(err, "this method has no direct manipulation of mesh points (drag its "
                             "skeleton instead)", op);
    ffd_status st = m->vt->linear_map(m, &d->map, err);
    if (st)
        return st;
    size_t k = s->pin_count + 1;
    /* limits: each drag step solves the dense pins x variables system */
    ffd_budget budget;
    ffd_error inner = {{0}};
    ffd_budget_init(&budget, &s->ctx.limits);
    if ((st = ffd_rig_charge_manip(&d->map, k, &budget, &inner)))
        return ffd_fail(err, st, "%s: %s", op, inner.message);
    d->rows = ffd_malloc_array(k, sizeof *d->rows);
    d->current = ffd_malloc_array(k, 3 * sizeof *d->current);
    d->targets = ffd_malloc_array(k, 3 * sizeof *d->targets);
    d->delta = ffd_calloc(d->map.variable_count ? d->map.variable_count : 1, 3 * sizeof *d->delta);
    if (!d->rows || !d->current || !d->targets || !d->delta)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", op);
    size_t c = 0;
    for (size_t i = 0; i < s->pin_count; i++) {
        if (s->pins[i].vertex == vertex)
            vertex = UINT32_MAX; /* dragging a pin moves its target */
        d->rows[c] = s->pins[i].vertex;
        memcpy(d->targets + 3 * c, s->pins[i].target, 3 * sizeof(double));
        c++;
    }
    if (vertex != UINT32_MAX) {
        d->rows[c] = vertex;
        memcpy(d->targets + 3 * c, s->positions + 3 * (size_t)vertex, 3 * sizeof(double));
        c++;
    }
    d->constraints = c;
    for (size_t i = 0; i < c; i++)
        memcpy(d->current + 3 * i, s->positions + 3 * d->rows[i], 3 * sizeof(double));
    return FFD_OK;
}

/* Solves for the targets in d->targets and applies the change (from the begin state). */
static ffd_status dm_solve(ffd_session *s, ffd_error *err)
{
    drag_state *d = &s->drag;
    double *res = ffd_malloc_array(d->constraints ? d->constraints : 1, sizeof *res);
    if (!res)
        return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
    ffd_manip_result result;
    /* pins hard, the dragged vertex soft (docs/editor.md "Pins hard, drag soft") */
    ffd_manip_options options = {.hard_count = s->pin_count};
    ffd_status st = ffd_manip_solve(&d->map, d->rows, d->constraints, d->current, d->targets,
                                    &options, d->delta, res, &result, err);
    if (!st)
        st = s->method->vt->set_variables(s->method, d->delta, err);
    if (!st) {
        float *r = ffd_realloc_array(s->residuals, d->constraints ? d->constraints : 1,
                                     sizeof *r);
        if (!r) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
        } else {
            s->residuals = r;
            for (size_t i = 0; i < d->constraints; i++)
                r[i] = (float)res[i];
            s->residual_count = d->constraints;
            s->pins_met = result.hard_met;
            s->drag_residual = result.soft_residual;
        }
    }
    ffd_free(res);
    return st;
}

/* ---------- drags ---------- */

static ffd_status need_method(const ffd_session *s, const char *op, ffd_error *err)
{
    if (!s->method)
        return conflict(err, "no deformer: create one first", op);
    return FFD_OK;
}

static ffd_status read_mode(const ffd_rig_parser *p, const cJSON *body, int *mode)
{
    static const char *const modes[] = {"translate", "rotate", "scale", NULL};
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(body, "mode");
    *mode = MODE_TRANSLATE;
    return item ? ffd_rig_read_enum(p, item, "mode", modes, "\"translate\", \"rotate\" or \"scale\"",
                                mode)
                : FFD_OK;
}

static ffd_status drag_begin_controls(ffd_session *s, const ffd_rig_parser *p, const cJSON *body,
                                      ffd_error *err)
{
    static const char *const keys[] = {"points", "mode", "center", "arap", NULL};
    ffd_status st = ffd_rig_check_keys(p, body, "body", keys, "points, mode, center, arap");
    drag_state *d = &s->drag;
    sess_method *m = s->method;
    size_t count = m->vt->control_count(m);
    if (!st)
        st = ffd_sess_read_ids(p, cJSON_GetObjectItemCaseSensitive(body, "points"), "points", count,
                           &d->ids, &d->k);
    if (!st)
        st = read_mode(p, body, &d->mode);
    const cJSON *arap = cJSON_GetObjectItemCaseSensitive(body, "arap");
    if (!st && arap && !cJSON_IsBool(arap))
        st = ffd_rig_expected(p, "arap", "true or false");
    if (st)
        return st;
    double *all = ffd_malloc_array(count, 3 * sizeof *all);
    d->start = ffd_malloc_array(d->k, 3 * sizeof *d->start);
    if (!all || !d->start) {
        ffd_free(all);
        return ffd_fail(err, FFD_ERR_NOMEM, "drag_begin: out of memory");
    }
    m->vt->controls(m, all);
    double c[3] = {0, 0, 0};
    for (size_t i = 0; i < d->k; i++)
        for (int a = 0; a < 3; a++) {
            d->start[3 * i + a] = all[3 * (size_t)d->ids[i] + a];
            c[a] += d->start[3 * i + a] / (double)d->k;
        }
    ffd_free(all);
    const cJSON *center = cJSON_GetObjectItemCaseSensitive(body, "center");
    if (center && ((st = ffd_rig_read_vec3(p, center, "center", c)) ||
                   (st = check_coords(c, 1, "drag_begin", "center", err))))
        return st;
    memcpy(d->center, c, sizeof c);
    d->kind = DRAG_CONTROLS;
    sess_name_drag(d->before.label, sizeof d->before.label, d->mode, d->ids, d->k);
    return m->vt->begin(m, d->ids, d->k, arap ? cJSON_IsTrue(arap) : 1, err);
}

static ffd_status op_drag_begin(ffd_session *s, const ffd_rig_parser *p, const cJSON *body,
                                ffd_error *err)
{
    ffd_status st = need_method(s, "drag_begin", err);
    if (st)
        return st;
    if (s->drag.kind)
        return conflict(err, "a drag is in progress: drag_end or drag_cancel first", "drag_begin");
    drag_state *d = &s->drag;
    memset(d, 0, sizeof *d);
    if ((st = capture(s, UNDO_STATE, "drag", &d->before, err)))
        return st;
    const cJSON *vertex = cJSON_GetObjectItemCaseSensitive(body, "vertex");
    if (vertex) {
        static const char *const keys[] = {"vertex", NULL};
        uint32_t v = 0;
        if (!(st = ffd_rig_check_keys(p, body, "body", keys, "vertex")) &&
            !(st = ffd_rig_read_index(p, vertex, "vertex", "a vertex id", &v)) && v >= s->ctx.n)
            st = ffd_fail(err, FFD_ERR_RANGE, "drag_begin: vertex: %u out of range (%zu vertices)",
                          v, s->ctx.n);
        if (!st && !(st = s->method->vt->begin(s->method, NULL, 0, 0, err))) {
            d->kind = DRAG_VERTEX;
            snprintf(d->before.label, sizeof d->before.label, "Drag vertex %u", v);
            if ((st = dm_setup(s, v, "drag_begin", err)))
                s->method->vt->end(s->method, 0);
        }
    } else {
        st = drag_begin_controls(s, p, body, err);
    }
    if (st)
        drag_free(d);
    return st;
}

/* Targets of the dragged controls for a drag step's transform. */
static ffd_status control_targets(ffd_session *s, const ffd_rig_parser *p, const cJSON *body,
                                  double *targets, double axis[3], double *angle, double t[3])
{
    drag_state *d = &s->drag;
    double M[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    axis[0] = axis[1] = 0;
    axis[2] = 1;
    *angle = 0;
    t[0] = t[1] = t[2] = 0;
    ffd_status st;
    if (cJSON_GetObjectItemCaseSensitive(body, "moves")) /* per control, any mode */
        return (st = ffd_sess_moves_targets(p, body, d->ids, d->k,
                                            s->method->vt->control_count(s->method), d->start,
                                            targets))
                   ? st
                   : check_coords(targets, d->k, p->name, "the moved control points", p->err);
    if (d->mode == MODE_TRANSLATE) {
        static const char *const keys[] = {"delta", NULL};
        if ((st = ffd_rig_check_keys(p, body, "body", keys, "delta")))
            return st;
        const cJSON *delta = cJSON_GetObjectItemCaseSensitive(body, "delta");
        if (!delta)
            return ffd_rig_expected(p, "delta", "an array of 3 finite numbers (missing)");
        if ((st = ffd_rig_read_vec3(p, delta, "delta", t)))
            return st;
    } else if (d->mode == MODE_ROTATE) {
        static const char *const keys[] = {"axis", "angle", NULL};
        if ((st = ffd_rig_check_keys(p, body, "body", keys, "axis, angle")) ||
            (st = ffd_rig_read_rotation(p, body, "body", axis, angle, NULL, NULL)))
            return st;
        for (int c = 0; c < 3; c++) {
            double e[3] = {c == 0, c == 1, c == 2}, r[3];
            ffd_rig_rotate(axis, *angle, e, r);
            for (int a = 0; a < 3; a++)
                M[a][c] = r[a];
        }
    } else {
        static const char *const keys[] = {"scale", NULL};
        if ((st = ffd_rig_check_keys(p, body, "body", keys, "scale")))
            return st;
        double sc[3];
        const cJSON *scale = cJSON_GetObjectItemCaseSensitive(body, "scale");
        if (!scale)
            return ffd_rig_expected(p, "scale", "an array of 3 finite numbers (missing)");
        if ((st = ffd_rig_read_vec3(p, scale, "scale", sc)))
            return st;
        for (int a = 0; a < 3; a++)
            M[a][a] = sc[a];
    }
    for (size_t i = 0; i < d->k; i++) {
        const double *q = d->start + 3 * i;
        double r[3] = {q[0] - d->center[0], q[1] - d->center[1], q[2] - d->center[2]};
        for (int a = 0; a < 3; a++)
            targets[3 * i + a] =
                d->center[a] + M[a][0] * r[0] + M[a][1] * r[1] + M[a][2] * r[2] + t[a];
    }
    return check_coords(targets, d->k, p->name, "the moved control points", p->err);
}

static ffd_status op_drag(ffd_session *s, const ffd_rig_parser *p, const cJSON *body, ffd_error *err)
{
    drag_state *d = &s->drag;
    ffd_status st;
    if (!d->kind)
        return conflict(err, "no drag in progress: drag_begin first", "drag");
    if (d->kind == DRAG_VERTEX) {
        static const char *const keys[] = {"target", NULL};
        double target[3];
        const cJSON *t = cJSON_GetObjectItemCaseSensitive(body, "target");
        if ((st = ffd_rig_check_keys(p, body, "body", keys, "target")))
            return st;
        if (!t)
            return ffd_rig_expected(p, "target", "an array of 3 finite numbers (missing)");
        if ((st = ffd_rig_read_vec3(p, t, "target", target)) ||
            (st = check_coords(target, 1, "drag", "target", err)))
            return st;
        if (d->constraints > s->pin_count)
            memcpy(d->targets + 3 * (d->constraints - 1), target, sizeof target);
        else /* dragging a pinned vertex: its pin's target */
            for (size_t i = 0; i < d->constraints; i++)
                if (d->rows[i] == d->rows[d->constraints - 1])
                    memcpy(d->targets + 3 * i, target, sizeof target);
        st = dm_solve(s, err);
    } else {
        double *targets = ffd_malloc_array(d->k, 3 * sizeof *targets);
        if (!targets)
            return ffd_fail(err, FFD_ERR_NOMEM, "drag: out of memory");
        double axis[3], angle, delta[3];
        st = control_targets(s, p, body, targets, axis, &angle, delta);
        int per_control = cJSON_GetObjectItemCaseSensitive(body, "moves") != NULL;
        if (!st && !per_control && d->mode != MODE_SCALE && ffd_sess_caps(s->method)->set_motion)
            st = s->method->vt->set_motion(s->method, d->ids, d->k, targets, axis, angle,
                                           d->center, delta, err);
        else if (!st)
            st = s->method->vt->set_controls(s->method, d->ids, d->k, targets, err);
        ffd_free(targets);
    }
    if (!st)
        st = refresh(s, err);
    return st;
}

/* A dragged pinned vertex's pin follows the drag. */
static void move_dragged_pin(ffd_session *s)
{
    drag_state *d = &s->drag;
    if (d->kind != DRAG_VERTEX || d->constraints == 0 || d->constraints > s->pin_count)
        return;
    for (size_t i = 0; i < s->pin_count; i++)
        memcpy(s->pins[i].target, d->targets + 3 * i, 3 * sizeof(double));
}

static ffd_status op_drag_end(ffd_session *s, int keep, ffd_error *err)
{
    drag_state *d = &s->drag;
    if (!d->kind)
        return conflict(err, "no drag in progress", keep ? "drag_end" : "drag_cancel");
    s->method->vt->end(s->method, keep);
    ffd_status st = FFD_OK;
    if (keep) {
        move_dragged_pin(s);
        st = commit(s, &d->before, err);
    } else if (d->kind == DRAG_VERTEX) {
        s->residual_count = 0; /* its steps' solves replaced the shown residuals */
    }
    drag_free(d);
    if (!st)
        st = refresh(s, err);
    return st;
}

/* ---------- pins ---------- */

static ffd_status op_pin(ffd_session *s, const ffd_rig_parser *p, const cJSON *body, ffd_error *err)
{
    static const char *const keys[] = {"vertex", "target", NULL};
    ffd_status st = need_method(s, "pin", err);
    uint32_t v = 0;
    double target[3];
    if (st || (st = ffd_rig_check_keys(p, body, "body", keys, "vertex, target")))
        return st;
    const cJSON *vertex = cJSON_GetObjectItemCaseSensitive(body, "vertex");
    if (!vertex)
        return ffd_rig_expected(p, "vertex", "a vertex id (missing)");
    if ((st = ffd_rig_read_index(p, vertex, "vertex", "a vertex id", &v)))
        return st;
    if (v >= s->ctx.n)
        return ffd_fail(err, FFD_ERR_RANGE, "pin: vertex: %u out of range (%zu vertices)", v,
                        s->ctx.n);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(body, "target");
    memcpy(target, s->positions + 3 * (size_t)v, sizeof target);
    if (t && ((st = ffd_rig_read_vec3(p, t, "target", target)) ||
              (st = check_coords(target, 1, "pin", "target", err))))
        return st;
    if (!ffd_sess_caps(s->method)->linear_map)
        return conflict(err, "this method has no direct manipulation of mesh points", "pin");
    undo_entry before;
    char label[SESS_STEP_NAME];
    size_t i = 0;
    while (i < s->pin_count && s->pins[i].vertex != v)
        i++;
    snprintf(label, sizeof label, i < s->pin_count ? "Move the pin of vertex %u" : "Pin vertex %u",
             v);
    if ((st = capture(s, UNDO_STATE, label, &before, err)))
        return st;
    if (i == s->pin_count) {
        pin *grown = ffd_realloc_array(s->pins, s->pin_count + 1, sizeof *grown);
        if (!grown) {
            entry_free(&before);
            return ffd_fail(err, FFD_ERR_NOMEM, "pin: out of memory");
        }
        s->pins = grown;
        s->pins[s->pin_count++].vertex = v;
    }
    memcpy(s->pins[i].target, target, sizeof target);
    /* Solve the pins together (the paper's eq. 2-7 from the current state). */
    drag_state *d = &s->drag;
    memset(d, 0, sizeof *d);
    if (!(st = s->method->vt->begin(s->method, NULL, 0, 0, err))) {
        d->kind = DRAG_VERTEX;
        if (!(st = dm_setup(s, UINT32_MAX, "pin", err)))
            st = dm_solve(s, err);
        s->method->vt->end(s->method, st == FFD_OK);
    }
    drag_free(d);
    if (!st)
        st = refresh(s, err);
    if (st)
        return roll_back(s, &before, st);
    return commit(s, &before, err);
}

static ffd_status op_unpin(ffd_session *s, const ffd_rig_parser *p, const cJSON *body, ffd_error *err)
{
    static const char *const keys[] = {"vertex", "all", NULL};
    ffd_status st = need_method(s, "unpin", err);
    if (!st)
        st = ffd_rig_check_keys(p, body, "body", keys, "vertex, all");
    if (st)
        return st;
    const cJSON *all = cJSON_GetObjectItemCaseSensitive(body, "all");
    const cJSON *vertex = cJSON_GetObjectItemCaseSensitive(body, "vertex");
    if ((all != NULL) == (vertex != NULL))
        return ffd_rig_expected(p, "body", "{\"vertex\": id} or {\"all\": true}");
    if (all && !cJSON_IsTrue(all))
        return ffd_rig_expected(p, "all", "true");
    uint32_t v = 0;
    size_t i = 0;
    if (vertex) {
        if ((st = ffd_rig_read_index(p, vertex, "vertex", "a vertex id", &v)))
            return st;
        while (i < s->pin_count && s->pins[i].vertex != v)
            i++;
        if (i == s->pin_count)
            return ffd_fail(err, FFD_ERR_RANGE, "unpin: vertex %u is not pinned", v);
    }
    if (s->pin_count == 0)
        return conflict(err, "there are no pins", "unpin");
    undo_entry before;
    char label[SESS_STEP_NAME];
    if (all)
        snprintf(label, sizeof label, "Unpin all (%zu pin%s)", s->pin_count,
                 s->pin_count == 1 ? "" : "s");
    else
        snprintf(label, sizeof label, "Unpin vertex %u", v);
    if ((st = capture(s, UNDO_STATE, label, &before, err)))
        return st;
    if (all) {
        s->pin_count = 0;
    } else {
        memmove(s->pins + i, s->pins + i + 1, (s->pin_count - i - 1) * sizeof *s->pins);
        s->pin_count--;
    }
    s->residual_count = 0;
    s->revision++;
    return commit(s, &before, err);
}

/* ---------- other ops ---------- */

static ffd_status op_reset(ffd_session *s, ffd_error *err)
{
    ffd_status st = need_method(s, "reset", err);
    undo_entry before;
    if (st || (st = capture(s, UNDO_STATE, "Reset to rest", &before, err)))
        return st;
    if ((st = s->method->vt->reset(s->method, err)) || (st = refresh(s, err)))
        return roll_back(s, &before, st);
    ffd_free(s->pins);
    s->pins = NULL;
    s->pin_count = 0;
    s->residual_count = 0;
    return commit(s, &before, err);
}

static ffd_status op_influence(ffd_session *s, const ffd_rig_parser *p, const cJSON *body, void **reply,
                               size_t *size, ffd_error *err)
{
    static const char *const keys[] = {"points", NULL};
    ffd_status st = need_method(s, "influence", err);
    uint32_t *ids = NULL;
    size_t k = 0;
    if (st || (st = ffd_rig_check_keys(p, body, "body", keys, "points")) ||
        (st = ffd_sess_read_ids(p, cJSON_GetObjectItemCaseSensitive(body, "points"), "points",
                            s->method->vt->control_count(s->method), &ids, &k)))
        return st;
    size_t n = s->ctx.n;
    unsigned char *buf = ffd_calloc(16 + 4 * n, 1);
    if (!buf) {
        ffd_free(ids);
        return ffd_fail(err, FFD_ERR_NOMEM, "influence: out of memory");
    }
    float *w = ffd_calloc(n ? n : 1, sizeof *w);
    st = w ? s->method->vt->influence(s->method, ids, k, w, err)
           : ffd_fail(err, FFD_ERR_NOMEM, "influence: out of memory");
    if (!st) {
        uint32_t head[4] = {0, s->revision, (uint32_t)n, 0};
        memcpy(head, "FFDI", 4);
        memcpy(buf, head, 16);
        memcpy(buf + 16, w, 4 * n);
        *reply = buf;
        *size = 16 + 4 * n;
    } else {
        ffd_free(buf);
    }
    ffd_free(w);
    ffd_free(ids);
    return st;
}

/* A method-specific op, with the undo entry it asks for. */
static ffd_status op_method(ffd_session *s, const char *op, const cJSON *body, ffd_error *err)
{
    ffd_status st = need_method(s, op, err);
    if (st)
        return st;
    undo_entry state, rebuild;
    char label[SESS_STEP_NAME];
    sess_name_op(label, sizeof label, ffd_sess_caps(s->method)->name, op, body);
    if ((st = capture(s, UNDO_STATE, label, &state, err)))
        return st;
    if ((st = capture(s, UNDO_REBUILD, label, &rebuild, err))) {
        entry_free(&state);
        return st;
    }
    int kind = SESS_UNDO_NONE;
    st = s->method->vt->op(s->method, op, body, &kind, err);
    if (st == FFD_ERR_UNSUPPORTED)
        st = ffd_fail(err, FFD_ERR_INVALID, SESS_CONFLICT "%s: not an operation of the %s method",
                      op, ffd_sess_caps(s->method)->name);
    if (!st && (st = refresh(s, err))) /* the op succeeded but evaluating failed: go back */
        roll_back(s, kind == SESS_UNDO_REBUILD ? &rebuild : &state, st);
    if (!st && kind == SESS_UNDO_STATE)
        st = commit(s, &state, err);
    else if (!st && kind == SESS_UNDO_REBUILD)
        st = commit(s, &rebuild, err);
    entry_free(&state);
    entry_free(&rebuild);
    return st;
}

/* Gives the method the weights w (NULL: none) as one undo step, or as part
 * of the step of the stroke the previous weights change began (the same
 * stroke id > 0, nothing in between). On error nothing changes. */
static ffd_status apply_weights(ffd_session *s, const double *w, double stroke, ffd_error *err)
{
    undo_entry before;
    ffd_status st = capture(s, UNDO_REBUILD, "paint weights", &before, err);
    if (st)
        return st;
    int merge = stroke > 0 && stroke == s->weights_stroke && s->revision == s->weights_revision &&
                s->undo.count && !s->redo.count;
    if ((st = ffd_layers_set_weights(&s->method, w, err)) || (st = refresh(s, err)))
        return roll_back(s, &before, st);
    if (merge)
        entry_free(&before);
    else if ((st = commit(s, &before, err)))
        return st;
    s->weights_stroke = stroke;
    s->weights_revision = s->revision;
    return FFD_OK;
}

/* Vertex-group weights (session_weights.c, deformer/layers.c): one undo
 * step per brush stroke. */
static ffd_status op_weights(ffd_session *s, const ffd_rig_parser *p, const cJSON *body,
                             ffd_error *err)
{
    ffd_status st = need_method(s, "weights", err);
    double *w = st ? NULL : ffd_malloc_array(s->ctx.n, sizeof *w);
    if (!st && !w)
        st = ffd_fail(err, FFD_ERR_NOMEM, "weights: out of memory");
    int clear = 0;
    double stroke = 0;
    if (!st && !(st = ffd_layers_weights(s->method, w, err)) &&
        !(st = ffd_sess_read_weights(p, body, s->ctx.n, w, &clear, &stroke)))
        st = apply_weights(s, clear ? NULL : w, stroke, err);
    ffd_free(w);
    return st;
}

ffd_status ffd_session_load_weights(ffd_session *s, const char *text, size_t size,
                                    const char *name, ffd_error *err)
{
    if (!s || (!text && size))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_session_load_weights: NULL argument");
    if (s->drag.kind)
        return conflict(err, "a drag is in progress", "weights/load");
    ffd_status st = need_method(s, "weights/load", err);
    if (st)
        return st;
    name = name ? name : "weights";
    double *w = NULL;
    size_t count = 0;
    if ((st = ffd_rig_parse_weights(text ? text : "", size, name, &w, &count, err)))
        return st;
    if (count != s->ctx.n)
        st = ffd_fail(err, FFD_ERR_INVALID, "%s: %zu weights for %zu vertices", name, count,
                      s->ctx.n);
    for (size_t i = 0; !st && i < count; i++)
        if (!(w[i] >= 0.0 && w[i] <= 1.0))
            st = ffd_fail(err, FFD_ERR_RANGE,
                          "%s: the weight of vertex %zu is %g, outside [0, 1] (the editor paints "
                          "weights from 0, at rest, to 1, the full effect)",
                          name, i, w[i]);
    if (!st)
        st = apply_weights(s, w, 0, err);
    ffd_free(w);
    return st;
}

/* Every vertex's weight as a binary reply (1 everywhere without weights). */
static ffd_status op_weights_values(ffd_session *s, void **reply, size_t *size, ffd_error *err)
{
    double *w = ffd_malloc_array(s->ctx.n, sizeof *w);
    if (!w)
        return ffd_fail(err, FFD_ERR_NOMEM, "weights_values: out of memory");
    ffd_status st = FFD_OK;
    if (s->method)
        st = ffd_layers_weights(s->method, w, err);
    else
        for (size_t i = 0; i < s->ctx.n; i++)
            w[i] = 1.0;
    if (!st)
        st = ffd_sess_weights_reply(w, s->ctx.n, s->revision, reply, size, err);
    ffd_free(w);
    return st;
}

static ffd_status reply_state(const ffd_session *s, void **reply, size_t *size, ffd_error *err)
{
    char *json = NULL;
    ffd_status st = ffd_session_state(s, &json, size, err);
    *reply = json;
    return st;
}

static ffd_status op_remove_mesh(ffd_session *s, const ffd_rig_parser *p, const cJSON *body,
                                 ffd_error *err);

ffd_status ffd_session_command(ffd_session *s, const char *op, const char *body, size_t size,
                               void **reply, size_t *reply_size, int *binary, ffd_error *err)
{
    if (!s || !op || !reply || !reply_size || !binary)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_session_command: NULL argument");
    *reply = NULL;
    *reply_size = 0;
    *binary = 0;
    double t0 = ffd_now();
    cJSON *doc = NULL;
    ffd_status parsed = ffd_sess_parse_body(op, body, size, &doc, err);
    if (parsed)
        return parsed;
    ffd_rig_parser p = {op, err, NULL};
    ffd_status st;
    int is_drag_step = 0;
    int empty = cJSON_GetArraySize(doc) == 0;
    if (s->drag.kind && strcmp(op, "drag") && strcmp(op, "drag_end") && strcmp(op, "drag_cancel") &&
        strcmp(op, "influence"))
        st = conflict(err, "a drag is in progress: drag_end or drag_cancel first", op);
    else if (!strcmp(op, "create"))
        st = op_create(s, &p, doc, err);
    else if (!strcmp(op, "drag_begin"))
        st = op_drag_begin(s, &p, doc, err);
    else if (!strcmp(op, "drag")) {
        st = op_drag(s, &p, doc, err);
        is_drag_step = 1;
    } else if (!strcmp(op, "drag_end") || !strcmp(op, "drag_cancel"))
        st = empty ? op_drag_end(s, op[5] == 'e', err) : ffd_rig_expected(&p, "body", "{}");
    else if (!strcmp(op, "move")) {
        /* a whole drag: drag_begin with the points and mode, one step, drag_end */
        cJSON *begin = cJSON_CreateObject(), *step = cJSON_CreateObject();
        const cJSON *item;
        st = begin && step ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "move: out of memory");
        for (item = st ? NULL : doc->child; item; item = item->next) {
            int to_begin = !strcmp(item->string, "points") || !strcmp(item->string, "center") ||
                           !strcmp(item->string, "arap");
            cJSON *copy = cJSON_Duplicate(item, 1);
            if (!copy || !cJSON_AddItemToObject(to_begin ? begin : step, item->string, copy)) {
                cJSON_Delete(copy);
                st = ffd_fail(err, FFD_ERR_NOMEM, "move: out of memory");
                break;
            }
        }
        const char *mode = cJSON_GetObjectItemCaseSensitive(doc, "angle")   ? "rotate"
                           : cJSON_GetObjectItemCaseSensitive(doc, "scale") ? "scale"
                                                                            : "translate";
        if (!st && !cJSON_AddStringToObject(begin, "mode", mode))
            st = ffd_fail(err, FFD_ERR_NOMEM, "move: out of memory");
        uint32_t revision = s->revision;
        if (!st && !(st = op_drag_begin(s, &p, begin, err))) {
            if ((st = op_drag(s, &p, step, err))) {
                op_drag_end(s, 0, NULL);
                s->revision = revision; /* nothing changed */
            } else {
                st = op_drag_end(s, 1, err);
            }
        }
        cJSON_Delete(begin);
        cJSON_Delete(step);
    } else if (!strcmp(op, "pin"))
        st = op_pin(s, &p, doc, err);
    else if (!strcmp(op, "unpin"))
        st = op_unpin(s, &p, doc, err);
    else if (!strcmp(op, "remove_mesh"))
        st = op_remove_mesh(s, &p, doc, err);
    else if (!strcmp(op, "reset"))
        st = empty ? op_reset(s, err) : ffd_rig_expected(&p, "body", "{}");
    else if (!strcmp(op, "undo"))
        st = empty ? undo_redo(s, &s->undo, &s->redo, op, err) : ffd_rig_expected(&p, "body", "{}");
    else if (!strcmp(op, "redo"))
        st = empty ? undo_redo(s, &s->redo, &s->undo, op, err) : ffd_rig_expected(&p, "body", "{}");
    else if (!strcmp(op, "history_goto"))
        st = sess_op_history_goto(s, &p, doc, err);
    else if (!strcmp(op, "influence")) {
        st = op_influence(s, &p, doc, reply, reply_size, err);
        cJSON_Delete(doc);
        *binary = !st;
        return st;
    } else if (!strcmp(op, "weights"))
        st = op_weights(s, &p, doc, err);
    else if (!strcmp(op, "weights_values")) {
        st = empty ? op_weights_values(s, reply, reply_size, err) : ffd_rig_expected(&p, "body", "{}");
        cJSON_Delete(doc);
        *binary = !st;
        return st;
    } else if (ffd_method_op_known(op))
        st = op_method(s, op, doc, err);
    else
        st = ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: unknown operation", op);
    cJSON_Delete(doc);
    s->busy_ms = (ffd_now() - t0) * 1e3;
    if (st)
        return st;
    if (is_drag_step) {
        *binary = 1;
        return ffd_session_frame(s, reply, reply_size, err);
    }
    return reply_state(s, reply, reply_size, err);
}

/* The operations every session knows (ffd_session_command), before the methods' own. */
static const char *const session_ops[] = {"create", "drag_begin", "drag",  "drag_end", "drag_cancel",
                                          "move",   "pin",        "unpin", "influence", "reset",
                                          "undo",   "redo",       "weights", "weights_values",
                                          "remove_mesh", "history_goto"};

const char *ffd_session_op_name(size_t i)
{
    size_t fixed = sizeof session_ops / sizeof *session_ops;
    if (i < fixed)
        return session_ops[i];
    i -= fixed;
    for (size_t m = 0; m < ffd_method_count(); m++)
        for (const char *const *o = ffd_method_at(m)->ops; o && *o; o++)
            if (i-- == 0)
                return *o;
    return NULL;
}

/* ---------- views ---------- */

ffd_status ffd_session_frame(const ffd_session *s, void **data, size_t *size, ffd_error *err)
{
    size_t n = s->ctx.n, c = s->method ? s->method->vt->control_count(s->method) : 0;
    size_t r = s->residual_count;
    size_t bytes = 20 + 4 * (3 * n + 3 * c + r);
    unsigned char *buf = ffd_malloc(bytes);
    double *controls = c ? ffd_malloc_array(c, 3 * sizeof *controls) : NULL;
    if (!buf || (c && !controls)) {
        ffd_free(buf);
        ffd_free(controls);
        return ffd_fail(err, FFD_ERR_NOMEM, "frame: out of memory");
    }
    uint32_t head[5] = {0, s->revision, (uint32_t)n, (uint32_t)c, (uint32_t)r};
    memcpy(head, "FFDF", 4);
    memcpy(buf, head, 20);
    float *f = (float *)(void *)(buf + 20);
    for (size_t i = 0; i < 3 * n; i++)
        f[i] = (float)s->positions[i];
    f += 3 * n;
    if (c)
        s->method->vt->controls(s->method, controls);
    for (size_t i = 0; i < 3 * c; i++)
        f[i] = (float)controls[i];
    f += 3 * c;
    if (r)
        memcpy(f, s->residuals, 4 * r);
    ffd_free(controls);
    *data = buf;
    *size = bytes;
    return FFD_OK;
}

ffd_status ffd_session_delta_frame(ffd_session *s, uint32_t base, const void *frame, size_t size,
                                  void **delta, size_t *delta_size, ffd_error *err)
{
    if (!s || !frame || !delta || !delta_size)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_session_delta_frame: NULL argument");
    uint32_t v = 0;
    if (size >= 20 && (memcpy(&v, (const char *)frame + 8, 4), v != s->ctx.n))
        return ffd_fail(err, FFD_ERR_INVALID, "delta frame: a frame of %u vertices (the mesh has %zu)",
                        v, s->ctx.n);
    ffd_status st = ffd_sess_frames_make(&s->frames, s->mesh, s->ctx.n, err);
    return st ? st : ffd_sess_frames_delta(s->frames, base, frame, size, delta, delta_size, err);
}

ffd_status ffd_session_topology(const ffd_session *s, void **data, size_t *size, ffd_error *err)
{
    const ffd_mesh *mesh = s->mesh;
    size_t n = s->ctx.n, nf = ffd_mesh_face_count(mesh);
    const uint32_t *off = ffd_mesh_face_offsets(mesh), *idx = ffd_mesh_face_indices(mesh);
    size_t t = 0;
    for (size_t f = 0; f < nf; f++)
        t += off[f + 1] - off[f] >= 3 ? off[f + 1] - off[f] - 2 : 0;
    if (t > UINT32_MAX / 3 || n > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "topology: mesh too large to send");
    size_t bytes = 16 + 12 * n + 12 * t;
    unsigned char *buf = ffd_malloc(bytes);
    if (!buf)
        return ffd_fail(err, FFD_ERR_NOMEM, "topology: out of memory");
    uint32_t head[4] = {0, s->revision, (uint32_t)n, (uint32_t)t};
    memcpy(head, "FFDT", 4);
    memcpy(buf, head, 16);
    float *p = (float *)(void *)(buf + 16);
    for (size_t i = 0; i < 3 * n; i++)
        p[i] = (float)s->ctx.rest[i];
    uint32_t *tri = (uint32_t *)(void *)(buf + 16 + 12 * n);
    for (size_t f = 0, w = 0; f < nf; f++)
        for (uint32_t c = off[f] + 1; c + 1 < off[f + 1]; c++) {
            tri[w++] = idx[off[f]];
            tri[w++] = idx[c];
            tri[w++] = idx[c + 1];
        }
    *data = buf;
    *size = bytes;
    return FFD_OK;
}

static cJSON *pins_json(const ffd_session *s)
{
    cJSON *arr = cJSON_CreateArray();
    for (size_t i = 0; arr && i < s->pin_count; i++) {
        cJSON *o = cJSON_CreateObject();
        if (!o || !cJSON_AddItemToArray(arr, o)) {
            cJSON_Delete(o);
            cJSON_Delete(arr);
            return NULL;
        }
        const double *x = s->positions + 3 * (size_t)s->pins[i].vertex, *t = s->pins[i].target;
        double d = sqrt((x[0] - t[0]) * (x[0] - t[0]) + (x[1] - t[1]) * (x[1] - t[1]) +
                        (x[2] - t[2]) * (x[2] - t[2]));
        if (!cJSON_AddNumberToObject(o, "vertex", s->pins[i].vertex) ||
            !ffd_sess_add_item(o, "target", ffd_sess_vec3(t)) ||
            !ffd_sess_add_item(o, "position", ffd_sess_vec3(x)) ||
            !cJSON_AddNumberToObject(o, "residual", d)) {
            cJSON_Delete(arr);
            return NULL;
        }
    }
    return arr;
}

/* "manip": the last direct-manipulation solve (null when none is shown):
 * whether the pins held, and how far the dragged vertex is from its target. */
static int manip_json(const ffd_session *s, cJSON *root)
{
    if (!s->residual_count)
        return cJSON_AddNullToObject(root, "manip") != NULL;
    cJSON *o = cJSON_CreateObject();
    if (!ffd_sess_add_item(root, "manip", o) || !cJSON_AddBoolToObject(o, "pins_met", s->pins_met))
        return 0;
    if (s->residual_count > s->pin_count)
        return cJSON_AddNumberToObject(o, "drag_residual", s->drag_residual) != NULL;
    return cJSON_AddNullToObject(o, "drag_residual") != NULL;
}

ffd_status ffd_session_state(const ffd_session *s, char **json, size_t *size, ffd_error *err)
{
    cJSON *root = cJSON_CreateObject(), *mesh = cJSON_CreateObject();
    ffd_status st = FFD_OK;
    int ok = root && mesh && cJSON_AddItemToObject(root, "mesh", mesh);
    if (!ok)
        cJSON_Delete(mesh);
    ok = ok && cJSON_AddNumberToObject(root, "revision", s->revision) &&
         cJSON_AddStringToObject(mesh, "name", s->name) &&
         cJSON_AddNumberToObject(mesh, "vertices", (double)s->ctx.n) &&
         cJSON_AddNumberToObject(mesh, "faces", (double)ffd_mesh_face_count(s->mesh)) &&
         ffd_sess_add_item(mesh, "min", ffd_sess_vec3(s->ctx.min)) &&
         ffd_sess_add_item(mesh, "max", ffd_sess_vec3(s->ctx.max));
    if (ok && s->method) {
        cJSON *params = cJSON_CreateObject(), *controls = cJSON_CreateObject();
        ok = params && controls && cJSON_AddItemToObject(root, "params", params);
        if (!ok)
            cJSON_Delete(params);
        ok = ok && cJSON_AddItemToObject(root, "controls", controls);
        if (!ok)
            cJSON_Delete(controls);
        ok = ok && cJSON_AddStringToObject(root, "method", ffd_sess_caps(s->method)->name) &&
             cJSON_AddNumberToObject(controls, "count",
                                     (double)s->method->vt->control_count(s->method));
        if (ok && (st = s->method->vt->describe(s->method, params, controls, err))) {
            cJSON_Delete(root);
            return st;
        }
    } else if (ok) {
        ok = cJSON_AddNullToObject(root, "method") != NULL;
    }
    cJSON *drag = NULL;
    if (ok && s->drag.kind) {
        drag = cJSON_CreateObject();
        ok = ffd_sess_add_item(root, "drag", drag) &&
             cJSON_AddStringToObject(drag, "kind", s->drag.kind == DRAG_VERTEX ? "vertex"
                                                                                : "controls");
    } else if (ok) {
        ok = cJSON_AddNullToObject(root, "drag") != NULL;
    }
    cJSON *pins = ok ? pins_json(s) : NULL;
    ok = ok && ffd_sess_add_item(root, "pins", pins); /* deletes pins it could not add */
    ok = ok && manip_json(s, root) && ffd_sess_meshes_json(&s->meshes, s->name, s->mesh, root);
    ok = ok && cJSON_AddNumberToObject(root, "undo", (double)s->undo.count) &&
         cJSON_AddNumberToObject(root, "redo", (double)s->redo.count) &&
         cJSON_AddNumberToObject(root, "busy_ms", s->busy_ms);
    if (ok && s->undo.count)
        ok = cJSON_AddStringToObject(root, "undo_label", s->undo.items[s->undo.count - 1].label) != NULL;
    if (ok && s->redo.count)
        ok = cJSON_AddStringToObject(root, "redo_label", s->redo.items[s->redo.count - 1].label) != NULL;
    ok = ok && sess_persist_state(s, root); /* "history", "autosave" (session_persist.c) */
    char *printed = ok ? cJSON_PrintUnformatted(root) : NULL;
    cJSON_Delete(root);
    if (!printed)
        return ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
    *json = ffd_strdup(printed);
    cJSON_free(printed);
    if (!*json)
        return ffd_fail(err, FFD_ERR_NOMEM, "state: out of memory");
    *size = strlen(*json);
    return FFD_OK;
}

ffd_status ffd_session_rig(const ffd_session *s, char **json, size_t *size, ffd_error *err)
{
    if (!s->method)
        return conflict(err, "no deformer: create one first", "rig");
    /* with the pins, but for several meshes: their vertex ids name the
     * concatenation, which no single mesh file has (docs/editor.md) */
    ffd_status st = state_rig(s, s->meshes.count < 2, json, err);
    if (!st)
        *size = strlen(*json);
    return st;
}

ffd_status ffd_session_deformed(const ffd_session *s, ffd_mesh **out, ffd_error *err)
{
    *out = NULL;
    ffd_mesh *copy = NULL;
    ffd_status st = ffd_sess_clone_mesh(s->mesh, &copy, err);
    if (st || !s->method) {
        *out = copy;
        return st;
    }
    /* The rig is the deformation's record: replaying it is what ffd deform does. */
    char *text = NULL;
    ffd_rig *rig = NULL;
    if (!(st = ffd_sess_rig_text(s->method, &text, err)) &&
        !(st = ffd_rig_parse_json(text, strlen(text), "session", &rig, err)))
        st = ffd_rig_apply_limited(rig, copy, &s->ctx.limits, NULL, err);
    ffd_rig_destroy(rig);
    ffd_free(text);
    if (st)
        ffd_mesh_destroy(copy);
    else
        *out = copy;
    return st;
}

ffd_status ffd_session_export(const ffd_session *s, const ffd_write_options *options, void **data,
                              size_t *size, ffd_error *err)
{
    ffd_mesh *mesh = NULL;
    ffd_status st = ffd_session_deformed(s, &mesh, err);
    if (st)
        return st;
    ffd_write_options o = options ? *options : (ffd_write_options){0};
    if (o.format == FFD_FORMAT_AUTO)
        o.format = ffd_mesh_source_format(s->mesh);
    if (o.format == FFD_FORMAT_AUTO)
        o.format = FFD_FORMAT_PLY;
    unsigned char *bytes = NULL;
    st = ffd_mesh_write_memory(mesh, &o, &bytes, size, err);
    ffd_mesh_destroy(mesh);
    *data = bytes;
    return st;
}

/* ---------- life cycle ---------- */

ffd_status ffd_session_create(ffd_mesh *mesh, const char *name, const ffd_session_options *options,
                              ffd_session **out, ffd_error *err)
{
    if (!mesh || !out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_session_create: NULL argument");
    *out = NULL;
    size_t n = ffd_mesh_vertex_count(mesh);
    if (n == 0)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: the mesh has no vertices", name ? name : "mesh");
    if (n > UINT32_MAX / 4)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: %zu vertices: too many for the editor",
                        name ? name : "mesh", n);
    ffd_session *s = ffd_calloc(1, sizeof *s);
    if (!s)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    s->options = options ? *options : (ffd_session_options){0};
    if (!s->options.max_undo)
        s->options.max_undo = 200;
    if (!s->options.max_controls)
        s->options.max_controls = 2000000;
    s->name = ffd_strdup(name ? name : "mesh");
    s->positions = ffd_malloc_array(n, 3 * sizeof *s->positions);
    if (!s->name || !s->positions) {
        ffd_free(s->name);
        ffd_free(s->positions);
        ffd_free(s);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for %zu vertices", n);
    }
    s->mesh = mesh;
    sess_name_file(s->first_step, sizeof s->first_step, "Open", s->name);
    ffd_sess_ctx_init(&s->ctx, mesh, s->options.max_controls, &s->options.limits);
    memcpy(s->positions, s->ctx.rest, n * 3 * sizeof *s->positions);
    *out = s;
    return FFD_OK;
}

void ffd_session_destroy(ffd_session *s)
{
    if (!s)
        return;
    if (s->drag.kind && s->method)
        s->method->vt->end(s->method, 0);
    drag_free(&s->drag);
    stack_clear(&s->undo);
    stack_clear(&s->redo);
    ffd_free(s->undo.items);
    ffd_free(s->redo.items);
    if (s->method)
        s->method->vt->destroy(s->method);
    ffd_mesh_destroy(s->mesh);
    ffd_sess_meshes_free(&s->meshes);
    ffd_free(s->name);
    ffd_free(s->positions);
    ffd_free(s->pins);
    ffd_free(s->residuals);
    ffd_sess_frames_free(s->frames);
    ffd_free(s->autosave_note);
    ffd_free(s);
}

const ffd_mesh *ffd_session_mesh(const ffd_session *s)
{
    return s->mesh;
}

const char *ffd_session_name(const ffd_session *s)
{
    return s->name;
}

/* ---------- several meshes (session_meshes.c) ---------- */

/* Makes mesh (taken over on success) the session's point set, the parts
 * next (taken over on success; count 0: mesh is the one mesh, named name)
 * its meshes, and rebinds the deformer to it (rebuilt from its rig, which
 * describes it without reference to the points). Pins follow map (old
 * vertex -> new, UINT32_MAX: dropped; NULL: unchanged). The undo history
 * refers to the old point set and is cleared. On error nothing changes. */
static ffd_status set_point_set(ffd_session *s, ffd_mesh *mesh, sess_meshes *next,
                                const char *name, const uint32_t *map, const char *op,
                                ffd_error *err)
{
    size_t n = ffd_mesh_vertex_count(mesh);
    double *positions = ffd_malloc_array(n, 3 * sizeof *positions);
    char *label = ffd_strdup(name);
    char *rig = NULL;
    ffd_status st = positions && label ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", op);
    if (!st && s->method)
        st = ffd_sess_rig_text(s->method, &rig, err);
    if (st) {
        ffd_free(positions);
        ffd_free(label);
        return st;
    }
    sess_ctx old = s->ctx;
    ffd_sess_ctx_init(&s->ctx, mesh, s->options.max_controls, &s->options.limits);
    sess_method *m = NULL;
    if (rig && (st = method_from_text(&s->ctx, rig, strlen(rig), op, NULL, &m, err))) {
        s->ctx = old;
        ffd_free(rig);
        ffd_free(positions);
        ffd_free(label);
        return st;
    }
    ffd_free(rig);
    if (s->method)
        s->method->vt->destroy(s->method);
    s->method = m;
    stack_clear(&s->undo);
    stack_clear(&s->redo);
    size_t kept = 0;
    for (size_t i = 0; i < s->pin_count; i++) {
        uint32_t v = map ? map[s->pins[i].vertex] : s->pins[i].vertex;
        if (v != UINT32_MAX) {
            s->pins[kept] = s->pins[i];
            s->pins[kept++].vertex = v;
        }
    }
    s->pin_count = kept;
    s->residual_count = 0;
    ffd_mesh_destroy(s->mesh);
    s->mesh = mesh;
    ffd_free(s->meshes.parts); /* the part meshes and names moved to next */
    s->meshes = *next;
    memset(next, 0, sizeof *next);
    ffd_free(s->name);
    s->name = label;
    ffd_free(s->positions);
    s->positions = positions;
    return refresh(s, err);
}

ffd_status ffd_session_add_mesh(ffd_session *s, ffd_mesh *mesh, const char *name, ffd_error *err)
{
    if (!s || !mesh)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_session_add_mesh: NULL argument");
    name = name ? name : "mesh";
    if (s->drag.kind)
        return conflict(err, "a drag is in progress: drag_end or drag_cancel first", "add mesh");
    if (!ffd_mesh_vertex_count(mesh))
        return ffd_fail(err, FFD_ERR_INVALID, "add mesh: %s: the mesh has no vertices", name);
    if (ffd_mesh_is_volume(s->mesh) && !s->meshes.count)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "add mesh: %s is a volume mesh: it cannot share the session", s->name);
    size_t count = s->meshes.count ? s->meshes.count : 1;
    sess_meshes next = {ffd_calloc(count + 1, sizeof *next.parts), count + 1};
    char *label = ffd_strdup(name);
    if (!next.parts || !label) {
        ffd_free(next.parts);
        ffd_free(label);
        return ffd_fail(err, FFD_ERR_NOMEM, "add mesh: out of memory");
    }
    if (s->meshes.count)
        memcpy(next.parts, s->meshes.parts, count * sizeof *next.parts);
    else
        next.parts[0] = (sess_mesh_part){s->mesh, s->name, 0, 0};
    next.parts[count] = (sess_mesh_part){mesh, label, 0, 0};
    ffd_mesh *all = NULL;
    ffd_error inner = {{0}};
    ffd_status st = ffd_sess_meshes_concat(&next, &all, &inner);
    if (st) {
        ffd_free(next.parts);
        ffd_free(label);
        return ffd_fail(err, st, "add mesh: %s", inner.message);
    }
    /* one mesh so far: it becomes part 0, owned by the parts from now on */
    ffd_mesh *own = s->mesh;
    if (!s->meshes.count) {
        if (!(next.parts[0].name = ffd_strdup(s->name))) {
            ffd_mesh_destroy(all);
            ffd_free(next.parts);
            ffd_free(label);
            return ffd_fail(err, FFD_ERR_NOMEM, "add mesh: out of memory");
        }
        s->mesh = NULL; /* kept by part 0: set_point_set must not destroy it */
    }
    if ((st = set_point_set(s, all, &next, next.parts[0].name, NULL, "add mesh", err))) {
        if (!s->meshes.count) {
            ffd_free(next.parts[0].name);
            s->mesh = own;
        }
        ffd_mesh_destroy(all);
        ffd_free(next.parts);
        ffd_free(label);
        return st;
    }
    return FFD_OK;
}

ffd_status ffd_session_remove_mesh(ffd_session *s, size_t index, ffd_error *err)
{
    if (!s)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_session_remove_mesh: NULL argument");
    if (s->drag.kind)
        return conflict(err, "a drag is in progress: drag_end or drag_cancel first", "remove_mesh");
    if (!s->meshes.count)
        return conflict(err, "the session's only mesh stays (open another mesh instead)",
                        "remove_mesh");
    if (index >= s->meshes.count)
        return ffd_fail(err, FFD_ERR_RANGE, "remove_mesh: mesh %zu out of range (%zu meshes)",
                        index, s->meshes.count);
    sess_mesh_part gone = s->meshes.parts[index];
    size_t count = s->meshes.count - 1;
    sess_meshes next = {ffd_malloc_array(count, sizeof *next.parts), count};
    uint32_t *map = ffd_malloc_array(s->ctx.n, sizeof *map);
    ffd_mesh *mesh = NULL;
    ffd_status st = next.parts && map ? FFD_OK
                                      : ffd_fail(err, FFD_ERR_NOMEM, "remove_mesh: out of memory");
    if (!st) {
        for (size_t i = 0, j = 0; i < s->meshes.count; i++)
            if (i != index)
                next.parts[j++] = s->meshes.parts[i];
        for (size_t v = 0; v < s->ctx.n; v++)
            map[v] = v < gone.first ? (uint32_t)v
                     : v < gone.first + gone.count ? UINT32_MAX
                                                   : (uint32_t)(v - gone.count);
        if (count > 1) {
            ffd_error inner = {{0}};
            if ((st = ffd_sess_meshes_concat(&next, &mesh, &inner)))
                ffd_fail(err, st, "remove_mesh: %s", inner.message);
        }
    }
    if (!st && count == 1) {
        /* back to one mesh: it is the session's own again, named after it */
        sess_meshes none = {NULL, 0};
        sess_mesh_part last = next.parts[0];
        if (!(st = set_point_set(s, last.mesh, &none, last.name, map, "remove_mesh", err)))
            ffd_free(last.name);
    } else if (!st) {
        st = set_point_set(s, mesh, &next, next.parts[0].name, map, "remove_mesh", err);
        if (st)
            ffd_mesh_destroy(mesh);
    }
    if (!st) {
        ffd_mesh_destroy(gone.mesh);
        ffd_free(gone.name);
    }
    ffd_free(next.parts);
    ffd_free(map);
    return st;
}

static ffd_status op_remove_mesh(ffd_session *s, const ffd_rig_parser *p, const cJSON *body,
                                 ffd_error *err)
{
    static const char *const keys[] = {"mesh", NULL};
    uint32_t index = 0;
    ffd_status st = ffd_rig_check_keys(p, body, "body", keys, "mesh");
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(body, "mesh");
    if (!st && !item)
        st = ffd_rig_expected(p, "mesh", "the index of a mesh (missing)");
    if (!st)
        st = ffd_rig_read_index(p, item, "mesh", "the index of a mesh", &index);
    return st ? st : ffd_session_remove_mesh(s, index, err);
}

size_t ffd_session_mesh_count(const ffd_session *s)
{
    return s->meshes.count ? s->meshes.count : 1;
}

const char *ffd_session_mesh_name(const ffd_session *s, size_t index)
{
    if (!s->meshes.count)
        return index == 0 ? s->name : NULL;
    return index < s->meshes.count ? s->meshes.parts[index].name : NULL;
}

ffd_status ffd_session_deformed_mesh(const ffd_session *s, size_t index, ffd_mesh **out,
                                     ffd_error *err)
{
    if (!s->meshes.count) {
        if (index != 0) {
            *out = NULL;
            return ffd_fail(err, FFD_ERR_RANGE, "mesh %zu out of range (1 mesh)", index);
        }
        return ffd_session_deformed(s, out, err);
    }
    char *rig = NULL;
    ffd_status st = s->method ? ffd_sess_rig_text(s->method, &rig, err) : FFD_OK;
    if (!st)
        st = ffd_sess_meshes_deformed(&s->meshes, index, rig, &s->ctx.limits, out, err);
    ffd_free(rig);
    return st;
}

ffd_status ffd_session_export_mesh(const ffd_session *s, size_t index,
                                   const ffd_write_options *options, void **data, size_t *size,
                                   ffd_error *err)
{
    ffd_mesh *mesh = NULL;
    *data = NULL;
    ffd_status st = ffd_session_deformed_mesh(s, index, &mesh, err);
    if (st)
        return st;
    ffd_write_options o = options ? *options : (ffd_write_options){0};
    if (o.format == FFD_FORMAT_AUTO)
        o.format = ffd_mesh_source_format(mesh);
    if (o.format == FFD_FORMAT_AUTO)
        o.format = FFD_FORMAT_PLY;
    unsigned char *bytes = NULL;
    st = ffd_mesh_write_memory(mesh, &o, &bytes, size, err);
    ffd_mesh_destroy(mesh);
    *data = bytes;
    return st;
}

/* ---------- the history and its record (session_persist.h) ---------- */

/* The state's rig as text; with_pins: the pins too (docs/rig.md "pins"). */
static ffd_status state_rig(const ffd_session *s, int with_pins, char **text, ffd_error *err)
{
    *text = NULL;
    if (!s->method)
        return FFD_OK;
    cJSON *root = cJSON_CreateObject();
    if (!root || !cJSON_AddNumberToObject(root, "version", 1) ||
        !cJSON_AddStringToObject(root, "deformer", ffd_sess_caps(s->method)->name)) {
        cJSON_Delete(root);
        return ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
    }
    ffd_status st = s->method->vt->rig(s->method, root, err);
    if (!st && with_pins && s->pin_count &&
        !ffd_sess_add_item(root, "pins", ffd_rig_pins_json(s->pins, s->pin_count)))
        st = ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
    if (!st) {
        char *printed = cJSON_Print(root);
        *text = printed ? ffd_strdup(printed) : NULL;
        cJSON_free(printed);
        if (!*text)
            st = ffd_fail(err, FFD_ERR_NOMEM, "rig: out of memory");
    }
    cJSON_Delete(root);
    return st;
}

ffd_status sess_state_rig(const ffd_session *s, char **text, ffd_error *err)
{
    return state_rig(s, 1, text, err);
}

size_t sess_history_count(const ffd_session *s)
{
    return s->undo.count + 1 + s->redo.count;
}

size_t sess_history_current(const ffd_session *s)
{
    return s->undo.count;
}

/* Step i is the state undo.items[i] restores (i < current), the present
 * (i == current) or the state redo.items[redo.count - 1 - (i - current - 1)]
 * restores; its name is the change that led to it. */
const char *sess_history_name(const ffd_session *s, size_t i)
{
    if (i == 0)
        return s->first_step;
    if (i <= s->undo.count)
        return s->undo.items[i - 1].label;
    size_t j = i - s->undo.count - 1;
    return j < s->redo.count ? s->redo.items[s->redo.count - 1 - j].label : NULL;
}

ffd_status sess_history_rig(const ffd_session *s, size_t i, char **text, ffd_error *err)
{
    *text = NULL;
    const undo_entry *e = NULL;
    if (i < s->undo.count)
        e = &s->undo.items[i];
    else if (i > s->undo.count && i - s->undo.count - 1 < s->redo.count)
        e = &s->redo.items[s->redo.count - 1 - (i - s->undo.count - 1)];
    else if (i != s->undo.count)
        return ffd_fail(err, FFD_ERR_RANGE, "history: step %zu out of range", i);
    if (!e)
        return sess_state_rig(s, text, err);
    if (e->state_rig && !(*text = ffd_strdup(e->state_rig)))
        return ffd_fail(err, FFD_ERR_NOMEM, "history: out of memory");
    return FFD_OK;
}

size_t sess_autosave_max_bytes(const ffd_session *s)
{
    return s->options.autosave_max_bytes ? s->options.autosave_max_bytes : FFD_AUTOSAVE_MAX_BYTES;
}

int sess_dragging(const ffd_session *s)
{
    return s->drag.kind != DRAG_NONE;
}

const char *sess_autosave_note(const ffd_session *s)
{
    return s->autosave_note;
}

void sess_set_autosave_note(ffd_session *s, char *json)
{
    ffd_free(s->autosave_note);
    s->autosave_note = json;
}

/* A jump of n >= 2 steps over entries that all rebuild from rig text (a
 * resumed history, structural steps): only the target is built. The top n
 * entries E_1 (top) .. E_n of from go to to as the states they leave:
 * the present (named E_1's label), then E_i's state named E_{i+1}'s label;
 * E_n's state becomes the present. 1: not such a jump (nothing changed). */
static int jump_rebuilding(ffd_session *s, undo_stack *from, undo_stack *to, size_t n,
                           ffd_status *status, ffd_error *err)
{
    if (n < 2 || n > from->count)
        return 1;
    undo_entry *top = from->items + from->count - 1, *deep = from->items + from->count - n;
    for (undo_entry *e = deep; e <= top; e++)
        if (e->kind != UNDO_REBUILD)
            return 1;
    /* all that can fail first: the target, the present's entry, room on to */
    sess_method *m = NULL;
    undo_entry present;
    ffd_status st = deep->rig ? method_from_text(&s->ctx, deep->rig, strlen(deep->rig),
                                                 "history_goto", NULL, &m, err)
                              : FFD_OK;
    if (!st && (st = capture(s, UNDO_REBUILD, top->label, &present, err))) {
        if (m)
            m->vt->destroy(m);
    }
    if (!st && !ffd_grow((void **)&to->items, &to->cap, to->count + n, sizeof *to->items)) {
        entry_free(&present);
        if (m)
            m->vt->destroy(m);
        st = ffd_fail(err, FFD_ERR_NOMEM, "history_goto: out of memory");
    }
    *status = st;
    if (st)
        return 0;
    stack_push(s, to, &present, NULL); /* cannot fail: room made */
    for (undo_entry *e = top; e > deep; e--) {
        undo_entry moved = *e; /* E_i's state, named after E_{i+1} */
        snprintf(moved.label, sizeof moved.label, "%s", (e - 1)->label);
        memset(e, 0, sizeof *e);
        stack_push(s, to, &moved, NULL);
    }
    if (s->method)
        s->method->vt->destroy(s->method);
    s->method = m;
    ffd_free(s->pins);
    s->pins = deep->pins;
    s->pin_count = deep->pin_count;
    deep->pins = NULL;
    entry_free(deep);
    from->count -= n;
    s->residual_count = 0;
    *status = refresh(s, err);
    return 0;
}

ffd_status sess_op_history_goto(ffd_session *s, const ffd_rig_parser *p, const cJSON *body,
                                ffd_error *err)
{
    static const char *const keys[] = {"index", NULL};
    ffd_status st = ffd_rig_check_keys(p, body, "body", keys, "index");
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(body, "index");
    uint32_t index = 0;
    if (st)
        return st;
    if (!item)
        return ffd_rig_expected(p, "index", "a step of the history, 0 for the first (missing)");
    if ((st = ffd_rig_read_index(p, item, "index", "a step of the history, 0 for the first",
                                 &index)))
        return st;
    size_t count = sess_history_count(s), start = s->undo.count;
    if (index >= count)
        return ffd_fail(err, FFD_ERR_RANGE,
                        "history_goto: index: %u out of range (the history has %zu steps, 0 to %zu)",
                        index, count, count - 1);
    if (s->undo.count > index &&
        !jump_rebuilding(s, &s->undo, &s->redo, s->undo.count - index, &st, err))
        return st;
    if (s->undo.count < index &&
        !jump_rebuilding(s, &s->redo, &s->undo, index - s->undo.count, &st, err))
        return st;
    while (!st && s->undo.count > index)
        st = undo_redo(s, &s->undo, &s->redo, "history_goto", err);
    while (!st && s->undo.count < index)
        st = undo_redo(s, &s->redo, &s->undo, "history_goto", err);
    if (st) { /* back to where it started, as far as it goes */
        while (s->undo.count > start && !undo_redo(s, &s->undo, &s->redo, "history_goto", NULL))
            ;
        while (s->undo.count < start && !undo_redo(s, &s->redo, &s->undo, "history_goto", NULL))
            ;
    }
    return st;
}

/* A stored step of a resumed history: an undo entry rebuilding from rig
 * (NULL: no deformer) with the rig's pins. */
static ffd_status restored_entry(const ffd_session *s, const char *name, const char *rig,
                                 undo_entry *e, ffd_error *err)
{
    memset(e, 0, sizeof *e);
    e->kind = UNDO_REBUILD;
    snprintf(e->label, sizeof e->label, "%s", name);
    if (!rig)
        return FFD_OK;
    ffd_rig *parsed = NULL;
    ffd_status st = ffd_rig_parse_json(rig, strlen(rig), "history", &parsed, err);
    if (!st)
        st = ffd_rig_check_pins(parsed, s->ctx.n, err);
    if (!st && parsed->pin_count) {
        e->pins = ffd_malloc_array(parsed->pin_count, sizeof *e->pins);
        if (e->pins) {
            memcpy(e->pins, parsed->pins, parsed->pin_count * sizeof *e->pins);
            e->pin_count = parsed->pin_count;
        }
    }
    ffd_rig_destroy(parsed);
    if (!st && (!(e->rig = ffd_strdup(rig)) || !(e->state_rig = ffd_strdup(rig)) ||
                (e->pin_count == 0) != (e->pins == NULL)))
        st = ffd_fail(err, FFD_ERR_NOMEM, "history: out of memory");
    if (st)
        entry_free(e);
    return st;
}

ffd_status sess_history_restore(ffd_session *s, const char *const *names, const char *const *rigs,
                                size_t count, size_t current, ffd_error *err)
{
    if (s->method || s->undo.count || s->redo.count || s->drag.kind)
        return conflict(err, "the session has changes already", "resume");
    if (current >= count)
        return ffd_fail(err, FFD_ERR_RANGE, "resume: current step %zu of %zu", current, count);
    size_t first = current > s->options.max_undo ? current - s->options.max_undo : 0;
    size_t last = count - 1;
    if (last - current > s->options.max_undo)
        last = current + s->options.max_undo;
    size_t n_undo = current - first, n_redo = last - current;
    undo_entry *undo = ffd_calloc(n_undo + 1, sizeof *undo);
    undo_entry *redo = ffd_calloc(n_redo + 1, sizeof *redo);
    undo_entry present;
    memset(&present, 0, sizeof present);
    ffd_status st = undo && redo ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "resume: out of memory");
    size_t made_undo = 0, made_redo = 0;
    /* undo.items[i] restores step first + i and is named after the next step */
    for (; !st && made_undo < n_undo; made_undo++)
        st = restored_entry(s, names[first + made_undo + 1], rigs[first + made_undo],
                            &undo[made_undo], err);
    /* redo.items[n_redo - 1 - j] restores step current + 1 + j, named after it */
    for (; !st && made_redo < n_redo; made_redo++)
        st = restored_entry(s, names[last - made_redo], rigs[last - made_redo], &redo[made_redo],
                            err);
    if (!st)
        st = restored_entry(s, names[current], rigs[current], &present, err);
    sess_method *m = NULL;
    if (!st && present.rig)
        st = method_from_text(&s->ctx, present.rig, strlen(present.rig), "resume", NULL, &m, err);
    if (st) {
        for (size_t i = 0; i < made_undo; i++)
            entry_free(&undo[i]);
        for (size_t i = 0; i < made_redo; i++)
            entry_free(&redo[i]);
        entry_free(&present);
        ffd_free(undo);
        ffd_free(redo);
        return st;
    }
    s->method = m;
    s->pins = present.pins;
    s->pin_count = present.pin_count;
    present.pins = NULL;
    entry_free(&present);
    ffd_free(s->undo.items);
    ffd_free(s->redo.items);
    s->undo.items = undo;
    s->undo.count = n_undo;
    s->undo.cap = n_undo + 1;
    s->redo.items = redo;
    s->redo.count = n_redo;
    s->redo.cap = n_redo + 1;
    snprintf(s->first_step, sizeof s->first_step, "%s", names[first]);
    if ((st = refresh(s, err))) { /* the rig did not evaluate: back to the bare session */
        stack_clear(&s->undo);
        stack_clear(&s->redo);
        if (s->method)
            s->method->vt->destroy(s->method);
        s->method = NULL;
        ffd_free(s->pins);
        s->pins = NULL;
        s->pin_count = 0;
        sess_name_file(s->first_step, sizeof s->first_step, "Open", s->name);
        refresh(s, NULL);
    }
    return st;
}
