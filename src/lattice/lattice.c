/* lattice — creation, control points and the parallelepiped box. */
#include "lattice/lattice.h"
#include "math/tolerance.h"

#include <math.h>
#include <string.h>

uint32_t ffd_basis_min_resolution(ffd_basis basis)
{
    (void)basis;
    return 2;
}

static double det3(const double a[3], const double b[3], const double c[3])
{
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
           a[2] * (b[0] * c[1] - b[1] * c[0]);
}

static double norm3(const double a[3])
{
    return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
}

ffd_status ffd_box_fit(const double *points, size_t n, double margin, ffd_box *box, ffd_error *err)
{
    if (n == 0)
        return ffd_fail(err, FFD_ERR_INVALID, "cannot fit a lattice box to zero points");
    if (!(margin >= 0) || !isfinite(margin))
        return ffd_fail(err, FFD_ERR_INVALID, "margin %g: expected a finite number >= 0", margin);
    double lo[3], hi[3];
    for (int c = 0; c < 3; c++)
        lo[c] = hi[c] = points[c];
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            double v = points[3 * i + c];
            if (!isfinite(v))
                return ffd_fail(err, FFD_ERR_NONFINITE, "point %zu has a non-finite coordinate", i);
            if (v < lo[c])
                lo[c] = v;
            if (v > hi[c])
                hi[c] = v;
        }
    double ext[3], diag = 0;
    for (int c = 0; c < 3; c++) {
        ext[c] = hi[c] - lo[c];
        diag += ext[c] * ext[c];
    }
    diag = sqrt(diag);
    double largest = fmax(ext[0], fmax(ext[1], ext[2]));
    if (!(largest <= FFD_BOX_MAX_EXTENT) || !isfinite(diag))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "the bounding box (extent %g x %g x %g) is too large for a lattice box "
                        "(extents up to %g)",
                        ext[0], ext[1], ext[2], FFD_BOX_MAX_EXTENT);
    if (largest > 0 && largest < FFD_BOX_MIN_EXTENT)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "the bounding box is degenerate (extent %g x %g x %g): too small for a "
                        "lattice box (extents from %g)",
                        ext[0], ext[1], ext[2], FFD_BOX_MIN_EXTENT);
    memset(box, 0, sizeof *box);
    for (int c = 0; c < 3; c++) {
        double e = ext[c];
        double pad = margin * e;
        if (e <= 1e-12 * diag || e == 0) { /* flat along this axis: give it thickness */
            pad = diag > 0 ? (margin > 0 ? margin : 0.05) * diag : 0.5;
            e = 0;
        }
        box->origin[c] = lo[c] - pad;
        box->axes[c][c] = e + 2 * pad;
    }
    return FFD_OK;
}

void ffd_lattice_sync(ffd_lattice *lat)
{
    if (lat->gen) {
        ffd_lattice_general_sync(lat);
        return;
    }
    size_t ne = (size_t)lat->ext[0] * lat->ext[1] * lat->ext[2];
    for (size_t e = 0; e < ne; e++) {
        size_t j = lat->basis == FFD_BASIS_BSPLINE ? (size_t)lat->tie[e] : e;
        for (int c = 0; c < 3; c++) {
            lat->P_ext[3 * e + c] = lat->P[3 * j + c];
            lat->D_ext[3 * e + c] = lat->P[3 * j + c] - lat->P_rest[3 * j + c];
        }
    }
}

