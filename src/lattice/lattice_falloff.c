/* lattice_falloff — a smooth falloff outside the lattice (Blender's lattice
 * and proportional editing, Maya's lattice "outside falloff"): instead of the
 * hard choice between "fixed" and "clamp", a point outside the box moves by
 * the displacement of its clamped point (as "clamp") times f(d / D), d its
 * distance to the box, D the falloff distance. f(0) = 1 makes the map
 * continuous across the boundary; f = 0 for d >= D leaves the point's bits.
 *
 * The map is x' = x + f(x) c(x), c the clamped displacement, so
 *   J = I + f dc/dx + c (grad f)^T,  grad f = f'(r) / D grad d,
 * and it stays linear in the control points: the rows of W are the clamped
 * rows scaled by f (lattice_map.c, lattice_eval.c, lattice_sensitivity.c). */
#include "lattice/lattice.h"

#include <math.h>
#include <string.h>

double ffd_falloff_value(ffd_falloff_curve curve, double r, double *dfdr)
{
    double f = 0.0, df = 0.0;
    if (r < 0)
        r = 0;
    if (r < 1) {
        switch (curve) {
        case FFD_FALLOFF_LINEAR:
            f = 1.0 - r;
            df = -1.0;
            break;
        case FFD_FALLOFF_SPHERE: /* Blender's sqrt(2t - t^2), t = 1 - r */
            f = sqrt(1.0 - r * r);
            df = f > 0 ? -r / f : 0.0;
            break;
        case FFD_FALLOFF_SHARP:
            f = (1.0 - r) * (1.0 - r);
            df = -2.0 * (1.0 - r);
            break;
        case FFD_FALLOFF_SMOOTH:
        default: /* smootherstep S(r) = r^3 (10 - 15 r + 6 r^2), f = 1 - S: C2 at both ends */
            f = 1.0 - r * r * r * (10.0 + r * (-15.0 + 6.0 * r));
            df = -30.0 * r * r * (1.0 - r) * (1.0 - r);
            break;
        }
    }
    if (dfdr)
        *dfdr = df;
    return f;
}

/* The clamped point of x (origin + A clamp(local)), and which local
 * coordinates were inside [0,1] (their axis moves the clamped point). */
static void clamped_point(const ffd_lattice *lat, const double x[3], double c[3], int free_axis[3])
{
    double loc[3];
    for (int a = 0; a < 3; a++) {
        double l = 0;
        for (int k = 0; k < 3; k++)
            l += lat->dual[a][k] * (x[k] - lat->box.origin[k]);
        free_axis[a] = l > 0 && l < 1;
        loc[a] = l < 0 ? 0 : l > 1 ? 1 : l;
    }
    for (int k = 0; k < 3; k++)
        c[k] = lat->box.origin[k] + loc[0] * lat->box.axes[0][k] + loc[1] * lat->box.axes[1][k] +
               loc[2] * lat->box.axes[2][k];
}

ffd_status ffd_lattice_bind_falloff(const ffd_lattice *lat, const double *points, size_t n,
                                    double distance, ffd_falloff_curve curve,
                                    ffd_lattice_binding **out, ffd_error *err)
{
    *out = NULL;
    if (!(distance > 0) || !isfinite(distance))
        return ffd_fail(err, FFD_ERR_INVALID, "falloff distance %g: expected a finite number > 0",
                        distance);
    if (curve < FFD_FALLOFF_SMOOTH || curve > FFD_FALLOFF_SHARP)
        return ffd_fail(err, FFD_ERR_INVALID, "unknown falloff curve %d", (int)curve);
    if (lat->gen)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "falloff: only on a box lattice with one "
                                                  "B-spline or Bernstein basis on every axis");
    ffd_lattice_binding *b = NULL;
    ffd_status st = ffd_lattice_bind(lat, points, n, FFD_OUTSIDE_CLAMP, &b, err);
    if (st)
        return st;
    const size_t nout = n - b->inside_count;
    b->outside = FFD_OUTSIDE_FALLOFF;
    b->falloff = ffd_malloc_array(n ? n : 1, sizeof *b->falloff);
    b->falloff_grad = ffd_malloc_array(nout ? nout : 1, 3 * sizeof *b->falloff_grad);
    if (!b->falloff || !b->falloff_grad) {
        ffd_lattice_binding_destroy(b);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory binding %zu points", n);
    }
    for (size_t i = 0; i < n; i++)
        b->falloff[i] = 1.0;
    for (size_t o = 0; o < nout; o++) {
        const double *x = b->out_point + 3 * o;
        double c[3], v[3], g[3] = {0, 0, 0};
        int free_axis[3];
        clamped_point(lat, x, c, free_axis);
        double d = 0;
        for (int k = 0; k < 3; k++) {
            v[k] = x[k] - c[k];
            d += v[k] * v[k];
        }
        d = sqrt(d);
        double dfdr, f = ffd_falloff_value(curve, d / distance, &dfdr);
        if (d > 0 && dfdr != 0) {
            /* grad d = (I - dc/dx)^T v / d, dc/dx = sum over free axes a of axes[a] dual[a]^T */
            for (int k = 0; k < 3; k++)
                g[k] = v[k];
            for (int a = 0; a < 3; a++) {
                if (!free_axis[a])
                    continue;
                double va = v[0] * lat->box.axes[a][0] + v[1] * lat->box.axes[a][1] +
                            v[2] * lat->box.axes[a][2];
                for (int k = 0; k < 3; k++)
                    g[k] -= va * lat->dual[a][k];
            }
            for (int k = 0; k < 3; k++)
                g[k] *= dfdr / (distance * d);
        }
        b->falloff[b->out_index[o]] = f;
        memcpy(b->falloff_grad + 3 * o, g, sizeof g);
    }
    *out = b;
    return FFD_OK;
}

void ffd_lattice_falloff_jacobian(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                  double *out)
{
    const size_t nout = bind->n - bind->inside_count;
    for (size_t o = 0; o < nout; o++) {
        size_t i = bind->out_index[o];
        double *J = out + 9 * i, f = bind->falloff[i], c[3];
        const double *g = bind->falloff_grad + 3 * o;
        ffd_lattice_displacement_at(lat, bind->out_params + 3 * o, c, NULL);
        int moved = c[0] != 0.0 || c[1] != 0.0 || c[2] != 0.0;
        for (int r = 0; r < 3; r++)
            for (int k = 0; k < 3; k++) {
                double id = r == k ? 1.0 : 0.0, dj = J[3 * r + k] - id;
                /* exactly I where nothing moved, as the evaluation keeps the point */
                J[3 * r + k] = moved ? id + f * dj + c[r] * g[k] : id + f * dj;
            }
    }
}
