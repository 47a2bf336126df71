/* gffd_track.c — repositioning points in a changed field (Qin et al. 2003,
 * §3, Fig. 5): gradient tracking (eq. 3) and tracking along the direction of
 * a variational warp through corresponding skeleton points (eq. 4-6). */
#include "gffd/gffd.h"

#include <math.h>
#include <string.h>

/* Fig. 5 halves a step at most this many times before giving it up. */
#define GFFD_MAX_HALVINGS 60

/* delta = ln E(x) - ln e_0 (Fig. 5, in units of u); -inf where E(x) = 0,
 * i.e. outside every influence region. */
static double field_delta(const ffd_gffd_skeleton *s, const double x[3], double ln_e0,
                          double grad[3], double *e)
{
    *e = ffd_gffd_skeleton_field(s, x, grad);
    if (!(*e > 0))
        return -INFINITY;
    return log(*e) - ln_e0;
}



/* The warp's prediction W(p0, 1) - p0 (eq. 5); 0 when it does not move p0. */
static double warp_line(const ffd_gffd_warp *w, const double p0[3], double disp[3], double line[3])
{
    ffd_rbf_eval(&w->displacement, p0, disp, NULL);
    double len = norm3(disp);
    if (!(len > 0) || !isfinite(len))
        return 0;
    for (int k = 0; k < 3; k++)
        line[k] = disp[k] / len; /* eq. 6 */
    return len;
}

/* The state of one search. */
typedef struct search {
    double p[3], grad[3], e, d;
} search;

static void search_at(const ffd_gffd_skeleton *s, const double x[3], double ln_e0, search *q)
{
    memcpy(q->p, x, sizeof q->p);
    q->d = field_delta(s, x, ln_e0, q->grad, &q->e);
}

/* Not in the paper: a point that the edit left outside every influence
 * region (E = 0) has no gradient of E to follow. It is carried along the
 * gradient of the nearest primitive's own distance field to just inside
 * that primitive's radius, where gradient tracking takes over: E's gradient
 * is parallel to it, so the point follows the same path as its neighbours
 * that stayed inside, and the deformation has no jump where the moved
 * region's boundary passes. 0 when no primitive is in range. */
static int enter_region(const ffd_gffd_tracker *t, double ln_e0, search *q)
{
    const ffd_gffd_skeleton *s = t->field;
    double x[3];
    memcpy(x, q->p, sizeof x);
    for (int it = 0; it < 8; it++) {
        double f, df[3], r;
        if (!ffd_gffd_skeleton_nearest(s, x, &f, df, &r))
            return 0;
        double target = r * (1 - 1e-3), gn = norm3(df);
        if (f < r && ffd_gffd_skeleton_field(s, x, NULL) > 0)
            break;
        if (!(gn > 0) || !isfinite(gn))
            return 0;
        double step = (f - target) / (gn * gn); /* Newton on f(x) = target */
        if (!(fabs(step * gn) <= t->max_step))
            step = (step < 0 ? -t->max_step : t->max_step) / gn;
        for (int k = 0; k < 3; k++)
            x[k] -= step * df[k];
    }
    search n;
    search_at(s, x, ln_e0, &n);
    if (!(n.e > 0))
        return 0;
    *q = n;
    return 1;
}

/* Fig. 5 from q: restore the field value, stepping along the normalised
 * gradient (eq. 3), or along line when it is given. Steps are counted in
 * *iterations; returns 1 when |delta| < tolerance. */
