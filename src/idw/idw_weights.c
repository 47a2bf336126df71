/* idw_weights — inverse-distance weighting (Shepard 1968, "A two-dimensional
 * interpolation function for irregularly-spaced data") as PyGeM's IDW
 * (pygem/idw.py, __call__) computes it: the displacement of a point is the
 * weighted mean of the control points' displacements, weights w_j = 1 /
 * |x - c_j|_p (PyGeM) or 1 / |x - c_j|_2^p (Shepard), and a point on control
 * points takes their mean displacement. */
#include "ffd.h"
#include "idw/idw.h"

#include <math.h>
#include <string.h>

static ffd_status check_points(const double *p, size_t n, const char *what, ffd_error *err)
{
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(p[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "idw: %s[%zu]: not finite", what, i / 3);
    return FFD_OK;
}

void ffd_idw_destroy(ffd_idw *idw)
{
    if (!idw)
        return;
    ffd_free(idw->rest);
    ffd_free(idw->points);
    ffd_free(idw->displacement);
    ffd_free(idw);
}

ffd_status ffd_idw_create(const double *control_points, size_t count,
                          const ffd_idw_options *options, ffd_idw **out, ffd_error *err)
{
    ffd_idw_options o = options ? *options : (ffd_idw_options){0};
    *out = NULL;
    if (!control_points || count == 0)
        return ffd_fail(err, FFD_ERR_INVALID, "idw: no control points");
    if (o.power == 0)
        o.power = 2;
    if (!(o.power > 0) || !isfinite(o.power))
        return ffd_fail(err, FFD_ERR_INVALID, "idw: power %g: expected a finite number > 0",
                        o.power);
    if ((unsigned)o.weighting > FFD_IDW_SHEPARD)
        return ffd_fail(err, FFD_ERR_INVALID, "idw: unknown weighting %d", (int)o.weighting);
    ffd_status s = check_points(control_points, count, "control_points", err);
    if (s)
        return s;
    const double *p = control_points;
    for (size_t i = 0; i < count; i++) /* two equal points would share every weight */
        for (size_t j = i + 1; j < count; j++)
            if (p[3 * i] == p[3 * j] && p[3 * i + 1] == p[3 * j + 1] && p[3 * i + 2] == p[3 * j + 2])
                return ffd_fail(err, FFD_ERR_INVALID,
                                "idw: control_points[%zu] and control_points[%zu] coincide "
                                "([%.17g, %.17g, %.17g])",
                                i, j, p[3 * i], p[3 * i + 1], p[3 * i + 2]);
    ffd_idw *idw = ffd_calloc(1, sizeof *idw);
    if (!idw)
        return ffd_fail(err, FFD_ERR_NOMEM, "idw: out of memory");
    idw->count = count;
    idw->options = o;
    idw->rest = ffd_malloc_array(count, 3 * sizeof(double));
    idw->points = ffd_malloc_array(count, 3 * sizeof(double));
    idw->displacement = ffd_calloc(count, 3 * sizeof(double));
    if (!idw->rest || !idw->points || !idw->displacement) {
        ffd_idw_destroy(idw);
        return ffd_fail(err, FFD_ERR_NOMEM, "idw: out of memory for %zu control points", count);
    }
    memcpy(idw->rest, control_points, count * 3 * sizeof(double));
    memcpy(idw->points, control_points, count * 3 * sizeof(double));
    *out = idw;
    return FFD_OK;
}

size_t ffd_idw_control_count(const ffd_idw *idw)
{
    return idw->count;
}

const double *ffd_idw_control_points(const ffd_idw *idw)
{
    return idw->points;
}

const double *ffd_idw_rest_points(const ffd_idw *idw)
{
    return idw->rest;
}

ffd_status ffd_idw_set_control_points(ffd_idw *idw, const double *points, ffd_error *err)
{
    ffd_status s = check_points(points, idw->count, "control point", err);
    if (s)
        return s;
    int moved = 0;
    for (size_t i = 0; i < 3 * idw->count; i++) {
        idw->displacement[i] = points[i] - idw->rest[i];
        moved |= points[i] != idw->rest[i];
    }
    memcpy(idw->points, points, idw->count * 3 * sizeof *points);
    idw->moved = moved;
    return FFD_OK;
}

/* The distance of e = x - c_j the weight is built on, and with grad != NULL
 * the gradient of the weight w_j with respect to x. */
static double weight_of(const ffd_idw_options *o, const double e[3], double *dist, double grad[3])
{
    const double p = o->power;
    double d;
    if (o->weighting == FFD_IDW_PYGEM) { /* numpy's norm(ord=p) of the difference */
        if (p == 2)
            d = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        else if (p == 1)
            d = fabs(e[0]) + fabs(e[1]) + fabs(e[2]);
        else
            d = pow(pow(fabs(e[0]), p) + pow(fabs(e[1]), p) + pow(fabs(e[2]), p), 1.0 / p);
        *dist = d;
        if (d == 0)
            return 1;
        if (grad) /* w = 1/d: dw/dx_b = -d^-2 sign(e_b) |e_b|^(p-1) / d^(p-1) */
            for (int b = 0; b < 3; b++)
                grad[b] = -copysign(pow(fabs(e[b]), p - 1), e[b]) / (d * d * pow(d, p - 1));
        return 1.0 / d;
    }
    double r2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
    d = sqrt(r2);
    *dist = d;
    if (d == 0)
        return 1;
    double w = p == 2 ? 1.0 / r2 : 1.0 / pow(d, p);
    if (grad) /* w = r^-p: dw/dx_b = -p r^(-p-2) e_b */
        for (int b = 0; b < 3; b++)
            grad[b] = -p * w / r2 * e[b];
    return w;
}

/* The normalised weights at x into a (count); returns 1 when x is on a
 * control point (weights 1 there, 0 elsewhere, normalised). */
static int weights_at(const ffd_idw *idw, const double x[3], double *a)
{
    const size_t N = idw->count;
    size_t on = 0;
    double sum = 0;
    for (size_t j = 0; j < N; j++) {
        const double *c = idw->rest + 3 * j;
        double e[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]}, d;
        a[j] = weight_of(&idw->options, e, &d, NULL);
        if (d == 0)
            on++;
        sum += a[j];
    }
    if (on) { /* PyGeM: np.where(d == 0.0, 1.0, 0.0) */
        for (size_t j = 0; j < N; j++) {
            const double *c = idw->rest + 3 * j;
            a[j] = x[0] == c[0] && x[1] == c[1] && x[2] == c[2] ? 1.0 / (double)on : 0.0;
        }
        return 1;
    }
    for (size_t j = 0; j < N; j++)
        a[j] /= sum;
    return 0;
}

