/* rig — applying a GFFD rig (Qin et al. 2003): build the skeleton's fields
 * and bind the mesh (§2-3), edit the skeleton or replace it (§5), then track
 * the vertices (Fig. 5) and, when asked, resample stretched edges (§4,
 * Fig. 6). The mesh changes only at the end, all at once. */
#include "gffd/gffd_method.h"
#include "rig/rig.h"
#include "mesh/mesh.h"
#include "gffd/gffd.h"

#include <cjson/cJSON.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void ffd_rig_primitive_free(ffd_rig_primitive *prim)
{
    ffd_free(prim->vertices);
    ffd_free(prim->face_offsets);
    ffd_free(prim->face_indices);
    memset(prim, 0, sizeof *prim);
}

/* ---- skeleton files ---- */

/* A polyline from an OBJ file: v lines, and at most one l statement
 * (without one, the v lines in order). */
static ffd_status load_polyline(const char *path, const char *text, size_t size,
                                ffd_rig_primitive *prim, ffd_error *err)
{
    size_t nv = 0, cap = 0, nl = 0, lcap = 0, line = 0, l_line = 0;
    double *v = NULL;
    uint32_t *chain = NULL;
    ffd_status st = FFD_OK;
    const char *p = text, *end = text + size;
    while (p < end && st == FFD_OK) {
        const char *eol = memchr(p, '\n', (size_t)(end - p));
        if (!eol)
            eol = end;
        line++;
        while (p < eol && (*p == ' ' || *p == '\t' || *p == '\r'))
            p++;
        if (p + 1 < eol && p[0] == 'v' && (p[1] == ' ' || p[1] == '\t')) {
            double xyz[3];
            const char *q = p + 1;
            for (int k = 0; k < 3 && st == FFD_OK; k++) {
                char *next;
                xyz[k] = strtod(q, &next);
                if (next == q || next > eol)
                    st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected 3 numbers after 'v'", path,
                                  line);
                else if (!isfinite(xyz[k]))
                    st = ffd_fail(err, FFD_ERR_NONFINITE, "%s:%zu: coordinate is not finite",
                                  path, line);
                q = next;
            }
            if (st == FFD_OK) {
                if (!ffd_grow((void **)&v, &cap, nv + 1, 3 * sizeof(double)))
                    st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", path);
                else
                    memcpy(v + 3 * nv++, xyz, sizeof xyz);
            }
        } else if (p + 1 < eol && p[0] == 'l' && (p[1] == ' ' || p[1] == '\t')) {
            if (l_line)
                st = ffd_fail(err, FFD_ERR_PARSE,
                              "%s:%zu: a second 'l' statement (line %zu had one): a polyline "
                              "file holds one polyline",
                              path, line, l_line);
            l_line = line;
            const char *q = p + 1;
            while (st == FFD_OK) {
                while (q < eol && (*q == ' ' || *q == '\t' || *q == '\r'))
                    q++;
                if (q >= eol || *q == '#')
                    break;
                char *next;
                long long k = strtoll(q, &next, 10);
                if (next == q || (next < eol && *next != ' ' && *next != '\t' && *next != '\r' &&
                                  *next != '/')) {
                    st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected vertex indices after 'l'",
                                  path, line);
                    break;
                }
                while (next < eol && *next != ' ' && *next != '\t' && *next != '\r')
                    next++; /* skip "/vt" */
                long long idx = k < 0 ? (long long)nv + k : k - 1;
                if (k == 0 || idx < 0 || idx >= (long long)nv) {
                    st = ffd_fail(err, FFD_ERR_RANGE,
                                  "%s:%zu: vertex index %lld out of range (%zu vertices so far)",
                                  path, line, k, nv);
                    break;
                }
                if (!ffd_grow((void **)&chain, &lcap, nl + 1, sizeof(uint32_t))) {
                    st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", path);
                    break;
                }
                chain[nl++] = (uint32_t)idx;
                q = next;
            }
        }
        p = eol + 1;
    }
    if (st == FFD_OK && (l_line ? nl : nv) < 2)
        st = ffd_fail(err, FFD_ERR_PARSE, "%s: a polyline needs at least 2 vertices, found %zu",
                      path, l_line ? nl : nv);
    if (st == FFD_OK && l_line) {
        double *w = ffd_malloc_array(nl, 3 * sizeof(double));
        if (!w) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", path);
        } else {
            for (size_t i = 0; i < nl; i++)
                memcpy(w + 3 * i, v + 3 * (size_t)chain[i], 3 * sizeof(double));
            ffd_free(v);
            v = w;
            nv = nl;
        }
    }
    ffd_free(chain);
    if (st != FFD_OK) {
        ffd_free(v);
        return st;
    }
    prim->vertices = v;
    prim->vertex_count = nv;
    return FFD_OK;
}

