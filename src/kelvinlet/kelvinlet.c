/* kelvinlet — regularised Kelvinlet brushes (de Goes and James, "Regularized
 * Kelvinlets: Sculpting Brushes based on Fundamental Solutions of
 * Elasticity", SIGGRAPH 2017, and its supplemental material).
 *
 * An infinite elastic medium (shear modulus mu, Poisson ratio nu) loaded by
 * a force density spread over a radius epsilon answers with a closed-form
 * displacement field. With a = 1/(4 pi mu), b = a / (4 (1 - nu)),
 * r = x - center and r_e = sqrt(|r|^2 + eps^2):
 *
 *   grab  (eq. 6)  u(r) = [ (a - b)/r_e I + b/r_e^3 r r^T + a eps^2/(2 r_e^3) I ] f
 *   affine (eq. 12) u(r) = -a (1/r_e^3 + 3 eps^2/(2 r_e^5)) F r
 *                          + b [ (F + F^T + tr(F) I) r / r_e^3 - 3 (r^T F r) r / r_e^5 ]
 *
 * the affine form being the response to the force couples F (twist: F skew,
 * scale: F = s I, pinch: F symmetric traceless). Their gradients are the
 * supplemental material's eq. 1 and 2. Each brush is calibrated so that
 * what it asks for happens at its center (§4-5): u(0) = (3a - 2b)/(2 eps) f
 * for a grab, and grad u(0) = (b (F + F^T + tr(F) I) - 5/2 a F) / eps^3 for
 * the affine loads (supplemental eq. 3). The calibration divides out mu,
 * which is therefore 1. The multi-scale extrapolation (§6) sums kernels
 * of radii eps_i with weights w_i whose far fields cancel. */
#include "ffd.h"
#include "kelvinlet/kelvinlet.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define KELVINLET_PI 3.14159265358979323846

const char *const ffd_kelvinlet_type_names[] = {"grab", "twist", "scale", "pinch", NULL};
const char *const ffd_kelvinlet_combine_names[] = {"superpose", "sequence", NULL};
const char *const ffd_kelvinlet_multiscale_names[] = {"single", "biscale", "triscale", NULL};

/* One brush ready to evaluate: its kernel's radii and weights, and the
 * calibrated load of one step (the whole brush when superposed). */
typedef struct brush_state {
    int active;          /* 0: the brush moves nothing and is skipped */
    int scales;          /* 1, 2 or 3 radii */
    double eps[3], w[3];
    double f[3];         /* grab: the force of one step */
    double F[3][3];      /* twist, scale, pinch: the force couple of one step */
    double step[3];      /* grab: how far its center moves per step (sequence) */
} brush_state;

struct ffd_kelvinlet {
    ffd_kelvinlet_brush *brushes;
    brush_state *state;
    size_t count;
    ffd_kelvinlet_options options; /* defaults filled in */
    double a, b;                   /* eq. 6's constants for mu = 1 */
};

/* ---- checks ---- */

static int finite3(const double v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

ffd_status ffd_kelvinlet_check_options(const ffd_kelvinlet_options *o, const char *where,
                                       ffd_error *err)
{
    if (!isfinite(o->poisson_ratio))
        return ffd_fail(err, FFD_ERR_NONFINITE, "%s: poisson_ratio: not a finite number", where);
    if (!(o->poisson_ratio >= 0 && o->poisson_ratio <= 0.5))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: poisson_ratio: %.17g is outside [0, 0.5] (0.5: the incompressible "
                        "limit)",
                        where, o->poisson_ratio);
    if ((unsigned)o->combine > FFD_KELVINLET_SEQUENCE)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: combine: unknown value %d", where,
                        (int)o->combine);
    if ((unsigned)o->multiscale > FFD_KELVINLET_TRISCALE)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: multiscale: unknown value %d", where,
                        (int)o->multiscale);
    if (o->steps > FFD_KELVINLET_MAX_STEPS)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: steps: %u is above the maximum %u", where,
                        o->steps, FFD_KELVINLET_MAX_STEPS);
    if (o->steps > 1 && o->combine != FFD_KELVINLET_SEQUENCE)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: steps: %u sub-steps need \"combine\": \"sequence\" (superposed "
                        "brushes act at the rest positions, in one step)",
                        where, o->steps);
    if (o->ratio != 0 && !(isfinite(o->ratio) && o->ratio > 1))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: ratio: %.17g is not a number > 1 (the multi-scale radii grow by it)",
                        where, o->ratio);
    return FFD_OK;
}

