/* pbffd — curve-based deformation (PB-FFD §3.5): an interpolating spline
 * (centripetal Catmull-Rom) through the control points is discretised into
 * EBFs with spherical ROIs and rotation-minimising frames (double reflection,
 * Wang, Jüttler, Zheng & Liu 2008); the enclosed points are parameterised in
 * them by an ordinary deformer, and moving a control point moves the samples
 * and their frames along the new curve. A master of small weight makes the
 * motion fade to zero on the ROI boundary. */
#include "pbffd/pbffd.h"

#include <math.h>
#include <string.h>

#define DEFAULT_CURVE_MASTER_WEIGHT 0.05
#define ARC_STEPS 64u  /* arc-length table resolution per segment */
#define FRAME_STEPS 8u /* double-reflection steps between samples */
#define MAX_SAMPLES 100000u
#define MIN_SAMPLES 8u

struct ffd_pbffd_curve {
    size_t count;
    double *cp; /* count by 3, current control points */
    double radius;
    size_t samples;
    double *u;           /* samples: global parameter, segment + local in [0, 1] */
    double *rest_speed;  /* samples: |dC/du| on the rest curve */
    double t0[3], r0[3]; /* rest frame at the first sample: tangent, normal */
    ffd_pbffd *pb;
};

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

/* Control point i, with reflected phantoms before the first and after the last. */
static void cp_at(const double *P, size_t count, long i, double o[3])
{
    for (int c = 0; c < 3; c++) {
        if (i < 0)
            o[c] = 2.0 * P[c] - P[3 + c];
        else if ((size_t)i >= count)
            o[c] = 2.0 * P[3 * (count - 1) + c] - P[3 * (count - 2) + c];
        else
            o[c] = P[3 * (size_t)i + c];
    }
}

/* Position and derivative at global parameter u in [0, count - 1]: the
 * centripetal Catmull-Rom segment between P_seg and P_seg+1 as a cubic
 * Hermite with the tangents of the non-uniform (knot spacing |dP|^1/2) form. */
static void curve_eval(const double *P, size_t count, double u, double x[3], double dx[3])
{
    size_t seg = u <= 0 ? 0 : (size_t)u;
    if (seg > count - 2)
        seg = count - 2;
    double s = u - (double)seg;
    double p[4][3];
    for (int k = 0; k < 4; k++)
        cp_at(P, count, (long)seg - 1 + k, p[k]);
    double d[3];
    for (int k = 0; k < 3; k++) {
        double e[3] = {p[k + 1][0] - p[k][0], p[k + 1][1] - p[k][1], p[k + 1][2] - p[k][2]};
        d[k] = sqrt(sqrt(dot3(e, e)));
    }
    double m1[3], m2[3];
    for (int c = 0; c < 3; c++) {
        m1[c] = ((p[1][c] - p[0][c]) / d[0] - (p[2][c] - p[0][c]) / (d[0] + d[1]) +
                 (p[2][c] - p[1][c]) / d[1]) *
                d[1];
        m2[c] = ((p[2][c] - p[1][c]) / d[1] - (p[3][c] - p[1][c]) / (d[1] + d[2]) +
                 (p[3][c] - p[2][c]) / d[2]) *
                d[1];
    }
    double s2 = s * s, s3 = s2 * s;
    double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s, h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
    double g00 = 6 * s2 - 6 * s, g10 = 3 * s2 - 4 * s + 1, g01 = -6 * s2 + 6 * s,
           g11 = 3 * s2 - 2 * s;
    for (int c = 0; c < 3; c++) {
        x[c] = h00 * p[1][c] + h10 * m1[c] + h01 * p[2][c] + h11 * m2[c];
        if (dx)
            dx[c] = g00 * p[1][c] + g10 * m1[c] + g01 * p[2][c] + g11 * m2[c];
    }
}

