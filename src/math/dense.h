/* math — dense linear algebra through LAPACK (dense.c is the only file that includes lapacke.h). */
#ifndef FFD_DENSE_H
#define FFD_DENSE_H

#include "core/core.h"

/* Sets OpenBLAS to one thread, once per process (every function below calls
 * it first): the library's own parallelism is OpenMP over points, and
 * OpenBLAS's pool would spin on the same cores. Results do not change. */
void ffd_blas_single_thread(void);

/* Minimum-norm least squares A X = B by SVD (LAPACK dgelsd).
 * A: m by n column-major (overwritten); B: max(m,n) by nrhs column-major,
 * holds the right-hand sides in its first m rows on entry and the solution in
 * its first n rows on exit. Singular values <= rcond * s_max count as zero.
 * rank receives the numerical rank. */
ffd_status ffd_dense_lstsq(size_t m, size_t n, size_t nrhs, double *A, double *B, double rcond,
                           size_t *rank, ffd_error *err);

/* Symmetric indefinite factorisation A = L D L' (LAPACK dsytrf, Bunch-Kaufman
 * pivoting) of the n by n column-major A, of which only the lower triangle is
 * read; A receives the factor, ipiv (n) the pivots. *singular is set to 1
 * when D has an exactly zero pivot (dsytrf info > 0: the factor exists but
 * cannot be used to solve), else 0. FFD_ERR_INVALID (n too large),
 * FFD_ERR_NOMEM, FFD_ERR_NUMERIC. */
ffd_status ffd_dense_sym_factor(size_t n, double *A, int *ipiv, int *singular, ffd_error *err);

/* Solves A X = B with a factor from ffd_dense_sym_factor (dsytrs): B is n by
 * nrhs column-major, overwritten by X. FFD_ERR_NUMERIC. */
ffd_status ffd_dense_sym_solve(size_t n, size_t nrhs, const double *factor, const int *ipiv,
                               double *B, ffd_error *err);

/* Reciprocal condition number estimate in the 1-norm (dsycon) of the matrix
 * whose factor is given; anorm is its 1-norm (ffd_dense_sym_norm1 of the
 * matrix before factoring). FFD_ERR_NOMEM, FFD_ERR_NUMERIC. */
ffd_status ffd_dense_sym_rcond(size_t n, const double *factor, const int *ipiv, double anorm,
                               double *rcond, ffd_error *err);

/* 1-norm (= infinity norm) of the symmetric n by n column-major matrix,
 * stored in full (both triangles). */
double ffd_dense_sym_norm1(size_t n, const double *A);

/* SVD of a 3 by 3 column-major matrix, A = U diag(S) Vt (LAPACK dgesvd);
 * U and Vt column-major. FFD_ERR_NUMERIC when it does not converge. */
ffd_status ffd_dense_svd3(const double *A, double *U, double *S, double *Vt);

#endif