ffd_status ffd_lattice_create(ffd_basis basis, const ffd_box *box, const uint32_t res[3],
                              ffd_lattice **out, ffd_error *err)
{
    *out = NULL;
    if (basis != FFD_BASIS_BSPLINE && basis != FFD_BASIS_BERNSTEIN)
        return ffd_fail(err, FFD_ERR_INVALID, "unknown lattice basis %d", (int)basis);
    uint32_t minres = ffd_basis_min_resolution(basis);
    uint32_t maxres = basis == FFD_BASIS_BERNSTEIN ? FFD_BERNSTEIN_MAX_RES : FFD_LATTICE_MAX_RES;
    const char *bname = basis == FFD_BASIS_BERNSTEIN ? "bernstein" : "bspline";
    for (int c = 0; c < 3; c++) {
        if (res[c] < minres)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "lattice resolution %u along axis %d is below the minimum %u of the %s "
                            "basis",
                            res[c], c, minres, bname);
        if (res[c] > maxres)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "lattice resolution %u along axis %d is above the maximum %u of the %s "
                            "basis",
                            res[c], c, maxres, bname);
    }
    for (int c = 0; c < 3; c++) {
        if (!isfinite(box->origin[c]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "lattice box origin is not finite");
        for (int d = 0; d < 3; d++)
            if (!isfinite(box->axes[c][d]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "lattice box axis %d is not finite", c);
    }
    double det = det3(box->axes[0], box->axes[1], box->axes[2]);
    double scale = norm3(box->axes[0]) * norm3(box->axes[1]) * norm3(box->axes[2]);
    if (!(fabs(det) > FFD_TOL_VOLUME * scale) || scale == 0)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "lattice box has zero volume (axes are zero or linearly dependent)");

    ffd_lattice *lat = ffd_calloc(1, sizeof *lat);
    if (!lat)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory creating the lattice");
    lat->basis = basis;
    memcpy(lat->res, res, sizeof lat->res);
    lat->box = *box;
    /* dual basis: rows of inverse([a b c]) where a, b, c are columns */
    const double *a = box->axes[0], *b = box->axes[1], *cc = box->axes[2];
    double inv = 1.0 / det;
    lat->dual[0][0] = (b[1] * cc[2] - b[2] * cc[1]) * inv;
    lat->dual[0][1] = (b[2] * cc[0] - b[0] * cc[2]) * inv;
    lat->dual[0][2] = (b[0] * cc[1] - b[1] * cc[0]) * inv;
    lat->dual[1][0] = (cc[1] * a[2] - cc[2] * a[1]) * inv;
    lat->dual[1][1] = (cc[2] * a[0] - cc[0] * a[2]) * inv;
    lat->dual[1][2] = (cc[0] * a[1] - cc[1] * a[0]) * inv;
    lat->dual[2][0] = (a[1] * b[2] - a[2] * b[1]) * inv;
    lat->dual[2][1] = (a[2] * b[0] - a[0] * b[2]) * inv;
    lat->dual[2][2] = (a[0] * b[1] - a[1] * b[0]) * inv;

    size_t count = (size_t)res[0] * res[1] * res[2];
    lat->P = ffd_malloc_array(count, 3 * sizeof(double));
    lat->P_rest = ffd_malloc_array(count, 3 * sizeof(double));
    if (!lat->P || !lat->P_rest)
        goto oom;
    for (uint32_t i = 0; i < res[0]; i++)
        for (uint32_t j = 0; j < res[1]; j++)
            for (uint32_t k = 0; k < res[2]; k++)
                ffd_lattice_rest_point(lat, i, j, k,
                                       lat->P_rest + 3 * (((size_t)i * res[1] + j) * res[2] + k));
    memcpy(lat->P, lat->P_rest, count * 3 * sizeof(double));

    if (basis == FFD_BASIS_BSPLINE) {
        for (int c = 0; c < 3; c++) {
            lat->ext[c] = res[c] + 4;
            if (ffd_bspline_rest_knots(res[c], &lat->knots_value[c]) != FFD_OK)
                goto oom;
        }
        size_t ne = (size_t)lat->ext[0] * lat->ext[1] * lat->ext[2];
        lat->P_ext = ffd_malloc_array(ne, 3 * sizeof(double));
        lat->D_ext = ffd_malloc_array(ne, 3 * sizeof(double));
        lat->tie = ffd_malloc_array(ne, sizeof(uint32_t));
        if (!lat->P_ext || !lat->D_ext || !lat->tie)
            goto oom;
        for (uint32_t i = 0; i < lat->ext[0]; i++)
            for (uint32_t j = 0; j < lat->ext[1]; j++)
                for (uint32_t k = 0; k < lat->ext[2]; k++) {
                    size_t e = ((size_t)i * lat->ext[1] + j) * lat->ext[2] + k;
                    lat->tie[e] = (ffd_bspline_tie(i, res[0]) * res[1] + ffd_bspline_tie(j, res[1])) *
                                      res[2] +
                                  ffd_bspline_tie(k, res[2]);
                }
        ffd_lattice_sync(lat);
    } else {
        memcpy(lat->ext, res, sizeof lat->ext);
        lat->P_ext = lat->P;
        lat->D_ext = ffd_calloc(count, 3 * sizeof(double));
        if (!lat->D_ext)
            goto oom;
    }
    *out = lat;
    return FFD_OK;
oom:
    ffd_lattice_destroy(lat);
    return ffd_fail(err, FFD_ERR_NOMEM, "out of memory creating a %ux%ux%u lattice", res[0], res[1],
                    res[2]);
}

