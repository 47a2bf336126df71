/* tspline_rig.c — applying a "tspline" rig (Zhang, Zheng & Cai 2020): build
 * the T-spline volume over the mesh, run the steps in order (refinements,
 * proxy-driven ARAP deformations, direct moves, direct manipulation of
 * vertices), evaluate, check the map for folds. The mesh changes only at
 * the end, all or nothing. */
#include "tspline/tspline_method.h"
#include "rig/rig.h"
#include "tspline/tsv.h"

#include <cjson/cJSON.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

/* A growable set of control ids with membership flags. */
typedef struct id_set {
    uint32_t *ids;
    size_t count, cap;
    uint8_t *in;   /* control_count flags */
} id_set;

static ffd_status set_add(id_set *s, uint32_t v, ffd_error *err)
{
    if (s->in[v])
        return FFD_OK;
    if (!ffd_grow((void **)&s->ids, &s->cap, s->count + 1, sizeof(uint32_t)))
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    s->ids[s->count++] = v;
    s->in[v] = 1;
    return FFD_OK;
}

static void set_clear(id_set *s)
{
    for (size_t i = 0; i < s->count; i++)
        s->in[s->ids[i]] = 0;
    s->count = 0;
}

static const char *select_name(ffd_rig_tsv_select k)
{
    static const char *const names[] = {"points", "near", "box", "edges", "faces", "cells"};
    return names[k];
}

/* The control points a selection names (design: proxy points for "near"). */
static ffd_status select_points(ffd_tsv *t, const ffd_rig_tsv_selection *sel, id_set *out,
                                ffd_error *err)
{
    const size_t nv = ffd_tsv_control_count(t);
    const double *P = ffd_tsv_control_points(t);
    ffd_status s = FFD_OK;
    switch (sel->kind) {
    case FFD_RIG_SELECT_POINTS:
        for (size_t i = 0; i < sel->id_count && !s; i++) {
            if (sel->ids[i] >= nv)
                return ffd_fail(err, FFD_ERR_RANGE, "points[%zu]: control point %u: there are %zu",
                                i, sel->ids[i], nv);
            s = set_add(out, sel->ids[i], err);
        }
        return s;
    case FFD_RIG_SELECT_NEAR: {
        ffd_tsv_proxy proxy;
        ffd_tsv_get_proxy(t, &proxy);
        size_t m = proxy.vertex_count ? proxy.vertex_count : nv;
        double best = INFINITY;
        uint32_t arg = 0;
        for (size_t i = 0; i < m; i++) {
            uint32_t v = proxy.vertex_count ? proxy.vertices[i] : (uint32_t)i;
            const double *p = P + 3 * (size_t)v;
            double d = (p[0] - sel->near[0]) * (p[0] - sel->near[0]) +
                       (p[1] - sel->near[1]) * (p[1] - sel->near[1]) +
                       (p[2] - sel->near[2]) * (p[2] - sel->near[2]);
            if (d < best) {
                best = d;
                arg = v;
            }
        }
        return set_add(out, arg, err);
    }
    case FFD_RIG_SELECT_BOX: {
        size_t found = 0; /* inside the box, whether or not already in out */
        for (size_t v = 0; v < nv && !s; v++) {
            const double *p = P + 3 * v;
            int inside = 1;
            for (int a = 0; a < 3; a++)
                if (p[a] < sel->box_min[a] || p[a] > sel->box_max[a])
                    inside = 0;
            if (inside) {
                found++;
                s = set_add(out, (uint32_t)v, err);
            }
        }
        if (!s && !found) {
            /* an empty box is almost always a mistake in the rig */
            return ffd_fail(err, FFD_ERR_INVALID,
                            "box [%g, %g, %g] - [%g, %g, %g] holds no control point",
                            sel->box_min[0], sel->box_min[1], sel->box_min[2], sel->box_max[0],
                            sel->box_max[1], sel->box_max[2]);
        }
        return s;
    }
    default: {
        ffd_tsv_element kind = sel->kind == FFD_RIG_SELECT_EDGES   ? FFD_TSV_EDGE
                               : sel->kind == FFD_RIG_SELECT_FACES ? FFD_TSV_FACE
                                                                    : FFD_TSV_CELL;
        for (size_t i = 0; i < sel->id_count && !s; i++) {
            uint32_t *ids = NULL;
            size_t count = 0;
            ffd_error inner = {{0}};
            s = ffd_tsv_element_points(t, kind, sel->ids[i], &ids, &count, &inner);
            if (s)
                return ffd_fail(err, s, "%s[%zu]: %s", select_name(sel->kind), i, inner.message);
            for (size_t j = 0; j < count && !s; j++)
                s = set_add(out, ids[j], err);
            ffd_free(ids);
        }
        return s;
    }
    }
}

