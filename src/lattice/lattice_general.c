/* lattice_general — the general tensor-product lattice: an interpolation per
 * axis (lattice_axis.c) on a Cartesian box, or a cylindrical (r, theta, z) or
 * spherical (r, theta, phi) grid (3ds Max FFD(cyl); SU2's cylindrical and
 * spherical FFD boxes), in displacement form like the fast path:
 *
 *     x'(x) = x + sum_ijk w_i(S) w_j(T) w_k(U) (P_ijk - P0_ijk),
 *
 * (S, T, U) the per-axis parameters of x: its normalised coordinates
 * (dual basis of the box, or (r, theta, z|phi) scaled to [0,1]) through the
 * inverse of each axis' rest map. The control points and their displacements
 * are Cartesian. On a closed theta axis indices wrap. The control points of
 * the axis (r0 = 0) and of the poles are tied to one representative (the
 * lowest index of the group): their weights sum onto it, so the map is
 * single-valued and continuous there.
 *
 * Evaluation, the Jacobian and the products run per point (OpenMP over
 * points, each point one fixed sequence of operations: bitwise the same for
 * any thread count); the adjoint product sums points in index order. */
#include "lattice/lattice.h"
#include "math/tolerance.h"

#include <math.h>
#include <string.h>

#define TWO_PI 6.283185307179586476925286766559
#define PI 3.1415926535897932384626433832795
/* B-spline ends: parameters pulled this far inside (the rest map is flat on
 * the tripled border), as lattice_map.c */
#define JACOBIAN_NUDGE 1e-4
/* normalised distance from the axis / a pole where the Jacobian is taken
 * instead (its limit: theta is undefined there) */
#define SINGULAR_NUDGE 1e-7
#define FOLD_GRID 5

struct ffd_lattice_general {
    ffd_lattice_shape shape;
    ffd_lattice_axis axis[3];
    double e[3][3];     /* e1, e2, e3 of the frame */
    double lo[3], w[3]; /* r, theta, z|phi ranges: lo and width */
    uint32_t *tie;      /* l*m*n -> representative, or NULL */
    size_t max_nnz;
};

static double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static double det3(const double m[9])
{
    return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
           m[2] * (m[3] * m[7] - m[4] * m[6]);
}

void ffd_lattice_general_free(struct ffd_lattice_general *g)
{
    if (!g)
        return;
    for (int a = 0; a < 3; a++)
        ffd_lattice_axis_release(&g->axis[a]);
    ffd_free(g->tie);
    ffd_free(g);
}

/* ---- coordinates ---- */

/* Normalised coordinates of x, unclamped; a closed theta wraps into [0,1); an
 * open one outside its range is put on the side of its nearer end. */
static void to_local(const ffd_lattice *lat, const double x[3], double loc[3])
{
    const struct ffd_lattice_general *g = lat->gen;
    double v[3];
    if (g->shape.coordinates == FFD_COORDINATES_CARTESIAN) {
        for (int c = 0; c < 3; c++)
            v[c] = x[c] - lat->box.origin[c];
        for (int a = 0; a < 3; a++)
            loc[a] = dot3(lat->dual[a], v);
        return;
    }
    for (int c = 0; c < 3; c++)
        v[c] = x[c] - g->shape.frame.centre[c];
    double p1 = dot3(v, g->e[0]), p2 = dot3(v, g->e[1]), p3 = dot3(v, g->e[2]);
    double rho = hypot(p1, p2), theta = atan2(p2, p1), third, r;
    if (g->shape.coordinates == FFD_COORDINATES_CYLINDRICAL) {
        r = rho;
        third = p3;
    } else {
        r = hypot(rho, p3);
        third = atan2(rho, p3); /* polar angle from e3, in [0, pi] */
    }
    double d = fmod(theta - g->lo[1], TWO_PI);
    if (d < 0)
        d += TWO_PI;
    if (d >= TWO_PI)
        d = 0;
    loc[0] = (r - g->lo[0]) / g->w[0];
    if (g->axis[1].periodic) {
        loc[1] = d / TWO_PI;
        if (loc[1] >= 1.0)
            loc[1] = 0.0;
    } else {
        loc[1] = d / g->w[1];
        if (d > g->w[1] && TWO_PI - d < d - g->w[1])
            loc[1] = -(TWO_PI - d) / g->w[1]; /* nearer the start */
    }
    loc[2] = (third - g->lo[2]) / g->w[2];
}

/* The rest point at normalised coordinates loc, and the gradients of loc
 * with respect to x (rows) when grad. */