/* Samples evenly spaced in arc length on the rest curve. */
static ffd_status place_samples(ffd_pbffd_curve *cv, size_t samples, ffd_error *err)
{
    const size_t nseg = cv->count - 1, nt = nseg * ARC_STEPS + 1;
    double *len = ffd_malloc_array(nt, sizeof *len);
    if (!len)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory sampling the curve");
    double prev[3];
    curve_eval(cv->cp, cv->count, 0.0, prev, NULL);
    len[0] = 0;
    for (size_t k = 1; k < nt; k++) {
        double x[3];
        curve_eval(cv->cp, cv->count, (double)k / ARC_STEPS, x, NULL);
        double e[3] = {x[0] - prev[0], x[1] - prev[1], x[2] - prev[2]};
        len[k] = len[k - 1] + sqrt(dot3(e, e));
        memcpy(prev, x, sizeof prev);
    }
    double L = len[nt - 1];
    if (samples == 0) {
        double want = ceil(L / (cv->radius / 4.0)) + 1.0;
        if (!(want <= MAX_SAMPLES)) {
            ffd_free(len);
            return ffd_fail(err, FFD_ERR_INVALID,
                            "curve of length %g with radius %g needs %g samples (at most %u): "
                            "pass samples",
                            L, cv->radius, want, MAX_SAMPLES);
        }
        samples = want < MIN_SAMPLES ? MIN_SAMPLES : (size_t)want;
    }
    cv->samples = samples;
    cv->u = ffd_malloc_array(samples, sizeof *cv->u);
    cv->rest_speed = ffd_malloc_array(samples, sizeof *cv->rest_speed);
    if (!cv->u || !cv->rest_speed) {
        ffd_free(len);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory sampling the curve");
    }
    size_t k = 0;
    for (size_t i = 0; i < samples; i++) {
        double target = L * (double)i / (double)(samples - 1);
        while (k + 2 < nt && len[k + 1] < target)
            k++;
        double span = len[k + 1] - len[k];
        double f = span > 0 ? (target - len[k]) / span : 0.0;
        f = f < 0 ? 0 : (f > 1 ? 1 : f);
        cv->u[i] = ((double)k + f) / ARC_STEPS;
    }
    cv->u[samples - 1] = (double)nseg;
    ffd_free(len);
    return FFD_OK;
}

/* Minimal rotation taking unit a to unit b, applied to x (Rodrigues); about
 * the perpendicular axis r when b = -a. */
static void rotate_min(const double a[3], const double b[3], const double r[3], const double x[3],
                       double o[3])
{
    double v[3], c = dot3(a, b);
    cross3(a, b, v);
    if (c > -1.0 + 1e-12) {
        double vx[3], k = dot3(v, x) / (1.0 + c);
        cross3(v, x, vx);
        for (int i = 0; i < 3; i++)
            o[i] = x[i] * c + vx[i] + v[i] * k;
    } else {
        double k = 2.0 * dot3(r, x);
        for (int i = 0; i < 3; i++)
            o[i] = k * r[i] - x[i];
    }
}

static int normalize(double v[3])
{
    double l = sqrt(dot3(v, v));
    if (!(l > 0) || !isfinite(l))
        return 0;
    for (int c = 0; c < 3; c++)
        v[c] /= l;
    return 1;
}

/* EBFs of the samples on the curve through P: centres and rotation-minimising
 * frames (double reflection) scaled to the radius, the tangent axis also by
 * the stretch |C'| / |C'_rest|. Returns the first sample with a zero tangent,
 * or SIZE_MAX. */