ffd_status ffd_kelvinlet_check_brush(const ffd_kelvinlet_brush *br, double nu, const char *where,
                                     ffd_error *err)
{
    if ((unsigned)br->type > FFD_KELVINLET_PINCH)
        return ffd_fail(err, FFD_ERR_INVALID, "%s.type: unknown brush type %d", where,
                        (int)br->type);
    if (!finite3(br->center))
        return ffd_fail(err, FFD_ERR_NONFINITE, "%s.center: not finite", where);
    if (!isfinite(br->radius))
        return ffd_fail(err, FFD_ERR_NONFINITE, "%s.radius: not finite", where);
    if (!(br->radius > 0))
        return ffd_fail(err, FFD_ERR_INVALID, "%s.radius: %.17g is not > 0", where, br->radius);
    switch (br->type) {
    case FFD_KELVINLET_GRAB:
        if (!finite3(br->displacement))
            return ffd_fail(err, FFD_ERR_NONFINITE, "%s.displacement: not finite", where);
        break;
    case FFD_KELVINLET_TWIST:
        if (!finite3(br->axis) || !isfinite(br->angle))
            return ffd_fail(err, FFD_ERR_NONFINITE, "%s: axis or angle not finite", where);
        if (br->axis[0] == 0 && br->axis[1] == 0 && br->axis[2] == 0)
            return ffd_fail(err, FFD_ERR_INVALID, "%s.axis: the zero vector has no direction",
                            where);
        break;
    case FFD_KELVINLET_SCALE:
        if (!isfinite(br->factor))
            return ffd_fail(err, FFD_ERR_NONFINITE, "%s.factor: not finite", where);
        if (!(br->factor > 0))
            return ffd_fail(err, FFD_ERR_INVALID, "%s.factor: %.17g is not > 0", where,
                            br->factor);
        /* eq. 12 with F = s I: the response is (2b - a) s (...) r, and 2b - a = 0 at nu = 0.5:
         * an incompressible medium cannot be scaled */
        if (nu >= 0.5 && br->factor != 1)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "%s: a scale brush changes volume, which an incompressible "
                            "material (poisson_ratio 0.5) cannot: use poisson_ratio < 0.5",
                            where);
        break;
    case FFD_KELVINLET_PINCH: {
        double big = 1, asym = 0;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                if (!isfinite(br->pinch[i][j]))
                    return ffd_fail(err, FFD_ERR_NONFINITE, "%s.pinch: not finite", where);
                big = fmax(big, fabs(br->pinch[i][j]));
                asym = fmax(asym, fabs(br->pinch[i][j] - br->pinch[j][i]));
            }
        double trace = br->pinch[0][0] + br->pinch[1][1] + br->pinch[2][2];
        if (asym > FFD_KELVINLET_TOL_PINCH * big)
            return ffd_fail(err, FFD_ERR_INVALID, "%s.pinch: not symmetric (asymmetry %.3g)",
                            where, asym);
        if (fabs(trace) > FFD_KELVINLET_TOL_PINCH * big)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "%s.pinch: trace %.17g is not 0 (a pinch keeps volume near its "
                            "center; use a scale brush for the trace)",
                            where, trace);
        break;
    }
    }
    return FFD_OK;
}

