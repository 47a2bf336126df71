/* The library runs BLAS on one thread (src/math/dense.c, ffd_blas_single_thread),
 * with the same results. Its own executable: the setting is made once per process. */
#include "ffd.h"
#include "check.h"
#include "math/dense.h"

#include <lapacke.h>

/* OpenBLAS's (cblas.h) */
void openblas_set_num_threads(int num_threads);
int openblas_get_num_threads(void);

/* A right-hand side block of nrhs columns of n rows, the first m set. */
static void fill(size_t m, size_t n, size_t nrhs, double *A, double *B)
{
    for (size_t i = 0; i < m * n; i++)
        A[i] = check_rand01() - 0.5;
    for (size_t c = 0; c < nrhs; c++)
        for (size_t i = 0; i < n; i++)
            B[c * n + i] = i < m ? check_rand01() : 0.0;
}

/* LAPACK's dgelsd on copies, with OpenBLAS set to `threads` (then left so). */
static void reference(size_t m, size_t n, size_t nrhs, const double *A, const double *B,
                      int threads, double *X)
{
    double *a = malloc(m * n * sizeof *a), *s = malloc(m * sizeof *s);
    memcpy(a, A, m * n * sizeof *a);
    memcpy(X, B, n * nrhs * sizeof *X);
    openblas_set_num_threads(threads);
    lapack_int rank = 0;
    CHECK(LAPACKE_dgelsd(LAPACK_COL_MAJOR, (lapack_int)m, (lapack_int)n, (lapack_int)nrhs, a,
                         (lapack_int)m, X, (lapack_int)n, s, 1e-12, &rank) == 0);
    free(a);
    free(s);
}

/* The library's least squares on copies. */
static void library(size_t m, size_t n, size_t nrhs, const double *A, const double *B, double *X)
{
    double *a = malloc(m * n * sizeof *a);
    memcpy(a, A, m * n * sizeof *a);
    memcpy(X, B, n * nrhs * sizeof *X);
    size_t rank = 0;
    CHECK_OK(ffd_dense_lstsq(m, n, nrhs, a, X, 1e-12, &rank, NULL));
    free(a);
}

/* Whatever OpenBLAS's pool was, the library's first BLAS call leaves it at one
 * thread; a drag-sized system (10 constraints on a 5^3 lattice) gets the bits
 * it got from two threads, a bigger one the bits of one thread on any machine
 * (with a pool, OpenBLAS's dgelsd changes in the last bits: its result
 * depended on the core count). */
static void test_blas_one_thread_same_result(void)
{
    const size_t ms[2] = {10, 300}, ns[2] = {125, 900}, nrhs = 3;
    double *A[2], *B[2], *X[2], *R[2];
    for (int k = 0; k < 2; k++) {
        A[k] = malloc(ms[k] * ns[k] * sizeof *A[k]);
        B[k] = malloc(ns[k] * nrhs * sizeof *B[k]);
        X[k] = malloc(ns[k] * nrhs * sizeof *X[k]);
        R[k] = malloc(ns[k] * nrhs * sizeof *R[k]);
        fill(ms[k], ns[k], nrhs, A[k], B[k]);
    }
    /* before the library's first BLAS call: a pool of two */
    reference(ms[0], ns[0], nrhs, A[0], B[0], 2, R[0]);
    CHECK(openblas_get_num_threads() == 2);
    library(ms[0], ns[0], nrhs, A[0], B[0], X[0]);
    CHECK(openblas_get_num_threads() == 1);
    CHECK(memcmp(X[0], R[0], ns[0] * nrhs * sizeof *X[0]) == 0);
    library(ms[1], ns[1], nrhs, A[1], B[1], X[1]);
    reference(ms[1], ns[1], nrhs, A[1], B[1], 1, R[1]);
    CHECK(memcmp(X[1], R[1], ns[1] * nrhs * sizeof *X[1]) == 0);
    for (int k = 0; k < 2; k++) {
        free(A[k]);
        free(B[k]);
        free(X[k]);
        free(R[k]);
    }
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"blas_one_thread_same_result", test_blas_one_thread_same_result},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
