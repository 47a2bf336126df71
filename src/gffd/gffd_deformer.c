/* gffd_deformer.c — the ffd_gffd handle (Qin et al. 2003): binding records
 * each point's field value (§3), the skeleton is edited or replaced (§5),
 * and tracking puts the points back on their iso-surfaces. */
#include "gffd/gffd.h"

#include <math.h>
#include <string.h>

/* The largest |f/u| the exponentials of eq. 2 may meet, far below where exp
 * overflows or underflows to zero. */
#define GFFD_MAX_EXPONENT 600.0

struct ffd_gffd {
    ffd_gffd_skeleton *rest, *cur;
    int replaced;                 /* cur is another skeleton, not an edit of rest */
    ffd_gffd_options opt;         /* defaults resolved */
    size_t n;
    double *points;               /* n by 3, as bound */
    double *e0;                   /* n recorded field values */
    double *weight;               /* n blend weights in the influence band (GFFD_BAND) */
    size_t influenced;
    /* automatic correspondences: the rest skeleton's vertices */
    size_t auto_count;
    double *auto_from;
    ffd_rbf_factor auto_factor;
    int has_auto_factor;
    /* user correspondences */
    size_t user_count;
    ffd_gffd_warp user_warp;
};

static void warp_release(ffd_gffd_warp *w)
{
    if (w->has_factor)
        ffd_rbf_factor_free(&w->factor);
    if (w->fitted)
        ffd_rbf_free(&w->displacement);
    memset(w, 0, sizeof *w);
}

static ffd_status resolve_options(const ffd_gffd_options *o, ffd_gffd_options *r, ffd_error *err)
{
    memset(r, 0, sizeof *r);
    if (o)
        *r = *o;
    if (!isfinite(r->unit) || r->unit < 0 || r->unit > 1e100)
        return ffd_fail(err, FFD_ERR_INVALID, "unit %g: expected > 0 (0: automatic)", r->unit);
    if (!isfinite(r->tolerance) || r->tolerance < 0 || r->tolerance > 1)
        return ffd_fail(err, FFD_ERR_INVALID, "tolerance %g: expected in (0, 1] (0: default)",
                        r->tolerance);
    if (r->tolerance == 0)
        r->tolerance = 1e-6;
    if (r->max_iterations == 0)
        r->max_iterations = 100;
    if (r->max_iterations > 100000)
        return ffd_fail(err, FFD_ERR_INVALID, "max_iterations %u: expected <= 100000",
                        r->max_iterations);
    if (r->tracking != FFD_GFFD_TRACK_GRADIENT && r->tracking != FFD_GFFD_TRACK_WARP)
        return ffd_fail(err, FFD_ERR_INVALID, "unknown tracking mode %d", (int)r->tracking);
    if (r->max_samples == 0)
        r->max_samples = 4000;
    return FFD_OK;
}

void ffd_gffd_destroy(ffd_gffd *g)
{
    if (!g)
        return;
    ffd_gffd_skeleton_destroy(g->rest);
    ffd_gffd_skeleton_destroy(g->cur);
    ffd_free(g->points);
    ffd_free(g->e0);
    ffd_free(g->weight);
    ffd_free(g->auto_from);
    if (g->has_auto_factor)
        ffd_rbf_factor_free(&g->auto_factor);
    warp_release(&g->user_warp);
    ffd_free(g);
}

/* The unit of eq. 2 must keep every exponent of a skeleton in range. */
static ffd_status check_unit(const ffd_gffd_skeleton *s, double unit, ffd_error *err)
{
    double lo[3], hi[3];
    ffd_gffd_skeleton_bounds(s, lo, hi);
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    double reach = (diag + 2 * s->max_radius) / unit;
    if (!(reach <= GFFD_MAX_EXPONENT))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "unit %g is too small for this skeleton: distances up to %g would reach "
                        "exp(-%g); use a unit of at least %g",
                        unit, diag + 2 * s->max_radius, reach,
                        (diag + 2 * s->max_radius) / GFFD_MAX_EXPONENT);
    return FFD_OK;
}

