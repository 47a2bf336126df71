/* math — LAPACK wrapper: minimum-norm least squares via the SVD (dgelsd). */
#include "math/dense.h"

#include <lapacke.h>
#include <limits.h>

ffd_status ffd_dense_lstsq(size_t m, size_t n, size_t nrhs, double *A, double *B, double rcond,
                           size_t *rank, ffd_error *err)
{
    *rank = 0;
    if (m == 0 || n == 0 || nrhs == 0)
        return FFD_OK;
    if (m > INT_MAX || n > INT_MAX || nrhs > INT_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "least squares: system of %zu x %zu is too large", m, n);
    lapack_int M = (lapack_int)m, N = (lapack_int)n, NRHS = (lapack_int)nrhs;
    lapack_int ldb = M > N ? M : N, r = 0, info;
    size_t ns = m < n ? m : n;
    double *s = ffd_malloc_array(ns, sizeof *s);
    double wq = 0;
    lapack_int iwq = 0;
    double *work = NULL;
    lapack_int *iwork = NULL;
    ffd_status st = FFD_OK;
    if (!s)
        return ffd_fail(err, FFD_ERR_NOMEM, "least squares: out of memory");
    /* workspace query, then the solve with our own allocations */
    info = LAPACKE_dgelsd_work(LAPACK_COL_MAJOR, M, N, NRHS, A, M, B, ldb, s, rcond, &r, &wq, -1,
                               &iwq);
    if (info != 0) {
        st = ffd_fail(err, FFD_ERR_NUMERIC, "least squares: dgelsd workspace query failed (info %d)",
                      (int)info);
        goto done;
    }
    size_t lwork = (size_t)wq + 1, liwork = (size_t)(iwq > 1 ? iwq : 1);
    work = ffd_malloc_array(lwork, sizeof *work);
    iwork = ffd_malloc_array(liwork, sizeof *iwork);
    if (!work || !iwork) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "least squares: out of memory");
        goto done;
    }
    info = LAPACKE_dgelsd_work(LAPACK_COL_MAJOR, M, N, NRHS, A, M, B, ldb, s, rcond, &r, work,
                               (lapack_int)lwork, iwork);
    if (info > 0) {
        st = ffd_fail(err, FFD_ERR_NUMERIC, "least squares: SVD did not converge (%d)", (int)info);
        goto done;
    }
    if (info < 0) {
        st = ffd_fail(err, FFD_ERR_NUMERIC, "least squares: dgelsd argument %d invalid", (int)-info);
        goto done;
    }
    *rank = (size_t)r;
done:
    ffd_free(s);
    ffd_free(work);
    ffd_free(iwork);
    return st;
}
