/* rig — applying a rig to a mesh: lattice FFD (Sederberg-Parry 1986; Hsu et al. 1992)
 * with moves on control points, then direct manipulation of constrained points
 * (Hsu et al. 1992, eq. 2-7) through the linear-deformer interface.
 *
 * The constrained points are bound in a small binding of their own, so that
 * the solve never touches the mesh-sized binding. The mesh is changed only by
 * the final ffd_mesh_set_positions, which is all-or-nothing. */
#include "rig/rig.h"
#include "deformer/method.h"

#include <cjson/cJSON.h>

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

void ffd_rig_report_free(ffd_rig_report *report)
{
    if (!report)
        return;
    ffd_free(report->residuals);
    ffd_free(report->reached);
    ffd_free(report->control_points);
    ffd_free(report->control_edges);
    ffd_free(report->control_face_offsets);
    ffd_free(report->control_face_points);
    ffd_free(report->control_mesh_points);
    ffd_free(report->notes);
    ffd_free(report->details);
    memset(report, 0, sizeof *report);
}

/* ======================================================================
 * The method's part of the report: details (JSON) and notes
 * ====================================================================== */

cJSON *ffd_rig_details_create(unsigned long *mark)
{
    *mark = ffd_json_alloc_failures();
    return cJSON_CreateObject();
}

ffd_status ffd_rig_report_set_details(ffd_rig_report *report, cJSON *details, unsigned long mark,
                                      const char *name, ffd_error *err)
{
    /* a failed cJSON allocation leaves the object short of a key: the
     * failure count (ffd_json_alloc_failures) tells */
    char *text = details && ffd_json_alloc_failures() == mark ? cJSON_PrintUnformatted(details)
                                                               : NULL;
    cJSON_Delete(details);
    char *copy = text && ffd_json_alloc_failures() == mark ? ffd_strdup(text) : NULL;
    cJSON_free(text);
    if (!copy)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the report", name);
    ffd_free(report->details);
    report->details = copy;
    return FFD_OK;
}

ffd_status ffd_rig_report_note(ffd_rig_report *report, const char *name, ffd_error *err,
                               const char *fmt, ...)
{
    char line[1024];
    va_list ap;
    va_start(ap, fmt);
    int len = vsnprintf(line, sizeof line - 1, fmt, ap);
    va_end(ap);
    if (len < 0)
        len = 0;
    if ((size_t)len > sizeof line - 2)
        len = (int)(sizeof line - 2);
    line[len++] = '\n';
    line[len] = 0;
    size_t old = report->notes ? strlen(report->notes) : 0;
    char *notes = ffd_realloc(report->notes, old + (size_t)len + 1);
    if (!notes)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the report", name);
    memcpy(notes + old, line, (size_t)len + 1);
    report->notes = notes;
    return FFD_OK;
}

/* Rodrigues: v rotated by angle about the unit axis k. */
void ffd_rig_rotate(const double k[3], double angle, const double v[3], double out[3])
{
    double c = cos(angle), s = sin(angle), kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    double cross[3] = {k[1] * v[2] - k[2] * v[1], k[2] * v[0] - k[0] * v[2],
                       k[0] * v[1] - k[1] * v[0]};
    for (int a = 0; a < 3; a++)
        out[a] = v[a] * c + cross[a] * s + k[a] * kv * (1 - c);
}

/* Prefixes a message from a lower layer with the rig's name and a context. */
ffd_status ffd_rig_wrap(ffd_error *err, ffd_status status, const char *name, const char *context,
                        const ffd_error *inner)
{
    return ffd_fail(err, status, "%s: %s: %s", name, context, inner->message);
}

double ffd_rig_residuals(size_t k, const double *reached, const double *targets,
                         double *residuals)
{
    double max = 0;
    for (size_t c = 0; c < k; c++) {
        double d0 = reached[3 * c] - targets[3 * c];
        double d1 = reached[3 * c + 1] - targets[3 * c + 1];
        double d2 = reached[3 * c + 2] - targets[3 * c + 2];
        residuals[c] = sqrt(d0 * d0 + d1 * d1 + d2 * d2);
        if (residuals[c] > max)
            max = residuals[c];
    }
    return max;
}

/* Rest positions of the constrained points (k by 3). Vertex ids are checked here. */
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

