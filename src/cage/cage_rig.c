/* cage_rig — applying a cage rig to a mesh: the cage (a file, inline, or
 * "auto"), the mesh bound to its mean value or harmonic coordinates, the
 * cage vertices' moves, then direct manipulation of constrained points
 * (Hsu et al. 1992, eq. 2-7) through the linear map, which for a cage is
 * dense rows over its vertices. Normals are recomputed from the deformed
 * faces (no Jacobian). The mesh changes only at the final
 * ffd_mesh_set_positions, which is all-or-nothing. */
#include "cage/cage_method.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

ffd_status ffd_rig_cage_auto(const double *points, size_t n, double margin,
                             double vertices[3 * CAGE_AUTO_VERTICES],
                             uint32_t triangles[3 * CAGE_AUTO_TRIANGLES], ffd_error *err)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], points[3 * i + a]);
            hi[a] = fmax(hi[a], points[3 * i + a]);
        }
    double d2 = 0;
    for (int a = 0; a < 3; a++)
        d2 += n ? (hi[a] - lo[a]) * (hi[a] - lo[a]) : 0;
    double grow = margin * sqrt(d2);
    for (int a = 0; a < 3; a++)
        if (!n || !(hi[a] - lo[a] + 2 * grow > 0))
            return ffd_fail(err, FFD_ERR_INVALID, "cage \"auto\": the mesh's bounding box is "
                            "flat along axis %d (grow it with \"margin\" > 0)", a);
    /* corner (i, j, k) is vertex 4 i + 2 j + k */
    for (int v = 0; v < CAGE_AUTO_VERTICES; v++)
        for (int a = 0; a < 3; a++)
            vertices[3 * v + a] = (v >> (2 - a) & 1) ? hi[a] + grow : lo[a] - grow;
    /* two triangles per side, outward */
    static const uint32_t tri[3 * CAGE_AUTO_TRIANGLES] = {
        0, 1, 3, 0, 3, 2, /* x = lo */
        4, 6, 7, 4, 7, 5, /* x = hi */
        0, 4, 5, 0, 5, 1, /* y = lo */
        2, 3, 7, 2, 7, 6, /* y = hi */
        0, 2, 6, 0, 6, 4, /* z = lo */
        1, 5, 7, 1, 7, 3, /* z = hi */
    };
    memcpy(triangles, tri, sizeof tri);
    return FFD_OK;
}

ffd_status ffd_rig_cage_create(const ffd_rig *rig, const double *points, size_t n,
                               ffd_cage **out, ffd_error *err)
{
    const ffd_rig_cage *c = ffd_rig_cage_of(rig);
    ffd_error inner = {{0}};
    ffd_status s;
    if (c->cage_auto) {
        double v[3 * CAGE_AUTO_VERTICES];
        uint32_t t[3 * CAGE_AUTO_TRIANGLES];
        if ((s = ffd_rig_cage_auto(points, n, c->margin, v, t, &inner)))
            return ffd_fail(err, s, "%s: %s", rig->name, inner.message);
        s = ffd_cage_create(v, CAGE_AUTO_VERTICES, t, CAGE_AUTO_TRIANGLES, NULL, &c->options,
                            out, &inner);
    } else {
        s = ffd_cage_create(c->vertices, c->vertex_count, c->triangles, c->triangle_count,
                            c->face_of, &c->options, out, &inner);
    }
    if (s)
        return ffd_fail(err, s, "%s: %s%s%s", rig->name, c->file ? c->file : "",
                        c->file ? ": " : "", inner.message);
    return FFD_OK;
}

/* Binding n points: n nv weights of 8 bytes; mean value: ~60 operations per
 * point and triangle; harmonic: the grid ((r+5)^3 nodes at most), its
 * boundary nodes' nearest points (~40 per node and triangle), the sparse
 * factor of a 3D grid Laplacian (nested dissection: ~N^2 / 10 operations,
 * ~30 N^(4/3) entries for N unknowns) and its solve for nv columns. */