/* Where a handle's points go: translated, or rotated about its centre. */
static void handle_targets(const ffd_rig_tsv_handle *h, const double *P, const uint32_t *ids,
                           size_t count, double *targets)
{
    double c[3] = {0, 0, 0}, k[3] = {0, 0, 0};
    if (h->has_rotate) {
        if (h->has_center) {
            memcpy(c, h->center, sizeof c);
        } else {
            for (size_t i = 0; i < count; i++)
                for (int a = 0; a < 3; a++)
                    c[a] += P[3 * (size_t)ids[i] + a] / (double)count;
        }
        double len = sqrt(h->axis[0] * h->axis[0] + h->axis[1] * h->axis[1] +
                          h->axis[2] * h->axis[2]);
        for (int a = 0; a < 3; a++)
            k[a] = h->axis[a] / len;
    }
    for (size_t i = 0; i < count; i++) {
        const double *p = P + 3 * (size_t)ids[i];
        double *q = targets + 3 * i;
        if (h->has_delta) {
            for (int a = 0; a < 3; a++)
                q[a] = p[a] + h->delta[a];
        } else {
            double v[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]}, r[3];
            ffd_rig_rotate(k, h->angle, v, r);
            for (int a = 0; a < 3; a++)
                q[a] = c[a] + r[a];
        }
    }
}

/* Sets the frozen set to exactly the points of the selections. */
static ffd_status apply_freeze(ffd_tsv *t, const ffd_rig_tsv_step *st, id_set *scratch,
                               ffd_error *err)
{
    const size_t nv = ffd_tsv_control_count(t);
    ffd_status s = FFD_OK;
    set_clear(scratch);
    for (size_t f = 0; f < st->freeze_count && !s; f++) {
        ffd_error inner = {{0}};
        s = select_points(t, &st->freeze[f], scratch, &inner);
        if (s)
            return ffd_fail(err, s, "freeze[%zu]: %s", f, inner.message);
    }
    for (size_t v = 0; v < nv && !s; v++)
        s = ffd_tsv_set_frozen(t, (uint32_t)v, scratch->in[v], err);
    set_clear(scratch);
    return s;
}

ffd_status ffd_rig_tsv_resolve(ffd_tsv *t, const ffd_rig_tsv_step *st, ffd_tsv_insertion **out,
                               size_t *out_count, ffd_error *err)
{
    ffd_tsv_insertion *ins = NULL;
    size_t count = 0, cap = 0;
    ffd_status s = FFD_OK;
    for (size_t i = 0; i < st->refinement_count && !s; i++) {
        const ffd_rig_tsv_refinement *r = &st->refinements[i];
        if (r->proxy_cells) {
            /* octree split of every cell inside the proxy (Fig. 6-7) */
            const tsv_lattice *L = t->L;
            for (size_t c = 0; c < L->nc && !s; c++) {
                if (L->cells[c].outside)
                    continue;
                int thick = 0;
                for (int a = 0; a < 3; a++)
                    thick += L->cells[c].hi[a] > L->cells[c].lo[a] &&
                             tsv_kappa(L->cells[c].hi[a]) > tsv_kappa(L->cells[c].lo[a]);
                if (!thick)
                    continue;
                if (!ffd_grow((void **)&ins, &cap, count + 1, sizeof *ins))
                    s = ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
                else
                    ins[count++] = (ffd_tsv_insertion){FFD_TSV_CELL, (uint32_t)c, 0};
            }
            continue;
        }
        ffd_tsv_insertion one = {r->kind, r->id, r->ratio};
        if (r->by_near) {
            ffd_error inner = {{0}};
            s = ffd_tsv_locate(t, r->kind, r->near, &one.id, &inner);
            if (s) {
                s = ffd_fail(err, s, "refine[%zu]: %s", i, inner.message);
                break;
            }
        }
        if (!ffd_grow((void **)&ins, &cap, count + 1, sizeof *ins))
            s = ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
        else
            ins[count++] = one;
    }
    if (s) {
        ffd_free(ins);
        return s;
    }
    *out = ins;
    *out_count = count;
    return FFD_OK;
}