static void from_local(const ffd_lattice *lat, const double loc[3], double x[3], double grad[3][3])
{
    const struct ffd_lattice_general *g = lat->gen;
    if (g->shape.coordinates == FFD_COORDINATES_CARTESIAN) {
        for (int r = 0; r < 3; r++)
            x[r] = lat->box.origin[r] + loc[0] * lat->box.axes[0][r] +
                   loc[1] * lat->box.axes[1][r] + loc[2] * lat->box.axes[2][r];
        if (grad)
            memcpy(grad, lat->dual, sizeof lat->dual);
        return;
    }
    const double *c = g->shape.frame.centre;
    const double(*e)[3] = (const double(*)[3])g->e;
    double r = g->lo[0] + loc[0] * g->w[0];
    double th = g->lo[1] + loc[1] * g->w[1];
    double third = g->lo[2] + loc[2] * g->w[2];
    double ct = cos(th), st = sin(th);
    double er[3], et[3];
    for (int k = 0; k < 3; k++) {
        er[k] = ct * e[0][k] + st * e[1][k];
        et[k] = -st * e[0][k] + ct * e[1][k];
    }
    if (g->shape.coordinates == FFD_COORDINATES_CYLINDRICAL) {
        for (int k = 0; k < 3; k++)
            x[k] = c[k] + r * er[k] + third * e[2][k];
        if (grad)
            for (int k = 0; k < 3; k++) {
                grad[0][k] = er[k] / g->w[0];
                grad[1][k] = et[k] / (r * g->w[1]);
                grad[2][k] = e[2][k] / g->w[2];
            }
        return;
    }
    double cp = cos(third), sp = sin(third);
    for (int k = 0; k < 3; k++)
        x[k] = c[k] + r * (sp * er[k] + cp * e[2][k]);
    if (grad)
        for (int k = 0; k < 3; k++) {
            grad[0][k] = (sp * er[k] + cp * e[2][k]) / g->w[0];
            grad[1][k] = et[k] / (r * sp * g->w[1]);
            grad[2][k] = (cp * er[k] - sp * e[2][k]) / (r * g->w[2]);
        }
}

/* ---- creation ---- */

static ffd_status check_frame(const ffd_lattice_shape *sh, struct ffd_lattice_general *g,
                              ffd_error *err)
{
    const ffd_lattice_frame *f = &sh->frame;
    const int cyl = sh->coordinates == FFD_COORDINATES_CYLINDRICAL;
    for (int k = 0; k < 3; k++)
        if (!isfinite(f->centre[k]) || !isfinite(f->axis[k]) || !isfinite(f->reference[k]) ||
            !isfinite(f->range[k][0]) || !isfinite(f->range[k][1]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "lattice frame: a value is not finite");
    double na = sqrt(dot3(f->axis, f->axis));
    if (!(na > 0))
        return ffd_fail(err, FFD_ERR_INVALID, "lattice frame: the axis is zero");
    for (int k = 0; k < 3; k++)
        g->e[2][k] = f->axis[k] / na;
    double along = dot3(f->reference, g->e[2]), ref[3];
    for (int k = 0; k < 3; k++)
        ref[k] = f->reference[k] - along * g->e[2][k];
    double nr = sqrt(dot3(ref, ref)), nref = sqrt(dot3(f->reference, f->reference));
    if (!(nr > 1e-9 * nref) || nref == 0)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "lattice frame: the reference direction is zero or parallel to the axis");
    for (int k = 0; k < 3; k++)
        g->e[0][k] = ref[k] / nr;
    g->e[1][0] = g->e[2][1] * g->e[0][2] - g->e[2][2] * g->e[0][1];
    g->e[1][1] = g->e[2][2] * g->e[0][0] - g->e[2][0] * g->e[0][2];
    g->e[1][2] = g->e[2][0] * g->e[0][1] - g->e[2][1] * g->e[0][0];
    const double(*rg)[2] = f->range;
    if (!(rg[0][0] >= 0 && rg[0][1] > rg[0][0]))
        return ffd_fail(err, FFD_ERR_INVALID, "lattice frame: r range [%g, %g]: expected 0 <= r0 < r1",
                        rg[0][0], rg[0][1]);
    double span = rg[1][1] - rg[1][0];
    if (!(span > 0 && span <= TWO_PI * (1 + 1e-12)))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "lattice frame: theta range [%g, %g]: expected t0 < t1 <= t0 + 2 pi", rg[1][0],
                        rg[1][1]);
    if (cyl && !(rg[2][1] > rg[2][0]))
        return ffd_fail(err, FFD_ERR_INVALID, "lattice frame: z range [%g, %g]: expected z0 < z1",
                        rg[2][0], rg[2][1]);
    if (!cyl && !(rg[2][0] >= 0 && rg[2][1] > rg[2][0] && rg[2][1] <= PI * (1 + 1e-15)))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "lattice frame: phi range [%g, %g]: expected 0 <= p0 < p1 <= pi", rg[2][0],
                        rg[2][1]);
    for (int a = 0; a < 3; a++) {
        g->lo[a] = rg[a][0];
        g->w[a] = rg[a][1] - rg[a][0];
    }
    if (fabs(span - TWO_PI) <= 1e-12 * TWO_PI)
        g->w[1] = TWO_PI;
    if (!cyl && rg[2][1] >= PI)
        g->w[2] = PI - g->lo[2];
    return FFD_OK;
}

