/* lattice — the Jacobian of the deformation (for normals, in displacement
 * form like the evaluation: lattice_eval.c) and the weight rows
 * of bound points over the control slots (for direct manipulation, Hsu et al.
 * 1992 §3: the row matrix B of eq. 2 and the selection matrix S of eq. 6). */
#include "lattice/lattice.h"

#include <math.h>
#include <string.h>

/* Parameters pulled this far inside the domain where the rest map is flat
 * (the tripled border, where dS/dx is unbounded) to take the limit Jacobian. */
#define JACOBIAN_NUDGE 1e-4

ffd_status ffd_lattice_jacobian(const ffd_lattice *lat, const ffd_lattice_binding *bind, double *out,
                                ffd_error *err)
{
    ffd_status st = ffd_lattice_check_binding(lat, bind, err);
    if (st != FFD_OK)
        return st;
    if (lat->gen)
        return ffd_lattice_general_jacobian(lat, bind, out, err);
    const long long nn = (long long)bind->n;
    const int bspline = lat->basis == FFD_BASIS_BSPLINE;
#pragma omp parallel for schedule(static)
    for (long long ii = 0; ii < nn; ii++) {
        size_t i = (size_t)ii;
        double *J = out + 9 * i;
        if (!bind->inside[i] && bind->outside == FFD_OUTSIDE_FIXED) {
            memset(J, 0, 9 * sizeof(double));
            J[0] = J[4] = J[8] = 1.0;
            continue;
        }
        double S[3], g[3];
        memcpy(S, bind->params + 3 * i, sizeof S);
        /* an outside point clamped (CLAMP, or EXTRAPOLATE on the B-spline) has
         * its parameters held at the boundary along the clamped axes: the
         * deformation does not vary along them (dS/d(local) = 0) */
        const int clamped = !bind->inside[i] && (bspline || bind->outside != FFD_OUTSIDE_EXTRAPOLATE);
        for (int c = 0; c < 3; c++) {
            g[c] = 1.0; /* dS/d(local) */
            const double top = bspline ? (double)lat->res[c] + 1.0 : 1.0;
            if (clamped && (S[c] <= 0.0 || S[c] >= top)) {
                g[c] = 0.0;
                continue;
            }
            if (bspline) {
                double hi = (double)lat->res[c] + 1.0;
                if (S[c] < JACOBIAN_NUDGE)
                    S[c] = JACOBIAN_NUDGE;
                if (S[c] > hi - JACOBIAN_NUDGE)
                    S[c] = hi - JACOBIAN_NUDGE;
                double df;
                ffd_bspline_rest_map(lat->res[c], S[c], &df);
                g[c] = 1.0 / df;
            }
        }
        double d[3], dd[3][3];
        ffd_lattice_displacement_at(lat, S, d, dd);
        /* The rest lattice reproduces x (linear precision), so
         * J = I + sum_a dD/dS_a (dS_a/dlocal_a) dual_a^T: exactly the identity
         * where no control point of the support moved (normals keep their bytes). */
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                J[3 * r + c] = (r == c ? 1.0 : 0.0) + (dd[0][r] * g[0] * lat->dual[0][c] +
                                                       dd[1][r] * g[1] * lat->dual[1][c] +
                                                       dd[2][r] * g[2] * lat->dual[2][c]);
    }
    if (bind->falloff)
        ffd_lattice_falloff_jacobian(lat, bind, out);
    return FFD_OK;
}

/* World Jacobian of the map at global parameters S (as ffd_lattice_jacobian
 * for an inside point). */
static void jacobian_at(const ffd_lattice *lat, const double S_in[3], double J[9])
{
    const int bspline = lat->basis == FFD_BASIS_BSPLINE;
    double S[3], g[3];
    for (int c = 0; c < 3; c++) {
        S[c] = S_in[c];
        g[c] = 1.0;
        if (bspline) {
            double hi = (double)lat->res[c] + 1.0;
            if (S[c] < JACOBIAN_NUDGE)
                S[c] = JACOBIAN_NUDGE;
            if (S[c] > hi - JACOBIAN_NUDGE)
                S[c] = hi - JACOBIAN_NUDGE;
            double df;
            ffd_bspline_rest_map(lat->res[c], S[c], &df);
            g[c] = 1.0 / df;
        }
    }
    double d[3], dd[3][3];
    ffd_lattice_displacement_at(lat, S, d, dd);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            J[3 * r + c] = (r == c ? 1.0 : 0.0) + (dd[0][r] * g[0] * lat->dual[0][c] +
                                                   dd[1][r] * g[1] * lat->dual[1][c] +
                                                   dd[2][r] * g[2] * lat->dual[2][c]);
}

static double det3(const double m[9])
{
    return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
           m[2] * (m[3] * m[7] - m[4] * m[6]);
}