static size_t curve_ebfs(const ffd_pbffd_curve *cv, const double *P, int rest, double t0[3],
                         double r0[3], ffd_ebf *out)
{
    double x[3], dx[3], t[3], r[3];
    curve_eval(P, cv->count, cv->u[0], x, dx);
    memcpy(t, dx, sizeof t);
    if (!normalize(t))
        return 0;
    if (rest) {
        /* any unit normal: the axis least aligned with the tangent, made perpendicular */
        int m = 0;
        for (int c = 1; c < 3; c++)
            if (fabs(t[c]) < fabs(t[m]))
                m = c;
        double e[3] = {0, 0, 0};
        e[m] = 1.0;
        double k = dot3(e, t);
        for (int c = 0; c < 3; c++)
            r[c] = e[c] - k * t[c];
        normalize(r);
        memcpy(t0, t, sizeof t);
        memcpy(r0, r, sizeof r);
    } else {
        rotate_min(t0, t, r0, r0, r);
        double k = dot3(r, t);
        for (int c = 0; c < 3; c++)
            r[c] -= k * t[c];
        if (!normalize(r))
            return 0;
    }
    double xp[3], tp[3];
    memcpy(xp, x, sizeof x);
    memcpy(tp, t, sizeof t);
    for (size_t i = 0; i < cv->samples; i++) {
        if (i > 0) {
            for (unsigned st = 1; st <= FRAME_STEPS; st++) {
                double u = cv->u[i - 1] + (cv->u[i] - cv->u[i - 1]) * st / FRAME_STEPS;
                double xn[3], tn[3];
                curve_eval(P, cv->count, u, xn, tn);
                if (!normalize(tn))
                    return i;
                /* double reflection (Wang et al. 2008, Algorithm 1) */
                double v1[3] = {xn[0] - xp[0], xn[1] - xp[1], xn[2] - xp[2]};
                double c1 = dot3(v1, v1);
                double rL[3], tL[3];
                memcpy(rL, r, sizeof r);
                memcpy(tL, tp, sizeof tp);
                if (c1 > 0) {
                    double kr = 2.0 / c1 * dot3(v1, r), kt = 2.0 / c1 * dot3(v1, tp);
                    for (int c = 0; c < 3; c++) {
                        rL[c] = r[c] - kr * v1[c];
                        tL[c] = tp[c] - kt * v1[c];
                    }
                }
                double v2[3] = {tn[0] - tL[0], tn[1] - tL[1], tn[2] - tL[2]};
                double c2 = dot3(v2, v2);
                if (c2 > 0) {
                    double k = 2.0 / c2 * dot3(v2, rL);
                    for (int c = 0; c < 3; c++)
                        r[c] = rL[c] - k * v2[c];
                } else {
                    memcpy(r, rL, sizeof r);
                }
                memcpy(xp, xn, sizeof xn);
                memcpy(tp, tn, sizeof tn);
            }
            /* keep the frame orthonormal against drift */
            double k = dot3(r, tp);
            for (int c = 0; c < 3; c++)
                r[c] -= k * tp[c];
            if (!normalize(r))
                return i;
        }
        curve_eval(P, cv->count, cv->u[i], x, dx);
        double speed = sqrt(dot3(dx, dx));
        if (!(speed > 0))
            return i;
        double s[3];
        cross3(tp, r, s);
        ffd_ebf *e = &out[i];
        memset(e, 0, sizeof *e);
        double stretch = rest ? 1.0 : speed / cv->rest_speed[i];
        for (int c = 0; c < 3; c++) {
            e->center[c] = x[c];
            e->frame[0][c] = tp[c] * cv->radius * stretch;
            e->frame[1][c] = r[c] * cv->radius;
            e->frame[2][c] = s[c] * cv->radius;
            e->radius[c] = cv->radius;
        }
    }
    return SIZE_MAX;
}

static ffd_status check_points(const double *P, size_t count, const char *what, ffd_error *err)
{
    for (size_t i = 0; i < count; i++)
        for (int c = 0; c < 3; c++)
            if (!isfinite(P[3 * i + c]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "%s[%zu]: not finite", what, i);
    for (size_t i = 0; i + 1 < count; i++)
        if (P[3 * i] == P[3 * i + 3] && P[3 * i + 1] == P[3 * i + 4] &&
            P[3 * i + 2] == P[3 * i + 5])
            return ffd_fail(err, FFD_ERR_INVALID,
                            "%s[%zu] and [%zu] coincide: consecutive control points must differ",
                            what, i, i + 1);
    return FFD_OK;
}

void ffd_pbffd_curve_destroy(ffd_pbffd_curve *cv)
{
    if (!cv)
        return;
    ffd_free(cv->cp);
    ffd_free(cv->u);
    ffd_free(cv->rest_speed);
    ffd_pbffd_destroy(cv->pb);
    ffd_free(cv);
}

ffd_status ffd_pbffd_curve_create(const double *control_points, size_t count, double radius,
                                  size_t samples, const double *points, size_t n,
                                  const ffd_pbffd_options *options, ffd_pbffd_curve **out,
                                  ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "out is NULL");
    *out = NULL;
    if (count < 2 || !control_points)
        return ffd_fail(err, FFD_ERR_INVALID, "count %zu: expected at least 2 control points",
                        count);
    if (!isfinite(radius))
        return ffd_fail(err, FFD_ERR_NONFINITE, "radius is not finite");
    if (!(radius > 0))
        return ffd_fail(err, FFD_ERR_INVALID, "radius %g: expected > 0", radius);
    if (samples == 1 || samples > MAX_SAMPLES)
        return ffd_fail(err, FFD_ERR_INVALID, "samples %zu: expected 0 or 2..%u", samples,
                        MAX_SAMPLES);
    ffd_status st = check_points(control_points, count, "control_points", err);
    if (st != FFD_OK)
        return st;
    ffd_pbffd_curve *cv = ffd_calloc(1, sizeof *cv);
    if (!cv)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory creating the curve");
    cv->count = count;
    cv->radius = radius;
    cv->cp = ffd_malloc_array(count, 3 * sizeof *cv->cp);
    if (!cv->cp) {
        ffd_pbffd_curve_destroy(cv);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory creating the curve");
    }
    memcpy(cv->cp, control_points, count * 3 * sizeof *cv->cp);
    if ((st = place_samples(cv, samples, err)) != FFD_OK) {
        ffd_pbffd_curve_destroy(cv);
        return st;
    }
    ffd_ebf *ebf = ffd_malloc_array(cv->samples, sizeof *ebf);
    if (!ebf) {
        ffd_pbffd_curve_destroy(cv);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory creating the curve");
    }
    for (size_t i = 0; i < cv->samples; i++) {
        double x[3], dx[3];
        curve_eval(cv->cp, count, cv->u[i], x, dx);
        cv->rest_speed[i] = sqrt(dot3(dx, dx));
    }
    size_t bad = curve_ebfs(cv, cv->cp, 1, cv->t0, cv->r0, ebf);
    if (bad != SIZE_MAX) {
        ffd_free(ebf);
        ffd_pbffd_curve_destroy(cv);
        return ffd_fail(err, FFD_ERR_INVALID, "the curve has no tangent at sample %zu", bad);
    }
    ffd_pbffd_options o;
    memset(&o, 0, sizeof o);
    if (options)
        o = *options;
    o.levels = 1;
    if (o.master_weight == 0)
        o.master_weight = DEFAULT_CURVE_MASTER_WEIGHT;
    st = ffd_pbffd_create(ebf, cv->samples, points, n, &o, &cv->pb, err);
    ffd_free(ebf);
    if (st != FFD_OK) {
        ffd_pbffd_curve_destroy(cv);
        return st;
    }
    *out = cv;
    return FFD_OK;
}

