/* manip — direct manipulation of free-form deformations (Hsu, Hughes & Kaufman
 * 1992, §3): move selected points to targets by the minimum-norm change of the
 * control points, dP = (B S)^+ dq (eq. 5-7), for one or many points that may
 * share control points (§3.2). Works on any ffd_linear_map, so on every
 * method whose deformer has one (ffd_deformer_linear_map).
 * Hard constraints (pins) are solved first and the soft ones (the drag) in
 * the null space of their rows, so that an over-constrained drag comes up
 * short instead of making the pins slide (solve_hard_soft). */
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

/* The largest |entry| of a k by 3 array. */
static double max_abs(const double *v, size_t k)
{
    double m = 0;
    for (size_t i = 0; i < 3 * k; i++)
        if (fabs(v[i]) > m)
            m = fabs(v[i]);
    return m;
}

/* Pins hard, drag soft. A (k by nv, column-major, leading dimension k) holds
 * the rows of B S: the first h hard (A_h), the other s = k - h soft (A_s);
 * dq (k by 3, leading dimension k) the wanted changes. Writes to x (nv by 3,
 * column-major) dV = dV_h + dV_s, where dV_h = A_h^+ dq_h (the minimum-norm
 * change meeting the pins, or their least-squares fit when they contradict
 * each other) and dV_s = C^+ (dq_s - A_s dV_h) with C = A_s (I - A_h^+ A_h),
 * the soft rows projected on the null space of the hard ones: C^+ = N (A_s
 * N)^+ for an orthonormal basis N of that null space, so dV_s moves no pin
 * and is the minimum-norm change bringing the soft points closest. dV_h lies
 * in the row space of A_h and dV_s in its null space, so when all rows can
 * be met dV is the minimum-norm solution of the whole system, (B S)^+ dq as
 * before. */
static ffd_status solve_hard_soft(size_t k, size_t h, size_t nv, const double *A, const double *dq,
                                  double rcond, double *x, size_t *rank, ffd_error *err)
{
    size_t s = k - h, ldh = h > nv ? h : nv, lds = s > nv ? s : nv, rank_h = 0, rank_c = 0;
    ffd_status st = FFD_OK;
    double *Ah = ffd_malloc_array(h, nv * sizeof *Ah);
    double *Rh = ffd_calloc(ldh * (3 + s), sizeof *Rh);
    double *C = ffd_malloc_array(s, nv * sizeof *C);
    double *Rs = ffd_calloc(lds * 3, sizeof *Rs);
    if (!Ah || !Rh || !C || !Rs) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "direct manipulation: out of memory (%zu x %zu)", k, nv);
        goto done;
    }
    /* one factorisation of A_h for [dq_h | A_h A_s^T]: columns 0-2 give
     * dV_h, column 3 + c gives A_h^+ A_h a_c (a_c: soft row c) */
    for (size_t j = 0; j < nv; j++)
        for (size_t r = 0; r < h; r++)
            Ah[j * h + r] = A[j * k + r];
    for (size_t r = 0; r < h; r++) {
        for (int d = 0; d < 3; d++)
            Rh[(size_t)d * ldh + r] = dq[(size_t)d * k + r];
        for (size_t c = 0; c < s; c++) {
            double dot = 0;
            for (size_t j = 0; j < nv; j++)
                dot += A[j * k + r] * A[j * k + h + c];
            Rh[(3 + c) * ldh + r] = dot;
        }
    }
    if ((st = ffd_dense_lstsq(h, nv, 3 + s, Ah, Rh, rcond, &rank_h, err)))
        goto done;
    /* C = A_s - A_s A_h^+ A_h (A_h^+ A_h is symmetric), and the soft rows' remaining change */
    double norm_s = 0, norm_c = 0;
    for (size_t j = 0; j < nv; j++)
        for (size_t c = 0; c < s; c++) {
            double a = A[j * k + h + c];
            C[j * s + c] = a - Rh[(3 + c) * ldh + j];
            norm_s += a * a;
            norm_c += C[j * s + c] * C[j * s + c];
        }
    for (size_t c = 0; c < s; c++)
        for (int d = 0; d < 3; d++) {
            double v = dq[(size_t)d * k + h + c];
            for (size_t j = 0; j < nv; j++)
                v -= A[j * k + h + c] * Rh[(size_t)d * ldh + j];
            Rs[(size_t)d * lds + c] = v;
        }
    /* Singular values of C are measured against A_s, not against C itself:
     * when the pins leave no freedom C is rounding noise, which a threshold
     * relative to its own largest singular value would amplify. */
    norm_s = sqrt(norm_s);
    norm_c = sqrt(norm_c);
    if (norm_c > rcond * norm_s) {
        double rc = rcond * norm_s / norm_c;
        if ((st = ffd_dense_lstsq(s, nv, 3, C, Rs, rc < 0.5 ? rc : 0.5, &rank_c, err)))
            goto done;
    } else {
        memset(Rs, 0, lds * 3 * sizeof *Rs); /* nothing left to move the soft points */
    }
    for (size_t j = 0; j < nv; j++)
        for (int d = 0; d < 3; d++)
            x[(size_t)d * nv + j] = Rh[(size_t)d * ldh + j] + Rs[(size_t)d * lds + j];
    *rank = rank_h + rank_c;