int ffd_kelvinlet_brush_inert(const ffd_kelvinlet_brush *br)
{
    switch (br->type) {
    case FFD_KELVINLET_GRAB:
        return br->displacement[0] == 0 && br->displacement[1] == 0 && br->displacement[2] == 0;
    case FFD_KELVINLET_TWIST:
        return br->angle == 0;
    case FFD_KELVINLET_SCALE:
        return br->factor == 1;
    case FFD_KELVINLET_PINCH:
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                if (br->pinch[i][j] != 0)
                    return 0;
        return 1;
    }
    return 1;
}

void ffd_kelvinlet_brush_make_inert(ffd_kelvinlet_brush *br)
{
    memset(br->displacement, 0, sizeof br->displacement);
    memset(br->pinch, 0, sizeof br->pinch);
    br->angle = 0;
    br->factor = 1;
}

/* ---- calibration ---- */

/* The multi-scale radii and weights (§6): eps_i = eps ratio^i; bi-scale
 * u_eps1 - u_eps2 cancels the 1/r far field; tri-scale weights with
 * sum w_i = 0 and sum w_i eps_i^2 = 0 cancel the 1/r and 1/r^3 terms too. */
static void scales(const ffd_kelvinlet *k, double eps, brush_state *s)
{
    double q = k->options.ratio;
    s->eps[0] = eps;
    s->eps[1] = eps * q;
    s->eps[2] = eps * q * q;
    switch (k->options.multiscale) {
    case FFD_KELVINLET_SINGLE:
        s->scales = 1;
        s->w[0] = 1;
        break;
    case FFD_KELVINLET_BISCALE:
        s->scales = 2;
        s->w[0] = 1;
        s->w[1] = -1;
        break;
    case FFD_KELVINLET_TRISCALE: {
        double e1 = s->eps[0] * s->eps[0], e2 = s->eps[1] * s->eps[1], e3 = s->eps[2] * s->eps[2];
        s->scales = 3;
        s->w[0] = 1;
        s->w[1] = -(e3 - e1) / (e3 - e2);
        s->w[2] = (e2 - e1) / (e3 - e2);
        break;
    }
    }
}

static void cross_matrix(const double q[3], double F[3][3])
{
    F[0][0] = 0, F[0][1] = -q[2], F[0][2] = q[1];
    F[1][0] = q[2], F[1][1] = 0, F[1][2] = -q[0];
    F[2][0] = -q[1], F[2][1] = q[0], F[2][2] = 0;
}

/* The calibrated load of one step of brush br (the whole brush for
 * superposition, 1/steps of it in a sequence). */
static void calibrate(const ffd_kelvinlet *k, const ffd_kelvinlet_brush *br, brush_state *s)
{
    const double a = k->a, b = k->b;
    const double steps = k->options.combine == FFD_KELVINLET_SEQUENCE ? k->options.steps : 1;
    memset(s, 0, sizeof *s);
    scales(k, br->radius, s);
    s->active = !ffd_kelvinlet_brush_inert(br);
    /* the centre responses of the kernels summed over the scales: a grab's
     * u(0) per unit force, and an affine load's grad u(0) per unit F up to
     * the bracket of supplemental eq. 3 */
    double g1 = 0, g3 = 0;
    for (int i = 0; i < s->scales; i++) {
        g1 += s->w[i] * (3 * a - 2 * b) / (2 * s->eps[i]);
        g3 += s->w[i] / (s->eps[i] * s->eps[i] * s->eps[i]);
    }
    switch (br->type) {
    case FFD_KELVINLET_GRAB:
        for (int c = 0; c < 3; c++) {
            s->step[c] = br->displacement[c] / steps;
            s->f[c] = s->step[c] / g1; /* u(0) = g1 f = the step */
        }
        break;
    case FFD_KELVINLET_TWIST: {
        /* F = [q]x: grad u(0) = -5/2 a g3 [q]x = (angle / steps) [axis]x */
        double n = sqrt(br->axis[0] * br->axis[0] + br->axis[1] * br->axis[1] +
                        br->axis[2] * br->axis[2]);
        double q[3], scale = (br->angle / steps) / (-2.5 * a * g3 * n);
        for (int c = 0; c < 3; c++)
            q[c] = br->axis[c] * scale;
        cross_matrix(q, s->F);
        break;
    }
    case FFD_KELVINLET_SCALE: {
        /* F = s I: grad u(0) = 5/2 (2b - a) g3 s I = (factor - 1) I when superposed; in a
         * sequence the field is a velocity whose flow over the steps is exp(steps (grad
         * u(0))) near the center, so log(factor) / steps there */
        double per = k->options.combine == FFD_KELVINLET_SEQUENCE ? log(br->factor) / steps
                                                                   : br->factor - 1;
        double sc = s->active ? per / (2.5 * (2 * b - a) * g3) : 0;
        for (int c = 0; c < 3; c++)
            s->F[c][c] = sc;
        break;
    }
    case FFD_KELVINLET_PINCH: {
        /* F symmetric traceless: grad u(0) = (2b - 5/2 a) g3 F = pinch / steps */
        double d = (2 * b - 2.5 * a) * g3 * steps;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                s->F[i][j] = br->pinch[i][j] / d;
        break;
    }
    }
}