static int fig5(const ffd_gffd_tracker *t, double ln_e0, const double *line, search *q,
                uint32_t *iterations)
{
    const ffd_gffd_skeleton *s = t->field;
    double sign = 1, scale = 1;
    if (!line && !(q->e > 0) && !enter_region(t, ln_e0, q))
        return 0; /* outside every field, and no primitive in range */
    for (uint32_t it = 0; fabs(q->d) >= t->tolerance; it++) {
        if (it >= t->max_iterations || scale < 1e-12 || !(q->e > 0))
            return 0; /* out of steps, stuck, or outside every field */
        (*iterations)++;
        double v[3], gn = norm3(q->grad);
        if (line) {
            memcpy(v, line, sizeof v);
        } else if (gn > 0) {
            for (int k = 0; k < 3; k++)
                v[k] = -q->grad[k] / gn;
        } else {
            return 0; /* a zero gradient gives no direction */
        }
        /* Fig. 5's step dV = delta V, with delta measured along V in the
         * field's own distance: delta / (grad(-ln E) . V). */
        double slope = -dot3(q->grad, v) / q->e;
        double step = (fabs(slope) > 0 && isfinite(slope)) ? q->d / slope : t->max_step;
        if (!isfinite(step) || fabs(step) > t->max_step)
            step = step < 0 ? -t->max_step : t->max_step;
        step *= sign * scale;
        search n;
        double x[3];
        for (int k = 0; k < 3; k++)
            x[k] = q->p[k] + step * v[k];
        search_at(s, x, ln_e0, &n);
        if (q->d * n.d < 0 && isfinite(n.d)) {
            /* The step crossed the iso-surface. Before Fig. 5's halving,
             * try the secant point of the bracket, which lands next to the
             * root: halving alone approaches it only linearly. */
            double shrink = q->d / (q->d - n.d);
            if (shrink > 0 && shrink < 1) {
                search t2;
                double y[3];
                for (int k = 0; k < 3; k++)
                    y[k] = q->p[k] + shrink * step * v[k];
                search_at(s, y, ln_e0, &t2);
                if (fabs(t2.d) < t->tolerance || q->d * t2.d > 0) {
                    step *= shrink;
                    n = t2;
                }
            }
        }
        for (int h = 0; q->d * n.d < 0 && h < GFFD_MAX_HALVINGS; h++) {
            step *= 0.5; /* the step crossed the iso-surface: halve it */
            for (int k = 0; k < 3; k++)
                x[k] = q->p[k] + step * v[k];
            search_at(s, x, ln_e0, &n);
        }
        if (fabs(n.d) < fabs(q->d)) {
            *q = n;
            sign = 1;
            scale = 1;
        } else if (sign > 0) {
            sign = -1; /* Fig. 5: dV = -dV */
        } else {
            sign = 1;
            scale *= 0.5;
        }
    }
    return 1;
}

int ffd_gffd_track_point(const ffd_gffd_tracker *t, const double p0[3], double e0, double out[3],
                         uint32_t *iterations, int *fallback, double *error)
{
    const ffd_gffd_skeleton *s = t->field;
    const double ln_e0 = log(e0);
    search start, best, q;
    *iterations = 0;
    *fallback = 0;
    search_at(s, p0, ln_e0, &start);
    double disp[3] = {0, 0, 0}, line[3] = {0, 0, 0};
    int has_line = t->warp && warp_line(t->warp, p0, disp, line) > 0;
    int gradient = t->mode == FFD_GFFD_TRACK_GRADIENT;
    if (fabs(start.d) < t->tolerance && (gradient || !has_line)) {
        /* gradient tracking: the field did not change here, no motion */
        memcpy(out, p0, 3 * sizeof(double));
        *error = fabs(start.d);
        return FFD_TRACK_UNCHANGED;
    }
    best = start;
    int ok = 0;
    if (gradient) {
        q = start;
        ok = fig5(t, ln_e0, NULL, &q, iterations);
        if (ok || fabs(q.d) < fabs(best.d))
            best = q;
    }
    if (!ok && has_line) {
        /* Warp tracking (gradient tracking's fallback): every influenced
         * point goes along V (eq. 6) to the warp's prediction W(p0) (eq. 5),
         * where the gradient restores its value: a rigid motion of the
         * skeleton is reproduced exactly, and a stretch along the skeleton
         * (where the field alone does not change) is followed. Failing
         * that, as the paper does, along the line through p0 in the
         * direction V. */
        *fallback = gradient;
        double w[3] = {p0[0] + disp[0], p0[1] + disp[1], p0[2] + disp[2]};
        search_at(s, w, ln_e0, &q);
        ok = fig5(t, ln_e0, NULL, &q, iterations);
        if (ok || fabs(q.d) < fabs(best.d))
            best = q;
        if (!ok) {
            q = start;
            ok = fig5(t, ln_e0, line, &q, iterations);
            if (ok || fabs(q.d) < fabs(best.d))
                best = q;
        }
    }
    if (!ok && !gradient) {
        q = start; /* warp tracking's last resort: the gradient from p0 */
        ok = fig5(t, ln_e0, NULL, &q, iterations);
        if (ok || fabs(q.d) < fabs(best.d))
            best = q;
    }
    double rot[3][3], shift[3];
    if (!ok && t->rest && ffd_gffd_skeleton_own_motion(t->rest, s, p0, rot, shift)) {
        /* Not in the paper: the primitive nearest to p0 moved rigidly, so
         * p0 moved with it has its value in that primitive's field; the
         * gradient restores it there. This catches points near the edge of
         * an influence region that the warp put outside every field. */
        *fallback = 1;
        double y[3];
        for (int k = 0; k < 3; k++)
            y[k] = rot[k][0] * p0[0] + rot[k][1] * p0[1] + rot[k][2] * p0[2] + shift[k];
        search_at(s, y, ln_e0, &q);
        ok = fig5(t, ln_e0, NULL, &q, iterations);
        if (ok || fabs(q.d) < fabs(best.d))
            best = q;
    }
    *error = fabs(best.d);
    memcpy(out, best.p, 3 * sizeof(double));
    if (ok)
        return FFD_TRACK_CONVERGED;
    return FFD_TRACK_FAILED;
}

