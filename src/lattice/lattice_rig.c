/* lattice_rig — applying a lattice rig to a mesh: lattice FFD (Sederberg-Parry
 * 1986; Hsu et al. 1992) with moves on control points, then direct
 * manipulation of constrained points (Hsu et al. 1992, eq. 2-7) through the
 * linear-deformer interface.
 *
 * The constrained points are bound in a small binding of their own, so that
 * the solve never touches the mesh-sized binding. The mesh is changed only by
 * the final ffd_mesh_set_positions, which is all-or-nothing. */
#include "lattice/lattice_method.h"
#include "lattice/lattice.h"
#include "mesh/mesh_quality.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

/* A constrained point the deformation cannot move is an error, not a residual:
 * point constraints must lie in the box; vertices too unless the outside
 * policy moves outside points. */
ffd_status ffd_rig_lattice_shape(const ffd_rig *rig, const double *points, size_t n,
                                 ffd_lattice_shape *shape, ffd_error *err)
{
    *shape = rig->shape;
    if (rig->shape.coordinates == FFD_COORDINATES_CARTESIAN || !rig->frame_auto)
        return FFD_OK;
    return ffd_lattice_frame_fit(rig->shape.coordinates, points, n, rig->margin, &shape->frame,
                                 err);
}

static ffd_status check_inside(const ffd_rig *rig, const ffd_lattice_binding *binding,
                               ffd_error *err)
{
    for (size_t c = 0; c < rig->constraint_count; c++) {
        const ffd_rig_constraint *con = &rig->constraints[c];
        double stu[3];
        if (ffd_lattice_binding_params(binding, c, stu))
            continue;
        if (con->kind == FFD_RIG_CONSTRAINT_POINT)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "%s: constraints[%zu].point: [%.17g, %.17g, %.17g] is outside the "
                            "lattice box",
                            rig->name, c, con->point[0], con->point[1], con->point[2]);
        if (rig->outside == FFD_OUTSIDE_FIXED)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "%s: constraints[%zu].vertex: vertex %u is outside the lattice box "
                            "and \"outside\" is \"fixed\", so it cannot move",
                            rig->name, c, con->vertex);
    }
    return FFD_OK;
}

/* Binding and evaluating n points under a lattice: each point's basis has
 * 4^3 terms (B-spline) or l m n (Bernstein); positions, parameters and
 * Jacobians are ~200 bytes a point. */
static ffd_status charge_lattice(const ffd_rig *rig, size_t n, ffd_budget *budget, ffd_error *err)
{
    const uint32_t *r = rig->resolution;
    double controls = (double)r[0] * r[1] * r[2];
    double terms = rig->basis == FFD_BASIS_BERNSTEIN ? controls : 64.0;
    double bytes = 200.0 * (double)n + 24.0 * controls;
    double work = 30.0 * terms * (double)n * (1 + (rig->constraint_count > 0)) + 10 * controls;
    char ns[32], cs[32];
    return ffd_budget_charge(budget, bytes, work, err,
                             "resolution: %s vertices under %s control points (%s basis terms "
                             "each)",
                             ffd_format_count((double)n, ns, sizeof ns),
                             ffd_format_count(controls, cs, sizeof cs),
                             rig->basis == FFD_BASIS_BERNSTEIN ? "l m n" : "64");
}

/* ---- step limiting ("limit_step", docs/rig.md) ---- */

#define STEP_HALVINGS 20 /* the fraction found is within 2^-20 of the largest that passes */

/* Whether the lattice as it is now passes: the map folds nowhere (the fold
 * check) and no 3D cell of the mesh inverts against the rest positions. */
static ffd_status step_passes(const ffd_lattice *lattice, const ffd_lattice_binding *binding,
                              const ffd_mesh *mesh, double *x, int *ok, ffd_error *err)
{
    ffd_fold_report f;
    ffd_status s = ffd_lattice_fold_check(lattice, &f, err);
    if (s)
        return s;
    *ok = f.folded == 0;
    ffd_free(f.cell_ids);
    if (*ok && ffd_mesh_cell_count(mesh)) {
        if ((s = ffd_lattice_eval(lattice, binding, x, err)))
            return s;
        *ok = ffd_mesh_inverted_cells(mesh, x, ffd_mesh_positions(mesh)) == 0;
    }
    return FFD_OK;
}

