/* rig — applying a PB-FFD rig (McDonnell & Qin): place or take the control
 * set, build the hierarchy and bind the mesh, apply control moves and frame
 * edits, solve the direct-manipulation constraints (§3.3) at the requested
 * level through the generic minimum-norm solver, evaluate (eq. 7), then run
 * the curve deformations (§3.5) on the result. The mesh is changed only by
 * the final ffd_mesh_set_positions, which is all-or-nothing. */
#include "pbffd/pbffd_method.h"
#include "rig/rig.h"

#include <cjson/cJSON.h>

#include <math.h>
#include <stdio.h>
#include <string.h>


void ffd_rig_pb_edited_frame(const ffd_rig_pb_edit *e, const double current[3][3],
                             double out[3][3])
{
    if (e->frame_kind == 1) {
        memcpy(out, e->frame, sizeof e->frame);
        return;
    }
    double len = sqrt(e->axis[0] * e->axis[0] + e->axis[1] * e->axis[1] + e->axis[2] * e->axis[2]);
    double k[3] = {e->axis[0] / len, e->axis[1] / len, e->axis[2] / len};
    for (int a = 0; a < 3; a++) {
        double scaled[3] = {current[a][0] * e->scale[a], current[a][1] * e->scale[a],
                            current[a][2] * e->scale[a]};
        ffd_rig_rotate(k, e->angle, scaled, out[a]);
    }
}

ffd_status ffd_rig_pb_edit_target(const ffd_rig *rig, const ffd_pbffd *pb, const char *key,
                                  size_t i, const ffd_rig_pb_edit *e, size_t *index,
                                  ffd_error *err)
{
    size_t count = ffd_pbffd_control_count(pb, e->level);
    if (!e->by_near) {
        if (e->control >= count)
            return ffd_fail(err, FFD_ERR_RANGE,
                            "%s: %s[%zu].control: %u out of range (level %u has %zu controls)",
                            rig->name, key, i, e->control, e->level, count);
        *index = e->control;
        return FFD_OK;
    }
    double best = INFINITY;
    for (size_t j = 0; j < count; j++) {
        ffd_ebf c;
        if (ffd_pbffd_control(pb, e->level, j, &c, NULL) != FFD_OK || c.disabled)
            continue;
        double d = 0;
        for (int a = 0; a < 3; a++)
            d += (c.center[a] - e->near[a]) * (c.center[a] - e->near[a]);
        if (d < best) {
            best = d;
            *index = j;
        }
    }
    if (best == INFINITY)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: %s[%zu].near: level %u has no enabled control",
                        rig->name, key, i, e->level);
    return FFD_OK;
}

ffd_status ffd_rig_pb_apply_edits(const ffd_rig *rig, ffd_pbffd *pb, size_t *resolved,
                                  double (*frames)[3][3], ffd_error *err)
{
    const ffd_rig_pbffd *r = ffd_rig_pbffd_of(rig);
    ffd_error inner = {{0}};
    char context[64];
    ffd_status s;
    for (size_t i = 0; i < r->move_count; i++) {
        const ffd_rig_pb_edit *e = &r->moves[i];
        size_t j = 0;
        if ((s = ffd_rig_pb_edit_target(rig, pb, "moves", i, e, &j, err)))
            return s;
        if ((s = ffd_pbffd_move(pb, e->level, j, e->delta, &inner))) {
            snprintf(context, sizeof context, "moves[%zu]", i);
            return ffd_rig_wrap(err, s, rig->name, context, &inner);
        }
        if (resolved)
            resolved[i] = j;
    }
    for (size_t i = 0; i < r->frame_count; i++) {
        const ffd_rig_pb_edit *e = &r->frames[i];
        size_t j = 0;
        if ((s = ffd_rig_pb_edit_target(rig, pb, "frames", i, e, &j, err)))
            return s;
        ffd_ebf ebf;
        double frame[3][3];
        if ((s = ffd_pbffd_control(pb, e->level, j, &ebf, &inner)) == FFD_OK) {
            ffd_rig_pb_edited_frame(e, (const double(*)[3])ebf.frame, frame);
            s = ffd_pbffd_set_frame(pb, e->level, j, (const double(*)[3])frame, &inner);
        }
        if (s) {
            snprintf(context, sizeof context, "frames[%zu]", i);
            return ffd_rig_wrap(err, s, rig->name, context, &inner);
        }
        if (resolved)
            resolved[r->move_count + i] = j;
        if (frames)
            memcpy(frames[i], frame, sizeof frame);
    }
    return FFD_OK;
}