ffd_status ffd_rig_tsv_charge_refine(const ffd_tsv *t, const ffd_tsv_insertion *ins, size_t count,
                                     ffd_budget *budget, ffd_error *err)
{
    tsv_estimate e;
    ffd_tsv_estimate_refine(t->L, ins, count, &e);
    char have[32], cells[32];
    return ffd_budget_charge(budget, e.bytes, e.work, err,
                             "refining %s cells would make %s cells",
                             ffd_format_count((double)t->L->nc, have, sizeof have),
                             ffd_format_count(e.cells, cells, sizeof cells));
}

/* What the steps did, for the report's details. */
typedef struct tsv_tally {
    size_t refinements;          /* refinement steps applied */
    size_t added_points;         /* control points they added (requested and extra) */
    size_t moved_points;         /* existing control points they moved */
    size_t arap_solves;          /* deform steps */
    double max_handle_error;     /* over all deform steps */
    ffd_tsv_fold_report folds;   /* fold-over check of the final map */
} tsv_tally;

static ffd_status step_refine(ffd_tsv *t, const ffd_rig_tsv_step *st, tsv_tally *tally,
                              ffd_budget *budget, ffd_error *err)
{
    ffd_tsv_insertion *ins = NULL;
    size_t count = 0;
    ffd_status s = ffd_rig_tsv_resolve(t, st, &ins, &count, err);
    if (!s)
        s = ffd_rig_tsv_charge_refine(t, ins, count, budget, err);
    if (!s) {
        ffd_tsv_refine_report rr;
        s = ffd_tsv_refine(t, ins, count, &rr, err);
        if (!s) {
            tally->refinements++;
            tally->added_points += rr.added_points;
            tally->moved_points += rr.moved_points;
        }
    }
    ffd_free(ins);
    return s;
}

ffd_status ffd_rig_tsv_charge_arap(const ffd_tsv *t, uint32_t iterations, ffd_budget *budget,
                                   ffd_error *err)
{
    tsv_estimate e;
    size_t nv = ffd_tsv_control_count(t);
    ffd_tsv_estimate_arap(nv, iterations, &e);
    char count[32];
    return ffd_budget_charge(budget, e.bytes, e.work, err,
                             "the ARAP system of %s control points",
                             ffd_format_count((double)nv, count, sizeof count));
}