#define FOLD_GRID 5 /* samples per axis and lattice cell */

ffd_status ffd_lattice_fold_check(const ffd_lattice *lat, ffd_fold_report *out, ffd_error *err)
{
    if (lat->gen)
        return ffd_lattice_general_fold_check(lat, out, err);
    const int bspline = lat->basis == FFD_BASIS_BSPLINE;
    memset(out, 0, sizeof *out);
    out->cells = "lattice cell";
    out->min_det = NAN;
    /* cells per axis and the parameter span of one: B-spline knot spans
     * (global parameter 0..res+1), Bernstein control-grid cells (0..1) */
    uint32_t nc[3];
    double h[3];
    for (int a = 0; a < 3; a++) {
        nc[a] = bspline ? lat->res[a] + 1 : (lat->res[a] > 1 ? lat->res[a] - 1 : 1);
        h[a] = bspline ? 1.0 : 1.0 / nc[a];
    }
    size_t total = (size_t)nc[0] * nc[1] * nc[2];
    double *cell_min = ffd_malloc_array(total, sizeof(double));
    if (!cell_min)
        return ffd_fail(err, FFD_ERR_NOMEM, "fold check: out of memory");
    const long long nn = (long long)total;
#pragma omp parallel for schedule(static)
    for (long long ii = 0; ii < nn; ii++) {
        size_t c = (size_t)ii;
        uint32_t ijk[3] = {(uint32_t)(c % nc[0]), (uint32_t)(c / nc[0] % nc[1]),
                           (uint32_t)(c / ((size_t)nc[0] * nc[1]))};
        double lo = INFINITY;
        /* a 5x5x5 grid at fractions 0, 1/4, .., 1 of the cell: the corners
         * and centre alone miss folds inside a knot span (a cubic's
         * derivative turns between them) */
        for (int s = 0; s < FOLD_GRID * FOLD_GRID * FOLD_GRID; s++) {
            double S[3], J[9];
            int g[3] = {s % FOLD_GRID, s / FOLD_GRID % FOLD_GRID, s / (FOLD_GRID * FOLD_GRID)};
            for (int a = 0; a < 3; a++)
                S[a] = (ijk[a] + (double)g[a] / (FOLD_GRID - 1)) * h[a];
            jacobian_at(lat, S, J);
            double dj = det3(J);
            if (!(dj >= lo))
                lo = dj; /* a NaN is kept: it is not > 0 */
        }
        cell_min[c] = lo;
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

static size_t lattice_row(const void *self, size_t i, uint32_t *cols, double *w)
{
    const ffd_lattice_binding *b = self;
    if (!b->inside[i] && b->outside == FFD_OUTSIDE_FIXED)
        return 0; /* a fixed outside point does not follow the control points */
    const double *S = b->params + 3 * i;
    double bb[3][FFD_BERNSTEIN_MAX_RES > 4 ? FFD_BERNSTEIN_MAX_RES : 4];
    uint32_t first[3], cnt[3], ext[3];
    const int bspline = b->basis == FFD_BASIS_BSPLINE;
    for (int c = 0; c < 3; c++) {
        ffd_axis_basis(b->basis, b->res[c], S[c], &first[c], bb[c], NULL);
        cnt[c] = bspline ? 4 : b->res[c];
        ext[c] = bspline ? b->res[c] + 4 : b->res[c];
    }
    size_t k = 0;
    for (uint32_t a = 0; a < cnt[0]; a++)
        for (uint32_t bj = 0; bj < cnt[1]; bj++)
            for (uint32_t c = 0; c < cnt[2]; c++) {
                cols[k] = (uint32_t)((((size_t)(first[0] + a)) * ext[1] + first[1] + bj) * ext[2] +
                                     first[2] + c);
                w[k] = bb[0][a] * bb[1][bj] * bb[2][c];
                k++;
            }
    if (b->falloff) { /* FFD_OUTSIDE_FALLOFF: the row scaled by the point's factor */
        if (b->falloff[i] == 0.0)
            return 0;
        for (size_t e = 0; e < k; e++)
            w[e] *= b->falloff[i];
    }
    return k;
}

void ffd_lattice_linear_map(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                            ffd_linear_map *map)
{
    if (lat->gen) {
        ffd_lattice_general_linear_map(lat, bind, map);
        return;
    }
    memset(map, 0, sizeof *map);
    map->self = bind;
    map->point_count = bind->n;
    map->column_count = (size_t)lat->ext[0] * lat->ext[1] * lat->ext[2];
    map->variable_count = ffd_lattice_control_count(lat);
    map->tie = lat->basis == FFD_BASIS_BSPLINE ? lat->tie : NULL;
    map->max_row_nnz = lat->basis == FFD_BASIS_BSPLINE ? 64 : ffd_lattice_control_count(lat);
    map->row = lattice_row;
}