void ffd_lattice_destroy(ffd_lattice *lat)
{
    if (!lat)
        return;
    ffd_lattice_general_free(lat->gen);
    if (lat->P_ext != lat->P)
        ffd_free(lat->P_ext);
    ffd_free(lat->D_ext);
    ffd_free(lat->P);
    ffd_free(lat->P_rest);
    ffd_free(lat->tie);
    for (int c = 0; c < 3; c++)
        ffd_free(lat->knots_value[c]);
    ffd_free(lat);
}

ffd_basis ffd_lattice_basis(const ffd_lattice *lat) { return lat->basis; }
void ffd_lattice_box(const ffd_lattice *lat, ffd_box *box) { *box = lat->box; }
void ffd_lattice_resolution(const ffd_lattice *lat, uint32_t res[3])
{
    memcpy(res, lat->res, sizeof lat->res);
}
size_t ffd_lattice_control_count(const ffd_lattice *lat)
{
    return (size_t)lat->res[0] * lat->res[1] * lat->res[2];
}
const double *ffd_lattice_control_points(const ffd_lattice *lat) { return lat->P; }

void ffd_lattice_rest_point(const ffd_lattice *lat, uint32_t i, uint32_t j, uint32_t k, double out[3])
{
    if (lat->gen) {
        ffd_lattice_general_rest_point(lat, i, j, k, out);
        return;
    }
    double s = (double)i / (double)(lat->res[0] - 1);
    double t = (double)j / (double)(lat->res[1] - 1);
    double u = (double)k / (double)(lat->res[2] - 1);
    for (int c = 0; c < 3; c++)
        out[c] = lat->box.origin[c] + s * lat->box.axes[0][c] + t * lat->box.axes[1][c] +
                 u * lat->box.axes[2][c];
}

ffd_status ffd_lattice_set_control_points(ffd_lattice *lat, const double *points, ffd_error *err)
{
    size_t count = ffd_lattice_control_count(lat);
    for (size_t i = 0; i < 3 * count; i++)
        if (!isfinite(points[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "control point %zu is not finite", i / 3);
    memcpy(lat->P, points, count * 3 * sizeof(double));
    ffd_lattice_sync(lat);
    return FFD_OK;
}

ffd_status ffd_lattice_move(ffd_lattice *lat, const uint32_t index[3], const double delta[3],
                            ffd_error *err)
{
    for (int c = 0; c < 3; c++)
        if (index[c] >= lat->res[c])
            return ffd_fail(err, FFD_ERR_RANGE,
                            "control point index [%u,%u,%u] out of range (lattice is %ux%ux%u)",
                            index[0], index[1], index[2], lat->res[0], lat->res[1], lat->res[2]);
    for (int c = 0; c < 3; c++)
        if (!isfinite(delta[c]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "control point move is not finite");
    size_t e = ((size_t)index[0] * lat->res[1] + index[1]) * lat->res[2] + index[2];
    if (lat->gen) /* a tied control point moves its group */
        e = ffd_lattice_general_representative(lat, e);
    double *p = lat->P + 3 * e;
    double np[3];
    for (int c = 0; c < 3; c++) {
        np[c] = p[c] + delta[c];
        if (!isfinite(np[c]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "control point move overflows");
    }
    memcpy(p, np, sizeof np);
    ffd_lattice_sync(lat);
    return FFD_OK;
}

ffd_status ffd_lattice_add(ffd_lattice *lat, const double *delta, ffd_error *err)
{
    size_t n = 3 * ffd_lattice_control_count(lat);
    for (size_t i = 0; i < n; i++)
        if (!isfinite(delta[i]) || !isfinite(lat->P[i] + delta[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "control point change %zu is not finite", i / 3);
    for (size_t i = 0; i < n; i++)
        lat->P[i] += delta[i];
    ffd_lattice_sync(lat);
    return FFD_OK;
}

void ffd_lattice_reset(ffd_lattice *lat)
{
    memcpy(lat->P, lat->P_rest, ffd_lattice_control_count(lat) * 3 * sizeof(double));
    ffd_lattice_sync(lat);
}
