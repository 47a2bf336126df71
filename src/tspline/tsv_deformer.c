/* tsv_deformer.c — the public ffd_tsv handle: a tailored T-spline volume
 * over an object (Zhang, Zheng & Cai 2020, §3.2), its refinement, proxy,
 * evaluation, direct manipulation, ARAP drags (§3.4) and the fold-over check. */
#include "tspline/tsv.h"
#include "math/tolerance.h"

#include <math.h>
#include <string.h>

#define TSV_MAX_RES 256u

static double extent_of(const tsv_lattice *L, int a)
{
    return L->box_max[a] - L->box_min[a];
}

/* Refreshes the public copy of the current control points (nv may have grown). */
static ffd_status sync_current(ffd_tsv *t, ffd_error *err)
{
    const tsv_lattice *L = t->L;
    double *c = ffd_realloc_array(t->current, L->nv ? L->nv : 1, 3 * sizeof(double));
    if (!c)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for %zu control points", L->nv);
    t->current = c;
    for (size_t v = 0; v < L->nv; v++)
        memcpy(c + 3 * v, L->verts[v].P[TSV_CURRENT], 3 * sizeof(double));
    return FFD_OK;
}

/* Rebuilds everything derived from the topology: support bins and proxy;
 * Phi is dropped, to be built by the first evaluation that needs it
 * (need_phi): a rig's refinements and ARAP steps, and `ffd tspline proxy`,
 * never read it, and it is the largest structure (64 entries per point of a
 * regular region). */
static ffd_status rebuild_derived(ffd_tsv *t, ffd_error *err)
{
    tsv_support *S = NULL;
    tsv_proxy proxy = {0};
    /* progress (ffd_set_progress): the shares are the stages' usual times */
    ffd_progress progress;
    ffd_progress_begin(&progress, "T-spline set-up");
    ffd_status st = ffd_tsv_support_build(t->L, &S, err);
    ffd_progress_update(&progress, 0.2);
    if (st == FFD_OK) {
        tsv_object obj = {t->params, t->n, t->face_offsets, t->face_indices, t->face_count};
        st = ffd_tsv_proxy_build(t->L, &obj, &proxy, err);
    }
    ffd_progress_update(&progress, 0.9);
    if (st == FFD_OK)
        st = sync_current(t, err);
    if (st == FFD_OK)
        ffd_progress_end(&progress);
    if (st != FFD_OK) {
        ffd_tsv_support_destroy(S);
        ffd_tsv_proxy_free(&proxy);
        return st;
    }
    ffd_tsv_support_destroy(t->S);
    ffd_tsv_phi_free(&t->phi);
    t->has_phi = 0;
    ffd_tsv_proxy_free(&t->proxy);
    t->S = S;
    t->proxy = proxy;
    ffd_free(t->tie);
    t->tie = NULL;
    return FFD_OK;
}

/* The parameter box (design §1.4): the bounding box, padded; flat axes get
 * 1e-9 of the diagonal so the linear parameterisation stays defined. */
static ffd_status fit_box(const double *points, size_t n, double padding, double mn[3],
                          double mx[3], ffd_error *err)
{
    for (int a = 0; a < 3; a++) {
        mn[a] = INFINITY;
        mx[a] = -INFINITY;
    }
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            double x = points[3 * i + a];
            if (!isfinite(x))
                return ffd_fail(err, FFD_ERR_NONFINITE, "point %zu: coordinate %d is %g", i, a, x);
            if (x < mn[a])
                mn[a] = x;
            if (x > mx[a])
                mx[a] = x;
        }
    double diag = 0;
    for (int a = 0; a < 3; a++)
        diag += (mx[a] - mn[a]) * (mx[a] - mn[a]);
    diag = sqrt(diag);
    if (!(fmax(mx[0] - mn[0], fmax(mx[1] - mn[1], mx[2] - mn[2])) <= FFD_BOX_MAX_EXTENT) ||
        !isfinite(diag))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "the bounding box (extent %g x %g x %g) is too large for a T-spline "
                        "lattice (extents up to %g)",
                        mx[0] - mn[0], mx[1] - mn[1], mx[2] - mn[2], FFD_BOX_MAX_EXTENT);
    if (diag == 0)
        diag = 1;
    for (int a = 0; a < 3; a++) {
        double e = mx[a] - mn[a];
        double pad = padding * e;
        if (e <= 1e-9 * diag)
            pad = (padding > 0 ? padding : 1e-9) * diag;
        mn[a] -= pad;
        mx[a] += pad;
    }
    return FFD_OK;
}

ffd_status ffd_tsv_create(const double *points, size_t n, const uint32_t *face_offsets,
                          const uint32_t *face_indices, size_t face_count, const uint32_t res[3],
                          const ffd_tsv_options *options, ffd_tsv **out, ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "out is NULL");
    *out = NULL;
    if (!res)
        return ffd_fail(err, FFD_ERR_INVALID, "resolution is NULL");
    for (int a = 0; a < 3; a++)
        if (res[a] < 4 || res[a] > TSV_MAX_RES)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "resolution %u x %u x %u: expected 4 to %u control points per axis "
                            "(a cubic T-spline volume needs at least 4)",
                            res[0], res[1], res[2], TSV_MAX_RES);
    if (n == 0 || !points)
        return ffd_fail(err, FFD_ERR_INVALID, "no points to bind: the lattice is fitted to the object");
    double padding = options ? options->padding : 0;
    if (!isfinite(padding) || padding < 0 || padding > 100)
        return ffd_fail(err, FFD_ERR_INVALID, "padding %g: expected in [0, 100]", padding);
    if (face_count && (!face_offsets || !face_indices))
        return ffd_fail(err, FFD_ERR_INVALID, "faces given without offsets or indices");
    if (face_count) {
        if (face_offsets[0] != 0)
            return ffd_fail(err, FFD_ERR_INVALID, "face_offsets[0] is %u: expected 0", face_offsets[0]);
        for (size_t f = 0; f < face_count; f++) {
            if (face_offsets[f + 1] < face_offsets[f] + 3)
                return ffd_fail(err, FFD_ERR_INVALID, "face %zu: fewer than 3 vertices", f);
            for (uint32_t k = face_offsets[f]; k < face_offsets[f + 1]; k++)
                if (face_indices[k] >= n)
                    return ffd_fail(err, FFD_ERR_RANGE, "face %zu: vertex %u: there are %zu points",
                                    f, face_indices[k], n);
        }
    }
    double mn[3], mx[3];
    ffd_status st = fit_box(points, n, padding, mn, mx, err);
    if (st != FFD_OK)
        return st;

    ffd_tsv *t = ffd_calloc(1, sizeof *t);
    if (!t)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    t->n = n;
    t->params = ffd_malloc_array(n, 3 * sizeof(double));
    t->points = ffd_malloc_array(n, 3 * sizeof(double));
    if (!t->params || !t->points) {
        ffd_free(t->params);
        ffd_free(t->points);
        ffd_free(t);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for %zu points", n);
    }
    memcpy(t->points, points, n * 3 * sizeof(double));
    /* the linear parameterisation of §3.2 */
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            double s = (points[3 * i + a] - mn[a]) / (mx[a] - mn[a]);
            t->params[3 * i + a] = s < 0 ? 0 : (s > 1 ? 1 : s);
        }
    if (face_count) {
        size_t corners = face_offsets[face_count];
        t->face_offsets = ffd_malloc_array(face_count + 1, sizeof(uint32_t));
        t->face_indices = ffd_malloc_array(corners, sizeof(uint32_t));
        if (!t->face_offsets || !t->face_indices) {
            ffd_tsv_destroy(t);
            return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for %zu faces", face_count);
        }
        memcpy(t->face_offsets, face_offsets, (face_count + 1) * sizeof(uint32_t));
        memcpy(t->face_indices, face_indices, corners * sizeof(uint32_t));
        t->face_count = face_count;
    }
    st = ffd_tsv_lattice_create(mn, mx, res, &t->L, err);
    if (st == FFD_OK)
        st = rebuild_derived(t, err);
    if (st != FFD_OK) {
        ffd_tsv_destroy(t);
        return st;
    }
    *out = t;
    return FFD_OK;
}

