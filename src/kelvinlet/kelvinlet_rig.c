/* kelvinlet_rig — applying a Kelvinlet rig to a mesh: the brushes
 * (kelvinlet.c), then the constraints of direct manipulation solved over
 * the grabs' displacements, then every vertex evaluated.
 *
 * Superposed brushes are linear in the grabs' displacements d_g:
 * x'(p) = x(p) + sum_g K_g(p) d_g with K_g the calibrated eq. 6, a 3 by 3
 * matrix (ffd_kelvinlet_grab_blocks). The constraints' change of the
 * displacements is the minimum-norm least-squares solution of
 * [K_g(p_c)] delta = targets - current (LAPACK dgelsd), as Hsu et al.'s
 * direct manipulation but over 3 by 3 blocks instead of scalar weights
 * (which is why the method has no ffd_linear_map). */
#include "kelvinlet/kelvinlet_method.h"
#include "math/dense.h"
#include "math/tolerance.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

/* The solve: k constraints at rest positions pts, over the G grabs. */
static ffd_status solve(const ffd_rig *rig, ffd_kelvinlet *kel, const double *pts,
                        ffd_budget *budget, ffd_manip_result *result, double *residuals,
                        double *reached, ffd_error *err)
{
    const size_t k = rig->constraint_count, G = ffd_kelvinlet_grab_count(kel);
    const size_t rows = 3 * k, cols = 3 * G, ld = rows > cols ? rows : cols;
    ffd_kelvinlet_options o;
    ffd_kelvinlet_get_options(kel, &o);
    if (o.combine != FFD_KELVINLET_SUPERPOSE)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: constraints: need \"combine\": \"superpose\" (a sequence is not "
                        "linear in the grabs' displacements)",
                        rig->name);
    if (G == 0)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: constraints: the rig has no grab brush to move (constraints are "
                        "met by the grabs' displacements)",
                        rig->name);
    char ks[32], gs[32];
    ffd_error inner = {{0}};
    ffd_status st = ffd_budget_charge(budget, 8.0 * (double)(rows * cols + ld * 2 + k * G * 9),
                                      (double)rows * cols * (cols + 60.0), &inner,
                                      "constraints: %s constraints over %s grab brushes (a dense "
                                      "least-squares solve)",
                                      ffd_format_count((double)k, ks, sizeof ks),
                                      ffd_format_count((double)G, gs, sizeof gs));
    if (st)
        return ffd_fail(err, st, "%s: %s", rig->name, inner.message);
    double *blocks = ffd_malloc_array(k * G, 9 * sizeof *blocks); /* k, G >= 1 here */
    double *A = ffd_malloc_array(rows * cols, sizeof *A);
    double *B = ffd_calloc(ld ? ld : 1, sizeof *B);
    double *current = ffd_malloc_array(k, 3 * sizeof *current);
    if (!blocks || !A || !B || !current) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "%s: constraints: out of memory", rig->name);
        goto done;
    }
    if ((st = ffd_kelvinlet_eval(kel, pts, k, current, err)) ||
        (st = ffd_kelvinlet_grab_blocks(kel, pts, k, blocks, err)))
        goto done;
    /* A (column-major): row 3c + a, column 3g + b is block (c, g)'s entry (a, b) */
    for (size_t c = 0; c < k; c++)
        for (size_t g = 0; g < G; g++)
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                    A[(3 * g + b) * rows + 3 * c + a] = blocks[9 * (c * G + g) + 3 * a + b];
    for (size_t c = 0; c < k; c++)
        for (int a = 0; a < 3; a++)
            B[3 * c + a] = rig->constraints[c].target[a] - current[3 * c + a];
    size_t rank = 0;
    if ((st = ffd_dense_lstsq(rows, cols, 1, A, B, rig->rcond > 0 ? rig->rcond : FFD_TOL_RCOND,
                              &rank, &inner))) {
        st = ffd_fail(err, st, "%s: constraints: %s", rig->name, inner.message);
        goto done;
    }
    size_t g = 0;
    for (size_t j = 0; j < ffd_kelvinlet_brush_count(kel); j++) {
        ffd_kelvinlet_brush br = *ffd_kelvinlet_brush_at(kel, j);
        if (br.type != FFD_KELVINLET_GRAB)
            continue;
        for (int b = 0; b < 3; b++)
            br.displacement[b] += B[3 * g + b];
        g++;
        if ((st = ffd_kelvinlet_set_brush(kel, j, &br, &inner))) {
            st = ffd_fail(err, st, "%s: constraints: %s", rig->name, inner.message);
            goto done;
        }
    }
    if ((st = ffd_kelvinlet_eval(kel, pts, k, current, err)))
        goto done;
    double worst = 0;
    for (size_t c = 0; c < k; c++) {
        double d2 = 0;
        for (int a = 0; a < 3; a++) {
            double d = current[3 * c + a] - rig->constraints[c].target[a];
            d2 += d * d;
        }
        if (residuals)
            residuals[c] = sqrt(d2);
        worst = fmax(worst, sqrt(d2));
    }
    if (reached)
        memcpy(reached, current, 3 * k * sizeof *current);
    result->rank = rank;
    result->variables_used = cols;
    result->max_residual = worst;