/* ---- the kernels ---- */

/* Grab, eq. 6, and its gradient, supplemental eq. 1 (G[a][b] = du_a/dx_b),
 * added with weight w. */
static void grab_kernel(double a, double b, double eps, double w, const double r[3],
                        const double f[3], double u[3], double G[3][3])
{
    double r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2], e2 = eps * eps;
    double re = sqrt(r2 + e2), i1 = 1 / re, i3 = i1 * i1 * i1, i5 = i3 * i1 * i1;
    double rf = r[0] * f[0] + r[1] * f[1] + r[2] * f[2];
    double A = (a - b) * i1 + 0.5 * a * e2 * i3, B = b * i3;
    for (int c = 0; c < 3; c++)
        u[c] += w * (A * f[c] + B * rf * r[c]);
    if (!G)
        return;
    for (int p = 0; p < 3; p++)
        for (int q = 0; q < 3; q++) {
            double g = i3 * (b * ((p == q) * rf + r[p] * f[q] + f[p] * r[q]) - a * f[p] * r[q]) -
                       3 * i5 * (0.5 * a * e2 * f[p] + b * rf * r[p]) * r[q];
            G[p][q] += w * g;
        }
}

/* Affine loads, eq. 12, and the gradient, supplemental eq. 2. */
static void affine_kernel(double a, double b, double eps, double w, const double r[3],
                          const double F[3][3], double u[3], double G[3][3])
{
    double r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2], e2 = eps * eps;
    double re = sqrt(r2 + e2), i1 = 1 / re, i3 = i1 * i1 * i1, i5 = i3 * i1 * i1;
    double i7 = i5 * i1 * i1, tr = F[0][0] + F[1][1] + F[2][2];
    double M[3][3], Fr[3], Mr[3], rFr = 0;
    for (int p = 0; p < 3; p++)
        for (int q = 0; q < 3; q++)
            M[p][q] = b * (F[p][q] + F[q][p] + (p == q) * tr);
    for (int p = 0; p < 3; p++) {
        Fr[p] = F[p][0] * r[0] + F[p][1] * r[1] + F[p][2] * r[2];
        Mr[p] = M[p][0] * r[0] + M[p][1] * r[1] + M[p][2] * r[2];
        rFr += r[p] * Fr[p];
    }
    double c1 = -a * (i3 + 1.5 * e2 * i5);
    for (int p = 0; p < 3; p++)
        u[p] += w * (c1 * Fr[p] + Mr[p] * i3 - 3 * b * rFr * r[p] * i5);
    if (!G)
        return;
    /* (F + F^T) r, for r r^T (F + F^T) */
    double Sr[3];
    for (int p = 0; p < 3; p++)
        Sr[p] = Fr[p] + F[0][p] * r[0] + F[1][p] * r[1] + F[2][p] * r[2];
    for (int p = 0; p < 3; p++)
        for (int q = 0; q < 3; q++) {
            double g = i3 * (M[p][q] - a * F[p][q]) -
                       3 * i5 * (0.5 * a * e2 * F[p][q] + b * rFr * (p == q) + b * r[p] * Sr[q]) -
                       3 * i5 * (Mr[p] - a * Fr[p]) * r[q] +
                       15 * i7 * (0.5 * a * e2 * Fr[p] + b * rFr * r[p]) * r[q];
            G[p][q] += w * g;
        }
}

