/* rig_apply — applying a rig to a mesh through its method's descriptor
 * (deformer/method.h), and the report every method fills: shared fields,
 * details and notes, and the OBJ writers of the control structure. Each
 * method's application is in its folder (lattice/lattice_rig.c, ...). */
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

/* Rest positions of the constrained points (k by 3): a vertex constraint
 * takes its vertex of positions (n by 3; the id checked), a point
 * constraint its point. */
ffd_status ffd_rig_constraint_points(const ffd_rig *rig, const double *positions, size_t n,
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


/* ======================================================================
 * A rig with the generic layers (deformer/layers.c, docs/constraints.md):
 * the method applies the rig to a copy, for its report; the positions come
 * from the method's deformer wrapped in the layers, as in ffd_deformer and
 * the editor, so the three agree.
 * ====================================================================== */

static ffd_status layered_positions(const ffd_method *method, const ffd_rig *rig, ffd_mesh *mesh,
                                    const ffd_limits *limits, ffd_rig_report *report,
                                    ffd_error *err)
{
    sess_ctx ctx;
    ffd_sess_ctx_init(&ctx, mesh, 0, limits);
    size_t n = ctx.n, nc = 0;
    sess_method *m = NULL;
    sess_binding *b = NULL;
    double *x = ffd_malloc_array(n ? n : 1, 3 * sizeof *x), *jac = NULL;
    ffd_status st = x ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
    if (!st)
        st = ffd_method_load(method, &ctx, rig, &m, err);
    if (!st)
        st = m->vt->eval(m, x, err);
    if (!st && ffd_sess_caps(m)->jacobian_points) {
        if (!(jac = ffd_malloc_array(n ? n : 1, 9 * sizeof *jac)))
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
        if (!st)
            st = m->vt->bind(m, ctx.rest, n, &b, err);
        if (!st)
            st = m->vt->jacobian_points(m, b, jac, err);
    }
    if (!st && report) {
        nc = m->vt->control_count(m);
        if (nc == report->control_count && nc) {
            /* the controls as the layers left them (constrained, shortened) */
            m->vt->controls(m, report->control_points);
        }
        /* the constraints' points as the layers leave them */
        for (size_t c = 0; c < rig->constraint_count && c < report->constraint_count; c++)
            if (rig->constraints[c].kind == FFD_RIG_CONSTRAINT_VERTEX &&
                rig->constraints[c].vertex < n)
                memcpy(report->reached + 3 * c, x + 3 * (size_t)rig->constraints[c].vertex,
                       3 * sizeof *x);
        if (report->constraint_count == rig->constraint_count && report->residuals) {
            double *targets = ffd_malloc_array(rig->constraint_count, 3 * sizeof *targets);
            if (targets) {
                for (size_t c = 0; c < rig->constraint_count; c++)
                    memcpy(targets + 3 * c, rig->constraints[c].target, sizeof rig->constraints[c].target);
                report->max_residual = ffd_rig_residuals(rig->constraint_count, report->reached,
                                                         targets, report->residuals);
                ffd_free(targets);
            }
        }
        unsigned long mark = ffd_json_alloc_failures();
        cJSON *details = report->details ? cJSON_Parse(report->details) : cJSON_CreateObject();
        if (!details || ffd_layers_outcome(m, details))
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the report", rig->name);
        if (!st)
            st = ffd_rig_report_set_details(report, details, mark, rig->name, err);
        else
            cJSON_Delete(details);
    }
    if (b)
        m->vt->binding_free(b);
    if (m)
        m->vt->destroy(m);
    /* the mesh's positions last: ctx.rest pointed at them */
    if (!st) {
        ffd_error inner = {{0}};
        if ((st = ffd_mesh_set_positions(mesh, x, jac, &inner)))
            st = ffd_fail(err, st, "%s: %s", rig->name, inner.message);
    }
    ffd_free(x);
    ffd_free(jac);
    return st;
}

static ffd_status apply_layered(const ffd_method *method, const ffd_rig *rig, ffd_mesh *mesh,
                                const ffd_limits *limits, ffd_rig_report *report,
                                ffd_budget *budget, ffd_error *err)
{
    ffd_mesh *copy = NULL;
    ffd_status st = ffd_sess_clone_mesh(mesh, &copy, err);
    if (!st)
        st = method->apply(rig, copy, report, budget, err);
    ffd_mesh_destroy(copy);
    if (!st)
        st = layered_positions(method, rig, mesh, limits, report, err);
    return st;
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
    ffd_status pins = ffd_rig_check_pins(rig, ffd_mesh_vertex_count(mesh), err);
    if (pins)
        return pins;
    /* read before apply: a method may replace the mesh's arrays */
    size_t cells = ffd_mesh_cell_count(mesh), faces = ffd_mesh_face_count(mesh);
    int volume = ffd_mesh_is_volume(mesh);
    ffd_status s = ffd_rig_layers_trivial(rig->layers)
                       ? method->apply(rig, mesh, report, &budget, err)
                       : apply_layered(method, rig, mesh, limits, report, &budget, err);
    if (s == FFD_OK && report && volume)
        s = ffd_rig_report_note(report, rig->name, err,
                                "note: volume mesh: all %zu nodes deformed; steps that need a "
                                "surface (PB-FFD placement, the T-spline proxy) used its boundary "
                                "surface, %zu faces of its %zu cells",
                                ffd_mesh_vertex_count(mesh), faces, cells);
    if (report && s != FFD_OK)
        ffd_rig_report_free(report); /* nothing half-filled on failure */
    else if (report)
        report->method = method->name;
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