static ffd_status set_box(ffd_lattice *lat, const ffd_box *box, ffd_error *err)
{
    const double *a = box->axes[0], *b = box->axes[1], *c = box->axes[2];
    for (int k = 0; k < 3; k++)
        if (!isfinite(box->origin[k]) || !isfinite(a[k]) || !isfinite(b[k]) || !isfinite(c[k]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "lattice box is not finite");
    double det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                 a[2] * (b[0] * c[1] - b[1] * c[0]);
    double scale = sqrt(dot3(a, a) * dot3(b, b) * dot3(c, c));
    if (!(fabs(det) > FFD_TOL_VOLUME * scale) || scale == 0)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "lattice box has zero volume (axes are zero or linearly dependent)");
    lat->box = *box;
    double inv = 1.0 / det;
    lat->dual[0][0] = (b[1] * c[2] - b[2] * c[1]) * inv;
    lat->dual[0][1] = (b[2] * c[0] - b[0] * c[2]) * inv;
    lat->dual[0][2] = (b[0] * c[1] - b[1] * c[0]) * inv;
    lat->dual[1][0] = (c[1] * a[2] - c[2] * a[1]) * inv;
    lat->dual[1][1] = (c[2] * a[0] - c[0] * a[2]) * inv;
    lat->dual[1][2] = (c[0] * a[1] - c[1] * a[0]) * inv;
    lat->dual[2][0] = (a[1] * b[2] - a[2] * b[1]) * inv;
    lat->dual[2][1] = (a[2] * b[0] - a[0] * b[2]) * inv;
    lat->dual[2][2] = (a[0] * b[1] - a[1] * b[0]) * inv;
    return FFD_OK;
}

/* Representative of control (i, j, k) under the axis and pole ties. */
static size_t representative(const ffd_lattice *lat, uint32_t i, uint32_t j, uint32_t k)
{
    const struct ffd_lattice_general *g = lat->gen;
    const uint32_t *res = lat->res;
    const ffd_coordinates co = g->shape.coordinates;
    if (co != FFD_COORDINATES_CARTESIAN && i == 0 && g->lo[0] == 0) {
        j = 0;
        if (co == FFD_COORDINATES_SPHERICAL)
            k = 0;
    } else if (co == FFD_COORDINATES_SPHERICAL &&
               ((k == 0 && g->lo[2] == 0) || (k == res[2] - 1 && g->lo[2] + g->w[2] >= PI)))
        j = 0;
    return ((size_t)i * res[1] + j) * res[2] + k;
}

static int interp_is(const ffd_lattice_shape *sh, ffd_basis basis, ffd_interp want)
{
    for (int a = 0; a < 3; a++) {
        ffd_interp it = sh->interp[a];
        if (it == FFD_INTERP_DEFAULT)
            it = basis == FFD_BASIS_BERNSTEIN ? FFD_INTERP_BERNSTEIN : FFD_INTERP_BSPLINE;
        if (it != want)
            return 0;
    }
    return 1;
}

int ffd_lattice_shape_is_general(ffd_basis basis, const ffd_lattice_shape *shape)
{
    return shape && (shape->coordinates != FFD_COORDINATES_CARTESIAN ||
                     !(interp_is(shape, basis, FFD_INTERP_BSPLINE) ||
                       interp_is(shape, basis, FFD_INTERP_BERNSTEIN)));
}

ffd_status ffd_lattice_create_shaped(ffd_basis basis, const ffd_box *box, const uint32_t res[3],
                                     const ffd_lattice_shape *shape, ffd_lattice **out,
                                     ffd_error *err)
{
    *out = NULL;
    ffd_lattice_shape zero;
    memset(&zero, 0, sizeof zero);
    if (!shape)
        shape = &zero;
    if (basis != FFD_BASIS_BSPLINE && basis != FFD_BASIS_BERNSTEIN)
        return ffd_fail(err, FFD_ERR_INVALID, "unknown lattice basis %d", (int)basis);
    if (shape->coordinates == FFD_COORDINATES_CARTESIAN) {
        /* one of the fast path's bases on every axis: the fast path */
        if (interp_is(shape, basis, FFD_INTERP_BSPLINE))
            return ffd_lattice_create(FFD_BASIS_BSPLINE, box, res, out, err);
        if (interp_is(shape, basis, FFD_INTERP_BERNSTEIN))
            return ffd_lattice_create(FFD_BASIS_BERNSTEIN, box, res, out, err);
    }
    return ffd_lattice_general_create(basis, box, res, shape, out, err);
}

void ffd_lattice_get_shape(const ffd_lattice *lat, ffd_lattice_shape *shape)
{
    if (lat->gen)
        *shape = lat->gen->shape;
    else
        memset(shape, 0, sizeof *shape);
}