ffd_status ffd_rig_cage_charge(const ffd_rig *rig, size_t n, size_t nv, size_t nt,
                               ffd_budget *budget, ffd_error *err)
{
    const ffd_rig_cage *c = ffd_rig_cage_of(rig);
    double dn = (double)n, dv = (double)nv, dt = (double)nt;
    double bytes = 8.0 * dn * dv + 40.0 * dn, work = 60.0 * dn * dt;
    char ns[32], vs[32];
    if (c->options.coordinates == FFD_CAGE_HARMONIC) {
        double r = c->options.resolution ? c->options.resolution : FFD_CAGE_RESOLUTION_DEFAULT;
        double nodes = (r + 5) * (r + 5) * (r + 5), boundary = 6 * 4 * (r + 5) * (r + 5);
        bytes += 6.0 * nodes + 8.0 * 30.0 * pow(nodes, 4.0 / 3.0) + 16.0 * nodes * dv;
        work = 30.0 * dn * dv + 40.0 * boundary * dt + 0.1 * nodes * nodes +
               4.0 * 30.0 * pow(nodes, 4.0 / 3.0) * dv;
        char rs[32];
        return ffd_budget_charge(budget, bytes, work, err,
                                 "resolution: harmonic coordinates on a grid of %s cells a side "
                                 "for %s cage vertices, %s points",
                                 ffd_format_count(r, rs, sizeof rs),
                                 ffd_format_count(dv, vs, sizeof vs),
                                 ffd_format_count(dn, ns, sizeof ns));
    }
    return ffd_budget_charge(budget, bytes, work, err,
                             "cage: mean value coordinates of %s points over %s cage vertices",
                             ffd_format_count(dn, ns, sizeof ns),
                             ffd_format_count(dv, vs, sizeof vs));
}

/* The report's control structure: the deformed cage as points, its edges
 * and its triangles (the control mesh). */
static ffd_status report_cage(const ffd_cage *cage, ffd_rig_report *report, const char *name,
                              ffd_error *err)
{
    size_t nv = ffd_cage_vertex_count(cage), nt = ffd_cage_triangle_count(cage);
    const uint32_t *tri = ffd_cage_triangles(cage);
    report->control_points = ffd_malloc_array(nv, 3 * sizeof(double));
    report->control_edges = ffd_malloc_array(nt, 3 * sizeof(uint32_t)); /* 3 nt / 2 pairs */
    report->control_face_offsets = ffd_malloc_array(nt + 1, sizeof(uint32_t));
    report->control_face_points = ffd_malloc_array(nt, 3 * sizeof(uint32_t));
    report->control_mesh_points = ffd_malloc_array(nv, sizeof(uint32_t));
    if (!report->control_points || !report->control_edges || !report->control_face_offsets ||
        !report->control_face_points || !report->control_mesh_points)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the report", name);
    memcpy(report->control_points, ffd_cage_vertices(cage), nv * 3 * sizeof(double));
    report->control_count = nv;
    /* each edge once: from the half-edge whose start is the lower vertex */
    size_t e = 0;
    for (size_t h = 0; h < 3 * nt; h++) {
        uint32_t a = tri[h], b = tri[h - h % 3 + (h % 3 + 1) % 3];
        if (a < b) {
            report->control_edges[2 * e] = a;
            report->control_edges[2 * e + 1] = b;
            e++;
        }
    }
    report->control_edge_count = e;
    for (size_t t = 0; t <= nt; t++)
        report->control_face_offsets[t] = (uint32_t)(3 * t);
    memcpy(report->control_face_points, tri, nt * 3 * sizeof(uint32_t));
    report->control_face_count = nt;
    for (size_t i = 0; i < nv; i++)
        report->control_mesh_points[i] = (uint32_t)i;
    report->control_mesh_point_count = nv;
    report->control_label = "cage vertices";
    return FFD_OK;
}