ffd_status ffd_gffd_create(const ffd_gffd_primitive *skeleton, size_t count, const double *points,
                           size_t n, const ffd_gffd_options *options, ffd_gffd **out,
                           ffd_error *err)
{
    *out = NULL;
    ffd_gffd_options opt;
    ffd_status st = resolve_options(options, &opt, err);
    if (st != FFD_OK)
        return st;
    if (n > 0 && !points)
        return ffd_fail(err, FFD_ERR_INVALID, "points missing");
    if (n > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "too many points (%zu)", n);
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(points[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "point %zu is not finite", i / 3);
    ffd_gffd *g = ffd_calloc(1, sizeof *g);
    if (!g)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    g->opt = opt;
    st = ffd_gffd_skeleton_create(skeleton, count, opt.max_samples, &g->rest, err);
    if (st != FFD_OK)
        goto fail;
    /* u: 1/10 of the diagonal of the points and the skeleton together */
    if (opt.unit == 0) {
        double lo[3], hi[3];
        ffd_gffd_skeleton_bounds(g->rest, lo, hi);
        for (size_t i = 0; i < n; i++)
            for (int k = 0; k < 3; k++) {
                lo[k] = fmin(lo[k], points[3 * i + k]);
                hi[k] = fmax(hi[k], points[3 * i + k]);
            }
        double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                           (hi[2] - lo[2]) * (hi[2] - lo[2]));
        g->opt.unit = diag > 0 ? diag / 10 : g->rest->max_radius;
    }
    st = check_unit(g->rest, g->opt.unit, err);
    if (st != FFD_OK)
        goto fail;
    ffd_gffd_skeleton_set_unit(g->rest, g->opt.unit);
    st = ffd_gffd_skeleton_copy(g->rest, &g->cur, err);
    if (st != FFD_OK)
        goto fail;

    g->n = n;
    g->points = ffd_malloc_array(n ? n : 1, 3 * sizeof(double));
    g->e0 = ffd_malloc_array(n ? n : 1, sizeof(double));
    g->weight = ffd_malloc_array(n ? n : 1, sizeof(double));
    g->auto_count = ffd_gffd_correspondence_count(g->rest);
    g->auto_from = ffd_malloc_array(g->auto_count, 3 * sizeof(double));
    if (!g->points || !g->e0 || !g->weight || !g->auto_from) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "out of memory binding %zu points", n);
        goto fail;
    }
    if (n)
        memcpy(g->points, points, n * 3 * sizeof(double));
    ffd_gffd_correspondences(g->rest, g->rest, g->auto_from, NULL);
    /* the warp's factor over P_j0 depends on the rest skeleton only: factor once */
    if (g->auto_count <= opt.max_samples) {
        st = ffd_rbf_factor_create(g->auto_from, g->auto_count, &g->auto_factor, err);
        if (st != FFD_OK)
            goto fail;
        g->has_auto_factor = 1;
    }

    /* bind (§3): e_0 = E(P) in the rest field, and the blend weight of the
     * influence band */
    ffd_gffd_bind_values(g, points, n, g->e0, g->weight);
    for (size_t i = 0; i < n; i++)
        g->influenced += g->e0[i] > 0;
    *out = g;
    return FFD_OK;
fail:
    ffd_gffd_destroy(g);
    return st;
}

size_t ffd_gffd_point_count(const ffd_gffd *g)
{
    return g->n;
}

size_t ffd_gffd_influenced_count(const ffd_gffd *g)
{
    return g->influenced;
}

double ffd_gffd_unit(const ffd_gffd *g)
{
    return g->opt.unit;
}

size_t ffd_gffd_primitive_count(const ffd_gffd *g)
{
    return g->cur->count;
}

ffd_status ffd_gffd_get_primitive(const ffd_gffd *g, size_t index, ffd_gffd_primitive *out,
                                  ffd_error *err)
{
    if (index >= g->cur->count)
        return ffd_fail(err, FFD_ERR_RANGE, "skeleton[%zu]: out of range (%zu primitives)", index,
                        g->cur->count);
    ffd_gffd_skeleton_describe(g->cur, index, out);
    return FFD_OK;
}

int ffd_gffd_regularised(const ffd_gffd *g)
{
    for (size_t i = 0; i < g->cur->count; i++)
        if (g->cur->parts[i].regularised)
            return 1;
    for (size_t i = 0; i < g->rest->count; i++)
        if (g->rest->parts[i].regularised)
            return 1;
    return 0;
}