ffd_status ffd_lattice_general_create(ffd_basis basis, const ffd_box *box, const uint32_t res[3],
                                      const ffd_lattice_shape *shape, ffd_lattice **out,
                                      ffd_error *err)
{
    static const char *const axis_names[3][3] = {
        {"axis 0", "axis 1", "axis 2"}, {"axis 0 (r)", "axis 1 (theta)", "axis 2 (z)"},
        {"axis 0 (r)", "axis 1 (theta)", "axis 2 (phi)"}};
    *out = NULL;
    if (shape->coordinates > FFD_COORDINATES_SPHERICAL)
        return ffd_fail(err, FFD_ERR_INVALID, "unknown lattice coordinates %d",
                        (int)shape->coordinates);
    ffd_lattice *lat = ffd_calloc(1, sizeof *lat);
    struct ffd_lattice_general *g = lat ? ffd_calloc(1, sizeof *g) : NULL;
    if (!g) {
        ffd_free(lat);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory creating the lattice");
    }
    lat->gen = g;
    g->shape = *shape;
    lat->basis = basis;
    memcpy(lat->res, res, sizeof lat->res);
    memcpy(lat->ext, res, sizeof lat->ext);
    ffd_status st;
    const int coords = (int)shape->coordinates;
    if (coords == FFD_COORDINATES_CARTESIAN)
        st = set_box(lat, box, err);
    else
        st = check_frame(shape, g, err);
    if (st)
        goto fail;
    g->max_nnz = 1;
    for (int a = 0; a < 3; a++) {
        ffd_interp it = shape->interp[a];
        if (it == FFD_INTERP_DEFAULT)
            it = basis == FFD_BASIS_BERNSTEIN ? FFD_INTERP_BERNSTEIN : FFD_INTERP_BSPLINE;
        g->shape.interp[a] = it;
        int periodic = a == 1 && coords != FFD_COORDINATES_CARTESIAN && g->w[1] == TWO_PI;
        if ((st = ffd_lattice_axis_init(&g->axis[a], it, shape->tension[a], shape->continuity[a],
                                        res[a], periodic, axis_names[coords][a], err)))
            goto fail;
        g->shape.tension[a] = g->axis[a].tension;
        g->shape.continuity[a] = g->axis[a].continuity;
        g->max_nnz *= it == FFD_INTERP_BERNSTEIN ? res[a] : (it == FFD_INTERP_LINEAR ? 2 : 4);
    }
    size_t count = (size_t)res[0] * res[1] * res[2];
    lat->P = ffd_malloc_array(count, 3 * sizeof(double));
    lat->P_rest = ffd_malloc_array(count, 3 * sizeof(double));
    lat->D_ext = ffd_calloc(count, 3 * sizeof(double));
    if (!lat->P || !lat->P_rest || !lat->D_ext)
        goto oom;
    lat->P_ext = lat->P;
    int tied = 0;
    for (uint32_t i = 0; i < res[0]; i++)
        for (uint32_t j = 0; j < res[1]; j++)
            for (uint32_t k = 0; k < res[2]; k++) {
                size_t e = ((size_t)i * res[1] + j) * res[2] + k;
                double loc[3] = {ffd_lattice_axis_node(&g->axis[0], i),
                                 ffd_lattice_axis_node(&g->axis[1], j),
                                 ffd_lattice_axis_node(&g->axis[2], k)};
                from_local(lat, loc, lat->P_rest + 3 * e, NULL);
                tied |= representative(lat, i, j, k) != e;
            }
    if (tied) {
        g->tie = ffd_malloc_array(count, sizeof *g->tie);
        if (!g->tie)
            goto oom;
        for (uint32_t i = 0; i < res[0]; i++)
            for (uint32_t j = 0; j < res[1]; j++)
                for (uint32_t k = 0; k < res[2]; k++) {
                    size_t e = ((size_t)i * res[1] + j) * res[2] + k, r = representative(lat, i, j, k);
                    g->tie[e] = (uint32_t)r;
                    /* one point, bitwise: the followers take the representative's rest */
                    memcpy(lat->P_rest + 3 * e, lat->P_rest + 3 * r, 3 * sizeof(double));
                }
    }
    if (coords != FFD_COORDINATES_CARTESIAN) { /* the box: the rest points' bounding box */
        double lo[3], hi[3];
        for (int c = 0; c < 3; c++)
            lo[c] = hi[c] = lat->P_rest[c];
        for (size_t e = 0; e < count; e++)
            for (int c = 0; c < 3; c++) {
                lo[c] = fmin(lo[c], lat->P_rest[3 * e + c]);
                hi[c] = fmax(hi[c], lat->P_rest[3 * e + c]);
            }
        memset(&lat->box, 0, sizeof lat->box);
        for (int c = 0; c < 3; c++) {
            lat->box.origin[c] = lo[c];
            lat->box.axes[c][c] = hi[c] - lo[c];
        }
    }
    memcpy(lat->P, lat->P_rest, count * 3 * sizeof(double));
    *out = lat;
    return FFD_OK;
oom:
    st = ffd_fail(err, FFD_ERR_NOMEM, "out of memory creating a %ux%ux%u lattice", res[0], res[1],
                  res[2]);
fail:
    ffd_lattice_destroy(lat);
    return st;
}

/* A point's distance from the fitted frame's axis (cylindrical) or centre. */
static double frame_radius(ffd_coordinates coordinates, const double centre[3], const double *p)
{
    double dx = p[0] - centre[0], dy = p[1] - centre[1], dz = p[2] - centre[2];
    return coordinates == FFD_COORDINATES_CYLINDRICAL ? hypot(dx, dy)
                                                      : sqrt(dx * dx + dy * dy + dz * dz);
}