void ffd_tsv_destroy(ffd_tsv *t)
{
    if (!t)
        return;
    ffd_tsv_lattice_destroy(t->L);
    ffd_tsv_support_destroy(t->S);
    ffd_tsv_phi_free(&t->phi);
    ffd_tsv_proxy_free(&t->proxy);
    ffd_free(t->params);
    ffd_free(t->points);
    ffd_free(t->face_offsets);
    ffd_free(t->face_indices);
    ffd_free(t->current);
    ffd_free(t->tie);
    ffd_free(t);
}

size_t ffd_tsv_point_count(const ffd_tsv *t)
{
    return t->n;
}

void ffd_tsv_box(const ffd_tsv *t, double min[3], double max[3])
{
    memcpy(min, t->L->box_min, sizeof t->L->box_min);
    memcpy(max, t->L->box_max, sizeof t->L->box_max);
}

void ffd_tsv_point_params(const ffd_tsv *t, size_t i, double stu[3])
{
    memcpy(stu, t->params + 3 * i, 3 * sizeof(double));
}

size_t ffd_tsv_control_count(const ffd_tsv *t)
{
    return t->L->nv;
}

const double *ffd_tsv_control_points(const ffd_tsv *t)
{
    return t->current;
}

static ffd_status check_vertex(const ffd_tsv *t, uint32_t v, ffd_error *err)
{
    if (v >= t->L->nv)
        return ffd_fail(err, FFD_ERR_RANGE, "control point %u: there are %zu control points", v,
                        t->L->nv);
    return FFD_OK;
}

ffd_status ffd_tsv_rest_point(const ffd_tsv *t, uint32_t v, double out[3], ffd_error *err)
{
    ffd_status st = check_vertex(t, v, err);
    if (st == FFD_OK)
        memcpy(out, t->L->verts[v].P[TSV_REST], 3 * sizeof(double));
    return st;
}

ffd_status ffd_tsv_control_info(const ffd_tsv *t, uint32_t v, double *weight, double sigma[3],
                                ffd_error *err)
{
    ffd_status st = check_vertex(t, v, err);
    if (st != FFD_OK)
        return st;
    if (weight)
        *weight = t->L->verts[v].W;
    if (sigma)
        memcpy(sigma, t->L->verts[v].sg, 3 * sizeof(double));
    return FFD_OK;
}

ffd_status ffd_tsv_knots(const ffd_tsv *t, uint32_t v, double knots[3][5], ffd_error *err)
{
    ffd_status st = check_vertex(t, v, err);
    if (st != FFD_OK)
        return st;
    ffd_tsv_infer_knots(t->L, v, knots);
    for (int d = 0; d < 3; d++)
        for (int k = 0; k < 5; k++)
            knots[d][k] = tsv_kappa(knots[d][k]);
    return FFD_OK;
}

double ffd_tsv_max_weight_deviation(const ffd_tsv *t)
{
    return ffd_tsv_lattice_max_weight_deviation(t->L);
}