void ffd_idw_weights(const ffd_idw *idw, const double x[3], double *weights)
{
    weights_at(idw, x, weights);
}

/* The displacement at x: sum_j D_j w_j / S, one fixed order per point
 * (PyGeM's order: each term divided by the sum, then summed). */
static void displacement_at(const ffd_idw *idw, const double x[3], double u[3])
{
    const size_t N = idw->count;
    double sum = 0, acc[3] = {0, 0, 0};
    size_t on = 0;
    for (size_t j = 0; j < N; j++) {
        const double *c = idw->rest + 3 * j;
        double e[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]}, d;
        double w = weight_of(&idw->options, e, &d, NULL);
        if (d == 0) {
            on++;
            for (int a = 0; a < 3; a++)
                acc[a] += idw->displacement[3 * j + a];
        }
        sum += w;
    }
    if (on) {
        for (int a = 0; a < 3; a++)
            u[a] = acc[a] / (double)on;
        return;
    }
    for (size_t j = 0; j < N; j++) {
        const double *c = idw->rest + 3 * j, *D = idw->displacement + 3 * j;
        double e[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]}, d;
        double w = weight_of(&idw->options, e, &d, NULL);
        for (int a = 0; a < 3; a++)
            acc[a] += D[a] * w / sum;
    }
    memcpy(u, acc, sizeof acc);
}

ffd_status ffd_idw_eval(const ffd_idw *idw, const double *points, size_t n, double *out,
                        ffd_error *err)
{
    (void)err;
    if (!idw->moved) {
        memmove(out, points, n * 3 * sizeof *out);
        return FFD_OK;
    }
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        double u[3];
        displacement_at(idw, points + 3 * i, u);
        for (int a = 0; a < 3; a++)
            out[3 * i + a] = points[3 * i + a] + u[a];
    }
    return FFD_OK;
}

/* du/dx = sum_j grad w_j (D_j - u)^T / S (quotient rule). */
static void jacobian_at(const ffd_idw *idw, const double x[3], double J[9])
{
    const size_t N = idw->count;
    double S = 0, u[3], g[3][3] = {{0}};
    for (int k = 0; k < 9; k++)
        J[k] = k % 4 == 0;
    if (!idw->moved)
        return;
    for (size_t j = 0; j < N; j++) {
        const double *c = idw->rest + 3 * j;
        double e[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]}, d;
        S += weight_of(&idw->options, e, &d, NULL);
        if (d == 0)
            return; /* a cone point: no derivative */
    }
    displacement_at(idw, x, u);
    for (size_t j = 0; j < N; j++) {
        const double *c = idw->rest + 3 * j, *D = idw->displacement + 3 * j;
        double e[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]}, d, grad[3] = {0, 0, 0};
        weight_of(&idw->options, e, &d, grad);
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                g[a][b] += grad[b] * (D[a] - u[a]);
    }
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            J[3 * a + b] += g[a][b] / S;
}

ffd_status ffd_idw_jacobian(const ffd_idw *idw, const double *points, size_t n, double *out,
                            ffd_error *err)
{
    (void)err;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++)
        jacobian_at(idw, points + 3 * i, out + 9 * i);
    return FFD_OK;
}

static size_t weight_row(const void *self, size_t i, uint32_t *columns, double *weights)
{
    const ffd_point_rows *rows = self;
    const ffd_idw *idw = rows->morph;
    weights_at(idw, rows->points + 3 * i, weights);
    for (size_t j = 0; j < idw->count; j++)
        columns[j] = (uint32_t)j;
    return idw->count;
}

void ffd_idw_linear_map(const ffd_point_rows *rows, size_t n, ffd_linear_map *map)
{
    const ffd_idw *idw = rows->morph;
    memset(map, 0, sizeof *map);
    map->self = rows;
    map->point_count = n;
    map->column_count = idw->count;
    map->variable_count = idw->count;
    map->max_row_nnz = idw->count;
    map->row = weight_row;
}