ffd_status ffd_rig_pb_constraint_delta(const ffd_rig *rig, ffd_pbffd *pb, const size_t *rows,
                                      const double *current, double *delta,
                                      ffd_manip_result *result, ffd_error *err)
{
    const size_t k = rig->constraint_count, level = ffd_rig_pbffd_of(rig)->constraint_level;
    ffd_error inner = {{0}};
    ffd_linear_map map;
    ffd_status s = ffd_pbffd_linear_map(pb, level, &map, &inner);
    if (s)
        return ffd_rig_wrap(err, s, rig->name, "constraints", &inner);
    size_t controls = ffd_pbffd_control_count(pb, level);
    if (map.variable_count != controls)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "%s: constraints: the map exposes %zu variables, expected %zu", rig->name,
                        map.variable_count, controls);
    uint32_t *cols = ffd_malloc_array(map.max_row_nnz ? map.max_row_nnz : 1, sizeof *cols);
    double *w = ffd_malloc_array(map.max_row_nnz ? map.max_row_nnz : 1, sizeof *w);
    double *now = ffd_malloc_array(k ? k : 1, 3 * sizeof *now);
    double *targets = ffd_malloc_array(k ? k : 1, 3 * sizeof *targets);
    if (!cols || !w || !now || !targets) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the constraints", rig->name);
        goto done;
    }
    for (size_t c = 0; c < k; c++) {
        /* a point that only the (immovable) master holds cannot move at all */
        size_t nnz = map.row(map.self, rows[c], cols, w), movable = 0;
        for (size_t e = 0; e < nnz; e++)
            movable += w[e] != 0.0 && (!map.tie || map.tie[cols[e]] != FFD_TIE_FIXED);
        if (!movable) {
            const ffd_rig_constraint *con = &rig->constraints[c];
            if (con->kind == FFD_RIG_CONSTRAINT_VERTEX)
                s = ffd_fail(err, FFD_ERR_INVALID,
                             "%s: constraints[%zu].vertex: vertex %u lies in no control point's "
                             "region of influence but the master's, so it cannot move (add a "
                             "control point near it or grow a radius)",
                             rig->name, c, con->vertex);
            else
                s = ffd_fail(err, FFD_ERR_INVALID,
                             "%s: constraints[%zu].point: [%.17g, %.17g, %.17g] lies in no "
                             "control point's region of influence but the master's, so it "
                             "cannot move",
                             rig->name, c, con->point[0], con->point[1], con->point[2]);
            goto done;
        }
        memcpy(now + 3 * c, current + 3 * rows[c], 3 * sizeof *now);
        memcpy(targets + 3 * c, rig->constraints[c].target, 3 * sizeof *targets);
    }
    ffd_manip_options options = {.rcond = rig->rcond};
    if ((s = ffd_manip_solve(&map, rows, k, now, targets, &options, delta, NULL, result,
                             &inner)))
        s = ffd_rig_wrap(err, s, rig->name, "constraints", &inner);
done:
    ffd_free(cols);
    ffd_free(w);
    ffd_free(now);
    ffd_free(targets);
    return s;
}

/* Direct manipulation (§3.3) at ffd_rig_pbffd_of(rig)->constraint_level. rows[c] is the bound
 * point of constraint c; current (all bound points) is updated on success. */
static ffd_status solve_constraints(const ffd_rig *rig, ffd_pbffd *pb, const size_t *rows,
                                    double *current, double *reached, double *residuals,
                                    ffd_manip_result *result, ffd_error *err)
{
    const size_t k = rig->constraint_count, level = ffd_rig_pbffd_of(rig)->constraint_level;
    const size_t controls = ffd_pbffd_control_count(pb, level);
    ffd_error inner = {{0}};
    double *delta = ffd_calloc(controls ? controls : 1, 3 * sizeof *delta);
    if (!delta)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the constraints", rig->name);
    ffd_status s = ffd_rig_pb_constraint_delta(rig, pb, rows, current, delta, result, err);
    for (size_t j = 0; !s && j < controls; j++) {
        const double *d = delta + 3 * j;
        if (d[0] == 0 && d[1] == 0 && d[2] == 0)
            continue;
        if ((s = ffd_pbffd_move(pb, level, j, d, &inner)))
            s = ffd_rig_wrap(err, s, rig->name, "constraints", &inner);
    }
    /* Report what the deformation really does at the constrained points. */
    if (!s && (s = ffd_pbffd_eval(pb, current, &inner)))
        s = ffd_rig_wrap(err, s, rig->name, "constraints", &inner);
    if (!s) {
        for (size_t c = 0; c < k; c++)
            memcpy(reached + 3 * c, current + 3 * rows[c], 3 * sizeof *reached);
        double *targets = ffd_malloc_array(k ? k : 1, 3 * sizeof *targets);
        if (!targets) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the constraints", rig->name);
        } else {
            for (size_t c = 0; c < k; c++)
                memcpy(targets + 3 * c, rig->constraints[c].target, 3 * sizeof *targets);
            result->max_residual = ffd_rig_residuals(k, reached, targets, residuals);
            ffd_free(targets);
        }
    }
    ffd_free(delta);
    return s;
}