size_t ffd_lattice_frame_farthest(ffd_coordinates coordinates, const double lo[3],
                                  const double hi[3], const double *points, size_t n)
{
    double corners[6] = {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]}, centre[3], rmax = -1;
    ffd_box box;
    if (ffd_box_fit(corners, 2, 0, &box, NULL))
        return SIZE_MAX;
    for (int c = 0; c < 3; c++)
        centre[c] = box.origin[c] + 0.5 * box.axes[c][c];
    size_t best = SIZE_MAX;
    for (size_t i = 0; i < n; i++) {
        double r = frame_radius(coordinates, centre, points + 3 * i);
        if (r > rmax)
            rmax = r, best = i;
    }
    return best;
}

ffd_status ffd_lattice_frame_fit(ffd_coordinates coordinates, const double *points, size_t n,
                                 double margin, ffd_lattice_frame *frame, ffd_error *err)
{
    ffd_box box;
    if (coordinates != FFD_COORDINATES_CYLINDRICAL && coordinates != FFD_COORDINATES_SPHERICAL)
        return ffd_fail(err, FFD_ERR_INVALID, "frame fit: coordinates %d are not cylindrical or "
                                              "spherical", (int)coordinates);
    ffd_status st = ffd_box_fit(points, n, 0, &box, err);
    if (st)
        return st;
    memset(frame, 0, sizeof *frame);
    double zlo = INFINITY, zhi = -INFINITY, rmax = 0;
    for (int c = 0; c < 3; c++)
        frame->centre[c] = box.origin[c] + 0.5 * box.axes[c][c];
    for (size_t i = 0; i < n; i++) {
        double dz = points[3 * i + 2] - frame->centre[2];
        rmax = fmax(rmax, frame_radius(coordinates, frame->centre, points + 3 * i));
        zlo = fmin(zlo, dz);
        zhi = fmax(zhi, dz);
    }
    if (!(rmax > 0))
        return ffd_fail(err, FFD_ERR_INVALID, "frame fit: the points have no extent around the axis");
    frame->axis[2] = 1;
    frame->reference[0] = 1;
    frame->range[0][1] = rmax * (1 + margin);
    frame->range[1][1] = TWO_PI;
    if (coordinates == FFD_COORDINATES_CYLINDRICAL) {
        double pad = margin * (zhi - zlo);
        if (!(zhi - zlo > 1e-12 * rmax))
            pad = (margin > 0 ? margin : 0.05) * rmax;
        frame->range[2][0] = zlo - pad;
        frame->range[2][1] = zhi + pad;
    } else {
        frame->range[2][1] = PI;
    }
    return FFD_OK;
}

/* ---- control points ---- */

/* A tied group is one point, its representative: the followers take its
 * position (the linear map has no variable for them, so setting one alone
 * changes nothing; ffd_lattice_move redirects to the representative). */
void ffd_lattice_general_sync(ffd_lattice *lat)
{
    size_t count = (size_t)lat->res[0] * lat->res[1] * lat->res[2];
    const uint32_t *tie = lat->gen->tie;
    if (tie)
        for (size_t e = 0; e < count; e++)
            if (tie[e] != e)
                memcpy(lat->P + 3 * e, lat->P + 3 * (size_t)tie[e], 3 * sizeof(double));
    for (size_t e = 0; e < count; e++)
        for (int c = 0; c < 3; c++)
            lat->D_ext[3 * e + c] = lat->P[3 * e + c] - lat->P_rest[3 * e + c];
}

void ffd_lattice_general_rest_point(const ffd_lattice *lat, uint32_t i, uint32_t j, uint32_t k,
                                    double out[3])
{
    memcpy(out, lat->P_rest + 3 * (((size_t)i * lat->res[1] + j) * lat->res[2] + k),
           3 * sizeof(double));
}

const ffd_lattice_axis *ffd_lattice_general_axis(const ffd_lattice *lat, int a)
{
    return &lat->gen->axis[a];
}

size_t ffd_lattice_general_representative(const ffd_lattice *lat, size_t index)
{
    return lat->gen->tie ? lat->gen->tie[index] : index;
}

/* ---- the map ---- */

/* Tensor-product weights at parameters S over the l*m*n controls (before
 * ties); derivatives d/dS_a into dw[a] when dw. Returns the count. */
static size_t weights_at(const struct ffd_lattice_general *g, const uint32_t res[3],
                         const double S[3], uint32_t *cols, double *w, double (*dw)[3])
{
    uint32_t idx[3][FFD_AXIS_MAX_SUPPORT], cnt[3];
    double b[3][FFD_AXIS_MAX_SUPPORT], d[3][FFD_AXIS_MAX_SUPPORT];
    for (int a = 0; a < 3; a++)
        cnt[a] = ffd_lattice_axis_weights(&g->axis[a], S[a], idx[a], b[a], dw ? d[a] : NULL);
    size_t k = 0;
    for (uint32_t p = 0; p < cnt[0]; p++)
        for (uint32_t q = 0; q < cnt[1]; q++)
            for (uint32_t r = 0; r < cnt[2]; r++) {
                cols[k] = (uint32_t)(((size_t)idx[0][p] * res[1] + idx[1][q]) * res[2] + idx[2][r]);
                w[k] = b[0][p] * b[1][q] * b[2][r];
                if (dw) {
                    dw[k][0] = d[0][p] * b[1][q] * b[2][r];
                    dw[k][1] = b[0][p] * d[1][q] * b[2][r];
                    dw[k][2] = b[0][p] * b[1][q] * d[2][r];
                }
                k++;
            }
    return k;
}