const double *ffd_gffd_bound_values(const ffd_gffd *g)
{
    return g->e0;
}

const double *ffd_gffd_bound_weights(const ffd_gffd *g)
{
    return g->weight;
}

ffd_status ffd_gffd_transform(ffd_gffd *g, size_t index, const double rotation[9],
                              const double translation[3], ffd_error *err)
{
    if (index >= g->cur->count)
        return ffd_fail(err, FFD_ERR_RANGE, "skeleton[%zu]: out of range (%zu primitives)", index,
                        g->cur->count);
    if (!rotation || !translation)
        return ffd_fail(err, FFD_ERR_INVALID, "skeleton[%zu]: rotation or translation missing",
                        index);
    double rot[3][3], shift[3];
    for (int a = 0; a < 3; a++) {
        shift[a] = translation[a];
        if (!isfinite(shift[a]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "skeleton[%zu]: translation is not finite",
                            index);
        for (int b = 0; b < 3; b++) {
            rot[a][b] = rotation[3 * a + b];
            if (!isfinite(rot[a][b]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "skeleton[%zu]: rotation is not finite",
                                index);
        }
    }
    /* a proper rotation: R R^T = I and det R = 1, to 1e-12 */
    double worst = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            double d = rot[a][0] * rot[b][0] + rot[a][1] * rot[b][1] + rot[a][2] * rot[b][2];
            worst = fmax(worst, fabs(d - (a == b)));
        }
    double det = rot[0][0] * (rot[1][1] * rot[2][2] - rot[1][2] * rot[2][1]) -
                 rot[0][1] * (rot[1][0] * rot[2][2] - rot[1][2] * rot[2][0]) +
                 rot[0][2] * (rot[1][0] * rot[2][1] - rot[1][1] * rot[2][0]);
    if (!(worst <= 1e-12) || !(det > 0))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "skeleton[%zu]: not a rotation (|R R^T - I| = %.3g, det %.17g)", index,
                        worst, det);
    /* the moved primitive must keep the exponents of eq. 2 in range too */
    ffd_gffd_part *q = &g->cur->parts[index];
    size_t nv = q->geom.vertex_count;
    double *moved = ffd_malloc_array(nv, 3 * sizeof(double));
    if (!moved)
        return ffd_fail(err, FFD_ERR_NOMEM, "skeleton[%zu]: out of memory", index);
    for (size_t i = 0; i < nv; i++) {
        const double *x = q->geom.vertices + 3 * i;
        for (int k = 0; k < 3; k++)
            moved[3 * i + k] = rot[k][0] * x[0] + rot[k][1] * x[1] + rot[k][2] * x[2] + shift[k];
    }
    double *old = q->geom.vertices;
    q->geom.vertices = moved;
    ffd_status st = check_unit(g->cur, g->opt.unit, err);
    for (size_t i = 0; st == FFD_OK && i < 3 * nv; i++)
        if (!(fabs(moved[i]) <= 1e100))
            st = ffd_fail(err, FFD_ERR_INVALID,
                          "skeleton[%zu]: vertex %zu: coordinate %g beyond 1e100", index, i / 3,
                          moved[i]);
    q->geom.vertices = old;
    if (st == FFD_OK && !q->collinear) {
        /* the vertices determine the motion: exactly ffd_gffd_set_vertices
         * (a Kabsch fit moves the field), so that a replay of the vertices
         * (the editor's) gives the same result bitwise */
        st = ffd_gffd_set_vertices(g, index, moved, err);
        ffd_free(moved);
        return st;
    }
    ffd_free(moved);
    if (st != FFD_OK)
        return st;
    ffd_gffd_skeleton_transform(g->cur, index, (const double(*)[3])rot, shift);
    return FFD_OK;
}