/* Curves (§3.5), each on the result of everything before it. */
static ffd_status apply_curves(const ffd_rig *rig, double *positions, size_t n, ffd_error *err)
{
    ffd_error inner = {{0}};
    char context[64];
    for (size_t c = 0; c < ffd_rig_pbffd_of(rig)->curve_count; c++) {
        const ffd_rig_curve *rc = &ffd_rig_pbffd_of(rig)->curves[c];
        ffd_pbffd_curve *curve = NULL;
        ffd_pbffd_options options = {0};
        options.sigma = ffd_rig_pbffd_of(rig)->options.sigma;
        ffd_status s = ffd_pbffd_curve_create(rc->points, rc->point_count, rc->radius, rc->samples,
                                              positions, n, &options, &curve, &inner);
        for (size_t m = 0; !s && m < rc->move_count; m++)
            s = ffd_pbffd_curve_move(curve, rc->moves[m].index, rc->moves[m].delta, &inner);
        if (!s)
            s = ffd_pbffd_curve_eval(curve, positions, &inner);
        ffd_pbffd_curve_destroy(curve);
        if (s) {
            snprintf(context, sizeof context, "curves[%zu]", c);
            return ffd_rig_wrap(err, s, rig->name, context, &inner);
        }
    }
    return FFD_OK;
}