done:
    ffd_free(Ah);
    ffd_free(Rh);
    ffd_free(C);
    ffd_free(Rs);
    return st;
}

ffd_status ffd_manip_solve(const ffd_linear_map *map, const size_t *points, size_t k,
                           const double *current, const double *targets,
                           const ffd_manip_options *options, double *delta, double *residuals,
                           ffd_manip_result *result, ffd_error *err)
{
    ffd_manip_result res = {0, 0, 0.0, 1, 0.0, 0.0};
    double rcond = options && options->rcond > 0 ? options->rcond : FFD_TOL_RCOND;
    size_t hard = options ? options->hard_count : 0;
    if (options && !(options->rcond >= 0 && options->rcond < 1))
        return ffd_fail(err, FFD_ERR_INVALID, "rcond %g: expected a number in [0, 1)",
                        options->rcond);
    if (hard > k)
        return ffd_fail(err, FFD_ERR_RANGE, "hard_count %zu: more than the %zu constraints", hard,
                        k);
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
        if (hard > 0 && hard < k) {
            /* pins hard, drag soft */
            double *x = ffd_malloc_array(nv, 3 * sizeof *x), *dq = ffd_malloc_array(k, 3 * sizeof *dq);
            if (!x || !dq) {
                ffd_free(x);
                ffd_free(dq);
                st = ffd_fail(err, FFD_ERR_NOMEM, "direct manipulation: out of memory");
                goto done;
            }
            for (int d = 0; d < 3; d++)
                memcpy(dq + (size_t)d * k, B + (size_t)d * ldb, k * sizeof *dq);
            st = solve_hard_soft(k, hard, nv, A, dq, rcond, x, &res.rank, err);
            for (size_t j = 0; !st && j < nv; j++)
                for (int d = 0; d < 3; d++)
                    delta[3 * (size_t)used[j] + d] = x[(size_t)d * nv + j];
            ffd_free(x);
            ffd_free(dq);
            if (st)
                goto done;
        } else {
            /* dP = (B S)^+ dq (eq. 7), by SVD so rank deficiency is normal */
            st = ffd_dense_lstsq(k, nv, 3, A, B, rcond, &res.rank, err);
            if (st != FFD_OK)
                goto done;
            for (size_t j = 0; j < nv; j++)
                for (int d = 0; d < 3; d++)
                    delta[3 * (size_t)used[j] + d] = B[(size_t)d * ldb + j];
        }
    }
    /* the size of the positions involved, for the test of the hard residuals */
    double size = max_abs(current, k), reach = max_abs(targets, k);
    size = size > reach ? size : reach;
    size = size > 1 ? size : 1;
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
        if (c < hard && r > res.hard_residual)
            res.hard_residual = r;
        if (c >= hard && r > res.soft_residual)
            res.soft_residual = r;
    }
    res.hard_met = res.hard_residual <= FFD_TOL_REACH * size;
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