ffd_status ffd_rig_apply_cage(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                              ffd_budget *budget, ffd_error *err)
{
    const ffd_rig_cage *c = ffd_rig_cage_of(rig);
    const char *name = rig->name;
    const size_t n = ffd_mesh_vertex_count(mesh), k = rig->constraint_count;
    const double *positions = ffd_mesh_positions(mesh);
    ffd_status s = FFD_OK;
    ffd_error inner = {{0}};
    ffd_cage *cage = NULL;
    ffd_cage_binding *binding = NULL, *pins = NULL;
    double *rest = NULL, *current = NULL, *delta = NULL, *residuals = NULL, *targets = NULL;
    double *deformed = NULL, *cage_v = NULL;
    size_t *rows = NULL;
    ffd_manip_result result = {0};
    ffd_timings timings = {0};
    size_t nv = c->cage_auto ? CAGE_AUTO_VERTICES : c->vertex_count;
    size_t nt = c->cage_auto ? CAGE_AUTO_TRIANGLES : c->triangle_count;

    if ((s = ffd_rig_cage_charge(rig, n + k, nv, nt, budget, &inner))) {
        s = ffd_fail(err, s, "%s: %s", name, inner.message);
        goto fail;
    }
    if (k) {
        rest = ffd_malloc_array(k, 3 * sizeof *rest);
        current = ffd_malloc_array(k, 3 * sizeof *current);
        targets = ffd_malloc_array(k, 3 * sizeof *targets);
        residuals = ffd_malloc_array(k, sizeof *residuals);
        rows = ffd_malloc_array(k, sizeof *rows);
        if (!rest || !current || !targets || !residuals || !rows) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu constraints", name, k);
            goto fail;
        }
        if ((s = ffd_rig_constraint_points(rig, positions, n, rest, err)))
            goto fail;
    }
    double t0 = ffd_now();
    if ((s = ffd_rig_cage_create(rig, positions, n, &cage, err)))
        goto fail;
    if ((s = ffd_cage_bind(cage, positions, n, &binding, &inner))) {
        s = ffd_rig_wrap(err, s, name, "binding the mesh", &inner);
        goto fail;
    }
    if (k && (s = ffd_cage_bind(cage, rest, k, &pins, &inner))) {
        s = ffd_rig_wrap(err, s, name, "binding the constraints", &inner);
        goto fail;
    }
    double t1 = ffd_now();
    timings.bind = t1 - t0;
    for (size_t i = 0; i < c->move_count; i++)
        if ((s = ffd_cage_move(cage, c->moves[i].index, c->moves[i].delta, &inner))) {
            char context[48];
            snprintf(context, sizeof context, "moves[%zu]", i);
            s = ffd_rig_wrap(err, s, name, context, &inner);
            goto fail;
        }
    if (k) {
        ffd_linear_map map;
        ffd_cage_linear_map(cage, pins, &map);
        for (size_t q = 0; q < k; q++) {
            const double *w = ffd_cage_binding_weights(pins, q);
            int zero = 1;
            for (size_t j = 0; j < nv && zero; j++)
                zero = w[j] == 0;
            /* a row of zeros: an outside point the cage cannot move */
            if (zero) {
                const ffd_rig_constraint *con = &rig->constraints[q];
                s = con->kind == FFD_RIG_CONSTRAINT_POINT
                        ? ffd_fail(err, FFD_ERR_INVALID, "%s: constraints[%zu].point: [%.17g, "
                                   "%.17g, %.17g] is outside the cage and \"outside\" is "
                                   "\"fixed\", so it cannot move", name, q, con->point[0],
                                   con->point[1], con->point[2])
                        : ffd_fail(err, FFD_ERR_INVALID, "%s: constraints[%zu].vertex: vertex "
                                   "%u is outside the cage and \"outside\" is \"fixed\", so it "
                                   "cannot move", name, q, con->vertex);
                goto fail;
            }
        }
        if ((s = ffd_rig_charge_manip(&map, k, budget, &inner))) {
            s = ffd_rig_wrap(err, s, name, "constraints", &inner);
            goto fail;
        }
        delta = ffd_calloc(nv, 3 * sizeof *delta);
        cage_v = ffd_malloc_array(nv, 3 * sizeof *cage_v);
        if (!delta || !cage_v) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
            goto fail;
        }
        for (size_t q = 0; q < k; q++) {
            rows[q] = q;
            memcpy(targets + 3 * q, rig->constraints[q].target, 3 * sizeof *targets);
        }
        ffd_manip_options options = {.rcond = rig->rcond};
        if (!(s = ffd_cage_eval(cage, pins, current, &inner)))
            s = ffd_manip_solve(&map, rows, k, current, targets, &options, delta, NULL, &result,
                                &inner);
        if (!s) {
            const double *v = ffd_cage_vertices(cage);
            for (size_t i = 0; i < 3 * nv; i++)
                cage_v[i] = v[i] + delta[i];
            s = ffd_cage_set_vertices(cage, cage_v, &inner);
        }
        /* what the deformation really does at the constrained points */
        if (!s)
            s = ffd_cage_eval(cage, pins, current, &inner);
        if (s) {
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
    if ((s = ffd_cage_eval(cage, binding, deformed, &inner))) {
        s = ffd_rig_wrap(err, s, name, "evaluating", &inner);
        goto fail;
    }
    if (report) {
        if ((s = report_cage(cage, report, name, err)))
            goto fail;
        unsigned long mark;
        cJSON *details = ffd_rig_details_create(&mark);
        const int harmonic = ffd_cage_coordinate_kind(cage) == FFD_CAGE_HARMONIC;
        if (details) {
            cJSON_AddStringToObject(details, "coordinates", harmonic ? "harmonic" : "mean_value");
            cJSON_AddNumberToObject(details, "cage_vertices", (double)nv);
            cJSON_AddNumberToObject(details, "cage_triangles", (double)nt);
        }
        if ((s = ffd_rig_report_set_details(report, details, mark, name, err)))
            goto fail;
    }
    if ((s = ffd_mesh_set_positions(mesh, deformed, NULL, &inner))) {
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
        report->outside_count = n - ffd_cage_binding_inside_count(binding);
        report->timings = timings;
    }
fail:
    ffd_cage_binding_destroy(pins);
    ffd_cage_binding_destroy(binding);
    ffd_cage_destroy(cage);
    ffd_free(rest);
    ffd_free(current);
    ffd_free(targets);
    ffd_free(delta);
    ffd_free(cage_v);
    ffd_free(residuals);
    ffd_free(rows);
    ffd_free(deformed);
    return s;
}