/* sum w_k net[tie(col_k)] (and d/dS_a) at S. */
static ffd_status sum_at(const ffd_lattice *lat, const double *net, const double S[3], double out[3],
                         double dout[3][3])
{
    const struct ffd_lattice_general *g = lat->gen;
    /* local bases on every axis: at most 4 x 4 x 4 weights, on the stack */
    uint32_t cols_s[64];
    double w_s[64], dw_s[64][3];
    const int heap = g->max_nnz > 64;
    uint32_t *cols = heap ? ffd_malloc_array(g->max_nnz, sizeof *cols) : cols_s;
    double *w = heap ? ffd_malloc_array(g->max_nnz, sizeof *w) : w_s;
    double(*dw)[3] = !dout ? NULL : heap ? ffd_malloc_array(g->max_nnz, sizeof *dw) : dw_s;
    if (!cols || !w || (dout && !dw)) {
        if (heap)
            ffd_free(cols), ffd_free(w), ffd_free(dw);
        return FFD_ERR_NOMEM;
    }
    size_t k = weights_at(g, lat->res, S, cols, w, dw);
    double acc[4][3] = {{0}};
    for (size_t e = 0; e < k; e++) {
        const double *p = net + 3 * (size_t)(g->tie ? g->tie[cols[e]] : cols[e]);
        for (int r = 0; r < 3; r++) {
            acc[0][r] += w[e] * p[r];
            if (dout)
                for (int a = 0; a < 3; a++)
                    acc[a + 1][r] += dw[e][a] * p[r];
        }
    }
    memcpy(out, acc[0], 3 * sizeof(double));
    if (dout)
        for (int a = 0; a < 3; a++)
            memcpy(dout[a], acc[a + 1], 3 * sizeof(double));
    if (heap)
        ffd_free(cols), ffd_free(w), ffd_free(dw);
    return FFD_OK;
}

ffd_status ffd_lattice_general_bind(const ffd_lattice *lat, const double *points, size_t n,
                                    ffd_outside outside, ffd_lattice_binding **out, ffd_error *err)
{
    *out = NULL;
    ffd_lattice_binding *b = ffd_calloc(1, sizeof *b);
    if (!b)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory binding %zu points", n);
    b->n = n;
    b->outside = outside;
    b->basis = lat->basis;
    b->general = lat->gen;
    memcpy(b->res, lat->res, sizeof b->res);
    b->params = ffd_malloc_array(n, 3 * sizeof(double));
    b->inside = ffd_malloc_array(n, 1);
    b->out_point = ffd_malloc_array(n, 3 * sizeof(double));
    b->blocks = ffd_malloc_array(1, sizeof *b->blocks);
    if (!b->params || !b->inside || !b->out_point || !b->blocks) {
        ffd_lattice_binding_destroy(b);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory binding %zu points", n);
    }
    size_t first_bad = SIZE_MAX, nin = 0;
    const long long nn = (long long)n;
#pragma omp parallel for schedule(static) reduction(min : first_bad) reduction(+ : nin)
    for (long long ii = 0; ii < nn; ii++) {
        size_t i = (size_t)ii;
        const double *x = points + 3 * i;
        double *S = b->params + 3 * i, loc[3];
        memcpy(b->out_point + 3 * i, x, 3 * sizeof(double));
        if (!(isfinite(x[0]) && isfinite(x[1]) && isfinite(x[2]))) {
            first_bad = i < first_bad ? i : first_bad;
            S[0] = S[1] = S[2] = 0;
            b->inside[i] = 0;
            continue;
        }
        to_local(lat, x, loc);
        int in = 1;
        for (int a = 0; a < 3; a++)
            if (!(loc[a] >= -FFD_TOL_BOUNDARY && loc[a] <= 1.0 + FFD_TOL_BOUNDARY))
                in = 0;
        b->inside[i] = (unsigned char)in;
        nin += (size_t)in;
        for (int a = 0; a < 3; a++) /* outside points: clamped (extrapolate is clamp here) */
            S[a] = ffd_lattice_axis_invert(&lat->gen->axis[a], loc[a]);
    }
    if (first_bad != SIZE_MAX) {
        ffd_lattice_binding_destroy(b);
        return ffd_fail(err, FFD_ERR_NONFINITE, "point %zu has a non-finite coordinate",
                        first_bad);
    }
    b->inside_count = nin;
    *out = b;
    return FFD_OK;
}

/* v == NULL: out_i = x_i + sum w D (displacement form; a zero displacement
 * leaves the point bitwise); else out_i = sum w v (the product W v). */