/* One step of brush s (center c) at x: adds its displacement to u and,
 * when G is not NULL, its gradient to G. */
static void brush_step(const ffd_kelvinlet *k, const ffd_kelvinlet_brush *br,
                       const brush_state *s, const double c[3], const double x[3], double u[3],
                       double G[3][3])
{
    double r[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]};
    for (int i = 0; i < s->scales; i++) {
        if (br->type == FFD_KELVINLET_GRAB)
            grab_kernel(k->a, k->b, s->eps[i], s->w[i], r, s->f, u, G);
        else
            affine_kernel(k->a, k->b, s->eps[i], s->w[i], r, s->F, u, G);
    }
}

/* ---- the handle ---- */

static void fill_defaults(ffd_kelvinlet_options *o)
{
    if (o->steps == 0)
        o->steps = 1;
    if (o->ratio == 0)
        o->ratio = 2;
}

static void calibrate_all(ffd_kelvinlet *k)
{
    for (size_t i = 0; i < k->count; i++)
        calibrate(k, &k->brushes[i], &k->state[i]);
}

ffd_status ffd_kelvinlet_create(const ffd_kelvinlet_brush *brushes, size_t count,
                                const ffd_kelvinlet_options *options, ffd_kelvinlet **out,
                                ffd_error *err)
{
    if (!out || (count && !brushes))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_kelvinlet_create: NULL argument");
    *out = NULL;
    ffd_kelvinlet_options o = {0};
    if (options)
        o = *options;
    ffd_status st = ffd_kelvinlet_check_options(&o, "kelvinlet", err);
    if (st)
        return st;
    fill_defaults(&o);
    for (size_t i = 0; i < count; i++) {
        char where[48];
        snprintf(where, sizeof where, "brushes[%zu]", i);
        if ((st = ffd_kelvinlet_check_brush(&brushes[i], o.poisson_ratio, where, err)))
            return st;
    }
    ffd_kelvinlet *k = ffd_calloc(1, sizeof *k);
    if (k) {
        k->brushes = ffd_malloc_array(count ? count : 1, sizeof *k->brushes);
        k->state = ffd_malloc_array(count ? count : 1, sizeof *k->state);
    }
    if (!k || !k->brushes || !k->state) {
        ffd_kelvinlet_destroy(k);
        return ffd_fail(err, FFD_ERR_NOMEM, "kelvinlet: out of memory for %zu brushes", count);
    }
    if (count)
        memcpy(k->brushes, brushes, count * sizeof *brushes);
    k->count = count;
    k->options = o;
    k->a = 1 / (4 * KELVINLET_PI); /* mu = 1 */
    k->b = k->a / (4 * (1 - o.poisson_ratio));
    calibrate_all(k);
    *out = k;
    return FFD_OK;
}

void ffd_kelvinlet_destroy(ffd_kelvinlet *k)
{
    if (!k)
        return;
    ffd_free(k->brushes);
    ffd_free(k->state);
    ffd_free(k);
}

size_t ffd_kelvinlet_brush_count(const ffd_kelvinlet *k)
{
    return k ? k->count : 0;
}

const ffd_kelvinlet_brush *ffd_kelvinlet_brush_at(const ffd_kelvinlet *k, size_t i)
{
    return k && i < k->count ? &k->brushes[i] : NULL;
}

void ffd_kelvinlet_get_options(const ffd_kelvinlet *k, ffd_kelvinlet_options *out)
{
    *out = k->options;
}