static ffd_status step_deform(ffd_tsv *t, const ffd_rig_tsv_step *st, id_set *set,
                              tsv_tally *tally, ffd_budget *budget, ffd_error *err)
{
    ffd_status s = apply_freeze(t, st, set, err);
    if (s)
        return s;
    const double *P = ffd_tsv_control_points(t);
    double *targets = NULL;
    size_t cap = 0;
    /* one handle's points, so that a point in two handles (two targets) is caught */
    id_set one = {0};
    one.in = ffd_calloc(ffd_tsv_control_count(t) ? ffd_tsv_control_count(t) : 1, 1);
    if (!one.in)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    set_clear(set);
    for (size_t h = 0; h < st->handle_count && !s; h++) {
        size_t before = set->count;
        ffd_error inner = {{0}};
        set_clear(&one);
        s = select_points(t, &st->handles[h].sel, &one, &inner);
        if (s) {
            s = ffd_fail(err, s, "handles[%zu]: %s", h, inner.message);
            break;
        }
        for (size_t i = 0; i < one.count && !s; i++) {
            uint32_t v = one.ids[i];
            if (ffd_tsv_frozen(t, v))
                s = ffd_fail(err, FFD_ERR_INVALID,
                             "handles[%zu]: control point %u is also frozen: a target for a "
                             "frozen point conflicts with keeping it fixed",
                             h, v);
            else if (set->in[v])
                s = ffd_fail(err, FFD_ERR_INVALID,
                             "handles[%zu]: control point %u is given twice (an earlier handle "
                             "has it too): a point has one target",
                             h, v);
            else
                s = set_add(set, v, err);
        }
        if (s)
            break;
        if (!ffd_grow((void **)&targets, &cap, 3 * set->count, sizeof(double))) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
            break;
        }
        handle_targets(&st->handles[h], P, set->ids + before, set->count - before,
                       targets + 3 * before);
    }
    ffd_tsv_arap *arap = NULL;
    ffd_tsv_arap_report ar = {0};
    if (!s)
        s = ffd_rig_tsv_charge_arap(t, st->arap.iterations, budget, err);
    if (!s)
        s = ffd_tsv_arap_begin(t, set->ids, set->count, &st->arap, &arap, err);
    if (!s)
        s = ffd_tsv_arap_solve(arap, targets, &ar, err);
    ffd_tsv_arap_destroy(arap);
    if (!s) {
        tally->arap_solves++;
        if (ar.max_handle_error > tally->max_handle_error)
            tally->max_handle_error = ar.max_handle_error;
    }
    set_clear(set);
    ffd_free(one.ids);
    ffd_free(one.in);
    ffd_free(targets);
    return s;
}

static ffd_status step_move(ffd_tsv *t, const ffd_rig_tsv_step *st, id_set *set, ffd_error *err)
{
    ffd_status s = FFD_OK;
    for (size_t h = 0; h < st->handle_count && !s; h++) {
        set_clear(set);
        ffd_error inner = {{0}};
        s = select_points(t, &st->handles[h].sel, set, &inner);
        if (s)
            return ffd_fail(err, s, "move[%zu]: %s", h, inner.message);
        double *q = ffd_malloc_array(set->count ? set->count : 1, 3 * sizeof(double));
        if (!q)
            return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
        const double *P = ffd_tsv_control_points(t);
        handle_targets(&st->handles[h], P, set->ids, set->count, q);
        for (size_t i = 0; i < set->count && !s; i++) {
            const double *p = P + 3 * (size_t)set->ids[i];
            double d[3] = {q[3 * i] - p[0], q[3 * i + 1] - p[1], q[3 * i + 2] - p[2]};
            s = ffd_tsv_move(t, set->ids[i], d, &inner);
        }
        ffd_free(q);
        if (s)
            return ffd_fail(err, s, "move[%zu]: %s", h, inner.message);
    }
    set_clear(set);
    return s;
}