ffd_status ffd_tsv_set_control_points(ffd_tsv *t, const double *points, ffd_error *err)
{
    size_t nv = t->L->nv;
    for (size_t i = 0; i < 3 * nv; i++)
        if (!isfinite(points[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "control point %zu: coordinate %zu is %g", i / 3,
                            i % 3, points[i]);
    for (size_t v = 0; v < nv; v++) {
        memcpy(t->L->verts[v].P[TSV_CURRENT], points + 3 * v, 3 * sizeof(double));
        memcpy(t->current + 3 * v, points + 3 * v, 3 * sizeof(double));
    }
    return FFD_OK;
}

ffd_status ffd_tsv_move(ffd_tsv *t, uint32_t v, const double delta[3], ffd_error *err)
{
    ffd_status st = check_vertex(t, v, err);
    if (st != FFD_OK)
        return st;
    double *P = t->L->verts[v].P[TSV_CURRENT];
    double q[3];
    for (int a = 0; a < 3; a++) {
        q[a] = P[a] + delta[a];
        if (!isfinite(q[a]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "control point %u: moved coordinate %d is %g", v,
                            a, q[a]);
    }
    memcpy(P, q, sizeof q);
    memcpy(t->current + 3 * (size_t)v, q, sizeof q);
    return FFD_OK;
}

void ffd_tsv_reset(ffd_tsv *t)
{
    for (size_t v = 0; v < t->L->nv; v++) {
        tsv_vertex *x = &t->L->verts[v];
        memcpy(x->P[TSV_CURRENT], x->P[TSV_REST], 3 * sizeof(double));
        memcpy(t->current + 3 * v, x->P[TSV_REST], 3 * sizeof(double));
    }
}

ffd_status ffd_tsv_set_frozen(ffd_tsv *t, uint32_t v, int frozen, ffd_error *err)
{
    ffd_status st = check_vertex(t, v, err);
    if (st != FFD_OK)
        return st;
    uint8_t f = frozen ? 1 : 0;
    if (t->L->verts[v].frozen != f) {
        t->L->verts[v].frozen = f;
        t->frozen_version++;
        ffd_free(t->tie);
        t->tie = NULL;
    }
    return FFD_OK;
}

int ffd_tsv_frozen(const ffd_tsv *t, uint32_t v)
{
    return v < t->L->nv ? t->L->verts[v].frozen : 0;
}

/* --- elements --- */

size_t ffd_tsv_element_count(const ffd_tsv *t, ffd_tsv_element kind)
{
    switch (kind) {
    case FFD_TSV_EDGE:
        return t->L->ne;
    case FFD_TSV_FACE:
        return t->L->nf;
    case FFD_TSV_CELL:
        return t->L->nc;
    }
    return 0;
}

static const char *element_name(ffd_tsv_element kind)
{
    return kind == FFD_TSV_EDGE ? "edge" : kind == FFD_TSV_FACE ? "face" : "cell";
}

static ffd_status check_element(const ffd_tsv *t, ffd_tsv_element kind, uint32_t id,
                                ffd_error *err)
{
    if (kind != FFD_TSV_EDGE && kind != FFD_TSV_FACE && kind != FFD_TSV_CELL)
        return ffd_fail(err, FFD_ERR_INVALID, "unknown element kind %d", (int)kind);
    size_t count = ffd_tsv_element_count(t, kind);
    if (id >= count)
        return ffd_fail(err, FFD_ERR_RANGE, "%s %u: there are %zu %ss", element_name(kind), id,
                        count, element_name(kind));
    return FFD_OK;
}

ffd_status ffd_tsv_edge(const ffd_tsv *t, uint32_t e, uint32_t ends[2], int *axis, ffd_error *err)
{
    ffd_status st = check_element(t, FFD_TSV_EDGE, e, err);
    if (st != FFD_OK)
        return st;
    ends[0] = t->L->edges[e].v0;
    ends[1] = t->L->edges[e].v1;
    if (axis)
        *axis = t->L->edges[e].axis;
    return FFD_OK;
}

/* The sigma box of an element. */
static void sigma_box(const tsv_lattice *L, ffd_tsv_element kind, uint32_t id, double lo[3],
                      double hi[3])
{
    if (kind == FFD_TSV_EDGE) {
        const tsv_edge *e = &L->edges[id];
        int k = 0;
        for (int a = 0; a < 3; a++) {
            if (a == e->axis) {
                lo[a] = e->lo;
                hi[a] = e->hi;
            } else {
                lo[a] = hi[a] = e->c[k++];
            }
        }
    } else if (kind == FFD_TSV_FACE) {
        const tsv_face *f = &L->faces[id];
        int k = 0;
        for (int a = 0; a < 3; a++) {
            if (a == f->normal) {
                lo[a] = hi[a] = f->c;
            } else {
                lo[a] = f->lo[k];
                hi[a] = f->hi[k];
                k++;
            }
        }
    } else {
        memcpy(lo, L->cells[id].lo, 3 * sizeof(double));
        memcpy(hi, L->cells[id].hi, 3 * sizeof(double));
    }
}

ffd_status ffd_tsv_element_box(const ffd_tsv *t, ffd_tsv_element kind, uint32_t id, double lo[3],
                               double hi[3], ffd_error *err)
{
    ffd_status st = check_element(t, kind, id, err);
    if (st != FFD_OK)
        return st;
    sigma_box(t->L, kind, id, lo, hi);
    for (int a = 0; a < 3; a++) {
        lo[a] = tsv_kappa(lo[a]);
        hi[a] = tsv_kappa(hi[a]);
    }
    return FFD_OK;
}

ffd_status ffd_tsv_element_points(const ffd_tsv *t, ffd_tsv_element kind, uint32_t id,
                                  uint32_t **ids, size_t *count, ffd_error *err)
{
    *ids = NULL;
    *count = 0;
    ffd_status st = check_element(t, kind, id, err);
    if (st != FFD_OK)
        return st;
    if (kind == FFD_TSV_FACE)
        return ffd_tsv_face_ring(t->L, id, ids, count, err);
    if (kind == FFD_TSV_CELL)
        return ffd_tsv_cell_points(t->L, id, ids, count, err);
    uint32_t *e = ffd_malloc_array(2, sizeof(uint32_t));
    if (!e)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    e[0] = t->L->edges[id].v0;
    e[1] = t->L->edges[id].v1;
    *ids = e;
    *count = 2;
    return FFD_OK;
}

/* Squared distance, in world units of the rest box, from parameters p to the
 * parameter box [lo,hi]. */
static double box_distance2(const tsv_lattice *L, const double p[3], const double lo[3],
                            const double hi[3])
{
    double d2 = 0;
    for (int a = 0; a < 3; a++) {
        double d = 0;
        if (p[a] < lo[a])
            d = lo[a] - p[a];
        else if (p[a] > hi[a])
            d = p[a] - hi[a];
        d *= extent_of(L, a);
        d2 += d * d;
    }
    return d2;
}

ffd_status ffd_tsv_locate(const ffd_tsv *t, ffd_tsv_element kind, const double point[3],
                          uint32_t *id, ffd_error *err)
{
    const tsv_lattice *L = t->L;
    if (kind != FFD_TSV_EDGE && kind != FFD_TSV_FACE && kind != FFD_TSV_CELL)
        return ffd_fail(err, FFD_ERR_INVALID, "unknown element kind %d", (int)kind);
    double p[3];
    for (int a = 0; a < 3; a++) {
        if (!isfinite(point[a]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "point coordinate %d is %g", a, point[a]);
        p[a] = (point[a] - L->box_min[a]) / extent_of(L, a);
        if (kind == FFD_TSV_CELL)
            p[a] = p[a] < 0 ? 0 : (p[a] > 1 ? 1 : p[a]);
    }
    size_t count = ffd_tsv_element_count(t, kind);
    double best = INFINITY;
    uint32_t best_id = 0;
    for (size_t i = 0; i < count; i++) {
        double lo[3], hi[3];
        sigma_box(L, kind, (uint32_t)i, lo, hi);
        int thin = 0;
        for (int a = 0; a < 3; a++) {
            if (kind == FFD_TSV_CELL && tsv_kappa(hi[a]) <= tsv_kappa(lo[a]))
                thin = 1; /* an end-layer cell has no parameter volume: prefer its neighbour */
            lo[a] = tsv_kappa(lo[a]);
            hi[a] = tsv_kappa(hi[a]);
        }
        double d = box_distance2(L, p, lo, hi) + (thin ? 1e-300 : 0);
        if (d < best) {
            best = d;
            best_id = (uint32_t)i;
        }
    }
    *id = best_id;
    return FFD_OK;
}

/* --- refinement --- */

ffd_status ffd_tsv_refine(ffd_tsv *t, const ffd_tsv_insertion *insertions, size_t count,
                          ffd_tsv_refine_report *report, ffd_error *err)
{
    if (report)
        memset(report, 0, sizeof *report);
    double t0 = ffd_now();
    tsv_refine_stats stats = {0};
    tsv_lattice *before = NULL;
    /* validates the insertions, and rolls the lattice back itself on failure */
    ffd_status st = ffd_tsv_lattice_refine_undoable(t->L, insertions, count, &stats, &before, err);
    if (st != FFD_OK)
        return st;
    st = rebuild_derived(t, err);
    if (st != FFD_OK) {
        /* the derived data still describe the lattice before the edit */
        if (before)
            ffd_tsv_lattice_swap_in(t->L, before);
        return st;
    }
    ffd_tsv_lattice_destroy(before);
    if (report) {
        report->added_points = stats.added_points;
        report->moved_points = stats.moved_points;
        report->topology_steps = stats.topology_steps;
        report->max_weight_deviation = stats.max_weight_deviation;
        report->seconds = ffd_now() - t0;
    }
    return FFD_OK;
}

/* --- evaluation --- */

/* Builds Phi for the current topology if it is not there (rebuild_derived).
 * A cache inside the handle, which one thread uses at a time (docs/api.md),
 * so the const functions that evaluate may fill it. FFD_ERR_NOMEM. */
static ffd_status need_phi(const ffd_tsv *t, ffd_error *err)
{
    if (t->has_phi)
        return FFD_OK;
    ffd_tsv *cache = (ffd_tsv *)t;
    tsv_phi phi;
    ffd_status st = ffd_tsv_phi_build(t->L, t->S, t->params, t->n, &phi, err);
    if (st != FFD_OK)
        return st;
    cache->phi = phi;
    cache->has_phi = 1;
    return FFD_OK;
}

ffd_status ffd_tsv_eval(const ffd_tsv *t, double *out, ffd_error *err)
{
    ffd_status st = need_phi(t, err);
    if (st != FFD_OK)
        return st;
    ffd_tsv_phi_apply_displacement(&t->phi, t->L, t->points, out);
    return FFD_OK;
}

/* d(x')/d(x) from dF/d(s,t,u): divide column a by the box extent. */
static void world_jacobian(const tsv_lattice *L, double jac[9])
{
    for (int r = 0; r < 3; r++)
        for (int a = 0; a < 3; a++)
            jac[3 * r + a] /= extent_of(L, a);
}

ffd_status ffd_tsv_eval_jacobian(const ffd_tsv *t, double *x, double *jac, ffd_error *err)
{
    (void)err;
    const size_t n = t->n;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        /* ffd_tsv_jacobian's sums, whose displacement d is Phi's row times
           P - P_rest bit for bit (Phi leaves out only terms that add zero) */
        double d[3], *J = jac + 9 * i;
        const double *p = t->points + 3 * i;
        ffd_tsv_eval_displacement(t->L, t->S, t->params + 3 * i, d, J);
        world_jacobian(t->L, J);
        J[0] += 1.0;
        J[4] += 1.0;
        J[8] += 1.0;
        /* ffd_tsv_phi_apply_displacement's rule: a zero displacement keeps the bits */
        for (int r = 0; r < 3; r++)
            x[3 * i + r] = d[r] != 0.0 ? p[r] + d[r] : p[r];
    }
    return FFD_OK;
}

ffd_status ffd_tsv_jacobian(const ffd_tsv *t, double *out, ffd_error *err)
{
    (void)err;
    const size_t n = t->n;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        /* displacement form, like ffd_tsv_eval: the identity where nothing moved */
        double d[3], *J = out + 9 * i;
        ffd_tsv_eval_displacement(t->L, t->S, t->params + 3 * i, d, J);
        world_jacobian(t->L, J);
        J[0] += 1.0;
        J[4] += 1.0;
        J[8] += 1.0;
    }
    return FFD_OK;
}

void ffd_tsv_eval_params(const ffd_tsv *t, const double stu[3], double out[3], double *jacobian)
{
    ffd_tsv_eval_point(t->L, t->S, TSV_CURRENT, stu, out, jacobian);
    if (jacobian)
        world_jacobian(t->L, jacobian);
}

double ffd_tsv_weight_sum(const ffd_tsv *t, const double stu[3])
{
    size_t m = ffd_tsv_support_max(t->S);
    uint32_t ids[512];
    double w[512];
    if (m > 512)
        return NAN; /* cannot happen: a point lies in at most 4^3 supports per knot structure */
    double p[3];
    for (int a = 0; a < 3; a++)
        p[a] = stu[a] < 0 ? 0 : (stu[a] > 1 ? 1 : stu[a]);
    size_t k = ffd_tsv_support_eval(t->S, p, ids, w, NULL);
    double s = 0;
    for (size_t i = 0; i < k; i++)
        s += w[i];
    return s;
}

static size_t phi_row(const void *self, size_t i, uint32_t *columns, double *weights)
{
    const ffd_tsv *t = self;
    size_t a = t->phi.rowptr[i], b = t->phi.rowptr[i + 1];
    memcpy(columns, t->phi.col + a, (b - a) * sizeof(uint32_t));
    memcpy(weights, t->phi.val + a, (b - a) * sizeof(double));
    return b - a;
}

ffd_status ffd_tsv_linear_map(ffd_tsv *t, ffd_linear_map *map, ffd_error *err)
{
    const tsv_lattice *L = t->L;
    ffd_status st = need_phi(t, err);
    if (st != FFD_OK)
        return st;
    uint32_t *tie = ffd_malloc_array(L->nv ? L->nv : 1, sizeof(uint32_t));
    if (!tie)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    uint32_t free_count = 0;
    for (size_t v = 0; v < L->nv; v++)
        tie[v] = L->verts[v].frozen ? FFD_TIE_FIXED : free_count++;
    size_t max_nnz = 0;
    for (size_t i = 0; i < t->phi.rows; i++) {
        size_t k = t->phi.rowptr[i + 1] - t->phi.rowptr[i];
        if (k > max_nnz)
            max_nnz = k;
    }
    ffd_free(t->tie);
    t->tie = tie;
    memset(map, 0, sizeof *map);
    map->self = t;
    map->point_count = t->n;
    map->column_count = L->nv;
    map->variable_count = free_count;
    map->max_row_nnz = max_nnz ? max_nnz : 1;
    map->tie = tie;
    map->row = phi_row;
    return FFD_OK;
}

/* --- proxy --- */

void ffd_tsv_get_proxy(const ffd_tsv *t, ffd_tsv_proxy *out)
{
    const tsv_proxy *p = &t->proxy;
    out->face_count = p->face_count;
    out->face_offsets = p->face_offsets;
    out->face_indices = p->face_indices;
    out->face_cells = p->face_cells;
    out->vertex_count = p->vertex_count;
    out->vertices = p->vertices;
    out->occupied_cells = p->occupied_cells;
    out->inside_cells = p->inside_cells;
    out->point_count = p->point_count;
    out->point_controls = p->point_controls;
    out->face_points = p->face_points;
}

/* --- ARAP drags (§3.4) --- */

struct ffd_tsv_arap {
    ffd_tsv *t;
    tsv_arap *solver;
    uint32_t *handles;
    size_t k;
    double *targets;     /* nv by 3 */
    double *x;           /* nv by 3 */
    uint64_t version, frozen_version;
    ffd_tsv_arap_options opt;
};

static ffd_status resolve_arap_options(const ffd_tsv_arap_options *o, ffd_tsv_arap_options *r,
                                       ffd_error *err)
{
    memset(r, 0, sizeof *r);
    if (o)
        *r = *o;
    const double *w[4] = {&r->w_one_form, &r->w_proxy, &r->w_volume, &r->w_target};
    const char *names[4] = {"w_one_form", "w_proxy", "w_volume", "w_target"};
    for (int i = 0; i < 4; i++)
        if (!isfinite(*w[i]) || *w[i] < 0 || *w[i] > 1e12)
            return ffd_fail(err, FFD_ERR_INVALID, "%s %g: expected >= 0 (0: default)", names[i],
                            *w[i]);
    /* eq. 3 defaults: w_1F = 1.5 w_M = 2 w_V = w_C */
    if (r->w_one_form == 0)
        r->w_one_form = 1;
    if (r->w_proxy == 0)
        r->w_proxy = 2.0 / 3.0;
    if (r->w_volume == 0)
        r->w_volume = 0.5;
    if (r->w_target == 0)
        r->w_target = 1;
    if (r->iterations == 0)
        r->iterations = 5;
    if (r->iterations > 1000)
        return ffd_fail(err, FFD_ERR_INVALID, "iterations %u: expected <= 1000", r->iterations);
    if (r->only_target) {
        r->w_one_form = r->w_proxy = r->w_volume = 1e-9;
        r->soft = 1;
    }
    return FFD_OK;
}

void ffd_tsv_arap_destroy(ffd_tsv_arap *arap)
{
    if (!arap)
        return;
    ffd_tsv_arap_solver_destroy(arap->solver);
    ffd_free(arap->handles);
    ffd_free(arap->targets);
    ffd_free(arap->x);
    ffd_free(arap);
}

ffd_status ffd_tsv_arap_begin(ffd_tsv *t, const uint32_t *handles, size_t k,
                              const ffd_tsv_arap_options *options, ffd_tsv_arap **out,
                              ffd_error *err)
{
    *out = NULL;
    ffd_tsv_arap_options opt;
    ffd_status st = resolve_arap_options(options, &opt, err);
    if (st != FFD_OK)
        return st;
    tsv_lattice *L = t->L;
    size_t nv = L->nv;
    if (k && !handles)
        return ffd_fail(err, FFD_ERR_INVALID, "handles is NULL");
    uint8_t *roles = ffd_calloc(nv ? nv : 1, 1);
    if (!roles)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    for (size_t v = 0; v < nv; v++)
        roles[v] = L->verts[v].frozen ? TSV_HARD : TSV_FREE;
    for (size_t h = 0; h < k; h++) {
        uint32_t v = handles[h];
        if (v >= nv) {
            ffd_free(roles);
            return ffd_fail(err, FFD_ERR_RANGE, "handle %zu: control point %u: there are %zu", h, v,
                            nv);
        }
        if (L->verts[v].frozen) {
            ffd_free(roles);
            return ffd_fail(err, FFD_ERR_INVALID,
                            "handle %zu: control point %u is frozen: a frozen point cannot be "
                            "moved (unfreeze it or drop the handle)",
                            h, v);
        }
        if (roles[v] != TSV_FREE) {
            ffd_free(roles);
            return ffd_fail(err, FFD_ERR_INVALID, "handle %zu: control point %u is given twice", h,
                            v);
        }
        roles[v] = opt.soft ? TSV_SOFT : TSV_HARD;
    }
    ffd_tsv_arap *a = ffd_calloc(1, sizeof *a);
    if (!a) {
        ffd_free(roles);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    }
    a->t = t;
    a->k = k;
    a->opt = opt;
    a->version = L->version;
    a->frozen_version = t->frozen_version;
    a->handles = ffd_malloc_array(k ? k : 1, sizeof(uint32_t));
    a->targets = ffd_malloc_array(nv ? nv : 1, 3 * sizeof(double));
    a->x = ffd_malloc_array(nv ? nv : 1, 3 * sizeof(double));
    if (!a->handles || !a->targets || !a->x) {
        ffd_free(roles);
        ffd_tsv_arap_destroy(a);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    }
    if (k)
        memcpy(a->handles, handles, k * sizeof(uint32_t));
    /* the reference is the lattice as it is now (design §6), so edits accumulate */
    for (size_t v = 0; v < nv; v++) {
        memcpy(L->verts[v].P[TSV_REFERENCE], L->verts[v].P[TSV_CURRENT], 3 * sizeof(double));
        memcpy(a->targets + 3 * v, L->verts[v].P[TSV_CURRENT], 3 * sizeof(double));
    }
    ffd_progress progress;
    ffd_progress_begin(&progress, "ARAP");
    tsv_arap_graph g = {0};
    st = ffd_tsv_arap_graph_build(L, &t->proxy, &g, err);
    ffd_progress_update(&progress, 0.3);
    if (st == FFD_OK) {
        tsv_arap_weights w = {opt.w_one_form, opt.w_proxy, opt.w_volume, opt.w_target};
        st = ffd_tsv_arap_solver_create(&g, roles, &w, &a->solver, err);
    }
    ffd_tsv_arap_graph_free(&g);
    ffd_free(roles);
    if (st != FFD_OK) {
        ffd_tsv_arap_destroy(a);
        return st;
    }
    ffd_progress_end(&progress);
    *out = a;
    return FFD_OK;
}

ffd_status ffd_tsv_arap_solve(ffd_tsv_arap *a, const double *targets,
                              ffd_tsv_arap_report *report, ffd_error *err)
{
    ffd_tsv *t = a->t;
    tsv_lattice *L = t->L;
    if (report)
        memset(report, 0, sizeof *report);
    if (L->version != a->version)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "the lattice was refined since the drag began: begin a new drag");
    if (t->frozen_version != a->frozen_version)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "the frozen set changed since the drag began: begin a new drag");
    for (size_t h = 0; h < 3 * a->k; h++)
        if (!isfinite(targets[h]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "target %zu: coordinate %zu is %g", h / 3, h % 3,
                            targets[h]);
    double t0 = ffd_now();
    for (size_t h = 0; h < a->k; h++)
        memcpy(a->targets + 3 * (size_t)a->handles[h], targets + 3 * h, 3 * sizeof(double));
    size_t nv = L->nv;
    for (size_t v = 0; v < nv; v++)
        memcpy(a->x + 3 * v, L->verts[v].P[TSV_CURRENT], 3 * sizeof(double));
    ffd_status st = ffd_tsv_arap_solver_solve(a->solver, a->targets, a->x, a->opt.iterations, err);
    if (st != FFD_OK)
        return st;
    for (size_t i = 0; i < 3 * nv; i++)
        if (!isfinite(a->x[i]))
            return ffd_fail(err, FFD_ERR_NUMERIC, "the ARAP solve produced a non-finite position");
    double max_err = 0;
    for (size_t v = 0; v < nv; v++) {
        memcpy(L->verts[v].P[TSV_CURRENT], a->x + 3 * v, 3 * sizeof(double));
        memcpy(t->current + 3 * v, a->x + 3 * v, 3 * sizeof(double));
    }
    for (size_t h = 0; h < a->k; h++) {
        const double *p = a->x + 3 * (size_t)a->handles[h], *q = targets + 3 * h;
        double d = sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                        (p[2] - q[2]) * (p[2] - q[2]));
        if (d > max_err)
            max_err = d;
    }
    if (report) {
        report->iterations = a->opt.iterations;
        report->max_handle_error = max_err;
        report->seconds = ffd_now() - t0;
    }
    return FFD_OK;
}

