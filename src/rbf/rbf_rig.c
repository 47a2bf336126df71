/* rbf_rig — applying an RBF rig to a mesh (ffd_method_rbf.apply): the RBF
 * on the rig's control points (rbf_map.c), its control points moved by
 * "deformed_control_points" and "moves", then direct manipulation of the
 * constrained points over the cardinal functions (Hsu et al. 1992, eq. 2-7,
 * through ffd_manip_solve), then the mesh's positions and normals in one
 * ffd_mesh_set_positions (all or nothing). */
#include "rbf/rbf.h"
#include "rbf/rbf_method.h"

#include <cjson/cJSON.h>
#include <string.h>

/* Bytes and operations: the (N+4)^2 factor and its N^3/3 factorisation,
 * then N kernel terms per point. */
static ffd_status charge(const ffd_rig *rig, size_t n, ffd_budget *budget, ffd_error *err)
{
    const double N = (double)ffd_rig_rbf_of(rig)->count + 4;
    char ns[32], cs[32];
    return ffd_budget_charge(budget, 8.0 * N * N + 100.0 * (double)n, N * N * N / 3 + 30.0 * N * (double)n,
                             err, "rbf: %s vertices under %s control points",
                             ffd_format_count((double)n, ns, sizeof ns),
                             ffd_format_count(N - 4, cs, sizeof cs));
}

/* Rest positions of the constrained points (k by 3). */
static ffd_status constraint_points(const ffd_rig *rig, const double *positions, size_t n,
                                    double *points, ffd_error *err)
{
    for (size_t c = 0; c < rig->constraint_count; c++) {
        const ffd_rig_constraint *con = &rig->constraints[c];
        const double *src = con->point;
        if (con->kind == FFD_RIG_CONSTRAINT_VERTEX) {
            if (con->vertex >= n)
                return ffd_fail(err, FFD_ERR_RANGE,
                                "%s: constraints[%zu].vertex: %u out of range (mesh has %zu "
                                "vertices)",
                                rig->name, c, con->vertex, n);
            src = positions + 3 * (size_t)con->vertex;
        }
        memcpy(points + 3 * c, src, 3 * sizeof *points);
    }
    return FFD_OK;
}

ffd_status ffd_rig_apply_rbf(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                             ffd_budget *budget, ffd_error *err)
{
    const ffd_rig_rbf *r = ffd_rig_rbf_of(rig);
    const char *name = rig->name;
    const size_t n = ffd_mesh_vertex_count(mesh), k = rig->constraint_count, N = r->count;
    const double *positions = ffd_mesh_positions(mesh);
    ffd_error inner = {{0}};
    ffd_rbf_morph *rbf = NULL;
    double *moved = NULL, *rest = NULL, *current = NULL, *targets = NULL, *delta = NULL;
    double *residuals = NULL, *deformed = NULL, *jacobians = NULL;
    size_t *rows = NULL;
    ffd_manip_result result = {0};
    ffd_timings timings = {0};
    ffd_status s = charge(rig, n, budget, &inner);
    if (s)
        return ffd_fail(err, s, "%s: %s", name, inner.message);

    double t0 = ffd_now();
    if ((s = ffd_rbf_morph_create(r->control_points, N, &r->options, &rbf, &inner))) {
        s = ffd_rig_wrap(err, s, name, "control_points", &inner);
        goto fail;
    }
    if (!(moved = ffd_rig_rbf_moved(r))) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
        goto fail;
    }
    if ((s = ffd_rbf_morph_set_control_points(rbf, moved, &inner))) {
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
        if ((s = constraint_points(rig, positions, n, rest, err)))
            goto fail;
        for (size_t c = 0; c < k; c++) {
            rows[c] = c;
            memcpy(targets + 3 * c, rig->constraints[c].target, 3 * sizeof *targets);
        }
        ffd_rbf_morph_rows pins = {rbf, rest};
        ffd_linear_map map;
        ffd_rbf_morph_linear_map(&pins, k, &map);
        ffd_manip_options options = {.rcond = rig->rcond};
        if ((s = ffd_rig_charge_manip(&map, k, budget, &inner)) ||
            (s = ffd_rbf_morph_eval(rbf, rest, k, current, &inner)) ||
            (s = ffd_manip_solve(&map, rows, k, current, targets, &options, delta, NULL, &result,
                                 &inner))) {
            s = ffd_rig_wrap(err, s, name, "constraints", &inner);
            goto fail;
        }
        for (size_t i = 0; i < 3 * N; i++)
            moved[i] += delta[i];
        if ((s = ffd_rbf_morph_set_control_points(rbf, moved, &inner)) ||
            (s = ffd_rbf_morph_eval(rbf, rest, k, current, &inner))) {
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
    if ((s = ffd_rbf_morph_eval(rbf, positions, n, deformed, &inner))) {
        s = ffd_rig_wrap(err, s, name, "evaluating", &inner);
        goto fail;
    }
    if (ffd_mesh_normal_count(mesh) > 0) {
        jacobians = ffd_malloc_array(n ? n : 1, 9 * sizeof *jacobians);
        if (!jacobians) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu Jacobians", name, n);
            goto fail;
        }
        if ((s = ffd_rbf_morph_jacobian(rbf, positions, n, jacobians, &inner))) {
            s = ffd_rig_wrap(err, s, name, "Jacobians", &inner);
            goto fail;
        }
    }
    if (report) {
        unsigned long mark;
        cJSON *details = ffd_rig_details_create(&mark);
        if (details) {
            cJSON_AddStringToObject(details, "kernel", ffd_rbf_kernel_name(r->options.kernel));
            cJSON_AddNumberToObject(details, "radius", r->options.radius);
            cJSON_AddNumberToObject(details, "power", r->options.power);
            cJSON_AddNumberToObject(details, "rcond", rbf->rcond);
        }
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
        report->control_label = "RBF control points";
        moved = NULL;
    }
fail:
    ffd_rbf_morph_destroy(rbf);
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
