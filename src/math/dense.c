/* math — LAPACK wrappers: minimum-norm least squares via the SVD (dgelsd);
 * symmetric indefinite factor, solve and condition estimate (dsytrf, dsytrs,
 * dsycon). */
#include "math/dense.h"

#include <lapacke.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <string.h>

/* OpenBLAS's own thread count (declared in OpenBLAS's cblas.h, which other
 * BLAS packages' cblas.h lacks; libopenblas is linked directly, CMakeLists.txt
 * OPENBLAS_LIB). */
void openblas_set_num_threads(int num_threads);

static void set_blas_single_thread(void) { openblas_set_num_threads(1); }

/* The library's matrices are small (a drag's constraints by the control
 * points) and its parallelism is OpenMP over points. OpenBLAS's pthread pool,
 * once woken by a call, spins on the same cores as the OpenMP team for a
 * while: a 100K-point evaluation right after a solve took 15 ms instead of
 * 3 ms. One thread gives the same results (OpenBLAS splits the work, not the
 * sums, across threads) with none of the contention. Set once, at the
 * library's first BLAS/LAPACK call. */
void ffd_blas_single_thread(void)
{
    static pthread_once_t once = PTHREAD_ONCE_INIT;
    pthread_once(&once, set_blas_single_thread);
}

ffd_status ffd_dense_lstsq(size_t m, size_t n, size_t nrhs, double *A, double *B, double rcond,
                           size_t *rank, ffd_error *err)
{
    ffd_blas_single_thread();
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

/* ---- symmetric indefinite systems (dsytrf / dsytrs / dsycon) ------------ */

_Static_assert(sizeof(lapack_int) == sizeof(int), "ipiv is int: LAPACK must use 32-bit integers");

ffd_status ffd_dense_sym_factor(size_t n, double *A, int *ipiv, int *singular, ffd_error *err)
{
    ffd_blas_single_thread();
    *singular = 0;
    if (n == 0)
        return FFD_OK;
    if (n > INT_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "symmetric factor: system of %zu is too large", n);
    lapack_int N = (lapack_int)n, info;
    double wq = 0;
    info = LAPACKE_dsytrf_work(LAPACK_COL_MAJOR, 'L', N, A, N, (lapack_int *)ipiv, &wq, -1);
    if (info != 0)
        return ffd_fail(err, FFD_ERR_NUMERIC,
                        "symmetric factor: dsytrf workspace query failed (info %d)", (int)info);
    size_t lwork = (size_t)wq + 1;
    if (lwork < n)
        lwork = n;
    double *work = ffd_malloc_array(lwork, sizeof *work);
    if (!work)
        return ffd_fail(err, FFD_ERR_NOMEM, "symmetric factor: out of memory");
    info = LAPACKE_dsytrf_work(LAPACK_COL_MAJOR, 'L', N, A, N, (lapack_int *)ipiv, work,
                               (lapack_int)lwork);
    ffd_free(work);
    if (info < 0)
        return ffd_fail(err, FFD_ERR_NUMERIC, "symmetric factor: dsytrf argument %d invalid",
                        (int)-info);
    if (info > 0)
        *singular = 1;
    return FFD_OK;
}

ffd_status ffd_dense_sym_solve(size_t n, size_t nrhs, const double *factor, const int *ipiv,
                               double *B, ffd_error *err)
{
    ffd_blas_single_thread();
    if (n == 0 || nrhs == 0)
        return FFD_OK;
    if (n > INT_MAX || nrhs > INT_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "symmetric solve: system of %zu is too large", n);
    lapack_int N = (lapack_int)n;
    lapack_int info = LAPACKE_dsytrs_work(LAPACK_COL_MAJOR, 'L', N, (lapack_int)nrhs, factor, N,
                                          (const lapack_int *)ipiv, B, N);
    if (info != 0)
        return ffd_fail(err, FFD_ERR_NUMERIC, "symmetric solve: dsytrs failed (info %d)",
                        (int)info);
    return FFD_OK;
}

ffd_status ffd_dense_sym_rcond(size_t n, const double *factor, const int *ipiv, double anorm,
                               double *rcond, ffd_error *err)
{
    ffd_blas_single_thread();
    *rcond = 0;
    if (n == 0)
        return FFD_OK;
    if (n > INT_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "condition estimate: system of %zu is too large", n);
    lapack_int N = (lapack_int)n;
    double *work = ffd_malloc_array(2 * n, sizeof *work);
    lapack_int *iwork = ffd_malloc_array(n, sizeof *iwork);
    ffd_status st = FFD_OK;
    if (!work || !iwork) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "condition estimate: out of memory");
        goto done;
    }
    lapack_int info = LAPACKE_dsycon_work(LAPACK_COL_MAJOR, 'L', N, factor, N,
                                          (const lapack_int *)ipiv, anorm, rcond, work, iwork);
    if (info != 0)
        st = ffd_fail(err, FFD_ERR_NUMERIC, "condition estimate: dsycon failed (info %d)",
                      (int)info);
done:
    ffd_free(work);
    ffd_free(iwork);
    return st;
}

double ffd_dense_sym_norm1(size_t n, const double *A)
{
    double best = 0;
    for (size_t j = 0; j < n; j++) {
        const double *col = A + j * n;
        double s = 0;
        for (size_t i = 0; i < n; i++)
            s += fabs(col[i]);
        if (s > best || s != s)
            best = s;
    }
    return best;
}

ffd_status ffd_dense_svd3(const double *A, double *U, double *S, double *Vt)
{
    ffd_blas_single_thread();
    double a[9], work[64];
    memcpy(a, A, sizeof a);
    lapack_int info = LAPACKE_dgesvd_work(LAPACK_COL_MAJOR, 'A', 'A', 3, 3, a, 3, S, U, 3, Vt, 3,
                                          work, 64);
    return info == 0 ? FFD_OK : FFD_ERR_NUMERIC;
}