/* --- sensitivities of a drag (docs/sensitivities.md, "T-spline proxy handles") ---
 * The bound points are X = X_0 + Phi (P - P_rest) (eq. 1 in displacement
 * form) and P is the ARAP solution for the handle targets q. At fixed
 * rotations one global step gives P = M^-1 (b(R) + B q) (tsv_arap.c), so
 * dX/dq = Phi M^-1 B S, S scattering the k handles into the lattice; its
 * transpose is S^T B^T M^-1 Phi^T (M symmetric). The rotation refit is not
 * differentiated. */

static ffd_status arap_current(const ffd_tsv_arap *a, ffd_error *err)
{
    if (a->t->L->version != a->version)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "the lattice was refined since the drag began: begin a new drag");
    if (a->t->frozen_version != a->frozen_version)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "the frozen set changed since the drag began: begin a new drag");
    return need_phi(a->t, err);
}

ffd_status ffd_tsv_arap_sensitivity_product(ffd_tsv_arap *a, const double *v, double *out,
                                            ffd_error *err)
{
    if (!a || (!v && a->k) || (!out && a->t->n))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_tsv_arap_sensitivity_product: NULL argument");
    ffd_status st = arap_current(a, err);
    if (st != FFD_OK)
        return st;
    const ffd_tsv *t = a->t;
    size_t nv = t->L->nv;
    double *dq = ffd_calloc(nv ? nv : 1, 3 * sizeof *dq);
    double *dp = ffd_malloc_array(nv ? nv : 1, 3 * sizeof *dp);
    if (!dq || !dp) {
        ffd_free(dq);
        ffd_free(dp);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    }
    for (size_t h = 0; h < a->k; h++)
        memcpy(dq + 3 * (size_t)a->handles[h], v + 3 * h, 3 * sizeof *dq);
    st = ffd_tsv_arap_solver_linear(a->solver, dq, dp, 0, err);
    if (st == FFD_OK) {
        const tsv_phi *phi = &t->phi;
        const long long n = (long long)phi->rows;
#pragma omp parallel for schedule(static, 1024)
        for (long long ii = 0; ii < n; ii++) {
            size_t i = (size_t)ii;
            double x = 0, y = 0, z = 0;
            for (size_t k = phi->rowptr[i]; k < phi->rowptr[i + 1]; k++) {
                const double *d = dp + 3 * (size_t)phi->col[k];
                x += phi->val[k] * d[0];
                y += phi->val[k] * d[1];
                z += phi->val[k] * d[2];
            }
            out[3 * i] = x;
            out[3 * i + 1] = y;
            out[3 * i + 2] = z;
        }
    }
    ffd_free(dq);
    ffd_free(dp);
    return st;
}