size_t ffd_pbffd_curve_control_count(const ffd_pbffd_curve *cv) { return cv->count; }
const double *ffd_pbffd_curve_control_points(const ffd_pbffd_curve *cv) { return cv->cp; }

ffd_status ffd_pbffd_curve_move(ffd_pbffd_curve *cv, size_t index, const double delta[3],
                                ffd_error *err)
{
    if (index >= cv->count)
        return ffd_fail(err, FFD_ERR_RANGE, "curve control point %zu out of range (%zu)", index,
                        cv->count);
    for (int c = 0; c < 3; c++)
        if (!isfinite(delta[c]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "curve move: delta is not finite");
    double *P = ffd_malloc_array(cv->count, 3 * sizeof *P);
    ffd_ebf *ebf = ffd_malloc_array(cv->samples, sizeof *ebf);
    ffd_status st =
        P && ebf ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "out of memory moving the curve");
    if (st == FFD_OK) {
        memcpy(P, cv->cp, cv->count * 3 * sizeof *P);
        for (int c = 0; c < 3; c++)
            P[3 * index + c] += delta[c];
        st = check_points(P, cv->count, "control_points", err);
    }
    if (st == FFD_OK) {
        double t0[3], r0[3];
        memcpy(t0, cv->t0, sizeof t0);
        memcpy(r0, cv->r0, sizeof r0);
        size_t bad = curve_ebfs(cv, P, 0, t0, r0, ebf);
        if (bad != SIZE_MAX)
            st =
                ffd_fail(err, FFD_ERR_INVALID, "the moved curve has no tangent at sample %zu", bad);
    }
    if (st == FFD_OK)
        for (size_t i = 0; i < cv->samples && st == FFD_OK; i++)
            if (ffd_ebf_frame_degenerate((const double(*)[3])ebf[i].frame))
                st = ffd_fail(err, FFD_ERR_INVALID,
                              "the moved curve has a degenerate frame at sample %zu", i);
    /* one level: placing a sample re-parameterises nothing and cannot fail */
    if (st == FFD_OK) {
        for (size_t i = 0; i < cv->samples; i++)
            ffd_pb_place(cv->pb, 0, i, ebf[i].center, (const double(*)[3])ebf[i].frame, NULL);
        memcpy(cv->cp, P, cv->count * 3 * sizeof *P);
    }
    ffd_free(P);
    ffd_free(ebf);
    return st;
}

ffd_status ffd_pbffd_curve_eval(const ffd_pbffd_curve *cv, double *out, ffd_error *err)
{
    return ffd_pbffd_eval(cv->pb, out, err);
}

int ffd_pbffd_curve_point_inside(const ffd_pbffd_curve *cv, size_t i)
{
    return ffd_pbffd_point_support(cv->pb, i) > 0;
}

ffd_pbffd *ffd_pb_curve_deformer(const ffd_pbffd_curve *cv)
{
    return cv->pb;
}
