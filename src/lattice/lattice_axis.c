/* lattice_axis — one axis of a general lattice: its basis (linear,
 * Kochanek-Bartels cardinal, uniform cubic B-spline, Bernstein), its rest map
 * and the exact inverse of the rest map.
 *
 * Cardinal / TCB (Kochanek & Bartels 1984, eq. 8-9 with bias 0): on the
 * segment p_i -> p_{i+1} with local t, P(t) = h00 p_i + h10 d_i + h01 p_{i+1}
 * + h11 d_{i+1}, the outgoing tangent d_i = A (p_i - p_{i-1}) + B (p_{i+1} - p_i)
 * and the incoming one d_{i+1} = B (p_{i+1} - p_i) + A (p_{i+2} - p_{i+1}),
 * A = (1-T)(1+C)/2, B = (1-T)(1-C)/2 (T tension, C continuity; T = C = 0 is
 * Catmull-Rom). The ends use linearly extrapolated phantom points
 * p_{-1} = 2 p_0 - p_1 and p_res = 2 p_{res-1} - p_{res-2}, folded into the
 * weights of the real control points. On nodes j the spline of the values j
 * (the rest lattice, phantoms included) is, per segment, i + g(t) with
 * g(t) = (1-T) t + T (3t^2 - 2t^3): continuity drops out (A + B = 1 - T), and
 * g' = (1-T) + 6T t(1-t) > 0 on [0,1] exactly when -2 < T < 1, so the rest
 * map is a monotone cubic there and is inverted by bracketed Newton.
 *
 * The rest map f(S) of an axis is the 1D spline of its nodes' normalised
 * coordinates: linear and cardinal f = (i + g(t)) / nseg, B-spline as the
 * fast path (tripled border; uniform and so f = S / res when periodic),
 * Bernstein f = S (linear precision). */
#include "lattice/lattice.h"
#include "math/tolerance.h"

#include <math.h>
#include <string.h>

static const char *const interp_names[] = {"default", "linear", "cardinal", "catmull-rom",
                                           "bspline", "bernstein"};

ffd_status ffd_lattice_axis_init(ffd_lattice_axis *ax, ffd_interp interp, double tension,
                                 double continuity, uint32_t res, int periodic, const char *name,
                                 ffd_error *err)
{
    memset(ax, 0, sizeof *ax);
    if (interp < FFD_INTERP_LINEAR || interp > FFD_INTERP_BERNSTEIN)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: unknown interpolation %d", name, (int)interp);
    if (interp == FFD_INTERP_CATMULL_ROM) {
        interp = FFD_INTERP_CARDINAL;
        tension = continuity = 0;
    }
    if (interp != FFD_INTERP_CARDINAL)
        tension = continuity = 0;
    const char *iname = interp_names[interp];
    uint32_t lo = periodic ? 3 : 2;
    uint32_t hi = interp == FFD_INTERP_BERNSTEIN ? FFD_BERNSTEIN_MAX_RES : FFD_LATTICE_MAX_RES;
    if (periodic && interp == FFD_INTERP_BERNSTEIN)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: the bernstein basis cannot be periodic (a closed theta axis "
                        "spanning 2 pi); use linear, cardinal, catmull-rom or bspline",
                        name);
    if (res < lo || res > hi)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: resolution %u outside [%u, %u] for %s%s interpolation", name, res, lo,
                        hi, periodic ? "periodic " : "", iname);
    if (!(tension >= -1.0 && tension < 1.0))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: tension %g outside [-1, 1) (the cardinal rest map is a monotone "
                        "cubic, invertible, only for tension < 1)",
                        name, tension);
    if (!(continuity >= -1.0 && continuity <= 1.0))
        return ffd_fail(err, FFD_ERR_INVALID, "%s: continuity %g outside [-1, 1]", name,
                        continuity);
    ax->interp = interp;
    ax->tension = tension;
    ax->continuity = continuity;
    ax->res = res;
    ax->periodic = periodic;
    if (interp == FFD_INTERP_BSPLINE && !periodic &&
        ffd_bspline_rest_knots(res, &ax->knots) != FFD_OK)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    return FFD_OK;
}

void ffd_lattice_axis_release(ffd_lattice_axis *ax)
{
    ffd_free(ax->knots);
    ax->knots = NULL;
}