ffd_status ffd_tsv_arap_sensitivity_transpose_product(ffd_tsv_arap *a, const double *w, double *out,
                                                      ffd_error *err)
{
    if (!a || (!w && a->t->n) || (!out && a->k))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "ffd_tsv_arap_sensitivity_transpose_product: NULL argument");
    ffd_status st = arap_current(a, err);
    if (st != FFD_OK)
        return st;
    const ffd_tsv *t = a->t;
    size_t nv = t->L->nv;
    double *g = ffd_calloc(nv ? nv : 1, 3 * sizeof *g);
    double *y = ffd_malloc_array(nv ? nv : 1, 3 * sizeof *y);
    if (!g || !y) {
        ffd_free(g);
        ffd_free(y);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    }
    /* Phi^T w: a scatter over the rows, in row order (deterministic) */
    const tsv_phi *phi = &t->phi;
    for (size_t i = 0; i < phi->rows; i++)
        for (size_t k = phi->rowptr[i]; k < phi->rowptr[i + 1]; k++) {
            double *gv = g + 3 * (size_t)phi->col[k];
            gv[0] += phi->val[k] * w[3 * i];
            gv[1] += phi->val[k] * w[3 * i + 1];
            gv[2] += phi->val[k] * w[3 * i + 2];
        }
    st = ffd_tsv_arap_solver_linear(a->solver, g, y, 1, err);
    if (st == FFD_OK)
        for (size_t h = 0; h < a->k; h++)
            memcpy(out + 3 * h, y + 3 * (size_t)a->handles[h], 3 * sizeof *out);
    ffd_free(g);
    ffd_free(y);
    return st;
}

