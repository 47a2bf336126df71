/* rig_points — the scattered-control-point methods' shared rig parts
 * (rig_points.h): the moved control points, the writer of the points and
 * moves, and the application of a rig to a mesh by the method's operations. */
#include "rig/rig_points.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <string.h>

/* The control points of a scattered-point method (RBF, IDW; docs/rbf-idw.md):
 * "control_points" (required), "deformed_control_points" (one per control
 * point) and "moves" (indices in range). */
ffd_status ffd_rig_read_control_points(const ffd_rig_parser *p, const cJSON *root,
                                       ffd_rig_points *pts)
{
    double **points = &pts->control_points, **deformed = &pts->deformed;
    size_t *count = &pts->count, *move_count = &pts->move_count;
    ffd_rig_point_move **moves = &pts->moves;
    const cJSON *item;
    ffd_status s;
    if (!(item = cJSON_GetObjectItemCaseSensitive(root, "control_points")))
        return ffd_rig_expected(p, "control_points", "an array of points [x,y,z] (missing)");
    if ((s = ffd_rig_read_points(p, item, "control_points", 1, points, count)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "deformed_control_points"))) {
        size_t deformed_count = 0;
        if ((s = ffd_rig_read_points(p, item, "deformed_control_points", 1, deformed,
                                     &deformed_count)))
            return s;
        if (deformed_count != *count)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: deformed_control_points: %zu points for %zu control_points "
                            "(expected one per control point)",
                            p->name, deformed_count, *count);
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "moves"))) {
        void *read;
        s = ffd_rig_read_array(p, item, "moves", "an array of {\"index\": i, \"delta\": [dx,dy,dz]}",
                               sizeof **moves, ffd_rig_read_point_move, NULL,
                               (void *)"a control point index", &read, move_count);
        *moves = read;
        if (s)
            return s;
        for (size_t i = 0; i < *move_count; i++)
            if ((*moves)[i].index >= *count)
                return ffd_fail(p->err, FFD_ERR_RANGE,
                                "%s: moves[%zu].index: %u out of range (%zu control points, "
                                "indices start at 0)",
                                p->name, i, (*moves)[i].index, *count);
    }
    return FFD_OK;
}

double *ffd_rig_points_moved(const ffd_rig_points *r)
{
    double *p = ffd_malloc_array(r->count, 3 * sizeof *p);
    if (!p)
        return NULL;
    memcpy(p, r->deformed ? r->deformed : r->control_points, r->count * 3 * sizeof *p);
    for (size_t i = 0; i < r->move_count; i++)
        for (int a = 0; a < 3; a++)
            p[3 * r->moves[i].index + a] += r->moves[i].delta[a];
    return p;
}

static cJSON *points_json(const double *p, size_t n)
{
    cJSON *a = cJSON_CreateArray();
    for (size_t i = 0; a && i < n; i++)
        if (!ffd_sess_add_to_array(a, ffd_sess_vec3(p + 3 * i))) {
            cJSON_Delete(a);
            return NULL;
        }
    return a;
}

int ffd_rig_points_write_rest(const ffd_rig_points *r, cJSON *root)
{
    return ffd_sess_add_item(root, "control_points", points_json(r->control_points, r->count));
}

int ffd_rig_points_write_moves(const ffd_rig_points *r, cJSON *root)
{
    cJSON *moves = NULL;
    int ok = (!r->deformed || ffd_sess_add_item(root, "deformed_control_points",
                                                points_json(r->deformed, r->count))) &&
             (moves = cJSON_AddArrayToObject(root, "moves"));
    for (size_t i = 0; ok && i < r->move_count; i++) {
        cJSON *move = cJSON_CreateObject();
        ok = ffd_sess_add_to_array(moves, move) &&
             cJSON_AddNumberToObject(move, "index", r->moves[i].index) &&
             ffd_sess_add_item(move, "delta", ffd_sess_vec3(r->moves[i].delta));
    }
    return ok;
}

void ffd_rig_points_release(ffd_rig_points *r)
{
    ffd_free(r->control_points);
    ffd_free(r->deformed);
    ffd_free(r->moves);
}