/* Direct manipulation of object vertices through the core solver (Hsu et al. 1992). */
static ffd_status step_constrain(ffd_tsv *t, const ffd_rig_tsv_step *st, id_set *set,
                                 const ffd_rig *rig, ffd_rig_report *report, ffd_budget *budget,
                                 ffd_error *err)
{
    ffd_status s = apply_freeze(t, st, set, err);
    if (s)
        return s;
    const size_t k = st->constraint_count, n = ffd_tsv_point_count(t);
    for (size_t c = 0; c < k; c++)
        if (st->constraints[c].vertex >= n)
            return ffd_fail(err, FFD_ERR_RANGE, "targets[%zu].vertex: %u: the mesh has %zu vertices",
                            c, st->constraints[c].vertex, n);
    ffd_linear_map map;
    if ((s = ffd_tsv_linear_map(t, &map, err)))
        return s;
    if ((s = ffd_rig_charge_manip(&map, k, budget, err)))
        return s;
    double *x = ffd_malloc_array(n, 3 * sizeof(double));
    size_t *rows = ffd_malloc_array(k ? k : 1, sizeof(size_t));
    double *cur = ffd_malloc_array(k ? k : 1, 3 * sizeof(double));
    double *tgt = ffd_malloc_array(k ? k : 1, 3 * sizeof(double));
    double *delta = ffd_malloc_array(map.variable_count ? map.variable_count : 1, 3 * sizeof(double));
    if (!x || !rows || !cur || !tgt || !delta) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
        goto done;
    }
    if ((s = ffd_tsv_eval(t, x, err)))
        goto done;
    for (size_t c = 0; c < k; c++) {
        rows[c] = st->constraints[c].vertex;
        memcpy(cur + 3 * c, x + 3 * rows[c], 3 * sizeof(double));
        memcpy(tgt + 3 * c, st->constraints[c].target, 3 * sizeof(double));
    }
    ffd_manip_options mo = {.rcond = rig->rcond};
    ffd_manip_result mr;
    if ((s = ffd_manip_solve(&map, rows, k, cur, tgt, &mo, delta, NULL, &mr, err)))
        goto done;
    const size_t nv = ffd_tsv_control_count(t);
    for (size_t v = 0; v < nv && !s; v++)
        if (map.tie[v] != FFD_TIE_FIXED)
            s = ffd_tsv_move(t, (uint32_t)v, delta + 3 * (size_t)map.tie[v], err);
    if (!s && report) {
        report->rank = mr.rank;
        if ((s = ffd_tsv_eval(t, x, err)))
            goto done;
        double *reached = ffd_malloc_array(k ? k : 1, 3 * sizeof(double));
        double *res = ffd_malloc_array(k ? k : 1, sizeof(double));
        if (!reached || !res) {
            ffd_free(reached);
            ffd_free(res);
            s = ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
            goto done;
        }
        for (size_t c = 0; c < k; c++)
            memcpy(reached + 3 * c, x + 3 * rows[c], 3 * sizeof(double));
        ffd_free(report->reached);
        ffd_free(report->residuals);
        report->reached = reached;
        report->residuals = res;
        report->constraint_count = k;
        report->max_residual = ffd_rig_residuals(k, reached, tgt, res);
    }
done:
    ffd_free(x);
    ffd_free(rows);
    ffd_free(cur);
    ffd_free(tgt);
    ffd_free(delta);
    return s;
}

/* The lattice's edges and proxy, copied into the report (the proxy as its
 * control mesh). */
static ffd_status report_lattice(const ffd_tsv *t, ffd_rig_report *report, ffd_error *err)
{
    const size_t nv = ffd_tsv_control_count(t), ne = ffd_tsv_element_count(t, FFD_TSV_EDGE);
    ffd_tsv_proxy proxy;
    ffd_tsv_get_proxy(t, &proxy);
    size_t corners = proxy.face_offsets ? proxy.face_offsets[proxy.face_count] : 0;
    report->control_points = ffd_malloc_array(nv ? nv : 1, 3 * sizeof(double));
    report->control_edges = ffd_malloc_array(ne ? ne : 1, 2 * sizeof(uint32_t));
    report->control_face_offsets = ffd_malloc_array(proxy.face_count + 1, sizeof(uint32_t));
    report->control_face_points = ffd_malloc_array(corners ? corners : 1, sizeof(uint32_t));
    report->control_mesh_points =
        ffd_malloc_array(proxy.point_count ? proxy.point_count : 1, sizeof(uint32_t));
    if (!report->control_points || !report->control_edges || !report->control_face_offsets ||
        !report->control_face_points || !report->control_mesh_points)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the report");
    memcpy(report->control_points, ffd_tsv_control_points(t), nv * 3 * sizeof(double));
    report->control_count = nv;
    report->control_label = "T-lattice";
    for (size_t e = 0; e < ne; e++)
        ffd_tsv_edge(t, (uint32_t)e, report->control_edges + 2 * e, NULL, NULL);
    report->control_edge_count = ne;
    report->control_face_offsets[0] = 0;
    if (proxy.face_count)
        memcpy(report->control_face_offsets, proxy.face_offsets,
               (proxy.face_count + 1) * sizeof(uint32_t));
    if (corners)
        memcpy(report->control_face_points, proxy.face_points, corners * sizeof(uint32_t));
    if (proxy.point_count)
        memcpy(report->control_mesh_points, proxy.point_controls,
               proxy.point_count * sizeof(uint32_t));
    report->control_mesh_point_count = proxy.point_count;
    report->control_face_count = proxy.face_count;
    return FFD_OK;
}