/* The controls at start + t delta (nc by 3 each). */
static ffd_status step_to(ffd_lattice *lattice, const double *start, const double *delta, size_t nc,
                          double t, double *work, ffd_error *err)
{
    for (size_t i = 0; i < 3 * nc; i++)
        work[i] = start[i] + t * delta[i];
    return ffd_lattice_set_control_points(lattice, work, err);
}

/* After the full step (start + delta) was applied: when it fails the check
 * and the state before it passes, bisects on the fraction t in [0, 1]
 * (STEP_HALVINGS halvings) and leaves the lattice at the largest t found
 * to pass. *fraction: the t applied (1 when the full step passes, or when
 * the state before the step fails too: then limiting cannot help, *hopeless). */
static ffd_status limit_step(ffd_lattice *lattice, const ffd_lattice_binding *binding,
                             const ffd_mesh *mesh, const double *start, const double *delta,
                             double *fraction, int *hopeless, ffd_error *err)
{
    size_t nc = ffd_lattice_control_count(lattice), n = ffd_mesh_vertex_count(mesh);
    double *full = ffd_malloc_array(nc, 3 * sizeof(double));
    double *work = ffd_malloc_array(nc, 3 * sizeof(double));
    double *x = ffd_malloc_array(n ? n : 1, 3 * sizeof(double));
    ffd_status s = FFD_OK;
    *fraction = 1.0;
    *hopeless = 0;
    if (!full || !work || !x) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "limit_step: out of memory");
        goto done;
    }
    memcpy(full, ffd_lattice_control_points(lattice), nc * 3 * sizeof(double));
    int ok;
    if ((s = step_passes(lattice, binding, mesh, x, &ok, err)) || ok)
        goto done;
    if ((s = step_to(lattice, start, delta, nc, 0.0, work, err)) ||
        (s = step_passes(lattice, binding, mesh, x, &ok, err)))
        goto done;
    if (!ok) { /* folded before the solve: keep the full step */
        *hopeless = 1;
        s = ffd_lattice_set_control_points(lattice, full, err);
        goto done;
    }
    double lo = 0.0, hi = 1.0;
    for (int h = 0; h < STEP_HALVINGS; h++) {
        double mid = 0.5 * (lo + hi);
        if ((s = step_to(lattice, start, delta, nc, mid, work, err)) ||
            (s = step_passes(lattice, binding, mesh, x, &ok, err)))
            goto done;
        if (ok)
            lo = mid;
        else
            hi = mid;
    }
    *fraction = lo;
    s = step_to(lattice, start, delta, nc, lo, work, err);
done:
    ffd_free(full);
    ffd_free(work);
    ffd_free(x);
    return s;
}