ffd_status ffd_rig_load_primitive(const char *path, ffd_rig_primitive *prim, ffd_error *err)
{
    memset(prim, 0, sizeof *prim);
    ffd_format format = ffd_format_from_path(path);
    if (format == FFD_FORMAT_STL)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "%s: STL has no shared vertices; give a skeleton as OBJ, PLY or OFF",
                        path);
    unsigned char *data = NULL;
    size_t size = 0;
    ffd_status st = ffd_read_file(path, &data, &size, err);
    if (st != FFD_OK)
        return st;
    /* an OBJ without faces is a polyline; a byte order mark is read past, as
     * ffd_obj_read does (it would hide the first line) */
    size_t bom = ffd_utf8_bom_length(data, size);
    int has_faces = 1;
    if (format == FFD_FORMAT_OBJ || format == FFD_FORMAT_AUTO) {
        has_faces = 0;
        for (size_t i = bom; i + 1 < size; i++)
            if ((i == bom || data[i - 1] == '\n') && data[i] == 'f' &&
                (data[i + 1] == ' ' || data[i + 1] == '\t'))
                has_faces = 1;
    }
    if (!has_faces) {
        st = load_polyline(path, (const char *)data + bom, size - bom, prim, err);
        ffd_free(data);
        return st;
    }
    ffd_mesh *m = NULL;
    if (format == FFD_FORMAT_AUTO) {
        ffd_free(data);
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "%s: unknown extension: expected .obj, .ply or .off", path);
    }
    st = ffd_mesh_read_owned(data, size, format, path, &m, err); /* takes data */
    if (st != FFD_OK)
        return st;
    size_t nv = ffd_mesh_vertex_count(m), nf = ffd_mesh_face_count(m);
    const uint32_t *off = ffd_mesh_face_offsets(m);
    prim->vertices = ffd_malloc_array(nv ? nv : 1, 3 * sizeof(double));
    prim->face_offsets = ffd_malloc_array(nf + 1, sizeof(uint32_t));
    prim->face_indices = ffd_malloc_array(off[nf] ? off[nf] : 1, sizeof(uint32_t));
    if (!prim->vertices || !prim->face_offsets || !prim->face_indices) {
        ffd_mesh_destroy(m);
        ffd_rig_primitive_free(prim);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", path);
    }
    memcpy(prim->vertices, ffd_mesh_positions(m), nv * 3 * sizeof(double));
    memcpy(prim->face_offsets, off, (nf + 1) * sizeof(uint32_t));
    memcpy(prim->face_indices, ffd_mesh_face_indices(m), off[nf] * sizeof(uint32_t));
    prim->vertex_count = nv;
    prim->face_count = nf;
    ffd_mesh_destroy(m);
    if (nf == 0) {
        ffd_rig_primitive_free(prim);
        return ffd_fail(err, FFD_ERR_INVALID, "%s: no faces: a patch or polyhedron needs faces",
                        path);
    }
    return FFD_OK;
}

/* ---- application ---- */

void ffd_rig_primitive_public(const ffd_rig_primitive *r, ffd_gffd_primitive *p)
{
    memset(p, 0, sizeof *p);
    p->kind = r->kind;
    p->vertices = r->vertices;
    p->vertex_count = r->vertex_count;
    p->face_offsets = r->face_offsets;
    p->face_indices = r->face_indices;
    p->face_count = r->face_count;
    p->radius = r->radius;
}