/* Segments of the axis (B-spline not periodic: res + 1 knot spans). */
static uint32_t segments(const ffd_lattice_axis *ax)
{
    if (ax->interp == FFD_INTERP_BERNSTEIN)
        return 1;
    if (ax->periodic)
        return ax->res;
    return ax->interp == FFD_INTERP_BSPLINE ? ax->res + 1 : ax->res - 1;
}

double ffd_lattice_axis_top(const ffd_lattice_axis *ax) { return (double)segments(ax); }

double ffd_lattice_axis_node(const ffd_lattice_axis *ax, uint32_t j)
{
    return (double)j / (double)(ax->periodic ? ax->res : ax->res - 1);
}

/* Segment of S and its local t in [0,1] (the last segment closed). */
static uint32_t segment_of(const ffd_lattice_axis *ax, double S, double *t)
{
    uint32_t nseg = segments(ax);
    uint32_t i = S <= 0 ? 0 : (S >= nseg ? nseg - 1 : (uint32_t)S);
    *t = S - (double)i;
    return i;
}

double ffd_cardinal_rest(double T, double t, double *dg)
{
    if (dg)
        *dg = (1.0 - T) + 6.0 * T * t * (1.0 - t);
    return (1.0 - T) * t + T * (t * t * (3.0 - 2.0 * t));
}

double ffd_cardinal_invert(double T, double y)
{
    if (T == 0.0 || y <= 0.0 || y >= 1.0)
        return y <= 0.0 ? 0.0 : (y >= 1.0 ? 1.0 : y);
    /* g is increasing on [0,1]: keep a bracket [lo, hi] around the root and
     * take Newton's step when it stays inside, else bisect */
    double lo = 0.0, hi = 1.0, t = y;
    for (int it = 0; it < 200; it++) {
        double dg, r = ffd_cardinal_rest(T, t, &dg) - y;
        if (r == 0.0)
            return t;
        if (r < 0)
            lo = t;
        else
            hi = t;
        double next = t - r / dg;
        if (!(next > lo && next < hi))
            next = 0.5 * (lo + hi);
        int done = fabs(next - t) <= 0.25 * FFD_TOL_CUBIC || next == t;
        t = next;
        if (done)
            break;
    }
    /* one last Newton step from the bracket's better end polishes the last bit */
    double dg, r = ffd_cardinal_rest(T, t, &dg) - y;
    double polished = t - r / dg;
    if (polished >= lo && polished <= hi &&
        fabs(ffd_cardinal_rest(T, polished, NULL) - y) < fabs(r))
        t = polished;
    return t;
}

double ffd_lattice_axis_rest(const ffd_lattice_axis *ax, double S, double *dfdS)
{
    double t, dg = 1.0, g;
    uint32_t i;
    switch (ax->interp) {
    case FFD_INTERP_BERNSTEIN:
        if (dfdS)
            *dfdS = 1.0;
        return S;
    case FFD_INTERP_BSPLINE:
        if (!ax->periodic)
            return ffd_bspline_rest_map(ax->res, S, dfdS);
        /* the uniform B-spline reproduces linear functions: f = S / res */
        if (dfdS)
            *dfdS = 1.0 / ax->res;
        return S / ax->res;
    case FFD_INTERP_CARDINAL:
        i = segment_of(ax, S, &t);
        g = ffd_cardinal_rest(ax->tension, t, &dg);
        break;
    default: /* linear */
        i = segment_of(ax, S, &t);
        g = t;
        break;
    }
    double nseg = (double)segments(ax);
    if (dfdS)
        *dfdS = dg / nseg;
    return ((double)i + g) / nseg;
}

double ffd_lattice_axis_invert(const ffd_lattice_axis *ax, double x)
{
    x = x < 0 ? 0 : (x > 1 ? 1 : x);
    if (ax->interp == FFD_INTERP_BERNSTEIN)
        return x;
    if (ax->interp == FFD_INTERP_BSPLINE && !ax->periodic)
        return ffd_bspline_invert(ax->res, ax->knots, x);
    uint32_t nseg = segments(ax);
    double y = x * nseg;
    if (ax->interp != FFD_INTERP_CARDINAL || ax->tension == 0.0)
        return y; /* linear, periodic B-spline, Catmull-Rom: f = S / nseg */
    uint32_t i = y >= nseg ? nseg - 1 : (uint32_t)y;
    return (double)i + ffd_cardinal_invert(ax->tension, y - (double)i);
}