ffd_status ffd_lattice_general_eval(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                    const double *v, double *out, ffd_error *err)
{
    const double *net = v ? v : lat->D_ext;
    int failed = 0;
    const long long nn = (long long)bind->n;
#pragma omp parallel for schedule(static) reduction(| : failed)
    for (long long ii = 0; ii < nn; ii++) {
        size_t i = (size_t)ii;
        const double *x = bind->out_point + 3 * i;
        double *o = out + 3 * i, d[3];
        if (!bind->inside[i] && bind->outside == FFD_OUTSIDE_FIXED) {
            if (v)
                o[0] = o[1] = o[2] = 0.0;
            else
                memcpy(o, x, 3 * sizeof(double));
            continue;
        }
        if (sum_at(lat, net, bind->params + 3 * i, d, NULL)) {
            failed = 1;
            continue;
        }
        for (int c = 0; c < 3; c++)
            o[c] = v ? d[c] : (d[c] != 0.0 ? x[c] + d[c] : x[c]);
    }
    if (failed)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory evaluating the lattice");
    return FFD_OK;
}

void ffd_lattice_general_eval_params(const ffd_lattice *lat, const double stu[3], double out[3])
{
    double loc[3], d[3] = {0, 0, 0};
    for (int a = 0; a < 3; a++)
        loc[a] = ffd_lattice_axis_rest(&lat->gen->axis[a], stu[a], NULL);
    from_local(lat, loc, out, NULL);
    if (sum_at(lat, lat->D_ext, stu, d, NULL) == FFD_OK)
        for (int c = 0; c < 3; c++)
            if (d[c] != 0.0)
                out[c] += d[c];
}

/* J = I + sum_a dD/dS_a (dS_a/dloc_a) grad loc_a at parameters S_in; axes
 * with keep[a] == 0 (clamped) do not vary. */
static ffd_status jacobian_at(const ffd_lattice *lat, const double S_in[3], const int keep[3],
                              double J[9])
{
    const struct ffd_lattice_general *g = lat->gen;
    double S[3], loc[3], df[3], grad[3][3], x[3], d[3], dd[3][3];
    for (int a = 0; a < 3; a++) {
        S[a] = S_in[a];
        const ffd_lattice_axis *ax = &g->axis[a];
        if (ax->interp == FFD_INTERP_BSPLINE && !ax->periodic) {
            double hi = ffd_lattice_axis_top(ax);
            S[a] = S[a] < JACOBIAN_NUDGE ? JACOBIAN_NUDGE
                                         : (S[a] > hi - JACOBIAN_NUDGE ? hi - JACOBIAN_NUDGE : S[a]);
        }
        loc[a] = ffd_lattice_axis_rest(ax, S[a], &df[a]);
    }
    /* on the axis and at the poles theta is undefined: the limit from inside */
    const ffd_coordinates co = g->shape.coordinates;
    int moved = 0;
    if (co != FFD_COORDINATES_CARTESIAN && g->lo[0] + loc[0] * g->w[0] < SINGULAR_NUDGE * g->w[0]) {
        loc[0] = (SINGULAR_NUDGE * g->w[0] - g->lo[0]) / g->w[0];
        moved |= 1;
    }
    if (co == FFD_COORDINATES_SPHERICAL) {
        double phi = g->lo[2] + loc[2] * g->w[2];
        if (phi < SINGULAR_NUDGE || phi > PI - SINGULAR_NUDGE) {
            phi = phi < SINGULAR_NUDGE ? SINGULAR_NUDGE : PI - SINGULAR_NUDGE;
            loc[2] = (phi - g->lo[2]) / g->w[2];
            moved |= 4;
        }
    }
    for (int a = 0; a < 3; a++)
        if (moved & (1 << a)) {
            S[a] = ffd_lattice_axis_invert(&g->axis[a], loc[a]);
            ffd_lattice_axis_rest(&g->axis[a], S[a], &df[a]);
        }
    from_local(lat, loc, x, grad);
    if (sum_at(lat, lat->D_ext, S, d, dd))
        return FFD_ERR_NOMEM;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            double s = r == c ? 1.0 : 0.0;
            for (int a = 0; a < 3; a++)
                if (keep[a])
                    s += dd[a][r] / df[a] * grad[a][c];
            J[3 * r + c] = s;
        }
    return FFD_OK;
}

ffd_status ffd_lattice_general_jacobian(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                        double *out, ffd_error *err)
{
    int failed = 0;
    const long long nn = (long long)bind->n;
#pragma omp parallel for schedule(static) reduction(| : failed)
    for (long long ii = 0; ii < nn; ii++) {
        size_t i = (size_t)ii;
        double *J = out + 9 * i;
        if (!bind->inside[i] && bind->outside == FFD_OUTSIDE_FIXED) {
            memset(J, 0, 9 * sizeof(double));
            J[0] = J[4] = J[8] = 1.0;
            continue;
        }
        const double *S = bind->params + 3 * i;
        int keep[3] = {1, 1, 1};
        if (!bind->inside[i]) { /* clamped: constant along the clamped axes */
            double loc[3];
            to_local(lat, bind->out_point + 3 * i, loc);
            for (int a = 0; a < 3; a++)
                keep[a] = loc[a] >= 0 && loc[a] <= 1;
        }
        failed |= jacobian_at(lat, S, keep, J) != FFD_OK;
    }
    if (failed)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for the lattice Jacobian");
    return FFD_OK;
}