ffd_status ffd_rig_apply_pbffd(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                               ffd_budget *budget, ffd_error *err)
{
    const char *name = rig->name;
    const size_t n = ffd_mesh_vertex_count(mesh);
    const size_t k = rig->constraint_count;
    const double *positions = ffd_mesh_positions(mesh);
    ffd_status s = FFD_OK;
    ffd_error inner = {{0}};
    ffd_ebf *placed = NULL;
    ffd_placement_report placement = {0};
    ffd_pbffd *pb = NULL;
    double *bound = NULL, *current = NULL, *jacobians = NULL, *reached = NULL, *residuals = NULL;
    double *report_points = NULL;
    size_t uncovered = 0; /* vertices under no control point but the master */
    size_t *rows = NULL;
    ffd_manip_result result = {0};
    ffd_timings timings = {0};

    /* Bound points: the vertices, then the rest positions of "point" constraints. */
    size_t extra = 0;
    for (size_t c = 0; c < k; c++) {
        const ffd_rig_constraint *con = &rig->constraints[c];
        if (con->kind == FFD_RIG_CONSTRAINT_VERTEX && con->vertex >= n)
            return ffd_fail(err, FFD_ERR_RANGE,
                            "%s: constraints[%zu].vertex: %u out of range (mesh has %zu "
                            "vertices)",
                            name, c, con->vertex, n);
        extra += con->kind == FFD_RIG_CONSTRAINT_POINT;
    }
    const size_t total = n + extra;
    bound = ffd_malloc_array(total ? total : 1, 3 * sizeof *bound);
    current = ffd_malloc_array(total ? total : 1, 3 * sizeof *current);
    rows = ffd_malloc_array(k ? k : 1, sizeof *rows);
    reached = ffd_malloc_array(k ? k : 1, 3 * sizeof *reached);
    residuals = ffd_malloc_array(k ? k : 1, sizeof *residuals);
    if (!bound || !current || !rows || !reached || !residuals) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu vertices", name, n);
        goto fail;
    }
    if (n)
        memcpy(bound, positions, n * 3 * sizeof *bound);
    for (size_t c = 0, e = n; c < k; c++) {
        const ffd_rig_constraint *con = &rig->constraints[c];
        if (con->kind == FFD_RIG_CONSTRAINT_VERTEX) {
            rows[c] = con->vertex;
        } else {
            memcpy(bound + 3 * e, con->point, 3 * sizeof *bound);
            rows[c] = e++;
        }
    }

    double t0 = ffd_now();
    const ffd_ebf *controls = ffd_rig_pbffd_of(rig)->controls;
    size_t control_count = ffd_rig_pbffd_of(rig)->control_count;
    if (ffd_rig_pbffd_of(rig)->controls_auto) {
        if ((s = ffd_pbffd_place(mesh, &ffd_rig_pbffd_of(rig)->placement, &placed, &control_count, &placement,
                                 &inner))) {
            s = ffd_rig_wrap(err, s, name, "controls (automatic placement)", &inner);
            goto fail;
        }
        controls = placed;
    }
    {
        /* Limits: binding tests every point against every control's region
         * (ROI) and keeps a sparse row of the ones it meets (at most all). */
        char ns[32], cs[32];
        double pairs = (double)total * (double)(control_count + 1);
        if ((s = ffd_budget_charge(budget, 24.0 * (double)total * 8.0 + 16.0 * pairs / 8.0,
                                   60.0 * pairs, &inner,
                                   "%s vertices under %s control points",
                                   ffd_format_count((double)total, ns, sizeof ns),
                                   ffd_format_count((double)control_count, cs, sizeof cs)))) {
            s = ffd_rig_wrap(err, s, name, "controls", &inner);
            goto fail;
        }
    }
    if ((s = ffd_pbffd_create(controls, control_count, bound, total, &ffd_rig_pbffd_of(rig)->options, &pb,
                              &inner))) {
        s = ffd_rig_wrap(err, s, name, ffd_rig_pbffd_of(rig)->controls_auto ? "controls (placed)" : "controls", &inner);
        goto fail;
    }
    double t1 = ffd_now();
    timings.bind = t1 - t0;

    if ((s = ffd_rig_pb_apply_edits(rig, pb, NULL, NULL, err)))
        goto fail;
    if ((s = ffd_pbffd_eval(pb, current, &inner))) {
        s = ffd_rig_wrap(err, s, name, "evaluating", &inner);
        goto fail;
    }
    if (k && (s = solve_constraints(rig, pb, rows, current, reached, residuals, &result, err)))
        goto fail;
    double t2 = ffd_now();
    timings.solve = t2 - t1;

    if (ffd_rig_pbffd_of(rig)->curve_count == 0 && ffd_mesh_normal_count(mesh) > 0) {
        jacobians = ffd_malloc_array(total, 9 * sizeof *jacobians);
        if (!jacobians) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu Jacobians", name, total);
            goto fail;
        }
        if ((s = ffd_pbffd_jacobian(pb, jacobians, &inner))) {
            s = ffd_rig_wrap(err, s, name, "Jacobians", &inner);
            goto fail;
        }
    }
    if ((s = apply_curves(rig, current, n, err)))
        goto fail;
    /* the report's copy of the finest level, before the mesh changes (all or nothing) */
    size_t nc = ffd_pbffd_control_count(pb, 0);
    if (report) {
        report_points = ffd_malloc_array(nc ? nc : 1, 3 * sizeof(double));
        if (!report_points) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the report", name);
            goto fail;
        }
        for (size_t j = 0; j < nc; j++) {
            ffd_ebf ebf;
            if (ffd_pbffd_control(pb, 0, j, &ebf, NULL) == FFD_OK)
                memcpy(report_points + 3 * j, ebf.center, sizeof ebf.center);
        }
        /* the method's details: levels, uncovered vertices, the placement
         * (made before the mesh changes: all or nothing) */
        for (size_t i = 0; i < n; i++)
            uncovered += ffd_pbffd_point_support(pb, i) == 0;
        unsigned long mark;
        cJSON *details = ffd_rig_details_create(&mark);
        cJSON_AddNumberToObject(details, "levels", (double)ffd_pbffd_level_count(pb));
        cJSON_AddNumberToObject(details, "uncovered", (double)uncovered);
        cJSON_AddBoolToObject(details, "placed", ffd_rig_pbffd_of(rig)->controls_auto != 0);
        if (ffd_rig_pbffd_of(rig)->controls_auto) {
            cJSON *p = cJSON_AddObjectToObject(details, "placement");
            cJSON_AddNumberToObject(p, "interior", (double)placement.interior_count);
            cJSON_AddNumberToObject(p, "exterior", (double)placement.exterior_count);
            cJSON_AddBoolToObject(p, "open", placement.open != 0);
            cJSON_AddBoolToObject(p, "fell_back", placement.fell_back != 0);
            cJSON_AddNumberToObject(p, "grown_radii", (double)placement.grown_radii);
        }
        if ((s = ffd_rig_report_set_details(report, details, mark, name, err)))
            goto fail;
        if (ffd_rig_pbffd_of(rig)->controls_auto && placement.note[0] &&
            (s = ffd_rig_report_note(report, name, err, "note: %s", placement.note)))
            goto fail;
    }
    if ((s = ffd_mesh_set_positions(mesh, current, jacobians, &inner))) {
        s = ffd_rig_wrap(err, s, name, "deformed positions", &inner);
        goto fail;
    }
    timings.evaluate = ffd_now() - t2;

    if (report) {
        report->constraint_count = k;
        if (k) {
            report->residuals = residuals;
            report->reached = reached;
            residuals = reached = NULL;
        }
        report->rank = result.rank;
        report->max_residual = result.max_residual;
        report->timings = timings;
        report->outside_count = uncovered;
        report->control_count = nc;
        report->control_points = report_points;
        report->control_label = "PB-FFD control points";
        report_points = NULL;
    }
fail:
    ffd_pbffd_destroy(pb);
    ffd_free(placed);
    ffd_free(bound);
    ffd_free(current);
    ffd_free(jacobians);
    ffd_free(rows);
    ffd_free(reached);
    ffd_free(residuals);
    ffd_free(report_points);
    return s;
}