/* The method's details: the T-lattice and proxy counts, what the steps did,
 * the fold-over check; a fold-over becomes a warning. */
static ffd_status report_details(const ffd_tsv *t, const tsv_tally *tally,
                                 ffd_rig_report *report, const char *name, ffd_error *err)
{
    ffd_tsv_proxy proxy;
    ffd_tsv_get_proxy(t, &proxy);
    const ffd_tsv_fold_report *f = &tally->folds;
    unsigned long mark;
    cJSON *d = ffd_rig_details_create(&mark);
    cJSON_AddNumberToObject(d, "cells", (double)ffd_tsv_element_count(t, FFD_TSV_CELL));
    cJSON_AddNumberToObject(d, "proxy_points", (double)proxy.point_count);
    cJSON_AddNumberToObject(d, "proxy_faces", (double)proxy.face_count);
    cJSON_AddNumberToObject(d, "proxy_vertices", (double)proxy.vertex_count);
    cJSON_AddNumberToObject(d, "refinements", (double)tally->refinements);
    cJSON_AddNumberToObject(d, "added_points", (double)tally->added_points);
    cJSON_AddNumberToObject(d, "moved_points", (double)tally->moved_points);
    cJSON_AddNumberToObject(d, "max_weight_deviation", ffd_tsv_max_weight_deviation(t));
    cJSON_AddNumberToObject(d, "arap_solves", (double)tally->arap_solves);
    cJSON_AddNumberToObject(d, "max_handle_error", tally->max_handle_error);
    cJSON *folds = cJSON_AddObjectToObject(d, "folds");
    cJSON_AddNumberToObject(folds, "cells_checked", (double)f->cells_checked);
    cJSON_AddNumberToObject(folds, "min_det", f->min_det);
    cJSON *cells = cJSON_AddArrayToObject(folds, "folded_cells");
    for (size_t i = 0; i < f->folded_cell_count && cells; i++)
        cJSON_AddItemToArray(cells, cJSON_CreateNumber(f->folded_cells[i]));
    cJSON *faces = cJSON_AddArrayToObject(folds, "inverted_faces");
    for (size_t i = 0; i < f->inverted_face_count && faces; i++)
        cJSON_AddItemToArray(faces, cJSON_CreateNumber(f->inverted_faces[i]));
    ffd_status s = ffd_rig_report_set_details(report, d, mark, name, err);
    if (!s && (f->folded_cell_count || f->inverted_face_count)) {
        char ids[160];
        size_t len = 0;
        for (size_t i = 0; i < f->folded_cell_count && i < 10; i++)
            len += (size_t)snprintf(ids + len, sizeof ids - len, " %u", f->folded_cells[i]);
        s = ffd_rig_report_note(report, name, err,
                                "warning: the deformation folds over: %zu cell%s with a "
                                "non-positive Jacobian determinant (min %.3g; cells%s%s), %zu "
                                "inverted face%s (--report lists all)",
                                f->folded_cell_count, f->folded_cell_count == 1 ? "" : "s",
                                f->min_det, ids, f->folded_cell_count > 10 ? " ..." : "",
                                f->inverted_face_count, f->inverted_face_count == 1 ? "" : "s");
    }
    return s;
}

