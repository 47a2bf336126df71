/* math — dense linear algebra through LAPACK (the only file that includes lapacke.h). */
#ifndef FFD_DENSE_H
#define FFD_DENSE_H

#include "core/core.h"

/* Minimum-norm least squares A X = B by SVD (LAPACK dgelsd).
 * A: m by n column-major (overwritten); B: max(m,n) by nrhs column-major,
 * holds the right-hand sides in its first m rows on entry and the solution in
 * its first n rows on exit. Singular values <= rcond * s_max count as zero.
 * rank receives the numerical rank. */
ffd_status ffd_dense_lstsq(size_t m, size_t n, size_t nrhs, double *A, double *B, double rcond,
                           size_t *rank, ffd_error *err);

#endif