ffd_status ffd_gffd_set_vertices(ffd_gffd *g, size_t index, const double *vertices,
                                 ffd_error *err)
{
    if (index >= g->cur->count)
        return ffd_fail(err, FFD_ERR_RANGE, "skeleton[%zu]: out of range (%zu primitives)", index,
                        g->cur->count);
    if (!vertices)
        return ffd_fail(err, FFD_ERR_INVALID, "skeleton[%zu]: vertices missing", index);
    /* the new skeleton must keep the exponents of eq. 2 in range too */
    ffd_gffd_part *q = &g->cur->parts[index];
    double *old = q->geom.vertices;
    q->geom.vertices = (double *)vertices;
    ffd_status st = check_unit(g->cur, g->opt.unit, err);
    q->geom.vertices = old;
    if (st != FFD_OK)
        return st;
    /* the alignment's scratch first: on error nothing changes */
    double *scratch = NULL;
    if (!g->replaced) {
        size_t nv = ffd_gffd_skeleton_vertex_count(g->rest);
        scratch = ffd_malloc_array(nv ? nv : 1, 6 * sizeof(double));
        if (!scratch)
            return ffd_fail(err, FFD_ERR_NOMEM, "skeleton[%zu]: out of memory", index);
    }
    st = ffd_gffd_skeleton_set_vertices(g->cur, index, vertices, g->opt.max_samples, err);
    if (st == FFD_OK) {
        ffd_gffd_skeleton_set_unit(g->cur, g->opt.unit);
        if (!g->replaced)
            ffd_gffd_skeleton_align(g->cur, g->rest, scratch);
    }
    ffd_free(scratch);
    return st;
}

ffd_status ffd_gffd_replace(ffd_gffd *g, const ffd_gffd_primitive *skeleton, size_t count,
                            ffd_error *err)
{
    ffd_gffd_skeleton *s = NULL;
    ffd_status st = ffd_gffd_skeleton_create(skeleton, count, g->opt.max_samples, &s, err);
    if (st == FFD_OK)
        st = check_unit(s, g->opt.unit, err);
    if (st != FFD_OK) {
        ffd_gffd_skeleton_destroy(s);
        return st;
    }
    ffd_gffd_skeleton_set_unit(s, g->opt.unit);
    ffd_gffd_skeleton_destroy(g->cur);
    g->cur = s;
    g->replaced = 1;
    return FFD_OK;
}

ffd_status ffd_gffd_reset(ffd_gffd *g, ffd_error *err)
{
    ffd_gffd_skeleton *s = NULL;
    ffd_status st = ffd_gffd_skeleton_copy(g->rest, &s, err);
    if (st != FFD_OK)
        return st;
    ffd_gffd_skeleton_destroy(g->cur);
    g->cur = s;
    g->replaced = 0;
    return ffd_gffd_set_correspondences(g, NULL, NULL, 0, err);
}

/* Fits the warp W(x, 1) - x through sources -> targets (eq. 4) on a factor of the sources. */
static ffd_status fit_warp(const ffd_rbf_factor *factor, const double *from, const double *to,
                           size_t k, ffd_rbf *out, ffd_error *err)
{
    double *disp = ffd_malloc_array(k, 3 * sizeof(double));
    if (!disp)
        return ffd_fail(err, FFD_ERR_NOMEM, "warp: out of memory");
    for (size_t i = 0; i < 3 * k; i++)
        disp[i] = to[i] - from[i];
    ffd_status st = ffd_rbf_fit(factor, disp, 3, out, err);
    ffd_free(disp);
    return st;
}