done:
    ffd_free(blocks);
    ffd_free(A);
    ffd_free(B);
    ffd_free(current);
    return st;
}

ffd_status ffd_kelvinlet_from_rig(const ffd_rig *rig, const double *points, size_t n,
                                  ffd_budget *budget, ffd_kelvinlet **out,
                                  ffd_manip_result *result, double *residuals, double *reached,
                                  ffd_error *err)
{
    const ffd_rig_kelvinlet *kr = ffd_rig_kelvinlet_of(rig);
    ffd_manip_result none = {0};
    ffd_error inner = {{0}};
    ffd_kelvinlet *kel = NULL;
    double *pts = NULL;
    *out = NULL;
    if (result)
        *result = none;
    ffd_status st = ffd_kelvinlet_create(kr->brushes, kr->brush_count, &kr->options, &kel, &inner);
    if (st)
        return ffd_fail(err, st, "%s: %s", rig->name, inner.message);
    const size_t k = rig->constraint_count;
    if (k) {
        pts = ffd_malloc_array(k, 3 * sizeof *pts);
        if (!pts)
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu constraints", rig->name,
                          k);
        if (!st)
            st = ffd_rig_constraint_points(rig, points, n, pts, err);
        if (!st)
            st = solve(rig, kel, pts, budget, result ? result : &none, residuals, reached, err);
    }
    ffd_free(pts);
    if (st) {
        ffd_kelvinlet_destroy(kel);
        return st;
    }
    *out = kel;
    return FFD_OK;
}

/* Evaluating n points under G brushes: ~60 operations per point and brush
 * (times the sub-steps of a sequence), positions and Jacobians ~100 bytes. */
static ffd_status charge_eval(const ffd_rig *rig, size_t n, ffd_budget *budget, ffd_error *err)
{
    const ffd_rig_kelvinlet *kr = ffd_rig_kelvinlet_of(rig);
    double steps = kr->options.steps ? kr->options.steps : 1;
    double scales = 1.0 + kr->options.multiscale;
    double work = 60.0 * scales * steps * (double)kr->brush_count * (double)n;
    char ns[32], bs[32];
    return ffd_budget_charge(budget, 100.0 * (double)n, work, err,
                             "brushes: %s vertices under %s brushes",
                             ffd_format_count((double)n, ns, sizeof ns),
                             ffd_format_count((double)kr->brush_count, bs, sizeof bs));
}