/* The whole skeleton moved rigidly: the point moves with it, exactly
 * (its field value there is e0 up to rounding, whatever the tracking mode;
 * the motion came with the edit, so it holds for a point or a straight
 * polyline too, whose vertices cannot show a turn about themselves). */
static int rigid_point(const ffd_gffd_tracker *t, const double p0[3], double e0, double out[3],
                       double *error)
{
    for (int k = 0; k < 3; k++)
        out[k] = t->rot[k][0] * p0[0] + t->rot[k][1] * p0[1] + t->rot[k][2] * p0[2] + t->shift[k];
    double e = ffd_gffd_skeleton_field(t->field, out, NULL);
    *error = e > 0 ? fabs(log(e) - log(e0)) : INFINITY;
    return FFD_TRACK_CONVERGED;
}

ffd_status ffd_gffd_track_points(const ffd_gffd_tracker *t, const double *points,
                                 const double *e0, const double *weight, size_t n, double *out,
                                 ffd_gffd_track_report *report, ffd_error *err)
{
    unsigned char *state = ffd_malloc(n ? n : 1);
    uint32_t *iters = ffd_malloc_array(n ? n : 1, sizeof(uint32_t));
    double *errors = ffd_malloc_array(n ? n : 1, sizeof(double));
    if (!state || !iters || !errors) {
        ffd_free(state);
        ffd_free(iters);
        ffd_free(errors);
        return ffd_fail(err, FFD_ERR_NOMEM, "tracking %zu points: out of memory", n);
    }
    long long count = (long long)n;
    /* progress from the master thread only (ffd_progress_update ignores the
     * others); dynamic chunks are handed out in order, so its i grows */
    ffd_progress progress;
    ffd_progress_begin(&progress, "tracking");
#pragma omp parallel for schedule(dynamic, 64)
    for (long long i = 0; i < count; i++) {
        const double *p0 = points + 3 * i;
        ffd_progress_update(&progress, (double)i / (double)count);
        iters[i] = 0;
        errors[i] = 0;
        if (!(e0[i] > 0)) {
            memcpy(out + 3 * i, p0, 3 * sizeof(double));
            state[i] = FFD_TRACK_UNCHANGED;
            continue;
        }
        if (t->rigid) {
            state[i] = (unsigned char)rigid_point(t, p0, e0[i], out + 3 * i, &errors[i]);
        } else {
            int fb = 0;
            state[i] = (unsigned char)ffd_gffd_track_point(t, p0, e0[i], out + 3 * i, &iters[i],
                                                           &fb, &errors[i]);
            if (fb)
                state[i] |= 4;
        }
        /* the influence band: the displacement fades to zero towards the
         * boundary of the region (C^2), so that the mesh does not tear
         * there; a point that did not converge is blended the same way */
        double w = weight[i];
        if (w < 1 && (state[i] & 3) != FFD_TRACK_UNCHANGED) {
            double *x = out + 3 * i;
            if (w > 0)
                for (int k = 0; k < 3; k++)
                    x[k] = p0[k] + w * (x[k] - p0[k]);
            else
                memcpy(x, p0, 3 * sizeof(double));
        }
    }
    ffd_progress_end(&progress);
    ffd_gffd_track_report r;
    memset(&r, 0, sizeof r);
    for (size_t i = 0; i < n; i++) {
        int st = state[i] & 3;
        r.iterations += iters[i];
        if (state[i] & 4)
            r.fallback_count++;
        if (st == FFD_TRACK_UNCHANGED)
            continue;
        r.tracked++;
        if (isfinite(errors[i])) /* a point left outside every field has no finite error */
            r.max_error = fmax(r.max_error, errors[i]);
        if (st == FFD_TRACK_CONVERGED)
            r.converged++;
        else
            r.failed_count++;
    }
    ffd_status status = FFD_OK;
    if (report && r.failed_count) {
        r.failed = ffd_malloc_array(r.failed_count, sizeof(uint32_t));
        if (!r.failed) {
            status = ffd_fail(err, FFD_ERR_NOMEM, "tracking: out of memory");
        } else {
            size_t k = 0;
            for (size_t i = 0; i < n; i++)
                if ((state[i] & 3) == FFD_TRACK_FAILED)
                    r.failed[k++] = (uint32_t)i;
        }
    }
    if (report && status == FFD_OK)
        *report = r;
    ffd_free(state);
    ffd_free(iters);
    ffd_free(errors);
    return status;
}

void ffd_gffd_track_report_free(ffd_gffd_track_report *report)
{
    if (!report)
        return;
    ffd_free(report->failed);
    memset(report, 0, sizeof *report);
}