ffd_status ffd_rig_apply_tspline(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                                 ffd_budget *budget, ffd_error *err)
{
    const ffd_rig_tspline *rt = ffd_rig_tspline_of(rig);
    const char *name = rig->name;
    const size_t n = ffd_mesh_vertex_count(mesh);
    ffd_error inner = {{0}};
    ffd_tsv *t = NULL;
    double *x = NULL, *jac = NULL;
    id_set set = {0};
    tsv_tally tally = {0};
    ffd_rig_report local;
    ffd_rig_report *rep = report ? report : &local;
    memset(rep, 0, sizeof *rep);
    double t0 = ffd_now();
    ffd_status s = ffd_tsv_create(ffd_mesh_positions(mesh), n, ffd_mesh_face_offsets(mesh),
                                  ffd_mesh_face_indices(mesh), ffd_mesh_face_count(mesh),
                                  rt->resolution, &rt->options, &t, &inner);
    if (s)
        return ffd_rig_wrap(err, s, name, "tspline", &inner);
    double t1 = ffd_now();
    for (size_t i = 0; i < rt->step_count && !s; i++) {
        const ffd_rig_tsv_step *st = &rt->steps[i];
        set.count = 0;
        ffd_free(set.in);
        set.in = ffd_calloc(ffd_tsv_control_count(t), 1);
        if (!set.in) {
            s = ffd_fail(&inner, FFD_ERR_NOMEM, "out of memory");
        } else if (st->kind == FFD_RIG_STEP_REFINE) {
            s = step_refine(t, st, &tally, budget, &inner);
        } else if (st->kind == FFD_RIG_STEP_DEFORM) {
            s = step_deform(t, st, &set, &tally, budget, &inner);
        } else if (st->kind == FFD_RIG_STEP_MOVE) {
            s = step_move(t, st, &set, &inner);
        } else {
            s = step_constrain(t, st, &set, rig, rep, budget, &inner);
        }
        if (s) {
            static const char *const kinds[] = {"refine", "deform", "move", "constraints"};
            char context[64];
            snprintf(context, sizeof context, "steps[%zu].%s", i, kinds[st->kind]);
            s = ffd_rig_wrap(err, s, name, context, &inner);
        }
    }
    double t2 = ffd_now();
    if (!s) {
        x = ffd_malloc_array(n, 3 * sizeof(double));
        jac = ffd_malloc_array(n, 9 * sizeof(double));
        if (!x || !jac)
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu vertices", name, n);
    }
    if (!s)
        s = ffd_tsv_eval_jacobian(t, x, jac, &inner);
    if (!s) {
        tsv_estimate e;
        ffd_tsv_estimate_folds(t->L, rt->fold_samples, &e);
        uint32_t fs = rt->fold_samples ? rt->fold_samples : 3;
        char cells[32];
        if ((s = ffd_budget_charge(budget, e.bytes, e.work, &inner,
                                   "%u: the fold check of %s cells at %u^3 samples each", fs,
                                   ffd_format_count((double)ffd_tsv_element_count(t, FFD_TSV_CELL),
                                                    cells, sizeof cells),
                                   fs)))
            s = ffd_rig_wrap(err, s, name, "fold_samples", &inner);
    }
    if (!s && (s = ffd_tsv_check_folds(t, rt->fold_samples, &tally.folds, &inner)))
        s = ffd_rig_wrap(err, s, name, "fold check", &inner);
    double t3 = ffd_now();
    if (!s && (s = report_lattice(t, rep, &inner)))
        s = ffd_rig_wrap(err, s, name, "report", &inner);
    if (!s)
        s = report_details(t, &tally, rep, name, err);
    if (!s && (s = ffd_mesh_set_positions(mesh, x, jac, &inner)))
        s = ffd_rig_wrap(err, s, name, "deformed positions", &inner);
    if (!s) {
        rep->timings.bind = t1 - t0;
        rep->timings.solve = t2 - t1;
        rep->timings.evaluate = t3 - t2;
    }
    if (s || !report)
        ffd_rig_report_free(rep);
    ffd_tsv_fold_report_free(&tally.folds);
    ffd_free(set.ids);
    ffd_free(set.in);
    ffd_free(x);
    ffd_free(jac);
    ffd_tsv_destroy(t);
    return s;
}