ffd_status ffd_rig_apply_lattice(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                                 ffd_budget *budget, ffd_error *err)
{
    const char *name = rig->name;
    const size_t n = ffd_mesh_vertex_count(mesh);
    const size_t k = rig->constraint_count;
    const double *positions = ffd_mesh_positions(mesh);
    ffd_status s = FFD_OK;
    ffd_error inner = {{0}};
    ffd_lattice *lattice = NULL;
    ffd_lattice_binding *binding = NULL, *pins = NULL;
    double *rest = NULL, *current = NULL, *delta = NULL, *residuals = NULL;
    double *deformed = NULL, *jacobians = NULL, *report_points = NULL;
    size_t *rows = NULL;
    double *start = NULL, step_fraction = 1.0;
    int hopeless = 0;
    ffd_manip_result result = {0};
    ffd_timings timings = {0};

    if (ffd_rig_lattice_of(rig)->child_count) /* nested lattices: lattice_nested_rig.c */
        return ffd_rig_apply_lattice_nested(rig, mesh, report, budget, err);
    ffd_error inner0 = {{0}};
    if ((s = charge_lattice(rig, n, budget, &inner0))) {
        s = ffd_fail(err, s, "%s: %s", name, inner0.message);
        goto fail;
    }
    if (k) {
        rest = ffd_malloc_array(k, 3 * sizeof *rest);
        current = ffd_malloc_array(k, 3 * sizeof *current);
        residuals = ffd_malloc_array(k, sizeof *residuals);
        rows = ffd_malloc_array(k, sizeof *rows);
        if (!rest || !current || !residuals || !rows) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu constraints", name, k);
            goto fail;
        }
        if ((s = ffd_rig_constraint_points(rig, positions, n, rest, err)))
            goto fail;
    }

    ffd_box box = rig->box;
    if (rig->box_auto && (s = ffd_box_fit(positions, n, rig->margin, &box, &inner))) {
        s = ffd_rig_wrap(err, s, name, "box \"auto\"", &inner);
        goto fail;
    }
    ffd_lattice_shape shape;
    if ((s = ffd_rig_lattice_shape(rig, positions, n, &shape, &inner))) {
        s = ffd_rig_wrap(err, s, name, "frame \"auto\"", &inner);
        goto fail;
    }
    if ((s = ffd_lattice_create_shaped(rig->basis, &box, rig->resolution, &shape, &lattice,
                                       &inner))) {
        s = ffd_rig_wrap(err, s, name,
                         shape.coordinates ? "lattice" : rig->box_auto ? "box \"auto\"" : "box",
                         &inner);
        goto fail;
    }

    double t0 = ffd_now();
    if ((s = ffd_lattice_bind_rig(lattice, positions, n, rig, &binding, &inner))) {
        s = ffd_rig_wrap(err, s, name, "binding the mesh", &inner);
        goto fail;
    }
    if (k && (s = ffd_lattice_bind_rig(lattice, rest, k, rig, &pins, &inner))) {
        s = ffd_rig_wrap(err, s, name, "binding the constraints", &inner);
        goto fail;
    }
    double t1 = ffd_now();
    timings.bind = t1 - t0;

    for (size_t i = 0; i < rig->move_count; i++) {
        if ((s = ffd_lattice_move(lattice, rig->moves[i].index, rig->moves[i].delta, &inner))) {
            char context[48];
            snprintf(context, sizeof context, "moves[%zu]", i);
            s = ffd_rig_wrap(err, s, name, context, &inner);
            goto fail;
        }
    }

    if (k) {
        if ((s = check_inside(rig, pins, err)))
            goto fail;
        if ((s = ffd_lattice_eval(lattice, pins, current, &inner))) {
            s = ffd_rig_wrap(err, s, name, "constraints", &inner);
            goto fail;
        }
        ffd_linear_map map;
        ffd_lattice_linear_map(lattice, pins, &map);
        if ((s = ffd_rig_charge_manip(&map, k, budget, &inner))) {
            s = ffd_rig_wrap(err, s, name, "constraints", &inner);
            goto fail;
        }
        if (map.variable_count != ffd_lattice_control_count(lattice)) {
            s = ffd_fail(err, FFD_ERR_UNSUPPORTED,
                         "%s: constraints: the lattice exposes %zu free variables, expected %zu",
                         name, map.variable_count, ffd_lattice_control_count(lattice));
            goto fail;
        }
        delta = ffd_calloc(map.variable_count, 3 * sizeof *delta);
        if (!delta) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
            goto fail;
        }
        double *targets = ffd_malloc_array(k, 3 * sizeof *targets);
        if (!targets) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
            goto fail;
        }
        for (size_t c = 0; c < k; c++) {
            rows[c] = c;
            memcpy(targets + 3 * c, rig->constraints[c].target, 3 * sizeof *targets);
        }
        ffd_manip_options options = {.rcond = rig->rcond};
        s = ffd_manip_solve(&map, rows, k, current, targets, &options, delta, NULL, &result,
                            &inner);
        if (!s && rig->limit_step) {
            size_t nc0 = ffd_lattice_control_count(lattice);
            start = ffd_malloc_array(nc0, 3 * sizeof *start);
            if (!start)
                s = ffd_fail(&inner, FFD_ERR_NOMEM, "out of memory");
            else
                memcpy(start, ffd_lattice_control_points(lattice), nc0 * 3 * sizeof *start);
        }
        if (!s && (s = ffd_lattice_add(lattice, delta, &inner)) == FFD_OK && rig->limit_step)
            s = limit_step(lattice, binding, mesh, start, delta, &step_fraction, &hopeless,
                           &inner);
        if (!s) {
            /* Report what the deformation really does at the constrained points. */
            s = ffd_lattice_eval(lattice, pins, current, &inner);
        }
        if (!s)
            result.max_residual = ffd_rig_residuals(k, current, targets, residuals);
        ffd_free(targets);
        if (s) {
            s = ffd_rig_wrap(err, s, name, "constraints", &inner);
            goto fail;
        }
    }
    double t2 = ffd_now();
    timings.solve = t2 - t1;

    deformed = ffd_malloc_array(n, 3 * sizeof *deformed);
    if (!deformed && n) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu vertices", name, n);
        goto fail;
    }
    if ((s = ffd_lattice_eval(lattice, binding, deformed, &inner))) {
        s = ffd_rig_wrap(err, s, name, "evaluating", &inner);
        goto fail;
    }
    if (ffd_mesh_normal_count(mesh) > 0) {
        jacobians = ffd_malloc_array(n, 9 * sizeof *jacobians);
        if (!jacobians && n) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu Jacobians", name, n);
            goto fail;
        }
        if ((s = ffd_lattice_jacobian(lattice, binding, jacobians, &inner))) {
            s = ffd_rig_wrap(err, s, name, "Jacobians", &inner);
            goto fail;
        }
    }
    size_t outside_count = n - ffd_lattice_binding_inside_count(binding);
    /* the report's copy of the lattice, before the mesh changes (all or nothing) */
    size_t nc = ffd_lattice_control_count(lattice);
    if (report) {
        report_points = ffd_malloc_array(nc, 3 * sizeof(double));
        if (!report_points) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the report", name);
            goto fail;
        }
        memcpy(report_points, ffd_lattice_control_points(lattice), nc * 3 * sizeof(double));
        /* the lattice's details: none beyond the shared part (its resolution
         * is a field), but the step fraction with "limit_step" */
        unsigned long mark;
        cJSON *details = ffd_rig_details_create(&mark);
        if (details && rig->limit_step && k)
            cJSON_AddNumberToObject(details, "step_fraction", step_fraction);
        if ((s = ffd_rig_report_set_details(report, details, mark, name, err)))
            goto fail;
        if (rig->limit_step && k && step_fraction < 1.0 &&
            (s = ffd_rig_report_note(report, name, err,
                                     "note: limit_step: the constraints' step shrunk to %.6g of "
                                     "the full step (the full step folds the lattice or inverts "
                                     "a cell)",
                                     step_fraction)))
            goto fail;
        if (hopeless &&
            (s = ffd_rig_report_note(report, name, err,
                                     "warning: limit_step: the lattice folds (or a cell is "
                                     "inverted) before the constraints' step: the full step "
                                     "was applied")))
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
        report->outside_count = outside_count;
        report->timings = timings;
        report->control_count = nc;
        report->control_points = report_points;
        report_points = NULL;
        ffd_lattice_resolution(lattice, report->resolution);
    }
fail:
    ffd_free(start);
    ffd_lattice_binding_destroy(pins);
    ffd_lattice_binding_destroy(binding);
    ffd_lattice_destroy(lattice);
    ffd_free(rest);
    ffd_free(current);
    ffd_free(delta);
    ffd_free(residuals);
    ffd_free(rows);
    ffd_free(deformed);
    ffd_free(jacobians);
    ffd_free(report_points);
    return s;
}