ffd_status ffd_tsv_arap_global_step(ffd_tsv_arap *a, const double *targets, double *out,
                                    ffd_error *err)
{
    ffd_status st = arap_current(a, err);
    if (st != FFD_OK)
        return st;
    ffd_tsv *t = a->t;
    tsv_lattice *L = t->L;
    size_t nv = L->nv;
    double *q = ffd_malloc_array(nv ? nv : 1, 3 * sizeof *q);
    double *x = ffd_malloc_array(nv ? nv : 1, 3 * sizeof *x);
    if (!q || !x) {
        ffd_free(q);
        ffd_free(x);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    }
    memcpy(q, a->targets, 3 * nv * sizeof *q);
    for (size_t h = 0; h < a->k; h++)
        memcpy(q + 3 * (size_t)a->handles[h], targets + 3 * h, 3 * sizeof *q);
    st = ffd_tsv_arap_solver_global_step(a->solver, q, x, err);
    if (st == FFD_OK) {
        const tsv_phi *phi = &t->phi;
        for (size_t i = 0; i < phi->rows; i++)
            for (int c = 0; c < 3; c++) {
                double d = 0;
                for (size_t k = phi->rowptr[i]; k < phi->rowptr[i + 1]; k++) {
                    size_t v = phi->col[k];
                    d += phi->val[k] * (x[3 * v + c] - L->verts[v].P[TSV_REST][c]);
                }
                out[3 * i + c] = t->points[3 * i + c] + d;
            }
    }
    ffd_free(q);
    ffd_free(x);
    return st;
}