/* A constrained point the deformation cannot move is an error, not a residual:
 * point constraints must lie in the box; vertices too unless the outside
 * policy moves outside points. */
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

/* Dense least squares (dgelsd): k rows by at most k * max_row_nnz of the
 * variables; the SVD's workspace about doubles the matrix; its flops
 * ~ 4 k v min(k, v), counted at 1/10 as LAPACK (ffd_limits). */
ffd_status ffd_rig_charge_manip(const ffd_linear_map *map, size_t k, ffd_budget *budget,
                                ffd_error *err)
{
    double kk = (double)k, v = (double)map->variable_count;
    double reach = kk * (double)(map->max_row_nnz ? map->max_row_nnz : 1);
    if (reach < v)
        v = reach;
    double bytes = 2.0 * 8.0 * kk * v, work = 0.4 * kk * v * (kk < v ? kk : v);
    char ks[32], vs[32];
    return ffd_budget_charge(budget, bytes, work, err,
                             "direct manipulation of %s constraints over %s variables",
                             ffd_format_count(kk, ks, sizeof ks), ffd_format_count(v, vs, sizeof vs));
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

ffd_status ffd_rig_apply(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                         ffd_error *err)
{
    return ffd_rig_apply_limited(rig, mesh, NULL, report, err);
}

ffd_status ffd_rig_apply_limited(const ffd_rig *rig, ffd_mesh *mesh, const ffd_limits *limits,
                                 ffd_rig_report *report, ffd_error *err)
{
    if (report)
        memset(report, 0, sizeof *report);
    if (!rig || !mesh)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_rig_apply: rig and mesh must not be NULL");
    ffd_budget budget;
    ffd_budget_init(&budget, limits);
    const ffd_method *method = ffd_method_of_rig(rig);
    if (!method)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: unknown deformer", rig->name);
    ffd_status s = method->apply(rig, mesh, report, &budget, err);
    if (report && s != FFD_OK)
        ffd_rig_report_free(report); /* nothing half-filled on failure */
    else if (report)
        report->method = method->name;
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
    ffd_manip_result result = {0};
    ffd_timings timings = {0};

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
        if ((s = constraint_points(rig, positions, n, rest, err)))
            goto fail;
    }

    ffd_box box = rig->box;
    if (rig->box_auto && (s = ffd_box_fit(positions, n, rig->margin, &box, &inner))) {
        s = ffd_rig_wrap(err, s, name, "box \"auto\"", &inner);
        goto fail;
    }
    if ((s = ffd_lattice_create(rig->basis, &box, rig->resolution, &lattice, &inner))) {
        s = ffd_rig_wrap(err, s, name, rig->box_auto ? "box \"auto\"" : "box", &inner);
        goto fail;
    }

    double t0 = ffd_now();
    if ((s = ffd_lattice_bind(lattice, positions, n, rig->outside, &binding, &inner))) {
        s = ffd_rig_wrap(err, s, name, "binding the mesh", &inner);
        goto fail;
    }
    if (k && (s = ffd_lattice_bind(lattice, rest, k, rig->outside, &pins, &inner))) {
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
        ffd_manip_options options = {rig->rcond};
        s = ffd_manip_solve(&map, rows, k, current, targets, &options, delta, NULL, &result,
                            &inner);
        if (!s && (s = ffd_lattice_add(lattice, delta, &inner)) == FFD_OK) {
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
         * is a field) */
        unsigned long mark;
        cJSON *details = ffd_rig_details_create(&mark);
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
        report->outside_count = outside_count;
        report->timings = timings;
        report->control_count = nc;
        report->control_points = report_points;
        report_points = NULL;
        ffd_lattice_resolution(lattice, report->resolution);
    }
fail:
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

/* "v" lines for the report's control points; returns the length written. */
static size_t obj_vertices(const ffd_rig_report *report, char *buf, size_t cap, size_t len)
{
    for (size_t i = 0; i < report->control_count; i++) {
        const double *p = report->control_points + 3 * i;
        len += (size_t)snprintf(buf + len, cap - len, "v %.17g %.17g %.17g\n", p[0], p[1], p[2]);
    }
    return len;
}

/* Explicit control edges: every control point and one line per edge. */
static ffd_status write_control_edges(const ffd_rig_report *report, const char *path,
                                      ffd_error *err)
{
    size_t cap = 128 + report->control_count * 80 + report->control_edge_count * 26;
    char *buf = ffd_malloc(cap);
    if (!buf)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", path);
    size_t len = (size_t)snprintf(buf, cap, "# ffdkit %s: %zu control points, %zu edges\n",
                                  report->control_label ? report->control_label : "controls",
                                  report->control_count, report->control_edge_count);
    len = obj_vertices(report, buf, cap, len);
    for (size_t e = 0; e < report->control_edge_count; e++)
        len += (size_t)snprintf(buf + len, cap - len, "l %u %u\n",
                                report->control_edges[2 * e] + 1,
                                report->control_edges[2 * e + 1] + 1);
    ffd_status s = ffd_write_file_atomic(path, buf, len, err);
    ffd_free(buf);
    return s;
}

ffd_status ffd_rig_report_write_proxy(const ffd_rig_report *report, const char *path,
                                      ffd_error *err)
{
    if (!report || !report->control_points || !report->control_face_offsets ||
        !report->control_face_points || !report->control_mesh_points)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: only a T-spline rig has a proxy", path);
    /* the manifold proxy: one point per sheet of each control point on it
     * (ffd_tsv_proxy.face_points), in the order of their control ids */
    size_t nf = report->control_face_count, np = report->control_mesh_point_count;
    size_t corners = report->control_face_offsets[nf];
    size_t cap = 160 + np * 80 + corners * 12 + nf * 4;
    char *buf = ffd_malloc(cap);
    if (!buf)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", path);
    size_t len = (size_t)snprintf(buf, cap,
                                  "# ffdkit T-spline proxy: %zu points, %zu faces "
                                  "(points in order of their control ids, once per sheet)\n",
                                  np, nf);
    for (size_t k = 0; k < np; k++) {
        const double *p = report->control_points + 3 * (size_t)report->control_mesh_points[k];
        len += (size_t)snprintf(buf + len, cap - len, "v %.17g %.17g %.17g\n", p[0], p[1], p[2]);
    }
    for (size_t f = 0; f < nf; f++) {
        len += (size_t)snprintf(buf + len, cap - len, "f");
        for (uint32_t k = report->control_face_offsets[f]; k < report->control_face_offsets[f + 1];
             k++)
            len += (size_t)snprintf(buf + len, cap - len, " %u", report->control_face_points[k] + 1);
        len += (size_t)snprintf(buf + len, cap - len, "\n");
    }
    ffd_status s = ffd_write_file_atomic(path, buf, len, err);
    ffd_free(buf);
    return s;
}

ffd_status ffd_rig_report_write_lattice(const ffd_rig_report *report, const char *path,
                                        ffd_error *err)
{
    if (!report || !report->control_points)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: the report holds no lattice", path);
    if (report->control_edges)
        return write_control_edges(report, path, err);
    const uint32_t l = report->resolution[0], m = report->resolution[1], n = report->resolution[2];
    size_t count = report->control_count;
    /* at most ~80 bytes per vertex line and 3 lines per point of ~36 bytes */
    size_t cap = 64 + count * (80 + 3 * 40);
    char *buf = ffd_malloc(cap);
    if (!buf)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", path);
    size_t len = l ? (size_t)snprintf(buf, cap, "# ffdkit lattice %ux%ux%u\n", l, m, n)
                   : (size_t)snprintf(buf, cap, "# ffdkit %s: %zu\n",
                                      report->control_label ? report->control_label
                                                            : "control points",
                                      count);
    len = obj_vertices(report, buf, cap, len);
    for (uint32_t i = 0; i < l; i++)
        for (uint32_t j = 0; j < m; j++)
            for (uint32_t k = 0; k < n; k++) {
                size_t a = ((size_t)i * m + j) * n + k + 1; /* OBJ indices are 1-based */
                if (i + 1 < l)
                    len += (size_t)snprintf(buf + len, cap - len, "l %zu %zu\n", a, a + (size_t)m * n);
                if (j + 1 < m)
                    len += (size_t)snprintf(buf + len, cap - len, "l %zu %zu\n", a, a + n);
                if (k + 1 < n)
                    len += (size_t)snprintf(buf + len, cap - len, "l %zu %zu\n", a, a + 1);
            }
    ffd_status s = ffd_write_file_atomic(path, buf, len, err);
    ffd_free(buf);
    return s;
}
