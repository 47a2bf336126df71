/* manip — direct manipulation of free-form deformations (Hsu, Hughes & Kaufman
 * 1992, §3): move selected points to targets by the minimum-norm change of the
 * control points, dP = (B S)^+ dq (eq. 5-7), for one or many points that may
 * share control points (§3.2). Works on any ffd_linear_map, so on every
 * method whose deformer has one (ffd_deformer_linear_map). */
#include "manip/manip.h"
#include "math/dense.h"
#include "math/tolerance.h"

#include <math.h>
#include <string.h>

/* Row i of B S over the free variables: entries merged per variable, fixed slots dropped. */
static size_t tied_row(const ffd_linear_map *map, size_t point, uint32_t *cols, double *w,
                       uint32_t *vars, double *vw)
{
    size_t nnz = map->row(map->self, point, cols, w), k = 0;
    for (size_t e = 0; e < nnz; e++) {
        uint32_t v = map->tie ? map->tie[cols[e]] : cols[e];
        if (v == FFD_TIE_FIXED || w[e] == 0.0)
            continue;
        size_t f = 0;
        while (f < k && vars[f] != v)
            f++;
        if (f == k) {
            vars[k] = v;
            vw[k] = 0.0;
            k++;
        }
        vw[f] += w[e];
    }
    return k;
}

ffd_status ffd_manip_solve(const ffd_linear_map *map, const size_t *points, size_t k,
                           const double *current, const double *targets,
                           const ffd_manip_options *options, double *delta, double *residuals,
                           ffd_manip_result *result, ffd_error *err)
{
    ffd_manip_result res = {0, 0, 0.0};
    double rcond = options && options->rcond > 0 ? options->rcond : FFD_TOL_RCOND;
    if (options && !(options->rcond >= 0 && options->rcond < 1))
        return ffd_fail(err, FFD_ERR_INVALID, "rcond %g: expected a number in [0, 1)",
                        options->rcond);
    for (size_t c = 0; c < k; c++) {
        if (points[c] >= map->point_count)
            return ffd_fail(err, FFD_ERR_RANGE, "constraint %zu: point %zu out of range (%zu points)",
                            c, points[c], map->point_count);
        for (int d = 0; d < 3; d++) {
            if (!isfinite(targets[3 * c + d]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "constraint %zu: target is not finite", c);
            if (!isfinite(current[3 * c + d]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "constraint %zu: position is not finite", c);
        }
    }
    memset(delta, 0, map->variable_count * 3 * sizeof(double));
    if (k == 0) {
        if (result)
            *result = res;
        return FFD_OK;
    }

    ffd_status st = FFD_OK;
    size_t mr = map->max_row_nnz ? map->max_row_nnz : 1;
    uint32_t *cols = ffd_malloc_array(mr, sizeof *cols);
    double *w = ffd_malloc_array(mr, sizeof *w);
    uint32_t *rowvar = ffd_malloc_array(k, mr * sizeof *rowvar);
    double *roww = ffd_malloc_array(k, mr * sizeof *roww);
    size_t *rownnz = ffd_malloc_array(k, sizeof *rownnz);
    uint32_t *compact = ffd_malloc_array(map->variable_count, sizeof *compact);
    uint32_t *used = ffd_malloc_array(k, mr * sizeof *used);
    double *A = NULL, *B = NULL;
    if (!cols || !w || !rowvar || !roww || !rownnz || !compact || !used) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "direct manipulation: out of memory");
        goto done;
    }
    /* gather the rows of the constrained points, listing each variable once (§3.2) */
    for (size_t v = 0; v < map->variable_count; v++)
        compact[v] = UINT32_MAX;
    size_t nv = 0;
    for (size_t c = 0; c < k; c++) {
        rownnz[c] = tied_row(map, points[c], cols, w, rowvar + c * mr, roww + c * mr);
        for (size_t e = 0; e < rownnz[c]; e++) {
            uint32_t v = rowvar[c * mr + e];
            if (compact[v] == UINT32_MAX) {
                compact[v] = (uint32_t)nv;
                used[nv++] = v;
            }
        }
    }
    res.variables_used = nv;
    if (nv > 0) {
        size_t ldb = k > nv ? k : nv;
        A = ffd_calloc(k * nv, sizeof *A);
        B = ffd_calloc(ldb * 3, sizeof *B);
        if (!A || !B) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "direct manipulation: out of memory (%zu x %zu)", k, nv);
            goto done;
        }
        for (size_t c = 0; c < k; c++) {
            for (size_t e = 0; e < rownnz[c]; e++)
                A[(size_t)compact[rowvar[c * mr + e]] * k + c] = roww[c * mr + e];
            for (int d = 0; d < 3; d++)
                B[(size_t)d * ldb + c] = targets[3 * c + d] - current[3 * c + d]; /* dq, eq. 2 */
        }
        /* dP = (B S)^+ dq (eq. 7), by SVD so rank deficiency is normal */
        st = ffd_dense_lstsq(k, nv, 3, A, B, rcond, &res.rank, err);
        if (st != FFD_OK)
            goto done;
        for (size_t j = 0; j < nv; j++)
            for (int d = 0; d < 3; d++)
                delta[3 * (size_t)used[j] + d] = B[(size_t)d * ldb + j];
    }
    /* the residual of every constraint, with the change applied */
    for (size_t c = 0; c < k; c++) {
        double r2 = 0;
        for (int d = 0; d < 3; d++) {
            double x = current[3 * c + d];
            for (size_t e = 0; e < rownnz[c]; e++)
                x += roww[c * mr + e] * delta[3 * (size_t)rowvar[c * mr + e] + d];
            double diff = x - targets[3 * c + d];
            r2 += diff * diff;
        }
        double r = sqrt(r2);
        if (residuals)
            residuals[c] = r;
        if (r > res.max_residual)
            res.max_residual = r;
    }
    if (result)
        *result = res;
done:
    ffd_free(cols);
    ffd_free(w);
    ffd_free(rowvar);
    ffd_free(roww);
    ffd_free(rownnz);
    ffd_free(compact);
    ffd_free(used);
    ffd_free(A);
    ffd_free(B);
    return st;
}