/* --- fold-over check --- */

static double det3(const double m[9])
{
    return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
           m[2] * (m[3] * m[7] - m[4] * m[6]);
}

/* The cofactor matrix of m applied to n: det(m) m^-T n, defined for singular m too. */
static void cofactor_apply(const double m[9], const double n[3], double out[3])
{
    double c[9] = {m[4] * m[8] - m[5] * m[7], m[5] * m[6] - m[3] * m[8], m[3] * m[7] - m[4] * m[6],
                   m[2] * m[7] - m[1] * m[8], m[0] * m[8] - m[2] * m[6], m[1] * m[6] - m[0] * m[7],
                   m[1] * m[5] - m[2] * m[4], m[2] * m[3] - m[0] * m[5], m[0] * m[4] - m[1] * m[3]};
    for (int r = 0; r < 3; r++)
        out[r] = c[3 * r] * n[0] + c[3 * r + 1] * n[1] + c[3 * r + 2] * n[2];
}

static void tri_normal(const double *a, const double *b, const double *c, double n[3])
{
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
}

void ffd_tsv_fold_report_free(ffd_tsv_fold_report *report)
{
    if (!report)
        return;
    ffd_free(report->folded_cells);
    ffd_free(report->inverted_faces);
    memset(report, 0, sizeof *report);
}

ffd_status ffd_tsv_check_folds(const ffd_tsv *t, uint32_t samples, ffd_tsv_fold_report *report,
                               ffd_error *err)
{
    memset(report, 0, sizeof *report);
    if (samples == 0)
        samples = 3;
    if (samples > 64)
        return ffd_fail(err, FFD_ERR_INVALID, "samples %u: expected <= 64", samples);
    const tsv_lattice *L = t->L;
    size_t nc = L->nc;
    uint8_t *folded = ffd_calloc(nc ? nc : 1, 1);
    double *cell_min = ffd_malloc_array(nc ? nc : 1, sizeof(double));
    if (!folded || !cell_min) {
        ffd_free(folded);
        ffd_free(cell_min);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    }
    size_t checked = 0;
#pragma omp parallel for schedule(dynamic, 8) reduction(+ : checked)
    for (size_t c = 0; c < nc; c++) {
        const tsv_cell *cell = &L->cells[c];
        double lo[3], hi[3];
        int volume = 1;
        for (int a = 0; a < 3; a++) {
            lo[a] = tsv_kappa(cell->lo[a]);
            hi[a] = tsv_kappa(cell->hi[a]);
            if (hi[a] <= lo[a])
                volume = 0;
        }
        cell_min[c] = INFINITY;
        if (!volume)
            continue;
        checked++;
        for (uint32_t i = 0; i < samples; i++)
            for (uint32_t j = 0; j < samples; j++)
                for (uint32_t l = 0; l < samples; l++) {
                    double p[3], x[3], J[9];
                    uint32_t ijl[3] = {i, j, l};
                    for (int a = 0; a < 3; a++)
                        p[a] = lo[a] + (hi[a] - lo[a]) * (ijl[a] + 0.5) / samples;
                    ffd_tsv_eval_point(L, t->S, TSV_CURRENT, p, x, J);
                    world_jacobian(L, J);
                    double d = det3(J);
                    if (d < cell_min[c])
                        cell_min[c] = d;
                    if (!(d > 0))
                        folded[c] = 1;
                }
    }
    report->cells_checked = checked;
    report->min_det = INFINITY;
    size_t nfold = 0;
    for (size_t c = 0; c < nc; c++) {
        if (cell_min[c] < report->min_det)
            report->min_det = cell_min[c];
        nfold += folded[c];
    }
    ffd_free(cell_min);
    if (nfold) {
        report->folded_cells = ffd_malloc_array(nfold, sizeof(uint32_t));
        if (!report->folded_cells) {
            ffd_free(folded);
            return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
        }
        for (size_t c = 0, k = 0; c < nc; c++)
            if (folded[c])
                report->folded_cells[k++] = (uint32_t)c;
        report->folded_cell_count = nfold;
    }
    ffd_free(folded);
    if (!t->face_count)
        return FFD_OK;

    /* inverted faces: the deformed normal against the Jacobian-mapped rest normal */
    double *x = ffd_malloc_array(t->n, 3 * sizeof(double));
    uint8_t *inv = ffd_calloc(t->face_count, 1);
    if (!x || !inv) {
        ffd_free(x);
        ffd_free(inv);
        ffd_tsv_fold_report_free(report);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    }
    if (t->has_phi) {
        ffd_tsv_phi_apply(&t->phi, L, TSV_CURRENT, x);
    } else {
        /* the same sums point by point (a term of Phi's zero entries adds
           nothing), without building Phi for one use */
        const size_t n = t->n;
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < n; i++)
            ffd_tsv_eval_point(L, t->S, TSV_CURRENT, t->params + 3 * i, x + 3 * i, NULL);
    }
    const size_t nfaces = t->face_count;