/* Adds weight w (and derivative dw) of index k to the unique list. */
static uint32_t add_weight(const ffd_lattice_axis *ax, int64_t k, double w, double d, uint32_t *idx,
                           double *wt, double *dwt, uint32_t n)
{
    if (ax->periodic) {
        int64_t r = (int64_t)ax->res;
        k = ((k % r) + r) % r;
    }
    for (uint32_t e = 0; e < n; e++)
        if (idx[e] == (uint32_t)k) {
            wt[e] += w;
            if (dwt)
                dwt[e] += d;
            return n;
        }
    idx[n] = (uint32_t)k;
    wt[n] = w;
    if (dwt)
        dwt[n] = d;
    return n + 1;
}

/* Adds the weight of slot k of an interpolating spline with phantom ends:
 * p_{-1} = 2 p_0 - p_1, p_res = 2 p_{res-1} - p_{res-2}. */
static uint32_t add_phantom(const ffd_lattice_axis *ax, int64_t k, double w, double d,
                            uint32_t *idx, double *wt, double *dwt, uint32_t n)
{
    int64_t r = (int64_t)ax->res;
    if (ax->periodic || (k >= 0 && k < r))
        return add_weight(ax, k, w, d, idx, wt, dwt, n);
    if (k < 0) {
        n = add_weight(ax, 0, 2 * w, 2 * d, idx, wt, dwt, n);
        return add_weight(ax, 1, -w, -d, idx, wt, dwt, n);
    }
    n = add_weight(ax, r - 1, 2 * w, 2 * d, idx, wt, dwt, n);
    return add_weight(ax, r - 2, -w, -d, idx, wt, dwt, n);
}

uint32_t ffd_lattice_axis_weights(const ffd_lattice_axis *ax, double S, uint32_t *idx, double *w,
                                  double *dw)
{
    double b[FFD_AXIS_MAX_SUPPORT], d[FFD_AXIS_MAX_SUPPORT], t;
    uint32_t n = 0, i;
    switch (ax->interp) {
    case FFD_INTERP_BERNSTEIN:
        ffd_bernstein_basis(ax->res - 1, S, b, dw ? d : NULL);
        for (uint32_t k = 0; k < ax->res; k++) {
            idx[k] = k;
            w[k] = b[k];
            if (dw)
                dw[k] = d[k];
        }
        return ax->res;
    case FFD_INTERP_BSPLINE:
        if (!ax->periodic) { /* the tripled border: slot e -> control ffd_bspline_tie */
            uint32_t sigma = ffd_bspline_segment(S, ax->res);
            ffd_bspline_basis(S - sigma, b, d);
            for (uint32_t k = 0; k < 4; k++)
                n = add_weight(ax, ffd_bspline_tie(sigma + k, ax->res), b[k], d[k], idx, w, dw, n);
            return n;
        }
        i = segment_of(ax, S, &t);
        ffd_bspline_basis(t, b, d);
        for (uint32_t k = 0; k < 4; k++)
            n = add_weight(ax, (int64_t)i - 1 + k, b[k], d[k], idx, w, dw, n);
        return n;
    case FFD_INTERP_CARDINAL: {
        i = segment_of(ax, S, &t);
        double t2 = t * t, t3 = t2 * t;
        double h00 = 2 * t3 - 3 * t2 + 1, h10 = t3 - 2 * t2 + t;
        double h01 = -2 * t3 + 3 * t2, h11 = t3 - t2;
        double e00 = 6 * t2 - 6 * t, e10 = 3 * t2 - 4 * t + 1;
        double e01 = -6 * t2 + 6 * t, e11 = 3 * t2 - 2 * t;
        double T = ax->tension, C = ax->continuity;
        double A = (1 - T) * (1 + C) / 2, B = (1 - T) * (1 - C) / 2;
        /* the tangents expanded over p_{i-1}, p_i, p_{i+1}, p_{i+2} */
        double ww[4] = {-A * h10, h00 + (A - B) * h10 - B * h11, h01 + B * h10 + (B - A) * h11,
                        A * h11};
        double dd[4] = {-A * e10, e00 + (A - B) * e10 - B * e11, e01 + B * e10 + (B - A) * e11,
                        A * e11};
        for (uint32_t k = 0; k < 4; k++)
            n = add_phantom(ax, (int64_t)i - 1 + k, ww[k], dd[k], idx, w, dw, n);
        return n;
    }
    default: /* linear */
        i = segment_of(ax, S, &t);
        n = add_weight(ax, i, 1.0 - t, -1.0, idx, w, dw, n);
        return add_weight(ax, (int64_t)i + 1, t, 1.0, idx, w, dw, n);
    }
}