ffd_status ffd_gffd_set_correspondences(ffd_gffd *g, const double *from, const double *to,
                                        size_t k, ffd_error *err)
{
    ffd_gffd_warp w;
    memset(&w, 0, sizeof w);
    if (k > 0) {
        if (!from || !to)
            return ffd_fail(err, FFD_ERR_INVALID, "correspondences missing");
        for (size_t i = 0; i < 3 * k; i++)
            if (!isfinite(from[i]) || !isfinite(to[i]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "correspondence %zu is not finite", i / 3);
        ffd_status st = ffd_rbf_factor_create(from, k, &w.factor, err);
        if (st == FFD_OK) {
            w.has_factor = 1;
            st = fit_warp(&w.factor, from, to, k, &w.displacement, err);
        }
        if (st != FFD_OK) {
            warp_release(&w);
            return st;
        }
        w.fitted = 1;
    }
    warp_release(&g->user_warp);
    g->user_count = k;
    g->user_warp = w;
    return FFD_OK;
}

/* The warp for the current state: the user's, or the edit's (rest vertices
 * -> current vertices) fitted on the cached factor. *local is set when the
 * caller must free warp->displacement. */
static ffd_status current_warp(const ffd_gffd *g, ffd_gffd_warp *warp, const ffd_gffd_warp **use,
                               int *local, ffd_error *err)
{
    *use = NULL;
    *local = 0;
    if (g->user_count) {
        *use = &g->user_warp;
        return FFD_OK;
    }
    if (g->replaced || !g->has_auto_factor)
        return FFD_OK;
    double *to = ffd_malloc_array(g->auto_count, 3 * sizeof(double));
    if (!to)
        return ffd_fail(err, FFD_ERR_NOMEM, "warp: out of memory");
    ffd_gffd_correspondences(g->rest, g->cur, NULL, to); /* the sources are auto_from */
    memset(warp, 0, sizeof *warp);
    ffd_status st = fit_warp(&g->auto_factor, g->auto_from, to, g->auto_count,
                             &warp->displacement, err);
    ffd_free(to);
    if (st != FFD_OK)
        return st;
    warp->fitted = 1;
    *use = warp;
    *local = 1;
    return FFD_OK;
}

/* Shared by ffd_gffd_track and the resampler: tracks n points with values
 * e0 and blend weights weight. */
ffd_status ffd_gffd_track_with(const ffd_gffd *g, const double *points, const double *e0,
                               const double *weight, size_t n, double *out,
                               ffd_gffd_track_report *report, ffd_error *err);
ffd_status ffd_gffd_track_with(const ffd_gffd *g, const double *points, const double *e0,
                               const double *weight, size_t n, double *out,
                               ffd_gffd_track_report *report, ffd_error *err)
{
    ffd_gffd_warp local_warp;
    const ffd_gffd_warp *warp;
    int local;
    ffd_status st = current_warp(g, &local_warp, &warp, &local, err);
    if (st != FFD_OK)
        return st;
    if (g->opt.tracking == FFD_GFFD_TRACK_WARP && !warp) {
        return ffd_fail(err, FFD_ERR_INVALID,
                        g->replaced ? "warp tracking after a skeleton replacement needs "
                                      "correspondences (P_j0 -> P_j1)"
                                    : "warp tracking needs correspondences: the skeleton has "
                                      "too many vertices for automatic ones");
    }
    ffd_gffd_tracker t;
    memset(&t, 0, sizeof t);
    t.field = g->cur;
    t.rest = g->replaced ? NULL : g->rest;
    /* an edit that moved the whole skeleton rigidly moves the points with
     * it, in either mode (the user's correspondences, when given, rule) */
    t.rigid = !g->replaced && !g->user_count &&
              ffd_gffd_skeleton_motion(g->cur, g->rest, t.rot, t.shift);
    t.warp = warp;
    t.mode = g->opt.tracking;
    t.tolerance = g->opt.tolerance;
    t.max_iterations = g->opt.max_iterations;
    t.max_step = 2 * g->cur->max_radius;
    st = ffd_gffd_track_points(&t, points, e0, weight, n, out, report, err);
    if (local)
        ffd_rbf_free(&local_warp.displacement);
    return st;
}

ffd_status ffd_gffd_track(const ffd_gffd *g, double *out, ffd_gffd_track_report *report,
                          ffd_error *err)
{
    if (report)
        memset(report, 0, sizeof *report);
    return ffd_gffd_track_with(g, g->points, g->e0, g->weight, g->n, out, report, err);
}

ffd_status ffd_gffd_field(const ffd_gffd *g, int current, const double *points, size_t n,
                          double *values, double *gradients, ffd_error *err)
{
    if (n > 0 && (!points || !values))
        return ffd_fail(err, FFD_ERR_INVALID, "points or values missing");
    const ffd_gffd_skeleton *s = current ? g->cur : g->rest;
    for (size_t i = 0; i < n; i++)
        values[i] = ffd_gffd_skeleton_field(s, points + 3 * i, gradients ? gradients + 3 * i : NULL);
    return FFD_OK;
}

void ffd_gffd_bind_values(const ffd_gffd *g, const double *points, size_t n, double *e0,
                          double *weight)
{
    /* one loop for ffd_gffd_create's points and any others */
    long long count_ll = (long long)n;
    const ffd_gffd_skeleton *rest = g->rest;
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < count_ll; i++)
        e0[i] = ffd_gffd_skeleton_field_weight(rest, points + 3 * i, &weight[i]);
}