static ffd_gffd_primitive *public_skeleton(const ffd_rig_primitive *r, size_t n)
{
    ffd_gffd_primitive *p = ffd_malloc_array(n, sizeof *p);
    if (p)
        for (size_t i = 0; i < n; i++)
            ffd_rig_primitive_public(&r[i], &p[i]);
    return p;
}

/* Limits: the fields of a skeleton (key "skeleton" or "replace"), fitted
 * once, and refitted once more per edit that touches them. */
ffd_status ffd_rig_gffd_charge(const ffd_rig *rig, const ffd_rig_primitive *prims, size_t count,
                               const char *key, ffd_budget *budget, ffd_error *err)
{
    const ffd_rig_gffd *rg = ffd_rig_gffd_of(rig);
    size_t max_samples = rg->options.max_samples ? rg->options.max_samples : 4000;
    for (size_t i = 0; i < count; i++) {
        ffd_gffd_primitive p;
        ffd_rig_primitive_public(&prims[i], &p);
        double m = ffd_gffd_estimate_samples(&p, max_samples), bytes, work;
        ffd_gffd_estimate_fit(m, p.face_count, &bytes, &work);
        size_t refits = 1;
        for (size_t e = 0; e < rg->edit_count && prims == rg->skeleton; e++)
            refits += rg->edits[e].all || rg->edits[e].primitive == i;
        char ms[32];
        ffd_status st = ffd_budget_charge(
            budget, bytes, work * (double)refits, err,
            "%s: %s[%zu]: a field of about %s samples (max_samples %zu) fitted %zu time%s",
            rig->name, key, i, ffd_format_count(m, ms, sizeof ms), max_samples, refits,
            refits == 1 ? "" : "s");
        if (st)
            return st;
    }
    return FFD_OK;
}

void ffd_rig_gffd_edit_center(const ffd_rig_gffd_edit *e, const ffd_gffd *g, double center[3])
{
    size_t first = e->all ? 0 : e->primitive, last = e->all ? ffd_gffd_primitive_count(g) : first + 1;
    center[0] = center[1] = center[2] = 0;
    if (e->has_center) {
        memcpy(center, e->center, 3 * sizeof *center);
        return;
    }
    size_t n = 0;
    for (size_t j = first; j < last; j++) {
        ffd_gffd_primitive p;
        ffd_gffd_get_primitive(g, j, &p, NULL);
        for (size_t v = 0; v < p.vertex_count; v++)
            for (int a = 0; a < 3; a++)
                center[a] += p.vertices[3 * v + a];
        n += p.vertex_count;
    }
    for (int a = 0; a < 3; a++)
        center[a] /= (double)n;
}

/* One edit on the current skeleton: a rotation or a translation through
 * ffd_gffd_transform, the other edits as the new vertices of each primitive
 * they touch, through ffd_gffd_set_vertices. */