static size_t general_row(const void *self, size_t i, uint32_t *cols, double *w)
{
    const ffd_lattice_binding *b = self;
    if (!b->inside[i] && b->outside == FFD_OUTSIDE_FIXED)
        return 0;
    return weights_at(b->general, b->res, b->params + 3 * i, cols, w, NULL);
}

void ffd_lattice_general_linear_map(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                    ffd_linear_map *map)
{
    memset(map, 0, sizeof *map);
    map->self = bind;
    map->point_count = bind->n;
    map->column_count = ffd_lattice_control_count(lat);
    map->variable_count = map->column_count;
    map->tie = lat->gen->tie;
    map->max_row_nnz = lat->gen->max_nnz;
    map->row = general_row;
}

ffd_status ffd_lattice_general_transpose(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                         const double *wv, double *out, ffd_error *err)
{
    const struct ffd_lattice_general *g = lat->gen;
    size_t nc = ffd_lattice_control_count(lat);
    uint32_t *cols = ffd_malloc_array(g->max_nnz, sizeof *cols);
    double *w = ffd_malloc_array(g->max_nnz, sizeof *w);
    if (!cols || !w) {
        ffd_free(cols), ffd_free(w);
        return ffd_fail(err, FFD_ERR_NOMEM, "sensitivity transpose: out of memory");
    }
    memset(out, 0, nc * 3 * sizeof *out);
    for (size_t i = 0; i < bind->n; i++) { /* in index order: deterministic */
        size_t k = general_row(bind, i, cols, w);
        for (size_t e = 0; e < k; e++) {
            double *o = out + 3 * (size_t)(g->tie ? g->tie[cols[e]] : cols[e]);
            for (int c = 0; c < 3; c++)
                o[c] += w[e] * wv[3 * i + c];
        }
    }
    ffd_free(cols), ffd_free(w);
    return FFD_OK;
}

ffd_status ffd_lattice_general_fold_check(const ffd_lattice *lat, ffd_fold_report *out,
                                          ffd_error *err)
{
    const struct ffd_lattice_general *g = lat->gen;
    memset(out, 0, sizeof *out);
    out->cells = "lattice cell";
    out->min_det = NAN;
    uint32_t nc[3];
    double h[3];
    for (int a = 0; a < 3; a++) {
        const ffd_lattice_axis *ax = &g->axis[a];
        nc[a] = ax->interp == FFD_INTERP_BERNSTEIN ? ax->res - 1 : (uint32_t)ffd_lattice_axis_top(ax);
        h[a] = ffd_lattice_axis_top(ax) / nc[a];
    }
    size_t total = (size_t)nc[0] * nc[1] * nc[2];
    double *cell_min = ffd_malloc_array(total, sizeof(double));
    if (!cell_min)
        return ffd_fail(err, FFD_ERR_NOMEM, "fold check: out of memory");
    int failed = 0;
    const long long nn = (long long)total;
#pragma omp parallel for schedule(static) reduction(| : failed)
    for (long long ii = 0; ii < nn; ii++) {
        size_t c = (size_t)ii;
        uint32_t ijk[3] = {(uint32_t)(c % nc[0]), (uint32_t)(c / nc[0] % nc[1]),
                           (uint32_t)(c / ((size_t)nc[0] * nc[1]))};
        double lo = INFINITY;
        static const int keep[3] = {1, 1, 1};
        for (int s = 0; s < FOLD_GRID * FOLD_GRID * FOLD_GRID; s++) {
            double S[3], J[9];
            int gg[3] = {s % FOLD_GRID, s / FOLD_GRID % FOLD_GRID, s / (FOLD_GRID * FOLD_GRID)};
            for (int a = 0; a < 3; a++)
                S[a] = (ijk[a] + (double)gg[a] / (FOLD_GRID - 1)) * h[a];
            if (jacobian_at(lat, S, keep, J)) {
                failed = 1;
                break;
            }
            double dj = det3(J);
            if (!(dj >= lo))
                lo = dj;
        }
        cell_min[c] = lo;
    }
    if (failed) {
        ffd_free(cell_min);
        return ffd_fail(err, FFD_ERR_NOMEM, "fold check: out of memory");
    }
    size_t folded = 0;
    for (size_t c = 0; c < total; c++) {
        if (isnan(out->min_det) || cell_min[c] < out->min_det || isnan(cell_min[c]))
            out->min_det = cell_min[c];
        folded += !(cell_min[c] > 0);
    }
    out->cells_checked = total;
    out->samples = (size_t)FOLD_GRID * FOLD_GRID * FOLD_GRID * total;
    out->folded = folded;
    if (folded) {
        out->cell_ids = ffd_malloc_array(folded, sizeof(uint32_t));
        if (!out->cell_ids) {
            ffd_free(cell_min);
            return ffd_fail(err, FFD_ERR_NOMEM, "fold check: out of memory");
        }
        for (size_t c = 0, k = 0; c < total; c++)
            if (!(cell_min[c] > 0))
                out->cell_ids[k++] = (uint32_t)c;
    }
    ffd_free(cell_min);
    return FFD_OK;
}