ffd_status ffd_rig_apply_kelvinlet(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                                   ffd_budget *budget, ffd_error *err)
{
    const char *name = rig->name;
    const size_t n = ffd_mesh_vertex_count(mesh), k = rig->constraint_count;
    const double *positions = ffd_mesh_positions(mesh);
    ffd_kelvinlet *kel = NULL;
    double *deformed = NULL, *jacobians = NULL, *residuals = NULL, *reached = NULL;
    double *handles = NULL;
    ffd_manip_result result = {0};
    ffd_timings timings = {0};
    ffd_error inner = {{0}};
    ffd_status st;
    if ((st = charge_eval(rig, n, budget, &inner))) {
        st = ffd_fail(err, st, "%s: %s", name, inner.message);
        goto fail;
    }
    if (k) {
        residuals = ffd_malloc_array(k, sizeof *residuals);
        reached = ffd_malloc_array(k, 3 * sizeof *reached);
        if (!residuals || !reached) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu constraints", name, k);
            goto fail;
        }
    }
    double t0 = ffd_now();
    if ((st = ffd_kelvinlet_from_rig(rig, positions, n, budget, &kel, &result, residuals, reached,
                                     err)))
        goto fail;
    double t1 = ffd_now();
    timings.solve = t1 - t0;
    deformed = ffd_malloc_array(n ? n : 1, 3 * sizeof *deformed);
    if (!deformed) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu vertices", name, n);
        goto fail;
    }
    if ((st = ffd_kelvinlet_eval(kel, positions, n, deformed, &inner))) {
        st = ffd_rig_wrap(err, st, name, "evaluating", &inner);
        goto fail;
    }
    if (ffd_mesh_normal_count(mesh) > 0) {
        jacobians = ffd_malloc_array(n ? n : 1, 9 * sizeof *jacobians);
        if (!jacobians) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu Jacobians", name, n);
            goto fail;
        }
        if ((st = ffd_kelvinlet_jacobian(kel, positions, n, jacobians, &inner))) {
            st = ffd_rig_wrap(err, st, name, "Jacobians", &inner);
            goto fail;
        }
    }
    const size_t G = ffd_kelvinlet_grab_count(kel), count = ffd_kelvinlet_brush_count(kel);
    if (report) {
        handles = ffd_malloc_array(G ? G : 1, 3 * sizeof *handles);
        if (!handles) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the report", name);
            goto fail;
        }
        size_t g = 0;
        for (size_t j = 0; j < count; j++) {
            const ffd_kelvinlet_brush *br = ffd_kelvinlet_brush_at(kel, j);
            if (br->type != FFD_KELVINLET_GRAB)
                continue;
            for (int a = 0; a < 3; a++)
                handles[3 * g + a] = br->center[a] + br->displacement[a];
            g++;
        }
        unsigned long mark;
        cJSON *details = ffd_rig_details_create(&mark);
        ffd_kelvinlet_options o;
        ffd_kelvinlet_get_options(kel, &o);
        if (details) {
            cJSON_AddNumberToObject(details, "brushes", (double)count);
            cJSON_AddNumberToObject(details, "grabs", (double)G);
            cJSON_AddStringToObject(details, "combine", ffd_kelvinlet_combine_names[o.combine]);
        }
        if ((st = ffd_rig_report_set_details(report, details, mark, name, err)))
            goto fail;
    }
    double t2 = ffd_now();
    if ((st = ffd_mesh_set_positions(mesh, deformed, jacobians, &inner))) {
        st = ffd_rig_wrap(err, st, name, "deformed positions", &inner);
        goto fail;
    }
    timings.evaluate = ffd_now() - t2 + (t2 - t1);
    if (report) {
        report->constraint_count = k;
        report->residuals = residuals;
        report->reached = reached;
        residuals = reached = NULL;
        report->rank = result.rank;
        report->max_residual = result.max_residual;
        report->outside_count = 0;
        report->timings = timings;
        report->control_count = G;
        report->control_points = handles;
        report->control_label = "Kelvinlet grab handles";
        handles = NULL;
    }
fail:
    ffd_kelvinlet_destroy(kel);
    ffd_free(deformed);
    ffd_free(jacobians);
    ffd_free(residuals);
    ffd_free(reached);
    ffd_free(handles);
    return st;
}