ffd_status ffd_rig_apply_points(const ffd_point_morph_ops *ops, const ffd_rig *rig,
                                ffd_mesh *mesh, ffd_rig_report *report, ffd_budget *budget,
                                ffd_error *err)
{
    const ffd_rig_points *r = ops->points_of(rig);
    const char *name = rig->name;
    const size_t n = ffd_mesh_vertex_count(mesh), k = rig->constraint_count, N = r->count;
    const double *positions = ffd_mesh_positions(mesh);
    ffd_error inner = {{0}};
    void *morph = NULL;
    double *moved = NULL, *rest = NULL, *current = NULL, *targets = NULL, *delta = NULL;
    double *residuals = NULL, *deformed = NULL, *jacobians = NULL;
    size_t *rows = NULL;
    ffd_manip_result result = {0};
    ffd_timings timings = {0};
    ffd_status s = ops->charge(rig, n, budget, &inner);
    if (s)
        return ffd_fail(err, s, "%s: %s", name, inner.message);

    double t0 = ffd_now();
    if ((s = ops->create(rig, &morph, &inner))) {
        s = ffd_rig_wrap(err, s, name, "control_points", &inner);
        goto fail;
    }
    if (!(moved = ffd_rig_points_moved(r))) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
        goto fail;
    }
    if ((s = ops->set_points(morph, moved, &inner))) {
        s = ffd_rig_wrap(err, s, name, "moves", &inner);
        goto fail;
    }
    double t1 = ffd_now();
    timings.bind = t1 - t0;

    if (k) {
        rest = ffd_malloc_array(k, 3 * sizeof *rest);
        current = ffd_malloc_array(k, 3 * sizeof *current);
        targets = ffd_malloc_array(k, 3 * sizeof *targets);
        residuals = ffd_malloc_array(k, sizeof *residuals);
        rows = ffd_malloc_array(k, sizeof *rows);
        delta = ffd_calloc(N, 3 * sizeof *delta);
        if (!rest || !current || !targets || !residuals || !rows || !delta) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu constraints", name, k);
            goto fail;
        }
        if ((s = ffd_rig_constraint_points(rig, positions, n, rest, err)))
            goto fail;
        for (size_t c = 0; c < k; c++) {
            rows[c] = c;
            memcpy(targets + 3 * c, rig->constraints[c].target, 3 * sizeof *targets);
        }
        ffd_point_rows pins = {morph, rest};
        ffd_linear_map map;
        ops->linear_map(&pins, k, &map);
        ffd_manip_options options = {.rcond = rig->rcond};
        if ((s = ffd_rig_charge_manip(&map, k, budget, &inner)) ||
            (s = ops->eval(morph, rest, k, current, &inner)) ||
            (s = ffd_manip_solve(&map, rows, k, current, targets, &options, delta, NULL, &result,
                                 &inner))) {
            s = ffd_rig_wrap(err, s, name, "constraints", &inner);
            goto fail;
        }
        for (size_t i = 0; i < 3 * N; i++)
            moved[i] += delta[i];
        if ((s = ops->set_points(morph, moved, &inner)) ||
            (s = ops->eval(morph, rest, k, current, &inner))) {
            s = ffd_rig_wrap(err, s, name, "constraints", &inner);
            goto fail;
        }
        result.max_residual = ffd_rig_residuals(k, current, targets, residuals);
    }
    double t2 = ffd_now();
    timings.solve = t2 - t1;

    deformed = ffd_malloc_array(n ? n : 1, 3 * sizeof *deformed);
    if (!deformed) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu vertices", name, n);
        goto fail;
    }
    if ((s = ops->eval(morph, positions, n, deformed, &inner))) {
        s = ffd_rig_wrap(err, s, name, "evaluating", &inner);
        goto fail;
    }
    if (ffd_mesh_normal_count(mesh) > 0) {
        jacobians = ffd_malloc_array(n ? n : 1, 9 * sizeof *jacobians);
        if (!jacobians) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu Jacobians", name, n);
            goto fail;
        }
        if ((s = ops->jacobian(morph, positions, n, jacobians, &inner))) {
            s = ffd_rig_wrap(err, s, name, "Jacobians", &inner);
            goto fail;
        }
    }
    if (report) {
        unsigned long mark;
        cJSON *details = ffd_rig_details_create(&mark);
        if (details)
            ops->details(rig, morph, details);
        if ((s = ffd_rig_report_set_details(report, details, mark, name, err)))
            goto fail;
    }
    if ((s = ffd_mesh_set_positions(mesh, deformed, jacobians, &inner))) {
        s = ffd_rig_wrap(err, s, name, "deformed positions", &inner);
        goto fail;
    }
    timings.evaluate = ffd_now() - t2;
    if (report) {
        report->constraint_count = k;
        report->residuals = residuals;
        report->reached = current;
        residuals = current = NULL;
        report->rank = result.rank;
        report->max_residual = result.max_residual;
        report->timings = timings;
        report->control_count = N;
        report->control_points = moved;
        report->control_label = ops->control_label;
        moved = NULL;
    }
fail:
    ops->destroy(morph);
    ffd_free(moved);
    ffd_free(rest);
    ffd_free(current);
    ffd_free(targets);
    ffd_free(delta);
    ffd_free(residuals);
    ffd_free(rows);
    ffd_free(deformed);
    ffd_free(jacobians);
    return s;
}