ffd_status ffd_kelvinlet_set_brush(ffd_kelvinlet *k, size_t i, const ffd_kelvinlet_brush *brush,
                                   ffd_error *err)
{
    if (!k || !brush)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_kelvinlet_set_brush: NULL argument");
    if (i >= k->count)
        return ffd_fail(err, FFD_ERR_RANGE, "brushes[%zu]: out of range (%zu brushes)", i,
                        k->count);
    char where[48];
    snprintf(where, sizeof where, "brushes[%zu]", i);
    ffd_status st = ffd_kelvinlet_check_brush(brush, k->options.poisson_ratio, where, err);
    if (st)
        return st;
    k->brushes[i] = *brush;
    calibrate(k, &k->brushes[i], &k->state[i]);
    return FFD_OK;
}

/* x' (and J = dx'/dx when J is not NULL) of one point. */
static void deform_point(const ffd_kelvinlet *k, const double x[3], double out[3], double J[3][3])
{
    if (J) {
        memset(J, 0, 9 * sizeof(double));
        J[0][0] = J[1][1] = J[2][2] = 1;
    }
    if (k->options.combine == FFD_KELVINLET_SUPERPOSE) {
        /* every brush at the rest position; a zero sum keeps the point's bits */
        double u[3] = {0, 0, 0}, G[3][3] = {{0}};
        for (size_t j = 0; j < k->count; j++)
            if (k->state[j].active)
                brush_step(k, &k->brushes[j], &k->state[j], k->brushes[j].center, x, u,
                           J ? G : NULL);
        for (int c = 0; c < 3; c++)
            out[c] = u[c] != 0 ? x[c] + u[c] : x[c];
        if (J)
            for (int p = 0; p < 3; p++)
                for (int q = 0; q < 3; q++)
                    J[p][q] += G[p][q];
        return;
    }
    /* sequence (§7): brush after brush, each brush's field a velocity
     * integrated over its steps with the classical Runge-Kutta rule (RK4)
     * from the current positions; a grab's center advances with the steps,
     * so the point at its center follows it to center + displacement */
    double p[3] = {x[0], x[1], x[2]};
    for (size_t j = 0; j < k->count; j++) {
        const brush_state *s = &k->state[j];
        if (!s->active)
            continue;
        const ffd_kelvinlet_brush *br = &k->brushes[j];
        for (uint32_t t = 0; t < k->options.steps; t++) {
            /* stage i at time t + tau[i], from p + frac[i] k_(i-1) */
            static const double tau[4] = {0, 0.5, 0.5, 1}, frac[4] = {0, 0.5, 0.5, 1};
            static const double weight[4] = {1.0 / 6, 2.0 / 6, 2.0 / 6, 1.0 / 6};
            double kv[4][3], KG[4][3][3], sum[3] = {0, 0, 0}, JS[3][3] = {{0}};
            for (int i = 0; i < 4; i++) {
                double c[3], q[3], G[3][3] = {{0}};
                for (int a = 0; a < 3; a++) {
                    c[a] = br->center[a] + (t + tau[i]) * s->step[a];
                    q[a] = i ? p[a] + frac[i] * kv[i - 1][a] : p[a];
                    kv[i][a] = 0;
                }
                brush_step(k, br, s, c, q, kv[i], J ? G : NULL);
                if (J) { /* K_i = G_i (I + frac_i K_(i-1)) */
                    for (int r = 0; r < 3; r++)
                        for (int col = 0; col < 3; col++) {
                            double v = G[r][col];
                            if (i)
                                v += frac[i] * (G[r][0] * KG[i - 1][0][col] +
                                                G[r][1] * KG[i - 1][1][col] +
                                                G[r][2] * KG[i - 1][2][col]);
                            KG[i][r][col] = v;
                        }
                }
                for (int a = 0; a < 3; a++)
                    sum[a] += weight[i] * kv[i][a];
                if (J)
                    for (int r = 0; r < 3; r++)
                        for (int col = 0; col < 3; col++)
                            JS[r][col] += weight[i] * KG[i][r][col];
            }
            if (J) { /* J <- (I + JS) J */
                double N[3][3];
                for (int r = 0; r < 3; r++)
                    for (int q = 0; q < 3; q++)
                        N[r][q] = J[r][q] + JS[r][0] * J[0][q] + JS[r][1] * J[1][q] +
                                  JS[r][2] * J[2][q];
                memcpy(J, N, sizeof N);
            }
            for (int a = 0; a < 3; a++)
                if (sum[a] != 0)
                    p[a] += sum[a];
        }
    }
    memcpy(out, p, sizeof p);
}