#pragma omp parallel for schedule(dynamic, 64)
    for (size_t f = 0; f < nfaces; f++) {
        uint32_t a0 = t->face_offsets[f], a1 = t->face_offsets[f + 1];
        double nr[3] = {0, 0, 0}, nd[3] = {0, 0, 0}, centre[3] = {0, 0, 0};
        for (uint32_t k = a0 + 1; k + 1 < a1; k++) {
            const uint32_t i0 = t->face_indices[a0], i1 = t->face_indices[k],
                           i2 = t->face_indices[k + 1];
            double r0[3], r1[3], r2[3], m[3];
            for (int a = 0; a < 3; a++) {
                r0[a] = L->box_min[a] + t->params[3 * i0 + a] * extent_of(L, a);
                r1[a] = L->box_min[a] + t->params[3 * i1 + a] * extent_of(L, a);
                r2[a] = L->box_min[a] + t->params[3 * i2 + a] * extent_of(L, a);
            }
            tri_normal(r0, r1, r2, m);
            for (int a = 0; a < 3; a++)
                nr[a] += m[a];
            tri_normal(x + 3 * i0, x + 3 * i1, x + 3 * i2, m);
            for (int a = 0; a < 3; a++)
                nd[a] += m[a];
        }
        for (uint32_t k = a0; k < a1; k++)
            for (int a = 0; a < 3; a++)
                centre[a] += t->params[3 * t->face_indices[k] + a] / (a1 - a0);
        double rest_area2 = nr[0] * nr[0] + nr[1] * nr[1] + nr[2] * nr[2];
        if (rest_area2 == 0)
            continue; /* degenerate at rest: nothing to invert */
        double y[3], J[9], expect[3];
        ffd_tsv_eval_point(L, t->S, TSV_CURRENT, centre, y, J);
        world_jacobian(L, J);
        /* cof(J) n is the image of an infinitesimal face's normal; times sign(det J)
           it is the normal an orientation-preserving map would give (J^-T n) */
        cofactor_apply(J, nr, expect);
        double sgn = det3(J) > 0 ? 1 : -1;
        if (!(sgn * (nd[0] * expect[0] + nd[1] * expect[1] + nd[2] * expect[2]) > 0))
            inv[f] = 1;
    }
    ffd_free(x);
    size_t ninv = 0;
    for (size_t f = 0; f < nfaces; f++)
        ninv += inv[f];
    if (ninv) {
        report->inverted_faces = ffd_malloc_array(ninv, sizeof(uint32_t));
        if (!report->inverted_faces) {
            ffd_free(inv);
            ffd_tsv_fold_report_free(report);
            return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
        }
        for (size_t f = 0, k = 0; f < nfaces; f++)
            if (inv[f])
                report->inverted_faces[k++] = (uint32_t)f;
        report->inverted_face_count = ninv;
    }
    ffd_free(inv);
    return FFD_OK;
}

/* --- any point set (ffd_deformer_bind) --- */

void ffd_tsv_points_free(tsv_points *p)
{
    if (!p)
        return;
    ffd_free(p->points);
    ffd_free(p->params);
    ffd_tsv_phi_free(&p->phi);
    ffd_free(p->tie);
    memset(p, 0, sizeof *p);
}

ffd_status ffd_tsv_points_bind(const ffd_tsv *t, const double *points, size_t n, tsv_points *out,
                               ffd_error *err)
{
    memset(out, 0, sizeof *out);
    out->points = ffd_malloc_array(n ? n : 1, 3 * sizeof(double));
    out->params = ffd_malloc_array(n ? n : 1, 3 * sizeof(double));
    if (!out->points || !out->params)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory binding %zu points", n);
    out->n = n;
    if (n)
        memcpy(out->points, points, n * 3 * sizeof(double));
    /* the linear parameterisation of §3.2, as ffd_tsv_create gives the object's */
    const tsv_lattice *L = t->L;
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            double s = (points[3 * i + a] - L->box_min[a]) / (L->box_max[a] - L->box_min[a]);
            out->params[3 * i + a] = s < 0 ? 0 : (s > 1 ? 1 : s);
        }
    return ffd_tsv_points_update(t, out, err);
}

ffd_status ffd_tsv_points_update(const ffd_tsv *t, tsv_points *p, ffd_error *err)
{
    /* the version only grows with committed topology (a refinement that
     * fails is rolled back with its version), so equal means the same lattice */
    if (p->has_phi && p->version == t->L->version)
        return FFD_OK;
    tsv_phi phi;
    ffd_status st = ffd_tsv_phi_build(t->L, t->S, p->params, p->n, &phi, err);
    if (st != FFD_OK)
        return st;
    ffd_tsv_phi_free(&p->phi);
    p->phi = phi;
    p->version = t->L->version;
    p->has_phi = 1;
    return FFD_OK;
}

void ffd_tsv_points_eval(const ffd_tsv *t, const tsv_points *p, double *out)
{
    ffd_tsv_phi_apply_displacement(&p->phi, t->L, p->points, out);
}

void ffd_tsv_points_jacobian(const ffd_tsv *t, const tsv_points *p, double *out)
{
    const tsv_lattice *L = t->L;
    long long n = (long long)p->n;
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < n; i++) {
        /* ffd_tsv_jacobian's formula: I + dD/d(s,t,u) diag(1/extent) */
        double d[3], *J = out + 9 * i;
        ffd_tsv_eval_displacement(L, t->S, p->params + 3 * i, d, J);
        world_jacobian(L, J);
        /* outside the box a parameter is clamped: the displacement does
         * not change along that axis there */
        for (int a = 0; a < 3; a++) {
            double x = p->points[3 * i + a];
            if (x < L->box_min[a] || x > L->box_max[a])
                J[a] = J[3 + a] = J[6 + a] = 0.0;
        }
        J[0] += 1.0;
        J[4] += 1.0;
        J[8] += 1.0;
    }
}

static size_t points_row(const void *self, size_t i, uint32_t *columns, double *weights)
{
    const tsv_points *p = self;
    size_t a = p->phi.rowptr[i], b = p->phi.rowptr[i + 1];
    memcpy(columns, p->phi.col + a, (b - a) * sizeof(uint32_t));
    memcpy(weights, p->phi.val + a, (b - a) * sizeof(double));
    return b - a;
}

ffd_status ffd_tsv_points_map(const ffd_tsv *t, tsv_points *p, ffd_linear_map *map,
                              ffd_error *err)
{
    size_t nv = t->L->nv;
    if (p->tie_count != nv) {
        uint32_t *tie = ffd_realloc_array(p->tie, nv ? nv : 1, sizeof(uint32_t));
        if (!tie)
            return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for %zu control points", nv);
        for (size_t v = 0; v < nv; v++)
            tie[v] = (uint32_t)v;
        p->tie = tie;
        p->tie_count = nv;
    }
    size_t max_nnz = 0;
    for (size_t i = 0; i < p->phi.rows; i++) {
        size_t k = p->phi.rowptr[i + 1] - p->phi.rowptr[i];
        if (k > max_nnz)
            max_nnz = k;
    }
    memset(map, 0, sizeof *map);
    map->self = p;
    map->point_count = p->n;
    map->column_count = nv;
    map->variable_count = nv;
    map->max_row_nnz = max_nnz ? max_nnz : 1;
    map->tie = p->tie;
    map->row = points_row;
    return FFD_OK;
}