ffd_status ffd_rig_gffd_apply_edit(const ffd_rig *rig, ffd_gffd *g, size_t i, ffd_error *err)
{
    const ffd_rig_gffd_edit *e = &ffd_rig_gffd_of(rig)->edits[i];
    size_t first = e->all ? 0 : e->primitive, last = e->all ? ffd_gffd_primitive_count(g) : first + 1;
    double center[3];
    ffd_rig_gffd_edit_center(e, g, center);
    double axis[3] = {0, 0, 1};
    if (e->kind == FFD_RIG_EDIT_ROTATE) {
        double len = sqrt(e->axis[0] * e->axis[0] + e->axis[1] * e->axis[1] +
                          e->axis[2] * e->axis[2]);
        for (int a = 0; a < 3; a++)
            axis[a] = e->axis[a] / len;
    }
    if (e->kind == FFD_RIG_EDIT_ROTATE || e->kind == FFD_RIG_EDIT_TRANSLATE) {
        /* a rigid edit goes to the library as the motion itself, not as new
         * vertices: a point or a straight polyline cannot show its turn */
        double rot[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, shift[3] = {0, 0, 0};
        if (e->kind == FFD_RIG_EDIT_ROTATE) {
            for (int b = 0; b < 3; b++) { /* column b: the rotated unit vector e_b */
                double unit[3] = {b == 0, b == 1, b == 2}, col[3];
                ffd_rig_rotate(axis, e->angle, unit, col);
                for (int a = 0; a < 3; a++)
                    rot[3 * a + b] = col[a];
            }
            for (int a = 0; a < 3; a++) /* t = c - R c: the centre stays */
                shift[a] = center[a] - (rot[3 * a] * center[0] + rot[3 * a + 1] * center[1] +
                                        rot[3 * a + 2] * center[2]);
        } else {
            memcpy(shift, e->delta, sizeof shift);
        }
        for (size_t j = first; j < last; j++) {
            ffd_error inner = {{0}};
            ffd_status st = ffd_gffd_transform(g, j, rot, shift, &inner);
            if (st != FFD_OK) {
                char context[48];
                snprintf(context, sizeof context, "edits[%zu]", i);
                return ffd_rig_wrap(err, st, rig->name, context, &inner);
            }
        }
        return FFD_OK;
    }
    for (size_t j = first; j < last; j++) {
        ffd_gffd_primitive p;
        ffd_gffd_get_primitive(g, j, &p, NULL);
        double *v = ffd_malloc_array(p.vertex_count, 3 * sizeof(double));
        if (!v)
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: edits[%zu]: out of memory", rig->name, i);
        memcpy(v, p.vertices, p.vertex_count * 3 * sizeof(double));
        if (e->kind == FFD_RIG_EDIT_VERTICES && e->vertex_count != p.vertex_count) {
            ffd_free(v);
            return ffd_fail(err, FFD_ERR_INVALID,
                            "%s: edits[%zu].vertices: %zu vertices, but skeleton[%zu] has %zu",
                            rig->name, i, e->vertex_count, j, p.vertex_count);
        }
        for (size_t k = 0; k < p.vertex_count; k++) {
            double *x = v + 3 * k, d[3];
            switch (e->kind) {
            case FFD_RIG_EDIT_TRANSLATE:
                for (int a = 0; a < 3; a++)
                    x[a] += e->delta[a];
                break;
            case FFD_RIG_EDIT_ROTATE:
                for (int a = 0; a < 3; a++)
                    d[a] = x[a] - center[a];
                ffd_rig_rotate(axis, e->angle, d, x);
                for (int a = 0; a < 3; a++)
                    x[a] += center[a];
                break;
            case FFD_RIG_EDIT_SCALE:
                for (int a = 0; a < 3; a++)
                    x[a] = center[a] + e->scale[a] * (x[a] - center[a]);
                break;
            case FFD_RIG_EDIT_MOVE:
                if (k == e->vertex)
                    for (int a = 0; a < 3; a++)
                        x[a] += e->delta[a];
                break;
            case FFD_RIG_EDIT_VERTICES:
                memcpy(x, e->vertices + 3 * k, 3 * sizeof(double));
                break;
            }
        }
        ffd_error inner = {{0}};
        ffd_status st = ffd_gffd_set_vertices(g, j, v, &inner);
        ffd_free(v);
        if (st != FFD_OK) {
            char context[48];
            snprintf(context, sizeof context, "edits[%zu]", i);
            return ffd_rig_wrap(err, st, rig->name, context, &inner);
        }
    }
    return FFD_OK;
}

/* The method's details: influence, the distance unit, tracking (and
 * resampling); lost vertices and a capped resampling become warnings. */
static ffd_status report_details(const ffd_rig_gffd *rg, const ffd_gffd *g,
                                 const ffd_gffd_resample_report *rr, ffd_rig_report *report,
                                 const char *name, ffd_error *err)
{
    const ffd_gffd_track_report *t = &rr->track;
    unsigned long mark;
    cJSON *d = ffd_rig_details_create(&mark);
    cJSON_AddNumberToObject(d, "influenced", (double)ffd_gffd_influenced_count(g));
    cJSON_AddNumberToObject(d, "unit", ffd_gffd_unit(g));
    cJSON_AddNumberToObject(d, "tracked", (double)t->tracked);
    cJSON_AddNumberToObject(d, "converged", (double)t->converged);
    cJSON_AddNumberToObject(d, "not_converged", (double)t->failed_count);
    cJSON *failed = cJSON_AddArrayToObject(d, "failed");
    for (size_t i = 0; i < t->failed_count && failed; i++)
        cJSON_AddItemToArray(failed, cJSON_CreateNumber(t->failed[i]));
    cJSON_AddNumberToObject(d, "fallbacks", (double)t->fallback_count);
    cJSON_AddNumberToObject(d, "iterations", (double)t->iterations);
    cJSON_AddNumberToObject(d, "max_field_error", t->max_error);
    cJSON_AddBoolToObject(d, "regularised", ffd_gffd_regularised(g) != 0);
    if (rg->resample) {
        cJSON *r = cJSON_AddObjectToObject(d, "resample");
        cJSON_AddNumberToObject(r, "rounds", (double)rr->rounds);
        cJSON_AddNumberToObject(r, "added_vertices", (double)rr->added_vertices);
        cJSON_AddNumberToObject(r, "split_edges", (double)rr->split_edges);
        cJSON_AddNumberToObject(r, "long_edges", (double)rr->long_edges);
        cJSON_AddBoolToObject(r, "capped", rr->capped != 0);
    }
    ffd_status st = ffd_rig_report_set_details(report, d, mark, name, err);
    if (!st && t->failed_count) {
        char ids[160];
        size_t len = 0;
        for (size_t i = 0; i < t->failed_count && i < 10; i++)
            len += (size_t)snprintf(ids + len, sizeof ids - len, " %u", t->failed[i]);
        st = ffd_rig_report_note(report, name, err,
                                 "warning: %zu vert%s did not regain %s field value (ids%s%s); "
                                 "they stay where tracking left them (--report lists all)",
                                 t->failed_count, t->failed_count == 1 ? "ex" : "ices",
                                 t->failed_count == 1 ? "its" : "their", ids,
                                 t->failed_count > 10 ? " ..." : "");
    }
    if (!st && rg->resample && rr->capped)
        st = ffd_rig_report_note(report, name, err,
                                 "warning: resampling stopped at its cap with %zu edges still "
                                 "stretched beyond the ratio",
                                 rr->long_edges);
    return st;
}

ffd_status ffd_rig_apply_gffd(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                              ffd_budget *budget, ffd_error *err)
{
    const ffd_rig_gffd *rg = ffd_rig_gffd_of(rig);
    ffd_error inner = {{0}};
    ffd_gffd *g = NULL;
    ffd_gffd_primitive *prims = NULL;
    double *out = NULL;
    ffd_mesh *resampled = NULL;
    ffd_gffd_resample_report rr;
    memset(&rr, 0, sizeof rr);
    ffd_status st;
    size_t nv = ffd_mesh_vertex_count(mesh);
    double t0 = ffd_now();

    if ((st = ffd_rig_gffd_charge(rig, rg->skeleton, rg->skeleton_count, "skeleton", budget,
                                  err)) ||
        (rg->replace &&
         (st = ffd_rig_gffd_charge(rig, rg->replace, rg->replace_count, "replace", budget, err))))
        goto done;
    if (!(prims = public_skeleton(rg->skeleton, rg->skeleton_count))) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
        goto done;
    }
    st = ffd_gffd_create(prims, rg->skeleton_count, ffd_mesh_positions(mesh), nv, &rg->options,
                         &g, &inner);
    ffd_free(prims);
    prims = NULL;
    if (st != FFD_OK) {
        st = ffd_rig_wrap(err, st, rig->name, "skeleton", &inner);
        goto done;
    }
    double t1 = ffd_now();
    for (size_t i = 0; i < rg->edit_count; i++)
        if ((st = ffd_rig_gffd_apply_edit(rig, g, i, err)) != FFD_OK)
            goto done;
    if (rg->replace) {
        if (!(prims = public_skeleton(rg->replace, rg->replace_count))) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
            goto done;
        }
        st = ffd_gffd_replace(g, prims, rg->replace_count, &inner);
        if (st != FFD_OK) {
            st = ffd_rig_wrap(err, st, rig->name, "replace", &inner);
            goto done;
        }
    }
    if (rg->corr_count) {
        st = ffd_gffd_set_correspondences(g, rg->corr_from, rg->corr_to, rg->corr_count, &inner);
        if (st != FFD_OK) {
            st = ffd_rig_wrap(err, st, rig->name, "correspondences", &inner);
            goto done;
        }
    }
    double t2 = ffd_now();
    if (rg->resample) {
        /* Limits: the refined mesh may grow to max_vertices (default 16 x
         * the input's); each vertex of it carries positions, attributes,
         * faces and a tracking record (~300 bytes) */
        double cap = rg->resample_options.max_vertices ? (double)rg->resample_options.max_vertices
                                                       : 16.0 * (double)nv;
        char cs[32];
        st = ffd_budget_charge(budget, 300.0 * cap, 1000.0 * cap, err,
                               "%s: resample: a mesh of up to %s vertices (max_vertices)",
                               rig->name, ffd_format_count(cap, cs, sizeof cs));
        if (st != FFD_OK)
            goto done;
        st = ffd_gffd_resample(g, mesh, &rg->resample_options, &resampled, &rr, &inner);
        if (st != FFD_OK) {
            st = ffd_rig_wrap(err, st, rig->name, "resample", &inner);
            goto done;
        }
    } else {
        if (!(out = ffd_malloc_array(nv ? nv : 1, 3 * sizeof(double)))) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", rig->name);
            goto done;
        }
        st = ffd_gffd_track(g, out, &rr.track, &inner);
        if (st != FFD_OK) {
            st = ffd_rig_wrap(err, st, rig->name, "tracking", &inner);
            goto done;
        }
    }
    /* the report's skeleton: every vertex of the current skeleton */
    double *skeleton_points = NULL;
    size_t skeleton_count = 0;
    if (report) {
        for (size_t i = 0; i < ffd_gffd_primitive_count(g); i++) {
            ffd_gffd_primitive p;
            ffd_gffd_get_primitive(g, i, &p, NULL);
            skeleton_count += p.vertex_count;
        }
        skeleton_points = ffd_malloc_array(skeleton_count ? skeleton_count : 1, 3 * sizeof(double));
        if (!skeleton_points) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the report", rig->name);
            goto done;
        }
        {
            size_t k = 0;
            for (size_t i = 0; i < ffd_gffd_primitive_count(g); i++) {
                ffd_gffd_primitive p;
                ffd_gffd_get_primitive(g, i, &p, NULL);
                memcpy(skeleton_points + 3 * k, p.vertices, p.vertex_count * 3 * sizeof(double));
                k += p.vertex_count;
            }
        }
        /* the details too, before the mesh changes (all or nothing) */
        if ((st = report_details(rg, g, &rr, report, rig->name, err))) {
            ffd_free(skeleton_points);
            goto done;
        }
    }
    /* the mesh changes here, all at once */
    if (resampled) {
        ffd_mesh tmp = *mesh;
        *mesh = *resampled;
        *resampled = tmp;
    } else {
        st = ffd_mesh_set_positions(mesh, out, NULL, &inner);
        if (st != FFD_OK) {
            ffd_free(skeleton_points);
            st = ffd_rig_wrap(err, st, rig->name, "tracking", &inner);
            goto done;
        }
    }
    double t3 = ffd_now();
    if (report) {
        report->timings.bind = t1 - t0;
        report->timings.solve = t2 - t1;
        report->timings.evaluate = t3 - t2;
        report->control_points = skeleton_points;
        report->control_count = skeleton_points ? skeleton_count : 0;
        report->control_label = "GFFD skeleton vertices";
    }
done:
    ffd_gffd_resample_report_free(&rr);
    ffd_mesh_destroy(resampled);
    ffd_free(prims);
    ffd_free(out);
    ffd_gffd_destroy(g);
    return st;
}