static ffd_status check_points(const double *points, size_t n, const char *what, ffd_error *err)
{
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(points[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "%s: point %zu is not finite", what, i / 3);
    return FFD_OK;
}

ffd_status ffd_kelvinlet_eval(const ffd_kelvinlet *k, const double *points, size_t n, double *out,
                              ffd_error *err)
{
    if (!k || (n && (!points || !out)))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_kelvinlet_eval: NULL argument");
    ffd_status st = check_points(points, n, "kelvinlet eval", err);
    if (st)
        return st;
    const ptrdiff_t m = (ptrdiff_t)n;
#pragma omp parallel for schedule(static)
    for (ptrdiff_t i = 0; i < m; i++) {
        double y[3];
        deform_point(k, points + 3 * i, y, NULL);
        memcpy(out + 3 * i, y, sizeof y);
    }
    return FFD_OK;
}

ffd_status ffd_kelvinlet_jacobian(const ffd_kelvinlet *k, const double *points, size_t n,
                                  double *out, ffd_error *err)
{
    if (!k || (n && (!points || !out)))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_kelvinlet_jacobian: NULL argument");
    ffd_status st = check_points(points, n, "kelvinlet Jacobian", err);
    if (st)
        return st;
    const ptrdiff_t m = (ptrdiff_t)n;
#pragma omp parallel for schedule(static)
    for (ptrdiff_t i = 0; i < m; i++) {
        double y[3], J[3][3];
        deform_point(k, points + 3 * i, y, J);
        memcpy(out + 9 * i, J, sizeof J);
    }
    return FFD_OK;
}

size_t ffd_kelvinlet_grab_count(const ffd_kelvinlet *k)
{
    size_t g = 0;
    for (size_t j = 0; k && j < k->count; j++)
        g += k->brushes[j].type == FFD_KELVINLET_GRAB;
    return g;
}

ffd_status ffd_kelvinlet_grab_blocks(const ffd_kelvinlet *k, const double *points, size_t n,
                                     double *blocks, ffd_error *err)
{
    if (!k || (n && (!points || !blocks)))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_kelvinlet_grab_blocks: NULL argument");
    if (k->options.combine != FFD_KELVINLET_SUPERPOSE)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "kelvinlet: brushes in a sequence are not linear in the grabs' "
                        "displacements: no sensitivity blocks");
    ffd_status st = check_points(points, n, "kelvinlet grab blocks", err);
    if (st)
        return st;
    const size_t grabs = ffd_kelvinlet_grab_count(k);
    const ptrdiff_t m = (ptrdiff_t)n;
#pragma omp parallel for schedule(static)
    for (ptrdiff_t i = 0; i < m; i++) {
        size_t g = 0;
        for (size_t j = 0; j < k->count; j++) {
            const ffd_kelvinlet_brush *br = &k->brushes[j];
            if (br->type != FFD_KELVINLET_GRAB)
                continue;
            /* eq. 6 with the calibrated force f = d / g1 is linear in d: column c of the
             * block is the response to the unit displacement e_c */
            brush_state s;
            ffd_kelvinlet_brush unit = *br;
            double *K = blocks + 9 * ((size_t)i * grabs + g++);
            for (int c = 0; c < 3; c++) {
                memset(unit.displacement, 0, sizeof unit.displacement);
                unit.displacement[c] = 1;
                calibrate(k, &unit, &s);
                double u[3] = {0, 0, 0};
                brush_step(k, &unit, &s, br->center, points + 3 * i, u, NULL);
                for (int r = 0; r < 3; r++)
                    K[3 * r + c] = u[r];
            }
        }
    }
    return FFD_OK;
}
